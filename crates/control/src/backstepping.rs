//! The backstepping robust control law of Section 3.2.2 and Appendix D, derived for the
//! 8-state model of Eq. (36).
//!
//! Notation of the paper: η = [z1 … z6] = [q_o, x_in, q̇_o], ξ = x_in = [z3, z4],
//! ξ̇ = [z7, z8] (Eq. 43); G = [[θ1, θ1], [αθ2, −αθ2]] with θ_i = K_qoi/M (A24, A29).
//! Rows 5–6 of B split into the part that multiplies ξ (that is G) and the rest,
//! N(η, ξ̇) = Σ_{j ∈ {1,2,5,6}} β_{4+i,j} η_j + β_{4+i,7} ξ̇1 + β_{4+i,8} ξ̇2, so that
//! q̈_o = G ξ + N(η, ξ̇) + Δ_η.
//!
//! # Step 1: virtual control a (Eq. 46–49, A16–A25)
//! ε = q_o − q_d, s = ε̇ + k_ε ε, ṡ = G ξ − Z + Δ_η with
//!
//! ```text
//! Z(ξ̇, t)    = q̈_d − k_ε ε̇ − N(η_d, ξ̇) − Δ̂_η                                 (A23*)
//! a_m = G⁻¹ (Z − (k_η − 1) s)                                                  (A24)
//! a_s = G⁻¹ (−s − ρ_η σ(s/φ_s))                                                (A25)
//! a   = a_m + a_s                                                              (49)
//! ```
//!
//! so that with ξ = a, ṡ = −k_η s − ρ_η σ(s/φ_s) − Λ(ε, ε̇) + (Δ_η − Δ̂_η) (A27, first
//! line), where η_d = (q_d, q̇_d), Λ is the mechanism's own spring and damper acting on the
//! error (N(η) − N(η_d), passive) and Δ̂_η the observer's estimate of the model error
//! ([`crate::observer`]); ṡ s < 0 outside the boundary layer whenever the residual
//! |Δ_η,i − Δ̂_η,i| ≤ ρ_η,i. A23 as printed evaluates N at the measured η, which cancels the
//! stiffness 2K_qo1/M ≈ 2·10⁸ s⁻²; see the crate docs for why the sampled loop cannot.
//!
//! # Step 2: v = ξ̇ (Eq. 45, 50–53, A26–A38)
//! ε_a = ξ − a (A26) and ε̇_a = ξ̇ − ȧ + Δ_ε. With ξ̇ = v:
//!
//! ```text
//! v_m = ȧ − k ε_a                                                              (A35)
//! v_s = −ε_a − ρ_ε σ(ε_a/φ_a)                                                  (A37)
//! v   = v_m + v_s                                                              (A33)
//! ```
//!
//! gives ε̇_a = −(k + 1) ε_a − ρ_ε σ(ε_a/φ_a) + Δ_ε. The ε_a-subsystem does not depend on s,
//! and s is driven by G ε_a: a cascade of two exponentially stable (ISS) systems, which is the
//! stability argument behind the composite CLF of Eq. (51).
//!
//! ȧ is the derivative of a along the nominal model flow (η̇ from Eq. 36 with Δ = 0 and the
//! estimated ξ̇ held): ȧ = G⁻¹ (Ż − (c + ψ'(s)) ṡ) with c = k_η − 1 (+1 when robust), the
//! Lie derivative Ż = ∂Z/∂η·η̇ + ∂Z/∂t, and ψ' the slope of the boundary-layer term. These
//! are the paper's "∂Z5/∂η", "∂Z6/∂η" and Π terms (Π11 = −a1, Π21 = −a2, Π12 = ȧ1,
//! Π22 = ȧ2 in A30–A32); `tests/backstepping.rs` checks each against central differences.
//! The ξ̈ that the damping terms β57, β58 of Z would add to Ż is left in Δ_ε, as the paper
//! does by writing ∂Z/∂η only.
//!
//! # Corrections of Appendix D (each documented where it is used)
//! * **A16, A23**: the output damping term β55 η5 (β66 η6) of row 5 (6) of B is missing from
//!   Z; it is included (and the cross term β52 η2 when the model has one). N is evaluated at
//!   the reference (q_d, q̇_d), plus the estimate Δ̂_η (A23*).
//! * **A22, A25**: the robust term −max|Δ_η| has no sign, so it does not oppose Δ_η when
//!   s < 0; it is −ρ_η sgn(s), or the boundary-layer saturation σ(s/φ_s) against chattering.
//! * **A34–A35**: (ξ̂₁ + Π11) is ε_a1 (A26 with a1 = −Π11); the paper's v_m1 = −k1 ε_a1/(ξ̂₁ +
//!   Π11) + Π12 is −k1 + Π12, singular at ε_a = 0 and not stabilizing. The condition that
//!   makes V̇_α negative is ε_a(v_m − ȧ) = −k ε_a², i.e. v_m = ȧ − k ε_a.
//! * **A36–A37**: likewise v_s = −(max|ε_aΔ_ε| + ε_a)/ε_a is replaced by −ε_a − ρ_ε σ(ε_a/φ_a)
//!   (ρ_ε bounds |Δ_ε|, the same split as A25); A37–A38 write ζ̂ for ξ̂.
//! * **A31–A32**: Π12, Π22 substitute ṡ = −k_η s; here ṡ is evaluated from the model, which
//!   is what the derivative of a actually is.
//! * **Eq. (44)** uses v̇ where ξ̇ = v (Eq. 45) is to be enforced: see
//!   [`crate::controller`] for the input transformation.
//!
//! The robust variant (Figure 9b) uses a_s and v_s; the non-robust one (Figure 9a, "aborting
//! the robust feedback output") sets both to zero, which also removes their linear parts
//! (−s, −ε_a), as in the paper's remark that its linear gain is lower.

