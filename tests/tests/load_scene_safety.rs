//! `load_scene` cannot hurt the world, tried as a careless or hostile peer would over Zenoh on
//! loopback: `/dev/zero`, a FIFO without a writer, a directory, a 2 MiB file and paths outside the
//! scene directories (`..`, a link out, an absolute path) are each answered `load_refused`, while
//! the world keeps stepping at its rate; a file in a scene directory that is not a scene is refused
//! without its contents in the message; a slow load (the loader's test delay of 1 s) does not stall
//! the step loop, a second load meanwhile is `busy`, and the new scene swaps in paused at time 0
//! with a new sequence. Every wait is bounded.

#![cfg(feature = "live")]

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use pivotsim_msgs as msgs;
use pivotsim_tests::{Server, temp_dir};
use zenoh::Wait;

/// Longest a refusal may take here: a stalled read never answers, a refusal takes milliseconds
/// (the measured times are printed); the margin is for a loaded CI machine.
const REFUSAL_LIMIT: Duration = Duration::from_secs(1);

/// Longest gap between two stats frames of a world stepping at 60 Hz that still counts as
/// "keeps stepping" on a loaded machine (a stalled loop shows the whole load time, ≥ 1 s, here).
const GAP_LIMIT: Duration = Duration::from_millis(500);

/// Stats frames as they arrive: (arrival, sequence, sim time).
type Arrivals = Arc<Mutex<Vec<(Instant, u64, f64)>>>;

fn watch_stats(s: &zenoh::Session, server: &Server) -> (zenoh::pubsub::Subscriber<()>, Arrivals) {
    let seen: Arrivals = Arc::new(Mutex::new(Vec::new()));
    let sink = seen.clone();
    let sub = s
        .declare_subscriber(server.key(msgs::Topic::Stats))
        .callback(move |sample| {
            if let Ok(st) = msgs::SolverStats::decode(&sample.payload().to_bytes()) {
                sink.lock().unwrap().push((Instant::now(), st.sequence, st.sim_time));
            }
        })
        .wait()
        .unwrap();
    (sub, seen)
}

/// The longest gap between arrivals within `[from, to]`, and how many arrived.
fn longest_gap(seen: &Arrivals, from: Instant, to: Instant) -> (Duration, usize) {
    let v = seen.lock().unwrap();
    let times: Vec<Instant> = v.iter().map(|a| a.0).filter(|&t| t >= from && t <= to).collect();
    let mut gap = times.first().map_or(to - from, |&t| t - from);
    for w in times.windows(2) {
        gap = gap.max(w[1] - w[0]);
    }
    gap = gap.max(times.last().map_or(Duration::ZERO, |&t| to - t));
    (gap, times.len())
}

fn failure(r: &msgs::ControlReply) -> &msgs::ControlFailure {
    match &r.outcome {
        msgs::ControlOutcome::Error(f) => f,
        msgs::ControlOutcome::Ok(s) => panic!("expected a failure, got {s:?}"),
    }
}

fn load(scene: &str) -> msgs::ControlCommand {
    msgs::ControlCommand::LoadScene { scene: scene.to_string() }
}

#[test]
fn hostile_paths_are_refused_at_once_while_the_world_keeps_stepping() {
    let dir = temp_dir("safety-scenes");
    let outside = temp_dir("safety-outside");
    std::fs::write(dir.join("big.toml"), vec![b'#'; 2 << 20]).unwrap();
    std::fs::create_dir_all(dir.join("adir.toml")).unwrap();
    let fifo = dir.join("pipe.toml");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status().expect("mkfifo");
    assert!(made.success());
    std::fs::write(dir.join("secret.toml"), "password = \"hunter2-secret\"\n").unwrap();
    std::fs::write(outside.join("away.toml"), "[scene]\nname = \"away\"\n").unwrap();
    std::os::unix::fs::symlink(outside.join("away.toml"), dir.join("link.toml")).unwrap();
    // `/dev` as a scene directory too: its files are still no regular files.
    let dirs = vec![dir.clone(), "/dev".into()];
    let server = Server::start_with("pendulum", "safety-hostile", move |c| {
        c.iceoryx2 = false;
        c.scene_dirs = dirs.clone();
    });
    let z = server.session();
    let (_sub, seen) = watch_stats(&z, &server);
    std::thread::sleep(Duration::from_millis(300));
    let from = Instant::now();
    let up = format!("{}/../{}/away.toml", dir.display(), outside.file_name().unwrap().to_string_lossy());
    let cases = [
        ("/dev/zero", "a device"),
        ("pipe.toml", "a FIFO"),
        ("adir.toml", "a directory"),
        ("big.toml", "larger than"),
        (up.as_str(), "outside"),
        ("link.toml", "outside"),
        ("/etc/passwd", "outside"),
        ("secret.toml", "not a scene"),
    ];
    for (k, (path, why)) in cases.iter().enumerate() {
        let t = Instant::now();
        let r = server.control(&z, 100 + k as u64, load(path));
        let took = t.elapsed();
        let f = failure(&r);
        println!("load_scene {path:?}: {:?} in {took:?}: {}", f.code, f.message);
        assert_eq!(f.code, msgs::ControlErrorCode::LoadRefused, "{path}: {}", f.message);
        assert!(f.message.contains(why), "{path}: {}", f.message);
        assert!(!f.message.contains("hunter2"), "the contents are echoed: {}", f.message);
        assert!(took < REFUSAL_LIMIT, "{path}: refused after {took:?}");
    }
    let to = Instant::now();
    let (gap, frames) = longest_gap(&seen, from, to);
    let expected = (to - from).as_secs_f64() * 60.0;
    println!("{frames} stats frames in {:?} (60 Hz: {expected:.0}), longest gap {gap:?}", to - from);
    assert!(gap < GAP_LIMIT, "the world stalled for {gap:?}");
    assert!(frames as f64 >= 0.5 * expected, "{frames} frames, {expected:.0} steps due");
    // The world is the one it was, still running.
    let r = server.control(&z, 200, msgs::ControlCommand::Step { count: 1 });
    assert_eq!(failure(&r).code, msgs::ControlErrorCode::Busy, "still running");
    server.stop();
}

