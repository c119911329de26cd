//! Contact scenes beyond a single body on the ground (issue 5, first slice):
//! - a stack of ten boxes with mass ratio 100 between neighbours stays standing 20 s (skyline);
//! - a ball launched sliding ends up rolling without slipping at `v = 5/7 v₀` (angular momentum
//!   about the contact point is conserved);
//! - contact rows join islands (the ground does not merge them), bodies joined by a joint do not
//!   collide, and persistent contacts are warm-started (one linear solve per step while a box
//!   slides, against six cold);
//! - a capsule launched along its axis slides the implicit-Euler distance of a constant
//!   deceleration `μ g` (`v₀²/(2 μ g)` less `~v₀ h/2`);
//! - a lying cylinder launched sideways ends up rolling at `v = 2/3 v₀`.

use nalgebra::{UnitQuaternion, Vector3};
use pivotsim_server::dynamics::{
    BodyBuilder, ColliderBuilder, JointBuilder, Shape, World, WorldSettings, box_inertia, capsule_inertia,
    cylinder_inertia, sphere_inertia,
};
use pivotsim_server::solver::Variant;

fn ground(w: &mut World) {
    let g = w.add_body(BodyBuilder::static_body("ground")).unwrap();
    w.add_collider(ColliderBuilder::new("ground", g, Shape::HalfSpace { normal: Vector3::z() })).unwrap();
}

#[test]
fn stack_of_ten_boxes_with_mass_ratio_100_stays_standing() {
    let mut w = World::new(WorldSettings::default()).unwrap();
    assert_eq!(w.settings().solver.variant, Variant::Skyline);
    ground(&mut w);
    let n: usize = 10;
    let mut ids = Vec::new();
    let mut z = 0.0;
    for k in 0..n {
        // Alternately 1 kg and 100 kg (mass ratio 100 between neighbours), each box 1 cm narrower
        // than the one below.
        let e = Vector3::new(0.3 - 0.01 * k as f64, 0.3 - 0.01 * k as f64, 0.1);
        let m = if k % 2 == 0 { 1.0 } else { 100.0 };
        let b = w
            .add_body(BodyBuilder::dynamic(&format!("box{k}"), m, box_inertia(m, e)).position(Vector3::new(
                0.0,
                0.0,
                z + e.z,
            )))
            .unwrap();
        w.add_collider(ColliderBuilder::new(&format!("box{k}"), b, Shape::Cuboid { half_extents: e }))
            .unwrap();
        ids.push((b, w.body(b).unwrap().position()));
        z += 2.0 * e.z;
    }
    let (mut drift, mut tilt, mut sink, mut pivots, mut residual): (f64, f64, f64, usize, f64) =
        (0.0, 0.0, 0.0, 0, 0.0);
    for _ in 0..1200 {
        w.step().unwrap();
        let st = &w.island_stats()[0];
        pivots = pivots.max(st.pivot_steps);
        residual = residual.max(st.residual_rel);
        for &(b, x0) in &ids {
            let body = w.body(b).unwrap();
            drift = drift.max((body.position() - x0).xy().norm());
            sink = sink.max((body.position().z - x0.z).abs());
            tilt = tilt.max(body.orientation().angle());
        }
    }
    let points = w.contacts().count();
    eprintln!(
        "stack of {n} boxes (1 kg / 100 kg alternating), skyline, 20 s: {points} contact points, {} island(s), \
         horizontal drift {drift:.2e} m, tilt {tilt:.2e} rad, |Δz| {sink:.2e} m (compliance), max pivot steps {pivots}, \
         max relative residual {residual:.2e}",
        w.island_stats().len()
    );
    assert_eq!(points, 4 * n);
    assert_eq!(w.island_stats().len(), 1, "contacts join the stack into one island");
    assert!(drift < 1e-9 && tilt < 1e-9, "stands: drift {drift:e}, tilt {tilt:e}");
    // Compliance 1e-10 m/N under up to 505 kg: a few µm in all, at rest.
    assert!(sink < 1e-5, "{sink:e}");
    assert!(residual < 1e-12, "{residual:e}");
}

