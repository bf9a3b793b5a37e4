//! The twin's verification against the full model.
//!
//! * **Full reference**: the assembled stage's Total Lagrangian FE model with its mass,
//!   the same Rayleigh damping and the PEA loads K_pea·x_nom(t), integrated with
//!   `flexstage_fem::transient` (Newmark average acceleration, Newton per step) —
//!   [`full_response`].
//! * **Twin**: the same x_nom(t) through the twin's mechanics alone (no rig) — [`twin_response`].
//! * **Agreement**: per axis, the largest |q_twin − q_full| over the run, relative to the range
//!   (peak to peak) of the full model's output — [`agreement`].
//! * **Modes**: the twin's natural frequencies against the FE modal analysis of the assembled
//!   stage (same mass, springs and plates), for every mode the twin claims (below its reach,
//!   [`Twin::covered_frequency`]) — [`mode_check`].
//! * [`validate`] runs a step and a 200 Hz sine (defaults of [`ValidationParams`]) and collects
//!   all of it with the reference's cost: the report's "validity of the twin".
//!
//! **Input bandwidth.** The twin represents the stage's dynamics up to the band its modes
//! cover; an input with content far above it (an ideal jump) excites FE modes the twin does
//! not have. The step therefore rises smoothly (C², 0.5 ms) and the sine starts with the same
//! window over one period. That is still far faster than the rig can move the PEAs: with the
//! default amplifier (0.1 A into 1.5 µF, 67 V/ms) a 24 µm step takes about 6 ms. A 50 µs rise
//! is reported as well ([`CaseResult`] "fast step"), with its larger error, as the twin's
//! documented limit.

use flexstage_fem::{Transient, TransientParams, TransientStats};
use flexstage_reduce::{ModalParams, PointMass, modal_analysis};
use flexstage_sim::rig::Mechanics;
use serde::Serialize;

use crate::error::{Result, check};
use crate::twin::Twin;

/// A time series of the output and the input plates.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Series {
    /// Time \[s\].
    pub t: Vec<f64>,
    /// Output q1, q2 \[m\].
    pub q: [Vec<f64>; 2],
    /// Input plates x_in1, x_in2 \[m\].
    pub x_in: [Vec<f64>; 2],
}

impl Series {
    fn with_capacity(n: usize) -> Series {
        let v = || Vec::with_capacity(n);
        Series {
            t: v(),
            q: [v(), v()],
            x_in: [v(), v()],
        }
    }

    fn push(&mut self, t: f64, q: [f64; 2], x_in: [f64; 2]) {
        self.t.push(t);
        for i in 0..2 {
            self.q[i].push(q[i]);
            self.x_in[i].push(x_in[i]);
        }
    }
}

/// Settings of the full transient reference.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ReferenceParams {
    /// Time step \[s\], in (0, 1e-4]. Default 0.5 µs: the period error (ωΔt)²/12 of the
    /// average-acceleration scheme is 2e-3 at 50 kHz, which the 50 µs fast step excites (at
    /// 2 µs it was 3 %, and the check itself made 2.4 of the fast step's 4.1 % of range with
    /// 24 fixed-interface modes).
    pub dt: f64,
    /// HHT α, in [−⅓, 0]. Default 0 (average acceleration).
    pub hht_alpha: f64,
    /// Newton residual tolerance, in (0, 1e-3]. Default 1e-10.
    pub residual_tol: f64,
}

impl Default for ReferenceParams {
    fn default() -> Self {
        ReferenceParams {
            dt: 0.5e-6,
            hht_alpha: 0.0,
            residual_tol: 1e-10,
        }
    }
}

/// The cost of a full transient run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ReferenceCost {
    /// Steps.
    pub steps: usize,
    /// Newton iterations.
    pub iterations: usize,
    /// Factorizations of the effective matrix.
    pub factorizations: usize,
    /// Wall-clock time \[s\].
    pub seconds: f64,
    /// Free DOFs of the model.
    pub dofs: usize,
}

