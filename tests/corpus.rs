//! The bad-input corpus: every file in `tests/corpus/` is a malformed case (`*.toml`) or Gmsh mesh
//! (`*.msh`) with the message it must produce. Each is run through `nurbs-contact check` (or `run`),
//! and the test fails on a panic, an abort or other signal, a hang, exit 0, or a message without
//! the expected text.
//!
//! Directives, one per line: in a case file as comments `# key: value`, in a mesh file in its
//! `$Comments` section (which Gmsh readers skip) as `key: value`. Other comment lines are prose.
//! - `expect: TEXT`: the output must contain TEXT (every `expect` line; at least one is required);
//! - `forbid: TEXT`: the output must not contain TEXT;
//! - `once: TEXT`: the output must contain TEXT exactly once;
//! - `command: run`: `run` instead of `check`;
//! - `ranks: 1 2`: the rank counts to `run` on (default 1);
//! - `args: ...`: more arguments, split at spaces; `{scratch}` is the entry's scratch directory,
//!   which is also the working directory (so `out/<name>` lands there);
//! - `setup: PATH`: create the file PATH (and its directories) in the scratch directory first;
//! - `keep: PATH`: that file must still exist afterwards (nothing foreign deleted);
//! - `exit: N`: the expected exit code (default 1; 0 for an input that only warns);
//! - `dim: 3`: for a mesh file, the dimension of the case it is checked in (default 2).

mod common;
use common::*;
use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{ExitStatus, Output};
use std::time::Duration;

/// A bad input ends in well under a second (a run in a few); anything near this is a hang.
const ENTRY_TIMEOUT: Duration = Duration::from_secs(120);

/// Text that only a crash prints (Rust panics and allocation aborts, mpirun's reports of a rank
/// killed by a signal).
const CRASH_SIGNS: [&str; 7] = [
    "panicked",
    "capacity overflow",
    "memory allocation of",
    "RUST_BACKTRACE",
    "exited on signal",
    "core dumped",
    "Segmentation fault",
];

#[derive(Debug, Default)]
struct Entry {
    path: PathBuf,
    expect: Vec<String>,
    forbid: Vec<String>,
    once: Vec<String>,
    run: bool,
    ranks: Vec<usize>,
    args: Vec<String>,
    setup: Vec<String>,
    keep: Vec<String>,
    exit: i32,
    dim: usize,
}

impl Entry {
    fn parse(path: &Path) -> Entry {
        let text = std::fs::read_to_string(path).unwrap();
        let mut e = Entry {
            path: path.to_path_buf(),
            exit: 1,
            dim: 2,
            ranks: vec![1],
            ..Entry::default()
        };
        let is_msh = path.extension().is_some_and(|x| x == "msh");
        let directives: Vec<&str> = if is_msh {
            text.lines()
                .skip_while(|l| l.trim() != "$Comments")
                .skip(1)
                .take_while(|l| l.trim() != "$EndComments")
                .collect()
        } else {
            text.lines()
                .filter_map(|l| l.trim().strip_prefix('#'))
                .collect()
        };
        for d in directives {
            let Some((key, value)) = d.trim().split_once(": ") else {
                continue;
            };
            let value = value.trim().to_string();
            match key {
                "expect" => e.expect.push(value),
                "forbid" => e.forbid.push(value),
                "once" => e.once.push(value),
                "command" => e.run = value == "run",
                "ranks" => {
                    e.ranks = value
                        .split_whitespace()
                        .map(|r| r.parse().unwrap())
                        .collect()
                }
                "args" => e.args = value.split_whitespace().map(str::to_string).collect(),
                "setup" => e.setup.push(value),
                "keep" => e.keep.push(value),
                "exit" => e.exit = value.parse().unwrap(),
                "dim" => e.dim = value.parse().unwrap(),
                _ => {}
            }
        }
        e
    }

    fn name(&self) -> String {
        self.path
            .file_name()
            .unwrap()
            .to_string_lossy()
            .into_owned()
    }

    /// Runs the entry on `np` ranks; the problems found, empty if it behaved.
    fn check(&self, np: usize) -> Vec<String> {
        let dir = scratch(&format!("corpus/{}-np{np}", self.name()));
        for f in &self.setup {
            let p = dir.join(f);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(&p, "not a result of nurbs-contact\n").unwrap();
        }
        let case = if self.path.extension().is_some_and(|x| x == "msh") {
            let c = dir.join("case.toml");
            std::fs::write(&c, mesh_case(&self.path, self.dim)).unwrap();
            c
        } else {
            self.path.clone()
        };
        let mut args: Vec<String> = vec![
            if self.run { "run" } else { "check" }.to_string(),
            case.to_string_lossy().into_owned(),
        ];
        let scratch_text = dir.to_string_lossy();
        args.extend(
            self.args
                .iter()
                .map(|a| a.replace("{scratch}", &scratch_text)),
        );
        let argv: Vec<&str> = args.iter().map(String::as_str).collect();
        let mut problems = match run_with(np, &argv, Some(&dir), ENTRY_TIMEOUT) {
            Some(out) => self.judge(&out),
            None => vec![format!("no answer in {ENTRY_TIMEOUT:?} (a hang)")],
        };
        for k in &self.keep {
            if !dir.join(k).exists() {
                problems.push(format!("{k} was deleted"));
            }
        }
        problems
            .into_iter()
            .map(|p| format!("{} on {np} rank(s): {p}", self.name()))
            .collect()
    }

