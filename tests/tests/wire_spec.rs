//! What `msgs/README.md` says the server does, checked against a live server on loopback: a
//! failing control request is answered with its own id (an unknown variant as `unknown_variant`),
//! `step` on a running world is `busy`, a paused server re-sends its last frame (same sequence),
//! and after `reset` the new state has a new sequence (the last plus one) while the simulation
//! time restarts.

#![cfg(feature = "live")]

use std::time::{Duration, Instant};

use pivotsim_msgs as msgs;
use pivotsim_tests::Server;
use zenoh::Wait;

fn failure(r: &msgs::ControlReply) -> msgs::ControlErrorCode {
    match &r.outcome {
        msgs::ControlOutcome::Error(f) => f.code,
        msgs::ControlOutcome::Ok(s) => panic!("expected a failure, got {s:?}"),
    }
}

fn status(r: &msgs::ControlReply) -> msgs::ServerStatus {
    match &r.outcome {
        msgs::ControlOutcome::Ok(s) => s.clone(),
        msgs::ControlOutcome::Error(f) => panic!("expected success, got {f:?}"),
    }
}

/// A raw control request frame with `json` as its payload.
fn raw_request(json: &str) -> Vec<u8> {
    let mut buf = Vec::new();
    msgs::ControlRequest { id: 1, command: msgs::ControlCommand::Pause }.encode(&mut buf).unwrap();
    buf.truncate(msgs::HEADER_LEN);
    buf.extend_from_slice(json.as_bytes());
    let len = (buf.len() - msgs::HEADER_LEN) as u32;
    buf[8..12].copy_from_slice(&len.to_le_bytes());
    buf
}

/// Pose frames (sequence, sim time) received within `window`.
fn poses(session: &zenoh::Session, server: &Server, window: Duration) -> Vec<(u64, f64)> {
    let sub = session.declare_subscriber(server.key(msgs::Topic::Poses)).wait().unwrap();
    let end = Instant::now() + window;
    let mut out = Vec::new();
    while let Some(left) = end.checked_duration_since(Instant::now()) {
        match sub.recv_timeout(left) {
            Ok(Some(s)) => {
                let f = msgs::PoseFrame::decode(&s.payload().to_bytes()).unwrap();
                out.push((f.sequence, f.sim_time));
            }
            _ => break,
        }
    }
    out
}

