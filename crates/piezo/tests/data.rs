// Reference: the PEA-identification requirements (CLI input `t, U, x` CSV; bad CSV must give a clear error with the line
// number: missing columns, non-monotonic time, NaN).
// Goal: records round-trip through CSV exactly, and each kind of bad input is rejected with
// a message naming the line and the problem.

use flexstage_piezo::{BoucWenParams, PeaData, samples, synthesize};

fn parse(text: &str) -> Result<PeaData, String> {
    PeaData::from_csv(text.as_bytes(), "test.csv").map_err(|e| e.to_string())
}

#[test]
fn round_trip_and_flexible_header() {
    let data = synthesize(
        &BoucWenParams::PEA1,
        &samples::full_range_sine(),
        1e-3,
        0.01,
        1,
    )
    .unwrap();
    assert_eq!(parse(&data.to_csv()).unwrap(), data);
    let d = parse("# comment\nx, extra, u ,T\n1,9,10,0\n2,9,20,0.1\n3,9,30,0.2\n").unwrap();
    assert_eq!(d.t(), &[0.0, 0.1, 0.2]);
    assert_eq!(d.u(), &[10.0, 20.0, 30.0]);
    assert_eq!(d.x(), &[1.0, 2.0, 3.0]);
}

#[test]
fn bad_files_name_the_line() {
    let e = parse("t,U\n0,1\n").unwrap_err();
    assert!(
        e.contains("missing column \"x\"") && e.contains("t, U"),
        "{e}"
    );
    let e = parse("t,U,x\n0,1,2\n0.1,2,3\n0.1,3,4\n").unwrap_err();
    assert!(e.contains("line 4") && e.contains("not increasing"), "{e}");
    let e = parse("t,U,x\n0,1,2\n0.1,NaN,3\n0.2,3,4\n").unwrap_err();
    assert!(
        e.contains("line 3") && e.contains("column U") && e.contains("finite"),
        "{e}"
    );
    let e = parse("t,U,x\n0,1,2\n0.1,2,abc\n").unwrap_err();
    assert!(
        e.contains("line 3") && e.contains("\"abc\" is not a number"),
        "{e}"
    );
    let e = parse("t,U,x\n0,1,2\n0.1,2\n").unwrap_err();
    assert!(e.contains("line 3") && e.contains("cut short"), "{e}");
    let e = parse("t,U,x\n0,1,2\n").unwrap_err();
    assert!(e.contains("at least 3 samples"), "{e}");
}
