//! Minimum solid and void sizes of the robust formulation: from millimetres to the filter
//! radius and the erosion/dilation thresholds (DECISIONS.md, "Robust formulation").
//!
//! # Theory
//!
//! Wang, Lazarov & Sigmund, "On projection methods, convergence and robust formulations in
//! topology optimization", SMO 43 (2011) 767–784, §4–5, and Qian & Sigmund, "Topological design
//! of electromechanical actuators with robustness toward over- and under-etching", CMAME 253
//! (2013) 237–251, §3: with a density filter of radius `R` and a sharp projection (β → ∞), the
//! eroded design is `{ρ̃ ≥ η_e}`, the blueprint `{ρ̃ ≥ ½}` and the dilated design `{ρ̃ ≥ η_d}`.
//! A solid member of the blueprint that also exists in the eroded design must contain a band
//! of design field whose filtered value reaches `η_e` at its centre; the thinnest such band
//! sets the smallest blueprint member, the guaranteed **minimum solid size**. Void is the
//! mirror image: a slot that stays open in the dilated design has a blueprint width of at
//! least the **minimum void size** of the threshold `1 − η_d`.
//!
//! For a straight band the cone kernel of [`crate::DensityFilter`], `w(r) = (R − r)₊`, acts
//! through its projection on the band's normal (exact for straight members), normalized to
//! unit integral (`s` in units of `R`):
//!
//! ```text
//! k(s) = (3/π) [Y − s² artanh Y],   Y = √(1 − s²),   |s| < 1,   F(s) = ∫₋₁ˢ k.
//! ```
//!
//! A band of width `b` (units of `R`) has the centre value `c(b) = F(b/2) − F(−b/2)`; its
//! blueprint half-width `h` solves `F(h + b/2) − F(h − b/2) = ½`. With `b(η)` the band whose
//! centre value is `η`, the normalized minimum size is `m(η) = 2h(b(η))`:
//!
//! | η | 0.55 | 0.6 | 0.65 | 0.7 | 0.75 |
//! |---|---|---|---|---|---|
//! | m(η) | 0.432 | 0.605 | 0.735 | 0.844 | 0.943 |
//!
//! A straight boundary moves by `R·F⁻¹(η)` between the blueprint and the design of threshold
//! η (the erosion or dilation depth, ≈ 0.105 R at η = 0.6).
//!
//! # Mapping
//!
//! The sizes asked for are lower bounds. The radius starts at the floor
//! `min_radius_elements × h` (a filter must span a few elements to act like its continuous
//! kernel) and grows only if a size needs a threshold beyond `0.5 + max_offset`; each threshold
//! is then the one whose minimum size is the size asked for, but at least `min_offset` from ½ so
//! that the three designs differ by a resolvable boundary shift. The guaranteed sizes
//! `R·m(η_e)` and `R·m(1 − η_d)` are therefore never below the sizes asked for, and are larger
//! when the mesh cannot resolve them.

use crate::error::{Result, check_range};

/// Points of the tabulated CDF of the projected kernel on `[−1, 1]` (Simpson pairs).
const TABLE: usize = 4096;

/// The projected cone kernel `k(s)` (module docs), `s` in units of the radius.
pub fn projected_kernel(s: f64) -> f64 {
    let s = s.abs();
    if s >= 1.0 {
        return 0.0;
    }
    let y = (1.0 - s * s).sqrt();
    let tail = if s > 0.0 { s * s * y.atanh() } else { 0.0 };
    3.0 / std::f64::consts::PI * (y - tail)
}

/// The CDF `F` of [`projected_kernel`], tabulated once (composite Simpson) and interpolated.
#[derive(Debug, Clone)]
pub struct KernelCdf {
    values: Vec<f64>,
}

impl Default for KernelCdf {
    fn default() -> Self {
        Self::new()
    }
}

