//! Reference: the rig's limits at the scenario's defaults (the amplifier range, 0.1 A into
//! 1.5 µF; DECISIONS.md, "Digital twin and rig"). Goal: on the twin of the rhombus sample,
//! every default trajectory needs less than 80 % of the stroke the amplifier range delivers
//! and less than the amplifier's current, through the controllers' feed-forward.

use flexstage_control::experiment::Setup;
use flexstage_sim::trajectory::Reference;
use flexstage_twin::{Twin, samples};

#[test]
fn default_trajectories_fit_the_twin_and_the_rig() {
    let (s, rho) = samples::quick_rhombus().unwrap();
    let t = Twin::from_scenario(&s, &rho).unwrap();
    let setup = Setup::from_scenario(&s);
    for tr in &s.trajectories {
        let (r, d) = Reference::from_scenario(tr);
        let f = setup.check_reference(&r, d, Some(t.dc_gain())).unwrap();
        println!(
            "{}: {:.0} % of the deliverable stroke",
            tr.name(),
            100.0 * f.stroke_usage
        );
        assert!(f.stroke_usage < 0.8 && f.peak_current < 0.1);
    }
}
