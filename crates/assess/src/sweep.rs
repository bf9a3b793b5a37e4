//! Error against scan frequency: every candidate on the Lissajous 3:1 whose fast component
//! (q1, 3 f) runs from 1 % to 30 % of the twin's first resonance, on the twin in the full
//! rig. Amplitudes start at the scenario's first Lissajous and are scaled down by the factor
//! the binding limit asks for (controller stroke, amplifier range, current, slew:
//! [`flexstage_control::feasibility::Feasibility::binding`]) until the candidate's
//! feed-forward command fits, so each candidate runs each point as large as the amplifier
//! allows it (its amplitude is in its row: a controller whose command asks more of the
//! amplifier scans a smaller range, and its error is in % of that range). The
//! static gain the check inverts is the measured one (the bench's identified response fit),
//! never the twin's.
//!
//! Every point reports, per candidate and axis, the RMS and the peak error over the second
//! half of the run (after the smooth start; no cut-off), also in % of the range, and what
//! limits it ([`Cause`]): a run that did not stay finite or grew (instability); a true error
//! more than twice the error the loop reads (the reading against the reference), which the
//! loop cannot see: what the sampled, filtered reading misses of the true output, chiefly the
//! modes above Nyquist the hold's images excite, folded onto the scan's lines (aliasing); else
//! the loop's lag at the scan's own lines (bandwidth) or error at other frequencies
//! (distortion: hysteresis residual, excited modes).
//!
//! The RMS and peak above are those of the true output at the samples. The true output
//! between them is scored too ([`SweepResult::rms_between`], on every substep of the
//! simulation, [`run_between`]): the held command's images at f_s ∓ f drive the modes above
//! Nyquist, which ring between the samples where no sampled reading sees them.
//!
//! # Learning
//! With [`SweepParams::learning`] every candidate of every point also runs with the
//! learning layer of `flexstage_control::learning`, as `track --learning` runs it on the
//! slow trajectories: the learning plant measured at every harmonic of the point's period
//! from the readings of fresh loops (never the true output) of the design that runs under
//! learning (`Bench::learning_controller`: tuned to wider margins), both laws designed from
//! it (phase lead and model inverse, ρ ≤ 0.95 for every plant within the measured
//! uncertainty) and the one that learns better on a trial kept
//! (`flexstage_control::learning::choose_law`), told the sensor chain's datasheet lag, [`SweepLearning::trials`] periods (at most [`MAX_SWEEP_TRIALS`]) of
//! learning, then the point's run scored with learning on ([`SweepPoint::learning`]), at
//! the samples and between them. With the lab's fast ADC on the sensor's analog output
//! ([`SweepLearning::fast_adc`]) the reading learned toward is corrected after every trial
//! by what that record shows the reading to exceed the output by at the samples
//! (`flexstage_control::learning::Learning::retarget`).

use flexstage_control::ControlError;
use flexstage_control::actuator::Compensation;
use flexstage_control::feasibility::Limit;
use flexstage_control::learning::{
    self, DesignParams, Learning, Readings, SensorLag, measure_learning_plant,
};
use flexstage_figures::plot::{Figure, Series};
use flexstage_identify::measured::{FastAdc, FastChannel, FastRecorded};
use flexstage_sim::experiment::{Record, StageControl, run};
use flexstage_sim::rig::StagePlant;
use flexstage_sim::trajectory::{Reference, Shape};

use flexstage_control::registry::Controller;

use crate::bench::Bench;
use crate::error::{Result, check};

/// Settings of the sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepParams {
    /// Fractions of the first resonance for the fast component (each in (0, 0.45)).
    pub fractions: Vec<f64>,
    /// Base periods simulated per point, ≥ 1 (the run is at least 50 ms).
    pub periods: f64,
    /// Learning on the sweep ([`SweepLearning`]); `None`: off, the default.
    pub learning: Option<SweepLearning>,
}

impl Default for SweepParams {
    fn default() -> Self {
        SweepParams {
            fractions: vec![0.01, 0.02, 0.03, 0.05, 0.08, 0.1, 0.12, 0.2, 0.3],
            periods: 2.0,
            learning: None,
        }
    }
}

/// The most learning trials (periods) per point and candidate (bounded work).
pub const MAX_SWEEP_TRIALS: usize = 30;