#[test]
fn control_failures_carry_the_request_id_and_the_documented_code() {
    let server = Server::start_with("pendulum", "spec-control", |c| c.iceoryx2 = false);
    let z = server.session();
    let r = server
        .control_bytes(&z, raw_request(r#"{"id":77,"command":{"op":"set_variant","variant":"fastest"}}"#));
    assert_eq!((r.id, failure(&r)), (77, msgs::ControlErrorCode::UnknownVariant));
    let r = server.control_bytes(&z, raw_request(r#"{"id":78,"command":{"op":"explode"}}"#));
    assert_eq!((r.id, failure(&r)), (78, msgs::ControlErrorCode::InvalidRequest));
    let r = server.control_bytes(&z, raw_request(r#"{"id":79,"command":{"op":"step","count":0}}"#));
    assert_eq!((r.id, failure(&r)), (79, msgs::ControlErrorCode::InvalidRequest));
    // `step` on a running world.
    let r = server.control(&z, 80, msgs::ControlCommand::Step { count: 1 });
    assert_eq!((r.id, failure(&r)), (80, msgs::ControlErrorCode::Busy));
    server.stop();
}

#[test]
fn paused_frames_repeat_and_sequences_outlive_a_reset() {
    let server = Server::start_with("pendulum", "spec-seq", |c| c.iceoryx2 = false);
    let z = server.session();
    let paused = status(&server.control(&z, 1, msgs::ControlCommand::Pause));
    assert!(paused.paused);
    let frames = poses(&z, &server, Duration::from_millis(500));
    assert!(frames.len() >= 5, "a paused server keeps publishing: {} frames", frames.len());
    assert!(frames.iter().all(|&(seq, t)| (seq, t) == frames[0]), "the same frame again: {frames:?}");
    let before = frames[0].0;
    assert!(before > 0 && frames[0].1 > 0.0);

    let reset = status(&server.control(&z, 2, msgs::ControlCommand::Reset));
    assert_eq!(reset.sim_time, 0.0);
    // A new state, a new sequence: the reset world is never sent under the old state's number.
    assert_eq!(reset.sequence, before + 1, "sequence {} after {before}", reset.sequence);
    let repeated = poses(&z, &server, Duration::from_millis(300));
    assert!(!repeated.is_empty() && repeated.iter().all(|&f| f == (before + 1, 0.0)), "{repeated:?}");
    status(&server.control(&z, 3, msgs::ControlCommand::Resume));
    let after = poses(&z, &server, Duration::from_millis(500));
    assert!(!after.is_empty());
    assert!(after.iter().all(|&(seq, t)| seq > before && t < 1.0), "{after:?}");
    server.stop();
}

/// Frames of every topic received within `window`: (topic, sequence).
fn frames(session: &zenoh::Session, server: &Server, window: Duration) -> Vec<(msgs::Topic, u64)> {
    use msgs::Topic as T;
    let subs: Vec<_> = [T::Poses, T::Stats, T::Signals, T::Events]
        .into_iter()
        .map(|t| (t, session.declare_subscriber(server.key(t)).wait().unwrap()))
        .collect();
    let end = Instant::now() + window;
    let mut out = Vec::new();
    while Instant::now() < end {
        for (t, sub) in &subs {
            while let Ok(Some(s)) = sub.try_recv() {
                let b = s.payload().to_bytes();
                let seq = match t {
                    T::Poses => msgs::PoseFrame::decode(&b).unwrap().sequence,
                    T::Stats => msgs::SolverStats::decode(&b).unwrap().sequence,
                    T::Signals => msgs::SignalsFrame::decode(&b).unwrap().sequence,
                    _ => msgs::EventsFrame::decode(&b).unwrap().sequence,
                };
                out.push((*t, seq));
            }
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    out
}

fn rig_server(tag: &str) -> Server {
    let rig = pivotsim_tests::temp_file(
        &format!("spec-{tag}.toml"),
        include_str!("../../server/tests/support/rig.toml"),
    );
    Server::start_with(&rig.display().to_string(), tag, |c| c.iceoryx2 = false)
}

fn put(session: &zenoh::Session, server: &Server, topic: msgs::Topic, frame: Vec<u8>) {
    session.put(server.key(topic), frame).wait().unwrap();
}

fn input(cmd: msgs::InputCommand) -> Vec<u8> {
    let mut buf = Vec::new();
    cmd.encode(&mut buf).unwrap();
    buf
}

fn name(s: &str) -> msgs::ActuatorName {
    msgs::ActuatorName::new(s).unwrap()
}

/// The latest stats frame.
fn stats(session: &zenoh::Session, server: &Server) -> msgs::SolverStats {
    let sub = session.declare_subscriber(server.key(msgs::Topic::Stats)).wait().unwrap();
    let s = sub.recv_timeout(Duration::from_secs(2)).unwrap().expect("a stats frame");
    msgs::SolverStats::decode(&s.payload().to_bytes()).unwrap()
}

/// "A boom command's value is read in its actuator's mode": on a position actuator 0.05 is a
/// position target of 0.05 m (the rig's slider rises 5 cm and stays), not a speed of 0.05 m/s
/// (which would have moved it 1.25 cm before the 250 ms deadman held it).
#[test]
fn a_boom_value_on_a_position_actuator_is_a_position_target() {
    let server = rig_server("spec-boom");
    let z = server.session();
    let d = server.scene(&z).unwrap();
    let slider = d.bodies.iter().find(|b| b.name == "slider").unwrap().id;
    let z0 = poses_of(&z, &server, slider);
    let boom = msgs::BoomCommand {
        sequence: 1,
        source_id: 9,
        targets: vec![msgs::BoomTarget { actuator: name("boom"), value: 0.05 }],
    };
    put(&z, &server, msgs::Topic::Boom, input(msgs::InputCommand::Boom(boom)));
    std::thread::sleep(Duration::from_millis(800));
    let z1 = poses_of(&z, &server, slider);
    assert!((z1 - z0 - 0.05).abs() < 1e-3, "the slider moved {} m, not to its 0.05 m target", z1 - z0);
    server.stop();
}

/// The slider's height in the latest pose frame.
fn poses_of(session: &zenoh::Session, server: &Server, id: u32) -> f64 {
    let sub = session.declare_subscriber(server.key(msgs::Topic::Poses)).wait().unwrap();
    let s = sub.recv_timeout(Duration::from_secs(2)).unwrap().expect("a pose frame");
    let f = msgs::PoseFrame::decode(&s.payload().to_bytes()).unwrap();
    f.bodies.iter().find(|b| b.id == id).unwrap().position[2]
}

/// A refused fault's target of any spelling or length is one event record (characters outside the
/// name rules as `_`, more than 32 characters as 30 and `..`), never silently cut or left out while
/// `events_total` counts it; while paused the server re-sends poses, stats and signals (the same
/// sequence) but never an events frame again.
#[test]
fn refused_fault_targets_are_records_and_a_paused_server_never_resends_events() {
    let server = rig_server("spec-events");
    let z = server.session();
    let events = z.declare_subscriber(server.key(msgs::Topic::Events)).wait().unwrap();
    let long = "a-joint-name-that-is-much-longer-than-32-bytes";
    let mut names = Vec::new();
    for (k, target) in ["no such joint", long].into_iter().enumerate() {
        let fault = msgs::ControlCommand::Fault {
            fault: msgs::FaultKind::Break,
            target: target.into(),
            tension: None,
            to: None,
            ramp: None,
        };
        assert_eq!(failure(&server.control(&z, 10 + k as u64, fault)), msgs::ControlErrorCode::FaultRejected);
        let s = events.recv_timeout(Duration::from_secs(2)).unwrap().expect("an events frame");
        let f = msgs::EventsFrame::decode(&s.payload().to_bytes()).unwrap();
        assert_eq!((f.events.len(), f.events_total), (1, k as u64 + 1), "{f:?}");
        names.push(f.events[0].name.as_str().to_string());
    }
    assert_eq!(names, ["no_such_joint".to_string(), format!("{}..", &long[..30])]);
    // A refused fault, then a pause: that step's events went out once; paused, none again.
    let fault = msgs::ControlCommand::Fault {
        fault: msgs::FaultKind::HoseBurst,
        target: "nope".into(),
        tension: None,
        to: None,
        ramp: None,
    };
    server.control(&z, 20, fault);
    status(&server.control(&z, 21, msgs::ControlCommand::Pause));
    std::thread::sleep(Duration::from_millis(100));
    let seen = frames(&z, &server, Duration::from_millis(600));
    let count = |t: msgs::Topic| seen.iter().filter(|f| f.0 == t).count();
    assert!(
        count(msgs::Topic::Poses) >= 5 && count(msgs::Topic::Stats) >= 5 && count(msgs::Topic::Signals) >= 5,
        "{seen:?}"
    );
    assert_eq!(count(msgs::Topic::Events), 0, "a paused server re-sent events: {seen:?}");
    let seq = seen[0].1;
    assert!(seen.iter().all(|f| f.1 == seq), "paused frames repeat one sequence: {seen:?}");
    server.stop();
}

/// The order of the input checks and the scope of `stale`: a boom command that says 17 targets
/// but carries 16 is `oversize` (the count is checked before the layout); sequences are per
/// `source_id` across every input kind, and outlive a `reset`.
#[test]
fn input_checks_run_in_the_documented_order_and_stale_is_per_source() {
    use msgs::RejectReason as R;
    let server = rig_server("spec-inputs");
    let z = server.session();
    let targets =
        (0..16).map(|i| msgs::BoomTarget { actuator: name(&format!("b{i}")), value: 0.0 }).collect();
    let mut boom = input(msgs::InputCommand::Boom(msgs::BoomCommand { sequence: 1, source_id: 1, targets }));
    boom[16 + 12..16 + 16].copy_from_slice(&17u32.to_le_bytes());
    put(&z, &server, msgs::Topic::Boom, boom);
    let winch = |seq, source| {
        input(msgs::InputCommand::Winch(msgs::WinchCommand {
            sequence: seq,
            source_id: source,
            actuator: name("winch"),
            drum_speed: 0.5,
        }))
    };
    let actuator = |seq, source| {
        input(msgs::InputCommand::Actuator(msgs::ActuatorCommand {
            sequence: seq,
            source_id: source,
            mode: msgs::ActuatorMode::Velocity,
            actuator: name("winch"),
            value: 0.5,
        }))
    };
    put(&z, &server, msgs::Topic::Winch, winch(10, 5));
    std::thread::sleep(Duration::from_millis(100));
    put(&z, &server, msgs::Topic::Actuator, actuator(10, 5)); // same source, not newer: stale
    put(&z, &server, msgs::Topic::Actuator, actuator(10, 6)); // another source: its own sequence
    std::thread::sleep(Duration::from_millis(300));
    // The sequences outlive a reset: source 5's next input must still be newer than 10.
    status(&server.control(&z, 1, msgs::ControlCommand::Reset));
    put(&z, &server, msgs::Topic::Winch, winch(9, 5));
    std::thread::sleep(Duration::from_millis(300));
    let h = stats(&z, &server).inputs;
    assert_eq!(h.rejected_for(R::Oversize), 1, "{h:?}");
    assert_eq!(h.rejected_for(R::Malformed), 0, "{h:?}");
    assert_eq!(h.rejected_for(R::Stale), 2, "{h:?}");
    assert_eq!(h.accepted, 2, "{h:?}");
    server.stop();
}

/// Control ids that are no u64 (2⁶⁴, −1) are answered with id 0 and `invalid_request`.
#[test]
fn control_ids_outside_u64_are_answered_with_id_zero() {
    let server = Server::start_with("pendulum", "spec-ids", |c| c.iceoryx2 = false);
    let z = server.session();
    for id in ["18446744073709551616", "-1"] {
        let r =
            server.control_bytes(&z, raw_request(&format!(r#"{{"id":{id},"command":{{"op":"pause"}}}}"#)));
        assert_eq!((r.id, failure(&r)), (0, msgs::ControlErrorCode::InvalidRequest), "id {id}");
    }
    let r = server.control_bytes(&z, raw_request(r#"{"id":18446744073709551615,"command":{"op":"pause"}}"#));
    assert_eq!(r.id, u64::MAX);
    assert!(status(&r).paused);
    server.stop();
}

/// "While paused the server re-sends at the step rate" holds also for a server stepping as fast as
/// possible (`--fast`): a paused world is re-sent about 60 times a second, not in a busy loop.
#[test]
fn a_paused_fast_server_resends_at_the_step_rate() {
    let server = Server::start_with("pendulum", "spec-fast", |c| {
        c.iceoryx2 = false;
        c.realtime_factor = None;
        c.start_paused = true;
    });
    let z = server.session();
    let frames = poses(&z, &server, Duration::from_millis(1000));
    println!("{} pose frames in 1 s while paused at --fast", frames.len());
    assert!(frames.len() >= 20 && frames.len() <= 90, "{} frames in 1 s", frames.len());
    server.stop();
}
