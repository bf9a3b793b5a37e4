//! The discretized regression of Eq. (54)–(56), derived from Eq. (31) and (34) (A13–A14).
//!
//! # Derivation
//! Central differences at t − T_s,
//!
//! ```text
//! ẍ(t−T_s) ≈ [x(t) − 2x(t−T_s) + x(t−2T_s)] / T_s²,   ẋ(t−T_s) ≈ [x(t) − x(t−2T_s)] / (2T_s),
//! ```
//!
//! turn Eq. (31), M q̈_o = K(A₀x_in − q_o) + C(A₀ẋ_in − q̇_o) (+ cross terms), multiplied by
//! T_s² M⁻¹, into
//!
//! ```text
//! Δ²q_o = T_s²M⁻¹K · [A₀x_in − q_o](t−T_s) + (T_s/2)M⁻¹C · Δ[A₀x_in − q_o] − T_s²M⁻¹k_c · q̄_o(t−T_s)
//! ```
//!
//! with Δ²s = s(t) − 2s(t−T_s) + s(t−2T_s) and Δs = s(t) − s(t−2T_s). The first two columns
//! are the first two rows of φ in Eq. (54) and of θ in Eq. (55); the target is the first row
//! of u_r in Eq. (56). (q̄_o = [q_o2, q_o1] swaps the axes; see "cross terms" below.)
//!
//! Eq. (34), written per input plate i with the entries of Eq. (35),
//! m_in,i ẍ_in,i = K_pea,i x_nom,i − (K_qo1 + K_in,i + K_pea,i) x_in,i − (C_qo1 + C_in,i) ẋ_in,i
//! + K_qo1 q_o1 + C_qo1 q̇_o1, is regrouped by the spring each term belongs to,
//!
//! ```text
//! m_in ẍ_in = K_pea(x_nom − x_in) − K_in x_in + K_qo1(q_o1 − x_in) − C_in ẋ_in + C_qo1(q̇_o1 − ẋ_in)
//! ```
//!
//! and discretized the same way:
//!
//! ```text
//! Δ²x_in,i = a₁ (x_nom,i − x_in,i)(t−T_s) + a₂ (−x_in,i(t−T_s)) + a₃ (q_o1 − x_in,i)(t−T_s)
//!          + a₄ (−Δx_in,i) + a₅ Δ(q_o1 − x_in,i),
//! a = T_s²/m_in,i · [K_pea,i, K_in,i, K_qo1] and (T_s/2)/m_in,i · [C_in,i, C_qo1].
//! ```
//!
//! The paper's θ₃ = T_s² M_in⁻¹ K_in and θ₄ = (T_s/2) M_in⁻¹ C_in of Eq. (55) (the lumped
//! entries of Eq. 35) are a₁ + a₂ + a₃ and a₄ + a₅; the paper's regressors −x_in(t−T_s) and
//! −Δx_in are the sums of our columns' x_in parts ([`paper_theta`]).
//!
//! # Corrections of Eq. (54)–(56)
//! * **Eq. (54), third row**: −x̂(t−T_s) is −x̂_in(t−T_s) (the stiffness term of Eq. 34).
//! * **Eq. (56), second row**: "− u + M_in⁻¹K_in x_in(t−T_s)" is inconsistent: the K_in term
//!   is already the regressor of θ₃ (it cannot also be in the target), it lacks T_s², and the
//!   input term u = T_s²M_in⁻¹K_pea x_nom contains K_pea, which is inside the unknown lumped
//!   K_in of Eq. (35). We move no unknown into the target: the target is Δ²x_in alone, and
//!   x_nom, q_o1 and Δq_o1 enter as regressors (the K_pea, K_qo1 and C_qo1 columns).
//! * **Eq. (54), signs**: with these regressors every θ entry is a positive stiffness or
//!   damping (the paper's third and fourth rows carry the minus signs of Eq. 34).
//! * **Eq. (33)**: the second plate's damper is C_qo1 (as in Eq. 35 and A14), not C_qo2.
//! * **Time index**: the two-step delays are read as written: the stiffness regressors at
//!   t − T_s (the centre of the three samples), the damping regressors as the central
//!   difference over t − 2T_s … t, the target the second difference centred at t − T_s.
//!
//! # Cross terms
//! Eq. (30) leaves the cross terms as a disturbance Δ_q. A coupling spring k_c between the
//! output directions (the simulated plant has one, 5 % of √(2K_qo1K_qo2)) is as large as the
//! signal that identifies K (the output lags A₀x_in by only (ω/ω_n)² at excitation
//! frequencies below the modes), so ignoring it biases K_qo1 and K_qo2 by tens of per cent.
//! The output rows therefore have a third column −q_o,other(t−T_s) with θ = T_s²k_c/M
//! ([`crate::IdentifyParams::coupling`], on by default; off gives the paper's two columns).

