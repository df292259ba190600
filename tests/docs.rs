//! The documentation (README.md and the book under docs/): every relative link resolves, with its
//! anchor; every command of a code block that starts with `nurbs-contact check` runs; and no page
//! speaks of the work that produced it (work periods, issue numbers, UTC times).

mod common;
use common::*;
use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::process::Command;

/// README.md and every Markdown page under docs/, sorted.
fn pages() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .map(|e| e.expect("directory entry").path())
            .collect();
        entries.sort();
        for p in entries {
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|x| x == "md") {
                out.push(p);
            }
        }
    }
    let mut out = vec![root().join("README.md")];
    walk(&root().join("docs"), &mut out);
    out
}

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn rel(p: &Path) -> String {
    p.strip_prefix(root()).unwrap_or(p).display().to_string()
}

/// The page's lines outside fenced code blocks, with their line numbers (1-based).
fn prose_lines(text: &str) -> Vec<(usize, &str)> {
    let mut fenced = false;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if !fenced {
            out.push((i + 1, line));
        }
    }
    out
}

/// The line without its inline code spans (`...`), which hold no links.
fn without_code_spans(line: &str) -> String {
    let mut out = String::new();
    let mut in_code = false;
    for c in line.chars() {
        if c == '`' {
            in_code = !in_code;
        } else if !in_code {
            out.push(c);
        }
    }
    out
}

/// Targets of the Markdown links and images `[text](target)` of a page, with their line numbers.
fn links(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (n, line) in prose_lines(text) {
        let line = without_code_spans(line);
        let mut rest = line.as_str();
        while let Some(i) = rest.find("](") {
            let after = &rest[i + 2..];
            let Some(end) = after.find(')') else { break };
            let target = after[..end].split_whitespace().next().unwrap_or("");
            out.push((n, target.to_string()));
            rest = &after[end..];
        }
    }
    out
}

/// GitHub's (and mdBook's) anchor of a heading: lower case, spaces to `-`, other punctuation
/// dropped.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// The anchors of a page's headings (a repeated heading gets `-1`, `-2`, ... as on GitHub).
fn anchors(text: &str) -> HashSet<String> {
    let mut seen = HashSet::new();
    for (_, line) in prose_lines(text) {
        let t = line.trim_start();
        if !t.starts_with('#') {
            continue;
        }
        let title = t.trim_start_matches('#');
        if !title.starts_with(' ') {
            continue;
        }
        let base = slug(&title.replace('`', ""));
        let mut a = base.clone();
        let mut k = 0;
        while seen.contains(&a) {
            k += 1;
            a = format!("{base}-{k}");
        }
        seen.insert(a);
    }
    seen
}

/// What is wrong with one link of `page`, if anything.
fn broken(page: &Path, target: &str) -> Option<String> {
    if target.is_empty() {
        return Some("empty link".into());
    }
    if target.contains("://") || target.starts_with("mailto:") {
        return None;
    }
    let (path, anchor) = match target.split_once('#') {
        Some((p, a)) => (p, Some(a)),
        None => (target, None),
    };
    let file = if path.is_empty() {
        page.to_path_buf()
    } else {
        page.parent().expect("a page's folder").join(path)
    };
    if !file.exists() {
        return Some(format!("`{target}`: no file {}", file.display()));
    }
    if let Some(a) = anchor {
        if file.extension().is_some_and(|x| x == "md") && !anchors(&read(&file)).contains(a) {
            return Some(format!(
                "`{target}`: no heading with anchor `#{a}` in {}",
                rel(&file)
            ));
        }
    }
    None
}

#[test]
fn every_relative_link_of_the_readme_and_the_book_resolves() {
    let mut bad = Vec::new();
    let mut count = 0;
    for page in pages() {
        for (line, target) in links(&read(&page)) {
            count += 1;
            if let Some(why) = broken(&page, &target) {
                bad.push(format!("{}:{line}: {why}", rel(&page)));
            }
        }
    }
    assert!(
        count > 100,
        "only {count} links found: the link parser is broken"
    );
    assert!(bad.is_empty(), "broken links:\n{}", bad.join("\n"));
}

#[test]
fn the_anchors_of_headings_follow_github() {
    assert_eq!(slug("4.1 Ironing"), "41-ironing");
    assert_eq!(
        slug("Contact settings: your problem, these keys"),
        "contact-settings-your-problem-these-keys"
    );
    let a = anchors("# A\n\n```\n# not a heading\n```\n## `check`'s estimate\n## A\n");
    assert!(
        a.contains("a") && a.contains("a-1") && a.contains("checks-estimate"),
        "{a:?}"
    );
    assert!(!a.contains("not-a-heading"), "{a:?}");
}

/// Splits a shell command line into words: single and double quotes, backslash escapes, and a
/// `#` comment at the start of a word.
fn shell_words(line: &str) -> Vec<String> {
    let mut words = Vec::new();
    let mut word = String::new();
    let mut has_word = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '\'' => {
                has_word = true;
                for d in chars.by_ref() {
                    if d == '\'' {
                        break;
                    }
                    word.push(d);
                }
            }
            '"' => {
                has_word = true;
                while let Some(d) = chars.next() {
                    match d {
                        '"' => break,
                        '\\' if matches!(chars.peek(), Some('"' | '\\' | '$' | '`')) => {
                            word.push(chars.next().expect("peeked"))
                        }
                        _ => word.push(d),
                    }
                }
            }
            '\\' => {
                has_word = true;
                if let Some(d) = chars.next() {
                    word.push(d);
                }
            }
            '#' if !has_word => break,
            c if c.is_whitespace() => {
                if has_word {
                    words.push(std::mem::take(&mut word));
                    has_word = false;
                }
            }
            c => {
                has_word = true;
                word.push(c);
            }
        }
    }
    if has_word {
        words.push(word);
    }
    words
}

