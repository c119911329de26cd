//! Signals (kind `0x0003`) and events (kind `0x0004`): the server's sensor channels of a step with
//! the per-contact states, and the threshold crossings and faults of a step.
//!
//! ```text
//! signals payload  size  field
//!               0     8  sequence          u64, the pose frame's sequence of the same step
//!               8     8  sim_time          f64, s (finite, ≥ 0)
//!              16     4  channel_count     u32, n ≤ MAX_CHANNELS (4096)
//!              20     4  contact_count     u32, k ≤ MAX_CONTACTS (4096)
//!              24     8  events_total      u64, events since the scene was (re)loaded
//!              32     4  faults_applied    u32, since (re)load
//!              36     4  faults_rejected   u32, since (re)load
//!              40  48·n  channel record × n
//!        40 + 48n 104·k  contact record × k
//!
//! channel record   size  field
//!               0    32  name              name field ([A-Za-z0-9_.-/], 1..=32 bytes, NUL-padded)
//!              32     4  flags             u32: bit 0 dropout (no reading; value 0); others 0
//!              36     4  reserved          0
//!              40     8  value             f64, finite, in the channel's unit (N, N m, m, %, count)
//!
//! contact record   size  field
//!               0     4  body_a            u32, body id (the normal points from A to B)
//!               4     4  body_b            u32, body id
//!               8     1  state             u8: 0 open, 1 stick, 2 slip
//!               9     7  reserved          0
//!              16    24  point             f64 × 3, on A, world frame (m)
//!              40     8  normal_force      f64, N, finite, ≥ 0
//!              48     8  friction_force    f64, N, finite, ≥ 0
//!              56    24  normal            f64 × 3, unit, A to B, world frame
//!              80    24  friction          f64 × 3, the friction force on B, world frame (N)
//!
//! events payload   size  field
//!               0     8  sequence          u64
//!               8     8  sim_time          f64, s (finite, ≥ 0)
//!              16     4  event_count       u32, n ≤ MAX_EVENTS (1024)
//!              20     4  reserved          0
//!              24     8  events_total      u64, since (re)load
//!              32  64·n  event record × n
//!
//! event record     size  field
//!               0    32  name              name field (the threshold's or fault's name)
//!              32     1  kind              u8: 0 raised, 1 cleared, 2 fault, 3 fault-rejected
//!              33     7  reserved          0
//!              40     8  time              f64, s, finite, ≥ 0
//!              48     8  value             f64, finite (the channel's value; a break's tension)
//!              56     8  level             f64, finite (the threshold; a break's limit)
//! ```

use crate::header::{self, DecodeError, FrameError, HEADER_LEN, Kind};
pub use crate::layout::{
    CHANNEL_RECORD_LEN, CONTACT_RECORD_LEN, EVENT_RECORD_LEN, EVENTS_FIXED_LEN, MAX_CHANNELS, MAX_CONTACTS,
    MAX_EVENTS, SIGNALS_FIXED_LEN,
};
use crate::le;
use crate::name::{ActuatorName, MAX_ACTUATOR_NAME_LEN, NameError};

/// Channel flag: the sensor dropped out (no reading; the value is 0).
pub const CHANNEL_DROPOUT: u32 = 1;

/// One sensor channel of a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SignalChannel {
    /// `{sensor}/{channel}`.
    pub name: ActuatorName,
    /// The sensor dropped out.
    pub dropout: bool,
    /// The reading (0 when `dropout`).
    pub value: f64,
}

/// Stick, slip or open.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum ContactCode {
    /// No normal force.
    #[default]
    Open = 0,
    /// Pressed, friction inside its cone.
    Stick = 1,
    /// Pressed, friction at its bound.
    Slip = 2,
}

impl ContactCode {
    /// From the wire code.
    pub fn from_code(c: u8) -> Option<ContactCode> {
        match c {
            0 => Some(ContactCode::Open),
            1 => Some(ContactCode::Stick),
            2 => Some(ContactCode::Slip),
            _ => None,
        }
    }
    /// Name in consoles.
    pub fn name(self) -> &'static str {
        match self {
            ContactCode::Open => "open",
            ContactCode::Stick => "stick",
            ContactCode::Slip => "slip",
        }
    }
}

