//! The pivoting loop (eq. 4–6): pivot steps on the current index set, the judgement of each
//! iterate, the block pivot or the safeguard on the infeasible variables, and semismooth Newton first
//! (module docs of `bpp`, "One pivot step", "Safeguard").

use super::super::{IndexState, Variant, natural_residual};
use super::options::Fallback;
use super::safeguard::Start;
use super::solver::Solver;
use super::workspace::Progress;

/// Pivot steps the semismooth Newton method may take first on a warm-started solve.
const NEWTON_FIRST_BUDGET: usize = 12;

impl Solver {
    /// Júdice–Pires block pivoting with Murty's fallback for fixed bounds. Returns convergence.
    pub(super) fn bpp_loop(&mut self, variant: Variant, friction: bool, bounds_known: bool) -> bool {
        self.update_bounds();
        self.best_res = f64::INFINITY;
        if friction && bounds_known && self.opts.newton_first && self.try_newton_first(variant) {
            return true;
        }
        // Without a warm-start λ the friction bounds are frozen at the first (all-free) solve.
        self.pivoting(variant, friction, Progress::default(), bounds_known)
    }

    /// The block pivoting resumed where a loop stopped for the interior point switch: `λ`, the
    /// index set and the frozen bounds restored by the caller (`ipm.rs`), its progress counters
    /// and best residual as that loop left them, so that a failed switch leaves the pivoting's
    /// path as it was.
    pub(super) fn resume_pivoting(&mut self, variant: Variant, friction: bool, progress: Progress) -> bool {
        self.pivoting(variant, friction, progress, true)
    }

    /// The loop of pivot steps (eq. 4–6) and what follows each (`after_pivot`); leaves its
    /// progress in `self.progress`.
    pub(super) fn pivoting(
        &mut self,
        variant: Variant,
        friction: bool,
        mut progress: Progress,
        mut bounds_set: bool,
    ) -> bool {
        let mut resolved = false;
        let converged = loop {
            if !resolved {
                if self.stop_now() {
                    break false;
                }
                self.pivot_solve(variant);
                self.record_step();
                if self.stats.regularized > 0 && self.prox_shift == 0.0 && self.opts.proximal {
                    // A is (numerically) singular: switch to proximal point iterations.
                    self.needs_prox = true;
                    break false;
                }
                if !bounds_set {
                    self.update_bounds();
                    bounds_set = true;
                }
            }
            match self.after_pivot(variant, friction, &mut progress) {
                Next::Return(converged) => break converged,
                Next::Pivot => resolved = false,
                Next::Resolved => resolved = true,
            }
        };
        self.progress = progress;
        converged
    }

    /// Judges the iterate of the current index set: an exact solution of the frozen problem goes
    /// to [`Self::at_frozen_solution`], else the infeasible variables are pivoted.
    pub(super) fn after_pivot(&mut self, variant: Variant, friction: bool, progress: &mut Progress) -> Next {
        let (res, res_rel) = natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
        if !res_rel.is_finite() {
            self.non_finite = true;
            return Next::Return(false);
        }
        self.note_best(res_rel);
        self.find_infeasible();
        if self.infeasible.is_empty() {
            self.at_frozen_solution(variant, friction, (res, res_rel), progress)
        } else {
            self.pivot_infeasible(variant, progress)
        }
    }

    /// Keeps `λ` as the best iterate when its relative residual `rr` is the smallest yet.
    pub(super) fn note_best(&mut self, rr: f64) {
        if rr.is_finite() && rr < self.best_res {
            self.best_res = rr;
            self.best.copy_from_slice(&self.lam);
        }
    }

    /// The block pivot on the infeasible variables (eq. 4), or the safeguard when their number
    /// has not decreased for `murty_after` steps.
    pub(super) fn pivot_infeasible(&mut self, variant: Variant, progress: &mut Progress) -> Next {
        let ninf = self.infeasible.len();
        let stalled = if ninf < progress.best_ninf {
            progress.best_ninf = ninf;
            progress.no_progress = 0;
            false
        } else if progress.no_progress < self.opts.murty_after {
            progress.no_progress += 1;
            false
        } else {
            true
        };
        if !stalled {
            for k in 0..self.infeasible.len() {
                let i = self.infeasible[k];
                self.pivot(i);
            }
            return Next::Pivot;
        }
        self.stats.fallback = true;
        match self.opts.fallback {
            Fallback::Murty => {
                self.stats.murty_steps += 1;
                let i = *self.infeasible.iter().max().expect("non-empty");
                self.pivot(i);
                Next::Pivot
            }
            Fallback::ProjectedNewton => {
                if !self.projected_newton(variant, Start::BindingSet) {
                    return Next::Return(false);
                }
                progress.best_ninf = usize::MAX;
                progress.no_progress = 0;
                Next::Resolved
            }
        }
    }

