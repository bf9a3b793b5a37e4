//! What a lab measures of the loop between its samples: the sensor recorded by a faster ADC
//! (an oscilloscope or DAQ on the sensor's analog output at L × f_s) during the response
//! experiment while the DAC holds the command at f_s, and the lifted response estimated from
//! it ([`LiftedResponse`]).
//!
//! The lifted response G_p(e^{jωT}), p = 0..L−1, is the response from the held command to the
//! output at kT + pT/L: the L phases of one sample. Its harmonics
//! H_m(f) = Σ_p G_p e^{−j2π f_m pT/L} / L (f_m = f + m f_s folded into the fast band) are the
//! output's content at f_m per unit command at f; H_0 is what the samples see at f, and
//! H_{−1} the hold's image at f_s − f (the mode above Nyquist the loop sees folded).
//! The sensor's datasheet filter is divided out harmonic by harmonic, so the lifted response
//! is that of the stage's output, not of the filtered reading.
//!
//! Only the analog sensor output enters, through the fast ADC's own white noise
//! ([`FastAdc`]): no truth of the simulation.

use flexstage_numerics::DataError;
use flexstage_sim::experiment::Command;
use flexstage_sim::rig::{Mechanics, RigPlant, SensorParams};

use crate::error::{IdentifyError, Result, check};
use crate::frequency::C64;
use crate::measured::multisine::period_statistics;
use crate::measured::{
    FastChannel, LabLog, MeasuredLine, MultisinePlan, dft_with, inverse, mul, twiddles,
};

/// The lab's fast ADC on the sensor's analog output.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FastAdc {
    /// Samples per controller sample L, 1–64; the rig's substeps must be a multiple of it.
    pub ratio: usize,
    /// White noise of each fast sample per axis \[m\], ≥ 0.
    pub noise_std: [f64; 2],
    /// Seed of that noise.
    pub seed: u64,
}

impl FastAdc {
    /// Checks the fields against `substeps` of the rig.
    pub fn validate(&self, substeps: usize) -> Result<()> {
        check(
            "fast_adc.ratio",
            self.ratio as f64,
            (1..=64).contains(&self.ratio) && substeps % self.ratio == 0,
            &format!("1–64 and a divisor of the rig's {substeps} substeps"),
        )?;
        for v in self.noise_std {
            check(
                "fast_adc.noise_std",
                v,
                v >= 0.0 && v.is_finite(),
                "≥ 0 [m]",
            )?;
        }
        Ok(())
    }
}

/// A [`LabLog`] with the fast ADC's record of the readings: `fast[i][k L + p]` is axis i at
/// kT + pT/L.
#[derive(Debug, Clone, PartialEq)]
pub struct FastLog {
    /// The log at the controller's rate.
    pub log: LabLog,
    /// L.
    pub ratio: usize,
    /// The fast readings \[m\], L per sample.
    pub fast: [Vec<f64>; 2],
}

/// [`crate::measured::run_log`] with the fast ADC `adc` recording the sensor's analog output
/// ([`RigPlant::sensed`]) L times per sample, each with its white noise: the same
/// [`FastChannel`] that records a scan while the loop runs.
pub fn run_fast_log<M: Mechanics>(
    plant: &mut RigPlant<M>,
    sample_time: f64,
    commands: &[[f64; 2]],
    mut voltage: impl FnMut([f64; 2]) -> [f64; 2],
    adc: &FastAdc,
) -> Result<FastLog> {
    let mut channel = FastChannel::attach(adc, plant)?;
    let n = commands.len();
    let mut command = [Vec::with_capacity(n), Vec::with_capacity(n)];
    let mut reading = [Vec::with_capacity(n), Vec::with_capacity(n)];
    use flexstage_sim::rig::StagePlant;
    for &x in commands {
        let y = plant.measure();
        for i in 0..2 {
            command[i].push(x[i]);
            reading[i].push(y[i]);
        }
        plant.apply(&Command {
            voltage: voltage(x),
            x_nom: x,
            reference: [0.0; 2],
            saturated: false,
            dropout: false,
        });
        channel.record(plant);
    }
    Ok(FastLog {
        log: LabLog::new(sample_time, command, reading)?,
        ratio: adc.ratio,
        fast: channel.into_samples(n),
    })
}

/// The lifted response at one line: one [`MeasuredLine`] per phase p (all at the line's f).
#[derive(Debug, Clone, PartialEq)]
pub struct LiftedLine {
    /// Frequency \[Hz\].
    pub f: f64,
    /// G_p, p = 0..L−1, with coherence and standard deviation.
    pub phase: Vec<MeasuredLine>,
}

