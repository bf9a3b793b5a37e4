//! Synthetic records: the model driven by a waveform, plus Gaussian sensor noise.

use rand_chacha::ChaCha8Rng;
use rand_core::{RngCore, SeedableRng};

use crate::data::PeaData;
use crate::error::{Result, check};
use crate::hysteresis::Waveform;
use crate::model::{BoucWenParams, simulate};

/// Gaussian white noise from a seeded ChaCha8 generator (Box–Muller), reproducible across
/// platforms.
#[derive(Debug, Clone)]
pub struct GaussianNoise {
    rng: ChaCha8Rng,
    std: f64,
    spare: Option<f64>,
}

impl GaussianNoise {
    /// Noise of standard deviation `std` (≥ 0) from `seed`.
    pub fn new(std: f64, seed: u64) -> Self {
        GaussianNoise {
            rng: ChaCha8Rng::seed_from_u64(seed),
            std,
            spare: None,
        }
    }

    fn uniform(&mut self) -> f64 {
        // 53 random bits in (0, 1].
        ((self.rng.next_u64() >> 11) as f64 + 1.0) * (1.0 / (1u64 << 53) as f64)
    }

    /// The next sample.
    pub fn sample(&mut self) -> f64 {
        if let Some(z) = self.spare.take() {
            return self.std * z;
        }
        let (u1, u2) = (self.uniform(), self.uniform());
        let r = (-2.0 * u1.ln()).sqrt();
        let a = std::f64::consts::TAU * u2;
        self.spare = Some(r * a.sin());
        self.std * r * a.cos()
    }
}

/// A synthetic record: the virgin actuator `params` driven by `waveform` [V] sampled every
/// `dt` [s], with Gaussian noise of standard deviation `noise_std` [µm] added to x.
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
