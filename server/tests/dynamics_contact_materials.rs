//! The material-pair friction table (issue 5): colliders carry a material name; the `μ` of a pair
//! is, first match wins, the pair's own override ([`World::set_pair_friction`]), the table entry of
//! the two material names ([`World::set_material_friction`], symmetric), or the geometric mean of
//! the colliders' `Material::friction` (default 1.0). Checked through the query and through the
//! motion it causes: a box on a 30° incline slides with `a = g (sin θ − μ cos θ)` for the `μ` that
//! wins, and sticks when that `μ` exceeds `tan θ`. Bad coefficients and names are typed errors.

use nalgebra::{UnitQuaternion, Vector3};
use pivotsim_server::dynamics::{
    BodyBuilder, BodyId, ColliderBuilder, ColliderId, ContactError, DEFAULT_MATERIAL, Material, Shape, World,
    WorldSettings, box_inertia,
};

const G: f64 = 9.81;

/// A 30° incline of material `ground_material` (per-collider μ `ground_mu`) with a 1.5 kg box of
/// material `box_material` (per-collider μ `box_mu`) resting on it.
fn incline(ground_material: &str, ground_mu: f64, box_material: &str, box_mu: f64) -> (World, BodyId) {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let tilt = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 30f64.to_radians());
    let g = w.add_body(BodyBuilder::static_body("ground").orientation(tilt)).unwrap();
    w.add_collider(
        ColliderBuilder::new("ground", g, Shape::HalfSpace { normal: Vector3::z() })
            .material(Material { friction: ground_mu })
            .material_name(ground_material),
    )
    .unwrap();
    let e = Vector3::new(0.3, 0.3, 0.1);
    let b = w
        .add_body(
            BodyBuilder::dynamic("box", 1.5, box_inertia(1.5, e))
                .position(tilt * Vector3::new(0.0, 0.0, e.z))
                .orientation(tilt),
        )
        .unwrap();
    w.add_collider(
        ColliderBuilder::new("box", b, Shape::Cuboid { half_extents: e })
            .friction(box_mu)
            .material_name(box_material),
    )
    .unwrap();
    (w, b)
}

/// Mean acceleration down the slope from step 30 to 120.
fn acceleration(w: &mut World, b: BodyId) -> f64 {
    let speed = |w: &World| w.body(b).unwrap().linvel().norm();
    for _ in 0..30 {
        w.step().unwrap();
    }
    let (v0, t0) = (speed(w), w.time());
    for _ in 0..90 {
        w.step().unwrap();
    }
    (speed(w) - v0) / (w.time() - t0)
}

fn ids(w: &World) -> (ColliderId, ColliderId) {
    (w.collider_id("ground").unwrap(), w.collider_id("box").unwrap())
}

#[test]
fn precedence_pair_over_table_over_geometric_mean() {
    let (mut w, _) = incline("concrete", 0.4, "rubber", 0.9);
    let (g, b) = ids(&w);
    assert_eq!(w.colliders()[b.index()].material_name(), "rubber");
    // 3. Geometric mean of the per-collider coefficients.
    assert!((w.pair_friction(g, b).unwrap() - 0.6).abs() < 1e-15);
    // 2. The table entry of the material names, in either order.
    w.set_material_friction("rubber", "concrete", 0.85).unwrap();
    assert_eq!(w.pair_friction(b, g).unwrap(), 0.85);
    assert_eq!(w.material_friction("concrete", "rubber"), Some(0.85));
    // 1. The pair's own coefficient wins over the table.
    w.set_pair_friction(g, b, Some(0.2)).unwrap();
    assert_eq!(w.pair_friction(g, b).unwrap(), 0.2);
    w.set_material_friction("concrete", "rubber", 0.7).unwrap();
    assert_eq!(w.pair_friction(g, b).unwrap(), 0.2);
    // Clearing falls back one level at a time.
    w.set_pair_friction(b, g, None).unwrap();
    assert_eq!(w.pair_friction(g, b).unwrap(), 0.7);
    w.clear_material_friction("rubber", "concrete");
    assert_eq!(w.material_friction("rubber", "concrete"), None);
    assert!((w.pair_friction(g, b).unwrap() - 0.6).abs() < 1e-15);
    // Unnamed colliders are of the default material, with default μ = 1.
    let (mut w, _) = incline(DEFAULT_MATERIAL, 1.0, DEFAULT_MATERIAL, 1.0);
    let (g, b) = ids(&w);
    assert_eq!(w.colliders()[g.index()].material_name(), "default");
    assert_eq!(w.pair_friction(g, b).unwrap(), 1.0);
    w.set_material_friction("default", "default", 0.25).unwrap();
    assert_eq!(w.pair_friction(g, b).unwrap(), 0.25);
    // The table entry of another pair of materials does not apply.
    w.set_material_friction("default", "ice", 0.05).unwrap();
    assert_eq!(w.pair_friction(g, b).unwrap(), 0.25);
    assert!(matches!(w.pair_friction(g, ColliderId(9)), Err(ContactError::UnknownCollider(_))));
}

