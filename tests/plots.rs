//! The pictures a run writes beside its results (`output.plots`): the default case of the README's
//! first command (ironing, 2D) and a 3D contact case, on 1 and 2 ranks; what they show is checked
//! against the run's own history.csv and results.h5, not only that files exist.

mod common;
use common::*;
use resvg::tiny_skia::Pixmap;
use std::path::Path;

/// Pixels of the colour map's upper half (green to yellow: high contact pressure) and grey
/// pixels (cells out of contact) in a PNG.
fn count_colours(png: &Path) -> (usize, usize, (u32, u32)) {
    let pix = Pixmap::load_png(png).unwrap_or_else(|e| panic!("{}: {e}", png.display()));
    let (mut hot, mut grey) = (0, 0);
    for p in pix.pixels() {
        let (r, g, b) = (p.red() as i32, p.green() as i32, p.blue() as i32);
        if g > 170 && b < 120 && r < 255 {
            hot += 1;
        }
        if (r - g).abs() < 4 && (g - b).abs() < 4 && (150..=232).contains(&r) {
            grey += 1;
        }
    }
    (hot, grey, (pix.width(), pix.height()))
}

#[test]
fn the_default_case_draws_its_forces_and_its_contact_pressure() {
    for np in [1, 2] {
        let d = scratch(&format!("plots-ironing-{np}"));
        let c = case("ironing_2d.toml");
        let out = run_ok(
            np,
            &[
                "run",
                c.to_str().unwrap(),
                "--out",
                d.to_str().unwrap(),
                "--overwrite",
            ],
        );
        let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), stderr(&out));
        // the paths are printed, once (rank 0 writes them)
        let line = text
            .lines()
            .find(|l| l.starts_with("pictures: "))
            .unwrap_or_else(|| panic!("no pictures line in:\n{text}"));
        assert_eq!(text.matches("pictures: ").count(), 1, "{text}");
        for f in ["history.png", "moments.png", "deformed.png"] {
            assert!(line.contains(&d.join(f).display().to_string()), "{line}");
            assert!(d.join(f).exists(), "{f} missing");
            assert!(
                d.join(f).with_extension("svg").exists(),
                "{f}'s svg missing"
            );
        }
        // every force column that is not zero is a series, and no zero one is (the default
        // formulation is one-pass: the slave `cylinder.arc` reports the contact force)
        let svg = std::fs::read_to_string(d.join("history.svg")).unwrap();
        for col in ["R_cylinder_top_y", "P_ironing_cylinder_arc_y"] {
            let peak = history_col(&d, col)
                .iter()
                .fold(0.0f64, |m, v| m.max(v.abs()));
            assert!(peak > 0.1, "{col} peaks at {peak}");
            assert!(svg.contains(col), "history.svg lacks {col}");
        }
        assert!(!svg.contains("wall_time") && !svg.contains("newton"));
        // the picture: grey cells, and the colour of the highest pressure where contact is
        let (hot, grey, (w, h)) = count_colours(&d.join("deformed.png"));
        assert!(w >= 1000 && h >= 500, "{w} x {h}");
        assert!(grey > 50_000, "grey pixels: {grey}");
        assert!(hot > 200, "high-pressure pixels: {hot}");
        // the colour bar's top label is the largest pressure of the last step, which the
        // surface grid of results.h5 holds
        let p_max = h5_last(&d, "surface", "contact_pressure")
            .into_iter()
            .chain(h5_last(&d, "bulk", "contact_pressure"))
            .fold(0.0f64, f64::max);
        let svg = std::fs::read_to_string(d.join("deformed.svg")).unwrap();
        assert!(
            svg.contains(&format!(">{p_max:.3}<")),
            "deformed.svg has no colour bar label {p_max:.3}"
        );
        assert!(
            svg.contains("#fde725"),
            "no segment at the largest pressure"
        );
    }
}

#[test]
fn a_3d_contact_case_shows_the_contact_zone_along_its_normal() {
    let d = run_case("plots-hemisphere", "hemisphere_block_3d.toml", 1, &[]);
    let svg = std::fs::read_to_string(d.join("deformed.svg")).unwrap();
    assert!(svg.contains("oblique view"));
    // the block's top is pressed from above: the contact zone is seen along +z
    // (a zero component may print with either sign)
    assert!(
        svg.replace("-0.00,", "0.00,")
            .contains("contact zone along n = (0.00, 0.00, 1.00)"),
        "{}",
        svg.lines()
            .filter(|l| l.contains("contact zone"))
            .collect::<String>()
    );
    let (hot, grey, _) = count_colours(&d.join("deformed.png"));
    assert!(grey > 50_000 && hot > 0, "grey {grey}, hot {hot}");
}

#[test]
fn plots_can_be_turned_off() {
    let d = run_case("plots-off", "hertz_2d.toml", 1, &["output.plots=false"]);
    for f in ["history.png", "history.svg", "deformed.png", "deformed.svg"] {
        assert!(!d.join(f).exists(), "{f} written with output.plots = false");
    }
    assert!(d.join("history.csv").exists());
}