/// Whether a fenced code block with this info string holds shell commands (a block of another
/// language, e.g. `text` for a usage synopsis, holds none).
fn is_shell(info: &str) -> bool {
    matches!(info.trim(), "" | "sh" | "bash" | "shell" | "console")
}

/// The `nurbs-contact check ...` commands of the pages' fenced shell code blocks (continued lines
/// joined), with the page and line where each starts.
fn check_commands() -> Vec<(String, Vec<String>)> {
    let mut out = Vec::new();
    for page in pages() {
        let text = read(&page);
        let mut fenced = false;
        let mut shell = false;
        let mut pending: Option<(usize, String)> = None;
        for (i, line) in text.lines().enumerate() {
            if let Some(info) = line.trim_start().strip_prefix("```") {
                fenced = !fenced;
                shell = fenced && is_shell(info);
                continue;
            }
            if !shell {
                continue;
            }
            let (start, joined) = match pending.take() {
                Some((n, mut s)) => {
                    s.push(' ');
                    s.push_str(line.trim());
                    (n, s)
                }
                None if line.trim_start().starts_with("nurbs-contact check ") => {
                    (i + 1, line.trim().to_string())
                }
                None => continue,
            };
            if let Some(s) = joined.strip_suffix('\\') {
                pending = Some((start, s.trim_end().to_string()));
            } else {
                out.push((
                    format!("{}:{start}", rel(&page)),
                    shell_words(&joined)[1..].to_vec(),
                ));
            }
        }
    }
    out
}

#[test]
fn only_shell_blocks_hold_commands() {
    assert!(is_shell("") && is_shell("sh") && is_shell("bash "));
    assert!(!is_shell("text") && !is_shell("toml"));
}

#[test]
fn shell_words_split_as_the_shell_does() {
    assert_eq!(
        shell_words(r#"nurbs-contact check a.toml --set "x=[1, 2]" --set 'y={ k = "v" }'  # c"#),
        [
            "nurbs-contact",
            "check",
            "a.toml",
            "--set",
            "x=[1, 2]",
            "--set",
            r#"y={ k = "v" }"#
        ]
    );
    assert_eq!(shell_words(r"a\ b c#d"), ["a b", "c#d"]);
}

#[test]
fn every_check_command_in_the_docs_runs() {
    let commands = check_commands();
    assert!(
        commands.len() >= 10,
        "only {} `nurbs-contact check` commands found in the docs' code blocks",
        commands.len()
    );
    let mut bad = Vec::new();
    for (at, args) in &commands {
        let mut cmd = Command::new(bin());
        cmd.args(args).current_dir(root());
        mpi_env(&mut cmd);
        let out = cmd.output().expect("start nurbs-contact");
        if !out.status.success() {
            bad.push(format!(
                "{at}: nurbs-contact {}\n{}",
                args.join(" "),
                String::from_utf8_lossy(&out.stderr)
            ));
        }
    }
    assert!(bad.is_empty(), "failed:\n{}", bad.join("\n"));
}

/// Whether `word` occurs in `line` as a whole word (not inside a longer word), ignoring case.
fn has_word(line: &str, word: &str) -> bool {
    let lower = line.to_lowercase();
    let w = word.to_lowercase();
    let bytes = lower.as_bytes();
    let mut from = 0;
    while let Some(i) = lower[from..].find(&w) {
        let (s, e) = (from + i, from + i + w.len());
        let before = s == 0 || !bytes[s - 1].is_ascii_alphanumeric();
        let after = e == bytes.len() || !bytes[e].is_ascii_alphanumeric();
        if before && after {
            return true;
        }
        from = e;
    }
    false
}

/// The lab-notebook words of one line: a work period, an issue number, a UTC time, the lead.
fn log_words(line: &str) -> Vec<&'static str> {
    let mut found = Vec::new();
    for w in ["session", "sessions", "the lead"] {
        if has_word(line, w) {
            found.push(w);
        }
    }
    if line
        .split(|c: char| !c.is_ascii_alphanumeric())
        .any(|t| t == "UTC")
    {
        found.push("UTC");
    }
    let lower = line.to_lowercase();
    let mut from = 0;
    while let Some(i) = lower[from..].find("issue") {
        let rest = lower[from + i + 5..].trim_start_matches(' ');
        if rest.starts_with('#') || rest.starts_with(|c: char| c.is_ascii_digit()) {
            found.push("issue number");
            break;
        }
        from += i + 5;
    }
    found
}

#[test]
fn the_log_words_are_found() {
    assert_eq!(log_words("measured in session 19"), ["session"]);
    assert_eq!(log_words("08:13-09:27 UTC"), ["UTC"]);
    assert_eq!(log_words("(issue 21)"), ["issue number"]);
    assert_eq!(log_words("see issue #8"), ["issue number"]);
    assert_eq!(log_words("run by the lead"), ["the lead"]);
    assert!(log_words("a known issue; the leading term; sessional; CUTBACK").is_empty());
}

#[test]
fn no_page_speaks_of_the_work_that_produced_it() {
    let mut bad = Vec::new();
    for page in pages() {
        for (i, line) in read(&page).lines().enumerate() {
            let found = log_words(line);
            if !found.is_empty() {
                bad.push(format!("{}:{}: {found:?}: {line}", rel(&page), i + 1));
            }
        }
    }
    assert!(bad.is_empty(), "lab-log words:\n{}", bad.join("\n"));
}
