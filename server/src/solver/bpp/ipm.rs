//! A primal–dual interior point method (Mehrotra's predictor–corrector) on the boxed MLCP *with
//! its friction coupling*, for solves that block pivoting does not finish.
//!
//! **The problem as constraints.** Every finite bound of a row without `findex` is a constraint
//! `s = ±(λ_i − bound) ≥ 0`; a friction row `i` with normal `n` has two, `s_l = λ_i − lo_i λ_n ≥ 0`
//! and `s_u = hi_i λ_n − λ_i ≥ 0` (`lo_i = −μ`, `hi_i = μ`). Each constraint `k` has a multiplier
//! `z_k ≥ 0` that acts on its own row only, `w = Aλ − b = Σ_k σ_k z_k e_{i_k}` (`σ = +1` for a
//! lower, `−1` for an upper bound), with `s_k z_k = 0`: exactly the complementarity of eq. 4 with
//! the bounds `±μ λ_n` at the returned normal impulses. (A convex QP with the friction pyramid would
//! also put `μ (z_l + z_u)` into the normal row's `w`; ODE's model, which the pivoting solves, does
//! not — hence a non-symmetric Newton matrix below.)
//!
//! **Newton step.** With `D_k = z_k / s_k` and `Δs_k = G_k Δλ` the linearised constraints,
//! eliminating `Δz_k = (τ_k − s_k z_k − z_k Δs_k) / s_k` leaves
//! `K Δλ = −w + Σ_k σ_k τ_k / s_k e_{i_k}`, `K = A + Σ_k D_k σ_k e_{i_k} G_k`: the diagonal
//! `A_ii + D_l + D_u`, plus on a friction row the coupling `K_in = −(D_l lo_i + D_u hi_i)`
//! (`= μ (D_l − D_u)`). `K` is factored by the envelope LU (`envelope_lu.rs`) on `A`'s own
//! envelope — one factorization per iteration, counted as one pivot step. Predictor `τ = 0`, step
//! `α_aff` to the boundary, `σ = (μ_aff / μ)³`, corrector `τ_k = σ μ − Δs_k^aff Δz_k^aff`, step
//! `0.995 α` (one step length for `λ` and `z`).
//!
//! **Start.** `λ` at the centre of two-sided boxes, `s₀` inside one-sided ones (`s₀` the 90th
//! percentile of `|b_i| / A_ii`: an impulse of the island's own scale), friction rows at 0;
//! `z = max(±w, 0) + 0.1 ‖w‖∞`.
//!
//! **Restarts.** Where a run stalls depends on where it starts. A run that stalls, and whose index
//! set the pivoting cannot finish in its bounded trial (`CROSSOVER_TRIAL`), is followed by one from
//! the next, more interior start of `IPM_STARTS` before the pivoting gets its own point back;
//! problems whose first run converges, or whose trial does, are untouched.
//!
//! **Stop** when the natural-map residual against the bounds at the iterate's own normal impulses
//! is within the solve's tolerance (the pivoting's criterion); the index set returned is the one
//! the iterate identifies (`s_k < z_k`: tight). Every iterate is strictly feasible — inside each
//! box and each friction cone — so a capped IPM iterate is a safe answer by construction.
//!
//! What it gains on the corpus and in simulation, where it stalls and why, and what was tried and
//! dropped: `docs/notes/solver.md`.

use super::super::IndexState;
use super::super::envelope_lu::LuError;
use super::solver::{Solver, resize};
use super::workspace::RowKind;

/// Iterations without halving the best residual after which the method gives up.
const IPM_PATIENCE: usize = 8;
/// Pivot steps from a converged interior point's index set to its exact solution.
const CROSSOVER_STEPS: usize = 3;
/// A run that stopped short hands its index set to the pivoting only below this residual
/// (measured on the corpus: 1e-6 sent the winch's sliding chains at 1e-10, whose runs wander at
/// 1e-5…1e-4, back to the pivoting's own start; 1e-4 … 1e-2 count the same files).
const CROSSOVER_BELOW: f64 = 1e-4;
/// Pivot steps the pivoting gets from a stalled run's index set before it goes back to its own.
const CROSSOVER_TRIAL: usize = 30;
/// The starting points a solve tries in turn: `(q, ζ)` puts `s₀` at the `q`-th percentile of
/// `|b_i| / A_ii` and adds `ζ ‖w‖∞` to every `z`. A run that stalls, and whose index set the
/// pivoting cannot finish within `CROSSOVER_TRIAL` steps, is followed by a run from the next,
/// more interior start (module docs, "Restarts"; measured on the corpus).
const IPM_STARTS: [(usize, f64); 2] = [(90, 0.1), (95, 0.3)];
/// Fraction of the step to the boundary.
const TO_BOUNDARY: f64 = 0.995;

