//! The named responses of the optimization problem (paper Eq. 5 and DECISIONS.md): the
//! objective and the quantities the constraints bound, with their partial derivatives with
//! respect to the case quantities that the adjoints need.
//!
//! Each response `Q(u_1 … u_pm, ρ)` depends on the load cases through a few quantities per
//! case — the output displacement `u_o = L_oᵀu` (Eq. 7), the input displacements, the strain
//! energy `W` and, for the stress, a full vector — so its adjoint right-hand side for case k is
//! `∂Q/∂u_k = a_o·L_o + a_in·L_in + a_W·∂W/∂u + b_k` ([`CaseCoefficients`]).

use std::ops::{Index, IndexMut};

use crate::analysis::CaseResults;
use crate::problem::{Objective, Problem, Tilt, shoelace, shoelace_gradient};

/// The tilt constraint bounds the angle error by `TILT_MARGIN · τ`: MMA leaves an active
/// constraint slightly violated while β continuation perturbs the design, and the margin keeps
/// the delivered design within the documented tolerance τ.
pub const TILT_MARGIN: f64 = 0.75;

/// Exponent of the p-norm that aggregates per-case strain energies (Σ ≈ max_k W_k) and input
/// strokes; the p-norm over-estimates the maximum by at most `N^{1/p}` (conservative).
pub const AGGREGATION_P: f64 = 8.0;

/// A response of the problem.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ResponseKind {
    /// The maximized objective Φ: signed workspace area `sign·J` (Eq. 4) or `d·u_out`.
    Objective,
    /// p-norm aggregate of the per-case strain energies \[J\] (≈ Σ of Eq. 15).
    Energy,
    /// p-norm aggregate of |u_in| / max stroke (1 = at the stroke limit).
    Stroke,
    /// Orientation error of the differential output (≤ 0 within tolerance; [`tilt`]).
    Tilt,
    /// p-norm aggregate of the relaxed von Mises stress / design allowable at the Table 2
    /// extreme inputs ([`crate::stress`]).
    Stress,
    /// Volume fraction of the design elements.
    Volume,
    /// Aggregate `Λ` of the stage's lowest eigenvalues `ω²` [rad²/s²] ([`crate::modal`]).
    Resonance,
}

impl ResponseKind {
    /// Every response, in a fixed order.
    pub const ALL: [ResponseKind; 7] = [
        ResponseKind::Objective,
        ResponseKind::Energy,
        ResponseKind::Stroke,
        ResponseKind::Tilt,
        ResponseKind::Stress,
        ResponseKind::Volume,
        ResponseKind::Resonance,
    ];

    /// Responses computed from the load cases (by adjoints); the volume and the resonance are
    /// not.
    pub const FE: [ResponseKind; 5] = [
        ResponseKind::Objective,
        ResponseKind::Energy,
        ResponseKind::Stroke,
        ResponseKind::Tilt,
        ResponseKind::Stress,
    ];

    /// A short name (for tables and gradient checks).
    pub fn name(self) -> &'static str {
        match self {
            ResponseKind::Objective => "objective",
            ResponseKind::Energy => "strain energy",
            ResponseKind::Stroke => "input stroke",
            ResponseKind::Tilt => "tilt",
            ResponseKind::Stress => "stress",
            ResponseKind::Volume => "volume",
            ResponseKind::Resonance => "resonance",
        }
    }

    fn index(self) -> usize {
        self as usize
    }
}

/// One value per response, indexed by [`ResponseKind`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PerResponse<T>(pub [T; 7]);

impl<T> Index<ResponseKind> for PerResponse<T> {
    type Output = T;
    fn index(&self, q: ResponseKind) -> &T {
        &self.0[q.index()]
    }
}

impl<T> IndexMut<ResponseKind> for PerResponse<T> {
    fn index_mut(&mut self, q: ResponseKind) -> &mut T {
        &mut self.0[q.index()]
    }
}

impl<T> PerResponse<T> {
    /// A map built from a function of the response.
    pub fn from_fn(f: impl FnMut(ResponseKind) -> T) -> Self {
        PerResponse(ResponseKind::ALL.map(f))
    }
}

