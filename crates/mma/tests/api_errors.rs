// Reference: this crate's API contract (typed thiserror errors, MmaParams ranges documented in
// src/params.rs).
// Goal: every invalid input is rejected with the error naming the offending slice/field, the
// index, and expected vs got; a rejected update leaves x and the optimizer unchanged.

use flexstage_mma::{KktProblem, Mma, MmaError, MmaParams, ParamError, kkt_residual};

fn mma() -> Mma {
    Mma::new(3, 2, vec![0.0; 3], vec![1.0; 3], MmaParams::default()).unwrap()
}

#[test]
fn params_validation_names_field_and_range() {
    assert_eq!(MmaParams::default().validate(), Ok(()));
    let bad = MmaParams {
        albefa: 1.5,
        ..MmaParams::default()
    };
    match bad.validate() {
        Err(ParamError::OutOfRange {
            field,
            value,
            range,
        }) => {
            assert_eq!(field, "albefa");
            assert_eq!(value, 1.5);
            assert_eq!(range, "(0, 1)");
        }
        other => panic!("unexpected {other:?}"),
    }
    let nan = MmaParams {
        move_limit: f64::NAN,
        ..MmaParams::default()
    };
    assert!(matches!(
        nan.validate(),
        Err(ParamError::OutOfRange {
            field: "move_limit",
            ..
        })
    ));
    let swapped = MmaParams {
        asymin: 2.0,
        asymax: 1.0,
        ..MmaParams::default()
    };
    assert!(matches!(
        swapped.validate(),
        Err(ParamError::Inconsistent {
            field: "asymin",
            ..
        })
    ));
    let msg = bad.validate().unwrap_err().to_string();
    assert!(msg.contains("albefa") && msg.contains("(0, 1)"), "{msg}");
    // Constructor forwards the parameter error.
    let e = Mma::new(1, 0, vec![0.0], vec![1.0], bad).unwrap_err();
    assert!(matches!(
        e,
        MmaError::InvalidParams(ParamError::OutOfRange {
            field: "albefa",
            ..
        })
    ));
}

#[test]
fn constructor_rejects_bad_dimensions_and_bounds() {
    let p = MmaParams::default();
    assert_eq!(
        Mma::new(0, 1, vec![], vec![], p).unwrap_err(),
        MmaError::NoVariables
    );
    assert_eq!(
        Mma::new(3, 1, vec![0.0; 2], vec![1.0; 3], p).unwrap_err(),
        MmaError::DimensionMismatch {
            name: "xmin",
            expected: 3,
            got: 2
        }
    );
    assert_eq!(
        Mma::new(2, 1, vec![0.0, 1.0], vec![1.0, 1.0], p).unwrap_err(),
        MmaError::InvalidBounds {
            index: 1,
            lower: 1.0,
            upper: 1.0
        }
    );
    assert!(matches!(
        Mma::new(2, 1, vec![0.0, f64::NEG_INFINITY], vec![1.0, 1.0], p).unwrap_err(),
        MmaError::NonFinite {
            name: "xmin",
            index: 1,
            ..
        }
    ));
}

#[test]
fn update_rejects_bad_inputs_without_side_effects() {
    let mut m = mma();
    let mut x = vec![0.5; 3];
    let g = vec![1.0; 3];
    let f = vec![-1.0; 2];
    let dfdx = vec![1.0; 6];
    assert_eq!(
        m.update(&mut x, 0.0, &g, &f, &dfdx[..5]).unwrap_err(),
        MmaError::DimensionMismatch {
            name: "dfdx",
            expected: 6,
            got: 5
        }
    );
    assert_eq!(
        m.update(&mut x, 0.0, &g[..2], &f, &dfdx).unwrap_err(),
        MmaError::DimensionMismatch {
            name: "df0dx",
            expected: 3,
            got: 2
        }
    );
    assert_eq!(
        m.update(&mut x, 0.0, &g, &f[..1], &dfdx).unwrap_err(),
        MmaError::DimensionMismatch {
            name: "f",
            expected: 2,
            got: 1
        }
    );
    let mut bad = dfdx.clone();
    bad[4] = f64::NAN;
    match m.update(&mut x, 0.0, &g, &f, &bad).unwrap_err() {
        MmaError::NonFinite { name, index, value } => {
            assert_eq!((name, index), ("dfdx", 4));
            assert!(value.is_nan());
        }
        e => panic!("unexpected {e}"),
    }
    assert!(matches!(
        m.update(&mut x, f64::INFINITY, &g, &f, &dfdx).unwrap_err(),
        MmaError::NonFinite { name: "f0", .. }
    ));
    let mut outside = vec![0.5, 1.5, 0.5];
    assert_eq!(
        m.update(&mut outside, 0.0, &g, &f, &dfdx).unwrap_err(),
        MmaError::OutOfBounds {
            index: 1,
            value: 1.5,
            lower: 0.0,
            upper: 1.0
        }
    );
    assert_eq!(x, vec![0.5; 3]);
    assert_eq!(m.iteration(), 0);
    // A valid update then works and moves x downhill, within the bounds.
    let rep = m.update(&mut x, 0.0, &g, &f, &dfdx).unwrap();
    assert_eq!(rep.iteration, 1);
    assert!(x.iter().all(|&v| (0.0..0.5).contains(&v)), "x = {x:?}");
}

#[test]
fn kkt_residual_checks_lengths() {
    let m = mma();
    let mut mult = m.multipliers();
    let short = [0.0; 2];
    mult.xsi = &short;
    let x = [0.5; 3];
    let e = kkt_residual(
        &KktProblem {
            x: &x,
            xmin: m.xmin(),
            xmax: m.xmax(),
            df0dx: &[0.0; 3],
            f: &[0.0; 2],
            dfdx: &[0.0; 6],
        },
        &mult,
        m.params(),
    )
    .unwrap_err();
    assert_eq!(
        e,
        MmaError::DimensionMismatch {
            name: "xsi",
            expected: 3,
            got: 2
        }
    );
}
