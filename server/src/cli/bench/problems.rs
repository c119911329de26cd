//! Stages 3 and 4: every variant on one problem with the paper's step cap and with 1000 steps, and
//! the deletion error (paper Table 4) for the variants that delete.

use std::path::Path;

use indicatif::ProgressBar;
use pivotsim_server::solver::ordering::{self, OrderingWorkspace};
use pivotsim_server::solver::{Mlcp, OrderingKind, SolveStats, SolveStatus, Solver, SolverOptions, Variant};
use serde::Serialize;

use super::plan::{LONG_STEPS, Plan, SHORT_STEPS};
use super::timing::median;

/// One solver configuration on one problem: the timings of the repeats, and the statistics of
/// the last solve as the solver reports them (`SolveStats`, flattened into the same JSON object).
#[derive(Debug, Clone, Serialize)]
pub struct RunRecord {
    pub max_steps: usize,
    /// Median `total_us` over the timed repeats.
    pub time_us: f64,
    /// Every timed repeat (the warm-up solve excluded when there is more than one run).
    pub time_us_samples: Vec<f64>,
    /// `time_us` per pivot step (PGS: per sweep).
    pub us_per_step: Option<f64>,
    /// Whether the repeats disagreed on the step count (should never happen).
    pub nondeterministic: bool,
    /// Copied from the 35-step run (which had converged) instead of run again.
    pub from_short: bool,
    /// The last solve's statistics.
    #[serde(flatten)]
    pub stats: SolveStats,
}

impl RunRecord {
    pub fn from_stats(st: &SolveStats, max_steps: usize, samples: Vec<f64>, nondeterministic: bool) -> Self {
        let mut s = samples.clone();
        let time_us = median(&mut s);
        let steps = if st.variant == Variant::Pgs { st.iterations } else { st.pivot_steps };
        RunRecord {
            max_steps,
            time_us,
            time_us_samples: samples,
            us_per_step: (steps > 0).then(|| time_us / steps as f64),
            nondeterministic,
            from_short: false,
            stats: st.clone(),
        }
    }

    pub fn converged(&self) -> bool {
        self.stats.status == SolveStatus::Converged
    }

    pub fn steps(&self) -> usize {
        self.stats.pivot_steps.max(self.stats.iterations)
    }
}

/// Every measurement of one variant on one problem.
#[derive(Debug, Clone, Serialize)]
pub struct VariantResult {
    pub variant: Variant,
    pub short: RunRecord,
    pub long: Option<RunRecord>,
    pub long_skipped: Option<String>,
    pub deletion_error: Option<f64>,
    pub deletion_error_abs: Option<f64>,
    pub deletion_backward_error: Option<f64>,
    pub deletion_error_skipped: Option<String>,
    /// Regularized pivots in the deletion-error run (a semidefinite `A`; the error is then large).
    pub deletion_run_regularized: usize,
}

/// One problem and its results.
#[derive(Debug, Clone, Serialize)]
pub struct ProblemResult {
    pub name: String,
    /// "generated", "scene" (tests/data/scene-shaped), "siconos" (tests/data/siconos) or "data" (`--data`).
    pub group: String,
    pub path: Option<String>,
    pub seed: Option<u64>,
    pub mass_ratio: Option<f64>,
    pub m: usize,
    pub nnz: usize,
    pub rows_unbounded: usize,
    pub rows_friction: usize,
    pub rows_other: usize,
    pub bandwidth_before: usize,
    pub bandwidth_after: usize,
    pub envelope_before: usize,
    pub envelope_after: usize,
    pub variants: Vec<VariantResult>,
}

impl ProblemResult {
    pub fn variant(&self, v: Variant) -> Option<&VariantResult> {
        self.variants.iter().find(|r| r.variant == v)
    }
}

pub fn options(variant: Variant, max_steps: usize) -> SolverOptions {
    let mut o = SolverOptions { variant, max_steps, ..Default::default() };
    o.pgs.max_iterations = max_steps;
    o.pgs.tol_rel = o.tol_rel;
    o
}

/// A warm-up solve, then `1..=max_repeats` timed solves within `budget_us` (one solve only when the
/// warm-up alone exceeds the budget, `single`).
pub fn timed_solve(
    p: &Mlcp,
    opts: SolverOptions,
    budget_us: f64,
    max_repeats: usize,
    single: bool,
) -> RunRecord {
    let mut solver = Solver::new(opts);
    let mut lambda = vec![0.0; p.n()];
    let first = solver.solve(p, &mut lambda).clone();
    let t1 = first.total_us.max(1.0);
    if single || t1 >= budget_us {
        return RunRecord::from_stats(&first, opts.max_steps, vec![first.total_us], false);
    }
    let reps = ((budget_us / t1).floor() as usize).clamp(1, max_repeats.max(1));
    let mut samples = Vec::with_capacity(reps);
    let mut nondet = false;
    let mut last = first.clone();
    for _ in 0..reps {
        lambda.fill(0.0);
        let st = solver.solve(p, &mut lambda);
        samples.push(st.total_us);
        nondet |= st.pivot_steps != first.pivot_steps || st.iterations != first.iterations;
        last = st.clone();
    }
    RunRecord::from_stats(&last, opts.max_steps, samples, nondet)
}

