//! Block principal pivoting (Júdice–Pires 1994; paper §3.1–3.3, eq. 4–6, Alg. 1 and 2) with the
//! factor strategies of [`Variant`], Murty's single-pivot fallback and friction coupling.
//!
//! **One pivot step.** For the index set `(F, T_lo, T_hi)` set `λ_T` to its bounds and solve
//! `A_FF λ_F = b_F − A_FT λ_T` (eq. 6), then `w = Aλ − b` (eq. 5). A variable is *infeasible* when
//! `i ∈ F` and `λ_i ∉ [lo_i, hi_i]`, `i ∈ T_lo` and `w_i < 0`, or `i ∈ T_hi` and `w_i > 0`; the block
//! pivot moves every infeasible variable to the set eq. 4 names. When the number of infeasible
//! variables has not decreased for `murty_after` steps, Murty's rule pivots only the infeasible
//! variable of largest index until the count drops below its best value again: for SPD `A` and fixed
//! bounds this terminates (Júdice–Pires, Theorem 1). A block pivot is exactly a full semismooth Newton
//! step on the natural map `r(λ) = λ − clamp(λ − w, lo, hi)`; the Murty fallback is its safeguard.
//!
//! **Friction coupling (globalization).** Friction bounds `±μ λ_n` move with the normal impulses;
//! pivoting with bounds that change at every step is not a monotone process and cycles (measured on
//! the paper-like islands in `shared/data/mlcp-scene`). We therefore freeze the bounds at the
//! current normal impulses, run the pivoting above to the exact solution of that boxed LCP (finite,
//! by the theorem), then update the bounds from the new normal impulses and continue from the same
//! index set (an outer fixed-point iteration on `λ_n`, ODE-like but with each inner problem solved
//! exactly). The factor of `A` is computed once and reused by every inner step of every outer
//! iteration, so the reuse keeps paying. Every iterate is judged by the natural-map residual against
//! the bounds at its own normal impulses; the solve stops when that residual meets the tolerance
//! with an unchanged index set, and a solve that hits the step cap returns the iterate with the
//! smallest residual seen.
//!
//! **Factor strategies.** `full`: gather and factor the compact `A_FF` each step. `downdate`: dense
//! `L₀ = chol(A)` once, per step copy + deletions (`dense.rs`). `skyline`: reorder (CM/RCM), envelope
//! `L₀`, per step copy of the columns from `min T` on + deletions on the skyline (`envelope.rs`).
//! `skyline-refactor`: envelope factor of `A_FF ⊕ I` per step. `incremental`: keep the last
//! factor and refactor from the first index whose state changed. `auto`: per step the cheapest
//! predicted of deletions from `L₀`, deletions from the last factor (when `T` only grew) and the
//! incremental refactor, from the skyline cost model.

use std::time::Instant;

use super::dense;
use super::envelope::Envelope;
use super::ordering::{self, OrderingWorkspace};
use super::pgs::{PgsOptions, PgsWorkspace, pgs_solve};
use super::{IndexState, Mlcp, OrderingKind, SolveStats, SolveStatus, SymCsr, Variant, effective_bounds};

/// Options of a [`Solver`].
#[derive(Debug, Clone, Copy)]
pub struct SolverOptions {
    /// Factor strategy.
    pub variant: Variant,
    /// Reordering for the envelope variants (dense variants and PGS keep the input order).
    pub ordering: OrderingKind,
    /// Cap on pivot steps (paper: 35).
    pub max_steps: usize,
    /// Relative natural-map residual at which a solve is converged.
    pub tol_rel: f64,
    /// Steps without a decrease of the infeasible count before Murty's single pivot.
    pub murty_after: usize,
    /// Measure `‖L_deleted − chol(A_FF)‖_F` at every deletion step (costly; for Table 4).
    pub measure_deletion_error: bool,
    /// One step of iterative refinement on the final free system.
    pub refine: bool,
    /// Options of the `pgs` variant.
    pub pgs: PgsOptions,
    /// Treatment of friction coupling.
    pub friction: FrictionStrategy,
    /// Relative weights of the `auto` cost model: (deleted entry, copied entry, factor multiply–add).
    pub auto_weights: (f64, f64, f64),
}

impl Default for SolverOptions {
    fn default() -> Self {
        SolverOptions {
            variant: Variant::Skyline,
            ordering: OrderingKind::ReverseCuthillMcKee,
            max_steps: 35,
            tol_rel: 1e-10,
            murty_after: 3,
            measure_deletion_error: false,
            refine: true,
            pgs: PgsOptions::default(),
            friction: FrictionStrategy::Outer,
            auto_weights: (3.0, 0.25, 1.0),
        }
    }
}

/// How friction bounds that follow the normal impulses are handled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FrictionStrategy {
    /// Freeze the bounds, solve that boxed LCP exactly by block pivoting (Murty fallback), update
    /// the bounds from the new normal impulses, repeat from the same index set.
    #[default]
    Outer,
    /// Semismooth Newton on the natural map with the true bounds: block pivot steps, the exact
    /// coupled Newton point (GMRES preconditioned by the factor) when the merit does not drop,
    /// and a backtracking line search (experimental; see the issue notes for measurements).
    Newton,
}

/// Which buffer holds the factor of the current index set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum FactorIn {
    L0,
    L,
    Compact,
}

