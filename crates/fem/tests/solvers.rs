//! Reference: faer sparse Cholesky (LLᵀ / intranodal Bunch–Kaufman LBLᵀ) and preconditioned
//! conjugate gradients (Saad, "Iterative Methods for Sparse Linear Systems", 2003, Alg. 9.1).
//! Goal: the direct solve satisfies K x = b; an indefinite matrix triggers the LBLᵀ fallback
//! (or a typed error when disabled); one factor and one symbolic analysis are shared by threads;
//! PCG with a factor of another design converges; Newton with PCG equals Newton with direct
//! solves; invalid parameters and non-convergence give typed errors with history.

use flexstage_fem::*;
use rayon::prelude::*;

fn stage_matrix(rho_seed: u64) -> (samples::Stage, SparseMatrix, Vec<f64>) {
    let stage = samples::Stage::paper(30, 15, Kinematics::TotalLagrangian).unwrap();
    let rho = stage.random_density(0.01, 1.0, rho_seed, 1e-3);
    let model = &stage.model;
    let mut k = model.new_matrix();
    let mut ws = model.new_workspace();
    model.assemble(
        &Design::new(&rho),
        &model.zero_vector(),
        None,
        Some(&mut k),
        &mut ws,
    );
    (stage, k, rho)
}

fn residual(k: &SparseMatrix, x: &[f64], b: &[f64]) -> f64 {
    let mut y = vec![0.0; b.len()];
    k.matvec(x, &mut y);
    let n: f64 = y
        .iter()
        .zip(b)
        .map(|(a, c)| (a - c).powi(2))
        .sum::<f64>()
        .sqrt();
    n / b.iter().map(|c| c * c).sum::<f64>().sqrt()
}

#[test]
fn direct_solve_and_indefinite_fallback() {
    let (stage, mut k, _) = stage_matrix(1);
    let sym = SymbolicFactor::new(stage.model.pattern().clone()).unwrap();
    let mut f = Factor::new(sym.clone());
    assert_eq!(f.factorize(&k).unwrap(), FactorKind::Llt);
    let b = samples::random_vector(k.n(), -1.0, 1.0, 2);
    let mut x = b.clone();
    let mut sws = f.new_solve_workspace();
    f.solve_in_place(&mut x, &mut sws).unwrap();
    assert!(residual(&k, &x, &b) < 1e-9);

    // Shift the diagonal to make the matrix indefinite.
    let diag: Vec<f64> = (0..k.n()).map(|i| k.diag(i)).collect();
    let shift = 0.3 * diag.iter().sum::<f64>() / diag.len() as f64;
    for (i, &s) in k.pattern().clone().diag_slots().iter().enumerate() {
        let _ = i;
        k.values_mut()[s] -= shift;
    }
    f.allow_indefinite = false;
    assert!(matches!(
        f.factorize(&k),
        Err(SolverError::NotPositiveDefinite { .. })
    ));
    assert!(matches!(
        f.solve_in_place(&mut x.clone(), &mut sws),
        Err(SolverError::NotFactorized)
    ));
    f.allow_indefinite = true;
    let kind = f.factorize(&k).unwrap();
    assert!(matches!(kind, FactorKind::Lblt { .. }), "{kind:?}");
    let mut x = b.clone();
    f.solve_in_place(&mut x, &mut sws).unwrap();
    assert!(
        residual(&k, &x, &b) < 1e-8,
        "LBLT residual {}",
        residual(&k, &x, &b)
    );
}

