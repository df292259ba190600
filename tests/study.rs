//! `nurbs-contact study`: a tiny study over the Hertz case (2 families x 2 mesh levels, 1 rank,
//! 2 runs at once), its metrics against values recomputed here from each run's history.csv, resuming,
//! failed runs, bad study files, and `--check` on every shipped study.

mod common;
use common::*;
use std::path::{Path, PathBuf};

fn study(args: &[&str]) -> std::process::Output {
    let mut a = vec!["study"];
    a.extend_from_slice(args);
    run(1, &a)
}

fn write_study(dir: &Path, body: &str) -> PathBuf {
    let f = dir.join("study.toml");
    let text = format!("case = \"{}\"\n{body}", case("hertz_2d.toml").display());
    std::fs::write(&f, text).unwrap();
    f
}

const LEVELS: &str = r#"
[[axes]]
name = "mesh"
levels = [ { name = "m16", value = 16, set = ["meshes.disk.n_arc=16", "meshes.disk.n_radial=4"] },
           { name = "m24", value = 24, set = ["meshes.disk.n_arc=24", "meshes.disk.n_radial=6"] } ]
"#;

const METRICS: &str = r#"
[[metrics]]
name = "dPy"
kind = "range"
columns = ["P_flat_disk_arc_y", "-R_disk_top_y"]
window = { column = "load_factor", min = 0.5 }
[[metrics]]
name = "dPy_ece"
kind = "range_ece"
columns = ["P_flat_disk_arc_y", "-R_disk_top_y"]
window = { column = "load_factor", min = 0.5 }
[[metrics]]
name = "Py_mean"
kind = "mean"
column = "P_flat_disk_arc_y"
[[metrics]]
name = "dPy_rel"
kind = "range"
column = "P_flat_disk_arc_y"
relative_to = "Py_mean"
[[metrics]]
name = "missing"
kind = "max"
column = "P_nope"
[plot]
curves = ["P_flat_disk_arc_y", "-R_disk_top_y"]
"#;

fn range(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::MIN, f64::max) - v.iter().copied().fold(f64::MAX, f64::min)
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * a.abs().max(b.abs()).max(1e-300)
}

