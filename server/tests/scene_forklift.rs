//! The forklift scene (paper §4.1.1, Tables 1–3): a 3,000 kg forklift picks up a 100 kg crate on
//! a pallet, accelerates and turns 360° around a traffic cone; its wheels skid in the turn and the
//! crate stays on the fork. The scene runs its scripted 20 s with `skyline`; we check that it stays
//! finite with tight joints, that the events happen (lift, turn, skid, crate kept), that its largest
//! island matches Table 2 (300 rows, mass ratio 2,700:1, ±25 %), and that `full` gives the same
//! trajectories.

#[path = "support/scene_run.rs"]
mod scene_run;

use nalgebra::Vector3;
use pivotsim_server::dynamics::World;
use pivotsim_server::run::{RunOptions, run_scene_observed};
use pivotsim_server::scene;
use pivotsim_server::solver::Variant;
use scene_run::{SceneRun, assert_near_paper, final_position, max_trajectory_difference, run_builtin};

/// The turn (s): the script steers from 7 s and straightens out from 17.5 s to 19 s.
const TURN: (f64, f64) = (7.0, 19.0);

/// What we watch after every step of the skyline run.
#[derive(Debug, Clone, Copy)]
struct Watch {
    time: f64,
    /// Tight rows over rows of the largest island.
    tight_fraction: f64,
    /// Heading of the chassis (rad, in (−π, π]).
    yaw: f64,
    /// The crate's centre in the carriage's frame (m).
    crate_in_carriage: Vector3<f64>,
    /// Largest sliding speed of a loaded wheel contact (m/s).
    wheel_slip: f64,
}

fn body(w: &World, name: &str) -> usize {
    w.body_id(name).unwrap_or_else(|| panic!("no body {name}")).index()
}

/// Largest sliding speed (m/s) of a loaded wheel–ground contact point in the last step, measured
/// as the solver sees it: the post-step velocities at the contact point found at the start of the
/// step (a rolling wheel's lowest point moves on with the wheel; its velocity after the step is not
/// a slip). `x − h v` is a body's position at the start of the step.
fn wheel_slip(w: &World) -> f64 {
    let h = w.settings().timestep;
    let colliders = w.colliders();
    w.contacts()
        .filter(|c| c.normal_impulse > 0.0)
        .filter_map(|c| {
            let (a, b) = (&colliders[c.collider_a.index()], &colliders[c.collider_b.index()]);
            let (wheel, p) = match (a.name().starts_with("wheel_"), b.name().starts_with("wheel_")) {
                (true, false) => (a.body(), c.point_a),
                (false, true) => (b.body(), c.point_b),
                _ => return None,
            };
            let b = w.body(wheel)?;
            let start = b.position() - b.linvel() * h;
            let v = b.linvel() + b.angvel().cross(&(p - start));
            Some((v - c.normal * c.normal.dot(&v)).norm())
        })
        .fold(0.0, f64::max)
}

fn watch(w: &World) -> Watch {
    let tight_fraction = w
        .island_stats()
        .iter()
        .max_by_key(|s| s.rows)
        .filter(|s| s.rows > 0)
        .map_or(0.0, |s| s.tight as f64 / s.rows as f64);
    let chassis = &w.bodies()[body(w, "chassis")];
    let forward = chassis.orientation() * Vector3::x();
    let carriage = &w.bodies()[body(w, "carriage")];
    let crate_ = &w.bodies()[body(w, "crate")];
    Watch {
        time: w.time(),
        tight_fraction,
        yaw: forward.y.atan2(forward.x),
        crate_in_carriage: carriage.orientation().inverse() * (crate_.position() - carriage.position()),
        wheel_slip: wheel_slip(w),
    }
}

/// [`run_builtin`] with a [`Watch`] after every step (the same runner and options).
fn run_watched(variant: Variant) -> (SceneRun, Vec<Watch>) {
    let mut sc = scene::load("forklift").expect("forklift");
    let opts = RunOptions { variant: Some(variant), every: 1, ..RunOptions::default() };
    let (mut positions, mut watched) = (Vec::new(), Vec::new());
    let summary = run_scene_observed(&mut sc, &opts, |w| {
        positions.push(w.bodies().iter().map(|b| b.position()).collect());
        watched.push(watch(w));
    })
    .expect("run");
    assert!(summary.finite, "forklift: {:?} at t = {}", summary.error, sc.world.time());
    (SceneRun { scene: sc, positions, summary }, watched)
}

