//! The design's geometric nonlinearity as a smooth correction of the twin's output.
//!
//! Over a `p × p` grid of nominal strokes `x_nom ∈ [−A, A]²` the assembled stage is solved
//! twice: with the nonlinear Total Lagrangian model (Newton, `flexstage_fem::newton`) and with
//! its linearization at u = 0 (one Cholesky factor). The difference of the output
//! displacements, `d(x_nom) = q_TL − q_lin`, is the nonlinear effect the linear twin misses
//! (≈ 0.2–0.4 % of the stroke for the default designs; `flexstage reduce` reports the same
//! number as its validity map). It is fitted by least squares as a polynomial of degree 2 and 3
//! in the linear input-plate displacements `ξ = x_in,lin / s` (the quantities the twin's state
//! carries; `s` the largest |x_in| of the grid):
//!
//! ```text
//! d_j(ξ) = c_j1 ξ1² + c_j2 ξ1ξ2 + c_j3 ξ2² + c_j4 ξ1³ + c_j5 ξ1²ξ2 + c_j6 ξ1ξ2² + c_j7 ξ2³
//! ```
//!
//! (no constant or linear term: the linearization is exact to first order). The twin adds
//! `d(x_in(t))` to its output: a quasi-static kinematic correction, valid because the
//! nonlinearity is weak (strains ≈ 1e-3) and the stroke varies far below the first resonance;
//! the stiffening it implies shifts the natural frequencies by far less than the modal
//! tolerance (checked in the tests against the tangent at the stroke corner).

use flexstage_fem::{Factor, NewtonParams, NewtonWorkspace, SymbolicFactor, newton};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use serde::Serialize;

use crate::error::{Result, TwinError, check};
use crate::structure::StageFe;

/// Number of polynomial terms.
pub const TERMS: usize = 7;

/// One grid point of the fit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StaticSample {
    /// Nominal strokes [m].
    pub x_nom: [f64; 2],
    /// Linear input-plate displacements [m].
    pub x_in: [f64; 2],
    /// Linear output [m].
    pub q_linear: [f64; 2],
    /// Nonlinear (Total Lagrangian) output [m].
    pub q_nonlinear: [f64; 2],
}

/// The fitted correction (module docs).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NonlinearMap {
    /// Scale s of the regressors [m].
    pub scale: f64,
    /// Coefficients of q1 and q2 [m].
    pub coefficients: [[f64; TERMS]; 2],
    /// The grid.
    pub samples: Vec<StaticSample>,
    /// Largest |q_TL − q_lin| over the grid, per axis [m].
    pub max_effect: [f64; 2],
    /// Largest |fit − (q_TL − q_lin)| over the grid, per axis [m].
    pub max_residual: [f64; 2],
}

#[inline]
fn terms(x: [f64; 2]) -> [f64; TERMS] {
    let [a, b] = x;
    [
        a * a,
        a * b,
        b * b,
        a * a * a,
        a * a * b,
        a * b * b,
        b * b * b,
    ]
}

impl NonlinearMap {
    /// The correction `d(x_in)` [m] to add to the linear output. No allocation.
    #[inline]
    pub fn correction(&self, x_in: [f64; 2]) -> [f64; 2] {
        let t = terms([x_in[0] / self.scale, x_in[1] / self.scale]);
        let mut d = [0.0; 2];
        for j in 0..2 {
            for k in 0..TERMS {
                d[j] += self.coefficients[j][k] * t[k];
            }
        }
        d
    }
}

/// The linear and nonlinear static responses of `fe` to the PEA strokes `x_nom`.
pub fn static_responses(fe: &StageFe, x_nom: &[[f64; 2]]) -> Result<Vec<StaticSample>> {
    let model = &fe.model;
    let dofs = model.dofs();
    let sym = SymbolicFactor::for_model(model)?;
    let mut factor = Factor::new(sym.clone());
    factor.allow_indefinite = false;
    factor.factorize(&fe.stiffness())?;
    let [i1, i2, ox, oy] = fe.interface;
    let np = NewtonParams {
        increments: 2,
        residual_tol: 1e-11,
        displacement_tol: 1e-10,
        ..NewtonParams::default()
    };
    x_nom
        .par_iter()
        .map_init(
            || {
                (
                    NewtonWorkspace::new(model, sym.clone()),
                    factor.new_solve_workspace(),
                    vec![0.0; dofs.n_free()],
                )
            },
            |(ws, sws, tmp), &x| {
                let p = fe.pea_load(x);
                let mut lin = model.zero_vector();
                factor.solve_full(dofs, &p, &mut lin, tmp, sws)?;
                let mut u = lin.clone();
                newton::solve(model, &fe.design(), &p, &mut u, &np, ws, None).map_err(
                    |source| TwinError::Newton {
                        x1: x[0],
                        x2: x[1],
                        source,
                    },
                )?;
                Ok(StaticSample {
                    x_nom: x,
                    x_in: [lin[i1], lin[i2]],
                    q_linear: [lin[ox], lin[oy]],
                    q_nonlinear: [u[ox], u[oy]],
                })
            },
        )
        .collect()
}

/// Fits the correction on a `points × points` grid over `[−amplitude, amplitude]²`.
pub fn fit(fe: &StageFe, amplitude: f64, points: usize) -> Result<NonlinearMap> {
    check(
        "nonlinear fit amplitude",
        amplitude,
        amplitude > 0.0 && amplitude <= 1e-3,
        "(0, 1e-3] m",
    )?;
    check(
        "twin.fit_points",
        points as f64,
        (3..=15).contains(&points),
        "an integer in [3, 15]",
    )?;
    let grid: Vec<[f64; 2]> = (0..points * points)
        .map(|k| {
            let s = |i: usize| amplitude * (2.0 * i as f64 / (points - 1) as f64 - 1.0);
            [s(k / points), s(k % points)]
        })
        .filter(|x| x != &[0.0, 0.0])
        .collect();
    let samples = static_responses(fe, &grid)?;
    let scale = samples
        .iter()
        .flat_map(|s| s.x_in)
        .fold(0.0f64, |a, x| a.max(x.abs()));
    check(
        "nonlinear fit scale",
        scale,
        scale > 0.0,
        "> 0 m (the inputs move)",
    )?;
    let a = DMatrix::from_fn(samples.len(), TERMS, |r, c| {
        terms([samples[r].x_in[0] / scale, samples[r].x_in[1] / scale])[c]
    });
    let svd = a.clone().svd(true, true);
    let mut coefficients = [[0.0; TERMS]; 2];
    let mut max_effect = [0.0f64; 2];
    let mut max_residual = [0.0f64; 2];
    for j in 0..2 {
        let b = DVector::from_fn(samples.len(), |r, _| {
            samples[r].q_nonlinear[j] - samples[r].q_linear[j]
        });
        let c = svd
            .solve(&b, 1e-12)
            .map_err(|e| TwinError::Reduced(format!("nonlinear fit: {e}")))?;
        let fitted = &a * &c;
        for r in 0..samples.len() {
            max_effect[j] = max_effect[j].max(b[r].abs());
            max_residual[j] = max_residual[j].max((fitted[r] - b[r]).abs());
        }
        for k in 0..TERMS {
            coefficients[j][k] = c[k];
        }
    }
    Ok(NonlinearMap {
        scale,
        coefficients,
        samples,
        max_effect,
        max_residual,
    })
}
