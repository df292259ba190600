//! The safe PETSc wrapper, exercised in-process: vectors and their views, COO and MatSetValues
//! assembly giving the same matrix, a KSP direct solve, errors carrying PETSc's message, and SNES
//! driving a Rust problem through the trampolines — including a domain error and a panic in a
//! callback, which must come back as values, not abort the process.
//!
//! MPI can be initialised once per process, so this is one test running its checks in sequence.

use nurbs_contact::petsc::{Ksp, Matrix, NonlinearProblem, Petsc, ProblemError, Snes, Vector};

/// F_i(x) = x_i^3 - 8 (root 2 in every component), with switches for failure modes.
struct Cubic {
    domain_error_below: f64,
    /// Residuals at x above this raise a domain error too.
    domain_error_above: f64,
    panic: bool,
    /// The Jacobian evaluation of this number (from 1) raises a domain error.
    jacobian_error_at: Option<usize>,
    /// `stop_requested` from this Jacobian evaluation on.
    stop_from: Option<usize>,
    /// Jacobian evaluations so far.
    jacobians: usize,
}

impl Cubic {
    fn new(domain_error_below: f64, panic: bool) -> Cubic {
        Cubic {
            domain_error_below,
            domain_error_above: f64::INFINITY,
            panic,
            jacobian_error_at: None,
            stop_from: None,
            jacobians: 0,
        }
    }
}

impl NonlinearProblem for Cubic {
    fn residual(&mut self, x: &Vector, f: &mut Vector) -> Result<(), ProblemError> {
        if self.panic {
            panic!("deliberate panic in a residual");
        }
        let xa = x.read().map_err(|e| ProblemError::Fatal(e.to_string()))?;
        if xa
            .iter()
            .any(|&v| v < self.domain_error_below || v > self.domain_error_above)
        {
            return Err(ProblemError::Domain("x left the domain".into()));
        }
        let mut fa = f.write().map_err(|e| ProblemError::Fatal(e.to_string()))?;
        for (fi, xi) in fa.iter_mut().zip(xa.iter()) {
            *fi = xi * xi * xi - 8.0;
        }
        Ok(())
    }

    fn stop_requested(&self) -> bool {
        self.stop_from.is_some_and(|n| self.jacobians >= n)
    }

    fn jacobian(&mut self, x: &Vector, j: &mut Matrix) -> Result<(), ProblemError> {
        self.jacobians += 1;
        if self.jacobian_error_at == Some(self.jacobians) {
            return Err(ProblemError::Domain("no Jacobian here".into()));
        }
        let (lo, _) = x
            .ownership_range()
            .map_err(|e| ProblemError::Fatal(e.to_string()))?;
        let xa = x.read().map_err(|e| ProblemError::Fatal(e.to_string()))?;
        j.zero().map_err(|e| ProblemError::Fatal(e.to_string()))?;
        for (k, xi) in xa.iter().enumerate() {
            let g = lo + k as i32;
            j.add_values(&[g], &[g], &[3.0 * xi * xi])
                .map_err(|e| ProblemError::Fatal(e.to_string()))?;
        }
        j.assemble().map_err(|e| ProblemError::Fatal(e.to_string()))
    }
}

fn diagonal_matrix<'p>(petsc: &'p Petsc, n: usize) -> Matrix<'p> {
    let mut j = Matrix::new_aij(petsc, n).unwrap();
    let counts = vec![1; n];
    j.preallocate_aij(&counts, &vec![0; n]).unwrap();
    j
}

