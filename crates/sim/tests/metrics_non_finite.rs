//! Reference: IEEE 754 — NaN compares false and `f64::max(a, NaN) = a`, so a fold with `max`
//! silently drops NaN samples (a defect the fault-handling work fixed: "max error 0" for a NaN series).
//! Goal: every metric of a record with a NaN or ∞ sample (RMS, max, % of range, settling, per
//! axis, voltage extremes) is non-finite and the record is marked diverged; a finite record
//! gives the hand-computed values and is not marked (so the check can fail both ways).

use flexstage_sim::experiment::Record;

fn record(error: [Vec<f64>; 2]) -> Record {
    let n = error[0].len();
    let mut r = Record {
        t: (0..n).map(|k| k as f64 * 1e-4).collect(),
        error,
        ..Record::default()
    };
    r.truth = [vec![0.0; n], vec![0.0; n]];
    r.voltage = [vec![10.0; n], vec![-5.0; n]];
    r
}

#[test]
fn ieee754_finite_record_gives_hand_values() {
    let m = record([vec![3e-9, -4e-9, 0.0, 0.0], vec![1e-9; 4]]).metrics([1e-6, 1e-6]);
    assert!(!m.diverged());
    assert_eq!(m.non_finite, 0);
    assert_eq!(m.max, [4e-9, 1e-9]);
    assert!((m.rms[0] - 2.5e-9).abs() < 1e-24, "{}", m.rms[0]);
    assert!((m.max_pct[0] - 100.0 * 4e-9 / 2e-6).abs() < 1e-12);
    assert_eq!((m.peak_voltage, m.min_voltage), (10.0, -5.0));
    assert!(m.settling.is_finite());
}

#[test]
fn ieee754_nan_or_inf_never_reads_as_zero_error() {
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        for axis in 0..2 {
            for at in [0usize, 2, 3] {
                let mut e = [vec![0.0; 4], vec![0.0; 4]];
                e[axis][at] = bad;
                let m = record(e).metrics([1e-6, 1e-6]);
                let what = format!("{bad} on axis {axis} at {at}");
                assert!(m.diverged(), "{what}: {m:?}");
                assert_eq!(m.non_finite, 1, "{what}");
                assert!(!m.max[axis].is_finite(), "{what}: max {:?}", m.max);
                assert!(!m.max_pct[axis].is_finite(), "{what}");
                assert!(!m.rms[axis].is_finite(), "{what}: rms {:?}", m.rms);
                assert!(!m.rms_pct[axis].is_finite(), "{what}");
                assert!(!m.rms_total().is_finite(), "{what}");
                assert!(m.settling.is_nan(), "{what}");
            }
        }
    }
    // An all-NaN series (the case) and a NaN voltage.
    let m = record([vec![f64::NAN; 4], vec![f64::NAN; 4]]).metrics([1e-6, 1e-6]);
    assert!(m.max.iter().all(|x| x.is_nan()), "{m:?}");
    let mut r = record([vec![0.0; 4], vec![0.0; 4]]);
    r.voltage[1][2] = f64::NAN;
    let m = r.metrics([1e-6, 1e-6]);
    assert!(
        m.diverged() && m.peak_voltage.is_nan() && m.min_voltage.is_nan(),
        "{m:?}"
    );
}
