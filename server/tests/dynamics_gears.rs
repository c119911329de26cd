//! Powertrain couplings (`coupling.rs`): gear pairs, an open differential and a slipping clutch,
//! against the textbook drivetrain relations.
//!
//! - **Gear pair, reflected inertia.** Shaft a (inertia `I_a`) drives shaft b (`I_b`) through a
//!   gear `ω_a = ρ ω_b`; a motor saturated at `τ_m` accelerates shaft a at `τ_m / (I_a + I_b / ρ²)`
//!   (b's inertia reflected through the ratio), and the gear's torque at shaft a is
//!   `−I_b α_a / ρ²`; the ratio holds to 1e-12 relative every step (compliance 0). On a
//!   free-floating gearbox (zero gravity, three bodies in the row) the housing turns the other way;
//!   the ratio, exact at the step's start, reads off at its end by no more than `δ²`, `δ` the
//!   hinges' own axis misalignment (second order, from spinning inside a turning housing).
//! - **Differential.** `ω_in = ρ (ω_left + ω_right) / 2`: one output braked, the other turns at
//!   `2 ω_in / ρ`; equal loads give equal speeds `ω_in / ρ`; outputs of unequal inertia receive equal
//!   torques (`I_l α_l = I_r α_r`), with `α_in` from the torque balance
//!   `T = τ_m / (1 + I_in ρ² (1/I_l + 1/I_r) / 4)`.
//! - **Clutch.** A gear of ratio 1 with a torque bound `τ_c` transmits the motor's drive while the
//!   load needs less than `τ_c`, the shafts locked (`α = τ_m / (I_a + I_b)`); with a smaller bound it
//!   slips: `α_a = (τ_m − τ_c) / I_a`, `α_b = τ_c / I_b`, the relative speed growing at their
//!   difference. Disengaged (bound 0 set live) the driven shaft coasts.
//! - **A broken axle ends its gear.** A coupling relates joint coordinates; when the driven shaft's
//!   axle breaks (its hinge disabled, as a `break` fault does) the gear has no coordinate to hold
//!   and carries no impulse: the freed shaft keeps its spin (no torque acts on it, isotropic
//!   inertia) and the driving shaft accelerates at `τ_m / I_a` instead of the geared
//!   `τ_m / (I_a + I_b / ρ²)`.

use nalgebra::{UnitQuaternion, Vector3};
use pivotsim_server::dynamics::{
    BodyBuilder, BodyId, CouplingBuilder, CouplingId, JointBuilder, JointId, JointMotor, World,
    WorldSettings, box_inertia,
};

/// A rotor of isotropic inertia `i` (unit mass) on a hinge through its centre about `axis`, to
/// `parent` (`None`: the world).
fn shaft(
    w: &mut World,
    name: &str,
    at: Vector3<f64>,
    axis: Vector3<f64>,
    i: f64,
    parent: Option<BodyId>,
) -> JointId {
    let b = w.add_body(BodyBuilder::dynamic(name, 1.0, Vector3::repeat(i)).position(at)).unwrap();
    w.add_joint(JointBuilder::hinge(&format!("{name}-axle"), b, parent, at, axis)).unwrap()
}

fn zero_g() -> WorldSettings {
    WorldSettings { gravity: Vector3::zeros(), ..Default::default() }
}

#[test]
fn gear_pair_reflects_inertia_and_keeps_its_ratio() {
    let (ia, ib, ratio, tau_m) = (0.2, 0.9, 3.0, 4.0);
    let mut w = World::new(zero_g()).unwrap();
    let h = w.settings().timestep;
    let a = shaft(&mut w, "a", Vector3::zeros(), Vector3::x(), ia, None);
    let b = shaft(&mut w, "b", Vector3::new(0.0, 0.4, 0.0), Vector3::x(), ib, None);
    w.set_joint_motor(a, Some(JointMotor::velocity(100.0, tau_m))).unwrap();
    let g = w.add_coupling(CouplingBuilder::gear("gear", a, b, ratio).compliance(0.0)).unwrap();
    let alpha = tau_m / (ia + ib / ratio / ratio);
    for n in 1..=60 {
        w.step().unwrap();
        let (wa, wb) = (w.joint_speed(a).unwrap(), w.joint_speed(b).unwrap());
        assert!((wa - alpha * h * n as f64).abs() < 1e-9 * wa, "step {n}: {wa}");
        assert!((wa - ratio * wb).abs() < 1e-12 * wa, "step {n}: {wa} vs {ratio} × {wb}");
        let tau_gear = w.coupling_impulse(g) / h;
        assert!((tau_gear + ib * alpha / ratio / ratio).abs() < 1e-9, "{tau_gear}");
    }
    println!(
        "gear: α_a = {:.12} rad/s² vs τ/(I_a + I_b/ρ²) = {alpha:.12}, gear torque {:.9} N m",
        w.joint_speed(a).unwrap() / w.time(),
        w.coupling_impulse(g) / h
    );
}

