//! The norm and max-norm of the relaxed KKT residual of the subproblem at barrier level ε
//! (the n-dimensional pieces come from the evaluation pass).

use super::SubSolver;
use super::evaluate::Eval;
use crate::subproblem::SubConsts;

impl SubSolver {
    /// Norm and max-norm of the full residual of the relaxed KKT conditions at level `eps`.
    pub(super) fn residual(&self, ev: &Eval, eps: f64, k: &SubConsts) -> (f64, f64) {
        let p = &ev.pieces;
        let (mut sum, mut mx) = (p.sum_x, p.max_x);
        if eps == ev.eps_a {
            sum += p.sum_a;
            mx = mx.max(p.max_a);
        } else {
            debug_assert_eq!(eps, ev.eps_b);
            sum += p.sum_b;
            mx = mx.max(p.max_b);
        }
        let mut alam = 0.0;
        for i in 0..self.m {
            let (y, lam, mu, s) = (self.y[i], self.lam[i], self.mu[i], self.s[i]);
            alam += k.a * lam;
            let rey = k.c + k.d * y - mu - lam;
            let relam = self.gvec[i] - k.a * self.z - y + s - self.b[i];
            let remu = mu * y - eps;
            let res = lam * s - eps;
            for r in [rey, relam, remu, res] {
                sum += r * r;
                mx = mx.max(r.abs());
            }
        }
        let rez = k.a0 - self.zet - alam;
        let rezet = self.zet * self.z - eps;
        for r in [rez, rezet] {
            sum += r * r;
            mx = mx.max(r.abs());
        }
        (sum.sqrt(), mx)
    }
}
