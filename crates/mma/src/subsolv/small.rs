//! The (n+1)×(n+1) Newton system of `subsolv`, used when `n ≤ m`: the m-dimensional
//! unknowns are eliminated instead of the n-dimensional ones. Serial: n is small here.

use super::SubSolver;
use super::terms::{step, terms};
use crate::dense::solve_in_place;
use crate::subproblem::{
    ALFA, BETA, DETA, DX, DXSI, ETA, LOW, NSTATE, P0, PQ, Q0, SubConsts, UPP, X, XSI, idx,
};

impl SubSolver {
    /// The (n+1)×(n+1) branch (`n <= m`), as in `subsolv`. Serial: n is small here.
    /// Stores Δx, Δξ, Δη and returns the largest step ratio of the n-dimensional variables.
    pub(super) fn small_direction(&mut self, eps: f64, k: &SubConsts) -> f64 {
        self.materialize();
        let (n, m, st) = (self.n, self.m, self.stride);
        let kk = n + 1;
        let nd = |j: usize, f: usize| self.nodes[idx(j, f, st)];
        for j in 0..n {
            let (x, xsi, eta) = (
                self.state[idx(j, X, NSTATE)],
                self.state[idx(j, XSI, NSTATE)],
                self.state[idx(j, ETA, NSTATE)],
            );
            let (mut plam, mut qlam) = (nd(j, P0), nd(j, Q0));
            for i in 0..m {
                plam += nd(j, PQ + i) * self.lam[i];
                qlam += nd(j, PQ + m + i) * self.lam[i];
            }
            let t = terms(
                nd(j, LOW),
                nd(j, UPP),
                nd(j, ALFA),
                nd(j, BETA),
                plam,
                qlam,
                x,
                xsi,
                eta,
            );
            for i in 0..m {
                self.gg[j * m + i] = nd(j, PQ + i) * t.uxinv2 - nd(j, PQ + m + i) * t.xlinv2;
            }
            self.delx[j] = t.dpsidx + eps * t.e;
            self.diagx[j] = t.diagx;
        }
        let alam: f64 = self.lam.iter().sum::<f64>() * k.a;
        let delz = k.a0 - alam - eps / self.z;
        // dellamyi / diaglamyi, stored temporarily in dy.
        for i in 0..m {
            self.dy[i] = (self.dellam[i] + self.dely[i] / self.diagy[i]) / self.diaglamyi[i];
        }
        let mut azz = self.zet / self.z;
        let mut bz = delz;
        for i in 0..m {
            azz += k.a * k.a / self.diaglamyi[i];
            bz -= k.a * self.dy[i];
        }
        for j in 0..n {
            for l in 0..=j {
                let mut v = 0.0;
                for i in 0..m {
                    v += self.gg[j * m + i] * self.gg[l * m + i] / self.diaglamyi[i];
                }
                self.mat[j * kk + l] = v;
                self.mat[l * kk + j] = v;
            }
            self.mat[j * kk + j] += self.diagx[j];
            let mut axz = 0.0;
            let mut bx = self.delx[j];
            for i in 0..m {
                axz -= self.gg[j * m + i] * k.a / self.diaglamyi[i];
                bx += self.gg[j * m + i] * self.dy[i];
            }
            self.mat[j * kk + n] = axz;
            self.mat[n * kk + j] = axz;
            self.rhs[j] = -bx;
        }
        self.mat[n * kk + n] = azz;
        self.rhs[n] = -bz;
        solve_in_place(&mut self.mat, &mut self.rhs, kk);
        let dz = self.rhs[n];
        for i in 0..m {
            let mut gdx = 0.0;
            for j in 0..n {
                gdx += self.gg[j * m + i] * self.rhs[j];
            }
            self.dlam[i] = gdx / self.diaglamyi[i] - dz * k.a / self.diaglamyi[i] + self.dy[i];
        }
        let mut stm = f64::NEG_INFINITY;
        for j in 0..n {
            let dx = self.rhs[j];
            let (alfa, beta) = (self.nodes[idx(j, ALFA, st)], self.nodes[idx(j, BETA, st)]);
            let (x, xsi, eta) = (
                self.state[idx(j, X, NSTATE)],
                self.state[idx(j, XSI, NSTATE)],
                self.state[idx(j, ETA, NSTATE)],
            );
            let xainv = 1.0 / (x - alfa);
            let bxinv = 1.0 / (beta - x);
            let d = step(xsi, eta, dx, xainv, bxinv, eps);
            self.state[idx(j, DX, NSTATE)] = dx;
            self.state[idx(j, DXSI, NSTATE)] = d.dxsi;
            self.state[idx(j, DETA, NSTATE)] = d.deta;
            stm = stm.max(d.ratio);
        }
        stm
    }
}
