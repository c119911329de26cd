//! Position-target motors (`motor.rs`): a velocity motor whose target speed is
//! `u = clamp(g (s* − s) / h, ±u_max)`, with a force/torque bound.
//!
//! - **Boom reaches and holds.** A 200 kg boom (centre of mass `r = 2 m` out from a horizontal hinge)
//!   is raised from horizontal to `θ* = 0.8 rad` by an ample torque bound. It travels at no more than
//!   `u_max`, then holds: at rest the motor torque equals the gravity torque `m g r cos θ` and the
//!   angle sits at `θ* − c τ / g` (the row's compliance `c` read through the motor law).
//! - **Undersized boom stalls.** Hanging at `−1.2 rad` and driven up with a bound `τ_b = 0.8 m g r`,
//!   the boom rises until gravity's torque `m g r cos θ` reaches the bound and stops there, at
//!   `θ = −acos(τ_b / (m g r))`, the motor pushing at its bound (body damping settles the swing
//!   without changing the equilibrium).
//! - **Hydraulic piston.** A cylindrical joint (piston in its barrel) lifts a 500 kg load 0.5 m at
//!   0.2 m/s with a position motor on its linear axis and holds it with the force `M g`; its rotation
//!   about the axis stays free (an initial spin is kept exactly).

use nalgebra::{UnitQuaternion, Vector3};
use pivotsim_server::dynamics::{
    BodyBuilder, DEFAULT_COMPLIANCE, FreeAxis, JointBuilder, JointId, JointMotor, JointRow, World,
    WorldSettings, box_inertia, cylinder_inertia,
};

const G: f64 = 9.81;
const M: f64 = 200.0;
const R: f64 = 2.0;

/// A boom of length `2R` hinged at the origin about `−y` (raising is positive), built at elevation
/// `theta0`: the joint coordinate is the elevation minus `theta0`.
fn boom(theta0: f64, motor: JointMotor, damping: f64) -> (World, JointId) {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let dir = Vector3::new(theta0.cos(), 0.0, theta0.sin());
    let b = w
        .add_body(
            BodyBuilder::dynamic("boom", M, box_inertia(M, Vector3::new(R, 0.1, 0.1)))
                .position(dir * R)
                .orientation(UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -theta0))
                .linear_damping(damping)
                .angular_damping(damping),
        )
        .unwrap();
    let j = w
        .add_joint(JointBuilder::hinge("base", b, None, Vector3::zeros(), -Vector3::y()).motor(motor))
        .unwrap();
    (w, j)
}

#[test]
fn boom_reaches_its_target_angle_and_holds_it_under_gravity() {
    let (target, max_speed, bound) = (0.8, 0.5, 2.0 * M * G * R);
    let (mut w, j) = boom(0.0, JointMotor::position(target, max_speed, bound), 0.0);
    let h = w.settings().timestep;
    let (mut max_speed_seen, mut overshoot, mut reached) = (0.0f64, 0.0f64, None);
    for n in 1..=360 {
        w.step().unwrap();
        let theta = w.joint_coordinate(j).unwrap();
        max_speed_seen = max_speed_seen.max(w.joint_speed(j).unwrap().abs());
        overshoot = overshoot.max(theta - target);
        if reached.is_none() && (theta - target).abs() < 1e-3 {
            reached = Some(n as f64 * h);
        }
    }
    let theta = w.joint_coordinate(j).unwrap();
    let torque = w.joint_impulse(j, JointRow::Motor(FreeAxis::Angular)) / h;
    let gravity_torque = M * G * R * theta.cos();
    // Compliance offset of the motor law at rest: g e / h = c λ / h² with g = 1.
    let expected = target - DEFAULT_COMPLIANCE * torque;
    println!(
        "boom: within 1 mrad of {target} rad after {:.3} s (travel at u_max: {:.3} s), max speed {max_speed_seen:.6} rad/s, overshoot {overshoot:.2e} rad; holds {theta:.12} rad (θ* − cτ/g = {expected:.12}), motor {torque:.6} N m vs m g r cos θ = {gravity_torque:.6} N m",
        reached.unwrap(),
        target / max_speed
    );
    assert!(max_speed_seen <= max_speed * (1.0 + 1e-9), "{max_speed_seen}");
    assert!(reached.unwrap() < target / max_speed + 1.0);
    assert!((theta - expected).abs() < 1e-9, "{theta} vs {expected}");
    assert!(w.joint_speed(j).unwrap().abs() < 1e-9);
    assert!((torque - gravity_torque).abs() < 1e-6 * gravity_torque, "{torque} vs {gravity_torque}");
}

