//! The cylindrical and universal joints against the mechanics of their free motions.
//!
//! - **Cylindrical, vertical axis through the centre of mass.** The body falls along the axis
//!   exactly as a free body under implicit Euler (`s_n = −g h² n(n+1)/2`) while keeping its spin
//!   about the axis, and nothing moves sideways.
//! - **Cylindrical, horizontal axis, centre of mass off the axis.** The rotation is a physical
//!   pendulum (small-angle period `2π √(I_axis / (m g r))`, `I_axis = I_c + m r²`) while the
//!   translation along the axis is free: a body pushed along it slides at constant speed, `s = v₀ t`
//!   (with rigid rows; with compliance `c` the angular rows, which carry the moment `m g v₀ t` of the
//!   support force at B's anchor about A's centre of mass, tilt by `c m g v₀ t` and the slide
//!   picks up that tilt times the tension — 9e-7 m over 9 s at the default 1e-10).
//! - **Universal (Cardan) joint.** An input shaft driven at constant `ω₁` through a Cardan joint
//!   bent by `β` turns the output non-uniformly: with the input pin in the shafts' plane at
//!   `θ₁ = 0`, `tan θ₂ = tan θ₁ / cos β` and `ω₂ / ω₁ = cos β / (1 − sin²β cos²θ₁)` (between
//!   `cos β` and `1 / cos β`). The angles follow the law to the second-order step error `(h ω₁)²`;
//!   the speeds carry the angular row's stabilization `−φ/h` of that error and follow it to first
//!   order (checked: quartering `h` divides the angle error by > 10 and the speed error by > 3).

use nalgebra::{UnitQuaternion, Vector3};
use pivotsim_server::dynamics::{
    BodyBuilder, FreeAxis, JointBuilder, JointMotor, World, WorldSettings, box_inertia, wrap_angle,
};

const G: f64 = 9.81;

#[test]
fn cylindrical_joint_falls_and_spins_freely_along_its_axis() {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let h = w.settings().timestep;
    let spin = 3.0;
    let x0 = Vector3::new(0.5, -0.2, 10.0);
    let b = w
        .add_body(
            BodyBuilder::dynamic("piston", 4.0, box_inertia(4.0, Vector3::new(0.2, 0.2, 0.5)))
                .position(x0)
                .angvel(Vector3::new(0.0, 0.0, spin)),
        )
        .unwrap();
    let j = w.add_joint(JointBuilder::cylindrical("bore", b, None, x0, Vector3::z())).unwrap();
    let mut worst: f64 = 0.0;
    for n in 1..=120u32 {
        w.step().unwrap();
        let n = n as f64;
        let fall = -G * h * h * n * (n + 1.0) / 2.0;
        let s = w.joint_coordinate(j).unwrap();
        let side = (w.body(b).unwrap().position() - x0).xy().norm();
        let omega = w.joint_axis_speed(j, FreeAxis::Angular).unwrap();
        let turned = w.joint_axis_coordinate(j, FreeAxis::Angular).unwrap();
        worst = worst.max((s - fall).abs()).max(side).max((omega - spin).abs());
        assert!((turned - wrap_angle(spin * h * n)).abs() < 1e-9, "step {n}: {turned}");
    }
    println!(
        "cylindrical, vertical: worst deviation from free fall / sideways / spin over 2 s = {worst:.2e}"
    );
    assert!(worst < 1e-9, "{worst}");
}