use flexstage_scenario::StageParams;

/// Names of the output-row regressors (q_o1 and q_o2 rows).
pub const OUTPUT_REGRESSORS: [&str; 4] = [
    "A0 x_in - q_o",
    "Δ(A0 x_in - q_o)",
    "-q_o(other axis)",
    "A0 row's input (static gain)",
];
/// Columns of the output rows (θ, φ): stiffness, damping, cross-axis coupling.
pub const OUT_K: usize = 0;
/// Damping column of the output rows.
pub const OUT_C: usize = 1;
/// Coupling (k_c) column of the output rows.
pub const OUT_KC: usize = 2;
/// Static-gain column of the output rows: (x_in1 + x_in2)/2 in the q_o1 row, x_in1 − x_in2 in
/// the q_o2 row ([`crate::IdentifyParams::static_gains`]).
pub const OUT_GAIN: usize = 3;
/// Columns of the plate rows (θ, φ): K_pea, K_in, K_qo1, C_in, C_qo1.
pub const PLATE_K_PEA: usize = 0;
/// K_in column of the plate rows.
pub const PLATE_K_IN: usize = 1;
/// K_qo1 column of the plate rows.
pub const PLATE_K_QO1: usize = 2;
/// C_in column of the plate rows.
pub const PLATE_C_IN: usize = 3;
/// C_qo1 column of the plate rows.
pub const PLATE_C_QO1: usize = 4;
/// Names of the input-plate regressors.
pub const PLATE_REGRESSORS: [&str; 5] = [
    "x_nom - x_in",
    "-x_in",
    "q_o1 - x_in",
    "-Δx_in",
    "Δ(q_o1 - x_in)",
];

/// Three consecutive samples s(t−2T_s), s(t−T_s), s(t) of the six signals.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Window {
    /// x_nom1, x_nom2 at t−2T_s, t−T_s, t.
    pub x_nom: [[f64; 3]; 2],
    /// x_in1, x_in2.
    pub x_in: [[f64; 3]; 2],
    /// q_o1, q_o2.
    pub q: [[f64; 3]; 2],
}

impl Window {
    /// Shifts in the sample at t.
    #[inline]
    pub fn push(&mut self, x_nom: [f64; 2], x_in: [f64; 2], q: [f64; 2]) {
        for i in 0..2 {
            self.x_nom[i] = [self.x_nom[i][1], self.x_nom[i][2], x_nom[i]];
            self.x_in[i] = [self.x_in[i][1], self.x_in[i][2], x_in[i]];
            self.q[i] = [self.q[i][1], self.q[i][2], q[i]];
        }
    }
}

/// One regression sample: φ and the target y of each of the four rows.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Rows {
    /// q_o1 and q_o2 rows: (φ, y).
    pub output: [([f64; 4], f64); 2],
    /// Input plates 1 and 2: (φ, y).
    pub plate: [([f64; 5], f64); 2],
}

#[inline]
fn d2(s: &[f64; 3]) -> f64 {
    s[2] - 2.0 * s[1] + s[0]
}

#[inline]
fn d1(s: &[f64; 3]) -> f64 {
    s[2] - s[0]
}

/// How the stiffness regressors are sampled.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scheme {
    /// Eq. (54) as printed: s(t − T_s). The central second difference then carries a
    /// relative error (ωT_s)²/12 (0.3 % at 300 Hz and 10 kHz), which biases K_qo1 and
    /// K_qo2 low by about 0.2 % for the default excitation.
    Central,
    /// Numerov's weighting (s(t) + 10 s(t−T_s) + s(t−2T_s))/12 of the stiffness regressors,
    /// against the same second-difference target: fourth-order accurate ((ωT_s)⁴/240), same
    /// θ and u_r. Default: K_in is a small spring (its force is below the plate's inertial
    /// force at a few hundred Hz), so the 0.2 % bias of K_qo1 becomes ≈ 3 % in K_in.
    Numerov,
}

