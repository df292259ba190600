//! Friction: the consistent tangent in stick and slip against central differences (2D, 3D, rigid
//! partners), and the anchors and warm starts across intermediate commits.

use super::*;

/// Friction: the pair is pressed to `u0` and that state committed (every active point anchors at
/// its projection), then the tangent at `u1` is checked against central differences at those fixed
/// anchors (the consistent tangent of a step). Returns (error, largest entry, sticking points,
/// slipping points) at `u1`.
fn friction_fd(h: &mut Harness, u0: &[f64], u1: &[f64]) -> (f64, f64, usize, usize) {
    h.eval(u0, false);
    h.sys.commit();
    let (err, kmax) = tangent_error(h, u1);
    h.eval(u1, false);
    let res = h.sys.results();
    let stick = res[0].1.iter().map(|r| r.n_stick).sum();
    let slip = res[0].1.iter().map(|r| r.n_slip).sum();
    (err, kmax, stick, slip)
}

/// The 2D pair pressed, then its disk shifted a little (most points stick) and far (most slip):
/// the frictional tangent against central differences in both.
pub(super) fn friction_fd_2d(block: &str, disk: &str, law: &str) {
    for (shift, want_slip) in [(2e-4, false), (0.06, true)] {
        let mut h = Harness::new(&case_2d(block, disk, law));
        let u0 = pressed(&h, 0.08, 0.0, 2e-3, 11);
        let disk_i = h
            .model
            .bodies
            .iter()
            .position(|b| b.name == "disk")
            .unwrap();
        let u1 = shifted(&h, &u0, &|b| {
            if b == disk_i {
                vec![shift, 0.0]
            } else {
                vec![0.0; 2]
            }
        });
        let (err, kmax, stick, slip) = friction_fd(&mut h, &u0, &u1);
        let what = if want_slip { "slip" } else { "stick" };
        assert!(kmax > 1.0, "{block}/{disk} {what}: no stiffness ({kmax})");
        assert!(
            if want_slip {
                slip > stick
            } else {
                stick > slip
            },
            "{block}/{disk} {what}: {stick} sticking, {slip} slipping"
        );
        assert!(err < 1e-6, "{block}/{disk} {what}: tangent error {err:e}");
    }
}

/// The hemisphere on a block, pressed, then shifted a little and far: the frictional tangent
/// against central differences with sticking and with slipping points.
pub(super) fn friction_fd_hemisphere(lower: &str, shell: &str, law: &str) {
    for (shift, want_slip) in [(1e-4, false), (0.05, true)] {
        let mut h = Harness::new(&case_3d_hemisphere(lower, shell, law));
        let u0 = pressed_3d(&h, 0.06, [0.05, 0.08], 2e-3, 23);
        let lo = h
            .model
            .bodies
            .iter()
            .position(|b| b.name == "lower")
            .unwrap();
        let u1 = shifted(&h, &u0, &|b| {
            if b == lo {
                vec![0.0; 3]
            } else {
                vec![-shift, shift, 0.0]
            }
        });
        let (err, _, stick, slip) = friction_fd(&mut h, &u0, &u1);
        let what = if want_slip { "slip" } else { "stick" };
        assert!(stick + slip > 0, "{lower}/{shell}: no frictional point");
        assert!(
            if want_slip { slip > 0 } else { stick > 0 },
            "{lower}/{shell} {what}: {stick} sticking, {slip} slipping"
        );
        assert!(err < 1e-6, "{lower}/{shell} {what}: tangent error {err:e}");
    }
}

/// `u` plus a rigid shift of the bodies `f` selects.
fn shifted(h: &Harness, u: &[f64], f: &dyn Fn(usize) -> Vec<f64>) -> Vec<f64> {
    let d = h.displacement(&|b, _| f(b));
    u.iter().zip(&d).map(|(a, b)| a + b).collect()
}

