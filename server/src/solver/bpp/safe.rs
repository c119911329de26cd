//! Safe iterates: what a solve returns, converged or not, is feasible and does no positive work.
//!
//! **Feasible.** Every returned `λ` lies in its box, `lo_i ≤ λ_i ≤ hi_i`, with every friction row
//! inside `±μ_i λ_j` of the normal impulse `λ_j ≥ 0` it is returned with. The projection `P` first
//! clamps the rows without `findex` (normals among them) to their boxes, then the friction rows to
//! the bounds at the clamped normals: `P(λ)` lies in the true feasible set `K`, which is not a box
//! (the friction bounds move with `λ_n`) but is a convex cone when every fixed box contains 0.
//!
//! **No energy injected.** With `A = J M⁻¹ Jᵀ + C/h²` and `b` the constraint velocity error
//! (paper eq. 1–2), the merit `f(λ) = ½ λᵀAλ − bᵀλ = ½ λᵀ(w − b)` is the change of kinetic energy
//! (plus the compliant rows' potential, minus the stabilization's work) that the impulses `Jᵀλ`
//! cause, against the step without them. `λ = 0` lies in `K`, so an exact solution `λ*` (the
//! minimiser of `f` over the box its own bounds freeze, which contains 0) has `f(λ*) ≤ f(0) = 0`:
//! the constraints never add energy. A capped iterate gets the same guarantee: when `f(P(λ)) > 0`
//! it is scaled along the ray to the origin, `λ ← t* λ` with `t* = clamp(bᵀλ / λᵀAλ, 0, 1)`, the
//! minimiser of `f(tλ)`, for which `f(t* λ) = −(bᵀλ)² / (2 λᵀAλ) ≤ 0`. Scaling keeps `λ` in `K`
//! because `K` is a cone (friction bounds scale with their normal). A problem with a fixed box that
//! excludes 0 (no physics row does) is only projected.

use super::super::{effective_bounds, natural_residual};
use super::Solver;

impl Solver {
    /// Makes `λ` (permuted order) feasible and of non-positive merit (module docs); leaves the
    /// matching `w`. Returns whether `λ` had to be scaled towards zero.
    pub(super) fn make_safe(&mut self) -> bool {
        let m = self.ap.n();
        for i in 0..m {
            if self.fip[i].is_none() {
                self.lam[i] = self.lam[i].max(self.lop[i]).min(self.hip[i]);
            }
        }
        for i in 0..m {
            if self.fip[i].is_some() {
                let (lo, hi) = effective_bounds(self.lop[i], self.hip[i], self.fip[i], &self.lam);
                self.lam[i] = self.lam[i].max(lo).min(hi);
            }
        }
        self.compute_w();
        let (mut lal, mut bl) = (0.0, 0.0);
        for i in 0..m {
            // λᵀAλ = λᵀ(w + b).
            lal += self.lam[i] * (self.w[i] + self.bp[i]);
            bl += self.bp[i] * self.lam[i];
        }
        let f = 0.5 * lal - bl;
        // A NaN merit is not positive: nothing to scale.
        if f.is_nan() || f <= 0.0 || !self.zero_feasible {
            return false;
        }
        let t = if lal > 0.0 { (bl / lal).clamp(0.0, 1.0) } else { 0.0 };
        for i in 0..m {
            self.lam[i] *= t;
        }
        self.compute_w();
        true
    }
    /// The answer of a solve that did not converge, left in `lam` with its `w`. Candidates: the best
    /// iterate, the warm start and the last exact solution with frozen friction bounds, each made
    /// safe; the one with the smallest true residual is returned.
    pub(super) fn choose_capped(&mut self) {
        let mut best_r = f64::INFINITY;
        for c in 0..3 {
            match c {
                0 => self.lam.copy_from_slice(&self.best),
                1 => self.lam.copy_from_slice(&self.warm_lam),
                _ if self.have_frozen && self.prox_shift == 0.0 => self.lam.copy_from_slice(&self.frozen),
                _ => continue,
            }
            let scaled = self.make_safe();
            let (_, r) = natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
            // The frozen-bounds solution is complementary (an ODE-style answer with friction
            // boxes from an intermediate normal): preferred whenever there is one.
            if r < best_r || c == 0 || (c == 2 && self.opts.prefer_frozen) {
                best_r = r;
                self.lam_hat.copy_from_slice(&self.lam);
                self.stats.energy_scaled = scaled;
                self.stats.returned_warm_start = c == 1;
                self.stats.returned_frozen = c == 2;
            }
        }
        self.lam.copy_from_slice(&self.lam_hat);
        self.compute_w();
    }
}
