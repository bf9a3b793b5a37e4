//! A payload on the output of a design: the stage's lowest natural frequencies from the
//! design's eigenproblem (`flexstage_topopt::stage_modes`: the design mesh with the PEA
//! springs and the model guess's plates, the rollers and the payload) beside the digital
//! twin's (void removed, the truth's plates, Craig–Bampton), for each payload named.
//!
//! ```text
//! cargo run --release -p flexstage-twin --example payload -- paper runs/paper/design/design.json 0 0.02
//! ```

use flexstage_run::Format;
use flexstage_run::files::design::DesignFile;
use flexstage_scenario::{Preset, Scenario};
use flexstage_topopt::{ModalParams, Problem, stage_modes};
use flexstage_twin::Twin;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: payload quick|paper DESIGN.json PAYLOAD_KG...";
    let preset = args
        .get(1)
        .and_then(|p| Preset::from_name(p))
        .ok_or(usage)?;
    let design = DesignFile::decode(&std::fs::read(args.get(2).ok_or(usage)?)?)?;
    let payloads = args[3..]
        .iter()
        .map(|a| a.parse::<f64>())
        .collect::<Result<Vec<f64>, _>>()?;
    for payload in payloads {
        let mut s = Scenario::preset(preset);
        s.output.payload = payload;
        let problem = Problem::from_scenario(&s, None)?;
        let d = stage_modes(&problem, &design.rho, &ModalParams::default(), false)?;
        let twin = Twin::from_scenario(&s, &design.rho)?;
        let (t, f1) = (twin.frequencies(), twin.first_resonance());
        println!(
            "payload {payload} kg: design {:.1?} Hz, twin {:.1?} Hz; first: design {:.1} Hz, \
             twin {f1:.1} Hz ({:+.2} %)",
            &d.frequencies[..3],
            &t[..3],
            d.frequencies[0],
            100.0 * (f1 / d.frequencies[0] - 1.0)
        );
    }
    Ok(())
}