#[inline]
fn mid(s: &[f64; 3], scheme: Scheme) -> f64 {
    match scheme {
        Scheme::Central => s[1],
        Scheme::Numerov => (s[0] + 10.0 * s[1] + s[2]) / 12.0,
    }
}

/// Regressors and targets of the window (module docs), with α of Eq. (27).
#[inline]
pub fn rows(w: &Window, alpha: f64, scheme: Scheme) -> Rows {
    let [x1, x2] = &w.x_in;
    let [q1, q2] = &w.q;
    // A₀ x_in − q_o at the three samples (A₀ of Eq. 32).
    let mut e1 = [0.0; 3];
    let mut e2 = [0.0; 3];
    let mut s1 = [0.0; 3];
    let mut s2 = [0.0; 3];
    for j in 0..3 {
        s1[j] = 0.5 * (x1[j] + x2[j]);
        s2[j] = x1[j] - x2[j];
        e1[j] = s1[j] - q1[j];
        e2[j] = alpha * s2[j] - q2[j];
    }
    let output = [
        (
            [
                mid(&e1, scheme),
                d1(&e1),
                -mid(q2, scheme),
                mid(&s1, scheme),
            ],
            d2(q1),
        ),
        (
            [
                mid(&e2, scheme),
                d1(&e2),
                -mid(q1, scheme),
                mid(&s2, scheme),
            ],
            d2(q2),
        ),
    ];
    let plate = [0, 1].map(|i| {
        let x = &w.x_in[i];
        let u = &w.x_nom[i];
        let r = [q1[0] - x[0], q1[1] - x[1], q1[2] - x[2]];
        let un = [u[0] - x[0], u[1] - x[1], u[2] - x[2]];
        (
            [
                mid(&un, scheme),
                -mid(x, scheme),
                mid(&r, scheme),
                -d1(x),
                d1(&r),
            ],
            d2(x),
        )
    });
    Rows { output, plate }
}

/// θ of the four rows.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Theta {
    /// q_o1 row: T_s²2K_qo1/M, (T_s/2)2C_qo1/M, T_s²k_c/M, T_s²2K_qo1(β − 1)/M (β the
    /// static gain of q_o1 on (x_in1 + x_in2)/2, 1 in Eq. 32).
    pub output1: [f64; 4],
    /// q_o2 row: T_s²K_qo2/M, (T_s/2)C_qo2/M, T_s²k_c/M, T_s²K_qo2(α' − α)/M (α' the static
    /// gain of q_o2 on x_in1 − x_in2, α of Eq. 27 in the model).
    pub output2: [f64; 4],
    /// Plates: T_s²/m_in·[K_pea, K_in, K_qo1], (T_s/2)/m_in·[C_in, C_qo1].
    pub plate: [[f64; 5]; 2],
}

impl Theta {
    /// θ of a parameter set (the initial guess) at sample time `ts`, with coupling `k_c`.
    pub fn from_params(p: &StageParams, k_c: f64, ts: f64) -> Theta {
        let (s2, s1) = (ts * ts, 0.5 * ts);
        let m = p.mass;
        let plate = |k_pea: f64, k_in: f64, c_in: f64, m_in: f64| {
            [
                s2 * k_pea / m_in,
                s2 * k_in / m_in,
                s2 * p.k_qo1 / m_in,
                s1 * c_in / m_in,
                s1 * p.c_qo1 / m_in,
            ]
        };
        Theta {
            output1: [
                s2 * 2.0 * p.k_qo1 / m,
                s1 * 2.0 * p.c_qo1 / m,
                s2 * k_c / m,
                0.0,
            ],
            output2: [s2 * p.k_qo2 / m, s1 * p.c_qo2 / m, s2 * k_c / m, 0.0],
            plate: [
                plate(p.k_pea1, p.k_in1, p.c_in1, p.m_in1),
                plate(p.k_pea2, p.k_in2, p.c_in2, p.m_in2),
            ],
        }
    }
}

