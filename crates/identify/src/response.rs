//! Frequency-response identification of what the controller's model takes from a stage: the
//! static gain x_nom → q and, per output axis, the lowest mode below the controller's Nyquist
//! frequency that carries a share of the axis's flexibility
//! ([`ResponseFit`], the quantities
//! `flexstage_control::fit::fit_to_response` turns into the lumped parameters).
//!
//! # Why not the time-domain regression on a structure
//! The regression of Eq. (54)–(56) ([`crate::identify`]) fits the lumped 8-state model to the
//! record. On the lumped model it recovers its parameters (crate docs); on the digital twin of a
//! design no lumped parameter set reproduces the response (its modes, the second output mode
//! above Nyquist, the input-inertia term; [`crate::frequency`]), so its estimates have no
//! truth to meet. What the controller actually uses on such a plant is the response fit
//! (`flexstage_control::controller::sized`); this module
//! measures exactly that, and its truth is the same fit computed from the plant's exact modes
//! ([`ResponseFit::from_modes`]).
//!
//! # Method (the classical experimental modal analysis of a multisine record)
//! 1. **Line spectra.** The multisine is periodic in 1/f₀; after `settle` seconds the whole
//!    periods are averaged into one and its DFT taken at every excited line (Goertzel). The
//!    lines alternate between the PEAs ([`crate::excitation::Multisine`]), so a line's driver j
//!    is the PEA with the larger x_nom there, and H_ij = Q_i / X_nom,j / S(f), with S the
//!    sensor chain's known response ([`flexstage_sim::rig::SensorParams::response`]).
//! 2. **Static gain.** Below `static_band`, per output i, the low-frequency expansion of a
//!    modal sum through both PEAs' x_nom, `Q_i = Σ_j (g_ij + a_ij ω² + j b_ij ω) X_j`, is fitted
//!    by linear least squares (the hysteresis puts a little of each PEA's x_nom on the
//!    other's lines); g_ij is the static gain.
//! 3. **Modes.** Around every peak of |H_i·| (a local maximum within ±`window` that exceeds
//!    `peak_factor` × the row's static gain) a rational model with one shared denominator,
//!    `H_ij(s) = N_j(s) / (s² + 2ζω_k s + ω_k²)`, N_j of degree 2 (the background of the
//!    other modes), is fitted to `Q_i = Σ_j H_ij X_j` by Levy's linearized least squares with Sanathanan–Koerner
//!    reweighting (5 iterations). The mode's residue r_ij is the remainder of N_j modulo the
//!    denominator at the pole; its share of axis i's static gain is
//!    `(r_i1 ± r_i2)/ω_k² / (g_i1 ± g_i2)` (+ for q_o1, driven by both PEAs alike; − for
//!    q_o2), as in `ResponseFit::from_modes`.
//! 4. **Selection.** Per axis, the lowest fitted mode below `nyquist` with a share of at least
//!    `share` ([`ResponseParams::share`], [`RESPONSE_SHARE`] as in the fit of the exact modes).
//!
//! The record must be free of aliasing below the controller's Nyquist frequency: a mode above
//! it, sampled at the controller's rate, folds into the band and would be fitted as a mode
//! there. The experiment therefore samples faster than the controller, as a signal analyser
//! does ([`acquisition_rig`]).

use flexstage_numerics::RangeError;
use flexstage_sim::modal::{PlantMode, static_gain};
use flexstage_sim::rig::{RigParams, SensorParams};
use nalgebra::{DMatrix, DVector};

use crate::data::StageRecord;
use crate::error::{IdentifyError, Result, check};
use crate::excitation::{Band, Excitation, RESONANCE_AMPLITUDE, RESONANCE_SPACING};
use crate::frequency::C64;

/// The least share of an axis's static gain a mode carries to be the axis's mode of a
/// [`ResponseFit`] (what the fit of a plant's exact modes and the response
/// identification use).
pub const RESPONSE_SHARE: f64 = 0.1;

