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
//! nonlinearity is weak (strains ≈ 1e-3) and the stroke varies far below the first resonance.
//!
//! # Stiffening of the operating point
//! The same geometric nonlinearity changes the tangent stiffness with the operating point:
//! at the stroke corners the first mode of the default designs shifts by ≈ ±0.2 %, which
//! over 20 ms of lightly damped ringing is a phase error of several per cent of the ringing.
//! To first order the modal stiffness is `ω_k² + s_k·x_in` with
//! `s_k = ∂(φ_kᵀ Tᵀ K_T(u(x_in)) T φ_k)/∂x_in` (first-order eigenvalue perturbation of the
//! reduced tangent, central differences of the tangent assembled at the linear static states
//! for x_nom = ±A e_j, converted from x_nom to x_in). The twin applies it to the motion about
//! the quasi-static state only, `η̈_k + 2ζ_kω_kη̇_k + ω_k²η_k + (s_k·x_in)(η_k − p_k/ω_k²) = p_k`,
//! so the statics stay those of the map above; the small term is evaluated at the start of
//! each substep.

use flexstage_fem::{Factor, NewtonParams, NewtonWorkspace, SymbolicFactor, newton};

use crate::craig_bampton::CraigBampton;
use crate::modal::ModalStage;
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
    /// Nominal strokes \[m\].
    pub x_nom: [f64; 2],
    /// Linear input-plate displacements \[m\].
    pub x_in: [f64; 2],
    /// Linear output \[m\].
    pub q_linear: [f64; 2],
    /// Nonlinear (Total Lagrangian) output \[m\].
    pub q_nonlinear: [f64; 2],
}

/// The fitted correction (module docs).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NonlinearMap {
    /// Scale s of the regressors \[m\].
    pub scale: f64,
    /// Coefficients of q1 and q2 \[m\].
    pub coefficients: [[f64; TERMS]; 2],
    /// The grid.
    pub samples: Vec<StaticSample>,
    /// Largest |q_TL − q_lin| over the grid, per axis \[m\].
    pub max_effect: [f64; 2],
    /// Largest |fit − (q_TL − q_lin)| over the grid, per axis \[m\].
    pub max_residual: [f64; 2],
    /// `∂(ω_k²)/∂x_in` per mode of the twin (modal order) [1/(s² m)] (module docs).
    pub stiffening: Vec<[f64; 2]>,
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
    /// The correction `d(x_in)` \[m\] to add to the linear output. No allocation.
    #[inline]
    pub fn correction(&self, x_in: [f64; 2]) -> [f64; 2] {
        self.evaluator().eval(x_in)
    }

    /// The polynomial alone, in a small copyable form for the real-time loop.
    pub fn evaluator(&self) -> Correction {
        Correction {
            inv_scale: 1.0 / self.scale,
            coefficients: self.coefficients,
        }
    }
}

/// The fitted polynomial `d(ξ)`, `ξ = x_in/s` (module docs), with `1/s` precomputed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Correction {
    /// 1/s \[1/m\].
    pub inv_scale: f64,
    /// Coefficients of q1 and q2 \[m\] in the order of the module docs.
    pub coefficients: [[f64; TERMS]; 2],
}

impl Correction {
    /// `d(x_in)` \[m\].
    #[inline]
    pub fn eval(&self, x_in: [f64; 2]) -> [f64; 2] {
        let t = terms([x_in[0] * self.inv_scale, x_in[1] * self.inv_scale]);
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
    let [_, _, ox, oy] = fe.interface;
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
                    x_in: fe.input_displacements(&lin),
                    q_linear: [lin[ox], lin[oy]],
                    q_nonlinear: [u[ox], u[oy]],
                })
            },
        )
        .collect()
}

/// `∂(ω_k²)/∂x_in` of every mode of `modal` (module docs), from the tangent at the linear
/// static states of x_nom = ±`amplitude` e_j.
pub fn stiffening(
    fe: &StageFe,
    cb: &CraigBampton,
    modal: &ModalStage,
    amplitude: f64,
) -> Result<Vec<[f64; 2]>> {
    let model = &fe.model;
    let dofs = model.dofs();
    let n = dofs.n_free();
    let sym = SymbolicFactor::for_model(model)?;
    let mut factor = Factor::new(sym.clone());
    factor.allow_indefinite = false;
    factor.factorize(&fe.stiffness())?;
    let mut sws = factor.new_solve_workspace();
    let r = cb.order();
    let mut kt = model.new_matrix();
    let mut aws = model.new_workspace();
    let mut tmp = vec![0.0; n];
    // Modal stiffness shifts and input displacements at x_nom = ±A e_j.
    let mut shift = [[vec![0.0; r], vec![0.0; r]], [vec![0.0; r], vec![0.0; r]]];
    let mut x_in = [[[0.0; 2]; 2]; 2];
    for j in 0..2 {
        for (s, sign) in [1.0, -1.0].into_iter().enumerate() {
            let mut x = [0.0; 2];
            x[j] = sign * amplitude;
            let mut u = model.zero_vector();
            factor.solve_full(dofs, &fe.pea_load(x), &mut u, &mut tmp, &mut sws)?;
            x_in[j][s] = fe.input_displacements(&u);
            model.assemble(&fe.design(), &u, None, Some(&mut kt), &mut aws);
            let dk = cb.project(model, &kt) - &cb.stiffness;
            for k in 0..r {
                let phi = modal.shapes.column(k);
                shift[j][s][k] = phi.dot(&(&dk * phi));
            }
        }
    }
    // d(shift)/dx_nom,j by central differences, then through ∂x_in/∂x_nom to x_in.
    let dx = [0, 1].map(|j| [0, 1].map(|i| 0.5 * (x_in[j][0][i] - x_in[j][1][i])));
    // dx[j][i] = ∂x_in,i per A e_j; columns of X are x_nom directions.
    let det = dx[0][0] * dx[1][1] - dx[1][0] * dx[0][1];
    check(
        "input compliance determinant",
        det,
        det.abs() > 0.0,
        "non-zero",
    )?;
    Ok((0..r)
        .map(|k| {
            let ds = [0, 1].map(|j| 0.5 * (shift[j][0][k] - shift[j][1][k]));
            // Solve [dx00 dx10; dx01 dx11]ᵀ-style: ds_j = Σ_i s_i dx[j][i].
            let s0 = (ds[0] * dx[1][1] - ds[1] * dx[0][1]) / det;
            let s1 = (ds[1] * dx[0][0] - ds[0] * dx[1][0]) / det;
            [s0, s1]
        })
        .collect())
}

/// Fits the correction on a `points × points` grid over `[−amplitude, amplitude]²`, with the
/// stiffening of the modes of `modal` (the reduction `cb`).
pub fn fit(
    fe: &StageFe,
    cb: &CraigBampton,
    modal: &ModalStage,
    amplitude: f64,
    points: usize,
) -> Result<NonlinearMap> {
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
        stiffening: stiffening(fe, cb, modal, amplitude)?,
    })
}