/// The physical parameters recovered from θ.
#[derive(Debug, Clone, PartialEq)]
pub struct Physical {
    /// The parameter set: estimated stiffnesses and dampings, weighed masses and α from
    /// the known set.
    pub params: StageParams,
    /// Coupling stiffness k_c from the q_o1 and q_o2 rows [N/m].
    pub coupling: [f64; 2],
    /// The static gains [β, α'] of the output rows (1 and the model's α when
    /// [`crate::IdentifyParams::static_gains`] is off; see [`Theta`]).
    pub gains: [f64; 2],
    /// K_qo1 from each plate row's own scale (a₃ m_in/T_s²): a consistency check, poorly
    /// determined (the plate rows fix ratios well and their scale only through the small
    /// inertial term, see [`physical`]).
    pub plate_k_qo1: [f64; 2],
}

/// Recovers the physical parameters (Section 4.2) from θ with the weighed masses and α of
/// `known`. `plate_cov` is the covariance (inverse information) of the two plate rows.
///
/// * K_qo1 = θ₁₁ M/(2T_s²), C_qo1 = θ₁₂ M/T_s; K_qo2 = θ₂₁ M/T_s², C_qo2 = 2θ₂₂ M/T_s;
///   k_c = θ₁₃ M/T_s² (and θ₂₃ M/T_s²).
/// * Plates: the least-squares estimate *constrained* to a₃ = T_s²K_qo1/m_in with K_qo1 of
///   the output row, θ_c = θ − P e₃ (θ₃ − a₃)/P₃₃ (the exact equality-constrained least
///   squares from the unconstrained θ and its covariance P), then K_pea = θ_c1 m_in/T_s²,
///   K_in = θ_c2 m_in/T_s², C_in = 2θ_c4 m_in/T_s. These are the values "calculated
///   algebraically from the estimated K_in and K_qo1" (Section 4.2).
///
/// Why constrained: the plate equation is nearly a static balance at excitation
/// frequencies far below the ≈ 12 kHz plate mode, K_pea(x_nom − x_in) − K_in x_in +
/// K_qo1(q_o1 − x_in) ≈ 0, which holds for any common scale of the three stiffnesses; only
/// the (ω/ω_in)² ≈ 10⁻³ inertial term fixes it. That direction of θ is the worst determined,
/// and with sensor noise the unconstrained estimate shrinks along it (errors in variables).
/// The scale is well determined by the output row through the weighed mass M; fixing it
/// there leaves K_pea and K_in well conditioned.
///
/// With `resonant` (the excitation has a band around the output modes,
/// [`crate::Band`]), the output rows' stiffness and damping are corrected for the
/// discretization at each row's own natural frequency ω_n (√(2K_qo1/M), √(K_qo2/M)), where a
/// resonance band makes them identified: K ← K/[`stiffness_factor`], C ← C/[`damping_factor`]
/// (ω_n from the corrected K, two fixed-point passes). The plate rows' constraint then uses
/// the corrected values: the plate rows see the low band, where the discretization is exact.
pub fn physical(
    theta: &Theta,
    plate_cov: &[[[f64; 5]; 5]; 2],
    known: &StageParams,
    ts: f64,
    scheme: Scheme,
    resonant: bool,
) -> Physical {
    let m = known.mass;
    let (s2, s1) = (ts * ts, 0.5 * ts);
    // (row stiffness as regressed, its factor in ω_n² = factor·K/M, damping as regressed)
    let row = |k: f64, factor: f64, c: f64| -> (f64, f64) {
        if !resonant {
            return (k, c);
        }
        let mut kk = k;
        for _ in 0..2 {
            let wt = (factor * kk.max(0.0) / m).sqrt() * ts;
            kk = k / stiffness_factor(wt, scheme);
        }
        let wt = (factor * kk.max(0.0) / m).sqrt() * ts;
        (kk, c / damping_factor(wt, scheme))
    };
    let (k_qo1, c_qo1) = row(
        theta.output1[OUT_K] * m / (2.0 * s2),
        2.0,
        theta.output1[OUT_C] * m / (2.0 * s1),
    );
    let (k_qo2, c_qo2) = row(
        theta.output2[OUT_K] * m / s2,
        1.0,
        theta.output2[OUT_C] * m / s1,
    );
    let ratio = |row: &[f64; 4]| {
        if row[OUT_K] != 0.0 {
            row[OUT_GAIN] / row[OUT_K]
        } else {
            0.0
        }
    };
    let gains = [
        1.0 + ratio(&theta.output1),
        known.alpha + ratio(&theta.output2),
    ];
    let coupling = [
        theta.output1[OUT_KC] * m / s2,
        theta.output2[OUT_KC] * m / s2,
    ];
    let (k, c) = (PLATE_K_QO1, PLATE_C_QO1);
    let plate = |a: &[f64; 5], p: &[[f64; 5]; 5], m_in: f64| {
        // Equality constraints θ₃ = T_s²K_qo1/m_in, θ₅ = (T_s/2)C_qo1/m_in:
        // θ_c = θ − P E (EᵀPE)⁻¹ (Eᵀθ − c), E = [e₃, e₅].
        let r = [a[k] - s2 * k_qo1 / m_in, a[c] - s1 * c_qo1 / m_in];
        let g = [[p[k][k], p[k][c]], [p[c][k], p[c][c]]];
        let det = g[0][0] * g[1][1] - g[0][1] * g[1][0];
        let mut th = *a;
        if det > 0.0 {
            let w = [
                (g[1][1] * r[0] - g[0][1] * r[1]) / det,
                (g[0][0] * r[1] - g[1][0] * r[0]) / det,
            ];
            for j in 0..5 {
                th[j] = a[j] - p[j][k] * w[0] - p[j][c] * w[1];
            }
        }
        (
            th[PLATE_K_PEA] * m_in / s2,
            th[PLATE_K_IN] * m_in / s2,
            th[PLATE_C_IN] * m_in / s1,
        )
    };
    let (k_pea1, k_in1, c_in1) = plate(&theta.plate[0], &plate_cov[0], known.m_in1);
    let (k_pea2, k_in2, c_in2) = plate(&theta.plate[1], &plate_cov[1], known.m_in2);
    Physical {
        params: StageParams {
            k_qo1,
            k_qo2,
            k_pea1,
            k_pea2,
            k_in1,
            k_in2,
            c_qo1,
            c_qo2,
            c_in1,
            c_in2,
            alpha: gains[1],
            ..known.clone()
        },
        coupling,
        gains,
        plate_k_qo1: [
            theta.plate[0][PLATE_K_QO1] * known.m_in1 / s2,
            theta.plate[1][PLATE_K_QO1] * known.m_in2 / s2,
        ],
    }
}