/// What a frequency-response identification of the stage gives, to fit the lumped model
/// to (`flexstage_control::fit::fit_to_response`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResponseFit {
    /// Static gain x_nom → q, rows q_o1, q_o2 (dimensionless).
    pub dc_gain: [[f64; 2]; 2],
    /// First output mode of q_o1 and of q_o2 \[Hz\], > 0; `None` when the sampled response
    /// shows none below Nyquist (that axis's stiffness is then kept from the design).
    pub frequency: [Option<f64>; 2],
    /// Their damping ratios, in [0, 1) (used only with a frequency).
    pub damping: [f64; 2],
}

impl ResponseFit {
    /// What a frequency-response identification below Nyquist reads off a modal plant
    /// (e.g. the twin's modes): the static gain Σ out inᵀ/ω², and per output axis the
    /// lowest mode below `nyquist` \[Hz\] whose share of that axis's static gain is at least
    /// `share` (in (0, 1]). An axis with no such mode (its flexibility sits in modes above
    /// Nyquist, which the sampled response shows only folded) gets `None`: its mode is not
    /// identifiable from the sampled response and is not fitted.
    pub fn from_modes(modes: &[PlantMode], nyquist: f64, share: f64) -> ResponseFit {
        let g = static_gain(modes);
        let mut frequency = [None; 2];
        let mut damping = [0.0; 2];
        for i in 0..2 {
            let axis = |m: &PlantMode| {
                let w2 = (std::f64::consts::TAU * m.frequency).powi(2);
                let drive = if i == 0 {
                    m.input[0] + m.input[1]
                } else {
                    m.input[0] - m.input[1]
                };
                m.output[i] * drive / w2
            };
            let total = g[i][0] + if i == 0 { g[i][1] } else { -g[i][1] };
            if let Some(m) = modes
                .iter()
                .filter(|m| m.frequency < nyquist && axis(m) / total >= share)
                .min_by(|a, b| a.frequency.total_cmp(&b.frequency))
            {
                frequency[i] = Some(m.frequency);
                damping[i] = m.damping;
            }
        }
        ResponseFit {
            dc_gain: g,
            frequency,
            damping,
        }
    }

    /// Checks the fields.
    pub fn validate(&self) -> std::result::Result<(), RangeError> {
        use flexstage_numerics::validate::{check, positive};
        for i in 0..2 {
            if let Some(f) = self.frequency[i] {
                positive(&format!("fit.frequency[{i}]"), f)?;
            }
            check(
                &format!("fit.damping[{i}]"),
                self.damping[i],
                (0.0..1.0).contains(&self.damping[i]),
                "a damping ratio in [0, 1)",
            )?;
            check(
                &format!("fit.dc_gain[0][{i}]"),
                self.dc_gain[0][i],
                self.dc_gain[0][i] > 0.0 && self.dc_gain[0][i] < 0.5,
                "a static gain of q_o1 in (0, 0.5) (each PEA drives half the output)",
            )?;
            check(
                &format!("fit.dc_gain[1][{i}]"),
                self.dc_gain[1][i],
                self.dc_gain[1][i].is_finite() && self.dc_gain[1][i] != 0.0,
                "a finite non-zero static gain of q_o2",
            )?;
        }
        Ok(())
    }
}

/// Settings of the response identification (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResponseParams {
    /// Time skipped at the start \[s\] (the ramp and the transient), ≥ 0. Default 0.2 s.
    pub settle: f64,
    /// Highest line of the static-gain fit \[Hz\], > 0. Default 150 Hz (the low band).
    pub static_band: f64,
    /// Half-width of a peak's fitting window, relative to its frequency, in (0, 0.5).
    /// Default 0.08.
    pub window: f64,
    /// A peak is fitted when |H| exceeds this many times the row's largest static gain, > 1.
    /// Default 3.
    pub peak_factor: f64,
    /// The controller's Nyquist frequency \[Hz\], > 0: modes at or above it are not selected.
    pub nyquist: f64,
    /// Least share of an axis's static gain a selected mode carries, in (0, 1]. Default
    /// [`RESPONSE_SHARE`] (0.1).
    pub share: f64,
    /// The sensor chain, divided out of the measured response.
    pub sensor: SensorParams,
}

