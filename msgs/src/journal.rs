//! The journal (topic `journal`): what a recording needs to reproduce a session bit for bit.
//!
//! ```text
//! applied (0x0005)  offset size field
//!                        0    8 sequence        u64, the state whose step these applied to
//!                        8    8 sim_time        f64, that state's time (s)
//!                       16    4 record_count    u32, n ≤ MAX_APPLIED (256)
//!                       20    4 reserved        0
//!                       24      records, each:
//!                          +0 1 kind            0 input, 1 control, 2 deadman
//!                          +1 3 reserved        0
//!                          +4 4 len             u32, ≤ MAX_APPLIED_RECORD_LEN (8 KiB)
//!                          +8 len bytes         an input frame / a control request frame / none
//!                               zero padding    to a multiple of 8
//!
//! keyframe (0x0006) offset size field
//!                        0    8 sequence        u64, the state the snapshot holds
//!                        8    8 sim_time        f64 (s)
//!                       16    4 reason          0 periodic, 1 requested, 2 scene (start, load, reset, restore)
//!                       20    4 snapshot_len    u32, payload_len = 24 + snapshot_len
//!                       24      snapshot        a snapshot file (starts with b"PIVSNAP\0")
//! ```
//!
//! An applied frame lists, in the order the server applied them, everything that changed the
//! world between two steps apart from the step itself: the input frames it accepted (byte for
//! byte), the control requests that act on the world (`fault`, `set_variant`), and deadman trips.
//! It is published once, at the step they applied to, and only when there was something.

use crate::header::{self, DecodeError, FrameError, HEADER_LEN, Kind};
use crate::le;

/// In a recording (MCAP, `pivotsim-client record`): the message encoding of the channels that
/// carry wire frames byte for byte (no schema: this page is the schema).
pub const RECORD_WIRE_ENCODING: &str = "pivotsim-wire";
/// In a recording: the channel of the pose frames, as published.
pub const RECORD_TOPIC_POSES: &str = "/pivotsim/wire/poses";
/// In a recording: the channel of the applied frames.
pub const RECORD_TOPIC_APPLIED: &str = "/pivotsim/wire/applied";
/// In a recording: the channel of the keyframes.
pub const RECORD_TOPIC_KEYFRAMES: &str = "/pivotsim/wire/keyframes";

/// Most records in one applied frame.
pub const MAX_APPLIED: usize = 256;
/// Longest record (bytes, before padding).
pub const MAX_APPLIED_RECORD_LEN: usize = 8 * 1024;
/// Bytes of an applied frame's fixed part and of a record's head.
pub const APPLIED_FIXED_LEN: usize = 24;
/// Bytes of a record's head (kind, reserved, length).
pub const APPLIED_RECORD_HEAD_LEN: usize = 8;
/// Bytes of a keyframe's fixed part.
pub const KEYFRAME_FIXED_LEN: usize = 24;
/// The first bytes of every snapshot file.
pub const SNAPSHOT_MAGIC: [u8; 8] = *b"PIVSNAP\0";

/// What an applied record holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum AppliedKind {
    /// An input frame the server accepted.
    Input = 0,
    /// A control request frame that acts on the world.
    Control = 1,
    /// The deadman tripped (no bytes): every actuator went to neutral.
    Deadman = 2,
}

impl AppliedKind {
    /// From the wire code.
    pub fn from_code(c: u8) -> Option<AppliedKind> {
        match c {
            0 => Some(AppliedKind::Input),
            1 => Some(AppliedKind::Control),
            2 => Some(AppliedKind::Deadman),
            _ => None,
        }
    }
}

/// One applied record.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AppliedRecord {
    /// What it is.
    pub kind: AppliedKind,
    /// The frame (empty for a deadman trip).
    pub bytes: Vec<u8>,
}

/// An owned applied frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct AppliedFrame {
    /// The state whose step the records applied to.
    pub sequence: u64,
    /// That state's time (s).
    pub sim_time: f64,
    /// In the order applied.
    pub records: Vec<AppliedRecord>,
}

/// Why a keyframe was taken.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u32)]
pub enum KeyframeReason {
    /// Every `K` seconds of simulation time.
    Periodic = 0,
    /// Asked for (the control op `keyframe`, e.g. a recorder that starts).
    Requested = 1,
    /// A new scene state: the server's start, `load_scene`, `reset`, `restore`.
    Scene = 2,
}

