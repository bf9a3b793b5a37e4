// Reference: the published optima of Svanberg's toy problem (2007 note) and five-segment
// cantilever (1987 paper), the analytic optimum of a separable box quadratic, and the
// primal–dual `subsolv` of this crate (a peer solver of the same subproblem).
// Goal: `Subsolver::Dual` (the dual interior-point method) reaches the same optima with a KKT
// residual below 1e-6 without falling back to `subsolv`, its iterates agree with those of
// `subsolv` to the subproblem tolerance, the serial and rayon paths agree bit for bit, a
// restored optimizer continues bitwise (the warm start comes from the saved multipliers),
// and a subproblem the dual cannot solve (c = d = 0) falls back to `subsolv`.

mod common;

use common::synthetic;
use flexstage_mma::{Mma, MmaParams, StopCriteria, Subsolver, UpdateReport, samples};

fn dual() -> MmaParams {
    MmaParams {
        subsolver: Subsolver::Dual,
        ..MmaParams::default()
    }
}

const STOP: StopCriteria = StopCriteria {
    max_iterations: 50,
    kkt_tolerance: 1e-6,
};

#[test]
fn toy_reaches_published_optimum() {
    let s = samples::toy();
    let sol = s.solve(dual(), STOP).unwrap();
    assert!(sol.converged, "KKT {:?} after {}", sol.kkt, sol.iterations);
    assert!(sol.iterations <= 20, "took {} iterations", sol.iterations);
    for (x, xs) in sol.x.iter().zip(&s.x_star) {
        assert!(
            (x - xs).abs() < 1e-3,
            "x = {:?}, expected {:?}",
            sol.x,
            s.x_star
        );
    }
    assert!((sol.f0 - s.f_star).abs() < 1e-3, "f0 = {}", sol.f0);
    assert!(sol.lambda.iter().all(|&l| l > 0.1), "λ = {:?}", sol.lambda);
}

#[test]
fn cantilever_reaches_paper_optimum() {
    let s = samples::cantilever();
    let sol = s.solve(dual(), STOP).unwrap();
    assert!(sol.converged, "KKT {:?} after {}", sol.kkt, sol.iterations);
    for (x, xs) in sol.x.iter().zip(&s.x_star) {
        assert!(
            (x - xs).abs() < 1e-3,
            "x = {:?}, expected {:?}",
            sol.x,
            s.x_star
        );
    }
    assert!((sol.f0 - s.f_star).abs() < 1e-5, "f0 = {}", sol.f0);
}

#[test]
fn box_quadratic_with_100k_variables() {
    let n = 100_000;
    let s = samples::box_quadratic(n);
    let params = MmaParams {
        subproblem_tolerance: 1e-10,
        raa0: 0.1,
        ..dual()
    };
    let sol = s
        .solve(
            params,
            StopCriteria {
                max_iterations: 40,
                kkt_tolerance: 1e-6,
            },
        )
        .unwrap();
    assert!(sol.converged, "KKT {:?} after {}", sol.kkt, sol.iterations);
    let err = sol
        .x
        .iter()
        .zip(&s.x_star)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    // x(λ) is the exact minimizer of the Lagrangian: bounds are met exactly, not ε inside.
    assert!(err < 1e-6, "max |x - x*| = {err}");
}

#[test]
fn agrees_with_primal_dual_subsolv() {
    // subsolv leaves a weakly active bound ε/ξ inside (ξ ~ |∂f/∂x| ~ 1/n here), the dual
    // method puts x on it; a tight tolerance makes the two comparable.
    let n = 20_000;
    let tight = |subsolver| MmaParams {
        subsolver,
        subproblem_tolerance: 1e-11,
        ..MmaParams::default()
    };
    let (xd, ld, rd) = synthetic(n, tight(Subsolver::Dual));
    let (xp, lp, rp) = synthetic(n, tight(Subsolver::PrimalDual));
    assert!(rd.iter().all(|r| r.subsolver == Subsolver::Dual), "{rd:?}");
    assert!(rp.iter().all(|r| r.subsolver == Subsolver::PrimalDual));
    // Update 2 is warm-started from λ ≈ c (update 1 is infeasible within its move limits)
    // while its own λ is small; once that settles, warm starts need few Newton steps.
    assert!(rd.iter().all(|r| r.subproblem_iterations <= 30), "{rd:?}");
    assert!(
        rd[2..].iter().all(|r| r.subproblem_iterations <= 4),
        "{rd:?}"
    );
    let dx = xd
        .iter()
        .zip(&xp)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(dx < 1e-7, "max |x_dual - x_subsolv| = {dx}");
    for (a, b) in ld.iter().zip(&lp) {
        assert!(
            (a - b).abs() <= 1e-7 * b.abs().max(1.0),
            "λ {ld:?} vs {lp:?}"
        );
    }
    assert!(ld.iter().any(|&l| l > 1e-3), "no active constraint: {ld:?}");
}

