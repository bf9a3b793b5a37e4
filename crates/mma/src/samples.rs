//! Test problems with known solutions.
//!
//! Each function returns a [`Sample`]: the problem (a [`Problem`]), the starting point, the
//! bounds and the known optimum `x*`, `f*`.

use crate::error::MmaError;
use crate::params::MmaParams;
use crate::solve::{Problem, Solution, StopCriteria, minimize};

/// A test problem together with its known answer.
pub struct Sample {
    /// Short name.
    pub name: &'static str,
    /// Where the problem and its answer come from.
    pub reference: &'static str,
    /// The problem.
    pub problem: Box<dyn Problem + Send + Sync>,
    /// Starting point.
    pub x0: Vec<f64>,
    /// Lower bounds.
    pub xmin: Vec<f64>,
    /// Upper bounds.
    pub xmax: Vec<f64>,
    /// Known minimiser.
    pub x_star: Vec<f64>,
    /// Known minimum.
    pub f_star: f64,
}

impl Sample {
    /// Runs [`minimize`] on this sample from `x0`.
    ///
    /// # Errors
    /// As [`minimize`].
    pub fn solve(&self, params: MmaParams, stop: StopCriteria) -> Result<Solution, MmaError> {
        minimize(
            self.problem.as_ref(),
            &self.x0,
            self.xmin.clone(),
            self.xmax.clone(),
            params,
            stop,
        )
    }
}

impl std::fmt::Debug for Sample {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Sample")
            .field("name", &self.name)
            .field("n", &self.problem.n())
            .field("m", &self.problem.m())
            .field("f_star", &self.f_star)
            .finish()
    }
}

/// Svanberg's toy problem (`toy2` of the MMA distribution, the example of the 2007 note):
///
/// ```text
/// min  x₁² + x₂² + x₃²
/// s.t. (x₁−5)² + (x₂−2)² + (x₃−1)² ≤ 9,   (x₁−3)² + (x₂−4)² + (x₃−3)² ≤ 9,   0 ≤ x ≤ 5
/// ```
///
/// from x₀ = (4, 3, 2). Both constraints are active at x* ≈ (2.0175, 1.7800, 1.2375),
/// f* ≈ 8.7702 (the published four-digit values).
pub fn toy() -> Sample {
    struct Toy;
    impl Problem for Toy {
        fn n(&self) -> usize {
            3
        }
        fn m(&self) -> usize {
            2
        }
        fn evaluate(&self, x: &[f64], df0dx: &mut [f64], f: &mut [f64], dfdx: &mut [f64]) -> f64 {
            let c1 = [5.0, 2.0, 1.0];
            let c2 = [3.0, 4.0, 3.0];
            f[0] = -9.0;
            f[1] = -9.0;
            let mut f0 = 0.0;
            for j in 0..3 {
                f0 += x[j] * x[j];
                df0dx[j] = 2.0 * x[j];
                f[0] += (x[j] - c1[j]).powi(2);
                f[1] += (x[j] - c2[j]).powi(2);
                dfdx[j] = 2.0 * (x[j] - c1[j]);
                dfdx[3 + j] = 2.0 * (x[j] - c2[j]);
            }
            f0
        }
    }
    Sample {
        name: "toy",
        reference: "K. Svanberg, MMA and GCMMA - two methods for nonlinear optimization (2007), toy problem",
        problem: Box::new(Toy),
        x0: vec![4.0, 3.0, 2.0],
        xmin: vec![0.0; 3],
        xmax: vec![5.0; 3],
        x_star: vec![2.0175, 1.7800, 1.2375],
        f_star: 8.7702,
    }
}

/// Coefficients of the five-segment cantilever of Svanberg (1987).
pub const CANTILEVER_COEFFS: [f64; 5] = [61.0, 37.0, 19.0, 7.0, 1.0];
/// Weight per unit cross-section size of the cantilever.
pub const CANTILEVER_WEIGHT: f64 = 0.0624;

