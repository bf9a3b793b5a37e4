//! Scratch probe: build the twin of a design file.
use flexstage_scenario::{Preset, Scenario};
use flexstage_topopt::DesignFile;
use flexstage_twin::Twin;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let s = Scenario::preset(if args[1] == "paper" {
        Preset::Paper
    } else {
        Preset::Quick
    });
    let f = DesignFile::from_json(&std::fs::read(&args[2]).unwrap()).unwrap();
    match Twin::from_scenario(&s, &f.rho) {
        Ok(t) => println!("twin f1 {}", t.first_resonance()),
        Err(e) => println!("error: {e:?}"),
    }
}
