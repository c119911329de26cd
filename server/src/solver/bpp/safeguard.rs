//! Safeguards of the block pivoting: projected Newton on the box QP when the infeasible count
//! stalls (fixed bounds), and proximal point iterations when `A` is only semidefinite.

use std::time::Instant;

use super::super::{IndexState, Variant, effective_bounds, natural_residual};
use super::solver::{Solver, resize, us};

impl Solver {
    /// Safeguard of the block pivoting for *fixed* bounds: a primal feasible active-set method on
    /// the strictly convex box QP `min f(λ) = ½λᵀAλ − bᵀλ, lo ≤ λ ≤ hi` whose optimality system the
    /// boxed LCP is. From the projection of the current iterate onto the box and its ε-binding set
    /// (at a bound with the gradient `w` pushing outwards), each step solves for the minimiser
    /// `λ̂` of `f` on the face `λ_T = bounds` — exactly a block pivoting step, with the same factor
    /// reuse — and moves to it as far as the box allows (ratio test on the free variables, an
    /// exact step along which the convex `f` decreases: no objective comparisons, which the
    /// rounding of a flat, ill-conditioned `f` makes unreliable). Variables that block are bound
    /// where they block; at a face minimiser, every bound variable whose gradient points into the
    /// box (eq. 4's infeasibility of `T`) is released at once. `f` decreases at every non-degenerate
    /// step and face minimisers never repeat, so the method is finite; the last step is an exact
    /// pivot step. (Projected Newton with an Armijo search on the projection arc, which this
    /// replaced, zig-zagged on the forklift's and forwarder's redundant contact sets: 30–870 steps
    /// of `α ≈ 1e-4` with `f` changing in its tenth digit.) Returns `false` when the step cap or
    /// the deadline comes first; on `true`, `λ`, `w` and the index set solve the frozen problem.
    ///
    /// **Along the projection arc** ([`super::SolverOptions::projected_arc`], off by default): when
    /// the full projected step fails, the points `P(λ + t (λ̂ − λ))` for `t = ½, ¼, …` down to the
    /// ratio test's `α` are tried with the same Armijo test before the ratio-test step. Measured
    /// (20 s runs at the paper's cap, `auto`; `tests/data/vehicle/README.md` per file): on the
    /// vehicle, whose torque-bounded couplings and sliding wheels leave many bounds to change at
    /// once, 4 halvings cut the mean pivot steps 5.7 → 3.8 (longest solve 28 → 18) and at contact
    /// compliance 1e-10 6.2 → 4.2 (35, one capped solve → 25); forklift and winch at 1e-10 keep
    /// their capped counts (9 → 11, 31 → 31); the forwarder's grasp loses (8 capped solves → 33;
    /// 37–157 when restricted to one kind of start or to 3 arc steps per call, 50–90 when the arc
    /// point must also beat the ratio-test step's decrease or a tenth of the face minimiser's):
    /// on redundant contact sets the shorter arc points are the zig-zag the ratio test replaced.
    /// Hence a scene setting, which the vehicle uses.
    ///
    /// `start` says which bounds bind at the start: the ε-binding set of the projected iterate
    /// (when block pivoting stalled), or the current index set with its tight variables moved to
    /// their bounds (after an outer update of the friction boxes, [`Start::IndexSet`]).
    pub(super) fn projected_newton(&mut self, variant: Variant, start: Start) -> bool {
        let m = self.ap.n();
        for v in [&mut self.lam_old, &mut self.w_old, &mut self.lam_hat, &mut self.w_hat] {
            resize(v, m);
        }
        // Start from the projection of the current iterate onto the box.
        for i in 0..m {
            self.lam[i] = match (start, self.state[i]) {
                (Start::IndexSet, IndexState::Lower) => self.lo_eff[i],
                (Start::IndexSet, IndexState::Upper) => self.hi_eff[i],
                _ => self.lam[i].max(self.lo_eff[i]).min(self.hi_eff[i]),
            };
        }
        self.compute_w();
        if start == Start::BindingSet {
            self.set_binding_set();
        }
        loop {
            if self.stop_now() {
                return false;
            }
            self.lam_old.copy_from_slice(&self.lam);
            self.w_old.copy_from_slice(&self.w);
            self.pivot_solve(variant);
            self.record_step();
            self.stats.projected_newton_steps += 1;
            if !self.w.iter().all(|x| x.is_finite()) {
                self.non_finite = true;
                return false;
            }
            let alpha = self.ratio_test();
            if alpha >= 1.0 {
                // At the face minimiser: release the bound variables whose gradient points inwards.
                self.find_infeasible();
                if self.infeasible.is_empty() {
                    return true;
                }
                for k in 0..self.infeasible.len() {
                    let i = self.infeasible[k];
                    self.state[i] = IndexState::Free;
                    self.tight[i] = false;
                }
                continue;
            }
            // A projected Newton step first (Bertsekas): the projection of λ̂ onto the box, taken
            // when it decreases `f` clearly (Armijo), changes many bounds at once; then, with
            // `projected_arc`, the shorter points of the projection arc down to the ratio test's
            // `α` (below it the arc is the plain segment, whose exact step comes next).
            self.lam_hat.copy_from_slice(&self.lam);
            self.w_hat.copy_from_slice(&self.w);
            if self.projected_arc_step(alpha) {
                self.stats.projected_steps += 1;
                self.set_binding_set();
                continue;
            }
            self.partial_step(alpha);
        }
    }

