//! Problems with known answers, used by the tests, the benches and the docs.

use crate::outline::Outline;
use flexstage_scenario::{Preset, Scenario};

/// Young's modulus, Poisson ratio and density of the scenario's aluminium (Table 3).
pub const ALUMINIUM: (f64, f64, f64) = (73e9, 0.33, 2710.0);

/// Counter-clockwise rectangle.
pub fn rectangle(x0: f64, y0: f64, x1: f64, y1: f64) -> Vec<[f64; 2]> {
    vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
}

/// Circle of `n` points, counter-clockwise (an outer loop) or clockwise (a hole).
pub fn circle(c: [f64; 2], r: f64, n: usize, ccw: bool) -> Vec<[f64; 2]> {
    (0..n)
        .map(|k| {
            let t = 2.0 * std::f64::consts::PI * k as f64 / n as f64;
            let t = if ccw { t } else { -t };
            [c[0] + r * t.cos(), c[1] + r * t.sin()]
        })
        .collect()
}

/// Circular-notch flexure hinge (Paros & Weisbord 1965): two blocks of length `block` joined by
/// a neck of minimum thickness `t` between two notches of radius `r`, centred at the origin;
/// height `2r + t`, hinge over `x ∈ [−r, r]`. One outer loop, `n` points per notch.
pub fn notch_hinge(r: f64, t: f64, block: f64, n: usize) -> Vec<[f64; 2]> {
    let h2 = 0.5 * t + r;
    let mut p = vec![[-r - block, -h2]];
    // Bottom notch: centre (0, −h2), from 180° to 0° through 90°.
    for k in 0..=n {
        let a = std::f64::consts::PI * (1.0 - k as f64 / n as f64);
        p.push([r * a.cos(), -h2 + r * a.sin()]);
    }
    p.push([r + block, -h2]);
    p.push([r + block, h2]);
    // Top notch: centre (0, h2), from 0° to −180° through −90°.
    for k in 0..=n {
        let a = -std::f64::consts::PI * k as f64 / n as f64;
        p.push([r * a.cos(), h2 + r * a.sin()]);
    }
    p.push([-r - block, h2]);
    p
}

/// Rotational compliance `θ/M` [rad/(N·m)] of a circular-notch hinge by Euler–Bernoulli
/// beam theory, `∫ 12 dx / (E b h(x)³)` over `x ∈ [−r, r]` with `h(x) = t + 2r − 2√(r² − x²)`:
/// the integral that Paros & Weisbord (1965, "How to design flexure hinges", Machine Design
/// 37:151–156) evaluate in closed form. Composite Simpson on a grid refined at the neck.
pub fn paros_weisbord_compliance(e: f64, b: f64, r: f64, t: f64) -> f64 {
    // Substitute x = r sin φ (dense near the neck at φ = 0), φ ∈ [−π/2, π/2].
    let f = |phi: f64| {
        let x = r * phi.sin();
        let h = t + 2.0 * r - 2.0 * (r * r - x * x).max(0.0).sqrt();
        12.0 / (e * b * h.powi(3)) * r * phi.cos()
    };
    let n = 200_000;
    let (a, bb) = (-0.5 * std::f64::consts::PI, 0.5 * std::f64::consts::PI);
    let dx = (bb - a) / n as f64;
    let mut s = f(a) + f(bb);
    for k in 1..n {
        s += if k % 2 == 1 { 4.0 } else { 2.0 } * f(a + k as f64 * dx);
    }
    s * dx / 3.0
}

/// Simplified Paros–Weisbord compliance for `t ≪ r`: `θ/M = 9π √r / (2 E b t^{5/2})`.
pub fn paros_weisbord_thin(e: f64, b: f64, r: f64, t: f64) -> f64 {
    9.0 * std::f64::consts::PI * r.sqrt() / (2.0 * e * b * t.powf(2.5))
}

/// Stress concentration of a central circular hole of diameter `d` in a strip of width `w`
/// under tension, on the **gross** section: Heywood's fit to Howland's (1930) solution,
/// `K_tn = 2 + 0.284 (1 − d/w) − 0.600 (1 − d/w)² + 1.32 (1 − d/w)³` on the net section
/// (Pilkey & Pilkey, *Peterson's Stress Concentration Factors*, 3rd ed., Chart 4.1), times
/// `w / (w − d)`. Tends to Kirsch's 3 as `d/w → 0`.
pub fn howland_kt_gross(d: f64, w: f64) -> f64 {
    let q = 1.0 - d / w;
    (2.0 + 0.284 * q - 0.600 * q * q + 1.32 * q * q * q) / q
}

/// A hand-made bridge-type amplifier on the scenario's design grid: input blocks at the two
/// PEA ports, an output block at the top centre, two inclined beams (0.08 × the domain width
/// thick) joining them. Returns the scenario, the densities (fem order, nearly binary like a
/// projected design: `tanh` edges 0.05 elements wide) and the exported outline (ρ = 0.5
/// contour, 10 Taubin passes, refined to 0.05 mm chords).
pub fn bridge_design(preset: Preset) -> (Scenario, Vec<f64>, Vec<Vec<[f64; 2]>>) {
    bridge_on(Scenario::preset(preset), 0.05)
}

/// [`bridge_design`] on a given scenario's grid with `tanh` edges `edge` elements wide.
pub fn bridge_on(s: Scenario, edge: f64) -> (Scenario, Vec<f64>, Vec<Vec<[f64; 2]>>) {
    let (l, w) = (s.mesh.length, s.mesh.width);
    let (nl, nw) = (s.mesh.nl, s.mesh.nw);
    let (dx, dy) = (l / nl as f64, w / nw as f64);
    let boxes = [
        ([0.0, 0.4 * w], [0.1 * l, 0.6 * w]),
        ([0.9 * l, 0.4 * w], [l, 0.6 * w]),
        ([0.4 * l, 0.8 * w], [0.6 * l, w]),
    ];
    let beams = [
        ([0.08 * l, 0.5 * w], [0.45 * l, 0.88 * w]),
        ([0.92 * l, 0.5 * w], [0.55 * l, 0.88 * w]),
    ];
    let half = 0.04 * w;
    let sdf = |p: [f64; 2]| {
        let mut d = f64::INFINITY;
        for (lo, hi) in boxes {
            let q = [
                (lo[0] - p[0]).max(p[0] - hi[0]),
                (lo[1] - p[1]).max(p[1] - hi[1]),
            ];
            let out = q[0].max(0.0).hypot(q[1].max(0.0));
            d = d.min(out + q[0].max(q[1]).min(0.0));
        }
        for (a, b) in beams {
            d = d.min(crate::geometry::segment_distance(p, a, b).0 - half);
        }
        d
    };
    let width = edge * dx.max(dy);
    let mut rho = vec![0.0; nl * nw];
    for i in 0..nl {
        for j in 0..nw {
            let c = [(i as f64 + 0.5) * dx, (j as f64 + 0.5) * dy];
            rho[i * nw + j] =
                (0.5 - 0.5 * (sdf(c) / width).tanh()).clamp(s.optimization.rho_min, 1.0);
        }
    }
    let outline = Outline::from_fem_order(nl, nw, dx, dy, 0.5, 10, &rho)
        .expect("sizes match")
        .refined(0.05e-3);
    (s, rho, outline.loops)
}