use nalgebra::{Matrix2, Vector2};

use crate::error::{ControlError, Result, check, non_negative, positive};
use flexstage_sim::model::state::{Q_O, Q_O_DOT, X_IN, X_IN_DOT};
use flexstage_sim::model::{Matrix8, StageModel};
use flexstage_sim::trajectory::RefSample;

/// Gains and robust-term settings of the law.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LawParams {
    /// Error gains k_ε [1/s], > 0 (s = ε̇ + k_ε ε). Table 4: 2e4, 1.5e4.
    pub error_gain: [f64; 2],
    /// Linear feedback gains k_η [1/s], > 1 (A21).
    pub eta_gain: [f64; 2],
    /// Feedback gains k [1/s], > 0 (A34). Table 4: 1.2e4, 1.2e3.
    pub feedback_gain: [f64; 2],
    /// Robust terms a_s, v_s on (true) or off (the non-robust variant of Figure 9a).
    pub robust: bool,
    /// Disturbance bounds ρ_η = max|Δ_η| [m/s²], ≥ 0 (A22, A25).
    pub eta_bound: [f64; 2],
    /// Disturbance bounds ρ_ε = max|Δ_ε| [m/s], ≥ 0 (A36–A37).
    pub a_bound: [f64; 2],
    /// Boundary layers (φ_s [m/s], φ_a \[m\]), ≥ 0: σ(x) = sat(x); 0 selects sgn (no layer).
    pub boundary_layer: [f64; 2],
}

impl LawParams {
    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        for i in 0..2 {
            positive(&format!("controller.error_gain[{i}]"), self.error_gain[i])?;
            check(
                &format!("controller.eta_gain[{i}]"),
                self.eta_gain[i],
                self.eta_gain[i] > 1.0,
                "a finite number > 1 (A21)",
            )?;
            positive(
                &format!("controller.feedback_gain[{i}]"),
                self.feedback_gain[i],
            )?;
            non_negative(&format!("controller.eta_bound[{i}]"), self.eta_bound[i])?;
            non_negative(&format!("controller.a_bound[{i}]"), self.a_bound[i])?;
            non_negative(
                &format!("controller.boundary_layer[{i}]"),
                self.boundary_layer[i],
            )?;
        }
        Ok(())
    }
}