#[test]
fn gear_pair_in_a_floating_gearbox_keeps_its_ratio() {
    let mut w = World::new(zero_g()).unwrap();
    let half = Vector3::new(0.3, 0.5, 0.2);
    let housing = w.add_body(BodyBuilder::dynamic("housing", 20.0, box_inertia(20.0, half))).unwrap();
    let axis = UnitQuaternion::from_euler_angles(0.3, -0.2, 0.5) * Vector3::x();
    let a = shaft(&mut w, "a", Vector3::new(0.0, -0.2, 0.0), axis, 0.05, Some(housing));
    let b = shaft(&mut w, "b", Vector3::new(0.0, 0.25, 0.05), axis, 0.3, Some(housing));
    w.set_joint_motor(a, Some(JointMotor::velocity(20.0, 2.0))).unwrap();
    let ratio = 2.5;
    w.add_coupling(CouplingBuilder::gear("gear", a, b, ratio).compliance(0.0)).unwrap();
    let (mut worst, mut misalign, mut housing_spin) = (0.0f64, 0.0f64, 0.0f64);
    let l0 = w.angular_momentum(Vector3::zeros());
    for _ in 0..180 {
        w.step().unwrap();
        let (wa, wb) = (w.joint_speed(a).unwrap(), w.joint_speed(b).unwrap());
        worst = worst.max((wa - ratio * wb).abs() / wa.abs());
        for j in [a, b] {
            let f = w.joint_frames_world(j).unwrap();
            misalign = misalign.max(f.axis_a.cross(&f.axis_b).norm());
        }
        housing_spin = housing_spin.max(w.body(housing).unwrap().angvel().norm());
    }
    let dl = (w.angular_momentum(Vector3::zeros()) - l0).norm();
    println!(
        "floating gearbox: ω_a = {:.6} rad/s, worst |ω_a − ρ ω_b| / |ω_a| = {worst:.2e} (hinge axis misalignment δ ≤ {misalign:.2e} rad, δ² = {:.2e}), housing up to {housing_spin:.4} rad/s, |ΔL| = {dl:.2e} N m s, island rows {}",
        w.joint_speed(a).unwrap(),
        misalign * misalign,
        w.island_stats()[0].rows
    );
    // The row holds the ratio exactly at the step's start; read at its end, the shafts' axes have
    // tilted by the hinges' second-order error δ (spin inside a turning housing), an O(δ²) effect.
    assert!(worst <= misalign * misalign, "{worst} vs δ² {}", misalign * misalign);
    assert!(housing_spin > 0.1, "the housing takes the reaction");
    assert!(w.joint_speed(a).unwrap() > 19.0);
}

/// Input shaft about x and two outputs about y on the world; differential ratio `rho`.
fn axle(i_in: f64, i_l: f64, i_r: f64, rho: f64) -> (World, [JointId; 3], CouplingId) {
    let mut w = World::new(zero_g()).unwrap();
    let input = shaft(&mut w, "input", Vector3::zeros(), Vector3::x(), i_in, None);
    let left = shaft(&mut w, "left", Vector3::new(0.0, 1.0, 0.0), Vector3::y(), i_l, None);
    let right = shaft(&mut w, "right", Vector3::new(0.0, -1.0, 0.0), -Vector3::y(), i_r, None);
    let d = w
        .add_coupling(CouplingBuilder::differential("diff", input, left, right, rho).compliance(0.0))
        .unwrap();
    (w, [input, left, right], d)
}

