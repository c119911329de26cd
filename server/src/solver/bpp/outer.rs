//! The outer friction loop: at an exact solution of the frozen problem, the globalized coupled
//! Newton point and the update of the friction bounds, the safeguard after it, and the semismooth
//! Newton fallback when the outer iteration stalls (module docs of `bpp`, "Friction coupling").

use super::super::{Variant, effective_bounds, natural_residual};
use super::pivot::Next;
use super::safeguard::Start;
use super::solver::{Solver, resize};
use super::workspace::{OUTER_MEMORY, Progress};

/// Outer updates without a 10 % improvement of the best residual before the Newton fallback;
/// with the safeguard after each update (each update then costs more steps) 4 measured best.
const OUTER_STALL: usize = 12;
const OUTER_STALL_SAFEGUARDED: usize = 4;

/// Pivot steps one semismooth-Newton fallback may take before the outer iteration resumes.
const NEWTON_BUDGET: usize = 60;

impl Solver {
    /// The boxed LCP with the frozen bounds is solved exactly (residual `(res, res_rel)` against
    /// the true bounds): done, or a coupled Newton point and an outer update of the friction
    /// bounds, or — bounds consistent — iterative refinement of what rounding left.
    pub(super) fn at_frozen_solution(
        &mut self,
        variant: Variant,
        friction: bool,
        (res, res_rel): (f64, f64),
        progress: &mut Progress,
    ) -> Next {
        // The answer of a capped solve (module docs, "Safe when capped").
        self.ws.safe.frozen.copy_from_slice(&self.lam);
        self.ws.safe.have_frozen = true;
        if res_rel <= self.opts.tol_rel || res == 0.0 {
            // `w` is the one this residual was computed from.
            self.converged_at = Some((res, res_rel));
            return Next::Return(true);
        }
        if friction && self.opts.coupled_update {
            if let Some(true) = self.coupled_outer_step(res_rel) {
                return Next::Return(true);
            }
            let (_, rr) = natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
            self.note_best(rr);
        }
        if friction && self.update_bounds() {
            return self.outer_update(variant, progress);
        }
        if self.opts.refine {
            self.refine_until_converged(res_rel);
        }
        Next::Return(true)
    }

    /// After the friction bounds followed the new normal impulses (outer iteration): a stalled
    /// outer iteration (cycling between index sets) hands over to the semismooth Newton method on
    /// the whole natural map, from the best iterate; with [`SolverOptions::safeguard_after_update`]
    /// the active-set safeguard continues from the last index set, its tight rows at the new bounds.
    pub(super) fn outer_update(&mut self, variant: Variant, progress: &mut Progress) -> Next {
        self.stats.friction_updates += 1;
        progress.best_ninf = usize::MAX;
        progress.no_progress = 0;
        if self.best_res < 0.9 * progress.outer_best {
            progress.outer_best = self.best_res;
            progress.outer_stall = 0;
        } else {
            progress.outer_stall += 1;
        }
        let safeguarded = self.opts.safeguard_after_update && !progress.block_pivots;
        let stall_limit = if safeguarded { OUTER_STALL_SAFEGUARDED } else { OUTER_STALL };
        if progress.outer_stall >= stall_limit && self.opts.newton_fallback {
            self.lam.copy_from_slice(&self.best);
            self.compute_w();
            if self.semismooth_newton(variant, NEWTON_BUDGET, false) {
                return Next::Return(true);
            }
            // Not there within its budget: resume the outer iteration from the best iterate seen
            // (Newton's or the outer loop's), with block pivots after its updates from now on
            // (friction cycles that the safeguarded updates do not break, measured on
            // `scene-shaped/scene-winch370`: not within 1000 steps without this switch, 205 with it; the
            // earlier defaults took 160).
            if self.non_finite {
                return Next::Return(false);
            }
            progress.block_pivots = true;
            self.lam.copy_from_slice(&self.best);
            self.compute_w();
            let (_, rr) = natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
            self.best_res = self.best_res.min(rr);
            progress.outer_best = self.best_res;
            progress.outer_stall = 0;
            self.update_bounds();
        }
        if safeguarded {
            // The bounds moved a little: from the last index set, its tight rows at the new
            // bounds, the monotone active-set method needs few steps, where block pivots from it
            // flail among redundant contacts.
            self.stats.fallback = true;
            if !self.projected_newton(variant, Start::IndexSet) {
                return Next::Return(false);
            }
            return Next::Resolved;
        }
        Next::Pivot
    }

