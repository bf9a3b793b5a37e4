//! Scratch probe: continuation on the resonance bound from the default design.
use flexstage_scenario::{Preset, Scenario};
use flexstage_topopt::summary::final_analysis;
use flexstage_topopt::{Optimizer, OptimizerParams, Problem};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let preset = if args.get(1).map(String::as_str) == Some("paper") {
        Preset::Paper
    } else {
        Preset::Quick
    };
    let asy: f64 = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(0.5);
    let iters: usize = args.get(3).and_then(|a| a.parse().ok()).unwrap_or(60);
    let beta: f64 = args.get(4).and_then(|a| a.parse().ok()).unwrap_or(16.0);
    let step: f64 = args.get(5).and_then(|a| a.parse().ok()).unwrap_or(0.15);
    let s0 = Scenario::preset(preset);
    let t = Instant::now();
    let p0 = Problem::from_scenario(&s0, None).unwrap();
    let mut o = Optimizer::new(&p0, OptimizerParams::from_scenario(&s0)).unwrap();
    o.run(|_, _| Ok(())).unwrap();
    let fin = final_analysis(&s0, &o.last().unwrap().0, o.params().robust).unwrap();
    let f0 = fin.summary.first_frequency_hz.unwrap();
    let a0 = fin.summary.area;
    println!(
        "d0: {} it, area {:.0} µm², f1 {:.0} Hz, {:.1} s",
        o.history().len(),
        a0 * 1e12,
        f0,
        t.elapsed().as_secs_f64()
    );
    let mut x = o.x().to_vec();
    for k in 1..=4 {
        let t = Instant::now();
        let mut s = s0.clone();
        s.optimization.min_frequency = f0 * (1.0 + step * k as f64);
        s.optimization.max_iterations = iters;
        let p = Problem::from_scenario(&s, None).unwrap();
        let mut params = OptimizerParams::from_scenario(&s);
        params.mma.asyinit = asy;
        params.mma.move_limit = asy.max(0.05);
        let mut o = Optimizer::continue_from(&p, params, &x, beta).unwrap();
        let stop = o.run(|_, _| Ok(())).unwrap();
        let h = o.history();
        let fin = final_analysis(&s, &o.last().unwrap().0, o.params().robust).unwrap();
        let f = &fin.summary;
        println!(
            "d{k}: bound {:.0} Hz, {:?} after {} it, area {:.0} µm² ({:.0} %), f1 {:.0} Hz ({:.2}x), stress {:.1} MPa, thinnest {:.2} mm, {:.1} s; g_last {:?}",
            s.optimization.min_frequency,
            stop,
            h.len(),
            f.area * 1e12,
            100.0 * f.area / a0,
            f.first_frequency_hz.unwrap(),
            f.first_frequency_hz.unwrap() / f0,
            f.constrained_stress.unwrap_or(0.0) / 1e6,
            f.thinnest_member.unwrap_or(0.0) * 1e3,
            t.elapsed().as_secs_f64(),
            h.last()
                .unwrap()
                .constraints
                .iter()
                .map(|v| (v * 1e3).round() / 1e3)
                .collect::<Vec<_>>()
        );
        x = o.x().to_vec();
    }
}
