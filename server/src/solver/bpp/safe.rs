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

use super::super::pgs::{inverse_diagonal, pgs_sweep};
use super::super::{effective_bounds, natural_residual};
use super::solver::Solver;

impl Solver {
    /// Makes `λ` (permuted order) feasible and of non-positive merit (module docs); leaves the
    /// matching `w`. `w_current`: `w` already matches `λ` (then it is recomputed only if the
    /// projection moves `λ`). Returns whether `λ` had to be scaled towards zero.
    pub(super) fn make_safe(&mut self, w_current: bool) -> bool {
        let m = self.ap.n();
        let mut moved = false;
        for i in 0..m {
            if self.fip[i].is_none() {
                let x = self.lam[i].max(self.lop[i]).min(self.hip[i]);
                moved |= x != self.lam[i];
                self.lam[i] = x;
            }
        }
        for i in 0..m {
            if self.fip[i].is_some() {
                let (lo, hi) = effective_bounds(self.lop[i], self.hip[i], self.fip[i], &self.lam);
                let x = self.lam[i].max(lo).min(hi);
                moved |= x != self.lam[i];
                self.lam[i] = x;
            }
        }
        if moved || !w_current {
            self.compute_w();
        }
        self.safe_unchanged = !moved;
        let (mut lal, mut bl) = (0.0, 0.0);
        for i in 0..m {
            // λᵀAλ = λᵀ(w + b).
            lal += self.lam[i] * (self.w[i] + self.bp[i]);
            bl += self.bp[i] * self.lam[i];
        }
        let f = 0.5 * lal - bl;
        // A NaN merit is not positive: nothing to scale.
        if f.is_nan() || f <= 0.0 || !self.ws.safe.zero_feasible {
            return false;
        }
        self.safe_unchanged = false;
        let t = if lal > 0.0 { (bl / lal).clamp(0.0, 1.0) } else { 0.0 };
        for i in 0..m {
            self.lam[i] *= t;
        }
        self.compute_w();
        true
    }

