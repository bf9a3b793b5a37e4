//! The PEAs as the rig drives them (Eq. 18, Table A1; Section 4.1): the preload to the bias
//! voltage, the stroke the amplifier range delivers around it, and the mean slope of the
//! virgin curve. Shared by the rig's own PEAs and the controller's actuator model.

use flexstage_piezo::{BoucWenParams, MICROMETRE, advance};

/// The state (U_b, h_b) of a virgin PEA after a slow (1 s) ramp from 0 V to `u_b`, and its
/// displacement x_bias = d_p U_b − h_b \[µm\].
pub fn preload(p: &BoucWenParams, u_b: f64) -> (f64, f64, f64) {
    let h = advance(p, 0.0, 0.0, u_b, 1.0);
    (u_b, h, p.d_p * u_b - h)
}

/// The nominal stroke the amplifier range delivers around the preloaded bias: `[up, down]`
/// \[m\], the largest x_nom above and below x_bias that the PEA reaches on its major loop
/// (bias → U_max → U_min → U_max → U_min with ramps of `ramp` seconds per half range; the
/// smaller of the two visits of each end). With Table A1 and 0–1000 V this is less than the
/// ±30 µm nominal stroke of Section 4.1.
pub fn deliverable_stroke(p: &BoucWenParams, range: [f64; 2], bias: f64, ramp: f64) -> [f64; 2] {
    let (u, h, x_bias) = preload(p, bias);
    let mut pea = flexstage_piezo::BoucWen::with_state(*p, u, h);
    let up1 = pea.step(range[1], ramp);
    let down1 = pea.step(range[0], 2.0 * ramp);
    let up2 = pea.step(range[1], 2.0 * ramp);
    let down2 = pea.step(range[0], 2.0 * ramp);
    [
        (up1.min(up2) - x_bias) * MICROMETRE,
        (x_bias - down1.max(down2)) * MICROMETRE,
    ]
}

/// Mean slope κ [µm/V] of the virgin curve over the amplifier range.
pub fn mean_slope(p: &BoucWenParams, range: [f64; 2]) -> f64 {
    let x = |u: f64| p.d_p * u - advance(p, 0.0, 0.0, u, 1.0);
    (x(range[1]) - x(range[0])) / (range[1] - range[0])
}
