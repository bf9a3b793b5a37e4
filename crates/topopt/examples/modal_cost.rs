//! Scratch probe: the stage's first frequency of a design file, as designed and thresholded.
use flexstage_scenario::{Preset, Scenario};
use flexstage_topopt::{DesignFile, ModalParams, Problem, stage_modes};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let preset = if args[1] == "paper" {
        Preset::Paper
    } else {
        Preset::Quick
    };
    let s = Scenario::preset(preset);
    let problem = Problem::from_scenario(&s, None).unwrap();
    let file = DesignFile::from_json(&std::fs::read(&args[2]).unwrap()).unwrap();
    let p = ModalParams::default();
    let m = stage_modes(&problem, &file.rho, &p, false).unwrap();
    println!("as designed: {:?}", m.frequencies);
    for t in [0.5] {
        let r: Vec<f64> = file
            .rho
            .iter()
            .map(|&v| if v >= t { 1.0 } else { 1e-6 })
            .collect();
        let m = stage_modes(&problem, &r, &p, false).unwrap();
        let mass: f64 = r.iter().sum::<f64>() / file.rho.iter().sum::<f64>();
        println!(
            "thresholded at {t}: {:?} (mass ratio {mass:.4})",
            m.frequencies
        );
    }
    let grey = file.rho.iter().filter(|&&v| v > 0.05 && v < 0.95).count();
    println!(
        "elements with 0.05 < rho < 0.95: {grey} of {}",
        file.rho.len()
    );
}