/// A reusable solver: buffers are sized by the first solve of a given size and reused afterwards
/// (no heap allocation per solve once warm).
#[derive(Debug, Default)]
pub struct Solver {
    opts: SolverOptions,
    stats: SolveStats,
    ord_ws: OrderingWorkspace,
    perm: Vec<usize>,
    inv: Vec<usize>,
    ap: SymCsr,
    bp: Vec<f64>,
    lop: Vec<f64>,
    hip: Vec<f64>,
    fip: Vec<Option<usize>>,
    lam: Vec<f64>,
    kry_v: Vec<f64>,
    kry_h: Vec<f64>,
    kry_g: Vec<f64>,
    kry_cs: Vec<f64>,
    kry_sn: Vec<f64>,
    kry_z: Vec<f64>,
    lam_old: Vec<f64>,
    w_old: Vec<f64>,
    w: Vec<f64>,
    best: Vec<f64>,
    rhs: Vec<f64>,
    tmp: Vec<f64>,
    lo_eff: Vec<f64>,
    hi_eff: Vec<f64>,
    state: Vec<IndexState>,
    tight: Vec<bool>,
    tight_l: Vec<bool>,
    tmp_tight: Vec<bool>,
    l_valid: bool,
    infeasible: Vec<usize>,
    env: Envelope,
    l0: Vec<f64>,
    l: Vec<f64>,
    lref: Vec<f64>,
    sigma: Vec<f64>,
    dense_l0: Vec<f64>,
    dense_l: Vec<f64>,
    compact: Vec<f64>,
    free_idx: Vec<usize>,
    pgs_ws: PgsWorkspace,
    out_state: Vec<IndexState>,
    max_diag: f64,
    non_finite: bool,
}

impl Solver {
    /// A solver with the given options.
    pub fn new(opts: SolverOptions) -> Self {
        Solver { opts, ..Default::default() }
    }

    /// Current options.
    pub fn options(&self) -> &SolverOptions {
        &self.opts
    }

    /// Changes the options (e.g. the variant, live).
    pub fn set_options(&mut self, opts: SolverOptions) {
        self.opts = opts;
    }

    /// Statistics of the last solve.
    pub fn stats(&self) -> &SolveStats {
        &self.stats
    }

    /// Index set of the last solution, in the problem's row order (warm start for the next solve).
    pub fn index_set(&self) -> &[IndexState] {
        &self.out_state
    }

    /// Solves `p`, writing `λ` (problem row order) into `lambda` (`lambda.len()` must be `m`;
    /// a wrong length is reported as an `Empty` status with no work done).
    pub fn solve(&mut self, p: &Mlcp, lambda: &mut [f64]) -> &SolveStats {
        let t_start = Instant::now();
        let m = p.n();
        let variant = self.opts.variant;
        let ordering = if variant.uses_envelope() { self.opts.ordering } else { OrderingKind::Natural };
        self.stats.reset(variant, ordering, m, p.a().nnz());
        if m == 0 || lambda.len() != m {
            self.stats.status = SolveStatus::Empty;
            self.out_state.clear();
            return &self.stats;
        }
        if variant == Variant::Pgs {
            self.solve_pgs(p, lambda);
            self.stats.total_us = us(t_start);
            return &self.stats;
        }

        // Ordering and permuted copy of the problem.
        let t = Instant::now();
        self.ord_ws.order(p.a(), ordering, &mut self.perm, &mut self.inv);
        self.ap.permuted_from(p.a(), &self.perm, &self.inv);
        self.stats.bandwidth_before = ordering::bandwidth(p.a());
        self.stats.envelope_before = ordering::envelope(p.a());
        self.stats.bandwidth_after = ordering::bandwidth(&self.ap);
        self.stats.envelope_after = ordering::envelope(&self.ap);
        resize(&mut self.bp, m);
        resize(&mut self.lop, m);
        resize(&mut self.hip, m);
        self.fip.clear();
        self.fip.resize(m, None);
        for new in 0..m {
            let old = self.perm[new];
            self.bp[new] = p.b()[old];
            self.lop[new] = p.lo()[old];
            self.hip[new] = p.hi()[old];
            self.fip[new] = p.findex()[old].map(|j| self.inv[j]);
        }
        self.stats.ordering_us = us(t);
        self.max_diag = self.ap.max_diag();

        for v in [&mut self.lam, &mut self.w, &mut self.best, &mut self.rhs, &mut self.tmp] {
            resize(v, m);
        }
        resize(&mut self.lo_eff, m);
        resize(&mut self.hi_eff, m);
        resize(&mut self.sigma, m);
        self.state.clear();
        self.state.resize(m, IndexState::Free);
        self.tight.clear();
        self.tight.resize(m, false);
        self.tight_l.clear();
        self.tight_l.resize(m, false);
        self.l_valid = false;
        self.non_finite = false;
        self.best.fill(0.0);
        if let Some(l0) = p.lambda0() {
            for new in 0..m {
                self.lam[new] = l0[self.perm[new]];
            }
        }
        if let Some(s0) = p.index0() {
            for new in 0..m {
                let s = s0[self.perm[new]];
                let ok = match s {
                    IndexState::Free => true,
                    IndexState::Lower => self.lop[new] > f64::NEG_INFINITY,
                    IndexState::Upper => self.hip[new] < f64::INFINITY,
                };
                self.state[new] = if ok { s } else { IndexState::Free };
                self.tight[new] = self.state[new].is_tight();
            }
        }

        // Initial factor.
        let t = Instant::now();
        self.prepare(variant);
        self.stats.factor_us += us(t);

        let has_friction = self.fip.iter().any(Option::is_some);
        let converged = match (has_friction, self.opts.friction) {
            (true, FrictionStrategy::Newton) => self.ssn_loop(variant, p.lambda0().is_some()),
            (true, FrictionStrategy::Outer) => self.bpp_loop(variant, true, p.lambda0().is_some()),
            (false, _) => self.bpp_loop(variant, false, true),
        };
        if !converged {
            self.lam.copy_from_slice(&self.best);
        }
        // Final report against the true bounds, in the original order.
        let t = Instant::now();
        self.compute_w();
        self.stats.solve_us += us(t);
        let (res, res_rel) = super::natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
        self.stats.residual = res;
        self.stats.residual_rel = res_rel;
        self.stats.status = if converged && (res_rel <= self.opts.tol_rel || res == 0.0) {
            SolveStatus::Converged
        } else if converged {
            SolveStatus::Inexact
        } else if self.non_finite {
            SolveStatus::NonFinite
        } else {
            SolveStatus::MaxSteps
        };
        self.out_state.clear();
        self.out_state.resize(m, IndexState::Free);
        let mut tight_final = 0;
        for new in 0..m {
            let old = self.perm[new];
            lambda[old] = self.lam[new];
            self.out_state[old] = self.state[new];
            tight_final += self.state[new].is_tight() as usize;
        }
        self.stats.tight = tight_final;
        self.stats.total_us = us(t_start);
        &self.stats
    }
}

