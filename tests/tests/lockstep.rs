//! Lockstep over Zenoh, read as a client written from `msgs/README.md` alone would: pose and events
//! frames are decoded at the spec's byte offsets (header 16 bytes; payload `sequence` at 0,
//! `sim_time` at 8; events `event_count` at 16, records of 64 bytes from 32 with `kind` at 32).
//! 1,000 `step 1` requests give 1,000 new states with consecutive sequences and none without a
//! request; a multi-step request publishes every step, and the events of each step reach the
//! client in that step's events frame.

#![cfg(feature = "live")]

use std::collections::BTreeSet;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use pivotsim_msgs as msgs;
use pivotsim_tests::Server;
use zenoh::Wait;

const HEADER: usize = 16;

fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[HEADER + at..HEADER + at + 8].try_into().unwrap())
}

fn f64_at(b: &[u8], at: usize) -> f64 {
    f64::from_bits(u64_at(b, at))
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[HEADER + at..HEADER + at + 4].try_into().unwrap())
}

/// Every frame of `topic` received, as raw bytes, drained on a thread of its own.
fn collect(session: &zenoh::Session, server: &Server, topic: msgs::Topic) -> mpsc::Receiver<Vec<u8>> {
    let (tx, rx) = mpsc::channel();
    session
        .declare_subscriber(server.key(topic))
        .callback(move |s| {
            let _ = tx.send(s.payload().to_bytes().into_owned());
        })
        .background()
        .wait()
        .unwrap();
    rx
}

fn ok(r: &msgs::ControlReply) -> msgs::ServerStatus {
    match &r.outcome {
        msgs::ControlOutcome::Ok(s) => s.clone(),
        msgs::ControlOutcome::Error(f) => panic!("expected success, got {f:?}"),
    }
}

/// What arrived within `window` after the last frame, or until `limit`.
fn drain(rx: &mpsc::Receiver<Vec<u8>>, window: Duration, limit: Instant) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    while Instant::now() < limit {
        match rx.recv_timeout(window) {
            Ok(b) => out.push(b),
            Err(_) => break,
        }
    }
    out
}

#[test]
fn a_thousand_lockstep_requests_give_a_thousand_consecutive_states_and_no_more() {
    let server = Server::start_with("pendulum", "lockstep-1000", |c| {
        c.iceoryx2 = false;
        c.start_paused = true;
    });
    let z = server.session();
    let poses = collect(&z, &server, msgs::Topic::Poses);
    let first = ok(&server.control(&z, 1, msgs::ControlCommand::Pause)).sequence;
    let mut h = 0.0;
    let start = Instant::now();
    for k in 1..=1000u64 {
        let s = ok(&server.control(&z, 1 + k, msgs::ControlCommand::Step { count: 1 }));
        if k == 1 {
            h = s.sim_time;
        }
        assert_eq!(s.sequence, first + k, "reply {k}");
        assert_eq!(s.steps.map(|r| r.count), Some(1));
        assert!(start.elapsed() < Duration::from_secs(60), "1,000 round trips took over a minute");
    }
    let round_trips = 1000.0 / start.elapsed().as_secs_f64();
    // Paused afterwards: the last state is re-sent (same sequence), nothing new.
    let frames = drain(&poses, Duration::from_millis(400), Instant::now() + Duration::from_secs(5));
    let seqs: BTreeSet<u64> = frames.iter().map(|b| u64_at(b, 0)).filter(|&s| s > first).collect();
    let want: BTreeSet<u64> = (first + 1..=first + 1000).collect();
    assert_eq!(seqs, want, "one new state per request, none without one ({round_trips:.0} round trips/s)");
    for b in &frames {
        let (seq, t) = (u64_at(b, 0), f64_at(b, 8));
        if seq > first {
            let k = (seq - first) as f64;
            assert!((t - k * h).abs() < 1e-9 * k.max(1.0), "sequence {seq} at {t} s");
        }
    }
    eprintln!("lockstep over Zenoh: {round_trips:.0} round trips/s (pendulum, test build)");
    server.stop();
}

#[test]
fn a_multi_step_request_publishes_every_step_and_its_events() {
    let server = Server::start_with("crane", "lockstep-events", |c| {
        c.iceoryx2 = false;
        c.start_paused = true;
    });
    let z = server.session();
    let (poses, events) =
        (collect(&z, &server, msgs::Topic::Poses), collect(&z, &server, msgs::Topic::Events));
    let first = ok(&server.control(&z, 1, msgs::ControlCommand::Pause)).sequence;
    for trial in 0..5u64 {
        // A fault at the first step of each request: its event must reach us in that step's frame.
        let fault = msgs::ControlCommand::Fault {
            fault: msgs::FaultKind::Dropout,
            target: "luff".into(),
            tension: None,
            to: None,
            ramp: None,
        };
        let r = server.control(&z, 10 + trial, fault);
        if let msgs::ControlOutcome::Error(f) = &r.outcome {
            panic!("fault refused: {f:?}");
        }
        let s = ok(&server.control(&z, 20 + trial, msgs::ControlCommand::Step { count: 5 }));
        assert_eq!(s.sequence, first + 5 * (trial + 1));
    }
    // Paused, the poses are re-sent at the step rate, so their drain runs to its limit; the
    // events (never re-sent) get a limit of their own.
    let pose_seqs: BTreeSet<u64> =
        drain(&poses, Duration::from_millis(400), Instant::now() + Duration::from_secs(2))
            .iter()
            .map(|b| u64_at(b, 0))
            .filter(|&s| s > first)
            .collect();
    assert_eq!(pose_seqs, (first + 1..=first + 25).collect(), "every step of the requests published");
    let ev = drain(&events, Duration::from_millis(400), Instant::now() + Duration::from_secs(5));
    let fault_steps: Vec<u64> = ev
        .iter()
        .filter(|b| (0..u32_at(b, 16) as usize).any(|i| b[HEADER + 32 + 64 * i + 32] == 2))
        .map(|b| u64_at(b, 0))
        .collect();
    let want: Vec<u64> = (0..5).map(|k| first + 5 * k + 1).collect();
    assert_eq!(fault_steps, want, "each fault in the events frame of its request's first step");
    server.stop();
}
