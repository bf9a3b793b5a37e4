//! A documented, repeatable tuning procedure for the loop-shaping controllers
//! ([`crate::pi_notch`]), applied with the same search budget to every structure compared
//! (PI + notch and PID, both with feed-forward): "equal effort".
//!
//! # Procedure
//! 1. **Notch** (structures with a notch): on each axis, at the frequency of the largest peak
//!    of the axis's plant response |P_ii(e^{jωT})| above the first resonance's band start,
//!    with zero damping ζ_z = the mode's damping (the notch cancels the resonant peak) and
//!    pole damping ζ_p = [`TuningParams::notch_width`].
//! 2. **Shape**: ki is the free gain; kp = ki/ω_z with the PI zero at a fixed fraction of
//!    the integral gain (ω_z = ki/kp, one of [`TuningParams::zero_ratios`] × ki) and, for
//!    the PID, kd = kp/ω_d with ω_d the derivative corner (one of
//!    [`TuningParams::derivative_corners`]). Every shape candidate is tried.
//! 3. **Gain**: for each shape, the largest common scale s of ki (both axes) such that the
//!    closed loop is stable ([`closed_loop_stable`], the multivariable Nyquist criterion) and
//!    both loop-at-a-time margins (with the other loop closed, the rig's delay included) are
//!    at least [`TuningParams::gain_margin_db`] and [`TuningParams::phase_margin_deg`], by
//!    bisection in log s (the margins fall monotonically with the gain for these loops;
//!    the result is re-checked).
//!    **3b.** Then each axis's ki (with its kp, kd) is raised on its own by the same
//!    bisection, the other axis held, while both loops keep the margins *and* the raised
//!    axis's loop keeps them with one more sample of delay: an axis whose loop has room (on
//!    the quick design q2 has 17.7 dB where q1 has 6 dB) is not held back by the other, and
//!    does not spend that room on a loop that a late sample destabilizes (the Monte-Carlo
//!    study draws 0–2 samples; without the second condition q2 went to 562 Hz and 6 % of the
//!    plants diverged).
//! 4. The shape with the largest product ki₁ ki₂ wins (ki sets the low-frequency rejection of
//!    hysteresis residue, creep and coupling, which dominate the tracking error at scan
//!    speeds).

use nalgebra::Complex;

use crate::error::{Result, check};
use crate::margins::{MarginParams, Margins, margin};
use crate::pi_notch::{AxisGains, Notch, PiNotchParams};
use crate::registry::Stage;
use flexstage_sim::modal::LoopPlant;

/// Settings of the tuning procedure (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct TuningParams {
    /// Required gain margin \[dB\], ≥ 0 (default 6).
    pub gain_margin_db: f64,
    /// Required phase margin \[deg\], 0–90 (default 40).
    pub phase_margin_deg: f64,
    /// Candidate PI zeros ω_z/ω_1 [-] (each > 0, ∞ = pure integral): kp = ki/ω_z.
    pub zero_ratios: Vec<f64>,
    /// Candidate derivative corners ω_d/ω_1 for the PID (each > 0): kd = kp/ω_d.
    pub derivative_corners: Vec<f64>,
    /// Pole damping ζ_p of the notch, 0 < ζ_p ≤ 2 (default 0.5).
    pub notch_width: f64,
    /// Search band and accuracy of the margins.
    pub margins: MarginParams,
    /// Bisection steps on the gain scale (default 30).
    pub steps: usize,
    /// The feed-forward of the tuned PI + notch and PID (default: the inverse fitted to the
    /// stage's lifted response with preview, [`FeedForward::Lifted`], where the stage has one
    /// (a fast ADC's measurement, the designs given its output at the samples); else the
    /// inverse fitted to its sampled response, [`crate::feedforward`]; [`FeedForwardFit`]
    /// says which).
    pub feedforward: FeedForward,
    /// How much wider \[dB, deg\] the margin targets of the designs that run under the
    /// learning layer are ([`TuningParams::for_learning`]), each ≥ 0 (default 6 dB, 20°;
    /// 0, 0: the same designs). Under learning the feedback no longer has to follow the
    /// periodic reference, only to hold the loop and reject what does not repeat, and the
    /// sensor's noise it feeds to the output (T n) becomes the floor of the error: a
    /// lower-bandwidth feedback lowers it (docs/DECISIONS.md, "The feedback under learning").
    pub learning_widening: [f64; 2],
}

