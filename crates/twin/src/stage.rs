//! The twin as a real-time [`Mechanics`]: every mode advanced with its exact first-order-hold
//! discretization per substep ([`crate::modal`]), the output recovered from the modes and
//! corrected for the geometric nonlinearity ([`crate::nonlinear`]). No allocation per step.

use flexstage_control::rig::Mechanics;

use crate::modal::{DiscreteMode, ModalStage};
use crate::nonlinear::NonlinearMap;

/// One mode's discrete data, packed for the step loop.
#[derive(Debug, Clone, Copy)]
struct Packed {
    phi: [f64; 4],
    gamma: [f64; 2],
    lambda: [f64; 2],
    input: [f64; 4],
    output: [f64; 2],
    plates: [f64; 2],
    omega2: f64,
}

/// The twin's mechanics for substeps of `h` (module docs).
#[derive(Debug, Clone)]
pub struct TwinStage {
    h: f64,
    modes: Vec<Packed>,
    state: Vec<[f64; 2]>,
    nonlinear: Option<NonlinearMap>,
}

impl TwinStage {
    /// The mechanics of `modal` (and the nonlinear correction, if any) for substep `h` [s],
    /// at rest.
    pub fn new(modal: &ModalStage, nonlinear: Option<NonlinearMap>, h: f64) -> TwinStage {
        let modes = modal
            .modes
            .iter()
            .map(|m| {
                let d = DiscreteMode::new(m, h);
                Packed {
                    phi: d.phi,
                    gamma: d.gamma,
                    lambda: d.lambda,
                    input: m.input,
                    output: m.output,
                    plates: m.plates,
                    omega2: (std::f64::consts::TAU * m.frequency).powi(2),
                }
            })
            .collect::<Vec<_>>();
        TwinStage {
            h,
            state: vec![[0.0; 2]; modes.len()],
            modes,
            nonlinear,
        }
    }

    /// Number of modes.
    pub fn order(&self) -> usize {
        self.modes.len()
    }

    /// The modal state (η, η̇) of every mode.
    pub fn modal_state(&self) -> &[[f64; 2]] {
        &self.state
    }

    /// Sets the modal state (η, η̇) of every mode (length = [`TwinStage::order`]).
    pub fn set_modal_state(&mut self, state: &[[f64; 2]]) {
        self.state.copy_from_slice(state);
    }

    /// The mechanical energy `Σ ½(η̇² + ω² η²)` of the reduced system [J] (modes are
    /// mass-normalized).
    pub fn energy(&self) -> f64 {
        self.modes
            .iter()
            .zip(&self.state)
            .map(|(m, s)| 0.5 * (s[1] * s[1] + m.omega2 * s[0] * s[0]))
            .sum()
    }

    /// The linear output (without the nonlinear correction) [m].
    #[inline]
    pub fn linear_output(&self) -> [f64; 2] {
        let mut q = [0.0; 2];
        for (m, s) in self.modes.iter().zip(&self.state) {
            q[0] += m.output[0] * s[0];
            q[1] += m.output[1] * s[0];
        }
        q
    }
}

impl Mechanics for TwinStage {
    fn substep_time(&self) -> f64 {
        self.h
    }

    #[inline]
    fn advance(&mut self, x_nom: [[f64; 2]; 2], floor: [[f64; 2]; 2]) {
        let quiet = floor == [[0.0; 2]; 2];
        for (m, s) in self.modes.iter().zip(self.state.iter_mut()) {
            let mut p0 = m.input[0] * x_nom[0][0] + m.input[1] * x_nom[0][1];
            let mut p1 = m.input[0] * x_nom[1][0] + m.input[1] * x_nom[1][1];
            if !quiet {
                p0 += m.input[2] * floor[0][0] + m.input[3] * floor[0][1];
                p1 += m.input[2] * floor[1][0] + m.input[3] * floor[1][1];
            }
            let dp = p1 - p0;
            let (e, v) = (s[0], s[1]);
            s[0] = m.phi[0] * e + m.phi[1] * v + m.gamma[0] * p0 + m.lambda[0] * dp;
            s[1] = m.phi[2] * e + m.phi[3] * v + m.gamma[1] * p0 + m.lambda[1] * dp;
        }
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
        let mut x = [0.0; 2];
        for (m, s) in self.modes.iter().zip(&self.state) {
            x[0] += m.plates[0] * s[0];
            x[1] += m.plates[1] * s[0];
        }
        x
    }
}