impl KernelCdf {
    /// Tabulates `F` on `TABLE + 1` points of `[−1, 1]`.
    pub fn new() -> Self {
        let h = 2.0 / TABLE as f64;
        let mut values = Vec::with_capacity(TABLE + 1);
        values.push(0.0);
        let mut acc = 0.0;
        for i in 0..TABLE {
            let (a, b) = (-1.0 + i as f64 * h, -1.0 + (i + 1) as f64 * h);
            acc += h / 6.0
                * (projected_kernel(a)
                    + 4.0 * projected_kernel(0.5 * (a + b))
                    + projected_kernel(b));
            values.push(acc);
        }
        // Remove the quadrature error of the total (≈ 1e-9) so that F(1) = 1 exactly.
        let total = acc;
        values.iter_mut().for_each(|v| *v /= total);
        Self { values }
    }

    /// `F(s)`.
    pub fn cdf(&self, s: f64) -> f64 {
        if s <= -1.0 {
            return 0.0;
        }
        if s >= 1.0 {
            return 1.0;
        }
        let t = (s + 1.0) * 0.5 * TABLE as f64;
        let i = (t.floor() as usize).min(TABLE - 1);
        let f = t - i as f64;
        self.values[i] * (1.0 - f) + self.values[i + 1] * f
    }

    /// Filtered value at distance `x` from the centre of a band of width `b` (units of R).
    pub fn band(&self, b: f64, x: f64) -> f64 {
        self.cdf(x + 0.5 * b) - self.cdf(x - 0.5 * b)
    }

    /// `m(η)`: blueprint width (units of R) of the thinnest band that survives threshold η,
    /// for η ∈ (0.5, 1).
    pub fn min_size(&self, eta: f64) -> f64 {
        // b(η): centre value c(b) is increasing in b, from 0 to 1 at b = 2.
        let b = bisect(|b| self.band(b, 0.0) - eta, 0.0, 2.0);
        // Blueprint half-width: the band profile decreases from the centre outwards.
        2.0 * bisect(|h| 0.5 - self.band(b, h), 0.0, 0.5 * b + 1.0)
    }

    /// Inverse of [`KernelCdf::min_size`] on `[eta_lo, eta_hi]`: the threshold whose minimum
    /// size is `m`, clamped to the interval.
    pub fn threshold_for(&self, m: f64, eta_lo: f64, eta_hi: f64) -> f64 {
        if m <= self.min_size(eta_lo) {
            return eta_lo;
        }
        if m >= self.min_size(eta_hi) {
            return eta_hi;
        }
        bisect(|eta| self.min_size(eta) - m, eta_lo, eta_hi)
    }

    /// `F⁻¹(η)`: distance (units of R) between the blueprint boundary and the boundary of
    /// threshold η for a straight edge.
    pub fn edge_shift(&self, eta: f64) -> f64 {
        bisect(|s| self.cdf(s) - eta, -1.0, 1.0)
    }
}

/// Root of an increasing function on `[a, b]` by bisection (to machine precision).
fn bisect(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64) -> f64 {
    for _ in 0..80 {
        let m = 0.5 * (a + b);
        if f(m) < 0.0 {
            a = m;
        } else {
            b = m;
        }
    }
    0.5 * (a + b)
}

/// What the mapping needs: the sizes asked for and the mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LengthScaleParams {
    /// Minimum solid (hinge) size asked for \[m\], > 0.
    pub min_solid: f64,
    /// Minimum void (slot) size asked for \[m\], > 0.
    pub min_void: f64,
    /// Element size h \[m\] (the geometric mean of dx and dy), > 0.
    pub element_size: f64,
    /// Smallest filter radius in element sizes, in [1.5, 20].
    pub min_radius_elements: f64,
    /// Smallest |η − ½| of the eroded and dilated thresholds, in [0.02, max_offset].
    pub min_offset: f64,
    /// Largest |η − ½| before the radius grows instead, in [min_offset, 0.45].
    pub max_offset: f64,
}

