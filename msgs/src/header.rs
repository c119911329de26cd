//! The 16-byte frame header shared by every message, the message kinds and frame-level errors.
//!
//! ```text
//! offset size field
//!      0    4 magic            b"PVSM"
//!      4    2 version          u16 LE, FORMAT_VERSION (5)
//!      6    2 kind             u16 LE, Kind code
//!      8    4 payload_len      u32 LE, bytes after the header
//!     12    4 flags            u32 LE, reserved: 0 in this version
//!     16    … payload          payload_len bytes
//! ```
//!
//! A frame is exactly `16 + payload_len` bytes: a shorter buffer is truncated, a longer one has
//! trailing bytes; both are errors. Kinds `0x0001..=0x00FF` carry a little-endian binary payload,
//! kinds `0x0100..=0x01FF` a UTF-8 JSON object. Checks run in the order of the table above, so the
//! payload length is bounded by [`Kind::max_payload_len`] before any payload byte is looked at.

use crate::le;

/// First four bytes of every frame.
pub const MAGIC: [u8; 4] = *b"PVSM";
/// Version written by this crate and the only one it decodes.
pub const FORMAT_VERSION: u16 = 5;
/// Bytes of the header.
pub const HEADER_LEN: usize = 16;
/// Largest frame of any kind, header included (16 MiB).
pub const MAX_FRAME_LEN: usize = 16 * 1024 * 1024;

/// What a frame carries; the code is the `kind` field of the header.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u16)]
pub enum Kind {
    /// [`PoseFrame`](crate::PoseFrame), binary.
    PoseFrame = 0x0001,
    /// [`SolverStats`](crate::SolverStats), binary.
    SolverStats = 0x0002,
    /// [`SignalsFrame`](crate::SignalsFrame), binary.
    Signals = 0x0003,
    /// [`EventsFrame`](crate::EventsFrame), binary.
    Events = 0x0004,
    /// [`AppliedFrame`](crate::AppliedFrame), binary.
    Applied = 0x0005,
    /// [`KeyframeView`](crate::KeyframeView), binary.
    Keyframe = 0x0006,
    /// [`Joystick`](crate::Joystick), binary.
    Joystick = 0x0010,
    /// [`WinchCommand`](crate::WinchCommand), binary.
    Winch = 0x0011,
    /// [`BoomCommand`](crate::BoomCommand), binary.
    Boom = 0x0012,
    /// [`ActuatorCommand`](crate::ActuatorCommand), binary.
    Actuator = 0x0013,
    /// [`ControlRequest`](crate::ControlRequest), JSON.
    ControlRequest = 0x0100,
    /// [`ControlReply`](crate::ControlReply), JSON.
    ControlReply = 0x0101,
    /// [`SceneDescription`](crate::SceneDescription), JSON.
    SceneDescription = 0x0102,
}

impl Kind {
    /// Every kind of this version, in code order.
    pub const ALL: [Kind; 13] = [
        Kind::PoseFrame,
        Kind::SolverStats,
        Kind::Signals,
        Kind::Events,
        Kind::Applied,
        Kind::Keyframe,
        Kind::Joystick,
        Kind::Winch,
        Kind::Boom,
        Kind::Actuator,
        Kind::ControlRequest,
        Kind::ControlReply,
        Kind::SceneDescription,
    ];

    /// The header code.
    #[inline]
    pub fn code(self) -> u16 {
        self as u16
    }

    /// The kind of a header code, if this version knows it.
    pub fn from_code(code: u16) -> Option<Kind> {
        Kind::ALL.into_iter().find(|k| k.code() == code)
    }

