//! The server over its real transports on loopback (the harness's in-process server on an
//! ephemeral port and a unique world name per test): poses arrive at the step rate with increasing
//! sequence and the same bytes on Zenoh and iceoryx2; a winch command over either transport turns
//! the drum; the deadman releases when the sender stops; malformed inputs are counted; the scene
//! and control queryables answer; a stalled subscriber does not change the step rate. Every wait
//! is bounded. (The server binary's own runs are in `server/tests/serve_binary.rs`.)

#![cfg(feature = "live")]

use std::collections::HashMap;
use std::time::{Duration, Instant};

use iceoryx2::prelude::*;
use pivotsim_msgs as msgs;
use pivotsim_tests::{Server, temp_file};
use zenoh::Wait;

/// The drum-and-slider rig of the engine tests.
const RIG: &str = include_str!("../../server/tests/support/rig.toml");

fn rig_path(tag: &str) -> String {
    temp_file(&format!("transport-{tag}.toml"), RIG).display().to_string()
}

/// A client session on loopback, connected to the server, once its scene queryable answers.
fn client(server: &Server) -> zenoh::Session {
    server.session()
}

fn scene(s: &zenoh::Session, server: &Server) -> Option<msgs::SceneDescription> {
    server.scene(s)
}

fn control(s: &zenoh::Session, server: &Server, command: msgs::ControlCommand) -> msgs::ControlOutcome {
    let r = server.control(s, 42, command);
    assert_eq!(r.id, 42);
    r.outcome
}

fn winch(seq: u64, speed: f64) -> Vec<u8> {
    let mut buf = Vec::new();
    msgs::InputCommand::Winch(msgs::WinchCommand {
        sequence: seq,
        source_id: 3,
        actuator: msgs::ActuatorName::new("winch").unwrap(),
        drum_speed: speed,
    })
    .encode(&mut buf)
    .unwrap();
    buf
}

/// Pose frames received within `window`.
fn collect_poses(s: &zenoh::Session, server: &Server, window: Duration) -> Vec<msgs::PoseFrame> {
    let sub = s.declare_subscriber(server.key(msgs::Topic::Poses)).wait().unwrap();
    let end = Instant::now() + window;
    let mut frames = Vec::new();
    while let Some(left) = end.checked_duration_since(Instant::now()) {
        match sub.recv_timeout(left) {
            Ok(Some(sample)) => frames.push(msgs::PoseFrame::decode(&sample.payload().to_bytes()).unwrap()),
            _ => break,
        }
    }
    frames
}

fn latest_stats(s: &zenoh::Session, server: &Server) -> msgs::SolverStats {
    let sub = s.declare_subscriber(server.key(msgs::Topic::Stats)).wait().unwrap();
    let sample = sub.recv_timeout(Duration::from_secs(3)).unwrap().expect("a stats frame");
    msgs::SolverStats::decode(&sample.payload().to_bytes()).unwrap()
}

#[test]
fn poses_arrive_at_the_step_rate_in_sequence_and_the_scene_answers() {
    let server = Server::start("pendulum", "rate");
    let s = client(&server);
    let d = scene(&s, &server).unwrap();
    assert_eq!(d.scene, "pendulum");
    assert_eq!(d.bodies.iter().map(|b| b.name.as_str()).collect::<Vec<_>>(), ["upper", "lower"]);
    let start = Instant::now();
    let frames = collect_poses(&s, &server, Duration::from_secs(2));
    let wall = start.elapsed().as_secs_f64();
    assert!(frames.len() >= 60, "{} frames in 2 s", frames.len());
    for w in frames.windows(2) {
        assert_eq!(w[1].sequence, w[0].sequence + 1, "consecutive frames, none lost on loopback");
        assert!(w[1].sim_time > w[0].sim_time);
    }
    let steps = (frames.last().unwrap().sequence - frames[0].sequence) as f64;
    let rate = steps / wall;
    assert!((40.0..=70.0).contains(&rate), "{rate:.1} steps/s (60 expected in real time)");
    let report = server.stop();
    assert!(report.steps > 100);
}

#[test]
fn a_winch_command_turns_the_drum_and_the_deadman_releases_it() {
    let server = Server::start(&rig_path("winch"), "winch");
    let s = client(&server);
    let key = server.key(msgs::Topic::Winch);
    // Drive at 1 rad/s, 30 Hz, for 0.6 s.
    let mut seq = 0;
    let t_end = Instant::now() + Duration::from_millis(600);
    while Instant::now() < t_end {
        seq += 1;
        s.put(&key, winch(seq, 1.0)).wait().unwrap();
        std::thread::sleep(Duration::from_millis(33));
    }
    let frames = collect_poses(&s, &server, Duration::from_millis(100));
    let omega = frames.last().expect("poses").bodies[0].angular_velocity[1];
    assert!((omega - 1.0).abs() < 1e-6, "drum at {omega} rad/s");
    let stopped = Instant::now();
    // The deadman trips 250 ms (+ a step, + loopback latency) after the last input.
    let sub = s.declare_subscriber(server.key(msgs::Topic::Stats)).wait().unwrap();
    let mut tripped = None;
    while stopped.elapsed() < Duration::from_secs(2) {
        if let Ok(Some(sample)) = sub.recv_timeout(Duration::from_millis(100)) {
            let st = msgs::SolverStats::decode(&sample.payload().to_bytes()).unwrap();
            if st.inputs.deadman_active {
                tripped = Some(stopped.elapsed());
                break;
            }
        }
    }
    let tripped = tripped.expect("the deadman tripped");
    assert!(tripped <= Duration::from_millis(250 + 17 + 60), "tripped {tripped:?} after the last send");
    let frames = collect_poses(&s, &server, Duration::from_millis(100));
    assert!(frames.last().unwrap().bodies[0].angular_velocity[1].abs() < 1e-6, "held still");
    let report = server.stop();
    assert_eq!(report.inputs.deadman_trips, 1);
    assert_eq!(report.inputs.accepted, seq);
}

