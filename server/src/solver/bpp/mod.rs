//! Block principal pivoting (Júdice–Pires 1994; paper §3.1–3.3, eq. 4–6, Alg. 1 and 2) with the
//! factor strategies of [`Variant`], a monotone safeguard, friction coupling, an interior point
//! switch and a proximal mode for semidefinite `A`. What was measured and what was tried and
//! dropped is in `docs/notes/solver.md`.
//!
//! **One pivot step.** For the index set `(F, T_lo, T_hi)` set `λ_T` to its bounds and solve
//! `A_FF λ_F = b_F − A_FT λ_T` (eq. 6), then `w = Aλ − b` (eq. 5). A variable is *infeasible* when
//! `i ∈ F` and `λ_i ∉ [lo_i, hi_i]`, `i ∈ T_lo` and `w_i < 0`, or `i ∈ T_hi` and `w_i > 0`; the block
//! pivot moves every infeasible variable to the set eq. 4 names. A block pivot is exactly a full
//! semismooth Newton step on the natural map `r(λ) = λ − clamp(λ − w, lo, hi)`. The sign of `w_i`
//! on a tight row is trusted beyond a per-row rounding scale `1e-13 (|b_i| + ‖A_i‖₁ ‖λ‖∞)`.
//!
//! **Safeguard.** When the number of infeasible variables has not decreased for `murty_after`
//! steps (default 0: at the first block pivot that does not lower it), either Murty's rule pivots
//! only the infeasible variable of largest index (Júdice–Pires: finite for SPD `A` and fixed
//! bounds, [`Fallback::Murty`]), or — the default, [`Fallback::ProjectedNewton`] — a primal
//! feasible active-set method on the strictly convex box QP `min ½λᵀAλ − bᵀλ` whose optimality
//! system the boxed LCP is (`safeguard.rs`): projected Newton steps while they decrease the
//! objective clearly, else exact ratio-test steps to the first blocking bound; every step a pivot
//! step with the same factor reuse, finite, ending on an exact pivot step.
//!
//! **Friction coupling** (the outer loop). Friction bounds `±μ λ_n` move with the normal impulses;
//! pivoting with bounds that change at every step cycles. The bounds are frozen at the current
//! normal impulses and that boxed LCP solved exactly; then, with the settled index set, the exact
//! coupled Newton point in which tight friction rows follow their free normal impulse is taken
//! (`coupled.rs`), globalized by backtracking on the true natural-map residual against a
//! non-monotone reference, the bounds updated from it, and the solve continues from the same
//! index set — with the active-set safeguard ([`SolverOptions::safeguard_after_update`]), its tight
//! rows at their moved bounds. This is Newton's method on the outer fixed point
//! `λ_n ↦ λ_n(bounds(λ_n))`; when it stalls (no 10 % gain of the best residual in 4 updates) the
//! semismooth Newton method on the whole natural map takes over from the best iterate for a budget
//! of steps, after which the outer iteration resumes with block pivots. Every iterate is judged by
//! the natural-map residual against the bounds at its own normal impulses. The outer loop has no
//! proof of convergence, and it can cycle (`docs/notes/solver.md`, "Generated-island sweep").
//!
//! **Interior point switch** (`ipm.rs`, [`SolverOptions::ipm_cold_after`],
//! [`SolverOptions::ipm_after`]): a solve that has not converged after a few pivot steps runs
//! Mehrotra's predictor–corrector on the friction-coupled problem itself, then crosses over to the
//! exact solution of the index set it identifies. A run that fails hands the pivoting back its
//! whole point (λ, index set, frozen bounds, loop progress): the switch costs its own iterations
//! and does not change the pivoting's path. On by default for cold solves with friction.
//!
//! **Semismooth Newton first** ([`SolverOptions::newton_first`], off by default): a warm-started
//! solve with friction first takes up to `NEWTON_FIRST_BUDGET` semismooth Newton steps on the true,
//! moving bounds, leaving early when `‖r‖²` does not halve in `NEWTON_PATIENCE` steps, then block
//! pivots from its warm start.
//!
//! **Safe when capped.** A solve stopped by the step cap or the time budget
//! ([`Solver::set_deadline`], [`SolverOptions::max_solve_us`]) returns its last exact solution with
//! frozen friction bounds when it has one ([`SolverOptions::prefer_frozen`]), else the better of its
//! best iterate and its warm start, each made safe (`safe.rs`: projected onto the feasible set and,
//! when the merit `f = ½λᵀAλ − bᵀλ` is positive, scaled towards zero to `f ≤ 0`), polished by
//! [`SolverOptions::polish_sweeps`] projected Gauss–Seidel sweeps when its residual exceeds
//! [`SolverOptions::polish_above`], and its bilateral rows solved exactly for its contact impulses
//! ([`SolverOptions::exact_bilateral`]).
//!
//! **Semidefinite `A`.** When the factorization has to regularize pivots, the solve switches to
//! proximal point iterations on `A + ρI` (`safeguard.rs`), judged against the original problem.
//!
//! **Factor strategies** (`factor.rs`). `full`: gather and factor the compact `A_FF` each step.
//! `downdate`: dense `L₀ = chol(A)` once, per step copy + deletions (`dense.rs`). `skyline`: reorder
//! (CM/RCM), envelope `L₀`, per step copy of the columns from `g_{min T}` on + deletions on the
//! skyline (`envelope.rs`), each sweep stopping at the last free index and skipping the columns of
//! the tight indices still to be deleted (`chol(A_FF)` is `L₀`'s free block after one rank-1 update
//! per tight column, each rotating through free columns only); when the tight set only grew since
//! the last pivot step, just the new tight indices are deleted from the factor at hand (deletions
//! commute). `skyline-refactor`: envelope factor of `A_FF ⊕ I` per step. `incremental`: keep the
//! last factor and refactor from the first index whose state changed. `auto`: per step the
//! cheapest predicted of deletions from `L₀`, deletions from the last factor (when `T` only grew)
//! and the incremental refactor, from the skyline cost model; `L₀` is factored only when first
//! chosen, its cost counted only as far as this solve's refactors have not yet paid it (ski
//! rental: never worse than twice the better choice in hindsight), and each rotated column of a
//! deletion counts at least `ROTATION_MIN_ENTRIES` entries.