impl TuningParams {
    /// The tuning of the designs that run under the learning layer: the margin targets
    /// widened by [`TuningParams::learning_widening`] (the phase margin at most 89°); `None`
    /// when the widening is zero (the learning layer runs on the same designs).
    pub fn for_learning(&self) -> Option<TuningParams> {
        let [gm, pm] = self.learning_widening;
        if gm == 0.0 && pm == 0.0 {
            return None;
        }
        Some(TuningParams {
            gain_margin_db: self.gain_margin_db + gm,
            phase_margin_deg: (self.phase_margin_deg + pm).min(89.0),
            learning_widening: [0.0; 2],
            ..self.clone()
        })
    }
}

impl Default for TuningParams {
    fn default() -> Self {
        TuningParams {
            gain_margin_db: 6.0,
            phase_margin_deg: 40.0,
            zero_ratios: vec![0.03, 0.1, 0.3, f64::INFINITY],
            derivative_corners: vec![0.5, 1.0],
            notch_width: 0.5,
            margins: MarginParams {
                points: 120,
                refine: 30,
                ..MarginParams::default()
            },
            steps: 30,
            feedforward: FeedForward::Lifted(FeedForwardParams::default()),
            learning_widening: [6.0, 20.0],
        }
    }
}

pub use crate::feedforward::{FeedForward, FeedForwardParams};

/// What the tuned linear designs' feed-forward is on a stage: the tuning's
/// [`FeedForward`] with what the stage offers to fit ([`crate::feedforward::design_with`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FeedForwardFit {
    /// The static inverse at the current sample (no response to fit, or asked for).
    Static,
    /// The static inverse some samples ahead.
    StaticLead,
    /// The inverse fitted to the sampled response (command → reading at the samples).
    Sampled,
    /// The inverse fitted to the lifted response of a fast ADC (the output, the sensor's
    /// datasheet filter divided out).
    Lifted,
}

impl FeedForwardFit {
    /// The feed-forward the linear designs on `stage` get.
    pub fn of(stage: &Stage<'_>) -> FeedForwardFit {
        match (stage.tuning.feedforward, stage.response, stage.lifted) {
            (FeedForward::StaticLead(_), ..) => FeedForwardFit::StaticLead,
            (FeedForward::Static, ..) | (_, None, _) => FeedForwardFit::Static,
            (FeedForward::Lifted(_), Some(_), Some(_)) => FeedForwardFit::Lifted,
            _ => FeedForwardFit::Sampled,
        }
    }

    /// Its name in files and summaries: `static`, `static-lead`, `sampled`, `lifted`.
    pub fn name(self) -> &'static str {
        match self {
            FeedForwardFit::Static => "static",
            FeedForwardFit::StaticLead => "static-lead",
            FeedForwardFit::Sampled => "sampled",
            FeedForwardFit::Lifted => "lifted",
        }
    }
}

impl TuningParams {
    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        check(
            "tuning.gain_margin_db",
            self.gain_margin_db,
            self.gain_margin_db >= 0.0,
            "≥ 0 dB",
        )?;
        check(
            "tuning.phase_margin_deg",
            self.phase_margin_deg,
            (0.0..=90.0).contains(&self.phase_margin_deg),
            "0–90°",
        )?;
        for &r in self.zero_ratios.iter().chain(&self.derivative_corners) {
            if r != f64::INFINITY {
                check(
                    "tuning.zero_ratios / derivative_corners",
                    r,
                    r > 0.0,
                    "> 0 or ∞",
                )?;
            }
        }
        check(
            "tuning.zero_ratios",
            self.zero_ratios.len() as f64,
            !self.zero_ratios.is_empty(),
            "at least one",
        )?;
        check(
            "tuning.notch_width",
            self.notch_width,
            self.notch_width > 0.0 && self.notch_width <= 2.0,
            "0 < ζ_p ≤ 2",
        )?;
        let [gm, pm] = self.learning_widening;
        check(
            "tuning.learning_widening[0]",
            gm,
            (0.0..=40.0).contains(&gm),
            "0–40 dB",
        )?;
        check(
            "tuning.learning_widening[1]",
            pm,
            (0.0..=90.0).contains(&pm),
            "0–90°",
        )?;
        self.margins.validate()
    }
}