/// The full nonlinear transient response of the twin's FE model to `x_nom(t)` over
/// `duration` seconds, from rest; one sample per step.
pub fn full_response(
    twin: &Twin,
    x_nom: &(dyn Fn(f64) -> [f64; 2] + Sync),
    duration: f64,
    params: &ReferenceParams,
) -> Result<(Series, ReferenceCost)> {
    check(
        "duration",
        duration,
        duration > 0.0 && duration <= 1.0,
        "(0, 1] s",
    )?;
    check(
        "reference dt",
        params.dt,
        params.dt > 0.0 && params.dt <= 1e-4,
        "(0, 1e-4] s",
    )?;
    let start = std::time::Instant::now();
    let fe = &twin.fe;
    let tp = TransientParams {
        dt: params.dt,
        hht_alpha: params.hht_alpha,
        residual_tol: params.residual_tol,
        ..TransientParams::default()
    };
    let mut tr = Transient::new(
        &fe.model,
        fe.design(),
        fe.mass_matrix()?,
        twin.modal.damping,
        tp,
    )?;
    let n = (duration / params.dt).round() as usize;
    let mut out = Series::with_capacity(n + 1);
    let [_, _, ox, oy] = fe.interface;
    out.push(0.0, [0.0; 2], [0.0; 2]);
    let mut p = fe.model.zero_vector();
    for k in 1..=n {
        let t = k as f64 * params.dt;
        fe.pea_load_into(x_nom(t), &mut p);
        tr.step(&p)?;
        let u = tr.displacement();
        out.push(t, [u[ox], u[oy]], fe.input_displacements(u));
    }
    let s: TransientStats = tr.stats();
    Ok((
        out,
        ReferenceCost {
            steps: s.steps,
            iterations: s.iterations,
            factorizations: s.factorizations,
            seconds: start.elapsed().as_secs_f64(),
            dofs: fe.model.dofs().n_free(),
        },
    ))
}

/// The twin's mechanics (no rig) driven by `x_nom(t)` with first-order hold between samples
/// `dt` apart, from rest.
pub fn twin_response(
    twin: &Twin,
    x_nom: &dyn Fn(f64) -> [f64; 2],
    duration: f64,
    dt: f64,
    nonlinear: bool,
) -> Series {
    let mut stage = twin.stage(dt);
    if !nonlinear {
        stage = crate::stage::TwinStage::new(&twin.modal, None, dt);
    }
    let n = (duration / dt).round() as usize;
    let mut out = Series::with_capacity(n + 1);
    out.push(0.0, stage.output(), stage.inputs());
    let mut x0 = x_nom(0.0);
    for k in 1..=n {
        let t = k as f64 * dt;
        let x1 = x_nom(t);
        stage.advance([x0, x1], [[0.0; 2]; 2]);
        out.push(t, stage.output(), stage.inputs());
        x0 = x1;
    }
    out
}

/// Agreement of two responses sampled at the same times.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Agreement {
    /// Largest |q_other − q_reference| per axis \[m\].
    pub max_error: [f64; 2],
    /// Range (max − min) of the reference per axis \[m\].
    pub range: [f64; 2],
}

impl Agreement {
    /// `max_error / range` per axis.
    pub fn relative(&self) -> [f64; 2] {
        [0, 1].map(|i| self.max_error[i] / self.range[i])
    }
}

/// The agreement of `other` with `reference` (same sample times).
pub fn agreement(reference: &Series, other: &Series) -> Agreement {
    let mut a = Agreement {
        max_error: [0.0; 2],
        range: [0.0; 2],
    };
    for i in 0..2 {
        let r = &reference.q[i];
        let lo = r.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = r.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        a.range[i] = hi - lo;
        a.max_error[i] = r
            .iter()
            .zip(&other.q[i])
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
    }
    a
}

/// One of the twin's modes against the FE modal analysis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ModeCheck {
    /// Mode number (1-based).
    pub index: usize,
    /// Twin \[Hz\].
    pub twin: f64,
    /// FE modal analysis of the assembled stage \[Hz\].
    pub fe: f64,
    /// (twin − fe)/fe.
    pub relative: f64,
    /// The twin's damping ratio of the mode.
    pub damping: f64,
}

/// The twin's modes below its reach ([`Twin::covered_frequency`], at least one) against the
/// FE modal analysis (shift-invert Lanczos) of the same assembled stage.
pub fn mode_check(twin: &Twin) -> Result<Vec<ModeCheck>> {
    let fe = &twin.fe;
    let limit = twin.covered_frequency();
    let claimed = twin
        .modal
        .modes
        .iter()
        .filter(|m| m.frequency <= limit * (1.0 + 1e-9))
        .count()
        .max(1);
    // The plates (over the inputs' faces along x) and the payload (on both output DOFs) as
    // node masses in their directions.
    let plates: Vec<PointMass> = fe
        .point_masses
        .iter()
        .map(|p| PointMass {
            node: p.dof / 2,
            mass: p.mass,
            axes: [p.dof % 2 == 0, p.dof % 2 == 1],
        })
        .collect();
    let params = ModalParams {
        modes: claimed,
        interpolation: fe.interpolation,
        ..ModalParams::default()
    };
    let modes = modal_analysis(&fe.model, &fe.rho, fe.density, &plates, &params)?;
    Ok(modes
        .frequencies
        .iter()
        .zip(&twin.modal.modes)
        .enumerate()
        .map(|(k, (&f, m))| ModeCheck {
            index: k + 1,
            twin: m.frequency,
            fe: f,
            relative: (m.frequency - f) / f,
            damping: m.damping,
        })
        .collect())
}

