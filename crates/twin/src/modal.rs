//! The reduced stage in modal coordinates and its exact discretization.
//!
//! The reduced system `M_r ẍ + C_r ẋ + K_r x = f` with Rayleigh damping
//! `C_r = a_M M_r + b_K K_r` (the projection of the FE's Rayleigh damping, so the twin and the
//! full reference are damped alike) is diagonalized by the undamped modes
//! `K_r φ = ω² M_r φ`, `φᵀ M_r φ = 1` (Cholesky of `M_r`, symmetric eigen-decomposition):
//!
//! ```text
//! η̈_k + 2 ζ_k ω_k η̇_k + ω_k² η_k = φ_kᵀ f(t),   ζ_k = a_M/(2ω_k) + b_K ω_k/2
//! f = [K_pea1 x_nom1, K_pea2 x_nom2, 0, 0, 0…] − (Tᵀ M r_x) a_gx − (Tᵀ M r_y) a_gy
//! ```
//!
//! Every mode is discretized exactly for a substep h with the input linear in time (first-order
//! hold): `s₊ = Φ s + Γ p₀ + Λ (p₁ − p₀)`, `s = (η, η̇)`, from one exponential of the augmented
//! matrix `[[A, B, 0], [0, 0, 1/h], [0, 0, 0]]·h = [[Φ, Γ, Λ], [0, 1, 1], [0, 0, 1]]`
//! (Van Loan). The output and input-plate displacements are `q = Σ φ_k[out] η_k`,
//! `x_in = Σ φ_k[in] η_k`. Undamped, the discrete map is a rotation of each mode's energy
//! ellipse: energy is conserved to round-off.

use flexstage_fem::RayleighDamping;
use flexstage_sim::modal::{PlantMode, static_gain};
use nalgebra::DMatrix;

use crate::craig_bampton::CraigBampton;
use crate::error::{Result, TwinError};

/// One mode of the twin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mode {
    /// Natural frequency ω/2π \[Hz\].
    pub frequency: f64,
    /// Damping ratio ζ.
    pub damping: f64,
    /// Modal force per unit x_nom of PEA1 and PEA2 and per unit base acceleration in x and y
    /// [N/m per unit modal mass, N/(m/s²)].
    pub input: [f64; 4],
    /// Output displacement per unit modal coordinate, q1 and q2.
    pub output: [f64; 2],
    /// Input-plate displacement per unit modal coordinate, x_in1 and x_in2.
    pub plates: [f64; 2],
}

/// The reduced stage in modal coordinates.
#[derive(Debug, Clone)]
pub struct ModalStage {
    /// The modes, lowest first.
    pub modes: Vec<Mode>,
    /// The damping used.
    pub damping: RayleighDamping,
    /// Mode shapes in the reduced coordinates (column k = mode k, `φᵀ M_r φ = 1`).
    pub shapes: DMatrix<f64>,
}

impl ModalStage {
    /// The modal form of `cb` with PEA stiffnesses `k_pea` and Rayleigh `damping`.
    pub fn new(cb: &CraigBampton, k_pea: [f64; 2], damping: RayleighDamping) -> Result<ModalStage> {
        let n = cb.order();
        let chol = cb.mass.clone().cholesky().ok_or_else(|| {
            TwinError::Reduced("the reduced mass matrix is not positive definite".into())
        })?;
        let l = chol.l();
        let linv = l
            .clone()
            .try_inverse()
            .ok_or_else(|| TwinError::Reduced("singular reduced mass".into()))?;
        let a = &linv * &cb.stiffness * linv.transpose();
        let a = 0.5 * (&a + a.transpose());
        let eig = a.symmetric_eigen();
        let shapes: DMatrix<f64> = linv.transpose() * &eig.eigenvectors;
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
        let mut modes = Vec::with_capacity(n);
        let mut sorted = DMatrix::zeros(n, n);
        for (c, &k) in order.iter().enumerate() {
            sorted.set_column(c, &shapes.column(k));
            let w2 = eig.eigenvalues[k];
            if w2.is_nan() || w2 <= 0.0 {
                return Err(TwinError::Reduced(format!(
                    "the reduced stiffness is not positive definite (ω² = {w2:e})"
                )));
            }
            let w = w2.sqrt();
            let phi = shapes.column(k);
            let fx = phi.dot(&cb.floor[0]);
            let fy = phi.dot(&cb.floor[1]);
            let plates = [phi.dot(&cb.inputs[0]), phi.dot(&cb.inputs[1])];
            modes.push(Mode {
                frequency: w / std::f64::consts::TAU,
                damping: damping.mass / (2.0 * w) + damping.stiffness * w / 2.0,
                input: [plates[0] * k_pea[0], plates[1] * k_pea[1], -fx, -fy],
                output: [phi[2], phi[3]],
                plates,
            });
        }
        Ok(ModalStage {
            modes,
            damping,
            shapes: sorted,
        })
    }