/// The lifted response of the output (module docs). Built only from two [`FastLog`]s or
/// read from its file ([`LiftedResponse::from_csv`]).
#[derive(Debug, Clone, PartialEq)]
pub struct LiftedResponse {
    sample_time: f64,
    ratio: usize,
    lines: Vec<LiftedLine>,
}

/// The frequency \[Hz\] of harmonic m of line `f` at sample time `t` with L = `ratio`:
/// f + m/T folded into (−L/2T, L/2T].
pub fn harmonic_frequency(f: f64, m: usize, ratio: usize, t: f64) -> f64 {
    let fm = f + m as f64 / t;
    if fm * t > ratio as f64 / 2.0 {
        fm - ratio as f64 / t
    } else {
        fm
    }
}

impl LiftedResponse {
    /// The lifted response of the output from the two fast logs of `plan` (as
    /// [`crate::measured::MeasuredResponse::from_multisine`], phase by phase), with the
    /// sensor chain `datasheet` divided out of every harmonic (module docs).
    pub fn from_multisine(
        logs: [&FastLog; 2],
        plan: &MultisinePlan,
        datasheet: &SensorParams,
    ) -> Result<LiftedResponse> {
        plan.validate()?;
        let n = plan.period;
        let l = logs[0].ratio;
        let need = (plan.settle + plan.periods) * n;
        for (j, log) in logs.iter().enumerate() {
            let rel = (log.log.sample_time() / plan.sample_time - 1.0).abs();
            if rel > 1e-9 || log.log.len() < need || log.ratio != l || log.fast[0].len() < need * l
            {
                return Err(IdentifyError::Data(DataError::new(
                    format!("fast log {}", j + 1),
                    format!(
                        "{} samples × {} at {} s; the plan plays {need} samples at {} s, \
                         both logs at one ratio",
                        log.log.len(),
                        log.ratio,
                        log.log.sample_time(),
                        plan.sample_time
                    ),
                )));
            }
        }
        let t = plan.sample_time;
        let tw = twiddles(n);
        let mut phase_buf = vec![0.0; n];
        // spectra[e][period][line] = (U (2), Y_p (2 per phase)).
        let mut spectra = vec![vec![Vec::with_capacity(plan.lines.len()); plan.periods]; 2];
        for (e, log) in logs.iter().enumerate() {
            for (pd, out) in spectra[e].iter_mut().enumerate() {
                let at = (plan.settle + pd) * n;
                let u = [0, 1].map(|i| &log.log.command()[i][at..at + n]);
                let mut ys = vec![vec![[C64::new(0.0, 0.0); 2]; plan.lines.len()]; l];
                for (p, yp) in ys.iter_mut().enumerate() {
                    for i in 0..2 {
                        for (m, v) in phase_buf.iter_mut().enumerate() {
                            *v = log.fast[i][(at + m) * l + p];
                        }
                        for (li, &k) in plan.lines.iter().enumerate() {
                            yp[li][i] = dft_with(&phase_buf, k, &tw);
                        }
                    }
                }
                for (li, &k) in plan.lines.iter().enumerate() {
                    let uk = u.map(|x| dft_with(x, k, &tw));
                    out.push((uk, (0..l).map(|p| ys[p][li]).collect::<Vec<_>>()));
                }
            }
        }
        let mut lines = Vec::with_capacity(plan.lines.len());
        for (li, &k) in plan.lines.iter().enumerate() {
            let f = plan.frequency(k);
            // Per period, the per-phase responses with the sensor divided out.
            let mut per_phase: Vec<Vec<[[C64; 2]; 2]>> = vec![Vec::with_capacity(plan.periods); l];
            for pd in 0..plan.periods {
                let (a, b) = (&spectra[0][pd][li], &spectra[1][pd][li]);
                let u = [[a.0[0], b.0[0]], [a.0[1], b.0[1]]];
                let Some(ui) = inverse(u) else {
                    return Err(IdentifyError::Data(DataError::new(
                        "fast logs",
                        format!(
                            "the commands of the two experiments are not independent at {f} Hz \
                             (period {pd})"
                        ),
                    )));
                };
                let g: Vec<[[C64; 2]; 2]> = (0..l)
                    .map(|p| {
                        let y = [[a.1[p][0], b.1[p][0]], [a.1[p][1], b.1[p][1]]];
                        mul(y, ui)
                    })
                    .collect();
                let g = divide_sensor(&g, f, t, datasheet);
                for (p, gp) in g.into_iter().enumerate() {
                    per_phase[p].push(gp);
                }
            }
            lines.push(LiftedLine {
                f,
                phase: per_phase
                    .iter()
                    .map(|hs| period_statistics(f, hs))
                    .collect(),
            });
        }
        Ok(LiftedResponse {
            sample_time: t,
            ratio: l,
            lines,
        })
    }

