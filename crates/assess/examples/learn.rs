//! Iterative learning on the twin of the designed stage (flexstage-control's `learning`) on
//! top of each shipped controller, as `flexstage track --learning` runs it: the controller's
//! design tuned for learning (`Designs::for_learning`: the linear designs tuned to the margin
//! targets widened by `TuningParams::learning_widening`), the learning plant T measured from
//! the ADC readings at every harmonic of the 3:1 Lissajous period on the twin in its rig with
//! that design closed (`MEASURE_PERIODS` periods a run, as `track`; fewer when PERIODS is
//! smaller, for a short check), both laws designed from it (monotone-convergence factor
//! ρ < 1 with the measurement's uncertainty) and the one kept that learns better in a trial
//! of PERIODS periods on the loop's readings (`learning::choose_law`), told the sensor
//! chain's datasheet lag; then PERIODS periods (default 20) with learning beside the
//! controller's own design without; RMS error against the true output (scoring only) of the
//! last period, the period from which it stays within 10 % of that, and the largest growth of
//! the per-period RMS from one period to the next after the third (monotone convergence: ≤ 1
//! within the noise), beside the same for the controller without learning, whose per-period
//! RMS varies by noise alone.
//!
//! The controllers are designed as `flexstage track` designs them ([`Bench::measured`]: from
//! the twin measured in its rig, the linear ones' feed-forward fitted to the lifted response);
//! the twin scores them.
//!
//! `cargo run --release -p flexstage-assess --example learn -- quick runs/quick/design/design.json [PERIODS]`

use flexstage_assess::Bench;
use flexstage_assess::lab::LabParams;
use flexstage_control::ControlError;
use flexstage_control::actuator::Compensation;
use flexstage_control::experiment::Setup;
use flexstage_control::learning::{
    DesignParams, Learning, MEASURE_PERIODS, Readings, SensorDatasheet, choose_law,
    measure_learning_plant, rms_per_period,
};
use flexstage_control::registry::Controller;
use flexstage_control::tuning::TuningParams;
use flexstage_run::Format;
use flexstage_run::files::design::DesignFile;
use flexstage_scenario::{Preset, Scenario, Trajectory};
use flexstage_sim::experiment::StageControl;
use flexstage_sim::experiment::run;
use flexstage_sim::trajectory::Reference;
use flexstage_twin::DesignedStage;

/// The multisine's RMS per axis with which the learning plant is measured \[m\] (as
/// `flexstage track`'s).
const AMPLITUDE: f64 = 20e-9;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let preset = args
        .get(1)
        .and_then(|p| Preset::from_name(p))
        .ok_or("usage: learn quick|paper DESIGN.json [PERIODS]")?;
    let design_file = DesignFile::decode(&std::fs::read(args.get(2).ok_or("missing design")?)?)?;
    let periods: usize = args.get(3).map(|s| s.parse()).transpose()?.unwrap_or(20);
    let DesignedStage {
        scenario: s, twin, ..
    } = DesignedStage::new(&Scenario::preset(preset), &design_file.rho)?;
    let setup = Setup::from_scenario(&s);
    // Designed from the twin measured in its rig, as `track` designs; the default tuning
    // widens the margin targets under learning (`Designs::for_learning`).
    let (bench, _) = Bench::measured(setup, twin, TuningParams::default(), &LabParams::default())?;
    let trajectory = s
        .trajectories
        .iter()
        .find(|t| matches!(t, Trajectory::Lissajous { ratio, .. } if *ratio == 3.0))
        .ok_or("the scenario has no 3:1 Lissajous")?;
    let (reference, _) = Reference::from_scenario(trajectory);
    let Trajectory::Lissajous { frequency, .. } = trajectory else {
        unreachable!()
    };
    let t = bench.setup.rig.sample_time;
    let period = (1.0 / (frequency * t)).round() as usize;
    let lag = SensorDatasheet::from_scenario(&s).lag(t)?;
    println!(
        "twin f1 = {:.0} Hz; 3:1 Lissajous at {frequency} Hz ({period} samples per period), \
         {periods} periods; RMS against the true output",
        bench.twin.first_resonance()
    );
    println!(
        "controller       without q1/q2 [nm]  with learning q1/q2 [nm]  settled from  \
         law, ρ  datasheet lag [samples]  growth after 3 (without)"
    );
    let measure_periods = periods.clamp(2, MEASURE_PERIODS);
    for c in Controller::defaults() {
        // The loop learning runs on: the design tuned for it, in the twin's rig.
        let make = || -> flexstage_control::Result<(Box<dyn StageControl>, Readings)> {
            let infeasible = |what: &str, e: &dyn std::fmt::Display| ControlError::Infeasible {
                what: what.into(),
                detail: e.to_string(),
            };
            let ctrl = bench
                .learning_controller(c, Compensation::Inverse, reference)
                .map_err(|e| infeasible("controller", &e))?;
            let plant = bench
                .twin
                .plant(&bench.setup.rig)
                .map_err(|e| infeasible("twin plant", &e))?;
            Ok((ctrl, Readings::new(plant)))
        };
        let plant = measure_learning_plant(&mut || make(), period, measure_periods, AMPLITUDE)?;
        let (law, rho) = choose_law(
            &mut || make(),
            &plant,
            &DesignParams::default(),
            lag,
            periods,
        )?;
        let duration = periods as f64 * period as f64 * t;
        // The scored runs: the same loop, the stage's true output recorded for the score.
        let twin_plant = || bench.twin.plant(&bench.setup.rig);
        let ctrl = bench.learning_controller(c, Compensation::Inverse, reference)?;
        let mut with = Learning::with_law(ctrl, &law)?.with_sensor_lag(lag)?;
        let rec = run(&mut with, &mut twin_plant()?, duration, t, |_| {});
        let mut c0 = bench.controller(c, Compensation::Inverse, reference)?;
        let rec0 = run(c0.as_mut(), &mut twin_plant()?, duration, t, |_| {});
        let with = rms_per_period(&rec.error, period);
        let without = rms_per_period(&rec0.error, period);
        let (last, last0) = (with[with.len() - 1], without[without.len() - 1]);
        let growth = |r: &[[f64; 2]]| {
            (3..r.len())
                .flat_map(|j| (0..2).map(move |a| (j, a)))
                .map(|(j, a)| r[j][a] / r[j - 1][a])
                .fold(0.0f64, f64::max)
        };
        let (growth, growth0) = (growth(&with), growth(&without));
        let settled = with
            .iter()
            .rposition(|r| (0..2).any(|a| r[a] > 1.1 * last[a]))
            .map_or(1, |j| j + 2);
        println!(
            "{:<16} {:>8.1}/{:<8.1}  {:>12.1}/{:<10.1}  {:>12}  {}, ρ {rho:.3}  {:.3}  {growth:.3} ({growth0:.3})",
            c.name,
            last0[0] * 1e9,
            last0[1] * 1e9,
            last[0] * 1e9,
            last[1] * 1e9,
            settled,
            law.describe(),
            lag.samples()[0],
        );
    }
    Ok(())
}
