//! Rig control in the engine, without transports: `run_until` reaches the step nearest its time and
//! refuses the past, a running world and a target too far ahead with typed codes; lockstep-served
//! poses equal a headless run's bit for bit; `snapshot` and `restore` round-trip the world (and a
//! restored engine steps on as the uninterrupted one), confined to the snapshot directory, and a
//! foreign or damaged snapshot leaves the world untouched.

use std::time::{Duration, Instant};

use pivotsim_msgs as msgs;
use pivotsim_server::run::{RunOptions, run_scene_observed};
use pivotsim_server::serve::Engine;
use pivotsim_server::serve::engine::ControlStep;
use pivotsim_tests::temp_dir;

fn engine(scene: &str) -> Engine {
    Engine::new(scene, msgs::WorldName::new("lockstep").unwrap(), Duration::from_secs(60)).unwrap()
}

fn request(id: u64, command: msgs::ControlCommand) -> Vec<u8> {
    let mut buf = Vec::new();
    msgs::ControlRequest { id, command }.encode(&mut buf).unwrap();
    buf
}

fn control(e: &mut Engine, id: u64, command: msgs::ControlCommand) -> msgs::ControlOutcome {
    msgs::ControlReply::decode(&e.handle_control(&request(id, command))).unwrap().outcome
}

/// A request written as JSON by hand (what a client that skips validation sends), answered.
fn raw(e: &mut Engine, json: &str) -> msgs::ControlErrorCode {
    // The header of msgs/README.md: magic, version, kind, payload length, reserved.
    let mut frame = Vec::new();
    frame.extend_from_slice(&msgs::MAGIC);
    frame.extend_from_slice(&msgs::FORMAT_VERSION.to_le_bytes());
    frame.extend_from_slice(&msgs::Kind::ControlRequest.code().to_le_bytes());
    frame.extend_from_slice(&(json.len() as u32).to_le_bytes());
    frame.extend_from_slice(&0u32.to_le_bytes());
    frame.extend_from_slice(json.as_bytes());
    code(msgs::ControlReply::decode(&e.handle_control(&frame)).unwrap().outcome)
}

fn code(o: msgs::ControlOutcome) -> msgs::ControlErrorCode {
    match o {
        msgs::ControlOutcome::Error(f) => f.code,
        o => panic!("expected an error, got {o:?}"),
    }
}

fn ok(o: msgs::ControlOutcome) -> msgs::ServerStatus {
    match o {
        msgs::ControlOutcome::Ok(s) => s,
        o => panic!("expected ok, got {o:?}"),
    }
}

/// Every body's pose and velocity, bitwise.
fn state_bits(e: &Engine) -> Vec<u64> {
    let mut out = Vec::new();
    for b in e.scene().world.bodies() {
        let (x, q, v, w) = (b.position(), b.orientation(), b.linvel(), b.angvel());
        out.extend(x.iter().chain(q.coords.iter()).chain(v.iter()).chain(w.iter()).map(|c| c.to_bits()));
    }
    out
}

#[test]
fn run_until_reaches_the_nearest_step_and_refuses_with_typed_codes() {
    use msgs::ControlCommand::RunUntil;
    use msgs::ControlErrorCode as E;
    let mut e = engine("winch");
    assert_eq!(code(control(&mut e, 1, RunUntil { sim_time: 1.0 })), E::Busy, "a running world");
    e.set_paused(true);
    let h = e.scene().world.settings().timestep;
    let s = ok(control(&mut e, 2, RunUntil { sim_time: 0.5 + 0.3 * h }));
    let n = (0.5 / h).round() as u64;
    assert_eq!(e.scene().world.steps(), n);
    assert_eq!(s.steps.unwrap().count as u64, n);
    assert_eq!(s.sim_time, e.scene().world.time());
    assert!(s.paused);
    let before = state_bits(&e);
    assert_eq!(code(control(&mut e, 3, RunUntil { sim_time: 0.5 })), E::InThePast);
    assert_eq!(code(control(&mut e, 4, RunUntil { sim_time: 0.1 })), E::InThePast);
    let far = 0.5 + 3601.0 * h;
    assert_eq!(code(control(&mut e, 5, RunUntil { sim_time: far })), E::InvalidRequest);
    assert_eq!(before, state_bits(&e), "refused requests change nothing");
    // NaN and negative times do not decode.
    for bad in [
        r#"{"id":6,"command":{"op":"run_until","sim_time":-1.0}}"#,
        r#"{"id":7,"command":{"op":"run_until"}}"#,
    ] {
        assert_eq!(raw(&mut e, bad), E::InvalidRequest, "{bad}");
    }
}

