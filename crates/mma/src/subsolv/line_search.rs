//! The line search of `subsolv`: from the full step, halve until the residual norm of the
//! relaxed KKT conditions decreases (at most 50 halvings). Trial points are not stored: the
//! n-dimensional ones are `base + t·Δ`, recomputed by the evaluation pass, so the search
//! only reads.

use super::SubSolver;
use super::evaluate::Eval;
use super::newton::Direction;
use crate::subproblem::SubConsts;

/// Halvings of the step in the line search (as in `subsolv`).
const MAX_HALVINGS: usize = 50;

impl SubSolver {
    /// Steps along `d` from the current point, whose residual norm and max-norm are
    /// `(rn, rmax)`; leaves the accepted point (pending for the n-dimensional variables),
    /// its evaluation in `ev`, and returns its residual norm and max-norm.
    pub(super) fn line_search(
        &mut self,
        d: &Direction,
        ev: &mut Eval,
        (rn, mut rmax): (f64, f64),
        epsi: f64,
        k: &SubConsts,
        need_h: bool,
    ) -> (f64, f64) {
        self.yo.copy_from_slice(&self.y);
        self.lamo.copy_from_slice(&self.lam);
        self.muo.copy_from_slice(&self.mu);
        self.so.copy_from_slice(&self.s);
        let (zo, zeto) = (self.z, self.zet);

        let mut steg = d.steg;
        let mut itto = 0;
        let mut resinew = 2.0 * rn;
        let mut accepted = steg;
        while resinew > rn && itto < MAX_HALVINGS {
            itto += 1;
            for i in 0..self.m {
                self.y[i] = self.yo[i] + steg * self.dy[i];
                self.lam[i] = self.lamo[i] + steg * self.dlam[i];
                self.mu[i] = self.muo[i] + steg * self.dmu[i];
                self.s[i] = self.so[i] + steg * self.ds[i];
            }
            self.z = zo + steg * d.dz;
            self.zet = zeto + steg * d.dzet;
            *ev = if itto == 1 && d.speculated == Some(steg) {
                // The direction pass evaluated exactly this point: the n-dimensional
                // variables did not shorten the step.
                self.reduce_eval(epsi)
            } else {
                self.eval(steg, epsi, need_h)
            };
            (resinew, rmax) = self.residual(ev, epsi, k);
            accepted = steg;
            steg /= 2.0;
        }
        self.pending = accepted;
        (resinew, rmax)
    }
}