impl KeyframeReason {
    /// From the wire code.
    pub fn from_code(c: u32) -> Option<KeyframeReason> {
        match c {
            0 => Some(KeyframeReason::Periodic),
            1 => Some(KeyframeReason::Requested),
            2 => Some(KeyframeReason::Scene),
            _ => None,
        }
    }
}

/// A decoded keyframe, borrowing its snapshot bytes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KeyframeView<'a> {
    /// The state the snapshot holds.
    pub sequence: u64,
    /// Its time (s).
    pub sim_time: f64,
    /// Why it was taken.
    pub reason: KeyframeReason,
    /// The snapshot file's bytes.
    pub snapshot: &'a [u8],
}

/// Invalid journal content.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum JournalError {
    /// More than [`MAX_APPLIED`] records.
    #[error("{found} applied records (at most {MAX_APPLIED})")]
    TooManyRecords {
        /// Records.
        found: usize,
    },
    /// A record over [`MAX_APPLIED_RECORD_LEN`], or one that runs past the frame.
    #[error("applied record {record}: {len} bytes does not fit")]
    RecordLength {
        /// Record index.
        record: usize,
        /// Its length.
        len: usize,
    },
    /// An unknown record kind or keyframe reason.
    #[error("{what}: unknown code {code}")]
    UnknownCode {
        /// What.
        what: &'static str,
        /// Code.
        code: u32,
    },
    /// A deadman record with bytes, or an input or control record without.
    #[error("applied record {record}: wrong length for its kind")]
    RecordContent {
        /// Record index.
        record: usize,
    },
    /// `sim_time` negative or not finite.
    #[error("sim_time {0} is not a finite time ≥ 0")]
    SimTime(f64),
    /// The keyframe's snapshot does not start with [`SNAPSHOT_MAGIC`].
    #[error("the keyframe does not hold a snapshot file")]
    NotASnapshot,
}

fn pad8(n: usize) -> usize {
    n.div_ceil(8) * 8
}

fn check_time(t: f64) -> Result<(), JournalError> {
    match t.is_finite() && t >= 0.0 {
        true => Ok(()),
        false => Err(JournalError::SimTime(t)),
    }
}

impl AppliedFrame {
    /// Frame length in bytes.
    pub fn encoded_len(&self) -> usize {
        HEADER_LEN
            + APPLIED_FIXED_LEN
            + self.records.iter().map(|r| APPLIED_RECORD_HEAD_LEN + pad8(r.bytes.len())).sum::<usize>()
    }

    /// Checks every rule a decoder checks.
    pub fn validate(&self) -> Result<(), JournalError> {
        if self.records.len() > MAX_APPLIED {
            return Err(JournalError::TooManyRecords { found: self.records.len() });
        }
        check_time(self.sim_time)?;
        for (i, r) in self.records.iter().enumerate() {
            if r.bytes.len() > MAX_APPLIED_RECORD_LEN {
                return Err(JournalError::RecordLength { record: i, len: r.bytes.len() });
            }
            if (r.kind == AppliedKind::Deadman) != r.bytes.is_empty() {
                return Err(JournalError::RecordContent { record: i });
            }
        }
        Ok(())
    }

    /// Clears `buf` and writes the frame. On error `buf` is left empty.
    pub fn encode(&self, buf: &mut Vec<u8>) -> Result<(), JournalError> {
        buf.clear();
        self.validate()?;
        buf.reserve(self.encoded_len());
        header::begin(buf, Kind::Applied);
        buf.extend_from_slice(&self.sequence.to_le_bytes());
        le::put_f64s(buf, &[self.sim_time]);
        buf.extend_from_slice(&(self.records.len() as u32).to_le_bytes());
        buf.extend_from_slice(&0u32.to_le_bytes());
        for r in &self.records {
            buf.extend_from_slice(&[r.kind as u8, 0, 0, 0]);
            buf.extend_from_slice(&(r.bytes.len() as u32).to_le_bytes());
            buf.extend_from_slice(&r.bytes);
            buf.resize(buf.len() + pad8(r.bytes.len()) - r.bytes.len(), 0);
        }
        header::set_payload_len(buf);
        Ok(())
    }

