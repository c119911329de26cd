//! The chain/cable helper (`chain.rs`): a 20-segment cable (2 kg capsules of 0.5 m) released from
//! 0.4 rad off vertical, hanging from a fixed point, with body damping. It settles to a vertical
//! line whose length is the analytic `N ℓ + c m g N (N + 1) / 2` — every ball joint `k` carries the
//! weight below it, `(N − k) m g`, and its rows (implicit springs of compliance `c`, here 1e-7 m/N so
//! that the stretch is visible) stretch by `c (N − k) m g` — and its top joint carries the full
//! weight `N m g` (reaction `λ / h` on the top segment), each joint below the weight of what hangs
//! from it.

use nalgebra::Vector3;
use pivotsim_server::dynamics::{ChainBuilder, ChainEnd, ChainShape, World, WorldSettings};

const N: usize = 20;
const ELL: f64 = 0.5;
const M: f64 = 2.0;
const C: f64 = 1e-7;
const G: f64 = 9.81;

#[test]
fn hanging_cable_settles_vertical_at_its_analytic_length() {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let top = Vector3::new(1.0, -2.0, 15.0);
    let tilt: f64 = 0.4;
    let dir = Vector3::new(tilt.sin(), 0.0, -tilt.cos());
    let cable = w
        .add_chain(
            ChainBuilder::new("cable", top, dir, ELL, M, N)
                .shape(ChainShape::Capsule { radius: 0.02 })
                .compliance(C)
                .damping(2.0, 2.0),
        )
        .unwrap();
    assert_eq!((cable.bodies.len(), cable.joints.len()), (N, N));
    // Built along the line: segment i centred at top + (i + ½) ℓ u, joints without violation.
    for (i, &b) in cable.bodies.iter().enumerate() {
        let p = w.body(b).unwrap().position();
        assert!((p - (top + dir * ((i as f64 + 0.5) * ELL))).norm() < 1e-12);
    }
    assert!(w.max_anchor_error() < 1e-12);

    let h = w.settings().timestep;
    for _ in 0..(40.0 / h) as usize {
        w.step().unwrap();
    }
    let horizontal =
        cable.bodies.iter().map(|&b| (w.body(b).unwrap().position() - top).xy().norm()).fold(0.0, f64::max);
    let last = w.body(*cable.bodies.last().unwrap()).unwrap();
    let bottom = last.point_world(Vector3::new(0.0, 0.0, ELL / 2.0));
    let length = (top - bottom).norm();
    let stretch = C * M * G * (N * (N + 1)) as f64 / 2.0;
    let analytic = N as f64 * ELL + stretch;
    let speed = w.bodies().iter().map(|b| b.linvel().norm()).fold(0.0, f64::max);
    let top_force = w.joint_reaction(cable.joints[0]).unwrap().force;
    let weight = N as f64 * M * G;
    println!(
        "cable: max horizontal offset {horizontal:.2e} m, length {length:.12} m vs N ℓ + c m g N(N+1)/2 = {analytic:.12} m (stretch {stretch:.3e} m), max speed {speed:.1e} m/s, top joint force {:.9?} N vs N m g = {weight:.9} N",
        top_force.as_slice()
    );
    assert!(horizontal < 1e-6, "{horizontal}");
    assert!(speed < 1e-6, "{speed}");
    assert!((length - analytic).abs() < 1e-3 * stretch, "{length} vs {analytic}");
    assert!((top_force - Vector3::new(0.0, 0.0, weight)).norm() < 1e-6 * weight, "{top_force}");
    for (k, &j) in cable.joints.iter().enumerate() {
        let f = w.joint_reaction(j).unwrap().force;
        let below = (N - k) as f64 * M * G;
        assert!((f.z - below).abs() < 1e-6 * below, "joint {k}: {f}");
    }
}