/// Learning on the sweep (module docs, "Learning"): every candidate of every point also runs
/// with the learning layer, designed from the loop's readings, for `trials` periods, then
/// the point's run is scored with learning on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepLearning {
    /// Learning trials (periods) before the scored run, 1..=[`MAX_SWEEP_TRIALS`].
    pub trials: usize,
    /// RMS per axis \[m\] of the multisine that measures the learning plant (> 0).
    pub amplitude: f64,
    /// The sensor chain's lag from its datasheet.
    pub lag: SensorLag,
    /// The lab's fast ADC on the sensor's analog output during the trials: with it, the
    /// reading learned toward is corrected after every trial by what its record shows the
    /// reading to exceed the output by at the samples
    /// (`flexstage_control::learning::Learning::retarget`); `None`: learning toward the
    /// reading the feedback expects alone.
    pub fast_adc: Option<FastAdc>,
}

/// How a candidate learned at a point of the sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Learned {
    /// The learning law chosen by trial (`phase-lead` or `inverse`,
    /// `flexstage_control::learning::choose_law`).
    pub law: &'static str,
    /// Its monotone-convergence factor ρ on the measured learning plant.
    pub rho: f64,
    /// Learning trials (periods) before the scored run.
    pub periods: usize,
}

/// What limits a candidate's error at a point of the sweep (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cause {
    /// Most of the error lies at the reference's own lines (f and 3 f): the loop's lag there.
    Bandwidth,
    /// Most of the error lies elsewhere (harmonics of the hysteresis residual, excited modes).
    Distortion,
    /// The true error is more than twice the error the loop reads: what the sampled,
    /// filtered reading misses (modes above Nyquist excited by the hold's images, folded).
    Aliasing,
    /// The run did not stay finite, or its error grew over the steady half.
    Unstable,
}

impl Cause {
    /// Its name in files and tables.
    pub fn name(self) -> &'static str {
        match self {
            Cause::Bandwidth => "bandwidth",
            Cause::Distortion => "distortion",
            Cause::Aliasing => "aliasing",
            Cause::Unstable => "unstable",
        }
    }
}

/// One candidate at one point of the sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepResult {
    /// The candidate.
    pub controller: &'static Controller,
    /// Amplitudes used (A1, A2) \[m\]: the largest its feed-forward's commands fit the rig
    /// with (module docs).
    pub amplitude: [f64; 2],
    /// The limit that reduced the amplitude from the scenario's, and the factor it was
    /// reduced by (`None`: not reduced).
    pub reduced: Reduced,
    /// RMS error per axis over the second half \[m\] (non-finite only for a run that was).
    pub rms: [f64; 2],
    /// Largest |error| per axis over the second half \[m\].
    pub peak: [f64; 2],
    /// `rms` in % of the range (peak to peak).
    pub rms_pct: [f64; 2],
    /// `peak` in % of the range.
    pub peak_pct: [f64; 2],
    /// RMS error per axis over the second half on every substep of the simulation \[m\]:
    /// the true output between the samples too (what a scanned image records), against the
    /// reference at the same instants.
    pub rms_between: [f64; 2],
    /// Largest |error| per axis over the second half on every substep \[m\].
    pub peak_between: [f64; 2],
    /// `rms_between` in % of the range.
    pub rms_between_pct: [f64; 2],
    /// RMS per axis over the second half of the error the loop reads (the ADC reading
    /// against the reference) in % of the range: what learning drives to zero.
    pub rms_read_pct: [f64; 2],
    /// What limits the error.
    pub cause: Cause,
    /// Frequency of the largest error line over both axes \[Hz\] (0 when there is none).
    pub dominant: f64,
    /// With the learning layer: how it learned (`None`: the controller alone).
    pub learned: Option<Learned>,
}

/// One point of the sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepPoint {
    /// Fraction of the first resonance.
    pub fraction: f64,
    /// Frequency of the fast component \[Hz\].
    pub frequency: f64,
    /// One result per candidate, in the candidates' order (a candidate no amplitude makes
    /// feasible here is left out).
    pub results: Vec<SweepResult>,
    /// With [`SweepParams::learning`]: one result per candidate with the learning layer, in
    /// the candidates' order; a candidate whose learning design finds no ρ ≤ 0.95 on the
    /// measured learning plant is left out and named in `refused` with the reason.
    pub learning: Vec<SweepResult>,
    /// The candidates whose learning layer could not be designed here, with the reason.
    pub refused: Vec<(&'static str, String)>,
}