impl Solver {
    /// Júdice–Pires block pivoting with Murty's fallback for fixed bounds. Returns convergence.
    fn bpp_loop(&mut self, variant: Variant, friction: bool, bounds_known: bool) -> bool {
        self.update_bounds();
        // Without a warm-start λ the friction bounds are frozen at the first (all-free) solve.
        let mut bounds_set = bounds_known;
        let mut best_res = f64::INFINITY;
        let mut best_ninf = usize::MAX;
        let mut no_progress = 0;
        while self.stats.pivot_steps < self.opts.max_steps {
            self.pivot_solve(variant);
            self.record_step();
            if !bounds_set {
                self.update_bounds();
                bounds_set = true;
            }
            let (res, res_rel) = super::natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
            if !res_rel.is_finite() {
                self.non_finite = true;
                return false;
            }
            if res_rel < best_res {
                best_res = res_rel;
                self.best.copy_from_slice(&self.lam);
            }
            self.find_infeasible();
            if self.infeasible.is_empty() {
                // The boxed LCP with these bounds is solved exactly.
                if res_rel <= self.opts.tol_rel || res == 0.0 {
                    return true;
                }
                if friction && self.update_bounds() {
                    // Outer iteration: friction bounds follow the new normal impulses.
                    self.stats.friction_updates += 1;
                    best_ninf = usize::MAX;
                    no_progress = 0;
                    continue;
                }
                // Bounds consistent: what is left is rounding. Iterative refinement.
                if self.opts.refine {
                    self.refine_until_converged(res_rel);
                }
                return true;
            }
            let ninf = self.infeasible.len();
            let murty = if ninf < best_ninf {
                best_ninf = ninf;
                no_progress = 0;
                false
            } else if no_progress < self.opts.murty_after {
                no_progress += 1;
                false
            } else {
                true
            };
            if murty {
                self.stats.fallback = true;
                self.stats.murty_steps += 1;
                let i = *self.infeasible.iter().max().expect("non-empty");
                self.pivot(i);
            } else {
                for k in 0..self.infeasible.len() {
                    let i = self.infeasible[k];
                    self.pivot(i);
                }
            }
        }
        false
    }