impl Solver {
    /// The interior point method, then block pivoting from the index set it identified:
    /// - converged: at most `CROSSOVER_STEPS` pivot steps to the exact solution of that index set
    ///   (a vertex answer, and a warm start the next step can reuse in one step); when they do not
    ///   converge, the interior point's own answer stands;
    /// - not converged but within `CROSSOVER_BELOW`: pivoting from its index set for at most
    ///   `CROSSOVER_TRIAL` steps;
    /// - still not converged: the same from the next of `IPM_STARTS`; after the last, the pivoting
    ///   resumes exactly where it stopped (its `λ`, index set, frozen friction bounds, loop
    ///   progress and best residual), so that a failed switch costs its own iterations and does
    ///   not change the pivoting's path (`tests/solver_regression_big1000.rs`).
    pub(super) fn interior_point_with_crossover(
        &mut self,
        variant: super::super::Variant,
        friction: bool,
    ) -> bool {
        self.save_point();
        for &start in &IPM_STARTS {
            self.ipm.start = start;
            if self.interior_point() {
                self.save_point();
                self.ipm_at = self.stats.pivot_steps + CROSSOVER_STEPS;
                let mut exact = !self.stop_now() && self.bpp_loop(variant, friction, true);
                self.ipm_at = usize::MAX;
                if exact {
                    // The pivoting's answer must meet the tolerance the interior point's did.
                    let (res, rr) =
                        super::super::natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
                    exact = rr <= self.opts.tol_rel || res == 0.0;
                }
                if !exact {
                    self.restore_point();
                }
                return true;
            }
            if self.stop_now() {
                return false;
            }
            if self.ipm.best <= CROSSOVER_BELOW {
                // Near a solution: pivoting from its index set, for a bounded trial.
                self.ipm_at = self.stats.pivot_steps.saturating_add(CROSSOVER_TRIAL);
                let exact = self.bpp_loop(variant, friction, true);
                self.ipm_at = usize::MAX;
                if exact || self.stop_now() {
                    return exact;
                }
            }
        }
        // Far from a solution (its index set says little), or the trial failed: back to where
        // the pivoting was, which goes on as if it had never switched.
        self.restore_point();
        self.resume_pivoting(variant, friction, self.ws.saved.progress)
    }

    /// Keeps the point to come back to: the index set, `λ`, the frozen bounds, the best residual
    /// and the pivoting loop's progress (`ipm_state`, `ipm_lam`, `ipm_lo`, `ipm_hi`, …).
    fn save_point(&mut self) {
        self.ws.saved.state.clear();
        self.ws.saved.state.extend_from_slice(&self.state);
        self.ws.saved.lam.clear();
        self.ws.saved.lam.extend_from_slice(&self.lam);
        self.ws.saved.lo.clear();
        self.ws.saved.lo.extend_from_slice(&self.lo_eff);
        self.ws.saved.hi.clear();
        self.ws.saved.hi.extend_from_slice(&self.hi_eff);
        self.ws.saved.best_res = self.best_res;
        self.ws.saved.progress = self.progress;
    }

    /// Back to the kept point, with its `w`.
    fn restore_point(&mut self) {
        self.state.copy_from_slice(&self.ws.saved.state);
        self.lam.copy_from_slice(&self.ws.saved.lam);
        for (t, s) in self.tight.iter_mut().zip(&self.state) {
            *t = s.is_tight();
        }
        self.lo_eff.copy_from_slice(&self.ws.saved.lo);
        self.hi_eff.copy_from_slice(&self.ws.saved.hi);
        self.best_res = self.ws.saved.best_res;
        self.compute_w();
        self.ws.factor.l_valid = false;
    }

