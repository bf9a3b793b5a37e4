//! Reference: Sigmund's 99-line mechanism code (Bendsøe & Sigmund, Topology Optimization,
//! 2003; Sigmund 1997): the linear displacement inverter, 40 × 20 elements, volume 0.3, p = 3,
//! filter radius 1.2, input and output springs 0.1, unit input force; the published optimum has
//! an output displacement of about −1.11 after 0/1 thresholding. Goal: our linear mode with MMA
//! and a density filter reaches that value within 8 % (measured: −1.18, a 6 % better design; MMA with a density
//! filter is not the OC with sensitivity filter of the 99-line code).
//!
//! The same problem stated as a scenario (`examples/scenarios/inverter.toml`: `[[ports]]`, an
//! output direction, the stage's constraints switched off) must reach the same answer through
//! the path `flexstage design` takes (`Problem::from_scenario`, `OptimizerParams::from_scenario`).

use flexstage_fem::Passive;
use flexstage_scenario::Scenario;
use flexstage_topopt::{AnalysisParams, Evaluator, Optimizer, OptimizerParams, Problem, samples};

/// Volume-preserving 0/1 thresholding (the `fraction` densest elements solid), then a linear
/// re-analysis: the thresholded output displacement.
fn thresholded_output(problem: &Problem, physical: &[f64], fraction: f64) -> f64 {
    let mut sorted = physical.to_vec();
    sorted.sort_by(|a, b| b.total_cmp(a));
    let level = sorted[(fraction * sorted.len() as f64).round() as usize - 1];
    let mut rho: Vec<f64> = physical
        .iter()
        .map(|&r| if r >= level { 1.0 } else { 1e-3 })
        .collect();
    problem.mesh().apply_passive(&mut rho, 1e-3);
    let mut ev = Evaluator::new(problem, AnalysisParams::tight()).unwrap();
    let r = ev.solve_cases(&rho, None).unwrap();
    r.outputs[0][0]
}

#[test]
fn scenario_inverter_toml_matches_the_99_line_code() {
    let text = include_str!("../../../examples/scenarios/inverter.toml");
    let s = Scenario::from_toml_str(text, "inverter.toml").unwrap();
    let problem = Problem::from_scenario(&s, None).unwrap();
    // The same problem data as samples::inverter(40, 20).
    let reference = samples::inverter(40, 20).unwrap();
    assert_eq!(problem.cases, reference.cases);
    assert_eq!(problem.inputs, reference.inputs);
    assert_eq!(problem.output, reference.output);
    assert_eq!(problem.objective, reference.objective);
    assert_eq!(problem.model.bcs().fixed, reference.model.bcs().fixed);
    let mut opt = Optimizer::new(&problem, OptimizerParams::from_scenario(&s)).unwrap();
    opt.run(|_, _| Ok(())).unwrap();
    let last = opt.history().last().unwrap();
    assert!(last.volume <= 0.3 + 1e-3, "volume {}", last.volume);
    let u_out = thresholded_output(&problem, &opt.last().unwrap().0.physical, 0.3);
    println!(
        "{} iterations, u_out = {:.4}, thresholded {u_out:.4}",
        opt.history().len(),
        -last.objective
    );
    assert!(
        (u_out - (-1.11)).abs() <= 0.08 * 1.11,
        "thresholded output displacement {u_out} is not within 8 % of -1.11"
    );
}

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
    let (dens, _) = opt.last().unwrap();
    assert!(problem.mesh().passive.iter().all(|p| *p == Passive::Design));
    let u_out = thresholded_output(&problem, &dens.physical, 0.3);
    println!("thresholded u_out = {u_out:.4}");
    assert!(
        (u_out - (-1.11)).abs() <= 0.08 * 1.11,
        "thresholded output displacement {u_out} is not within 8 % of -1.11"
    );
}
