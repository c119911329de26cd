//! Contacts with Coulomb friction against analytic mechanics (issue 5, first slice): a box resting
//! on flat ground carries exactly its weight and does not creep, a box on an incline sticks when
//! `tan θ < μ` and otherwise slides with `a = g (sin θ − μ cos θ)` (as a cuboid and as the convex
//! hull of its corners), a dropped ball comes to rest,
//! a friction coefficient set per collider pair overrides the materials', and degenerate shapes are
//! refused at build time.

use nalgebra::{UnitQuaternion, Vector3};
use pivotsim_server::dynamics::{
    BodyBuilder, BodyId, ColliderBuilder, ContactError, Shape, World, WorldSettings, box_inertia,
    sphere_inertia,
};

const G: f64 = 9.81;
const H: f64 = 1.0 / 60.0;

/// A world with a static half-space ground through the origin, tilted by `theta` about `y`.
fn world_with_ground(theta: f64, mu: f64) -> (World, UnitQuaternion<f64>) {
    let mut w = World::new(WorldSettings { timestep: H, ..Default::default() }).unwrap();
    let tilt = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), theta);
    let ground = w.add_body(BodyBuilder::static_body("ground").orientation(tilt)).unwrap();
    w.add_collider(
        ColliderBuilder::new("ground", ground, Shape::HalfSpace { normal: Vector3::z() }).friction(mu),
    )
    .unwrap();
    (w, tilt)
}

/// A box of half extents `e` and mass `m` resting on the (tilted) ground.
fn add_box(w: &mut World, tilt: &UnitQuaternion<f64>, e: Vector3<f64>, m: f64, mu: f64) -> BodyId {
    add_box_shape(w, tilt, e, m, mu, Shape::Cuboid { half_extents: e })
}

/// The same box with the shape `shape` (a cuboid or the convex hull of its corners).
fn add_box_shape(
    w: &mut World,
    tilt: &UnitQuaternion<f64>,
    e: Vector3<f64>,
    m: f64,
    mu: f64,
    shape: Shape,
) -> BodyId {
    let b = w
        .add_body(
            BodyBuilder::dynamic("box", m, box_inertia(m, e))
                .position(tilt * Vector3::new(0.0, 0.0, e.z))
                .orientation(*tilt),
        )
        .unwrap();
    w.add_collider(ColliderBuilder::new("box", b, shape).friction(mu)).unwrap();
    b
}

#[test]
fn box_at_rest_carries_its_weight_and_does_not_creep() {
    let (mut w, tilt) = world_with_ground(0.0, 1.0);
    let m = 2.0;
    let b = add_box(&mut w, &tilt, Vector3::new(0.2, 0.3, 0.1), m, 1.0);
    let x0 = w.body(b).unwrap().position();
    let (mut worst_weight, mut settled, mut worst_drift, mut worst_z): (f64, f64, f64, f64) =
        (0.0, 0.0, 0.0, 0.0);
    let mut points = 0;
    for n in 0..1200 {
        w.step().unwrap();
        let sum: f64 = w.contacts().map(|c| c.normal_impulse * c.normal.z).sum();
        points = w.contacts().count();
        let rel = (sum - m * G * H).abs() / (m * G * H);
        if n >= 2 {
            worst_weight = worst_weight.max(rel);
        }
        if n >= 60 {
            settled = settled.max(rel);
        }
        let x = w.body(b).unwrap().position();
        worst_drift = worst_drift.max((x - x0).xy().norm());
        worst_z = worst_z.max((x.z - x0.z).abs());
    }
    let q = w.body(b).unwrap().orientation();
    eprintln!(
        "box at rest 20 s: {points} points, normal impulse sum rel err {worst_weight:.2e} (from step 3), \
         {settled:.2e} (after 1 s), horizontal drift \
         {worst_drift:.2e} m, |Δz| {worst_z:.2e} m, rotation {:.2e} rad",
        q.angle()
    );
    assert_eq!(points, 4);
    assert!(worst_weight < 1e-6, "normal impulses sum to m g h: rel err {worst_weight:e}");
    assert!(settled < 1e-10, "settled: rel err {settled:e}");
    assert!(worst_drift < 1e-6, "no horizontal creep: {worst_drift:e} m");
    assert!(worst_z < 1e-6, "no sinking: {worst_z:e} m");
    assert!(q.angle() < 1e-6);
}

