//! The server's engine in-process, without transports: inputs move the right joints in wire
//! units; NaN, truncated, oversized, wrong-version, unknown-actuator and stale inputs are
//! rejected, counted by reason, and leave the world bit-identical to a run without them; the
//! deadman neutralizes within its timeout plus one step; control requests pause, step, reset,
//! switch the solver variant live without a discontinuity, load scenes, and fail with typed
//! errors; every built-in scene's description passes the wire validation.

use std::time::{Duration, Instant};

use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use pivotsim_msgs as msgs;
use pivotsim_server::serve::Engine;
use pivotsim_tests::temp_file;

const DEADMAN: Duration = Duration::from_millis(250);

/// A drum on a hinge (a winch: 2 rad/s per unit) and a slider on a prismatic joint under a
/// position actuator (the boom), no contacts.
const RIG: &str = include_str!("support/rig.toml");

fn rig_path() -> String {
    temp_file("serve-engine-rig.toml", RIG).display().to_string()
}

fn engine(scene: &str) -> Engine {
    Engine::new(scene, msgs::WorldName::new("test").unwrap(), DEADMAN).unwrap()
}

fn name(s: &str) -> msgs::ActuatorName {
    msgs::ActuatorName::new(s).unwrap()
}

fn frame(cmd: msgs::InputCommand) -> Vec<u8> {
    let mut buf = Vec::new();
    cmd.encode(&mut buf).unwrap();
    buf
}

fn winch(seq: u64, speed: f64) -> Vec<u8> {
    frame(msgs::InputCommand::Winch(msgs::WinchCommand {
        sequence: seq,
        source_id: 7,
        actuator: name("winch"),
        drum_speed: speed,
    }))
}

fn joint_speed(e: &Engine, joint: &str) -> f64 {
    let w = &e.scene().world;
    w.joint_speed(w.joint_id(joint).unwrap()).unwrap()
}

fn joint_coordinate(e: &Engine, joint: &str) -> f64 {
    let w = &e.scene().world;
    w.joint_coordinate(w.joint_id(joint).unwrap()).unwrap()
}

/// Every body's state, bitwise.
fn state_bits(e: &Engine) -> Vec<u64> {
    e.scene()
        .world
        .bodies()
        .iter()
        .flat_map(|b| {
            let q = b.orientation();
            [b.position().as_slice(), b.linvel().as_slice(), b.angvel().as_slice(), q.coords.as_slice()]
                .concat()
                .into_iter()
                .map(f64::to_bits)
                .collect::<Vec<_>>()
        })
        .collect()
}

#[test]
fn winch_boom_and_actuator_commands_move_the_right_joints_in_wire_units() {
    let mut e = engine(&rig_path());
    let t0 = Instant::now();
    e.handle_input(Some(msgs::Topic::Winch), &winch(1, 1.5), t0).unwrap();
    assert!(e.tick(t0));
    assert!((joint_speed(&e, "axle") - 1.5).abs() < 1e-6, "drum at the commanded 1.5 rad/s");
    assert!(joint_speed(&e, "rail").abs() < 1e-6, "the slider did not move");
    // A boom command is read in each actuator's mode (msgs/README.md): on the position actuator
    // 0.6 is a position target of 0.6 m, reached at the actuator's 10 m/s and held — not a
    // speed (which would have moved the slider 0.6 m/s × 30 h = 0.3 m).
    let boom = frame(msgs::InputCommand::Boom(msgs::BoomCommand {
        sequence: 2,
        source_id: 7,
        targets: vec![msgs::BoomTarget { actuator: name("boom"), value: 0.6 }],
    }));
    e.handle_input(Some(msgs::Topic::Boom), &boom, t0).unwrap();
    let h = e.scene().world.settings().timestep;
    for _ in 0..30 {
        e.tick(t0);
    }
    let s = joint_coordinate(&e, "rail");
    assert!((s - 0.6).abs() < 1e-6, "slider at {s}, not at the 0.6 m target");
    assert!((0.6 * 30.0 * h - 0.6).abs() > 0.1, "the test tells a position from a speed");
    // An actuator command in position mode sets the target.
    let pos = frame(msgs::InputCommand::Actuator(msgs::ActuatorCommand {
        sequence: 3,
        source_id: 7,
        mode: msgs::ActuatorMode::Position,
        actuator: name("boom"),
        value: -0.25,
    }));
    e.handle_input(Some(msgs::Topic::Actuator), &pos, t0).unwrap();
    // At most 10 m/s (max_speed): 0.85 m takes 6 steps.
    for _ in 0..7 {
        e.tick(t0);
    }
    assert!((joint_coordinate(&e, "rail") + 0.25).abs() < 1e-6);
    // A joystick goes through the scene's mapping: axis 0 → winch (±1 → ±2 rad/s).
    let joy = frame(msgs::InputCommand::Joystick(msgs::Joystick::new(4, 7, &[-0.5], 0, 0).unwrap()));
    e.handle_input(Some(msgs::Topic::Joystick), &joy, t0).unwrap();
    e.tick(t0);
    assert!((joint_speed(&e, "axle") + 1.0).abs() < 1e-6);
    assert_eq!(e.health().accepted, 4);
    assert_eq!(e.health().rejected_total(), 0);
}

