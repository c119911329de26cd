//! The solver's entry: the [`Solver`] with its buffers, one solve from the permuted problem to the
//! reported answer (`Solver::solve`), the warm start, the PGS variant and the buffer helpers.

use std::time::Instant;

use super::super::ordering;
use super::super::pgs::{PgsWorkspace, pgs_solve};
use super::super::problem::reserve_touched;
use super::super::{
    IndexState, Mlcp, OrderingKind, SolveStats, SolveStatus, SymCsr, Variant, natural_residual,
};
use super::options::SolverOptions;
pub(super) use super::workspace::FactorIn;
use super::workspace::{CoupledWork, IpmWork, OUTER_MEMORY, Progress, Workspace};

/// A reusable solver: buffers are sized by the first solve of a given size and reused afterwards
/// (no heap allocation per solve once warm). The large ones — the permuted copy of `A` and its
/// pattern, the factor buffers, the per-row iterates — grow to 1.5× what a solve needs, their
/// memory touched at once (`problem::reserve_touched`), so an island that grows by up to half (a
/// contact onset) neither reallocates them nor page-faults in the middle of a step.
#[derive(Debug, Default)]
pub struct Solver {
    pub(super) opts: SolverOptions,
    pub(super) stats: SolveStats,
    pub(super) ap: SymCsr,
    pub(super) bp: Vec<f64>,
    pub(super) lop: Vec<f64>,
    pub(super) hip: Vec<f64>,
    pub(super) fip: Vec<Option<usize>>,
    pub(super) lam: Vec<f64>,
    pub(super) lam_old: Vec<f64>,
    pub(super) lam_hat: Vec<f64>,
    /// `w` at `lam_hat` (the safeguard's Newton point).
    pub(super) w_hat: Vec<f64>,
    pub(super) w_old: Vec<f64>,
    pub(super) w: Vec<f64>,
    pub(super) best: Vec<f64>,
    pub(super) rhs: Vec<f64>,
    pub(super) tmp: Vec<f64>,
    pub(super) lo_eff: Vec<f64>,
    pub(super) hi_eff: Vec<f64>,
    pub(super) state: Vec<IndexState>,
    pub(super) tight: Vec<bool>,
    pub(super) infeasible: Vec<usize>,
    pub(super) pgs_ws: PgsWorkspace,
    pub(super) out_state: Vec<IndexState>,
    pub(super) max_diag: f64,
    pub(super) non_finite: bool,
    pub(super) best_res: f64,
    pub(super) kernel: Variant,
    pub(super) outer_hist: [f64; OUTER_MEMORY],
    pub(super) needs_prox: bool,
    pub(super) prox_shift: f64,
    /// Inside the proximal outer iteration (`outer.rs`).
    pub(super) in_prox_outer: bool,
    /// The residual `(abs, rel)` the pivoting converged at, set where it returns with `λ` and `w`
    /// still that iterate's (the safe answer then needs no second `w = Aλ − b` and residual).
    pub(super) converged_at: Option<(f64, f64)>,
    /// Set by `make_safe` when it left `λ` and `w` as they were.
    pub(super) safe_unchanged: bool,
    /// The solve must stop by then (time budget), if set.
    pub(super) deadline: Option<Instant>,
    /// The deadline stopped the solve.
    pub(super) out_of_time: bool,
    /// The deadline of the current solve: `deadline`, or its own budget.
    pub(super) solve_deadline: Option<Instant>,
    /// Scratch of the interior point method (`ipm.rs`).
    pub(super) ipm: IpmWork,
    /// Pivot steps after which this solve switches to the interior point method (`usize::MAX`
    /// once it has, or never).
    pub(super) ipm_at: usize,
    /// The progress of the last pivoting loop as it stopped.
    pub(super) progress: Progress,
    /// Scratch of the direct coupled Newton point (`coupled.rs`).
    pub(super) cpl: CoupledWork,
    /// The scratch, by stage.
    pub(super) ws: Workspace,
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

    /// Forgets what the cost model learned from this solver's earlier solves (the recent GMRES
    /// iterations per coupled point and the share of rejected direct points, `coupled.rs`), which
    /// decide between GMRES and the LU: the next solve is then the one a new solver would do, bit
    /// for bit, with the buffers kept (`solve --repeats` times the same solve this way). A
    /// simulation keeps the memory from step to step: a replay from a snapshot is bit-exact only
    /// if the snapshot is taken where the memory is too (see [`Solver::cost_memory`]).
    pub fn forget_history(&mut self) {
        self.cpl.gmres_iters = 0.0;
        self.cpl.lu_rejects = 0.0;
    }

    /// The cost model's memory of earlier solves: (recent GMRES iterations per coupled point,
    /// recent share of rejected direct points). It decides the method of later coupled points,
    /// so it is part of the state a bit-exact replay restores ([`Solver::set_cost_memory`]).
    pub fn cost_memory(&self) -> (f64, f64) {
        (self.cpl.gmres_iters, self.cpl.lu_rejects)
    }

