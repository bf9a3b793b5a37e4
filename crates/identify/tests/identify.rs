// Reference: paper Section 4.2 (Eq. 54–56, Table 4), the bad-data requirement. Goal: the online RLS
// identification recovers every stiffness of a simulated stage with known truth — within
// 1 % on noise-free data of the linear model (Eq. 36), within 5 % with the default sensor
// noise and quantization — and, in the paper's scenario (guess = Table 4 guesses, truth =
// Table 4 estimates), the estimates converge from the guesses to the truth.

use flexstage_identify::{IdentifyParams, identify, samples, simulate};
use flexstage_scenario::StageParams;

fn stiffness_errors(e: &StageParams, t: &StageParams) -> [(&'static str, f64); 6] {
    let r = |a: f64, b: f64| 100.0 * (a - b) / b;
    [
        ("k_qo1", r(e.k_qo1, t.k_qo1)),
        ("k_qo2", r(e.k_qo2, t.k_qo2)),
        ("k_in1", r(e.k_in1, t.k_in1)),
        ("k_in2", r(e.k_in2, t.k_in2)),
        ("k_pea1", r(e.k_pea1, t.k_pea1)),
        ("k_pea2", r(e.k_pea2, t.k_pea2)),
    ]
}

fn run(duration: f64, linear: bool, noisy: bool, limit_pct: f64) {
    let sim = samples::paper_simulation(duration, linear, noisy);
    let record = simulate(&sim).unwrap();
    let id = identify(
        &record,
        &samples::table4_guess(),
        &IdentifyParams::default(),
    )
    .unwrap();
    let errs = stiffness_errors(&id.raw.params, &sim.plant.truth);
    println!("duration {duration} s, linear {linear}, noisy {noisy}: {errs:?}");
    for (name, e) in errs {
        assert!(
            e.abs() < limit_pct,
            "{name}: error {e:+.3} % exceeds {limit_pct} %"
        );
    }
}

#[test]
fn noise_free_linear_model_within_1_percent() {
    run(1.0, true, false, 1.0);
}

#[test]
fn noisy_linear_model_within_5_percent() {
    run(4.0, true, true, 5.0);
}

#[test]
fn paper_scenario_converges_from_table4_guess_to_table4_estimate() {
    // The full digital twin: Bouc–Wen PEAs, cross terms, noise and quantization.
    let sim = samples::paper_simulation(4.0, false, true);
    let record = simulate(&sim).unwrap();
    let guess = samples::table4_guess();
    let truth = samples::table4_truth();
    let id = identify(&record, &guess, &IdentifyParams::default()).unwrap();
    let end = stiffness_errors(&id.raw.params, &truth);
    let start = stiffness_errors(&guess, &truth);
    let quarter = &id.history[id.history.len() / 4].estimate.params;
    let mid = stiffness_errors(quarter, &truth);
    println!("start {start:?}\nquarter {mid:?}\nend {end:?}");
    for i in 0..6 {
        assert!(end[i].1.abs() < 5.0, "{}: {:+.3} %", end[i].0, end[i].1);
        // Table 4: K_qo1 guess 5e6 against 3.78e6 (+32 %), K_in1 1e5 against 9.2e4 (+8.7 %).
        if start[i].1.abs() > 5.0 {
            assert!(end[i].1.abs() < start[i].1.abs() / 2.0, "{}", end[i].0);
        }
    }
    // Converged: the last three quarters change the estimates by less than 5 %.
    for i in 0..6 {
        assert!(
            (mid[i].1 - end[i].1).abs() < 5.0,
            "{} still moving",
            end[i].0
        );
    }
    // The parameter set for `track` is valid.
    id.params.validate("params").unwrap();
    assert!(id.warnings.is_empty(), "{:?}", id.warnings);
}

#[test]
fn identical_drives_are_not_persistently_exciting() {
    // Both PEAs driven with the same signal: x_in1 − x_in2 and q_o2 stay at zero.
    let mut sim = samples::paper_simulation(0.3, true, false);
    sim.excitation.duration = 0.3;
    let mut record = simulate(&sim).unwrap();
    record.x_nom[1] = record.x_nom[0].clone();
    record.x_in[1] = record.x_in[0].clone();
    record.q[1] = vec![0.0; record.len()];
    let err = identify(
        &record,
        &samples::table4_guess(),
        &IdentifyParams::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("no persistent excitation"), "{err}");
    assert!(err.contains("q_o1") || err.contains("q_o2"), "{err}");
}

#[test]
fn nearly_identical_drives_warn_of_ill_conditioning() {
    let sim = samples::paper_simulation(0.3, true, false);
    let mut record = simulate(&sim).unwrap();
    // The second plate moves like the first one up to a tiny independent part.
    for k in 0..record.len() {
        record.x_nom[1][k] = record.x_nom[0][k] * (1.0 + 1e-9);
        record.x_in[1][k] = record.x_in[0][k] * (1.0 + 1e-9);
    }
    match identify(
        &record,
        &samples::table4_guess(),
        &IdentifyParams::default(),
    ) {
        Ok(id) => assert!(
            id.warnings.iter().any(|w| w.contains("ill-conditioned")),
            "{:?} {:?}",
            id.warnings,
            id.conditioning
        ),
        Err(e) => panic!("expected a warning, got the error {e}"),
    }
}

#[test]
fn identified_coupling_is_the_plants_cross_stiffness() {
    // Reference: the plant's own cross-coupling k_c of Eq. (30) (flexstage-control's lumped
    // plant). Goal: the field the controller uses (`Identification::coupling`) carries it,
    // noise-free on the full plant (Bouc–Wen PEAs, cross terms), and is 0 when switched off.
    let sim = samples::paper_simulation(2.0, false, false);
    assert!(sim.plant.coupling > 0.0);
    let record = simulate(&sim).unwrap();
    let guess = samples::table4_guess();
    let id = identify(&record, &guess, &IdentifyParams::default()).unwrap();
    let err = id.coupling / sim.plant.coupling - 1.0;
    println!(
        "k_c {} vs {}: {:+.2} %",
        id.coupling,
        sim.plant.coupling,
        100.0 * err
    );
    assert!(
        err.abs() < 0.05,
        "k_c {} vs {}",
        id.coupling,
        sim.plant.coupling
    );
    let off = IdentifyParams {
        coupling: false,
        ..IdentifyParams::default()
    };
    assert_eq!(identify(&record, &guess, &off).unwrap().coupling, 0.0);
}

/// The two-band excitation of the lumped stage (Table 4 truth with the plant's cross terms)
/// for `seed`: the resonance band of the model's own modes and the output prefilter above it.
fn two_band(seed: u64, duration: f64) -> (StageParams, f64, flexstage_identify::Identification) {
    use flexstage_sim::model::StageModel;
    let mut sim = samples::paper_simulation(duration, false, true);
    sim.plant.seed = seed;
    let model = StageModel::with_coupling(&sim.plant.truth, sim.plant.coupling).unwrap();
    let (band, cut) = flexstage_identify::resonance_plan(
        &model,
        sim.plant.sample_time,
        flexstage_identify::RESONANCE_AMPLITUDE,
    )
    .unwrap();
    sim.excitation.resonance = Some(band);
    let params = IdentifyParams {
        output_prefilter: Some(cut),
        resonant: true,
        ..IdentifyParams::default()
    };
    let record = simulate(&sim).unwrap();
    let id = identify(&record, &samples::table4_guess(), &params).unwrap();
    (sim.plant.truth.clone(), sim.plant.coupling, id)
}

#[test]
fn two_band_excitation_meets_the_identification_targets_on_the_lumped_plant() {
    // Reference: the simulated lumped stage's truth (Table 4 estimates, cross terms 5 % of
    // √(2K_qo1K_qo2)), Bouc–Wen PEAs, the default sensor noise and quantization, 8 s records
    // (the default), default estimator settings plus the resonance plan.
    // Goal: with the resonance band derived from the model's output modes,
    // every stiffness within 3 % and the output dampings c_qo1, c_qo2 within 10 % of the
    // truth, for each of four noise seeds; the coupling k_c within 10 %.
    for seed in [1u64, 2, 3, 4] {
        let (truth, k_c, id) = two_band(seed, 8.0);
        let e = &id.raw.params;
        let r = |a: f64, b: f64| 100.0 * (a - b) / b;
        let damp = [
            ("c_qo1", r(e.c_qo1, truth.c_qo1)),
            ("c_qo2", r(e.c_qo2, truth.c_qo2)),
        ];
        let kc = r(id.coupling, k_c);
        let stiff = stiffness_errors(e, &truth);
        println!("seed {seed}: {stiff:?} {damp:?} k_c {kc:+.3} %");
        for (name, v) in stiff {
            assert!(v.abs() < 3.0, "seed {seed}: {name} {v:+.3} % (limit 3 %)");
        }
        for (name, v) in damp {
            assert!(v.abs() < 10.0, "seed {seed}: {name} {v:+.3} % (limit 10 %)");
        }
        assert!(kc.abs() < 10.0, "seed {seed}: k_c {kc:+.3} %");
    }
}

#[test]
#[ignore = "a measurement, not a check: cargo test --release -p flexstage-identify --test identify explore -- --ignored --nocapture"]
fn explore_two_band_settings() {
    use flexstage_sim::model::StageModel;
    let var = |name: &str, default: f64| {
        std::env::var(name)
            .ok()
            .and_then(|v| v.parse::<f64>().ok())
            .unwrap_or(default)
    };
    let (dur, amp, pre, top) = (
        var("ID_DUR", 4.0),
        var("ID_AMP", 2e-6),
        var("ID_PRE", 300.0),
        var("ID_TOP", 0.0),
    );
    for seed in [1u64, 2, 3] {
        let mut sim =
            samples::paper_simulation(dur, var("ID_LIN", 0.0) > 0.0, var("ID_NOISE", 1.0) > 0.0);
        sim.plant.seed = seed;
        let model = StageModel::with_coupling(&sim.plant.truth, sim.plant.coupling).unwrap();
        let (mut band, cut) =
            flexstage_identify::resonance_plan(&model, sim.plant.sample_time, amp).unwrap();
        if top > 0.0 {
            band.f_hi = top;
        }
        sim.excitation.resonance = Some(band);
        let params = IdentifyParams {
            output_prefilter: Some(if top > 0.0 {
                (1.2 * top).min(4750.0)
            } else {
                cut
            }),
            prefilter: pre,
            resonant: var("ID_RES", 1.0) > 0.0,
            ..IdentifyParams::default()
        };
        let record = simulate(&sim).unwrap();
        let id = identify(&record, &samples::table4_guess(), &params).unwrap();
        let (e, t) = (&id.raw.params, &sim.plant.truth);
        let r = |a: f64, b: f64| 100.0 * (a - b) / b;
        println!(
            "seed {seed} band {:.0}-{:.0}: {:?} c_qo1 {:+.2} c_qo2 {:+.2} k_c {:+.2}",
            band.f_lo,
            band.f_hi,
            stiffness_errors(e, t)
                .iter()
                .map(|(n, v)| format!("{n} {v:+.2}"))
                .collect::<Vec<_>>(),
            r(e.c_qo1, t.c_qo1),
            r(e.c_qo2, t.c_qo2),
            r(id.coupling, sim.plant.coupling)
        );
    }
}

#[test]
#[ignore = "open defect: the rig holds one voltage per sample and its 3 kHz \
            amplifier moves the plates within the sample, which the sampled regression does not \
            see; measured K_qo1 +2.3 %, K_in1 −13 %, c_qo1 +59 %, c_qo2 +20 % (K_qo2 −0.5 %, \
            k_c +0.1 %). Needs a hold-aware discretization of the regression."]
fn rig_record_of_the_lumped_stage_identifies_its_truth() {
    // Reference: the lumped stage (Table 4 truth, cross terms 5 %) inside the scenario's rig
    // with its Bouc–Wen PEAs and 3 kHz amplifiers, the sensors ideal and noise-free and no
    // floor vibration, so that the record is the one the twin's path (`simulate_rig`) logs.
    // Goal: `simulate_rig` logs a record from which the two-band identification recovers the
    // stiffnesses within 1 % and the output dampings and k_c within 5 %.
    use flexstage_sim::model::StageModel;
    use flexstage_sim::plant::PlantParams;
    use flexstage_sim::rig::RigParams;
    let scenario = flexstage_scenario::Scenario::paper();
    let truth = PlantParams::from_scenario(&scenario);
    let mut rig = RigParams::from_scenario(&scenario);
    rig.noise_std = [0.0; 2];
    rig.resolution = [0.0; 2];
    rig.sensor.bandwidth = 0.0;
    rig.sensor.flicker_corner = 0.0;
    rig.floor.velocity_rms = 0.0;
    let sim = samples::paper_simulation(2.0, false, false);
    let model = StageModel::with_coupling(&truth.truth, truth.coupling).unwrap();
    let (band, cut) = flexstage_identify::resonance_plan(
        &model,
        rig.sample_time,
        flexstage_identify::RESONANCE_AMPLITUDE,
    )
    .unwrap();
    let exp = flexstage_identify::RigExperiment {
        excitation: flexstage_identify::Excitation {
            resonance: Some(band),
            ..sim.excitation.clone()
        },
        plate_sensor: [0.0; 2],
        slope: sim.slope,
        bias_voltage: rig.bias_voltage,
        voltage_range: rig.voltage_range,
        seed: 1,
    };
    let mut plant = truth.in_rig(rig).unwrap();
    let record = flexstage_identify::simulate_rig(&mut plant, &exp).unwrap();
    let params = IdentifyParams {
        output_prefilter: Some(cut),
        resonant: true,
        ..IdentifyParams::default()
    };
    let id = identify(&record, &samples::table4_guess(), &params).unwrap();
    let (e, t) = (&id.raw.params, &truth.truth);
    let r = |a: f64, b: f64| 100.0 * (a - b) / b;
    let damp = [r(e.c_qo1, t.c_qo1), r(e.c_qo2, t.c_qo2)];
    let kc = r(id.coupling, truth.coupling);
    let stiff = stiffness_errors(e, t);
    println!("rig: {stiff:?} c {damp:?} k_c {kc:+.3} %");
    for (name, v) in stiff {
        assert!(v.abs() < 1.0, "{name} {v:+.3} %");
    }
    assert!(damp.iter().all(|v| v.abs() < 5.0), "{damp:?}");
    assert!(kc.abs() < 5.0, "k_c {kc:+.3} %");
}
