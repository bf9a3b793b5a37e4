//! Writes every exportable registry controller as C (`<prefix>.c`, `<prefix>.h`) with the
//! sequence the Rust controller recorded (`<prefix>.csv`, [`recorded_sequence`]), for the CI
//! check that compiles the C and requires it to agree to 1e-12 (`.ci/c-check`). The
//! controllers are designed as the registry test designs them: the paper scenario on two
//! decoupled 1 %-damped modes with one sample of delay, inverse compensation; the PI + notch
//! and the PID with the FIR inverse of that loop with preview (the default feed-forward), the
//! PPF controller with its damping filters. The default controller is also written with the
//! compensation off and ideal (`<prefix>_off`, `<prefix>_ideal`) and with a learned table of
//! one 20 Hz period (`<prefix>_learning`), and mutated copies that the check must refuse,
//! each checked against the unchanged sequence (`<prefix>_mutated_*`): its k_i, its largest
//! FIR tap, its learned table, its rate limit (the amplifier's, from the paper scenario's
//! datasheet values) and the PPF filter's gain, each changed by one part in 10⁹.
//! The backstepping controllers (`robust`, `nonrobust`) are written with their own law and
//! sequence ([`BacksteppingLaw`], checked by `c/check_backstepping.c`) predicting over the
//! stage's one sample of delay; `robust` also over none and two (`robust_delay0`,
//! `robust_delay2`), with the compensation off (`robust_off`), with the learned table
//! (`robust_learning`), and mutated: an entry of its filter matrix F, its G⁻¹ and its
//! learned table, each changed by one part in 10⁹ (`robust_mutated_*`).
//!
//! `cargo run --release -p flexstage-control --example export_check -- OUT_DIR`

use std::fmt::Write as _;
use std::path::Path;

use flexstage_control::actuator::Compensation;
use flexstage_control::experiment::Setup;
use flexstage_control::feedforward::FirFeedForward;
use flexstage_control::registry::{CONTROLLERS, DEFAULT, Design};
use flexstage_control::target::{TargetLaw, c_prefix, recorded_sequence};
use flexstage_control::target_backstepping::{self as bs, BacksteppingLaw};
use flexstage_control_core::Biquad;

fn write(
    dir: &Path,
    prefix: &str,
    law: &TargetLaw,
    sequence_of: &TargetLaw,
) -> Result<(), Box<dyn std::error::Error>> {
    let src = law.c_source(prefix, &format!("{prefix}.h"))?;
    std::fs::write(dir.join(format!("{prefix}.h")), src.header)?;
    std::fs::write(dir.join(format!("{prefix}.c")), src.source)?;
    let seq = recorded_sequence(sequence_of, 2022)?;
    let mut csv =
        String::from("ahead1,ahead2,r1,r2,y1,y2,index,voltage1,voltage2,x_nom1,x_nom2,saturated\n");
    for q in &seq.primed {
        let _ = writeln!(csv, "p,{:e},{:e}", q[0], q[1]);
    }
    for s in &seq.samples {
        let (i, c) = (s.input, s.command);
        let _ = writeln!(
            csv,
            "{:e},{:e},{:e},{:e},{:e},{:e},{},{:e},{:e},{:e},{:e},{}",
            i.ahead[0],
            i.ahead[1],
            i.reference[0],
            i.reference[1],
            i.reading[0],
            i.reading[1],
            i.index,
            c.voltage[0],
            c.voltage[1],
            c.x_nom[0],
            c.x_nom[1],
            u8::from(c.saturated)
        );
    }
    std::fs::write(dir.join(format!("{prefix}.csv")), csv)?;
    println!("{prefix}.c, {prefix}.h, {prefix}.csv");
    Ok(())
}

fn write_backstepping(
    dir: &Path,
    prefix: &str,
    law: &BacksteppingLaw,
    sequence_of: &BacksteppingLaw,
) -> Result<(), Box<dyn std::error::Error>> {
    let src = law.c_source(prefix, &format!("{prefix}.h"))?;
    std::fs::write(dir.join(format!("{prefix}.h")), src.header)?;
    std::fs::write(dir.join(format!("{prefix}.c")), src.source)?;
    let seq = bs::recorded_sequence(sequence_of, 2022)?;
    std::fs::write(dir.join(format!("{prefix}.csv")), seq.to_csv(sequence_of))?;
    println!("{prefix}.c, {prefix}.h, {prefix}.csv (backstepping)");
    Ok(())
}

/// The backstepping design `design` written as C with its variants and mutated copies
/// (module docs; the variants and mutants for `robust` only).
fn backstepping(
    dir: &Path,
    prefix: &str,
    design: &dyn Design,
    setup: &Setup,
) -> Result<(), Box<dyn std::error::Error>> {
    let inverse = setup.actuator(Compensation::Inverse);
    let of = |actuator, delay| -> Result<BacksteppingLaw, Box<dyn std::error::Error>> {
        Ok(design
            .backstepping(actuator, delay)?
            .ok_or("a backstepping design")?)
    };
    let law = of(inverse, 1)?;
    write_backstepping(dir, prefix, &law, &law)?;
    if prefix != "robust" {
        return Ok(());
    }
    for (name, l) in [
        ("delay0", of(inverse, 0)?),
        ("delay2", of(inverse, 2)?),
        ("off", of(setup.actuator(Compensation::Off), 1)?),
    ] {
        write_backstepping(dir, &format!("{prefix}_{name}"), &l, &l)?;
    }
    let scale = 1.0 + 1e-9;
    let mut m = law.clone();
    m.f[(4, 0)] *= scale;
    write_backstepping(dir, &format!("{prefix}_mutated_f"), &m, &law)?;
    let mut m = law.clone();
    m.g_inv[(1, 0)] *= scale;
    write_backstepping(dir, &format!("{prefix}_mutated_g_inv"), &m, &law)?;
    let learning = law.clone().with_learned(learned_table());
    write_backstepping(dir, &format!("{prefix}_learning"), &learning, &learning)?;
    let table = learned_table()
        .into_iter()
        .map(|c| c.map(|v| v * scale))
        .collect();
    let m = law.clone().with_learned(table);
    write_backstepping(dir, &format!("{prefix}_mutated_learned"), &m, &learning)?;
    Ok(())
}

