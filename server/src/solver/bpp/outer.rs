//! The outer friction loop: at an exact solution of the frozen problem, the globalized coupled
//! Newton point and the update of the friction bounds, the safeguard after it, the semismooth
//! Newton fallback when the outer iteration stalls, and the proximal outer iteration when that
//! fails too (module docs of `bpp`, "Friction coupling", "Proximal outer iteration").

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
    /// the whole natural map, from the best iterate; with
    /// [`SolverOptions::safeguard_after_update`](super::SolverOptions::safeguard_after_update) the
    /// active-set safeguard continues from the last index set, its tight rows at the new bounds.
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
        if progress.outer_stall >= stall_limit && self.in_prox_outer {
            // An inner solve of the proximal outer iteration that stalls: its `ρ` is too small.
            return Next::Return(false);
        }
        if progress.outer_stall >= stall_limit && (self.opts.newton_fallback || self.opts.prox_outer) {
            if self.opts.newton_fallback {
                self.lam.copy_from_slice(&self.best);
                self.compute_w();
                if self.semismooth_newton(variant, NEWTON_BUDGET, false) {
                    return Next::Return(true);
                }
            }
            // With steps left (at the paper's cap of 35 the fallback's budget of 60 takes them all,
            // and the solve ends as it did before this iteration existed).
            if self.opts.prox_outer && self.prox_shift == 0.0 && !self.non_finite && !self.stop_now() {
                return Next::Return(self.proximal_outer(variant));
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

impl Solver {
    /// The proximal outer iteration (module docs of `bpp`, "Proximal outer iteration"): from the
    /// best iterate `c`, each outer step solves the friction-coupled problem with
    /// `A_ρ = A + ρD` (`D = diag A`) and `b_ρ = b + ρDc` — the pivoting with its outer friction
    /// loop, within `PROX_INNER_STEPS` pivot steps and failing at its first stall — and is judged
    /// against the true problem. A solved step moves `c` to its answer and shrinks `ρ` by
    /// `PROX_SHRINK`; a failed one keeps `c` and grows `ρ` by `PROX_GROW`. Returns convergence,
    /// with `λ`, `w` of the true problem (the best true iterate in `best` either way); leaves `A`,
    /// `b` and the factor as they were and does not count its factorizations of `A_ρ` as steps.
    pub(super) fn proximal_outer(&mut self, variant: Variant) -> bool {
        let m = self.ap.n();
        self.in_prox_outer = true;
        self.stats.fallback = true;
        let px = &mut self.ws.proximal;
        self.ap.diagonal_into(&mut px.diag0);
        resize(&mut px.bp0, m);
        px.bp0.copy_from_slice(&self.bp);
        resize(&mut px.center, m);
        px.center.copy_from_slice(&self.best);
        resize(&mut px.best, m);
        px.best.copy_from_slice(&self.best);
        // The inner solves' frozen solutions are not the true problem's (`choose_capped`).
        resize(&mut px.frozen0, m);
        px.frozen0.copy_from_slice(&self.ws.safe.frozen);
        let have_frozen = self.ws.safe.have_frozen;
        self.lam.copy_from_slice(&self.best);
        let mut best_true = self.best_res;
        let mut rho = PROX_RHO0;
        let mut converged = false;
        let ipm_at = self.ipm_at;
        let cap = self.opts.max_steps.min(ipm_at);
        while !self.stop_now() {
            self.stats.proximal_iterations += 1;
            let px = &self.ws.proximal;
            for i in 0..m {
                self.tmp[i] = px.diag0[i] * (1.0 + rho);
                self.bp[i] = px.bp0[i] + rho * px.diag0[i] * px.center[i];
            }
            self.ap.set_diagonal(&self.tmp);
            self.ws.factor.l_valid = false;
            self.prepare(variant);
            self.compute_w();
            self.update_bounds();
            self.best_res = f64::INFINITY;
            self.outer_hist = [0.0; OUTER_MEMORY];
            self.ipm_at = cap.min(self.stats.pivot_steps + PROX_INNER_STEPS);
            let inner = self.pivoting(variant, true, Progress::default(), true);
            self.ipm_at = ipm_at;
            if self.non_finite {
                break;
            }
            // The true `w = w_ρ − ρD(λ − c)`, judged with the bounds at its own normals.
            let px = &self.ws.proximal;
            for i in 0..m {
                self.tmp[i] = self.w[i] - rho * px.diag0[i] * (self.lam[i] - px.center[i]);
            }
            let (r, rr) = natural_residual(&self.lam, &self.tmp, &self.lop, &self.hip, &self.fip);
            if rr < best_true {
                best_true = rr;
                self.ws.proximal.best.copy_from_slice(&self.lam);
            }
            if rr <= self.opts.tol_rel || r == 0.0 {
                converged = true;
                break;
            }
            if inner {
                rho *= PROX_SHRINK;
                self.ws.proximal.center.copy_from_slice(&self.lam);
            } else {
                rho *= PROX_GROW;
                self.lam.copy_from_slice(&self.ws.proximal.center);
            }
            rho = rho.clamp(PROX_RHO_MIN, PROX_RHO_MAX);
        }
        // Back to the original problem and its factor.
        self.ap.set_diagonal(&self.ws.proximal.diag0);
        self.bp.copy_from_slice(&self.ws.proximal.bp0);
        self.ws.factor.l_valid = false;
        self.prepare(variant);
        self.ws.safe.frozen.copy_from_slice(&self.ws.proximal.frozen0);
        self.ws.safe.have_frozen = have_frozen;
        if !converged {
            self.lam.copy_from_slice(&self.ws.proximal.best);
        }
        self.best.copy_from_slice(&self.ws.proximal.best);
        self.best_res = best_true;
        self.compute_w();
        self.update_bounds();
        self.in_prox_outer = false;
        converged
    }
}

/// First `ρ` of the proximal outer iteration, relative to the diagonal (`A_ρ = A + ρ D`).
const PROX_RHO0: f64 = 1.0;
/// `ρ` after a solved proximal step: times this.
const PROX_SHRINK: f64 = 0.3;
/// `ρ` after a failed proximal step (the inner solve stalled or ran out of steps): times this.
const PROX_GROW: f64 = 4.0;
/// The range of `ρ`.
const PROX_RHO_MIN: f64 = 1e-12;
const PROX_RHO_MAX: f64 = 1e4;
/// Pivot steps one inner solve may take.
const PROX_INNER_STEPS: usize = 40;
