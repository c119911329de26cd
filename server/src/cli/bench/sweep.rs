//! `bench-solver --sweep N`: the generated-island sweep of `tests/solver_sweep.rs` at scale.
//!
//! Islands `SEED0 + k`, `k < N`, of `solver::generate::sweep_island` (50–1,000 rows, mass ratio
//! 1e1–1e9, compliance 1e-12–1e-6, μ 0.3–1); island `k` is solved by the exact variant `k mod 6`
//! of `Variant::EXACT`, cold and then from the perturbed warm start of its cold answer
//! (`generate::perturbed_warm_start`), with a cap of 1,000 pivot steps. Each answer is judged by
//! the natural-map residual recomputed from the problem (`Mlcp::natural_residual`), not by the
//! solver's statistics. Writes `sweep.json` (counts per variant and start, step quantiles and the
//! worst cases by residual and by steps, each with its seed and parameters) and prints a summary.

use std::path::Path;
use std::time::Instant;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use pivotsim_server::solver::generate::{IslandParams, perturbed_warm_start, sweep_island};
use pivotsim_server::solver::{Mlcp, Solver, SolverOptions, Variant};
use serde::Serialize;

/// Seed of island 0 (apart from the test's islands, which start at 31,000).
const SEED0: u64 = 1_000_000;
/// Pivot-step cap of every solve.
const MAX_STEPS: usize = 1_000;
/// A solve converged when its recomputed relative residual is at most this.
const TOL: f64 = 1e-9;
/// Worst cases kept per list.
const WORST: usize = 20;

/// One solve of the sweep.
#[derive(Debug, Clone, Serialize)]
pub struct SweepSolve {
    /// Island index and seed (`sweep_island(seed)` rebuilds it).
    pub island: usize,
    /// The seed.
    pub seed: u64,
    /// Rows.
    pub m: usize,
    /// Mass ratio, compliance and μ of the island.
    pub mass_ratio: f64,
    /// Contact compliance.
    pub compliance: f64,
    /// Friction coefficient.
    pub mu: f64,
    /// Variant name.
    pub variant: &'static str,
    /// `cold` or `warm`.
    pub start: &'static str,
    /// Solver status name.
    pub status: &'static str,
    /// Pivot steps.
    pub steps: usize,
    /// Recomputed relative natural-map residual.
    pub residual_rel: f64,
    /// Wall time of the solve, ms.
    pub ms: f64,
}

impl SweepSolve {
    /// Within the tolerance by the recomputed residual (the step cap bounds every solve), whatever
    /// the status says.
    fn ok(&self) -> bool {
        self.residual_rel <= TOL
    }
}

/// Counts of one variant and start.
#[derive(Debug, Clone, Default, Serialize)]
pub struct SweepCount {
    /// Variant name.
    pub variant: String,
    /// `cold` or `warm`.
    pub start: String,
    /// Solves.
    pub solves: usize,
    /// Solves that did not converge to `TOL` within `MAX_STEPS`.
    pub failed: usize,
    /// Median, 99th percentile and largest pivot step count.
    pub steps_p50: usize,
    /// 99th percentile of the pivot steps.
    pub steps_p99: usize,
    /// Largest pivot step count.
    pub steps_max: usize,
}

/// The `sweep.json` document.
#[derive(Debug, Clone, Serialize)]
pub struct SweepReport {
    /// Islands swept.
    pub islands: usize,
    /// Seed of island 0.
    pub seed0: u64,
    /// Step cap and tolerance of every solve.
    pub max_steps: usize,
    /// Residual tolerance.
    pub tol: f64,
    /// Solves and failed solves in all.
    pub solves: usize,
    /// Failed solves in all.
    pub failed: usize,
    /// Islands with at least one failed solve.
    pub failed_islands: usize,
    /// Wall time of the sweep, s.
    pub elapsed_s: f64,
    /// Counts per variant and start.
    pub counts: Vec<SweepCount>,
    /// The solves of largest residual.
    pub worst_residual: Vec<SweepSolve>,
    /// The solves of most pivot steps.
    pub worst_steps: Vec<SweepSolve>,
}

/// Runs the sweep over `islands` islands and writes `sweep.json` into `out`.
pub fn run(islands: usize, out: &Path) -> anyhow::Result<SweepReport> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let t0 = Instant::now();
    let pb = ProgressBar::new(islands as u64);
    pb.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} islands, {msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let mut solves: Vec<SweepSolve> = Vec::with_capacity(2 * islands);
    let mut failed = 0usize;
    for k in 0..islands {
        let seed = SEED0 + k as u64;
        let variant = Variant::EXACT[k % Variant::EXACT.len()];
        let (params, mut p) = sweep_island(seed);
        let mut solver = Solver::new(SolverOptions { variant, max_steps: MAX_STEPS, ..Default::default() });
        let mut lam = vec![0.0; p.n()];
        let cold = solve_one(&mut solver, &p, &mut lam, (k, seed, &params, variant, "cold"));
        let (lam0, index0) = perturbed_warm_start(&lam, solver.index_set(), seed);
        p.set_warm_start(Some(&lam0), Some(&index0)).context("perturbed warm start")?;
        let warm = solve_one(&mut solver, &p, &mut lam, (k, seed, &params, variant, "warm"));
        failed += usize::from(!cold.ok()) + usize::from(!warm.ok());
        solves.push(cold);
        solves.push(warm);
        pb.set_message(format!("{failed} failed"));
        pb.inc(1);
    }
    pb.finish_and_clear();
    let report = summarize(islands, solves, t0.elapsed().as_secs_f64());
    let path = out.join("sweep.json");
    std::fs::write(&path, serde_json::to_string_pretty(&report)?)
        .with_context(|| format!("cannot write {}", path.display()))?;
    println!("{}", summary_text(&report));
    println!("report: {}", path.display());
    Ok(report)
}

