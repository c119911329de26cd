//! Stage 4, the extremes: the winch over the compliance of its joints and contacts, and the crane
//! over the mass ratio of its load (pipe mass / lightest body, a cable segment of 1.75 kg), each
//! with block pivoting (`auto`, cap 35; in the full report every exact variant, which must agree
//! with it) and with projected Gauss–Seidel (its default 100 sweeps): where each method holds and
//! where it breaks.

use indicatif::ProgressBar;
use pivotsim_server::scene::SceneOverride;
use serde::Serialize;

use super::Plan;
use super::scenes::run_one;

/// Mass of the crane's lightest body (a cable segment, kg): the mass ratio's denominator.
pub const CRANE_LIGHTEST_KG: f64 = 1.75;

/// One run of a sweep.
#[derive(Debug, Clone, Serialize)]
pub struct ExtremePoint {
    /// The swept value (compliance, or mass ratio).
    pub x: f64,
    /// `auto` or `pgs`.
    pub variant: String,
    /// No energy gain flagged and finite.
    pub stable: bool,
    /// Largest joint error (m).
    pub max_joint_error_m: f64,
    /// Largest relative residual of a solve.
    pub max_residual_rel: f64,
    /// Mean pivot steps (block pivoting).
    pub mean_pivot_steps: f64,
    /// Solves that stopped at their cap or were inexact.
    pub not_converged: u64,
    /// Solves in which a safeguard ran.
    pub fallback: u64,
    /// Mean solve time per step (µs).
    pub mean_solve_us: f64,
}

/// Both sweeps.
#[derive(Debug, Clone, Serialize)]
pub struct Extremes {
    /// The winch over compliance (joints and contacts alike).
    pub winch_compliance: Vec<ExtremePoint>,
    /// The crane over its load's mass ratio.
    pub crane_mass_ratio: Vec<ExtremePoint>,
}

/// Runs both sweeps.
pub fn run(plan: &Plan, pb: &ProgressBar) -> anyhow::Result<Extremes> {
    let short = Plan { duration: Some(plan.extreme_duration), ..plan.clone() };
    let mut winch_compliance = Vec::new();
    for &c in &plan.compliances {
        let set = [format!("compliance={c:e}"), format!("contact_compliance={c:e}")];
        winch_compliance.extend(sweep_point(&short, "winch", c, &set, pb)?);
    }
    let mut crane_mass_ratio = Vec::new();
    for &r in &plan.mass_ratios {
        let set = [format!("body.pipe.mass={:e}", r * CRANE_LIGHTEST_KG)];
        crane_mass_ratio.extend(sweep_point(&short, "crane", r, &set, pb)?);
    }
    Ok(Extremes { winch_compliance, crane_mass_ratio })
}

fn sweep_point(
    plan: &Plan,
    scene: &str,
    x: f64,
    set: &[String],
    pb: &ProgressBar,
) -> anyhow::Result<Vec<ExtremePoint>> {
    let set: Vec<SceneOverride> = set.iter().map(|s| s.parse()).collect::<Result<_, _>>()?;
    let mut out = Vec::new();
    for &v in &plan.extreme_variants {
        pb.set_message(format!("extremes: {scene} at {x:.0e}, {}", v.name()));
        // A run that fails (the world refuses a step) broke there: recorded, not fatal.
        let Ok((s, _)) = run_one(scene, v, plan, &set, None) else {
            out.push(ExtremePoint {
                x,
                variant: v.name().to_string(),
                stable: false,
                max_joint_error_m: f64::NAN,
                max_residual_rel: f64::NAN,
                mean_pivot_steps: f64::NAN,
                not_converged: 0,
                fallback: 0,
                mean_solve_us: f64::NAN,
            });
            pb.inc(1);
            continue;
        };
        out.push(ExtremePoint {
            x,
            variant: v.name().to_string(),
            stable: s.stable && s.finite,
            max_joint_error_m: s.max_joint_error_m,
            max_residual_rel: s.max_residual_rel,
            mean_pivot_steps: s.mean_pivot_steps,
            not_converged: s.solves_max_steps + s.solves_inexact,
            fallback: s.solves_fallback,
            mean_solve_us: s.mean_solve_us,
        });
        pb.inc(1);
    }
    Ok(out)
}
