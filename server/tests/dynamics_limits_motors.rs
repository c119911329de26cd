//! Limits and motors on a joint's free axis.
//!
//! - **Limit.** A horizontal bar (mass m, centre of mass at r from a horizontal hinge) falls under
//!   gravity until its upper limit stops it; it then rests at the bound (the limit row is
//!   inelastic: `λ ≥ 0`, `J v⁺ ≥ −φ/h`), and the limit's mean reaction torque `λ/h` equals the
//!   gravity torque about the axis, `m g r cos θ_limit`.
//! - **Motor, unloaded.** A disc on a hinge through its centre, driven towards 2 rad/s with a torque
//!   bound of 10 N m: it accelerates at exactly `τ_max / I` (the boxed motor row is saturated) and
//!   then holds the target speed, with zero motor torque once there.
//! - **Motor, stalled.** A 10 kg carriage on a vertical prismatic rail, motor target 0.5 m/s upwards:
//!   with a 50 N bound (< m g) it cannot lift — it sinks at `(m g − F)/m` with the motor pushing at
//!   its bound; with a 200 N bound it rises at the target speed, the motor holding `m g` (up to the
//!   row's compliance `c`, which makes a velocity row a stiff damper: `v = target − c F / h`).

use nalgebra::{UnitQuaternion, Vector3};
use pivotsim_server::dynamics::{
    BodyBuilder, DEFAULT_COMPLIANCE, FreeAxis, JointBuilder, JointLimit, JointMotor, JointRow, World,
    WorldSettings, box_inertia, cylinder_inertia,
};

const G: f64 = 9.81;

#[test]
fn upper_limit_stops_a_falling_bar_with_the_gravity_reaction() {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let h = w.settings().timestep;
    let (m, r) = (4.0, 0.6);
    let bar = w
        .add_body(
            BodyBuilder::dynamic("bar", m, box_inertia(m, Vector3::new(r, 0.05, 0.05)))
                .position(Vector3::new(r, 0.0, 1.0)),
        )
        .unwrap();
    // Hinge about +y: the bar falling (+x end going down) is a positive rotation of the bar.
    let upper = 0.7;
    let j = w
        .add_joint(
            JointBuilder::hinge("hinge", bar, None, Vector3::new(0.0, 0.0, 1.0), Vector3::y())
                .limit(JointLimit::new(-0.2, upper)),
        )
        .unwrap();
    assert!(w.joint_coordinate(j).unwrap().abs() < 1e-15);
    let mut max_angle: f64 = 0.0;
    for _ in 0..180 {
        w.step().unwrap();
        max_angle = max_angle.max(w.joint_coordinate(j).unwrap());
    }
    let angle = w.joint_coordinate(j).unwrap();
    let torque = w.joint_impulse(j, JointRow::UpperLimit(FreeAxis::Angular)) / h;
    let expected = m * G * r * upper.cos();
    println!(
        "limit: rests at {angle:.9} rad (bound {upper}), overshoot {:.2e} rad, reaction {torque:.6} N m vs m g r cos θ = {expected:.6} N m",
        max_angle - upper
    );
    assert!((angle - upper).abs() < 1e-6, "{angle}");
    assert!(max_angle - upper < 1e-3, "overshoot {}", max_angle - upper);
    assert!(w.joint_speed(j).unwrap().abs() < 1e-6);
    assert!((torque - expected).abs() < 1e-6 * expected, "{torque} vs {expected}");
    assert_eq!(w.joint_impulse(j, JointRow::LowerLimit(FreeAxis::Angular)), 0.0);
}

#[test]
fn motor_reaches_its_target_speed_unloaded() {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let h = w.settings().timestep;
    let (m, radius) = (4.0, 0.5);
    let inertia = cylinder_inertia(m, radius, 0.05);
    let disc = w
        .add_body(
            BodyBuilder::dynamic("disc", m, inertia).orientation(UnitQuaternion::from_axis_angle(
                &Vector3::x_axis(),
                std::f64::consts::FRAC_PI_2,
            )),
        )
        .unwrap();
    let (target, max_torque) = (2.1, 10.0);
    let j = w
        .add_joint(
            JointBuilder::hinge("axle", disc, None, Vector3::zeros(), Vector3::y())
                .motor(JointMotor::velocity(target, max_torque)),
        )
        .unwrap();
    let accel = max_torque / inertia.z;
    let ramp_steps = (target / (accel * h)).floor() as usize;
    for n in 1..=60 {
        w.step().unwrap();
        let speed = w.joint_speed(j).unwrap();
        let torque = w.joint_impulse(j, JointRow::Motor(FreeAxis::Angular)) / h;
        if n <= ramp_steps {
            // Saturated: the speed ramps at exactly τ_max / I.
            assert!((speed - accel * h * n as f64).abs() < 1e-9, "step {n}: {speed}");
            assert!((torque - max_torque).abs() < 1e-9, "step {n}: {torque}");
        } else if n > ramp_steps + 1 {
            assert!((speed - target).abs() < 1e-9, "step {n}: {speed}");
            assert!(torque.abs() < 1e-6, "step {n}: {torque}");
        }
    }
    println!("motor: ramped {ramp_steps} steps at {accel} rad/s², holds {} rad/s", w.joint_speed(j).unwrap());
}

#[test]
fn motor_stalls_at_its_force_bound_under_a_heavy_load() {
    for max_force in [50.0, 200.0] {
        let mut w = World::new(WorldSettings::default()).unwrap();
        let h = w.settings().timestep;
        let m = 10.0;
        let cart = w.add_body(BodyBuilder::dynamic("cart", m, box_inertia(m, Vector3::repeat(0.2)))).unwrap();
        let j = w
            .add_joint(
                JointBuilder::prismatic("rail", cart, None, Vector3::zeros(), Vector3::z())
                    .motor(JointMotor::velocity(0.5, max_force)),
            )
            .unwrap();
        for _ in 0..60 {
            w.step().unwrap();
        }
        let speed = w.joint_speed(j).unwrap();
        let force = w.joint_impulse(j, JointRow::Motor(FreeAxis::Linear)) / h;
        println!("motor bound {max_force} N: speed after 1 s {speed:.6} m/s, motor force {force:.6} N");
        if max_force < m * G {
            let a = (m * G - max_force) / m;
            assert!((speed + a * 1.0).abs() < 1e-9, "{speed}");
            assert!((force - max_force).abs() < 1e-9, "{force}");
        } else {
            // A compliant velocity row is a stiff damper: v = target − c F / h.
            let expected = 0.5 - DEFAULT_COMPLIANCE * force / h;
            assert!((speed - expected).abs() < 1e-9, "{speed} vs {expected}");
            assert!((force - m * G).abs() < 1e-6, "{force}");
        }
    }
}
