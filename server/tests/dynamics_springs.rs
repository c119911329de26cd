//! Spring–dampers as implicit force rows (`force.rs`: `c_row = 1/(k + c/h)`, `β = h k/(h k + c)`).
//!
//! - **Static deflection.** A mass hanging on a damped vertical spring settles at the stretch
//!   `m g / k` exactly, the row's force `λ / h` equal to the weight.
//! - **Oscillation.** Undamped, it oscillates with the period `2π √(m/k)` (implicit Euler: period
//!   error `O((hω)²)`, amplitude decaying by the factor `1/√(1 + (hω)²)` per step — checked against
//!   that closed form).
//! - **Unconditional stability.** A 1 g body on a 1e6 N/m spring (`h ω ≈ 530`, far beyond the
//!   explicit limit 2) neither diverges nor oscillates: it lands on `m g / k`.
//! - **Momentum.** Two bodies joined by a spring in zero gravity keep their total linear momentum to
//!   round-off and their angular momentum to the step's rotation update (equal and opposite forces
//!   along the line of the spring).

use nalgebra::Vector3;
use pivotsim_server::dynamics::{
    BodyBuilder, ForceElement, ForceId, SpringDamper, World, WorldSettings, sphere_inertia,
};

const G: f64 = 9.81;

/// A mass `m` hanging from a spring attached at the world point (0, 0, 0), released at rest with
/// the spring at its rest length 1 m.
fn hanging(m: f64, k: f64, c: f64, h: f64) -> (World, ForceId, pivotsim_server::dynamics::BodyId) {
    let mut w = World::new(WorldSettings { timestep: h, ..Default::default() }).unwrap();
    let b = w
        .add_body(
            BodyBuilder::dynamic("bob", m, sphere_inertia(m, 0.05)).position(Vector3::new(0.0, 0.0, -1.0)),
        )
        .unwrap();
    let spring = SpringDamper {
        body_a: b,
        anchor_a: Vector3::zeros(),
        body_b: None,
        anchor_b: Vector3::zeros(),
        rest_length: 1.0,
        stiffness: k,
        damping: c,
    };
    let f = w.add_force("spring", ForceElement::SpringDamper(spring)).unwrap();
    (w, f, b)
}

#[test]
fn damped_spring_settles_at_the_static_deflection() {
    for (m, k, c) in [(2.0, 500.0, 20.0), (1e-3, 1e6, 10.0)] {
        let (mut w, f, b) = hanging(m, k, c, 1.0 / 60.0);
        let mut lowest: f64 = 0.0;
        for _ in 0..600 {
            w.step().unwrap();
            lowest = lowest.min(w.body(b).unwrap().position().z);
        }
        let z = w.body(b).unwrap().position().z;
        let stretch = -1.0 - z;
        let force = -w.force_impulse(f) / w.settings().timestep;
        let hw = w.settings().timestep * (k / m).sqrt();
        println!(
            "m {m} kg, k {k} N/m (h ω = {hw:.1}): stretch {stretch:.12} m vs m g/k = {:.12} m, lowest {lowest:.6} m, spring force {force:.9} N vs m g = {:.9} N",
            m * G / k,
            m * G
        );
        assert!((stretch - m * G / k).abs() < 1e-9 * (1.0 + m * G / k), "{stretch}");
        assert!((force - m * G).abs() < 1e-9 * m * G, "{force}");
        assert!(lowest > -1.0 - 2.5 * m * G / k, "overshoot beyond twice the deflection: {lowest}");
    }
}

#[test]
fn undamped_spring_oscillates_with_its_period() {
    let (m, k, h) = (2.0, 200.0, 1.0 / 240.0);
    let (mut w, _, b) = hanging(m, k, 0.0, h);
    let omega = (k / m).sqrt();
    let rest = -1.0 - m * G / k;
    // Upward crossings of the equilibrium, interpolated; amplitude of the first and last swing.
    let (mut prev, mut crossings, mut first, mut last) = (-1.0 - rest, Vec::new(), 0.0f64, 0.0f64);
    let steps = (10.0 * std::f64::consts::TAU / omega / h) as usize;
    for n in 1..=steps {
        w.step().unwrap();
        let x = w.body(b).unwrap().position().z - rest;
        if prev < 0.0 && x >= 0.0 {
            crossings.push(n as f64 * h - h * x / (x - prev));
        }
        if crossings.is_empty() {
            first = first.max(x.abs());
        }
        if n + (std::f64::consts::TAU / omega / h) as usize > steps {
            last = last.max(x.abs());
        }
        prev = x;
    }
    let period = (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64;
    let expected = std::f64::consts::TAU / omega;
    // Implicit Euler shrinks the amplitude by 1/√(1 + (hω)²) per step.
    let decay = (1.0 + (h * omega).powi(2)).powf(-0.5 * (crossings[crossings.len() - 1] - crossings[0]) / h);
    println!(
        "spring: period {period:.6} s vs 2π√(m/k) = {expected:.6} s ({:+.3} %), amplitude ratio {:.4} vs implicit Euler's {decay:.4}",
        100.0 * (period / expected - 1.0),
        last / first
    );
    assert!((period - expected).abs() < 0.01 * expected);
    assert!((last / first - decay).abs() < 0.02, "{} vs {decay}", last / first);
}

#[test]
fn spring_between_two_bodies_conserves_momentum() {
    let mut w = World::new(WorldSettings { gravity: Vector3::zeros(), ..Default::default() }).unwrap();
    let a = w
        .add_body(
            BodyBuilder::dynamic("a", 3.0, Vector3::new(0.1, 0.2, 0.15))
                .linvel(Vector3::new(0.5, -0.2, 0.1))
                .angvel(Vector3::new(0.3, 0.0, -0.4)),
        )
        .unwrap();
    let b = w
        .add_body(
            BodyBuilder::dynamic("b", 1.0, Vector3::new(0.05, 0.05, 0.08))
                .position(Vector3::new(1.0, 0.5, 0.0))
                .linvel(Vector3::new(-1.0, 0.3, 0.0)),
        )
        .unwrap();
    let spring = SpringDamper {
        body_a: a,
        anchor_a: Vector3::new(0.1, 0.05, 0.0),
        body_b: Some(b),
        anchor_b: Vector3::new(-0.1, 0.0, 0.02),
        rest_length: 0.8,
        stiffness: 300.0,
        damping: 2.0,
    };
    w.add_force("coil", ForceElement::SpringDamper(spring)).unwrap();
    let (p0, l0) = (w.linear_momentum(), w.angular_momentum(Vector3::zeros()));
    let (mut dp, mut dl) = (0.0f64, 0.0f64);
    for _ in 0..300 {
        w.step().unwrap();
        dp = dp.max((w.linear_momentum() - p0).norm());
        dl = dl.max((w.angular_momentum(Vector3::zeros()) - l0).norm());
    }
    println!(
        "two bodies on a spring: |ΔP| ≤ {dp:.2e}, |ΔL| ≤ {dl:.2e} (|P₀| = {:.3}, |L₀| = {:.3}); one island of {} rows",
        p0.norm(),
        l0.norm(),
        w.island_stats()[0].rows
    );
    assert!(dp < 1e-12 * p0.norm().max(1.0));
    assert!(w.islands().len() == 1);
    // The line of action passes through both attachment points: the impulses carry no net angular
    // momentum; what remains is the step's rotation update of bodies that receive impulses
    // (as for joints, `dynamics_momentum.rs`).
    assert!(dl < 1e-2 * l0.norm(), "{dl}");
}
