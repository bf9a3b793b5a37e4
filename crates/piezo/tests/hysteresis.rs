// Reference: DECISIONS.md "Units" (Table A1 with 0–1000 V gives about 56–58 µm of stroke and
// 7–11 % hysteresis), Table 1 (60 µm stroke).
// Goal: the steady-state loops of PEA1 and PEA2 under a 0–1000 V, 1 Hz sine have a stroke of
// 55–60 µm and a loop width of 5–12 % of range; the metrics are right on a loop with a known
// width (a parallelogram) and zero on a straight line.

use flexstage_piezo::{BoucWenParams, LoopParams, loop_metrics, samples, steady_state_loop};

#[test]
fn table_a1_loops_have_the_expected_stroke_and_width() {
    let wave = samples::full_range_sine();
    for (name, p) in [("PEA1", BoucWenParams::PEA1), ("PEA2", BoucWenParams::PEA2)] {
        let l = steady_state_loop(&p, |t| wave.value(t), 1.0, LoopParams::default()).unwrap();
        let m = loop_metrics(&l.input, &l.output).unwrap();
        assert!(l.periods >= 2 && l.periods < 50);
        assert!(
            (55.0..=60.0).contains(&m.range),
            "{name}: stroke {} µm",
            m.range
        );
        assert!(
            (5.0..=12.0).contains(&m.width_pct),
            "{name}: width {} %",
            m.width_pct
        );
        assert!(
            m.max_deviation_pct > 1.0 && m.max_deviation_pct < 10.0,
            "{name}: {m:?}"
        );
    }
}

#[test]
fn metrics_of_known_shapes() {
    // Up along y = x, down along y = x − 2 (parallelogram, width 2 over range 12).
    let mut input = Vec::new();
    let mut output = Vec::new();
    for k in 0..=100 {
        let u = 10.0 * k as f64 / 100.0;
        input.push(u);
        output.push(u + 2.0);
    }
    for k in (0..=100).rev() {
        let u = 10.0 * k as f64 / 100.0;
        input.push(u);
        output.push(u);
    }
    let m = loop_metrics(&input, &output).unwrap();
    assert!((m.range - 12.0).abs() < 1e-12);
    assert!((m.width - 2.0).abs() < 1e-12, "{m:?}");
    assert!((m.max_deviation - 1.0).abs() < 1e-12, "{m:?}");
    let line: Vec<f64> = input.iter().map(|u| 3.0 * u + 1.0).collect();
    let m = loop_metrics(&input, &line).unwrap();
    assert!(m.width < 1e-12 && m.max_deviation < 1e-12, "{m:?}");
}