impl ResponseParams {
    /// The defaults for a controller sampled every `sample_time` seconds behind `sensor`.
    pub fn new(sample_time: f64, sensor: SensorParams) -> ResponseParams {
        ResponseParams {
            settle: 0.2,
            static_band: 150.0,
            window: 0.08,
            peak_factor: 3.0,
            nyquist: 0.5 / sample_time,
            share: RESPONSE_SHARE,
            sensor,
        }
    }

    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        check(
            "response.settle",
            self.settle,
            self.settle >= 0.0 && self.settle.is_finite(),
            "a time ≥ 0 [s]",
        )?;
        check(
            "response.static_band",
            self.static_band,
            self.static_band > 0.0 && self.static_band.is_finite(),
            "a frequency > 0 [Hz]",
        )?;
        check(
            "response.window",
            self.window,
            self.window > 0.0 && self.window < 0.5,
            "a relative half-width in (0, 0.5)",
        )?;
        check(
            "response.peak_factor",
            self.peak_factor,
            self.peak_factor > 1.0 && self.peak_factor.is_finite(),
            "a factor > 1",
        )?;
        check(
            "response.nyquist",
            self.nyquist,
            self.nyquist > 0.0 && self.nyquist.is_finite(),
            "a frequency > 0 [Hz]",
        )?;
        check(
            "response.share",
            self.share,
            self.share > 0.0 && self.share <= 1.0,
            "a share in (0, 1]",
        )
    }
}

/// How much faster than the controller the identification samples by default
/// ([`acquisition_rig`]).
pub const ACQUISITION_FACTOR: usize = 5;

/// Top of the response experiment's band relative to the controller's Nyquist frequency
/// ([`response_excitation`]): a mode just above Nyquist is fitted whole and then left out.
pub const BAND_TOP: f64 = 1.2;

/// The rig of the identification experiment: the controller's rig sampled `factor` times
/// faster (same substep, at least one per sample), with the white sensor noise scaled by
/// √factor so that its spectral density, what a faster acquisition of the same sensor sees,
/// is unchanged.
pub fn acquisition_rig(rig: &RigParams, factor: usize) -> RigParams {
    let f = factor.max(1);
    let mut r = rig.clone();
    r.sample_time = rig.sample_time / f as f64;
    r.substeps = rig.substeps.div_ceil(f).max(1);
    r.noise_std = rig.noise_std.map(|s| s * (f as f64).sqrt());
    r
}

/// The excitation of the response experiment: `low` (its low band for the static gain) and a
/// band of lines every [`RESONANCE_SPACING`] Hz from just above the low band to
/// [`BAND_TOP`] × `nyquist` (the controller's), [`RESONANCE_AMPLITUDE`] peak per PEA: every
/// mode the controller's sampled response can show is excited, whatever the design model
/// predicted.
pub fn response_excitation(low: &Excitation, nyquist: f64) -> Excitation {
    let mut e = low.clone();
    e.resonance = Some(Band {
        f_lo: low.f_max + RESONANCE_SPACING,
        f_hi: BAND_TOP * nyquist,
        spacing: RESONANCE_SPACING,
        amplitude: RESONANCE_AMPLITUDE,
    });
    e
}

/// The measured spectra at one excited line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Line {
    /// Frequency \[Hz\].
    pub f: f64,
    /// The PEA that drives this line (0 or 1).
    pub driver: usize,
    /// X_nom,1, X_nom,2 (the other PEA's is its hysteresis's distortion, small).
    pub x: [C64; 2],
    /// Q_1, Q_2 with the sensor chain divided out.
    pub q: [C64; 2],
}

impl Line {
    /// The response H_{i,driver} ≈ Q_i / X_driver (the other PEA's small part ignored; the
    /// fits use both).
    pub fn h(&self, i: usize) -> C64 {
        self.q[i] / self.x[self.driver]
    }
}