#[test]
fn parallel_and_serial_paths_agree_bitwise() {
    let run = |parallel_threshold| {
        synthetic(
            20_000,
            MmaParams {
                parallel_threshold,
                ..dual()
            },
        )
    };
    let (s, p) = (run(usize::MAX), run(0));
    assert!(s.0 == p.0, "iterates differ");
    assert_eq!(s.1, p.1);
    let its = |r: &[UpdateReport]| {
        r.iter()
            .map(|r| r.subproblem_iterations)
            .collect::<Vec<_>>()
    };
    assert_eq!(its(&s.2), its(&p.2));
}

#[test]
fn restored_optimizer_continues_bitwise() {
    let s = samples::toy();
    let p = s.problem.as_ref();
    let new = || Mma::new(3, 2, s.xmin.clone(), s.xmax.clone(), dual()).unwrap();
    let step = |mma: &mut Mma, x: &mut Vec<f64>| {
        let (mut g, mut f, mut dfdx) = (vec![0.0; 3], vec![0.0; 2], vec![0.0; 6]);
        let f0 = p.evaluate(x, &mut g, &mut f, &mut dfdx);
        mma.update(x, f0, &g, &f, &dfdx).unwrap()
    };
    let mut a = new();
    let mut xa = s.x0.clone();
    for _ in 0..3 {
        step(&mut a, &mut xa);
    }
    let saved = (a.state(), xa.clone());
    for _ in 0..4 {
        assert_eq!(step(&mut a, &mut xa).subsolver, Subsolver::Dual);
    }
    let mut b = new();
    b.restore(&saved.0).unwrap();
    let mut xb = saved.1;
    for _ in 0..4 {
        step(&mut b, &mut xb);
    }
    assert_eq!(xa, xb);
    assert_eq!(a.state(), b.state());
}

#[test]
fn falls_back_to_subsolv_when_the_dual_has_no_interior() {
    // c = d = 0 pins λ to 0 in the dual: no interior point exists.
    let s = samples::toy();
    let params = MmaParams {
        c: 0.0,
        d: 0.0,
        ..dual()
    };
    let p = s.problem.as_ref();
    let mut mma = Mma::new(3, 2, s.xmin.clone(), s.xmax.clone(), params).unwrap();
    let mut x = s.x0.clone();
    let (mut g, mut f, mut dfdx) = (vec![0.0; 3], vec![0.0; 2], vec![0.0; 6]);
    let f0 = p.evaluate(&x, &mut g, &mut f, &mut dfdx);
    let rep = mma.update(&mut x, f0, &g, &f, &dfdx).unwrap();
    assert_eq!(rep.subsolver, Subsolver::PrimalDual);
    assert!(x.iter().all(|v| (0.0..=5.0).contains(v)));
}

#[test]
fn artificial_variable_z_and_linear_y_costs() {
    // a > 0 adds the dual constraint aᵀλ ≤ a₀, d = 0 the caps λ ≤ c: the toy optimum is
    // unchanged (its multipliers are far below both bounds).
    let s = samples::toy();
    let params = MmaParams {
        a: 1e-3,
        d: 0.0,
        ..dual()
    };
    let sol = s.solve(params, STOP).unwrap();
    assert!(sol.converged, "KKT {:?} after {}", sol.kkt, sol.iterations);
    assert!((sol.f0 - s.f_star).abs() < 1e-3, "f0 = {}", sol.f0);
}
