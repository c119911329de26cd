//! Stages 1 and 3: every scene with every exact variant (per-step solve time, tight count, pivot
//! steps), its islands dumped from the `auto` run, the same scene without warm starts, and `full`
//! with `skyline` and `auto` solving each of its island problems beside it (paired speed-ups,
//! `dynamics/shadow.rs`).
//!
//! **Rounds.** A single run per variant reads the host's speed at one moment; on the project's
//! 2-core VMs whole runs swing by up to 1.7× from one minute to the next (the crane with `auto`:
//! mean solve over its steps with tight rows 112–204 µs over six runs in a row, every step slower
//! alike), which made its speed-up over `full` read anywhere from 8.4× to 13× depending on which
//! run met which phase. So stage 1 runs `Plan::scene_rounds` rounds, each running every variant
//! once in turn (a phase falls on all variants of a round), and each variant reports its median
//! run by the mean over steps with tight rows; the means of all its rounds are kept beside it
//! (`rounds_mean_tight_us`) so the spread is on record. The trajectories are deterministic: the
//! rounds differ in time only.

use std::path::{Path, PathBuf};

use anyhow::Context;
use indicatif::ProgressBar;
use pivotsim_server::dynamics::World;
use pivotsim_server::run::{RunOptions, RunSummary, ShadowSummary, run_scene_observed};
use pivotsim_server::scene::{self, SceneOverride};
use pivotsim_server::solver::Variant;
use serde::Serialize;

use super::Plan;

/// One step of one run: the sums over its islands.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct StepPoint {
    /// Solve time of all islands (µs).
    pub solve_us: f64,
    /// Tight rows.
    pub tight: usize,
    /// Rows.
    pub rows: usize,
    /// Most pivot steps of an island.
    pub pivot_steps: usize,
}

/// One scene run with one variant.
#[derive(Debug, Clone, Serialize)]
pub struct VariantRun {
    /// Variant name.
    pub variant: String,
    /// Mean solve time per step over the steps with tight rows (the paper's Table 3), µs.
    pub mean_tight_us: f64,
    /// Mean solve time over every step (µs).
    pub mean_us: f64,
    /// 99th percentile and maximum of the per-step solve time (µs).
    pub p99_us: f64,
    /// Largest per-step solve time (µs).
    pub max_us: f64,
    /// Steps with tight rows (the steps the paper's Table 3 averages).
    pub tight_steps: usize,
    /// Mean pivot steps of an island solve.
    pub mean_pivot_steps: f64,
    /// Island solves that stopped at the cap or were inexact.
    pub not_converged: u64,
    /// Largest joint error (m).
    pub max_joint_error_m: f64,
    /// Stable (no energy gain flagged), finite.
    pub stable: bool,
    /// `mean_tight_us` of every round's run of this variant (this run is the median of them).
    pub rounds_mean_tight_us: Vec<f64>,
    /// The per-step series (not in `report.json`: `steps.csv` holds it).
    #[serde(skip)]
    pub steps: Vec<StepPoint>,
}

/// One scene: its runs and its Table 2 numbers.
#[derive(Debug, Clone, Serialize)]
pub struct SceneResult {
    /// Scene name.
    pub scene: String,
    /// Largest island: rows.
    pub max_rows: usize,
    /// Largest mass ratio in an island.
    pub max_mass_ratio: f64,
    /// One run per variant (`full` first).
    pub variants: Vec<VariantRun>,
    /// `auto` without warm starts (stage 3).
    pub cold: VariantRun,
    /// `full`'s run with `skyline` and `auto` as shadows: their paired numbers on its problems.
    pub paired: Vec<ShadowSummary>,
    /// Where the `auto` run dumped its islands.
    #[serde(skip)]
    pub dump_dir: PathBuf,
}

impl SceneResult {
    /// The run of a variant.
    pub fn variant(&self, v: Variant) -> Option<&VariantRun> {
        self.variants.iter().find(|r| r.variant == v.name())
    }
}

/// Runs stage 1 and 3 for every scene of the plan.
pub fn run(plan: &Plan, dumps: &Path, pb: &ProgressBar) -> anyhow::Result<Vec<SceneResult>> {
    let mut results = Vec::new();
    for &name in &plan.scenes {
        let dump_dir = dumps.join(name);
        let _ = std::fs::remove_dir_all(&dump_dir);
        std::fs::create_dir_all(&dump_dir)
            .with_context(|| format!("cannot create {}", dump_dir.display()))?;
        let mut rounds: Vec<Vec<VariantRun>> = vec![Vec::new(); plan.variants.len()];
        let mut table2 = (0, 0.0);
        for round in 0..plan.scene_rounds.max(1) {
            for (&v, runs) in plan.variants.iter().zip(&mut rounds) {
                pb.set_message(format!(
                    "{name}: {} (round {} of {})",
                    v.name(),
                    round + 1,
                    plan.scene_rounds
                ));
                let dump = (v == Variant::Auto && round == 0).then(|| dump_dir.clone());
                let (summary, run) = run_one(name, v, plan, &[], dump)?;
                if v == Variant::Auto && round == 0 {
                    table2 = (summary.max_island_rows, summary.max_mass_ratio);
                }
                runs.push(run);
                pb.inc(1);
            }
        }
        let variants: Vec<VariantRun> = rounds.into_iter().map(median_run).collect();
        pb.set_message(format!("{name}: auto without warm starts"));
        let cold_set = ["warm_start=false".parse::<SceneOverride>().context("override")?];
        let (_, cold) = run_one(name, Variant::Auto, plan, &cold_set, None)?;
        pb.inc(1);
        pb.set_message(format!("{name}: full with paired skyline and auto"));
        let paired = run_paired(name, plan)?;
        pb.inc(1);
        results.push(SceneResult {
            scene: name.to_string(),
            max_rows: table2.0,
            max_mass_ratio: table2.1,
            variants,
            cold,
            paired,
            dump_dir,
        });
    }
    Ok(results)
}