mod coupled;
mod factor;
mod ipm;
mod safe;
mod safeguard;

use safeguard::Start;

use std::time::Instant;

use super::envelope::Envelope;
use super::ordering::{self, OrderingWorkspace};
use super::pgs::{PgsOptions, PgsWorkspace, pgs_solve};
use super::problem::reserve_touched;
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
    /// Time budget (µs): of one solve, or — set by the world — of all island solves of a step. A
    /// solve that spends it returns its best safe iterate with status `Budget` (`None`: no budget).
    pub max_solve_us: Option<f64>,
    /// Block pivots without a decrease of the infeasible count before the safeguard takes over
    /// (0: at the first that does not decrease it; measured in `docs/notes/solver.md`).
    pub murty_after: usize,
    /// Measure `‖L_deleted − chol(A_FF)‖_F` at every deletion step (costly; for Table 4).
    pub measure_deletion_error: bool,
    /// One step of iterative refinement on the final free system.
    pub refine: bool,
    /// Options of the `pgs` variant.
    pub pgs: PgsOptions,
    /// Safeguard when block pivoting stalls.
    pub fallback: Fallback,
    /// When the outer friction iteration stalls, finish with a semismooth Newton method on the
    /// natural map (exact coupled Newton points, backtracking line search).
    pub newton_fallback: bool,
    /// Switch to proximal point iterations when the factorization had to regularize pivots
    /// (semidefinite `A`).
    pub proximal: bool,
    /// Outer friction updates take the exact coupled Newton point of the settled index set (GMRES
    /// preconditioned by the factor) instead of the plain fixed-point update.
    pub coupled_update: bool,
    /// How the exact coupled Newton point is solved (`coupled.rs`): `Some(true)` by one envelope LU
    /// of the coupled matrix, `Some(false)` by GMRES preconditioned with the factor at hand, `None`
    /// (default) by whichever the cost model predicts cheaper. The LU needs an envelope kernel (the
    /// dense kernels of small islands always use GMRES), and a direct point whose residual the LU
    /// (no row exchanges) lost is redone by GMRES either way.
    pub coupled_lu: Option<bool>,
    /// A capped solve returns its last exact frozen-bounds solution when it has one, rather than
    /// the candidate of smallest residual (module docs, "Safe when capped").
    pub prefer_frozen: bool,
    /// A warm-started solve with friction first tries the semismooth Newton method on the true,
    /// moving friction bounds from its warm start (exact coupled points, `NEWTON_FIRST_BUDGET`
    /// steps, left early when it stalls), then the block pivoting from the warm start.
    pub newton_first: bool,
    /// After an outer update of the friction bounds, continue with the active-set safeguard from
    /// the last index set (tight rows at their moved bounds) instead of block pivots.
    pub safeguard_after_update: bool,
    /// Projected Gauss–Seidel sweeps that polish the safe answer of a solve that did not converge
    /// (`safe.rs`); 0 turns the polish off.
    pub polish_sweeps: usize,
    /// Only answers whose relative residual exceeds this are polished (measured: 1e-3).
    pub polish_above: f64,
    /// The answer of a solve that did not converge gets its bilateral rows (joints: unbounded, no
    /// friction index) solved exactly for its contact impulses, those scaled toward zero only as
    /// far as the merit needs (`safe.rs`).
    pub exact_bilateral: bool,
    /// Relative weights of the `auto` cost model: (deleted entry, copied entry, factor multiply–add);
    /// measured on this machine (m = 430, bandwidth 28): 3.0, 0.16 and 1.4 ns per unit.
    pub auto_weights: (f64, f64, f64),
    /// Pivot steps after which a solve that has not converged switches to the interior point
    /// method on the coupled problem (`ipm.rs`), once; `usize::MAX`: never.
    pub ipm_after: usize,
    /// The same switch for a cold solve with friction (no warm `λ`): after this many pivot steps
    /// (default 3: easy problems finish before it; measured in `docs/notes/solver.md`); `usize::MAX`: never.
    pub ipm_cold_after: usize,
    /// Halvings of the step tried along the projection arc `P(λ + t (λ̂ − λ))` when the full
    /// projected Newton step of the active-set safeguard fails its Armijo test (`safeguard.rs`);
    /// 0: only the full step, then the exact ratio-test step. Measured in `safeguard.rs`: the
    /// vehicle's geared, boxed rows want 4, redundant contact sets (forwarder) want 0.
    pub projected_arc: usize,
}

