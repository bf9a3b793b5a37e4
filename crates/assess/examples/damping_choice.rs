//! Which damping pays on a measured loop: integral resonant control (IRC, Fleming & Leang
//! 2013: an integrator on the loop with a feed-through d, both signs of k and d searched) or
//! positive position feedback (PPF, `flexstage_control::damping`), each on the modal model of
//! each axis's mode, kept only when its damping loop alone is stable and meets the margins
//! (with the lab's allowance) on the full loop model; then the PPF design's gains and the
//! feedback bandwidths against the PI + notch. From a run's measured response only:
//!
//! ```text
//! cargo run --release -p flexstage-assess --example damping_choice -- RUN/track/measured_response.csv
//! ```

use flexstage_assess::lab::{LabMeasurement, LabParams};
use flexstage_control::damping::design;
use flexstage_control::tuning::{Structure, TuningParams, tune};
use flexstage_identify::measured::MeasuredResponse;
use flexstage_sim::modal::LoopPlant;

fn main() {
    let Some(path) = std::env::args().nth(1) else {
        eprintln!("usage: damping_choice <the measured response file in a run's track folder>");
        std::process::exit(2);
    };
    let file = std::fs::File::open(&path).expect("the measured response file");
    let resp = MeasuredResponse::from_csv(file, &path).expect("a measured response");
    let lab = LabParams::default();
    let m = LabMeasurement::from_response(resp, &lab.fit).expect("its loop model");
    let tuning = lab
        .allowing(&TuningParams::default())
        .expect("valid tuning");
    let plant = &m.model;
    let g = plant.static_gain();
    let det = g[0][0] * g[1][1] - g[0][1] * g[1][0];
    let gi = [
        [g[1][1] / det, -g[0][1] / det],
        [-g[1][0] / det, g[0][0] / det],
    ];
    let pn = tune(plant, Structure::PiNotch, &tuning).expect("the PI + notch");
    let t0 = std::time::Instant::now();
    let Some(d) = design(plant, &tuning).expect("the damping design") else {
        println!("ppf-pi-ff: not designed on this loop");
        return;
    };
    println!("ppf-pi-ff designed in {:.2} s", t0.elapsed().as_secs_f64());
    for (i, f) in d.damping.iter().enumerate() {
        let Some(f) = f else { continue };
        let (irc, ppf) = constrained(
            plant,
            gi,
            i,
            f,
            tuning.gain_margin_db,
            tuning.phase_margin_deg,
        );
        let (irc_free, ppf_free) = irc_vs_ppf(f);
        println!(
            "q{}: mode {:.0} Hz, ζ {:.4} in the sampled loop; best damping on its modal model: \
             IRC {irc_free:.4}, PPF {ppf_free:.4}; with the damping loop alone stable and within \
             the margins on the full loop model: IRC {irc:.4}, PPF {ppf:.4}; the design's PPF \
             (after step 5) {:.4}",
            i + 1,
            f.mode.0,
            f.mode.1,
            f.predicted()
        );
    }
    println!(
        "integral gains [1/s]: pi-notch-ff {:.0} / {:.0}, ppf-pi-ff {:.0} / {:.0}",
        pn.params.axes[0].ki, pn.params.axes[1].ki, d.outer.axes[0].ki, d.outer.axes[1].ki
    );
    let zero = |_f: f64| [nalgebra::Complex::new(0.0, 0.0); 2];
    let bw_pn = bandwidth(plant, &|f| pn.params.axis_response(f), &zero, gi);
    let bw_ppf = bandwidth(
        plant,
        &|f| d.outer.axis_response(f),
        &|f| d.damping_response(f),
        gi,
    );
    println!(
        "feedback bandwidth (|T_ii| first below −3 dB) [Hz]: pi-notch-ff {:.0} / {:.0}, \
         ppf-pi-ff {:.0} / {:.0}",
        bw_pn[0], bw_pn[1], bw_ppf[0], bw_ppf[1]
    );
}

