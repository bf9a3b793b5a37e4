//! Reference: the closed forms of each rig part (module docs of `flexstage_sim::rig`):
//! a d-sample delay, the first-order amplifier `U(t) = U_f + (U_0 − U_f)e^{−2πf_a t}`, the
//! current-limited ramp `dU/dt = I/C` (PI piezo tutorial, Eq. 4-15), PI's logarithmic creep
//! `Δx(t) = Δx(0.1 s)(1 + γ lg(t/0.1 s))` (Eq. 4-2), a first-order sensor, a white + 1/f
//! spectrum `S(f) = S_w(1 + f_c/f)`, the VC-C floor level (12.5 µm/s RMS per 1/3-octave band,
//! Gordon 1991), and the legacy lumped plant (the rig with every effect off must reproduce it
//! bit for bit).
//! Goal: each part, driven through a mechanics that passes x_nom straight to the output,
//! matches its closed form.

use flexstage_scenario::Scenario;
use flexstage_sim::experiment::Command;
use flexstage_sim::pea::deliverable_stroke;
use flexstage_sim::plant::{LumpedStage, Plant, PlantParams};
use flexstage_sim::rig::{
    AmplifierParams, CreepParams, FloorParams, Mechanics, PlantActuator, RigParams, RigPlant,
    SensorParams, StagePlant,
};

/// Mechanics whose output is x_nom (or the floor acceleration) at the end of the substep.
#[derive(Debug, Clone)]
struct Direct {
    h: f64,
    q: [f64; 2],
    floor: bool,
}

impl Mechanics for Direct {
    fn substep_time(&self) -> f64 {
        self.h
    }
    fn advance(&mut self, x_nom: [[f64; 2]; 2], floor: [[f64; 2]; 2]) {
        self.q = if self.floor { floor[1] } else { x_nom[1] };
    }
    fn output(&self) -> [f64; 2] {
        self.q
    }
    fn inputs(&self) -> [f64; 2] {
        self.q
    }
}

/// The paper's rig with every effect off.
fn quiet() -> RigParams {
    let mut r = PlantParams::from_scenario(&Scenario::paper()).rig();
    r.noise_std = [0.0; 2];
    r.resolution = [0.0; 2];
    r
}

fn plant(r: RigParams, floor: bool) -> RigPlant<Direct> {
    let h = r.substep();
    RigPlant::new(
        r,
        Direct {
            h,
            q: [0.0; 2],
            floor,
        },
    )
    .unwrap()
}

fn command(voltage: [f64; 2], x_nom: [f64; 2]) -> Command {
    Command {
        voltage,
        x_nom,
        ..Command::default()
    }
}

#[test]
fn delay_holds_the_command_back_by_whole_samples() {
    for delay in 0..=2 {
        let mut r = quiet();
        r.delay = delay;
        r.actuator = PlantActuator::Ideal;
        let mut p = plant(r, false);
        let mut seen = Vec::new();
        for k in 0..5 {
            let x = if k == 0 { 1e-6 } else { 0.0 };
            p.apply(&command([500.0; 2], [x, 0.0]));
            seen.push(p.output()[0]);
        }
        let first = seen.iter().position(|&q| q > 0.0).unwrap();
        assert_eq!(first, delay, "delay {delay}: {seen:?}");
    }
}

#[test]
fn amplifier_follows_the_first_order_response_and_the_current_limit() {
    let mut r = quiet();
    let (fa, t) = (3000.0, r.sample_time);
    r.amplifier = AmplifierParams {
        bandwidth: fa,
        ..AmplifierParams::ideal()
    };
    let mut p = plant(r.clone(), false);
    for k in 1..=5 {
        p.apply(&command([520.0; 2], [0.0; 2]));
        let exact = 520.0 - 20.0 * (-std::f64::consts::TAU * fa * k as f64 * t).exp();
        let u = p.voltage()[0];
        assert!((u - exact).abs() < 1e-9, "k {k}: {u} vs {exact}");
    }
    // A 400 V step through 0.1 A into 1.5 µF: a ramp of I/C = 66.7 V/ms.
    r.amplifier = AmplifierParams {
        bandwidth: 0.0,
        slew_rate: 0.0,
        current_limit: 0.1,
        capacitance: 1.5e-6,
    };
    let mut p = plant(r, false);
    for k in 1..=3 {
        p.apply(&command([900.0; 2], [0.0; 2]));
        let exact = 500.0 + 0.1 / 1.5e-6 * k as f64 * t;
        assert!((p.voltage()[1] - exact).abs() < 1e-9, "{}", p.voltage()[1]);
    }
}

#[test]
fn creep_follows_the_logarithmic_law_per_decade() {
    let mut r = quiet();
    let gamma = 0.02;
    r.creep = CreepParams { factor: gamma };
    r.sample_time = 1e-3;
    r.substeps = 1;
    let mut p = plant(r, false);
    let at = |p: &mut RigPlant<Direct>, until: f64, t: &mut f64| {
        while *t < until - 1e-12 {
            p.apply(&command([700.0; 2], [0.0; 2]));
            *t += 1e-3;
        }
        p.x_nom()[0]
    };
    let mut t = 0.0;
    let x01 = at(&mut p, 0.1, &mut t);
    for (tt, lg) in [(1.0, 1.0), (10.0, 2.0)] {
        let x = at(&mut p, tt, &mut t);
        let law = gamma * lg;
        let got = x / x01 - 1.0;
        println!("t = {tt} s: creep {got:.4} (law {law:.4})");
        assert!((got - law).abs() < 0.15 * law, "{got} vs {law}");
    }
}