#[test]
fn one_pass_friction_tangent_matches_central_differences_in_stick_and_slip() {
    // one-pass: the master rows carry the opposite of the slave point's frictional traction,
    // which varies with the anchor element's unknowns too (a cross block: the master's rows, the
    // anchor element's columns); pointwise and mortar gaps, 2D and the hemisphere
    for gap in ["pointwise", "weighted"] {
        let law = format!(
            "law = \"penalty\"\neps_n = 100.0\nmu = 0.3\neps_t = 80.0\ngap = \"{gap}\"\n\
             algorithm = \"one_pass\""
        );
        for (block, disk) in [("Q1N2", "Q1N2"), ("Q1C1", "Q1N2"), ("Q1N2", "Q1C1")] {
            friction_fd_2d(block, disk, &law);
        }
        friction_fd_hemisphere("Q1N2", "Q1N2", &law);
    }
}

#[test]
fn friction_tangent_matches_central_differences_in_stick_and_slip_2d() {
    for (block, disk) in [
        ("Q1C1", "Q1C1"),
        ("Q1N2", "Q1N2"),
        ("Q1N2", "Q1C1"),
        ("Q1N2.1", "Q1CH"),
    ] {
        let law = "law = \"penalty\"\neps_n = 100.0\nmu = 0.3\neps_t = 80.0";
        friction_fd_2d(block, disk, law);
    }
}

#[test]
fn friction_tangent_matches_central_differences_in_stick_and_slip_3d() {
    for (lower, upper) in [("Q1C1", "Q1C1"), ("Q1N2", "Q1N2"), ("Q1N2", "Q1C1")] {
        let law = "law = \"penalty\"\neps_n = 100.0\nmu = 0.3";
        for (shift, want_slip) in [(1e-4, false), (0.05, true)] {
            let mut h = Harness::new(&case_3d_blocks(lower, upper, law));
            let u0 = pressed_3d(&h, 0.04, [0.11, -0.07], 2e-3, 17);
            let lo = h
                .model
                .bodies
                .iter()
                .position(|b| b.name == "lower")
                .unwrap();
            let u1 = shifted(&h, &u0, &|b| {
                if b == lo {
                    vec![0.0; 3]
                } else {
                    vec![shift, 0.6 * shift, 0.0]
                }
            });
            let (err, kmax, stick, slip) = friction_fd(&mut h, &u0, &u1);
            let what = if want_slip { "slip" } else { "stick" };
            assert!(kmax > 1.0, "{lower}/{upper} {what}: no stiffness ({kmax})");
            if want_slip {
                assert!(
                    slip > stick,
                    "{lower}/{upper}: {slip} slipping, {stick} sticking"
                );
            } else {
                assert!(
                    stick > slip,
                    "{lower}/{upper}: {stick} sticking, {slip} slipping"
                );
            }
            assert!(err < 1e-6, "{lower}/{upper} {what}: tangent error {err:e}");
        }
    }
    // the curved partner: a Q1N2 hemisphere on a block
    let law = "law = \"penalty\"\neps_n = 100.0\nmu = 0.3";
    for (lower, shell) in [("Q1N2", "Q1N2"), ("Q1C1", "Q1N2")] {
        friction_fd_hemisphere(lower, shell, law);
    }
}