#[test]
fn cylindrical_joint_is_a_pendulum_that_slides() {
    let mut w = World::new(WorldSettings { timestep: 1.0 / 240.0, ..Default::default() }).unwrap();
    let h = w.settings().timestep;
    let (m, r, v0) = (3.0, 0.6, 0.25);
    let half = Vector3::new(0.1, 0.05, 0.1);
    let inertia = box_inertia(m, half);
    let theta0: f64 = 0.05;
    // Axis x through the origin; centre of mass r below it, swung by θ₀ about x.
    let com = Vector3::new(0.0, r * theta0.sin(), -r * theta0.cos());
    let b = w
        .add_body(
            BodyBuilder::dynamic("bob", m, inertia)
                .position(com)
                .orientation(UnitQuaternion::from_axis_angle(&Vector3::x_axis(), theta0))
                .linvel(Vector3::new(v0, 0.0, 0.0)),
        )
        .unwrap();
    let j = w
        .add_joint(JointBuilder::cylindrical("rod", b, None, Vector3::zeros(), Vector3::x()).compliance(0.0))
        .unwrap();
    let i_axis = inertia.x + m * r * r;
    let period = std::f64::consts::TAU * (i_axis / (m * G * r)).sqrt();
    // Zero crossings of the swing angle (descending), interpolated.
    let (mut prev, mut crossings) = (theta0, Vec::new());
    let mut slide_err: f64 = 0.0;
    for n in 1..=(6.0 * period / h) as usize {
        w.step().unwrap();
        let t = n as f64 * h;
        let a = w.joint_axis_coordinate(j, FreeAxis::Angular).unwrap() + theta0;
        if prev > 0.0 && a <= 0.0 {
            crossings.push(t - h * a / (a - prev));
        }
        prev = a;
        slide_err = slide_err.max((w.joint_coordinate(j).unwrap() - v0 * t).abs());
    }
    let measured = (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64;
    println!(
        "cylindrical pendulum: period {measured:.5} s vs 2π√(I/(m g r)) = {period:.5} s ({:+.3} %), slide error {slide_err:.2e} m",
        100.0 * (measured / period - 1.0)
    );
    assert!((measured - period).abs() < 0.01 * period);
    assert!(slide_err < 1e-9, "{slide_err}");
}

/// One input revolution pair through a Cardan joint bent by `beta` at time step `h`: the worst
/// deviations of `ω₂/ω₁` and of `θ₂` from the Cardan law, and the extremes of `ω₂/ω₁`.
fn cardan(h: f64, beta: f64, omega1: f64) -> (f64, f64, f64, f64) {
    let mut w =
        World::new(WorldSettings { timestep: h, gravity: Vector3::zeros(), ..Default::default() }).unwrap();
    let u = Vector3::new(beta.cos(), beta.sin(), 0.0);
    let rod = |m: f64| box_inertia(m, Vector3::new(0.3, 0.05, 0.05));
    // Input shaft along x, output shaft along u, both centred 0.5 m from the joint at the origin.
    let input = w
        .add_body(BodyBuilder::dynamic("input", 1.0, rod(1.0)).position(Vector3::new(-0.5, 0.0, 0.0)))
        .unwrap();
    let output = w
        .add_body(
            BodyBuilder::dynamic("output", 1.0, rod(1.0))
                .position(u * 0.5)
                .orientation(UnitQuaternion::from_axis_angle(&Vector3::z_axis(), beta)),
        )
        .unwrap();
    let j1 = w
        .add_joint(
            JointBuilder::hinge("in-bearing", input, None, Vector3::new(-0.5, 0.0, 0.0), Vector3::x())
                .motor(JointMotor::velocity(omega1, 1e4)),
        )
        .unwrap();
    let j2 = w.add_joint(JointBuilder::hinge("out-bearing", output, None, u * 0.5, u)).unwrap();
    // Input pin along y (in the shafts' plane), output pin along z.
    w.add_joint(JointBuilder::universal(
        "cardan",
        input,
        Some(output),
        Vector3::zeros(),
        Vector3::y(),
        Vector3::z(),
    ))
    .unwrap();
    let (mut worst_speed, mut worst_angle, mut lo, mut hi) = (0.0f64, 0.0f64, f64::INFINITY, 0.0f64);
    for _ in 0..(2.0 * std::f64::consts::TAU / omega1 / h) as usize {
        w.step().unwrap();
        let (t1, t2) = (w.joint_coordinate(j1).unwrap(), w.joint_coordinate(j2).unwrap());
        let (w1, w2) = (w.joint_speed(j1).unwrap(), w.joint_speed(j2).unwrap());
        let ratio = beta.cos() / (1.0 - beta.sin().powi(2) * t1.cos().powi(2));
        worst_speed = worst_speed.max((w2 / w1 - ratio).abs());
        // tan θ₂ = tan θ₁ / cos β on the same branch: θ₂ = atan2(sin θ₁, cos θ₁ cos β).
        let expected = t1.sin().atan2(t1.cos() * beta.cos());
        worst_angle = worst_angle.max(wrap_angle(t2 - expected).abs());
        lo = lo.min(w2 / w1);
        hi = hi.max(w2 / w1);
    }
    (worst_speed, worst_angle, lo, hi)
}

#[test]
fn cardan_joint_drives_its_output_non_uniformly() {
    let (beta, omega1): (f64, f64) = (0.5, 2.0);
    let mut results = Vec::new();
    for h in [1.0 / 60.0, 1.0 / 240.0] {
        let (speed, angle, lo, hi) = cardan(h, beta, omega1);
        println!(
            "cardan β = {beta}, h = {h:.5}: ω₂/ω₁ in [{lo:.6}, {hi:.6}] vs [cos β, 1/cos β] = [{:.6}, {:.6}]; worst |ω₂/ω₁ − law| {speed:.2e}, worst |θ₂ − law| {angle:.2e} rad; (hω)² = {:.2e}",
            beta.cos(),
            1.0 / beta.cos(),
            (h * omega1).powi(2)
        );
        assert!(angle < (h * omega1).powi(2), "{angle}");
        assert!(speed < h * omega1, "{speed}");
        assert!((lo - beta.cos()).abs() < 2.0 * speed && (hi - 1.0 / beta.cos()).abs() < 2.0 * speed);
        results.push((speed, angle));
    }
    // Angles converge at second order in h, speeds (which carry the rows' −φ/h) at first.
    let (coarse, fine) = (results[0], results[1]);
    println!(
        "cardan convergence for h/4: speed error ÷ {:.1}, angle error ÷ {:.1}",
        coarse.0 / fine.0,
        coarse.1 / fine.1
    );
    assert!(coarse.0 / fine.0 > 3.0 && coarse.1 / fine.1 > 10.0);
}