    /// The lines as estimated or read from a file (checked by the caller).
    pub(crate) fn from_parts(sample_time: f64, ratio: usize, lines: Vec<LiftedLine>) -> Self {
        LiftedResponse {
            sample_time,
            ratio,
            lines,
        }
    }

    /// The controller's sample time T \[s\].
    pub fn sample_time(&self) -> f64 {
        self.sample_time
    }

    /// L.
    pub fn ratio(&self) -> usize {
        self.ratio
    }

    /// The lines, by frequency.
    pub fn lines(&self) -> &[LiftedLine] {
        &self.lines
    }

    /// Phase 0 alone (L = 1): the response to the output at the samples, the sensor divided
    /// out.
    pub fn at_samples(&self) -> LiftedResponse {
        LiftedResponse {
            sample_time: self.sample_time,
            ratio: 1,
            lines: self
                .lines
                .iter()
                .map(|l| LiftedLine {
                    f: l.f,
                    phase: l.phase[..1].to_vec(),
                })
                .collect(),
        }
    }

    /// The harmonics H_m, m = 0..L−1 (module docs), of line `n`.
    pub fn harmonics(&self, n: usize) -> Vec<[[C64; 2]; 2]> {
        let line = &self.lines[n];
        let g: Vec<[[C64; 2]; 2]> = line.phase.iter().map(|p| p.h).collect();
        to_harmonics(&g, line.f, self.sample_time)
    }
}

impl LiftedResponse {
    /// The bound of line `n` per axis over its baseband and the hold's two images f_s ∓ f
    /// ([`image_bound`] with each image's noise variance Σ_p std_p²/L², from the phases'
    /// standard deviations): the harmonics beyond them are left out, as under a fast ADC's
    /// noise floor.
    pub fn image_bound(&self, n: usize) -> [f64; 2] {
        let h = self.harmonics(n);
        let l = h.len();
        let var = [0, 1].map(|i| {
            self.lines[n]
                .phase
                .iter()
                .map(|ph| ph.std[i][i].powi(2))
                .sum::<f64>()
                / (l * l) as f64
        });
        let images: Vec<_> = if l > 2 {
            vec![h[1], h[l - 1]]
        } else {
            h[1..].to_vec()
        };
        image_bound(&h[0], &images, var)
    }
}

/// The single-image bound per axis i of the diagonal, |b|/√(|a|² + |b|²):
/// a = H_0,ii, |b|² = Σ over `images` of max(|H_m,ii|² − `var`_i, 0) (each image's power less
/// the estimate's noise variance).
pub fn image_bound(h0: &[[C64; 2]; 2], images: &[[[C64; 2]; 2]], var: [f64; 2]) -> [f64; 2] {
    [0, 1].map(|i| {
        let a2 = h0[i][i].norm_sqr();
        let b2: f64 = images
            .iter()
            .map(|h| (h[i][i].norm_sqr() - var[i]).max(0.0))
            .sum();
        if a2 + b2 > 0.0 {
            (b2 / (a2 + b2)).sqrt()
        } else {
            1.0
        }
    })
}

/// The harmonics of the lifted `g` at `f` (module docs).
pub fn to_harmonics(g: &[[[C64; 2]; 2]], f: f64, t: f64) -> Vec<[[C64; 2]; 2]> {
    let l = g.len();
    (0..l)
        .map(|m| {
            let fm = harmonic_frequency(f, m, l, t);
            let mut h = [[C64::new(0.0, 0.0); 2]; 2];
            for (p, gp) in g.iter().enumerate() {
                let e = C64::from_polar(
                    1.0 / l as f64,
                    -std::f64::consts::TAU * fm * p as f64 * t / l as f64,
                );
                for i in 0..2 {
                    for j in 0..2 {
                        h[i][j] += e * gp[i][j];
                    }
                }
            }
            h
        })
        .collect()
}