/// The feedback bandwidth per axis: the first frequency (1 % steps from 1 Hz) where the
/// diagonal of T = (I + P G⁻¹ diag(c − D))⁻¹ P G⁻¹ diag(c) falls below 1/√2.
pub fn bandwidth(
    plant: &dyn LoopPlant,
    c: &dyn Fn(f64) -> [nalgebra::Complex<f64>; 2],
    d: &dyn Fn(f64) -> [nalgebra::Complex<f64>; 2],
    gi: [[f64; 2]; 2],
) -> [f64; 2] {
    use nalgebra::Complex;
    let mut out = [f64::NAN; 2];
    let one = Complex::new(1.0, 0.0);
    let mut f = 1.0;
    while f < 4990.0 {
        let p = plant.response(f);
        let pg: [[Complex<f64>; 2]; 2] =
            [0, 1].map(|i| [0, 1].map(|j| p[i][0] * gi[0][j] + p[i][1] * gi[1][j]));
        let (cc, dd) = (c(f), d(f));
        let k = [cc[0] - dd[0], cc[1] - dd[1]];
        // M = I + PG K, T = M^-1 PG diag(c)
        let m = [
            [one + pg[0][0] * k[0], pg[0][1] * k[1]],
            [pg[1][0] * k[0], one + pg[1][1] * k[1]],
        ];
        let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
        let mi = [
            [m[1][1] / det, -m[0][1] / det],
            [-m[1][0] / det, m[0][0] / det],
        ];
        for i in 0..2 {
            let t = (mi[i][0] * pg[0][i] + mi[i][1] * pg[1][i]) * cc[i];
            if out[i].is_nan() && t.norm() < std::f64::consts::FRAC_1_SQRT_2 {
                out[i] = f;
            }
        }
        f *= 1.01;
    }
    out
}