#[test]
fn bad_inputs_are_rejected_counted_by_reason_and_change_nothing() {
    let path = rig_path();
    let (mut clean, mut dirty) = (engine(&path), engine(&path));
    let t0 = Instant::now();
    let good = winch(10, 1.0);
    for e in [&mut clean, &mut dirty] {
        e.handle_input(Some(msgs::Topic::Winch), &good, t0).unwrap();
    }
    // NaN: the encoder refuses it, so patch the speed's bytes in a valid frame.
    let mut nan = winch(11, 1.25);
    let at = nan.windows(8).position(|w| w == 1.25f64.to_le_bytes()).unwrap();
    nan[at..at + 8].copy_from_slice(&f64::NAN.to_le_bytes());
    let truncated = winch(12, 0.5)[..40].to_vec();
    // Oversized: a header that claims a payload far beyond a winch command's.
    let mut oversized = winch(13, 0.5);
    oversized[8..12].copy_from_slice(&100_000u32.to_le_bytes());
    oversized.resize(16 + 100_000, 0);
    let mut version = winch(14, 0.5);
    version[4..6].copy_from_slice(&99u16.to_le_bytes());
    let unknown = frame(msgs::InputCommand::Winch(msgs::WinchCommand {
        sequence: 15,
        source_id: 7,
        actuator: name("crane"),
        drum_speed: 0.5,
    }));
    // The boom is a position actuator, not a winch.
    let wrong_kind = frame(msgs::InputCommand::Winch(msgs::WinchCommand {
        sequence: 16,
        source_id: 7,
        actuator: name("boom"),
        drum_speed: 0.5,
    }));
    // The boom is a position actuator: a velocity command to it is in the wrong mode.
    let wrong_mode = frame(msgs::InputCommand::Actuator(msgs::ActuatorCommand {
        sequence: 18,
        source_id: 7,
        mode: msgs::ActuatorMode::Velocity,
        actuator: name("boom"),
        value: 0.1,
    }));
    let stale = winch(10, -1.0);
    // A winch frame on the joystick key.
    let wrong_key = winch(17, -1.0);
    let cases: [(&[u8], Option<msgs::Topic>, msgs::RejectReason); 9] = [
        (&nan, Some(msgs::Topic::Winch), msgs::RejectReason::NonFinite),
        (&truncated, Some(msgs::Topic::Winch), msgs::RejectReason::Malformed),
        (&oversized, Some(msgs::Topic::Winch), msgs::RejectReason::Oversize),
        (&version, Some(msgs::Topic::Winch), msgs::RejectReason::Version),
        (&unknown, Some(msgs::Topic::Winch), msgs::RejectReason::UnknownActuator),
        (&wrong_kind, Some(msgs::Topic::Winch), msgs::RejectReason::UnknownActuator),
        (&wrong_mode, Some(msgs::Topic::Actuator), msgs::RejectReason::WrongMode),
        (&stale, Some(msgs::Topic::Winch), msgs::RejectReason::Stale),
        (&wrong_key, Some(msgs::Topic::Joystick), msgs::RejectReason::Version),
    ];
    for step in 0..120 {
        if step % 10 == 0 {
            for (bytes, topic, reason) in &cases {
                assert_eq!(dirty.handle_input(*topic, bytes, t0), Err(*reason));
            }
        }
        clean.tick(t0);
        dirty.tick(t0);
        assert_eq!(state_bits(&clean), state_bits(&dirty), "step {step}");
    }
    let h = dirty.health();
    assert_eq!(h.accepted, 1);
    for (reason, n) in [
        (msgs::RejectReason::NonFinite, 12),
        (msgs::RejectReason::Malformed, 12),
        (msgs::RejectReason::Oversize, 12),
        (msgs::RejectReason::Version, 24),
        (msgs::RejectReason::UnknownActuator, 24),
        (msgs::RejectReason::WrongMode, 12),
        (msgs::RejectReason::Stale, 12),
    ] {
        assert_eq!(h.rejected_for(reason), n, "{reason}");
    }
    // The stats frame carries the counters.
    let stats = msgs::SolverStats::decode(dirty.stats_frame()).unwrap();
    assert_eq!(stats.inputs, *h);
    assert_eq!(stats.sequence, 120);
}