pub fn run_problem(
    name: String,
    group: &str,
    path: Option<&Path>,
    origin: Option<(u64, f64)>,
    p: &Mlcp,
    plan: &Plan,
    pb: &ProgressBar,
) -> ProblemResult {
    let a = p.a();
    let m = p.n();
    let mut ws = OrderingWorkspace::new();
    let (mut perm, mut inv) = (Vec::new(), Vec::new());
    ws.order(a, OrderingKind::ReverseCuthillMcKee, &mut perm, &mut inv);
    let rows_friction = p.findex().iter().filter(|f| f.is_some()).count();
    let rows_unbounded =
        (0..m).filter(|&i| p.lo()[i] == f64::NEG_INFINITY && p.hi()[i] == f64::INFINITY).count();
    let mut variants = Vec::with_capacity(Variant::ALL.len());
    for v in Variant::ALL {
        pb.set_message(format!("{name} [{v}]"));
        variants.push(run_variant(p, v, plan));
        pb.inc(1);
    }
    measure_deletion_errors(p, plan, &mut variants);
    ProblemResult {
        name,
        group: group.to_string(),
        path: path.map(|p| p.display().to_string()),
        seed: origin.map(|g| g.0),
        mass_ratio: origin.map(|g| g.1),
        m,
        nnz: a.nnz(),
        rows_unbounded,
        rows_friction,
        rows_other: m - rows_unbounded - rows_friction,
        bandwidth_before: ordering::bandwidth(a),
        bandwidth_after: ordering::bandwidth_permuted(a, &inv),
        envelope_before: ordering::envelope(a),
        envelope_after: ordering::envelope_permuted(a, &inv),
        variants,
    }
}

/// Variant `v` on `p` with the paper's step cap, then with 1000 steps (copied when already
/// converged, skipped when predicted over the budget); deletion errors not yet measured.
fn run_variant(p: &Mlcp, v: Variant, plan: &Plan) -> VariantResult {
    let short = timed_solve(p, options(v, SHORT_STEPS), plan.solve_budget_us, plan.solve_max_repeats, false);
    let (long, long_skipped) = if short.converged() {
        let mut l = short.clone();
        l.max_steps = LONG_STEPS;
        l.from_short = true;
        (Some(l), None)
    } else {
        let est = short.time_us * LONG_STEPS as f64 / short.steps().max(1) as f64;
        if est > plan.long_budget_us {
            (None, Some(format!("predicted {:.1} s", est * 1e-6)))
        } else {
            (Some(timed_solve(p, options(v, LONG_STEPS), 0.0, 1, true)), None)
        }
    };
    VariantResult {
        variant: v,
        short,
        long,
        long_skipped,
        deletion_error: None,
        deletion_error_abs: None,
        deletion_backward_error: None,
        deletion_error_skipped: None,
        deletion_run_regularized: 0,
    }
}

/// Deletion error (paper Table 4) for the variants that delete, outside the timings. The
/// measurement refactors at every deletion step: its cost is predicted from the refactoring
/// variants, and skipped over the budget.
fn measure_deletion_errors(p: &Mlcp, plan: &Plan, variants: &mut [VariantResult]) {
    let time_of = |v: Variant, vs: &[VariantResult]| {
        vs.iter().find(|r| r.variant == v).map(|r| r.short.time_us).unwrap_or(0.0)
    };
    for v in [Variant::Downdate, Variant::Skyline, Variant::Auto] {
        let refactor = if v == Variant::Downdate { Variant::Full } else { Variant::SkylineRefactor };
        let est = time_of(v, variants) + 2.0 * time_of(refactor, variants);
        let Some(k) = variants.iter().position(|r| r.variant == v) else { continue };
        if est > plan.long_budget_us {
            variants[k].deletion_error_skipped = Some(format!("predicted {:.1} s", est * 1e-6));
            continue;
        }
        let mut opts = options(v, SHORT_STEPS);
        opts.measure_deletion_error = true;
        let mut solver = Solver::new(opts);
        let mut lambda = vec![0.0; p.n()];
        let st = solver.solve(p, &mut lambda);
        variants[k].deletion_error = st.deletion_error;
        variants[k].deletion_error_abs = st.deletion_error_abs;
        variants[k].deletion_backward_error = st.deletion_backward_error;
        variants[k].deletion_run_regularized = st.regularized;
    }
}
