//! The lumped parameter set of the reduced 8-state model (Eq. 31–35, Appendix C A13–A14) in
//! the [`StageParams`] format that the control stage reads (`flexstage track --params`).
//!
//! From the design (this crate): `K_qo1`, `K_qo2` (output stiffness with the inputs held,
//! [`crate::Condensation::k_qo1`]), `M` ([`crate::design_mass`], plus the payload
//! `output.payload`, which moves with the output) and `α` (the scalar
//! amplification `½(α21 − α22)`, [`crate::Condensation::alpha_scalar`]). Not from the design:
//! `K_pea1 = K_pea2` = `scenario.actuators.stiffness`, the input plates `k_in`, `m_in` from
//! `scenario.stage.guess` (Table 4), and the damping from `scenario.stage.damping_ratio`
//! through [`StageParams::with_damping_ratio`].

use flexstage_scenario::{Scenario, StageParams};

use crate::error::{ReduceError, Result};

/// Assembles the parameter set.
pub fn stage_params(
    scenario: &Scenario,
    k_qo1: f64,
    k_qo2: f64,
    mass: f64,
    alpha: f64,
) -> Result<StageParams> {
    let g = &scenario.stage.guess;
    let p = StageParams {
        k_qo1,
        k_qo2,
        mass,
        alpha,
        k_pea1: scenario.actuators.stiffness,
        k_pea2: scenario.actuators.stiffness,
        k_in1: g.k_in1,
        k_in2: g.k_in2,
        m_in1: g.m_in1,
        m_in2: g.m_in2,
        c_qo1: 0.0,
        c_qo2: 0.0,
        c_in1: 0.0,
        c_in2: 0.0,
    }
    .with_damping_ratio(scenario.stage.damping_ratio);
    p.validate("reduce")
        .map_err(|e| ReduceError::Input(format!("the reduced parameters are not usable: {e}")))?;
    Ok(p)
}