#[test]
fn the_deadman_neutralizes_after_its_timeout_and_the_next_input_clears_it() {
    let mut e = engine(&rig_path());
    let t0 = Instant::now();
    e.handle_input(None, &winch(1, 2.0), t0).unwrap();
    let h = Duration::from_secs_f64(e.scene().world.settings().timestep);
    let mut t = t0;
    let mut tripped_at = None;
    for _ in 0..60 {
        t += h;
        e.tick(t);
        if e.health().deadman_active && tripped_at.is_none() {
            tripped_at = Some(t - t0);
            // Neutral: the drum is held still within the step that follows.
            e.tick(t + h);
            assert!(joint_speed(&e, "axle").abs() < 1e-6);
            break;
        }
        assert!((joint_speed(&e, "axle") - 2.0).abs() < 1e-6, "driven until the deadman");
    }
    let at = tripped_at.expect("the deadman tripped");
    assert!(at > DEADMAN && at <= DEADMAN + h, "tripped after {at:?}");
    assert_eq!(e.health().deadman_trips, 1);
    let stats = msgs::SolverStats::decode(e.stats_frame()).unwrap();
    assert!(stats.inputs.deadman_active);
    e.handle_input(None, &winch(2, 1.0), t + h).unwrap();
    assert!(!e.health().deadman_active);
    e.tick(t + 2 * h);
    assert!((joint_speed(&e, "axle") - 1.0).abs() < 1e-6);
}

fn control(e: &mut Engine, id: u64, command: msgs::ControlCommand) -> msgs::ControlOutcome {
    let mut buf = Vec::new();
    msgs::ControlRequest { id, command }.encode(&mut buf).unwrap();
    let reply = msgs::ControlReply::decode(&e.handle_control(&buf)).unwrap();
    assert_eq!(reply.id, id);
    reply.outcome
}

#[test]
fn control_requests_pause_step_reset_load_and_fail_with_typed_errors() {
    use msgs::ControlCommand as C;
    use msgs::ControlOutcome as O;
    let mut e = engine("pendulum");
    let t0 = Instant::now();
    for _ in 0..10 {
        e.tick(t0);
    }
    match control(&mut e, 1, C::Step { count: 3 }) {
        O::Error(f) => assert_eq!(f.code, msgs::ControlErrorCode::Busy),
        o => panic!("{o:?}"),
    }
    let O::Ok(s) = control(&mut e, 2, C::Pause) else { panic!() };
    assert!(s.paused && s.sequence == 10);
    assert!(!e.tick(t0), "paused: no step");
    let O::Ok(s) = control(&mut e, 3, C::Step { count: 3 }) else { panic!() };
    assert_eq!(s.sequence, 13);
    assert_eq!(msgs::PoseFrameView::parse(e.pose_frame()).unwrap().sequence(), 13);
    let O::Ok(s) = control(&mut e, 4, C::Reset) else { panic!() };
    assert!(s.paused && s.sim_time == 0.0 && s.scene == "pendulum");
    // The reset state is a new state: a new sequence, never a repeat of step 13's.
    assert_eq!(s.sequence, 14);
    assert_eq!(msgs::PoseFrameView::parse(e.pose_frame()).unwrap().sequence(), 14);
    let O::Ok(s) = control(&mut e, 5, C::LoadScene { scene: "box_stack".into() }) else { panic!() };
    assert_eq!(s.scene, "box_stack");
    assert_eq!(s.sequence, 15);
    assert_eq!(msgs::SceneDescription::decode(e.description()).unwrap().scene, "box_stack");
    match control(&mut e, 6, C::LoadScene { scene: "no-such-scene".into() }) {
        O::Error(f) => assert_eq!(f.code, msgs::ControlErrorCode::UnknownScene),
        o => panic!("{o:?}"),
    }
    let bad = temp_file("serve-engine-bad.toml", "[scene]\nname = 3\n");
    // A file outside the scene directories is refused before it is read; inside, it is loaded
    // and its mistakes are located.
    match control(&mut e, 7, C::LoadScene { scene: bad.display().to_string() }) {
        O::Error(f) => assert_eq!(f.code, msgs::ControlErrorCode::LoadRefused, "{}", f.message),
        o => panic!("{o:?}"),
    }
    let dir = bad.parent().unwrap().to_path_buf();
    e.set_load_policy(pivotsim_server::serve::loader::LoadPolicy::new(&[dir], 1 << 20).unwrap());
    match control(&mut e, 7, C::LoadScene { scene: bad.display().to_string() }) {
        O::Error(f) => {
            assert_eq!(f.code, msgs::ControlErrorCode::SceneLoadFailed);
            assert!(f.message.contains(":2:"), "located: {}", f.message);
        }
        o => panic!("{o:?}"),
    }
    assert_eq!(e.scene().name, "box_stack", "a failed load keeps the running scene");
    let O::Ok(s) = control(&mut e, 8, C::Resume) else { panic!() };
    assert!(!s.paused);
    assert!(e.tick(t0));
    // A frame that is no control request.
    let reply = msgs::ControlReply::decode(&e.handle_control(b"garbage")).unwrap();
    assert!(matches!(reply.outcome, O::Error(f) if f.code == msgs::ControlErrorCode::InvalidRequest));
}