    /// The answer of a solve that did not converge, left in `lam` with its `w`. Candidates: the best
    /// iterate, the warm start and the last exact solution with frozen friction bounds, each made
    /// safe; the frozen one when there is one and [`SolverOptions::prefer_frozen`](super::SolverOptions::prefer_frozen)
    /// is set, else the one with the smallest true residual.
    pub(super) fn choose_capped(&mut self) {
        let mut best_r = f64::INFINITY;
        for c in 0..3 {
            match c {
                0 => self.lam.copy_from_slice(&self.best),
                1 => self.lam.copy_from_slice(&self.ws.safe.warm_lam),
                _ if self.ws.safe.have_frozen && self.prox_shift == 0.0 => {
                    self.lam.copy_from_slice(&self.ws.safe.frozen)
                }
                _ => continue,
            }
            let scaled = self.make_safe(false);
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

    /// Polishes the safe candidate of a solve that did not converge (in `λ`, with its `w`) when its
    /// relative residual exceeds [`SolverOptions::polish_above`](super::SolverOptions::polish_above):
    /// up to [`SolverOptions::polish_sweeps`](super::SolverOptions::polish_sweeps) projected
    /// Gauss–Seidel sweeps (`pgs.rs`, true friction bounds) from it, none started after the deadline,
    /// then made safe again; kept when its natural-map residual is smaller. The index set handed
    /// on as the next step's warm start stays the pivoting's (re-reading it off the polished
    /// iterate made the forwarder cap 254 solves instead of 248 and the winch 113 instead of 48).
    ///
    /// Measured on the corpus at cap 35: the capped answer alone was worse than PGS run from
    /// scratch for the same time on 33 of 35 capped solves (forwarder grasp 4.2e-1 against
    /// 3.7e-4, winch chain at contact compliance 1e-10 7.8 against 2.1e-4); 20 sweeps from it cut
    /// its residual by 1–3 orders (to 1e-2…1e-5) for about a tenth of the solve's time. In
    /// simulation at cap 35 and contact compliance 1e-10: the winch went from 1,039 of 1,200 solves
    /// capped, energy gain flagged at t = 0.12 s and 9 cm joint error to 42 capped, stable, 2e-6 m;
    /// the forklift from an energy gain at t = 7.7 s and 9 cm joint error to stable, 8 mm. Polishing
    /// every capped answer (threshold 0) also polished the forwarder's frozen-bounds answers of its
    /// grasp (residual ~1e-3), whose redundant teeth PGS redistributes slowly: 248 capped solves
    /// instead of 17 and the log 23 cm from the exact run; above 1e-3 it is 55 and 8.7 cm (4.9 cm
    /// unpolished); above 1e-2 the winch loses its stability again. Deterministic (a sweep count,
    /// not a time) unless a deadline is set.
    pub(super) fn polish(&mut self) {
        let sweeps = self.opts.polish_sweeps;
        let m = self.ap.n();
        if sweeps == 0 || self.non_finite || m == 0 {
            return;
        }
        let (_, r0) = natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
        if r0.is_nan() || r0 <= self.opts.polish_above {
            return;
        }
        self.ws.safe.polish_save.clear();
        self.ws.safe.polish_save.extend_from_slice(&self.lam);
        inverse_diagonal(&self.ap, &mut self.ws.safe.inv_diag);
        let mut done = 0;
        while done < sweeps {
            if self.past_deadline() {
                break;
            }
            if !pgs_sweep(
                &self.ap,
                &self.bp,
                &self.lop,
                &self.hip,
                &self.fip,
                &self.ws.safe.inv_diag,
                1.0,
                &mut self.lam,
            ) {
                break;
            }
            done += 1;
        }
        let scaled = self.make_safe(false);
        let (_, r1) = natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
        if done > 0 && r1 < r0 {
            self.stats.polish_sweeps = done;
            self.stats.energy_scaled = scaled;
        } else {
            self.lam.copy_from_slice(&self.ws.safe.polish_save);
            self.compute_w();
        }
    }

    /// Makes the joints of a capped answer exact (`λ`, `w` in; [`SolverOptions::exact_bilateral`](super::SolverOptions::exact_bilateral)).
    ///
    /// Split the rows into bilateral ones `J` (unbounded, no friction index: the joints) and the
    /// rest `C` (contacts, limits, motors). A capped answer `λ = (λ_J, λ_C)` is feasible but its
    /// joint rows are not solved: `w_J ≠ 0`, and in a stiff machine that error is a joint pulled
    /// apart (the forwarder at cap 35: 6 cm over 19 capped steps of a grasp). With `λ_C` kept,
    ///
    /// ```text
    /// λ_J(t) = A_JJ⁻¹ (b_J − t A_JC λ_C),   λ(t) = (λ_J(t), t λ_C),   t ∈ [0, 1],
    /// ```
    ///
    /// solves the joints exactly for the contact impulses `t λ_C`; `λ(t)` is affine in `t`, so
    /// `g(t) = f(λ(t))` (the merit, `½λᵀAλ − bᵀλ`, module docs) is a convex quadratic whose
    /// minimiser over `[0, 1]` is taken. `λ(0)` minimises `f` over `λ_J` with no contact impulse,
    /// so `g(t*) ≤ g(0) ≤ f(0) = 0`: no energy added; `t λ_C` stays feasible because the feasible
    /// set of the contact rows is a cone (friction bounds scale with their normal). Costs one
    /// factor of `A_JJ` (the pivoting's kernel with every `C` row tight) and two solves.
    pub(super) fn exact_bilateral(&mut self) {
        let m = self.ap.n();
        if !self.opts.exact_bilateral || self.non_finite || m == 0 || !self.ws.safe.zero_feasible {
            return;
        }
        let bilateral = |i: usize, s: &Self| {
            s.fip[i].is_none() && s.lop[i] == f64::NEG_INFINITY && s.hip[i] == f64::INFINITY
        };
        let nb = (0..m).filter(|&i| bilateral(i, self)).count();
        if nb == 0 || nb == m {
            return;
        }
        self.ws.safe.bil_tight.clear();
        self.ws.safe.bil_tight.extend_from_slice(&self.tight);
        for i in 0..m {
            self.tight[i] = !bilateral(i, self);
        }
        let kernel = self.kernel;
        self.factor_for(kernel);
        // λ(1): the joints for the contact impulses as they are.
        self.refine_free();
        self.ws.safe.bil_d.clear();
        self.ws.safe.bil_d.extend_from_slice(&self.lam);
        self.ws.safe.bil_ad.clear();
        self.ws.safe.bil_ad.extend_from_slice(&self.w);
        // λ(0): the joints alone.
        for i in 0..m {
            if self.tight[i] {
                self.lam[i] = 0.0;
            }
        }
        self.compute_w();
        self.refine_free();
        // d = λ(1) − λ(0), A d = w(1) − w(0); g(t) = g(0) + t dᵀw(0) + ½ t² dᵀAd.
        let (mut dw0, mut dad) = (0.0, 0.0);
        for i in 0..m {
            self.ws.safe.bil_d[i] -= self.lam[i];
            self.ws.safe.bil_ad[i] -= self.w[i];
            dw0 += self.ws.safe.bil_d[i] * self.w[i];
            dad += self.ws.safe.bil_d[i] * self.ws.safe.bil_ad[i];
        }
        let t = if dad > 0.0 {
            (-dw0 / dad).clamp(0.0, 1.0)
        } else if dw0 < 0.0 {
            1.0
        } else {
            0.0
        };
        let t = if t.is_finite() { t } else { 0.0 };
        for i in 0..m {
            self.lam[i] += t * self.ws.safe.bil_d[i];
        }
        self.compute_w();
        self.stats.bilateral_scale = Some(t);
        self.tight.copy_from_slice(&self.ws.safe.bil_tight);
    }
}
