//! Reference: Sigmund's 99-line mechanism code (Bendsøe & Sigmund, Topology Optimization,
//! 2003; Sigmund 1997): the linear displacement inverter, 40 × 20 elements, volume 0.3, p = 3,
//! filter radius 1.2, input and output springs 0.1, unit input force; the published optimum has
//! an output displacement of about −1.11 after 0/1 thresholding. Goal: our linear mode with MMA
//! and a density filter reaches that value within 8 % (measured: −1.18, a 6 % better design; MMA with a density
//! filter is not the OC with sensitivity filter of the 99-line code).

use flexstage_fem::Passive;
use flexstage_topopt::{AnalysisParams, Evaluator, Optimizer, samples};

#[test]
fn linear_inverter_matches_the_99_line_code() {
    let problem = samples::inverter(40, 20).unwrap();
    let mut opt = Optimizer::new(&problem, samples::inverter_params(200)).unwrap();
    opt.run(|_, _| Ok(())).unwrap();
    let h = opt.history();
    let last = h.last().unwrap();
    println!(
        "{} iterations, u_out = {:.4}, volume {:.3}, grey {:.3}",
        h.len(),
        -last.objective,
        last.volume,
        last.grey
    );
    assert!(last.volume <= 0.3 + 1e-3, "volume {}", last.volume);
    // Volume-preserving 0/1 thresholding (the 30 % densest elements solid), then a linear
    // re-analysis.
    let (dens, _) = opt.last().unwrap();
    let mut sorted = dens.physical.clone();
    sorted.sort_by(|a, b| b.total_cmp(a));
    let level = sorted[(0.3 * sorted.len() as f64).round() as usize - 1];
    let mut rho: Vec<f64> = dens
        .physical
        .iter()
        .map(|&r| if r >= level { 1.0 } else { 1e-3 })
        .collect();
    problem.mesh().apply_passive(&mut rho, 1e-3);
    assert!(problem.mesh().passive.iter().all(|p| *p == Passive::Design));
    let mut ev = Evaluator::new(&problem, AnalysisParams::tight()).unwrap();
    let r = ev.solve_cases(&rho, None).unwrap();
    let u_out = r.outputs[0][0];
    println!("thresholded u_out = {u_out:.4}");
    assert!(
        (u_out - (-1.11)).abs() <= 0.08 * 1.11,
        "thresholded output displacement {u_out} is not within 8 % of -1.11"
    );
}
