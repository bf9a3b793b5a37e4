//! Robustness as a number: every candidate on `plants` perturbed twins in the full rig,
//! designed as [`MonteCarloParams::design`] says: by default ([`PlantDesign::Identified`])
//! each perturbed twin is measured in its own rig with its own noise
//! ([`crate::lab::measure`]) and every controller is designed from that measurement alone
//! ([`Bench::measured`], the procedure `track` follows on the nominal twin), as a lab user
//! tunes on a noisy identification of their own stage; [`PlantDesign::Nominal`] runs the
//! bench's designs (from the nominal twin) unchanged on every perturbed twin. The
//! perturbation acts on the twin's modal model (not the lumped plant): it keeps the designed
//! stage's modes, tilt and coupling, which the controllers must survive, and perturbs them
//! the way a manufactured stage differs from its drawing:
//!
//! * stiffness and mass × U(0.8, 1.2) each: ω_k ∝ √(K/M), mass-normalized shapes ∝ 1/√M, so
//!   the static gain ∝ 1/K;
//! * amplification α × U(0.8, 1.2): the q2 output row;
//! * damping: every mode ζ ~ U(0.5 %, 3 %);
//! * coupling: q1 += c₁ q2, q2 += c₂ q1, |c_i| ~ U(0, 0.15) with random sign;
//! * the compensator's Bouc–Wen parameters (d_p, A, B, γ, δ of both PEAs) × U(0.8, 1.2)
//!   each (the rig's PEAs stay the twin's own);
//! * delay 0, 1 or 2 samples;
//! * the sensor noise (white and 1/f, `sensors.noise_std`) × [`MonteCarloParams::noise`]
//!   (default 2), in the measurement and in the run.
//!
//! A plant passes when the run does not diverge and the RMS error of each axis is within
//! [`MonteCarloParams::rms_bound_pct`] of that axis's reference range (peak to peak).

use flexstage_control::experiment::Setup;
use flexstage_control::registry::Controller;
use flexstage_control::tuning::TuningParams;
use flexstage_numerics::noise::SplitMix64;
use flexstage_sim::rig::RigParams;
use flexstage_sim::trajectory::Reference;
use flexstage_twin::Twin;
use rayon::prelude::*;

use crate::bench::Bench;
use crate::error::{Result, check};
use crate::lab::LabParams;
use crate::track::{diverged, track_on};

/// How the study designs the controllers it runs on a perturbed plant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PlantDesign {
    /// Each perturbed twin measured in its own rig with its noise
    /// ([`crate::lab::measure`], [`LabParams::default`]) and every controller designed from
    /// that measurement alone with [`TuningParams::default`] ([`Bench::measured`], as
    /// `track` designs on the nominal twin).
    #[default]
    Identified,
    /// The bench's designs, from the nominal twin, on every perturbed twin unchanged.
    Nominal,
}

impl PlantDesign {
    /// The name in settings and files: `identified` or `nominal`.
    pub fn name(self) -> &'static str {
        match self {
            PlantDesign::Identified => "identified",
            PlantDesign::Nominal => "nominal",
        }
    }

    /// The design named `name` ([`PlantDesign::name`]); the error names the accepted ones.
    pub fn from_name(name: &str) -> Result<PlantDesign> {
        match name {
            "identified" => Ok(PlantDesign::Identified),
            "nominal" => Ok(PlantDesign::Nominal),
            _ => Err(flexstage_numerics::RangeError::new(
                "montecarlo.design",
                name,
                "identified (each plant measured, the controllers designed from it) or \
                 nominal (the nominal designs on every plant)",
            )
            .into()),
        }
    }
}

/// Settings of the Monte-Carlo study.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MonteCarloParams {
    /// Number of plants, ≥ 1 (default 100).
    pub plants: usize,
    /// Duration of each run \[s\], > 0 (default 0.5: one period of the default Lissajous).
    pub duration: f64,
    /// Pass bound on the RMS error per axis in % of its reference range, > 0 (default 0.5 %:
    /// 80/160 nm on the default 8/16 µm Lissajous).
    pub rms_bound_pct: f64,
    /// Seed of the perturbations.
    pub seed: u64,
    /// Relative spread of K, M, α and the compensator parameters (default 0.2).
    pub spread: f64,
    /// Largest coupling (default 0.15).
    pub coupling: f64,
    /// Damping range (default 0.5–3 %).
    pub damping: [f64; 2],
    /// Largest delay \[samples\] (default 2).
    pub max_delay: usize,
    /// Factor on the rig's sensor noise `sensors.noise_std` (white and 1/f), ≥ 0 (default 2).
    pub noise: f64,
    /// How the controllers on a perturbed plant are designed (default
    /// [`PlantDesign::Identified`]).
    pub design: PlantDesign,
}

