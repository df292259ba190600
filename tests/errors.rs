//! Bad input gives a clear message naming the file, key, set or element, and a non-zero exit; never
//! a panic.

mod common;
use common::*;
use std::path::{Path, PathBuf};

const BLOCK: &str = r#"
[case]
name = "bad"
dim = 3

[meshes.block]
generator = "box"
origin = [0.0, 0.0, 0.0]
size = [1.0, 1.0, 1.0]
divisions = [2, 2, 2]

[bodies.block]
mesh = "block"
element = "Q1C1"
[bodies.block.material]
model = "neo_hookean"
E = 1.0
nu = 0.3

[[bcs]]
body = "block"
set = "zmin"
kind = "fixed"

[[bcs]]
body = "block"
set = "zmax"
kind = "displacement"
components = ["z"]
value = [[-0.2]]

[[stages]]
name = "compress"
steps = 2
"#;

fn write_case(dir: &Path, text: &str) -> PathBuf {
    let p = dir.join("case.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// Runs `run` on a case text and returns (exit ok, stderr), asserting there was no panic.
fn fails_with(name: &str, text: &str, np: usize) -> String {
    let d = scratch(name);
    let p = write_case(&d, text);
    let out = run(
        np,
        &[
            "run",
            p.to_str().unwrap(),
            "--out",
            d.join("out").to_str().unwrap(),
            "-q",
        ],
    );
    let err = stderr(&out);
    assert!(!out.status.success(), "{name}: bad input was accepted");
    assert!(
        !err.contains("panicked"),
        "{name}: panic instead of an error:\n{err}"
    );
    assert!(
        err.contains("case.toml"),
        "{name}: message does not name the file:\n{err}"
    );
    err
}

#[test]
fn unknown_key_is_named() {
    let e = fails_with(
        "unknown-key",
        &BLOCK.replace("nu = 0.3", "nu = 0.3\nshear = 2.0"),
        1,
    );
    assert!(
        e.contains("shear") && e.contains("bodies.block.material"),
        "{e}"
    );
}

/// A retired key is refused with the key, the file and its line, why it was retired and what to
/// do, on `run` and `check`, in the file or as an override.
#[test]
fn retired_contact_freeze_after_is_refused_with_the_reason() {
    let text = format!("{BLOCK}\n[solver]\ncontact_freeze_after = 4\n");
    let e = fails_with("retired-key", &text, 1);
    let line = text
        .lines()
        .position(|l| l.starts_with("contact_freeze_after"))
        .unwrap()
        + 1;
    for want in [
        format!("case.toml:{line}:"),
        "`solver.contact_freeze_after`".to_string(),
        "changed no measured result".to_string(),
        "docs/formulations.md".to_string(),
        "delete this line".to_string(),
    ] {
        assert!(e.contains(&want), "lacks `{want}`:\n{e}");
    }
    let c = case("hertz_2d.toml");
    let out = run(
        1,
        &[
            "check",
            c.to_str().unwrap(),
            "--set",
            "solver.contact_freeze_after=4",
        ],
    );
    let e = stderr(&out);
    assert!(!out.status.success(), "the override was accepted");
    for want in [
        "hertz_2d.toml",
        "override `solver.contact_freeze_after=4`",
        "docs/formulations.md",
    ] {
        assert!(e.contains(want), "lacks `{want}`:\n{e}");
    }
}

#[test]
fn impossible_poisson_ratio_is_named() {
    let e = fails_with("nu", &BLOCK.replace("nu = 0.3", "nu = 0.5"), 1);
    assert!(e.contains("bodies.block.material.nu"), "{e}");
}

#[test]
fn missing_mesh_file_is_named() {
    let text = BLOCK.replace(
        "generator = \"box\"\norigin = [0.0, 0.0, 0.0]\nsize = [1.0, 1.0, 1.0]\ndivisions = [2, 2, 2]",
        "file = \"meshes/does_not_exist.msh\"",
    );
    let e = fails_with("missing-mesh", &text, 1);
    assert!(e.contains("does_not_exist.msh"), "{e}");
}

#[test]
fn undefined_set_is_named() {
    let e = fails_with(
        "undefined-set",
        &BLOCK.replace("set = \"zmin\"", "set = \"floor\""),
        1,
    );
    assert!(e.contains("floor") && e.contains("bcs.0"), "{e}");
}

#[test]
fn inconsistent_boundary_sets_are_reported_with_both_conditions() {
    // xmin shares an edge with zmin: fixed there, but also pushed in x.
    let text = format!(
        "{BLOCK}\n[[bcs]]\nbody = \"block\"\nset = \"xmin\"\nkind = \"displacement\"\ncomponents = [\"x\"]\nvalue = [[0.1]]\n"
    );
    let e = fails_with("inconsistent-bcs", &text, 1);
    assert!(
        e.contains("inconsistent boundary conditions")
            && e.contains("bcs.0")
            && e.contains("bcs.2"),
        "{e}"
    );
}

#[test]
fn inverted_element_in_input_mesh_is_named() {
    let d = scratch("inverted-mesh");
    // Two quads; the first is a bow tie (nodes 5 and 6 swapped in space).
    let msh = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 6 1 6\n2 1 0 6\n1\n2\n3\n4\n5\n6\n\
               0 0 0\n1 0 0\n2 0 0\n2 1 0\n0 1 0\n1 1 0\n$EndNodes\n$Elements\n1 2 1 2\n2 1 3 2\n1 1 2 5 6\n2 2 3 4 5\n$EndElements\n";
    std::fs::write(d.join("bowtie.msh"), msh).unwrap();
    let text = r#"
[case]
name = "bowtie"
dim = 2
[meshes.m]
file = "bowtie.msh"
[bodies.b]
mesh = "m"
element = "Q1C1"
[bodies.b.material]
model = "neo_hookean"
E = 1.0
nu = 0.3
[[stages]]
name = "s"
steps = 1
"#;
    let p = write_case(&d, text);
    let out = run(
        1,
        &[
            "run",
            p.to_str().unwrap(),
            "--out",
            d.join("out").to_str().unwrap(),
            "-q",
        ],
    );
    let e = stderr(&out);
    assert!(!out.status.success() && !e.contains("panicked"), "{e}");
    assert!(
        e.contains("bowtie.msh") || e.contains("mesh `m`"),
        "names the mesh: {e}"
    );
    assert!(e.to_lowercase().contains("cell 0"), "names the cell: {e}");
}

#[test]
fn element_inverted_by_the_load_fails_cleanly_after_cutbacks_on_2_ranks() {
    // Pushing the top 1.2 down through a unit cube inverts elements whatever the step size.
    let text = BLOCK
        .replace("value = [[-0.2]]", "value = [[-1.2]]")
        .replace("steps = 2", "steps = 2\n[steps]\nmax_cutbacks = 3");
    let e = fails_with("inverted-by-load", &text, 2);
    assert!(e.contains("load step") && e.contains("cutbacks"), "{e}");
    assert!(e.contains("inverted") || e.contains("DIVERGED"), "{e}");
    // The failure is recorded, and what converged before it is complete and readable.
    let out = root().join("target/test-scratch/inverted-by-load/out");
    let s = summary(&out);
    assert_eq!(s["status"], "failed");
    assert!(s["reason"].as_str().unwrap().contains("load step"));
    assert!(out.join("results.h5").exists() && !out.join("results.h5.partial").exists());
}

#[test]
fn a_pattern_one_rank_cannot_build_stops_every_rank() {
    // Rank 1's part of the Jacobian's pattern fails (fault injection, as an index beyond the maps'
    // 2^32 entries would): rank 0 must not wait for it in the collective preallocation.
    let d = scratch("pattern-fails-on-rank-1");
    let p = write_case(&d, BLOCK);
    let out = run_with_env(
        2,
        &[
            "run",
            p.to_str().unwrap(),
            "--out",
            d.join("out").to_str().unwrap(),
            "-q",
            "--overwrite",
        ],
        None,
        std::time::Duration::from_secs(120),
        &[("NURBS_CONTACT_FAIL_PATTERN_ON_RANK", "1")],
    )
    .expect("a rank waited for the other in the pattern's preallocation (killed at 120 s)");
    let e = stderr(&out);
    assert!(!out.status.success() && !e.contains("panicked"), "{e}");
    assert!(
        e.contains("failed on rank 1") && e.contains("NURBS_CONTACT_FAIL_PATTERN_ON_RANK"),
        "names the failure of rank 1: {e}"
    );
}

#[test]
fn unwritable_output_directory_stops_every_rank_with_one_message() {
    // --out names an existing file: rank 0 cannot create the directory; rank 1 must not hang.
    let d = scratch("unwritable-out");
    let blocker = d.join("not_a_dir");
    std::fs::write(&blocker, "x").unwrap();
    let p = write_case(&d, BLOCK);
    let out = run(
        2,
        &[
            "run",
            p.to_str().unwrap(),
            "--out",
            blocker.to_str().unwrap(),
            "-q",
        ],
    );
    let e = stderr(&out);
    assert!(!out.status.success() && !e.contains("panicked"), "{e}");
    assert!(e.contains("not_a_dir"), "names the directory: {e}");
    assert_eq!(
        e.matches("error:").count(),
        1,
        "one message for the job: {e}"
    );
}

#[test]
fn ambiguous_periodic_tie_is_reported() {
    let text = std::fs::read_to_string(case("periodic_shear_2d.toml"))
        .unwrap()
        .replace(
            "offset = [4.0, 0.0]",
            "offset = [4.0, 0.0]\ntolerance = 0.5",
        );
    let e = fails_with("ambiguous-tie", &text, 1);
    assert!(e.contains("ties.0") && e.contains("master"), "{e}");
}

#[test]
fn output_directory_is_reused_when_marked_and_refused_when_foreign_unless_overwrite() {
    let d = scratch("out-dir-policy");
    let p = write_case(&d, BLOCK);
    let go = |out: &Path, extra: &[&str]| {
        let mut args = vec!["run", p.to_str().unwrap(), "--out", out.to_str().unwrap()];
        args.extend_from_slice(extra);
        run(1, &args)
    };
    // created, marked; a second run reuses it
    let mine = d.join("mine");
    for _ in 0..2 {
        let o = go(&mine, &["-q"]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(mine.join(".nurbs-contact-run").is_file());
        assert_eq!(summary(&mine)["status"], "converged");
    }
    // a directory of someone else's files is refused, and nothing in it is touched
    let theirs = d.join("theirs");
    std::fs::create_dir_all(&theirs).unwrap();
    std::fs::write(theirs.join("summary.json"), "their own").unwrap();
    let o = go(&theirs, &[]);
    let e = stderr(&o);
    assert!(!o.status.success(), "foreign directory accepted: {e}");
    assert!(
        e.contains("cannot use as the output directory") && e.contains("--overwrite"),
        "{e}"
    );
    assert!(!e.contains("results in"), "{e}");
    assert_eq!(
        std::fs::read_to_string(theirs.join("summary.json")).unwrap(),
        "their own"
    );
    // --overwrite writes into it (and marks it)
    let o = go(&theirs, &["-q", "--overwrite"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(summary(&theirs)["status"], "converged");
    assert!(theirs.join(".nurbs-contact-run").is_file());
}

#[test]
fn default_output_directory_is_out_slash_name_in_the_working_directory() {
    let d = scratch("out-dir-default");
    let p = write_case(&d, BLOCK);
    let o = run_with(
        1,
        &["run", p.to_str().unwrap()],
        Some(&d),
        std::time::Duration::from_secs(300),
    )
    .expect("finishes");
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert!(e.contains("results in out/bad"), "{e}");
    assert_eq!(summary(&d.join("out/bad"))["status"], "converged");
}