    /// Name used in logs and errors.
    pub fn name(self) -> &'static str {
        match self {
            Kind::PoseFrame => "pose-frame",
            Kind::SolverStats => "solver-stats",
            Kind::Signals => "signals",
            Kind::Events => "events",
            Kind::Applied => "applied",
            Kind::Keyframe => "keyframe",
            Kind::Joystick => "joystick",
            Kind::Winch => "winch",
            Kind::Boom => "boom",
            Kind::Actuator => "actuator",
            Kind::ControlRequest => "control-request",
            Kind::ControlReply => "control-reply",
            Kind::SceneDescription => "scene-description",
        }
    }

    /// Whether the payload is UTF-8 JSON (codes `0x0100..=0x01FF`) rather than binary.
    #[inline]
    pub fn is_json(self) -> bool {
        self.code() & 0xFF00 == 0x0100
    }

    /// Largest payload a valid frame of this kind can have (bytes after the header).
    pub fn max_payload_len(self) -> usize {
        use crate::layout::*;
        match self {
            Kind::PoseFrame => POSE_FIXED_LEN + BODY_RECORD_LEN * MAX_BODIES,
            Kind::SolverStats => STATS_FIXED_LEN + ISLAND_RECORD_LEN * MAX_ISLANDS,
            Kind::Signals => {
                SIGNALS_FIXED_LEN + CHANNEL_RECORD_LEN * MAX_CHANNELS + CONTACT_RECORD_LEN * MAX_CONTACTS
            }
            Kind::Events => EVENTS_FIXED_LEN + EVENT_RECORD_LEN * MAX_EVENTS,
            Kind::Applied => {
                use crate::journal::*;
                APPLIED_FIXED_LEN + MAX_APPLIED * (APPLIED_RECORD_HEAD_LEN + MAX_APPLIED_RECORD_LEN)
            }
            Kind::Keyframe => MAX_FRAME_LEN - HEADER_LEN,
            Kind::Joystick => JOYSTICK_LEN,
            Kind::Winch => WINCH_LEN,
            Kind::Boom => BOOM_FIXED_LEN + BOOM_ENTRY_LEN * MAX_BOOM_TARGETS,
            Kind::Actuator => ACTUATOR_LEN,
            Kind::ControlRequest => 4096,
            Kind::ControlReply => 16384,
            Kind::SceneDescription => MAX_FRAME_LEN - HEADER_LEN,
        }
    }
}

impl std::fmt::Display for Kind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} (0x{:04x})", self.name(), self.code())
    }
}

/// A parsed, checked header: the frame it came from is exactly `16 + payload_len` bytes long.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Header {
    /// Message kind.
    pub kind: Kind,
    /// Bytes after the header.
    pub payload_len: usize,
}

/// Why a buffer is not a well-formed frame (header, length or payload layout).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// The buffer ends before the header or the declared payload does.
    #[error("truncated frame: {needed} bytes needed, {available} available")]
    Truncated {
        /// Bytes the header (or header + declared payload) needs.
        needed: usize,
        /// Bytes in the buffer.
        available: usize,
    },
    /// The buffer is longer than header + declared payload.
    #[error("trailing bytes: frame is {expected} bytes, buffer has {available}")]
    TrailingBytes {
        /// `16 + payload_len`.
        expected: usize,
        /// Bytes in the buffer.
        available: usize,
    },
    /// The first four bytes are not `PVSM`.
    #[error("bad magic {found:02x?} (expected \"PVSM\")")]
    BadMagic {
        /// The first four bytes.
        found: [u8; 4],
    },
    /// A version this crate does not decode.
    #[error("unsupported format version {found} (this decoder reads {FORMAT_VERSION})")]
    UnsupportedVersion {
        /// Version field.
        found: u16,
    },
    /// A kind code this version does not define.
    #[error("unknown message kind 0x{found:04x}")]
    UnknownKind {
        /// Kind field.
        found: u16,
    },
    /// A valid kind, but not the one the decoder was asked for.
    #[error("expected a {expected} frame, got {found}")]
    WrongKind {
        /// Kind the decoder reads.
        expected: Kind,
        /// Kind in the header.
        found: Kind,
    },
    /// An input decoder got a frame of a kind that is not an input.
    #[error("expected an input frame (0x0010..=0x0013), got {found}")]
    NotAnInput {
        /// Kind in the header.
        found: Kind,
    },
    /// Reserved flag bits set.
    #[error("reserved header flags 0x{found:08x} set (must be 0 in version {FORMAT_VERSION})")]
    Flags {
        /// Flags field.
        found: u32,
    },
    /// The declared payload exceeds the maximum for its kind.
    #[error("{kind} payload of {declared} bytes exceeds the maximum of {max}")]
    PayloadTooLarge {
        /// Kind in the header.
        kind: Kind,
        /// Declared payload length.
        declared: usize,
        /// [`Kind::max_payload_len`].
        max: usize,
    },
    /// A binary payload whose length does not match the layout its own counts imply.
    #[error("{kind} payload is {found} bytes, its layout needs {expected}")]
    PayloadLength {
        /// Kind in the header.
        kind: Kind,
        /// Length implied by the fixed part and the record count.
        expected: usize,
        /// Declared payload length.
        found: usize,
    },
    /// A reserved or padding byte is not zero (offset from the start of the frame).
    #[error("reserved byte at frame offset {offset} is not zero")]
    ReservedNonZero {
        /// Offset of the first offending byte.
        offset: usize,
    },
    /// A JSON payload that does not parse into the kind's schema.
    #[error("invalid JSON payload at line {line}, column {column}: {message}")]
    Json {
        /// 1-based line (0 when unknown).
        line: usize,
        /// 1-based column (0 when unknown).
        column: usize,
        /// The parser's message.
        message: String,
    },
}