#[test]
fn friction_tangent_against_rigid_partners_matches_central_differences() {
    let rigid_2d = [
        "{ shape = \"plane\", point = [0.0, 0.0], normal = [0.2, 1.0], translation = [[0.3, 0.1]] }",
        "{ shape = \"circle\", center = [0.3, -2.0], radius = 2.0 }",
    ];
    let rigid_3d = [
        "{ shape = \"plane\", point = [0.0, 0.0, 0.0], normal = [0.1, -0.2, 1.0] }",
        "{ shape = \"sphere\", center = [0.2, 0.1, -3.0], radius = 3.0, rotation_deg = [10.0] }",
    ];
    for (dim, fams, shapes) in [
        (2, &["Q1C1", "Q1N2", "Q1N2.1"][..], &rigid_2d),
        (3, &["Q1C1", "Q1N2"][..], &rigid_3d),
    ] {
        for fam in fams {
            for r in shapes {
                for (shift, want_slip) in [(1e-4, false), (0.3, true)] {
                    let text = case_rigid(dim, fam, r)
                        .replace("eps_n = 100.0", "eps_n = 100.0\nmu = 0.4\neps_t = 50.0");
                    let mut h = Harness::new(&text);
                    // the rigid partner sits at its load-0.5 position (translated, rotated)
                    h.sys.set_load(0.5);
                    let down = if dim == 2 {
                        vec![0.05, -0.06]
                    } else {
                        vec![0.02, 0.01, -0.05]
                    };
                    let u0 = h.shifted_noisy(&down, 1);
                    // rigid shift along x (the partner moves too: its anchors with it)
                    let u1 = shifted(&h, &u0, &|_| {
                        let mut v = vec![0.0; dim];
                        v[0] = shift;
                        v
                    });
                    h.eval(&u0, false);
                    h.sys.commit();
                    h.sys.set_load(0.6);
                    let (err, kmax) = tangent_error(&mut h, &u1);
                    h.eval(&u1, false);
                    let res = &h.sys.results()[0].1[0];
                    let what = if want_slip { "slip" } else { "stick" };
                    assert!(kmax > 1.0, "{fam} {r} {what}: no stiffness ({kmax})");
                    if want_slip {
                        assert!(res.n_slip > 0, "{fam} {r}: {res:?}");
                    } else {
                        assert!(res.n_stick > 0, "{fam} {r}: {res:?}");
                    }
                    assert!(err < 1e-6, "{fam} {r} {what}: tangent error {err:e}");
                }
            }
        }
    }
}

/// The rescue's intermediate commits (`commit_warm_starts`) keep the friction anchors of the last
/// converged step, while a step's `commit` moves the slipping points' anchors; the warm starts
/// follow both (`export_points` rows: key 0..4, warm start 4..8, anchor 8..12; see
/// `system/checkpoint.rs`).
#[test]
fn intermediate_commits_keep_the_friction_anchors() {
    let law = "law = \"penalty\"\neps_n = 100.0\nmu = 0.3\neps_t = 80.0";
    let mut h = Harness::new(&case_2d("Q1N2", "Q1N2", law));
    let u0 = pressed(&h, 0.08, 0.0, 2e-3, 11);
    let disk_i = h
        .model
        .bodies
        .iter()
        .position(|b| b.name == "disk")
        .unwrap();
    let u1 = shifted(&h, &u0, &|b| {
        if b == disk_i {
            vec![0.06, 0.0]
        } else {
            vec![0.0; 2]
        }
    });
    h.eval(&u0, false);
    h.sys.commit();
    let at_u0 = h.sys.export_points();
    h.eval(&u1, false);
    let slip: usize = h.sys.results()[0].1.iter().map(|r| r.n_slip).sum();
    assert!(slip > 0, "the shift must make points slip");
    h.sys.commit_warm_starts();
    let intermediate = h.sys.export_points();
    h.sys.commit();
    let converged = h.sys.export_points();
    let row = crate::contact::system::CHECKPOINT_ROW;
    let split = |v: &[f64]| -> (Vec<f64>, Vec<f64>) {
        let (mut warm, mut anchors) = (Vec::new(), Vec::new());
        for r in v.chunks_exact(row) {
            warm.extend_from_slice(&r[4..8]);
            anchors.extend_from_slice(&r[8..12]);
        }
        (warm, anchors)
    };
    let ((w0, a0), (wi, ai), (wc, ac)) = (split(&at_u0), split(&intermediate), split(&converged));
    assert_eq!(ai, a0, "an intermediate commit moved friction anchors");
    assert_ne!(
        ac, a0,
        "a converged step's commit moves the slipping points' anchors"
    );
    assert_ne!(
        wi, w0,
        "an intermediate commit keeps the warm starts it reached"
    );
    assert_eq!(wi, wc);
}
