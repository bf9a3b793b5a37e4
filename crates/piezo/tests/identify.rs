// Reference: paper Appendix B (Eq. A8–A12, Algorithm A1, Table A1), DECISIONS.md "PEA
// hysteresis" (on noise-free synthetic data the estimators must recover known parameters),
// the PEA-identification requirements ("noise-free synthetic data recovers the true parameters within 1 %; with sensor
// noise of 10 nm, within 5 %").
// Goal: on synthetic records of PEA1 and PEA2 (Table A1, 10 kHz, the decaying 1 Hz drive),
// the online parallel RLS of Algorithm A1 (summed regression, src/identify.rs) from Table A1's
// zero initial guess recovers all five parameters within 1 % without noise and within 5 %
// with 10 nm sensor noise (several seeds); it agrees with the batch fit, which meets the same
// bounds; two passes and a forgetting factor keep working.

use flexstage_piezo::{BoucWenParams, IdentifyParams, fit_batch, identify, samples, synthesize};

fn worst_error(est: &BoucWenParams, truth: &BoucWenParams) -> f64 {
    [
        (est.d_p, truth.d_p),
        (est.a_bw, truth.a_bw),
        (est.b_bw, truth.b_bw),
        (est.gamma_bw, truth.gamma_bw),
        (est.delta_bw, truth.delta_bw),
    ]
    .iter()
    .map(|(e, t)| ((e - t) / t).abs())
    .fold(0.0, f64::max)
}

#[test]
fn parallel_rls_recovers_noise_free_parameters() {
    for truth in [BoucWenParams::PEA1, BoucWenParams::PEA2] {
        let prob = samples::identification_problem(truth, 0.0, 1).unwrap();
        let id = identify(&prob.data, &IdentifyParams::default()).unwrap();
        let err = worst_error(&id.estimate, &truth);
        assert!(
            err < 0.01,
            "{truth:?}: estimate {:?}, worst error {err}",
            id.estimate
        );
        assert!(id.rms_error < 0.01, "rms {}", id.rms_error);
        // The history starts at the initial guess and ends at the estimate (Figure A2).
        let first = id.history.first().unwrap().estimate;
        assert_eq!((first.a_bw, first.b_bw, first.gamma_bw), (0.0, 0.0, 0.0));
        assert_eq!(id.history.last().unwrap().estimate, id.estimate);
    }
}

#[test]
fn batch_fit_recovers_noise_free_parameters() {
    for truth in [BoucWenParams::PEA1, BoucWenParams::PEA2] {
        let prob = samples::identification_problem(truth, 0.0, 1).unwrap();
        let fit = fit_batch(&prob.data).unwrap();
        let err = worst_error(&fit.estimate, &truth);
        assert!(
            err < 0.01,
            "{truth:?}: {:?}, worst error {err}",
            fit.estimate
        );
    }
}

#[test]
fn batch_fit_with_10nm_sensor_noise() {
    // The 1 Hz decaying drive of 10 s at 10 kHz; 10 nm = 0.010 µm of white noise on x.
    for truth in [BoucWenParams::PEA1, BoucWenParams::PEA2] {
        let data = synthesize(&truth, &samples::identification_drive(), 1e-4, 0.010, 11).unwrap();
        let fit = fit_batch(&data).unwrap();
        let err = worst_error(&fit.estimate, &truth);
        assert!(
            err < 0.05,
            "{truth:?}: {:?}, worst error {err}",
            fit.estimate
        );
        // The model explains the record down to the noise.
        assert!(fit.rms_error < 0.02, "rms {}", fit.rms_error);
    }
}

#[test]
fn parallel_rls_with_10nm_sensor_noise() {
    // Online, one pass, λ_f = 1: the recursive form of the batch least squares. Measured worst
    // errors over seeds 1–10: PEA1 1.1 %, PEA2 2.7 % (δ_bw is the hardest).
    for truth in [BoucWenParams::PEA1, BoucWenParams::PEA2] {
        for seed in [1, 2, 3, 4] {
            let data =
                synthesize(&truth, &samples::identification_drive(), 1e-4, 0.010, seed).unwrap();
            let id = identify(&data, &IdentifyParams::default()).unwrap();
            let err = worst_error(&id.estimate, &truth);
            assert!(
                err < 0.05,
                "{truth:?} seed {seed}: {:?}, worst error {err}",
                id.estimate
            );
            assert!(id.rms_error < 0.02, "rms {}", id.rms_error);
            // With λ_f = 1 it converges to the batch solution of the same record.
            let fit = fit_batch(&data).unwrap();
            let gap = worst_error(&id.estimate, &fit.estimate);
            assert!(
                gap < 0.01,
                "seed {seed}: online {:?} vs batch {:?}",
                id.estimate,
                fit.estimate
            );
        }
    }
}

#[test]
fn parallel_rls_with_forgetting_and_passes() {
    // λ_f = 0.99998 (5 s of memory at 10 kHz): measured worst 1.2 % / 2.9 % over 10 seeds.
    for truth in [BoucWenParams::PEA1, BoucWenParams::PEA2] {
        let data = synthesize(&truth, &samples::identification_drive(), 1e-4, 0.010, 3).unwrap();
        let params = IdentifyParams {
            forgetting: 0.99998,
            ..IdentifyParams::default()
        };
        let id = identify(&data, &params).unwrap();
        let err = worst_error(&id.estimate, &truth);
        assert!(
            err < 0.05,
            "{truth:?}: {:?}, worst error {err}",
            id.estimate
        );
        // A second pass over the same record (a new record for the estimator: new sums, new
        // offset) keeps the noise-free estimates exact.
        let clean = samples::identification_problem(truth, 0.0, 1).unwrap();
        let params = IdentifyParams {
            passes: 2,
            ..IdentifyParams::default()
        };
        let id = identify(&clean.data, &params).unwrap();
        let err = worst_error(&id.estimate, &truth);
        assert!(
            err < 0.01,
            "{truth:?} two passes: {:?}, worst error {err}",
            id.estimate
        );
    }
}