    /// What is wrong with how the program answered this entry.
    fn judge(&self, out: &Output) -> Vec<String> {
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        let mut problems = Vec::new();
        match out.status.code() {
            None => problems.push(format!(
                "killed by signal {:?}",
                out.status.signal().unwrap_or(0)
            )),
            Some(c) if c != self.exit => {
                problems.push(format!("exit code {c}, expected {}", self.exit))
            }
            Some(_) => {}
        }
        if self.exit != 0 && !text.contains("error:") {
            problems.push("no `error:` message".into());
        }
        for sign in CRASH_SIGNS {
            if text.contains(sign) {
                problems.push(format!("crashed (`{sign}`)"));
            }
        }
        if self.expect.is_empty() {
            problems.push("the entry has no `expect:` directive".into());
        }
        for e in &self.expect {
            if !text.contains(e.as_str()) {
                problems.push(format!("message lacks `{e}`"));
            }
        }
        for f in &self.forbid {
            if text.contains(f.as_str()) {
                problems.push(format!("message contains `{f}`"));
            }
        }
        for o in &self.once {
            let n = text.matches(o.as_str()).count();
            if n != 1 {
                problems.push(format!("`{o}` appears {n} times, expected once"));
            }
        }
        if !problems.is_empty() {
            problems.push(format!("output was:\n{text}"));
        }
        problems
    }
}

/// The case a mesh entry is checked in: one body on the mesh, nothing else.
fn mesh_case(mesh: &Path, dim: usize) -> String {
    format!(
        "[case]\nname = \"corpus_mesh\"\ndim = {dim}\n\n[meshes.m]\nfile = \"{}\"\n\n\
         [bodies.b]\nmesh = \"m\"\nelement = \"Q1C1\"\n[bodies.b.material]\n\
         model = \"neo_hookean\"\nE = 1.0\nnu = 0.3\n\n[[stages]]\nname = \"s\"\nsteps = 1\n",
        mesh.display()
    )
}

fn entries() -> Vec<Entry> {
    let dir = root().join("tests/corpus");
    let mut paths: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml" || x == "msh"))
        .collect();
    paths.sort();
    paths.iter().map(|p| Entry::parse(p)).collect()
}

#[test]
fn every_corpus_entry_fails_cleanly_with_its_message() {
    let entries = entries();
    assert!(entries.len() >= 80, "corpus has {} entries", entries.len());
    let mut problems = Vec::new();
    let mut runs = 0;
    for e in &entries {
        let ranks = if e.run { e.ranks.clone() } else { vec![1] };
        for np in ranks {
            problems.extend(e.check(np));
            runs += 1;
        }
    }
    assert!(
        problems.is_empty(),
        "{} problems in {runs} runs of {} corpus entries:\n{}",
        problems.len(),
        entries.len(),
        problems.join("\n")
    );
    eprintln!(
        "corpus: {} entries, {runs} runs, no panic, signal, hang or missing message",
        entries.len()
    );
}

/// The judge itself catches each way of failing, so the corpus test can fail.
#[test]
fn the_judge_rejects_exit_0_signals_panics_and_missing_text() {
    let e = Entry {
        expect: vec!["`case.name`".into()],
        forbid: vec!["results in".into()],
        once: vec!["error:".into()],
        exit: 1,
        ..Entry::default()
    };
    let out = |raw: i32, stderr: &str| Output {
        status: ExitStatus::from_raw(raw),
        stdout: Vec::new(),
        stderr: stderr.as_bytes().to_vec(),
    };
    let good = "error: c.toml: invalid case:\n  `case.name`: bad\n";
    assert!(e.judge(&out(1 << 8, good)).is_empty());
    let cases = [
        (0, good, "exit code 0"),
        (6, good, "killed by signal 6"),
        (1 << 8, "error: c.toml: `case.dim`: bad", "lacks"),
        (
            1 << 8,
            "thread 'main' panicked at src/x.rs: capacity overflow\nerror: `case.name`",
            "crashed",
        ),
        (1 << 8, "results in out/x\nerror: `case.name`", "contains"),
        (1 << 8, "error: `case.name`\nerror: `case.name`", "2 times"),
        (2 << 8, good, "exit code 2"),
    ];
    for (raw, text, why) in cases {
        let p = e.judge(&out(raw, text));
        assert!(p.iter().any(|p| p.contains(why)), "{why}: {p:?}");
    }
    assert!(Entry::default()
        .judge(&out(1 << 8, "error: x"))
        .iter()
        .any(|p| p.contains("no `expect:`")));
}

/// Every class of issue 9 that this corpus covers has entries, each with a directive to check.
#[test]
fn corpus_directives_parse() {
    let entries = entries();
    for e in &entries {
        assert!(!e.expect.is_empty() || !e.once.is_empty(), "{}", e.name());
    }
    let count = |prefix: &str| {
        entries
            .iter()
            .filter(|e| e.name().starts_with(prefix))
            .count()
    };
    assert!(count("name_") + count("out_") >= 10);
    assert!(count("msh_") >= 30);
    assert!(count("huge_") >= 6);
    assert!(count("petsc_") >= 6);
    assert!(count("illposed_") >= 5);
    assert!(entries.iter().filter(|e| e.run).count() >= 8);
    assert!(entries.iter().any(|e| e.ranks.contains(&2)));
}