/// Reference: the exact solution of the creep relaxations `ż_j = (Δx − z_j)/τ_j`,
/// τ_j = 0.1, 1, 10, 100 s (module docs), for a displacement step Δx at t = 0 (ideal
/// amplifier: the voltage jumps): `x_nom(t) = Δx (1 + γ Σ_j (1 − e^{−t/τ_j}))`. Goal: the rig's
/// per-sample creep update reproduces it to round-off at every sample.
#[test]
fn creep_after_a_step_is_the_exact_sum_of_relaxations() {
    let gamma = 0.02;
    let mut r = quiet();
    r.creep = CreepParams { factor: 0.0 };
    let mut plain = plant(r.clone(), false);
    r.creep = CreepParams { factor: gamma };
    let t = r.sample_time;
    let mut creeping = plant(r, false);
    for k in 1..=2000 {
        let cmd = command([700.0, 400.0], [0.0; 2]);
        plain.apply(&cmd);
        creeping.apply(&cmd);
        let tk = k as f64 * t;
        let law: f64 = [0.1, 1.0, 10.0, 100.0]
            .iter()
            .map(|tau| -(-tk / tau).exp_m1())
            .sum::<f64>()
            * gamma;
        for i in 0..2 {
            let dx = plain.x_nom()[i];
            let got = creeping.x_nom()[i] / dx - 1.0;
            assert!(
                (got - law).abs() < 1e-12,
                "sample {k}, PEA {i}: {got:e} vs {law:e}"
            );
        }
    }
}

#[test]
fn sensor_is_first_order_and_its_noise_is_white_plus_one_over_f() {
    let mut r = quiet();
    r.actuator = PlantActuator::Ideal;
    let fs = 2000.0;
    r.sensor = SensorParams {
        bandwidth: fs,
        flicker_corner: 0.0,
        anti_alias: 0.0,
    };
    let t = r.sample_time;
    let h = r.substep();
    let mut p = plant(r.clone(), false);
    // Here the output ramps to 1 µm over the first substep, then stays: the first-order
    // response to that ramp is the reference. The chain interpolates the output by parabolas
    // through three nodes (exact for quadratics, O(h³)), so at the ramp's kinks it differs
    // from the true ramp by a fraction of the substep's rise; the tolerance, 1 % of the step,
    // still catches a bandwidth off by 10 % (≈ 3 % at the first sample). At rest the gain is 1.
    let w = std::f64::consts::TAU * fs;
    let after_ramp = 1.0 - (1.0 - (-w * h).exp()) / (w * h);
    for k in 1..=4 {
        p.apply(&command([500.0; 2], [1e-6, 0.0]));
        let exact = 1e-6 * (1.0 - (1.0 - after_ramp) * (-w * (k as f64 * t - h)).exp());
        let y = p.measure()[0];
        assert!((y - exact).abs() < 1e-8, "k {k}: {y} vs {exact}");
    }
    for _ in 0..200 {
        p.apply(&command([500.0; 2], [1e-6, 0.0]));
    }
    assert!((p.measure()[0] - 1e-6).abs() < 1e-15);
    // Spectrum: white σ = 10 nm, 1/f corner 1 Hz. Hann-windowed periodograms of 16 segments
    // of 2^17 samples; each bin is compared with S_w(1 + f_c/f) at its own frequency and the
    // ratios of 11 bins around 1 Hz and around 100 Hz are averaged.
    r.sensor = SensorParams {
        bandwidth: 0.0,
        flicker_corner: 1.0,
        anti_alias: 0.0,
    };
    r.noise_std = [10e-9; 2];
    let mut p = plant(r, false);
    let (seg, segs) = (1usize << 17, 16);
    let y: Vec<f64> = (0..segs * seg).map(|_| p.measure()[0]).collect();
    let s_white = 10e-9f64.powi(2) / (0.5 / t);
    for f in [1.0, 100.0] {
        let k0 = (f * seg as f64 * t).round() as usize;
        let (mut acc, mut count) = (0.0, 0);
        for s in 0..segs {
            let x = &y[s * seg..(s + 1) * seg];
            let mean = x.iter().sum::<f64>() / seg as f64;
            for k in k0 - 5..=k0 + 5 {
                // DFT bin k by a rotating phasor.
                let w = std::f64::consts::TAU * k as f64 / seg as f64;
                let (rc, rs) = (w.cos(), w.sin());
                let (mut c, mut sn) = (1.0, 0.0);
                let (mut re, mut im) = (0.0, 0.0);
                for (n, v) in x.iter().enumerate() {
                    let hann = 0.5 - 0.5 * (std::f64::consts::TAU * n as f64 / seg as f64).cos();
                    re += hann * (v - mean) * c;
                    im -= hann * (v - mean) * sn;
                    (c, sn) = (c * rc - sn * rs, sn * rc + c * rs);
                }
                // One-sided PSD; the Hann window's mean square is 3/8.
                let psd = 2.0 * t * (re * re + im * im) / (0.375 * seg as f64);
                let fk = k as f64 / (seg as f64 * t);
                acc += psd / (s_white * (1.0 + 1.0 / fk));
                count += 1;
            }
        }
        let ratio = acc / count as f64;
        println!("f = {f} Hz: PSD / S_w(1 + f_c/f) = {ratio:.3}");
        assert!((ratio - 1.0).abs() < 0.2, "{ratio}");
    }
}

