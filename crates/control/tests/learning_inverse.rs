// Reference: Bristow, Tharayil & Alleyne, "A survey of iterative learning control", IEEE
// Control Systems Magazine 26(3), 2006 ("plant inversion": with L = T⁻¹ and Q = 1 the error
// vanishes after one trial; Eq. (24), monotone convergence |Q(1 − L T)| < 1); the DFT of a
// circular convolution is the product of the DFTs.
// Goal: the model-inverse law's time-domain kernels are the inverse DFTs of its gains
// (checked against direct sums); on a known periodic LTI plant it cancels the error in one
// trial with γ = 1 and no uncertainty; with a plant off the measured one by up to δ_k its
// error contracts every trial by at most the designed ρ; on the lumped rig with the PID +
// feed-forward baseline, the law designed from the readings alone learns the true output's
// error well below the baseline's.

mod common;

use common::LumpedRig;
use flexstage_control::learning::{
    Complex, DesignParams, InverseLaw, Law, Learning, LearningPlant, design_inverse, design_law,
    inverse_convergence_factor,
};

use std::f64::consts::TAU;

/// The DFT bin k of a real sequence, Σ x_m e^{−j2πkm/N} (direct sum).
fn dft(x: &[f64], k: usize) -> Complex {
    let n = x.len();
    x.iter().enumerate().fold((0.0, 0.0), |(re, im), (m, v)| {
        let a = TAU * (k * m) as f64 / n as f64;
        (re + v * a.cos(), im - v * a.sin())
    })
}

/// A damped, delayed periodic impulse response (a loop with two samples of delay, a
/// first-order roll-off of unit DC gain and a small resonance), wrapped over the period N.
fn impulse(n: usize) -> Vec<f64> {
    let mut h = vec![0.0; n];
    for i in 0..400 {
        let t = i as f64;
        h[(i + 2) % n] +=
            0.5 * 0.5f64.powi(i as i32) + 0.05 * (-0.12 * t).exp() * (0.4 * t + 0.3).cos();
    }
    h
}

/// The plant of the impulse response `h` as the learning design sees it: T_k = DFT(h) at
/// k = 1..=N/2 on both axes, with the uncertainty `delta` everywhere.
fn plant_of(h: &[f64], delta: f64) -> LearningPlant {
    let n = h.len();
    let response: Vec<Complex> = (1..=n / 2).map(|k| dft(h, k)).collect();
    LearningPlant {
        period: n,
        response: [response.clone(), response],
        uncertainty: [vec![delta; n / 2], vec![delta; n / 2]],
    }
}

/// y = h ⊛ c (circular convolution over the period).
fn convolve(h: &[f64], c: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let n = h.len();
    (0..n)
        .map(|k| core::array::from_fn(|a| (0..n).map(|m| h[m] * c[(k + n - m) % n][a]).sum()))
        .collect()
}

/// A zero-mean periodic reference with content up to the 12th harmonic on each axis.
fn reference(n: usize) -> Vec<[f64; 2]> {
    (0..n)
        .map(|k| {
            let w = TAU * k as f64 / n as f64;
            [
                (3.0 * w).sin() + 0.2 * (9.0 * w + 1.0).cos(),
                w.sin() + 0.1 * (12.0 * w).sin(),
            ]
        })
        .collect()
}

/// One trial of the law on the periodic plant h: the error e_j = r − h ⊛ c_j, then
/// c_{j+1} from the law; returns (e_j, c_{j+1}).
fn trial(
    law: &InverseLaw,
    h: &[f64],
    r: &[[f64; 2]],
    c: &[[f64; 2]],
) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
    let y = convolve(h, c);
    let e: Vec<[f64; 2]> = r
        .iter()
        .zip(&y)
        .map(|(r, y)| [r[0] - y[0], r[1] - y[1]])
        .collect();
    let next = (0..h.len()).map(|k| law.correction(c, &e, k)).collect();
    (e, next)
}

fn norm(e: &[[f64; 2]]) -> f64 {
    e.iter()
        .map(|v| v[0] * v[0] + v[1] * v[1])
        .sum::<f64>()
        .sqrt()
}

