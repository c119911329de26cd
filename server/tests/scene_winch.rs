//! The paper's winch (§4.1.6; `scenes/winch.toml`): a 400 kg drum on a motorized hinge winds a chain
//! of 50 × 1 kg capsule links whose tail is dragged along the ground. One 20 s run under the scene's
//! script with `skyline`, checked for:
//!
//! - no NaN, joint error ≤ 1e-4 m (the scene projects positions once per step);
//! - the drum turned the scripted angle, `0.35 rad/s × (20 − 1 − 0.5) s` (1 s ramp from t = 1 s),
//!   within 1 %: the hinge coordinate (in (−π, π]) plus the whole turns counted by following
//!   `link0`, which is joined to the drum, around the drum axis step by step;
//! - the chain followed: the links on the drum (axis 0.52 m from the drum axis, drum radius plus
//!   link radius) are a prefix `link0, link1, …` whose number matches the turned angle, the last link
//!   moved toward the drum by most of the wound length, and the tail lies on the ground, in contact;
//! - many friction rows at their bounds (the sliding tail), and the largest island's rows and mass
//!   ratio within ±25 % of the paper's Table 2 (370 rows, 400:1);
//! - the `full` variant gives the same trajectories within 1e-6 m.

#[path = "support/scene_run.rs"]
mod scene_run;

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use pivotsim_server::solver::Variant;
use scene_run::{SceneRun, assert_near_paper, final_position, max_trajectory_difference, run_builtin};

/// Drum axis height (m); the axis is along y through x = 0.
const DRUM_Z: f64 = 1.22;
/// Distance from the drum axis of a wrapped link's axis: drum radius 0.5 + link radius 0.02 (m).
const WRAP_RADIUS: f64 = 0.52;
/// Joint-to-joint length of a link (m).
const PITCH: f64 = 0.2;
/// Link radius: a link lying on the ground has its axis this high (m).
const LINK_RADIUS: f64 = 0.02;
/// The script: full speed (rad/s), start and ramp (s).
const SPEED: f64 = 0.35;
const START: f64 = 1.0;
const RAMP: f64 = 1.0;

/// The chain from the drum: `link0` … `link5` (hanging at load), then `tail0` … `tail43`.
fn chain() -> Vec<String> {
    (0..6).map(|i| format!("link{i}")).chain((0..44).map(|i| format!("tail{i}"))).collect()
}

fn body_index(run: &SceneRun, name: &str) -> usize {
    run.scene.world.body_id(name).unwrap_or_else(|| panic!("no body {name}")).index()
}

/// Angle of point `(x, z)` about the drum axis, growing as the drum winds (front moving up).
fn drum_angle(x: f64, z: f64) -> f64 {
    (z - DRUM_Z).atan2(x)
}

/// Total angle the drum turned: the hinge coordinate, with the whole turns counted by unwrapping
/// `link0`'s angle about the drum axis step by step (it stays within a fraction of a radian of the
/// hook, where it is joined to the drum).
fn drum_turned(run: &SceneRun) -> f64 {
    let world = &run.scene.world;
    let coordinate = world.joint_coordinate(world.joint_id("winch").expect("winch joint")).unwrap();
    let k = body_index(run, "link0");
    let (mut last, mut unwrapped) = (None::<f64>, 0.0);
    for p in &run.positions {
        let a = drum_angle(p[k].x, p[k].z);
        if let Some(l) = last {
            unwrapped += (a - l + PI).rem_euclid(TAU) - PI;
        }
        last = Some(a);
    }
    let turns = ((unwrapped - coordinate) / TAU).round();
    eprintln!(
        "winch: hinge coordinate {coordinate:.4} rad, link0 swept {unwrapped:.4} rad about the drum axis → \
         {turns} whole turns"
    );
    coordinate + turns * TAU
}

