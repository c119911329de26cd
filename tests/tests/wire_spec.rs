//! What `msgs/README.md` says the server does, checked against a live server on loopback: a
//! failing control request is answered with its own id (an unknown variant as `unknown_variant`),
//! `step` on a running world is `busy`, a paused server re-sends its last frame (same sequence),
//! and after `reset` the sequence keeps counting while the simulation time restarts.

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
    assert!(reset.sequence >= before, "sequence {} after {before}", reset.sequence);
    status(&server.control(&z, 3, msgs::ControlCommand::Resume));
    let after = poses(&z, &server, Duration::from_millis(500));
    assert!(!after.is_empty());
    assert!(after.iter().all(|&(seq, t)| seq > before && t < 1.0), "{after:?}");
    server.stop();
}