/// A learned table of one 20 Hz period at 10 kHz (the recorded sequence's Lissajous): an
/// offset and a harmonic of a few nm per axis, as a converged learning layer leaves.
fn learned_table() -> Vec<[f64; 2]> {
    (0..500)
        .map(|k| {
            let w = std::f64::consts::TAU * k as f64 / 500.0;
            [2e-9 + 3e-9 * (3.0 * w).sin(), -1e-9 + 4e-9 * w.cos()]
        })
        .collect()
}

/// `ff` with its largest tap entry scaled by `s`.
fn mutated_tap(ff: &FirFeedForward, s: f64) -> Result<FirFeedForward, Box<dyn std::error::Error>> {
    let mut taps = ff.taps().to_vec();
    let (mut at, mut big) = ((0, 0, 0), 0.0);
    for (n, t) in taps.iter().enumerate() {
        for (i, row) in t.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                if v.abs() > big {
                    (at, big) = ((n, i, j), v.abs());
                }
            }
        }
    }
    taps[at.0][at.1][at.2] *= s;
    Ok(FirFeedForward::from_taps(ff.preview(), taps, ff.lag())?)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::env::args()
        .nth(1)
        .ok_or("usage: export_check OUT_DIR")?;
    let dir = Path::new(&dir);
    std::fs::create_dir_all(dir)?;
    let setup = Setup::from_scenario(&flexstage_scenario::Scenario::paper());
    let designs = flexstage_control::samples::decoupled_designs(&setup)?;
    let inverse = setup.actuator(Compensation::Inverse);
    let scale = 1.0 + 1e-9;
    for c in CONTROLLERS {
        let Some(design) = designs.get(c) else {
            println!("{}: not designed on this stage", c.name);
            continue;
        };
        let Some(law) = TargetLaw::of_design(&**design, inverse)? else {
            backstepping(dir, &c_prefix(c.name), &**design, &setup)?;
            continue;
        };
        let prefix = c_prefix(c.name);
        write(dir, &prefix, &law, &law)?;
        if let Some(d) = law.damping {
            let mut m = law.clone();
            let (b, a) = (d[1].numerator(), d[1].denominator());
            let mut dm = d;
            dm[1] = Biquad::new(b.map(|v| v * scale), a);
            m.damping = Some(dm);
            write(dir, &format!("{prefix}_mutated_damping"), &m, &law)?;
        }
        if c != DEFAULT {
            continue;
        }
        for mode in [Compensation::Off, Compensation::Ideal] {
            let l = TargetLaw::of_design(&**design, setup.actuator(mode))?.ok_or("linear")?;
            let p = format!(
                "{prefix}_{}",
                flexstage_control::target::compensation_name(mode)
            );
            write(dir, &p, &l, &l)?;
        }
        let mut m = law.clone();
        m.gains[0].ki *= scale;
        write(dir, &format!("{prefix}_mutated_ki"), &m, &law)?;
        let mut m = law.clone();
        m.actuator.max_voltage_step *= scale;
        write(dir, &format!("{prefix}_mutated_rate"), &m, &law)?;
        let ff = law.feedforward.as_ref().ok_or("the default has its FIR")?;
        let m = law.clone().with_feedforward(mutated_tap(ff, scale)?);
        write(dir, &format!("{prefix}_mutated_tap"), &m, &law)?;
        // The reading correction of the feedback's reference: a lead-lag of a few per cent
        // on the window, coupled.
        let correction: Vec<[[f64; 2]; 2]> = (0..ff.taps().len())
            .map(|u| {
                let v = match u as i64 - ff.preview() as i64 {
                    0 => 0.04,
                    1 => -0.03,
                    2 => -0.01,
                    _ => 0.0,
                };
                [[v, 0.002 * v], [-0.001 * v, 0.5 * v]]
            })
            .collect();
        let reading = law
            .clone()
            .with_feedforward(ff.clone().with_reading(correction.clone())?);
        write(dir, &format!("{prefix}_reading"), &reading, &reading)?;
        let mutated: Vec<[[f64; 2]; 2]> = correction
            .iter()
            .map(|t| {
                if t[0][0] == 0.04 {
                    [[0.04 * scale, t[0][1]], t[1]]
                } else {
                    *t
                }
            })
            .collect();
        let m = law
            .clone()
            .with_feedforward(ff.clone().with_reading(mutated)?);
        write(dir, &format!("{prefix}_mutated_reading"), &m, &reading)?;
        let learning = law.clone().with_learned(learned_table());
        write(dir, &format!("{prefix}_learning"), &learning, &learning)?;
        let table = learned_table()
            .into_iter()
            .map(|c| c.map(|v| v * scale))
            .collect();
        let m = law.clone().with_learned(table);
        write(dir, &format!("{prefix}_mutated_learned"), &m, &learning)?;
    }
    Ok(())
}
