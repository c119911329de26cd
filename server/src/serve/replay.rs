//! Replaying a recording (`pivotsim-server replay FILE.mcap`): the session a live server journaled
//! (`journal.rs`; `msgs/README.md`, "Journal") and `pivotsim-client record` stored, reproduced bit
//! for bit by the same build.
//!
//! **What a recording holds.** Three channels of wire frames, byte for byte (message encoding
//! [`WIRE_ENCODING`]): the pose frames ([`TOPIC_POSES`]), the applied frames
//! ([`TOPIC_APPLIED`]) and the keyframes ([`TOPIC_KEYFRAMES`]). [`Recording::read`] gathers them by
//! sequence: a paused server's re-sends of a state collapse into one pose frame, applied frames of
//! one sequence (a long pause's inputs can take several) concatenate in order.
//!
//! **The replay.** It starts from a keyframe (the last one at or before `--from`): the snapshot's
//! scene is built from the text it carries and its state restored, with the sequence, the
//! operator flag and the watchdog's ledger of that moment. Then, for each next sequence `s`: a
//! keyframe of a new scene state at `s` (a load, reset or restore in the session) is installed;
//! otherwise the applied records of `s` are applied in order (inputs as the live server applied
//! them, world-acting control requests, deadman trips — the replay's own deadman never trips on
//! the wall clock) and the world steps. Each state's pose frame must equal the recorded one but
//! for `wall_time_ns`, and a periodic keyframe's snapshot the replay's own; the first difference
//! is a [`Divergence`], reported with its sequence and time, and the replay stops there (paused).
//! Live inputs and world-changing requests are refused until the replay ends or, with `--branch
//! T`, until it reaches `T`: from there live inputs drive (the instructor's "take over from here").

use std::collections::BTreeMap;
use std::path::Path;

use pivotsim_msgs as msgs;
use thiserror::Error;

use crate::snapshot::{Snapshot, SnapshotError};

/// The applied frames, as published.
pub use msgs::RECORD_TOPIC_APPLIED as TOPIC_APPLIED;
/// The keyframes, as published.
pub use msgs::RECORD_TOPIC_KEYFRAMES as TOPIC_KEYFRAMES;
/// The pose frames, as published.
pub use msgs::RECORD_TOPIC_POSES as TOPIC_POSES;
/// Message encoding of the channels that carry wire frames byte for byte.
pub use msgs::RECORD_WIRE_ENCODING as WIRE_ENCODING;
/// Largest recording read (bytes): it is read into memory whole.
pub const MAX_RECORDING_BYTES: u64 = 4 << 30;

/// A keyframe of the recording.
#[derive(Debug, Clone)]
pub struct Keyframe {
    /// The state it holds.
    pub sequence: u64,
    /// Its time (s).
    pub sim_time: f64,
    /// Why it was taken.
    pub reason: msgs::KeyframeReason,
    /// The snapshot file's bytes.
    pub snapshot: Vec<u8>,
}

/// The replayable part of a recording (module doc).
#[derive(Debug, Clone, Default)]
pub struct Recording {
    /// In sequence order.
    pub keyframes: Vec<Keyframe>,
    /// Applied records by the sequence of the step they applied to, in order.
    pub applied: BTreeMap<u64, Vec<msgs::AppliedRecord>>,
    /// The pose frame of each sequence (the first one received).
    pub poses: BTreeMap<u64, Vec<u8>>,
    /// Frames of the wire channels that did not decode (skipped).
    pub malformed: u64,
}

/// Why a recording cannot be replayed.
#[derive(Debug, Error)]
pub enum ReplayError {
    /// Reading the file.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The error.
        source: std::io::Error,
    },
    /// Over [`MAX_RECORDING_BYTES`].
    #[error("{path}: {bytes} bytes is more than a replay reads ({MAX_RECORDING_BYTES})")]
    TooLarge {
        /// The file.
        path: String,
        /// Its size.
        bytes: u64,
    },
    /// Not an MCAP file, or a truncated or corrupt one.
    #[error("not a readable MCAP recording: {0}")]
    Mcap(String),
    /// No keyframe (recorded by a client older than the journal, or from a server started with
    /// `--keyframes 0` and no `keyframe` request), or none at or before the time asked.
    #[error("{0}")]
    NoKeyframe(String),
    /// The keyframe's snapshot does not restore.
    #[error("keyframe at sequence {sequence}: {source}")]
    Snapshot {
        /// The keyframe.
        sequence: u64,
        /// Why.
        source: SnapshotError,
    },
}