#[test]
fn shared_factor_across_threads_and_pcg() {
    let (stage, k1, rho) = stage_matrix(3);
    let model = &stage.model;
    let sym = SymbolicFactor::new(model.pattern().clone()).unwrap();
    let mut f1 = Factor::new(sym.clone());
    f1.factorize(&k1).unwrap();
    // A perturbed design: its tangent solved by PCG with f1 as preconditioner, in parallel.
    let rho2: Vec<f64> = rho.iter().map(|r| (r * 1.1).min(1.0)).collect();
    let mut k2 = model.new_matrix();
    model.assemble(
        &Design::new(&rho2),
        &model.zero_vector(),
        None,
        Some(&mut k2),
        &mut model.new_workspace(),
    );
    let mut f2 = Factor::new(sym.clone());
    f2.factorize(&k2).unwrap();
    let rhs: Vec<Vec<f64>> = (0..8)
        .map(|s| samples::random_vector(k2.n(), -1.0, 1.0, 100 + s))
        .collect();
    let results: Vec<(Vec<f64>, usize)> = rhs
        .par_iter()
        .map(|b| {
            let mut sws = SolveWorkspace::new(&sym);
            let mut pws = PcgWorkspace::new(b.len());
            let mut x = vec![0.0; b.len()];
            let rep = pcg(
                &k2,
                &f1,
                b,
                &mut x,
                PcgParams {
                    rel_tol: 1e-11,
                    max_iter: 200,
                },
                &mut pws,
                &mut sws,
            )
            .unwrap();
            (x, rep.iterations)
        })
        .collect();
    let mut sws = SolveWorkspace::new(&sym);
    for (b, (x, its)) in rhs.iter().zip(&results) {
        assert!(*its > 1 && *its < 100, "PCG iterations {its}");
        let mut xd = b.clone();
        f2.solve_in_place(&mut xd, &mut sws).unwrap();
        let err = x
            .iter()
            .zip(&xd)
            .map(|(a, c)| (a - c).abs())
            .fold(0.0, f64::max);
        let sc = xd.iter().fold(0.0f64, |a, c| a.max(c.abs()));
        assert!(err < 1e-8 * sc);
    }
    // Exact preconditioner: one iteration.
    let mut pws = PcgWorkspace::new(k2.n());
    let mut x = vec![0.0; k2.n()];
    let rep = pcg(
        &k2,
        &f2,
        &rhs[0],
        &mut x,
        PcgParams::default(),
        &mut pws,
        &mut sws,
    )
    .unwrap();
    assert_eq!(rep.iterations, 1);
}

#[test]
fn newton_pcg_matches_direct_and_parallel_load_cases() {
    let stage = samples::Stage::paper(30, 15, Kinematics::TotalLagrangian).unwrap();
    let model = &stage.model;
    let rho = stage.random_density(0.05, 1.0, 9, 1e-3);
    let yeoh = AdditiveYeoh::paper(model.mesh().n_elements(), 73e9, 1e-6, 3.0);
    let design = Design::with_yeoh(&rho, &yeoh);
    let sym = SymbolicFactor::new(model.pattern().clone()).unwrap();
    // Shared preconditioner: the tangent at u = 0.
    let mut k0 = model.new_matrix();
    model.assemble(
        &design,
        &model.zero_vector(),
        None,
        Some(&mut k0),
        &mut model.new_workspace(),
    );
    let mut f0 = Factor::new(sym.clone());
    f0.factorize(&k0).unwrap();
    let cases: Vec<(f64, f64)> = (0..8)
        .map(|i| {
            let t = i as f64 / 8.0 * std::f64::consts::TAU;
            (30e-6 * t.cos(), 30e-6 * t.sin())
        })
        .collect();
    let pcg_params = NewtonParams {
        linear: LinearStrategy::Pcg(PcgParams {
            rel_tol: 1e-10,
            max_iter: 100,
        }),
        ..Default::default()
    };
    let sols: Vec<Vec<f64>> = cases
        .par_iter()
        .map_init(
            || NewtonWorkspace::new(model, sym.clone()),
            |ws, &(a, b)| {
                let mut u = model.zero_vector();
                let rep = newton::solve(
                    model,
                    &design,
                    &stage.pea_load(a, b),
                    &mut u,
                    &pcg_params,
                    ws,
                    Some(&f0),
                )
                .unwrap();
                assert_eq!(rep.factorizations, 0);
                u
            },
        )
        .collect();
    let mut ws = NewtonWorkspace::new(model, sym.clone());
    for (&(a, b), up) in cases.iter().zip(&sols) {
        let mut u = model.zero_vector();
        newton::solve(
            model,
            &design,
            &stage.pea_load(a, b),
            &mut u,
            &NewtonParams::default(),
            &mut ws,
            None,
        )
        .unwrap();
        let err = u
            .iter()
            .zip(up)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        let sc = u.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(err < 1e-7 * sc, "PCG-Newton differs: {err:e} / {sc:e}");
    }
}