/// The structure being tuned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Structure {
    /// PI with a notch on each axis's resonance.
    PiNotch,
    /// PID without notch (the existing baseline's structure).
    Pid,
}

/// The two loop-at-a-time return ratios (output side: L = P G⁻¹ diag(c)) of a PI-notch
/// controller on a plant, at `f` \[Hz\].
pub fn loop_response(plant: &dyn LoopPlant, params: &PiNotchParams, f: f64) -> [Complex<f64>; 2] {
    let l = return_ratio(plant, params, f);
    [0, 1].map(|i| crate::margins::loop_at_a_time(&l, i))
}

/// The MIMO return ratio L = P G⁻¹ diag(c) (output side) at `f` \[Hz\].
pub fn return_ratio(
    plant: &dyn LoopPlant,
    params: &PiNotchParams,
    f: f64,
) -> [[Complex<f64>; 2]; 2] {
    let p = plant.response(f);
    let g = params.static_gain;
    let det = g[0][0] * g[1][1] - g[0][1] * g[1][0];
    let gi = [
        [g[1][1] / det, -g[0][1] / det],
        [-g[1][0] / det, g[0][0] / det],
    ];
    let c = params.axis_response(f);
    let mut l = [[Complex::new(0.0, 0.0); 2]; 2];
    for i in 0..2 {
        for j in 0..2 {
            for k in 0..2 {
                l[i][j] += p[i][k] * gi[k][j] * c[j];
            }
        }
    }
    l
}

/// Whether the closed loop of `params` on `plant` is stable, by the multivariable Nyquist
/// criterion on the sampled loop (Skogestad & Postlethwaite, *Multivariable Feedback
/// Control*, 2nd ed., Theorem 4.9, with the unit circle as contour).
///
/// The open loop has no pole outside the unit circle (stable modes, sensor filters, delay,
/// Tustin notches) and one pole at z = 1 per axis with integral action (n_I of them). With
/// the contour indented outside z = 1, the closed loop has Z = −W poles outside the unit
/// circle, W the counter-clockwise winding number of det(I + L(z)) around the origin. By
/// conjugate symmetry and the indentation (near z = 1, det(I + L) ∝ (z − 1)^{−n_I}, which
/// turns by −n_I π), W = (2Δ − n_I π)/2π with Δ the phase change of det(I + L(e^{jωT})) from
/// ω = 0⁺ to the Nyquist frequency: the loop is stable iff Δ = n_I π/2.
///
/// Δ is unwrapped on a grid that is refined wherever the phase turns by more than 0.3 rad
/// between neighbours, and that holds points across every mode's half-power band (aliases
/// folded into the Nyquist band), so a lightly damped mode's loop cannot slip between
/// two points. A loop that passes within 1e-9 of the origin is reported unstable
/// (marginal).
///
/// The margins alone do not show this: a loop whose gain never crosses 1 in the band reports
/// an infinite phase margin, however it encircles −1 (found on the paper design's twin,
/// where the tuned PI + notch met 6 dB "with no gain crossover" and diverged).
pub fn closed_loop_stable(plant: &dyn LoopPlant, params: &PiNotchParams) -> bool {
    let t = plant.sample_time();
    let nyquist = 0.5 / t;
    let det = |f: f64| {
        let l = return_ratio(plant, params, f);
        let one = Complex::new(1.0, 0.0);
        (one + l[0][0]) * (one + l[1][1]) - l[0][1] * l[1][0]
    };
    let modes = plant.modes().into_iter().map(|(f, zeta)| {
        let r = f.rem_euclid(2.0 * nyquist);
        (if r > nyquist { 2.0 * nyquist - r } else { r }, zeta)
    });
    let grid = nyquist_grid(nyquist, modes);
    let Some((first, phase)) = unwrapped_phase(det, &grid, nyquist) else {
        return false;
    };
    let start = first.arg();
    let n_int = params.axes.iter().filter(|a| a.ki > 0.0).count() as f64;
    // At ω = 0⁺ det(I + L) → (−j∞)^{n_I} (phase −n_I π/2): the turn from there to the
    // grid's first point is added; W is then an integer.
    let from_zero = Complex::from_polar(1.0, start + n_int * std::f64::consts::FRAC_PI_2).arg();
    let delta = phase + from_zero;
    let w = (2.0 * delta - n_int * std::f64::consts::PI) / std::f64::consts::TAU;
    w.abs() < 0.25
}