    /// Runs the interior point method from scratch on the current (permuted) problem, each
    /// iteration a counted pivot step. Returns whether it converged; `λ`, `w`, the index set it
    /// identifies and the frozen bounds hold its last iterate either way.
    pub(super) fn interior_point(&mut self) -> bool {
        let m = self.ap.n();
        self.ipm_at = usize::MAX;
        if !self.ipm_setup() {
            return false;
        }
        self.stats.ipm_runs += 1;
        self.stats.fallback = true;
        self.ipm.best = f64::INFINITY;
        let mut best = f64::INFINITY;
        let mut since_best = 0;
        loop {
            self.compute_w();
            let (res, rr) =
                super::super::natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
            if !rr.is_finite() {
                break;
            }
            self.note_best(rr);
            if rr <= self.opts.tol_rel || res == 0.0 {
                self.ipm_finish();
                return true;
            }
            self.ipm.best = self.ipm.best.min(rr);
            if rr < 0.5 * best {
                best = rr;
                since_best = 0;
            } else {
                since_best += 1;
                if since_best >= IPM_PATIENCE {
                    break;
                }
            }
            if self.stop_now() {
                break;
            }
            self.stats.ipm_iterations += 1;
            self.record_step();
            if !self.ipm_iteration(m) {
                break;
            }
        }
        // Not converged: the index set it points at, for the pivoting to start from.
        self.ipm_finish();
        self.compute_w();
        false
    }

    /// Whether the pivoting stopped at the switch to the interior point method (not at the step
    /// cap or the deadline).
    pub(super) fn ipm_due(&self) -> bool {
        self.ipm_at != usize::MAX
            && self.stats.pivot_steps >= self.ipm_at
            && self.stats.pivot_steps < self.opts.max_steps
            && !self.out_of_time
    }

    /// Classifies the rows and sets the starting point; `false` when the problem has a shape the
    /// method does not take (a friction row whose normal row is not a plain `λ_n ≥ 0`).
    fn ipm_setup(&mut self) -> bool {
        let m = self.ap.n();
        let ws = &mut self.ipm;
        ws.kind.clear();
        for i in 0..m {
            let (lo, hi) = (self.lop[i], self.hip[i]);
            let kind = match self.fip[i] {
                Some(n) => {
                    if self.fip[n].is_some() || self.lop[n] != 0.0 {
                        return false;
                    }
                    if hi > lo { RowKind::Friction(n) } else { RowKind::Fixed(0.0) }
                }
                None if lo == hi => RowKind::Fixed(lo),
                None if lo.is_finite() || hi.is_finite() => {
                    RowKind::Box { lower: lo.is_finite(), upper: hi.is_finite() }
                }
                None => RowKind::Free,
            };
            ws.kind.push(kind);
        }
        ws.env.build(&self.ap);
        for v in [&mut ws.zl, &mut ws.zu, &mut ws.sl, &mut ws.su, &mut ws.d, &mut ws.cv] {
            resize(v, m);
        }
        for v in
            [&mut ws.dlam, &mut ws.dsl, &mut ws.dsu, &mut ws.dzl, &mut ws.dzu, &mut ws.aff_l, &mut ws.aff_u]
        {
            resize(v, m);
        }
        ws.cpl.clear();
        ws.cpl.resize(m, None);
        // s₀: the 90th percentile of |b_i| / A_ii.
        ws.ratio.clear();
        for i in 0..m {
            let r = (self.bp[i] / self.ap.get(i, i)).abs();
            if r.is_finite() && r > 0.0 {
                ws.ratio.push(r);
            }
        }
        let s0 = if ws.ratio.is_empty() {
            1.0
        } else {
            let k = (ws.ratio.len() * ws.start.0 / 100).min(ws.ratio.len() - 1);
            *ws.ratio.select_nth_unstable_by(k, f64::total_cmp).1
        };
        for i in 0..m {
            self.lam[i] = match ws.kind[i] {
                RowKind::Box { lower: true, upper: true } => 0.5 * (self.lop[i] + self.hip[i]),
                RowKind::Box { lower: true, upper: false } => self.lop[i] + s0,
                RowKind::Box { lower: false, upper: true } => self.hip[i] - s0,
                RowKind::Fixed(v) => v,
                _ => 0.0,
            };
        }
        self.compute_w();
        let wmax = self.w.iter().fold(f64::MIN_POSITIVE, |a, &x| a.max(x.abs()));
        let zf = self.ipm.start.1;
        let ws = &mut self.ipm;
        for i in 0..m {
            let (has_l, has_u) = ws.kind[i].sides();
            ws.zl[i] = if has_l { self.w[i].max(0.0) + zf * wmax } else { 0.0 };
            ws.zu[i] = if has_u { (-self.w[i]).max(0.0) + zf * wmax } else { 0.0 };
        }
        true
    }