#[test]
fn forklift_lifts_the_crate_turns_around_the_cone_and_skids() {
    let (sky, watched) = run_watched(Variant::Skyline);
    let s = &sky.summary;
    let start = &watched[0];

    // Finite, tight joints.
    eprintln!(
        "forklift (skyline): {} steps, largest island {} rows, mass ratio {:.0}, solve mean {:.0} µs, \
         p99 {:.0} µs, max tight fraction {:.3}, solves at the step cap {}, joint error {:.2e} m",
        s.steps,
        s.max_island_rows,
        s.max_mass_ratio,
        s.mean_solve_us,
        s.p99_solve_us,
        s.max_tight_fraction,
        s.solves_max_steps,
        s.max_joint_error_m
    );
    assert!(s.finite && s.steps == 1200, "{s:?}");
    assert!(s.max_joint_error_m <= 1e-4, "joint error {} m", s.max_joint_error_m);

    // Table 2: the largest island's rows and mass ratio.
    assert_near_paper("largest island rows", s.max_island_rows as f64, 300.0, 0.25);
    assert_near_paper("largest island mass ratio", s.max_mass_ratio, 2700.0, 0.25);

    // The lift: the crate rises at least 0.5 m.
    let crate_id = body(&sky.scene.world, "crate");
    let z0 = sky.positions[0][crate_id].z;
    let lift = sky.positions.iter().map(|p| p[crate_id].z - z0).fold(f64::MIN, f64::max);
    let before_turn = watched.iter().rev().find(|w| w.time <= TURN.0).expect("step before the turn");
    eprintln!(
        "crate lifted {lift:.3} m; in the carriage frame before the turn {:?}, at the end {:?}",
        before_turn.crate_in_carriage.as_slice(),
        watched.last().unwrap().crate_in_carriage.as_slice()
    );
    assert!(lift >= 0.5, "crate lifted {lift} m");

    // The turn: the chassis' heading turns through a full circle (unwrapped sum of the steps).
    let turned: f64 = watched
        .windows(2)
        .map(|p| {
            let d = p[1].yaw - p[0].yaw;
            (d + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
        })
        .sum();
    eprintln!("chassis turned {:.1}° (start yaw {:.2}°)", turned.to_degrees(), start.yaw.to_degrees());
    assert!(turned >= std::f64::consts::TAU, "turned {:.1}°", turned.to_degrees());

    // The wheels skid during the turn and the tight set grows.
    let in_turn = || watched.iter().filter(|w| w.time >= TURN.0 && w.time <= TURN.1);
    let slip = in_turn().map(|w| w.wheel_slip).fold(0.0, f64::max);
    let tight = in_turn().map(|w| w.tight_fraction).fold(0.0, f64::max);
    eprintln!("in the turn: largest wheel slip {slip:.3} m/s, largest tight fraction {tight:.3}");
    assert!(slip > 0.1, "no wheel skids: slip {slip} m/s");
    assert!(tight >= 0.01, "tight fraction {tight}");

    // The crate stays on the fork: unmoved in the carriage frame (within 5 cm), above the ground.
    let moved = (watched.last().unwrap().crate_in_carriage - before_turn.crate_in_carriage).norm();
    let end = final_position(&sky, "crate");
    eprintln!("crate moved {moved:.4} m on the fork; ends at {:?}", end.as_slice());
    assert!(moved < 0.05, "the crate moved {moved} m on the fork");
    assert!(end.z - z0 >= 0.5, "the crate ends {} m above its start", end.z - z0);

    // The same run with `full` (dense factor of A_FF per pivot step) follows the same trajectory.
    let full = run_builtin("forklift", Variant::Full, None);
    let diff = max_trajectory_difference(&sky, &full);
    eprintln!(
        "full: solve mean {:.0} µs, p99 {:.0} µs; largest trajectory difference to skyline {diff:.2e} m",
        full.summary.mean_solve_us, full.summary.p99_solve_us
    );
    assert!(diff <= 1e-6, "skyline and full differ by {diff} m");
}