    /// Newton on the outer fixed point, globalized: from the solution `λ*` of the frozen problem
    /// (residual `r*` against its own bounds), take the exact coupled point `λ_c` of the settled
    /// index set and backtrack along `λ* + t (λ_c − λ*)` (`w` is affine in `t`) until the true
    /// natural-map residual drops below `(1 − 10⁻⁴ t) r*`; with no such `t ≥ 1/64` keep `λ*` (the plain
    /// fixed-point update). Leaves the accepted `λ`, `w`. `Some(true)`: `λ` solves the problem;
    /// `None`: nothing was coupled.
    pub(super) fn coupled_outer_step(&mut self, r_star: f64) -> Option<bool> {
        let m = self.ap.n();
        for v in [&mut self.lam_old, &mut self.w_old, &mut self.lam_hat] {
            resize(v, m);
        }
        self.lam_old.copy_from_slice(&self.lam);
        self.w_old.copy_from_slice(&self.w);
        match self.coupled_newton(self.ws.factor.last_factor) {
            None => return None,
            Some(true) => {}
            Some(false) => {
                self.stats.outer_damped += 1;
                self.lam.copy_from_slice(&self.lam_old);
                self.w.copy_from_slice(&self.w_old);
                return Some(false);
            }
        }
        self.stats.coupled_steps += 1;
        let (r, rr) = natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
        if rr <= self.opts.tol_rel || r == 0.0 {
            return Some(true);
        }
        // Non-monotone reference (Grippo–Lampariello–Lucidi): the largest of the last few r*.
        self.outer_hist[self.stats.friction_updates % OUTER_MEMORY] = r_star;
        let r_ref = self.outer_hist.iter().fold(r_star, |a, &x| a.max(x));
        if rr < (1.0 - 1e-4) * r_ref {
            return Some(false);
        }
        // Backtrack between λ* (lam_old, w_old) and λ_c (lam_hat, w in tmp).
        self.lam_hat.copy_from_slice(&self.lam);
        self.tmp.copy_from_slice(&self.w);
        let mut t = 0.5;
        while t >= 1.0 / 64.0 {
            for i in 0..m {
                self.lam[i] = self.lam_old[i] + t * (self.lam_hat[i] - self.lam_old[i]);
                self.w[i] = self.w_old[i] + t * (self.tmp[i] - self.w_old[i]);
            }
            let (_, rt) = natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
            if rt < (1.0 - 1e-4 * t) * r_ref {
                self.stats.outer_damped += 1;
                return Some(false);
            }
            t *= 0.5;
        }
        self.stats.outer_damped += 1;
        self.lam.copy_from_slice(&self.lam_old);
        self.w.copy_from_slice(&self.w_old);
        Some(false)
    }

    /// Freezes the bounds at the current normal impulses; returns whether any moved.
    pub(super) fn update_bounds(&mut self) -> bool {
        let m = self.ap.n();
        let mut moved = false;
        for i in 0..m {
            let (lo, hi) = effective_bounds(self.lop[i], self.hip[i], self.fip[i], &self.lam);
            let tol = 1e-14 * (1.0 + lo.abs().max(hi.abs()));
            if self.fip[i].is_some()
                && ((lo - self.lo_eff[i]).abs() > tol || (hi - self.hi_eff[i]).abs() > tol)
            {
                moved = true;
            }
            self.lo_eff[i] = lo;
            self.hi_eff[i] = hi;
        }
        moved
    }
}
