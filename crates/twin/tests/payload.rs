//! Reference: the design's eigenproblem of the stage (`flexstage_topopt::modal`: the design
//! mesh with the PEA springs and the plates of the model guess, the rollers and the payload,
//! the optimizer's output load taken off), an independent assembly of the same stage from the
//! twin's side (void removed, the plates of the truth, Craig–Bampton). Goal: with a 20 g
//! payload on the output the twin's three lowest modes are within 1 % of the design's (the
//! issue asks 3 % of the first), and the payload lowers the modes that move the output
//! (here the second and third; the rhombus's first moves the input plates) alike in both.

use flexstage_topopt::{ModalParams, Problem, stage_modes};
use flexstage_twin::{Twin, samples};

/// The design's and the twin's three lowest frequencies with `payload` kg on the output.
fn lowest(payload: f64) -> (Vec<f64>, Vec<f64>) {
    let (mut s, rho) = samples::quick_rhombus().unwrap();
    s.output.payload = payload;
    let problem = Problem::from_scenario(&s, None).unwrap();
    let design = stage_modes(&problem, &rho, &ModalParams::default(), false).unwrap();
    let twin = Twin::from_scenario(&s, &rho).unwrap();
    let t: Vec<f64> = twin
        .modal
        .modes
        .iter()
        .take(3)
        .map(|m| m.frequency)
        .collect();
    println!(
        "payload {payload} kg: design {:.1?} Hz, twin {t:.1?} Hz",
        &design.frequencies[..3]
    );
    (design.frequencies[..3].to_vec(), t)
}

#[test]
fn a_payload_enters_the_design_and_the_twin_alike() {
    let (d0, t0) = lowest(0.0);
    let (d20, t20) = lowest(0.02);
    for k in 0..3 {
        assert!(
            (t20[k] - d20[k]).abs() <= 0.01 * d20[k],
            "20 g, mode {}: {t20:?} vs {d20:?}",
            k + 1
        );
        assert!(
            (t0[k] - d0[k]).abs() <= 0.01 * d0[k],
            "no payload, mode {}",
            k + 1
        );
    }
    assert!(
        d20[1] < 0.95 * d0[1],
        "20 g should lower the output's modes: {d20:?} vs {d0:?}"
    );
    assert!(
        ((d20[1] / d0[1]) - (t20[1] / t0[1])).abs() <= 0.005,
        "the payload's effect differs"
    );
}
