//! Stage 6, the trade in the running simulation: each scene with block pivoting (`auto`) and with
//! projected Gauss–Seidel given the same solve time per step — what PGS at equal cost does to the
//! joints, the contacts and the payload (the crane's hanging pipe, the forwarder's log, …).
//!
//! Equal time: a first PGS run with its default 100 sweeps per solve measures PGS's time per step;
//! the sweep cap (`pgs_sweeps`) is then scaled by `auto`'s mean solve time per step over that one
//! (time per sweep is close to constant; the sweeps also stop early at relative residual 1e-9)
//! and the scene is run again. Reported per run: mean solve time per step, the largest joint error,
//! the deepest contact penetration (the largest `−gap` of a contact carrying load, so it includes
//! the compliant sink `c·F` both methods share), and the payload's displacement from its start —
//! and, for PGS, how far its payload ends from where `auto` put it.

use indicatif::ProgressBar;
use nalgebra::Point3;
use pivotsim_server::dynamics::World;
use pivotsim_server::run::{RunOptions, RunSummary, run_scene_observed};
use pivotsim_server::scene::{self, SceneOverride};
use pivotsim_server::solver::Variant;
use pivotsim_server::solver::pgs::PgsOptions;
use serde::Serialize;

use super::Plan;

/// The body whose motion is the scene's point, and what it is.
pub fn payload(scene: &str) -> Option<(&'static str, &'static str)> {
    Some(match scene {
        "forklift" => ("crate", "the crate on the tines"),
        "winch" => ("tail43", "the chain's free end, dragged along the ground"),
        "forwarder" => ("log", "the log in the grapple"),
        "crane" => ("pipe", "the hanging pipe"),
        "offshore" => ("module", "the subsea module"),
        "vehicle" => ("hull", "the hull"),
        _ => return None,
    })
}

/// One run of the stage.
#[derive(Debug, Clone, Serialize)]
pub struct Watched {
    /// `auto`, or `pgs` with its sweep cap.
    pub method: String,
    /// Mean solve time per step (µs).
    pub mean_solve_us: f64,
    /// Largest joint error (m).
    pub max_joint_error_m: f64,
    /// Deepest penetration of a contact carrying load (m).
    pub max_penetration_m: f64,
    /// Largest relative residual of a solve.
    pub max_residual_rel: f64,
    /// Payload displacement from its start at the end (m).
    pub payload_moved_m: f64,
    /// Payload height change at the end (m).
    pub payload_lift_m: f64,
    /// Finite and no energy gain flagged.
    pub stable: bool,
    /// Payload displacement from its start per step (m; `steps.csv` has no room for it: plotted).
    #[serde(skip)]
    pub payload_series: Vec<f64>,
    /// Payload position at the end.
    #[serde(skip)]
    pub payload_end: Option<Point3<f64>>,
}

/// One scene.
#[derive(Debug, Clone, Serialize)]
pub struct EqualTime {
    /// Scene name.
    pub scene: String,
    /// The payload body and what it is.
    pub payload: String,
    /// PGS sweep cap that matched `auto`'s time.
    pub pgs_sweeps: usize,
    /// `auto`.
    pub auto: Watched,
    /// PGS with its default 100 sweeps (the calibration run).
    pub pgs_default: Watched,
    /// PGS at `auto`'s time per step.
    pub pgs_equal: Watched,
    /// Distance between PGS's payload (equal time) and `auto`'s at the end (m).
    pub payload_gap_m: f64,
}

/// Runs the stage for every scene of the plan that has a payload.
pub fn run(plan: &Plan, pb: &ProgressBar) -> anyhow::Result<Vec<EqualTime>> {
    let mut out = Vec::new();
    for &name in &plan.scenes {
        let Some((body, what)) = payload(name) else { continue };
        pb.set_message(format!("equal time: {name}, auto"));
        let auto = watched(name, Variant::Auto, None, plan, body)?;
        let default = PgsOptions::default().max_iterations;
        pb.set_message(format!("equal time: {name}, pgs {default}"));
        let pgs_default = watched(name, Variant::Pgs, Some(default), plan, body)?;
        let per_sweep = pgs_default.mean_solve_us / default as f64;
        let sweeps = if per_sweep > 0.0 && auto.mean_solve_us.is_finite() {
            ((auto.mean_solve_us / per_sweep).round() as usize).clamp(1, 100_000)
        } else {
            default
        };
        pb.set_message(format!("equal time: {name}, pgs {sweeps}"));
        let pgs_equal = watched(name, Variant::Pgs, Some(sweeps), plan, body)?;
        let payload_gap_m = match (auto.payload_end, pgs_equal.payload_end) {
            (Some(a), Some(b)) => (a - b).norm(),
            _ => f64::NAN,
        };
        out.push(EqualTime {
            scene: name.to_string(),
            payload: format!("{body} ({what})"),
            pgs_sweeps: sweeps,
            auto,
            pgs_default,
            pgs_equal,
            payload_gap_m,
        });
        pb.inc(1);
    }
    Ok(out)
}

fn watched(
    name: &str,
    v: Variant,
    sweeps: Option<usize>,
    plan: &Plan,
    body: &str,
) -> anyhow::Result<Watched> {
    let set: Vec<SceneOverride> =
        sweeps.map(|n| format!("pgs_sweeps={n}").parse()).transpose()?.into_iter().collect();
    let mut sc = scene::load_with(name, &set)?;
    let id = sc.world.body_id(body);
    let start = id.and_then(|b| sc.world.body(b)).map(|b| b.position());
    let opts = RunOptions { duration: plan.duration, variant: Some(v), ..RunOptions::default() };
    let (mut series, mut end, mut pen) = (Vec::new(), None, 0.0f64);
    // A run the world refuses to continue broke: recorded as unstable with what it had.
    let summary = run_scene_observed(&mut sc, &opts, |w: &World| {
        for c in w.contacts().filter(|c| c.normal_impulse > 0.0) {
            pen = pen.max(-c.gap);
        }
        if let (Some(b), Some(p0)) = (id.and_then(|b| w.body(b)), start) {
            let p = b.position();
            series.push((p - p0).norm());
            end = Some(Point3::from(p));
        }
    });
    let method = sweeps.map_or(v.name().to_string(), |n| format!("{} ({n} sweeps)", v.name()));
    let (moved, lift) = match (end, start) {
        (Some(e), Some(s)) => ((e.coords - s).norm(), e.z - s.z),
        _ => (f64::NAN, f64::NAN),
    };
    let s = summary.unwrap_or_else(|e| RunSummary { error: Some(e.to_string()), ..RunSummary::default() });
    Ok(Watched {
        method,
        mean_solve_us: s.mean_solve_us,
        max_joint_error_m: s.max_joint_error_m,
        max_penetration_m: pen,
        max_residual_rel: s.max_residual_rel,
        payload_moved_m: moved,
        payload_lift_m: lift,
        stable: s.stable && s.finite && s.error.is_none(),
        payload_series: series,
        payload_end: end,
    })
}
