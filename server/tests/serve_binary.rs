//! The server binary as a user runs it over its real transports on loopback: a server killed with
//! SIGKILL leaves its shared memory behind and the next one cleans it and serves the same world;
//! the README's main command serves the default scene and says how to connect. Every wait is
//! bounded.

#![cfg(all(feature = "zenoh", feature = "iceoryx2"))]

use std::time::{Duration, Instant};

use iceoryx2::prelude::*;
use pivotsim_msgs as msgs;

/// A server process killed with SIGKILL leaves its shared memory behind; the next one cleans it
/// and serves on the same world.
#[test]
fn a_server_killed_with_sigkill_restarts_cleanly() {
    let world = format!("k{}", std::process::id());
    let spawn = || {
        std::process::Command::new(env!("CARGO_BIN_EXE_pivotsim-server"))
            .args([
                "serve",
                "--scene",
                "pendulum",
                "--world",
                &world,
                "--listen",
                &pivotsim_tests::free_endpoint(),
            ])
            .arg("--status-interval")
            .arg("0")
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap()
    };
    let node = NodeBuilder::new().create::<ipc::Service>().unwrap();
    let name = format!("pivotsim/{world}/poses");
    let first_frame = |deadline: Duration| -> Option<u64> {
        let end = Instant::now() + deadline;
        while Instant::now() < end {
            if let Ok(service) =
                node.service_builder(&name.as_str().try_into().unwrap()).publish_subscribe::<[u8]>().open()
                && let Ok(sub) = service.subscriber_builder().create()
            {
                let end2 = Instant::now() + Duration::from_secs(2);
                while Instant::now() < end2 {
                    if let Ok(Some(s)) = sub.receive() {
                        return Some(msgs::PoseFrameView::parse(s.payload()).unwrap().sequence());
                    }
                    std::thread::sleep(Duration::from_millis(10));
                }
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        None
    };
    let mut a = spawn();
    assert!(first_frame(Duration::from_secs(10)).is_some(), "the first server publishes");
    a.kill().unwrap(); // SIGKILL
    a.wait().unwrap();
    let mut b = spawn();
    let seq = first_frame(Duration::from_secs(10));
    let alive = b.try_wait().unwrap().is_none();
    // SIGTERM: a clean shutdown that releases the shared memory (Ctrl-C does the same).
    let term = std::process::Command::new("kill").args(["-TERM", &b.id().to_string()]).status();
    let deadline = Instant::now() + Duration::from_secs(10);
    let mut clean_exit = false;
    while Instant::now() < deadline {
        if let Some(st) = b.try_wait().unwrap() {
            clean_exit = st.success();
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    if b.try_wait().unwrap().is_none() {
        b.kill().unwrap();
        b.wait().unwrap();
    }
    assert!(alive, "the second server is running");
    if term.is_ok_and(|s| s.success()) {
        assert!(clean_exit, "SIGTERM stops the server cleanly");
    }
    assert!(seq.is_some(), "the restarted server publishes on the same world");
}

/// The README's main command: no subcommand serves the default scene, and says on start where it
/// listens, which scene and transports are up, and how to connect; its log on a pipe has no
/// colour codes.
#[test]
fn the_default_command_serves_the_default_scene() {
    let endpoint = pivotsim_tests::free_endpoint();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_pivotsim-server"))
        .args(["--steps", "30", "--fast", "--no-iceoryx2", "--listen", &endpoint])
        .env("RUST_LOG", "info")
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{log}");
    // Its log, written to a pipe, is plain text: levels without ANSI colour codes.
    assert!(log.contains(" INFO "), "{log}");
    assert!(!log.contains('\u{1b}'), "colour codes in a piped log: {log:?}");
    let text = String::from_utf8_lossy(&out.stdout);
    let start = text.lines().next().unwrap_or_default();
    assert!(start.contains("scene `forklift`") && start.contains("world `default`"), "{text}");
    assert!(text.contains("Zenoh peer") && text.contains(&format!("listening on {endpoint}")), "{text}");
    assert!(!text.contains("iceoryx2 (same host"), "iceoryx2 is off: {text}");
    assert!(text.contains(&format!("pivotsim-client -- --connect {endpoint} watch")), "{text}");
    assert!(text.contains("pivotsim-ros2-bridge"), "{text}");
    assert!(text.lines().any(|l| l.starts_with("30 steps")), "{text}");
}
