//! The half-cylinder case (cases/half_cylinder_press_2d.toml) with every enriched family: the same
//! displacement on 1 and 2 ranks, and refinement converging towards a fine Q1C1 solution; the 3D
//! block case with a Q1N2-enriched top on 1 and 2 ranks.
//! Runs the solver binary (with mpirun for 2 ranks), reads results.h5 and history.csv.
use std::path::{Path, PathBuf};
use std::process::Command;

const CASE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/cases/half_cylinder_press_2d.toml"
);

const BLOCK_3D: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/cases/block_compression_3d.toml"
);

/// Runs the half-cylinder case on `ranks` ranks with `--set` overrides; returns the output directory.
fn run(tag: &str, ranks: usize, sets: &[String]) -> PathBuf {
    run_case(CASE, tag, ranks, sets)
}

/// Runs `case` on `ranks` ranks with `--set` overrides; returns the output directory.
fn run_case(case: &str, tag: &str, ranks: usize, sets: &[String]) -> PathBuf {
    let out =
        Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("enriched_ranks_{tag}_np{ranks}"));
    let _ = std::fs::remove_dir_all(&out);
    let bin = env!("CARGO_BIN_EXE_nurbs-contact");
    let mut cmd = if ranks == 1 {
        Command::new(bin)
    } else {
        let mut c = Command::new("mpirun");
        c.args(["--oversubscribe", "-np", &ranks.to_string(), bin]);
        c
    };
    cmd.env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .args(["run", case, "--out"])
        .arg(&out);
    for s in sets {
        cmd.args(["--set", s]);
    }
    let res = cmd.output().expect("cannot start the solver");
    assert!(
        res.status.success(),
        "{tag} on {ranks} ranks failed:\n{}\n{}",
        String::from_utf8_lossy(&res.stdout),
        String::from_utf8_lossy(&res.stderr)
    );
    out
}

/// Bulk displacement of the last written step.
fn last_displacement(out: &Path) -> Vec<f64> {
    let f = hdf5::File::open(out.join("results.h5")).unwrap();
    let steps = f.group("steps").unwrap().member_names().unwrap();
    let last = steps.iter().max().unwrap();
    f.dataset(&format!("steps/{last}/bulk/displacement"))
        .unwrap()
        .read_raw::<f64>()
        .unwrap()
}

/// Last value of a history column.
fn last_history(out: &Path, column: &str) -> f64 {
    let text = std::fs::read_to_string(out.join("history.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = header.iter().position(|h| *h == column).unwrap();
    let last = lines.last().unwrap();
    last.split(',').nth(col).unwrap().parse().unwrap()
}

fn element(family: &str) -> String {
    format!("bodies.disk.element={family}")
}

#[test]
fn every_enriched_family_gives_the_same_displacement_on_1_and_2_ranks() {
    for family in ["Q1C1", "Q1N2", "Q1N2.1", "Q1C2", "Q1CH"] {
        let sets = [element(family)];
        let u1 = last_displacement(&run(family, 1, &sets));
        let u2 = last_displacement(&run(family, 2, &sets));
        assert_eq!(u1.len(), u2.len());
        let scale = u1.iter().fold(0.0_f64, |a, x| a.max(x.abs()));
        assert!(scale > 0.09, "{family}: the top must move by 0.1");
        let diff = u1
            .iter()
            .zip(&u2)
            .fold(0.0_f64, |a, (x, y)| a.max((x - y).abs()));
        assert!(
            diff <= 1e-10 * scale,
            "{family}: 1 vs 2 ranks differ by {diff}"
        );
    }
}

/// Max difference between two displacement vectors relative to the largest entry of the first.
fn relative_difference(u1: &[f64], u2: &[f64]) -> f64 {
    assert_eq!(u1.len(), u2.len());
    let scale = u1.iter().fold(0.0_f64, |a, x| a.max(x.abs()));
    u1.iter()
        .zip(u2)
        .fold(0.0_f64, |a, (x, y)| a.max((x - y).abs()))
        / scale
}

#[test]
fn enriched_3d_block_gives_the_same_displacement_on_1_and_2_ranks() {
    let sets = [
        "bodies.block.element=Q1N2".to_string(),
        "bodies.block.enriched_surface=zmax".to_string(),
    ];
    let u1 = last_displacement(&run_case(BLOCK_3D, "block_q1n2", 1, &sets));
    let u2 = last_displacement(&run_case(BLOCK_3D, "block_q1n2", 2, &sets));
    let d = relative_difference(&u1, &u2);
    assert!(d <= 1e-10, "3D Q1N2: 1 vs 2 ranks differ by {d}");
}

#[test]
fn refined_enriched_meshes_converge_to_the_fine_q1c1_reaction() {
    let mesh = |n_arc: usize, n_rad: usize| {
        [
            format!("meshes.disk.n_arc={n_arc}"),
            format!("meshes.disk.n_radial={n_rad}"),
        ]
    };
    let reaction = |tag: &str, family: &str, n_arc: usize, n_rad: usize| {
        let mut sets = mesh(n_arc, n_rad).to_vec();
        sets.push(element(family));
        last_history(&run(tag, 1, &sets), "R_disk_top_core_y")
    };
    let fine = reaction("fine_q1c1", "Q1C1", 128, 32);
    for family in ["Q1N2", "Q1N2.1"] {
        let errors: Vec<f64> = [(8, 2), (16, 4), (32, 8)]
            .iter()
            .map(|&(a, r)| (reaction(&format!("{family}_{a}"), family, a, r) - fine).abs())
            .collect();
        assert!(
            errors.windows(2).all(|w| w[1] < 0.7 * w[0]),
            "{family}: reaction errors {errors:?} must decrease with refinement"
        );
    }
}