#[test]
fn petsc_wrapper_end_to_end() {
    let universe = mpi::initialize().expect("MPI init");
    let world = universe.world();
    let petsc = Petsc::init(&world, &["petsc_wrapper".to_string()]).expect("PETSc init");

    // Vectors: views write and read back, restored on drop; norms and axpy.
    let mut v = Vector::new_mpi(&petsc, 5).unwrap();
    v.set(2.0).unwrap();
    assert!((v.norm2().unwrap() - 20f64.sqrt()).abs() < 1e-14);
    {
        let mut w = v.write().unwrap();
        w[0] = -1.0;
    }
    assert_eq!(v.read().unwrap()[0], -1.0);
    let mut u = v.duplicate().unwrap();
    v.copy_to(&mut u).unwrap();
    u.axpy(-1.0, &v).unwrap();
    assert_eq!(u.norm2().unwrap(), 0.0);

    // The same 4x4 tridiagonal matrix through COO (repeated entries summed, negative indices
    // dropped) and through MatSetValues.
    let n = 4;
    let mut a = Matrix::new_aij(&petsc, n).unwrap();
    let (mut rows, mut cols, mut vals) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..n as i32 {
        for (j, v) in [(i - 1, -1.0), (i, 1.0), (i, 1.0), (i + 1, -1.0)] {
            if j >= 0 && j < n as i32 {
                rows.push(i);
                cols.push(j);
                vals.push(v);
            }
        }
        rows.push(-1);
        cols.push(i);
        vals.push(1e9); // dropped
    }
    a.set_preallocation_coo(&mut rows, &mut cols).unwrap();
    a.set_values_coo(&vals).unwrap();
    let mut b = Matrix::new_aij(&petsc, n).unwrap();
    b.preallocate_aij(&[2, 3, 3, 2], &[0; 4]).unwrap();
    for i in 0..n as i32 {
        for (j, v) in [(i - 1, -1.0), (i, 2.0), (i + 1, -1.0)] {
            if j >= 0 && j < n as i32 {
                b.add_values(&[i], &[j], &[v]).unwrap();
            }
        }
    }
    b.assemble().unwrap();
    assert_eq!(b.assembly_mallocs().unwrap(), 0.0);
    let mut x = Vector::new_mpi(&petsc, n).unwrap();
    {
        let mut w = x.write().unwrap();
        w.copy_from_slice(&[1.0, -2.0, 3.0, 0.5]);
    }
    let (mut ya, mut yb) = (x.duplicate().unwrap(), x.duplicate().unwrap());
    a.mult(&x, &mut ya).unwrap();
    b.mult(&x, &mut yb).unwrap();
    yb.axpy(-1.0, &ya).unwrap();
    assert!(
        yb.norm2().unwrap() < 1e-14,
        "COO and MatSetValues matrices differ"
    );
    assert_eq!(a.nonzeros().unwrap(), 10.0);

    // KSP: a direct MUMPS solve of A z = A x recovers x.
    let mut ksp = Ksp::new(&petsc).unwrap();
    ksp.set_operators(&a).unwrap();
    ksp.set_type("preonly").unwrap();
    {
        let mut pc = ksp.pc().unwrap();
        pc.set_type("lu").unwrap();
        pc.set_factor_solver_type("mumps").unwrap();
    }
    let mut z = x.duplicate().unwrap();
    let out = ksp.solve(&ya, &mut z).unwrap();
    assert!(out.converged, "{out:?}");
    z.axpy(-1.0, &x).unwrap();
    assert!(z.norm2().unwrap() < 1e-12);

    // KSP's convergence test: a stop query ends an unpreconditioned GMRES solve of a 1D
    // Laplacian (which needs far more than 5 iterations) at the first iteration it answers yes,
    // and `stopped` says so once; without the query the same solve converges, and a solve stopped
    // by its iteration limit is accepted as converged when its true residual is small enough.
    let m = 200;
    let mut lap = Matrix::new_aij(&petsc, m).unwrap();
    lap.preallocate_aij(&vec![3; m], &vec![0; m]).unwrap();
    for i in 0..m as i32 {
        for (j, v) in [(i - 1, -1.0), (i, 2.0), (i + 1, -1.0)] {
            if j >= 0 && j < m as i32 {
                lap.add_values(&[i], &[j], &[v]).unwrap();
            }
        }
    }
    lap.assemble().unwrap();
    let mut rhs = Vector::new_mpi(&petsc, m).unwrap();
    rhs.set(1.0).unwrap();
    let mut sol = rhs.duplicate().unwrap();
    let gmres = |stop: Option<nurbs_contact::petsc::StopQuery>, accept: Option<f64>, max_it| {
        let mut k = Ksp::new(&petsc).unwrap();
        k.set_operators(&lap).unwrap();
        k.set_type("gmres").unwrap();
        k.pc().unwrap().set_type("none").unwrap();
        k.set_tolerances(1e-10, 1e-50, 1e4, max_it).unwrap();
        k.set_convergence_test(accept, stop).unwrap();
        k
    };
    let calls = std::rc::Rc::new(std::cell::Cell::new(0usize));
    let seen = calls.clone();
    let mut k = gmres(
        Some(Box::new(move || {
            seen.set(seen.get() + 1);
            seen.get() > 5
        })),
        None,
        10_000,
    );
    sol.set(0.0).unwrap();
    let out = k.solve(&rhs, &mut sol).unwrap();
    assert!(!out.converged, "{out:?}");
    assert_eq!(out.iterations, 5, "{out:?}");
    assert_eq!(calls.get(), 6);
    assert!(k.stopped().unwrap(), "the stop is not reported");
    assert!(!k.stopped().unwrap(), "the stop is reported twice");
    let mut k = gmres(Some(Box::new(|| false)), None, 10_000);
    sol.set(0.0).unwrap();
    let out = k.solve(&rhs, &mut sol).unwrap();
    assert!(out.converged && out.iterations > 5, "{out:?}");
    assert!(!k.stopped().unwrap());
    let mut k = gmres(None, Some(1.0), 3);
    sol.set(0.0).unwrap();
    let out = k.solve(&rhs, &mut sol).unwrap();
    assert!(out.converged && out.iterations == 3, "{out:?}");
    assert_eq!(k.accepted_at_limit().unwrap(), 1);

    // Errors carry PETSc's message and the function name (PETSc also prints its traceback).
    let small = Vector::new_seq(&petsc, 3).unwrap();
    let mut big = Vector::new_seq(&petsc, 4).unwrap();
    let err = small.copy_to(&mut big).unwrap_err();
    assert_eq!(err.function, "VecCopy");
    assert!(!err.message.is_empty() && err.code != 0, "{err}");
    assert!(Ksp::new(&petsc).unwrap().set_type("no_such_ksp").is_err());

    // SNES on x^3 = 8 from x = 1: converges to 2, quadratically at the end.
    let mut snes = Snes::new(&petsc).unwrap();
    snes.set_tolerances(1e-12, 1e-14, 0.0, 50).unwrap();
    snes.set_from_options().unwrap();
    let mut jm = diagonal_matrix(&petsc, 3);
    let mut xs = Vector::new_mpi(&petsc, 3).unwrap();
    xs.set(1.0).unwrap();
    let mut problem = Cubic::new(-1e9, false);
    let out = snes.solve(&mut problem, &mut xs, &mut jm).unwrap();
    assert!(out.converged, "{out:?}");
    assert!(xs.read().unwrap().iter().all(|&v| (v - 2.0).abs() < 1e-12));
    let h = &out.residual_history;
    assert_eq!(h.len(), out.iterations + 1);
    let k = h.len() - 2;
    assert!(
        h[k] < 1e-4 && h[k] / (h[k - 1] * h[k - 1]) < 10.0,
        "not quadratic: {h:?}"
    );

    // A domain error at the start is reported as a diverged solve with the message, not an error.
    xs.set(1.0).unwrap();
    let mut problem = Cubic::new(1.5, false);
    let out = snes.solve(&mut problem, &mut xs, &mut jm).unwrap();
    assert!(!out.converged);
    assert_eq!(out.domain_error.as_deref(), Some("x left the domain"));

    // A panic inside a callback is caught at the FFI boundary and comes back as an error.
    let mut problem = Cubic::new(-1e9, true);
    let err = snes.solve(&mut problem, &mut xs, &mut jm).unwrap_err();
    assert!(err.message.contains("deliberate panic"), "{err}");

    // A Jacobian domain error stops the solve after that iteration (PETSc 3.18 would otherwise go
    // on with the previous matrix and its factorisation), and does not stick to the SNES: the
    // next solve converges quadratically, every iteration with a fresh factorisation.
    xs.set(1.0).unwrap();
    let mut problem = Cubic::new(-1e9, false);
    problem.jacobian_error_at = Some(2);
    let out = snes.solve(&mut problem, &mut xs, &mut jm).unwrap();
    assert!(!out.converged, "{out:?}");
    assert_eq!(out.reason, "DIVERGED_JACOBIAN_DOMAIN");
    assert_eq!(out.iterations, 2, "{out:?}");
    assert_eq!(out.domain_error.as_deref(), Some("no Jacobian here"));
    let mut problem = Cubic::new(-1e9, false);
    let out = snes.solve(&mut problem, &mut xs, &mut jm).unwrap();
    assert!(out.converged, "{out:?}");
    assert_eq!(problem.jacobians, out.iterations);
    let h = &out.residual_history;
    let k = h.len() - 2;
    assert!(
        h[k] < 1e-4 && h[k] / (h[k - 1] * h[k - 1]) < 10.0,
        "not quadratic after a Jacobian domain error: {h:?}"
    );

    // The problem can ask for a stop (a new sparsity pattern between solves): the solve ends
    // after that iteration, not converged and with no domain error, and the caller resumes.
    xs.set(1.0).unwrap();
    let mut problem = Cubic::new(-1e9, false);
    problem.stop_from = Some(1);
    let out = snes.solve(&mut problem, &mut xs, &mut jm).unwrap();
    assert!(!out.converged, "{out:?}");
    assert_eq!(out.iterations, 1, "{out:?}");
    assert_eq!(out.domain_error, None);
    let mut problem = Cubic::new(-1e9, false);
    assert!(
        snes.solve(&mut problem, &mut xs, &mut jm)
            .unwrap()
            .converged
    );

    // A Krylov solve ended by the stop query of the KSP's convergence test (a signal to stop the
    // run) ends the Newton solve as interrupted, not as a failed linear solve to retry; the next
    // solve, without the stop, converges.
    {
        let mut k = snes.ksp().unwrap();
        k.set_type("gmres").unwrap();
        k.pc().unwrap().set_type("none").unwrap();
    }
    let stop_now = std::rc::Rc::new(std::cell::Cell::new(true));
    let flag = stop_now.clone();
    snes.ksp()
        .unwrap()
        .set_convergence_test(None, Some(Box::new(move || flag.get())))
        .unwrap();
    xs.set(1.0).unwrap();
    let mut problem = Cubic::new(-1e9, false);
    let out = snes.solve(&mut problem, &mut xs, &mut jm).unwrap();
    assert!(out.interrupted && !out.converged, "{out:?}");
    assert!(out.reason.starts_with("INTERRUPTED"), "{out:?}");
    stop_now.set(false);
    let mut problem = Cubic::new(-1e9, false);
    let out = snes.solve(&mut problem, &mut xs, &mut jm).unwrap();
    assert!(out.converged && !out.interrupted, "{out:?}");

    // PETSc's `l2` line search on x^3 = 8 from x = 1 with a domain error above x = 2.18: the full
    // step (x = 3.33) fails, lambda = 0.5 (x = 2.17) reduces |F|, and its secant step 0.511
    // (x = 2.19) lands outside again. Unchecked, SNES would stop there with
    // DIVERGED_FUNCTION_DOMAIN; the post-check halves that step (x = 1.60) and Newton converges.
    petsc
        .insert_options("-snes_linesearch_type l2", "")
        .unwrap();
    let mut snes_l2 = Snes::new(&petsc).unwrap();
    snes_l2.set_tolerances(1e-12, 1e-14, 0.0, 50).unwrap();
    snes_l2.set_from_options().unwrap();
    xs.set(1.0).unwrap();
    let mut problem = Cubic::new(-1e9, false);
    problem.domain_error_above = 2.18;
    let out = snes_l2.solve(&mut problem, &mut xs, &mut jm).unwrap();
    assert!(out.converged, "{out:?}");
    assert!(xs.read().unwrap().iter().all(|&v| (v - 2.0).abs() < 1e-12));
    // the first iterate is the halved secant step
    let first = 1.0 - 0.5108476450438046 / 2.0 * (1.0 - 8.0) / 3.0;
    let f1 = (first * first * first - 8.0f64).abs() * 3f64.sqrt();
    assert!(
        (out.residual_history[1] - f1).abs() < 1e-9 * f1,
        "{:?} against {f1}",
        out.residual_history
    );

    // The solver is still usable afterwards.
    xs.set(3.0).unwrap();
    let mut problem = Cubic::new(-1e9, false);
    assert!(
        snes.solve(&mut problem, &mut xs, &mut jm)
            .unwrap()
            .converged
    );
}