/// Displacement along the slope after `steps` and the mean acceleration from step 30 to `steps`.
fn incline(theta: f64, mu: f64, steps: usize, hull: bool) -> (f64, f64) {
    let (mut w, tilt) = world_with_ground(theta, mu);
    let e = Vector3::new(0.3, 0.3, 0.1);
    let shape = if hull {
        let corners = (0..8).map(|i| {
            let s = |bit: i32| if i & bit == 0 { -1.0 } else { 1.0 };
            Vector3::new(s(1) * e.x, s(2) * e.y, s(4) * e.z)
        });
        Shape::ConvexHull { points: corners.collect() }
    } else {
        Shape::Cuboid { half_extents: e }
    };
    let b = add_box_shape(&mut w, &tilt, e, 1.5, mu, shape);
    // Downhill along the slope: the tilted x axis points up the slope for theta > 0 about y
    // (z tilts towards +x), so downhill is -x' ... pick the direction of gravity's tangential part.
    let n = tilt * Vector3::z();
    let g = Vector3::new(0.0, 0.0, -G);
    let down = (g - n * n.dot(&g)).normalize();
    let x0 = w.body(b).unwrap().position();
    let (mut v30, mut t30) = (0.0, 0.0);
    for k in 1..=steps {
        w.step().unwrap();
        if k == 30 {
            v30 = w.body(b).unwrap().linvel().dot(&down);
            t30 = w.time();
        }
    }
    let body = w.body(b).unwrap();
    let a = (body.linvel().dot(&down) - v30) / (w.time() - t30);
    ((body.position() - x0).dot(&down), a)
}

#[test]
fn box_on_incline_sticks_below_the_friction_angle() {
    let theta = 30f64.to_radians();
    let mu = 0.8; // tan 30° = 0.577 < 0.8
    let (d, a) = incline(theta, mu, 600, false);
    eprintln!("incline 30°, μ = 0.8 (sticks): displacement after 10 s {d:.2e} m, acceleration {a:.2e} m/s²");
    assert!(d.abs() < 1e-5, "sticks: {d:e} m");
}

#[test]
fn box_on_incline_slides_with_coulomb_acceleration() {
    let theta = 30f64.to_radians();
    for (mu, hull) in [(0.3, false), (0.5, false), (0.0, false), (0.3, true)] {
        let (d, a) = incline(theta, mu, 180, hull);
        let expected = G * (theta.sin() - mu * theta.cos());
        let rel = (a - expected).abs() / expected;
        eprintln!(
            "incline 30°, μ = {mu}, {}: acceleration {a:.6} m/s² vs g(sin θ − μ cos θ) = {expected:.6} (rel err {rel:.2e}), \
             slid {d:.3} m",
            if hull { "convex hull" } else { "cuboid" }
        );
        assert!(rel < 0.02, "μ = {mu}: a = {a}, expected {expected}");
    }
}

#[test]
fn dropped_ball_comes_to_rest() {
    let (mut w, _) = world_with_ground(0.0, 1.0);
    let r = 0.1;
    let ball = w
        .add_body(
            BodyBuilder::dynamic("ball", 1.0, sphere_inertia(1.0, r)).position(Vector3::new(0.0, 0.0, 1.0)),
        )
        .unwrap();
    w.add_collider(ColliderBuilder::new("ball", ball, Shape::Ball { radius: r })).unwrap();
    let mut max_after_impact: f64 = 0.0;
    let mut landed = false;
    for _ in 0..300 {
        w.step().unwrap();
        let b = w.body(ball).unwrap();
        if w.contacts().any(|c| c.normal_impulse > 0.0) {
            landed = true;
        }
        if landed {
            max_after_impact = max_after_impact.max(b.position().z);
        }
    }
    let b = w.body(ball).unwrap();
    eprintln!(
        "ball dropped from 1 m: rest height {:.9} m (radius {r}), speed {:.2e} m/s, max height after impact {:.6} m",
        b.position().z,
        b.linvel().norm(),
        max_after_impact
    );
    assert!(landed);
    assert!((b.position().z - r).abs() < 1e-4, "rests on the ground: z = {}", b.position().z);
    assert!(b.linvel().norm() < 1e-6 && b.angvel().norm() < 1e-6);
    assert!(max_after_impact < r + 0.02, "no bounce: {max_after_impact}");
}

