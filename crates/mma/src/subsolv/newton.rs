//! The Newton step in the m-dimensional variables: right-hand sides and diagonals, the
//! (m+1)×(m+1) reduced system in (Δλ, Δz) (Svanberg 2007, section 5.3)
//!
//! ```text
//! [ D_λ + G D_x⁻¹ Gᵀ   a       ] [Δλ]   [ δ_λ + δ_y / D_y − G D_x⁻¹ δ_x ]
//! [ aᵀ                 −ζ / z  ] [Δz] = [ δ_z                          ]
//! ```
//!
//! solved in place, and the directions Δy, Δμ, Δs that follow from Δλ.

use super::SubSolver;
use crate::dense::solve_in_place;
use crate::subproblem::SubConsts;

/// A Newton direction, as the line search needs it.
pub(super) struct Direction {
    /// The full step `1/max(ratio, 1)`, the largest that keeps every variable interior (with
    /// the fraction-to-the-boundary factor 1.01).
    pub steg: f64,
    /// The step at which the direction pass evaluated the trial point (the step of the
    /// m-dimensional variables alone), when it did.
    pub speculated: Option<f64>,
    /// Δz.
    pub dz: f64,
    /// Δζ.
    pub dzet: f64,
}

impl SubSolver {
    /// The Newton direction of the relaxed KKT system at level ε: by the (n+1)×(n+1) system
    /// when `n ≤ m`, else by the (m+1)×(m+1) system and the direction pass.
    pub(super) fn newton_direction(&mut self, epsi: f64, k: &SubConsts, need_h: bool) -> Direction {
        self.newton_prelude(epsi, k);
        let (stm, speculated) = if self.small_branch() {
            let stm_n = self.small_direction(epsi, k);
            (stm_n.max(self.m_directions(epsi)), None)
        } else {
            self.solve_reduced(epsi, k);
            let stm_m = self.m_directions(epsi);
            let steg_m = 1.0 / stm_m.max(1.0);
            let stm_n = self.direction_pass(epsi, steg_m, need_h);
            (stm_n.max(stm_m), Some(steg_m))
        };
        let dz = self.rhs_dz();
        let dzet = -self.zet + epsi / self.z - self.zet * dz / self.z;
        Direction {
            steg: 1.0 / stm.max(1.0),
            speculated,
            dz,
            dzet,
        }
    }

    /// m-dimensional right-hand sides and diagonals of the Newton system.
    pub(super) fn newton_prelude(&mut self, eps: f64, k: &SubConsts) {
        for i in 0..self.m {
            let (y, lam, mu, s) = (self.y[i], self.lam[i], self.mu[i], self.s[i]);
            self.dely[i] = k.c + k.d * y - lam - eps / y;
            self.dellam[i] = self.gvec[i] - k.a * self.z - y - self.b[i] + eps / lam;
            let diagy = k.d + mu / y;
            self.diagy[i] = diagy;
            self.diaglamyi[i] = s / lam + 1.0 / diagy;
        }
    }

    /// The (m+1)×(m+1) branch (`m < n`): solves for Δλ, Δz (Δz is left in `rhs[m]`).
    pub(super) fn solve_reduced(&mut self, eps: f64, k: &SubConsts) {
        let m = self.m;
        let kk = m + 1;
        let alam: f64 = self.lam.iter().sum::<f64>() * k.a;
        let delz = k.a0 - alam - eps / self.z;
        for i in 0..m {
            self.rhs[i] =
                self.dellam[i] + self.dely[i] / self.diagy[i] - (self.b0[i] + eps * self.b1[i]);
            for j in 0..=i {
                let v = self.h[i * m + j];
                self.mat[i * kk + j] = v;
                self.mat[j * kk + i] = v;
            }
            self.mat[i * kk + i] += self.diaglamyi[i];
            self.mat[i * kk + m] = k.a;
            self.mat[m * kk + i] = k.a;
        }
        self.mat[m * kk + m] = -self.zet / self.z;
        self.rhs[m] = delz;
        solve_in_place(&mut self.mat, &mut self.rhs, kk);
        self.dlam.copy_from_slice(&self.rhs[..m]);
    }

    /// Δy, Δμ, Δs from Δλ (Δz is in `rhs`); returns the largest step ratio of y, λ, μ, s,
    /// z and ζ.
    pub(super) fn m_directions(&mut self, epsi: f64) -> f64 {
        let mut stm = f64::NEG_INFINITY;
        for i in 0..self.m {
            let dy = (self.dlam[i] - self.dely[i]) / self.diagy[i];
            self.dy[i] = dy;
            self.dmu[i] = -self.mu[i] + epsi / self.y[i] - self.mu[i] * dy / self.y[i];
            self.ds[i] = -self.s[i] + epsi / self.lam[i] - self.s[i] * self.dlam[i] / self.lam[i];
            stm = stm
                .max(-1.01 * dy / self.y[i])
                .max(-1.01 * self.dlam[i] / self.lam[i])
                .max(-1.01 * self.dmu[i] / self.mu[i])
                .max(-1.01 * self.ds[i] / self.s[i]);
        }
        let dz = self.rhs_dz();
        let dzet = -self.zet + epsi / self.z - self.zet * dz / self.z;
        stm.max(-1.01 * dz / self.z).max(-1.01 * dzet / self.zet)
    }
}