#[test]
fn differential_splits_speed_and_torque() {
    let (rho, w_in) = (3.0, 30.0);
    // One output braked: the other turns at twice the mean.
    let (mut w, [input, left, right], _) = axle(0.5, 0.3, 0.3, rho);
    w.set_joint_motor(input, Some(JointMotor::velocity(w_in, 500.0))).unwrap();
    w.set_joint_motor(left, Some(JointMotor::velocity(0.0, 1e6))).unwrap();
    for _ in 0..120 {
        w.step().unwrap();
    }
    let (wl, wr, wi) =
        (w.joint_speed(left).unwrap(), w.joint_speed(right).unwrap(), w.joint_speed(input).unwrap());
    println!(
        "differential, left braked: input {wi:.12}, left {wl:.3e}, right {wr:.12} rad/s (2 ω_in/ρ = {:.12})",
        2.0 * w_in / rho
    );
    assert!((wi - w_in).abs() < 1e-9 * w_in && wl.abs() < 1e-9);
    assert!((wr - 2.0 * w_in / rho).abs() < 1e-9 * wr, "{wr}");

    // Equal loads (equal inertias, equal friction torques): equal speeds ω_in / ρ.
    let (mut w, [input, left, right], _) = axle(0.5, 0.3, 0.3, rho);
    w.set_joint_motor(input, Some(JointMotor::velocity(w_in, 500.0))).unwrap();
    for j in [left, right] {
        w.set_joint_motor(j, Some(JointMotor::velocity(0.0, 2.0))).unwrap();
    }
    for _ in 0..120 {
        w.step().unwrap();
    }
    let (wl, wr) = (w.joint_speed(left).unwrap(), w.joint_speed(right).unwrap());
    println!("differential, equal loads: left {wl:.12}, right {wr:.12} rad/s (ω_in/ρ = {:.12})", w_in / rho);
    assert!((wl - wr).abs() < 1e-9 * wl && (wl - w_in / rho).abs() < 1e-9 * wl, "{wl} {wr}");

    // Unequal inertias, input motor saturated: equal output torques, accelerations from the balance.
    let (i_in, i_l, i_r, tau_m) = (0.5, 0.2, 0.7, 6.0);
    let (mut w, [input, left, right], d) = axle(i_in, i_l, i_r, rho);
    w.set_joint_motor(input, Some(JointMotor::velocity(1e3, tau_m))).unwrap();
    let t = tau_m / (1.0 + i_in * rho * rho * (1.0 / i_l + 1.0 / i_r) / 4.0);
    let (a_in, a_l, a_r) = ((tau_m - t) / i_in, rho * t / (2.0 * i_l), rho * t / (2.0 * i_r));
    let h = w.settings().timestep;
    for n in 1..=30 {
        w.step().unwrap();
        let tn = h * n as f64;
        for (j, a) in [(input, a_in), (left, a_l), (right, a_r)] {
            let s = w.joint_speed(j).unwrap();
            assert!((s - a * tn).abs() < 1e-9 * a * tn, "step {n}: {s} vs {}", a * tn);
        }
        assert!((w.coupling_impulse(d) / h + t).abs() < 1e-9 * t);
    }
    let (wl, wr) = (w.joint_speed(left).unwrap(), w.joint_speed(right).unwrap());
    println!(
        "differential, unequal inertias: I_l α_l = {:.12}, I_r α_r = {:.12} N m (ρT/2 = {:.12})",
        i_l * wl / w.time(),
        i_r * wr / w.time(),
        rho * t / 2.0
    );
}