impl LengthScaleParams {
    /// Default offsets (0.1 and 0.25) for the given sizes and mesh.
    pub fn new(min_solid: f64, min_void: f64, element_size: f64, min_radius_elements: f64) -> Self {
        Self {
            min_solid,
            min_void,
            element_size,
            min_radius_elements,
            min_offset: 0.1,
            max_offset: 0.25,
        }
    }

    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        for (field, v) in [
            ("LengthScaleParams::min_solid", self.min_solid),
            ("LengthScaleParams::min_void", self.min_void),
            ("LengthScaleParams::element_size", self.element_size),
        ] {
            check_range(field, v, v > 0.0 && v.is_finite(), "(0, ∞) m")?;
        }
        check_range(
            "LengthScaleParams::min_radius_elements",
            self.min_radius_elements,
            (1.5..=20.0).contains(&self.min_radius_elements),
            "[1.5, 20]",
        )?;
        check_range(
            "LengthScaleParams::max_offset",
            self.max_offset,
            (0.02..=0.45).contains(&self.max_offset),
            "[0.02, 0.45]",
        )?;
        check_range(
            "LengthScaleParams::min_offset",
            self.min_offset,
            self.min_offset >= 0.02 && self.min_offset <= self.max_offset,
            "[0.02, max_offset]",
        )
    }
}

/// The filter radius and thresholds of the robust formulation, with the sizes they guarantee.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LengthScale {
    /// Filter radius R \[m\].
    pub radius: f64,
    /// Filter radius in element sizes.
    pub radius_elements: f64,
    /// Erosion threshold η_e > ½.
    pub eta_eroded: f64,
    /// Dilation threshold η_d < ½.
    pub eta_dilated: f64,
    /// Guaranteed minimum solid size of the blueprint, `R·m(η_e)` \[m\].
    pub solid_size: f64,
    /// Guaranteed minimum void size of the blueprint, `R·m(1 − η_d)` \[m\].
    pub void_size: f64,
    /// Distance a straight boundary moves from the blueprint to the eroded design \[m\].
    pub erosion_depth: f64,
    /// Distance a straight boundary moves from the blueprint to the dilated design \[m\].
    pub dilation_depth: f64,
}

impl LengthScale {
    /// The mapping of the module docs, after checking the parameters.
    pub fn from_sizes(p: &LengthScaleParams) -> Result<Self> {
        p.validate()?;
        Ok(Self::map(p))
    }

    /// The mapping of the module docs, for parameters known to be valid (e.g. from a validated
    /// scenario).
    pub fn map(p: &LengthScaleParams) -> Self {
        let cdf = KernelCdf::new();
        let (lo, hi) = (0.5 + p.min_offset, 0.5 + p.max_offset);
        let m_hi = cdf.min_size(hi);
        let radius = (p.min_radius_elements * p.element_size)
            .max(p.min_solid / m_hi)
            .max(p.min_void / m_hi);
        let eta_e = cdf.threshold_for(p.min_solid / radius, lo, hi);
        let eta_v = cdf.threshold_for(p.min_void / radius, lo, hi);
        Self {
            radius,
            radius_elements: radius / p.element_size,
            eta_eroded: eta_e,
            eta_dilated: 1.0 - eta_v,
            solid_size: radius * cdf.min_size(eta_e),
            void_size: radius * cdf.min_size(eta_v),
            erosion_depth: radius * cdf.edge_shift(eta_e),
            dilation_depth: radius * cdf.edge_shift(eta_v),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernel_is_normalized_and_table_matches_the_docs() {
        let cdf = KernelCdf::new();
        assert!((cdf.cdf(0.0) - 0.5).abs() < 1e-9);
        for (eta, m) in [(0.55, 0.432), (0.6, 0.605), (0.7, 0.844), (0.75, 0.943)] {
            let got = cdf.min_size(eta);
            assert!((got - m).abs() < 2e-3, "m({eta}) = {got}, docs say {m}");
        }
        // A band wider than the kernel keeps its width in the blueprint.
        assert!((cdf.min_size(0.9) - 1.284).abs() < 2e-3);
        let eta = cdf.threshold_for(0.8, 0.55, 0.75);
        assert!((cdf.min_size(eta) - 0.8).abs() < 1e-9);
    }
}