/// Decoding a frame of one message family: either the frame is malformed, or its content breaks
/// the family's rules (`E`: [`PoseError`](crate::PoseError), [`InputError`](crate::InputError), …).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DecodeError<E: std::error::Error + 'static> {
    /// Header, length or payload layout.
    #[error(transparent)]
    Frame(#[from] FrameError),
    /// Content: non-finite values, out-of-range fields, names, counts.
    #[error(transparent)]
    Invalid(E),
}

impl<E: std::error::Error + 'static> DecodeError<E> {
    /// The content error, if that is what this is.
    pub fn invalid(&self) -> Option<&E> {
        match self {
            DecodeError::Invalid(e) => Some(e),
            DecodeError::Frame(_) => None,
        }
    }

    /// The frame error, if that is what this is.
    pub fn frame(&self) -> Option<&FrameError> {
        match self {
            DecodeError::Frame(e) => Some(e),
            DecodeError::Invalid(_) => None,
        }
    }
}

/// Reads and checks the header of `bytes` (magic, version, kind, flags, payload bound, exact length)
/// without looking at the payload. Use it to route a frame by kind.
pub fn peek(bytes: &[u8]) -> Result<Header, FrameError> {
    if bytes.len() < HEADER_LEN {
        return Err(FrameError::Truncated { needed: HEADER_LEN, available: bytes.len() });
    }
    let magic = le::array::<4>(bytes, 0);
    if magic != MAGIC {
        return Err(FrameError::BadMagic { found: magic });
    }
    let version = le::u16_at(bytes, 4);
    if version != FORMAT_VERSION {
        return Err(FrameError::UnsupportedVersion { found: version });
    }
    let code = le::u16_at(bytes, 6);
    let kind = Kind::from_code(code).ok_or(FrameError::UnknownKind { found: code })?;
    let flags = le::u32_at(bytes, 12);
    if flags != 0 {
        return Err(FrameError::Flags { found: flags });
    }
    let declared = le::u32_at(bytes, 8) as usize;
    let max = kind.max_payload_len();
    if declared > max {
        return Err(FrameError::PayloadTooLarge { kind, declared, max });
    }
    let expected = HEADER_LEN + declared;
    if bytes.len() < expected {
        return Err(FrameError::Truncated { needed: expected, available: bytes.len() });
    }
    if bytes.len() > expected {
        return Err(FrameError::TrailingBytes { expected, available: bytes.len() });
    }
    Ok(Header { kind, payload_len: declared })
}

