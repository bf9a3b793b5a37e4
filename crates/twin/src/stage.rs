//! The twin as a real-time [`Mechanics`]: every mode advanced with its exact first-order-hold
//! discretization per substep ([`crate::modal`]), the output recovered from the modes and
//! corrected for the geometric nonlinearity ([`crate::nonlinear`]). No allocation per step.

use flexstage_control::rig::Mechanics;
use multiversion::multiversion;

use crate::modal::{DiscreteMode, ModalStage};
use crate::nonlinear::NonlinearMap;

/// The modes' discrete data as structure-of-arrays, so that the per-substep update of all
/// modes is a handful of element-wise vector operations (compiled for AVX2 + FMA and
/// AVX-512 besides baseline x86-64, chosen at run time).
#[derive(Debug, Clone, Default)]
struct Modes {
    phi: [Vec<f64>; 4],
    gamma: [Vec<f64>; 2],
    lambda: [Vec<f64>; 2],
    input: [Vec<f64>; 4],
    output: [Vec<f64>; 2],
    plates: [Vec<f64>; 2],
    omega2: Vec<f64>,
    /// 1/ω² (quasi-static modal compliance).
    compliance: Vec<f64>,
    /// ∂(ω²)/∂x_in per mode (zeros for the linear twin).
    stiffening: [Vec<f64>; 2],
}

/// The twin's mechanics for substeps of `h` (module docs).
#[derive(Debug, Clone)]
pub struct TwinStage {
    h: f64,
    modes: Modes,
    eta: Vec<f64>,
    rate: Vec<f64>,
    nonlinear: Option<NonlinearMap>,
}

/// One substep of every mode: `s₊ = Φ s + Γ p₀ + Λ (p₁ − p₀)` with `p = in·u` minus the
/// operating-point stiffening `(s·x_in)(η − p₀/ω²)` held over the substep
/// ([`crate::nonlinear`]).
#[multiversion(targets("x86_64+avx512f+avx512vl+avx2+fma", "x86_64+avx2+fma"))]
fn advance_modes(
    m: &Modes,
    eta: &mut [f64],
    rate: &mut [f64],
    u0: [f64; 4],
    u1: [f64; 4],
    x_in: [f64; 2],
) {
    let n = eta.len();
    let [i0, i1, i2, i3] = [
        &m.input[0][..n],
        &m.input[1][..n],
        &m.input[2][..n],
        &m.input[3][..n],
    ];
    let [a00, a01, a10, a11] = [
        &m.phi[0][..n],
        &m.phi[1][..n],
        &m.phi[2][..n],
        &m.phi[3][..n],
    ];
    let [g0, g1, l0, l1] = [
        &m.gamma[0][..n],
        &m.gamma[1][..n],
        &m.lambda[0][..n],
        &m.lambda[1][..n],
    ];
    let [s0, s1, c] = [
        &m.stiffening[0][..n],
        &m.stiffening[1][..n],
        &m.compliance[..n],
    ];
    for k in 0..n {
        let mut p0 = i0[k] * u0[0] + i1[k] * u0[1] + i2[k] * u0[2] + i3[k] * u0[3];
        let mut p1 = i0[k] * u1[0] + i1[k] * u1[1] + i2[k] * u1[2] + i3[k] * u1[3];
        let g = (s0[k] * x_in[0] + s1[k] * x_in[1]) * (eta[k] - p0 * c[k]);
        p0 -= g;
        p1 -= g;
        let dp = p1 - p0;
        let (e, v) = (eta[k], rate[k]);
        eta[k] = a00[k] * e + a01[k] * v + g0[k] * p0 + l0[k] * dp;
        rate[k] = a10[k] * e + a11[k] * v + g1[k] * p0 + l1[k] * dp;
    }
}

/// `(Σ a_k η_k, Σ b_k η_k)`, four independent partial sums per output (no dependency chain
/// through one accumulator).
#[inline]
fn dot2(a: &[f64], b: &[f64], eta: &[f64]) -> [f64; 2] {
    let n = eta.len();
    let (a, b) = (&a[..n], &b[..n]);
    let mut sa = [0.0; 4];
    let mut sb = [0.0; 4];
    let chunks = n / 4;
    for c in 0..chunks {
        for l in 0..4 {
            let k = 4 * c + l;
            sa[l] += a[k] * eta[k];
            sb[l] += b[k] * eta[k];
        }
    }
    for k in 4 * chunks..n {
        sa[0] += a[k] * eta[k];
        sb[0] += b[k] * eta[k];
    }
    [
        (sa[0] + sa[1]) + (sa[2] + sa[3]),
        (sb[0] + sb[1]) + (sb[2] + sb[3]),
    ]
}

