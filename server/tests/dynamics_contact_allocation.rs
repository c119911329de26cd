//! Contacts keep the step allocation-free once warm: a resting scene with every shape of the
//! contact slice (boxes stacked, a ball, a standing capsule, a standing cylinder, a convex hull) on a
//! half-space ground. parry's manifolds and workspaces are cached per pair and the contact
//! warm-start map keeps its keys, so a step with persistent contacts allocates nothing.

use nalgebra::Vector3;
use pivotsim_server::dynamics::{
    BodyBuilder, ColliderBuilder, Shape, World, WorldSettings, box_inertia, capsule_inertia,
    cylinder_inertia, sphere_inertia,
};

#[path = "support/counting_alloc.rs"]
mod counting_alloc;
use counting_alloc::allocations_per_call;

fn scene() -> World {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let ground = w.add_body(BodyBuilder::static_body("ground")).unwrap();
    w.add_collider(ColliderBuilder::new("ground", ground, Shape::HalfSpace { normal: Vector3::z() }))
        .unwrap();
    let mut add = |name: &str, m: f64, inertia: Vector3<f64>, x: Vector3<f64>, s: Shape| {
        let b = w.add_body(BodyBuilder::dynamic(name, m, inertia).position(x)).unwrap();
        w.add_collider(ColliderBuilder::new(name, b, s)).unwrap();
    };
    let e = Vector3::new(0.2, 0.2, 0.1);
    for k in 0..3 {
        let x = Vector3::new(0.0, 0.0, 0.1 + 0.2 * k as f64);
        add(&format!("box{k}"), 1.0, box_inertia(1.0, e), x, Shape::Cuboid { half_extents: e });
    }
    add("ball", 1.0, sphere_inertia(1.0, 0.1), Vector3::new(1.0, 0.0, 0.1), Shape::Ball { radius: 0.1 });
    add(
        "capsule",
        1.0,
        capsule_inertia(1.0, 0.1, 0.3),
        Vector3::new(-1.0, 0.0, 0.1),
        Shape::Capsule { radius: 0.1, half_length: 0.3 },
    );
    add(
        "cylinder",
        1.0,
        cylinder_inertia(1.0, 0.2, 0.15),
        Vector3::new(0.0, 1.0, 0.15),
        Shape::Cylinder { radius: 0.2, half_length: 0.15 },
    );
    let hull: Vec<_> = [(-1.0, -1.0), (1.0, -1.0), (0.0, 1.0)]
        .iter()
        .flat_map(|&(x, y)| [Vector3::new(0.2 * x, 0.2 * y, -0.1), Vector3::new(0.15 * x, 0.15 * y, 0.1)])
        .collect();
    add("hull", 1.0, Vector3::repeat(0.01), Vector3::new(0.0, -1.0, 0.1), Shape::ConvexHull { points: hull });
    w
}

#[test]
fn resting_contacts_allocate_nothing_once_warm() {
    let mut w = scene();
    // 8 s: the stack of three boxes settles into its compliant contacts with speeds of a few
    // 1e-9 m/s still at 4 s (by 1e-10 m in all; how long depends on rounding), 1e-15 from 8 s on.
    for _ in 0..480 {
        w.step().unwrap();
    }
    let per_step = allocations_per_call(20, || w.step().unwrap());
    let points = w.contacts().count();
    let rows: usize = w.island_stats().iter().map(|s| s.rows).sum();
    println!("contact scene: {per_step} allocations per step, {points} contact points, {rows} rows");
    assert!(points >= 4 * 3 + 1 + 2 + 3);
    assert!(w.bodies().iter().skip(1).all(|b| b.position().z > 0.0 && b.linvel().norm() < 1e-9));
    assert_eq!(per_step, 0.0);
}
