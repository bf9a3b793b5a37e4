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

use crate::error::{Result, SimError, check, non_negative, positive};

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
            .ok_or_else(|| SimError::Singular { what: "B".into() })?;
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
