//! Shared helpers of the scene tests: run a built-in scene under its script with a given solver
//! variant, keeping every body's trajectory and the run summary, and compare two runs.
//! Include with `#[path = "support/scene_run.rs"] mod scene_run;`.

#![allow(dead_code)]

use nalgebra::Vector3;
use pivotsim_server::dynamics::World;
use pivotsim_server::run::{RunOptions, RunSummary, run_scene_observed};
use pivotsim_server::scene::{self, Scene};
use pivotsim_server::solver::Variant;

/// A finished run: the scene in its final state, positions of every body after every step
/// (`positions[step][body]`), and the runner's summary.
pub struct SceneRun {
    pub scene: Scene,
    pub positions: Vec<Vec<Vector3<f64>>>,
    pub summary: RunSummary,
}

/// Runs built-in scene `name` for `duration` seconds (default: its own) with `variant` through
/// the runner (so that the summary is the CLI's), recording every body's position after every step.
pub fn run_builtin(name: &str, variant: Variant, duration: Option<f64>) -> SceneRun {
    run_builtin_with(name, variant, duration, &[])
}

/// [`run_builtin`] with scene overrides (`KEY=VALUE`, scenes/README.md).
#[allow(dead_code)]
pub fn run_builtin_with(name: &str, variant: Variant, duration: Option<f64>, set: &[&str]) -> SceneRun {
    let set: Vec<_> = set.iter().map(|kv| kv.parse().expect("override")).collect();
    let mut sc = scene::load_with(name, &set).unwrap_or_else(|e| panic!("{name}: {e}"));
    let opts = RunOptions { duration, variant: Some(variant), every: 1, ..RunOptions::default() };
    let mut positions = Vec::new();
    let summary = run_scene_observed(&mut sc, &opts, |w| {
        positions.push(w.bodies().iter().map(|b| b.position()).collect());
    })
    .expect("run");
    assert!(summary.finite, "{name} ({variant:?}): {:?} at t = {}", summary.error, sc.world.time());
    SceneRun { scene: sc, positions, summary }
}

/// Largest distance between the same body's positions at the same step of two runs (m).
pub fn max_trajectory_difference(a: &SceneRun, b: &SceneRun) -> f64 {
    assert_eq!(a.positions.len(), b.positions.len());
    a.positions
        .iter()
        .zip(&b.positions)
        .flat_map(|(x, y)| x.iter().zip(y).map(|(p, q)| (p - q).norm()))
        .fold(0.0, f64::max)
}

/// Checks `value` within ±`tol` (relative) of the paper's `target`.
pub fn assert_near_paper(what: &str, value: f64, target: f64, tol: f64) {
    assert!(
        (value - target).abs() <= tol * target,
        "{what}: {value} is not within ±{:.0} % of the paper's {target}",
        tol * 100.0
    );
}

/// Position of body `name` in the run's final state.
pub fn final_position(run: &SceneRun, name: &str) -> Vector3<f64> {
    let id = run.scene.world.body_id(name).unwrap_or_else(|| panic!("no body {name}"));
    run.scene.world.body(id).expect("body").position()
}

/// Runs built-in scene `name` under its script with `variant` and `set` overrides for `duration`
/// seconds, recording every body's position and what `watch` makes of the world after every step.
/// `watch_from` gets the world before the first step and returns the watcher (which may keep state
/// from one step to the next).
pub fn run_watched<W, F: FnMut(&World) -> W>(
    name: &str,
    variant: Variant,
    duration: f64,
    set: &[&str],
    watch_from: impl FnOnce(&World) -> F,
) -> (SceneRun, Vec<W>) {
    let set: Vec<_> = set.iter().map(|s| s.parse().expect("override")).collect();
    let mut sc = scene::load_with(name, &set).unwrap_or_else(|e| panic!("{name}: {e}"));
    let opts =
        RunOptions { duration: Some(duration), variant: Some(variant), every: 1, ..RunOptions::default() };
    let mut watch = watch_from(&sc.world);
    let (mut positions, mut watched) = (Vec::new(), Vec::new());
    let summary = run_scene_observed(&mut sc, &opts, |w| {
        positions.push(w.bodies().iter().map(|b| b.position()).collect());
        watched.push(watch(w));
    })
    .expect("run");
    assert!(summary.finite, "{name}: {:?} at t = {}", summary.error, sc.world.time());
    (SceneRun { scene: sc, positions, summary }, watched)
}

/// Prints one line of a run's summary: sizes, capped solves, joint error, stability, solve times.
pub fn print_summary(name: &str, what: &str, s: &RunSummary) {
    let solves = s.solves_converged + s.solves_inexact + s.solves_max_steps + s.solves_other;
    eprintln!(
        "{name} ({what}): {} steps, largest island {} rows, mass ratio {:.4e}, {} of {solves} solves at the \
         cap ({} inexact), most pivot steps {}, joint error {:.2e} m, stable {}, solve mean {:.0} µs, max {:.0} µs",
        s.steps,
        s.max_island_rows,
        s.max_mass_ratio,
        s.solves_max_steps,
        s.solves_inexact,
        s.max_pivot_steps,
        s.max_joint_error_m,
        s.stable,
        s.mean_solve_us,
        s.max_solve_us
    );
}