#[test]
fn clutch_transmits_below_its_bound_and_slips_above() {
    let (ia, ib, tau_m) = (0.4, 0.6, 5.0);
    let run = |tau_c: f64| {
        let mut w = World::new(zero_g()).unwrap();
        let a = shaft(&mut w, "a", Vector3::zeros(), Vector3::x(), ia, None);
        let b = shaft(&mut w, "b", Vector3::new(0.5, 0.0, 0.0), Vector3::x(), ib, None);
        w.set_joint_motor(a, Some(JointMotor::velocity(1e3, tau_m))).unwrap();
        let c = w
            .add_coupling(CouplingBuilder::gear("clutch", a, b, 1.0).max_torque(tau_c).compliance(0.0))
            .unwrap();
        (w, a, b, c)
    };
    let locked_torque = ib * tau_m / (ia + ib); // what the load needs to follow the drive
    // Bound above the need: locked.
    let (mut w, a, b, c) = run(1.2 * locked_torque);
    for _ in 0..60 {
        w.step().unwrap();
    }
    let (wa, wb) = (w.joint_speed(a).unwrap(), w.joint_speed(b).unwrap());
    let alpha = tau_m / (ia + ib);
    let h = w.settings().timestep;
    println!(
        "clutch locked: ω_a {wa:.12}, ω_b {wb:.12} rad/s after 1 s (τ/(I_a+I_b) t = {alpha:.12}), transmitted {:.9} N m",
        -w.coupling_impulse(c) / h
    );
    assert!((wa - alpha).abs() < 1e-9 && (wb - alpha).abs() < 1e-9);
    assert!((-w.coupling_impulse(c) / h - locked_torque).abs() < 1e-9);

    // Bound below the need: slips, each side under ±τ_c.
    let tau_c = 0.5 * locked_torque;
    let (mut w, a, b, c) = run(tau_c);
    let (alpha_a, alpha_b) = ((tau_m - tau_c) / ia, tau_c / ib);
    for n in 1..=60 {
        w.step().unwrap();
        let tn = h * n as f64;
        let (wa, wb) = (w.joint_speed(a).unwrap(), w.joint_speed(b).unwrap());
        assert!((wa - alpha_a * tn).abs() < 1e-9 && (wb - alpha_b * tn).abs() < 1e-9, "step {n}: {wa} {wb}");
        assert!((w.coupling_impulse(c) / h + tau_c).abs() < 1e-9);
    }
    let slip = w.joint_speed(a).unwrap() - w.joint_speed(b).unwrap();
    println!(
        "clutch slipping: slip speed {slip:.12} rad/s after 1 s vs (τ_m − τ_c)/I_a − τ_c/I_b = {:.12} rad/s²",
        alpha_a - alpha_b
    );
    assert!((slip - (alpha_a - alpha_b)).abs() < 1e-9);

    // Disengaged live: the driven shaft coasts at its speed.
    w.set_coupling_max_torque(c, Some(0.0)).unwrap();
    let coast = w.joint_speed(b).unwrap();
    for _ in 0..30 {
        w.step().unwrap();
    }
    assert!((w.joint_speed(b).unwrap() - coast).abs() < 1e-12);
}

#[test]
fn gear_pair_lets_go_when_the_driven_axle_breaks() {
    let (ia, ib, ratio, tau_m) = (0.2, 0.9, 3.0, 4.0);
    let mut w = World::new(zero_g()).unwrap();
    let h = w.settings().timestep;
    let a = shaft(&mut w, "a", Vector3::zeros(), Vector3::x(), ia, None);
    let b = shaft(&mut w, "b", Vector3::new(0.0, 0.4, 0.0), Vector3::x(), ib, None);
    w.set_joint_motor(a, Some(JointMotor::velocity(1000.0, tau_m))).unwrap();
    let g = w.add_coupling(CouplingBuilder::gear("gear", a, b, ratio).compliance(0.0)).unwrap();
    for _ in 0..30 {
        w.step().unwrap();
    }
    assert!(w.coupling_impulse(g).abs() > 1e-3, "the gear carries the driven shaft's inertia");
    let rotor_b = w.body_id("b").unwrap();
    let spin_b = w.body(rotor_b).unwrap().angvel();
    let wa0 = w.joint_speed(a).unwrap();
    w.set_joint_enabled(b, false, false).unwrap();
    for n in 1..=60 {
        w.step().unwrap();
        assert_eq!(w.coupling_impulse(g), 0.0, "step {n}: a gear across a broken axle pushed");
        let wa = w.joint_speed(a).unwrap();
        let expected = wa0 + tau_m / ia * h * n as f64;
        assert!((wa - expected).abs() < 1e-9 * expected, "step {n}: ω_a {wa} vs free {expected}");
        let db = (w.body(rotor_b).unwrap().angvel() - spin_b).norm();
        assert!(db < 1e-12, "step {n}: the freed shaft's spin changed by {db}");
    }
    println!(
        "broken axle: α_a = {:.9} rad/s² (free τ/I_a = {}, geared {:.6}), freed shaft at {:.6} rad/s",
        (w.joint_speed(a).unwrap() - wa0) / (60.0 * h),
        tau_m / ia,
        tau_m / (ia + ib / ratio / ratio),
        spin_b.norm()
    );
}
