//! Record and replay (issue 33), in process: the forklift served by the engine under 20 s of
//! seeded random joystick input (with silences that trip the deadman on the engine's clock), its
//! published frames gathered as `pivotsim-client record` stores them, then replayed. The
//! reference is the recording itself: every replayed pose frame must equal the recorded one (but
//! for the wall time), every keyframe the replay's own snapshot; from the 10 s keyframe the same;
//! branched at 10 s with other inputs, identical before and different from the first new input
//! on. A tampered recording must be caught at the first step it touches, and damaged MCAP files
//! refused with typed errors.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

use pivotsim_msgs as msgs;
use pivotsim_server::serve::Engine;
use pivotsim_server::serve::replay::{Recording, ReplayError, replay_headless};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

const STEPS: u64 = 1200; // 20 s at 60 Hz
const SOURCE: u32 = 7;

fn world() -> msgs::WorldName {
    msgs::WorldName::new("replay-test").unwrap()
}

fn joystick(seq: u64, rng: &mut ChaCha8Rng) -> Vec<u8> {
    let axes: Vec<f32> = (0..6).map(|_| rng.random_range(-1.0f32..=1.0)).collect();
    let j = msgs::Joystick::new(seq, SOURCE, &axes, 0, 0).unwrap();
    let mut b = Vec::new();
    msgs::InputCommand::Joystick(j).encode(&mut b).unwrap();
    b
}

/// Every frame a recorder of the session would store, in publishing order.
#[derive(Default)]
struct Tape {
    frames: Vec<Vec<u8>>,
}

impl Tape {
    fn take(&mut self, e: &Engine) {
        let f = e.frames();
        self.frames.push(f.poses.to_vec());
        self.frames.extend(f.applied.iter().cloned());
        if !f.keyframe.is_empty() {
            self.frames.push(f.keyframe.to_vec());
        }
    }

    fn recording(&self) -> Recording {
        let mut r = Recording::default();
        for f in &self.frames {
            assert!(r.add_frame(f), "a published frame did not decode");
        }
        r
    }
}

/// The session: the forklift stepped on the engine's clock (60 Hz from an arbitrary origin),
/// joystick input at random steps from `seed`, silent in [6 s, 7 s) and [13 s, 14 s) so that the
/// deadman (250 ms) trips twice.
fn session(seed: u64) -> (Tape, BTreeMap<u64, Vec<u8>>) {
    let mut e = Engine::new("forklift", world(), Duration::from_millis(250)).unwrap();
    e.set_keyframe_every(5.0);
    e.set_paused(false);
    let mut tape = Tape::default();
    let t0 = Instant::now();
    e.encode_frames(0);
    tape.take(&e);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let h = Duration::from_secs_f64(1.0 / 60.0);
    let mut poses = BTreeMap::new();
    for k in 1..=STEPS {
        let now = t0 + h * k as u32;
        let silent = (360..420).contains(&k) || (780..840).contains(&k);
        if !silent && rng.random_bool(0.4) {
            e.handle_input(Some(msgs::Topic::Joystick), &joystick(k, &mut rng), now).unwrap();
        }
        assert!(e.tick(now), "step {k}");
        tape.take(&e);
        poses.insert(e.sequence(), e.pose_frame().to_vec());
    }
    assert!(e.health().deadman_trips >= 2, "the silences trip the deadman");
    (tape, poses)
}

#[test]
fn a_recorded_session_replays_bit_for_bit_from_the_start_and_from_a_keyframe() {
    let (tape, _) = session(11);
    let rec = Arc::new(tape.recording());
    assert_eq!(rec.keyframes.len(), 5, "start, 5, 10, 15, 20 s");
    assert!(rec.applied.len() > 300, "{} steps had inputs", rec.applied.len());
    let deadman = rec.applied.values().flatten().filter(|r| r.kind == msgs::AppliedKind::Deadman).count();
    assert!(deadman >= 2, "{deadman} deadman trips journaled");

    let e = replay_headless(rec.clone(), None, None, None, world()).unwrap();
    let p = e.replay_progress();
    assert_eq!(p.divergence, None);
    assert!(p.finished);
    assert_eq!(p.poses_compared, STEPS, "every step compared");
    assert_eq!(p.keyframes_compared, 4, "the periodic keyframes");
    assert_eq!(e.sequence(), STEPS);

    // From the 10 s keyframe: identical from there.
    let e = replay_headless(rec.clone(), Some(10.0), None, None, world()).unwrap();
    let p = e.replay_progress();
    assert_eq!(p.divergence, None);
    assert_eq!(p.poses_compared, STEPS - 600);
    // From 12.5 s: through the 10 s keyframe and the recorded inputs, stopped at 12.5 s.
    let e = replay_headless(rec.clone(), Some(12.5), Some(12.5), None, world()).unwrap();
    assert_eq!(e.replay_progress().divergence, None);
    assert!((e.scene().world.time() - 12.5).abs() < 1e-9);
    assert!(e.is_replaying());
}

