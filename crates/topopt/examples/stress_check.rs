//! Physical plausibility of a design: peak von Mises stress in the solid phase at the four
//! corner inputs (nonlinear analysis, no additive material), the differential amplification
//! α = Δy_out/Δx_in and the output displacements.
//!
//! `cargo run --release -p flexstage-topopt --example stress_check -- quick|paper [design.json]
//! [output_spring N/m]`: without a design file, the preset is optimized first (quick only).

use flexstage_fem::{Design, Kinematics};
use flexstage_scenario::{Preset, Scenario};
use flexstage_topopt::{AnalysisParams, Evaluator, Optimizer, OptimizerParams, Problem};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let preset = match args.get(1).map(String::as_str) {
        Some("paper") => Preset::Paper,
        _ => Preset::Quick,
    };
    let mut s = Scenario::preset(preset);
    if let Some(k) = args.get(3).and_then(|v| v.parse::<f64>().ok()) {
        s.optimization.output_spring = k;
    }
    let problem = Problem::from_scenario(&s, None).unwrap();
    let rho: Vec<f64> = match args.get(2).filter(|a| a.as_str() != "-") {
        Some(path) => {
            let v: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
            v["rho"]
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect()
        }
        None => {
            let t = std::time::Instant::now();
            let mut opt = Optimizer::new(&problem, OptimizerParams::from_scenario(&s)).unwrap();
            opt.run(|_, _| Ok(())).unwrap();
            let h = opt.history();
            println!(
                "optimized: {} iterations in {:.1} s, area growth {:.1}x, grey {:.3}",
                h.len(),
                t.elapsed().as_secs_f64(),
                h.last().unwrap().area / h[0].area,
                h.last().unwrap().grey
            );
            opt.last().unwrap().0.physical.clone()
        }
    };
    let mut fin = problem
        .with_kinematics(Kinematics::TotalLagrangian)
        .unwrap();
    let a = s.actuators.stroke_amplitude;
    fin.cases = vec![vec![a, a], vec![a, -a], vec![-a, -a], vec![-a, a]];
    let mut ev = Evaluator::new(&fin, 0.0, AnalysisParams::default()).unwrap();
    let r = ev.solve_cases(&rho, None).unwrap();
    let model = &fin.model;
    let ne = model.mesh().n_elements();
    let mut vm = vec![0.0; ne];
    let yield_al = 276e6;
    for (k, c) in fin.cases.iter().enumerate() {
        model.von_mises_stresses(&Design::new(&rho), &ev.cases[k].u, &mut vm);
        let peak = |thr: f64| {
            (0..ne)
                .filter(|&e| rho[e] >= thr)
                .map(|e| vm[e])
                .fold(0.0, f64::max)
        };
        let mut eps = vec![0.0; ne];
        model.element_von_mises_strains(&ev.cases[k].u, &mut eps);
        let void_strain = (0..ne)
            .filter(|&e| rho[e] < 0.1)
            .map(|e| eps[e])
            .fold(0.0, f64::max);
        let solid_strain = (0..ne)
            .filter(|&e| rho[e] >= 0.5)
            .map(|e| eps[e])
            .fold(0.0, f64::max);
        let over = (0..ne)
            .filter(|&e| rho[e] >= 0.5 && vm[e] > yield_al)
            .count();
        println!(
            "case ({:+.0},{:+.0}) µm: u_in = ({:.2}, {:.2}) µm, u_out = ({:.2}, {:.2}) µm, peak σ_vM (ρ≥0.5) {:.0} MPa, (ρ≥0.9) {:.0} MPa, solid elements above 276 MPa: {over}; max strain solid {solid_strain:.1e}, void (ρ<0.1) {void_strain:.1e}",
            c[0] * 1e6,
            c[1] * 1e6,
            r.inputs[k][0] * 1e6,
            r.inputs[k][1] * 1e6,
            r.outputs[k][0] * 1e6,
            r.outputs[k][1] * 1e6,
            peak(0.5) / 1e6,
            peak(0.9) / 1e6,
        );
    }
    let (kc, kt) = (1, 3);
    let dy = r.outputs[kc][1] - r.outputs[kt][1];
    let dx = (r.inputs[kc][0] - r.inputs[kc][1]) - (r.inputs[kt][0] - r.inputs[kt][1]);
    println!(
        "differential amplification α = Δy_out/Δ(x1−x2) = {:.3} (paper Table 4: 1.012); volume {:.3}",
        dy / dx,
        rho.iter().sum::<f64>() / ne as f64
    );
}