    /// Restores the memory [`Solver::cost_memory`] returned.
    pub fn set_cost_memory(&mut self, memory: (f64, f64)) {
        (self.cpl.gmres_iters, self.cpl.lu_rejects) = memory;
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
    pub(super) fn kernel_for(&mut self, m: usize) -> (Variant, OrderingKind) {
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
    pub(super) fn permute_problem(&mut self, p: &Mlcp, ordering: OrderingKind) {
        let m = p.n();
        self.ws.permuted.pattern_reused = self.ws.permuted.pattern_ordering == Some(ordering)
            && self.ws.permuted.perm.len() == m
            && self.ws.permuted.pattern.same_pattern(p.a());
        if self.ws.permuted.pattern_reused {
            self.ap.refresh_permuted_values(p.a());
        } else {
            self.ws.permuted.ord_ws.order(
                p.a(),
                ordering,
                &mut self.ws.permuted.perm,
                &mut self.ws.permuted.inv,
            );
            self.ap.permuted_from(p.a(), &self.ws.permuted.perm, &self.ws.permuted.inv);
            self.ws.permuted.pattern.copy_pattern_from(p.a());
            self.ws.permuted.pattern_ordering = Some(ordering);
            // Where each row's diagonal entry is stored (`usize::MAX`: not stored, i.e. zero).
            self.ws.permuted.diag_at.clear();
            for i in 0..m {
                let (cols, _) = self.ap.row(i);
                let at = cols.binary_search(&i).map_or(usize::MAX, |q| self.ap.row_ptr()[i] + q);
                self.ws.permuted.diag_at.push(at);
            }
            // From the rows' first and last columns: O(m) each, on the permuted copy just built
            // (the same numbers as `*_permuted` on the input, without their O(nnz) gathers).
            self.ws.permuted.metrics = [
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
        ] = self.ws.permuted.metrics;
        self.stats.pattern_reused = self.ws.permuted.pattern_reused;
        resize(&mut self.bp, m);
        resize(&mut self.lop, m);
        resize(&mut self.hip, m);
        self.fip.clear();
        self.fip.resize(m, None);
        for new in 0..m {
            let old = self.ws.permuted.perm[new];
            self.bp[new] = p.b()[old];
            self.lop[new] = p.lo()[old];
            self.hip[new] = p.hi()[old];
            self.fip[new] = p.findex()[old].map(|j| self.ws.permuted.inv[j]);
        }
        self.ws.safe.zero_feasible =
            (0..m).all(|i| self.fip[i].is_some() || (self.lop[i] <= 0.0 && self.hip[i] >= 0.0));
        let vals = self.ap.values();
        self.max_diag =
            self.ws.permuted.diag_at.iter().filter_map(|&k| vals.get(k)).fold(0.0, |a: f64, &d| a.max(d));
        if m == 0 {
            self.max_diag = 1.0;
        }
    }

    /// Sizes and clears the iterates, index sets and flags of an `m`-row solve, and sets its
    /// deadline: the world's, or the solve's own budget from `t_start`.
    pub(super) fn reset_iterates(&mut self, m: usize, t_start: Instant) {
        for v in [&mut self.lam, &mut self.w, &mut self.best, &mut self.rhs, &mut self.tmp] {
            resize(v, m);
        }
        resize(&mut self.lo_eff, m);
        resize(&mut self.hi_eff, m);
        resize(&mut self.ws.factor.sigma, m);
        self.state.clear();
        self.state.resize(m, IndexState::Free);
        self.tight.clear();
        self.tight.resize(m, false);
        self.ws.factor.tight_l.clear();
        self.ws.factor.tight_l.resize(m, false);
        self.ws.factor.l_valid = false;
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
        self.in_prox_outer = false;
        resize(&mut self.ws.safe.warm_lam, m);
        resize(&mut self.lam_hat, m);
        resize(&mut self.ws.safe.frozen, m);
        self.ws.safe.have_frozen = false;
    }

    /// The warm start, permuted: `λ₀` (kept as a candidate answer) and the index set, where a
    /// bound state on an infinite bound is read as free.
    pub(super) fn load_warm_start(&mut self, p: &Mlcp) {
        let m = p.n();
        if let Some(l0) = p.lambda0() {
            for new in 0..m {
                self.lam[new] = l0[self.ws.permuted.perm[new]];
            }
            self.ws.safe.warm_lam.copy_from_slice(&self.lam);
        }
        if let Some(s0) = p.index0() {
            for new in 0..m {
                let s = s0[self.ws.permuted.perm[new]];
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
            self.ws.safe.state0.clear();
            self.ws.safe.state0.extend_from_slice(&self.state);
        }
    }

    /// Residual against the true bounds and status of the answer in `λ`, which it writes into
    /// `lambda` in the problem's row order with its index set.
    /// `known`: that residual when the caller has it.
    pub(super) fn report(&mut self, converged: bool, known: Option<(f64, f64)>, lambda: &mut [f64]) {
        let m = lambda.len();
        let (res, res_rel) =
            known.unwrap_or_else(|| natural_residual(&self.lam, &self.w, &self.lop, &self.hip, &self.fip));
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
            let old = self.ws.permuted.perm[new];
            lambda[old] = self.lam[new];
            self.out_state[old] = self.state[new];
            tight_final += self.state[new].is_tight() as usize;
        }
        self.stats.tight = tight_final;
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

/// Largest island that `auto` solves with the dense kernel.
const AUTO_DENSE_MAX: usize = 24;

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
