//! Stage 2, on the islands the `auto` run of each scene dumped (each with the warm start the
//! simulation gave it): condition numbers (Table 2), deletion errors (Table 4), the sparsity of the
//! largest island (Fig. 5/6) and the trade of residual against time, PGS against block pivoting.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use indicatif::ProgressBar;
use nalgebra::{DMatrix, SymmetricEigen};
use pivotsim_server::solver::{Mlcp, OrderingKind, Solver, SolverOptions, Variant, io};
use serde::Serialize;

use super::Plan;
use super::scenes::SceneResult;
use super::spread::Spread;

/// One point of a trade curve: the median over the islands of time and relative residual.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct TradePoint {
    /// Sweeps (PGS) or the step cap (block pivoting).
    pub budget: usize,
    /// Median wall time of a solve (µs).
    pub time_us: f64,
    /// Median relative natural-map residual against the true bounds.
    pub residual_rel: f64,
}

/// One method's curve.
#[derive(Debug, Clone, Serialize)]
pub struct TradeCurve {
    /// `pgs warm`, `pgs cold`, `bpp (auto) warm`.
    pub method: String,
    /// Points by budget.
    pub points: Vec<TradePoint>,
}

/// Stage 2 of one scene.
#[derive(Debug, Clone, Serialize)]
pub struct IslandsResult {
    /// Scene name.
    pub scene: String,
    /// Islands analysed.
    pub islands: usize,
    /// Rows of the largest.
    pub largest_rows: usize,
    /// Condition number of `A` of the largest island (dense symmetric eigenvalues).
    pub condition: Option<f64>,
    /// Largest condition number over the analysed islands.
    pub max_condition: Option<f64>,
    /// Deletion error `‖L_deleted − chol(A_FF)‖_F` per solve (cold), without the skyline (`downdate`).
    pub deletion_dense: Option<Spread>,
    /// The same with the skyline (`skyline`).
    pub deletion_skyline: Option<Spread>,
    /// Residual against time.
    pub trade: Vec<TradeCurve>,
    /// The sparsity figure of the largest island, if written.
    pub sparsity_figure: Option<String>,
    /// The paper's tight-rows-last ordering against RCM on the warm-started islands.
    pub tight_last: Vec<super::tight_last::TightLast>,
}

/// Runs stage 2 for every scene.
pub fn run(
    plan: &Plan,
    out: &Path,
    scenes: &[SceneResult],
    pb: &ProgressBar,
) -> anyhow::Result<Vec<IslandsResult>> {
    let mut results = Vec::new();
    for s in scenes {
        pb.set_message(format!("{}: islands", s.scene));
        let files = pick(&s.dump_dir, plan.islands)?;
        let problems: Vec<Mlcp> = files
            .iter()
            .map(|f| io::read_mlcp_file(f).with_context(|| format!("{}", f.display())))
            .collect::<anyhow::Result<_>>()?;
        results.push(analyse(plan, out, &s.scene, &s.dump_dir, &problems)?);
        pb.inc(1);
    }
    Ok(results)
}

/// Up to `n` dumped islands spread evenly over the run, plus the largest.
fn pick(dir: &Path, n: usize) -> anyhow::Result<Vec<PathBuf>> {
    let mut all: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot read {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "txt"))
        .collect();
    all.sort();
    if all.len() <= n {
        return Ok(all);
    }
    let mut out: Vec<PathBuf> = (0..n).map(|k| all[k * all.len() / n].clone()).collect();
    let largest = all.iter().max_by_key(|p| std::fs::metadata(p).map(|m| m.len()).unwrap_or(0)).cloned();
    if let Some(l) = largest
        && !out.contains(&l)
    {
        out.push(l);
    }
    Ok(out)
}

