//! The server publishes the instability watchdog (`dynamics/watchdog.rs`, issue 12) in its stats
//! frames: `unstable` for a flagged step and `unstable_steps` since the scene was loaded. The
//! shipped `hanging_chain` keeps both at zero; the same chain with the geometric stiffness off
//! (the paper's step as published) whips apart within half a second, and the frames say so while
//! every state is still finite.

use std::time::{Duration, Instant};

use pivotsim_msgs as msgs;
use pivotsim_server::scene::builtin;
use pivotsim_server::serve::Engine;
use pivotsim_tests::temp_file;

fn run(scene: &str, ticks: usize) -> (usize, u16) {
    let mut e = Engine::new(scene, msgs::WorldName::new("test").unwrap(), Duration::from_secs(1)).unwrap();
    let mut flagged = 0;
    let mut last = 0;
    for _ in 0..ticks {
        assert!(e.tick(Instant::now()));
        let s = msgs::SolverStats::decode(e.stats_frame()).unwrap();
        flagged += usize::from(s.unstable);
        assert!(s.unstable_steps >= last);
        last = s.unstable_steps;
    }
    (flagged, last)
}

#[test]
fn stats_frames_carry_the_watchdog() {
    assert_eq!(run("hanging_chain", 120), (0, 0));

    let text = builtin("hanging_chain").unwrap().text.replacen(
        "[scene]",
        "[scene]\ngeometric_stiffness = \"off\"\njoint_error_tolerance = 0.0",
        1,
    );
    let path = temp_file("serve-watchdog-chain_off.toml", &text);
    let (flagged, count) = run(&path.display().to_string(), 120);
    println!("geometric stiffness off: {flagged} of 120 frames flagged, count {count}");
    assert!(flagged > 0 && count as usize == flagged);
}