/// `∂Q/∂(case quantities)` of one response for one load case (module docs).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CaseCoefficients {
    /// `∂Q/∂u_o` (x, y).
    pub output: [f64; 2],
    /// `∂Q/∂u_in,i` per input port (at most two).
    pub inputs: [f64; 2],
    /// `∂Q/∂W_k` (strain energy of the case).
    pub energy: f64,
    /// Any other part of `∂Q/∂u_k`, as a full vector (the stress response).
    pub extra: Option<Vec<f64>>,
}

impl CaseCoefficients {
    /// Whether the response depends on this case at all.
    pub fn is_active(&self) -> bool {
        self.output.iter().chain(&self.inputs).any(|v| *v != 0.0)
            || self.energy != 0.0
            || self.extra.is_some()
    }
}

/// A response's value and its partial derivatives: per case, and the explicit `∂Q/∂ρ` at fixed
/// displacements (the stress relaxation; zero for the others).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ResponseCoefficients {
    /// The value Q.
    pub value: f64,
    /// Per load case.
    pub cases: Vec<CaseCoefficients>,
    /// Explicit `∂Q/∂ρ_e` (length n_elements), if any.
    pub explicit: Option<Vec<f64>>,
}

impl ResponseCoefficients {
    fn zero(value: f64, nc: usize) -> Self {
        Self {
            value,
            cases: vec![CaseCoefficients::default(); nc],
            explicit: None,
        }
    }
}

/// `‖v‖_p` and its gradient `∂‖v‖_p/∂v` (scaled by the largest entry, overflow-free).
pub fn pnorm(v: &[f64], p: f64) -> (f64, Vec<f64>) {
    let vmax = v.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    if vmax == 0.0 {
        return (0.0, vec![0.0; v.len()]);
    }
    let s: f64 = v.iter().map(|x| (x.abs() / vmax).powf(p)).sum();
    let n = vmax * s.powf(1.0 / p);
    let d = v
        .iter()
        .map(|x| (x.abs() / n).powf(p - 1.0) * x.signum())
        .collect();
    (n, d)
}

/// The objective Φ (Eq. 4 or `d·u_out`) and the workspace area `sign · J` of the output
/// polygon in the configuration's orientation ([`Problem::workspace_area`]; 0 for the
/// displacement objective).
pub fn objective(problem: &Problem, r: &CaseResults) -> (ResponseCoefficients, f64) {
    let nc = r.outputs.len();
    match problem.objective {
        Objective::Workspace { sign } => {
            let a = sign * shoelace(&r.outputs);
            let mut c = ResponseCoefficients::zero(a, nc);
            for (cc, g) in c.cases.iter_mut().zip(shoelace_gradient(&r.outputs)) {
                cc.output = [sign * g[0], sign * g[1]];
            }
            (c, a)
        }
        Objective::Displacement { direction } => {
            let o = r.outputs[0];
            let mut c = ResponseCoefficients::zero(direction[0] * o[0] + direction[1] * o[1], nc);
            c.cases[0].output = direction;
            (c, 0.0)
        }
    }
}

/// p-norm of the per-case strain energies.
pub fn energy(r: &CaseResults) -> ResponseCoefficients {
    let (value, de) = pnorm(&r.energies, AGGREGATION_P);
    let mut c = ResponseCoefficients::zero(value, r.energies.len());
    for (cc, d) in c.cases.iter_mut().zip(de) {
        cc.energy = d;
    }
    c
}

/// p-norm (exponent `2·AGGREGATION_P`) of `|u_in| / max_stroke` over cases and inputs.
pub fn stroke(max_stroke: f64, r: &CaseResults) -> ResponseCoefficients {
    let ni = r.inputs.first().map_or(0, Vec::len);
    let s: Vec<f64> = r.inputs.iter().flatten().map(|u| u / max_stroke).collect();
    let (value, ds) = pnorm(&s, 2.0 * AGGREGATION_P);
    let mut c = ResponseCoefficients::zero(value, r.inputs.len());
    for (k, cc) in c.cases.iter_mut().enumerate() {
        for i in 0..ni {
            cc.inputs[i] = ds[k * ni + i] / max_stroke;
        }
    }
    c
}

