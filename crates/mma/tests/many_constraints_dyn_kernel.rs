// Reference: analytic (projection). min Σ ½ (xⱼ − tⱼ)² over [0, 1]ⁿ subject to six group
// constraints Σ_{j ≡ g (mod 6)} xⱼ ≤ V_g has the solution xⱼ = clamp(tⱼ − λ_g, 0, 1) with
// λ_g ≥ 0 the root of Σ clamp(tⱼ − λ_g, 0, 1) = V_g (or 0 if the group is inactive),
// found here by bisection.
// Goal: the subproblem kernels for m > 4 (m not a compile-time constant) converge to that
// solution, with n = 3001 (two full chunks and a last chunk ending in a partial SIMD block),
// and the serial and rayon paths agree bitwise.

use flexstage_mma::{MmaParams, Problem, StopCriteria, minimize};

const M: usize = 6;

struct Groups {
    t: Vec<f64>,
    v: [f64; M],
}

impl Problem for Groups {
    fn n(&self) -> usize {
        self.t.len()
    }
    fn m(&self) -> usize {
        M
    }
    fn evaluate(&self, x: &[f64], df0dx: &mut [f64], f: &mut [f64], dfdx: &mut [f64]) -> f64 {
        let n = x.len();
        f.iter_mut().zip(&self.v).for_each(|(f, v)| *f = -v);
        dfdx.fill(0.0);
        let mut f0 = 0.0;
        for j in 0..n {
            let r = x[j] - self.t[j];
            f0 += 0.5 * r * r;
            df0dx[j] = r;
            f[j % M] += x[j];
            dfdx[(j % M) * n + j] = 1.0;
        }
        f0
    }
}

fn problem(n: usize) -> Groups {
    let t = (0..n)
        .map(|j| -0.2 + 1.4 * ((j * 7919 + 13) % 1000) as f64 / 1000.0)
        .collect();
    let per = (n / M) as f64;
    // Groups 0..3 active (budget below the unconstrained sum), 4 and 5 inactive.
    Groups {
        t,
        v: [
            0.3 * per,
            0.35 * per,
            0.4 * per,
            0.45 * per,
            0.9 * per,
            1.0 * per,
        ],
    }
}

fn reference(p: &Groups) -> (Vec<f64>, [f64; M]) {
    let n = p.t.len();
    let sum = |g: usize, lam: f64| -> f64 {
        (g..n)
            .step_by(M)
            .map(|j| (p.t[j] - lam).clamp(0.0, 1.0))
            .sum()
    };
    let mut lams = [0.0; M];
    for (g, lam) in lams.iter_mut().enumerate() {
        if sum(g, 0.0) <= p.v[g] {
            continue;
        }
        let (mut lo, mut hi) = (0.0, 2.0);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if sum(g, mid) > p.v[g] {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        *lam = 0.5 * (lo + hi);
    }
    let x = (0..n)
        .map(|j| (p.t[j] - lams[j % M]).clamp(0.0, 1.0))
        .collect();
    (x, lams)
}

fn solve(p: &Groups, parallel_threshold: usize) -> flexstage_mma::Solution {
    let n = p.n();
    let params = MmaParams {
        raa0: 0.1,
        subproblem_tolerance: 1e-9,
        parallel_threshold,
        ..MmaParams::default()
    };
    let stop = StopCriteria {
        max_iterations: 60,
        kkt_tolerance: 1e-6,
    };
    minimize(p, &vec![0.5; n], vec![0.0; n], vec![1.0; n], params, stop).unwrap()
}

#[test]
fn six_constraints_converge_to_the_projection() {
    let p = problem(3001);
    let (x_star, lam_star) = reference(&p);
    let sol = solve(&p, usize::MAX);
    assert!(
        sol.converged,
        "KKT {:?} after {} iterations",
        sol.kkt, sol.iterations
    );
    let err = sol
        .x
        .iter()
        .zip(&x_star)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(err < 1e-4, "max |x - x*| = {err}");
    for g in 0..M {
        assert!(
            (sol.lambda[g] - lam_star[g]).abs() < 1e-4 * (1.0 + lam_star[g]),
            "lambda = {:?}, expected {lam_star:?}",
            sol.lambda
        );
    }
    assert!(lam_star[..4].iter().all(|&l| l > 1e-2), "{lam_star:?}");
    assert!(lam_star[4..].iter().all(|&l| l == 0.0), "{lam_star:?}");

    let par = solve(&p, 0);
    assert_eq!(sol.iterations, par.iterations);
    assert!(sol.x == par.x, "serial and parallel iterates differ");
    assert_eq!(sol.lambda, par.lambda);
}