/// The best damping of the least damped root on the modal model, unconstrained: IRC
/// (u = −k T z/(z − 1) (y + d u), k and d of either sign) and PPF.
pub fn irc_vs_ppf(f: &flexstage_control::damping::DampingFilter) -> (f64, f64) {
    use flexstage_control::damping::{DampingFilter, FILTER_DAMPINGS, damping_of};
    use nalgebra::{Complex, Matrix3};
    let t = f.sample_time;
    let w = std::f64::consts::TAU * f.mode.0;
    let z = f.mode.1;
    let p = (Complex::new(-z * w, w * (1.0 - z * z).sqrt()) * t).exp();
    let r = f.residue;
    let (a1, a2) = (-2.0 * p.re, p.norm_sqr());
    let (n1, n0) = (2.0 * r.re, -2.0 * (r * p.conj()).re);
    let mut best_irc = f64::NEG_INFINITY;
    for sg in [1.0, -1.0] {
        for i in 0..60 {
            let d = 10f64.powf(-2.0 + 3.0 * i as f64 / 59.0);
            for dsg in [1.0, -1.0] {
                let d = d * dsg;
                for j in 0..60 {
                    let k = sg * w * 10f64.powf(-3.0 + 3.5 * j as f64 / 59.0);
                    // (z-1)(z^2+a1 z+a2) + k T z (n1 z + n0 + d (z^2 + a1 z + a2)) = 0
                    let kt = k * t;
                    let c3 = 1.0 + kt * d;
                    let c2 = (a1 - 1.0) + kt * (n1 + d * a1);
                    let c1 = (a2 - a1) + kt * (n0 + d * a2);
                    let c0 = -a2;
                    let c = [c2 / c3, c1 / c3, c0 / c3];
                    let m = Matrix3::new(-c[0], -c[1], -c[2], 1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
                    let zz = m
                        .complex_eigenvalues()
                        .iter()
                        .map(|&x| damping_of(x, t))
                        .fold(f64::INFINITY, f64::min);
                    if zz > best_irc {
                        best_irc = zz;
                    }
                }
            }
        }
    }
    let mut best_ppf = f64::NEG_INFINITY;
    for &zf in &FILTER_DAMPINGS {
        for j in 0..80 {
            let k = w * 10f64.powf(-3.0 + 3.5 * j as f64 / 79.0);
            let g = DampingFilter::new(f.mode, r, zf, k, t).predicted();
            if g > best_ppf {
                best_ppf = g;
            }
        }
    }
    (best_irc, best_ppf)
}

/// IRC and PPF as step 5a of `flexstage_control::damping` selects them: the best damping
/// predicted on the modal model among the candidates whose damping loop alone is stable
/// (winding of 1 − (P G⁻¹)_ii D on a 20 000-line grid) and meets the margins on the full loop
/// model.
pub fn constrained(
    plant: &dyn LoopPlant,
    gi: [[f64; 2]; 2],
    i: usize,
    f: &flexstage_control::damping::DampingFilter,
    gm: f64,
    pm: f64,
) -> (f64, f64) {
    use flexstage_control::damping::{DampingFilter, FILTER_DAMPINGS, damping_of};
    use flexstage_control::margins::{MarginParams, margin};
    use nalgebra::{Complex, Matrix3};
    let t = f.sample_time;
    let w = std::f64::consts::TAU * f.mode.0;
    let z = f.mode.1;
    let p = (Complex::new(-z * w, w * (1.0 - z * z).sqrt()) * t).exp();
    let r = f.residue;
    let (a1, a2) = (-2.0 * p.re, p.norm_sqr());
    let (n1, n0) = (2.0 * r.re, -2.0 * (r * p.conj()).re);
    let pgii = |fr: f64| {
        let pp = plant.response(fr);
        pp[i][0] * gi[0][i] + pp[i][1] * gi[1][i]
    };
    let mp = MarginParams {
        points: 120,
        refine: 30,
        ..MarginParams::default()
    };
    let ok = |dfun: &dyn Fn(f64) -> Complex<f64>| -> bool {
        // winding of 1 - PG D over 0..nyquist must be 0 (open loop stable)
        let n = 20000;
        let mut ph = 0.0;
        let mut prev = Complex::new(1.0, 0.0) - pgii(0.01) * dfun(0.01);
        for k in 1..=n {
            let fr = 5000.0 * k as f64 / n as f64 - 1e-6;
            let v = Complex::new(1.0, 0.0) - pgii(fr) * dfun(fr);
            ph += (v / prev).arg();
            prev = v;
        }
        if ph.abs() > 1.5 {
            return false;
        }
        let m = margin(|fr| -pgii(fr) * dfun(fr), &mp).unwrap();
        m.meets(gm, pm)
    };
    let mut irc: Vec<(f64, f64, f64, f64)> = Vec::new();
    for sg in [1.0, -1.0] {
        for ii in 0..30 {
            let d = 10f64.powf(-2.0 + 3.0 * ii as f64 / 29.0);
            for dsg in [1.0, -1.0] {
                let d = d * dsg;
                for j in 0..30 {
                    let k = sg * w * 10f64.powf(-3.0 + 3.5 * j as f64 / 29.0);
                    let kt = k * t;
                    let c3 = 1.0 + kt * d;
                    let c2 = (a1 - 1.0) + kt * (n1 + d * a1);
                    let c1 = (a2 - a1) + kt * (n0 + d * a2);
                    let c0 = -a2;
                    let c = [c2 / c3, c1 / c3, c0 / c3];
                    let m = Matrix3::new(-c[0], -c[1], -c[2], 1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
                    let zz = m
                        .complex_eigenvalues()
                        .iter()
                        .map(|&x| damping_of(x, t))
                        .fold(f64::INFINITY, f64::min);
                    if zz.is_finite() {
                        irc.push((zz, k, d, 0.0));
                    }
                }
            }
        }
    }
    irc.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut best_irc = f64::NAN;
    for (zz, k, d, _) in irc.iter().take(4000) {
        // u = C (y + d u), C = -k T z/(z-1)  => D = C/(1 - C d)
        let dfun = |fr: f64| {
            let zq = Complex::from_polar(1.0, std::f64::consts::TAU * fr * t);
            let c = -k * t * zq / (zq - 1.0);
            c / (1.0 - c * d)
        };
        if ok(&dfun) {
            best_irc = *zz;
            break;
        }
    }
    let mut ppf: Vec<(f64, DampingFilter)> = Vec::new();
    for &zf in &FILTER_DAMPINGS {
        for j in 0..40 {
            let k = w * 10f64.powf(-3.0 + 3.5 * j as f64 / 39.0);
            let g = DampingFilter::new(f.mode, r, zf, k, t);
            let v = g.predicted();
            if v.is_finite() {
                ppf.push((v, g));
            }
        }
    }
    ppf.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut best_ppf = f64::NAN;
    for (v, g) in &ppf {
        if ok(&|fr| g.response(fr)) {
            best_ppf = *v;
            break;
        }
    }
    (best_irc, best_ppf)
}
