//! The designed stage as the examples and assessments simulate it: the scenario whose
//! controller model and simulated truth are both the reduced model of the design, and the
//! twin of the same design.
//!
//! This is the "perfect model knowledge" setting (guess = truth = the design's reduced
//! model, `flexstage_reduce::reduce` without modal analysis or validity map): what remains
//! between the controller's model and the twin is what the lumped 8-state model leaves out
//! (higher modes, geometric nonlinearity, the rig). The pipeline's `identify stage` and
//! `track` take a different split (Actuators 2022, 11(7), 179, Section 4.2: only the mass and
//! α are known, stiffnesses and dampings are identified).

use flexstage_reduce::{ReduceParams, reduce, reduction_problem};
use flexstage_scenario::{Scenario, StageParams};

use crate::{Result, Twin};

/// A design ready to simulate: [`DesignedStage::new`].
pub struct DesignedStage {
    /// The scenario with `stage.guess = stage.truth =` [`DesignedStage::reduced`].
    pub scenario: Scenario,
    /// The reduced (lumped) model of the design.
    pub reduced: StageParams,
    /// The twin of the design in the scenario's `[twin]` group.
    pub twin: Twin,
}

impl DesignedStage {
    /// Reduces the design `rho` (physical densities in fem element order, e.g.
    /// `DesignFile::rho`) on `scenario`, sets guess and truth to the reduced model, and builds
    /// the twin of the same design.
    pub fn new(scenario: &Scenario, rho: &[f64]) -> Result<DesignedStage> {
        let reduced = reduced_model(scenario, rho)?;
        let mut s = scenario.clone();
        s.stage.guess = reduced.clone();
        s.stage.truth = reduced.clone();
        let twin = Twin::from_scenario(&s, rho)?;
        Ok(DesignedStage {
            scenario: s,
            reduced,
            twin,
        })
    }
}

/// The reduced (lumped) model of the design `rho` on `scenario`: `flexstage_reduce::reduce`
/// of the final-analysis problem without the output spring, without modal analysis or
/// validity map.
pub fn reduced_model(scenario: &Scenario, rho: &[f64]) -> Result<StageParams> {
    let problem = reduction_problem(scenario, false)?;
    let params = ReduceParams {
        modal: None,
        validity: None,
        ..ReduceParams::default()
    };
    Ok(reduce(scenario, &problem, rho, &params)?.params)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn designed_stage_has_guess_equal_truth_equal_the_reduced_model() {
        // Goal: the examples' "perfect knowledge" setting — the controller's model, the
        // simulated truth and the returned reduced model are one and the same, and the twin
        // is built from the same scenario (its plates are stage.truth's).
        let scenario = Scenario::preset(flexstage_scenario::Preset::Quick);
        let n = scenario.mesh.nl * scenario.mesh.nw;
        let d = DesignedStage::new(&scenario, &vec![0.5; n]).unwrap();
        assert_eq!(d.scenario.stage.guess, d.reduced);
        assert_eq!(d.scenario.stage.truth, d.reduced);
        assert_eq!(d.reduced, reduced_model(&scenario, &vec![0.5; n]).unwrap());
        assert_ne!(
            d.reduced, scenario.stage.truth,
            "the design replaces Table 4's truth"
        );
        assert!(d.twin.first_resonance() > 0.0);
    }
}
