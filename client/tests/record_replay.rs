//! Record and replay end to end: the forklift served live in real time, driven by joystick commands
//! from another process (with silences that trip the deadman), recorded by `pivotsim-client
//! record` over Zenoh; the file replayed by the server's replay (`pivotsim-server replay --check`
//! runs the same code). The reference is the recording: every replayed pose frame must equal the
//! recorded one bit for bit, every keyframe the replay's own snapshot.

mod common;

use std::sync::Arc;
use std::time::{Duration, Instant};

use common::{ClientOf, Server, spawn_client};
use pivotsim_server::serve::replay::{Recording, replay_headless};

const LIMIT: Duration = Duration::from_secs(60);

#[test]
fn a_live_session_recorded_by_the_client_replays_bit_for_bit() {
    let s = Server::start_with("forklift", "recreplay", |c| c.keyframes = 2.0);
    let path = pivotsim_tests::temp_path("recreplay.mcap");
    let _ = std::fs::remove_file(&path);
    let mut a = s.args();
    a.extend(["record", path.to_str().unwrap(), "--duration", "8"].map(String::from));
    let recorder = spawn_client(&a, LIMIT);
    recorder.wait_for_stderr("recording world", LIMIT);
    // Joystick commands at irregular moments, each a new state of the sticks; the gaps longer
    // than the deadman (250 ms) trip it.
    let axes =
        ["0.8,0.2,0,0,0,0", "0.5,-0.6,0.3,0,0,0", "-0.4,0.9,0,0.2,0,0", "1,0,-0.5,0,0,0", "0,0.3,0.7,0,0,0"];
    let start = Instant::now();
    for (k, axes) in axes.iter().cycle().take(12).enumerate() {
        let out = s.client(&["send", "joystick", "--axes", axes], LIMIT);
        assert_eq!(out.code, Some(0), "send {k}: {}", out.stderr);
        std::thread::sleep(Duration::from_millis(150 + 60 * (k as u64 % 4)));
        if start.elapsed() > Duration::from_secs(6) {
            break;
        }
    }
    let out = recorder.wait();
    assert_eq!(out.code, Some(0), "{}", out.stderr);
    s.stop();

    let rec = Arc::new(Recording::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())));
    assert!(
        rec.keyframes.len() >= 3,
        "the recorder's keyframe and the periodic ones: {}",
        rec.keyframes.len()
    );
    assert!(!rec.applied.is_empty(), "the joystick commands were journaled");
    let world = pivotsim_msgs::WorldName::new("replayed").unwrap();
    let e = replay_headless(rec.clone(), None, None, None, world).unwrap();
    let p = e.replay_progress();
    assert_eq!(p.divergence, None, "the replay diverged");
    assert!(p.finished, "{p:?}");
    assert!(p.poses_compared >= 300, "{p:?}");
    assert!(p.keyframes_compared >= 2, "{p:?}");
    eprintln!(
        "live forklift: {} poses and {} keyframes replayed bit for bit ({} missing from the recording), {} steps with applied records",
        p.poses_compared,
        p.keyframes_compared,
        p.poses_missing,
        rec.applied.len()
    );
    let _ = std::fs::remove_file(&path);
}
