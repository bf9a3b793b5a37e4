//! The fatigue stress response (DECISIONS.md, "Stress constraint"): an aggregated, relaxed von
//! Mises stress of a design at the Table 2 extreme inputs.
//!
//! * **Relaxation** ("qp", Bruggi 2008; Le, Norato, Bruns, Ha & Tortorelli, "Stress-based
//!   topology optimization for continua", SMO 41 (2010) 605–620, Eq. 7): the stress measure of
//!   Gauss point g of element e in case k is `s_keg = ρ_e^q σ⁰_keg / σ_a`, with `σ⁰` the von
//!   Mises value of the *solid* stress at the element's strain ([`flexstage_fem::stress`]),
//!   `q < p` (default ½), and `σ_a` the design allowable. Exact for solid (ρ = 1) and void
//!   (s → 0) elements, conservative for grey ones (`ρ^q ≥ ρ^p`), and free of the singular optima
//!   of the unrelaxed measure.
//! * **Aggregation** (p-norm, Le et al. Eq. 11): `Σ_S = (Σ_{k,e,g} s_keg^P)^{1/P}` over the
//!   design elements (passive port pads carry the point loads and are not designed) and the
//!   stress cases, `P = 8`. It over-estimates `max s` by a factor between 1 and `N^{1/P}`; the
//!   optimizer rescales it by the ratio `max s / Σ_S` of the previous iteration (Le et al.'s
//!   adaptive normalization, Eq. 13–14), so that the constraint tracks the true maximum.
//!
//! Derivatives, for the adjoint of each stress case:
//! `∂Σ_S/∂u_e = Σ_g (s/Σ_S)^{P−1} (ρ^q/σ_a) ∂σ⁰/∂u_e = Σ_g w_g ∂(σ⁰)²/∂u_e` with
//! `w_g = (s/Σ_S)^P Σ_S / (2 (σ⁰)²)` (finite where σ⁰ → 0 for P > 2), and the explicit term
//! `∂Σ_S/∂ρ_e = Σ_{k,g} (s/Σ_S)^{P−1} q s / ρ_e`.

use flexstage_fem::{Model, Passive, STRESS_POINTS};
use rayon::prelude::*;

use crate::analysis::CaseState;
use crate::responses::{CaseCoefficients, ResponseCoefficients};

/// The stress constraint of a problem.
#[derive(Debug, Clone, PartialEq)]
pub struct StressConstraint {
    /// Design allowable σ_a \[Pa\] on the design mesh: fatigue strength / safety factor /
    /// mesh stress factor (`limits` of the scenario).
    pub allowable: f64,
    /// Load cases evaluated: the four corners of the stroke square (Table 2). The von Mises
    /// stress of a linear response is a norm of a linear function of the inputs, so its
    /// maximum over the square is at a corner.
    pub cases: Vec<usize>,
    /// Relaxation exponent q, in (0, 1].
    pub relaxation: f64,
    /// Aggregation exponent P, in [2, 64].
    pub exponent: f64,
}

/// The stress response of one design: the p-norm with its coefficients, and the largest
/// relaxed stress (for the adaptive normalization and reports).
#[derive(Debug, Clone, PartialEq)]
pub struct StressMeasure {
    /// `Σ_S` and its derivatives (value in units of σ_a).
    pub coefficients: ResponseCoefficients,
    /// `max_{k,e,g} s_keg` (units of σ_a).
    pub max: f64,
}

/// Evaluates [`StressMeasure`] at the converged states `cases` of the design `rho`.
pub fn stress_measure(
    model: &Model,
    sc: &StressConstraint,
    rho: &[f64],
    cases: &[CaseState],
) -> StressMeasure {
    let mesh = model.mesh();
    let ne = mesh.n_elements();
    let e0 = model.material().e0;
    let kernel = model.kernel();
    let (q, pe) = (sc.relaxation, sc.exponent);
    let design = |e: usize| mesh.passive[e] == Passive::Design;
    // Pass 1: values, the maximum and the aggregate.
    let mut vm2 = vec![vec![[0.0; STRESS_POINTS]; ne]; sc.cases.len()];
    for (v, &k) in vm2.iter_mut().zip(&sc.cases) {
        model.solid_von_mises_squared(&cases[k].u, v);
    }
    let rel = |e: usize| rho[e].max(0.0).powf(q) / sc.allowable;
    let mut smax = 0.0f64;
    for v in &vm2 {
        for (e, p) in v.iter().enumerate().filter(|(e, _)| design(*e)) {
            for s2 in p {
                smax = smax.max(rel(e) * s2.sqrt());
            }
        }
    }
    let nc = cases.len();
    let mut coefficients = ResponseCoefficients {
        value: 0.0,
        cases: vec![CaseCoefficients::default(); nc],
        explicit: Some(vec![0.0; ne]),
    };
    if smax == 0.0 {
        return StressMeasure {
            coefficients,
            max: 0.0,
        };
    }
    let sum: f64 = vm2
        .iter()
        .flat_map(|v| v.iter().enumerate().filter(|(e, _)| design(*e)))
        .map(|(e, p)| {
            p.iter()
                .map(|s2| (rel(e) * s2.sqrt() / smax).powf(pe))
                .sum::<f64>()
        })
        .sum();
    let sigma = smax * sum.powf(1.0 / pe);
    coefficients.value = sigma;
    // Pass 2: per stress case, ∂Σ_S/∂u (full vector) and the explicit ∂Σ_S/∂ρ.
    let explicit = coefficients.explicit.as_mut().expect("allocated above");
    for (v, &k) in vm2.iter().zip(&sc.cases) {
        let u = &cases[k].u;
        let local: Vec<[f64; 8]> = (0..ne)
            .into_par_iter()
            .with_min_len(128)
            .map(|e| {
                if !design(e) {
                    return [0.0; 8];
                }
                let mut grad = [[0.0; 8]; STRESS_POINTS];
                kernel.solid_von_mises_squared(
                    e0,
                    &model.element_displacement(e, u),
                    Some(&mut grad),
                );
                let mut out = [0.0; 8];
                for (s2, g) in v[e].iter().zip(&grad) {
                    if *s2 <= 0.0 {
                        continue;
                    }
                    let s = rel(e) * s2.sqrt();
                    let w = (s / sigma).powf(pe) * sigma / (2.0 * s2);
                    for (o, gp) in out.iter_mut().zip(g) {
                        *o += w * gp;
                    }
                }
                out
            })
            .collect();
        let mut b = model.zero_vector();
        for (e, l) in local.iter().enumerate() {
            for (d, x) in mesh.element_dofs(e).iter().zip(l) {
                b[*d] += x;
            }
        }
        for (e, p) in v.iter().enumerate().filter(|(e, _)| design(*e)) {
            if rho[e] > 0.0 {
                let r = rel(e);
                explicit[e] += p
                    .iter()
                    .map(|s2| {
                        let s = r * s2.sqrt();
                        (s / sigma).powf(pe - 1.0) * q * s / rho[e]
                    })
                    .sum::<f64>();
            }
        }
        coefficients.cases[k].extra = Some(b);
    }
    StressMeasure {
        coefficients,
        max: smax,
    }
}
