//! The sampled response of a stage known by its modes, as the rig samples it: every mode
//! discretized exactly with a zero-order hold, the rig's delay and its sensor chain before the
//! sampler ([`ModalPlant`]). This is the linear part of the simulated loop, exactly: what the
//! rig delivers with an ideal amplifier and no noise. [`LoopPlant`] is what a controller's
//! design may know of a plant's sampled response, whatever it comes from (a modal model here,
//! an identified response elsewhere).

use nalgebra::Complex;

use crate::error::{Result, check};
use crate::rig::SensorParams;

/// A plant's sampled 2 × 2 response x_nom → measurement, as a loop-shaping design or a
/// margin computation needs it.
pub trait LoopPlant {
    /// The plant's discrete response x_nom → y (2 × 2, with the rig's delay) at `f` \[Hz\].
    fn response(&self, f: f64) -> [[Complex<f64>; 2]; 2];
    /// The static gain x_nom → q.
    fn static_gain(&self) -> [[f64; 2]; 2];
    /// Resonances (frequency \[Hz\], damping) in ascending order.
    fn modes(&self) -> Vec<(f64, f64)>;
    /// The sample time \[s\].
    fn sample_time(&self) -> f64;
}

/// One mode of a [`ModalPlant`]: `η̈ + 2ζωη̇ + ω²η = in·x_nom`, `q = out·η`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlantMode {
    /// Natural frequency \[Hz\].
    pub frequency: f64,
    /// Damping ratio.
    pub damping: f64,
    /// Modal force per unit x_nom1, x_nom2.
    pub input: [f64; 2],
    /// Output q1, q2 per unit modal coordinate.
    pub output: [f64; 2],
}

/// The static gain x_nom → q of a modal plant, `Σ_k out_k in_kᵀ / ω_k²` (2 × 2), summed in
/// the order of `modes`.
pub fn static_gain(modes: &[PlantMode]) -> [[f64; 2]; 2] {
    let mut g = [[0.0; 2]; 2];
    for m in modes {
        let w2 = (std::f64::consts::TAU * m.frequency).powi(2);
        for i in 0..2 {
            for j in 0..2 {
                g[i][j] += m.output[i] * m.input[j] / w2;
            }
        }
    }
    g
}

/// One partial fraction of a filtered mode: its residue r_j and e^{p_j T}.
type Residue = (Complex<f64>, Complex<f64>);

/// A modal plant sampled with a zero-order hold and `delay` samples of delay: each mode
/// discretized exactly (`c2d`), `P(z) = z^{−d} Σ_k out_k in_kᵀ [1 0](zI − Φ_k)⁻¹Γ_k`. This is
/// the sampled loop the rig runs with an ideal amplifier and sensor.
///
/// With the rig's sensor chain H(s) (electronics and anti-aliasing filter,
/// [`SensorParams`]) between the output and the sampler ([`ModalPlant::with_sensor`]), each
/// mode's filtered response `G_k(s) = H(s)/(s² + 2ζω s + ω²) = K/Π_j(s − p_j)` (the mode's
/// pair and the filter's poles, all simple) is sampled exactly by partial fractions:
/// `G_k(z) = (1 − z⁻¹)·Z{G_k(s)/s} = G_k(0) + (1 − z⁻¹) Σ_j r_j/(1 − e^{p_j T} z⁻¹)`,
/// `r_j = K/(p_j Π_{i≠j}(p_j − p_i))` (Franklin, Powell & Workman, Digital Control of Dynamic
/// Systems, 3rd ed., Section 6.2: the ZOH equivalent). The filter does not commute with the
/// sampler, so this is not P(z)·H(jω); it is what the rig samples.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalPlant {
    modes: Vec<PlantMode>,
    discrete: Vec<([f64; 4], [f64; 2])>,
    /// With a sensor chain: per mode, G_k(0) and the pairs (r_j, e^{p_j T}).
    filtered: Vec<(f64, Vec<Residue>)>,
    delay: usize,
    t: f64,
}

impl ModalPlant {
    /// The plant of `modes` sampled at `t` \[s\] with `delay` samples of delay and the
    /// sensor chain `sensor` before the sampler (module docs).
    pub fn with_sensor(
        modes: Vec<PlantMode>,
        t: f64,
        delay: usize,
        sensor: &SensorParams,
    ) -> Result<ModalPlant> {
        ModalPlant::with_chain(modes, t, delay, 0.0, sensor)
    }