#[test]
fn typed_errors() {
    let p = NewtonParams {
        residual_tol: 2.0,
        ..Default::default()
    };
    match p.validate() {
        Err(ParamError::OutOfRange { field, range, .. }) => {
            assert_eq!(field, "NewtonParams::residual_tol");
            assert_eq!(range, "(0, 1)");
        }
        other => panic!("{other:?}"),
    }
    let msg = NewtonParams {
        increments: 0,
        ..Default::default()
    }
    .validate()
    .unwrap_err()
    .to_string();
    assert!(
        msg.contains("increments") && msg.contains("[1, 10000]"),
        "{msg}"
    );

    // Non-convergence: a strongly nonlinear load with one iteration and no cutbacks.
    let c = samples::Cantilever::new(
        Material {
            e0: 1e7,
            e_min: 1e-6,
            nu: 0.0,
            penalty: 3.0,
        },
        Kinematics::TotalLagrangian,
        1.0,
        0.05,
        0.05,
        40,
        2,
    )
    .unwrap();
    let rho = vec![1.0; c.model.mesh().n_elements()];
    let sym = SymbolicFactor::new(c.model.pattern().clone()).unwrap();
    let mut ws = NewtonWorkspace::new(&c.model, sym);
    let mut u = c.model.zero_vector();
    let ei = 1e7 * c.inertia();
    let params = NewtonParams {
        max_iterations: 2,
        max_cutbacks: 0,
        ..Default::default()
    };
    let err = newton::solve(
        &c.model,
        &Design::new(&rho),
        &c.tip_load(0.0, -5.0 * ei),
        &mut u,
        &params,
        &mut ws,
        None,
    )
    .unwrap_err();
    assert!(matches!(err, NewtonError::NotConverged { .. }), "{err}");
    assert_eq!(err.history().len(), 2);
    // The same load converges with increments and cutbacks allowed.
    let mut u = c.model.zero_vector();
    let params = NewtonParams {
        increments: 2,
        max_iterations: 12,
        max_cutbacks: 10,
        ..Default::default()
    };
    let rep = newton::solve(
        &c.model,
        &Design::new(&rho),
        &c.tip_load(0.0, -5.0 * ei),
        &mut u,
        &params,
        &mut ws,
        None,
    )
    .unwrap();
    assert!(rep.relative_residual < 1e-9);
    // Non-finite input.
    let mut u = c.model.zero_vector();
    u[5] = f64::NAN;
    let err = newton::solve(
        &c.model,
        &Design::new(&rho),
        &c.tip_load(0.0, -1.0),
        &mut u,
        &NewtonParams::default(),
        &mut ws,
        None,
    )
    .unwrap_err();
    assert!(
        matches!(
            err,
            NewtonError::Params(ParamError::NonFinite { what: "u", .. })
        ),
        "{err}"
    );
    // Density out of range.
    let bad = vec![1.5; c.model.mesh().n_elements()];
    let mut u = c.model.zero_vector();
    let err = newton::solve(
        &c.model,
        &Design::new(&bad),
        &c.tip_load(0.0, -1.0),
        &mut u,
        &NewtonParams::default(),
        &mut ws,
        None,
    )
    .unwrap_err();
    assert!(err.to_string().contains("Design::rho"), "{err}");
}

