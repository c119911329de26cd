//! Stages 1 and 3: every scene with every exact variant (per-step solve time, tight count, pivot
//! steps), its islands dumped from the `auto` run, the same scene without warm starts, and `full`
//! with `skyline` and `auto` solving each of its island problems beside it (paired speed-ups,
//! `dynamics/shadow.rs`).

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
        let mut variants = Vec::new();
        let mut table2 = (0, 0.0);
        for &v in &plan.variants {
            pb.set_message(format!("{name}: {}", v.name()));
            let dump = (v == Variant::Auto).then(|| dump_dir.clone());
            let (summary, run) = run_one(name, v, plan, &[], dump)?;
            if v == Variant::Auto {
                table2 = (summary.max_island_rows, summary.max_mass_ratio);
            }
            variants.push(run);
            pb.inc(1);
        }
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
    VariantRun {
        variant: v.name().to_string(),
        mean_tight_us: mean(&tight),
        mean_us: mean(&all),
        p99_us: p99.unwrap_or(0.0),
        max_us: all.last().copied().unwrap_or(0.0),
        tight_steps: tight.len(),
        mean_pivot_steps: s.mean_pivot_steps,
        not_converged: s.solves_max_steps + s.solves_inexact,
        max_joint_error_m: s.max_joint_error_m,
        stable: s.stable && s.finite,
        steps,
    }
}
