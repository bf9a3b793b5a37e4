// Reference: the bad-data requirement ("bad data gets clear errors"). Goal: stage records are read from CSV
// with the columns t, x_nom1/x_nom2 (or U1/U2), x_in1, x_in2, q1, q2, and too few samples,
// non-uniform sampling and malformed cells are rejected with messages naming the problem.

use flexstage_identify::{IdentifyParams, StageRecord, identify, samples, simulate};

fn hysteresis() -> [flexstage_piezo::BoucWenParams; 2] {
    let s = flexstage_scenario::Scenario::paper();
    [
        flexstage_piezo::BoucWenParams::from(&s.hysteresis.pea1),
        flexstage_piezo::BoucWenParams::from(&s.hysteresis.pea2),
    ]
}

fn read(text: &str) -> flexstage_identify::Result<StageRecord> {
    StageRecord::from_csv(text.as_bytes(), "test.csv", &hysteresis(), 500.0, 1e-3)
}

fn rows(n: usize, dt: impl Fn(usize) -> f64) -> String {
    let mut s = String::from("t,x_nom1,x_nom2,x_in1,x_in2,q1,q2\n");
    let mut t = 0.0;
    for k in 0..n {
        s.push_str(&format!("{t},{},0,0,0,0,0\n", k as f64 * 1e-9));
        t += dt(k);
    }
    s
}

#[test]
fn csv_round_trip_and_identification_agree() {
    let sim = samples::paper_simulation(0.5, true, false);
    let rec = simulate(&sim).unwrap();
    let back = read(&rec.to_csv()).unwrap();
    assert_eq!(back.len(), rec.len());
    assert_eq!(back.q[1], rec.q[1]);
    let p = IdentifyParams::default();
    let a = identify(&rec, &samples::table4_guess(), &p).unwrap();
    let b = identify(&back, &samples::table4_guess(), &p).unwrap();
    assert_eq!(a.raw.params.k_qo1, b.raw.params.k_qo1);
}

#[test]
fn too_few_samples() {
    let e = read(&rows(50, |_| 1e-4)).unwrap_err().to_string();
    assert!(e.contains("too few samples: 50"), "{e}");
}

#[test]
fn non_uniform_sampling() {
    let e = read(&rows(400, |k| if k == 123 { 2e-4 } else { 1e-4 }))
        .unwrap_err()
        .to_string();
    assert!(e.contains("non-uniform sampling"), "{e}");
}

#[test]
fn time_not_increasing_and_bad_cells_name_the_line() {
    let mut text = rows(300, |_| 1e-4);
    text = text.replacen("0.0002,", "0.0001,", 1);
    let e = read(&text).unwrap_err().to_string();
    assert!(e.contains("line 4") && e.contains("not increasing"), "{e}");
    let e = read("t,x_nom1,x_nom2,x_in1,x_in2,q1,q2\n0,1,2,3,abc,5,6\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 2") && e.contains("x_in2"), "{e}");
    let e = read("t,x_nom1,x_in1,x_in2,q1,q2\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("missing column \"x_nom2\""), "{e}");
}

#[test]
fn voltages_are_turned_into_x_nom_by_the_pea_model() {
    // Drive both PEAs around the bias; x_nom follows the Bouc–Wen model (µm → m).
    let mut text = String::from("t,U1,U2,x_in1,x_in2,q1,q2\n");
    for k in 0..400 {
        let u = 500.0 + 100.0 * (k as f64 * 0.01).sin();
        text.push_str(&format!("{},{u},{u},0,0,0,0\n", k as f64 * 1e-4));
    }
    let rec = read(&text).unwrap();
    assert!(rec.voltage.is_some());
    let peak = rec.x_nom[0].iter().cloned().fold(0.0, f64::max);
    assert!(peak > 1e-6 && peak < 50e-6, "x_nom peak {peak}");
    assert_eq!(rec.x_nom[0][0], 0.0);
}
