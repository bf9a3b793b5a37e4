//! Reference: eigenfrequency topology optimization with a bound formulation or aggregate over
//! the lowest eigenvalues stays smooth where the lowest two coincide (Du & Olhoff, Struct.
//! Multidisc. Optim. 34, 2007), where bounding the lowest eigenvalue alone oscillates as the
//! modes switch order. Goal, on the quick preset (robust, symmetric, stress-constrained, the
//! stage with its PEA plates):
//! * maximizing the first natural frequency with the workspace bounded drives the lowest two
//!   frequencies together (within 5 %), and the history at the final β moves by less than 1 %
//!   per iteration without oscillating (its total variation at most 3× its net change,
//!   measured 1.5×; with the lowest eigenvalue alone 8.7×, the ignored test);
//! * a first-frequency bound 1.3× the workspace design's, reached by continuation from that
//!   design, holds within 1 % at the end with the workspace at least 80 % of the
//!   unconstrained one.

use flexstage_scenario::{ObjectiveKind, Preset, Scenario};
use flexstage_topopt::summary::final_analysis;
use flexstage_topopt::{Optimizer, OptimizerParams, Problem};

/// The history of the quick preset maximizing its first frequency, with `modes` eigenvalues
/// in the aggregate.
fn maximize(modes: usize) -> Vec<flexstage_topopt::IterationRecord> {
    let mut s = Scenario::preset(Preset::Quick);
    s.optimization.objective = ObjectiveKind::Resonance;
    s.optimization.min_workspace = 2.4e-9;
    let problem = Problem::from_scenario(&s, None).unwrap();
    let mut params = OptimizerParams::from_scenario(&s);
    params.analysis.modal.modes = modes;
    let mut opt = Optimizer::new(&problem, params).unwrap();
    opt.run(|_, _| Ok(())).unwrap();
    opt.history().to_vec()
}

/// The largest relative step of f1 at the final β and the total variation over the net
/// change there.
fn roughness(h: &[flexstage_topopt::IterationRecord]) -> (f64, f64) {
    let sharp: Vec<f64> = h
        .iter()
        .filter(|r| r.beta >= 16.0)
        .map(|r| r.frequencies[0])
        .collect();
    let steps: Vec<f64> = sharp.windows(2).map(|w| (w[1] - w[0]) / w[0]).collect();
    let largest = steps.iter().fold(0.0f64, |a, s| a.max(s.abs()));
    let variation: f64 = steps.iter().map(|s| s.abs()).sum();
    let net = (sharp[sharp.len() - 1] - sharp[0]).abs() / sharp[0];
    (largest, variation / net.max(1e-12))
}

#[test]
fn maximized_resonance_converges_smoothly_where_the_lowest_two_meet() {
    let h = maximize(4);
    let last = h.last().unwrap();
    let (f1, f2) = (last.frequencies[0], last.frequencies[1]);
    println!(
        "f1 {:.0} → {f1:.0} Hz, f2 {f2:.0} Hz, area {:.0} µm²",
        h[0].frequencies[0],
        last.area * 1e12
    );
    assert!(f1 >= 1.8 * h[0].frequencies[0], "f1 {f1}");
    assert!(
        (f2 - f1) / f1 <= 0.05,
        "the lowest two should meet: {f1} vs {f2}"
    );
    assert!(
        last.area >= 0.99 * 2.4e-9,
        "workspace bound: {:e}",
        last.area
    );
    let (largest, ratio) = roughness(&h);
    println!("aggregate of 4: largest step {largest:.2e}, variation / net change {ratio:.2}");
    assert!(largest <= 0.01, "largest step {largest}");
    assert!(ratio <= 3.0, "variation / net change {ratio}");
}

/// The same with the lowest eigenvalue alone in the objective: its history at the final β
/// wanders more (measured: total variation 8.7× the net change, against 1.5× with the
/// aggregate of four). Shows the smoothness test above can fail; two designs, so not run by
/// default (`-- --ignored`).
#[test]
#[ignore]
fn the_lowest_eigenvalue_alone_is_rougher() {
    let (_, aggregate) = roughness(&maximize(4));
    let (_, alone) = roughness(&maximize(1));
    println!("variation / net change: aggregate {aggregate:.2}, lowest alone {alone:.2}");
    assert!(alone > 3.0 && alone > aggregate, "{alone} vs {aggregate}");
}

#[test]
fn a_frequency_bound_reached_by_continuation_holds() {
    let s0 = Scenario::preset(Preset::Quick);
    let p0 = Problem::from_scenario(&s0, None).unwrap();
    let mut o0 = Optimizer::new(&p0, OptimizerParams::from_scenario(&s0)).unwrap();
    o0.run(|_, _| Ok(())).unwrap();
    let d0 = final_analysis(&s0, &o0.last().unwrap().0, o0.params().robust).unwrap();
    let f0 = d0.summary.first_frequency_hz.unwrap();
    let mut s = s0.clone();
    s.optimization.min_frequency = 1.3 * f0;
    s.optimization.max_iterations = 60;
    let p = Problem::from_scenario(&s, None).unwrap();
    let mut params = OptimizerParams::from_scenario(&s);
    params.mma.asyinit = 0.2;
    params.mma.move_limit = 0.2;
    let mut o = Optimizer::continue_from(&p, params, o0.x(), 4.0).unwrap();
    o.run(|_, _| Ok(())).unwrap();
    let d = final_analysis(&s, &o.last().unwrap().0, o.params().robust).unwrap();
    let f = d.summary.first_frequency_hz.unwrap();
    println!(
        "f0 {f0:.0} Hz, bound {:.0} Hz → {f:.0} Hz; area {:.0} → {:.0} µm²",
        1.3 * f0,
        d0.summary.area * 1e12,
        d.summary.area * 1e12
    );
    assert!(f >= 0.99 * 1.3 * f0, "bound not met: {f} Hz");
    assert!(
        d.summary.area >= 0.8 * d0.summary.area,
        "area {:e}",
        d.summary.area
    );
}
