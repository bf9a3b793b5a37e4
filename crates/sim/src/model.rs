//! The reduced 8-state stage model: Eq. (31)–(36) and Appendix C (A13–A14).
//!
//! State z = [q_o1, q_o2, x_in1, x_in2, q̇_o1, q̇_o2, ẋ_in1, ẋ_in2] (SI: m, m/s), input
//! u = [x_nom1, x_nom2] (m), measured output y = [q_o1, q_o2]:
//!
//! ```text
//! ż = B z + [0; D] u + Δ                                                   (36)
//! ```
//!
//! with the β_ij and d_ij of (A14). Two corrections of the paper are applied, both so that the
//! matrices agree with Eq. (33)–(35) from which they are derived:
//!
//! * **Eq. (33)** writes f₂ = K_qo1(x_in2 − q_o1) + C_qo2(ẋ_in2 − q̇_o1). Eq. (35) and (A14)
//!   use K_qo1 *and* C_qo1 for the second input plate (C_in,q = [[C_qo1, 0], [C_qo1, 0]],
//!   β85 = C_qo1/M_in2), so the damper is C_qo1: the spring and damper of one connection
//!   share their index.
//! * **(A14) β81 and K_in** are kept as printed (β81 = K_qo1/M_in2, K_in,ii = K_qo1 + K_in,i +
//!   K_pea,i): input plate *i* is tied to the horizontal output coordinate by the spring
//!   K_qo1 of Eq. (33), which is the reaction of the force K_qo1(x_in,i − q_o1) that Eq. (31)
//!   applies to the output mass (rows 5 and 7–8 are then reciprocal). The vertical lever
//!   (α K_qo2) has no reaction on the plates in the paper's model; that non-reciprocity is
//!   kept, since it is part of the design model, and it makes B a cascade of a stable
//!   (q_o1, x_in) block and a stable q_o2 oscillator.
//!
//! The **cross terms** of Eq. (30) (left as Δ_q in the paper) are a coupling spring k_c
//! between the two output directions: M q̈_o1 gets −k_c q_o2 and M q̈_o2 gets −k_c q_o1
//! (symmetric, hence passive). The controller's model has k_c = 0; the simulated plant
//! does not ([`StageModel::with_coupling`]).

use flexstage_scenario::StageParams;
use nalgebra::{DMatrix, Matrix2, SMatrix, SVector};

/// Where the components of the state z are (module docs). The first six are also the
/// backstepping state η = [q_o, ξ, q̇_o] with ξ = x_in (Section 3.2.2), and a state's index
/// is the row of B that gives its derivative.
pub mod state {
    /// Output displacements q_o1, q_o2.
    pub const Q_O: [usize; 2] = [0, 1];
    /// Input-plate displacements x_in1, x_in2 (ξ of the backstepping law).
    pub const X_IN: [usize; 2] = [2, 3];
    /// Output velocities q̇_o1, q̇_o2.
    pub const Q_O_DOT: [usize; 2] = [4, 5];
    /// Input-plate velocities ẋ_in1, ẋ_in2.
    pub const X_IN_DOT: [usize; 2] = [6, 7];
}

use crate::error::{ControlError, Result, check, non_negative, positive};

/// 8 × 8 matrix.
pub type Matrix8 = SMatrix<f64, 8, 8>;
/// 8 × 2 matrix.
pub type Matrix8x2 = SMatrix<f64, 8, 2>;
/// 8-vector.
pub type Vector8 = SVector<f64, 8>;

/// The linear model of Eq. (36): B, D and b = [0; D], built from a parameter set.
#[derive(Debug, Clone, PartialEq)]
pub struct StageModel {
    /// The parameters (SI).
    pub params: StageParams,
    /// Cross-coupling stiffness k_c of Eq. (30) [N/m] (0 for the design model).
    pub coupling: f64,
    /// B = \[β_ij\], (A14).
    pub b: Matrix8,
    /// D = \[d_ij\], (A14).
    pub d: Matrix2<f64>,
}

impl StageModel {
    /// The design model of Eq. (36) (no cross terms).
    pub fn new(params: &StageParams) -> Result<StageModel> {
        StageModel::with_coupling(params, 0.0)
    }

