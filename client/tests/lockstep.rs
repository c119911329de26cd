//! `pivotsim-client lockstep` against an in-process server, over Zenoh and over iceoryx2:
//!
//! - the closed loop takes exactly the steps asked for, each a new state with the next sequence,
//!   the world's time advancing by one step each, and the server takes no step without a request;
//! - a controller killed with SIGKILL (no chance to say goodbye) is seen gone within 1 s —
//!   through its Zenoh liveliness token, or over iceoryx2 through its node's death — the server
//!   says so in a `controller-lost` event and resumes real time as configured.

mod common;

use std::sync::mpsc;
use std::time::{Duration, Instant};

use common::{ClientOf, Server, spawn_client};
use pivotsim_msgs as msgs;
use pivotsim_server::serve::ControllerLost;
use serde_json::Value;
use zenoh::Wait;

const LIMIT: Duration = Duration::from_secs(60);

fn status(s: &Server, z: &zenoh::Session) -> msgs::ServerStatus {
    match s.control(z, 7, msgs::ControlCommand::Pause).outcome {
        msgs::ControlOutcome::Ok(st) => st,
        other => panic!("pause: {other:?}"),
    }
}

fn closed_loop(transport: &str) {
    let s = Server::start("pendulum", &format!("ls-{transport}"));
    let out =
        s.client(&["lockstep", "--transport", transport, "--steps", "300", "--gain", "2", "--json"], LIMIT);
    assert_eq!(out.code, Some(0), "{}\n{}", out.stdout, out.stderr);
    let v: Value = serde_json::from_str(out.stdout.trim()).unwrap_or_else(|e| panic!("{e}: {}", out.stdout));
    assert_eq!(v["steps"], 300, "{v}");
    let (first, last) = (v["first_sequence"].as_u64().unwrap(), v["last_sequence"].as_u64().unwrap());
    assert_eq!(last - first, 299, "consecutive states: {v}");
    assert_eq!(v["not_converged"], 0, "{v}");
    assert_eq!(v["malformed_poses"], 0, "{v}");
    // The world stays paused at the controller's last state: no step without a request.
    let z = s.session();
    std::thread::sleep(Duration::from_millis(200));
    let st = status(&s, &z);
    assert_eq!(st.sequence, last, "the server stepped without a request");
    assert!((st.sim_time - v["sim_time"].as_f64().unwrap()).abs() < 1e-12);
    eprintln!(
        "lockstep over {transport} (test build): {:.0} round trips/s, p50 {:.0} µs",
        v["round_trips_per_s"].as_f64().unwrap(),
        v["latency_us"]["p50"].as_f64().unwrap()
    );
    s.stop();
}

#[test]
fn the_closed_loop_takes_exactly_its_steps_over_zenoh() {
    closed_loop("zenoh");
}

#[test]
fn the_closed_loop_takes_exactly_its_steps_over_iceoryx2() {
    closed_loop("iceoryx2");
}

/// A controller event: kind, name (the controller's id), value, arrival.
type Seen = (msgs::EventCode, String, f64, Instant);

/// Controller events from the world's events frames.
fn controller_events(z: &zenoh::Session, s: &Server) -> mpsc::Receiver<Seen> {
    let (tx, rx) = mpsc::channel();
    z.declare_subscriber(s.key(msgs::Topic::Events))
        .callback(move |sample| {
            if let Ok(msgs::Message::Events(f)) = msgs::Message::decode(&sample.payload().to_bytes()) {
                for e in f.events {
                    if matches!(e.kind, msgs::EventCode::ControllerJoined | msgs::EventCode::ControllerLost) {
                        let _ = tx.send((e.kind, e.name.as_str().to_string(), e.value, Instant::now()));
                    }
                }
            }
        })
        .background()
        .wait()
        .unwrap();
    rx
}

/// Pose frame sequences as they arrive.
fn pose_sequences(z: &zenoh::Session, s: &Server) -> mpsc::Receiver<u64> {
    let (tx, rx) = mpsc::channel();
    z.declare_subscriber(s.key(msgs::Topic::Poses))
        .callback(move |sample| {
            if let Ok(v) = msgs::PoseFrameView::parse(&sample.payload().to_bytes()) {
                let _ = tx.send(v.sequence());
            }
        })
        .background()
        .wait()
        .unwrap();
    rx
}

fn killed_controller(transport: &str) {
    let s = Server::start_with("pendulum", &format!("lk-{transport}"), |c| {
        c.on_controller_lost = ControllerLost::Resume;
    });
    let z = s.session();
    let events = controller_events(&z, &s);
    let poses = pose_sequences(&z, &s);
    let mut args = s.args();
    args.extend(
        ["lockstep", "--transport", transport, "--steps", "100000000", "--max-seconds", "50"]
            .map(String::from),
    );
    let controller = spawn_client(&args, LIMIT);
    let (kind, joined, _, _) = events.recv_timeout(Duration::from_secs(15)).unwrap_or_else(|_| {
        panic!("no controller-joined event; the controller said:\n{}", controller.stderr_so_far())
    });
    assert_eq!(kind, msgs::EventCode::ControllerJoined);
    assert!(joined.starts_with('c'), "{joined}");
    // Let it step a while (the world is its: paused between its requests), then kill it.
    std::thread::sleep(Duration::from_millis(300));
    let killed = Instant::now();
    controller.signal("KILL");
    let (kind, lost, value, at) =
        events.recv_timeout(Duration::from_secs(5)).expect("no controller-lost event");
    let seen = at.saturating_duration_since(killed);
    assert_eq!((kind, lost.as_str()), (msgs::EventCode::ControllerLost, joined.as_str()));
    assert!(seen < Duration::from_secs(1), "the killed controller was seen gone after {seen:?}");
    assert_eq!(value, 1.0, "the lost event says real time resumed");
    // Configured to resume: real time runs on without any request.
    while poses.try_recv().is_ok() {}
    let first = poses.recv_timeout(Duration::from_secs(2)).expect("poses after the controller went");
    let deadline = Instant::now() + Duration::from_millis(500);
    let mut last = first;
    while let Some(left) = deadline.checked_duration_since(Instant::now()) {
        match poses.recv_timeout(left) {
            Ok(q) => last = last.max(q),
            Err(_) => break,
        }
    }
    assert!(last >= first + 5, "the world did not run on: sequences {first} → {last} in 0.5 s");
    eprintln!("{transport}: a killed controller seen gone after {:.0} ms", seen.as_secs_f64() * 1e3);
    s.stop();
}

#[test]
fn a_killed_controller_is_seen_within_a_second_over_zenoh() {
    killed_controller("zenoh");
}

#[test]
fn a_killed_controller_is_seen_within_a_second_over_iceoryx2() {
    killed_controller("iceoryx2");
}