/// One contact point of a step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ContactRecord {
    /// Body A.
    pub body_a: u32,
    /// Body B.
    pub body_b: u32,
    /// State.
    pub state: ContactCode,
    /// The point on A (world, m).
    pub point: [f64; 3],
    /// Normal force (N).
    pub normal_force: f64,
    /// Friction force (N, its magnitude).
    pub friction_force: f64,
    /// Unit normal from A to B (world).
    pub normal: [f64; 3],
    /// Friction force on B (world, N; A receives the opposite).
    pub friction: [f64; 3],
}

/// An owned signals frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SignalsFrame {
    /// Step sequence (same as the step's pose frame).
    pub sequence: u64,
    /// Simulation time (s).
    pub sim_time: f64,
    /// Events since the scene was (re)loaded.
    pub events_total: u64,
    /// Faults applied since (re)load.
    pub faults_applied: u32,
    /// Fault requests refused since (re)load.
    pub faults_rejected: u32,
    /// Channels.
    pub channels: Vec<SignalChannel>,
    /// Contact points.
    pub contacts: Vec<ContactRecord>,
}

/// What happened.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum EventCode {
    /// A threshold was crossed.
    #[default]
    Raised = 0,
    /// A threshold's channel came back.
    Cleared = 1,
    /// A fault took effect.
    Fault = 2,
    /// A fault request was refused.
    FaultRejected = 3,
    /// A lockstep controller appeared (its liveliness token; the name is its id).
    ControllerJoined = 4,
    /// A lockstep controller disappeared (the name is its id; `value` 1 when the server
    /// resumed real time, 0 when it stays paused).
    ControllerLost = 5,
}

impl EventCode {
    /// From the wire code.
    pub fn from_code(c: u8) -> Option<EventCode> {
        match c {
            0 => Some(EventCode::Raised),
            1 => Some(EventCode::Cleared),
            2 => Some(EventCode::Fault),
            3 => Some(EventCode::FaultRejected),
            4 => Some(EventCode::ControllerJoined),
            5 => Some(EventCode::ControllerLost),
            _ => None,
        }
    }
    /// Name in consoles.
    pub fn name(self) -> &'static str {
        match self {
            EventCode::Raised => "raised",
            EventCode::Cleared => "cleared",
            EventCode::Fault => "fault",
            EventCode::FaultRejected => "fault-rejected",
            EventCode::ControllerJoined => "controller-joined",
            EventCode::ControllerLost => "controller-lost",
        }
    }
}

/// One event.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EventRecord {
    /// The threshold's or fault's name.
    pub name: ActuatorName,
    /// What happened.
    pub kind: EventCode,
    /// When (s).
    pub time: f64,
    /// The value that crossed (a break's tension).
    pub value: f64,
    /// The threshold (a break's limit).
    pub level: f64,
}

/// An owned events frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct EventsFrame {
    /// Step sequence.
    pub sequence: u64,
    /// Simulation time (s).
    pub sim_time: f64,
    /// Events since the scene was (re)loaded.
    pub events_total: u64,
    /// This step's events.
    pub events: Vec<EventRecord>,
}

/// What is wrong with the content of a signals or events frame.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SignalsError {
    /// More than [`MAX_CHANNELS`], [`MAX_CONTACTS`] or [`MAX_EVENTS`] records.
    #[error("{count} {what} in one frame (at most {max})")]
    TooMany {
        /// Channels, contacts or events.
        what: &'static str,
        /// Records in the frame.
        count: usize,
        /// The bound.
        max: usize,
    },
    /// NaN or ±Inf (`record` is the record index, `None` for the frame's fields).
    #[error("non-finite {field} (record {record:?})")]
    NonFinite {
        /// Record index.
        record: Option<usize>,
        /// Field.
        field: &'static str,
    },
    /// A time or force below zero.
    #[error("negative {field} {value} (record {record:?})")]
    Negative {
        /// Record index.
        record: Option<usize>,
        /// Field.
        field: &'static str,
        /// The value.
        value: f64,
    },
    /// A bad name field.
    #[error("record {record}: {source}")]
    Name {
        /// Record index.
        record: usize,
        /// Why.
        source: NameError,
    },
    /// Undefined channel flag bits.
    #[error("channel record {record}: undefined flags 0x{flags:08x}")]
    ChannelFlags {
        /// Record index.
        record: usize,
        /// The flags.
        flags: u32,
    },
    /// A dropped-out channel with a value other than 0.
    #[error("channel record {record}: dropout with value {value}")]
    DropoutValue {
        /// Record index.
        record: usize,
        /// The value.
        value: f64,
    },
    /// Contact state or event kind code out of range.
    #[error("record {record}: unknown {what} code {code}")]
    UnknownCode {
        /// Record index.
        record: usize,
        /// `contact state` or `event kind`.
        what: &'static str,
        /// The code.
        code: u8,
    },
}