#[test]
fn malformed_inputs_over_zenoh_are_counted_and_control_answers() {
    let server = Server::start(&rig_path("bad"), "bad");
    let s = client(&server);
    let key = server.key(msgs::Topic::Winch);
    s.put(&key, b"not a frame".to_vec()).wait().unwrap();
    let mut truncated = winch(1, 1.0);
    truncated.truncate(30);
    s.put(&key, truncated).wait().unwrap();
    s.put(server.key(msgs::Topic::Joystick), winch(2, 1.0)).wait().unwrap();
    let deadline = Instant::now() + Duration::from_secs(3);
    let mut st = latest_stats(&s, &server);
    while st.inputs.rejected_total() < 3 && Instant::now() < deadline {
        st = latest_stats(&s, &server);
    }
    assert_eq!(st.inputs.rejected_for(msgs::RejectReason::Malformed), 2);
    assert_eq!(st.inputs.rejected_for(msgs::RejectReason::Version), 1);
    assert_eq!(st.inputs.accepted, 0);
    match control(&s, &server, msgs::ControlCommand::Pause) {
        msgs::ControlOutcome::Ok(status) => assert!(status.paused),
        o => panic!("{o:?}"),
    }
    match control(&s, &server, msgs::ControlCommand::LoadScene { scene: "nope".into() }) {
        msgs::ControlOutcome::Error(f) => assert_eq!(f.code, msgs::ControlErrorCode::UnknownScene),
        o => panic!("{o:?}"),
    }
    server.stop();
}

#[test]
fn a_stalled_subscriber_does_not_change_the_step_rate() {
    let server = Server::start("box_stack", "stall");
    let s = client(&server);
    // A Zenoh subscriber (its own session) whose callback blocks for 300 ms per frame, and an
    // iceoryx2 subscriber that never reads.
    let stalled_session = client(&server);
    let _stalled = stalled_session
        .declare_subscriber(server.key(msgs::Topic::Poses))
        .callback(|_| std::thread::sleep(Duration::from_millis(300)))
        .wait()
        .unwrap();
    let node = NodeBuilder::new().create::<ipc::Service>().unwrap();
    let name = format!("pivotsim/{}/poses", server.world.as_str());
    let service = node
        .service_builder(&name.as_str().try_into().unwrap())
        .publish_subscribe::<[u8]>()
        .open_or_create()
        .unwrap();
    let _never_read = service.subscriber_builder().create().unwrap();
    let first = latest_stats(&s, &server);
    std::thread::sleep(Duration::from_secs(2));
    let last = latest_stats(&s, &server);
    // Two wall seconds apart, plus the time to catch the second frame.
    let wall_rate = (last.sim_time - first.sim_time) / 2.0;
    assert!((0.8..=1.25).contains(&wall_rate), "sim seconds per wall second {wall_rate:.2}");
    assert!(last.overruns <= first.overruns + 5, "overruns {} → {}", first.overruns, last.overruns);
    server.stop();
}

#[test]
fn iceoryx2_carries_the_same_pose_bytes_and_takes_inputs() {
    let server = Server::start(&rig_path("iox"), "iox");
    let s = client(&server);
    let node = NodeBuilder::new().create::<ipc::Service>().unwrap();
    let open = |what: &str| {
        let name = format!("pivotsim/{}/{what}", server.world.as_str());
        node.service_builder(&name.as_str().try_into().unwrap())
            .publish_subscribe::<[u8]>()
            .open_or_create()
            .unwrap()
    };
    let poses = open("poses");
    let cmd = open("cmd");
    let sub = poses.subscriber_builder().create().unwrap();
    let publisher = cmd.publisher_builder().initial_max_slice_len(4096).create().unwrap();
    let frame = winch(1, -0.5);
    let sample = publisher.loan_slice_uninit(frame.len()).unwrap();
    sample.write_from_slice(&frame).send().unwrap();
    // Collect frames from both transports, then compare those seen on both.
    let zsub = s.declare_subscriber(server.key(msgs::Topic::Poses)).wait().unwrap();
    let deadline = Instant::now() + Duration::from_secs(2);
    let (mut iox_frames, mut zenoh_frames) = (HashMap::new(), HashMap::new());
    while Instant::now() < deadline {
        while let Ok(Some(sample)) = sub.receive() {
            let view = msgs::PoseFrameView::parse(sample.payload()).unwrap();
            iox_frames.insert(view.sequence(), sample.payload().to_vec());
        }
        while let Ok(Some(z)) = zsub.try_recv() {
            let bytes = z.payload().to_bytes().into_owned();
            zenoh_frames.insert(msgs::PoseFrameView::parse(&bytes).unwrap().sequence(), bytes);
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let mut both = 0;
    for (seq, bytes) in &zenoh_frames {
        if let Some(b) = iox_frames.get(seq) {
            assert_eq!(b, bytes, "frame {seq}: same bytes on both transports");
            both += 1;
        }
    }
    assert!(both >= 60, "{both} frames seen on both transports");
    // The command turned the drum (until the deadman stopped it 250 ms later).
    let turning = iox_frames
        .values()
        .filter(|f| {
            (msgs::PoseFrameView::parse(f).unwrap().get(0).unwrap().angular_velocity[1] + 0.5).abs() < 1e-6
        })
        .count();
    assert!((8..=20).contains(&turning), "{turning} frames at the commanded −0.5 rad/s (≈ 250 ms)");
    server.stop();
}