    /// The model with the cross terms of Eq. (30): a coupling spring `k_c` [N/m] between the
    /// two output directions.
    pub fn with_coupling(params: &StageParams, k_c: f64) -> Result<StageModel> {
        validate(params)?;
        check("coupling", k_c, k_c.is_finite(), "a finite stiffness [N/m]")?;
        let p = params;
        let m = p.mass;
        let mut b = Matrix8::zeros();
        // Kinematics (A13): ż1..4 = z5..8.
        for i in 0..4 {
            b[(i, i + 4)] = 1.0;
        }
        // Row 5 (q̈_o1), Eq. (31) with A0 row [1/2, 1/2] and K = 2 K_qo1.
        b[(4, 0)] = -2.0 * p.k_qo1 / m;
        b[(4, 2)] = p.k_qo1 / m;
        b[(4, 3)] = p.k_qo1 / m;
        b[(4, 4)] = -2.0 * p.c_qo1 / m;
        b[(4, 6)] = p.c_qo1 / m;
        b[(4, 7)] = p.c_qo1 / m;
        // Row 6 (q̈_o2), Eq. (31) with A0 row [α, −α].
        b[(5, 1)] = -p.k_qo2 / m;
        b[(5, 2)] = p.alpha * p.k_qo2 / m;
        b[(5, 3)] = -p.alpha * p.k_qo2 / m;
        b[(5, 5)] = -p.c_qo2 / m;
        b[(5, 6)] = p.alpha * p.c_qo2 / m;
        b[(5, 7)] = -p.alpha * p.c_qo2 / m;
        // Cross terms of Eq. (30).
        b[(4, 1)] = -k_c / m;
        b[(5, 0)] = -k_c / m;
        // Rows 7–8 (ẍ_in), Eq. (34)–(35).
        let plates = [
            (p.k_in1, p.k_pea1, p.m_in1, p.c_in1),
            (p.k_in2, p.k_pea2, p.m_in2, p.c_in2),
        ];
        for (i, &(k_in, k_pea, m_in, c_in)) in plates.iter().enumerate() {
            let r = 6 + i;
            b[(r, 0)] = p.k_qo1 / m_in;
            b[(r, 2 + i)] = -(k_in + k_pea + p.k_qo1) / m_in;
            b[(r, 4)] = p.c_qo1 / m_in;
            b[(r, 6 + i)] = -(c_in + p.c_qo1) / m_in;
        }
        let d = Matrix2::new(p.k_pea1 / p.m_in1, 0.0, 0.0, p.k_pea2 / p.m_in2);
        Ok(StageModel {
            params: p.clone(),
            coupling: k_c,
            b,
            d,
        })
    }

    /// b = [0; D] (8 × 2), Eq. (38).
    pub fn input_matrix(&self) -> Matrix8x2 {
        let mut bu = Matrix8x2::zeros();
        bu[(6, 0)] = self.d[(0, 0)];
        bu[(6, 1)] = self.d[(0, 1)];
        bu[(7, 0)] = self.d[(1, 0)];
        bu[(7, 1)] = self.d[(1, 1)];
        bu
    }

    /// The gain G of the virtual input ξ = x_in in the output accelerations (rows 5–6,
    /// columns 3–4 of B): G = [[θ1, θ1], [αθ2, −αθ2]], θ1 = K_qo1/M, θ2 = K_qo2/M (A24).
    pub fn g(&self) -> Matrix2<f64> {
        Matrix2::new(
            self.b[(4, 2)],
            self.b[(4, 3)],
            self.b[(5, 2)],
            self.b[(5, 3)],
        )
    }

    /// B as a dynamic matrix.
    pub fn b_dyn(&self) -> DMatrix<f64> {
        DMatrix::from_column_slice(8, 8, self.b.as_slice())
    }

    /// b = [0; D] as a dynamic matrix.
    pub fn input_dyn(&self) -> DMatrix<f64> {
        DMatrix::from_column_slice(8, 2, self.input_matrix().as_slice())
    }