    /// One predictor–corrector iteration from `λ`, `w` (current). `false` when the Newton matrix
    /// could not be factored or the step vanished.
    fn ipm_iteration(&mut self, m: usize) -> bool {
        let ws = &mut self.ipm;
        let lam = &self.lam;
        // Slacks, μ, the Newton matrix's diagonal and couplings.
        let mut gap = 0.0;
        let mut pairs = 0usize;
        for i in 0..m {
            let (sl, su) = ws.kind[i].slacks(lam, i, self.lop[i], self.hip[i]);
            ws.sl[i] = sl;
            ws.su[i] = su;
            let (has_l, has_u) = ws.kind[i].sides();
            let dl = if has_l { ws.zl[i] / sl } else { 0.0 };
            let du = if has_u { ws.zu[i] / su } else { 0.0 };
            gap += if has_l { sl * ws.zl[i] } else { 0.0 } + if has_u { su * ws.zu[i] } else { 0.0 };
            pairs += has_l as usize + has_u as usize;
            ws.d[i] = dl + du;
            ws.cpl[i] = None;
            ws.cv[i] = 0.0;
            match ws.kind[i] {
                RowKind::Friction(n) => {
                    ws.cpl[i] = Some(n);
                    ws.cv[i] = -(dl * self.lop[i] + du * self.hip[i]);
                }
                // Held rows: a diagonal that swamps the row, and a zero right-hand side below.
                RowKind::Fixed(_) => ws.d[i] = 1e12 * self.ap.get(i, i).abs().max(1.0),
                _ => {}
            }
        }
        let mu = gap / pairs.max(1) as f64;
        loop {
            match ws.lu.factor(&ws.env, &self.ap, &ws.d, &ws.cpl, &ws.cv) {
                Ok(()) => break,
                // A friction row not coupled to its normal in `A`'s pattern: an inexact direction.
                Err(LuError::OutsideEnvelope { row, .. }) => {
                    ws.cpl[row] = None;
                    self.stats.ipm_dropped += 1;
                }
                Err(LuError::Pivot { .. }) => return false,
            }
        }
        // Predictor (τ = 0), then the corrector with Mehrotra's centring and second-order term.
        ws.aff_l.fill(0.0);
        ws.aff_u.fill(0.0);
        let a_aff = self.ipm_direction(m, None);
        let ws = &mut self.ipm;
        let mut gap_aff = 0.0;
        for i in 0..m {
            let (has_l, has_u) = ws.kind[i].sides();
            if has_l {
                gap_aff += (ws.sl[i] + a_aff * ws.dsl[i]) * (ws.zl[i] + a_aff * ws.dzl[i]);
                ws.aff_l[i] = ws.dsl[i] * ws.dzl[i];
            }
            if has_u {
                gap_aff += (ws.su[i] + a_aff * ws.dsu[i]) * (ws.zu[i] + a_aff * ws.dzu[i]);
                ws.aff_u[i] = ws.dsu[i] * ws.dzu[i];
            }
        }
        let mu_aff = gap_aff / pairs.max(1) as f64;
        let sigma = if mu > 0.0 { (mu_aff / mu).powi(3).min(1.0) } else { 0.0 };
        let alpha = (TO_BOUNDARY * self.ipm_direction(m, Some(sigma * mu))).min(1.0);
        if alpha.is_nan() || alpha <= 0.0 {
            return false;
        }
        let ws = &mut self.ipm;
        for i in 0..m {
            self.lam[i] += alpha * ws.dlam[i];
            ws.zl[i] += alpha * ws.dzl[i];
            ws.zu[i] += alpha * ws.dzu[i];
            if let RowKind::Fixed(v) = ws.kind[i] {
                self.lam[i] = v;
            }
        }
        self.lam.iter().all(|x| x.is_finite())
    }

