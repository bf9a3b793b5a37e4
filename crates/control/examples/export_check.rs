//! Writes every exportable registry controller as C (`<prefix>.c`, `<prefix>.h`) with the
//! sequence the Rust controller recorded (`<prefix>.csv`, [`recorded_sequence`]), for the CI
//! check that compiles the C and requires it to agree to 1e-12 (`.ci/c-check`). The
//! controllers are designed as the registry test designs them: the paper scenario on two
//! decoupled 1 %-damped modes with one sample of delay, inverse compensation. The default
//! controller is also written with the compensation off and ideal (`<prefix>_off`,
//! `<prefix>_ideal`), and once with its k_i changed by one part in 10⁹ (`<prefix>_mutated`,
//! checked against the unchanged sequence), which the check must refuse.
//!
//! `cargo run --release -p flexstage-control --example export_check -- OUT_DIR`

use std::fmt::Write as _;
use std::path::Path;

use flexstage_control::actuator::Compensation;
use flexstage_control::experiment::Setup;
use flexstage_control::registry::{CONTROLLERS, DEFAULT, Designs, Stage};
use flexstage_control::target::{TargetLaw, c_prefix, recorded_sequence};
use flexstage_control::tuning::TuningParams;
use flexstage_identify::response::ResponseFit;

fn write(
    dir: &Path,
    prefix: &str,
    law: &TargetLaw,
    sequence_of: &TargetLaw,
) -> std::io::Result<()> {
    let src = law
        .c_source(prefix, &format!("{prefix}.h"))
        .map_err(std::io::Error::other)?;
    std::fs::write(dir.join(format!("{prefix}.h")), src.header)?;
    std::fs::write(dir.join(format!("{prefix}.c")), src.source)?;
    let seq = recorded_sequence(sequence_of, 2022).map_err(std::io::Error::other)?;
    let mut csv = String::from("r1,r2,y1,y2,voltage1,voltage2,x_nom1,x_nom2,saturated\n");
    for s in seq {
        let c = s.command;
        let _ = writeln!(
            csv,
            "{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{}",
            s.reference[0],
            s.reference[1],
            s.reading[0],
            s.reading[1],
            c.voltage[0],
            c.voltage[1],
            c.x_nom[0],
            c.x_nom[1],
            u8::from(c.saturated)
        );
    }
    std::fs::write(dir.join(format!("{prefix}.csv")), csv)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::env::args()
        .nth(1)
        .ok_or("usage: export_check OUT_DIR")?;
    let dir = Path::new(&dir);
    std::fs::create_dir_all(dir)?;
    let setup = Setup::from_scenario(&flexstage_scenario::Scenario::paper());
    let modes = flexstage_sim::samples::decoupled_modes();
    let fit = ResponseFit::from_modes(&modes, 5000.0, 0.1);
    let plant = flexstage_sim::modal::ModalPlant::new(modes, 1e-4, 1)?;
    let stage = Stage::new(
        &setup,
        Some(&plant),
        Some(fit),
        None,
        TuningParams::default(),
    );
    let designs = Designs::for_stage(&stage)?;
    let inverse = setup.actuator(Compensation::Inverse);
    for c in CONTROLLERS {
        let Some(design) = designs.get(c) else {
            println!("{}: not designed on this stage", c.name);
            continue;
        };
        let Some(law) = TargetLaw::of_design(&**design, inverse)? else {
            println!("{}: nonlinear, not exported", c.name);
            continue;
        };
        let prefix = c_prefix(c.name);
        write(dir, &prefix, &law, &law)?;
        println!("{}: {prefix}.c, {prefix}.h, {prefix}.csv", c.name);
        if c == DEFAULT {
            for mode in [Compensation::Off, Compensation::Ideal] {
                let l = TargetLaw::of_design(&**design, setup.actuator(mode))?.ok_or("linear")?;
                let p = format!(
                    "{prefix}_{}",
                    flexstage_control::target::compensation_name(mode)
                );
                write(dir, &p, &l, &l)?;
                println!("{}: {p}.c, {p}.h, {p}.csv", c.name);
            }
            let mut mutated = law;
            mutated.gains[0].ki *= 1.0 + 1e-9;
            write(dir, &format!("{prefix}_mutated"), &mutated, &law)?;
            println!("{}: {prefix}_mutated (k_i × (1 + 1e-9), must fail)", c.name);
        }
    }
    Ok(())
}
