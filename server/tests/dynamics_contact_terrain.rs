//! Terrain contacts against analytic mechanics (issue 5): height fields and triangle meshes as
//! static ground.
//! - a box resting on a flat height field and on a flat deck mesh carries exactly its weight
//!   (`Σ λ_n = m g h`, over however many triangle contacts) and does not creep over 20 s;
//! - a box on a height-field ramp and on a tilted deck mesh sticks when `tan θ < μ`, otherwise slides
//!   with `a = g (sin θ − μ cos θ)`, crossing triangle edges without catching;
//! - a ball rolls down a height-field ramp without slipping at `a = 5/7 g sin θ`;
//! - a box dropped onto stairs comes to rest on the step below it at the tread height;
//! - persistent terrain contacts are warm-started (feature ids carry the triangle index).

use nalgebra::{UnitQuaternion, Vector3};
use pivotsim_server::dynamics::{
    BodyBuilder, BodyId, ColliderBuilder, Shape, World, WorldSettings, box_inertia, sphere_inertia, terrain,
};

const G: f64 = 9.81;
const H: f64 = 1.0 / 60.0;

fn world() -> World {
    World::new(WorldSettings { timestep: H, ..Default::default() }).unwrap()
}

/// A static body at `tilt` with the terrain `shape` (friction `mu`).
fn add_terrain(w: &mut World, shape: Shape, tilt: UnitQuaternion<f64>, mu: f64) {
    let g = w.add_body(BodyBuilder::static_body("terrain").orientation(tilt)).unwrap();
    w.add_collider(ColliderBuilder::new("terrain", g, shape).friction(mu)).unwrap();
}

/// A dynamic box of half extents `e`, mass `m` at `x` with orientation `q`.
fn add_box(
    w: &mut World,
    e: Vector3<f64>,
    m: f64,
    x: Vector3<f64>,
    q: UnitQuaternion<f64>,
    mu: f64,
) -> BodyId {
    let b = w.add_body(BodyBuilder::dynamic("box", m, box_inertia(m, e)).position(x).orientation(q)).unwrap();
    w.add_collider(ColliderBuilder::new("box", b, Shape::Cuboid { half_extents: e }).friction(mu)).unwrap();
    b
}

/// 20 s of a 2 kg box resting on `shape` (flat, `z = 0`): worst relative error of the vertical
/// normal impulses against `m g h` after 1 s, horizontal drift, sinking, tilt, number of points,
/// largest pivot count after 1 s.
fn rest_on(shape: Shape, x: Vector3<f64>) -> (f64, f64, f64, f64, usize, usize) {
    let mut w = world();
    add_terrain(&mut w, shape, UnitQuaternion::identity(), 1.0);
    let (m, e) = (2.0, Vector3::new(0.2, 0.3, 0.1));
    let b = add_box(&mut w, e, m, x + Vector3::new(0.0, 0.0, e.z), UnitQuaternion::identity(), 1.0);
    let x0 = w.body(b).unwrap().position();
    let (mut weight, mut drift, mut sink, mut points, mut pivots): (f64, f64, f64, usize, usize) =
        (0.0, 0.0, 0.0, 0, 0);
    for k in 1..=1200 {
        w.step().unwrap();
        let sum: f64 = w.contacts().map(|c| c.normal_impulse * c.normal.z).sum();
        if k > 60 {
            weight = weight.max((sum - m * G * H).abs() / (m * G * H));
            pivots = pivots.max(w.island_stats()[0].pivot_steps);
        }
        points = w.contacts().count();
        let p = w.body(b).unwrap().position();
        drift = drift.max((p - x0).xy().norm());
        sink = sink.max((p.z - x0.z).abs());
    }
    (weight, drift, sink, w.body(b).unwrap().orientation().angle(), points, pivots)
}

#[test]
fn box_rests_on_flat_heightfield_and_deck_with_its_weight() {
    // A 10 m × 10 m height field of 1 m cells; the box straddles a grid vertex (8 triangles) and,
    // second, sits inside one cell. The deck: 4 × 4 m, 2 × 2 quads, the box straddling its centre.
    let flat = || terrain::hills(11, 11, 10.0, 10.0, |_, _| 0.0);
    for (what, shape, x) in [
        ("height field, on a vertex", flat(), Vector3::zeros()),
        ("height field, in a cell", flat(), Vector3::new(0.5, 0.45, 0.0)),
        ("deck mesh", terrain::deck(2.0, 2.0, 2), Vector3::zeros()),
    ] {
        let (weight, drift, sink, tilt, points, pivots) = rest_on(shape, x);
        eprintln!(
            "box at rest 20 s on a {what}: {points} points, Σ λ_n rel err vs m g h {weight:.2e} (after 1 s), \
             drift {drift:.2e} m, |Δz| {sink:.2e} m, tilt {tilt:.2e} rad, ≤ {pivots} pivot steps per step"
        );
        assert!(points >= 4, "{what}: {points} points");
        assert!(weight < 1e-9, "{what}: Σ λ_n = m g h: {weight:e}");
        assert!(drift < 1e-6 && sink < 1e-6 && tilt < 1e-6, "{what}: {drift:e} {sink:e} {tilt:e}");
        assert!(pivots <= 1, "{what}: warm-started contacts: {pivots} pivot steps");
    }
}