/// One solve, judged by its recomputed residual.
fn solve_one(
    solver: &mut Solver,
    p: &Mlcp,
    lam: &mut [f64],
    (island, seed, params, variant, start): (usize, u64, &IslandParams, Variant, &'static str),
) -> SweepSolve {
    let t = Instant::now();
    let st = solver.solve(p, lam);
    let (status, steps) = (st.status.name(), st.pivot_steps);
    let ms = t.elapsed().as_secs_f64() * 1e3;
    let mut w = vec![0.0; p.n()];
    let (_, residual_rel) = p.natural_residual(lam, &mut w);
    SweepSolve {
        island,
        seed,
        m: p.n(),
        mass_ratio: params.mass_ratio,
        compliance: params.compliance,
        mu: params.mu,
        variant: variant.name(),
        start,
        status,
        steps,
        residual_rel,
        ms,
    }
}

/// Counts per variant and start, and the worst cases.
fn summarize(islands: usize, solves: Vec<SweepSolve>, elapsed_s: f64) -> SweepReport {
    let mut counts = Vec::new();
    for v in Variant::EXACT {
        for start in ["cold", "warm"] {
            let mut steps: Vec<usize> = solves
                .iter()
                .filter(|s| s.variant == v.name() && s.start == start)
                .map(|s| s.steps)
                .collect();
            steps.sort_unstable();
            let q =
                |f: f64| steps.get(((steps.len() as f64 - 1.0) * f).round() as usize).copied().unwrap_or(0);
            counts.push(SweepCount {
                variant: v.name().to_string(),
                start: start.to_string(),
                solves: steps.len(),
                failed: solves
                    .iter()
                    .filter(|s| s.variant == v.name() && s.start == start && !s.ok())
                    .count(),
                steps_p50: q(0.5),
                steps_p99: q(0.99),
                steps_max: steps.last().copied().unwrap_or(0),
            });
        }
    }
    let mut failed_islands: Vec<usize> = solves.iter().filter(|s| !s.ok()).map(|s| s.island).collect();
    failed_islands.dedup();
    let failed = solves.iter().filter(|s| !s.ok()).count();
    let mut by_res = solves.clone();
    by_res.sort_by(|a, b| b.residual_rel.total_cmp(&a.residual_rel));
    by_res.truncate(WORST);
    let mut by_steps = solves.clone();
    by_steps.sort_by(|a, b| b.steps.cmp(&a.steps).then(b.residual_rel.total_cmp(&a.residual_rel)));
    by_steps.truncate(WORST);
    SweepReport {
        islands,
        seed0: SEED0,
        max_steps: MAX_STEPS,
        tol: TOL,
        solves: solves.len(),
        failed,
        failed_islands: failed_islands.len(),
        elapsed_s,
        counts,
        worst_residual: by_res,
        worst_steps: by_steps,
    }
}

/// The summary printed at the end: counts per variant and start, then the ten worst by residual.
fn summary_text(r: &SweepReport) -> String {
    let mut s = format!(
        "sweep: {} islands, {} solves, {} failed on {} islands ({:.0} s)\n",
        r.islands, r.solves, r.failed, r.failed_islands, r.elapsed_s
    );
    for c in &r.counts {
        s += &format!(
            "  {:17} {}: {:5} solves, {:4} failed, steps p50 {} p99 {} max {}\n",
            c.variant, c.start, c.solves, c.failed, c.steps_p50, c.steps_p99, c.steps_max
        );
    }
    s += "worst by residual:\n";
    for w in r.worst_residual.iter().take(10) {
        s += &format!(
            "  seed {} m {} ratio {:.1e} c {:.1e} mu {:.2} {} {}: {} {} steps, residual {:.2e}\n",
            w.seed,
            w.m,
            w.mass_ratio,
            w.compliance,
            w.mu,
            w.variant,
            w.start,
            w.status,
            w.steps,
            w.residual_rel
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tiny_sweep_writes_its_report() {
        let dir = std::env::temp_dir().join(format!("pivotsim-sweep-{}", std::process::id()));
        let r = run(6, &dir).expect("sweep runs");
        assert_eq!((r.islands, r.solves), (6, 12));
        assert_eq!(r.counts.iter().map(|c| c.solves).sum::<usize>(), 12);
        let text = std::fs::read_to_string(dir.join("sweep.json")).expect("sweep.json");
        let v: serde_json::Value = serde_json::from_str(&text).expect("valid JSON");
        assert_eq!(v["solves"], 12);
        std::fs::remove_dir_all(&dir).ok();
    }
}
