//! Terrain contacts keep the step allocation-free once warm: every convex shape of the contact
//! slice (box, ball, lying capsule, standing cylinder, convex hull) resting on a height field,
//! and the same on a triangle-mesh deck. The per-triangle manifolds of a terrain pair stay in place
//! from step to step (parry's own height-field driver rebuilds its manifold vector every call).
//! So do the convex pairs that need GJK/EPA (cylinder, capsule, hull on a slab and on each other):
//! the EPA buffers are reused (parry's query builds a new EPA, ~11 allocations, per overlapping
//! call).

use nalgebra::{UnitQuaternion, Vector3};
use pivotsim_server::dynamics::{
    BodyBuilder, ColliderBuilder, Shape, World, WorldSettings, box_inertia, capsule_inertia,
    cylinder_inertia, sphere_inertia, terrain,
};

#[path = "support/counting_alloc.rs"]
mod counting_alloc;
use counting_alloc::allocations_per_call;

fn scene(ground: Shape) -> World {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let g = w.add_body(BodyBuilder::static_body("ground")).unwrap();
    w.add_collider(ColliderBuilder::new("ground", g, ground)).unwrap();
    let mut add_at = |name: &str, m: f64, inertia: Vector3<f64>, x: Vector3<f64>, q, s: Shape| {
        let b = w.add_body(BodyBuilder::dynamic(name, m, inertia).position(x).orientation(q)).unwrap();
        w.add_collider(ColliderBuilder::new(name, b, s)).unwrap();
    };
    // A capsule lying along y.
    add_at(
        "capsule",
        1.0,
        capsule_inertia(1.0, 0.1, 0.3),
        Vector3::new(-1.2, 0.3, 0.1),
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2),
        Shape::Capsule { radius: 0.1, half_length: 0.3 },
    );
    let mut add = |name: &str, m: f64, inertia: Vector3<f64>, x: Vector3<f64>, s: Shape| {
        add_at(name, m, inertia, x, UnitQuaternion::identity(), s)
    };
    let e = Vector3::new(0.2, 0.2, 0.1);
    // Off the grid's diagonals: a box corner exactly on a triangle edge makes the clipped points of
    // the two triangles flicker (module doc of `contact/`).
    add("box", 1.0, box_inertia(1.0, e), Vector3::new(0.1, 0.35, 0.1), Shape::Cuboid { half_extents: e });
    add("ball", 1.0, sphere_inertia(1.0, 0.1), Vector3::new(1.3, 0.2, 0.1), Shape::Ball { radius: 0.1 });
    add(
        "cylinder",
        1.0,
        cylinder_inertia(1.0, 0.2, 0.15),
        Vector3::new(0.4, 1.1, 0.15),
        Shape::Cylinder { radius: 0.2, half_length: 0.15 },
    );
    let hull: Vec<_> = [(-1.0, -1.0), (1.0, -1.0), (0.0, 1.0)]
        .iter()
        .flat_map(|&(x, y)| [Vector3::new(0.2 * x, 0.2 * y, -0.1), Vector3::new(0.15 * x, 0.15 * y, 0.1)])
        .collect();
    add("hull", 1.0, Vector3::repeat(0.01), Vector3::new(0.3, -1.2, 0.1), Shape::ConvexHull { points: hull });
    w
}

#[test]
fn resting_terrain_contacts_allocate_nothing_once_warm() {
    for (what, ground) in [
        ("height field", terrain::hills(9, 9, 8.0, 8.0, |_, _| 0.0)),
        ("deck mesh", terrain::deck(4.0, 4.0, 8)),
    ] {
        let mut w = scene(ground);
        for _ in 0..240 {
            w.step().unwrap();
        }
        let per_step = allocations_per_call(20, || w.step().unwrap());
        let points = w.contacts().count();
        println!("{what}: {per_step} allocations per step, {points} contact points");
        assert!(points >= 4 + 1 + 1 + 3 + 3, "{what}: {points} points");
        for b in w.bodies().iter().skip(1) {
            assert!(b.linvel().norm() < 1e-8 && b.angvel().norm() < 1e-7, "{what}: {} moves", b.name());
        }
        assert_eq!(per_step, 0.0, "{what}");
    }
}

#[test]
fn resting_polygonal_pairs_allocate_nothing_once_warm() {
    // Shapes that meet through GJK and, in penetration, EPA (a cylinder, a lying capsule and a
    // convex hull on a slab; a cylinder on the hull): the EPA buffers are reused, where parry's
    // own query builds a new EPA at every call.
    let mut w = World::new(WorldSettings::default()).unwrap();
    let g = w.add_body(BodyBuilder::static_body("ground")).unwrap();
    w.add_collider(ColliderBuilder::new("ground", g, Shape::HalfSpace { normal: Vector3::z() })).unwrap();
    let e = Vector3::new(1.0, 1.0, 0.1);
    let slab =
        w.add_body(BodyBuilder::dynamic("slab", 20.0, box_inertia(20.0, e)).position(Vector3::z() * 0.1));
    w.add_collider(ColliderBuilder::new("slab", slab.unwrap(), Shape::Cuboid { half_extents: e })).unwrap();
    let mut add = |name: &str, x: Vector3<f64>, q: UnitQuaternion<f64>, inertia: Vector3<f64>, s: Shape| {
        let b = w.add_body(BodyBuilder::dynamic(name, 1.0, inertia).position(x).orientation(q)).unwrap();
        w.add_collider(ColliderBuilder::new(name, b, s)).unwrap();
    };
    let id = UnitQuaternion::identity();
    let cyl = Shape::Cylinder { radius: 0.2, half_length: 0.15 };
    add("cylinder", Vector3::new(0.5, 0.5, 0.35), id, cylinder_inertia(1.0, 0.2, 0.15), cyl.clone());
    let lying = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2);
    let capsule = Shape::Capsule { radius: 0.1, half_length: 0.3 };
    add("capsule", Vector3::new(-0.5, 0.4, 0.3), lying, capsule_inertia(1.0, 0.1, 0.3), capsule);
    let sign = |i: i32, bit: i32| if i & bit == 0 { -1.0 } else { 1.0 };
    let corners: Vec<_> =
        (0..8).map(|i| Vector3::new(0.3 * sign(i, 1), 0.3 * sign(i, 2), 0.1 * sign(i, 4))).collect();
    add(
        "hull",
        Vector3::new(0.0, -0.5, 0.3),
        id,
        Vector3::repeat(0.03),
        Shape::ConvexHull { points: corners },
    );
    add("on hull", Vector3::new(0.0, -0.5, 0.55), id, cylinder_inertia(1.0, 0.2, 0.15), cyl);
    for _ in 0..240 {
        w.step().unwrap();
    }
    let per_step = allocations_per_call(20, || w.step().unwrap());
    let points = w.contacts().count();
    println!(
        "cylinder, capsule, hull on a slab, cylinder on the hull: {per_step} allocations per step, {points} points"
    );
    for b in w.bodies().iter().skip(1) {
        assert!(b.linvel().norm() < 1e-8 && b.angvel().norm() < 1e-7, "{} moves", b.name());
    }
    assert!(points >= 4 + 3 + 2 + 4 + 3, "{points} points");
    assert_eq!(per_step, 0.0);
}