/// Both variants are exact: switching from `skyline` to `full` mid-run keeps the trajectory of a
/// pure `skyline` run (a discontinuity would show as a jump far above round-off).
#[test]
fn switching_the_solver_variant_live_keeps_the_simulation_continuous() {
    let (mut a, mut b) = (engine("box_stack"), engine("box_stack"));
    let t0 = Instant::now();
    let mut max_diff: f64 = 0.0;
    for step in 0..240 {
        if step == 120 {
            let out =
                control(&mut b, 1, msgs::ControlCommand::SetVariant { variant: msgs::SolverVariant::Full });
            assert!(matches!(out, msgs::ControlOutcome::Ok(ref s) if s.variant == msgs::SolverVariant::Full));
        }
        a.tick(t0);
        b.tick(t0);
        for (p, q) in a.scene().world.bodies().iter().zip(b.scene().world.bodies()) {
            max_diff = max_diff.max((p.position() - q.position()).norm());
        }
    }
    assert_eq!(b.scene().world.island_stats()[0].variant.name(), "full");
    assert!(max_diff < 1e-9, "trajectories differ by {max_diff}");
}

#[test]
fn every_builtin_scene_has_a_valid_description_and_pose_frame() {
    for s in pivotsim_server::scene::BUILTIN {
        let mut e = engine(s.name);
        let d =
            msgs::SceneDescription::decode(e.description()).unwrap_or_else(|err| panic!("{}: {err}", s.name));
        d.validate().unwrap();
        assert_eq!(d.bodies.len(), e.scene().world.bodies().len());
        assert_eq!(d.actuators.len(), e.scene().controls.actuators().len());
        // Every joint's frame on its child (body A), every sensor in the scene's order.
        for j in &d.joints {
            assert_eq!(j.frame.as_ref().and_then(|f| f.body), Some(j.child), "{}: {}", s.name, j.name);
        }
        let sensors: Vec<&str> = e.scene().signals.sensors().iter().map(|x| x.name.as_str()).collect();
        let described: Vec<&str> = d.sensors.iter().map(|x| x.name()).collect();
        assert_eq!(described, sensors, "{}", s.name);
        e.tick(Instant::now());
        let f = msgs::PoseFrame::decode(e.pose_frame()).unwrap();
        assert_eq!(f.bodies.len(), d.bodies.len());
        assert_eq!(f.sequence, 1);
        for (p, b) in f.bodies.iter().zip(e.scene().world.bodies()) {
            assert_eq!(p.position, [b.position().x, b.position().y, b.position().z]);
        }
    }
}