/// The frequency grid of a Nyquist test on (0, `nyquist`]: log-spaced from 1e-5 of Nyquist,
/// linear in thousandths of it, and 81 points across each of `modes` (centre \[Hz\] within
/// the band, damping ratio) over ± 5 half-power half-widths; sorted, without repeats.
pub(crate) fn nyquist_grid(nyquist: f64, modes: impl IntoIterator<Item = (f64, f64)>) -> Vec<f64> {
    let lo = 1e-5 * nyquist;
    let mut grid: Vec<f64> = (0..=400)
        .map(|k| lo * (nyquist / lo).powf(k as f64 / 400.0))
        .collect();
    grid.extend((1..1000).map(|k| nyquist * k as f64 / 1000.0));
    for (f, zeta) in modes {
        let w = (zeta.max(1e-4) * f).max(1e-6 * nyquist);
        grid.extend((-40..=40).map(|k| f + w * k as f64 / 8.0));
    }
    grid.retain(|&f| f >= lo && f <= nyquist);
    grid.sort_by(f64::total_cmp);
    grid.dedup();
    grid
}

/// `det` at the grid's first point and its phase change along `grid`, unwrapped: each
/// interval is bisected until every step turns by at most 0.3 rad. `None` when `det`
/// passes within 1e-9 of the origin (a marginal loop).
pub(crate) fn unwrapped_phase(
    det: impl Fn(f64) -> Complex<f64>,
    grid: &[f64],
    nyquist: f64,
) -> Option<(Complex<f64>, f64)> {
    let first = det(grid[0]);
    let mut phase = 0.0;
    let mut prev = first;
    let mut fp = grid[0];
    let mut stack = Vec::new();
    for &f in &grid[1..] {
        stack.push((f, det(f)));
        while let Some(&(fb, db)) = stack.last() {
            if prev.norm() < 1e-9 || db.norm() < 1e-9 {
                return None;
            }
            let step = (db / prev).arg();
            if step.abs() > 0.3 && fb - fp > 1e-9 * nyquist {
                let fm = 0.5 * (fp + fb);
                stack.push((fm, det(fm)));
            } else {
                phase += step;
                prev = db;
                fp = fb;
                stack.pop();
            }
        }
    }
    Some((first, phase))
}

/// Margins of both loops of `params` on `plant`.
pub fn loop_margins(
    plant: &dyn LoopPlant,
    params: &PiNotchParams,
    m: &MarginParams,
) -> Result<[Margins; 2]> {
    Ok([
        margin(|f| loop_response(plant, params, f)[0], m)?,
        margin(|f| loop_response(plant, params, f)[1], m)?,
    ])
}