    /// Friction-coupled problems: block pivoting globalized as a semismooth Newton method on the
    /// natural map with a backtracking line search (see the module docs). Returns convergence.
    fn ssn_loop(&mut self, variant: Variant, warm_lambda: bool) -> bool {
        let m = self.ap.n();
        for v in [&mut self.lam_old, &mut self.w_old] {
            resize(v, m);
        }
        self.compute_w();
        if warm_lambda && !self.tight.iter().any(|&t| t) {
            self.classify_natural();
        }
        let mut theta = natural_residual_sq(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
        let mut best = f64::INFINITY;
        let mut fresh = !warm_lambda;
        while self.stats.pivot_steps < self.opts.max_steps {
            self.update_bounds();
            self.lam_old.copy_from_slice(&self.lam);
            self.w_old.copy_from_slice(&self.w);
            // Newton point for the current index set with the bounds frozen at λ.
            let which = self.pivot_solve(variant);
            self.record_step();
            let mut theta_full = natural_residual_sq(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
            if !fresh && theta_full > (1.0 - 2e-4) * theta && self.coupled_newton(which) {
                // The frozen-bound point does not decrease the merit: take the exact Newton point.
                self.stats.coupled_steps += 1;
                theta_full = natural_residual_sq(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
            }
            let mut accepted = theta_full;
            if !fresh && theta_full > (1.0 - 2e-4) * theta {
                // Backtrack along λ_old + t (λ̂ − λ_old); w is affine in t, so no matrix products.
                let (mut best_t, mut best_theta) = (1.0, theta_full);
                let mut t = 0.5;
                while t > 1e-3 {
                    for i in 0..m {
                        self.tmp[i] = self.lam_old[i] + t * (self.lam[i] - self.lam_old[i]);
                        self.rhs[i] = self.w_old[i] + t * (self.w[i] - self.w_old[i]);
                    }
                    let th = natural_residual_sq(&self.tmp, &self.rhs, &self.lop, &self.hip, &self.fip);
                    if th < best_theta {
                        best_theta = th;
                        best_t = t;
                    }
                    if th <= (1.0 - 2e-4 * t) * theta {
                        break;
                    }
                    t *= 0.5;
                }
                if best_t < 1.0 && best_theta < theta {
                    self.stats.line_search_steps += 1;
                    for i in 0..m {
                        self.lam[i] = self.lam_old[i] + best_t * (self.lam[i] - self.lam_old[i]);
                        self.w[i] = self.w_old[i] + best_t * (self.w[i] - self.w_old[i]);
                    }
                    accepted = best_theta;
                }
            }
            fresh = false;
            theta = accepted;
            let (res, res_rel) = super::natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
            if !res_rel.is_finite() {
                self.non_finite = true;
                return false;
            }
            if res_rel < best {
                best = res_rel;
                self.best.copy_from_slice(&self.lam);
            }
            if res_rel <= self.opts.tol_rel || res == 0.0 {
                return true;
            }
            let changed = self.classify_natural();
            if !changed && self.opts.refine && self.stats.pivot_steps + 1 < self.opts.max_steps {
                // Same index set and bounds consistent up to rounding: refine and re-check.
                self.update_bounds();
                self.refine_free();
                let (res, res_rel) =
                    super::natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
                theta = natural_residual_sq(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
                if res_rel < best {
                    best = res_rel;
                    self.best.copy_from_slice(&self.lam);
                }
                if res_rel <= self.opts.tol_rel || res == 0.0 {
                    return true;
                }
            }
        }
        false
    }

    /// Index set from the natural map at the current `(λ, w)` and the bounds at `λ`:
    /// `T_lo` where `λ − w ≤ lo(λ)`, `T_hi` where `λ − w ≥ hi(λ)`. Returns whether it changed.
    fn classify_natural(&mut self) -> bool {
        let m = self.ap.n();
        let mut changed = false;
        for i in 0..m {
            let (lo, hi) = effective_bounds(self.lop[i], self.hip[i], self.fip[i], &self.lam);
            let z = self.lam[i] - self.w[i];
            let s = if z <= lo && lo > f64::NEG_INFINITY {
                IndexState::Lower
            } else if z >= hi && hi < f64::INFINITY {
                IndexState::Upper
            } else {
                IndexState::Free
            };
            if s != self.state[i] {
                changed = true;
                self.state[i] = s;
                self.tight[i] = s.is_tight();
            }
        }
        changed
    }

    fn record_step(&mut self) {
        self.stats.pivot_steps += 1;
        let ntight = self.tight.iter().filter(|&&t| t).count();
        self.stats.tight_per_step.push(ntight as u32);
    }

    /// Computes what every later step reuses: the dense `L₀`, the envelope and its `L₀`.
    fn prepare(&mut self, variant: Variant) {
        let m = self.ap.n();
        match variant {
            Variant::Full => {
                self.stats.factor_entries = m * (m + 1) / 2;
            }
            Variant::Downdate => {
                resize(&mut self.dense_l0, m * m);
                self.ap.to_dense(&mut self.dense_l0);
                self.stats.regularized += dense::cholesky_in_place(&mut self.dense_l0, m, self.max_diag);
                resize(&mut self.dense_l, m * m);
                self.stats.factor_entries = m * (m + 1) / 2;
            }
            Variant::Skyline | Variant::SkylineRefactor | Variant::Incremental | Variant::Auto => {
                self.env.build(&self.ap);
                let len = self.env.len();
                self.stats.factor_entries = len;
                resize(&mut self.l, len);
                if matches!(variant, Variant::Skyline | Variant::Auto) {
                    resize(&mut self.l0, len);
                    self.tmp_tight_clear();
                    self.stats.regularized +=
                        self.env.factor_from(&self.ap, &self.tmp_tight, &mut self.l0, 0, self.max_diag);
                }
            }
            Variant::Pgs => {}
        }
        if self.opts.measure_deletion_error {
            let n = if variant == Variant::Downdate { m * m } else { self.env.len() };
            resize(&mut self.lref, n);
        }
    }

    fn tmp_tight_clear(&mut self) {
        self.tmp_tight.clear();
        self.tmp_tight.resize(self.ap.n(), false);
    }

    /// Sets `λ_T` to the frozen bounds, solves eq. 6 with the variant's factor, computes `w`.
    fn pivot_solve(&mut self, variant: Variant) -> FactorIn {
        let m = self.ap.n();
        // λ_T at the bounds; rhs = b − A_{·T} λ_T, zero on T.
        for i in 0..m {
            match self.state[i] {
                IndexState::Free => self.tmp[i] = 0.0,
                IndexState::Lower => {
                    self.lam[i] = self.lo_eff[i];
                    self.tmp[i] = self.lam[i];
                }
                IndexState::Upper => {
                    self.lam[i] = self.hi_eff[i];
                    self.tmp[i] = self.lam[i];
                }
            }
        }
        let t = Instant::now();
        self.ap.mul_vec(&self.tmp, &mut self.rhs);
        for i in 0..m {
            self.rhs[i] = if self.tight[i] { 0.0 } else { self.bp[i] - self.rhs[i] };
        }
        self.stats.solve_us += us(t);

        let which = self.factor_for(variant);

        let t = Instant::now();
        self.solve_with(which);
        for i in 0..m {
            if !self.tight[i] {
                self.lam[i] = self.rhs[i];
            }
        }
        self.compute_w();
        self.stats.solve_us += us(t);
        which
    }

    /// Exact semismooth-Newton point for the current index set when friction rows are tight
    /// against a *free* normal impulse: their value `λ_i = μ_i^± λ_j` moves with `λ_j`, so the
    /// system `(A_FF + A_FT E) λ_F = b_F − A_FT c_T` is not symmetric. Solved by GMRES, right
    /// preconditioned with the factor of `A_FF` already at hand (the preconditioned operator is the
    /// identity plus a term of rank ≤ #coupled rows, so few iterations), starting from the frozen
    /// point in `λ`. Leaves the corrected `λ` and `w`. Returns false when nothing is coupled.
    fn coupled_newton(&mut self, which: FactorIn) -> bool {
        let m = self.ap.n();
        let mut coupled = 0;
        for i in 0..m {
            if let (true, Some(j)) = (self.tight[i], self.fip[i])
                && !self.tight[j]
                && self.lam[j] > 0.0
            {
                coupled += 1;
            }
        }
        if coupled == 0 {
            return false;
        }
        let t0 = Instant::now();
        let restart = GMRES_RESTART.min(m);
        resize(&mut self.kry_v, (restart + 1) * m);
        resize(&mut self.kry_h, (restart + 1) * restart);
        resize(&mut self.kry_g, restart + 1);
        resize(&mut self.kry_cs, restart);
        resize(&mut self.kry_sn, restart);
        resize(&mut self.kry_z, m);
        // Coupled rows follow the current normal impulses.
        self.apply_coupling();
        self.compute_w();
        let mut beta0 = 0.0;
        for cycle in 0..GMRES_CYCLES {
            // r = −w_F (residual of the free rows), zero on T.
            for i in 0..m {
                self.kry_v[i] = if self.tight[i] { 0.0 } else { -self.w[i] };
            }
            let beta = dot(&self.kry_v[..m], &self.kry_v[..m]).sqrt();
            if cycle == 0 {
                beta0 = beta;
            }
            if beta == 0.0 || beta <= GMRES_TOL * beta0 {
                break;
            }
            self.kry_v[..m].iter_mut().for_each(|x| *x /= beta);
            self.kry_g.fill(0.0);
            self.kry_g[0] = beta;
            let mut k_used = 0;
            for k in 0..restart {
                // z = P⁻¹ v_k, then v_{k+1} = B z.
                self.rhs.copy_from_slice(&self.kry_v[k * m..(k + 1) * m]);
                self.solve_with(which);
                self.kry_z.copy_from_slice(&self.rhs);
                self.apply_b();
                // Modified Gram–Schmidt.
                for q in 0..=k {
                    let h = dot(&self.rhs, &self.kry_v[q * m..(q + 1) * m]);
                    self.kry_h[q * restart + k] = h;
                    for (x, &v) in self.rhs.iter_mut().zip(&self.kry_v[q * m..(q + 1) * m]) {
                        *x -= h * v;
                    }
                }
                let hn = dot(&self.rhs, &self.rhs).sqrt();
                self.kry_h[(k + 1) * restart + k] = hn;
                if hn > 0.0 {
                    for (dst, &x) in self.kry_v[(k + 1) * m..(k + 2) * m].iter_mut().zip(&self.rhs) {
                        *dst = x / hn;
                    }
                }
                // Givens rotations on column k.
                for q in 0..k {
                    let (a, b) = (self.kry_h[q * restart + k], self.kry_h[(q + 1) * restart + k]);
                    self.kry_h[q * restart + k] = self.kry_cs[q] * a + self.kry_sn[q] * b;
                    self.kry_h[(q + 1) * restart + k] = -self.kry_sn[q] * a + self.kry_cs[q] * b;
                }
                let (a, b) = (self.kry_h[k * restart + k], self.kry_h[(k + 1) * restart + k]);
                let r = a.hypot(b);
                let (c, sn) = if r == 0.0 { (1.0, 0.0) } else { (a / r, b / r) };
                self.kry_cs[k] = c;
                self.kry_sn[k] = sn;
                self.kry_h[k * restart + k] = r;
                self.kry_h[(k + 1) * restart + k] = 0.0;
                self.kry_g[k + 1] = -sn * self.kry_g[k];
                self.kry_g[k] *= c;
                k_used = k + 1;
                self.stats.krylov_iterations += 1;
                if self.kry_g[k + 1].abs() <= GMRES_TOL * beta0 || hn == 0.0 {
                    break;
                }
            }
            // y = H⁻¹ g (upper triangular), u = V y, λ_F += P⁻¹ u.
            for q in (0..k_used).rev() {
                let mut acc = self.kry_g[q];
                for p in q + 1..k_used {
                    acc -= self.kry_h[q * restart + p] * self.kry_g[p];
                }
                self.kry_g[q] = acc / self.kry_h[q * restart + q];
            }
            self.rhs.fill(0.0);
            for q in 0..k_used {
                let y = self.kry_g[q];
                for (x, &v) in self.rhs.iter_mut().zip(&self.kry_v[q * m..(q + 1) * m]) {
                    *x += y * v;
                }
            }
            self.solve_with(which);
            for i in 0..m {
                if !self.tight[i] {
                    self.lam[i] += self.rhs[i];
                }
            }
            self.apply_coupling();
            self.compute_w();
        }
        self.stats.solve_us += us(t0);
        true
    }

    /// Tight friction rows against a free, positive normal impulse take `μ^± λ_j`.
    fn apply_coupling(&mut self) {
        let m = self.ap.n();
        for i in 0..m {
            if let (true, Some(j)) = (self.tight[i], self.fip[i])
                && !self.tight[j]
            {
                let coef = if self.state[i] == IndexState::Upper { self.hip[i] } else { self.lop[i] };
                self.lam[i] = coef * self.lam[j].max(0.0);
            }
        }
    }

    /// `rhs = (A z̃)_F` where `z̃ = kry_z` on F, `μ^± z_j` on coupled rows and 0 elsewhere on T.
    fn apply_b(&mut self) {
        let m = self.ap.n();
        for i in 0..m {
            if self.tight[i] {
                self.kry_z[i] = 0.0;
            }
        }
        for i in 0..m {
            if let (true, Some(j)) = (self.tight[i], self.fip[i])
                && !self.tight[j]
                && self.lam[j] > 0.0
            {
                let coef = if self.state[i] == IndexState::Upper { self.hip[i] } else { self.lop[i] };
                self.kry_z[i] = coef * self.kry_z[j];
            }
        }
        self.ap.mul_vec(&self.kry_z, &mut self.rhs);
        for i in 0..m {
            if self.tight[i] {
                self.rhs[i] = 0.0;
            }
        }
    }

    /// Brings a factor of `A_FF ⊕ I_TT` for the current `tight` into one of the buffers.
    fn factor_for(&mut self, variant: Variant) -> FactorIn {
        let m = self.ap.n();
        let any_tight = self.tight.iter().any(|&t| t);
        match variant {
            Variant::Full => {
                let t = Instant::now();
                self.free_idx.clear();
                self.free_idx.extend((0..m).filter(|&i| !self.tight[i]));
                let k = self.free_idx.len();
                // Position of each free index in the compact system (reuse `sigma` as a map).
                for (q, &i) in self.free_idx.iter().enumerate() {
                    self.sigma[i] = q as f64;
                }
                resize(&mut self.compact, k * k);
                for (q, &i) in self.free_idx.iter().enumerate() {
                    let (cols, vals) = self.ap.row(i);
                    for (&j, &v) in cols.iter().zip(vals) {
                        if !self.tight[j] {
                            self.compact[q * k + self.sigma[j] as usize] = v;
                        }
                    }
                }
                self.sigma.fill(0.0);
                self.stats.regularized += dense::cholesky_in_place(&mut self.compact, k, self.max_diag);
                self.stats.factor_us += us(t);
                FactorIn::Compact
            }
            Variant::Downdate => {
                if !any_tight {
                    return FactorIn::L0;
                }
                let t = Instant::now();
                self.dense_l.copy_from_slice(&self.dense_l0);
                for i in 0..m {
                    if self.tight[i] {
                        dense::delete_in_place(&mut self.dense_l, m, i, &mut self.sigma);
                        self.stats.deletions += 1;
                    }
                }
                self.sigma.fill(0.0);
                self.stats.downdate_us += us(t);
                self.measure_error(true);
                FactorIn::L
            }
            Variant::Skyline => {
                if !any_tight {
                    return FactorIn::L0;
                }
                self.delete_from_l0();
                FactorIn::L
            }
            Variant::SkylineRefactor => {
                let t = Instant::now();
                self.stats.regularized +=
                    self.env.factor_from(&self.ap, &self.tight, &mut self.l, 0, self.max_diag);
                self.stats.factor_us += us(t);
                FactorIn::L
            }
            Variant::Incremental => {
                self.incremental();
                FactorIn::L
            }
            Variant::Auto => {
                if !any_tight {
                    return FactorIn::L0;
                }
                if self.l_valid && self.tight == self.tight_l {
                    return FactorIn::L;
                }
                let (wd, wc, wf) = self.opts.auto_weights;
                // (a) deletions from L₀.
                let tmin = self.tight.iter().position(|&t| t).unwrap_or(m);
                let del_all: f64 = (0..m).filter(|&i| self.tight[i]).map(|i| self.env.cost_delete(i)).sum();
                let lmin = if self.l_valid { self.tight_l.iter().position(|&t| t).unwrap_or(m) } else { 0 };
                let cost_a =
                    wc * self.env.cost_copy_from(self.env.first_column_of_row(tmin.min(lmin))) + wd * del_all;
                // (b) further deletions from the current factor, when T only grew.
                let grew = self.l_valid && (0..m).all(|i| !self.tight_l[i] || self.tight[i]);
                let cost_b = if grew {
                    wd * (0..m)
                        .filter(|&i| self.tight[i] && !self.tight_l[i])
                        .map(|i| self.env.cost_delete(i))
                        .sum::<f64>()
                } else {
                    f64::INFINITY
                };
                // (c) incremental refactor from the first change (a full refactor when L is stale).
                let c = if self.l_valid {
                    (0..m).position(|i| self.tight[i] != self.tight_l[i]).unwrap_or(m)
                } else {
                    0
                };
                let cost_c = wf * self.env.cost_factor_from(c);
                if cost_b <= cost_a && cost_b <= cost_c {
                    self.stats.auto_choices[1] += 1;
                    let t = Instant::now();
                    for i in 0..m {
                        if self.tight[i] && !self.tight_l[i] {
                            self.env.delete(&mut self.l, i, &mut self.sigma);
                            self.stats.deletions += 1;
                        }
                    }
                    self.tight_l.copy_from_slice(&self.tight);
                    self.stats.downdate_us += us(t);
                    self.measure_error(false);
                } else if cost_a <= cost_c {
                    self.stats.auto_choices[0] += 1;
                    self.delete_from_l0();
                } else {
                    self.stats.auto_choices[2] += 1;
                    self.incremental();
                }
                FactorIn::L
            }
            Variant::Pgs => unreachable!("pgs does not pivot"),
        }
    }

    /// `skyline`: copy the columns of `L₀` from `min T` on, then delete every tight index.
    fn delete_from_l0(&mut self) {
        let m = self.ap.n();
        let t = Instant::now();
        let tmin = self.tight.iter().position(|&t| t).unwrap_or(m);
        if self.l_valid {
            // Deleting i writes columns g_i.. only (row i is zeroed from g_i on), so the columns
            // before g_{min(T ∪ T_L)} are identical in L and L₀.
            let lmin = self.tight_l.iter().position(|&t| t).unwrap_or(m);
            self.env.copy_from_column(&self.l0, &mut self.l, self.env.first_column_of_row(tmin.min(lmin)));
        } else {
            self.env.copy_from_column(&self.l0, &mut self.l, 0);
        }
        for i in tmin..m {
            if self.tight[i] {
                self.env.delete(&mut self.l, i, &mut self.sigma);
                self.stats.deletions += 1;
            }
        }
        self.tight_l.copy_from_slice(&self.tight);
        self.l_valid = true;
        self.stats.downdate_us += us(t);
        self.measure_error(false);
    }

    /// `incremental`: refactor the masked matrix from the first index whose state changed.
    fn incremental(&mut self) {
        let m = self.ap.n();
        let t = Instant::now();
        let c =
            if self.l_valid { (0..m).position(|i| self.tight[i] != self.tight_l[i]).unwrap_or(m) } else { 0 };
        self.stats.regularized += self.env.factor_from(&self.ap, &self.tight, &mut self.l, c, self.max_diag);
        self.tight_l.copy_from_slice(&self.tight);
        self.l_valid = true;
        self.stats.factor_us += us(t);
    }

    /// Deletion error against a refactor from scratch (paper Table 4), outside the timings.
    fn measure_error(&mut self, dense_storage: bool) {
        if !self.opts.measure_deletion_error {
            return;
        }
        let m = self.ap.n();
        let (abs, norm) = if dense_storage {
            // Dense: refactor the masked matrix densely.
            self.ap.to_dense(&mut self.lref);
            for i in 0..m {
                if self.tight[i] {
                    for j in 0..m {
                        self.lref[i * m + j] = 0.0;
                        self.lref[j * m + i] = 0.0;
                    }
                    self.lref[i * m + i] = 1.0;
                }
            }
            dense::cholesky_in_place(&mut self.lref, m, self.max_diag);
            let abs = dense::frobenius_diff(&self.dense_l, &self.lref, m);
            let norm = (0..m)
                .map(|j| self.lref[j * m + j..j * m + m].iter().map(|x| x * x).sum::<f64>())
                .sum::<f64>();
            (abs, norm.sqrt())
        } else {
            self.env.factor_from(&self.ap, &self.tight, &mut self.lref, 0, self.max_diag);
            (self.env.frobenius_diff(&self.l, &self.lref), self.env.frobenius(&self.lref))
        };
        let rel = abs / norm.max(f64::MIN_POSITIVE);
        let cur = self.stats.deletion_error.unwrap_or(0.0);
        self.stats.deletion_error = Some(cur.max(rel));
        let cur = self.stats.deletion_error_abs.unwrap_or(0.0);
        self.stats.deletion_error_abs = Some(cur.max(abs));
    }

    /// Solves in place on `rhs` with the factor held in `which`.
    fn solve_with(&mut self, which: FactorIn) {
        let m = self.ap.n();
        match (self.opts.variant, which) {
            (_, FactorIn::Compact) => {
                let k = self.free_idx.len();
                for (q, &i) in self.free_idx.iter().enumerate() {
                    self.tmp[q] = self.rhs[i];
                }
                dense::solve_in_place(&self.compact, k, &mut self.tmp[..k]);
                for (q, &i) in self.free_idx.iter().enumerate() {
                    self.rhs[i] = self.tmp[q];
                }
            }
            (Variant::Downdate, FactorIn::L0) => dense::solve_in_place(&self.dense_l0, m, &mut self.rhs),
            (Variant::Downdate, FactorIn::L) => dense::solve_in_place(&self.dense_l, m, &mut self.rhs),
            (_, FactorIn::L0) => self.env.solve(&self.l0, &mut self.rhs),
            (_, FactorIn::L) => self.env.solve(&self.l, &mut self.rhs),
        }
    }

    /// `w = Aλ − b` in the permuted order.
    fn compute_w(&mut self) {
        self.ap.mul_vec(&self.lam, &mut self.w);
        for (w, b) in self.w.iter_mut().zip(&self.bp) {
            *w -= b;
        }
    }

    /// Freezes the bounds at the current normal impulses; returns whether any moved.
    fn update_bounds(&mut self) -> bool {
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

    /// Fills `infeasible` with the variables that violate eq. 4 against the frozen bounds.
    fn find_infeasible(&mut self) {
        let m = self.ap.n();
        let lam_scale = self.lam.iter().fold(0.0f64, |a, &x| a.max(x.abs()));
        let b_scale = self.bp.iter().fold(0.0f64, |a, &x| a.max(x.abs()));
        let tol_l = 1e-13 * lam_scale.max(f64::MIN_POSITIVE);
        let tol_w = 1e-13 * b_scale.max(self.max_diag * lam_scale).max(f64::MIN_POSITIVE);
        self.infeasible.clear();
        for i in 0..m {
            let (lo, hi) = (self.lo_eff[i], self.hi_eff[i]);
            let bad = match self.state[i] {
                IndexState::Free => self.lam[i] < lo - tol_l || self.lam[i] > hi + tol_l,
                // A degenerate box (lo = hi) is satisfied by any w.
                IndexState::Lower => lo < hi && self.w[i] < -tol_w,
                IndexState::Upper => lo < hi && self.w[i] > tol_w,
            };
            if bad {
                self.infeasible.push(i);
            }
        }
    }

    /// Moves variable `i` to the set eq. 4 names.
    fn pivot(&mut self, i: usize) {
        let new = match self.state[i] {
            IndexState::Free => {
                if self.lam[i] < self.lo_eff[i] {
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

    /// One step of iterative refinement on the free system `A_FF λ_F = b_F − A_FT λ_T`.
    /// Up to three refinement steps while they reduce the residual (ill-conditioned `A_FF`).
    fn refine_until_converged(&mut self, mut res_rel: f64) {
        for _ in 0..3 {
            if res_rel <= self.opts.tol_rel {
                return;
            }
            self.best.copy_from_slice(&self.lam);
            self.refine_free();
            let (_, r) = super::natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
            if r.is_nan() || r >= res_rel {
                self.lam.copy_from_slice(&self.best);
                self.compute_w();
                return;
            }
            res_rel = r;
        }
    }

    fn refine_free(&mut self) {
        let m = self.ap.n();
        let t = Instant::now();
        // Residual of the free rows: −w_F.
        for i in 0..m {
            self.rhs[i] = if self.tight[i] { 0.0 } else { -self.w[i] };
        }
        let which = match self.opts.variant {
            Variant::Full => FactorIn::Compact,
            Variant::Downdate | Variant::Skyline | Variant::Auto if !self.tight.iter().any(|&t| t) => {
                FactorIn::L0
            }
            _ => FactorIn::L,
        };
        self.solve_with(which);
        for i in 0..m {
            if !self.tight[i] {
                self.lam[i] += self.rhs[i];
            }
        }
        self.compute_w();
        self.stats.solve_us += us(t);
    }

    fn solve_pgs(&mut self, p: &Mlcp, lambda: &mut [f64]) {
        match p.lambda0() {
            Some(l0) => lambda.copy_from_slice(l0),
            None => lambda.fill(0.0),
        }
        let t = Instant::now();
        let info = pgs_solve(p, lambda, &mut self.pgs_ws, &self.opts.pgs);
        self.stats.solve_us = us(t);
        self.stats.iterations = info.iterations;
        self.stats.residual = info.residual;
        self.stats.residual_rel = info.residual_rel;
        self.stats.status = if info.converged { SolveStatus::Converged } else { SolveStatus::MaxSteps };
        // Index set of the PGS iterate, for warm starts and reports.
        let m = p.n();
        self.out_state.clear();
        let mut tight = 0;
        for i in 0..m {
            let (lo, hi) = p.bounds_at(i, lambda);
            let s = if lambda[i] <= lo {
                IndexState::Lower
            } else if lambda[i] >= hi {
                IndexState::Upper
            } else {
                IndexState::Free
            };
            tight += s.is_tight() as usize;
            self.out_state.push(s);
        }
        self.stats.tight = tight;
    }
}

/// `‖r(λ)‖₂²` of the natural map with bounds at `λ` (the line-search merit).
fn natural_residual_sq(lambda: &[f64], w: &[f64], lo: &[f64], hi: &[f64], findex: &[Option<usize>]) -> f64 {
    let mut acc = 0.0;
    for i in 0..lambda.len() {
        let (l, h) = effective_bounds(lo[i], hi[i], findex[i], lambda);
        let r = lambda[i] - (lambda[i] - w[i]).max(l).min(h);
        acc += r * r;
    }
    if acc.is_nan() { f64::INFINITY } else { acc }
}

const GMRES_RESTART: usize = 30;
const GMRES_CYCLES: usize = 3;
const GMRES_TOL: f64 = 1e-12;

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn us(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e6
}

fn resize(v: &mut Vec<f64>, m: usize) {
    v.clear();
    v.resize(m, 0.0);
}