    /// The modes as the rig's sampled loop sees them: the PEA inputs x_nom and the outputs q
    /// only (no base acceleration, no plates).
    pub fn plant_modes(&self) -> Vec<PlantMode> {
        self.modes
            .iter()
            .map(|m| PlantMode {
                frequency: m.frequency,
                damping: m.damping,
                input: [m.input[0], m.input[1]],
                output: m.output,
            })
            .collect()
    }

    /// Static gain x_nom → q (2 × 2), `Σ_k out_k in_kᵀ / ω_k²`.
    pub fn dc_gain(&self) -> [[f64; 2]; 2] {
        static_gain(&self.plant_modes())
    }

    /// Frequency response x_nom → q at `f` \[Hz\]: `G(jω) = Σ_k out_k in_kᵀ / (ω_k² − ω² +
    /// 2jζ_kω_kω)`, as (re, im) per entry.
    pub fn frequency_response(&self, f: f64) -> [[(f64, f64); 2]; 2] {
        let w = std::f64::consts::TAU * f;
        let mut g = [[(0.0, 0.0); 2]; 2];
        for m in &self.modes {
            let wk = std::f64::consts::TAU * m.frequency;
            let (re, im) = (wk * wk - w * w, 2.0 * m.damping * wk * w);
            let d = re * re + im * im;
            let (hr, hi) = (re / d, -im / d);
            for i in 0..2 {
                for j in 0..2 {
                    let c = m.output[i] * m.input[j];
                    g[i][j].0 += c * hr;
                    g[i][j].1 += c * hi;
                }
            }
        }
        g
    }
}

/// The exact first-order-hold discretization of one mode for substep h.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct DiscreteMode {
    /// Φ row-major.
    pub phi: [f64; 4],
    /// Γ (response to a constant unit modal force).
    pub gamma: [f64; 2],
    /// Λ (response to a unit ramp of the modal force over the substep).
    pub lambda: [f64; 2],
}

impl DiscreteMode {
    /// Van Loan's augmented exponential (module docs).
    pub(crate) fn new(mode: &Mode, h: f64) -> DiscreteMode {
        let w = std::f64::consts::TAU * mode.frequency;
        let z = mode.damping;
        let mut aug = DMatrix::<f64>::zeros(4, 4);
        aug[(0, 1)] = h;
        aug[(1, 0)] = -w * w * h;
        aug[(1, 1)] = -2.0 * z * w * h;
        aug[(1, 2)] = h; // B = [0; 1]
        aug[(2, 3)] = 1.0; // (1/h)·h
        let e = aug.exp();
        DiscreteMode {
            phi: [e[(0, 0)], e[(0, 1)], e[(1, 0)], e[(1, 1)]],
            gamma: [e[(0, 2)], e[(1, 2)]],
            lambda: [e[(0, 3)], e[(1, 3)]],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reference: the damped single-DOF response to a unit force step and ramp (e.g. Meirovitch,
    /// *Fundamentals of Vibrations*, 2001, §3.5): for η̈ + 2ζωη̇ + ω²η = p(t) from rest,
    /// step p = 1: η = (1 − e^{−ζωt}(cos ω_d t + ζω/ω_d sin ω_d t))/ω²;
    /// ramp p = t/h: η = (t − 2ζ/ω + e^{−ζωt}(2ζ/ω cos ω_d t − (1 − 2ζ²)/ω_d sin ω_d t))/(ω² h).
    /// Goal: Γ and Λ of the augmented exponential equal these closed forms at t = h.
    #[test]
    fn foh_discretization_matches_the_single_dof_closed_forms() {
        for (f, zeta, h) in [
            (3000.0, 0.01, 5e-6),
            (20_000.0, 0.3, 1e-5),
            (500.0, 0.0, 1e-4),
        ] {
            let mode = Mode {
                frequency: f,
                damping: zeta,
                input: [0.0; 4],
                output: [0.0; 2],
                plates: [0.0; 2],
            };
            let d = DiscreteMode::new(&mode, h);
            let w = std::f64::consts::TAU * f;
            let wd = w * (1.0 - zeta * zeta).sqrt();
            let e = (-zeta * w * h).exp();
            let (s, c) = (wd * h).sin_cos();
            let step = (1.0 - e * (c + zeta * w / wd * s)) / (w * w);
            let ramp = (h - 2.0 * zeta / w
                + e * (2.0 * zeta / w * c - (1.0 - 2.0 * zeta * zeta) / wd * s))
                / (w * w * h);
            assert!(
                (d.gamma[0] - step).abs() < 1e-9 * step.abs(),
                "{f}: {} vs {step}",
                d.gamma[0]
            );
            assert!(
                (d.lambda[0] - ramp).abs() < 1e-7 * ramp.abs(),
                "{f}: {} vs {ramp}",
                d.lambda[0]
            );
            // Free response: Φ₀₀ = e^{−ζωh}(cos ω_d h + ζω/ω_d sin ω_d h).
            let phi00 = e * (c + zeta * w / wd * s);
            assert!((d.phi[0] - phi00).abs() < 1e-12, "{f}");
        }
    }
}