impl Default for SolverOptions {
    fn default() -> Self {
        SolverOptions {
            variant: Variant::Skyline,
            ordering: OrderingKind::ReverseCuthillMcKee,
            max_steps: 35,
            tol_rel: 1e-10,
            max_solve_us: None,
            murty_after: 0,
            measure_deletion_error: false,
            refine: true,
            pgs: PgsOptions::default(),
            fallback: Fallback::ProjectedNewton,
            coupled_update: true,
            coupled_lu: None,
            proximal: true,
            newton_fallback: true,
            auto_weights: (2.15, 0.11, 1.0),
            prefer_frozen: true,
            newton_first: false,
            polish_sweeps: POLISH_SWEEPS,
            polish_above: 1e-3,
            exact_bilateral: true,
            safeguard_after_update: true,
            ipm_after: usize::MAX,
            ipm_cold_after: 3,
            projected_arc: 0,
        }
    }
}

/// What the block pivoting does when the number of infeasible variables stops decreasing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Fallback {
    /// Murty's single pivot on the infeasible variable of largest index (Júdice–Pires): finite for
    /// SPD `A` and fixed bounds, but may need very many steps.
    Murty,
    /// Projected Newton with an Armijo search on the box QP: monotone, finite identification of
    /// the active set, each step a pivot step with the same factor reuse.
    #[default]
    ProjectedNewton,
}