#[test]
fn a_slow_load_does_not_stall_the_loop_and_swaps_in_with_a_new_sequence() {
    let dir = temp_dir("safety-slow");
    std::fs::write(dir.join("rig.toml"), include_str!("../../server/tests/support/rig.toml")).unwrap();
    let dirs = vec![dir.clone()];
    let server = Server::start_with("pendulum", "safety-slow", move |c| {
        c.iceoryx2 = false;
        c.scene_dirs = dirs.clone();
        c.slow_load = Some(Duration::from_secs(1));
    });
    let z = server.session();
    let (_sub, seen) = watch_stats(&z, &server);
    std::thread::sleep(Duration::from_millis(300));
    let from = Instant::now();
    let slow = {
        let z = z.clone();
        let key = server.key(msgs::Topic::Control);
        std::thread::spawn(move || {
            let mut buf = Vec::new();
            msgs::ControlRequest { id: 1, command: load("rig.toml") }.encode(&mut buf).unwrap();
            let replies = z.get(key).payload(buf).timeout(Duration::from_secs(5)).wait().unwrap();
            let reply = replies.recv_timeout(Duration::from_secs(6)).ok().flatten().expect("a reply");
            let bytes = reply.result().expect("a sample").payload().to_bytes().into_owned();
            (Instant::now(), msgs::ControlReply::decode(&bytes).unwrap())
        })
    };
    std::thread::sleep(Duration::from_millis(300));
    // A second load while the first is under way.
    let r = server.control(&z, 2, load("box_stack"));
    assert_eq!(failure(&r).code, msgs::ControlErrorCode::Busy, "{}", failure(&r).message);
    let (replied, r) = slow.join().unwrap();
    let msgs::ControlOutcome::Ok(status) = r.outcome else { panic!("{:?}", r.outcome) };
    assert_eq!((r.id, status.scene.as_str(), status.paused, status.sim_time), (1, "rig", true, 0.0));
    assert!(replied - from >= Duration::from_millis(900), "the load took its second");
    let (gap, frames) = longest_gap(&seen, from, replied - Duration::from_millis(50));
    println!("during the 1 s load: {frames} stats frames, longest gap {gap:?}");
    assert!(gap < GAP_LIMIT, "the loop stalled for {gap:?} during the load");
    // The old scene's frames all came before the new state's one, whose sequence is new.
    std::thread::sleep(Duration::from_millis(200));
    let v = seen.lock().unwrap().clone();
    let old: Vec<&(Instant, u64, f64)> =
        v.iter().filter(|a| a.0 < replied - Duration::from_millis(50)).collect();
    let last_old = old.iter().map(|a| a.1).max().expect("frames of the old scene");
    assert!(status.sequence > last_old, "new state {} after old {last_old}", status.sequence);
    let new: Vec<&(Instant, u64, f64)> =
        v.iter().filter(|a| a.0 > replied + Duration::from_millis(50)).collect();
    assert!(!new.is_empty(), "the paused new scene is re-sent");
    assert!(new.iter().all(|a| (a.1, a.2) == (status.sequence, 0.0)), "{new:?}");
    server.stop();
}