    /// The plant of `modes` sampled at `t` \[s\] with `delay` samples of delay, the
    /// amplifier's first-order small-signal response of bandwidth `amplifier` \[Hz\] (0 =
    /// ideal) between the hold and the stage, and the sensor chain `sensor` before the
    /// sampler. Every continuous filter sits in series between the hold and the sampler, so
    /// the amplifier's pole −2πf_a joins the filter poles of the partial fractions and the
    /// sampling stays exact (module docs).
    pub fn with_chain(
        modes: Vec<PlantMode>,
        t: f64,
        delay: usize,
        amplifier: f64,
        sensor: &SensorParams,
    ) -> Result<ModalPlant> {
        check(
            "amplifier bandwidth",
            amplifier,
            amplifier >= 0.0,
            ">= 0 Hz",
        )?;
        let mut p = ModalPlant::new(modes, t, delay)?;
        let mut filter = sensor.poles();
        if amplifier > 0.0 {
            filter.push(Complex::new(-std::f64::consts::TAU * amplifier, 0.0));
        }
        if filter.is_empty() {
            return Ok(p);
        }
        let k: Complex<f64> = filter.iter().map(|&q| -q).product();
        for m in &p.modes {
            let w = std::f64::consts::TAU * m.frequency;
            let (re, im) = (-m.damping * w, w * (1.0 - m.damping * m.damping).sqrt());
            let mut poles = vec![Complex::new(re, im), Complex::new(re, -im)];
            poles.extend_from_slice(&filter);
            let terms = (0..poles.len())
                .map(|j| {
                    let pj = poles[j];
                    let den: Complex<f64> = poles
                        .iter()
                        .enumerate()
                        .filter(|&(i, _)| i != j)
                        .map(|(_, &pi)| pj - pi)
                        .product();
                    (k / (pj * den), (pj * t).exp())
                })
                .collect();
            p.filtered.push((1.0 / (w * w), terms));
        }
        Ok(p)
    }

    /// The plant of `modes` sampled at `t` \[s\] with `delay` samples of delay.
    pub fn new(modes: Vec<PlantMode>, t: f64, delay: usize) -> Result<ModalPlant> {
        check("sample_time", t, t > 0.0, "> 0 s")?;
        let mut discrete = Vec::with_capacity(modes.len());
        for m in &modes {
            check("mode frequency", m.frequency, m.frequency > 0.0, "> 0 Hz")?;
            let w = std::f64::consts::TAU * m.frequency;
            let a =
                nalgebra::DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -w * w, -2.0 * m.damping * w]);
            let b = nalgebra::DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
            let (phi, gam) = crate::linalg::c2d(&a, &b, t)?;
            discrete.push((
                [phi[(0, 0)], phi[(0, 1)], phi[(1, 0)], phi[(1, 1)]],
                [gam[0], gam[1]],
            ));
        }
        Ok(ModalPlant {
            modes,
            discrete,
            filtered: Vec::new(),
            delay,
            t,
        })
    }

    /// The modes.
    pub fn plant_modes(&self) -> &[PlantMode] {
        &self.modes
    }
}

impl LoopPlant for ModalPlant {
    fn response(&self, f: f64) -> [[Complex<f64>; 2]; 2] {
        let z = Complex::from_polar(1.0, std::f64::consts::TAU * f * self.t);
        let delay = z.powi(-(self.delay as i32));
        let mut p = [[Complex::new(0.0, 0.0); 2]; 2];
        let zi = z.inv();
        let one = Complex::new(1.0, 0.0);
        for (k, (m, (phi, gam))) in self.modes.iter().zip(&self.discrete).enumerate() {
            let eta = if let Some((g0, terms)) = self.filtered.get(k) {
                let sum: Complex<f64> = terms.iter().map(|&(r, e)| r / (one - e * zi)).sum();
                (sum * (one - zi) + g0) * delay
            } else {
                // [1 0](zI − Φ)⁻¹Γ = ((z − Φ22)Γ1 + Φ12 Γ2) / det.
                let det = (z - phi[0]) * (z - phi[3]) - phi[1] * phi[2];
                ((z - phi[3]) * gam[0] + phi[1] * gam[1]) / det * delay
            };
            for i in 0..2 {
                for j in 0..2 {
                    p[i][j] += eta * (m.output[i] * m.input[j]);
                }
            }
        }
        p
    }