fn finite(record: Option<usize>, field: &'static str, v: f64) -> Result<(), SignalsError> {
    if v.is_finite() { Ok(()) } else { Err(SignalsError::NonFinite { record, field }) }
}

fn non_negative(record: Option<usize>, field: &'static str, v: f64) -> Result<(), SignalsError> {
    finite(record, field, v)?;
    if v < 0.0 { Err(SignalsError::Negative { record, field, value: v }) } else { Ok(()) }
}

fn name_at(p: &[u8], off: usize, record: usize) -> Result<ActuatorName, SignalsError> {
    let field: [u8; MAX_ACTUATOR_NAME_LEN] = le::array(p, off);
    ActuatorName::from_field(&field).map_err(|source| SignalsError::Name { record, source })
}

fn too_many(what: &'static str, count: usize, max: usize) -> Result<(), SignalsError> {
    if count > max { Err(SignalsError::TooMany { what, count, max }) } else { Ok(()) }
}

impl SignalChannel {
    fn validate(&self, i: usize) -> Result<(), SignalsError> {
        finite(Some(i), "value", self.value)?;
        if self.dropout && self.value != 0.0 {
            return Err(SignalsError::DropoutValue { record: i, value: self.value });
        }
        Ok(())
    }
}

impl ContactRecord {
    /// The contact force on body B, `normal_force · normal + friction` (world, N; A receives the
    /// opposite).
    pub fn force(&self) -> [f64; 3] {
        std::array::from_fn(|i| self.normal_force * self.normal[i] + self.friction[i])
    }

    fn validate(&self, i: usize) -> Result<(), SignalsError> {
        for v in self.point {
            finite(Some(i), "point", v)?;
        }
        non_negative(Some(i), "normal_force", self.normal_force)?;
        non_negative(Some(i), "friction_force", self.friction_force)?;
        for v in self.normal {
            finite(Some(i), "normal", v)?;
        }
        for v in self.friction {
            finite(Some(i), "friction", v)?;
        }
        Ok(())
    }
}

impl EventRecord {
    fn validate(&self, i: usize) -> Result<(), SignalsError> {
        non_negative(Some(i), "time", self.time)?;
        finite(Some(i), "value", self.value)?;
        finite(Some(i), "level", self.level)
    }
}

impl SignalsFrame {
    /// Frame length in bytes: `16 + 40 + 48 · channels + 104 · contacts`.
    pub fn encoded_len(&self) -> usize {
        HEADER_LEN
            + SIGNALS_FIXED_LEN
            + CHANNEL_RECORD_LEN * self.channels.len()
            + CONTACT_RECORD_LEN * self.contacts.len()
    }

    /// Checks every rule a decoder checks.
    pub fn validate(&self) -> Result<(), SignalsError> {
        too_many("channels", self.channels.len(), MAX_CHANNELS)?;
        too_many("contacts", self.contacts.len(), MAX_CONTACTS)?;
        non_negative(None, "sim_time", self.sim_time)?;
        self.channels.iter().enumerate().try_for_each(|(i, c)| c.validate(i))?;
        self.contacts.iter().enumerate().try_for_each(|(i, c)| c.validate(i))
    }