/// Everything the law computes at one sample (for logging and tests).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LawOutput {
    /// ε = q_o − q_d.
    pub eps: [f64; 2],
    /// s = ε̇ + k_ε ε.
    pub s: [f64; 2],
    /// ṡ along the nominal model flow.
    pub s_dot: [f64; 2],
    /// Z of (A23).
    pub z: [f64; 2],
    /// Ż = ∂Z/∂η·η̇ + ∂Z/∂t.
    pub z_dot: [f64; 2],
    /// a = a_m + a_s (Eq. 49).
    pub a: [f64; 2],
    /// ȧ.
    pub a_dot: [f64; 2],
    /// ε_a = ξ − a (A26).
    pub eps_a: [f64; 2],
    /// v = v_m + v_s (A33).
    pub v: [f64; 2],
}

/// The law with its model matrices precomputed. `Copy`, no allocation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Law {
    b: Matrix8,
    g_inv: Matrix2<f64>,
    params: LawParams,
}

/// σ(x/φ): saturation of width φ, or sgn(x) when φ = 0.
#[inline]
pub fn sigma(x: f64, phi: f64) -> f64 {
    if phi > 0.0 {
        (x / phi).clamp(-1.0, 1.0)
    } else if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// dσ(x/φ)/dx: 1/φ inside the layer, 0 outside (and for sgn).
#[inline]
pub fn sigma_slope(x: f64, phi: f64) -> f64 {
    if phi > 0.0 && x.abs() < phi {
        1.0 / phi
    } else {
        0.0
    }
}

impl Law {
    /// The law for the controller's model.
    pub fn new(model: &StageModel, params: LawParams) -> Result<Law> {
        params.validate()?;
        let g_inv = model
            .g()
            .try_inverse()
            .ok_or_else(|| ControlError::Singular {
                what: "G = [[θ1, θ1], [αθ2, −αθ2]] (A24)".into(),
            })?;
        Ok(Law {
            b: model.b,
            g_inv,
            params,
        })
    }

    /// The law of the model matrix `b` (Eq. 36) with G⁻¹ = `g_inv` given (as
    /// [`Law::g_inv`] of a law made by [`Law::new`]).
    pub fn with_inverse(b: Matrix8, g_inv: Matrix2<f64>, params: LawParams) -> Result<Law> {
        params.validate()?;
        Ok(Law { b, g_inv, params })
    }

    /// G⁻¹ (A24).
    pub fn g_inv(&self) -> Matrix2<f64> {
        self.g_inv
    }

    /// The settings.
    pub fn params(&self) -> &LawParams {
        &self.params
    }

    /// N(η, ξ̇): rows 5–6 of B without the ξ columns.
    #[inline]
    fn n(&self, eta: &[f64; 6], xi_dot: &[f64; 2], delta: &[f64; 2]) -> [f64; 2] {
        let b = &self.b;
        let mut out = [0.0; 2];
        let ([q1, q2], [v1, v2], [w1, w2]) = (Q_O, Q_O_DOT, X_IN_DOT);
        for (i, o) in out.iter_mut().enumerate() {
            let r = Q_O_DOT[i];
            *o = delta[i]
                + b[(r, q1)] * eta[q1]
                + b[(r, q2)] * eta[q2]
                + b[(r, v1)] * eta[v1]
                + b[(r, v2)] * eta[v2]
                + b[(r, w1)] * xi_dot[0]
                + b[(r, w2)] * xi_dot[1];
        }
        out
    }

    /// N at the desired output (q_d, q̇_d) with the estimated ξ̇ and Δ̂: the part of Z that is
    /// kept as feedforward (the mechanism's own stiffness and damping act on the error).
    #[inline]
    fn n_d(&self, r: &RefSample, xi_dot: &[f64; 2], delta: &[f64; 2]) -> [f64; 2] {
        let mut eta_d = [0.0; 6];
        for i in 0..2 {
            eta_d[Q_O[i]] = r.q[i];
            eta_d[Q_O_DOT[i]] = r.dq[i];
        }
        self.n(&eta_d, xi_dot, delta)
    }

    /// Ṅ_d (reference terms only; ξ̇ and Δ̂ held).
    #[inline]
    fn n_d_dot(&self, r: &RefSample) -> [f64; 2] {
        let b = &self.b;
        let ([q1, q2], [v1, v2]) = (Q_O, Q_O_DOT);
        Q_O_DOT.map(|row| {
            b[(row, q1)] * r.dq[0]
                + b[(row, q2)] * r.dq[1]
                + b[(row, v1)] * r.ddq[0]
                + b[(row, v2)] * r.ddq[1]
        })
    }

    /// η̇ along the nominal model (Eq. 36 with Δ = 0); ξ̇ is the estimate.
    #[inline]
    pub fn eta_dot(&self, eta: &[f64; 6], xi_dot: &[f64; 2], delta: &[f64; 2]) -> [f64; 6] {
        let n = self.n(eta, xi_dot, delta);
        let b = &self.b;
        let [x1, x2] = X_IN;
        let acc = |i: usize| {
            let row = Q_O_DOT[i];
            n[i] + b[(row, x1)] * eta[x1] + b[(row, x2)] * eta[x2]
        };
        let mut out = [0.0; 6];
        for i in 0..2 {
            out[Q_O[i]] = eta[Q_O_DOT[i]];
            out[X_IN[i]] = xi_dot[i];
            out[Q_O_DOT[i]] = acc(i);
        }
        out
    }

    /// Step 1: s, Z and a at (η, ξ̇, reference).
    #[inline]
    pub fn virtual_control(
        &self,
        eta: &[f64; 6],
        xi_dot: &[f64; 2],
        delta: &[f64; 2],
        r: &RefSample,
    ) -> ([f64; 2], [f64; 2], [f64; 2]) {
        let p = &self.params;
        let robust = if p.robust { 1.0 } else { 0.0 };
        let n = self.n_d(r, xi_dot, delta);
        let mut s = [0.0; 2];
        let mut z = [0.0; 2];
        let mut rhs = Vector2::zeros();
        for i in 0..2 {
            let e = eta[Q_O[i]] - r.q[i];
            let ed = eta[Q_O_DOT[i]] - r.dq[i];
            s[i] = ed + p.error_gain[i] * e;
            z[i] = r.ddq[i] - p.error_gain[i] * ed - n[i];
            // a_m (A24) + a_s (A25, with the sign fixed).
            rhs[i] = z[i] - (p.eta_gain[i] - 1.0) * s[i]
                + robust * (-s[i] - p.eta_bound[i] * sigma(s[i], p.boundary_layer[0]));
        }
        let a = self.g_inv * rhs;
        (s, z, [a[0], a[1]])
    }

    /// The complete law at one sample: a, ȧ, ε_a and v (A24–A38, corrected).
    #[inline]
    pub fn evaluate(
        &self,
        eta: &[f64; 6],
        xi_dot: &[f64; 2],
        delta: &[f64; 2],
        r: &RefSample,
    ) -> LawOutput {
        let p = &self.params;
        let robust = if p.robust { 1.0 } else { 0.0 };
        let (s, z, a) = self.virtual_control(eta, xi_dot, delta, r);
        let eta_dot = self.eta_dot(eta, xi_dot, delta);
        let n_d_dot = self.n_d_dot(r);
        let mut s_dot = [0.0; 2];
        let mut z_dot = [0.0; 2];
        let mut rhs = Vector2::zeros();
        for i in 0..2 {
            let qdd = eta_dot[Q_O_DOT[i]];
            let ed = eta[Q_O_DOT[i]] - r.dq[i];
            let edd = qdd - r.ddq[i];
            s_dot[i] = edd + p.error_gain[i] * ed;
            let n_dot = n_d_dot[i];
            z_dot[i] = r.dddq[i] - p.error_gain[i] * edd - n_dot;
            let slope = (p.eta_gain[i] - 1.0)
                + robust * (1.0 + p.eta_bound[i] * sigma_slope(s[i], p.boundary_layer[0]));
            rhs[i] = z_dot[i] - slope * s_dot[i];
        }
        let a_dot = self.g_inv * rhs;
        let mut out = LawOutput {
            eps: [0, 1].map(|i| eta[Q_O[i]] - r.q[i]),
            s,
            s_dot,
            z,
            z_dot,
            a,
            a_dot: [a_dot[0], a_dot[1]],
            ..LawOutput::default()
        };
        for i in 0..2 {
            let ea = eta[X_IN[i]] - a[i];
            out.eps_a[i] = ea;
            let v_m = a_dot[i] - p.feedback_gain[i] * ea;
            let v_s = robust * (-ea - p.a_bound[i] * sigma(ea, p.boundary_layer[1]));
            out.v[i] = v_m + v_s;
        }
        out
    }
}
