//! The engine publishes the scene's signals every step and its events at the steps that have them
//! (issue 17), byte for byte as `msgs/README.md` specifies: the crane's channels decode with their
//! names, a `fault` control request on the hoist rope parts it at the next step and is one events
//! frame, a paused world's re-sent frames carry no events again, and a fault on a joint the scene
//! does not have is `fault_rejected` and a counted `fault-rejected` event.

use std::time::{Duration, Instant};

use pivotsim_msgs as msgs;
use pivotsim_server::serve::Engine;

fn control(e: &mut Engine, id: u64, command: msgs::ControlCommand) -> msgs::ControlOutcome {
    let mut buf = Vec::new();
    msgs::ControlRequest { id, command }.encode(&mut buf).unwrap();
    msgs::ControlReply::decode(&e.handle_control(&buf)).unwrap().outcome
}

fn fault(kind: msgs::FaultKind, target: &str) -> msgs::ControlCommand {
    msgs::ControlCommand::Fault { fault: kind, target: target.into(), tension: None, to: None, ramp: None }
}

#[test]
fn signals_every_step_events_once_and_faults_by_control() {
    let mut e = Engine::new("crane", msgs::WorldName::new("sig").unwrap(), Duration::from_secs(60)).unwrap();
    let t = Instant::now();
    for _ in 0..5 {
        assert!(e.tick(t));
        let s = msgs::SignalsFrame::decode(e.signals_frame()).unwrap();
        assert_eq!(s.sequence, e.sequence());
        let names: Vec<&str> = s.channels.iter().map(|c| c.name.as_str()).collect();
        for want in ["outriggers/fz", "hoist/hook", "lmi/percent", "luff/force", "drum/torque"] {
            assert!(names.contains(&want), "{want} in {names:?}");
        }
        assert!(e.events_frame().is_empty(), "no events yet");
    }
    // A refused request: typed reply, counted, listed with the next step's events.
    match control(&mut e, 1, fault(msgs::FaultKind::Break, "no-such-joint")) {
        msgs::ControlOutcome::Error(f) => assert_eq!(f.code, msgs::ControlErrorCode::FaultRejected),
        o => panic!("{o:?}"),
    }
    // The hoist rope parts at the next step.
    match control(&mut e, 2, fault(msgs::FaultKind::Break, "rope/end")) {
        msgs::ControlOutcome::Ok(_) => {}
        o => panic!("{o:?}"),
    }
    assert!(e.tick(t));
    let ev = msgs::EventsFrame::decode(e.events_frame()).unwrap();
    let kinds: Vec<_> = ev.events.iter().map(|x| (x.kind, x.name.as_str().to_string())).collect();
    assert!(kinds.contains(&(msgs::EventCode::FaultRejected, "no-such-joint".into())), "{kinds:?}");
    assert!(kinds.contains(&(msgs::EventCode::Fault, "rope/end".into())), "{kinds:?}");
    let s = msgs::SignalsFrame::decode(e.signals_frame()).unwrap();
    assert_eq!((s.faults_applied, s.faults_rejected), (1, 1));
    assert_eq!(s.events_total, ev.events_total);
    let w = &e.scene().world;
    assert!(!w.joint(w.joint_id("rope/end").unwrap()).unwrap().is_enabled());
    // Paused: the frames are re-sent without the events.
    e.set_paused(true);
    e.encode_frames(1);
    assert!(e.events_frame().is_empty());
    assert!(e.frames().signals == e.signals_frame());
}

/// `step N` on a paused world (lockstep) gives every step its frames, with consecutive sequences:
/// a fault requested before the request acts at its first step and its event is in that step's
/// events frame; the reply, after the last step, says how many steps were taken.
#[test]
fn a_multi_step_request_publishes_every_step_with_its_events() {
    use pivotsim_server::serve::engine::ControlStep;
    let mut e = Engine::new("crane", msgs::WorldName::new("sig3").unwrap(), Duration::from_secs(60)).unwrap();
    let t = Instant::now();
    assert!(e.tick(t));
    e.set_paused(true);
    match control(&mut e, 1, fault(msgs::FaultKind::Break, "rope/end")) {
        msgs::ControlOutcome::Ok(_) => {}
        o => panic!("{o:?}"),
    }
    let before = e.sequence();
    let mut buf = Vec::new();
    msgs::ControlRequest { id: 2, command: msgs::ControlCommand::Step { count: 3 } }
        .encode(&mut buf)
        .unwrap();
    let ControlStep::Steps(mut job) = e.begin_control(&buf) else { panic!("a lockstep job") };
    let h = e.scene().world.settings().timestep;
    let mut frames = Vec::new();
    for k in 0..3 {
        let more = e.lockstep_step(&mut job);
        assert_eq!(more, k < 2);
        let pose = msgs::PoseFrameView::parse(e.pose_frame()).unwrap();
        let events =
            (!e.events_frame().is_empty()).then(|| msgs::EventsFrame::decode(e.events_frame()).unwrap());
        frames.push((pose.sequence(), pose.sim_time(), events));
    }
    assert!(!e.lockstep_step(&mut job), "no step beyond the request");
    let seqs: Vec<u64> = frames.iter().map(|f| f.0).collect();
    assert_eq!(seqs, [before + 1, before + 2, before + 3], "one frame per step, no jump");
    let ev = frames[0].2.as_ref().expect("the first step's events frame");
    assert_eq!(ev.sequence, before + 1);
    let fault_at: Vec<f64> =
        ev.events.iter().filter(|x| x.kind == msgs::EventCode::Fault).map(|x| x.time).collect();
    assert_eq!(fault_at.len(), 1, "{:?}", ev.events);
    // Stamped with the time it acted, the start of the step whose frame carries it.
    assert!(
        (frames[0].1 - fault_at[0] - h).abs() < 1e-9,
        "fault at {} s, frame at {} s",
        fault_at[0],
        frames[0].1
    );
    for f in &frames[1..] {
        assert!(f.2.as_ref().is_none_or(|ev| ev.events.iter().all(|x| x.kind != msgs::EventCode::Fault)));
    }
    let reply = msgs::ControlReply::decode(&e.finish_steps(&job)).unwrap();
    let msgs::ControlOutcome::Ok(status) = reply.outcome else { panic!("{reply:?}") };
    assert_eq!((reply.id, status.sequence, status.paused), (2, before + 3, true));
    let steps = status.steps.expect("a lockstep reply says how many steps");
    assert_eq!(steps.count, 3);
    assert!(steps.island_solves >= 3);
}