#[test]
fn a_branch_is_identical_before_and_different_from_the_first_new_input() {
    let (tape, recorded) = session(12);
    let rec = Arc::new(tape.recording());
    let mut e = replay_headless(rec, None, None, Some(10.0), world()).unwrap();
    let p = e.replay_progress().clone();
    assert_eq!(p.divergence, None);
    assert!(p.branched && !e.is_replaying());
    assert_eq!(p.poses_compared, 600, "identical up to the branch");
    assert!((e.scene().world.time() - 10.0).abs() < 1e-9);
    // Live inputs now drive: other inputs than the recording's.
    e.set_paused(false);
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let t0 = Instant::now();
    let mut differs = 0;
    for k in 0..60u32 {
        let now = t0 + Duration::from_millis(16) * k;
        e.handle_input(Some(msgs::Topic::Joystick), &joystick(10_000 + u64::from(k), &mut rng), now).unwrap();
        assert!(e.tick(now));
        let mine = e.pose_frame();
        let theirs = &recorded[&e.sequence()];
        if pivotsim_server::serve::replay::compare_poses(mine, theirs).is_some() {
            differs += 1;
        }
    }
    assert_eq!(differs, 60, "every step after the first new input differs from the recording");
}

#[test]
fn a_tampered_recording_diverges_at_the_first_step_it_touches() {
    let (tape, _) = session(13);
    // A recorded pose changed in its last bit at sequence 500.
    let mut rec = tape.recording();
    let f = rec.poses.get_mut(&500).unwrap();
    let at = msgs::HEADER_LEN + 48; // the first body's x position
    f[at] ^= 1;
    let e = replay_headless(Arc::new(rec), None, None, None, world()).unwrap();
    let d = e.replay_progress().divergence.clone().expect("caught");
    assert_eq!(d.sequence, 500, "{d}");
    assert!(!e.is_replaying() && e.is_paused());

    // An input changed (another axis value) at the first step with one after 3 s: the poses
    // differ from that step on.
    let mut rec = tape.recording();
    let (&seq, records) = rec.applied.range_mut(181..).next().unwrap();
    let r = records.iter_mut().find(|r| r.kind == msgs::AppliedKind::Input).unwrap();
    let mut j = match msgs::InputCommand::decode(&r.bytes).unwrap() {
        msgs::InputCommand::Joystick(j) => j,
        other => panic!("{other:?}"),
    };
    j.axes[1] = if j.axes[1] > 0.0 { -0.9 } else { 0.9 };
    r.bytes.clear();
    msgs::InputCommand::Joystick(j).encode(&mut r.bytes).unwrap();
    let e = replay_headless(Arc::new(rec), None, None, None, world()).unwrap();
    let d = e.replay_progress().divergence.clone().expect("caught");
    assert_eq!(d.sequence, seq, "{d}");
}

#[test]
fn recordings_without_keyframes_or_with_damage_are_typed_errors() {
    let (tape, _) = session(14);
    let mut rec = tape.recording();
    rec.keyframes.clear();
    let e = replay_headless(Arc::new(rec), None, None, None, world());
    assert!(matches!(e, Err(ReplayError::NoKeyframe(_))));
    let rec = Arc::new(tape.recording());
    assert!(matches!(rec.start(Some(-1.0)), Err(ReplayError::NoKeyframe(_))));
    // A keyframe whose snapshot is cut short: typed, nothing replayed.
    let mut bad = tape.recording();
    let n = bad.keyframes[0].snapshot.len();
    bad.keyframes[0].snapshot.truncate(n / 2);
    assert!(matches!(
        replay_headless(Arc::new(bad), None, None, None, world()),
        Err(ReplayError::Snapshot { sequence: 0, .. })
    ));

    // The same frames in an MCAP file read back equal; cut or flipped files are errors.
    let mcap = write_mcap(&tape.frames);
    let back = Recording::from_bytes(&mcap).unwrap();
    assert_eq!(back.poses, rec.poses);
    assert_eq!(back.applied, rec.applied);
    assert_eq!(back.keyframes.len(), rec.keyframes.len());
    let e = replay_headless(Arc::new(back), None, None, None, world()).unwrap();
    assert_eq!(e.replay_progress().divergence, None);
    for cut in [0, 7, 100, mcap.len() / 3, mcap.len() - 9] {
        match Recording::from_bytes(&mcap[..cut]) {
            Err(ReplayError::Mcap(_)) => {}
            other => panic!("cut at {cut}: {:?}", other.map(|r| r.poses.len())),
        }
    }
    let path = std::env::temp_dir().join(format!("pivotsim-replay-missing-{}.mcap", std::process::id()));
    assert!(matches!(Recording::read(&path), Err(ReplayError::Io { .. })));
}

/// The frames as `pivotsim-client record` writes them: one channel per wire topic.
fn write_mcap(frames: &[Vec<u8>]) -> Vec<u8> {
    let mut w = mcap::Writer::new(std::io::Cursor::new(Vec::new())).unwrap();
    let mut channels = BTreeMap::new();
    for topic in [msgs::RECORD_TOPIC_POSES, msgs::RECORD_TOPIC_APPLIED, msgs::RECORD_TOPIC_KEYFRAMES] {
        let id = w.add_channel(0, topic, msgs::RECORD_WIRE_ENCODING, &BTreeMap::new()).unwrap();
        channels.insert(topic, id);
    }
    for (i, f) in frames.iter().enumerate() {
        let topic = match msgs::header::peek(f).unwrap().kind {
            msgs::Kind::PoseFrame => msgs::RECORD_TOPIC_POSES,
            msgs::Kind::Applied => msgs::RECORD_TOPIC_APPLIED,
            _ => msgs::RECORD_TOPIC_KEYFRAMES,
        };
        let header = mcap::records::MessageHeader {
            channel_id: channels[topic],
            sequence: i as u32,
            log_time: i as u64,
            publish_time: i as u64,
        };
        w.write_to_known_channel(&header, f).unwrap();
    }
    w.finish().unwrap();
    w.into_inner().into_inner()
}