fn mcap_error(e: impl std::fmt::Display) -> ReplayError {
    ReplayError::Mcap(e.to_string())
}

impl Recording {
    /// Reads the wire channels of an MCAP file (module doc).
    pub fn read(path: &Path) -> Result<Recording, ReplayError> {
        let io = |source| ReplayError::Io { path: path.display().to_string(), source };
        let bytes = std::fs::metadata(path).map_err(io)?.len();
        if bytes > MAX_RECORDING_BYTES {
            return Err(ReplayError::TooLarge { path: path.display().to_string(), bytes });
        }
        Recording::from_bytes(&std::fs::read(path).map_err(io)?)
    }

    /// [`Recording::read`] from the file's bytes.
    pub fn from_bytes(file: &[u8]) -> Result<Recording, ReplayError> {
        let mut rec = Recording::default();
        for m in mcap::MessageStream::new(file).map_err(mcap_error)? {
            let m = m.map_err(mcap_error)?;
            if m.channel.message_encoding != WIRE_ENCODING {
                continue;
            }
            if [TOPIC_POSES, TOPIC_APPLIED, TOPIC_KEYFRAMES].contains(&m.channel.topic.as_str())
                && !rec.add_frame(&m.data)
            {
                rec.malformed += 1;
            }
        }
        Ok(rec)
    }

    /// Adds one wire frame (pose, applied or keyframe, by its header's kind); `false` when it
    /// does not decode or is of another kind. Keyframes stay in sequence order.
    pub fn add_frame(&mut self, frame: &[u8]) -> bool {
        match msgs::header::peek(frame).map(|h| h.kind) {
            Ok(msgs::Kind::PoseFrame) => self.add_pose(frame),
            Ok(msgs::Kind::Applied) => self.add_applied(frame),
            Ok(msgs::Kind::Keyframe) => self.add_keyframe(frame),
            _ => false,
        }
    }

    fn add_pose(&mut self, frame: &[u8]) -> bool {
        match msgs::PoseFrameView::parse(frame) {
            Ok(v) => {
                self.poses.entry(v.sequence()).or_insert_with(|| frame.to_vec());
                true
            }
            Err(_) => false,
        }
    }

    fn add_applied(&mut self, frame: &[u8]) -> bool {
        match msgs::AppliedFrame::decode(frame) {
            Ok(f) => {
                self.applied.entry(f.sequence).or_default().extend(f.records);
                true
            }
            Err(_) => false,
        }
    }

    fn add_keyframe(&mut self, frame: &[u8]) -> bool {
        match msgs::KeyframeView::parse(frame) {
            Ok(k) => {
                if let Err(at) = self.keyframes.binary_search_by_key(&k.sequence, |k| k.sequence) {
                    let snapshot = k.snapshot.to_vec();
                    let kf =
                        Keyframe { sequence: k.sequence, sim_time: k.sim_time, reason: k.reason, snapshot };
                    self.keyframes.insert(at, kf);
                }
                true
            }
            Err(_) => false,
        }
    }

    /// The keyframe a replay from `from` (s; `None`: the first) starts at: the last one at or
    /// before `from` among those before the first keyframe past it.
    pub fn start(&self, from: Option<f64>) -> Result<&Keyframe, ReplayError> {
        let Some(first) = self.keyframes.first() else {
            return Err(ReplayError::NoKeyframe("the recording holds no keyframe to start from".into()));
        };
        let Some(t) = from else { return Ok(first) };
        self.keyframes.iter().take_while(|k| k.sim_time <= t + 1e-9).last().ok_or_else(|| {
            ReplayError::NoKeyframe(format!(
                "no keyframe at or before {t} s (the first is at {} s)",
                first.sim_time
            ))
        })
    }

    /// The keyframe of a new scene state at `sequence`, if the session had one there.
    pub fn scene_keyframe(&self, sequence: u64) -> Option<&Keyframe> {
        self.keyframe(sequence).filter(|k| k.reason == msgs::KeyframeReason::Scene)
    }

    /// The keyframe at `sequence`.
    pub fn keyframe(&self, sequence: u64) -> Option<&Keyframe> {
        self.keyframes.binary_search_by_key(&sequence, |k| k.sequence).ok().map(|i| &self.keyframes[i])
    }