    /// The static gain from x_nom to the output q: q = G_dc x_nom at equilibrium,
    /// G_dc = −C B⁻¹ b with C selecting z1, z2.
    pub fn dc_gain(&self) -> Result<Matrix2<f64>> {
        let inv = self
            .b
            .try_inverse()
            .ok_or_else(|| ControlError::Singular { what: "B".into() })?;
        let x = -(inv * self.input_matrix());
        Ok(Matrix2::new(x[(0, 0)], x[(0, 1)], x[(1, 0)], x[(1, 1)]))
    }

    /// Undamped natural frequencies \[Hz\] of the three mode families of the design model:
    /// horizontal output (2K_qo1/M), vertical output (K_qo2/M) and the PEA / input plate
    /// ((K_in1 + K_pea1 + K_qo1)/m_in1), for documentation and checks.
    pub fn natural_frequencies(&self) -> [f64; 3] {
        let p = &self.params;
        let f = |k: f64, m: f64| (k / m).sqrt() / std::f64::consts::TAU;
        [
            f(2.0 * p.k_qo1, p.mass),
            f(p.k_qo2, p.mass),
            f(p.k_in1 + p.k_pea1 + p.k_qo1, p.m_in1),
        ]
    }
}

/// The least share of an axis's static gain a mode carries to be the axis's mode of a
/// [`ResponseFit`] (what `ControllerParams::for_sampled_plant` and the response
/// identification use).
pub const RESPONSE_SHARE: f64 = 0.1;

/// What a frequency-response identification of the stage gives, to fit the lumped model
/// to ([`fit_to_response`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResponseFit {
    /// Static gain x_nom → q, rows q_o1, q_o2 (dimensionless).
    pub dc_gain: [[f64; 2]; 2],
    /// First output mode of q_o1 and of q_o2 \[Hz\], > 0; `None` when the sampled response
    /// shows none below Nyquist (that axis's stiffness is then kept from the design).
    pub frequency: [Option<f64>; 2],
    /// Their damping ratios, in [0, 1) (used only with a frequency).
    pub damping: [f64; 2],
}

impl ResponseFit {
    /// What a frequency-response identification below Nyquist reads off a modal plant
    /// (e.g. the twin's modes): the static gain Σ out inᵀ/ω², and per output axis the
    /// lowest mode below `nyquist` \[Hz\] whose share of that axis's static gain is at least
    /// `share` (in (0, 1]). An axis with no such mode (its flexibility sits in modes above
    /// Nyquist, which the sampled response shows only folded) gets `None`: its mode is not
    /// identifiable from the sampled response and is not fitted.
    pub fn from_modes(modes: &[crate::tuning::PlantMode], nyquist: f64, share: f64) -> ResponseFit {
        let mut g = [[0.0; 2]; 2];
        for m in modes {
            let w2 = (std::f64::consts::TAU * m.frequency).powi(2);
            for i in 0..2 {
                for j in 0..2 {
                    g[i][j] += m.output[i] * m.input[j] / w2;
                }
            }
        }
        let mut frequency = [None; 2];
        let mut damping = [0.0; 2];
        for i in 0..2 {
            let axis = |m: &crate::tuning::PlantMode| {
                let w2 = (std::f64::consts::TAU * m.frequency).powi(2);
                let drive = if i == 0 {
                    m.input[0] + m.input[1]
                } else {
                    m.input[0] - m.input[1]
                };
                m.output[i] * drive / w2
            };
            let total = g[i][0] + if i == 0 { g[i][1] } else { -g[i][1] };
            if let Some(m) = modes
                .iter()
                .filter(|m| m.frequency < nyquist && axis(m) / total >= share)
                .min_by(|a, b| a.frequency.total_cmp(&b.frequency))
            {
                frequency[i] = Some(m.frequency);
                damping[i] = m.damping;
            }
        }
        ResponseFit {
            dc_gain: g,
            frequency,
            damping,
        }
    }

    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        for i in 0..2 {
            if let Some(f) = self.frequency[i] {
                positive(&format!("fit.frequency[{i}]"), f)?;
            }
            check(
                &format!("fit.damping[{i}]"),
                self.damping[i],
                (0.0..1.0).contains(&self.damping[i]),
                "a damping ratio in [0, 1)",
            )?;
            check(
                &format!("fit.dc_gain[0][{i}]"),
                self.dc_gain[0][i],
                self.dc_gain[0][i] > 0.0 && self.dc_gain[0][i] < 0.5,
                "a static gain of q_o1 in (0, 0.5) (each PEA drives half the output)",
            )?;
            check(
                &format!("fit.dc_gain[1][{i}]"),
                self.dc_gain[1][i],
                self.dc_gain[1][i].is_finite() && self.dc_gain[1][i] != 0.0,
                "a finite non-zero static gain of q_o2",
            )?;
        }
        Ok(())
    }
}