    /// Semismooth Newton on the natural map `r(λ) = λ − mid(lo(λ), hi(λ), λ − w)` with the true,
    /// moving friction bounds: the index set is read off `r` at `λ`, the Newton point is the pivot
    /// step for it with the bounds frozen, corrected to the exact coupled point (tight friction
    /// rows follow their free normal impulse, `coupled.rs`), and a backtracking search on `‖r‖²`
    /// along the segment (where `w` is affine) takes the first Armijo point, or the best point
    /// tried when none is. The last resort of friction-coupled solves whose outer iteration stalls.
    /// With `bail`, it also gives up after `NEWTON_PATIENCE` steps without halving `‖r‖²`.
    pub(super) fn semismooth_newton(&mut self, variant: Variant, budget: usize, bail: bool) -> bool {
        let cap = self.opts.max_steps.min(self.stats.pivot_steps + budget);
        let m = self.ap.n();
        for v in [&mut self.lam_old, &mut self.w_old, &mut self.lam_hat] {
            resize(v, m);
        }
        self.stats.fallback = true;
        let mut theta = natural_residual_sq(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
        let mut best = f64::INFINITY;
        let (mut mark, mut since) = (theta, 0);
        while self.stats.pivot_steps < cap && !self.stop_now() {
            if bail {
                if theta <= 0.5 * mark {
                    (mark, since) = (theta, 0);
                } else if since >= NEWTON_PATIENCE {
                    break;
                } else {
                    since += 1;
                }
            }
            let (r, rr) = natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
            if rr < best {
                best = rr;
                if rr < self.best_res {
                    self.best_res = rr;
                    self.best.copy_from_slice(&self.lam);
                }
            }
            if rr <= self.opts.tol_rel || r == 0.0 {
                return true;
            }
            if !rr.is_finite() {
                self.non_finite = true;
                return false;
            }
            self.classify_natural();
            self.update_bounds();
            self.lam_old.copy_from_slice(&self.lam);
            self.w_old.copy_from_slice(&self.w);
            let which = self.pivot_solve(variant);
            self.record_step();
            self.stats.newton_steps += 1;
            if let Some(false) = self.coupled_newton(which) {
                // GMRES did not converge: recompute the frozen point (a pivot step of its own).
                if self.stop_now() {
                    self.lam.copy_from_slice(&self.lam_old);
                    self.w.copy_from_slice(&self.w_old);
                    break;
                }
                self.pivot_solve(variant);
                self.record_step();
            }
            let theta_n = natural_residual_sq(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
            if theta_n <= (1.0 - 2e-4) * theta {
                theta = theta_n;
                continue;
            }
            theta = self.backtrack_natural(theta, theta_n);
        }
        // The final iterate may be the best one.
        let (_, rr) = natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
        if rr < self.best_res {
            self.best_res = rr;
            self.best.copy_from_slice(&self.lam);
        }
        false
    }

    /// Tries the points `P(λ_old + t (λ̂ − λ_old))` of the projection arc (`λ̂` in `lam_hat`) for
    /// `t = 1, ½, …` (`projected_arc` halvings, while `t > α`) and stops at the first that passes
    /// the Armijo test on `f`, beyond the rounding of its terms; leaves it in `λ`, `w` and returns
    /// `true`, else returns `false` with `λ`, `w` to be overwritten by the caller.
    fn projected_arc_step(&mut self, alpha: f64) -> bool {
        let m = self.ap.n();
        let f_old = objective(&self.lam_old, &self.w_old, &self.bp);
        let mut t = 1.0;
        for _ in 0..=self.opts.projected_arc {
            let mut gd = 0.0;
            for i in 0..m {
                let x = self.lam_old[i] + t * (self.lam_hat[i] - self.lam_old[i]);
                self.lam[i] = x.max(self.lo_eff[i]).min(self.hi_eff[i]);
                gd += self.w_old[i] * (self.lam[i] - self.lam_old[i]);
            }
            self.w_along(t);
            let f_p = objective(&self.lam, &self.w, &self.bp);
            let noise = 1e-12 * (f_old.abs() + objective_scale(&self.lam, &self.w, &self.bp));
            if gd < 0.0 && f_p <= f_old + 1e-4 * gd - noise {
                return true;
            }
            t *= 0.5;
            if t <= alpha {
                break;
            }
        }
        false
    }

    /// The largest step along `λ̂ − λ_old` (`λ̂` in `λ`) that keeps the free variables inside
    /// their boxes (1 when none blocks).
    fn ratio_test(&self) -> f64 {
        let mut alpha: f64 = 1.0;
        for i in 0..self.ap.n() {
            if self.tight[i] {
                continue;
            }
            let (x0, x1) = (self.lam_old[i], self.lam[i]);
            if x1 < self.lo_eff[i] && x1 < x0 {
                alpha = alpha.min(((self.lo_eff[i] - x0) / (x1 - x0)).max(0.0));
            } else if x1 > self.hi_eff[i] && x1 > x0 {
                alpha = alpha.min(((self.hi_eff[i] - x0) / (x1 - x0)).max(0.0));
            }
        }
        alpha
    }

    /// The step to `λ_old + α (λ̂ − λ_old)` (`λ̂` in `lam_hat`), binding the variables that block
    /// at `α`; leaves `λ`, `w`.
    fn partial_step(&mut self, alpha: f64) {
        let m = self.ap.n();
        for i in 0..m {
            let (x0, x1) = (self.lam_old[i], self.lam_hat[i]);
            let x = x0 + alpha * (x1 - x0);
            if self.tight[i] {
                self.lam[i] = x;
                continue;
            }
            let (lo, hi) = (self.lo_eff[i], self.hi_eff[i]);
            let tol = 1e-12 * (1.0 + x0.abs().max(x1.abs()));
            if x1 < lo && x <= lo + tol {
                self.lam[i] = lo;
                self.state[i] = IndexState::Lower;
                self.tight[i] = true;
            } else if x1 > hi && x >= hi - tol {
                self.lam[i] = hi;
                self.state[i] = IndexState::Upper;
                self.tight[i] = true;
            } else {
                self.lam[i] = x.max(lo).min(hi);
            }
        }
        self.w_along(alpha);
    }

    /// `w = Aλ − b` at `λ`, a point `λ_old + t (λ̂ − λ_old)` of the Newton segment with some of its
    /// entries moved onto their bounds, from the segment's ends (`w_old`, `w_hat`): `w` is affine
    /// along the segment, so `w = w_old + t (ŵ − w_old) + Σ_i A_{·i} δ_i` with `δ_i` the moves —
    /// the columns of the few clipped entries instead of a product with all of `A` (two of the
    /// three products of a safeguard step; measured on the forwarder's capped grasp solves, where
    /// the products were a quarter of the time). `x_i` is computed as the callers do, so `δ_i`
    /// is exactly zero where they did not move `λ_i`.
    fn w_along(&mut self, t: f64) {
        let m = self.ap.n();
        for i in 0..m {
            self.w[i] = self.w_old[i] + t * (self.w_hat[i] - self.w_old[i]);
        }
        for i in 0..m {
            let x = self.lam_old[i] + t * (self.lam_hat[i] - self.lam_old[i]);
            let d = self.lam[i] - x;
            if d != 0.0 {
                // Column i of the symmetric A is its row i.
                let (cols, vals) = self.ap.row(i);
                for (&j, &a) in cols.iter().zip(vals) {
                    self.w[j] += a * d;
                }
            }
        }
        #[cfg(test)]
        tests::check_w(self);
    }

    /// Backtracking on `‖r‖²` between `λ_old` (with `w_old`) and the Newton point (in `λ`, `w`;
    /// `θ_n` its merit, `θ` the old one): the first Armijo point of `t = ½, ¼, …, 1e-4`, or the
    /// best tried when none is. Leaves that point in `λ`, `w`; returns its merit.
    fn backtrack_natural(&mut self, theta: f64, theta_n: f64) -> f64 {
        let m = self.ap.n();
        self.lam_hat.copy_from_slice(&self.lam);
        self.tmp.copy_from_slice(&self.w);
        let (mut best_t, mut best_theta) = (1.0, theta_n);
        let mut t = 0.5;
        while t >= 1e-4 {
            for i in 0..m {
                self.lam[i] = self.lam_old[i] + t * (self.lam_hat[i] - self.lam_old[i]);
                self.w[i] = self.w_old[i] + t * (self.tmp[i] - self.w_old[i]);
            }
            let th = natural_residual_sq(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
            if th < best_theta {
                (best_t, best_theta) = (t, th);
            }
            if th <= (1.0 - 2e-4 * t) * theta {
                break;
            }
            t *= 0.5;
        }
        for i in 0..m {
            self.lam[i] = self.lam_old[i] + best_t * (self.lam_hat[i] - self.lam_old[i]);
            self.w[i] = self.w_old[i] + best_t * (self.tmp[i] - self.w_old[i]);
        }
        best_theta
    }

    /// Index set read off the natural map at `(λ, w)` with the bounds at `λ`: `T_lo` where
    /// `λ − w ≤ lo(λ)`, `T_hi` where `λ − w ≥ hi(λ)`, free otherwise.
    fn classify_natural(&mut self) {
        for i in 0..self.ap.n() {
            let (lo, hi) = effective_bounds(self.lop[i], self.hip[i], self.fip[i], &self.lam);
            let z = self.lam[i] - self.w[i];
            let s = if z <= lo && lo > f64::NEG_INFINITY {
                IndexState::Lower
            } else if z >= hi && hi < f64::INFINITY {
                IndexState::Upper
            } else {
                IndexState::Free
            };
            self.state[i] = s;
            self.tight[i] = s.is_tight();
        }
    }

    /// ε-binding set at a feasible `λ` with `ε = min(1e-6 (1 + ‖λ‖∞), ‖λ − P(λ − w)‖∞)`:
    /// variables at a bound whose gradient `w` pushes outwards are held there.
    pub(super) fn set_binding_set(&mut self) {
        let m = self.ap.n();
        let mut pg: f64 = 0.0;
        let mut scale: f64 = 0.0;
        for i in 0..m {
            let p = (self.lam[i] - self.w[i]).max(self.lo_eff[i]).min(self.hi_eff[i]);
            pg = pg.max((self.lam[i] - p).abs());
            scale = scale.max(self.lam[i].abs());
        }
        let eps = pg.min(1e-6 * (1.0 + scale));
        for i in 0..m {
            let (lo, hi, l, g) = (self.lo_eff[i], self.hi_eff[i], self.lam[i], self.w[i]);
            let s = if lo == hi || (l <= lo + eps && g > 0.0) {
                IndexState::Lower
            } else if l >= hi - eps && g < 0.0 {
                IndexState::Upper
            } else {
                IndexState::Free
            };
            self.state[i] = s;
            self.tight[i] = s.is_tight();
        }
    }

    /// Semidefinite `A` (redundant contacts): proximal point iterations. Each solves the strongly
    /// monotone problem `(A + ρI) λ − (b + ρ λ_k) = w_ρ` with the same pivoting (one factor of
    /// `A + ρI` serves all of them), then moves the centre `λ_k ← λ`. At a fixed point
    /// `w_ρ = Aλ − b`, so the iterates approach a solution of the original problem, whose residual
    /// is what is judged (`w = w_ρ − ρ(λ − λ_k)`). `ρ = 1e-5 · max_diag` dominates the rounding-level
    /// negative eigenvalues of such matrices while keeping `A + ρI` well conditioned.
    pub(super) fn proximal_solve(&mut self, variant: Variant, friction: bool) -> bool {
        let m = self.ap.n();
        self.needs_prox = false;
        let rho = 1e-5 * self.max_diag;
        self.prox_shift = rho;
        self.ap.diagonal_into(&mut self.ws.proximal.diag0);
        for i in 0..m {
            self.tmp[i] = self.ws.proximal.diag0[i] + rho;
        }
        self.ap.set_diagonal(&self.tmp);
        resize(&mut self.ws.proximal.bp0, m);
        self.ws.proximal.bp0.copy_from_slice(&self.bp);
        resize(&mut self.ws.proximal.center, m);
        self.ws.proximal.center.copy_from_slice(&self.best);
        self.lam.copy_from_slice(&self.best);
        let t = Instant::now();
        self.ws.factor.l_valid = false;
        self.prepare(variant);
        self.stats.factor_us += us(t);
        let mut best_true = f64::INFINITY;
        let mut converged = false;
        while !self.stop_now() {
            self.stats.proximal_iterations += 1;
            for i in 0..m {
                self.bp[i] = self.ws.proximal.bp0[i] + rho * self.ws.proximal.center[i];
            }
            self.compute_w();
            let inner = self.bpp_loop(variant, friction, true);
            // True w of the original problem.
            for i in 0..m {
                self.tmp[i] = self.w[i] - rho * (self.lam[i] - self.ws.proximal.center[i]);
            }
            let (r, rr) = natural_residual(&self.lam, &self.tmp, &self.lop, &self.hip, &self.fip);
            if rr < best_true {
                best_true = rr;
                self.ws.proximal.best.clone_from(&self.lam);
            }
            if rr <= self.opts.tol_rel || r == 0.0 {
                converged = true;
                break;
            }
            if !inner || self.non_finite {
                break;
            }
            self.ws.proximal.center.copy_from_slice(&self.lam);
        }
        // Back to the original problem.
        self.ap.set_diagonal(&self.ws.proximal.diag0);
        self.bp.copy_from_slice(&self.ws.proximal.bp0);
        self.prox_shift = 0.0;
        if best_true.is_finite() {
            self.best.copy_from_slice(&self.ws.proximal.best);
        }
        if converged {
            self.best.copy_from_slice(&self.lam);
        }
        // The caller reports `best` when not converged; with convergence λ is already the answer.
        converged || best_true <= self.opts.tol_rel
    }
}

/// Which bounds bind when the active-set safeguard starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Start {
    /// The ε-binding set of the projected iterate: bounds it sits on with the gradient pushing out.
    BindingSet,
    /// The current index set, its tight variables at their (moved) bounds. After an outer update
    /// the friction boxes moved a little and the last solution's index set is nearly right; its
    /// ε-binding set instead lost the rows whose bounds moved away from them (measured on the
    /// winch's chain at contact compliance 1e-10: 116 bound rows before the update, 73 after,
    /// then one ratio-test step per row to bind them again).
    IndexSet,
}

/// Steps the first semismooth Newton attempt may take without halving `‖r‖²`.
const NEWTON_PATIENCE: usize = 6;

/// `½λᵀAλ − bᵀλ = ½λᵀ(w − b)` with `w = Aλ − b`.
fn objective(lambda: &[f64], w: &[f64], b: &[f64]) -> f64 {
    0.5 * lambda.iter().zip(w).zip(b).map(|((l, w), b)| l * (w - b)).sum::<f64>()
}

/// `½ Σ |λ_i (w_i − b_i)|`: the size of the terms whose rounding the objective carries.
fn objective_scale(lambda: &[f64], w: &[f64], b: &[f64]) -> f64 {
    0.5 * lambda.iter().zip(w).zip(b).map(|((l, w), b)| (l * (w - b)).abs()).sum::<f64>()
}

/// `‖r(λ)‖₂²` of the natural map with bounds at `λ` (the merit of the Newton fallback).
fn natural_residual_sq(lambda: &[f64], w: &[f64], lo: &[f64], hi: &[f64], findex: &[Option<usize>]) -> f64 {
    let mut acc = 0.0;
    for i in 0..lambda.len() {
        let (l, h) = effective_bounds(lo[i], hi[i], findex[i], lambda);
        let r = lambda[i] - (lambda[i] - w[i]).max(l).min(h);
        acc += r * r;
    }
    if acc.is_nan() { f64::INFINITY } else { acc }
}

#[cfg(test)]
mod tests {
    //! `w_along` against a fresh product: the unit tests of the crate run this check at every
    //! safeguard step (the integration tests and the product do not).

    use super::super::{Solver, SolverOptions};
    use crate::solver::io::read_mlcp_file;
    use crate::solver::{SolveStatus, Variant};
    use std::cell::Cell;

    thread_local! {
        /// Checks made, and the largest error seen relative to its row's scale.
        static CHECKED: Cell<(usize, f64)> = const { Cell::new((0, 0.0)) };
    }

    /// Compares `w` (from the segment's ends) with `Aλ − b` entry by entry, relative to
    /// `Σ_j |A_ij λ_j| + |b_i|`, the size of the terms the product sums.
    pub(super) fn check_w(s: &Solver) {
        let m = s.ap.n();
        let mut worst: f64 = 0.0;
        for i in 0..m {
            let (cols, vals) = s.ap.row(i);
            let (mut sum, mut scale) = (-s.bp[i], s.bp[i].abs());
            for (&j, &a) in cols.iter().zip(vals) {
                sum += a * s.lam[j];
                scale += (a * s.lam[j]).abs();
            }
            if scale > 0.0 {
                worst = worst.max((s.w[i] - sum).abs() / scale);
            }
        }
        CHECKED.with(|c| {
            let (n, w) = c.get();
            c.set((n + 1, w.max(worst)));
        });
    }

    /// The corpus's forwarder grasps and forklift files, warm at the paper's cap: hundreds of
    /// safeguard steps, every `w` from the segment's ends within 1e-9 of the product's scale.
    #[test]
    fn w_along_the_segment_matches_the_product() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/corpus");
        let mut solver = Solver::new(SolverOptions { variant: Variant::Auto, ..Default::default() });
        let mut solved = 0;
        for name in [
            "forwarder-hard00-step000903-island1.txt",
            "forwarder-hard02-step000904-island1.txt",
            "forklift-c1e-10-hard00-step000462-island0.txt",
            "forklift-hard00-step000483-island0.txt",
        ] {
            let p = read_mlcp_file(&dir.join(name)).expect("corpus file");
            let mut lambda = vec![0.0; p.n()];
            let st = solver.solve(&p, &mut lambda);
            assert!(matches!(st.status, SolveStatus::Converged | SolveStatus::MaxSteps), "{name}");
            solved += st.projected_newton_steps;
        }
        let (checks, worst) = CHECKED.with(Cell::get);
        eprintln!("{checks} segment points over {solved} safeguard steps; worst relative error {worst:.1e}");
        assert!(checks >= 20, "the safeguard took too few steps to test anything ({checks})");
        assert!(worst <= 1e-9, "w from the segment's ends is {worst:e} off the product");
    }
}