/// Smoothing angle of the tilt measure, as a fraction of the bound `TILT_MARGIN·τ`.
const TILT_SMOOTHING: f64 = 0.1;

/// Tilt measure `√(φ² + ε²)/(TILT_MARGIN·τ) − 1` of the differential output
/// `D = u_o(+a,−a) − u_o(−a,+a)` against the axis `d = (sin θ, cos θ)`, `n = (cos θ, −sin θ)`
/// (Figure 4b), with the angle error `φ = atan((D·n)/(D·d))` ∈ (−90°, 90°] (either sign of
/// `D·d`; the objective's orientation fixes it) and `ε = TILT_SMOOTHING·TILT_MARGIN·τ`:
/// ≤ 0 iff `D` is within about `TILT_MARGIN·τ` of the axis. Dimensionless, independent of |D|
/// and linear in the angle error, so an error of 20° reads ≈ 26 for τ = 1°, not thousands:
/// an earlier measure `(tan²φ − t)cos²φ/t` (`t = tan²(TILT_MARGIN·τ)`) reached 10³ and made
/// MMA oscillate between violated and over-satisfied tilts without settling.
/// `∂φ/∂(D·n) = (D·d)/|D|²`, `∂φ/∂(D·d) = −(D·n)/|D|²` on both branches of the arctangent.
pub fn tilt(t: Tilt, corners: (usize, usize), r: &CaseResults) -> ResponseCoefficients {
    let (kc, kt) = corners;
    let (oc, ot) = (r.outputs[kc], r.outputs[kt]);
    let dvec = [oc[0] - ot[0], oc[1] - ot[1]];
    let d = [t.theta.sin(), t.theta.cos()];
    let n = [t.theta.cos(), -t.theta.sin()];
    let (dn, dd) = (
        dvec[0] * n[0] + dvec[1] * n[1],
        dvec[0] * d[0] + dvec[1] * d[1],
    );
    let bound = TILT_MARGIN * t.tolerance;
    let eps = TILT_SMOOTHING * bound;
    let phi = if dd == 0.0 {
        std::f64::consts::FRAC_PI_2
    } else {
        (dn / dd).atan()
    };
    let root = (phi * phi + eps * eps).sqrt();
    let s2 = (dn * dn + dd * dd).max(f64::MIN_POSITIVE);
    let gphi = phi / (root * bound);
    let (g_dn, g_dd) = (gphi * dd / s2, -gphi * dn / s2);
    let g = [g_dn * n[0] + g_dd * d[0], g_dn * n[1] + g_dd * d[1]];
    let mut c = ResponseCoefficients::zero(root / bound - 1.0, r.outputs.len());
    for (i, gi) in g.into_iter().enumerate() {
        c.cases[kc].output[i] += gi;
        c.cases[kt].output[i] -= gi;
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pnorm_gradient_matches_central_differences() {
        let v = [0.3, -1.2, 0.8, 1.1];
        let (n, d) = pnorm(&v, 8.0);
        assert!(n >= 1.2 && n <= 1.2 * 4f64.powf(1.0 / 8.0));
        let h = 1e-7;
        for j in 0..v.len() {
            let (mut p, mut m) = (v, v);
            p[j] += h;
            m[j] -= h;
            let fd = (pnorm(&p, 8.0).0 - pnorm(&m, 8.0).0) / (2.0 * h);
            assert!((fd - d[j]).abs() < 1e-7, "{fd} vs {}", d[j]);
        }
    }

    #[test]
    fn per_response_is_indexed_by_name() {
        let mut p = PerResponse::from_fn(|q| q.name().len());
        assert_eq!(p[ResponseKind::Volume], "volume".len());
        p[ResponseKind::Tilt] = 0;
        assert_eq!(p.0[3], 0);
    }
}
