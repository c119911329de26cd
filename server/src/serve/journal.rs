//! The journal a live server publishes so that a session can be reproduced bit for bit
//! (`msgs/README.md`, "Journal"): the **applied** frames (what changed the world before each step:
//! accepted inputs, world-acting control requests, deadman trips, in the order applied) and the
//! **keyframes** (snapshots every `K` s of simulation time, at each new scene state and on request).
//!
//! The engine records into the journal as it applies things; [`Journal::encode`] runs with the
//! frames of each new state and produces that state's applied frames (several when more than
//! [`msgs::MAX_APPLIED`] records waited, all with the same sequence) and, when one is due, its
//! keyframe. Both are published once, like events. A new scene state (load, reset, restore)
//! drops what was recorded for the state it replaces and asks for a keyframe.

use pivotsim_msgs as msgs;
use tracing::warn;

use crate::dynamics::Watchdog;
use crate::scene::Scene;
use crate::snapshot::Snapshot;

/// Default keyframe interval (s of simulation time).
pub const DEFAULT_KEYFRAME_EVERY: f64 = 5.0;

/// The journal (module doc).
#[derive(Debug)]
pub struct Journal {
    pending: Vec<msgs::AppliedRecord>,
    /// Frames of full batches, waiting for the step's sequence.
    batches: Vec<Vec<msgs::AppliedRecord>>,
    applied: Vec<Vec<u8>>,
    keyframe: Vec<u8>,
    every: f64,
    next_at: f64,
    want: Option<msgs::KeyframeReason>,
    /// The sequence whose applied frames and keyframe were encoded last.
    encoded: Option<u64>,
}

impl Journal {
    /// A journal with keyframes every `every` seconds of simulation time (0: only at new scene
    /// states and on request); the first state gets a keyframe.
    pub fn new(every: f64) -> Journal {
        Journal {
            pending: Vec::new(),
            batches: Vec::new(),
            applied: Vec::new(),
            keyframe: Vec::new(),
            every: if every.is_finite() && every > 0.0 { every } else { 0.0 },
            next_at: 0.0,
            want: Some(msgs::KeyframeReason::Scene),
            encoded: None,
        }
    }

    /// Records something applied to the world before the next step.
    pub fn record(&mut self, kind: msgs::AppliedKind, bytes: &[u8]) {
        if bytes.len() > msgs::MAX_APPLIED_RECORD_LEN {
            warn!("journal: a {kind:?} record of {} bytes does not fit; not recorded", bytes.len());
            return;
        }
        if self.pending.len() == msgs::MAX_APPLIED {
            self.batches.push(std::mem::take(&mut self.pending));
        }
        self.pending.push(msgs::AppliedRecord { kind, bytes: bytes.to_vec() });
    }

    /// A keyframe of the current state, published with the next frames.
    pub fn request_keyframe(&mut self, reason: msgs::KeyframeReason) {
        // A new scene state outranks a request.
        if self.want != Some(msgs::KeyframeReason::Scene) {
            self.want = Some(reason);
        }
    }

    /// A new scene state replaces the current one: what was recorded for the old one is moot.
    pub fn new_scene_state(&mut self) {
        self.pending.clear();
        self.batches.clear();
        self.request_keyframe(msgs::KeyframeReason::Scene);
    }

    /// Encodes the frames of the state `sequence`: at its first encoding, its applied frames
    /// (what was recorded since the last state) and a periodic keyframe when one is due; at any
    /// encoding, a requested keyframe. A re-send of the same state otherwise encodes nothing.
    /// `operator`: whether inputs drive (a keyframe keeps it).
    pub fn encode(&mut self, sequence: u64, scene: &Scene, watchdog: &Watchdog, operator: bool) {
        self.applied.clear();
        self.keyframe.clear();
        let t = scene.world.time();
        if self.encoded != Some(sequence) {
            self.encoded = Some(sequence);
            let last = (!self.pending.is_empty()).then(|| std::mem::take(&mut self.pending));
            for records in self.batches.drain(..).chain(last) {
                let f = msgs::AppliedFrame { sequence, sim_time: t, records };
                let mut buf = Vec::new();
                match f.encode(&mut buf) {
                    Ok(()) => self.applied.push(buf),
                    Err(e) => warn!("journal: applied frame not encodable: {e}"),
                }
            }
            if self.every > 0.0 && t + 1e-9 >= self.next_at && self.want.is_none() {
                self.want = Some(msgs::KeyframeReason::Periodic);
            }
        }
        if let Some(reason) = self.want.take() {
            if self.every > 0.0 {
                self.next_at = ((t / self.every + 1e-9).floor() + 1.0) * self.every;
            }
            match keyframe(scene, watchdog, operator) {
                Ok(snapshot) => {
                    let k = msgs::KeyframeView { sequence, sim_time: t, reason, snapshot: &snapshot };
                    if let Err(e) = k.encode(&mut self.keyframe) {
                        warn!("journal: keyframe not encodable: {e}");
                    }
                }
                Err(e) => warn!("journal: no keyframe at {t:.3} s: {e}"),
            }
        }
    }

    /// The applied frames of the last new state (none for a re-send).
    pub fn applied(&self) -> &[Vec<u8>] {
        &self.applied
    }

    /// The keyframe of the last new state, empty when none was due.
    pub fn keyframe(&self) -> &[u8] {
        &self.keyframe
    }
}

/// The snapshot bytes of a keyframe.
pub fn keyframe(
    scene: &Scene,
    watchdog: &Watchdog,
    operator: bool,
) -> Result<Vec<u8>, crate::snapshot::SnapshotError> {
    let mut snap = Snapshot::capture(scene, Some(watchdog))?;
    snap.operator = operator;
    snap.to_bytes()
}
