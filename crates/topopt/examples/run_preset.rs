//! Runs the design loop of a preset and prints the history and the final summary:
//! `cargo run --release -p flexstage-topopt --example run_preset -- quick [max_iterations]`.

use flexstage_scenario::{Preset, Scenario};
use flexstage_topopt::{Optimizer, OptimizerParams, Problem, summary::final_analysis};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let preset = Preset::from_name(args.get(1).map(String::as_str).unwrap_or("quick"))
        .expect("preset: paper, quick or fine");
    let mut s = Scenario::preset(preset);
    if let Some(n) = args.get(2) {
        s.optimization.max_iterations = n.parse().expect("max iterations");
    }
    // RUN_BETA_MAX=b: another final β (experiments).
    if let Some(b) = std::env::var("RUN_BETA_MAX")
        .ok()
        .and_then(|v| v.parse().ok())
    {
        s.optimization.projection.beta_max = b;
    }
    let problem = Problem::from_scenario(&s, None).expect("problem");
    let params = OptimizerParams::from_scenario(&s);
    if let Some(l) = params.robust {
        println!(
            "length scale: R = {:.2} mm ({:.2} elements), η_e = {:.3}, η_d = {:.3}, minimum solid {:.2} mm, void {:.2} mm",
            l.radius * 1e3,
            l.radius_elements,
            l.eta_eroded,
            l.eta_dilated,
            l.solid_size * 1e3,
            l.void_size * 1e3
        );
    }
    let mut opt = Optimizer::new(&problem, params.clone()).expect("optimizer");
    println!("constraints: {:?}", opt.constraint_names());
    let t = std::time::Instant::now();
    let stop = opt
        .run(|_, r| {
            println!(
                "{:4} J={:.0}µm² e/d={:?}/{:?} g={:?} V={:.3} σ={:?}MPa grey={:.3} ch={:.3e}/{:.1e} kkt={:?} β={} newton={}/{} t={:.3}s",
                r.iteration,
                r.area * 1e12,
                r.area_eroded.map(|a| (a * 1e12).round()),
                r.area_dilated.map(|a| (a * 1e12).round()),
                r.constraints.iter().map(|v| (v * 1e3).round() / 1e3).collect::<Vec<_>>(),
                r.volume,
                r.stress.map(|v| (v / 1e5).round() / 10.0),
                r.grey,
                r.change,
                r.mean_change,
                r.kkt.map(|v| (v * 1e4).round() / 1e4),
                r.beta,
                r.newton_total,
                r.newton_max,
                r.time
            );
            Ok(())
        })
        .expect("run");
    let h = opt.history();
    println!(
        "{stop:?} after {} iterations, {:.1} s",
        h.len(),
        t.elapsed().as_secs_f64()
    );
    let (dens, _) = opt.last().expect("evaluated");
    let fin = final_analysis(&s, dens, params.robust).expect("final analysis");
    for l in fin.summary.lines() {
        println!("{l}");
    }
    if let Some(path) = args.get(3) {
        let json = serde_json::json!({ "rho": dens.physical, "nl": s.mesh.nl, "nw": s.mesh.nw });
        std::fs::write(path, json.to_string()).expect("write densities");
    }
}