fn analyse(
    plan: &Plan,
    out: &Path,
    scene: &str,
    _dir: &Path,
    problems: &[Mlcp],
) -> anyhow::Result<IslandsResult> {
    let largest = problems.iter().max_by_key(|p| p.n());
    // Deletions happen when pivoting: warm-started islands mostly need none, so Table 4 solves cold.
    let colds: Vec<Mlcp> = problems.iter().map(Mlcp::without_warm_start).collect();
    let conds: Vec<f64> = problems.iter().filter_map(condition).collect();
    let mut sparsity_figure = None;
    if let Some(p) = largest {
        let name = format!("fig5_sparsity_{scene}.svg");
        super::super::pattern::sparsity_svg(&out.join(&name), p.a(), OrderingKind::ReverseCuthillMcKee)?;
        sparsity_figure = Some(name);
    }
    Ok(IslandsResult {
        scene: scene.to_string(),
        islands: problems.len(),
        largest_rows: largest.map_or(0, |p| p.n()),
        condition: largest.and_then(condition),
        max_condition: conds.iter().copied().reduce(f64::max),
        deletion_dense: deletion_errors(&colds, Variant::Downdate),
        deletion_skyline: deletion_errors(&colds, Variant::Skyline),
        trade: trade(plan, problems),
        sparsity_figure,
        tight_last: super::tight_last::run(scene, problems, plan.repeats),
    })
}

/// `λ_max / λ_min` of `A` (dense symmetric eigenvalues; `None` when not positive definite).
fn condition(p: &Mlcp) -> Option<f64> {
    let m = p.n();
    let mut dense = vec![0.0; m * m];
    p.a().to_dense(&mut dense);
    let eig = SymmetricEigen::new(DMatrix::from_column_slice(m, m, &dense)).eigenvalues;
    let (lo, hi) = eig.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &e| (lo.min(e), hi.max(e)));
    (lo > 0.0).then(|| hi / lo)
}

/// The deletion error of every solve of `problems` with `variant` (35-step cap).
fn deletion_errors(problems: &[Mlcp], variant: Variant) -> Option<Spread> {
    let mut solver =
        Solver::new(SolverOptions { variant, measure_deletion_error: true, ..SolverOptions::default() });
    let mut errs = Vec::new();
    for p in problems {
        let mut lambda = vec![0.0; p.n()];
        if let Some(e) = solver.solve(p, &mut lambda).deletion_error_abs {
            errs.push(e);
        }
    }
    Spread::of(errs)
}

/// Residual against time on `problems`: PGS with 1…1000 sweeps and block pivoting (`auto`) with
/// caps 1…35, each from the warm start and cold.
fn trade(plan: &Plan, problems: &[Mlcp]) -> Vec<TradeCurve> {
    let colds: Vec<Mlcp> = problems.iter().map(Mlcp::without_warm_start).collect();
    let mut curves = Vec::new();
    for (method, set, budgets, pgs) in [
        ("pgs warm", problems, &plan.pgs_sweeps, true),
        ("pgs cold", &colds[..], &plan.pgs_sweeps, true),
        ("bpp (auto) warm", problems, &plan.bpp_caps, false),
        ("bpp (auto) cold", &colds[..], &plan.bpp_caps, false),
    ] {
        let mut points = Vec::new();
        for &budget in budgets {
            let mut opts = SolverOptions {
                variant: if pgs { Variant::Pgs } else { Variant::Auto },
                max_steps: budget,
                ..SolverOptions::default()
            };
            opts.pgs.max_iterations = budget;
            // Every sweep runs: the curve is residual after k sweeps, not time to a tolerance.
            opts.pgs.tol_rel = 0.0;
            let mut solver = Solver::new(opts);
            let (mut times, mut res) = (Vec::new(), Vec::new());
            for p in set {
                let mut lambda = vec![0.0; p.n()];
                let mut best = f64::INFINITY;
                let mut rr = f64::NAN;
                for _ in 0..plan.repeats.max(1) {
                    let t = Instant::now();
                    let st = solver.solve(p, &mut lambda);
                    best = best.min(t.elapsed().as_secs_f64() * 1e6);
                    rr = st.residual_rel;
                }
                times.push(best);
                res.push(rr);
            }
            if let (Some(t), Some(r)) = (Spread::of(times), Spread::of(res)) {
                points.push(TradePoint { budget, time_us: t.median, residual_rel: r.median });
            }
        }
        curves.push(TradeCurve { method: method.to_string(), points });
    }
    curves
}