/// The limit that reduced a candidate's amplitude and the factor, if one did.
pub type Reduced = Option<(Limit, f64)>;

/// The amplitude of one candidate at one point: `amplitude` scaled until the candidate's
/// feed-forward command fits the rig (at most 8 rounds of the binding factor, each with a
/// 3 % allowance), with the first binding limit and the total factor.
fn fitting_amplitude(
    bench: &Bench,
    candidate: &'static Controller,
    amplitude: [f64; 2],
    base: f64,
    duration: f64,
) -> Result<Option<([f64; 2], Reduced)>> {
    let mut scale = 1.0;
    let mut first: Option<Limit> = None;
    for _ in 0..8 {
        let r = lissajous(amplitude.map(|a| a * scale), base);
        let binding = bench.feasibility(candidate, &r, duration)?.binding();
        match binding {
            None => {
                return Ok(Some((
                    amplitude.map(|a| a * scale),
                    first.map(|l| (l, scale)),
                )));
            }
            Some((limit, factor)) => {
                first.get_or_insert(limit);
                scale *= 0.97 * factor.min(1.0);
            }
        }
    }
    Ok(None)
}

fn lissajous(amplitude: [f64; 2], frequency: f64) -> Reference {
    Reference::new(Shape::Lissajous {
        ratio: 3.0,
        amplitude,
        frequency,
    })
}