/// `serve --set` overrides the start scene's settings (and again at a reset), `--max-solve-us`
/// puts every solve of a step under a budget: a budget far below one pivot step stops the solves
/// with status `budget`, and the stats frame counts them (since the scene was loaded) beside the
/// per-island status, so no degraded solve is silent.
#[test]
fn overrides_and_the_solve_budget_reach_the_world_and_the_stats() {
    let set: Vec<pivotsim_server::scene::SceneOverride> =
        vec!["max_pivot_steps=7".parse().unwrap(), "contact_compliance=1e-9".parse().unwrap()];
    let world = msgs::WorldName::new("test").unwrap();
    let mut e = Engine::with_settings("forklift", world.clone(), DEADMAN, &set, Some(0.001)).unwrap();
    assert_eq!(e.scene().world.settings().solver.max_steps, 7);
    assert_eq!(e.scene().world.settings().solver.max_solve_us, Some(0.001));
    let t0 = Instant::now();
    let mut budget_islands = 0u32;
    for k in 0..30 {
        e.tick(t0 + Duration::from_millis(17 * k));
        let st = msgs::SolverStats::decode(e.stats_frame()).unwrap();
        budget_islands += st.islands.iter().filter(|i| i.status == msgs::SolveStatus::Budget).count() as u32;
        assert_eq!(
            st.degraded.budget, budget_islands,
            "step {k}: counted on the wire as seen in the records"
        );
    }
    assert!(budget_islands > 0, "a budget of 1 ns stopped no solve");
    // A reset reloads the start scene with the same overrides and clears the counters.
    use msgs::ControlCommand as C;
    let msgs::ControlOutcome::Ok(_) = control(&mut e, 1, C::Reset) else { panic!("reset") };
    assert_eq!(e.scene().world.settings().solver.max_steps, 7);
    assert_eq!(msgs::SolverStats::decode(e.stats_frame()).unwrap().degraded, msgs::DegradedSolves::default());
    // An override that names nothing is a typed error, not a half-loaded world.
    let bad = vec!["body.nosuchbody.mass=3".parse().unwrap()];
    assert!(matches!(
        Engine::with_settings("forklift", world, DEADMAN, &bad, None),
        Err(pivotsim_server::scene::SceneError::Override { .. })
    ));
}

/// A rotated 5 kg load hanging from an inclined hinge on a static beam, a 10 kg crate resting on
/// the ground, and one sensor of each body-set kind.
const FRAMES: &str = r#"
[scene]
name = "frames"
[[body]]
name = "ground"
kind = "static"
[[body.shape]]
type = "box"
size = [4, 4, 0.2]
[[body]]
name = "crate"
mass = 10
position = [0, 0, 0.35]
[[body.shape]]
type = "box"
size = [0.5, 0.5, 0.5]
[[body]]
name = "beam"
kind = "static"
position = [2, 0, 3.3]
[[body.shape]]
type = "box"
size = [0.2, 0.2, 0.2]
[[body]]
name = "load"
mass = 5
inertia = [0.1, 0.2, 0.3]
position = [2, 0, 2]
rotation = [30, 20, 10]
[[body.shape]]
type = "ball"
radius = 0.1
[[joint]]
name = "pin"
type = "hinge"
a = "load"
b = "beam"
anchor = [2, 0, 3]
axis = [0, 0.6, 0.8]
[[sensor]]
name = "pin.reaction"
type = "joint"
joint = "pin"
[[sensor]]
name = "pin_t"
type = "tension"
joint = "pin"
[[sensor]]
name = "support"
type = "contact_sum"
bodies = ["crate"]
with = ["ground"]
[[sensor]]
name = "lmi"
type = "tipping"
bodies = ["*"]
[[sensor]]
name = "touching"
type = "contacts"
bodies = ["crate"]
"#;