#[test]
fn tiny_study_computes_metrics_and_resumes() {
    let d = scratch("study-tiny");
    let file = write_study(
        &d,
        &format!(
            "jobs = 2\nranks = 1\nreference = \"Q1C1\"\nset = [\"stages.0.steps=3\"]\n\
             [[axes]]\nname = \"family\"\nkeys = [\"bodies.disk.element\"]\nvalues = [\"Q1C1\", \"Q1N2\"]\n\
             {LEVELS}{METRICS}"
        ),
    );
    let out = d.join("out");
    let o = study(&[file.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = study_rows(&out);
    assert_eq!(rows.len(), 4);
    for fam in ["Q1C1", "Q1N2"] {
        for lvl in ["m16", "m24"] {
            let name = format!("{fam}_{lvl}");
            let r = &rows[&name];
            assert_eq!((r["family"].as_str(), r["mesh"].as_str()), (fam, lvl));
            assert_eq!(r["status"], "converged", "{r:?}");
            assert_eq!(r["skipped"], "0");
            let dir = out.join(&name);
            // the run was given the axes' overrides
            let case_toml = std::fs::read_to_string(dir.join("case.toml")).unwrap();
            assert!(
                case_toml.contains(&format!("element = \"{fam}\"")),
                "{case_toml}"
            );
            let s = summary(&dir);
            assert_eq!(r["unknowns"], s["unknowns"].to_string());
            assert_eq!(
                r["newton_total"],
                s["newton"]["total_iterations"].to_string()
            );
            assert_eq!(
                r["newton_max_per_step"],
                s["newton"]["max_iterations_per_step"].to_string()
            );
            assert_eq!(r["steps"], "3");
            let wall: f64 = r["wall_time"].parse().unwrap();
            assert_eq!(wall, s["wall_time"]["total"].as_f64().unwrap());
            // metrics recomputed from history.csv
            let load = history_col(&dir, "load_factor");
            let p1 = history_col(&dir, "P_flat_disk_arc_y");
            let p2: Vec<f64> = history_col(&dir, "R_disk_top_y")
                .iter()
                .map(|v| -v)
                .collect();
            let win: Vec<usize> = (0..load.len()).filter(|&i| load[i] >= 0.5).collect();
            assert_eq!(win.len(), 2, "loads {load:?}");
            let w1: Vec<f64> = win.iter().map(|&i| p1[i]).collect();
            let w2: Vec<f64> = win.iter().map(|&i| p2[i]).collect();
            let both: Vec<f64> = w1.iter().chain(&w2).copied().collect();
            let m = |k: &str| -> f64 { r[k].parse().unwrap_or_else(|_| panic!("{k}: {r:?}")) };
            assert!(
                close(m("dPy"), range(&both)),
                "{} {}",
                m("dPy"),
                range(&both)
            );
            assert!(close(m("dPy_ece"), range(&w1).max(range(&w2))));
            let mean = p1.iter().sum::<f64>() / p1.len() as f64;
            assert!(close(m("Py_mean"), mean));
            assert!(close(m("dPy_rel"), range(&p1) / mean));
            assert!(m("dPy") > 0.0);
            // a metric on a column the history does not have is empty, with the reason
            assert_eq!(r["missing"], "");
            assert!(r["reason"].contains("no column `P_nope`"), "{r:?}");
            assert!(out.join(format!("plots/run_{name}.svg")).is_file());
        }
    }
    for p in [
        "dPy_vs_level.svg",
        "dPy_vs_wall_time.svg",
        "curve_P_flat_disk_arc_y.svg",
    ] {
        let svg = std::fs::read_to_string(out.join("plots").join(p)).unwrap();
        assert!(svg.contains("Q1C1") && svg.contains("<polyline"), "{p}");
        // the same plot as PNG
        let png = std::fs::read(out.join("plots").join(p.replace(".svg", ".png"))).unwrap();
        assert!(png.starts_with(b"\x89PNG") && png.len() > 10_000, "{p}");
    }
    let md = std::fs::read_to_string(out.join("study.md")).unwrap();
    assert!(
        md.contains("| mesh | Q1C1 | Q1N2 |") && md.contains("(100.0 %)"),
        "{md}"
    );

    // a second invocation runs nothing
    let mtimes = |out: &Path| -> Vec<std::time::SystemTime> {
        let mut v: Vec<_> = rows
            .keys()
            .map(|n| {
                std::fs::metadata(out.join(n).join("summary.json"))
                    .unwrap()
                    .modified()
                    .unwrap()
            })
            .collect();
        v.sort();
        v
    };
    let before = mtimes(&out);
    let o = study(&[file.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let again = study_rows(&out);
    for (name, r) in &again {
        assert_eq!(r["skipped"], "1", "{name} ran again");
        assert_eq!(r["dPy"], rows[name]["dPy"]);
    }
    assert_eq!(mtimes(&out), before);

    // a changed resolved case runs again
    let text = std::fs::read_to_string(&file).unwrap();
    std::fs::write(&file, text.replace("stages.0.steps=3", "stages.0.steps=2")).unwrap();
    let o = study(&[file.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    for (name, r) in study_rows(&out) {
        assert_eq!(
            (r["skipped"].as_str(), r["steps"].as_str()),
            ("0", "2"),
            "{name}"
        );
    }
}

#[test]
fn failed_runs_are_recorded_and_the_others_complete() {
    let d = scratch("study-failures");
    let file = write_study(
        &d,
        "jobs = 2\nset = [\"stages.0.steps=2\"]\n\
         [[axes]]\nname = \"family\"\nkeys = [\"bodies.disk.element\"]\nvalues = [\"Q1C1\", \"Q1Z7\", \"Q1N2\"]\n\
         [[axes]]\nname = \"mesh\"\nlevels = [ { name = \"m16\", set = [\"meshes.disk.n_arc=16\", \"meshes.disk.n_radial=4\"] } ]\n\
         [[metrics]]\nname = \"Pmax\"\nkind = \"max\"\ncolumn = \"P_flat_disk_arc_y\"\n",
    );
    let out = d.join("out");
    // the Q1C1 run's directory holds something else: the run itself refuses it and fails
    std::fs::create_dir_all(out.join("Q1C1_m16")).unwrap();
    std::fs::write(out.join("Q1C1_m16/notes.txt"), "mine").unwrap();
    let o = study(&[file.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    // the table is written, and the study says that runs failed
    assert!(!o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("2 of 3 runs failed"), "{}", stderr(&o));
    let rows = study_rows(&out);
    let bad = &rows["Q1Z7_m16"];
    assert_eq!(bad["status"], "failed");
    assert!(
        bad["reason"].contains("unknown element family `Q1Z7`"),
        "{bad:?}"
    );
    let refused = &rows["Q1C1_m16"];
    assert_eq!(refused["status"], "failed");
    assert!(
        refused["reason"].contains("stderr:") && refused["reason"].contains("--overwrite"),
        "{refused:?}"
    );
    assert_eq!(refused["Pmax"], "");
    let good = &rows["Q1N2_m16"];
    assert_eq!(good["status"], "converged", "{good:?}");
    let p = history_col(&out.join("Q1N2_m16"), "P_flat_disk_arc_y");
    let pmax: f64 = good["Pmax"].parse().unwrap();
    assert_eq!(pmax, p.iter().copied().fold(f64::MIN, f64::max));
    let err = stderr(&o);
    assert!(
        err.contains("failed: Q1Z7_m16") && err.contains("1 converged"),
        "{err}"
    );
    let md = std::fs::read_to_string(out.join("study.md")).unwrap();
    assert!(md.contains("2 failed"), "{md}");
}

#[test]
fn bad_study_files_are_errors_naming_file_and_key() {
    let d = scratch("study-bad");
    let cases: &[(&str, &str)] = &[
        (
            "[[axes]]\nname = \"f\"\nkeys = [\"bodies.disk.element\"]\nvalues = [\"Q1C1\"]\nbogus = 1\n",
            "unknown field `bogus`",
        ),
        (
            "[[axes]]\nname = \"f\"\nkeys = [\"bodies.disk.element\"]\nvalues = [\"Q1C1\"]\n\
             [[metrics]]\nname = \"a\"\nkind = \"range\"\ncolumn = \"x\"\nrelative_to = \"b\"\n",
            "`metrics.0.relative_to`: no metric `b`",
        ),
        (
            "[[axes]]\nname = \"f\"\nkeys = [\"bodies.disk.element\"]\nvalues = [\"Q1C1\"]\n\
             [[metrics]]\nname = \"a\"\nkind = \"median\"\ncolumn = \"x\"\n",
            "unknown variant `median`",
        ),
        ("jobs = 2\n", "missing field `axes`"),
    ];
    for (body, want) in cases {
        let file = write_study(&d, body);
        let o = study(&["--check", file.to_str().unwrap()]);
        let e = stderr(&o);
        assert!(!o.status.success(), "{body}");
        assert!(e.contains(want) && e.contains("study.toml"), "{body}\n{e}");
    }
    // a run whose case does not pass check fails --check, naming the run
    let file = write_study(
        &d,
        "[[axes]]\nname = \"f\"\nkeys = [\"bodies.disk.element\"]\nvalues = [\"Q1C1\", \"Q1Z7\"]\n",
    );
    let o = study(&["--check", file.to_str().unwrap()]);
    let e = stderr(&o);
    assert!(
        !o.status.success() && e.contains("1 of 2 runs") && e.contains("Q1Z7:"),
        "{e}"
    );
}

#[test]
fn every_shipped_study_passes_check() {
    let dir = root().join("cases/studies");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).expect("cases/studies") {
        let p = entry.unwrap().path();
        if p.extension().is_some_and(|e| e == "toml") {
            let o = study(&["--check", p.to_str().unwrap()]);
            assert!(o.status.success(), "{}: {}", p.display(), stderr(&o));
            n += 1;
        }
    }
    assert!(n >= 5, "found only {n} studies");
    let readme = std::fs::read_to_string(dir.join("README.md")).expect("cases/studies/README.md");
    for entry in std::fs::read_dir(&dir).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        if name.ends_with(".toml") {
            assert!(
                readme.contains(&name),
                "cases/studies/README.md does not mention {name}"
            );
        }
    }
}

#[test]
fn runs_go_through_mpirun_and_a_timeout_stops_a_run() {
    let d = scratch("study-ranks");
    let file = write_study(
        &d,
        "ranks = 2\nset = [\"stages.0.steps=2\"]\n\
         [[axes]]\nname = \"family\"\nkeys = [\"bodies.disk.element\"]\nvalues = [\"Q1N2\"]\n\
         [[axes]]\nname = \"mesh\"\nlevels = [ { name = \"m16\", set = [\"meshes.disk.n_arc=16\", \"meshes.disk.n_radial=4\"] } ]\n",
    );
    let out = d.join("out");
    let o = study(&[file.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = &study_rows(&out)["Q1N2_m16"];
    assert_eq!(r["status"], "converged", "{r:?}");
    assert_eq!(summary(&out.join("Q1N2_m16"))["ranks"], 2);

    // the same run with a timeout far below its run time is stopped and recorded
    let text = std::fs::read_to_string(&file).unwrap();
    std::fs::write(
        &file,
        format!("timeout = 0.01\n{text}").replace("steps=2", "steps=3"),
    )
    .unwrap();
    let o = study(&[file.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(!o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("1 of 1 runs failed"), "{}", stderr(&o));
    let r = &study_rows(&out)["Q1N2_m16"];
    assert_eq!(r["status"], "failed", "{r:?}");
    assert!(r["reason"].contains("timeout of 0.01 s"), "{r:?}");
}