/// The five-segment cantilever beam of Svanberg (1987), section 6:
///
/// ```text
/// min  0.0624 Σⱼ xⱼ   s.t.  61/x₁³ + 37/x₂³ + 19/x₃³ + 7/x₄³ + 1/x₅³ − 1 ≤ 0,   1 ≤ x ≤ 10
/// ```
///
/// from x₀ = (5, …, 5). Stationarity gives `xⱼ = S^{1/3} cⱼ^{1/4}` with
/// `S = Σ cⱼ^{1/4}`, so x* ≈ (6.016, 5.309, 4.494, 3.502, 2.153) and
/// f* = 0.0624 S^{4/3} ≈ 1.33996; these exact values are returned.
pub fn cantilever() -> Sample {
    struct Cantilever;
    impl Problem for Cantilever {
        fn n(&self) -> usize {
            5
        }
        fn m(&self) -> usize {
            1
        }
        fn evaluate(&self, x: &[f64], df0dx: &mut [f64], f: &mut [f64], dfdx: &mut [f64]) -> f64 {
            f[0] = -1.0;
            let mut f0 = 0.0;
            for j in 0..5 {
                f0 += CANTILEVER_WEIGHT * x[j];
                df0dx[j] = CANTILEVER_WEIGHT;
                f[0] += CANTILEVER_COEFFS[j] / x[j].powi(3);
                dfdx[j] = -3.0 * CANTILEVER_COEFFS[j] / x[j].powi(4);
            }
            f0
        }
    }
    let s: f64 = CANTILEVER_COEFFS.iter().map(|c| c.powf(0.25)).sum();
    let x_star: Vec<f64> = CANTILEVER_COEFFS
        .iter()
        .map(|c| s.cbrt() * c.powf(0.25))
        .collect();
    Sample {
        name: "cantilever",
        reference: "K. Svanberg, The method of moving asymptotes, IJNME 24 (1987) 359-373, section 6",
        problem: Box::new(Cantilever),
        x0: vec![5.0; 5],
        xmin: vec![1.0; 5],
        xmax: vec![10.0; 5],
        f_star: CANTILEVER_WEIGHT * s.powf(4.0 / 3.0),
        x_star,
    }
}

/// A separable quadratic `½ Σ hⱼ (xⱼ − tⱼ)²` with an optional linear constraint
/// `Σ aⱼ xⱼ − rhs ≤ 0`.
#[derive(Debug, Clone)]
pub struct SeparableQuadratic {
    /// Curvatures hⱼ > 0.
    pub h: Vec<f64>,
    /// Targets tⱼ.
    pub t: Vec<f64>,
    /// Constraint coefficients and right-hand side, or `None` for m = 0.
    pub linear: Option<(Vec<f64>, f64)>,
}

impl Problem for SeparableQuadratic {
    fn n(&self) -> usize {
        self.h.len()
    }
    fn m(&self) -> usize {
        usize::from(self.linear.is_some())
    }
    fn evaluate(&self, x: &[f64], df0dx: &mut [f64], f: &mut [f64], dfdx: &mut [f64]) -> f64 {
        let mut f0 = 0.0;
        for j in 0..x.len() {
            let d = x[j] - self.t[j];
            f0 += 0.5 * self.h[j] * d * d;
            df0dx[j] = self.h[j] * d;
        }
        if let Some((a, rhs)) = &self.linear {
            f[0] = a.iter().zip(x).map(|(a, x)| a * x).sum::<f64>() - rhs;
            dfdx.copy_from_slice(a);
        }
        f0
    }
}

impl SeparableQuadratic {
    /// Objective value at `x`.
    pub fn objective(&self, x: &[f64]) -> f64 {
        x.iter()
            .zip(&self.t)
            .zip(&self.h)
            .map(|((x, t), h)| 0.5 * h * (x - t) * (x - t))
            .sum()
    }

