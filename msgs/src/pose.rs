//! Pose frame (kind `0x0001`): every body's pose and velocity at one step, the high-rate stream.
//!
//! ```text
//! payload offset  size  field
//!              0     8  sequence        u64, +1 per published step
//!              8     8  sim_time        f64, s (finite, ≥ 0)
//!             16     8  wall_time_ns    u64, ns since the UNIX epoch when the step ended
//!             24     4  body_count      u32, ≤ MAX_BODIES (65 535)
//!             28     4  reserved        0
//!             32   112  body record × body_count
//!
//! body record     size  field
//!              0     4  id              u32, body id of the scene description
//!              4     4  flags           u32: bit 0 asleep, bit 1 kinematic, bit 2 static
//!              8    24  position        f64 × 3, m, world frame (origin of the body frame)
//!             32    32  orientation     f64 × 4, unit quaternion (x, y, z, w), body → world
//!             64    24  linear_velocity f64 × 3, m/s, world frame, of the body frame origin
//!             88    24  angular_velocity f64 × 3, rad/s, world frame
//! ```
//!
//! Every record is 112 bytes and every `f64` sits at a multiple of 8 from the frame start, so the
//! same bytes go over Zenoh and into an iceoryx2 `[u8]` sample unchanged. [`BodyPose`] is
//! `#[repr(C)]` with exactly this layout on a little-endian machine, but this crate never casts:
//! [`PoseFrameView`] validates a byte slice once and then yields [`BodyPose`] values by reading
//! fields, with no allocation (the subscriber hot path); [`PoseFrameWriter`] appends records to a
//! reused buffer (the publisher hot path).

use crate::header::{self, DecodeError, FrameError, HEADER_LEN, Kind};
pub use crate::layout::{BODY_RECORD_LEN, MAX_BODIES, POSE_FIXED_LEN};
use crate::le;

/// Largest accepted `| ‖q‖ − 1 |` of an orientation quaternion.
pub const QUAT_NORM_TOLERANCE: f64 = 1e-6;
/// Body flag: the body sleeps (pose unchanged, velocities zero).
pub const BODY_ASLEEP: u32 = 1 << 0;
/// Body flag: the body is kinematic (scripted velocity, infinite mass).
pub const BODY_KINEMATIC: u32 = 1 << 1;
/// Body flag: the body is static (never moves).
pub const BODY_STATIC: u32 = 1 << 2;
/// Every defined body flag; the others must be zero.
pub const BODY_FLAGS_KNOWN: u32 = BODY_ASLEEP | BODY_KINEMATIC | BODY_STATIC;

/// One body of a pose frame; the field order and sizes are the wire record.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C)]
pub struct BodyPose {
    /// Body id (see the scene description).
    pub id: u32,
    /// `BODY_*` flags.
    pub flags: u32,
    /// Origin of the body frame in world coordinates (m).
    pub position: [f64; 3],
    /// Unit quaternion `(x, y, z, w)` rotating body coordinates into world coordinates.
    pub orientation: [f64; 4],
    /// Velocity of the body frame origin, world frame (m/s).
    pub linear_velocity: [f64; 3],
    /// Angular velocity, world frame (rad/s).
    pub angular_velocity: [f64; 3],
}

impl Default for BodyPose {
    fn default() -> Self {
        BodyPose {
            id: 0,
            flags: 0,
            position: [0.0; 3],
            orientation: [0.0, 0.0, 0.0, 1.0],
            linear_velocity: [0.0; 3],
            angular_velocity: [0.0; 3],
        }
    }
}

/// What is wrong with the content of a pose frame (from `encode`, `validate` or a decoder).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PoseError {
    /// More than [`MAX_BODIES`] bodies.
    #[error("{count} bodies in one frame (at most {MAX_BODIES})")]
    TooManyBodies {
        /// Bodies in the frame.
        count: usize,
    },
    /// NaN or ±Inf in a field (`body` is the record index, `None` for the frame's own fields).
    #[error("non-finite {field} (body record {body:?})")]
    NonFinite {
        /// Record index.
        body: Option<usize>,
        /// Field name.
        field: &'static str,
    },
    /// Simulation time below zero.
    #[error("negative sim_time {value}")]
    NegativeSimTime {
        /// The value.
        value: f64,
    },
    /// `| ‖q‖ − 1 | > QUAT_NORM_TOLERANCE`.
    #[error("body record {body}: orientation norm {norm} is not 1 (tolerance {QUAT_NORM_TOLERANCE})")]
    NonUnitQuaternion {
        /// Record index.
        body: usize,
        /// `‖q‖`.
        norm: f64,
    },
    /// Undefined flag bits, or kinematic and static together.
    #[error("body record {body}: invalid flags 0x{flags:08x}")]
    BodyFlags {
        /// Record index.
        body: usize,
        /// The flags.
        flags: u32,
    },
}