/// Displacement down the slope after `steps` and mean acceleration from step 30 to `steps` of a
/// 1.5 kg box on a `theta` incline made of `terrain` (`"field"`: a height-field ramp; `"mesh"`: a
/// deck on a tilted static body).
fn incline(terrain_kind: &str, theta: f64, mu: f64, steps: usize) -> (f64, f64) {
    let mut w = world();
    let e = Vector3::new(0.3, 0.3, 0.1);
    let (n, start) = match terrain_kind {
        "field" => {
            // z = x tan θ over x, y ∈ [−10, 10], 1 m cells; normal (−sin θ, 0, cos θ).
            add_terrain(&mut w, terrain::ramp(21, 21, 20.0, 20.0, theta), UnitQuaternion::identity(), mu);
            let n = Vector3::new(-theta.sin(), 0.0, theta.cos());
            (n, Vector3::new(7.0, 0.3, 7.0 * theta.tan()))
        }
        _ => {
            // A 20 m × 20 m deck of 2 m quads tilted by θ about y: normal (sin θ, 0, cos θ).
            let tilt = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), theta);
            add_terrain(&mut w, terrain::deck(10.0, 10.0, 10), tilt, mu);
            (tilt * Vector3::z(), tilt * Vector3::new(-7.0, 0.3, 0.0))
        }
    };
    let q = UnitQuaternion::rotation_between(&Vector3::z(), &n).unwrap();
    let b = add_box(&mut w, e, 1.5, start + n * e.z, q, mu);
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
fn box_on_terrain_incline_sticks_below_the_friction_angle() {
    let theta = 30f64.to_radians();
    for kind in ["field", "mesh"] {
        let (d, a) = incline(kind, theta, 0.8, 600);
        eprintln!("{kind} incline 30°, μ = 0.8 (sticks): moved {d:.2e} m in 10 s, acceleration {a:.2e} m/s²");
        assert!(d.abs() < 1e-5, "{kind}: sticks: {d:e} m");
    }
}

#[test]
fn box_on_terrain_incline_slides_with_coulomb_acceleration() {
    let theta = 30f64.to_radians();
    for kind in ["field", "mesh"] {
        for mu in [0.3, 0.0] {
            let (d, a) = incline(kind, theta, mu, 180);
            let expected = G * (theta.sin() - mu * theta.cos());
            let rel = (a - expected).abs() / expected;
            eprintln!(
                "{kind} incline 30°, μ = {mu}: a = {a:.6} m/s² vs g(sin θ − μ cos θ) = {expected:.6} \
                 (rel err {rel:.2e}), slid {d:.3} m across triangle edges"
            );
            assert!(rel < 0.02, "{kind}, μ = {mu}: a = {a}, expected {expected}");
        }
    }
}

#[test]
fn ball_rolls_down_heightfield_ramp_without_slipping() {
    let theta = 20f64.to_radians();
    let mut w = world();
    add_terrain(&mut w, terrain::ramp(21, 21, 20.0, 20.0, theta), UnitQuaternion::identity(), 1.0);
    let (m, r) = (1.0, 0.2);
    let n = Vector3::new(-theta.sin(), 0.0, theta.cos());
    let start = Vector3::new(7.0, 0.3, 7.0 * theta.tan()) + n * r;
    let ball = w.add_body(BodyBuilder::dynamic("ball", m, sphere_inertia(m, r)).position(start)).unwrap();
    w.add_collider(ColliderBuilder::new("ball", ball, Shape::Ball { radius: r })).unwrap();
    let down = Vector3::new(-theta.cos(), 0.0, -theta.sin());
    let (mut v30, mut t30, mut slip, mut lift): (f64, f64, f64, f64) = (0.0, 0.0, 0.0, 0.0);
    for k in 1..=180 {
        w.step().unwrap();
        let b = w.body(ball).unwrap();
        if k == 30 {
            v30 = b.linvel().dot(&down);
            t30 = w.time();
        }
        if k >= 10 {
            // Velocity of the contact point: v + ω × (−r n).
            slip = slip.max((b.linvel() + b.angvel().cross(&(-n * r))).norm());
        }
        // Distance of the centre from the plane minus the radius.
        lift = lift.max((n.dot(&b.position()) - r).abs());
    }
    let b = w.body(ball).unwrap();
    let a = (b.linvel().dot(&down) - v30) / (w.time() - t30);
    let expected = 5.0 / 7.0 * G * theta.sin();
    let rel = (a - expected).abs() / expected;
    eprintln!(
        "ball on a height-field ramp 20°: a = {a:.6} m/s² vs 5/7 g sin θ = {expected:.6} (rel err {rel:.2e}), \
         contact slip ≤ {slip:.2e} m/s, |gap| ≤ {lift:.2e} m, rolled {:.2} m",
        (b.position() - start).norm()
    );
    assert!(rel < 0.02, "a = {a}, expected {expected}");
    assert!(slip < 1e-3, "rolls without slipping: {slip:e} m/s");
    assert!(lift < 1e-3, "stays on the surface: {lift:e} m");
}