/// Numerov's weight W(ω) = (10 + 2cos ωT_s)/12 of the stiffness regressors (1 for the central
/// scheme); `None` outside (0, 0.9π), where no mode can be resolved and nothing is corrected.
fn weight(wt: f64, scheme: Scheme) -> Option<f64> {
    (wt > 1e-6 && wt < 0.9 * std::f64::consts::PI).then(|| match scheme {
        Scheme::Central => 1.0,
        Scheme::Numerov => (10.0 + 2.0 * wt.cos()) / 12.0,
    })
}

/// The factor by which the regression's stiffness estimate of a mode at ωT_s = `wt` falls
/// short, h = 2(1 − cos ωT_s)/((ωT_s)²·W(ω)). For a sinusoid at ω the second-difference
/// target is −2(1 − cos ωT_s)·q and the stiffness regressor W·e; matching the continuous
/// −ω²M q = (K + jωC)e term by term gives the estimate K·h(ω). A resonance band identifies a
/// row's stiffness at its resonance, so the estimate is K·h(ω_n) (−0.4 % at 1.5 kHz, −1.2 % at
/// 2 kHz with T_s = 0.1 ms, Numerov: the measured biases). 1 outside (0, 0.9π).
pub fn stiffness_factor(wt: f64, scheme: Scheme) -> f64 {
    weight(wt, scheme).map_or(1.0, |w| 2.0 * (1.0 - wt.cos()) / (wt * wt * w))
}

