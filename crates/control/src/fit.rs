//! The controller's lumped model fitted to what a frequency-response identification
//! measures ([`ResponseFit`]: the static gain and the output modes below Nyquist), and the
//! cross-axis coupling of Eq. (30) that reproduces the measured static cross terms.

use flexstage_identify::response::ResponseFit;
use flexstage_scenario::StageParams;
use flexstage_sim::model::{StageModel, validate};

use crate::error::{Result, check};

/// The controller's lumped model on a stage with the response fit `fit`: `model` fitted to
/// it ([`fit_to_response`]; kept when the fit is refused) and the coupling k_c that
/// reproduces its static cross terms ([`fit_coupling`]; `coupling` kept when refused). A
/// mirror-symmetric design gets k_c = 0: a coupling identified on another plant is not this
/// one's.
pub fn fitted_model(model: &StageParams, coupling: f64, fit: &ResponseFit) -> (StageParams, f64) {
    let m = fit_to_response(model, fit).unwrap_or_else(|_| model.clone());
    let k_c = fit_coupling(&m, fit.dc_gain).unwrap_or(coupling);
    (m, k_c)
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
