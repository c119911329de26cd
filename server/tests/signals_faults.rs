//! Faults (issue 17), scripted and live, on a pendulum held by its actuators: a rope break
//! releases it, a hose burst makes its drive limp, a faded brake lets it go, a sticking valve
//! keeps it turning whatever is commanded, a dropped-out sensor reads nothing and raises no event.
//! Bad requests — unknown joints, actuators or sensors, NaN or out-of-range values, a brake fade on
//! a motor — are typed errors and counted rejections, never panics. The sensors evaluate without
//! allocating.

use pivotsim_server::scene::{self, FaultError, FaultRequest, Scene, SceneError};
use pivotsim_server::signals::EventKind;

#[path = "support/counting_alloc.rs"]
mod counting_alloc;
use counting_alloc::allocations_during;

/// Two 10 kg bobs on 1 m arms hinged to the world about y, held horizontal: `arm` by a drive
/// (velocity actuator), `arm2` by a brake.
fn pendulums(faults: &str) -> String {
    format!("{}{faults}\n", include_str!("support/scenes/pendulums.toml"))
}

fn load(text: &str) -> Scene {
    scene::load_str("faults.toml", text).unwrap_or_else(|e| panic!("{e}"))
}

fn angle(s: &Scene, joint: &str) -> f64 {
    s.world.joint_coordinate(s.world.joint_id(joint).unwrap()).unwrap()
}

fn run(s: &mut Scene, steps: usize) -> Vec<(EventKind, String, f64)> {
    let mut ev = Vec::new();
    for _ in 0..steps {
        s.step().unwrap();
        ev.extend(s.signals.events().iter().map(|e| (e.kind, e.name.as_str().to_string(), e.time)));
    }
    ev
}

#[test]
fn scripted_faults_act_at_their_time() {
    let faults = r#"
[[fault]]
name = "hose"
type = "hose_burst"
actuator = "drive"
t = 0.5
[[fault]]
name = "fade"
type = "brake_fade"
actuator = "brake"
t = 0.5
to = 0.0
ramp = 0.5
[[fault]]
name = "blind"
type = "dropout"
sensor = "pivot"
t = 0.25
"#;
    let mut s = load(&pendulums(faults));
    let ev = run(&mut s, 29);
    // Held: the drive (speed 0) and the brake keep both arms horizontal; the joint sensor read
    // the drive's load (weight 98.1 N) until it dropped out at 0.25 s.
    assert!(angle(&s, "pivot").abs() < 1e-6 && angle(&s, "pivot2").abs() < 1e-6);
    assert!(ev.iter().any(|e| e.0 == EventKind::Raised && e.1 == "drive-loaded"), "{ev:?}");
    let blind = ev.iter().find(|e| e.0 == EventKind::Fault && e.1 == "blind").expect("dropout fired");
    assert!((blind.2 - 0.25).abs() < 1e-9, "{blind:?}");
    let v = s.signals.sensor_values("pivot").unwrap();
    assert!(v.iter().all(|x| *x == 0.0));
    let first = s.signals.channel("pivot/fx").unwrap();
    assert!(!s.signals.valid()[first]);
    // The brake's torque holds m g l = 98.1 N m.
    let torque = s.signals.value("brake/torque").unwrap().abs();
    assert!((torque - 98.1).abs() < 1e-6 * 98.1, "brake torque {torque}");
    let ev = run(&mut s, 90);
    assert!(
        ev.iter().any(|e| e.0 == EventKind::Fault && e.1 == "hose" && (e.2 - 0.5).abs() < 0.02),
        "{ev:?}"
    );
    assert!(ev.iter().any(|e| e.0 == EventKind::Fault && e.1 == "fade"));
    assert!(angle(&s, "pivot").abs() > 0.5, "a limp drive lets the arm fall: {}", angle(&s, "pivot"));
    assert!(angle(&s, "pivot2").abs() > 0.2, "a faded brake lets go: {}", angle(&s, "pivot2"));
    assert_eq!(s.signals.faults_applied(), 3);
}