    /// The exact minimiser over the box `[xmin, xmax]`: `xⱼ(λ) = clamp(tⱼ − λ aⱼ / hⱼ)`, with
    /// λ = 0 if that point is feasible and otherwise the root of `Σ aⱼ xⱼ(λ) = rhs` (a
    /// non-increasing function of λ) found by bisection. Returns `(x*, λ*)`.
    ///
    /// # Panics
    /// If the constraint cannot be satisfied inside the box.
    pub fn analytic_optimum(&self, xmin: &[f64], xmax: &[f64]) -> (Vec<f64>, f64) {
        let x_of = |lam: f64| -> Vec<f64> {
            (0..self.h.len())
                .map(|j| {
                    let a = self.linear.as_ref().map_or(0.0, |(a, _)| a[j]);
                    (self.t[j] - lam * a / self.h[j]).clamp(xmin[j], xmax[j])
                })
                .collect()
        };
        let Some((a, rhs)) = &self.linear else {
            return (x_of(0.0), 0.0);
        };
        let g =
            |lam: f64| -> f64 { x_of(lam).iter().zip(a).map(|(x, a)| x * a).sum::<f64>() - rhs };
        if g(0.0) <= 0.0 {
            return (x_of(0.0), 0.0);
        }
        let mut hi = 1.0;
        while g(hi) > 0.0 {
            hi *= 2.0;
            assert!(hi < 1e300, "linear constraint infeasible in the box");
        }
        let mut lo = 0.0;
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if g(mid) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        (x_of(hi), hi)
    }
}

/// Builds a [`Sample`] from a [`SeparableQuadratic`], computing x* and f* with
/// [`SeparableQuadratic::analytic_optimum`].
pub fn separable_quadratic(
    q: SeparableQuadratic,
    x0: Vec<f64>,
    xmin: Vec<f64>,
    xmax: Vec<f64>,
) -> Sample {
    let (x_star, _) = q.analytic_optimum(&xmin, &xmax);
    let f_star = q.objective(&x_star);
    Sample {
        name: "separable quadratic",
        reference: "analytic: clamp(t - lambda a / h) with lambda from a 1-D dual bisection",
        problem: Box::new(q),
        x0,
        xmin,
        xmax,
        x_star,
        f_star,
    }
}

/// A deterministic unconstrained (m = 0) box-bounded quadratic in `n` variables:
/// `½ Σ hⱼ (xⱼ − tⱼ)²` over `0 ≤ x ≤ 1`, with hⱼ ∈ [1, 3) and tⱼ ∈ [−0.5, 1.5) from a
/// fixed pseudo-random sequence, so about half of the components of x* = clamp(t, 0, 1) are
/// at a bound. Starts from x₀ = 0.5.
pub fn box_quadratic(n: usize) -> Sample {
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let mut next = move || {
        // xorshift64*
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        (state.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    };
    let h: Vec<f64> = (0..n).map(|_| 1.0 + 2.0 * next()).collect();
    let t: Vec<f64> = (0..n).map(|_| -0.5 + 2.0 * next()).collect();
    let mut s = separable_quadratic(
        SeparableQuadratic { h, t, linear: None },
        vec![0.5; n],
        vec![0.0; n],
        vec![1.0; n],
    );
    s.name = "box quadratic";
    s
}

/// A problem with more constraints than variables (n = 2, m = 3), which exercises the
/// (n+1)×(n+1) Newton system of `subsolv`:
///
/// ```text
/// min (x₁−2)² + (x₂−2)²   s.t.  x₁ + x₂ ≤ 2,  x₁ ≤ 1.5,  x₂ ≤ 1.5,   0 ≤ x ≤ 3
/// ```
///
/// from x₀ = (0.5, 0.5); x* = (1, 1), f* = 2, only the first constraint active.
pub fn few_variables() -> Sample {
    struct Few;
    impl Problem for Few {
        fn n(&self) -> usize {
            2
        }
        fn m(&self) -> usize {
            3
        }
        fn evaluate(&self, x: &[f64], df0dx: &mut [f64], f: &mut [f64], dfdx: &mut [f64]) -> f64 {
            df0dx[0] = 2.0 * (x[0] - 2.0);
            df0dx[1] = 2.0 * (x[1] - 2.0);
            f[0] = x[0] + x[1] - 2.0;
            f[1] = x[0] - 1.5;
            f[2] = x[1] - 1.5;
            dfdx.copy_from_slice(&[1.0, 1.0, 1.0, 0.0, 0.0, 1.0]);
            (x[0] - 2.0).powi(2) + (x[1] - 2.0).powi(2)
        }
    }
    Sample {
        name: "few variables",
        reference: "constructed; x* by inspection (projection of (2, 2) on x1 + x2 = 2)",
        problem: Box::new(Few),
        x0: vec![0.5, 0.5],
        xmin: vec![0.0; 2],
        xmax: vec![3.0; 2],
        x_star: vec![1.0, 1.0],
        f_star: 2.0,
    }
}