/// Box links, both ends attached: a chain slung between the world and a kinematic post that is
/// first moved 1 m closer (slack), then held. It settles into the discrete catenary of rigid
/// uniform links: the horizontal tension `H` is the same at every joint, joint `k` carries the
/// vertical force `V_k = N m g / 2 − k m g` (the ends share the weight), and link `k` slopes down by
/// `tan θ_k = (V_k + V_{k+1}) / (2H)` (moment balance about its centre), `H` being fixed by the span
/// `Σ ℓ cos θ_k = S` (solved here by bisection). A straight-down chain is built with its body z
/// axes pointing down.
#[test]
fn slung_chain_shares_its_weight_between_its_ends() {
    let mut w = World::new(WorldSettings::default()).unwrap();
    let (n, m) = (8, 1.0);
    let post = w
        .add_body(
            pivotsim_server::dynamics::BodyBuilder::kinematic("post").position(Vector3::new(4.0, 0.0, 5.0)),
        )
        .unwrap();
    let chain = w
        .add_chain(
            ChainBuilder::new("sling", Vector3::new(0.0, 0.0, 5.0), Vector3::x(), 0.5, m, n)
                .shape(ChainShape::Box { half_width: 0.03 })
                .attach_end(ChainEnd::Body(post))
                .damping(1.5, 1.5),
        )
        .unwrap();
    assert_eq!(chain.joints.len(), n + 1);
    w.set_velocity(post, Vector3::new(-1.0, 0.0, 0.0), Vector3::zeros()).unwrap();
    for _ in 0..60 {
        w.step().unwrap();
    }
    w.set_velocity(post, Vector3::zeros(), Vector3::zeros()).unwrap();
    for _ in 0..(30.0 / w.settings().timestep) as usize {
        w.step().unwrap();
    }
    let z = |i: usize| w.body(chain.bodies[i]).unwrap().position().z;
    let asym = (0..n).map(|i| (z(i) - z(n - 1 - i)).abs()).fold(0.0, f64::max);
    let start = w.joint_reaction(chain.joints[0]).unwrap().force;
    let end = w.joint_reaction(chain.joints[n]).unwrap().force;
    let weight = n as f64 * m * G;
    println!(
        "sling: span 3 m, sag of the middle links {:.6} m, asymmetry {asym:.2e} m, end forces {:.6?} + {:.6?} N (weight {weight:.6} N), max anchor error {:.2e} m",
        5.0 - z(n / 2),
        start.as_slice(),
        end.as_slice(),
        w.max_anchor_error()
    );
    assert!(5.0 - z(n / 2) > 0.5, "it sags");
    assert!(asym < 1e-6, "{asym}");
    assert!((start.z + end.z - weight).abs() < 1e-6 * weight);
    assert!((start.z - weight / 2.0).abs() < 1e-6 * weight && (start.x + end.x).abs() < 1e-6 * weight);
    assert!(w.max_anchor_error() < 1e-6);
    // Discrete catenary: link k's mean vertical load and H from the span.
    let v_mean = |k: usize| weight / 2.0 - (k as f64 + 0.5) * m * G;
    let span = |hh: f64| (0..n).map(|k| 0.5 * hh / hh.hypot(v_mean(k))).sum::<f64>();
    let (mut lo, mut hi) = (1e-6, 1e6);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if span(mid) < 3.0 { lo = mid } else { hi = mid }
    }
    let hh = 0.5 * (lo + hi);
    let com_depth = |i: usize| {
        (0..i).map(|k| 0.5 * v_mean(k) / hh.hypot(v_mean(k))).sum::<f64>()
            + 0.25 * v_mean(i) / hh.hypot(v_mean(i))
    };
    println!(
        "discrete catenary: H = {hh:.9} N (simulated {:.9}), middle link depth {:.9} m (simulated {:.9})",
        -start.x,
        com_depth(n / 2),
        5.0 - z(n / 2)
    );
    assert!((-start.x - hh).abs() < 1e-6 * hh);
    for i in 0..n {
        assert!((5.0 - z(i) - com_depth(i)).abs() < 1e-6, "link {i}");
    }

    let mut w = World::new(WorldSettings::default()).unwrap();
    let down = w.add_chain(ChainBuilder::new("down", Vector3::zeros(), -Vector3::z(), 1.0, 1.0, 3)).unwrap();
    let b = w.body(down.bodies[2]).unwrap();
    assert!((b.position() - Vector3::new(0.0, 0.0, -2.5)).norm() < 1e-12);
    assert!((b.orientation() * Vector3::z() + Vector3::z()).norm() < 1e-12);
}