#[test]
fn winch_winds_the_chain_and_drags_its_tail_like_the_paper() {
    let run = run_builtin("winch", Variant::Skyline, None);
    let s = &run.summary;
    let world = &run.scene.world;
    let h = world.settings().timestep;
    eprintln!(
        "winch (skyline): {} steps, largest island {} rows / {} bodies, mass ratio {:.0}, solve mean {:.0} µs \
         p99 {:.0} µs, pivots mean {:.2} max {}, tight fraction max {:.3} (largest island, mean {:.3}), joint \
         error {:.2e} m, step cap hit {}×, real-time factor {:.1}",
        s.steps,
        s.max_island_rows,
        s.max_island_bodies,
        s.max_mass_ratio,
        s.mean_solve_us,
        s.p99_solve_us,
        s.mean_pivot_steps,
        s.max_pivot_steps,
        s.max_tight_fraction,
        s.mean_tight_fraction,
        s.max_joint_error_m,
        s.solves_max_steps,
        s.realtime_factor
    );
    assert_eq!(s.steps, 1200);
    assert!(s.max_joint_error_m <= 1e-4, "joint error {} m", s.max_joint_error_m);

    // The drum turned the scripted angle.
    let duration = s.steps as f64 * h;
    let planned = SPEED * (duration - START - RAMP / 2.0);
    let turned = drum_turned(&run);
    eprintln!("winch: drum turned {turned:.4} rad, script {planned:.4} rad");
    assert!((turned - planned).abs() <= 0.01 * planned, "drum turned {turned} rad, script {planned} rad");

    // The chain is wound on the drum from link0 on. A link lying on the drum touches it at its middle,
    // so its centre is WRAP_RADIUS from the axis (link0's, hanging from the hook, within 0.01 m).
    let names = chain();
    let on_drum: Vec<bool> = names
        .iter()
        .map(|n| {
            let p = final_position(&run, n);
            ((p.x.powi(2) + (p.z - DRUM_Z).powi(2)).sqrt() - WRAP_RADIUS).abs() < 0.02
        })
        .collect();
    let wrapped = on_drum.iter().take_while(|&&w| w).count();
    assert_eq!(
        on_drum.iter().filter(|&&w| w).count(),
        wrapped,
        "only a prefix of the chain lies on the drum"
    );
    // Each wrapped link spans the angle of a chord of one pitch between joints 0.53 m from the axis;
    // the free span leaves the drum in its upper front quadrant (toward a touchdown point in front
    // of and below the drum), so the wrapped arc is the turned angle less at most π/2.
    let r_joint = (WRAP_RADIUS.powi(2) + (PITCH / 2.0).powi(2)).sqrt();
    let per_link = 2.0 * (PITCH / 2.0 / r_joint).asin();
    let (lo, hi) = ((turned - FRAC_PI_2) / per_link, turned / per_link + 1.0);
    eprintln!("winch: {wrapped} links on the drum (expected {lo:.1} to {hi:.1}: {per_link:.3} rad per link)");
    assert!(
        wrapped as f64 >= lo && wrapped as f64 <= hi,
        "{wrapped} links wrapped, expected {lo:.1}–{hi:.1}"
    );

    // The tail followed. The chain is inextensible: the tail moves by the wound length less what the
    // suspended span between drum and ground gained. That span grows — it hung straight down 1.2 m
    // from the drum's front and now leaves from the top front as a catenary — but stays well under
    // the wound length, so the tail moves by at least half of it (measured: 72 %).
    let tail = names.last().unwrap();
    let (start, end) = (run.positions[0][body_index(&run, tail)], final_position(&run, tail));
    let moved = start.x - end.x;
    let wound = turned * WRAP_RADIUS;
    eprintln!(
        "winch: wound {wound:.3} m; {tail} moved {moved:.3} m toward the drum ({:.0} %), from x = {:.3} to {:.3}, \
         ends at z = {:.4}, y = {:.1e}",
        100.0 * moved / wound,
        start.x,
        end.x,
        end.z,
        end.y
    );
    assert!(moved >= 0.5 * wound && moved <= wound, "tail moved {moved} m of the wound {wound} m");
    assert!((end.z - LINK_RADIUS).abs() < 1e-3 && end.y.abs() < 1e-3, "the tail lies on the ground: {end:?}");

    // The tail's links touch the ground (two points each when flat), nothing else does.
    let ground = world.collider_id("ground").expect("ground collider");
    let mut ground_points = 0;
    let mut touching = std::collections::BTreeSet::new();
    for c in world.contacts().filter(|c| c.collider_a == ground || c.collider_b == ground) {
        let other = if c.collider_a == ground { c.collider_b } else { c.collider_a };
        let name = world.colliders()[other.index()].name().to_string();
        assert!(name.starts_with("tail"), "{name} touches the ground");
        ground_points += 1;
        touching.insert(name);
    }
    eprintln!("winch: {ground_points} contact points with the ground, {} links on it", touching.len());
    assert!(
        touching.len() >= 15 && ground_points >= 2 * touching.len() - 2,
        "{ground_points} points, {touching:?}"
    );

    // Many friction rows at their bounds: while the tail slides, each of its ground points has its
    // sliding-direction friction row at the Coulomb bound, about 2 N of 160 + 6 N + 3 n rows with N
    // links on the ground (20–26) and n on the drum: 0.15–0.18 (before sliding: < 0.04).
    assert!(s.max_tight_fraction >= 0.15, "tight fraction {}", s.max_tight_fraction);

    // Paper Table 2: largest island 370 rows, mass ratio 400:1.
    assert_near_paper("largest island rows", s.max_island_rows as f64, 370.0, 0.25);
    assert_near_paper("mass ratio", s.max_mass_ratio, 400.0, 0.25);

    // The same run with the dense full factorization.
    let full = run_builtin("winch", Variant::Full, None);
    let diff = max_trajectory_difference(&run, &full);
    eprintln!("winch: skyline vs full, largest trajectory difference {diff:.2e} m");
    assert!(diff <= 1e-6, "skyline and full trajectories differ by {diff} m");
}
