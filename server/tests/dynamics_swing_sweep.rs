//! Measurement, not a check (ignored by default; run with `--ignored --nocapture`): the
//! swinging-load rig of issue 12 over loads and geometric-stiffness modes, printed as a table for
//! the issue note — joint error, top speed, energy gain, period against the compound pendulum's,
//! hook tension and wall time per step.

#[path = "support/swing_rig.rs"]
mod swing_rig;

use pivotsim_server::dynamics::GeometricStiffness;
use pivotsim_server::solver::Variant;
use swing_rig::*;

#[test]
#[ignore]
fn sweep() {
    let seconds: f64 = std::env::var("SWEEP_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(20.0);
    let angle: f64 = std::env::var("SWEEP_ANGLE").ok().and_then(|s| s.parse().ok()).unwrap_or(30.0);
    let loads: Vec<f64> = std::env::var("SWEEP_LOADS")
        .ok()
        .map(|s| s.split(',').map(|x| x.parse().unwrap()).collect())
        .unwrap_or(vec![5.0, 10.0, 15.0, 30.0, 50.0, 150.0, 500.0, 5000.0, 50000.0, 5e5]);
    let variant = match std::env::var("SWEEP_VARIANT").as_deref() {
        Ok("auto") => Variant::Auto,
        _ => Variant::Skyline,
    };
    println!(
        "mode      load_kg ratio    joint_err_m  max_speed  max_gain  final_E  period/ref  tension_N  step_us finite"
    );
    for gs in GeometricStiffness::ALL {
        for &load in &loads {
            let r = run(load, angle, gs, variant, seconds);
            let p = r.period.map(|p| p / compound_period(load, angle.to_radians())).unwrap_or(f64::NAN);
            println!(
                "{:9} {:8} {:8.0} {:11.3e} {:10.3e} {:9.2e} {:8.3} {:10.4} {:10.3e} {:8.1} {}",
                gs.name(),
                load,
                load / M_LINK,
                r.max_joint_error,
                r.max_speed,
                r.max_energy_gain,
                r.final_energy,
                p,
                r.max_tension,
                r.step_us,
                r.finite
            );
        }
    }
}

#[test]
#[ignore]
fn trace() {
    let load: f64 = std::env::var("TRACE_LOAD").ok().and_then(|s| s.parse().ok()).unwrap_or(5000.0);
    let mut w = world(load, 30.0, GeometricStiffness::Implicit, Variant::Skyline);
    for n in 0..1200 {
        w.step().unwrap();
        let e = w.max_joint_error();
        if n < 10 || e > 5e-4 {
            let st = w.island_stats()[0];
            println!(
                "step {n} err {e:.3e} gs_bodies {} status {:?} pivots {} res {:.2e} viol {:.2e} wmax {:.3} wload {:.3}",
                w.geometric_stiffness_bodies(),
                st.status,
                st.pivot_steps,
                st.residual_rel,
                st.max_violation,
                w.bodies().iter().map(|b| b.angvel().norm()).fold(0.0, f64::max),
                w.bodies().last().unwrap().angvel().norm()
            );
        }
    }
}

/// Cost per step (release; medians over `COST_RUNS` runs, 5 by default), for the note.
#[test]
#[ignore]
fn cost() {
    let runs: usize = std::env::var("COST_RUNS").ok().and_then(|s| s.parse().ok()).unwrap_or(5);
    let cases: [(&str, f64, f64, GeometricStiffness); 6] = [
        ("swing 5 kg", 5.0, 30.0, GeometricStiffness::Implicit),
        ("swing 500 kg", 500.0, 30.0, GeometricStiffness::Implicit),
        ("swing 5 t", 5000.0, 30.0, GeometricStiffness::Implicit),
        ("hang 5 kg", 5.0, 0.0, GeometricStiffness::Implicit),
        ("hang 5 kg", 5.0, 0.0, GeometricStiffness::Off),
        ("hang 5 kg", 5.0, 0.0, GeometricStiffness::Inertial),
    ];
    for (what, load, angle, gs) in cases {
        let mut t: Vec<f64> =
            (0..runs).map(|_| run(load, angle, gs, Variant::Skyline, 20.0).step_us).collect();
        t.sort_by(f64::total_cmp);
        let r = run(load, angle, gs, Variant::Skyline, 20.0);
        println!(
            "{what:12} {:9}: median {:.1} µs/step (min {:.1}, max {:.1}), joint error {:.2e} m",
            gs.name(),
            t[runs / 2],
            t[0],
            t[runs - 1],
            r.max_joint_error
        );
    }
}