    /// Solves for the direction with targets `τ` (`None`: the predictor, `τ = 0`; `Some(σμ)`: the
    /// corrector, which also subtracts the predictor's `Δs Δz`), fills `dlam`, `ds*`, `dz*` and
    /// returns the largest step that keeps every slack and multiplier non-negative.
    fn ipm_direction(&mut self, m: usize, centre: Option<f64>) -> f64 {
        let ws = &mut self.ipm;
        let tau = |aff: f64| centre.map_or(0.0, |c| c - aff);
        for i in 0..m {
            let (has_l, has_u) = ws.kind[i].sides();
            let mut r = -self.w[i];
            if has_l {
                r += tau(ws.aff_l[i]) / ws.sl[i];
            }
            if has_u {
                r -= tau(ws.aff_u[i]) / ws.su[i];
            }
            if let RowKind::Fixed(_) = ws.kind[i] {
                r = 0.0;
            }
            ws.dlam[i] = r;
        }
        ws.lu.solve(&ws.env, &mut ws.dlam);
        let mut alpha = f64::INFINITY;
        for i in 0..m {
            let (has_l, has_u) = ws.kind[i].sides();
            let (dsl, dsu) = ws.kind[i].slack_steps(&ws.dlam, i, self.lop[i], self.hip[i]);
            if has_l {
                let (dz, a) = side_step(tau(ws.aff_l[i]), ws.sl[i], ws.zl[i], dsl);
                (ws.dsl[i], ws.dzl[i]) = (dsl, dz);
                alpha = alpha.min(a);
            } else {
                ws.dzl[i] = 0.0;
            }
            if has_u {
                let (dz, a) = side_step(tau(ws.aff_u[i]), ws.su[i], ws.zu[i], dsu);
                (ws.dsu[i], ws.dzu[i]) = (dsu, dz);
                alpha = alpha.min(a);
            } else {
                ws.dzu[i] = 0.0;
            }
        }
        alpha.min(1.0 / TO_BOUNDARY)
    }

    /// The converged iterate's index set (`s < z`: tight on that side) and frozen bounds.
    fn ipm_finish(&mut self) {
        let m = self.ap.n();
        let ws = &self.ipm;
        for i in 0..m {
            let (sl, su) = ws.kind[i].slacks(&self.lam, i, self.lop[i], self.hip[i]);
            let (has_l, has_u) = ws.kind[i].sides();
            let state = match ws.kind[i] {
                RowKind::Fixed(_) => IndexState::Lower,
                _ if has_l && sl < ws.zl[i] => IndexState::Lower,
                _ if has_u && su < ws.zu[i] => IndexState::Upper,
                _ => IndexState::Free,
            };
            self.state[i] = state;
            self.tight[i] = state.is_tight();
        }
        self.update_bounds();
        self.ws.factor.l_valid = false;
    }
}

impl RowKind {
    /// Whether the row has a lower and an upper constraint.
    fn sides(self) -> (bool, bool) {
        match self {
            RowKind::Box { lower, upper } => (lower, upper),
            RowKind::Friction(_) => (true, true),
            RowKind::Free | RowKind::Fixed(_) => (false, false),
        }
    }

    /// `(s_l, s_u)` at `λ` (1 where the side does not exist).
    fn slacks(self, lam: &[f64], i: usize, lo: f64, hi: f64) -> (f64, f64) {
        match self {
            RowKind::Box { lower, upper } => {
                (if lower { lam[i] - lo } else { 1.0 }, if upper { hi - lam[i] } else { 1.0 })
            }
            RowKind::Friction(n) => (lam[i] - lo * lam[n], hi * lam[n] - lam[i]),
            RowKind::Free | RowKind::Fixed(_) => (1.0, 1.0),
        }
    }

    /// `(Δs_l, Δs_u)` for the step `Δλ`.
    fn slack_steps(self, d: &[f64], i: usize, lo: f64, hi: f64) -> (f64, f64) {
        match self {
            RowKind::Friction(n) => (d[i] - lo * d[n], hi * d[n] - d[i]),
            _ => (d[i], -d[i]),
        }
    }
}

/// One constraint's multiplier step `Δz = (τ − s z − z Δs) / s` for the slack step `Δs`, and the
/// largest step length that keeps `s` and `z` non-negative.
fn side_step(tau: f64, s: f64, z: f64, ds: f64) -> (f64, f64) {
    let dz = (tau - s * z - z * ds) / s;
    (dz, step_to_zero(s, ds).min(step_to_zero(z, dz)))
}

/// Largest `t ≥ 0` with `x + t dx ≥ 0` (∞ when `dx ≥ 0`).
fn step_to_zero(x: f64, dx: f64) -> f64 {
    if dx < 0.0 { -x / dx } else { f64::INFINITY }
}