    fn static_gain(&self) -> [[f64; 2]; 2] {
        static_gain(&self.modes)
    }

    fn modes(&self) -> Vec<(f64, f64)> {
        self.modes
            .iter()
            .map(|m| (m.frequency, m.damping))
            .collect()
    }

    fn sample_time(&self) -> f64 {
        self.t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`crate::samples::decoupled_modes`] with one sample of delay at 10 kHz.
    fn plant() -> ModalPlant {
        ModalPlant::new(crate::samples::decoupled_modes(), 1e-4, 1).unwrap()
    }

    /// Reference: at z = 1 the exact ZOH discretization keeps the static gain Σ out inᵀ/ω²
    /// (here the identity). Goal: the discrete response is the sampled plant.
    #[test]
    fn zoh_response_keeps_static_gain() {
        let p = plant();
        let g = p.response(1e-6);
        assert!((g[0][0].re - 1.0).abs() < 1e-6 && (g[1][1].re - 1.0).abs() < 1e-6);
        assert!(g[0][1].norm() < 1e-12);
        assert_eq!(p.static_gain(), [[1.0, 0.0], [0.0, 1.0]]);
    }

    /// Reference: the ZOH discretization (`c2d`, Van Loan) of the augmented state space of
    /// one mode followed by the sensor chain (15 kHz first order, 3 kHz 2nd-order Butterworth),
    /// evaluated as C(zI − Φ)⁻¹Γ. Goal: the partial-fraction response of
    /// [`ModalPlant::with_sensor`] equals it to 1e-9 (relative) from 1 Hz to Nyquist; at 20 Hz
    /// it is the unfiltered response times the filter's analytic H(j2πf) (phase to 0.01°),
    /// and an ideal sensor leaves the plant unchanged.
    #[test]
    fn sampled_sensor_chain_matches_augmented_c2d_and_analytic_phase() {
        use nalgebra::{DMatrix, DVector};
        let (f0, zeta, t) = (2700.0, 0.01, 1e-4);
        let w = std::f64::consts::TAU * f0;
        let mode = PlantMode {
            frequency: f0,
            damping: zeta,
            input: [w * w, 0.0],
            output: [1.0, 0.0],
        };
        let sensor = SensorParams {
            bandwidth: 15_000.0,
            flicker_corner: 0.0,
            anti_alias: 3000.0,
        };
        let p = ModalPlant::with_sensor(vec![mode], t, 0, &sensor).unwrap();
        let bare = ModalPlant::new(vec![mode], t, 0).unwrap();
        let (ws, wa) = (
            std::f64::consts::TAU * 15_000.0,
            std::f64::consts::TAU * 3000.0,
        );
        #[rustfmt::skip]
        let a = DMatrix::from_row_slice(5, 5, &[
            0.0, 1.0, 0.0, 0.0, 0.0,
            -w * w, -2.0 * zeta * w, 0.0, 0.0, 0.0,
            ws, 0.0, -ws, 0.0, 0.0,
            0.0, 0.0, 0.0, 0.0, 1.0,
            0.0, 0.0, wa * wa, -wa * wa, -std::f64::consts::SQRT_2 * wa,
        ]);
        let b = DMatrix::from_row_slice(5, 1, &[0.0, w * w, 0.0, 0.0, 0.0]);
        let (phi, gam) = crate::linalg::c2d(&a, &b, t).unwrap();
        for f in [1.0, 20.0, 300.0, 2700.0, 4000.0, 4990.0] {
            let z = Complex::from_polar(1.0, std::f64::consts::TAU * f * t);
            let m = DMatrix::<Complex<f64>>::identity(5, 5) * z - phi.map(|v| Complex::new(v, 0.0));
            let g = DVector::from_iterator(5, gam.iter().map(|&v| Complex::new(v, 0.0)));
            let x = m.lu().solve(&g).unwrap();
            let expect = x[3];
            let got = p.response(f)[0][0];
            assert!(
                (got - expect).norm() < 1e-9 * expect.norm(),
                "f {f}: {got} vs {expect}"
            );
        }
        let f = 20.0;
        let ratio = p.response(f)[0][0] / bare.response(f)[0][0];
        let h = sensor.response(f);
        let dphase = (ratio.arg() - h.arg()).to_degrees();
        assert!(
            dphase.abs() < 0.01,
            "{dphase}° off the analytic filter phase"
        );
        // Analytic phase of the chain: −atan(f/f_s) − atan2(√2 f/f_a, 1 − (f/f_a)²).
        let (x, y) = (f / 15_000.0, f / 3000.0);
        let analytic = -x.atan() - (std::f64::consts::SQRT_2 * y).atan2(1.0 - y * y);
        assert!((h.arg() - analytic).abs() < 1e-12);
        let ideal = ModalPlant::with_sensor(vec![mode], t, 0, &SensorParams::ideal()).unwrap();
        assert_eq!(ideal.response(700.0), bare.response(700.0));
    }