/// Multi-column solves and block PCG (per-column matrices, one shared preconditioner) agree
/// with single solves and single-column PCG.
#[test]
fn block_solves_and_block_pcg_match_single_columns() {
    let (stage, k1, rho) = stage_matrix(3);
    let model = &stage.model;
    let sym = SymbolicFactor::new(model.pattern().clone()).unwrap();
    let mut f1 = Factor::new(sym.clone());
    f1.factorize(&k1).unwrap();
    let n = k1.n();
    let k = 5;
    let b: Vec<f64> = (0..k)
        .flat_map(|s| samples::random_vector(n, -1.0, 1.0, 300 + s as u64))
        .collect();
    // Multi-column direct solve = single solves.
    let mut xb = b.clone();
    let mut sws = SolveWorkspace::with_columns(&sym, k);
    f1.solve_columns_in_place(&mut xb, k, &mut sws).unwrap();
    let mut s1 = SolveWorkspace::new(&sym);
    for j in 0..k {
        let mut x = b[j * n..(j + 1) * n].to_vec();
        f1.solve_in_place(&mut x, &mut s1).unwrap();
        let d = x
            .iter()
            .zip(&xb[j * n..(j + 1) * n])
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f64::max);
        let s = x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        assert!(d <= 1e-12 * s, "column {j}: {d:e}");
    }
    // Block PCG: columns alternate between two matrices.
    let rho2: Vec<f64> = rho.iter().map(|r| (r * 1.1).min(1.0)).collect();
    let mut k2 = model.new_matrix();
    model.assemble(
        &Design::new(&rho2),
        &model.zero_vector(),
        None,
        Some(&mut k2),
        &mut model.new_workspace(),
    );
    let mats: Vec<&SparseMatrix> = (0..k).map(|j| if j % 2 == 0 { &k2 } else { &k1 }).collect();
    let params = PcgParams {
        rel_tol: 1e-10,
        max_iter: 200,
    };
    let mut x = vec![0.0; n * k];
    let mut ws = BlockPcgWorkspace::new(n, k);
    let mut outcome = vec![ColumnOutcome::Running; k];
    let its = pcg_block(
        &mats,
        &f1,
        &b,
        &mut x,
        params,
        &mut ws,
        &mut sws,
        &mut outcome,
    )
    .unwrap();
    assert!(its > 0);
    let mut y = vec![0.0; n];
    for j in 0..k {
        assert!(
            matches!(outcome[j], ColumnOutcome::Converged(_)),
            "{:?}",
            outcome[j]
        );
        if j % 2 == 1 {
            // Exact preconditioner: one iteration.
            assert_eq!(outcome[j], ColumnOutcome::Converged(1));
        }
        mats[j].matvec(&x[j * n..(j + 1) * n], &mut y);
        let bj = &b[j * n..(j + 1) * n];
        let r = y
            .iter()
            .zip(bj)
            .map(|(p, q)| (p - q).powi(2))
            .sum::<f64>()
            .sqrt();
        let bn = bj.iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!(r <= 1e-9 * bn, "column {j}: residual {:e}", r / bn);
    }

    // Multi-column mat-vec (one sweep over the matrix for up to 4 columns, interleaved) =
    // single mat-vecs bit for bit (same summation order per column), for every block width
    // including the split of 5 into 4 + 1.
    let mut scratch = Vec::new();
    for w in 1..=k {
        let mut yb = vec![0.0; n * w];
        k2.matvec_columns(&b[..n * w], &mut yb, w, &mut scratch);
        for j in 0..w {
            k2.matvec(&b[j * n..(j + 1) * n], &mut y);
            assert!(
                yb[j * n..(j + 1) * n]
                    .iter()
                    .zip(&y)
                    .all(|(p, q)| p.to_bits() == q.to_bits()),
                "width {w}, column {j}: not bitwise the single mat-vec"
            );
        }
    }

    // Warm starts: runs of columns sharing a matrix (one sweep per run); initial guesses that
    // are multiples of the solutions (−1, 2, 0.5, 0, 3) are rescaled by xᵀb/xᵀAx to the exact
    // solution, so every column converges without an iteration — except the zero guess,
    // which must behave as a cold start.
    let mats: Vec<&SparseMatrix> = vec![&k2, &k2, &k2, &k1, &k1];
    let mut x = vec![0.0; n * k];
    let mut outcome = vec![ColumnOutcome::Running; k];
    pcg_block(
        &mats,
        &f1,
        &b,
        &mut x,
        params,
        &mut ws,
        &mut sws,
        &mut outcome,
    )
    .unwrap();
    let solved = x.clone();
    let factors = [-1.0, 2.0, 0.5, 0.0, 3.0];
    for (j, f) in factors.iter().enumerate() {
        for v in &mut x[j * n..(j + 1) * n] {
            *v *= f;
        }
    }
    pcg_block(
        &mats,
        &f1,
        &b,
        &mut x,
        params,
        &mut ws,
        &mut sws,
        &mut outcome,
    )
    .unwrap();
    for j in 0..k {
        if factors[j] == 0.0 {
            // k1 is the preconditioner: one iteration from zero.
            assert_eq!(outcome[j], ColumnOutcome::Converged(1), "column {j}");
        } else {
            assert_eq!(outcome[j], ColumnOutcome::Converged(0), "column {j}");
        }
        let d = x[j * n..(j + 1) * n]
            .iter()
            .zip(&solved[j * n..(j + 1) * n])
            .fold(0.0f64, |a, (p, q)| a.max((p - q).abs()));
        let s = solved[j * n..(j + 1) * n]
            .iter()
            .fold(0.0f64, |a, v| a.max(v.abs()));
        assert!(d <= 1e-8 * s, "column {j}: {d:e}");
    }
}

