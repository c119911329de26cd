//! Signals against statics (issue 17): the forces the sensors report are the solver's impulses
//! over `h`, so at rest they must be the weights statics predicts. A rope hanging a load carries
//! at each of its joints the weight of everything below it; a machine at rest presses the ground
//! with its weight; a box on an incline sticks while `tan θ < μ` and slips above; a rope set to
//! break at a tension parts within one step's change of it.

use pivotsim_server::scene::{self, Scene};
use pivotsim_server::signals::{ContactStateKind, EventKind};

const G: f64 = 9.81;

fn load(text: &str) -> Scene {
    scene::load_str("test.toml", text).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

/// A 2,000 kg load on a 5 m, 10-segment, 20 kg rope from a fixed point: the tension at joint `k`
/// (0 the top, 10 the hook) is `g (m_load + (10 − k) m_seg)`.
#[test]
fn hanging_load_rope_tension_is_the_weight_below_every_joint() {
    let text = include_str!("support/scenes/hanging_load.toml");
    let mut s = load(text);
    let (m_load, m_seg, n) = (2000.0, 2.0, 10usize);
    let mut worst: f64 = 0.0;
    for step in 1..=120 {
        s.step().unwrap();
        // The rope starts unstretched: its compliance (1e-10 m/N) takes the load within the
        // first steps (implicit Euler damps the stiff mode), then the tension holds.
        if step % 30 != 0 {
            continue;
        }
        let t = s.signals.sensor_values("hoist").unwrap();
        assert_eq!(t.len(), n + 3);
        for (k, &tension) in t[..=n].iter().enumerate() {
            let expected = G * (m_load + (n - k) as f64 * m_seg);
            let rel = (tension - expected).abs() / expected;
            worst = worst.max(rel);
            assert!(rel < 1e-6, "step {step} joint {k}: {tension} N vs {expected} N ({rel:e})");
        }
        assert_eq!(t[n + 1], t[n], "hook = the last joint");
        assert!((t[n + 2] - G * (m_load + n as f64 * m_seg)).abs() < 1e-6 * G * m_load, "max at the top");
    }
    eprintln!("worst relative tension error {worst:e}");
}

const MACHINE: &str = include_str!("support/scenes/machine.toml");

/// A 2,500 kg machine (chassis and boom on a fixed joint) at rest on the ground: the contact
/// reactions sum to its weight, the boom's mount carries the boom's weight and moment, and the
/// tipping margin is the distance from its centre of mass (x = 0.2 m) to the nearest edge (1 m).
#[test]
fn machine_at_rest_support_reactions_sum_to_its_weight() {
    let mut s = load(MACHINE);
    let w = 2500.0 * G;
    let mut worst: f64 = 0.0;
    for step in 1..=120 {
        s.step().unwrap();
        if step < 30 {
            continue;
        }
        let p = s.signals.sensor_values("pads").unwrap();
        let rel = (p[2] - w).abs() / w;
        worst = worst.max(rel);
        assert!(rel < 1e-6, "step {step}: Σ fz = {} N vs {w} N ({rel:e})", p[2]);
        assert!(p[0].abs() < 1e-6 * w && p[1].abs() < 1e-6 * w, "no horizontal force: {p:?}");
        assert!((p[3] - w).abs() < 1e-6 * w, "normal sum {}", p[3]);
        assert_eq!(p[5], 4.0, "four corners pressed");
        assert_eq!(p[6], 4.0, "all sticking");
    }
    eprintln!("worst relative support error {worst:e}");
    // The mount (A = boom): the joint holds the boom up (+z) and against its moment about the
    // anchor (the boom's weight 1 m out along +x turns it about +y by m g · 1 m; the joint holds
    // it with the opposite torque).
    let m = s.signals.sensor_values("mount").unwrap();
    assert!((m[2] - 500.0 * G).abs() < 1e-6 * 500.0 * G, "mount fz {m:?}");
    assert!((m[4] + 500.0 * G * 1.0).abs() < 1e-5 * 500.0 * G, "mount ty {m:?}");
    let t = s.signals.sensor_values("lmi").unwrap();
    assert!((t[0] - 1.0).abs() < 1e-3, "margin {t:?}");
    assert!((t[1] - 100.0).abs() < 1e-9, "percent {t:?}");
    assert_eq!(t[2], 4.0, "a four-cornered polygon");
}

fn incline(ratio: f64) -> String {
    // μ = 0.5 on both shapes (the pair's μ is their geometric mean); tan θ = ratio · μ.
    let theta = (ratio * 0.5f64).atan();
    let (s, c) = theta.sin_cos();
    let deg = theta.to_degrees();
    format!(
        r#"
[scene]
name = "incline"
[[body]]
name = "slope"
kind = "static"
[[body.shape]]
type = "plane"
normal = [{s}, 0, {c}]
friction = 0.5
[[body]]
name = "box"
mass = 50.0
position = [{x}, 0, {z}]
rotation = [0, {deg}, 0]
[[body.shape]]
type = "box"
size = [0.6, 0.6, 0.4]
friction = 0.5
[[sensor]]
name = "box"
type = "contacts"
bodies = ["box"]
[[sensor]]
name = "grip"
type = "contact_sum"
bodies = ["box"]
[[event]]
name = "box-slipping"
channel = "grip/sliding"
above = 0.5
"#,
        x = 0.2 * s,
        z = 0.2 * c,
    )
}

/// A box on an incline with μ = 0.5: below `tan θ = μ` the box sticks (it does not move, its
/// contact does not slide: at least one of its four pressed corners sticks — which of the
/// redundant corners the solver puts at its bound is not unique); above, every corner slips, the
/// contact slides and that is one event.
/// Every pressed corner reports a unit normal across the slope and a friction vector in the
/// slope's plane with the reported magnitude; on the box they sum to a force up the slope,
/// `m g sin θ` once it rests.
#[test]
fn box_on_incline_sticks_below_tan_theta_mu_and_slips_above() {
    for ratio in [0.5, 0.95, 1.05, 1.5] {
        let mut s = load(&incline(ratio));
        let box_id = s.world.body_id("box").unwrap();
        let x0 = s.world.body(box_id).unwrap().position();
        let mut slip_events = 0;
        let mut last_up = 0.0;
        for _ in 0..60 {
            s.step().unwrap();
            slip_events += s.signals.events().iter().filter(|e| e.kind == EventKind::Raised).count();
            let pressed: Vec<_> =
                s.signals.contacts().iter().filter(|c| c.state != ContactStateKind::Open).collect();
            assert_eq!(pressed.len(), 4, "ratio {ratio}: four pressed corners");
            let slipping = pressed.iter().filter(|c| c.state == ContactStateKind::Slip).count();
            let sliding = s.signals.value("grip/sliding").unwrap();
            if ratio < 1.0 {
                assert!(slipping < 4 && sliding == 0.0, "ratio {ratio}: {pressed:?}");
            } else {
                assert!(slipping == 4 && sliding == 1.0, "ratio {ratio}: {pressed:?}");
            }
            // The slip speed against Coulomb's law: at rest below tan θ = μ; above, the box slides
            // down the static slope at a = g (sin θ − μ cos θ), so its points slip at a t.
            let slip = s.signals.value("grip/slip_speed").unwrap();
            let t = s.world.time();
            if ratio < 1.0 {
                assert!(slip < 1e-4, "ratio {ratio}: a sticking box slips at {slip} m/s");
            } else if t > 0.1 {
                let th = (ratio * 0.5f64).atan();
                let a = G * (th.sin() - 0.5 * th.cos());
                assert!(
                    (slip - a * t).abs() < 0.05 * a * t,
                    "ratio {ratio}, t = {t}: {slip} m/s vs a t = {}",
                    a * t
                );
            }
            let f = s.signals.sensor_values("grip").unwrap();
            // The directions (the wire's contact record): a unit normal across the slope, the
            // friction vector in the slope's plane with the reported magnitude; on the box, the
            // friction of the four corners sums to `m g sin θ` up the slope while it sticks.
            let theta = (ratio * 0.5f64).atan();
            let (sn, cs) = theta.sin_cos();
            let up_slope = nalgebra::Vector3::new(-cs, 0.0, sn);
            let slope_normal = nalgebra::Vector3::new(sn, 0.0, cs);
            let mut up = 0.0;
            for c in &pressed {
                assert!(c.friction_force <= 0.5 * c.normal_force * (1.0 + 1e-9) * 2f64.sqrt(), "{c:?}");
                assert!((c.normal.norm() - 1.0).abs() < 1e-9, "{c:?}");
                assert!((c.normal.dot(&slope_normal).abs() - 1.0).abs() < 1e-9, "{c:?}");
                assert!(
                    (c.friction.norm() - c.friction_force).abs() <= 1e-9 * (1.0 + c.friction_force),
                    "{c:?}"
                );
                assert!(c.friction.dot(&c.normal).abs() <= 1e-9 * (1.0 + c.friction_force), "{c:?}");
                let on_box = if c.bodies[1] == box_id { c.friction } else { -c.friction };
                up += on_box.dot(&up_slope);
            }
            assert!(up > 0.0, "ratio {ratio}: friction on the box points up the slope ({up} N)");
            last_up = up;
            let _ = f;
        }
        let x1 = s.world.body(s.world.body_id("box").unwrap()).unwrap().position();
        let moved = (x1 - x0).norm();
        if ratio < 1.0 {
            // At rest the contact carries the weight: normal m g cos θ, friction m g sin θ.
            let f = s.signals.sensor_values("grip").unwrap();
            let theta = (ratio * 0.5f64).atan();
            let w = 50.0 * G;
            assert!((f[3] - w * theta.cos()).abs() < 1e-6 * w, "ratio {ratio}: normal {f:?}");
            assert!((f[4] - w * theta.sin()).abs() < 1e-6 * w, "ratio {ratio}: friction {f:?}");
            assert!((f[2] - w).abs() < 1e-6 * w, "ratio {ratio}: vertical {f:?}");
            assert!(
                (last_up - w * theta.sin()).abs() < 1e-6 * w,
                "ratio {ratio}: friction vectors {last_up} N"
            );
            assert!(moved < 1e-6, "ratio {ratio}: a sticking box moved {moved} m");
            assert_eq!(slip_events, 0);
        } else {
            assert!(moved > 1e-3, "ratio {ratio}: a slipping box moved only {moved} m");
            assert_eq!(slip_events, 1, "ratio {ratio}: one slip event");
        }
    }
}

/// A 100 kg load released from the horizontal on a 2 m rope swings down: the rope's tension,
/// `3 m g sin φ` at the angle φ below the horizontal, rises through 2 m g, where the rope is set to
/// break. It parts at the first step whose tension exceeds the limit, so the reported tension is
/// within one step's change of it; then the load falls free.
#[test]
fn rope_breaks_at_its_tension_limit() {
    let limit = 2.0 * 100.0 * G;
    let text = format!(
        r#"
[scene]
name = "break"
[[body]]
name = "load"
mass = 100.0
inertia = [1.0, 1.0, 1.0]
position = [2.0, 0, 5.0]
[[joint]]
name = "rope"
type = "ball"
a = "load"
anchor = [0, 0, 5.0]
[[sensor]]
name = "rope"
type = "joint"
joint = "rope"
[[fault]]
name = "rope-parted"
type = "break"
joint = "rope"
tension = {limit}
"#
    );
    let mut s = load(&text);
    let rope = s.world.joint_id("rope").unwrap();
    let mut last = 0.0;
    let mut broke = None;
    for step in 0..120 {
        s.step().unwrap();
        let f = s.signals.sensor_values("rope").unwrap();
        let tension = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
        if let Some(e) = s.signals.events().iter().find(|e| e.kind == EventKind::Fault) {
            assert_eq!(e.name.as_str(), "rope-parted");
            assert!((e.value - tension).abs() < 1e-9 * limit, "the event carries this step's tension");
            assert!(tension > limit && last <= limit, "first crossing: {last} → {tension}");
            let change = tension - last;
            assert!(
                tension - limit <= change,
                "parted at {tension} N, limit {limit} N, step change {change} N"
            );
            assert!(!s.world.joint(rope).unwrap().is_enabled());
            eprintln!("parted at {tension:.3} N (limit {limit:.3} N, step change {change:.3} N)");
            broke = Some(step);
            break;
        }
        last = tension;
    }
    let step = broke.expect("the rope parted");
    assert!(step > 5, "not at once");
    assert_eq!(s.signals.faults_applied(), 1);
    let load = s.world.body_id("load").unwrap();
    let v0 = s.world.body(load).unwrap().linvel();
    s.step().unwrap();
    let v1 = s.world.body(load).unwrap().linvel();
    assert!(((v1 - v0).z + G / 60.0).abs() < 1e-9, "free fall after the break: Δv {:?}", v1 - v0);
    let f = s.signals.sensor_values("rope").unwrap();
    assert!(f.iter().all(|x| *x == 0.0), "a parted rope carries nothing: {f:?}");
}