    /// Clears `buf` and writes the frame; allocates only if `buf` must grow. On error `buf` is
    /// left empty.
    pub fn encode(&self, buf: &mut Vec<u8>) -> Result<(), SignalsError> {
        buf.clear();
        self.validate()?;
        buf.reserve(self.encoded_len());
        header::begin(buf, Kind::Signals);
        buf.extend_from_slice(&self.sequence.to_le_bytes());
        le::put_f64s(buf, &[self.sim_time]);
        for v in [self.channels.len() as u32, self.contacts.len() as u32] {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        buf.extend_from_slice(&self.events_total.to_le_bytes());
        for v in [self.faults_applied, self.faults_rejected] {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        for c in &self.channels {
            buf.extend_from_slice(c.name.field());
            let flags = if c.dropout { CHANNEL_DROPOUT } else { 0 };
            buf.extend_from_slice(&flags.to_le_bytes());
            buf.extend_from_slice(&0u32.to_le_bytes());
            le::put_f64s(buf, &[c.value]);
        }
        for c in &self.contacts {
            buf.extend_from_slice(&c.body_a.to_le_bytes());
            buf.extend_from_slice(&c.body_b.to_le_bytes());
            buf.extend_from_slice(&[c.state as u8, 0, 0, 0, 0, 0, 0, 0]);
            le::put_f64s(buf, &c.point);
            le::put_f64s(buf, &[c.normal_force, c.friction_force]);
            le::put_f64s(buf, &c.normal);
            le::put_f64s(buf, &c.friction);
        }
        header::set_payload_len(buf);
        Ok(())
    }

    /// Decodes and validates a frame.
    pub fn decode(bytes: &[u8]) -> Result<SignalsFrame, DecodeError<SignalsError>> {
        let mut s = SignalsFrame::default();
        s.decode_into(bytes)?;
        Ok(s)
    }

    /// Decodes into `self`, reusing its vectors (no allocation once they have grown). On error
    /// `self` is unspecified but valid to reuse.
    pub fn decode_into(&mut self, bytes: &[u8]) -> Result<(), DecodeError<SignalsError>> {
        let kind = Kind::Signals;
        let p = header::expect(bytes, kind)?;
        if p.len() < SIGNALS_FIXED_LEN {
            return Err(
                FrameError::PayloadLength { kind, expected: SIGNALS_FIXED_LEN, found: p.len() }.into()
            );
        }
        let (n, k) = (le::u32_at(p, 16) as usize, le::u32_at(p, 20) as usize);
        too_many("channels", n, MAX_CHANNELS).map_err(DecodeError::Invalid)?;
        too_many("contacts", k, MAX_CONTACTS).map_err(DecodeError::Invalid)?;
        let expected = SIGNALS_FIXED_LEN + CHANNEL_RECORD_LEN * n + CONTACT_RECORD_LEN * k;
        if p.len() != expected {
            return Err(FrameError::PayloadLength { kind, expected, found: p.len() }.into());
        }
        self.sequence = le::u64_at(p, 0);
        self.sim_time = le::f64_at(p, 8);
        self.events_total = le::u64_at(p, 24);
        self.faults_applied = le::u32_at(p, 32);
        self.faults_rejected = le::u32_at(p, 36);
        non_negative(None, "sim_time", self.sim_time).map_err(DecodeError::Invalid)?;
        self.channels.clear();
        let ch_end = SIGNALS_FIXED_LEN + CHANNEL_RECORD_LEN * n;
        for (i, r) in p[SIGNALS_FIXED_LEN..ch_end].chunks_exact(CHANNEL_RECORD_LEN).enumerate() {
            let base = HEADER_LEN + SIGNALS_FIXED_LEN + i * CHANNEL_RECORD_LEN;
            let name = name_at(r, 0, i).map_err(DecodeError::Invalid)?;
            let flags = le::u32_at(r, 32);
            if flags & !CHANNEL_DROPOUT != 0 {
                return Err(DecodeError::Invalid(SignalsError::ChannelFlags { record: i, flags }));
            }
            header::check_reserved(r, 36..40, base)?;
            let c = SignalChannel { name, dropout: flags & CHANNEL_DROPOUT != 0, value: le::f64_at(r, 40) };
            c.validate(i).map_err(DecodeError::Invalid)?;
            self.channels.push(c);
        }
        self.contacts.clear();
        for (i, r) in p[ch_end..].chunks_exact(CONTACT_RECORD_LEN).enumerate() {
            let base = HEADER_LEN + ch_end + i * CONTACT_RECORD_LEN;
            let code = r[8];
            let state =
                ContactCode::from_code(code).ok_or(DecodeError::Invalid(SignalsError::UnknownCode {
                    record: i,
                    what: "contact state",
                    code,
                }))?;
            header::check_reserved(r, 9..16, base)?;
            let [nf, ff] = le::f64s_at::<2>(r, 40);
            let c = ContactRecord {
                body_a: le::u32_at(r, 0),
                body_b: le::u32_at(r, 4),
                state,
                point: le::f64s_at::<3>(r, 16),
                normal_force: nf,
                friction_force: ff,
                normal: le::f64s_at::<3>(r, 56),
                friction: le::f64s_at::<3>(r, 80),
            };
            c.validate(i).map_err(DecodeError::Invalid)?;
            self.contacts.push(c);
        }
        Ok(())
    }
}

impl EventsFrame {
    /// Frame length in bytes: `16 + 32 + 64 · events`.
    pub fn encoded_len(&self) -> usize {
        HEADER_LEN + EVENTS_FIXED_LEN + EVENT_RECORD_LEN * self.events.len()
    }

    /// Checks every rule a decoder checks.
    pub fn validate(&self) -> Result<(), SignalsError> {
        too_many("events", self.events.len(), MAX_EVENTS)?;
        non_negative(None, "sim_time", self.sim_time)?;
        self.events.iter().enumerate().try_for_each(|(i, e)| e.validate(i))
    }

    /// Clears `buf` and writes the frame. On error `buf` is left empty.
    pub fn encode(&self, buf: &mut Vec<u8>) -> Result<(), SignalsError> {
        buf.clear();
        self.validate()?;
        buf.reserve(self.encoded_len());
        header::begin(buf, Kind::Events);
        buf.extend_from_slice(&self.sequence.to_le_bytes());
        le::put_f64s(buf, &[self.sim_time]);
        buf.extend_from_slice(&(self.events.len() as u32).to_le_bytes());
        buf.extend_from_slice(&0u32.to_le_bytes());
        buf.extend_from_slice(&self.events_total.to_le_bytes());
        for e in &self.events {
            buf.extend_from_slice(e.name.field());
            buf.extend_from_slice(&[e.kind as u8, 0, 0, 0, 0, 0, 0, 0]);
            le::put_f64s(buf, &[e.time, e.value, e.level]);
        }
        header::set_payload_len(buf);
        Ok(())
    }

    /// Decodes and validates a frame.
    pub fn decode(bytes: &[u8]) -> Result<EventsFrame, DecodeError<SignalsError>> {
        let mut s = EventsFrame::default();
        s.decode_into(bytes)?;
        Ok(s)
    }

    /// Decodes into `self`, reusing its vector.
    pub fn decode_into(&mut self, bytes: &[u8]) -> Result<(), DecodeError<SignalsError>> {
        let kind = Kind::Events;
        let p = header::expect(bytes, kind)?;
        if p.len() < EVENTS_FIXED_LEN {
            return Err(FrameError::PayloadLength { kind, expected: EVENTS_FIXED_LEN, found: p.len() }.into());
        }
        let n = le::u32_at(p, 16) as usize;
        too_many("events", n, MAX_EVENTS).map_err(DecodeError::Invalid)?;
        let expected = EVENTS_FIXED_LEN + EVENT_RECORD_LEN * n;
        if p.len() != expected {
            return Err(FrameError::PayloadLength { kind, expected, found: p.len() }.into());
        }
        header::check_reserved(p, 20..24, HEADER_LEN)?;
        self.sequence = le::u64_at(p, 0);
        self.sim_time = le::f64_at(p, 8);
        self.events_total = le::u64_at(p, 24);
        non_negative(None, "sim_time", self.sim_time).map_err(DecodeError::Invalid)?;
        self.events.clear();
        for (i, r) in p[EVENTS_FIXED_LEN..].chunks_exact(EVENT_RECORD_LEN).enumerate() {
            let base = HEADER_LEN + EVENTS_FIXED_LEN + i * EVENT_RECORD_LEN;
            let name = name_at(r, 0, i).map_err(DecodeError::Invalid)?;
            let code = r[32];
            let kind = EventCode::from_code(code).ok_or(DecodeError::Invalid(SignalsError::UnknownCode {
                record: i,
                what: "event kind",
                code,
            }))?;
            header::check_reserved(r, 33..40, base)?;
            let [time, value, level] = le::f64s_at::<3>(r, 40);
            let e = EventRecord { name, kind, time, value, level };
            e.validate(i).map_err(DecodeError::Invalid)?;
            self.events.push(e);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> SignalsFrame {
        SignalsFrame {
            sequence: 9,
            sim_time: 0.15,
            events_total: 2,
            faults_applied: 1,
            faults_rejected: 0,
            channels: vec![
                SignalChannel {
                    name: ActuatorName::new("hoist/hook").unwrap(),
                    dropout: false,
                    value: 19620.0,
                },
                SignalChannel { name: ActuatorName::new("lmi/percent").unwrap(), dropout: true, value: 0.0 },
            ],
            contacts: vec![ContactRecord {
                body_a: 1,
                body_b: 0,
                state: ContactCode::Slip,
                point: [1.0, -2.0, 0.0],
                normal_force: 100.0,
                friction_force: 50.0,
                normal: [0.0, 0.0, 1.0],
                friction: [0.0, 50.0, 0.0],
            }],
        }
    }

    #[test]
    fn round_trips_and_rejects_bad_records() {
        let s = sample();
        let mut b = Vec::new();
        s.encode(&mut b).unwrap();
        assert_eq!(b.len(), s.encoded_len());
        assert_eq!(SignalsFrame::decode(&b).unwrap(), s);
        let ch = HEADER_LEN + SIGNALS_FIXED_LEN;
        let mut x = b.clone();
        x[ch + 32] = 2;
        assert!(matches!(
            SignalsFrame::decode(&x),
            Err(DecodeError::Invalid(SignalsError::ChannelFlags { .. }))
        ));
        let mut x = b.clone();
        x[ch + CHANNEL_RECORD_LEN + 40..ch + CHANNEL_RECORD_LEN + 48].copy_from_slice(&1.0f64.to_le_bytes());
        assert!(matches!(
            SignalsFrame::decode(&x),
            Err(DecodeError::Invalid(SignalsError::DropoutValue { .. }))
        ));
        let ct = ch + 2 * CHANNEL_RECORD_LEN;
        let mut x = b.clone();
        x[ct + 8] = 3;
        assert!(matches!(
            SignalsFrame::decode(&x),
            Err(DecodeError::Invalid(SignalsError::UnknownCode { .. }))
        ));
        let mut x = b.clone();
        x[ct + 9] = 1;
        assert_eq!(SignalsFrame::decode(&x), Err(FrameError::ReservedNonZero { offset: ct + 9 }.into()));
        let mut x = b.clone();
        x[ct + 40..ct + 48].copy_from_slice(&(-1.0f64).to_le_bytes());
        assert!(matches!(SignalsFrame::decode(&x), Err(DecodeError::Invalid(SignalsError::Negative { .. }))));
        for (at, field) in [(56, "normal"), (80 + 16, "friction")] {
            let mut x = b.clone();
            x[ct + at..ct + at + 8].copy_from_slice(&f64::NAN.to_le_bytes());
            assert_eq!(
                SignalsFrame::decode(&x),
                Err(DecodeError::Invalid(SignalsError::NonFinite { record: Some(0), field }))
            );
        }
        let mut x = b.clone();
        x[ch] = b' ';
        assert!(matches!(SignalsFrame::decode(&x), Err(DecodeError::Invalid(SignalsError::Name { .. }))));
        let mut bad = s.clone();
        bad.channels[0].value = f64::NAN;
        assert!(bad.encode(&mut b).is_err() && b.is_empty());
    }

    #[test]
    fn events_round_trip() {
        let e = EventsFrame {
            sequence: 4,
            sim_time: 2.0,
            events_total: 7,
            events: vec![EventRecord {
                name: ActuatorName::new("rope-parted").unwrap(),
                kind: EventCode::Fault,
                time: 2.0,
                value: 1997.0,
                level: 1962.0,
            }],
        };
        let mut b = Vec::new();
        e.encode(&mut b).unwrap();
        assert_eq!(b.len(), e.encoded_len());
        assert_eq!(EventsFrame::decode(&b).unwrap(), e);
        let mut x = b.clone();
        x[HEADER_LEN + EVENTS_FIXED_LEN + 32] = 6;
        assert!(matches!(
            EventsFrame::decode(&x),
            Err(DecodeError::Invalid(SignalsError::UnknownCode { .. }))
        ));
        let mut x = b.clone();
        x[HEADER_LEN + 20] = 1;
        assert_eq!(
            EventsFrame::decode(&x),
            Err(FrameError::ReservedNonZero { offset: HEADER_LEN + 20 }.into())
        );
    }
}