#[test]
fn sliding_ball_ends_up_rolling_without_slipping() {
    let mut w = World::new(WorldSettings::default()).unwrap();
    ground(&mut w);
    let (m, r, v0) = (2.0, 0.15, 1.0);
    let ball = w
        .add_body(
            BodyBuilder::dynamic("ball", m, sphere_inertia(m, r))
                .position(Vector3::new(0.0, 0.0, r))
                .linvel(Vector3::new(v0, 0.0, 0.0)),
        )
        .unwrap();
    w.add_collider(ColliderBuilder::new("ball", ball, Shape::Ball { radius: r }).friction(0.3)).unwrap();
    // Slipping phase: friction μ m g decelerates for t = 2 v₀ / (7 μ g) ≈ 0.097 s.
    for _ in 0..120 {
        w.step().unwrap();
    }
    let b = w.body(ball).unwrap();
    let slip = (b.linvel() + b.angvel().cross(&Vector3::new(0.0, 0.0, -r))).norm();
    let rel = (b.linvel().x - 5.0 / 7.0 * v0).abs() / (5.0 / 7.0 * v0);
    eprintln!(
        "ball v₀ = {v0} m/s, μ = 0.3: after 2 s v = {:.9} m/s (5/7 v₀ = {:.9}, rel err {rel:.2e}), slip speed {slip:.2e} m/s",
        b.linvel().x,
        5.0 / 7.0 * v0
    );
    assert!(slip < 1e-6, "rolls without slipping: {slip}");
    assert!(rel < 1e-3, "v = 5/7 v₀: rel err {rel}");
}

/// The scene of [`islands_joint_filter_and_warm_start`] after 0.2 s: (bodies, rows, pivot steps)
/// per island, the pivot steps of the sliding box's island at steps 2–12, and whether the welded
/// boxes touched each other.
fn islands_scene(warm_start: bool) -> (Vec<(usize, usize, usize)>, Vec<usize>, bool) {
    let mut w = World::new(WorldSettings { warm_start, ..Default::default() }).unwrap();
    ground(&mut w);
    let e = Vector3::new(0.2, 0.2, 0.1);
    let add = |w: &mut World, name: &str, x: Vector3<f64>| {
        let b = w.add_body(BodyBuilder::dynamic(name, 1.0, box_inertia(1.0, e)).position(x)).unwrap();
        w.add_collider(ColliderBuilder::new(name, b, Shape::Cuboid { half_extents: e })).unwrap();
        b
    };
    // Two boxes apart on the ground, one resting, one sliding (5 m/s, μ = 1): two islands. Two
    // overlapping boxes joined by a fixed joint, in the air: no contact between them (they would be
    // pushed apart otherwise).
    add(&mut w, "left", Vector3::new(-1.0, 0.0, 0.1));
    let right = add(&mut w, "right", Vector3::new(1.0, 0.0, 0.1));
    w.set_velocity(right, Vector3::new(5.0, 0.0, 0.0), Vector3::zeros()).unwrap();
    let a = add(&mut w, "a", Vector3::new(0.0, 3.0, 2.0));
    let b = add(&mut w, "b", Vector3::new(0.1, 3.0, 2.05));
    w.add_joint(JointBuilder::fixed("weld", a, Some(b), Vector3::new(0.05, 3.0, 2.0))).unwrap();
    let mut sliding = Vec::new();
    for k in 1..=12 {
        w.step().unwrap();
        if k >= 2 {
            sliding.push(w.island_stats()[1].pivot_steps);
        }
    }
    let ia = w.collider_id("a").unwrap();
    let ib = w.collider_id("b").unwrap();
    let touched = w.contacts().any(|c| (c.collider_a, c.collider_b) == (ia, ib));
    (w.island_stats().iter().map(|s| (s.bodies, s.rows, s.pivot_steps)).collect(), sliding, touched)
}

#[test]
fn islands_joint_filter_and_warm_start() {
    let (islands, warm, touched) = islands_scene(true);
    let (_, cold, _) = islands_scene(false);
    eprintln!(
        "islands (bodies, rows, pivot steps): {islands:?}; sliding box pivot steps per step: warm {warm:?}, cold {cold:?}"
    );
    assert!(!touched, "jointed bodies do not collide");
    // left and right (4 points × 3 rows each, one body each), the welded pair (6 joint rows).
    assert_eq!(islands.iter().map(|s| (s.0, s.1)).collect::<Vec<_>>(), [(1, 12), (1, 12), (2, 6)]);
    // Warm-started from the last index set (friction rows at their bounds, keyed by feature ids),
    // the sliding box's island is solved with its first linear solve; cold, it pivots.
    assert!(warm.iter().all(|&p| p == 1), "{warm:?}");
    assert!(cold.iter().all(|&p| p > 1), "{cold:?}");
}