/// The notches of axis `i` by step 1 of the procedure: at the highest peaks of the sampled
/// response |P_ii(e^{jωT})| relative to its static value (aliased modes above Nyquist
/// included: a mode at f_s − f appears at f), each at least 1.5× the static value, up to
/// two, with the depth ζ_z/ζ_p equal to the inverse of the peak's height (the notch flattens
/// the peak) and the width ζ_p = `width`.
pub fn notches_for_axis(plant: &dyn LoopPlant, i: usize, width: f64) -> [Option<Notch>; 2] {
    let nyquist = 0.5 / plant.sample_time();
    let g0 = plant.response(1e-3 * nyquist)[i][i].norm();
    let n = 2000;
    let grid: Vec<f64> = (0..n)
        .map(|k| nyquist * (0.02 + 0.97 * k as f64 / (n - 1) as f64))
        .collect();
    let mag: Vec<f64> = grid
        .iter()
        .map(|&f| plant.response(f)[i][i].norm() / g0)
        .collect();
    let mut peaks: Vec<(f64, f64)> = (1..n - 1)
        .filter(|&k| mag[k] > mag[k - 1] && mag[k] >= mag[k + 1] && mag[k] > 1.5)
        .map(|k| (grid[k], mag[k]))
        .collect();
    peaks.sort_by(|a, b| b.1.total_cmp(&a.1));
    let mut out = [None, None];
    for (slot, (f, h)) in out.iter_mut().zip(peaks) {
        *slot = Some(Notch {
            frequency: f,
            zero_damping: width / h,
            pole_damping: width,
        });
    }
    out
}

/// The result of tuning one structure.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tuned {
    /// The gains found.
    pub params: PiNotchParams,
    /// Their margins per loop.
    pub margins: [Margins; 2],
}

/// Tunes `structure` on `plant` by the procedure of the module docs.
pub fn tune(plant: &dyn LoopPlant, structure: Structure, p: &TuningParams) -> Result<Tuned> {
    p.validate()?;
    let t = plant.sample_time();
    let notch = match structure {
        Structure::PiNotch => [0, 1].map(|i| notches_for_axis(plant, i, p.notch_width)),
        Structure::Pid => [[None, None]; 2],
    };
    let corners: Vec<Option<f64>> = match structure {
        Structure::PiNotch => vec![None],
        Structure::Pid => std::iter::once(None)
            .chain(p.derivative_corners.iter().map(|&w| Some(w)))
            .collect(),
    };
    let w1 = std::f64::consts::TAU * plant.modes().first().map_or(1.0, |m| m.0);
    let mut best: Option<Tuned> = None;
    for &ratio in &p.zero_ratios {
        for &corner in &corners {
            let shape = |ki: [f64; 2]| {
                let kp = ki.map(|k| k / (ratio * w1));
                let kd = kp.map(|k| corner.map_or(0.0, |c| k / (c * w1)));
                let axes = [0, 1].map(|a| AxisGains {
                    kp: kp[a],
                    ki: ki[a],
                    kd: kd[a],
                    notches: notch[a],
                });
                PiNotchParams {
                    axes,
                    static_gain: plant.static_gain(),
                    sample_time: t,
                }
            };
            let ok = |ki: [f64; 2]| -> Result<Option<[Margins; 2]>> {
                let params = shape(ki);
                let m = loop_margins(plant, &params, &p.margins)?;
                Ok((m
                    .iter()
                    .all(|m| m.meets(p.gain_margin_db, p.phase_margin_deg))
                    && closed_loop_stable(plant, &params))
                .then_some(m))
            };
            if ok([1.0; 2])?.is_none() {
                continue;
            }
            // Step 3: the common scale; step 3b: each axis on its own, the other held.
            let common = largest(1.0, p.steps, |k| ok([k; 2]))?;
            let mut ki = [common; 2];
            let later = OneMoreSample(plant);
            for a in 0..2 {
                let factor = largest(1.0, p.steps, |f| {
                    let mut k = ki;
                    k[a] *= f;
                    let Some(m) = ok(k)? else { return Ok(None) };
                    let params = shape(k);
                    let late = margin(|f| loop_response(&later, &params, f)[a], &p.margins)?;
                    Ok((late.meets(p.gain_margin_db, p.phase_margin_deg)
                        && closed_loop_stable(&later, &params))
                    .then_some(m))
                })?;
                ki[a] *= factor;
            }
            if let Some(m) = ok(ki)? {
                let cand = Tuned {
                    params: shape(ki),
                    margins: m,
                };
                let score = |t: &Tuned| t.params.axes[0].ki * t.params.axes[1].ki;
                if best.is_none_or(|b| score(&cand) > score(&b)) {
                    best = Some(cand);
                }
            }
        }
    }
    best.ok_or_else(|| crate::error::ControlError::Unstable {
        what: "tuning".into(),
        detail: "no candidate shape meets the margins even at ki = 1 s⁻¹".into(),
    })
}