#[test]
fn undersized_boom_stalls_where_its_bound_meets_the_gravity_torque() {
    let bound = 0.8 * M * G * R;
    let stall = -(bound / (M * G * R)).acos();
    let theta0 = -1.2;
    // Target elevation +0.5 rad, i.e. joint coordinate 0.5 − θ₀.
    let (mut w, j) = boom(theta0, JointMotor::position(0.5 - theta0, 0.3, bound), 2.0);
    let h = w.settings().timestep;
    let mut highest = f64::NEG_INFINITY;
    for _ in 0..(20.0 / h) as usize {
        w.step().unwrap();
        highest = highest.max(w.joint_coordinate(j).unwrap() + theta0);
    }
    let theta = w.joint_coordinate(j).unwrap() + theta0;
    let torque = w.joint_impulse(j, JointRow::Motor(FreeAxis::Angular)) / h;
    println!(
        "stall: rests at {theta:.9} rad vs −acos(τ_b/(m g r)) = {stall:.9} rad (highest {highest:.6}), motor {torque:.6} N m at bound {bound:.6}, m g r cos θ = {:.6} N m",
        M * G * R * theta.cos()
    );
    assert!((theta - stall).abs() < 1e-6, "{theta} vs {stall}");
    assert!((torque - bound).abs() < 1e-9 * bound, "{torque}");
    assert!(w.joint_speed(j).unwrap().abs() < 1e-6);
    // It swings a little past the stall angle on its momentum, never anywhere near horizontal.
    assert!(highest < stall + 0.1, "{highest}");
}

#[test]
fn hydraulic_piston_lifts_and_holds_its_load_and_turns_freely() {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let h = w.settings().timestep;
    let load = 500.0;
    let spin = 0.7;
    let inertia = cylinder_inertia(load, 0.3, 0.2);
    let piston = w
        .add_body(BodyBuilder::dynamic("piston", load, inertia).angvel(Vector3::new(0.0, 0.0, spin)))
        .unwrap();
    let (target, max_speed) = (0.5, 0.2);
    let j = w
        .add_joint(
            JointBuilder::cylindrical("cylinder", piston, None, Vector3::zeros(), Vector3::z())
                .motor(JointMotor::position(target, max_speed, 3.0 * load * G)),
        )
        .unwrap();
    for _ in 0..(5.0 / h) as usize {
        w.step().unwrap();
        let v = w.joint_speed(j).unwrap();
        assert!(v <= max_speed * (1.0 + 1e-9), "{v}");
    }
    let s = w.joint_coordinate(j).unwrap();
    let force = w.joint_impulse(j, JointRow::Motor(FreeAxis::Linear)) / h;
    let omega = w.joint_axis_speed(j, FreeAxis::Angular).unwrap();
    let turned = w.joint_axis_coordinate(j, FreeAxis::Angular).unwrap();
    let expected_turn = pivotsim_server::dynamics::wrap_angle(spin * w.time());
    println!(
        "piston: extension {s:.12} m (target {target}), force {force:.6} N vs M g = {:.6} N, spin {omega:.15} rad/s, turned {turned:.9} rad vs {expected_turn:.9}",
        load * G
    );
    assert!((s - (target - DEFAULT_COMPLIANCE * force)).abs() < 1e-9, "{s}");
    assert!((force - load * G).abs() < 1e-6 * load * G, "{force}");
    assert!((omega - spin).abs() < 1e-12, "{omega}");
    assert!((turned - expected_turn).abs() < 1e-9, "{turned} vs {expected_turn}");
}