/// [`peek`] and require `expected`; returns the payload.
pub fn expect(bytes: &[u8], expected: Kind) -> Result<&[u8], FrameError> {
    let h = peek(bytes)?;
    if h.kind != expected {
        return Err(FrameError::WrongKind { expected, found: h.kind });
    }
    Ok(&bytes[HEADER_LEN..])
}

/// Clears `buf` and writes a header with `payload_len = 0`; [`set_payload_len`] patches it.
pub(crate) fn begin(buf: &mut Vec<u8>, kind: Kind) {
    buf.clear();
    buf.extend_from_slice(&MAGIC);
    buf.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    buf.extend_from_slice(&kind.code().to_le_bytes());
    buf.extend_from_slice(&0u32.to_le_bytes());
    buf.extend_from_slice(&0u32.to_le_bytes());
}

/// Sets the header's payload length to `buf.len() - 16`.
pub(crate) fn set_payload_len(buf: &mut [u8]) {
    let len = buf.len() - HEADER_LEN;
    le::patch_u32(buf, 8, len as u32);
}

/// Checks that `payload` (starting at frame offset `base`) is zero from `range.start` to
/// `range.end` (payload offsets).
pub(crate) fn check_reserved(
    payload: &[u8],
    range: std::ops::Range<usize>,
    base: usize,
) -> Result<(), FrameError> {
    match le::first_non_zero(&payload[range.clone()]) {
        Some(i) => Err(FrameError::ReservedNonZero { offset: base + range.start + i }),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(kind: u16, payload: &[u8]) -> Vec<u8> {
        let mut b = Vec::new();
        b.extend_from_slice(b"PVSM");
        b.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        b.extend_from_slice(&kind.to_le_bytes());
        b.extend_from_slice(&(payload.len() as u32).to_le_bytes());
        b.extend_from_slice(&0u32.to_le_bytes());
        b.extend_from_slice(payload);
        b
    }

    #[test]
    fn codes_round_trip_and_json_range() {
        for k in Kind::ALL {
            assert_eq!(Kind::from_code(k.code()), Some(k));
            assert_eq!(k.is_json(), k.code() >= 0x100);
            assert!(HEADER_LEN + k.max_payload_len() <= MAX_FRAME_LEN, "{k}");
        }
        assert_eq!(Kind::from_code(0x0007), None);
    }

    #[test]
    fn header_checks_in_order() {
        let ok = frame(0x0011, &[0; 56]);
        assert_eq!(peek(&ok), Ok(Header { kind: Kind::Winch, payload_len: 56 }));
        let mut b = ok.clone();
        b[0] = b'X';
        assert!(matches!(peek(&b), Err(FrameError::BadMagic { .. })));
        let mut b = ok.clone();
        b[4] = 3;
        assert_eq!(peek(&b), Err(FrameError::UnsupportedVersion { found: 3 }));
        let mut b = ok.clone();
        b[6] = 0x77;
        assert_eq!(peek(&b), Err(FrameError::UnknownKind { found: 0x77 }));
        let mut b = ok.clone();
        b[15] = 1;
        assert_eq!(peek(&b), Err(FrameError::Flags { found: 1 << 24 }));
        let mut b = ok.clone();
        b[8] = 57;
        assert!(matches!(peek(&b), Err(FrameError::PayloadTooLarge { declared: 57, max: 56, .. })));
        b[8] = 55;
        assert_eq!(peek(&b), Err(FrameError::TrailingBytes { expected: 71, available: 72 }));
        assert_eq!(peek(&ok[..40]), Err(FrameError::Truncated { needed: 72, available: 40 }));
        assert_eq!(peek(&ok[..3]), Err(FrameError::Truncated { needed: 16, available: 3 }));
        assert_eq!(
            expect(&ok, Kind::Boom),
            Err(FrameError::WrongKind { expected: Kind::Boom, found: Kind::Winch })
        );
    }
}