/// The tuning of `structure` on the stage's sampled response by [`tune`] with the stage's
/// settings, computed once per stage; `None` when the stage has no response to tune on.
pub fn tuned(stage: &Stage<'_>, structure: Structure) -> Result<Option<Tuned>> {
    let Some(plant) = stage.response else {
        return Ok(None);
    };
    let key = match structure {
        Structure::PiNotch => "tuning::pi_notch",
        Structure::Pid => "tuning::pid",
    };
    stage
        .shared(key, || tune(plant, structure, &stage.tuning))
        .map(Some)
}

/// A plant with one more sample of delay than `.0` (step 3b of the procedure).
struct OneMoreSample<'a>(&'a dyn LoopPlant);

impl LoopPlant for OneMoreSample<'_> {
    fn response(&self, f: f64) -> [[Complex<f64>; 2]; 2] {
        let z1 = Complex::from_polar(1.0, -std::f64::consts::TAU * f * self.0.sample_time());
        self.0.response(f).map(|row| row.map(|x| x * z1))
    }
    fn static_gain(&self) -> [[f64; 2]; 2] {
        self.0.static_gain()
    }
    fn modes(&self) -> Vec<(f64, f64)> {
        self.0.modes()
    }
    fn sample_time(&self) -> f64 {
        self.0.sample_time()
    }
}