#[test]
fn inverse_law_kernels_are_the_inverse_dfts_of_its_gains() {
    for n in [90usize, 91] {
        let h = impulse(n);
        let plant = plant_of(&h, 0.0);
        let mut band = vec![1.0; n / 2];
        band[n / 2 - 3] = 0.0; // a hole in the passband
        let law = InverseLaw::new(&plant, 0.7, [band.clone(), band]).unwrap();
        for a in 0..2 {
            let (q, l) = law.kernels(a);
            for k in 1..=n / 2 {
                let qk = dft(q, k);
                let lk = dft(l, k);
                let want_q = law.passband(a)[k];
                let want_l = law.learning_gain(a)[k];
                let nyquist = 2 * k == n;
                // The Nyquist bin of a real sequence is real.
                let want_l = if nyquist { (want_l.0, 0.0) } else { want_l };
                assert!(
                    (qk.0 - want_q).abs() < 1e-12 && qk.1.abs() < 1e-12,
                    "N {n} k {k}"
                );
                assert!(
                    (lk.0 - want_l.0).abs() < 1e-10 && (lk.1 - want_l.1).abs() < 1e-10,
                    "N {n} k {k}: {lk:?} vs {want_l:?}"
                );
                // L_k = Q_k γ / T_k against the measured response.
                if want_q > 0.0 && !nyquist {
                    let t = plant.response[a][k - 1];
                    let prod = (
                        want_l.0 * t.0 - want_l.1 * t.1,
                        want_l.0 * t.1 + want_l.1 * t.0,
                    );
                    assert!((prod.0 - 0.7).abs() < 1e-12 && prod.1.abs() < 1e-12);
                }
            }
        }
    }
}

#[test]
fn inverse_law_cancels_the_error_in_one_trial_on_a_known_periodic_plant() {
    let n = 90;
    let h = impulse(n);
    let plant = plant_of(&h, 0.0);
    let band = vec![1.0; n / 2];
    let law = InverseLaw::new(&plant, 1.0, [band.clone(), band]).unwrap();
    assert_eq!(inverse_convergence_factor(&plant, &law), 0.0);
    let r = reference(n);
    let (e0, c1) = trial(&law, &h, &r, &vec![[0.0; 2]; n]);
    let (e1, _) = trial(&law, &h, &r, &c1);
    assert!(norm(&e0) > 1.0);
    assert!(
        norm(&e1) < 1e-10 * norm(&e0),
        "{} vs {}",
        norm(&e1),
        norm(&e0)
    );
}

#[test]
fn inverse_law_contracts_by_its_rho_for_a_plant_within_the_uncertainty() {
    let n = 90;
    let h = impulse(n);
    // The true plant: h plus a perturbation whose DFT stays within δ at every harmonic
    // (|Δ_k| ≤ Σ|Δh| = 0.02 ≤ δ).
    let mut truth = h.clone();
    truth[3] += 0.012;
    truth[7] -= 0.008;
    let measured = plant_of(&h, 0.02);
    let (law, rho) = design_inverse(&measured, &DesignParams::default()).unwrap();
    assert!((rho - inverse_convergence_factor(&measured, &law)).abs() < 1e-15);
    assert!(rho < 0.95);
    let r = reference(n);
    let mut c = vec![[0.0; 2]; n];
    let mut last = f64::INFINITY;
    // The passband's part of the error contracts by ρ per trial; the error outside it is
    // not learned and stays. The total norm never grows.
    for j in 0..30 {
        let (e, next) = trial(&law, &truth, &r, &c);
        let nrm = norm(&e);
        assert!(nrm <= last * (1.0 + 1e-12), "trial {j}: {nrm} after {last}");
        last = nrm;
        c = next;
    }
    let (e, _) = trial(&law, &truth, &r, &c);
    assert!(norm(&e) < 0.05 * norm(&r), "{} of {}", norm(&e), norm(&r));
}

#[test]
fn inverse_law_from_the_readings_learns_on_the_lumped_rig() {
    let rig = LumpedRig::paper();
    let plant = rig.learning_plant(3);
    let (law, rho) = design_inverse(&plant, &DesignParams::default()).unwrap();
    assert!(rho < 0.95);
    let (chosen, chosen_rho) = design_law(&plant, &DesignParams::default()).unwrap();
    assert!(chosen_rho <= rho);
    assert_eq!(chosen.name() == "inverse", chosen_rho == rho);
    let periods = 8;
    let mut learning = Learning::with_law(rig.baseline(), &Law::Inverse(law)).unwrap();
    let rms = rig.rms(&mut learning, periods);
    let rms0 = rig.rms(rig.baseline().as_mut(), periods);
    for a in 0..2 {
        // Learned, and it stays learned: no growth after the first periods (a passband
        // reaching |T| = 0.05 diverged here after three periods).
        for j in 4..periods {
            assert!(rms[j][a] < 1.5 * rms[3][a], "axis {a} period {j}: {rms:?}");
        }
        assert!(
            rms[periods - 1][a] < 0.5 * rms0[periods - 1][a],
            "axis {a}: {rms:?} vs {rms0:?}"
        );
    }
}
