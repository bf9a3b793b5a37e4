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
