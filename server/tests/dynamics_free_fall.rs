//! Free fall under the paper's implicit Euler step (eq. 1 with no rows): `v_n = v₀ − g t_n`
//! and `x_n = x₀ + h Σ_{k=1..n} v_k = x₀ + v₀ t_n − g h² n(n+1)/2` exactly (the position update uses
//! the new velocity). A spinning free body keeps its centre of mass on that parabola, whatever its
//! rotation, and a body without gravity moves in a straight line. Static bodies stay put; a kinematic
//! body follows its scripted velocity and ignores gravity.

use nalgebra::{UnitQuaternion, Vector3};
use pivotsim_server::dynamics::{BodyBuilder, World, WorldSettings, box_inertia};

#[test]
fn free_fall_matches_implicit_euler_closed_form() {
    let h = 1.0 / 60.0;
    let g = Vector3::new(0.0, 0.0, -9.81);
    let mut w = World::new(WorldSettings { timestep: h, gravity: g, ..Default::default() }).unwrap();
    let x0 = Vector3::new(1.0, -2.0, 10.0);
    let v0 = Vector3::new(0.5, 0.25, 3.0);
    let falling =
        w.add_body(BodyBuilder::dynamic("ball", 2.0, Vector3::repeat(0.1)).position(x0).linvel(v0)).unwrap();
    // A tumbling brick: rotation must not leak into the centre-of-mass motion.
    let brick = w
        .add_body(
            BodyBuilder::dynamic("brick", 3.0, box_inertia(3.0, Vector3::new(0.1, 0.3, 0.6)))
                .position(x0)
                .linvel(v0)
                .orientation(UnitQuaternion::from_euler_angles(0.3, 0.2, 0.1))
                .angvel(Vector3::new(4.0, -1.0, 7.0)),
        )
        .unwrap();
    let ground =
        w.add_body(BodyBuilder::static_body("ground").position(Vector3::new(0.0, 0.0, -1.0))).unwrap();
    let kin = w.add_body(BodyBuilder::kinematic("lift").linvel(Vector3::new(0.0, 0.0, 0.5))).unwrap();
    let mut worst: f64 = 0.0;
    for n in 1..=240u32 {
        w.step().unwrap();
        let nf = n as f64;
        let t = nf * h;
        let x = x0 + v0 * t + g * (h * h * nf * (nf + 1.0) / 2.0);
        let v = v0 + g * t;
        for id in [falling, brick] {
            let b = w.body(id).unwrap();
            worst = worst.max((b.position() - x).norm()).max((b.linvel() - v).norm());
        }
    }
    println!("free fall: worst deviation from the closed form over 240 steps = {worst:.3e} m");
    assert!(worst < 1e-12, "{worst}");
    assert_eq!(w.body(ground).unwrap().position(), Vector3::new(0.0, 0.0, -1.0));
    let k = w.body(kin).unwrap();
    assert!((k.position() - Vector3::new(0.0, 0.0, 0.5 * 240.0 * h)).norm() < 1e-12);
    assert_eq!(k.linvel(), Vector3::new(0.0, 0.0, 0.5));
    // No rows: every dynamic body is its own island, nothing was solved.
    assert_eq!(w.islands().len(), 2);
    assert!(w.island_stats().is_empty());
}

#[test]
fn without_gravity_bodies_move_in_straight_lines() {
    let h = 0.01;
    let mut w =
        World::new(WorldSettings { timestep: h, gravity: Vector3::zeros(), ..Default::default() }).unwrap();
    let v0 = Vector3::new(1.0, 2.0, -0.5);
    let id = w
        .add_body(
            BodyBuilder::dynamic("b", 1.0, box_inertia(1.0, Vector3::new(0.2, 0.5, 1.0)))
                .linvel(v0)
                .angvel(Vector3::new(0.0, 3.0, 5.0)),
        )
        .unwrap();
    for _ in 0..1000 {
        w.step().unwrap();
    }
    let b = w.body(id).unwrap();
    assert!((b.position() - v0 * 10.0).norm() < 1e-12);
    assert_eq!(b.linvel(), v0);
    assert!((b.orientation().norm() - 1.0).abs() < 1e-15);
}