#[test]
fn live_requests_fire_next_step_and_bad_ones_are_typed_and_counted() {
    let mut s = load(&pendulums(""));
    s.controls.set("drive", 0.5).unwrap();
    run(&mut s, 10);
    let req = |kind: &str, target: &str| FaultRequest {
        kind: kind.into(),
        target: target.into(),
        tension: None,
        to: None,
        ramp: None,
    };
    s.request_fault(&req("stick_valve", "drive")).unwrap();
    run(&mut s, 1);
    s.controls.set("drive", 0.0).unwrap();
    let a0 = angle(&s, "pivot");
    run(&mut s, 30);
    let a1 = angle(&s, "pivot");
    assert!((a1 - a0 - 0.5 * 0.5).abs() < 0.01, "a stuck valve keeps the drive at 0.5 rad/s: {a0} → {a1}");
    // Bad requests.
    let bad = [
        (req("break", "nope"), "joint"),
        (req("hose_burst", "nope"), "actuator"),
        (req("dropout", "nope"), "sensor"),
        (req("brake_fade", "drive"), "brake"),
        (req("melt", "drive"), "kind"),
        (FaultRequest { tension: Some(f64::NAN), ..req("break", "pivot") }, "value"),
        (FaultRequest { tension: Some(10.0), ..req("hose_burst", "drive") }, "value"),
        (FaultRequest { to: Some(2.0), ..req("brake_fade", "brake") }, "value"),
        (FaultRequest { ramp: Some(f64::INFINITY), ..req("brake_fade", "brake") }, "value"),
    ];
    for (r, what) in &bad {
        let e = s.request_fault(r).unwrap_err();
        let ok = matches!(
            (what, &e),
            (&"joint", FaultError::UnknownJoint(_))
                | (&"actuator", FaultError::UnknownActuator(_))
                | (&"sensor", FaultError::UnknownSensor(_))
                | (&"brake", FaultError::NotABrake(_))
                | (&"kind", FaultError::UnknownKind(_))
                | (&"value", FaultError::BadValue { .. })
        );
        assert!(ok, "{r:?}: {e:?}");
    }
    assert_eq!(s.signals.faults_rejected(), bad.len() as u64);
    let ev = run(&mut s, 1);
    assert_eq!(ev.iter().filter(|e| e.0 == EventKind::FaultRejected).count(), bad.len(), "{ev:?}");
    // A live break parts the joint at the next step.
    s.request_fault(&req("break", "pivot2")).unwrap();
    run(&mut s, 1);
    assert!(!s.world.joint(s.world.joint_id("pivot2").unwrap()).unwrap().is_enabled());
}

#[test]
fn bad_declarations_are_located_errors() {
    let cases = [
        ("[[sensor]]\nname = \"x\"\ntype = \"strain\"\njoint = \"pivot\"", "type"),
        ("[[sensor]]\nname = \"x\"\ntype = \"cylinder\"\njoint = \"pivot\"", "joint"),
        ("[[sensor]]\nname = \"x\"\ntype = \"joint\"\njoint = \"nope\"", "joint"),
        ("[[sensor]]\nname = \"x\"\ntype = \"cable\"\ncable = \"nope\"", "cable"),
        ("[[sensor]]\nname = \"x\"\ntype = \"tipping\"\nbodies = [\"arm\"]\ntouch = nan", "touch"),
        (
            "[[sensor]]\nname = \"a-name-much-too-long-for-the-wire\"\ntype = \"joint\"\njoint = \"pivot\"",
            "name",
        ),
        ("[[sensor]]\nname = \"pivot\"\ntype = \"joint\"\njoint = \"pivot\"", "name"),
        ("[[event]]\nname = \"e\"\nchannel = \"pivot/nope\"\nabove = 1.0", "channel"),
        ("[[event]]\nname = \"e\"\nchannel = \"pivot/fx\"\nabove = 1.0\nbelow = 0.0", "above"),
        ("[[fault]]\nname = \"f\"\ntype = \"break\"\nactuator = \"drive\"\nt = 1.0", "actuator"),
        ("[[fault]]\nname = \"f\"\ntype = \"break\"\njoint = \"pivot\"", "t"),
        ("[[fault]]\nname = \"f\"\ntype = \"break\"\njoint = \"pivot\"\ntension = -5.0", "type"),
    ];
    for (extra, field) in cases {
        let text = pendulums(extra);
        match scene::load_str("bad.toml", &text) {
            Err(SceneError::Invalid { field: f, at, .. }) => {
                assert_eq!(f, field, "{extra}");
                let first = extra.lines().next().unwrap();
                let table = text.lines().enumerate().filter(|(_, l)| *l == first).last().unwrap().0 + 1;
                assert_eq!(at.line, table, "{extra}: located at {at}");
            }
            Err(SceneError::Syntax { .. }) => assert_eq!(field, "syntax", "{extra}"),
            other => panic!("{extra}: {other:?}"),
        }
    }
}

#[test]
fn sensors_evaluate_without_allocating() {
    let text = include_str!("support/scenes/all_sensors.toml");
    let mut s = scene::load_str("alloc.toml", text).unwrap();
    for _ in 0..5 {
        s.step().unwrap();
    }
    assert!(s.signals.contacts().len() == 4, "{:?}", s.signals.contacts());
    assert!(s.signals.value("rope/hook").unwrap() > 400.0);
    let (world, signals) = (&s.world, &mut s.signals);
    let n = allocations_during(|| {
        for _ in 0..10 {
            signals.begin_events();
            signals.evaluate(world);
            signals.check_thresholds(world.time());
        }
    });
    assert_eq!(n, 0, "{n} allocations in 10 evaluations");
}