/// One mode fitted around a peak of output `axis`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FittedMode {
    /// The output row whose peak it is (0: q_o1, 1: q_o2).
    pub axis: usize,
    /// Natural frequency \[Hz\].
    pub frequency: f64,
    /// Damping ratio.
    pub damping: f64,
    /// Residue per PEA, r_{axis,j} \[1/s²\].
    pub residue: [f64; 2],
    /// Its share of the axis's static gain.
    pub share: f64,
}

/// What [`identify_response`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct ResponseIdentification {
    /// The fit the controller's model takes.
    pub fit: ResponseFit,
    /// Every fitted peak, by axis then frequency.
    pub modes: Vec<FittedMode>,
    /// The measured response per excited line, by frequency.
    pub lines: Vec<Line>,
    /// Whole periods averaged.
    pub periods: usize,
}

/// Identifies the response fit from a multisine `record` of `excitation` (module docs).
pub fn identify_response(
    record: &StageRecord,
    excitation: &Excitation,
    p: &ResponseParams,
) -> Result<ResponseIdentification> {
    p.validate()?;
    excitation.validate()?;
    let (lines, periods) = line_spectra(record, excitation, p)?;
    let g = [
        static_gains(&lines, 0, p.static_band)?,
        static_gains(&lines, 1, p.static_band)?,
    ];
    let band: Vec<&Line> = lines.iter().filter(|l| l.f > p.static_band).collect();
    let mut modes = Vec::new();
    for axis in 0..2 {
        let scale = g[axis][0].abs().max(g[axis][1].abs());
        let sign = if axis == 0 { 1.0 } else { -1.0 };
        let total = g[axis][0] + sign * g[axis][1];
        for peak in peaks(&band, axis, p.peak_factor * scale, p.window) {
            let Some((w, zeta, r)) = fit_mode(&band, axis, peak, p.window) else {
                continue;
            };
            modes.push(FittedMode {
                axis,
                frequency: w / std::f64::consts::TAU,
                damping: zeta,
                residue: r,
                share: (r[0] + sign * r[1]) / (w * w) / total,
            });
        }
    }
    modes.sort_by(|a, b| {
        (a.axis, a.frequency)
            .partial_cmp(&(b.axis, b.frequency))
            .unwrap()
    });
    modes.dedup_by(|a, b| a.axis == b.axis && (a.frequency / b.frequency - 1.0).abs() < 0.01);
    let mut fit = ResponseFit {
        dc_gain: g,
        frequency: [None; 2],
        damping: [0.0; 2],
    };
    for axis in 0..2 {
        if let Some(m) = modes
            .iter()
            .find(|m| m.axis == axis && m.frequency < p.nyquist && m.share >= p.share)
        {
            fit.frequency[axis] = Some(m.frequency);
            fit.damping[axis] = m.damping;
        }
    }
    Ok(ResponseIdentification {
        fit,
        modes,
        lines,
        periods,
    })
}

/// The excited lines' responses (step 1) and the number of periods averaged.
fn line_spectra(
    record: &StageRecord,
    e: &Excitation,
    p: &ResponseParams,
) -> Result<(Vec<Line>, usize)> {
    let ts = record.sample_time();
    let per = 1.0 / (e.f_min * ts);
    let n = per.round() as usize;
    check(
        "excitation.f_min",
        e.f_min,
        n >= 4 && (per - n as f64).abs() < 1e-6 * per,
        "a line spacing whose period 1/f₀ is a whole number (≥ 4) of the record's samples",
    )?;
    let start = (p.settle.max(e.ramp) / ts).ceil() as usize;
    let periods = record.len().saturating_sub(start) / n;
    if periods == 0 {
        return Err(IdentifyError::Data(flexstage_numerics::DataError::new(
            "record",
            format!(
                "{} samples hold no whole period of {n} samples after the {start} settling ones",
                record.len()
            ),
        )));
    }
    let first = record.len() - periods * n;
    let channels = [
        &record.x_nom[0],
        &record.x_nom[1],
        &record.q[0],
        &record.q[1],
    ];
    let mean: Vec<Vec<f64>> = channels
        .iter()
        .map(|x| {
            let mut m = vec![0.0; n];
            for k in 0..periods * n {
                m[k % n] += x[first + k];
            }
            m
        })
        .collect();
    let mut ks: Vec<usize> = e
        .harmonics()
        .into_iter()
        .flat_map(|(lo, hi, step)| (lo..=hi).step_by(step))
        .collect();
    ks.retain(|&k| 2 * k < n);
    ks.sort_unstable();
    ks.dedup();
    let mut lines = Vec::with_capacity(ks.len());
    for k in ks {
        let [x1, x2, q1, q2] = [0, 1, 2, 3].map(|c| goertzel(&mean[c], k));
        let driver = usize::from(x2.norm() > x1.norm());
        let x = if driver == 0 { x1 } else { x2 };
        if x.norm() == 0.0 {
            continue;
        }
        let f = k as f64 * e.f_min;
        let s = p.sensor.response(f);
        lines.push(Line {
            f,
            driver,
            x: [x1, x2],
            q: [q1 / s, q2 / s],
        });
    }
    Ok((lines, periods))
}