impl Default for MonteCarloParams {
    fn default() -> Self {
        MonteCarloParams {
            plants: 100,
            duration: 0.5,
            rms_bound_pct: 0.5,
            seed: 18,
            spread: 0.2,
            coupling: 0.15,
            damping: [0.005, 0.03],
            max_delay: 2,
            noise: 2.0,
            design: PlantDesign::Identified,
        }
    }
}

impl MonteCarloParams {
    /// Checks the fields.
    pub fn validate(&self) -> Result<()> {
        check(
            "montecarlo.plants",
            self.plants as f64,
            self.plants >= 1,
            "≥ 1",
        )?;
        check(
            "montecarlo.duration",
            self.duration,
            self.duration > 0.0,
            "> 0 s",
        )?;
        check(
            "montecarlo.rms_bound_pct",
            self.rms_bound_pct,
            self.rms_bound_pct > 0.0,
            "> 0 %",
        )?;
        check(
            "montecarlo.spread",
            self.spread,
            (0.0..0.9).contains(&self.spread),
            "0–0.9",
        )?;
        check(
            "montecarlo.coupling",
            self.coupling,
            (0.0..0.9).contains(&self.coupling),
            "0–0.9",
        )?;
        check(
            "montecarlo.damping",
            self.damping[0],
            self.damping[0] > 0.0 && self.damping[1] >= self.damping[0] && self.damping[1] < 1.0,
            "0 < min ≤ max < 1",
        )?;
        check(
            "montecarlo.max_delay",
            self.max_delay as f64,
            self.max_delay <= 2,
            "0–2 samples",
        )?;
        check(
            "montecarlo.noise",
            self.noise,
            self.noise >= 0.0 && self.noise.is_finite(),
            "a factor ≥ 0",
        )
    }
}

/// One perturbed plant and every candidate's result on it.
#[derive(Debug, Clone, PartialEq)]
pub struct PlantResult {
    /// Plant index.
    pub index: usize,
    /// The plant's perturbation.
    pub perturbation: Perturbation,
    /// Per candidate: RMS error per axis \[m\] and pass.
    pub results: Vec<(&'static Controller, [f64; 2], bool)>,
}

/// The study's result.
#[derive(Debug, Clone, PartialEq)]
pub struct MonteCarlo {
    /// The candidates, in column order.
    pub candidates: Vec<&'static Controller>,
    /// One entry per plant.
    pub plants: Vec<PlantResult>,
}

impl MonteCarlo {
    /// Pass rate of candidate column `j` [0–1].
    pub fn pass_rate(&self, j: usize) -> f64 {
        let n = self.plants.iter().filter(|p| p.results[j].2).count();
        n as f64 / self.plants.len().max(1) as f64
    }
}

/// Runs the study on `reference` for the `candidates`, plants in parallel.
pub fn monte_carlo(
    bench: &Bench,
    candidates: &[&'static Controller],
    reference: Reference,
    p: &MonteCarloParams,
) -> Result<MonteCarlo> {
    p.validate()?;
    let plants = (0..p.plants)
        .into_par_iter()
        .map(|i| one_plant(bench, candidates, reference, p, i))
        .collect::<Result<Vec<_>>>()?;
    Ok(MonteCarlo {
        candidates: candidates.to_vec(),
        plants,
    })
}

/// The perturbation of one plant (module docs), drawn from the study's seed and the plant's
/// index alone.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Perturbation {
    /// Stiffness factor.
    pub stiffness: f64,
    /// Mass factor.
    pub mass: f64,
    /// Amplification factor.
    pub alpha: f64,
    /// Damping ratio of every mode.
    pub damping: f64,
    /// Couplings (c₁, c₂).
    pub coupling: [f64; 2],
    /// Delay \[samples\].
    pub delay: usize,
    /// Factors on the compensator's (d_p, A, B, γ, δ) of each PEA.
    pub compensator: [[f64; 5]; 2],
}

impl Perturbation {
    /// The perturbation of plant `i` of the study `p`: the same whichever process or thread
    /// draws it, and in whatever order.
    pub fn draw(p: &MonteCarloParams, i: usize) -> Perturbation {
        let mut rng = SplitMix64::new(p.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ i as u64);
        let mut u = |lo: f64, hi: f64| lo + (hi - lo) * rng.next_f64();
        let s = p.spread;
        let (stiffness, mass, alpha) = (
            u(1.0 - s, 1.0 + s),
            u(1.0 - s, 1.0 + s),
            u(1.0 - s, 1.0 + s),
        );
        let damping = u(p.damping[0], p.damping[1]);
        let mut coupling = [0.0; 2];
        for c in &mut coupling {
            let sign = if u(0.0, 1.0) < 0.5 { -1.0 } else { 1.0 };
            *c = sign * u(0.0, p.coupling);
        }
        let delay = ((u(0.0, 1.0) * (p.max_delay + 1) as f64) as usize).min(p.max_delay);
        let mut compensator = [[1.0; 5]; 2];
        for f in compensator.iter_mut().flatten() {
            *f = u(1.0 - s, 1.0 + s);
        }
        Perturbation {
            stiffness,
            mass,
            alpha,
            damping,
            coupling,
            delay,
            compensator,
        }
    }