fn finite(x: &[f64]) -> bool {
    x.iter().all(|v| v.is_finite())
}

fn check_time(sim_time: f64) -> Result<(), PoseError> {
    if !sim_time.is_finite() {
        return Err(PoseError::NonFinite { body: None, field: "sim_time" });
    }
    if sim_time < 0.0 {
        return Err(PoseError::NegativeSimTime { value: sim_time });
    }
    Ok(())
}

impl BodyPose {
    /// Checks flags, finiteness and the quaternion norm (`index` names the record in errors).
    pub fn validate(&self, index: usize) -> Result<(), PoseError> {
        let f = self.flags;
        if f & !BODY_FLAGS_KNOWN != 0 || f & (BODY_KINEMATIC | BODY_STATIC) == BODY_KINEMATIC | BODY_STATIC {
            return Err(PoseError::BodyFlags { body: index, flags: f });
        }
        let fields: [(&'static str, &[f64]); 4] = [
            ("position", &self.position),
            ("orientation", &self.orientation),
            ("linear_velocity", &self.linear_velocity),
            ("angular_velocity", &self.angular_velocity),
        ];
        for (field, x) in fields {
            if !finite(x) {
                return Err(PoseError::NonFinite { body: Some(index), field });
            }
        }
        let norm = self.orientation.iter().map(|v| v * v).sum::<f64>().sqrt();
        if (norm - 1.0).abs() > QUAT_NORM_TOLERANCE {
            return Err(PoseError::NonUnitQuaternion { body: index, norm });
        }
        Ok(())
    }

    /// Reads a record (`r` is exactly [`BODY_RECORD_LEN`] bytes); no checks.
    #[inline]
    fn read(r: &[u8]) -> BodyPose {
        BodyPose {
            id: le::u32_at(r, 0),
            flags: le::u32_at(r, 4),
            position: le::f64s_at(r, 8),
            orientation: le::f64s_at(r, 32),
            linear_velocity: le::f64s_at(r, 64),
            angular_velocity: le::f64s_at(r, 88),
        }
    }

    /// Appends the record to `buf`; no checks.
    #[inline]
    fn write(&self, buf: &mut Vec<u8>) {
        buf.extend_from_slice(&self.id.to_le_bytes());
        buf.extend_from_slice(&self.flags.to_le_bytes());
        le::put_f64s(buf, &self.position);
        le::put_f64s(buf, &self.orientation);
        le::put_f64s(buf, &self.linear_velocity);
        le::put_f64s(buf, &self.angular_velocity);
    }
}

/// An owned pose frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PoseFrame {
    /// Step sequence number.
    pub sequence: u64,
    /// Simulation time (s).
    pub sim_time: f64,
    /// Wall clock when the step ended (ns since the UNIX epoch).
    pub wall_time_ns: u64,
    /// Body records, in publication order.
    pub bodies: Vec<BodyPose>,
}

impl PoseFrame {
    /// Frame length in bytes: `16 + 32 + 112 · bodies`.
    pub fn encoded_len(&self) -> usize {
        HEADER_LEN + POSE_FIXED_LEN + BODY_RECORD_LEN * self.bodies.len()
    }

    /// Checks every rule a decoder checks.
    pub fn validate(&self) -> Result<(), PoseError> {
        if self.bodies.len() > MAX_BODIES {
            return Err(PoseError::TooManyBodies { count: self.bodies.len() });
        }
        check_time(self.sim_time)?;
        self.bodies.iter().enumerate().try_for_each(|(i, b)| b.validate(i))
    }

    /// Clears `buf` and writes the frame; allocates only if `buf` must grow. On error `buf` is
    /// left empty.
    pub fn encode(&self, buf: &mut Vec<u8>) -> Result<(), PoseError> {
        if self.bodies.len() > MAX_BODIES {
            buf.clear();
            return Err(PoseError::TooManyBodies { count: self.bodies.len() });
        }
        buf.clear();
        buf.reserve(self.encoded_len());
        let mut w = PoseFrameWriter::begin(buf, self.sequence, self.sim_time, self.wall_time_ns)?;
        for b in &self.bodies {
            if let Err(e) = w.push(b) {
                w.buf.clear();
                return Err(e);
            }
        }
        Ok(())
    }

    /// Decodes and validates a frame.
    pub fn decode(bytes: &[u8]) -> Result<PoseFrame, DecodeError<PoseError>> {
        let mut f = PoseFrame::default();
        f.decode_into(bytes)?;
        Ok(f)
    }