    /// The last sequence the recording says anything about.
    pub fn last_sequence(&self) -> u64 {
        let p = self.poses.keys().next_back().copied().unwrap_or(0);
        let a = self.applied.keys().next_back().copied().unwrap_or(0);
        let k = self.keyframes.last().map_or(0, |k| k.sequence);
        p.max(a).max(k)
    }
}

/// The first difference between the recording and the replay.
#[derive(Debug, Clone, PartialEq)]
pub struct Divergence {
    /// The sequence of the state that differs.
    pub sequence: u64,
    /// Its simulation time (s, the replay's).
    pub sim_time: f64,
    /// What differs.
    pub what: String,
}

impl std::fmt::Display for Divergence {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "diverged at sequence {} (t = {:.4} s): {}", self.sequence, self.sim_time, self.what)
    }
}

/// Compares a replayed pose frame with the recorded one, all but `wall_time_ns`; `None` when equal.
pub fn compare_poses(replayed: &[u8], recorded: &[u8]) -> Option<String> {
    const WALL: std::ops::Range<usize> = msgs::HEADER_LEN + 16..msgs::HEADER_LEN + 24;
    if replayed.len() == recorded.len()
        && replayed[..WALL.start] == recorded[..WALL.start]
        && replayed[WALL.end..] == recorded[WALL.end..]
    {
        return None;
    }
    let (Ok(a), Ok(b)) = (msgs::PoseFrame::decode(replayed), msgs::PoseFrame::decode(recorded)) else {
        return Some("a pose frame does not decode".into());
    };
    if a.bodies.len() != b.bodies.len() {
        return Some(format!("{} bodies replayed, {} recorded", a.bodies.len(), b.bodies.len()));
    }
    if a.sim_time.to_bits() != b.sim_time.to_bits() {
        return Some(format!("sim_time {} replayed, {} recorded", a.sim_time, b.sim_time));
    }
    for (x, y) in a.bodies.iter().zip(&b.bodies) {
        if x != y {
            let d = (0..3).map(|i| (x.position[i] - y.position[i]).abs()).fold(0.0, f64::max);
            return Some(format!(
                "body {}: position differs by {d:.3e} m (or its velocity or orientation)",
                x.id
            ));
        }
    }
    Some("the pose frames differ".into())
}

/// Compares the replay's snapshot with a recorded keyframe's, but for the build string (the
/// poses have already told whether the build matters); `None` when equal.
pub fn compare_snapshots(replayed: &Snapshot, recorded: &[u8]) -> Option<String> {
    let mut rec = match Snapshot::from_bytes(recorded) {
        Ok(s) => s,
        Err(e) => return Some(format!("the recorded keyframe does not decode: {e}")),
    };
    rec.build.clone_from(&replayed.build);
    match (replayed.to_bytes(), rec.to_bytes()) {
        (Ok(a), Ok(b)) if a == b => None,
        (Ok(_), Ok(_)) if replayed.scene.digest != rec.scene.digest => Some("another scene".into()),
        (Ok(_), Ok(_)) => {
            Some("the keyframe's state differs (warm starts, contacts, signals or actuators)".into())
        }
        (Err(e), _) | (_, Err(e)) => Some(format!("a snapshot does not encode: {e}")),
    }
}

/// Replays `recording` from the keyframe at or before `from` without transports, as fast as
/// possible, until its end, a divergence, `until` (s) or `branch` (s: the engine is then live,
/// paused at the branch, for its caller to drive); returns the engine where it stopped. Bounded by
/// the recording's length in steps.
pub fn replay_headless(
    recording: std::sync::Arc<Recording>,
    from: Option<f64>,
    until: Option<f64>,
    branch: Option<f64>,
    world: msgs::WorldName,
) -> Result<super::Engine, ReplayError> {
    let start = recording.start(from)?;
    let first = start.sequence;
    let mut e = super::Engine::replay(recording.clone(), start, world, branch)?;
    let steps = recording.last_sequence().saturating_sub(first) + 2;
    let h = e.scene().world.settings().timestep;
    // Up to `from` first (through the recorded inputs), then on to the end or `until`.
    e.set_paused(false);
    for _ in 0..steps {
        let t = e.scene().world.time();
        if !e.is_replaying() || until.is_some_and(|u| t + 0.5 * h >= u) {
            break;
        }
        e.tick(std::time::Instant::now());
    }
    e.set_paused(true);
    Ok(e)
}