#[test]
fn floor_vibration_has_the_vc_c_level_per_band() {
    let mut r = quiet();
    r.floor = FloorParams {
        velocity_rms: 12.5e-6,
        bands: [8.0, 80.0],
    };
    r.substeps = 1;
    let mut p = plant(r.clone(), true);
    let n = 200_000; // 20 s
    let mut ms = [0.0; 2];
    for _ in 0..n {
        p.apply(&command([500.0; 2], [0.0; 2]));
        let a = p.output();
        ms[0] += a[0] * a[0] / n as f64;
        ms[1] += a[1] * a[1] / n as f64;
    }
    // 11 bands 8·10^(k/10) Hz, each with velocity RMS v: acceleration RMS² = Σ (v ω_k)².
    let expected: f64 = (0..=10)
        .map(|k| (12.5e-6 * std::f64::consts::TAU * 8.0 * 10f64.powf(k as f64 / 10.0)).powi(2))
        .sum();
    for m in ms {
        println!(
            "floor acceleration RMS {:.3e} m/s², expected {:.3e}",
            m.sqrt(),
            expected.sqrt()
        );
        assert!((m / expected - 1.0).abs() < 0.02);
    }
}

#[test]
fn lumped_plant_in_a_rig_without_effects_is_the_legacy_plant() {
    let plant = PlantParams::from_scenario(&Scenario::paper());
    let mut legacy = Plant::new(plant.clone()).unwrap();
    let rig = plant.rig();
    let mech = LumpedStage::new(&plant.truth, plant.coupling, rig.substep()).unwrap();
    let mut rigged = RigPlant::new(rig, mech).unwrap();
    for k in 0..300 {
        let u = 500.0 + 200.0 * (k as f64 * 0.05).sin();
        let cmd = command([u, 1000.0 - u], [0.0; 2]);
        assert_eq!(legacy.measure(), rigged.measure());
        legacy.apply(&cmd);
        rigged.apply(&cmd);
        assert_eq!(legacy.output(), rigged.output());
        assert_eq!(legacy.voltage(), rigged.voltage());
    }
}

#[test]
fn deliverable_stroke_is_less_than_the_nominal_30_um() {
    let s = Scenario::paper();
    let a = PlantParams::from_scenario(&s);
    for p in &a.hysteresis {
        let [up, down] = deliverable_stroke(p, a.voltage_range, a.bias_voltage, 0.25);
        println!("deliverable: +{:.2} / -{:.2} µm", up * 1e6, down * 1e6);
        assert!(down < 30e-6 && up > down);
        // The default controller stroke fits inside it.
        assert!(s.controller.stroke <= down.min(up));
    }
}

/// Reference: the mechanics' output is x_nom at the end of each substep (`Direct`), and with
/// an ideal actuator x_nom steps at the start of the sample. Goal: once recorded, the true
/// output on every substep is that output, the sensed output with an ideal sensor is the
/// output, and with a first-order sensor the sensed output after the last substep is what
/// `sensed` reads at the next sample; nothing is recorded before `record_substeps`.
#[test]
fn substeps_are_recorded_as_a_fast_adc_sees_the_sensor() {
    let mut r = quiet();
    r.actuator = PlantActuator::Ideal;
    r.delay = 0;
    r.sensor = SensorParams::ideal();
    let mut p = plant(r.clone(), false);
    p.apply(&command([0.0; 2], [1e-6, 2e-6]));
    assert!(p.sensed_substeps().is_empty() && p.output_substeps().is_empty());
    p.record_substeps();
    p.apply(&command([0.0; 2], [3e-6, 4e-6]));
    assert_eq!(p.output_substeps().len(), r.substeps);
    for (q, s) in p.output_substeps().iter().zip(p.sensed_substeps()) {
        assert_eq!(*q, [3e-6, 4e-6]);
        assert_eq!(q, s);
    }
    r.sensor = SensorParams {
        bandwidth: 2000.0,
        flicker_corner: 0.0,
        anti_alias: 0.0,
    };
    let mut p = plant(r.clone(), false);
    p.record_substeps();
    p.apply(&command([0.0; 2], [1e-6, 0.0]));
    let path = p.sensed_substeps().to_vec();
    assert_eq!(path[r.substeps - 1], p.sensed());
    assert!(path.windows(2).all(|w| w[1][0] > w[0][0]) && path[0][0] > 0.0);
    assert!(path[r.substeps - 1][0] < 1e-6);
}
