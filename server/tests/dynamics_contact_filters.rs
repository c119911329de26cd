//! Collision filtering (issue 5): collision groups per collider (two colliders collide only if each
//! one's memberships intersect the other's filter) and the opt-in for bodies joined by a joint.

use nalgebra::Vector3;
use pivotsim_server::dynamics::{
    BodyBuilder, BodyId, ColliderBuilder, CollisionGroups, JointBuilder, Shape, World, WorldSettings,
    box_inertia,
};

const E: Vector3<f64> = Vector3::new(0.2, 0.2, 0.1);

fn add_box(w: &mut World, name: &str, x: Vector3<f64>, groups: CollisionGroups) -> BodyId {
    let b = w.add_body(BodyBuilder::dynamic(name, 1.0, box_inertia(1.0, E)).position(x)).unwrap();
    w.add_collider(ColliderBuilder::new(name, b, Shape::Cuboid { half_extents: E }).groups(groups)).unwrap();
    b
}

#[test]
fn collision_groups_filter_pairs() {
    let (ground_g, ghost_g) = (CollisionGroups::new(0b01, u32::MAX), CollisionGroups::new(0b10, 0b10));
    assert!(CollisionGroups::default().interacts_with(CollisionGroups::default()));
    assert!(!ground_g.interacts_with(ghost_g) && !ghost_g.interacts_with(ground_g));
    assert!(CollisionGroups::ALL.interacts_with(ghost_g) && ghost_g.interacts_with(CollisionGroups::ALL));

    let mut w = World::new(WorldSettings::default()).unwrap();
    let g = w.add_body(BodyBuilder::static_body("ground")).unwrap();
    w.add_collider(
        ColliderBuilder::new("ground", g, Shape::HalfSpace { normal: Vector3::z() }).groups(ground_g),
    )
    .unwrap();
    // A ghost (group 2, filter 2) does not meet the ground (group 1) and falls through it; a solid
    // box (all groups) rests on the ground, and a second ghost dropped onto it lands on it.
    let ghost = add_box(&mut w, "ghost", Vector3::new(-1.0, 0.0, 0.1), ghost_g);
    let solid = add_box(&mut w, "solid", Vector3::new(1.0, 0.0, 0.1), CollisionGroups::ALL);
    let rider = add_box(&mut w, "rider", Vector3::new(1.0, 0.0, 0.4), ghost_g);
    for _ in 0..60 {
        w.step().unwrap();
    }
    let z = |w: &World, b: BodyId| w.body(b).unwrap().position().z;
    let (zg, zs, zr) = (z(&w, ghost), z(&w, solid), z(&w, rider));
    eprintln!(
        "after 1 s: ghost z = {zg:.4} m (fell through), solid z = {zs:.9} m, rider z = {zr:.9} m (on the solid)"
    );
    assert!(zg < -4.0, "the ghost falls through the ground: {zg}");
    assert!((zs - 0.1).abs() < 1e-6, "{zs}");
    assert!((zr - 0.3).abs() < 1e-6, "{zr}");
    // Changed at run time: with an empty filter the rider collides with nothing (not even the
    // solid box, a member of all groups) and falls through.
    let rc = w.collider_id("rider").unwrap();
    w.set_collision_groups(rc, CollisionGroups::new(0b10, 0)).unwrap();
    assert_eq!(w.colliders()[rc.index()].groups(), CollisionGroups::new(0b10, 0));
    for _ in 0..60 {
        w.step().unwrap();
    }
    let zr = z(&w, rider);
    eprintln!("rider with an empty filter after another 1 s: z = {zr:.4} m");
    assert!(zr < -4.0, "{zr}");
}

/// A box on the ground and a second box dropped onto it, joined to it by a vertical slider: where
/// the dropped box comes to rest, with and without `collide_connected`.
fn slider_drop(collide: bool) -> f64 {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let g = w.add_body(BodyBuilder::static_body("ground")).unwrap();
    w.add_collider(ColliderBuilder::new("ground", g, Shape::HalfSpace { normal: Vector3::z() })).unwrap();
    let base = add_box(&mut w, "base", Vector3::new(0.0, 0.0, 0.1), CollisionGroups::ALL);
    let top = add_box(&mut w, "top", Vector3::new(0.0, 0.0, 0.6), CollisionGroups::ALL);
    w.add_joint(
        JointBuilder::prismatic("slider", top, Some(base), Vector3::new(0.0, 0.0, 0.35), Vector3::z())
            .collide_connected(collide),
    )
    .unwrap();
    for _ in 0..120 {
        w.step().unwrap();
    }
    w.body(top).unwrap().position().z
}

#[test]
fn jointed_bodies_collide_only_when_asked() {
    let (apart, connected) = (slider_drop(false), slider_drop(true));
    eprintln!(
        "box dropped on a box it is joined to by a slider, after 2 s: z = {apart:.9} m (default: passes through, rests \
         on the ground), {connected:.9} m (collide_connected: rests on the box)"
    );
    assert!((apart - 0.1).abs() < 1e-5, "{apart}");
    assert!((connected - 0.3).abs() < 1e-5, "{connected}");
}