/// The largest x in [lo, 1e6·lo] with `ok(x)` passing, by bisection in log x over `steps`
/// steps (`ok(lo)` is assumed to pass; the margins fall monotonically with the gain).
fn largest(
    lo: f64,
    steps: usize,
    mut ok: impl FnMut(f64) -> Result<Option<[Margins; 2]>>,
) -> Result<f64> {
    let (mut lo, mut hi) = (lo, 1e6 * lo);
    for _ in 0..steps {
        let mid = (lo * hi).sqrt();
        if ok(mid)?.is_some() {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(lo)
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexstage_sim::modal::ModalPlant;

    /// [`flexstage_sim::samples::decoupled_modes`] with one sample of delay at 10 kHz.
    fn plant() -> ModalPlant {
        ModalPlant::new(flexstage_sim::samples::decoupled_modes(), 1e-4, 1).unwrap()
    }

    /// A static, coupled plant A z^{−d} (no modes): its closed loop with a PI is a polynomial.
    struct StaticDelay {
        a: [[f64; 2]; 2],
        d: i32,
    }

    impl LoopPlant for StaticDelay {
        fn response(&self, f: f64) -> [[Complex<f64>; 2]; 2] {
            let zd = Complex::from_polar(1.0, -std::f64::consts::TAU * f * 1e-4 * self.d as f64);
            self.a.map(|row| row.map(|x| zd * x))
        }
        fn static_gain(&self) -> [[f64; 2]; 2] {
            self.a
        }
        fn modes(&self) -> Vec<(f64, f64)> {
            Vec::new()
        }
        fn sample_time(&self) -> f64 {
            1e-4
        }
    }

    /// Product of two polynomials (coefficients in ascending powers of z).
    fn mul(p: &[f64], q: &[f64]) -> Vec<f64> {
        let mut r = vec![0.0; p.len() + q.len() - 1];
        for (i, a) in p.iter().enumerate() {
            for (j, b) in q.iter().enumerate() {
                r[i + j] += a * b;
            }
        }
        r
    }

    /// Largest root modulus of a polynomial (ascending coefficients), from the eigenvalues
    /// of its companion matrix.
    fn spectral_radius(p: &[f64]) -> f64 {
        let n = p.len() - 1;
        let lead = p[n];
        let c = nalgebra::DMatrix::from_fn(n, n, |i, j| {
            if j == n - 1 {
                -p[i] / lead
            } else if i == j + 1 {
                1.0
            } else {
                0.0
            }
        });
        c.complex_eigenvalues()
            .iter()
            .map(|z| z.norm())
            .fold(0.0, f64::max)
    }

    /// Reference: the closed-loop characteristic polynomial. With P = A z^{−d}, the
    /// controller's static gain G (B = A G⁻¹) and the Tustin PI c_i = n_i(z)/(2(z − 1)),
    /// n_i = 2kp_i(z − 1) + ki_i T(z + 1), the closed-loop poles are the roots of
    /// (2(z − 1)z^d + B₀₀n₀)(2(z − 1)z^d + B₁₁n₁) − B₀₁B₁₀n₀n₁; for d = 1, one axis, kp = 0
    /// the loop is stable iff ki T < 2. Goal: [`closed_loop_stable`] agrees with the roots
    /// on a grid of gains, delays and couplings, both sides of the boundary.
    #[test]
    fn nyquist_test_agrees_with_the_closed_loop_poles() {
        let t = 1e-4;
        let pi = |kp: [f64; 2], ki: [f64; 2], g: [[f64; 2]; 2]| PiNotchParams {
            axes: [0, 1].map(|i| AxisGains {
                kp: kp[i],
                ki: ki[i],
                kd: 0.0,
                notches: [None, None],
            }),
            static_gain: g,
            sample_time: t,
        };
        let id = [[1.0, 0.0], [0.0, 1.0]];
        let p1 = StaticDelay { a: id, d: 1 };
        assert!(closed_loop_stable(&p1, &pi([0.0; 2], [1.9 / t; 2], id)));
        assert!(!closed_loop_stable(&p1, &pi([0.0; 2], [2.1 / t; 2], id)));
        assert!(!closed_loop_stable(
            &p1,
            &pi([0.0; 2], [1.0 / t, 2.1 / t], id)
        ));
        let mut checked = [0, 0];
        for d in 1..=3 {
            for a in [id, [[1.0, 0.3], [-0.2, 0.8]], [[0.6, 0.6], [1.5, -1.5]]] {
                let plant = StaticDelay { a, d };
                // The controller's decoupler is a little off (5 %) so the loops couple.
                let g = [[a[0][0] * 1.05, a[0][1]], [a[1][0], a[1][1] * 0.95]];
                let det = g[0][0] * g[1][1] - g[0][1] * g[1][0];
                let gi = [
                    [g[1][1] / det, -g[0][1] / det],
                    [-g[1][0] / det, g[0][0] / det],
                ];
                let mut b = [[0.0; 2]; 2];
                for i in 0..2 {
                    for j in 0..2 {
                        b[i][j] = a[i][0] * gi[0][j] + a[i][1] * gi[1][j];
                    }
                }
                for kp in [0.0, 0.2, 0.6] {
                    for s in [0.1, 0.3, 0.5, 0.7, 0.9, 1.1, 1.3, 1.6, 2.0] {
                        let ki = [s / t, 0.7 * s / t];
                        let n = [0, 1].map(|i| [-2.0 * kp + ki[i] * t, 2.0 * kp + ki[i] * t]);
                        let mut den = vec![0.0; d as usize + 2];
                        den[d as usize] = -2.0;
                        den[d as usize + 1] = 2.0;
                        let diag = [0, 1].map(|i| {
                            let mut q = den.clone();
                            q[0] += b[i][i] * n[i][0];
                            q[1] += b[i][i] * n[i][1];
                            q
                        });
                        let mut ch = mul(&diag[0], &diag[1]);
                        for (k, c) in mul(&n[0], &n[1]).iter().enumerate() {
                            ch[k] -= b[0][1] * b[1][0] * c;
                        }
                        let r = spectral_radius(&ch);
                        if (r - 1.0).abs() < 1e-3 {
                            continue;
                        }
                        let stable = closed_loop_stable(&plant, &pi([kp; 2], ki, g));
                        assert_eq!(stable, r < 1.0, "d {d} a {a:?} kp {kp} s {s}: ρ = {r}");
                        checked[usize::from(stable)] += 1;
                    }
                }
            }
        }
        // Both verdicts occur often enough for the comparison to mean something.
        assert!(checked[0] > 20 && checked[1] > 20, "{checked:?}");
    }

    /// Goal: the tuning under learning is the tuning with its margin targets widened (the
    /// phase margin at most 89°), none without a widening, and a widening out of range is
    /// refused naming the field.
    #[test]
    fn the_learning_tuning_widens_the_margin_targets() {
        let t = TuningParams::default();
        let l = t.for_learning().unwrap();
        assert_eq!((l.gain_margin_db, l.phase_margin_deg), (12.0, 60.0));
        assert_eq!(l.learning_widening, [0.0; 2]);
        assert!(l.for_learning().is_none());
        let steep = TuningParams {
            phase_margin_deg: 80.0,
            ..TuningParams::default()
        };
        assert_eq!(steep.for_learning().unwrap().phase_margin_deg, 89.0);
        for (w, field) in [([-1.0, 0.0], "[0]"), ([0.0, f64::NAN], "[1]")] {
            let bad = TuningParams {
                learning_widening: w,
                ..TuningParams::default()
            };
            let e = bad.validate().unwrap_err().to_string();
            assert!(
                e.contains(&format!("tuning.learning_widening{field}")),
                "{e}"
            );
        }
    }

    /// Goal: the procedure returns gains whose margins meet the targets, and each axis's gain
    /// is the largest that does: 10 % more integral gain on either axis breaks a target
    /// (nominal, or that axis's loop with one more sample of delay, step 3b). Both structures; the notch
    /// sits on each axis's mode.
    #[test]
    fn tuned_gains_meet_margins_and_are_maximal() {
        let p = plant();
        let tp = TuningParams::default();
        for s in [Structure::PiNotch, Structure::Pid] {
            let t = tune(&p, s, &tp).unwrap();
            assert!(t.margins.iter().all(|m| m.meets(6.0, 40.0)), "{s:?} {t:?}");
            assert!(closed_loop_stable(&p, &t.params), "{s:?} {t:?}");
            // Maximal per axis (step 3b): 10 % more on either axis alone breaks a target.
            for axis in 0..2 {
                let mut more = t.params;
                let a = &mut more.axes[axis];
                a.kp *= 1.1;
                a.ki *= 1.1;
                a.kd *= 1.1;
                let m = loop_margins(&p, &more, &tp.margins).unwrap();
                let late = loop_margins(&OneMoreSample(&p), &more, &tp.margins).unwrap();
                assert!(
                    !(m.iter().all(|m| m.meets(6.0, 40.0))
                        && late[axis].meets(6.0, 40.0)
                        && closed_loop_stable(&p, &more)
                        && closed_loop_stable(&OneMoreSample(&p), &more)),
                    "{s:?} not maximal on axis {axis}"
                );
            }
        }
        let n = notches_for_axis(&p, 1, 0.5)[0].unwrap();
        assert!((n.frequency - 3900.0).abs() < 5.0, "{n:?}");
        // The peak of a 1 % mode is 1/(2ζ) = 50× its static value, times the ZOH's
        // sin(πfT)/(πfT) in the sampled response: the notch depth is its inverse.
        let x = std::f64::consts::PI * 3900.0 * 1e-4;
        let peak = 50.0 * x.sin() / x;
        assert!(
            (n.zero_damping / n.pole_damping * peak - 1.0).abs() < 0.05,
            "{n:?}"
        );
    }
}
