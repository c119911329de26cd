//! parry's manifolds of a round shape against a polygonal feature can repeat a point (a capsule
//! on a cylinder or a convex hull); the contact module keeps one row per point. Checked: no two
//! contact points of a collider pair coincide, the capsule rests with Σλ_n = m g h, and `skyline`
//! and `full` give the same trajectory (with a repeated row, `A` is singular and the two variants'
//! round-off drifts apart: 1.7e-5 m over 20 s in the winch scene before the fix).

use nalgebra::{UnitQuaternion, Vector3};
use pivotsim_server::dynamics::{BodyBuilder, ColliderBuilder, Shape, World, WorldSettings, capsule_inertia};
use pivotsim_server::solver::Variant;

const M: f64 = 2.0;

fn world(variant: Variant, drum: Shape) -> World {
    let mut s = WorldSettings::default();
    s.solver.variant = variant;
    let mut w = World::new(s).unwrap();
    let base = w.add_body(BodyBuilder::static_body("drum").position(Vector3::new(0.0, 0.0, 1.0))).unwrap();
    // The drum's axis along y (shapes are along z).
    let along_y = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2);
    w.add_collider(
        ColliderBuilder::new("drum", base, drum)
            .offset(nalgebra::Isometry3::from_parts(Default::default(), along_y)),
    )
    .unwrap();
    // A capsule across the drum (along x), resting on its top line.
    let along_x = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), std::f64::consts::FRAC_PI_2);
    let bar = w
        .add_body(
            BodyBuilder::dynamic("bar", M, capsule_inertia(M, 0.05, 0.4))
                .position(Vector3::new(0.0, 0.0, 1.0 + 0.5 + 0.05))
                .orientation(along_x),
        )
        .unwrap();
    w.add_collider(ColliderBuilder::new("bar", bar, Shape::Capsule { radius: 0.05, half_length: 0.4 }))
        .unwrap();
    w
}

#[test]
fn a_capsule_on_a_cylinder_or_hull_gets_distinct_points_and_identical_variants() {
    let hull: Vec<Vector3<f64>> = (0..16)
        .flat_map(|k| {
            let a = k as f64 * std::f64::consts::TAU / 16.0;
            [-0.6, 0.6].map(|z| Vector3::new(0.5 * a.cos(), 0.5 * a.sin(), z))
        })
        .collect();
    for drum in [Shape::Cylinder { radius: 0.5, half_length: 0.6 }, Shape::ConvexHull { points: hull }] {
        let (mut a, mut b) = (world(Variant::Skyline, drum.clone()), world(Variant::Full, drum.clone()));
        let mut diff: f64 = 0.0;
        for _ in 0..240 {
            a.step().unwrap();
            b.step().unwrap();
            diff = diff.max((a.bodies()[1].position() - b.bodies()[1].position()).norm());
            let pts: Vec<_> = a.contacts().collect();
            assert!(!pts.is_empty(), "the bar rests on the drum");
            for (i, p) in pts.iter().enumerate() {
                for q in &pts[i + 1..] {
                    assert!((p.point_a - q.point_a).norm() > 1e-9, "a repeated point: {p:?}");
                }
            }
        }
        let h = a.settings().timestep;
        let sum: f64 = a.contacts().map(|c| c.normal_impulse).sum();
        assert!((sum - M * 9.81 * h).abs() < 1e-9 * M * 9.81 * h.max(1.0), "Σλ_n = {sum}");
        assert!(diff < 1e-10, "{}: skyline and full differ by {diff}", drum.kind_name());
    }
}
