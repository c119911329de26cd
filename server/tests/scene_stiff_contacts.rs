//! The shipped scenes at the stiff end of the paper's Table 1 (contact compliance 1e-10) and the
//! paper's cap of 35 pivot steps, with `auto`: what the polish of capped answers (solver
//! `safe.rs`) is for. Without it, the winch's first, cold solve stops short, the steps after
//! start from a poorer state and nearly every solve of the run ends capped, with the energy
//! watchdog firing within a fraction of a second.
//!
//! Checked:
//! - the winch for 5 s: no energy gain flagged, joint error ≤ 1e-4 m, at most 10 % of the solves
//!   capped, and fewer capped solves than the same run with the polish off (`polish_sweeps = 0`);
//! - the forklift for its 20 s: no energy gain flagged, joint error ≤ 0.05 m, no NaN.

use pivotsim_server::run::{RunOptions, RunSummary, run_scene_observed};
use pivotsim_server::scene;
use pivotsim_server::solver::Variant;

fn run(name: &str, duration: Option<f64>, polish: bool) -> RunSummary {
    let mut set = vec![
        "contact_compliance=1e-10".parse().expect("override"),
        "max_pivot_steps=35".parse().expect("override"),
    ];
    if !polish {
        set.push("polish_sweeps=0".parse().expect("override"));
    }
    let mut sc = scene::load_with(name, &set).unwrap_or_else(|e| panic!("{name}: {e}"));
    let opts = RunOptions { duration, variant: Some(Variant::Auto), every: 1, ..RunOptions::default() };
    let s = run_scene_observed(&mut sc, &opts, |_| {}).expect("run");
    eprintln!(
        "{name} at contact compliance 1e-10, cap 35, polish {polish}: {} steps, {} of {} solves capped, \
         max residual {:.1e}, joint error {:.2e} m, stable {} ({} steps flagged), mean island solve {:.0} µs",
        s.steps,
        s.solves_max_steps,
        s.solves_converged + s.solves_inexact + s.solves_max_steps + s.solves_other,
        s.max_residual_rel,
        s.max_joint_error_m,
        s.stable,
        s.unstable_steps,
        s.mean_island_solve_us
    );
    s
}

#[test]
fn winch_at_stiff_contacts_stays_stable_at_the_papers_cap() {
    let polished = run("winch", Some(5.0), true);
    let bare = run("winch", Some(5.0), false);
    let solves = polished.solves_converged + polished.solves_inexact + polished.solves_max_steps;
    assert!(polished.finite, "{:?}", polished.error);
    assert!(polished.stable && polished.unstable_steps == 0, "{:?}", polished.instability);
    assert!(polished.max_joint_error_m <= 1e-4, "joint error {} m", polished.max_joint_error_m);
    assert!(
        polished.solves_max_steps * 10 <= solves,
        "{} of {solves} solves capped",
        polished.solves_max_steps
    );
    assert!(
        polished.solves_max_steps < bare.solves_max_steps,
        "polish {} capped, without {}",
        polished.solves_max_steps,
        bare.solves_max_steps
    );
}

#[test]
fn forklift_at_stiff_contacts_stays_stable_at_the_papers_cap() {
    let polished = run("forklift", None, true);
    assert!(polished.finite, "{:?}", polished.error);
    assert!(polished.stable && polished.unstable_steps == 0, "{:?}", polished.instability);
    assert!(polished.max_joint_error_m <= 0.05, "joint error {} m", polished.max_joint_error_m);
}