    /// Decodes into `self`, reusing its body vector (no allocation once it has grown). On error
    /// `self` is unspecified but valid to reuse.
    pub fn decode_into(&mut self, bytes: &[u8]) -> Result<(), DecodeError<PoseError>> {
        let view = PoseFrameView::parse(bytes)?;
        self.sequence = view.sequence();
        self.sim_time = view.sim_time();
        self.wall_time_ns = view.wall_time_ns();
        self.bodies.clear();
        self.bodies.extend(view.bodies());
        Ok(())
    }
}

/// Writes a pose frame record by record into a reused buffer, with no intermediate vector.
///
/// After `begin` and after every successful `push` the buffer holds a complete, valid frame (the
/// body count and payload length are patched as records are appended).
#[derive(Debug)]
pub struct PoseFrameWriter<'b> {
    buf: &'b mut Vec<u8>,
    count: usize,
}

impl<'b> PoseFrameWriter<'b> {
    /// Clears `buf` and writes the header and fixed part of a frame with no bodies.
    pub fn begin(
        buf: &'b mut Vec<u8>,
        sequence: u64,
        sim_time: f64,
        wall_time_ns: u64,
    ) -> Result<Self, PoseError> {
        if let Err(e) = check_time(sim_time) {
            buf.clear();
            return Err(e);
        }
        header::begin(buf, Kind::PoseFrame);
        buf.extend_from_slice(&sequence.to_le_bytes());
        buf.extend_from_slice(&sim_time.to_le_bytes());
        buf.extend_from_slice(&wall_time_ns.to_le_bytes());
        buf.extend_from_slice(&0u32.to_le_bytes());
        buf.extend_from_slice(&0u32.to_le_bytes());
        header::set_payload_len(buf);
        Ok(PoseFrameWriter { buf, count: 0 })
    }

    /// Validates and appends one body; on error nothing is appended.
    pub fn push(&mut self, body: &BodyPose) -> Result<(), PoseError> {
        if self.count == MAX_BODIES {
            return Err(PoseError::TooManyBodies { count: self.count + 1 });
        }
        body.validate(self.count)?;
        body.write(self.buf);
        self.count += 1;
        le::patch_u32(self.buf, HEADER_LEN + 24, self.count as u32);
        header::set_payload_len(self.buf);
        Ok(())
    }

    /// Bodies written so far.
    pub fn len(&self) -> usize {
        self.count
    }

    /// Whether no body has been written.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// The frame as written so far (complete and valid).
    pub fn as_bytes(&self) -> &[u8] {
        self.buf
    }

    /// The finished frame.
    pub fn finish(self) -> &'b [u8] {
        self.buf
    }
}

/// A validated pose frame borrowed from a byte slice; iterating it allocates nothing.
#[derive(Debug, Clone, Copy)]
pub struct PoseFrameView<'a> {
    sequence: u64,
    sim_time: f64,
    wall_time_ns: u64,
    records: &'a [u8],
}

impl<'a> PoseFrameView<'a> {
    /// Checks the header, the layout and every record (one pass, no allocation).
    pub fn parse(bytes: &'a [u8]) -> Result<Self, DecodeError<PoseError>> {
        let p = header::expect(bytes, Kind::PoseFrame)?;
        if p.len() < POSE_FIXED_LEN {
            let found = p.len();
            return Err(
                FrameError::PayloadLength { kind: Kind::PoseFrame, expected: POSE_FIXED_LEN, found }.into()
            );
        }
        let count = le::u32_at(p, 24) as usize;
        if count > MAX_BODIES {
            return Err(DecodeError::Invalid(PoseError::TooManyBodies { count }));
        }
        let expected = POSE_FIXED_LEN + BODY_RECORD_LEN * count;
        if p.len() != expected {
            return Err(FrameError::PayloadLength { kind: Kind::PoseFrame, expected, found: p.len() }.into());
        }
        header::check_reserved(p, 28..32, HEADER_LEN)?;
        let sim_time = le::f64_at(p, 8);
        check_time(sim_time).map_err(DecodeError::Invalid)?;
        let records = &p[POSE_FIXED_LEN..];
        for (i, r) in records.chunks_exact(BODY_RECORD_LEN).enumerate() {
            BodyPose::read(r).validate(i).map_err(DecodeError::Invalid)?;
        }
        Ok(PoseFrameView { sequence: le::u64_at(p, 0), sim_time, wall_time_ns: le::u64_at(p, 16), records })
    }

    /// Step sequence number.
    pub fn sequence(&self) -> u64 {
        self.sequence
    }

    /// Simulation time (s).
    pub fn sim_time(&self) -> f64 {
        self.sim_time
    }

    /// Wall clock when the step ended (ns since the UNIX epoch).
    pub fn wall_time_ns(&self) -> u64 {
        self.wall_time_ns
    }