    /// Decodes and validates a frame.
    pub fn decode(bytes: &[u8]) -> Result<AppliedFrame, DecodeError<JournalError>> {
        let kind = Kind::Applied;
        let p = header::expect(bytes, kind)?;
        if p.len() < APPLIED_FIXED_LEN {
            return Err(
                FrameError::PayloadLength { kind, expected: APPLIED_FIXED_LEN, found: p.len() }.into()
            );
        }
        let n = le::u32_at(p, 16) as usize;
        if n > MAX_APPLIED {
            return Err(DecodeError::Invalid(JournalError::TooManyRecords { found: n }));
        }
        header::check_reserved(p, 20..24, HEADER_LEN)?;
        let mut f =
            AppliedFrame { sequence: le::u64_at(p, 0), sim_time: le::f64_at(p, 8), records: Vec::new() };
        check_time(f.sim_time).map_err(DecodeError::Invalid)?;
        let mut at = APPLIED_FIXED_LEN;
        for i in 0..n {
            if p.len() < at + APPLIED_RECORD_HEAD_LEN {
                return Err(FrameError::PayloadLength {
                    kind,
                    expected: at + APPLIED_RECORD_HEAD_LEN,
                    found: p.len(),
                }
                .into());
            }
            let code = p[at];
            let kind_i =
                AppliedKind::from_code(code).ok_or(DecodeError::Invalid(JournalError::UnknownCode {
                    what: "applied record kind",
                    code: u32::from(code),
                }))?;
            header::check_reserved(p, at + 1..at + 4, HEADER_LEN)?;
            let len = le::u32_at(p, at + 4) as usize;
            let body = at + APPLIED_RECORD_HEAD_LEN;
            if len > MAX_APPLIED_RECORD_LEN || p.len() < body + pad8(len) {
                return Err(DecodeError::Invalid(JournalError::RecordLength { record: i, len }));
            }
            header::check_reserved(p, body + len..body + pad8(len), HEADER_LEN)?;
            f.records.push(AppliedRecord { kind: kind_i, bytes: p[body..body + len].to_vec() });
            at = body + pad8(len);
        }
        if p.len() != at {
            return Err(FrameError::PayloadLength { kind, expected: at, found: p.len() }.into());
        }
        f.validate().map_err(DecodeError::Invalid)?;
        Ok(f)
    }
}

impl<'a> KeyframeView<'a> {
    /// Clears `buf` and writes a keyframe frame holding `snapshot`. On error `buf` is left empty.
    pub fn encode(&self, buf: &mut Vec<u8>) -> Result<(), JournalError> {
        buf.clear();
        check_time(self.sim_time)?;
        if !self.snapshot.starts_with(&SNAPSHOT_MAGIC) {
            return Err(JournalError::NotASnapshot);
        }
        buf.reserve(HEADER_LEN + KEYFRAME_FIXED_LEN + self.snapshot.len());
        header::begin(buf, Kind::Keyframe);
        buf.extend_from_slice(&self.sequence.to_le_bytes());
        le::put_f64s(buf, &[self.sim_time]);
        buf.extend_from_slice(&(self.reason as u32).to_le_bytes());
        buf.extend_from_slice(&(self.snapshot.len() as u32).to_le_bytes());
        buf.extend_from_slice(self.snapshot);
        header::set_payload_len(buf);
        Ok(())
    }

