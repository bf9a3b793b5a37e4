//! Reference: the PID + static feed-forward law in closed form (module docs of
//! `flexstage_control_core::pid`, the baseline of Actuators 2022, 11(7), 179, Section 4):
//! for a constant error the trapezoidal integral grows by T e per sample from T e / 2, the
//! backward-difference derivative of a ramp is its slope (0 at the first sample), G_dc⁻¹
//! maps the per-axis sum, a clipped command freezes the integral, a section
//! b = [0, 1, 0] delays the feedback by one sample, and a dropout repeats the last finite
//! measurement.
//! Goal: the law's commands equal those closed forms to rounding, so each of its parts
//! (gains, feed-forward, integral rule, derivative, decoupling, anti-windup, sections,
//! dropout) is checked against a known answer; a wrong sign, factor or order fails.

use flexstage_control_core::{Biquad, PidGains, PidLaw};

const T: f64 = 1e-4;
const IDENTITY: [[f64; 2]; 2] = [[1.0, 0.0], [0.0, 1.0]];

fn gains(kp: f64, ki: f64, kd: f64) -> [PidGains; 2] {
    [PidGains { kp, ki, kd }; 2]
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * b.abs().max(1e-12)
}

#[test]
fn constant_error_follows_the_trapezoidal_closed_form() {
    let (kp, ki, kd) = (0.3, 800.0, 2e-5);
    let mut law = PidLaw::new(gains(kp, ki, kd), IDENTITY, T, 1.0).unwrap();
    let (r, y) = ([2e-6, -1e-6], [1.5e-6, -1.2e-6]);
    for k in 0..200 {
        let u = law.step(y, r);
        for i in 0..2 {
            let e = r[i] - y[i];
            let want = r[i] + kp * e + ki * (k as f64 * T * e + 0.5 * T * e);
            assert!(
                close(u[i], want),
                "sample {k}, axis {i}: {} vs {want}",
                u[i]
            );
        }
        assert!(!law.saturated());
    }
}

#[test]
fn derivative_of_a_ramp_is_its_slope_from_the_second_sample() {
    let mut law = PidLaw::new(gains(0.0, 0.0, 1.0), IDENTITY, T, 1.0).unwrap();
    let slope = 3e-3; // error rate [m/s]
    for k in 0..50 {
        let y = [-slope * k as f64 * T, 0.0];
        let u = law.step(y, [0.0; 2]);
        let want = if k == 0 { 0.0 } else { slope };
        assert!((u[0] - want).abs() <= 1e-12 * slope, "sample {k}: {}", u[0]);
        assert_eq!(u[1], 0.0);
    }
}

#[test]
fn the_inverse_static_gain_maps_feed_forward_and_feedback() {
    let g_inv = [[1.1, 0.05], [0.04, 1.2]];
    let kp = 0.5;
    let mut law = PidLaw::new(gains(kp, 0.0, 0.0), g_inv, T, 1.0).unwrap();
    let (r, y) = ([3e-6, 7e-6], [1e-6, 6e-6]);
    let w = [0, 1].map(|i| r[i] + kp * (r[i] - y[i]));
    let u = law.command(y, r);
    for i in 0..2 {
        let want = g_inv[i][0] * w[0] + g_inv[i][1] * w[1];
        assert_eq!(u[i], want, "axis {i}");
    }
}

/// Reference: x_nom = G_dc⁻¹ N(c) + x_ff (module docs of the law): with x_ff = G_dc⁻¹ r the
/// command is the static law's to rounding, and any other x_ff enters additively; the
/// integral advances the same in both.
#[test]
fn an_outside_feed_forward_replaces_the_static_inverse() {
    let g_inv = [[1.1, 0.05], [0.04, 1.2]];
    let g = gains(0.5, 300.0, 1e-5);
    let mut stat = PidLaw::new(g, g_inv, T, 1.0).unwrap();
    let mut with = PidLaw::new(g, g_inv, T, 1.0).unwrap();
    let mut other = PidLaw::new(g, g_inv, T, 1.0).unwrap();
    let extra = [2e-7, -1e-7];
    for k in 0..50 {
        let r = [3e-6 + 1e-8 * k as f64, 7e-6];
        let y = [1e-6, 6e-6 - 2e-9 * k as f64];
        let x_ff = [0, 1].map(|i| g_inv[i][0] * r[0] + g_inv[i][1] * r[1]);
        let a = stat.command(y, r);
        let b = with.command_with_feedforward(y, r, x_ff);
        let c = other.command_with_feedforward(y, r, [x_ff[0] + extra[0], x_ff[1] + extra[1]]);
        for i in 0..2 {
            assert!(
                close(b[i], a[i]),
                "sample {k}, axis {i}: {} vs {}",
                b[i],
                a[i]
            );
            assert!(close(c[i] - b[i], extra[i]) || (c[i] - b[i] - extra[i]).abs() < 1e-20);
        }
        stat.end_sample(false);
        with.end_sample(false);
        other.end_sample(false);
    }
}

#[test]
fn a_clipped_command_freezes_the_integral() {
    let (ki, stroke) = (500.0, 2e-6);
    let mut law = PidLaw::new(gains(0.0, ki, 0.0), IDENTITY, T, stroke).unwrap();
    let (r, y) = ([1e-6, 0.0], [0.0; 2]);
    // Unclipped, r + ki (k T e + T e / 2) reaches the stroke at k = ⌈(stroke − r − ki T e/2)/(ki T e)⌉.
    let mut clipped_at = None;
    for k in 0..100 {
        let u = law.step(y, r);
        if law.saturated() {
            assert_eq!(u[0], stroke);
            clipped_at.get_or_insert(k);
        }
    }
    let k0 = clipped_at.expect("the command reaches the stroke");
    let e = r[0] - y[0];
    let first = ((stroke - r[0] - 0.5 * ki * T * e) / (ki * T * e)).ceil() as usize;
    assert_eq!(k0, first, "first clip at the closed-form sample");
    // Frozen at the integral of the k0 unclipped samples: the next command is that of k0.
    let want = r[0] + ki * (k0 as f64 * T * e + 0.5 * T * e);
    let u = law.command(y, r);
    assert!(close(u[0], want), "{} vs {want}", u[0]);
}

#[test]
fn a_delay_section_delays_the_feedback_by_one_sample() {
    let kp = 2.0;
    let delay = Biquad::new([0.0, 1.0, 0.0], [0.0, 0.0]);
    let mut law = PidLaw::new(gains(kp, 0.0, 0.0), IDENTITY, T, 1.0)
        .unwrap()
        .with_sections([[delay, Biquad::IDENTITY], [Biquad::IDENTITY; 2]]);
    let mut previous = 0.0;
    for k in 0..20 {
        let y = [1e-7 * (k as f64).sin(), 1e-7 * (k as f64).cos()];
        let u = law.step(y, [0.0; 2]);
        assert_eq!(
            u[0], previous,
            "sample {k}: axis 1 sees the last sample's feedback"
        );
        assert_eq!(u[1], -kp * y[1], "sample {k}: axis 2 has no section");
        previous = -kp * y[0];
    }
}

#[test]
fn a_dropout_repeats_the_last_finite_measurement() {
    let mut a = PidLaw::new(gains(0.4, 300.0, 1e-5), IDENTITY, T, 1.0).unwrap();
    let mut b = a;
    let y = [4e-7, -2e-7];
    a.step(y, [0.0; 2]);
    b.step(y, [0.0; 2]);
    assert_eq!(a.step([f64::NAN, 0.0], [1e-6; 2]), b.step(y, [1e-6; 2]));
}