#[test]
fn degenerate_shapes_are_refused() {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let b = w.add_body(BodyBuilder::dynamic("b", 1.0, Vector3::repeat(0.1))).unwrap();
    let ground = w.add_body(BodyBuilder::static_body("ground")).unwrap();
    let add = |w: &mut World, s: Shape| w.add_collider(ColliderBuilder::new("c", b, s));
    assert!(matches!(add(&mut w, Shape::Ball { radius: 0.0 }), Err(ContactError::InvalidSize { .. })));
    assert!(matches!(add(&mut w, Shape::Ball { radius: f64::NAN }), Err(ContactError::InvalidSize { .. })));
    assert!(matches!(
        add(&mut w, Shape::Cuboid { half_extents: Vector3::new(1.0, 0.0, 1.0) }),
        Err(ContactError::InvalidSize { what: "half extent y", .. })
    ));
    assert!(matches!(
        add(&mut w, Shape::Capsule { radius: -1.0, half_length: 1.0 }),
        Err(ContactError::InvalidSize { .. })
    ));
    assert!(matches!(
        add(&mut w, Shape::Cylinder { radius: 0.5, half_length: 0.0 }),
        Err(ContactError::InvalidSize { .. })
    ));
    let cube: Vec<_> =
        (0..8).map(|i| Vector3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64)).collect();
    let mut nan = cube.clone();
    nan[5].y = f64::NAN;
    assert!(matches!(
        add(&mut w, Shape::ConvexHull { points: nan }),
        Err(ContactError::NonFiniteVertex { index: 5, .. })
    ));
    let flat: Vec<_> = cube.iter().map(|p| Vector3::new(p.x, p.y, 0.0)).collect();
    assert!(matches!(
        add(&mut w, Shape::ConvexHull { points: flat }),
        Err(ContactError::DegenerateHull { .. })
    ));
    let same = vec![Vector3::new(1.0, 2.0, 3.0); 6];
    assert!(matches!(
        add(&mut w, Shape::ConvexHull { points: same }),
        Err(ContactError::DegenerateHull { .. })
    ));
    assert!(matches!(
        add(&mut w, Shape::HalfSpace { normal: Vector3::z() }),
        Err(ContactError::UnboundedOnDynamic { .. })
    ));
    assert!(matches!(
        w.add_collider(ColliderBuilder::new(
            "g",
            ground,
            Shape::HalfSpace { normal: Vector3::new(0.0, 0.0, 2.0) }
        )),
        Err(ContactError::NonUnitNormal { .. })
    ));
    assert!(matches!(
        w.add_collider(ColliderBuilder::new("c", b, Shape::Ball { radius: 1.0 }).friction(-0.1)),
        Err(ContactError::InvalidFriction { .. })
    ));
    // Valid shapes of every kind are accepted.
    assert!(add(&mut w, Shape::ConvexHull { points: cube }).is_ok());
    for (i, s) in [
        Shape::Ball { radius: 0.1 },
        Shape::Cuboid { half_extents: Vector3::repeat(0.1) },
        Shape::Capsule { radius: 0.1, half_length: 0.0 },
        Shape::Cylinder { radius: 0.1, half_length: 0.2 },
    ]
    .into_iter()
    .enumerate()
    {
        assert!(w.add_collider(ColliderBuilder::new(&format!("ok{i}"), b, s)).is_ok());
    }
    assert!(matches!(
        w.add_collider(ColliderBuilder::new("ok0", b, Shape::Ball { radius: 1.0 })),
        Err(ContactError::DuplicateName { .. })
    ));
}

#[test]
fn pair_friction_overrides_the_materials() {
    // Materials μ = 1 (sticks at 30°), the pair set to 0.3: slides with g (sin θ − 0.3 cos θ).
    let theta = 30f64.to_radians();
    let (mut w, tilt) = world_with_ground(theta, 1.0);
    let b = add_box(&mut w, &tilt, Vector3::new(0.3, 0.3, 0.1), 1.5, 1.0);
    let (g, bx) = (w.collider_id("ground").unwrap(), w.collider_id("box").unwrap());
    w.set_pair_friction(bx, g, Some(0.3)).unwrap();
    assert!(matches!(w.set_pair_friction(bx, g, Some(f64::NAN)), Err(ContactError::InvalidFriction { .. })));
    assert!(matches!(
        w.set_pair_friction(bx, pivotsim_server::dynamics::ColliderId(7), Some(0.3)),
        Err(ContactError::UnknownCollider(_))
    ));
    let v_down = |w: &World| w.body(b).unwrap().linvel().norm();
    for _ in 0..30 {
        w.step().unwrap();
    }
    let (v0, t0) = (v_down(&w), w.time());
    for _ in 0..60 {
        w.step().unwrap();
    }
    let a = (v_down(&w) - v0) / (w.time() - t0);
    let expected = G * (theta.sin() - 0.3 * theta.cos());
    eprintln!("pair friction 0.3 over materials 1.0: acceleration {a:.6} vs {expected:.6}");
    assert!((a - expected).abs() / expected < 0.02);
    // Cleared: back to the materials' μ = 1, the box sticks (decelerates to rest).
    w.set_pair_friction(g, bx, None).unwrap();
    for _ in 0..120 {
        w.step().unwrap();
    }
    assert!(v_down(&w) < 1e-6, "sticks again: {}", v_down(&w));
}
