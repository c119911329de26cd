//! Compound colliders (issue 5): a table (a top slab on two legs, one compound collider) with a
//! ball on its top stands on the ground on both legs, the ground's normal impulses summing to
//! `(m + m_ball) g h` and the ball's to `m_ball g h`, without creeping; malformed compounds are
//! refused at build time.

use nalgebra::{Isometry3, Vector3};
use pivotsim_server::dynamics::{
    BodyBuilder, ColliderBuilder, ContactError, Shape, World, WorldSettings, box_inertia, sphere_inertia,
};

fn cuboid(x: f64, y: f64, z: f64) -> Shape {
    Shape::Cuboid { half_extents: Vector3::new(x, y, z) }
}

#[test]
fn table_compound_stands_on_both_legs() {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let h = w.settings().timestep;
    let g = w.add_body(BodyBuilder::static_body("ground")).unwrap();
    w.add_collider(ColliderBuilder::new("ground", g, Shape::HalfSpace { normal: Vector3::z() })).unwrap();
    // Body origin 0.3 m above the ground; top slab 0.6 × 0.4 × 0.1 m at the origin, legs
    // 0.1 × 0.4 × 0.25 m under its ends, reaching the ground.
    let m = 5.0;
    let table = w
        .add_body(
            BodyBuilder::dynamic("table", m, box_inertia(m, Vector3::new(0.3, 0.2, 0.175)))
                .position(Vector3::new(0.0, 0.0, 0.3)),
        )
        .unwrap();
    let parts = vec![
        (Isometry3::identity(), cuboid(0.3, 0.2, 0.05)),
        (Isometry3::translation(-0.25, 0.0, -0.175), cuboid(0.05, 0.2, 0.125)),
        (Isometry3::translation(0.25, 0.0, -0.175), cuboid(0.05, 0.2, 0.125)),
    ];
    let tc = w.add_collider(ColliderBuilder::new("table", table, Shape::Compound { parts })).unwrap();
    let (mb, r) = (1.0, 0.05);
    let ball = w
        .add_body(BodyBuilder::dynamic("ball", mb, sphere_inertia(mb, r)).position(Vector3::new(
            0.1,
            0.0,
            0.35 + r,
        )))
        .unwrap();
    let bc = w.add_collider(ColliderBuilder::new("ball", ball, Shape::Ball { radius: r })).unwrap();
    let x0 = w.body(table).unwrap().position();
    let (mut worst, mut worst_ball, mut drift, mut sink): (f64, f64, f64, f64) = (0.0, 0.0, 0.0, 0.0);
    for k in 1..=600 {
        w.step().unwrap();
        if k > 60 {
            let sum = |ball_pair: bool| -> f64 {
                w.contacts()
                    .filter(|c| (c.collider_a == bc || c.collider_b == bc) == ball_pair)
                    .map(|c| c.normal_impulse * c.normal.z.abs())
                    .sum()
            };
            let weight = (m + mb) * 9.81 * h;
            worst = worst.max((sum(false) - weight).abs() / weight);
            worst_ball = worst_ball.max((sum(true) - mb * 9.81 * h).abs() / (mb * 9.81 * h));
        }
        let x = w.body(table).unwrap().position();
        drift = drift.max((x - x0).xy().norm());
        sink = sink.max((x.z - x0.z).abs());
    }
    let points: Vec<_> = w.contacts().filter(|c| c.collider_a != bc && c.collider_b != bc).collect();
    let ball_points = w.contacts().count() - points.len();
    let ball_drift = (w.body(ball).unwrap().position() - Vector3::new(0.1, 0.0, 0.35 + r)).norm();
    let left = points.iter().filter(|c| c.point_b.x.min(c.point_a.x) < 0.0).count();
    let tilt = w.body(table).unwrap().orientation().angle();
    eprintln!(
        "compound table ({m} kg, 3 parts) 10 s: {} contact points ({left} under the left leg), Σ λ_n rel err vs (m + m_ball) g h \
         {worst:.2e} (after 1 s), drift {drift:.2e} m, |Δz| {sink:.2e} m, tilt {tilt:.2e} rad; ball on the top: \
         {ball_points} point(s), Σ λ_n rel err vs m_ball g h {worst_ball:.2e}, moved {ball_drift:.2e} m",
        points.len()
    );
    assert!(points.iter().all(|c| c.collider_a == tc || c.collider_b == tc));
    assert_eq!((points.len(), left), (8, 4), "four corners under each leg");
    assert!(worst < 1e-9, "{worst:e}");
    assert_eq!(ball_points, 1);
    assert!(worst_ball < 1e-9 && ball_drift < 1e-6, "{worst_ball:e} {ball_drift:e}");
    assert!(drift < 1e-6 && sink < 1e-6 && tilt < 1e-6, "{drift:e} {sink:e} {tilt:e}");
}

#[test]
fn malformed_compounds_are_refused() {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let b = w.add_body(BodyBuilder::dynamic("b", 1.0, Vector3::new(1.0, 1.0, 1.0))).unwrap();
    let one = |s: Shape| vec![(Isometry3::identity(), s)];
    let cases = [
        (Shape::Compound { parts: vec![] }, "needs 1 to 1024 parts"),
        (
            Shape::Compound { parts: one(Shape::HalfSpace { normal: Vector3::z() }) },
            "a part cannot be a half-space",
        ),
        (
            Shape::Compound { parts: one(Shape::Compound { parts: one(cuboid(1.0, 1.0, 1.0)) }) },
            "a part cannot be a compound",
        ),
        (
            Shape::Compound {
                parts: vec![(Isometry3::translation(f64::NAN, 0.0, 0.0), cuboid(1.0, 1.0, 1.0))],
            },
            "a part's pose is invalid",
        ),
    ];
    for (shape, reason) in cases {
        let err = w.add_collider(ColliderBuilder::new("c", b, shape)).unwrap_err();
        assert_eq!(err, ContactError::InvalidCompound { collider: "c".into(), reason });
    }
    // A degenerate part is refused with its own error.
    let err = w
        .add_collider(ColliderBuilder::new("c", b, Shape::Compound { parts: one(cuboid(1.0, 0.0, 1.0)) }))
        .unwrap_err();
    assert!(matches!(err, ContactError::InvalidSize { what: "half extent y", .. }), "{err:?}");
    assert!(w.colliders().is_empty());
}