/// The test inputs of [`validate`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ValidationParams {
    /// Stroke scale a \[m\]: the step goes to (a, −a/2), the sine has amplitude a. Default 24 µm.
    pub amplitude: f64,
    /// Rise time of the step and ramp-in time of the sine \[s\] (the C² window
    /// `10x³ − 15x⁴ + 6x⁵`). Default 0.5 ms.
    pub rise: f64,
    /// Rise time of the additional fast step \[s\] (0: not run). Default 50 µs.
    pub fast_rise: f64,
    /// Sine frequency \[Hz\]. Default 200.
    pub frequency: f64,
    /// Duration of each run \[s\]. Default 20 ms.
    pub duration: f64,
    /// The full reference.
    pub reference: ReferenceParams,
}

impl Default for ValidationParams {
    fn default() -> Self {
        ValidationParams {
            amplitude: 24e-6,
            rise: 0.5e-3,
            fast_rise: 50e-6,
            frequency: 200.0,
            duration: 20e-3,
            reference: ReferenceParams::default(),
        }
    }
}

/// The C² window `10x³ − 15x⁴ + 6x⁵`, x = t/rise clamped to [0, 1].
fn window(t: f64, rise: f64) -> f64 {
    if rise <= 0.0 {
        return if t > 0.0 { 1.0 } else { 0.0 };
    }
    let x = (t / rise).clamp(0.0, 1.0);
    x * x * x * (10.0 + x * (6.0 * x - 15.0))
}

impl ValidationParams {
    /// The step input: x_nom = (a, −a/2)·w(t) with rise time `rise`: both output axes move.
    pub fn step(&self, rise: f64) -> impl Fn(f64) -> [f64; 2] + Sync + '_ {
        move |t: f64| {
            let w = window(t, rise);
            [self.amplitude * w, -0.5 * self.amplitude * w]
        }
    }

    /// The sine input: x_nom = a·w(t)·(sin ωt, −sin(ωt − π/3)), ramped in over `rise`: both
    /// output axes move.
    pub fn sine(&self) -> impl Fn(f64) -> [f64; 2] + Sync + '_ {
        move |t: f64| {
            let w = std::f64::consts::TAU * self.frequency * t;
            let a = self.amplitude * window(t, self.rise);
            [a * w.sin(), -a * (w - std::f64::consts::FRAC_PI_3).sin()]
        }
    }
}

/// One input of the validation: twin (with and without the nonlinear correction) against the
/// full model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CaseResult {
    /// "step", "sine" or "fast step".
    pub name: String,
    /// The twin as built.
    pub twin: Agreement,
    /// The linear twin (no nonlinear correction).
    pub linear_twin: Agreement,
    /// The full reference's cost.
    pub cost: ReferenceCost,
    /// The full model's output, decimated to ≤ 2000 points (for figures).
    pub full: Series,
    /// The twin's output at the same times.
    pub twin_series: Series,
}

/// The twin's validity (module docs).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Validity {
    /// Modes against the FE modal analysis.
    pub modes: Vec<ModeCheck>,
    /// Step and sine.
    pub cases: Vec<CaseResult>,
    /// The settings.
    pub params: ValidationParams,
}

fn decimate(s: &Series, max: usize) -> Series {
    let step = (s.t.len() / max).max(1);
    let pick = |v: &Vec<f64>| v.iter().step_by(step).copied().collect::<Vec<_>>();
    Series {
        t: pick(&s.t),
        q: [pick(&s.q[0]), pick(&s.q[1])],
        x_in: [pick(&s.x_in[0]), pick(&s.x_in[1])],
    }
}

fn case(
    twin: &Twin,
    name: &str,
    input: &(dyn Fn(f64) -> [f64; 2] + Sync),
    p: &ValidationParams,
) -> Result<CaseResult> {
    let (full, cost) = full_response(twin, input, p.duration, &p.reference)?;
    let dt = p.reference.dt;
    let tw = twin_response(twin, input, p.duration, dt, true);
    let lin = twin_response(twin, input, p.duration, dt, false);
    Ok(CaseResult {
        name: name.into(),
        twin: agreement(&full, &tw),
        linear_twin: agreement(&full, &lin),
        cost,
        full: decimate(&full, 2000),
        twin_series: decimate(&tw, 2000),
    })
}

/// Runs the modal check, the step, the sine and (if `fast_rise` > 0) the fast step against
/// the full model, in parallel.
pub fn validate(twin: &Twin, params: &ValidationParams) -> Result<Validity> {
    let modes = mode_check(twin)?;
    let step = params.step(params.rise);
    let fast = params.step(params.fast_rise);
    let sine = params.sine();
    let (a, (b, c)) = rayon::join(
        || case(twin, "step", &step, params),
        || {
            rayon::join(
                || case(twin, "sine", &sine, params),
                || {
                    (params.fast_rise > 0.0)
                        .then(|| case(twin, "fast step", &fast, params))
                        .transpose()
                },
            )
        },
    );
    let mut cases = vec![a?, b?];
    cases.extend(c?);
    Ok(Validity {
        modes,
        cases,
        params: *params,
    })
}