/// The DFT Σ x_m e^{−j2πkm/n} of one period at line k.
fn goertzel(x: &[f64], k: usize) -> C64 {
    let n = x.len();
    let w = std::f64::consts::TAU * k as f64 / n as f64;
    let c = 2.0 * w.cos();
    let (mut s1, mut s2) = (0.0, 0.0);
    for &v in x {
        let s = v + c * s1 - s2;
        s2 = s1;
        s1 = s;
    }
    // s1 − e^{−jw} s2 = Σ x_m e^{jw(n−1−m)} = e^{jw(n−1)} X.
    let e = C64::from_polar(1.0, -w);
    (C64::new(s1, 0.0) - e * s2) * C64::from_polar(1.0, -w * (n as f64 - 1.0))
}

/// The static gains g_i1, g_i2 of output `i` from the lines below `band` (step 2):
/// `Q_i = Σ_j (g_ij + a_ij ω² + j b_ij ω) X_j` by linear least squares over both PEAs' lines
/// (the hysteresis puts a little of each PEA's x_nom on the other's lines).
fn static_gains(lines: &[Line], i: usize, band: f64) -> Result<[f64; 2]> {
    let pts: Vec<&Line> = lines.iter().filter(|l| l.f <= band).collect();
    for j in 0..2 {
        let n = pts.iter().filter(|l| l.driver == j).count();
        if n < 2 {
            return Err(IdentifyError::Data(flexstage_numerics::DataError::new(
                "record",
                format!(
                    "{n} excited line(s) of PEA {} up to {band} Hz; the static gain needs 2",
                    j + 1
                ),
            )));
        }
    }
    let mut a = DMatrix::zeros(2 * pts.len(), 6);
    let mut b = DVector::zeros(2 * pts.len());
    for (r, l) in pts.iter().enumerate() {
        let w = l.f / band;
        for j in 0..2 {
            let x = l.x[j] / l.x[l.driver].norm();
            for (c, v) in [x, x * (w * w), x * C64::new(0.0, w)]
                .into_iter()
                .enumerate()
            {
                a[(2 * r, 3 * j + c)] = v.re;
                a[(2 * r + 1, 3 * j + c)] = v.im;
            }
        }
        let q = l.q[i] / l.x[l.driver].norm();
        b[2 * r] = q.re;
        b[2 * r + 1] = q.im;
    }
    let x = a
        .svd(true, true)
        .solve(&b, 1e-12)
        .map_err(|e| estimate("static gain", e.to_string()))?;
    Ok([x[0], x[3]])
}

fn estimate(what: &str, reason: String) -> IdentifyError {
    IdentifyError::Estimate {
        what: what.into(),
        reason,
    }
}

/// Indices into `band` of the peaks of |H_axis·| above `level`, each the largest within
/// ±`window` of its frequency.
fn peaks(band: &[&Line], axis: usize, level: f64, window: f64) -> Vec<usize> {
    let mag = |k: usize| band[k].h(axis).norm();
    (0..band.len())
        .filter(|&k| {
            let f = band[k].f;
            mag(k) > level
                && band
                    .iter()
                    .enumerate()
                    .filter(|(_, l)| (l.f - f).abs() <= window * f)
                    .all(|(m, _)| mag(m) <= mag(k))
        })
        .collect()
}