/// The lifted response of the harmonics `h` at `f` ([`to_harmonics`] inverted).
pub fn from_harmonics(h: &[[[C64; 2]; 2]], f: f64, t: f64) -> Vec<[[C64; 2]; 2]> {
    let l = h.len();
    (0..l)
        .map(|p| {
            let mut g = [[C64::new(0.0, 0.0); 2]; 2];
            for (m, hm) in h.iter().enumerate() {
                let fm = harmonic_frequency(f, m, l, t);
                let e = C64::from_polar(1.0, std::f64::consts::TAU * fm * p as f64 * t / l as f64);
                for i in 0..2 {
                    for j in 0..2 {
                        g[i][j] += e * hm[i][j];
                    }
                }
            }
            g
        })
        .collect()
}

/// `g` with the sensor chain divided out of every harmonic.
fn divide_sensor(
    g: &[[[C64; 2]; 2]],
    f: f64,
    t: f64,
    datasheet: &SensorParams,
) -> Vec<[[C64; 2]; 2]> {
    let l = g.len();
    let mut h = to_harmonics(g, f, t);
    for (m, hm) in h.iter_mut().enumerate() {
        let s = datasheet.response(harmonic_frequency(f, m, l, t));
        hm.iter_mut().flatten().for_each(|v| *v /= s);
    }
    from_harmonics(&h, f, t)
}

/// The smallest relative error per axis of the output at `f` that any command through the
/// hold can reach for a reference on that axis alone (the harmonics `h`, module docs): the
/// command U minimizing ‖H_0 U − e_i‖² + Σ_{m≠0} ‖H_m U‖² leaves
/// `e_iᵀ (I − H_0 (Σ_m H_mᴴ H_m)⁻¹ H_0ᴴ) e_i`. With one image b and SISO baseband a:
/// |b| / √(|a|² + |b|²).
pub fn intersample_bound(h: &[[[C64; 2]; 2]]) -> [f64; 2] {
    let mut n = [[C64::new(0.0, 0.0); 2]; 2];
    for hm in h {
        for i in 0..2 {
            for j in 0..2 {
                n[i][j] += hm[0][i].conj() * hm[0][j] + hm[1][i].conj() * hm[1][j];
            }
        }
    }
    let Some(ni) = inverse(n) else {
        return [1.0; 2];
    };
    let a = h[0];
    let ah = [
        [a[0][0].conj(), a[1][0].conj()],
        [a[0][1].conj(), a[1][1].conj()],
    ];
    let p = mul(mul(a, ni), ah);
    [0, 1].map(|i| (1.0 - p[i][i].re).clamp(0.0, 1.0).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reference: the harmonics of a lifted response built from known harmonics are those
    /// harmonics (the two maps are inverse), and the bound of a SISO baseband a with one
    /// image b is |b|/√(|a|² + |b|²), in the 2 × 2 form and the single-image form.
    #[test]
    fn harmonics_round_trip_and_the_single_image_bound() {
        let t = 1e-4;
        let f = 842.0;
        let a = C64::new(0.7, -0.4);
        let b = C64::new(-0.2, 0.35);
        let mut h = vec![[[C64::new(0.0, 0.0); 2]; 2]; 5];
        h[0] = [[a, C64::new(0.0, 0.0)], [C64::new(0.0, 0.0), a]];
        h[4] = [[b, C64::new(0.0, 0.0)], [C64::new(0.0, 0.0), b]];
        let g = from_harmonics(&h, f, t);
        let back = to_harmonics(&g, f, t);
        for (x, y) in h.iter().zip(&back) {
            for i in 0..2 {
                for j in 0..2 {
                    assert!((x[i][j] - y[i][j]).norm() < 1e-14);
                }
            }
        }
        assert!((harmonic_frequency(f, 4, 5, t) - (f - 1e4)).abs() < 1e-9);
        let want = b.norm() / (a.norm_sqr() + b.norm_sqr()).sqrt();
        let bound = intersample_bound(&back);
        assert!((bound[0] - want).abs() < 1e-12 && (bound[1] - want).abs() < 1e-12);
        let single = image_bound(&back[0], &[back[1], back[4]], [0.0; 2]);
        assert!((single[0] - want).abs() < 1e-12 && (single[1] - want).abs() < 1e-12);
        // Noise variance above the image's power: no image left.
        let none = image_bound(&back[0], &[back[4]], [1.0; 2]);
        assert_eq!(none, [0.0; 2]);
    }

    /// Goal: a bad ratio is refused naming the field.
    #[test]
    fn a_ratio_that_does_not_divide_the_substeps_is_refused() {
        let adc = FastAdc {
            ratio: 3,
            noise_std: [0.0; 2],
            seed: 1,
        };
        let e = adc.validate(20).unwrap_err().to_string();
        assert!(e.contains("fast_adc.ratio"), "{e}");
        assert!(adc.validate(21).is_ok());
    }
}