/// Reference: A. George, "Nested dissection of a regular finite element mesh", SIAM J. Numer.
/// Anal. 10 (1973): the factor of a k×k grid has O(k² log k) entries, fewer than minimum-degree
/// orderings give. Goal: the mesh's nested-dissection order is a permutation of the free DOFs,
/// its factor solves K x = b, and on the 240×120 grid it has less fill than AMD.
#[test]
fn nested_dissection_ordering_reduces_fill() {
    let stage = samples::Stage::paper(240, 120, Kinematics::TotalLagrangian).unwrap();
    let model = &stage.model;
    let order = model.mesh().nested_dissection();
    let mut seen = vec![false; model.mesh().n_nodes()];
    for &n in &order {
        assert!(!seen[n], "node {n} twice");
        seen[n] = true;
    }
    assert!(seen.iter().all(|s| *s), "every node ordered");
    let nd = SymbolicFactor::for_model(model).unwrap();
    let amd = SymbolicFactor::new(model.pattern().clone()).unwrap();
    assert!(
        (nd.factor_nnz() as f64) < 0.9 * amd.factor_nnz() as f64,
        "nested dissection {} vs AMD {}",
        nd.factor_nnz(),
        amd.factor_nnz()
    );
    // The factor with the custom order solves the system.
    let rho = stage.random_density(0.01, 1.0, 7, 1e-3);
    let mut k = model.new_matrix();
    model.assemble(
        &Design::new(&rho),
        &model.zero_vector(),
        None,
        Some(&mut k),
        &mut model.new_workspace(),
    );
    let mut f = Factor::new(nd.clone());
    f.factorize(&k).unwrap();
    let b = samples::random_vector(k.n(), -1.0, 1.0, 11);
    let mut x = b.clone();
    f.solve_in_place(&mut x, &mut SolveWorkspace::new(&nd))
        .unwrap();
    let mut y = vec![0.0; k.n()];
    k.matvec(&x, &mut y);
    let r = y
        .iter()
        .zip(&b)
        .map(|(p, q)| (p - q).powi(2))
        .sum::<f64>()
        .sqrt();
    let bn = b.iter().map(|v| v * v).sum::<f64>().sqrt();
    assert!(r <= 1e-8 * bn, "relative residual {:e}", r / bn);
    // A bad order is a typed error, not a panic.
    let err = SymbolicFactor::with_order(model.pattern().clone(), vec![0; k.n()]).unwrap_err();
    assert!(err.to_string().contains("permutation"), "{err}");
}
