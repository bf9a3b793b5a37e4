//! The twin of a design and its validity against the full nonlinear transient, with the data
//! the report shows: the modes, the Bode magnitude and phase from x_nom to q beside the lumped
//! model, and the step / sine / fast-step comparisons.
//!
//! ```text
//! cargo run --release -p flexstage-twin --example validate -- paper runs/paper/design/design.json OUT_DIR
//! ```
//!
//! Writes `OUT_DIR/{validity.json, modes.csv, bode.csv, bode_magnitude.svg, bode_phase.svg}`
//! and prints the summary.

use flexstage_reduce::{ReduceParams, reduce, reduction_problem};
use flexstage_scenario::{Preset, Scenario};
use flexstage_topopt::DesignFile;
use flexstage_twin::report::{bode_for, modes_table, validity_lines};
use flexstage_twin::{Twin, ValidationParams, validate};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: validate quick|paper DESIGN.json OUT_DIR";
    let preset = args
        .get(1)
        .and_then(|p| Preset::from_name(p))
        .ok_or(usage)?;
    let design = DesignFile::from_json(&std::fs::read(args.get(2).ok_or(usage)?)?)?;
    let out = std::path::PathBuf::from(args.get(3).ok_or(usage)?);
    std::fs::create_dir_all(&out)?;
    let scenario = Scenario::preset(preset);
    let t0 = std::time::Instant::now();
    let twin = Twin::from_scenario(&scenario, &design.rho)?;
    println!(
        "twin of {} ({} × {} mesh): {} fixed-interface modes, {} modes, built in {:.2} s",
        design.scenario,
        design.nl,
        design.nw,
        twin.reduction.modes(),
        twin.modal.modes.len(),
        t0.elapsed().as_secs_f64()
    );
    if let Some(nl) = &twin.nonlinear {
        println!(
            "nonlinear effect over the fit grid: {:.2} / {:.2} nm (q1 / q2), fit residual {:.3} / {:.3} nm",
            nl.max_effect[0] * 1e9,
            nl.max_effect[1] * 1e9,
            nl.max_residual[0] * 1e9,
            nl.max_residual[1] * 1e9
        );
    }
    let mut modes = String::from(
        "mode,frequency_Hz,damping,common_participation,differential_participation,claimed\n",
    );
    for m in modes_table(&twin) {
        modes.push_str(&format!(
            "{},{},{},{},{},{}\n",
            m.index, m.frequency, m.damping, m.common, m.differential, m.claimed
        ));
    }
    std::fs::write(out.join("modes.csv"), modes)?;
    // The lumped model of the same design (flexstage reduce), beside the twin.
    let problem = reduction_problem(&scenario, false)?;
    let params = ReduceParams {
        modal: None,
        validity: None,
        ..ReduceParams::default()
    };
    let reduced = reduce(&scenario, &problem, &design.rho, &params)?;
    let bode = bode_for(&twin, &reduced.params)?;
    std::fs::write(out.join("bode.csv"), bode.csv())?;
    let [mag, phase] = bode.svg()?;
    std::fs::write(out.join("bode_magnitude.svg"), mag)?;
    std::fs::write(out.join("bode_phase.svg"), phase)?;
    let t0 = std::time::Instant::now();
    let v = validate(&twin, &ValidationParams::default())?;
    for m in &v.modes {
        println!(
            "mode {}: twin {:.2} Hz, FE {:.2} Hz ({:+.4} %), ζ = {:.4}",
            m.index,
            m.twin,
            m.fe,
            100.0 * m.relative,
            m.damping
        );
    }
    for line in validity_lines(&v) {
        println!("{line}");
    }
    println!("validation: {:.1} s", t0.elapsed().as_secs_f64());
    std::fs::write(out.join("validity.json"), serde_json::to_string_pretty(&v)?)?;
    println!("wrote {}", out.display());
    Ok(())
}