    /// Reference: the ZOH discretization (`c2d`, Van Loan) of the augmented state space of
    /// a 1 kHz-bandwidth first-order amplifier, one 8.99 kHz mode (folded to 1.01 kHz at
    /// 10 kHz) and the sensor chain (15 kHz first order, 3 kHz 2nd-order Butterworth),
    /// evaluated as C(zI − Φ)⁻¹Γ with one sample of delay. Goal: the partial-fraction
    /// response of [`ModalPlant::with_chain`] equals it to 1e-9 (relative) from 1 Hz to
    /// Nyquist; a zero bandwidth is [`ModalPlant::with_sensor`]; a negative one is refused.
    #[test]
    fn amplifier_in_the_chain_matches_augmented_c2d() {
        use nalgebra::{DMatrix, DVector};
        let (f0, zeta, t, fa) = (8990.0, 0.01, 1e-4, 1000.0);
        let tau = std::f64::consts::TAU;
        let w = tau * f0;
        let mode = PlantMode {
            frequency: f0,
            damping: zeta,
            input: [w * w, 0.0],
            output: [1.0, 0.0],
        };
        let sensor = SensorParams {
            bandwidth: 15_000.0,
            flicker_corner: 0.0,
            anti_alias: 3000.0,
        };
        let p = ModalPlant::with_chain(vec![mode], t, 1, fa, &sensor).unwrap();
        let (wa, ws, wf) = (tau * fa, tau * 15_000.0, tau * 3000.0);
        // States: amplifier output, η, η̇, electronics, filter output, its rate.
        #[rustfmt::skip]
        let a = DMatrix::from_row_slice(6, 6, &[
            -wa, 0.0, 0.0, 0.0, 0.0, 0.0,
            0.0, 0.0, 1.0, 0.0, 0.0, 0.0,
            w * w, -w * w, -2.0 * zeta * w, 0.0, 0.0, 0.0,
            0.0, ws, 0.0, -ws, 0.0, 0.0,
            0.0, 0.0, 0.0, 0.0, 0.0, 1.0,
            0.0, 0.0, 0.0, wf * wf, -wf * wf, -std::f64::consts::SQRT_2 * wf,
        ]);
        let b = DMatrix::from_row_slice(6, 1, &[wa, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let (phi, gam) = crate::linalg::c2d(&a, &b, t).unwrap();
        for f in [1.0, 20.0, 300.0, 1010.0, 2700.0, 4000.0, 4990.0] {
            let z = Complex::from_polar(1.0, tau * f * t);
            let m = DMatrix::<Complex<f64>>::identity(6, 6) * z - phi.map(|v| Complex::new(v, 0.0));
            let g = DVector::from_iterator(6, gam.iter().map(|&v| Complex::new(v, 0.0)));
            let x = m.lu().solve(&g).unwrap();
            let expect = x[4] / z;
            let got = p.response(f)[0][0];
            assert!(
                (got - expect).norm() < 1e-9 * expect.norm(),
                "f {f}: {got} vs {expect}"
            );
        }
        let plain = ModalPlant::with_sensor(vec![mode], t, 1, &sensor).unwrap();
        let zero = ModalPlant::with_chain(vec![mode], t, 1, 0.0, &sensor).unwrap();
        assert_eq!(plain.response(1010.0), zero.response(1010.0));
        assert!(ModalPlant::with_chain(vec![mode], t, 1, -1.0, &sensor).is_err());
    }
}