    /// Plant `i`'s result with this perturbation and the candidates' `results`.
    pub fn result(
        &self,
        i: usize,
        results: Vec<(&'static Controller, [f64; 2], bool)>,
    ) -> PlantResult {
        PlantResult {
            index: i,
            perturbation: *self,
            results,
        }
    }

    /// The perturbed twin, the controllers' settings with the perturbed compensator and the
    /// perturbed rig (delay, sensor noise × `noise`, noise seed + `i`) of `bench`'s.
    pub fn apply(&self, bench: &Bench, noise: f64, i: usize) -> (Twin, Setup, RigParams) {
        let (k, m, a) = (self.stiffness, self.mass, self.alpha);
        let mut twin = bench.twin.clone();
        for mode in &mut twin.modal.modes {
            mode.frequency *= (k / m).sqrt();
            mode.damping = self.damping;
            for x in mode.input.iter_mut().take(2) {
                *x /= m.sqrt();
            }
            let o = mode.output.map(|x| x / m.sqrt());
            mode.output = [
                o[0] + self.coupling[0] * o[1] * a,
                a * (o[1] + self.coupling[1] * o[0]),
            ];
        }
        let mut setup = bench.setup.clone();
        for (h, f) in setup
            .controller
            .actuator
            .hysteresis
            .iter_mut()
            .zip(&self.compensator)
        {
            h.d_p *= f[0];
            h.a_bw *= f[1];
            h.b_bw *= f[2];
            h.gamma_bw *= f[3];
            h.delta_bw *= f[4];
        }
        let mut rig = bench.setup.rig.clone();
        rig.delay = self.delay;
        rig.seed = rig.seed.wrapping_add(i as u64);
        rig.noise_std = rig.noise_std.map(|s| s * noise);
        (twin, setup, rig)
    }
}

/// Plant `i` of the study: its perturbation ([`Perturbation::draw`]) and every candidate's
/// result on it, designed as `p.design` says. [`monte_carlo`] is this for `i` in
/// `0..p.plants`. With [`PlantDesign::Identified`], `bench`'s designs are not used: its
/// twin, rig and controllers' settings are the nominal stage ([`Bench::scenario`] is the
/// cheapest such bench; a designed bench's fitted controller model is where each plant's
/// model fit starts).
pub fn one_plant(
    bench: &Bench,
    candidates: &[&'static Controller],
    reference: Reference,
    p: &MonteCarloParams,
    i: usize,
) -> Result<PlantResult> {
    let pert = Perturbation::draw(p, i);
    let (twin, mut setup, rig) = pert.apply(bench, p.noise, i);
    let own;
    let (bench, setup, twin) = match p.design {
        PlantDesign::Nominal => (bench, &setup, &twin),
        PlantDesign::Identified => {
            setup.rig = rig.clone();
            // The study runs the controllers without learning: no designs for it.
            let tuning = TuningParams {
                learning_widening: [0.0; 2],
                ..TuningParams::default()
            };
            match Bench::measured(setup, twin, tuning, &LabParams::default()) {
                Ok((b, _)) => own = b,
                // The procedure gives no controller for this stage: every candidate fails.
                Err(e) if no_design(&e) => {
                    let failed = candidates.iter().map(|&c| (c, [f64::INFINITY; 2], false));
                    return Ok(pert.result(i, failed.collect()));
                }
                Err(e) => return Err(e),
            }
            (&own, &own.setup, &own.twin)
        }
    };
    let mut results = Vec::with_capacity(candidates.len());
    for &c in candidates {
        let r = match track_on(bench, setup, twin, &rig, c, reference, p.duration) {
            Ok(r) => r,
            // The procedure gave no design of this controller for this plant's measurement
            // (the bench keeps only the designs that met their margins): it fails here.
            Err(e) if no_design(&e) => {
                results.push((c, [f64::INFINITY; 2], false));
                continue;
            }
            Err(e) => return Err(e),
        };
        let pass =
            !diverged(&r) && r.rms_pct[0] <= p.rms_bound_pct && r.rms_pct[1] <= p.rms_bound_pct;
        let rms = if diverged(&r) {
            [f64::INFINITY; 2]
        } else {
            r.rms
        };
        results.push((c, rms, pass));
    }
    Ok(pert.result(i, results))
}

/// Whether `e` says the design procedure found no controller for a measured stage (the
/// tuning meets no margins, a design is infeasible, the loop model cannot be fitted): the
/// plant fails, the study goes on. Any other error stops the study.
fn no_design(e: &crate::error::AssessError) -> bool {
    use crate::error::AssessError;
    use flexstage_control::ControlError;
    matches!(
        e,
        AssessError::Control(ControlError::Unstable { .. } | ControlError::Infeasible { .. })
            | AssessError::Identify(flexstage_identify::IdentifyError::Estimate { .. })
    )
}