#[test]
fn table_entry_sets_the_sliding_acceleration() {
    let theta = 30f64.to_radians();
    let coulomb = |mu: f64| G * (theta.sin() - mu * theta.cos());
    // Per-collider μ 1.0 and 1.0 (sticks: tan 30° = 0.577), the table says ice on steel 0.1.
    let (mut w, b) = incline("steel", 1.0, "ice", 1.0);
    w.set_material_friction("ice", "steel", 0.1).unwrap();
    let a = acceleration(&mut w, b);
    eprintln!("table μ(ice, steel) = 0.1 over per-collider 1.0: a = {a:.6} vs {:.6}", coulomb(0.1));
    assert!((a - coulomb(0.1)).abs() / coulomb(0.1) < 0.02);
    // A pair override of 0.3 wins over the table.
    let (mut w, b) = incline("steel", 1.0, "ice", 1.0);
    w.set_material_friction("steel", "ice", 0.1).unwrap();
    let (g, bx) = ids(&w);
    w.set_pair_friction(g, bx, Some(0.3)).unwrap();
    let a = acceleration(&mut w, b);
    eprintln!("pair μ = 0.3 over table 0.1: a = {a:.6} vs {:.6}", coulomb(0.3));
    assert!((a - coulomb(0.3)).abs() / coulomb(0.3) < 0.02);
    // Per-collider 0.1 and 0.4 (mean 0.2: slides), the table entry 0.9 makes it stick.
    let (mut w, b) = incline("rubber", 0.1, "concrete", 0.4);
    w.set_material_friction("rubber", "concrete", 0.9).unwrap();
    let x0 = w.body(b).unwrap().position();
    for _ in 0..300 {
        w.step().unwrap();
    }
    let moved = (w.body(b).unwrap().position() - x0).norm();
    eprintln!("table μ(rubber, concrete) = 0.9 over the mean 0.2: moved {moved:.2e} m in 5 s");
    assert!(moved < 1e-5, "sticks: {moved:e} m");
    // Without the table entry, the geometric mean 0.2 lets it slide.
    let (mut w, b) = incline("rubber", 0.1, "concrete", 0.4);
    let a = acceleration(&mut w, b);
    assert!((a - coulomb(0.2)).abs() / coulomb(0.2) < 0.02, "a = {a}");
}

#[test]
fn bad_coefficients_and_names_are_typed_errors() {
    let (mut w, _) = incline("a", 1.0, "b", 1.0);
    for mu in [f64::NAN, -0.1, f64::INFINITY] {
        assert!(matches!(
            w.set_material_friction("a", "b", mu),
            Err(ContactError::InvalidMaterialFriction { value, .. }) if value.is_nan() == mu.is_nan()
        ));
    }
    assert!(matches!(w.set_material_friction("", "b", 0.5), Err(ContactError::EmptyMaterialName)));
    assert_eq!(w.material_friction("a", "b"), None, "a refused entry is not stored");
    assert!(w.set_material_friction("a", "b", 0.0).is_ok(), "μ = 0 is frictionless, valid");
    let body = w.add_body(BodyBuilder::dynamic("c", 1.0, Vector3::repeat(0.1))).unwrap();
    assert!(matches!(
        w.add_collider(ColliderBuilder::new("c", body, Shape::Ball { radius: 0.1 }).material_name("")),
        Err(ContactError::EmptyMaterialName)
    ));
}