    /// Decodes and checks a keyframe frame (the snapshot's own content is the server's to check).
    pub fn parse(bytes: &'a [u8]) -> Result<KeyframeView<'a>, DecodeError<JournalError>> {
        let kind = Kind::Keyframe;
        let p = header::expect(bytes, kind)?;
        if p.len() < KEYFRAME_FIXED_LEN {
            return Err(
                FrameError::PayloadLength { kind, expected: KEYFRAME_FIXED_LEN, found: p.len() }.into()
            );
        }
        let expected = KEYFRAME_FIXED_LEN + le::u32_at(p, 20) as usize;
        if p.len() != expected {
            return Err(FrameError::PayloadLength { kind, expected, found: p.len() }.into());
        }
        let code = le::u32_at(p, 16);
        let reason = KeyframeReason::from_code(code)
            .ok_or(DecodeError::Invalid(JournalError::UnknownCode { what: "keyframe reason", code }))?;
        let v = KeyframeView {
            sequence: le::u64_at(p, 0),
            sim_time: le::f64_at(p, 8),
            reason,
            snapshot: &p[24..],
        };
        check_time(v.sim_time).map_err(DecodeError::Invalid)?;
        if !v.snapshot.starts_with(&SNAPSHOT_MAGIC) {
            return Err(DecodeError::Invalid(JournalError::NotASnapshot));
        }
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> AppliedFrame {
        AppliedFrame {
            sequence: 42,
            sim_time: 0.7,
            records: vec![
                AppliedRecord { kind: AppliedKind::Input, bytes: vec![1, 2, 3] },
                AppliedRecord { kind: AppliedKind::Deadman, bytes: vec![] },
                AppliedRecord { kind: AppliedKind::Control, bytes: vec![9; 8] },
            ],
        }
    }

    #[test]
    fn applied_frames_round_trip_with_padding_checked() {
        let f = sample();
        let mut b = Vec::new();
        f.encode(&mut b).unwrap();
        assert_eq!(b.len(), f.encoded_len());
        assert_eq!(b.len(), 16 + 24 + (8 + 8) + 8 + (8 + 8));
        assert_eq!(AppliedFrame::decode(&b).unwrap(), f);
        // The first record's padding (3 bytes of data, 5 of zeros) must be zero.
        let mut x = b.clone();
        x[16 + 24 + 8 + 3] = 1;
        assert!(matches!(
            AppliedFrame::decode(&x),
            Err(DecodeError::Frame(FrameError::ReservedNonZero { .. }))
        ));
        // A length that runs past the frame.
        let mut x = b.clone();
        x[16 + 24 + 4] = 200;
        assert!(matches!(
            AppliedFrame::decode(&x),
            Err(DecodeError::Invalid(JournalError::RecordLength { .. }))
        ));
        // Cut short.
        assert!(AppliedFrame::decode(&b[..b.len() - 8]).is_err());
        // A record kind this version does not know.
        let mut x = b.clone();
        x[16 + 24] = 7;
        assert!(matches!(
            AppliedFrame::decode(&x),
            Err(DecodeError::Invalid(JournalError::UnknownCode { .. }))
        ));
    }

    #[test]
    fn bad_applied_content_is_refused_before_encoding() {
        let mut f = sample();
        f.records[1].bytes = vec![1];
        assert_eq!(f.encode(&mut Vec::new()), Err(JournalError::RecordContent { record: 1 }));
        let mut f = sample();
        f.sim_time = f64::NAN;
        assert!(matches!(f.encode(&mut Vec::new()), Err(JournalError::SimTime(_))));
        let mut f = sample();
        f.records = vec![AppliedRecord { kind: AppliedKind::Deadman, bytes: vec![] }; MAX_APPLIED + 1];
        assert_eq!(f.encode(&mut Vec::new()), Err(JournalError::TooManyRecords { found: MAX_APPLIED + 1 }));
    }

    #[test]
    fn keyframes_round_trip_and_hold_snapshots_only() {
        let mut snap = SNAPSHOT_MAGIC.to_vec();
        snap.extend_from_slice(&[5; 13]);
        let k =
            KeyframeView { sequence: 3, sim_time: 5.0, reason: KeyframeReason::Periodic, snapshot: &snap };
        let mut b = Vec::new();
        k.encode(&mut b).unwrap();
        assert_eq!(KeyframeView::parse(&b).unwrap(), k);
        let mut x = b.clone();
        x[16 + 24] = b'X';
        assert_eq!(KeyframeView::parse(&x), Err(DecodeError::Invalid(JournalError::NotASnapshot)));
        let mut x = b.clone();
        x[16 + 16] = 9;
        assert!(matches!(
            KeyframeView::parse(&x),
            Err(DecodeError::Invalid(JournalError::UnknownCode { .. }))
        ));
        let bad = KeyframeView { snapshot: b"not one", ..k };
        assert_eq!(bad.encode(&mut Vec::new()), Err(JournalError::NotASnapshot));
    }
}
