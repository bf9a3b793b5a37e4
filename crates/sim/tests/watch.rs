//! Reference: the second hardening review, "Hang": a run whose state became NaN was simulated
//! to its end (and then drawn without end); "Absurd results with exit 0": runs at 54–670 % of
//! range RMS with up to 9,999 saturated samples were reported as results. Goal: the runner
//! stops a run at the first non-finite state, at an error beyond its bound and at a saturation
//! longer than its bound, recording up to that sample and saying why, with the progress
//! finished; a run that stays inside every bound runs to its end; the status tells a diverged,
//! a worse-than-at-rest, a saturated and a good run apart (each case can fail both ways).

use flexstage_sim::experiment::{
    Command, StageControl, Status, StopCause, WatchParams, run, run_watched,
};
use flexstage_sim::rig::StagePlant;

const DT: f64 = 1e-4;
const N: usize = 10_000;
const REF: f64 = 1e-6;

/// A controller that asks for a constant reference and flags saturation as told.
struct Hold {
    saturated: fn(usize) -> bool,
    k: usize,
}

impl StageControl for Hold {
    fn step(&mut self, _y: [f64; 2]) -> Command {
        self.k += 1;
        Command {
            reference: [REF, REF],
            saturated: (self.saturated)(self.k - 1),
            ..Command::default()
        }
    }
    fn estimate(&self) -> [f64; 10] {
        [0.0; 10]
    }
}

/// A plant whose output is `gain` × its last output plus `offset` each sample.
struct Grow {
    q: f64,
    gain: f64,
    offset: f64,
}

impl StagePlant for Grow {
    fn measure(&mut self) -> [f64; 2] {
        [self.q; 2]
    }
    fn output(&self) -> [f64; 2] {
        [self.q; 2]
    }
    fn apply(&mut self, _cmd: &Command) {
        self.q = self.gain * self.q + self.offset;
    }
    fn voltage(&self) -> [f64; 2] {
        [0.0; 2]
    }
    fn x_nom(&self) -> [f64; 2] {
        [0.0; 2]
    }
}

fn hold(saturated: fn(usize) -> bool) -> Hold {
    Hold { saturated, k: 0 }
}

#[test]
fn a_growing_output_stops_at_the_first_non_finite_state_and_the_progress_ends() {
    let mut plant = Grow {
        q: 1e-9,
        gain: 2.0,
        offset: 0.0,
    };
    let mut done = 0;
    let rec = run(&mut hold(|_| false), &mut plant, N as f64 * DT, DT, |n| {
        done += n
    });
    let stopped = rec.stopped.expect("stopped");
    assert_eq!(stopped.cause, StopCause::NonFinite);
    assert!(rec.len() < 1100, "{} samples", rec.len());
    assert_eq!(done, N);
    let m = rec.metrics([REF, REF]);
    assert_eq!(m.status(), Status::Diverged);
    assert!(
        m.status_detail().contains("non-finite"),
        "{}",
        m.status_detail()
    );
}

#[test]
fn an_error_beyond_its_bound_stops_the_run() {
    let mut plant = Grow {
        q: 1e-9,
        gain: 2.0,
        offset: 0.0,
    };
    let watch = WatchParams {
        max_error: 1e-3,
        ..WatchParams::default()
    };
    let rec = run_watched(&mut hold(|_| false), &mut plant, 1.0, DT, &watch, |_| {});
    let Some(stopped) = rec.stopped else {
        panic!("not stopped")
    };
    let StopCause::Error { error, bound } = stopped.cause else {
        panic!("{stopped}")
    };
    assert!(error > 1e-3 && error < 3e-3 && bound == 1e-3, "{stopped}");
    assert_eq!(rec.len(), 21, "2^20 nm is the first beyond 1 mm");
    assert!(rec.metrics([REF, REF]).status().refused());
}

#[test]
fn a_saturation_longer_than_its_bound_stops_the_run() {
    let mut plant = Grow {
        q: REF,
        gain: 1.0,
        offset: 0.0,
    };
    let watch = WatchParams {
        max_saturated: 0.01,
        ..WatchParams::default()
    };
    // Saturated in bursts of 50 samples (never stopped), then for good from sample 5000.
    let rec = run_watched(
        &mut hold(|k| k % 100 < 50 || k >= 5000),
        &mut plant,
        1.0,
        DT,
        &watch,
        |_| {},
    );
    let stopped = rec.stopped.expect("stopped");
    assert!(
        matches!(stopped.cause, StopCause::Saturated { bound } if bound == 0.01),
        "{stopped}"
    );
    assert!((5100..=5102).contains(&rec.len()), "{} samples", rec.len());
}

#[test]
fn a_run_inside_its_bounds_runs_to_its_end_and_its_status_says_what_it_is_worth() {
    let watch = WatchParams {
        max_error: 1e-3,
        max_saturated: 0.01,
    };
    let status = |q0: f64, saturated: fn(usize) -> bool| {
        let mut plant = Grow {
            q: q0,
            gain: 1.0,
            offset: 0.0,
        };
        let rec = run_watched(&mut hold(saturated), &mut plant, 1.0, DT, &watch, |_| {});
        assert_eq!((rec.len(), rec.stopped), (N, None));
        rec.metrics([REF, REF]).status()
    };
    // On the reference: ok; saturated in 2 % of the samples: flagged; at −reference (error
    // twice that of a stage at rest): above the bound, refused; at rest itself: not above.
    assert_eq!(status(REF, |_| false), Status::Ok);
    assert_eq!(status(REF, |k| k % 50 == 0), Status::Saturated);
    assert!(!Status::Saturated.refused());
    assert_eq!(status(-REF, |_| false), Status::ErrorAboveBound);
    assert_eq!(status(0.0, |_| false), Status::Ok);
}
