//! The twin of a design and its validity against the full nonlinear transient: the modes
//! against the FE modal analysis and the step / sine / fast-step comparisons. (`flexstage run`
//! and `flexstage track --write-twin` store the same data, with the Bode figures, in a run
//! folder's `twin/`.)
//!
//! ```text
//! cargo run --release -p flexstage-twin --example validate -- paper runs/paper/design/design.json
//! ```
//!
//! An optional third argument shortens each comparison run (milliseconds, default 20, the
//! duration of `ValidationParams::default`); CI runs 5 ms, the same check at a quarter of the
//! cost, since `flexstage run` already checks the same design over 20 ms.

use flexstage_run::Format;
use flexstage_run::files::design::DesignFile;
use flexstage_scenario::{Preset, Scenario};
use flexstage_twin::designed::reduced_model;
use flexstage_twin::report::{bode_for, validity_lines};
use flexstage_twin::{Twin, ValidationParams, validate};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: validate quick|paper DESIGN.json [DURATION_MS]";
    let preset = args
        .get(1)
        .and_then(|p| Preset::from_name(p))
        .ok_or(usage)?;
    let design = DesignFile::decode(&std::fs::read(args.get(2).ok_or(usage)?)?)?;
    let scenario = Scenario::preset(preset);
    let t0 = std::time::Instant::now();
    let twin = Twin::from_scenario(&scenario, &design.rho)?;
    let build_seconds = t0.elapsed().as_secs_f64();
    println!(
        "twin of {} ({} × {} mesh): {} fixed-interface modes, {} modes, built in {:.2} s",
        design.scenario,
        design.nl,
        design.nw,
        twin.reduction.modes(),
        twin.modal.modes.len(),
        build_seconds
    );
    let t0 = std::time::Instant::now();
    let mut params = ValidationParams::default();
    if let Some(ms) = args.get(3) {
        params.duration = ms.parse::<f64>().map_err(|_| usage)? * 1e-3;
    }
    let v = validate(&twin, &params)?;
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
    // The lumped model of the same design (flexstage reduce), beside the twin.
    let reduced = reduced_model(&scenario, &design.rho)?;
    let bode = bode_for(&twin, &reduced)?;
    let peak = bode
        .frequency
        .iter()
        .zip(&bode.twin)
        .map(|(f, g)| (f, g[1][0].0.hypot(g[1][0].1)))
        .fold((0.0, 0.0), |a, (f, m)| if m > a.1 { (*f, m) } else { a });
    println!(
        "largest |q2/x_nom1| of the twin: {:.3e} at {:.0} Hz",
        peak.1, peak.0
    );
    Ok(())
}