impl TwinStage {
    /// The mechanics of `modal` (and the nonlinear correction, if any) for substep `h` \[s\],
    /// at rest.
    pub fn new(modal: &ModalStage, nonlinear: Option<NonlinearMap>, h: f64) -> TwinStage {
        let mut m = Modes::default();
        for mode in &modal.modes {
            let d = DiscreteMode::new(mode, h);
            for i in 0..4 {
                m.phi[i].push(d.phi[i]);
                m.input[i].push(mode.input[i]);
            }
            for i in 0..2 {
                m.gamma[i].push(d.gamma[i]);
                m.lambda[i].push(d.lambda[i]);
                m.output[i].push(mode.output[i]);
                m.plates[i].push(mode.plates[i]);
            }
            let w2 = (std::f64::consts::TAU * mode.frequency).powi(2);
            m.omega2.push(w2);
            m.compliance.push(1.0 / w2);
        }
        let n = modal.modes.len();
        m.stiffening = [vec![0.0; n], vec![0.0; n]];
        if let Some(nl) = &nonlinear {
            for (k, s) in nl.stiffening.iter().enumerate().take(n) {
                m.stiffening[0][k] = s[0];
                m.stiffening[1][k] = s[1];
            }
        }
        TwinStage {
            h,
            modes: m,
            eta: vec![0.0; n],
            rate: vec![0.0; n],
            nonlinear,
        }
    }

    /// Number of modes.
    pub fn order(&self) -> usize {
        self.eta.len()
    }

    /// The modal state (η, η̇) of every mode.
    pub fn modal_state(&self) -> Vec<[f64; 2]> {
        self.eta
            .iter()
            .zip(&self.rate)
            .map(|(e, v)| [*e, *v])
            .collect()
    }

    /// Sets the modal state (η, η̇) of every mode (length = [`TwinStage::order`]).
    pub fn set_modal_state(&mut self, state: &[[f64; 2]]) {
        for (k, s) in state.iter().enumerate() {
            self.eta[k] = s[0];
            self.rate[k] = s[1];
        }
    }

    /// The mechanical energy `Σ ½(η̇² + ω² η²)` of the reduced system \[J\] (modes are
    /// mass-normalized).
    pub fn energy(&self) -> f64 {
        (0..self.order())
            .map(|k| 0.5 * (self.rate[k].powi(2) + self.modes.omega2[k] * self.eta[k].powi(2)))
            .sum()
    }

    /// The linear output (without the nonlinear correction) \[m\].
    #[inline]
    pub fn linear_output(&self) -> [f64; 2] {
        dot2(&self.modes.output[0], &self.modes.output[1], &self.eta)
    }
}

impl Mechanics for TwinStage {
    fn substep_time(&self) -> f64 {
        self.h
    }

    #[inline]
    fn advance(&mut self, x_nom: [[f64; 2]; 2], floor: [[f64; 2]; 2]) {
        let u0 = [x_nom[0][0], x_nom[0][1], floor[0][0], floor[0][1]];
        let u1 = [x_nom[1][0], x_nom[1][1], floor[1][0], floor[1][1]];
        let x_in = if self.nonlinear.is_some() {
            self.inputs()
        } else {
            [0.0; 2]
        };
        advance_modes(&self.modes, &mut self.eta, &mut self.rate, u0, u1, x_in);
    }

    #[inline]
    fn output(&self) -> [f64; 2] {
        let mut q = self.linear_output();
        if let Some(nl) = &self.nonlinear {
            let d = nl.correction(self.inputs());
            q[0] += d[0];
            q[1] += d[1];
        }
        q
    }

    #[inline]
    fn inputs(&self) -> [f64; 2] {
        dot2(&self.modes.plates[0], &self.modes.plates[1], &self.eta)
    }
}