/// The factor by which the regression's damping estimate of a mode at ωT_s = `wt` exceeds
/// its damping, g = 2(1 − cos ωT_s)/(ωT_s·sin ωT_s), for either scheme: the damping regressor
/// Δe = e(t) − e(t−2T_s) is 2j·sin(ωT_s)·e(t−T_s) where the continuous damping force is
/// jωC·e, against the target −2(1 − cos ωT_s)·q (same derivation as [`stiffness_factor`]).
/// g → 1 as ωT_s → 0 (+7 % at 1.5 kHz, +22 % at 2.3 kHz with T_s = 0.1 ms); 1 outside
/// (0, 0.9π).
pub fn damping_factor(wt: f64, scheme: Scheme) -> f64 {
    weight(wt, scheme).map_or(1.0, |_| 2.0 * (1.0 - wt.cos()) / (wt * wt.sin()))
}

/// θ in the paper's form, Eq. (55), diagonals only: [T_s²M⁻¹K (2), (T_s/2)M⁻¹C (2),
/// T_s²M_in⁻¹K_in (2, lumped as in Eq. 35), (T_s/2)M_in⁻¹C_in (2, lumped)].
pub fn paper_theta(theta: &Theta) -> [f64; 8] {
    let lumped_k = |a: &[f64; 5]| a[PLATE_K_PEA] + a[PLATE_K_IN] + a[PLATE_K_QO1];
    let lumped_c = |a: &[f64; 5]| a[PLATE_C_IN] + a[PLATE_C_QO1];
    let p = &theta.plate;
    [
        theta.output1[OUT_K],
        theta.output2[OUT_K],
        theta.output1[OUT_C],
        theta.output2[OUT_C],
        lumped_k(&p[0]),
        lumped_k(&p[1]),
        lumped_c(&p[0]),
        lumped_c(&p[1]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn discretization_factors_match_the_regression_on_an_exact_sinusoid() {
        // Reference: the exact steady state of the q_o2 row, M q̈ = (K + C d/dt)(α x − q),
        // under x = sin(ωt) with x_in2 = 0 (so A₀x_in = αx), sampled at T_s = 0.1 ms, at
        // 1.5 and 2.3 kHz. Goal: the θ that satisfies `rows` on two windows of that sampled
        // signal gives K·h and C·g (stiffness_factor, damping_factor) to 1e-9, both schemes.
        let (m, k, c, alpha, ts) = (0.05, 1e7, 20.0, 2.0, 1e-4);
        for f in [1500.0, 2300.0] {
            for scheme in [Scheme::Numerov, Scheme::Central] {
                let w = std::f64::consts::TAU * f;
                // q = H·x, H = α(K + jωC)/(K − ω²M + jωC).
                let num = nalgebra::Complex::new(k, w * c) * alpha;
                let h = num / nalgebra::Complex::new(k - w * w * m, w * c);
                let sample = |t: f64| {
                    let z = nalgebra::Complex::new(0.0, w * t).exp();
                    (z.im, (h * z).im)
                };
                let window = |t0: f64| {
                    let mut win = Window::default();
                    for j in 0..3 {
                        let (x, q) = sample(t0 + j as f64 * ts);
                        win.push([0.0; 2], [x, 0.0], [0.0, q]);
                    }
                    rows(&win, alpha, scheme).output[1]
                };
                let (a, b) = (window(0.0), window(0.37 * ts));
                // θ_K φ₀ + θ_C φ₁ = y on both windows (q_o1 = 0: no coupling term).
                let det = a.0[0] * b.0[1] - a.0[1] * b.0[0];
                let th_k = (a.1 * b.0[1] - a.0[1] * b.1) / det;
                let th_c = (a.0[0] * b.1 - a.1 * b.0[0]) / det;
                let k_est = th_k * m / (ts * ts);
                let c_est = th_c * m / (0.5 * ts);
                let wt = w * ts;
                let rel = |x: f64, y: f64| ((x - y) / y).abs();
                assert!(
                    rel(k_est, k * stiffness_factor(wt, scheme)) < 1e-9,
                    "{f} Hz {scheme:?}: K {k_est:e}"
                );
                assert!(
                    rel(c_est, c * damping_factor(wt, scheme)) < 1e-9,
                    "{f} Hz {scheme:?}: C {c_est:e}"
                );
            }
        }
    }
}