#[test]
fn capsule_slides_to_the_coulomb_stopping_distance() {
    let mut w = World::new(WorldSettings::default()).unwrap();
    ground(&mut w);
    let (m, r, l, v0, mu) = (3.0, 0.1, 0.4, 2.0, 0.5);
    // Lying along x (body z → world x), launched along its axis.
    let q = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), std::f64::consts::FRAC_PI_2);
    let c = w
        .add_body(
            BodyBuilder::dynamic("capsule", m, capsule_inertia(m, r, l))
                .position(Vector3::new(0.0, 0.0, r))
                .orientation(q)
                .linvel(Vector3::new(v0, 0.0, 0.0)),
        )
        .unwrap();
    w.add_collider(
        ColliderBuilder::new("capsule", c, Shape::Capsule { radius: r, half_length: l }).friction(mu),
    )
    .unwrap();
    for _ in 0..60 {
        w.step().unwrap();
    }
    let points = w.contacts().count();
    let b = w.body(c).unwrap();
    // μ of the pair: the geometric mean with the ground's 1.0. Implicit Euler: v_k = v₀ − k μ g h
    // until it stops, x_n = h Σ v_k (the continuous v₀²/(2μg) less about v₀ h / 2).
    let mu_pair = (mu * 1.0f64).sqrt();
    let h = 1.0 / 60.0;
    let continuous = v0 * v0 / (2.0 * mu_pair * 9.81);
    let expected: f64 = (1..=60).map(|k| h * (v0 - k as f64 * mu_pair * 9.81 * h).max(0.0)).sum();
    let d = b.position().x;
    let rel = (d - expected).abs() / expected;
    eprintln!(
        "capsule v₀ = {v0} m/s, μ = {mu} (pair {mu_pair:.4}): {points} contact points, stopped after {d:.6} m (discrete {expected:.6}, \
         rel {rel:.2e}; continuous v₀²/(2μg) = {continuous:.5}), speed {:.2e} m/s, |Δz| {:.2e} m",
        b.linvel().norm(),
        (b.position().z - r).abs()
    );
    assert_eq!(points, 2);
    assert!(rel < 1e-6, "{d} vs {expected}");
    assert!((d - continuous).abs() < v0 * h, "{d} vs {continuous}");
    assert!(b.linvel().norm() < 1e-9 && b.angvel().norm() < 1e-9);
    assert!((b.position().z - r).abs() < 1e-6);
}

#[test]
fn lying_cylinder_ends_up_rolling() {
    let mut w = World::new(WorldSettings::default()).unwrap();
    ground(&mut w);
    let (m, r, l, v0) = (4.0, 0.25, 0.1, 1.5);
    // Axis along y (body z → world y), launched along x.
    let q = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2);
    let c = w
        .add_body(
            BodyBuilder::dynamic("wheel", m, cylinder_inertia(m, r, l))
                .position(Vector3::new(0.0, 0.0, r))
                .orientation(q)
                .linvel(Vector3::new(v0, 0.0, 0.0)),
        )
        .unwrap();
    w.add_collider(
        ColliderBuilder::new("wheel", c, Shape::Cylinder { radius: r, half_length: l }).friction(0.4),
    )
    .unwrap();
    for _ in 0..120 {
        w.step().unwrap();
    }
    let b = w.body(c).unwrap();
    let slip = (b.linvel() + b.angvel().cross(&Vector3::new(0.0, 0.0, -r))).norm();
    let expected = 2.0 / 3.0 * v0;
    let rel = (b.linvel().x - expected).abs() / expected;
    eprintln!(
        "lying cylinder v₀ = {v0} m/s: after 2 s v = {:.9} m/s (2/3 v₀ = {expected:.9}, rel {rel:.2e}), slip {slip:.2e} m/s, \
         |Δz| {:.2e} m, axis drift {:.2e}",
        b.linvel().x,
        (b.position().z - r).abs(),
        (b.orientation() * Vector3::z() - Vector3::new(0.0, -1.0, 0.0)).norm()
    );
    assert!(slip < 1e-6, "rolls without slipping: {slip}");
    assert!(rel < 1e-3, "v = 2/3 v₀: {rel}");
    assert!((b.position().z - r).abs() < 1e-5);
}