/// Which buffer holds the factor of the current index set.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
enum FactorIn {
    #[default]
    L0,
    L,
    Compact,
}

/// A reusable solver: buffers are sized by the first solve of a given size and reused afterwards
/// (no heap allocation per solve once warm). The large ones — the permuted copy of `A` and its
/// pattern, the factor buffers, the per-row iterates — grow to 1.5× what a solve needs, their
/// memory touched at once (`problem::reserve_touched`), so an island that grows by up to half (a
/// contact onset) neither reallocates them nor page-faults in the middle of a step.
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
    lam_hat: Vec<f64>,
    /// `w` at `lam_hat` (the safeguard's Newton point).
    w_hat: Vec<f64>,
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
    /// `l0` holds `chol(A)` of the current problem (`auto` factors it lazily).
    l0_valid: bool,
    l: Vec<f64>,
    lref: Vec<f64>,
    sigma: Vec<f64>,
    /// Prefix sums of the free columns' lengths (the `auto` cost model of deletions).
    free_sums: Vec<f64>,
    /// Predicted cost of the refactors `auto` chose in this solve (its rent against `L₀`).
    refactor_spent: f64,
    dense_l0: Vec<f64>,
    dense_l: Vec<f64>,
    compact: Vec<f64>,
    free_idx: Vec<usize>,
    pgs_ws: PgsWorkspace,
    out_state: Vec<IndexState>,
    max_diag: f64,
    non_finite: bool,
    best_res: f64,
    kernel: Variant,
    pattern: SymCsr,
    pattern_ordering: Option<OrderingKind>,
    pattern_reused: bool,
    metrics: [usize; 4],
    outer_hist: [f64; OUTER_MEMORY],
    needs_prox: bool,
    prox_shift: f64,
    diag0: Vec<f64>,
    bp0: Vec<f64>,
    center: Vec<f64>,
    prox_best: Vec<f64>,
    last_factor: FactorIn,
    /// Every fixed box (rows without `findex`) contains 0 (`safe.rs`).
    zero_feasible: bool,
    /// The candidate a polish started from (`safe.rs`).
    polish_save: Vec<f64>,
    /// Scratch of `exact_bilateral` (`safe.rs`): the pivoting's tight set, the step `d` and `A d`.
    bil_tight: Vec<bool>,
    bil_d: Vec<f64>,
    bil_ad: Vec<f64>,
    /// `1 / A_ii` of the permuted matrix, for the polish.
    inv_diag: Vec<f64>,
    /// The warm-start index set, permuted (all free without one).
    state0: Vec<IndexState>,
    /// The warm-start `λ₀`, permuted (zero without one): a candidate for a capped solve's answer.
    warm_lam: Vec<f64>,
    /// The last exact solution of the problem with frozen friction bounds, if any (`have_frozen`).
    frozen: Vec<f64>,
    have_frozen: bool,
    /// Position of each row's diagonal in `ap`'s values (per pattern).
    diag_at: Vec<usize>,
    /// The residual `(abs, rel)` the pivoting converged at, set where it returns with `λ` and `w`
    /// still that iterate's (the safe answer then needs no second `w = Aλ − b` and residual).
    converged_at: Option<(f64, f64)>,
    /// Set by `make_safe` when it left `λ` and `w` as they were.
    safe_unchanged: bool,
    /// The solve must stop by then (time budget), if set.
    deadline: Option<Instant>,
    /// The deadline stopped the solve.
    out_of_time: bool,
    /// The deadline of the current solve: `deadline`, or its own budget.
    solve_deadline: Option<Instant>,
    /// Scratch of the interior point method (`ipm.rs`).
    ipm: ipm::IpmWork,
    /// Pivot steps after which this solve switches to the interior point method (`usize::MAX`
    /// once it has, or never).
    ipm_at: usize,
    /// The index set and `λ` the interior point method started from or converged to (`ipm.rs`).
    ipm_state: Vec<IndexState>,
    ipm_lam: Vec<f64>,
    /// The frozen bounds, best residual and loop progress kept with `ipm_state`, `ipm_lam`.
    ipm_lo: Vec<f64>,
    ipm_hi: Vec<f64>,
    ipm_best_res: f64,
    ipm_progress: Progress,
    /// The progress of the last pivoting loop as it stopped.
    progress: Progress,
    /// Scratch of the direct coupled Newton point (`coupled.rs`).
    cpl: coupled::CoupledWork,
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

    /// Sets the time by which the next solves must stop (`None`: only the step cap bounds them).
    /// A solve checks it before every pivot step, so it overruns by at most one step; stopped
    /// there, it returns its best safe iterate with status [`SolveStatus::Budget`].
    pub fn set_deadline(&mut self, deadline: Option<Instant>) {
        self.deadline = deadline;
    }

    /// Whether the solve must stop before another pivot step: the step cap, or the deadline.
    pub(super) fn stop_now(&mut self) -> bool {
        if self.stats.pivot_steps >= self.opts.max_steps || self.stats.pivot_steps >= self.ipm_at {
            return true;
        }
        self.past_deadline()
    }

    /// Whether the solve's deadline has passed (then `out_of_time` is set).
    pub(super) fn past_deadline(&mut self) -> bool {
        if self.solve_deadline.is_some_and(|d| Instant::now() >= d) {
            self.out_of_time = true;
        }
        self.out_of_time
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
        let cpu_start = cpu_time::ThreadTime::try_now().ok();
        let m = p.n();
        let (variant, ordering) = self.kernel_for(m);
        self.stats.reset(self.opts.variant, ordering, m, p.a().nnz());
        if m == 0 || lambda.len() != m {
            self.stats.status = SolveStatus::Empty;
            self.out_state.clear();
            return &self.stats;
        }
        if variant == Variant::Pgs {
            self.solve_pgs(p, lambda);
            // CPU clock read inside the wall clock's interval (read second at the start, first at
            // the end), so that the CPU time never exceeds the wall time by a slow clock read.
            self.stats.cpu_us = cpu_us(cpu_start);
            self.stats.total_us = us(t_start);
            return &self.stats;
        }
        let t = Instant::now();
        self.permute_problem(p, ordering);
        self.stats.ordering_us = us(t);
        self.reset_iterates(m, t_start);
        self.load_warm_start(p);

        // Initial factor.
        let t = Instant::now();
        self.prepare(variant);
        self.stats.factor_us += us(t);

        let has_friction = self.fip.iter().any(Option::is_some);
        let warm = p.lambda0().is_some();
        self.ipm_at = if has_friction && !warm {
            self.opts.ipm_cold_after.min(self.opts.ipm_after)
        } else {
            self.opts.ipm_after
        };
        let mut converged = self.bpp_loop(variant, has_friction, warm || !has_friction);
        let converged_at = if converged { self.converged_at } else { None };
        if !converged && !self.needs_prox && self.ipm_due() {
            converged = self.interior_point_with_crossover(variant, has_friction);
        }
        self.ipm_at = usize::MAX;
        if self.needs_prox {
            converged = self.proximal_solve(variant, has_friction);
        }
        // The answer, made safe: the solution, or else the chosen candidate, polished.
        let t = Instant::now();
        let mut known_residual = None;
        if converged {
            let converged_at = converged_at.filter(|_| !self.needs_prox);
            self.stats.energy_scaled = self.make_safe(converged_at.is_some());
            if self.safe_unchanged {
                // `λ` and `w` are still the pair whose residual ended the loop.
                known_residual = converged_at;
            }
        } else {
            self.choose_capped();
            self.polish();
            self.exact_bilateral();
        }
        self.stats.solve_us += us(t);
        self.report(converged, known_residual, lambda);
        self.stats.cpu_us = cpu_us(cpu_start);
        self.stats.total_us = us(t_start);
        &self.stats
    }

    /// The factor kernel and ordering of an `m`-row solve: `auto` on a tiny island takes the dense
    /// copy-and-delete kernel (the envelope machinery costs more than it saves; measured fastest
    /// below `AUTO_DENSE_MAX` rows); dense kernels keep the input order.
    fn kernel_for(&mut self, m: usize) -> (Variant, OrderingKind) {
        let variant = if self.opts.variant == Variant::Auto && m <= AUTO_DENSE_MAX {
            Variant::Downdate
        } else {
            self.opts.variant
        };
        self.kernel = variant;
        let ordering = if variant.uses_envelope() { self.opts.ordering } else { OrderingKind::Natural };
        (variant, ordering)
    }

    /// Ordering and permuted copy of the problem (`ap`, `bp`, bounds, friction indices, row norms).
    /// An island whose sparsity pattern did not change since the last solve (the common case from
    /// one time step to the next) keeps its ordering, its envelope and their metrics.
    fn permute_problem(&mut self, p: &Mlcp, ordering: OrderingKind) {
        let m = p.n();
        self.pattern_reused = self.pattern_ordering == Some(ordering)
            && self.perm.len() == m
            && self.pattern.same_pattern(p.a());
        if self.pattern_reused {
            self.ap.refresh_permuted_values(p.a());
        } else {
            self.ord_ws.order(p.a(), ordering, &mut self.perm, &mut self.inv);
            self.ap.permuted_from(p.a(), &self.perm, &self.inv);
            self.pattern.copy_pattern_from(p.a());
            self.pattern_ordering = Some(ordering);
            // Where each row's diagonal entry is stored (`usize::MAX`: not stored, i.e. zero).
            self.diag_at.clear();
            for i in 0..m {
                let (cols, _) = self.ap.row(i);
                let at = cols.binary_search(&i).map_or(usize::MAX, |q| self.ap.row_ptr()[i] + q);
                self.diag_at.push(at);
            }
            // From the rows' first and last columns: O(m) each, on the permuted copy just built
            // (the same numbers as `*_permuted` on the input, without their O(nnz) gathers).
            self.metrics = [
                ordering::bandwidth(p.a()),
                ordering::envelope(p.a()),
                ordering::bandwidth(&self.ap),
                ordering::envelope(&self.ap),
            ];
        }
        [
            self.stats.bandwidth_before,
            self.stats.envelope_before,
            self.stats.bandwidth_after,
            self.stats.envelope_after,
        ] = self.metrics;
        self.stats.pattern_reused = self.pattern_reused;
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
        self.zero_feasible =
            (0..m).all(|i| self.fip[i].is_some() || (self.lop[i] <= 0.0 && self.hip[i] >= 0.0));
        let vals = self.ap.values();
        self.max_diag = self.diag_at.iter().filter_map(|&k| vals.get(k)).fold(0.0, |a: f64, &d| a.max(d));
        if m == 0 {
            self.max_diag = 1.0;
        }
    }

    /// Sizes and clears the iterates, index sets and flags of an `m`-row solve, and sets its
    /// deadline: the world's, or the solve's own budget from `t_start`.
    fn reset_iterates(&mut self, m: usize, t_start: Instant) {
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
        self.out_of_time = false;
        self.solve_deadline = self.deadline.or_else(|| {
            let budget = std::time::Duration::try_from_secs_f64(self.opts.max_solve_us? * 1e-6).ok()?;
            t_start.checked_add(budget)
        });
        self.outer_hist = [0.0; OUTER_MEMORY];
        self.needs_prox = false;
        self.converged_at = None;
        self.prox_shift = 0.0;
        resize(&mut self.warm_lam, m);
        resize(&mut self.lam_hat, m);
        resize(&mut self.frozen, m);
        self.have_frozen = false;
    }

    /// The warm start, permuted: `λ₀` (kept as a candidate answer) and the index set, where a
    /// bound state on an infinite bound is read as free.
    fn load_warm_start(&mut self, p: &Mlcp) {
        let m = p.n();
        if let Some(l0) = p.lambda0() {
            for new in 0..m {
                self.lam[new] = l0[self.perm[new]];
            }
            self.warm_lam.copy_from_slice(&self.lam);
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
        // Kept only for the Newton-first attempt, which restores it on failure.
        if self.opts.newton_first {
            self.state0.clear();
            self.state0.extend_from_slice(&self.state);
        }
    }

    /// Residual against the true bounds and status of the answer in `λ`, which it writes into
    /// `lambda` in the problem's row order with its index set.
    /// `known`: that residual when the caller has it.
    fn report(&mut self, converged: bool, known: Option<(f64, f64)>, lambda: &mut [f64]) {
        let m = lambda.len();
        let (res, res_rel) = known
            .unwrap_or_else(|| super::natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip));
        self.stats.residual = res;
        self.stats.residual_rel = res_rel;
        self.stats.status = if converged && (res_rel <= self.opts.tol_rel || res == 0.0) {
            SolveStatus::Converged
        } else if converged {
            SolveStatus::Inexact
        } else if self.non_finite {
            SolveStatus::NonFinite
        } else if self.out_of_time {
            SolveStatus::Budget
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
    }
}

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
    fn pivoting(
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
    fn after_pivot(&mut self, variant: Variant, friction: bool, progress: &mut Progress) -> Next {
        let (res, res_rel) = super::natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
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
    fn note_best(&mut self, rr: f64) {
        if rr.is_finite() && rr < self.best_res {
            self.best_res = rr;
            self.best.copy_from_slice(&self.lam);
        }
    }

    /// The boxed LCP with the frozen bounds is solved exactly (residual `(res, res_rel)` against
    /// the true bounds): done, or a coupled Newton point and an outer update of the friction
    /// bounds, or — bounds consistent — iterative refinement of what rounding left.
    fn at_frozen_solution(
        &mut self,
        variant: Variant,
        friction: bool,
        (res, res_rel): (f64, f64),
        progress: &mut Progress,
    ) -> Next {
        // The answer of a capped solve (module docs, "Safe when capped").
        self.frozen.copy_from_slice(&self.lam);
        self.have_frozen = true;
        if res_rel <= self.opts.tol_rel || res == 0.0 {
            // `w` is the one this residual was computed from.
            self.converged_at = Some((res, res_rel));
            return Next::Return(true);
        }
        if friction && self.opts.coupled_update {
            if let Some(true) = self.coupled_outer_step(res_rel) {
                return Next::Return(true);
            }
            let (_, rr) = super::natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
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
    fn outer_update(&mut self, variant: Variant, progress: &mut Progress) -> Next {
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
            let (_, rr) = super::natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
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

    /// The block pivot on the infeasible variables (eq. 4), or the safeguard when their number
    /// has not decreased for `murty_after` steps.
    fn pivot_infeasible(&mut self, variant: Variant, progress: &mut Progress) -> Next {
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
    fn try_newton_first(&mut self, variant: Variant) -> bool {
        self.compute_w();
        if self.semismooth_newton(variant, NEWTON_FIRST_BUDGET, true) {
            return true;
        }
        self.non_finite = false;
        self.lam.copy_from_slice(&self.warm_lam);
        for i in 0..self.state.len() {
            self.state[i] = self.state0[i];
            self.tight[i] = self.state0[i].is_tight();
        }
        self.compute_w();
        self.update_bounds();
        false
    }

    /// Newton on the outer fixed point, globalized: from the solution `λ*` of the frozen problem
    /// (residual `r*` against its own bounds), take the exact coupled point `λ_c` of the settled
    /// index set and backtrack along `λ* + t (λ_c − λ*)` (`w` is affine in `t`) until the true
    /// natural-map residual drops below `(1 − 10⁻⁴ t) r*`; with no such `t ≥ 1/64` keep `λ*` (the plain
    /// fixed-point update). Leaves the accepted `λ`, `w`. `Some(true)`: `λ` solves the problem;
    /// `None`: nothing was coupled.
    fn coupled_outer_step(&mut self, r_star: f64) -> Option<bool> {
        let m = self.ap.n();
        for v in [&mut self.lam_old, &mut self.w_old, &mut self.lam_hat] {
            resize(v, m);
        }
        self.lam_old.copy_from_slice(&self.lam);
        self.w_old.copy_from_slice(&self.w);
        match self.coupled_newton(self.last_factor) {
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
        let (r, rr) = super::natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
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
            let (_, rt) = super::natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip);
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

    pub(super) fn record_step(&mut self) {
        self.stats.pivot_steps += 1;
        let ntight = self.tight.iter().filter(|&&t| t).count();
        self.stats.tight_per_step.push(ntight as u32);
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

    pub(super) fn solve_pgs(&mut self, p: &Mlcp, lambda: &mut [f64]) {
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

/// Progress of the block pivoting loop: the fewest infeasible variables since the last reset and
/// the steps without a decrease; the best outer residual and the outer updates without a 10 %
/// improvement of it.
#[derive(Debug, Clone, Copy)]
pub(super) struct Progress {
    best_ninf: usize,
    no_progress: usize,
    outer_best: f64,
    outer_stall: usize,
    /// The safeguarded outer iteration and the Newton fallback both stalled: block pivots after
    /// the remaining outer updates.
    block_pivots: bool,
}

impl Default for Progress {
    fn default() -> Self {
        Progress {
            best_ninf: usize::MAX,
            no_progress: 0,
            outer_best: f64::INFINITY,
            outer_stall: 0,
            block_pivots: false,
        }
    }
}

/// What the block pivoting loop does after judging an iterate.
enum Next {
    /// Stop: converged (`true`) or not.
    Return(bool),
    /// Take a pivot step with the (changed) index set.
    Pivot,
    /// `λ` and `w` already solve the current index set (a safeguard ended on an exact step).
    Resolved,
}

/// Outer updates without a 10 % improvement of the best residual before the Newton fallback;
/// with the safeguard after each update (each update then costs more steps) 4 measured best.
const OUTER_STALL: usize = 12;
const OUTER_STALL_SAFEGUARDED: usize = 4;

/// Pivot steps one semismooth-Newton fallback may take before the outer iteration resumes.
const NEWTON_BUDGET: usize = 60;

/// Default [`SolverOptions::polish_sweeps`].
pub const POLISH_SWEEPS: usize = 20;

/// Pivot steps the semismooth Newton method may take first on a warm-started solve.
const NEWTON_FIRST_BUDGET: usize = 12;

/// Largest island that `auto` solves with the dense kernel.
const AUTO_DENSE_MAX: usize = 24;

/// Outer residuals remembered by the non-monotone acceptance of coupled Newton points.
const OUTER_MEMORY: usize = 4;

/// Thread CPU time since `start` in µs (0 without a start: the clock was unavailable).
fn cpu_us(start: Option<cpu_time::ThreadTime>) -> f64 {
    start.and_then(|t| t.try_elapsed().ok()).map_or(0.0, |d| d.as_secs_f64() * 1e6)
}

pub(super) fn us(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e6
}

pub(super) fn resize(v: &mut Vec<f64>, m: usize) {
    reserve_touched(v, m, 0.0);
    v.clear();
    v.resize(m, 0.0);
}

/// `v` sized to `m` without clearing what it holds: for the factor buffers, which every solve
/// writes in full before it reads them (`l0_valid`, `l_valid`; a factor from column 0 writes every
/// stored entry). Zeroing them was three `memset`s of the whole envelope per solve (6 % of the
/// crane's solve instructions).
pub(super) fn size_to(v: &mut Vec<f64>, m: usize) {
    reserve_touched(v, m, 0.0);
    if v.len() < m {
        v.resize(m, 0.0);
    } else {
        v.truncate(m);
    }
}