/// The lumped parameters fitted to a measured response (the PEA stiffnesses and plate
/// masses of `guess` kept): the symmetric static gain (rows averaged over the two PEAs) and
/// the output modes that the response shows. An axis without a mode keeps the design's
/// stiffness (K_qo1 or K_qo2) and damping ratio; without the q_o2 mode the mass is kept too.
///
/// With the plates statically condensed (their modes, ≈ 12 kHz, are far above the output
/// modes), Eq. (31)–(35) give, with k_p = K_in + K_pea:
///
/// ```text
/// G_dc,1i = K_pea / (2 k_p)                → K_in = K_pea (1/(2 g₁) − 1)
/// G_dc,2i = ± α K_pea / (k_p + K_qo1)      → α = g₂ (k_p + K_qo1) / K_pea
/// ω₁² = 2 K_qo1 k_p / ((k_p + K_qo1) M)    → K_qo1 = K₁ k_p / (2 k_p − K₁), K₁ = M ω₁²
/// ω₂² = K_qo2 / M                          → M = K_qo2 / ω₂² (K_qo2 kept)
/// C_qo1 = ζ₁ √(K₁ M) (two dampers in parallel), C_qo2 = 2 ζ₂ √(K_qo2 M)
/// ```
///
/// The fit is exact for the static gain and within the plates' mass effect (≪ 1 %) for the
/// modes (`tests/model.rs`). Errors when ω₁ needs K₁ ≥ 2 k_p (no stiffness can give it).
pub fn fit_to_response(guess: &StageParams, fit: &ResponseFit) -> Result<StageParams> {
    validate(guess)?;
    fit.validate()?;
    let mut p = guess.clone();
    let g1 = 0.5 * (fit.dc_gain[0][0] + fit.dc_gain[0][1]);
    let g2 = 0.5 * (fit.dc_gain[1][0] - fit.dc_gain[1][1]);
    let tau = std::f64::consts::TAU;
    if let Some(f2) = fit.frequency[1] {
        p.mass = guess.k_qo2 / (tau * f2).powi(2);
        p.c_qo2 = 2.0 * fit.damping[1] * (p.k_qo2 * p.mass).sqrt();
    } else {
        // The design's damping ratio at the kept stiffness and mass.
        p.c_qo2 = guess.c_qo2;
    }
    p.k_in1 = p.k_pea1 * (0.5 / g1 - 1.0);
    p.k_in2 = p.k_pea2 * (0.5 / g1 - 1.0);
    let k_p = 0.5 * (p.k_in1 + p.k_pea1 + p.k_in2 + p.k_pea2);
    if let Some(f1) = fit.frequency[0] {
        let k1 = p.mass * (tau * f1).powi(2);
        check(
            "fit.frequency[0]",
            f1,
            k1 < 2.0 * k_p,
            "a q_o1 mode below the one of rigid output springs, √(2 k_p / M)",
        )?;
        p.k_qo1 = k1 * k_p / (2.0 * k_p - k1);
        p.c_qo1 = fit.damping[0] * (k1 * p.mass).sqrt();
    } else {
        // Same damping ratio as the design at the new mass.
        p.c_qo1 = guess.c_qo1 * (p.mass / guess.mass).sqrt();
    }
    p.alpha = g2 * (k_p + p.k_qo1) / (0.5 * (p.k_pea1 + p.k_pea2));
    validate(&p)?;
    Ok(p)
}