#[test]
fn lockstep_served_poses_equal_the_headless_run_bit_for_bit() {
    let steps = 240u64;
    let mut headless: Vec<Vec<u64>> = Vec::new();
    let mut scene = pivotsim_server::scene::load("forklift").unwrap();
    let opts = RunOptions { duration: Some(steps as f64 / 60.0), ..RunOptions::default() };
    run_scene_observed(&mut scene, &opts, |w| {
        let mut out = Vec::new();
        for b in w.bodies() {
            let (x, q, v, om) = (b.position(), b.orientation(), b.linvel(), b.angvel());
            out.extend(x.iter().chain(q.coords.iter()).chain(v.iter()).chain(om.iter()).map(|c| c.to_bits()));
        }
        headless.push(out);
    })
    .unwrap();
    assert_eq!(headless.len() as u64, steps);
    let mut e = engine("forklift");
    e.set_paused(true);
    // One request per step (a controller's loop), then the rest as one request of many steps.
    for k in 0..steps / 2 {
        let s = ok(control(&mut e, 10 + k, msgs::ControlCommand::Step { count: 1 }));
        assert_eq!(s.steps.unwrap().count, 1);
        assert_eq!(state_bits(&e), headless[k as usize], "step {}", k + 1);
    }
    let ControlStep::Steps(mut job) = e.begin_control(&request(1, msgs::ControlCommand::Step { count: 120 }))
    else {
        panic!("a lockstep job")
    };
    let mut k = steps / 2;
    loop {
        let more = e.lockstep_step(&mut job);
        assert_eq!(state_bits(&e), headless[k as usize], "step {}", k + 1);
        k += 1;
        if !more {
            break;
        }
    }
    assert_eq!(k, steps);
}

#[test]
fn snapshot_and_restore_round_trip_the_served_world() {
    use msgs::ControlCommand::{Restore, Snapshot, Step};
    use msgs::ControlErrorCode as E;
    let dir = temp_dir("serve-lockstep-snapshots");
    let mut e = engine("crane");
    let snap = |p: &str| Snapshot { path: p.into() };
    assert_eq!(code(control(&mut e, 1, snap("a.snap"))), E::LoadRefused, "no snapshot directory");
    e.set_snapshot_dir(Some(dir.clone()));
    e.set_paused(true);
    ok(control(&mut e, 2, Step { count: 90 }));
    ok(control(&mut e, 3, snap("debrief/t1.5.snap")));
    assert!(dir.join("debrief/t1.5.snap").is_file());
    let at_snapshot = state_bits(&e);
    ok(control(&mut e, 4, Step { count: 60 }));
    let after_60 = state_bits(&e);
    let seq = e.sequence();
    let s = ok(control(&mut e, 5, Restore { path: "debrief/t1.5.snap".into() }));
    assert_eq!((s.paused, s.sequence), (true, seq + 1), "restored paused, with a new sequence");
    assert_eq!(state_bits(&e), at_snapshot);
    ok(control(&mut e, 6, Step { count: 60 }));
    assert_eq!(state_bits(&e), after_60, "the restored world steps on as the uninterrupted one");

    // Refusals leave the world as it is.
    let before = state_bits(&e);
    assert_eq!(code(control(&mut e, 7, Restore { path: "missing.snap".into() })), E::SnapshotFailed);
    std::fs::write(dir.join("junk.snap"), b"PIVSNAP\0\x01\0\0\0junk").unwrap();
    assert_eq!(code(control(&mut e, 8, Restore { path: "junk.snap".into() })), E::SnapshotFailed);
    let mut winch = engine("winch");
    winch.set_snapshot_dir(Some(dir.clone()));
    ok(control(&mut winch, 9, snap("winch.snap")));
    assert_eq!(code(control(&mut e, 10, Restore { path: "winch.snap".into() })), E::SnapshotFailed);
    for bad in ["../escape.snap", "/etc/passwd", "a/../../b.snap", "", "a\\u0000b"] {
        for op in ["snapshot", "restore"] {
            let json = format!(r#"{{"id":11,"command":{{"op":"{op}","path":"{bad}"}}}}"#);
            assert_eq!(raw(&mut e, &json), E::InvalidRequest, "{json}");
        }
    }
    assert_eq!(before, state_bits(&e));
    assert!(!dir.join("../escape.snap").exists());
    // A lockstep request on a running world is refused.
    e.set_paused(false);
    assert_eq!(code(control(&mut e, 13, Step { count: 1 })), E::Busy);
    assert!(e.tick(Instant::now()), "and the world runs on");
}