/// Runs the sweep for `candidates`, starting from the Lissajous amplitudes `amplitude`.
/// A point no amplitude makes feasible is left out. Each point's base period is a whole
/// number of samples (the learning layer's period; the fast line within 2 % of its fraction
/// at 30 % of f1 on the quick design, closer below).
pub fn sweep(
    bench: &Bench,
    candidates: &[&'static Controller],
    amplitude: [f64; 2],
    p: &SweepParams,
) -> Result<Vec<SweepPoint>> {
    check("sweep.periods", p.periods, p.periods >= 1.0, "≥ 1")?;
    if let Some(l) = &p.learning {
        let trials = l.trials as f64;
        check(
            "sweep.learning.trials",
            trials,
            (1..=MAX_SWEEP_TRIALS).contains(&l.trials),
            "an integer in 1..=30",
        )?;
        check(
            "sweep.learning.amplitude",
            l.amplitude,
            l.amplitude > 0.0 && l.amplitude.is_finite(),
            "> 0 [m]",
        )?;
    }
    let f1 = bench.twin.first_resonance();
    let t = bench.setup.rig.sample_time;
    let mut out = Vec::new();
    for &frac in &p.fractions {
        check("sweep.fractions", frac, frac > 0.0 && frac < 0.45, "0–0.45")?;
        let period = (3.0 / (frac * f1 * t)).round().max(4.0) as usize;
        let base = 1.0 / (period as f64 * t);
        let duration = (p.periods / base).max(0.05);
        let mut results = Vec::new();
        let mut learning = Vec::new();
        let mut refused = Vec::new();
        for &c in candidates {
            let Some((amp, reduced)) = fitting_amplitude(bench, c, amplitude, base, duration)?
            else {
                continue;
            };
            let r = lissajous(amp, base);
            let half = r.half_range(duration, t);
            let (rec, between) = run_between(bench, c, r, duration)?;
            let at = |mut res: SweepResult| {
                (res.amplitude, res.reduced) = (amp, reduced);
                res
            };
            results.push(at(scored(c, &rec, &between, half, base, t)));
            let Some(l) = &p.learning else { continue };
            match run_learning(bench, c, r, period, duration, l)? {
                Ok((rec, between, learned)) => {
                    let mut res = at(scored(c, &rec, &between, half, base, t));
                    res.learned = Some(learned);
                    learning.push(res);
                }
                Err(why) => refused.push((c.name, why)),
            }
        }
        if results.is_empty() {
            continue;
        }
        out.push(SweepPoint {
            fraction: frac,
            frequency: 3.0 * base,
            results,
            learning,
            refused,
        });
    }
    Ok(out)
}

/// The score of one run ([`score`]) with its error between the samples.
fn scored(
    c: &'static Controller,
    rec: &Record,
    between: &Between,
    half: [f64; 2],
    base: f64,
    t: f64,
) -> SweepResult {
    let mut res = score(c, rec, half, base, t);
    (res.rms_between, res.peak_between) = between.steady_rms_peak();
    res.rms_between_pct = [0, 1].map(|i| 100.0 * res.rms_between[i] / (2.0 * half[i]));
    res
}

/// A run with the learning layer, or why its layer could not be designed.
type LearningRun = std::result::Result<(Record, Between, Learned), String>;

/// `c` with the learning layer on `r` (module docs, "Learning"): the learning plant measured
/// from the readings of fresh loops (the twin in its rig, ten periods a run), the law
/// chosen by trial and told the datasheet lag, `trials` periods of learning, then the
/// scored run of `duration` with learning on, with its error between the samples.
fn run_learning(
    bench: &Bench,
    c: &'static Controller,
    r: Reference,
    period: usize,
    duration: f64,
    l: &SweepLearning,
) -> Result<LearningRun> {
    let t = bench.setup.rig.sample_time;
    let infeasible = |e: crate::error::AssessError| ControlError::Infeasible {
        what: "learning loop on the sweep".into(),
        detail: e.to_string(),
    };
    let mut factory = || -> flexstage_control::Result<(Box<dyn StageControl>, Readings)> {
        let ctrl = bench
            .learning_controller(c, Compensation::Inverse, r)
            .map_err(infeasible)?;
        let plant = bench
            .twin
            .plant(&bench.setup.rig)
            .map_err(|e| infeasible(e.into()))?;
        Ok((ctrl, Readings::new(plant)))
    };
    let measured =
        measure_learning_plant(&mut factory, period, learning::MEASURE_PERIODS, l.amplitude)?;
    let designed = learning::choose_law(
        &mut factory,
        &measured,
        &DesignParams::default(),
        l.lag,
        l.trials,
    );
    let (law, rho) = match designed {
        Ok(d) => d,
        Err(e @ ControlError::Unstable { .. }) => return Ok(Err(e.to_string())),
        Err(e) => return Err(e.into()),
    };
    let inner = bench.learning_controller(c, Compensation::Inverse, r)?;
    let mut ctrl = Learning::with_law(inner, &law)?.with_sensor_lag(l.lag)?;
    let mut plant = bench.twin.plant(&bench.setup.rig)?;
    plant.record_substeps();
    let mut sub = Substeps {
        plant,
        out: Vec::new(),
    };
    let learned = l.trials as f64 * period as f64 * t;
    let mut fast = l
        .fast_adc
        .map(|adc| FastChannel::attach(&adc, &mut sub.plant))
        .transpose()?;
    for _ in 0..l.trials {
        match &mut fast {
            None => {
                run(&mut ctrl, &mut sub, period as f64 * t, t, |_| {});
            }
            Some(fast) => {
                let mut recorded = FastRecorded {
                    plant: &mut sub.plant,
                    fast,
                };
                run(&mut ctrl, &mut recorded, period as f64 * t, t, |_| {});
                let record = fast.take_period(period, t)?;
                ctrl.retarget(&record.output_at_samples(&bench.setup.rig.sensor)?)?;
            }
        }
    }
    sub.out.clear();
    let rec = run(&mut ctrl, &mut sub, duration, t, |_| {});
    let between = between(&sub.out, r, bench.setup.rig.substep(), learned);
    let learned = Learned {
        law: law.name(),
        rho,
        periods: l.trials,
    };
    Ok(Ok((rec, between, learned)))
}

/// The true error between the samples of one run: per axis, on every substep h of the run
/// (sample k, substep s at kT + (s + 1) h), the true output minus the reference there.
#[derive(Debug, Clone, PartialEq)]
pub struct Between {
    /// The substep h \[s\].
    pub substep: f64,
    /// The error per axis \[m\].
    pub error: [Vec<f64>; 2],
}

impl Between {
    /// RMS and peak per axis over the second half \[m\].
    pub fn steady_rms_peak(&self) -> ([f64; 2], [f64; 2]) {
        let mut rms = [f64::NAN; 2];
        let mut peak = [f64::NAN; 2];
        for i in 0..2 {
            let e = &self.error[i][self.error[i].len() / 2..];
            if e.is_empty() {
                continue;
            }
            rms[i] = (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt();
            peak[i] = e.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        }
        (rms, peak)
    }

    /// The amplitude \[m\] of axis `i`'s error at frequency `f` \[Hz\] over the second half
    /// (Hann window, amplitude-corrected): to split the error into the scan's lines and the
    /// hold's images f_s ± f.
    pub fn amplitude(&self, i: usize, f: f64) -> f64 {
        let e = &self.error[i][self.error[i].len() / 2..];
        let n = e.len();
        if n < 2 {
            return 0.0;
        }
        let (mut re, mut im, mut wsum) = (0.0, 0.0, 0.0);
        for (k, x) in e.iter().enumerate() {
            let w = 0.5 - 0.5 * (std::f64::consts::TAU * k as f64 / (n - 1) as f64).cos();
            let (sn, cs) = (std::f64::consts::TAU * f * k as f64 * self.substep).sin_cos();
            re += w * x * cs;
            im -= w * x * sn;
            wsum += w;
        }
        2.0 * (re * re + im * im).sqrt() / wsum
    }
}

/// The steady state `StagePlant` of a run that keeps the true output of every substep.
struct Substeps {
    plant: flexstage_sim::rig::RigPlant<flexstage_twin::TwinStage>,
    out: Vec<[f64; 2]>,
}

impl StagePlant for Substeps {
    fn measure(&mut self) -> [f64; 2] {
        self.plant.measure()
    }
    fn output(&self) -> [f64; 2] {
        self.plant.output()
    }
    fn apply(&mut self, cmd: &flexstage_sim::experiment::Command) {
        self.plant.apply(cmd);
        self.out.extend_from_slice(self.plant.output_substeps());
    }
    fn voltage(&self) -> [f64; 2] {
        self.plant.voltage()
    }
    fn x_nom(&self) -> [f64; 2] {
        self.plant.x_nom()
    }
}

/// Runs `c` on the bench's twin in its full rig on `r` for `duration` \[s\]: the record and
/// the true error on every substep ([`Between`]; scoring only).
pub fn run_between(
    bench: &Bench,
    c: &'static Controller,
    r: Reference,
    duration: f64,
) -> Result<(Record, Between)> {
    let t = bench.setup.rig.sample_time;
    let substeps = bench.setup.rig.substeps;
    let h = bench.setup.rig.substep();
    let mut ctrl = bench.controller(c, Compensation::Inverse, r)?;
    let mut plant = bench.twin.plant(&bench.setup.rig)?;
    plant.record_substeps();
    let n = (duration / t).round() as usize;
    let mut sub = Substeps {
        plant,
        out: Vec::with_capacity(n * substeps),
    };
    let rec = run(ctrl.as_mut(), &mut sub, duration, t, |_| {});
    Ok((rec, between(&sub.out, r, h, 0.0)))
}

/// The true error on every substep `h` of a run that started at `start` \[s\]: output j
/// at start + (j + 1) h against the reference there.
fn between(out: &[[f64; 2]], r: Reference, h: f64, start: f64) -> Between {
    let mut error = [Vec::with_capacity(out.len()), Vec::with_capacity(out.len())];
    for (j, q) in out.iter().enumerate() {
        let q_d = r.sample(start + (j + 1) as f64 * h).q;
        for i in 0..2 {
            error[i].push(q[i] - q_d[i]);
        }
    }
    Between { substep: h, error }
}

/// The result of one run (module docs): steady RMS and peak, the largest error line, the
/// share of the error at the reference's lines `base` and 3 `base`, and the error the loop
/// reads.
fn score(c: &'static Controller, rec: &Record, half: [f64; 2], base: f64, t: f64) -> SweepResult {
    let n = rec.t.len();
    let steady = n / 2;
    let mut rms = [0.0; 2];
    let mut peak = [0.0; 2];
    let mut growth = false;
    let mut unseen = false;
    let mut rms_read = [0.0; 2];
    for i in 0..2 {
        let e = &rec.error[i][steady..];
        let ms = |s: &[f64]| s.iter().map(|x| x * x).sum::<f64>() / s.len().max(1) as f64;
        rms[i] = ms(e).sqrt();
        peak[i] = e.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let q = e.len() / 2;
        let (a, b) = (ms(&e[..q]), ms(&e[q..]));
        // Grown by more than 4× in power over a quarter of the run and beyond the reference.
        growth |= b > 4.0 * a && b.sqrt() > half[i];
        let read = rec.measured[i][steady..]
            .iter()
            .zip(&rec.reference[i][steady..])
            .map(|(y, r)| (y - r) * (y - r))
            .sum::<f64>()
            / e.len().max(1) as f64;
        rms_read[i] = read.sqrt();
        unseen |= rms[i] > 2.0 * read.sqrt() && rms[i] > 1e-3 * half[i];
    }
    let finite = rms.iter().chain(&peak).all(|v| v.is_finite()) && rec.stopped.is_none();
    let pct = |v: [f64; 2]| [0, 1].map(|i| 100.0 * v[i] / (2.0 * half[i]));
    let (share, dominant) = if finite {
        lines(rec, steady, base, t)
    } else {
        (0.0, 0.0)
    };
    let cause = if !finite || growth {
        Cause::Unstable
    } else if unseen {
        Cause::Aliasing
    } else if share >= 0.5 {
        Cause::Bandwidth
    } else {
        Cause::Distortion
    };
    SweepResult {
        controller: c,
        amplitude: [f64::NAN; 2],
        reduced: None,
        rms,
        peak,
        rms_pct: pct(rms),
        peak_pct: pct(peak),
        rms_between: [f64::NAN; 2],
        peak_between: [f64::NAN; 2],
        rms_between_pct: [f64::NAN; 2],
        rms_read_pct: pct(rms_read),
        cause,
        dominant,
        learned: None,
    }
}

/// The error's spectrum over the whole base periods of the steady half (a DFT of that
/// window, both axes): the share of its power at the bins of `base` and 3 `base`, and the
/// frequency of its largest line (DC excluded).
fn lines(rec: &Record, steady: usize, base: f64, t: f64) -> (f64, f64) {
    let per = 1.0 / (base * t);
    let len = rec.t.len() - steady;
    let periods = (len as f64 / per).floor().max(1.0);
    let w = ((periods * per).round() as usize).min(len);
    if w < 4 {
        return (0.0, 0.0);
    }
    let table: Vec<(f64, f64)> = (0..w)
        .map(|k| (std::f64::consts::TAU * k as f64 / w as f64).sin_cos())
        .collect();
    let df = 1.0 / (w as f64 * t);
    let own = [base, 3.0 * base].map(|f| (f / df).round() as usize);
    let (mut total, mut at_own, mut best, mut best_f) = (0.0, 0.0, 0.0, 0.0);
    for j in 1..w.div_ceil(2) {
        let mut p = 0.0;
        for i in 0..2 {
            let e = &rec.error[i][steady..steady + w];
            let (mut re, mut im) = (0.0, 0.0);
            for (k, x) in e.iter().enumerate() {
                let (s, c) = table[(j * k) % w];
                re += x * c;
                im -= x * s;
            }
            p += re * re + im * im;
        }
        total += p;
        if own.contains(&j) {
            at_own += p;
        }
        if p > best {
            best = p;
            best_f = j as f64 * df;
        }
    }
    if total > 0.0 {
        (at_own / total, best_f)
    } else {
        (0.0, 0.0)
    }
}

/// The figure: RMS error (mean of both axes, % of range, on a log axis) against the fast
/// component's frequency in % of the first resonance, one line per candidate, and one per
/// candidate with the learning layer (`<name>+learning`) where the sweep learned.
pub fn figure(points: &[SweepPoint], candidates: &[&Controller]) -> Result<String> {
    let mut fig = Figure::new(
        "Lissajous 3:1 on the twin: error against scan frequency",
        "fast component [% of first resonance]",
        "RMS error [% of range], mean of q1, q2",
    )
    .log10_y();
    for (j, c) in candidates.iter().enumerate() {
        let pts = points
            .iter()
            .filter_map(|p| {
                let pct = p.results.get(j)?.rms_pct;
                let v = 0.5 * (pct[0] + pct[1]);
                (v.is_finite() && v > 0.0).then(|| (100.0 * p.fraction, v.log10()))
            })
            .collect();
        fig = fig.with(Series::line(c.name, pts));
    }
    for c in candidates {
        let pts: Vec<(f64, f64)> = points
            .iter()
            .filter_map(|p| {
                let r = p.learning.iter().find(|r| r.controller.name == c.name)?;
                let v = 0.5 * (r.rms_pct[0] + r.rms_pct[1]);
                (v.is_finite() && v > 0.0).then(|| (100.0 * p.fraction, v.log10()))
            })
            .collect();
        if !pts.is_empty() {
            fig = fig.with(Series::line(format!("{}+learning", c.name), pts));
        }
    }
    Ok(fig.to_svg()?)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A steady record at 10 kHz: q1's error 10 nm at 3 f (the reference's own line) and
    /// 5 nm at 7 f, q2's zero; the reading is the true output plus `reading_error` times
    /// the true error.
    fn record(base: f64, reading_error: f64) -> Record {
        let t = 1e-4;
        let n = 4000;
        let mut rec = Record::default();
        for k in 0..n {
            let s = k as f64 * t;
            let w = std::f64::consts::TAU * base * s;
            let e = 1e-8 * (3.0 * w).sin() + 0.5e-8 * (7.0 * w).cos();
            let r = [1e-6 * (3.0 * w).sin(), 1e-6 * w.sin()];
            rec.t.push(s);
            rec.error[0].push(e);
            rec.error[1].push(0.0);
            rec.reference[0].push(r[0]);
            rec.reference[1].push(r[1]);
            rec.measured[0].push(r[0] + reading_error * e);
            rec.measured[1].push(r[1]);
        }
        rec
    }

    /// Reference: a sine of 3 nm at 1 kHz plus 1 nm at 9 kHz sampled at 200 kHz, and its
    /// RMS √(3² + 1²)/√2 nm. Goal: the Hann amplitude reads each line to 1e-3 and the
    /// steady RMS is the analytical one to 1e-3.
    #[test]
    fn the_error_between_the_samples_splits_into_its_lines() {
        let h = 5e-6;
        let e: Vec<f64> = (0..40_000)
            .map(|k| {
                let t = k as f64 * h;
                3e-9 * (std::f64::consts::TAU * 1000.0 * t).sin()
                    + 1e-9 * (std::f64::consts::TAU * 9000.0 * t + 0.3).cos()
            })
            .collect();
        let b = Between {
            substep: h,
            error: [e.clone(), e],
        };
        assert!((b.amplitude(0, 1000.0) / 3e-9 - 1.0).abs() < 1e-3);
        assert!((b.amplitude(0, 9000.0) / 1e-9 - 1.0).abs() < 1e-3);
        assert!(b.amplitude(0, 5000.0) < 1e-12);
        let (rms, _) = b.steady_rms_peak();
        assert!((rms[0] / (10f64.sqrt() / 2f64.sqrt() * 1e-9) - 1.0).abs() < 1e-3);
    }

    /// Reference: Parseval on whole periods: the share of the error's power at the
    /// reference's lines is 1/(1 + 0.5²) = 0.8 and the largest line is 3 f. Goal: the causes
    /// follow their definitions: bandwidth when the loop reads its error, aliasing when the
    /// true error is over twice what it reads, unstable for a non-finite run.
    #[test]
    fn the_error_lines_and_the_causes_follow_their_definitions() {
        let base = 50.0;
        let rec = record(base, 1.0);
        let (share, dominant) = lines(&rec, rec.t.len() / 2, base, 1e-4);
        assert!((share - 0.8).abs() < 1e-9, "{share}");
        assert!((dominant - 150.0).abs() < 1e-9, "{dominant}");
        let c = flexstage_control::registry::DEFAULT;
        let half = [1e-6; 2];
        let r = score(c, &rec, half, base, 1e-4);
        assert_eq!(r.cause, Cause::Bandwidth);
        let rms = (0.5f64 * (1e-16 + 0.25e-16)).sqrt();
        assert!((r.rms[0] / rms - 1.0).abs() < 1e-9, "{:?}", r.rms);
        assert!((r.rms_pct[0] - 100.0 * rms / 2e-6).abs() < 1e-9);
        assert_eq!(
            score(c, &record(base, 0.3), half, base, 1e-4).cause,
            Cause::Aliasing
        );
        let mut bad = record(base, 1.0);
        bad.error[1][3000] = f64::NAN;
        assert_eq!(score(c, &bad, half, base, 1e-4).cause, Cause::Unstable);
    }
}
