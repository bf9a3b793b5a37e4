//! Settings with known answers, for tests and examples.

/// An actuator stage that passes x_nom through unchanged (`Compensation::Ideal`, Table A1
/// PEAs, ±1 mm stroke): for linear tests of the controllers' feedback paths.
pub fn ideal_actuator() -> crate::actuator::ActuatorParams {
    let h = flexstage_scenario::Scenario::paper().hysteresis;
    crate::actuator::ActuatorParams {
        hysteresis: [
            flexstage_piezo::BoucWenParams::from(&h.pea1),
            flexstage_piezo::BoucWenParams::from(&h.pea2),
        ],
        voltage_range: [h.voltage_min, h.voltage_max],
        bias_voltage: 0.5 * (h.voltage_min + h.voltage_max),
        stroke: 1e-3,
        compensation: crate::actuator::Compensation::Ideal,
        max_voltage_step: 0.0,
    }
}

/// Every registry controller designed on the sampled loop of two decoupled 1 %-damped modes
/// (`flexstage_sim::samples::decoupled_modes`, 10 kHz, one sample of delay) with their
/// response fit, the settings of `setup` and the default tuning: a stage on which every
/// controller of the registry is designed.
pub fn decoupled_designs(
    setup: &crate::experiment::Setup,
) -> crate::error::Result<crate::registry::Designs> {
    let modes = flexstage_sim::samples::decoupled_modes();
    let fit = flexstage_identify::response::ResponseFit::from_modes(&modes, 5000.0, 0.1);
    let plant = flexstage_sim::modal::ModalPlant::new(modes, 1e-4, 1)?;
    let stage = crate::registry::Stage::new(
        setup,
        Some(&plant),
        Some(fit),
        None,
        crate::tuning::TuningParams::default(),
    );
    crate::registry::Designs::for_stage(&stage)
}