#[test]
fn box_dropped_onto_stairs_rests_on_a_step() {
    let mut w = world();
    // Five steps of rise 0.2 m and run 0.4 m climbing towards +x from x = 0, 2 m wide, on a floor.
    let (rise, run) = (0.2, 0.4);
    add_terrain(&mut w, terrain::stairs(5, rise, run, 2.0), UnitQuaternion::identity(), 1.0);
    let floor = w.add_body(BodyBuilder::static_body("floor")).unwrap();
    w.add_collider(ColliderBuilder::new("floor", floor, Shape::HalfSpace { normal: Vector3::z() })).unwrap();
    // A 0.24 × 0.4 × 0.2 m box, yawed and tilted onto an edge, dropped from 1.5 m over the middle
    // of step 2 (x ∈ [0.8, 1.2], tread at 0.6 m): it lands on a corner and settles flat.
    let e = Vector3::new(0.12, 0.2, 0.1);
    let q = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.2)
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.3);
    let b = add_box(&mut w, e, 3.0, Vector3::new(1.0, 0.1, 1.5), q, 1.0);
    let mut landed_at = None;
    for k in 1..=300 {
        w.step().unwrap();
        if landed_at.is_none() && w.contacts().any(|c| c.normal_impulse > 0.0) {
            landed_at = Some(k);
        }
    }
    let body = w.body(b).unwrap();
    let tread = 3.0 * rise;
    let (p, v) = (body.position(), body.linvel().norm() + body.angvel().norm());
    let weight: f64 = w.contacts().map(|c| c.normal_impulse * c.normal.z).sum();
    eprintln!(
        "box dropped on stairs: landed at step {landed_at:?}, rests at z = {:.6} m (tread {tread} + half height {}), \
         x = {:.4} m, speed {v:.2e}, Σ λ_n rel err {:.2e}, tilt {:.2e} rad",
        p.z,
        e.z,
        p.x,
        (weight - 3.0 * G * H).abs() / (3.0 * G * H),
        (body.orientation() * Vector3::z()).angle(&Vector3::z())
    );
    assert!(landed_at.is_some());
    assert!((p.z - (tread + e.z)).abs() < 1e-4, "rests on the tread: z = {}", p.z);
    assert!(p.x > 2.0 * run && p.x < 3.0 * run, "on step 2: x = {}", p.x);
    assert!(v < 1e-6, "at rest: {v:e}");
    assert!((weight - 3.0 * G * H).abs() < 1e-9 * 3.0 * G * H);
}

/// Pivot steps per step of a box launched at 4 m/s across a flat height field of 1 m cells
/// (μ = 0.3) over 1 s, its speed then and the worst relative residual.
fn slide_across_cells(warm_start: bool) -> (Vec<usize>, f64, f64) {
    let mut w = World::new(WorldSettings { timestep: H, warm_start, ..Default::default() }).unwrap();
    add_terrain(&mut w, terrain::hills(21, 21, 20.0, 20.0, |_, _| 0.0), UnitQuaternion::identity(), 0.3);
    let e = Vector3::new(0.3, 0.2, 0.1);
    let b = add_box(&mut w, e, 1.0, Vector3::new(-5.0, -1.3, e.z), UnitQuaternion::identity(), 0.3);
    w.set_velocity(b, Vector3::new(4.0, 1.0, 0.0).normalize() * 4.0, Vector3::zeros()).unwrap();
    let (mut pivots, mut residual) = (Vec::new(), 0.0_f64);
    for _ in 0..60 {
        w.step().unwrap();
        pivots.push(w.island_stats()[0].pivot_steps);
        residual = residual.max(w.island_stats()[0].residual_rel);
    }
    (pivots, w.body(b).unwrap().linvel().norm(), residual)
}

#[test]
fn sliding_contacts_on_terrain_are_warm_started() {
    // Points whose features persist keep their keys (the triangle index is part of them); where
    // the box's outline crosses a triangle edge, clipping makes new points, which start cold.
    let (warm, v, residual) = slide_across_cells(true);
    let (cold, _, _) = slide_across_cells(false);
    let mean = |p: &[usize]| p.iter().sum::<usize>() as f64 / p.len() as f64;
    let ones = warm.iter().filter(|&&p| p == 1).count();
    // Coulomb deceleration μ g over 1 s.
    let expected = 4.0 - 0.3 * G * 1.0;
    eprintln!(
        "box sliding across 1 m cells: pivot steps per step warm {:.2} (1 in {ones}/60 steps), cold {:.2}; \
         speed after 1 s {v:.6} vs v₀ − μ g t = {expected:.6}; worst relative residual {residual:.1e}",
        mean(&warm),
        mean(&cold)
    );
    assert!((v - expected).abs() / expected < 0.02, "v = {v}");
    assert!(ones >= 40, "warm-started: {warm:?}");
    assert!(residual < 1e-8, "{residual:e}");
    assert!(mean(&warm) < 0.5 * mean(&cold), "warm {warm:?}, cold {cold:?}");
}