/// The description carries each joint's frame on its child and every sensor with what it reads;
/// a joint sensor's channels, turned into the world with that frame (the child's pose times the
/// frame), are the joint's force on the child: a hanging load's weight upwards, (0, 0, m g).
#[test]
fn the_description_gives_the_frame_a_joint_sensor_reports_in() {
    let path = temp_file("serve-engine-frames.toml", FRAMES).display().to_string();
    let mut e = engine(&path);
    let d = msgs::SceneDescription::decode(e.description()).unwrap();
    let id = |n: &str| d.bodies.iter().find(|b| b.name == n).unwrap().id;
    let pin = d.joint("pin").unwrap();
    assert_eq!((pin.parent, pin.child), (Some(id("beam")), id("load")));
    let frame = pin.frame.clone().unwrap();
    assert_eq!(frame.body, Some(id("load")));
    // The anchor is 1 m above the load's centre of mass: in the load's (rotated) frame.
    let q = |o: [f64; 4]| UnitQuaternion::from_quaternion(Quaternion::new(o[3], o[0], o[1], o[2]));
    let p0 = msgs::PoseFrame::decode(e.pose_frame()).unwrap();
    let load0 = p0.bodies.iter().find(|b| b.id == id("load")).unwrap();
    let anchor = Vector3::from(load0.position) + q(load0.orientation) * Vector3::from(frame.position);
    assert!((anchor - Vector3::new(2.0, 0.0, 3.0)).norm() < 1e-12, "anchor {anchor}");
    // x of the joint frame is the hinge axis.
    let x = q(load0.orientation) * q(frame.orientation) * Vector3::x();
    assert!((x - Vector3::new(0.0, 0.6, 0.8)).norm() < 1e-12, "x {x}");
    assert_eq!(
        d.sensors,
        [
            msgs::SensorInfo::Joint { name: "pin.reaction".into(), joint: "pin".into() },
            msgs::SensorInfo::Tension { name: "pin_t".into(), joint: "pin".into() },
            msgs::SensorInfo::ContactSum {
                name: "support".into(),
                bodies: vec![id("crate")],
                with: Some(vec![id("ground")])
            },
            msgs::SensorInfo::Tipping {
                name: "lmi".into(),
                bodies: vec![id("crate"), id("load")],
                touch: pivotsim_server::scene::DEFAULT_TOUCH
            },
            msgs::SensorInfo::Contacts { name: "touching".into(), bodies: vec![id("crate")] },
        ]
    );
    // After 1 s the load hangs still: the channels in the frame, turned into the world.
    let t0 = Instant::now();
    for _ in 0..60 {
        assert!(e.tick(t0));
    }
    let signals = msgs::SignalsFrame::decode(e.signals_frame()).unwrap();
    let pose = msgs::PoseFrame::decode(e.pose_frame()).unwrap();
    assert_eq!(signals.sequence, pose.sequence);
    let ch = |n: &str| signals.channels.iter().find(|c| c.name.as_str() == n).unwrap().value;
    let f = Vector3::new(ch("pin.reaction/fx"), ch("pin.reaction/fy"), ch("pin.reaction/fz"));
    let t = Vector3::new(ch("pin.reaction/tx"), ch("pin.reaction/ty"), ch("pin.reaction/tz"));
    let load = pose.bodies.iter().find(|b| b.id == id("load")).unwrap();
    let r = q(load.orientation) * q(frame.orientation);
    let (fw, tw) = (r * f, r * t);
    let w = 5.0 * 9.81;
    assert!((fw - Vector3::new(0.0, 0.0, w)).norm() <= 1e-6 * w, "force on the load in the world {fw}");
    assert!(tw.norm() <= 1e-6 * w, "torque about the anchor {tw}");
    assert!((ch("pin_t/tension") - w).abs() <= 1e-6 * w);
    assert!((ch("support/fz") - 10.0 * 9.81).abs() <= 1e-6 * 98.1);
}

/// A refused fault's target is published as an event record whatever its length or spelling
/// (`msgs/README.md`, events): characters outside the name rules become `_`, a target of more than
/// 32 characters keeps 30 and ends in `..`; `events_total` never counts a record the frame lacks.
#[test]
fn refused_fault_targets_of_any_length_or_spelling_give_one_record_each() {
    use msgs::ControlCommand as C;
    let mut e = engine(&rig_path());
    control(&mut e, 1, C::Pause);
    let long = "a-joint-name-that-is-much-longer-than-32-bytes";
    let cases = [("no such joint", "no_such_joint".to_string()), (long, format!("{}..", &long[..30]))];
    for (k, (target, want)) in cases.iter().enumerate() {
        let fault = C::Fault {
            fault: msgs::FaultKind::Break,
            target: target.to_string(),
            tension: None,
            to: None,
            ramp: None,
        };
        match control(&mut e, 10 + k as u64, fault) {
            msgs::ControlOutcome::Error(f) => assert_eq!(f.code, msgs::ControlErrorCode::FaultRejected),
            o => panic!("{o:?}"),
        }
        control(&mut e, 20 + k as u64, C::Step { count: 1 });
        let ev = msgs::EventsFrame::decode(e.events_frame()).expect("an events frame");
        assert_eq!(ev.events.len(), 1, "one record for `{target}`");
        assert_eq!(ev.events_total, k as u64 + 1);
        assert_eq!(ev.events[0].kind, msgs::EventCode::FaultRejected);
        assert_eq!(ev.events[0].name.as_str(), want);
    }
}
