//! Reference: Wang, Lazarov & Sigmund, "On projection methods, convergence and robust
//! formulations in topology optimization", SMO 43 (2011) §4, and Qian & Sigmund, CMAME 253
//! (2013) §3: with a density filter of radius R and a sharp projection, a blueprint member that
//! survives in the eroded design (threshold η_e) is at least `R·m(η_e)` wide, and a slot that
//! stays open in the dilated design (η_d) at least `R·m(1 − η_d)`; `m` is derived in
//! `flexstage_topopt::length_scale` for the cone kernel projected on a straight band.
//! Goal: on the discrete filter of a 2D mesh, for straight bands of design field at 0°, 30° and
//! 45°, the thinnest solid band that survives erosion and the thinnest void band that survives
//! dilation have blueprint widths (measured as local thickness) within one element of the
//! guaranteed sizes, which are at least the sizes asked for (0.5 mm hinge, 0.4 mm slot on
//! 0.1 mm elements).

use flexstage_fem::Mesh;
use flexstage_topopt::geometry::{Field, member_sizes};
use flexstage_topopt::{DensityFilter, LengthScale, LengthScaleParams};

const NL: usize = 100;
const NW: usize = 50;
const H: f64 = 1e-4;

/// Design field: `inside` within distance b/2 of the line through the domain centre at angle
/// `angle` from the x axis, `outside` elsewhere; the edge elements take the fraction of them
/// inside (a linear ramp over one element), so that widths are not quantized to elements.
fn band(b: f64, angle: f64, inside: f64, outside: f64) -> Vec<f64> {
    let (c, s) = (angle.cos(), angle.sin());
    let (x0, y0) = (0.5 * NL as f64 * H, 0.5 * NW as f64 * H);
    let mut x = vec![outside; NL * NW];
    for i in 0..NL {
        for j in 0..NW {
            let (px, py) = ((i as f64 + 0.5) * H - x0, (j as f64 + 0.5) * H - y0);
            let w = ((0.5 * b - (-s * px + c * py).abs()) / H + 0.5).clamp(0.0, 1.0);
            x[i * NW + j] = w * inside + (1.0 - w) * outside;
        }
    }
    x
}

/// Filtered value at the band's centre (mean over the elements within half an element of the
/// centre line, away from the domain edges).
fn centre_value(filtered: &[f64], angle: f64) -> f64 {
    let (c, s) = (angle.cos(), angle.sin());
    let (x0, y0) = (0.5 * NL as f64 * H, 0.5 * NW as f64 * H);
    let mut vals = Vec::new();
    for i in NL / 4..3 * NL / 4 {
        for j in NW / 4..3 * NW / 4 {
            let (px, py) = ((i as f64 + 0.5) * H - x0, (j as f64 + 0.5) * H - y0);
            if (-s * px + c * py).abs() <= 0.51 * H && (c * px + s * py).abs() < 0.2 * NW as f64 * H
            {
                vals.push(filtered[i * NW + j]);
            }
        }
    }
    vals.iter().sum::<f64>() / vals.len() as f64
}

/// Blueprint width of the thinnest band (solid, or void when `void`) whose centre survives the
/// threshold `eta` (solid: x̃ ≥ η; void: x̃ ≤ η).
fn thinnest_surviving(filter: &DensityFilter, eta: f64, angle: f64, void: bool) -> f64 {
    let (inside, outside) = if void { (0.0, 1.0) } else { (1.0, 0.0) };
    let mut filtered = vec![0.0; NL * NW];
    let survives = |b: f64, filtered: &mut Vec<f64>| {
        filter.apply(&band(b, angle, inside, outside), filtered);
        let v = centre_value(filtered, angle);
        (!void && v >= eta) || (void && v <= eta)
    };
    // The centre value is monotone in the width: bisection to a hundredth of an element.
    let (mut lo, mut hi) = (0.0, 20.0 * H);
    while hi - lo > 0.01 * H {
        let b = 0.5 * (lo + hi);
        if survives(b, &mut filtered) {
            hi = b;
        } else {
            lo = b;
        }
    }
    survives(hi, &mut filtered);
    // Blueprint: the sharp projection at ½ of the filtered field, whose ½-contour (of the field
    // interpolated between element centres) is the blueprint's boundary.
    let f = Field {
        nl: NL,
        nw: NW,
        h: (H, H),
        rho: &filtered,
    };
    let (solid, gap) = member_sizes(&f, 2);
    if void { gap } else { solid }.expect("band present").size
}

#[test]
fn thinnest_surviving_bands_match_the_guaranteed_sizes() {
    let p = LengthScaleParams::new(0.5e-3, 0.4e-3, H, 1.5);
    let l = LengthScale::from_sizes(&p).unwrap();
    println!(
        "R = {:.3} mm ({:.2} elements), η_e = {:.3}, η_d = {:.3}, guaranteed solid {:.3} mm, void {:.3} mm",
        l.radius * 1e3,
        l.radius_elements,
        l.eta_eroded,
        l.eta_dilated,
        l.solid_size * 1e3,
        l.void_size * 1e3
    );
    assert!(l.solid_size >= 0.5e-3 - 1e-12 && l.void_size >= 0.4e-3 - 1e-12);
    let mesh = Mesh::new(NL as f64 * H, NW as f64 * H, 1e-3, NL, NW).unwrap();
    let filter = DensityFilter::new(&mesh, l.radius_elements);
    for deg in [0.0f64, 45.0, 90.0] {
        let a = deg.to_radians();
        let solid = thinnest_surviving(&filter, l.eta_eroded, a, false);
        let void = thinnest_surviving(&filter, l.eta_dilated, a, true);
        println!(
            "{deg:>4}°: thinnest surviving member {:.3} mm (guaranteed {:.3}), slot {:.3} mm (guaranteed {:.3})",
            solid * 1e3,
            l.solid_size * 1e3,
            void * 1e3,
            l.void_size * 1e3
        );
        assert!((solid - l.solid_size).abs() <= H, "{deg}°: member {solid}");
        assert!((void - l.void_size).abs() <= H, "{deg}°: slot {void}");
    }
}
