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

use flexstage_scenario::{Preset, Scenario};
use flexstage_topopt::DesignFile;
use flexstage_twin::designed::reduced_model;
use flexstage_twin::report::validity_lines;
use flexstage_twin::{Twin, ValidationParams, report_data};

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
    let build_seconds = t0.elapsed().as_secs_f64();
    // The lumped model of the same design (flexstage reduce), beside the twin.
    let reduced = reduced_model(&scenario, &design.rho)?;
    let check = Ok((ValidationParams::default(), "requested".to_string()));
    let data = report_data(&twin, &reduced, build_seconds, check)?;
    let v = &data.validity;
    println!(
        "twin of {} ({} × {} mesh): {} fixed-interface modes, {} modes, built in {:.2} s",
        design.scenario, design.nl, design.nw, v.fixed_interface_modes, v.order, build_seconds
    );
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
    for line in data.full.iter().flat_map(validity_lines) {
        println!("{line}");
    }
    println!("validation: {:.1} s", v.transient.seconds);
    for (rel, text) in data.files()? {
        let name = std::path::Path::new(rel).file_name().ok_or("file name")?;
        std::fs::write(out.join(name), text)?;
    }
    println!("wrote {}", out.display());
    Ok(())
}