/// The coupling stiffness k_c of Eq. (30) that reproduces the cross terms of a measured
/// static gain `dc_gain` (rows q_o1, q_o2; columns PEA 1, 2) on the model `params`.
///
/// Without coupling the model's q_o1 responds equally to both PEAs and q_o2 oppositely
/// (G₁₁ = G₁₂, G₂₁ = −G₂₂, the sums [`fit_to_response`] fits); the coupling shows as the
/// other halves h₁ = (G₁₁ − G₁₂)/2 and h₂ = (G₂₁ + G₂₂)/2. k_c is their least-squares fit,
/// each relative to its axis's gain, by two Gauss–Newton steps (h is smooth in k_c and
/// nearly linear at the couplings a stage has). A mirror-symmetric design has h = 0 and gets
/// k_c = 0. The result is clamped to |k_c| ≤ 0.9 √(K_qo1 K_qo2).
pub fn fit_coupling(params: &StageParams, dc_gain: [[f64; 2]; 2]) -> Result<f64> {
    validate(params)?;
    let halves = |g: [[f64; 2]; 2]| {
        let (g1, g2) = (
            0.5 * (g[0][0] + g[0][1]).abs(),
            0.5 * (g[1][0] - g[1][1]).abs(),
        );
        [
            0.5 * (g[0][0] - g[0][1]) / g1.max(f64::MIN_POSITIVE),
            0.5 * (g[1][0] + g[1][1]) / g2.max(f64::MIN_POSITIVE),
        ]
    };
    let model = |k: f64| -> Result<[f64; 2]> {
        let g = StageModel::with_coupling(params, k)?.dc_gain()?;
        Ok(halves([[g[(0, 0)], g[(0, 1)]], [g[(1, 0)], g[(1, 1)]]]))
    };
    let target = halves(dc_gain);
    let bound = 0.9 * (params.k_qo1 * params.k_qo2).sqrt();
    let step = 1e-6 * bound;
    let mut k = 0.0;
    for _ in 0..2 {
        let h = model(k)?;
        let hd = model(k + step)?;
        let s = [(hd[0] - h[0]) / step, (hd[1] - h[1]) / step];
        let den = s[0] * s[0] + s[1] * s[1];
        if den == 0.0 {
            return Ok(0.0);
        }
        k += (s[0] * (target[0] - h[0]) + s[1] * (target[1] - h[1])) / den;
        k = k.clamp(-bound, bound);
    }
    Ok(k)
}

/// Checks a parameter set (all stiffnesses and masses > 0, dampings ≥ 0, α ≠ 0).
pub fn validate(p: &StageParams) -> Result<()> {
    for (name, v) in [
        ("k_qo1", p.k_qo1),
        ("k_qo2", p.k_qo2),
        ("mass", p.mass),
        ("k_pea1", p.k_pea1),
        ("k_pea2", p.k_pea2),
        ("k_in1", p.k_in1),
        ("k_in2", p.k_in2),
        ("m_in1", p.m_in1),
        ("m_in2", p.m_in2),
    ] {
        positive(name, v)?;
    }
    for (name, v) in [
        ("c_qo1", p.c_qo1),
        ("c_qo2", p.c_qo2),
        ("c_in1", p.c_in1),
        ("c_in2", p.c_in2),
    ] {
        non_negative(name, v)?;
    }
    check("alpha", p.alpha, p.alpha != 0.0, "a finite non-zero number")
}

/// Converts a fixed-size matrix to a dynamic one.
pub fn to_dyn<const R: usize, const C: usize>(m: &SMatrix<f64, R, C>) -> DMatrix<f64> {
    DMatrix::from_column_slice(R, C, m.as_slice())
}

/// Converts a dynamic matrix of the right size to a fixed-size one.
pub fn from_dyn<const R: usize, const C: usize>(m: &DMatrix<f64>) -> SMatrix<f64, R, C> {
    assert_eq!((m.nrows(), m.ncols()), (R, C), "matrix size");
    SMatrix::<f64, R, C>::from_column_slice(m.as_slice())
}