/// One run of `name` with variant `v` and `set`; dumps its islands into `dump` every
/// `plan.dump_every` steps.
pub fn run_one(
    name: &str,
    v: Variant,
    plan: &Plan,
    set: &[SceneOverride],
    dump: Option<PathBuf>,
) -> anyhow::Result<(RunSummary, VariantRun)> {
    let mut sc = scene::load_with(name, set).with_context(|| format!("scene {name}"))?;
    let opts = RunOptions {
        duration: plan.duration,
        variant: Some(v),
        dump_mlcp: dump,
        every: plan.dump_every,
        ..RunOptions::default()
    };
    let mut steps = Vec::new();
    let summary = run_scene_observed(&mut sc, &opts, |w: &World| steps.push(step_point(w)))
        .with_context(|| format!("scene {name}, {}", v.name()))?;
    Ok((summary.clone(), variant_run(v, &summary, steps)))
}

/// `full` on `name` with `skyline` and `auto` solving every island problem beside it: the speed-up
/// of each over `full` on the very same problems (`shadow.rs`), and their deviation from its answers.
fn run_paired(name: &str, plan: &Plan) -> anyhow::Result<Vec<ShadowSummary>> {
    let mut sc = scene::load(name).with_context(|| format!("scene {name}"))?;
    let opts = RunOptions {
        duration: plan.duration,
        variant: Some(Variant::Full),
        shadow: vec![Variant::Skyline, Variant::Auto],
        ..RunOptions::default()
    };
    let summary =
        run_scene_observed(&mut sc, &opts, |_| {}).with_context(|| format!("scene {name}, paired"))?;
    Ok(summary.shadow)
}

fn step_point(w: &World) -> StepPoint {
    let st = w.island_stats();
    StepPoint {
        solve_us: st.iter().map(|s| s.solve_us).sum(),
        tight: st.iter().map(|s| s.tight).sum(),
        rows: st.iter().map(|s| s.rows).sum(),
        pivot_steps: st.iter().map(|s| s.pivot_steps).max().unwrap_or(0),
    }
}

fn variant_run(v: Variant, s: &RunSummary, steps: Vec<StepPoint>) -> VariantRun {
    let tight: Vec<f64> = steps.iter().filter(|p| p.tight > 0).map(|p| p.solve_us).collect();
    let mut all: Vec<f64> = steps.iter().map(|p| p.solve_us).collect();
    all.sort_by(f64::total_cmp);
    let mean = |x: &[f64]| if x.is_empty() { 0.0 } else { x.iter().sum::<f64>() / x.len() as f64 };
    let p99 = all.get(((all.len() as f64 * 0.99) as usize).min(all.len().saturating_sub(1))).copied();
    let mean_tight_us = mean(&tight);
    VariantRun {
        variant: v.name().to_string(),
        mean_tight_us,
        mean_us: mean(&all),
        p99_us: p99.unwrap_or(0.0),
        max_us: all.last().copied().unwrap_or(0.0),
        tight_steps: tight.len(),
        mean_pivot_steps: s.mean_pivot_steps,
        not_converged: s.solves_max_steps + s.solves_inexact,
        max_joint_error_m: s.max_joint_error_m,
        stable: s.stable && s.finite,
        rounds_mean_tight_us: vec![mean_tight_us],
        steps,
    }
}

/// The run with the median `mean_tight_us` of one variant's rounds (the lower middle one of an
/// even count), carrying every round's mean.
fn median_run(mut runs: Vec<VariantRun>) -> VariantRun {
    let means: Vec<f64> = runs.iter().map(|r| r.mean_tight_us).collect();
    runs.sort_by(|a, b| a.mean_tight_us.total_cmp(&b.mean_tight_us));
    let mut median = runs.swap_remove((runs.len().max(1) - 1) / 2);
    median.rounds_mean_tight_us = means;
    median
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run_with(mean: f64) -> VariantRun {
        VariantRun {
            variant: "auto".into(),
            mean_tight_us: mean,
            mean_us: mean / 2.0,
            p99_us: 0.0,
            max_us: 0.0,
            tight_steps: 1,
            mean_pivot_steps: 1.0,
            not_converged: 0,
            max_joint_error_m: 0.0,
            stable: true,
            rounds_mean_tight_us: vec![mean],
            steps: vec![],
        }
    }

    /// The median run is the middle one by its mean over steps with tight rows (the lower middle
    /// of an even count), whole, and it carries every round's mean in round order.
    #[test]
    fn a_variant_reports_its_median_round() {
        let m = median_run(vec![run_with(300.0), run_with(100.0), run_with(200.0)]);
        assert_eq!((m.mean_tight_us, m.mean_us), (200.0, 100.0));
        assert_eq!(m.rounds_mean_tight_us, [300.0, 100.0, 200.0]);
        let m = median_run(vec![run_with(4.0), run_with(1.0), run_with(3.0), run_with(2.0)]);
        assert_eq!(m.mean_tight_us, 2.0);
        assert_eq!(median_run(vec![run_with(7.0)]).rounds_mean_tight_us, [7.0]);
    }
}