/// Fits one mode around `band[peak]` (step 3): (ω_k \[rad/s\], ζ_k, residues per PEA), or
/// `None` when the window holds too few lines or the fit is not a lightly damped mode
/// inside the window.
fn fit_mode(band: &[&Line], axis: usize, peak: usize, window: f64) -> Option<(f64, f64, [f64; 2])> {
    let fp = band[peak].f;
    let pts: Vec<&Line> = band
        .iter()
        .copied()
        .filter(|l| (l.f - fp).abs() <= window * fp)
        .collect();
    if (0..2).any(|j| pts.iter().filter(|l| l.driver == j).count() < 3) {
        return None;
    }
    // Both PEAs' x_nom at every line: Σ_j N_j(s) X_j − Q (a0 + a1 s) = Q s².
    // Frequencies scaled by ω_p: s̃ = jω/ω_p. Unknowns: a0, a1, then b0, b1, b2 per PEA.
    let wp = std::f64::consts::TAU * fp;
    let mut den = [0.0, 0.0]; // a0, a1 of the previous iteration (none yet)
    let mut sol = DVector::zeros(8);
    for it in 0..6 {
        let mut a = DMatrix::zeros(2 * pts.len(), 8);
        let mut b = DVector::zeros(2 * pts.len());
        for (r, l) in pts.iter().enumerate() {
            let s = C64::new(0.0, l.f / fp);
            let norm = l.x[l.driver].norm();
            let (x, q) = (l.x.map(|x| x / norm), l.q[axis] / norm);
            let weight = if it == 0 {
                1.0
            } else {
                1.0 / (s * s + den[1] * s + den[0]).norm()
            };
            let mut put = |c: usize, v: C64| {
                a[(2 * r, c)] = weight * v.re;
                a[(2 * r + 1, c)] = weight * v.im;
            };
            put(0, -q);
            put(1, -q * s);
            for j in 0..2 {
                put(2 + 3 * j, x[j]);
                put(3 + 3 * j, x[j] * s);
                put(4 + 3 * j, x[j] * s * s);
            }
            let rhs = q * s * s;
            b[2 * r] = weight * rhs.re;
            b[2 * r + 1] = weight * rhs.im;
        }
        sol = a.svd(true, true).solve(&b, 1e-14).ok()?;
        den = [sol[0], sol[1]];
    }
    let (a0, a1) = (den[0], den[1]);
    if !(a0 > 0.0) {
        return None;
    }
    let wn = a0.sqrt();
    let zeta = a1 / (2.0 * wn);
    if !(zeta > 0.0 && zeta < 0.5 && (wn - 1.0).abs() <= window) {
        return None;
    }
    // The pole (scaled) and the remainder c1 s + c0 of N_j modulo the denominator.
    let pole = C64::new(-zeta * wn, wn * (1.0 - zeta * zeta).sqrt());
    let r = [0, 1].map(|j| {
        let (b0, b1, b2) = (sol[2 + 3 * j], sol[3 + 3 * j], sol[4 + 3 * j]);
        let (c0, c1) = (b0 - b2 * a0, b1 - b2 * a1);
        (pole * c1 + c0).re * wp * wp
    });
    Some((wn * wp, zeta, r))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn goertzel_is_the_dft_at_its_line() {
        // Goal: one period of cos(2πkm/n + φ) gives (n/2)e^{jφ} at line k.
        let n = 64;
        let (k, phi) = (5, 0.7);
        let x: Vec<f64> = (0..n)
            .map(|m| (std::f64::consts::TAU * (k * m) as f64 / n as f64 + phi).cos())
            .collect();
        let d = goertzel(&x, k);
        assert!(
            (d - C64::from_polar(n as f64 / 2.0, phi)).norm() < 1e-9,
            "{d}"
        );
        assert!(goertzel(&x, k + 1).norm() < 1e-9);
    }
}