    /// Number of bodies.
    pub fn len(&self) -> usize {
        self.records.len() / BODY_RECORD_LEN
    }

    /// Whether the frame has no bodies.
    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    /// Body `i`, if there is one.
    pub fn get(&self, i: usize) -> Option<BodyPose> {
        let r = self.records.get(i * BODY_RECORD_LEN..(i + 1) * BODY_RECORD_LEN)?;
        Some(BodyPose::read(r))
    }

    /// The bodies in publication order.
    pub fn bodies(&self) -> BodyIter<'a> {
        BodyIter { records: self.records.chunks_exact(BODY_RECORD_LEN) }
    }

    /// An owned copy.
    pub fn to_frame(&self) -> PoseFrame {
        PoseFrame {
            sequence: self.sequence,
            sim_time: self.sim_time,
            wall_time_ns: self.wall_time_ns,
            bodies: self.bodies().collect(),
        }
    }
}

/// Iterator over the bodies of a [`PoseFrameView`] (reads fields in place, allocates nothing).
#[derive(Debug, Clone)]
pub struct BodyIter<'a> {
    records: std::slice::ChunksExact<'a, u8>,
}

impl Iterator for BodyIter<'_> {
    type Item = BodyPose;

    #[inline]
    fn next(&mut self) -> Option<BodyPose> {
        self.records.next().map(BodyPose::read)
    }

    #[inline]
    fn size_hint(&self) -> (usize, Option<usize>) {
        self.records.size_hint()
    }
}

impl DoubleEndedIterator for BodyIter<'_> {
    #[inline]
    fn next_back(&mut self) -> Option<BodyPose> {
        self.records.next_back().map(BodyPose::read)
    }
}

impl ExactSizeIterator for BodyIter<'_> {}
impl std::iter::FusedIterator for BodyIter<'_> {}

#[cfg(test)]
mod tests {
    use super::*;

    fn body(id: u32) -> BodyPose {
        let h = std::f64::consts::FRAC_1_SQRT_2;
        BodyPose {
            id,
            flags: BODY_ASLEEP,
            position: [1.0, -2.0, id as f64],
            orientation: [0.0, 0.0, h, h],
            linear_velocity: [0.5, 0.0, 0.0],
            angular_velocity: [0.0, 0.0, -1.0],
        }
    }

    #[test]
    fn repr_c_matches_the_record_size() {
        assert_eq!(std::mem::size_of::<BodyPose>(), BODY_RECORD_LEN);
    }

    #[test]
    fn writer_and_owned_encode_agree() {
        let frame =
            PoseFrame { sequence: 9, sim_time: 0.25, wall_time_ns: 77, bodies: vec![body(1), body(4)] };
        let mut a = Vec::new();
        frame.encode(&mut a).unwrap();
        assert_eq!(a.len(), frame.encoded_len());
        let mut b = Vec::new();
        let mut w = PoseFrameWriter::begin(&mut b, 9, 0.25, 77).unwrap();
        w.push(&body(1)).unwrap();
        let mut bad = body(2);
        bad.orientation[3] = 2.0;
        assert!(matches!(w.push(&bad), Err(PoseError::NonUnitQuaternion { body: 1, .. })));
        w.push(&body(4)).unwrap();
        assert_eq!(w.len(), 2);
        assert_eq!(w.finish(), &a[..]);
        assert_eq!(PoseFrame::decode(&a).unwrap(), frame);
        let v = PoseFrameView::parse(&a).unwrap();
        assert_eq!(v.get(1), Some(body(4)));
        assert_eq!(v.get(2), None);
        assert_eq!(v.bodies().rev().map(|b| b.id).collect::<Vec<_>>(), [4, 1]);
    }

    #[test]
    fn flags_must_be_defined_and_exclusive() {
        let mut b = body(0);
        b.flags = BODY_KINEMATIC | BODY_STATIC;
        assert!(matches!(b.validate(3), Err(PoseError::BodyFlags { body: 3, .. })));
        b.flags = 8;
        assert!(b.validate(0).is_err());
    }

    #[test]
    fn encode_error_leaves_the_buffer_empty() {
        let mut frame = PoseFrame { sequence: 1, sim_time: 0.0, wall_time_ns: 0, bodies: vec![body(0)] };
        frame.bodies[0].position[1] = f64::NAN;
        let mut buf = vec![1, 2, 3];
        let e = frame.encode(&mut buf).unwrap_err();
        assert_eq!(e, PoseError::NonFinite { body: Some(0), field: "position" });
        assert!(buf.is_empty());
        frame.sim_time = -1.0;
        assert!(matches!(frame.encode(&mut buf), Err(PoseError::NegativeSimTime { .. })));
    }
}
