//! Synthetic records: the model driven by a waveform, plus Gaussian sensor noise
//! ([`GaussianNoise`] of `flexstage-numerics`, re-exported here).

pub use flexstage_numerics::noise::GaussianNoise;

use crate::data::PeaData;
use crate::error::{Result, check};
use crate::hysteresis::Waveform;
use crate::model::{BoucWenParams, simulate};

/// A synthetic record: the virgin actuator `params` driven by `waveform` \[V\] sampled every
/// `dt` \[s\], with Gaussian noise of standard deviation `noise_std` \[µm\] added to x.
pub fn synthesize(
    params: &BoucWenParams,
    waveform: &Waveform,
    dt: f64,
    noise_std: f64,
    seed: u64,
) -> Result<PeaData> {
    params.validate()?;
    waveform.validate()?;
    check("dt", dt, dt > 0.0, "a finite number > 0 [s]")?;
    check(
        "noise_std",
        noise_std,
        noise_std >= 0.0,
        "a finite number ≥ 0 [µm]",
    )?;
    let (t, u) = waveform.sample(dt);
    let mut x = simulate(params, &t, &u, 0.0);
    if noise_std > 0.0 {
        let mut noise = GaussianNoise::new(noise_std, seed);
        for v in x.iter_mut() {
            *v += noise.sample();
        }
    }
    PeaData::new(t, u, x)
}
