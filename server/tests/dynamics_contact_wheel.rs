//! A driven cylinder wheel pulls a vehicle body as Coulomb friction allows (issue 5):
//! a single wheel, hinged to a body that otherwise rests on the ground on a frictionless skid,
//! driven by a saturated velocity motor (a constant torque `τ`):
//! - with a large torque the wheel spins and the vehicle accelerates at `μ N / M_total`, with `N`
//!   the wheel's measured normal force;
//! - with a small torque it rolls without slipping at `a = τ / (r M_eff)`.

use nalgebra::{UnitQuaternion, Vector3};
use pivotsim_server::dynamics::{
    BodyBuilder, ColliderBuilder, JointBuilder, JointMotor, Shape, World, WorldSettings, box_inertia,
    cylinder_inertia,
};

const H: f64 = 1.0 / 60.0;
const MU: f64 = 0.5;
const R: f64 = 0.2;
const M_BODY: f64 = 10.0;
const M_WHEEL: f64 = 2.0;

/// Drives the vehicle with torque `tau` for 1 s; returns (acceleration from 0.5 s to 1 s, mean
/// wheel normal force over that time (N), slip speed at the end (m/s), the wheel's moment of
/// inertia about its axle).
fn drive(tau: f64) -> (f64, f64, f64, f64) {
    let mut w = World::new(WorldSettings { timestep: H, ..Default::default() }).unwrap();
    let g = w.add_body(BodyBuilder::static_body("ground")).unwrap();
    let gc =
        w.add_collider(ColliderBuilder::new("ground", g, Shape::HalfSpace { normal: Vector3::z() })).unwrap();
    // The body: a flat box resting on the ground; its contact with the ground is frictionless.
    let e = Vector3::new(0.4, 0.3, 0.05);
    let body = w
        .add_body(
            BodyBuilder::dynamic("body", M_BODY, box_inertia(M_BODY, e))
                .position(Vector3::new(0.0, 0.0, e.z)),
        )
        .unwrap();
    let bc = w.add_collider(ColliderBuilder::new("skid", body, Shape::Cuboid { half_extents: e })).unwrap();
    w.set_pair_friction(gc, bc, Some(0.0)).unwrap();
    // The wheel: a cylinder with its axis along world y, in front of the body.
    let half = 0.05;
    let centre = Vector3::new(0.7, 0.0, R);
    let q = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2);
    let inertia = cylinder_inertia(M_WHEEL, R, half);
    let wheel =
        w.add_body(BodyBuilder::dynamic("wheel", M_WHEEL, inertia).position(centre).orientation(q)).unwrap();
    let wc = w
        .add_collider(ColliderBuilder::new("wheel", wheel, Shape::Cylinder { radius: R, half_length: half }))
        .unwrap();
    w.set_pair_friction(gc, wc, Some(MU)).unwrap();
    // A velocity motor with an unreachable target speed stays at its bound: a constant torque. The
    // wheel turns about +y when rolling forward (+x); with the hinge's speed convention (body
    // relative to wheel) that is a negative joint speed, hence the negative target.
    w.add_joint(
        JointBuilder::hinge("axle", body, Some(wheel), centre, Vector3::y())
            .motor(JointMotor::velocity(-1e4, tau)),
    )
    .unwrap();
    let (mut v30, mut n_sum, mut n_count) = (0.0, 0.0, 0);
    for k in 1..=60 {
        w.step().unwrap();
        if k == 30 {
            v30 = w.body(body).unwrap().linvel().x;
        }
        if k > 30 {
            let n: f64 = w
                .contacts()
                .filter(|c| c.collider_a == wc || c.collider_b == wc)
                .map(|c| c.normal_impulse * c.normal.z.abs())
                .sum();
            n_sum += n / H;
            n_count += 1;
        }
    }
    let a = (w.body(body).unwrap().linvel().x - v30) / (30.0 * H);
    let wb = w.body(wheel).unwrap();
    let slip = (wb.linvel() + wb.angvel().cross(&Vector3::new(0.0, 0.0, -R))).norm();
    (a, n_sum / n_count as f64, slip, inertia.z)
}

#[test]
fn driven_wheel_slips_at_the_friction_limit() {
    let tau = 10.0;
    let (a, n, slip, _) = drive(tau);
    let m_total = M_BODY + M_WHEEL;
    let expected = MU * n / m_total;
    let rel = (a - expected).abs() / expected;
    eprintln!(
        "driven wheel τ = {tau} N m, μ = {MU}: a = {a:.6} m/s², wheel normal force N = {n:.4} N, μ N / M = {expected:.6} \
         (rel err {rel:.2e}), slip speed {slip:.3} m/s"
    );
    assert!(slip > 0.1, "the wheel spins: slip {slip}");
    assert!(rel < 0.02, "a = {a}, μ N / M = {expected}");
}

#[test]
fn driven_wheel_rolls_below_the_friction_limit() {
    let tau = 1.0;
    let (a, n, slip, i_wheel) = drive(tau);
    // Wheel: I α = τ − F r (F the ground's friction force on it, forward); vehicle as a whole:
    // M_total a = F (the skid is frictionless; the hinge forces are internal); rolling: a = α r.
    // Hence τ = I a / r + M_total a r, a = τ / (r M_eff) with M_eff = M_total + I / r².
    let m_eff = M_BODY + M_WHEEL + i_wheel / (R * R);
    let expected = tau / (R * m_eff);
    let rel = (a - expected).abs() / expected;
    let friction = (M_BODY + M_WHEEL) * a;
    eprintln!(
        "driven wheel τ = {tau} N m: a = {a:.6} m/s², τ/(r M_eff) = {expected:.6} (M_eff = {m_eff:.3} kg, rel err {rel:.2e}), \
         friction {friction:.4} N ≤ μ N = {:.4} N, slip speed {slip:.2e} m/s",
        MU * n
    );
    assert!(friction < MU * n);
    assert!(slip < 1e-6, "rolls without slipping: {slip}");
    assert!(rel < 0.02, "a = {a}, τ/(r M_eff) = {expected}");
}