    /// Semismooth Newton from the warm start, for at most `NEWTON_FIRST_BUDGET` steps; on failure
    /// the warm start (λ₀, index set) is restored for the block pivoting, the best iterate kept.
    /// Measured on the corpus: from a warm start it needs 2–13 steps where the outer friction
    /// iteration needs 8–30 or cycles (a chain sliding with stiff contacts), but it stalls on
    /// redundant contact sets, which the block pivoting with its safeguard then solves.
    pub(super) fn try_newton_first(&mut self, variant: Variant) -> bool {
        self.compute_w();
        if self.semismooth_newton(variant, NEWTON_FIRST_BUDGET, true) {
            return true;
        }
        self.non_finite = false;
        self.lam.copy_from_slice(&self.ws.safe.warm_lam);
        for i in 0..self.state.len() {
            self.state[i] = self.ws.safe.state0[i];
            self.tight[i] = self.ws.safe.state0[i].is_tight();
        }
        self.compute_w();
        self.update_bounds();
        false
    }

    pub(super) fn record_step(&mut self) {
        self.stats.pivot_steps += 1;
        let ntight = self.tight.iter().filter(|&&t| t).count();
        self.stats.tight_per_step.push(ntight as u32);
    }

    /// Fills `infeasible` with the variables that violate eq. 4 against the frozen bounds. The
    /// sign of `w_i` on a tight row is trusted beyond `1e-13 (|b_i| + ‖A_i‖₁ ‖λ‖∞)`: the rounding
    /// of the row's sum when `λ` carries errors of the size of its largest entry. (A global scale,
    /// the largest diagonal times `‖λ‖∞`, let a normal row of the forwarder sit at 0 with
    /// `w = −1.1e-5` because a 0.08 kg pin elsewhere in the island had a diagonal of 3.9e5; the
    /// row's own `Σ |A_ij λ_j|` is too small where the neighbouring `λ` vanish, and released a
    /// contact with `w = −4e-16` over and over.)
    pub(super) fn find_infeasible(&mut self) {
        let m = self.ap.n();
        let lam_scale = self.lam.iter().fold(0.0f64, |a, &x| a.max(x.abs()));
        let tol_l = 1e-13 * lam_scale.max(f64::MIN_POSITIVE);
        self.infeasible.clear();
        for i in 0..m {
            let (lo, hi) = (self.lo_eff[i], self.hi_eff[i]);
            // `‖A_i‖₁` only for a tight row whose `w` has the wrong sign at all.
            let tol_w = || {
                let row_norm: f64 = self.ap.row(i).1.iter().map(|a| a.abs()).sum();
                1e-13 * (self.bp[i].abs() + row_norm * lam_scale).max(f64::MIN_POSITIVE)
            };
            let bad = match self.state[i] {
                IndexState::Free => self.lam[i] < lo - tol_l || self.lam[i] > hi + tol_l,
                // A degenerate box (lo = hi) is satisfied by any w.
                IndexState::Lower => lo < hi && self.w[i] < 0.0 && self.w[i] < -tol_w(),
                IndexState::Upper => lo < hi && self.w[i] > 0.0 && self.w[i] > tol_w(),
            };
            if bad {
                self.infeasible.push(i);
            }
        }
    }

    /// Moves variable `i` to the set eq. 4 names.
    pub(super) fn pivot(&mut self, i: usize) {
        let lam_i = self.lam[i];
        let new = match self.state[i] {
            IndexState::Free => {
                if lam_i < self.lo_eff[i] {
                    IndexState::Lower
                } else {
                    IndexState::Upper
                }
            }
            IndexState::Lower | IndexState::Upper => IndexState::Free,
        };
        self.state[i] = new;
        self.tight[i] = new.is_tight();
    }
}

/// What the block pivoting loop does after judging an iterate.
pub(super) enum Next {
    /// Stop: converged (`true`) or not.
    Return(bool),
    /// Take a pivot step with the (changed) index set.
    Pivot,
    /// `λ` and `w` already solve the current index set (a safeguard ended on an exact step).
    Resolved,
}
