//! Operator inputs (kinds `0x0010..=0x0013`): joystick, winch, boom and generic actuator commands.
//!
//! All four are small binary frames. Every one starts with `sequence` (u64, increasing per source)
//! and `source_id` (u32, chosen by the sender: the server keeps the latest input per source and
//! drops older or equal sequences as stale — one counter per `source_id`, across the four kinds).
//! [`InputCommand::decode`] checks in the order `msgs/README.md` gives ("Order of the input
//! checks"): header, input kind, fixed part, then by kind; a boom's `count` before its layout.
//!
//! ```text
//! joystick (0x0010), payload 152 bytes
//!    0  8  sequence      u64
//!    8  4  source_id     u32
//!   12  1  axis_count    u8, ≤ 32
//!   13  1  button_count  u8, ≤ 64
//!   14  2  reserved      0
//!   16  8  buttons       u64, bit i = button i pressed; bits ≥ button_count are 0
//!   24 128 axes          f32 × 32, each in [-1, 1]; axes ≥ axis_count are +0.0 (all bits 0)
//!
//! winch (0x0011), payload 56 bytes
//!    0  8  sequence      u64
//!    8  4  source_id     u32
//!   12  4  reserved      0
//!   16 32  actuator      name field (see name.rs): the winch's actuator name
//!   48  8  drum_speed    f64, rad/s; positive hauls in (shortens the cable), negative pays out
//!
//! boom (0x0012), payload 16 + 40 · count bytes
//!    0  8  sequence      u64
//!    8  4  source_id     u32
//!   12  4  count         u32, ≤ 16 (0 is a keep-alive that sets nothing)
//!   16 40  entry × count: name field (32) + f64 target in the actuator's mode; names unique
//!
//! actuator (0x0013), payload 56 bytes
//!    0  8  sequence      u64
//!    8  4  source_id     u32
//!   12  1  mode          u8, ActuatorMode code: 0 velocity, 1 position, 2 effort
//!   13  3  reserved      0
//!   16 32  actuator      name field
//!   48  8  value         f64, in the mode's unit
//! ```
//!
//! Values are finite; range limits of each actuator are the scene's business (the server clamps).
//! Whether a named actuator exists is checked against the scene with
//! [`SceneDescription::check_input`](crate::SceneDescription::check_input).

use crate::codes::{ActuatorMode, RejectReason};
use crate::header::{self, DecodeError, FrameError, HEADER_LEN, Kind};
pub use crate::layout::{
    ACTUATOR_LEN, BOOM_ENTRY_LEN, BOOM_FIXED_LEN, JOYSTICK_LEN, MAX_BOOM_TARGETS, WINCH_LEN,
};
use crate::le;
use crate::name::{ActuatorName, MAX_ACTUATOR_NAME_LEN, NameError};

/// Most joystick axes.
pub const MAX_AXES: usize = 32;
/// Most joystick buttons.
pub const MAX_BUTTONS: usize = 64;

/// A gamepad or console state.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Joystick {
    /// Increasing per source.
    pub sequence: u64,
    /// Sender id.
    pub source_id: u32,
    /// Axes in use (`≤ 32`).
    pub axis_count: u8,
    /// Buttons in use (`≤ 64`).
    pub button_count: u8,
    /// Bit `i` set: button `i` pressed.
    pub buttons: u64,
    /// Axis values in `[-1, 1]`; entries from `axis_count` on are `0.0`.
    pub axes: [f32; MAX_AXES],
}

impl Joystick {
    /// A joystick state from the axes in use (`axes.len() ≤ 32`, else `None`).
    pub fn new(
        sequence: u64,
        source_id: u32,
        axes: &[f32],
        buttons: u64,
        button_count: u8,
    ) -> Option<Joystick> {
        if axes.len() > MAX_AXES {
            return None;
        }
        let mut a = [0.0; MAX_AXES];
        a[..axes.len()].copy_from_slice(axes);
        Some(Joystick { sequence, source_id, axis_count: axes.len() as u8, button_count, buttons, axes: a })
    }

    /// The axes in use.
    pub fn axes(&self) -> &[f32] {
        &self.axes[..(self.axis_count as usize).min(MAX_AXES)]
    }

    /// Whether button `i` is pressed.
    pub fn button(&self, i: usize) -> bool {
        i < self.button_count as usize && self.buttons >> i & 1 == 1
    }
}

/// Drum speed of a winch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WinchCommand {
    /// Increasing per source.
    pub sequence: u64,
    /// Sender id.
    pub source_id: u32,
    /// The winch's actuator name.
    pub actuator: ActuatorName,
    /// rad/s; positive hauls in.
    pub drum_speed: f64,
}

/// One named target of a boom command, read in its actuator's mode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoomTarget {
    /// Actuator name.
    pub actuator: ActuatorName,
    /// Target in the actuator's mode: a velocity (m/s, rad/s) or a position (m, rad).
    pub value: f64,
}

/// Targets for the boom functions (slew, lift, stick, telescope, …), one lever each, each read
/// in its actuator's mode (velocity or position).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BoomCommand {
    /// Increasing per source.
    pub sequence: u64,
    /// Sender id.
    pub source_id: u32,
    /// At most [`MAX_BOOM_TARGETS`] entries, names unique.
    pub targets: Vec<BoomTarget>,
}

/// One value for one named actuator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActuatorCommand {
    /// Increasing per source.
    pub sequence: u64,
    /// Sender id.
    pub source_id: u32,
    /// What `value` means.
    pub mode: ActuatorMode,
    /// Actuator name.
    pub actuator: ActuatorName,
    /// Target or effort in the mode's unit.
    pub value: f64,
}

/// Any operator input.
#[derive(Debug, Clone, PartialEq)]
pub enum InputCommand {
    /// Kind `0x0010`.
    Joystick(Joystick),
    /// Kind `0x0011`.
    Winch(WinchCommand),
    /// Kind `0x0012`.
    Boom(BoomCommand),
    /// Kind `0x0013`.
    Actuator(ActuatorCommand),
}

/// What is wrong with the content of an input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InputError {
    /// `axis_count > 32`.
    #[error("{count} joystick axes (at most {MAX_AXES})")]
    TooManyAxes {
        /// Declared count.
        count: usize,
    },
    /// `button_count > 64`.
    #[error("{count} joystick buttons (at most {MAX_BUTTONS})")]
    TooManyButtons {
        /// Declared count.
        count: usize,
    },
    /// A finite axis value outside `[-1, 1]`.
    #[error("joystick axis {axis} = {value} outside [-1, 1]")]
    AxisOutOfRange {
        /// Axis index.
        axis: usize,
        /// The value.
        value: f32,
    },
    /// An axis beyond `axis_count` is not `+0.0`.
    #[error("unused joystick axis {axis} is not zero")]
    UnusedAxis {
        /// Axis index.
        axis: usize,
    },
    /// A button bit at or beyond `button_count` is set.
    #[error("button bits 0x{buttons:016x} set beyond button_count")]
    UnusedButtons {
        /// The offending bits.
        buttons: u64,
    },
    /// NaN or ±Inf (`entry`: axis or boom entry index).
    #[error("non-finite {field} (entry {entry:?})")]
    NonFinite {
        /// Field name.
        field: &'static str,
        /// Axis or entry index.
        entry: Option<usize>,
    },
    /// More than [`MAX_BOOM_TARGETS`] boom entries.
    #[error("{count} boom targets (at most {MAX_BOOM_TARGETS})")]
    TooManyTargets {
        /// Entries.
        count: usize,
    },
    /// The same actuator twice in one boom command.
    #[error("actuator {name:?} appears twice in one boom command")]
    DuplicateTarget {
        /// The name.
        name: String,
    },
    /// A bad actuator name field (`entry`: boom entry index).
    #[error("actuator name (entry {entry:?}): {source}")]
    Name {
        /// Boom entry index.
        entry: Option<usize>,
        /// What is wrong.
        source: NameError,
    },
    /// Mode code outside `0..=2`.
    #[error("unknown actuator mode code {code}")]
    UnknownMode {
        /// The code.
        code: u8,
    },
    /// The scene has no actuator of that name.
    #[error("unknown actuator {name:?}")]
    UnknownActuator {
        /// The name.
        name: String,
    },
    /// The actuator exists but cannot take this command (a winch command to a joint motor).
    #[error("actuator {name:?} is not a {expected}")]
    WrongActuatorKind {
        /// The name.
        name: String,
        /// What the command needs.
        expected: &'static str,
    },
}

impl InputError {
    /// The stats counter this rejection goes to.
    pub fn reject_reason(&self) -> RejectReason {
        use InputError as E;
        match self {
            E::TooManyAxes { .. } | E::TooManyButtons { .. } | E::TooManyTargets { .. } => {
                RejectReason::Oversize
            }
            E::Name { source: NameError::TooLong { .. }, .. } => RejectReason::Oversize,
            E::Name { source: NameError::Padding { .. }, .. } => RejectReason::Malformed,
            E::NonFinite { .. } => RejectReason::NonFinite,
            E::UnknownActuator { .. } | E::WrongActuatorKind { .. } => RejectReason::UnknownActuator,
            E::AxisOutOfRange { .. }
            | E::UnusedAxis { .. }
            | E::UnusedButtons { .. }
            | E::DuplicateTarget { .. }
            | E::Name { .. }
            | E::UnknownMode { .. } => RejectReason::OutOfRange,
        }
    }
}

impl FrameError {
    /// The stats counter a malformed input goes to.
    pub fn reject_reason(&self) -> RejectReason {
        match self {
            FrameError::UnsupportedVersion { .. }
            | FrameError::UnknownKind { .. }
            | FrameError::WrongKind { .. }
            | FrameError::NotAnInput { .. }
            | FrameError::Flags { .. } => RejectReason::Version,
            FrameError::PayloadTooLarge { .. } => RejectReason::Oversize,
            _ => RejectReason::Malformed,
        }
    }
}

impl DecodeError<InputError> {
    /// The stats counter this rejection goes to.
    pub fn reject_reason(&self) -> RejectReason {
        match self {
            DecodeError::Frame(e) => e.reject_reason(),
            DecodeError::Invalid(e) => e.reject_reason(),
        }
    }
}

fn finite(field: &'static str, entry: Option<usize>, v: f64) -> Result<(), InputError> {
    if v.is_finite() { Ok(()) } else { Err(InputError::NonFinite { field, entry }) }
}

impl Joystick {
    /// Checks counts, ranges and unused slots.
    pub fn validate(&self) -> Result<(), InputError> {
        let (na, nb) = (self.axis_count as usize, self.button_count as usize);
        if na > MAX_AXES {
            return Err(InputError::TooManyAxes { count: na });
        }
        if nb > MAX_BUTTONS {
            return Err(InputError::TooManyButtons { count: nb });
        }
        for (axis, &value) in self.axes.iter().enumerate() {
            if axis >= na {
                if value.to_bits() != 0 {
                    return Err(InputError::UnusedAxis { axis });
                }
            } else if !value.is_finite() {
                return Err(InputError::NonFinite { field: "axes", entry: Some(axis) });
            } else if !(-1.0..=1.0).contains(&value) {
                return Err(InputError::AxisOutOfRange { axis, value });
            }
        }
        let extra = if nb >= 64 { 0 } else { self.buttons & !((1u64 << nb) - 1) };
        if extra != 0 {
            return Err(InputError::UnusedButtons { buttons: extra });
        }
        Ok(())
    }
}

impl BoomCommand {
    /// Checks the count, values and name uniqueness.
    pub fn validate(&self) -> Result<(), InputError> {
        if self.targets.len() > MAX_BOOM_TARGETS {
            return Err(InputError::TooManyTargets { count: self.targets.len() });
        }
        for (i, t) in self.targets.iter().enumerate() {
            finite("value", Some(i), t.value)?;
            if self.targets[..i].iter().any(|u| u.actuator == t.actuator) {
                return Err(InputError::DuplicateTarget { name: t.actuator.to_string() });
            }
        }
        Ok(())
    }
}

fn name_at(p: &[u8], off: usize, entry: Option<usize>) -> Result<ActuatorName, InputError> {
    ActuatorName::from_field(&le::array::<MAX_ACTUATOR_NAME_LEN>(p, off))
        .map_err(|source| InputError::Name { entry, source })
}

fn put_head(buf: &mut Vec<u8>, kind: Kind, sequence: u64, source_id: u32) {
    header::begin(buf, kind);
    buf.extend_from_slice(&sequence.to_le_bytes());
    buf.extend_from_slice(&source_id.to_le_bytes());
}

impl InputCommand {
    /// Frame kind.
    pub fn kind(&self) -> Kind {
        match self {
            InputCommand::Joystick(_) => Kind::Joystick,
            InputCommand::Winch(_) => Kind::Winch,
            InputCommand::Boom(_) => Kind::Boom,
            InputCommand::Actuator(_) => Kind::Actuator,
        }
    }

    /// Sequence number.
    pub fn sequence(&self) -> u64 {
        match self {
            InputCommand::Joystick(c) => c.sequence,
            InputCommand::Winch(c) => c.sequence,
            InputCommand::Boom(c) => c.sequence,
            InputCommand::Actuator(c) => c.sequence,
        }
    }

    /// Sender id.
    pub fn source_id(&self) -> u32 {
        match self {
            InputCommand::Joystick(c) => c.source_id,
            InputCommand::Winch(c) => c.source_id,
            InputCommand::Boom(c) => c.source_id,
            InputCommand::Actuator(c) => c.source_id,
        }
    }

    /// Checks every rule a decoder checks (names are valid by construction).
    pub fn validate(&self) -> Result<(), InputError> {
        match self {
            InputCommand::Joystick(j) => j.validate(),
            InputCommand::Winch(w) => finite("drum_speed", None, w.drum_speed),
            InputCommand::Boom(b) => b.validate(),
            InputCommand::Actuator(a) => finite("value", None, a.value),
        }
    }

    /// Clears `buf` and writes the frame; allocates only if `buf` must grow. On error `buf` is
    /// left empty.
    pub fn encode(&self, buf: &mut Vec<u8>) -> Result<(), InputError> {
        buf.clear();
        self.validate()?;
        match self {
            InputCommand::Joystick(j) => {
                put_head(buf, Kind::Joystick, j.sequence, j.source_id);
                buf.extend_from_slice(&[j.axis_count, j.button_count, 0, 0]);
                buf.extend_from_slice(&j.buttons.to_le_bytes());
                for a in j.axes {
                    buf.extend_from_slice(&a.to_le_bytes());
                }
            }
            InputCommand::Winch(w) => {
                put_head(buf, Kind::Winch, w.sequence, w.source_id);
                buf.extend_from_slice(&[0; 4]);
                buf.extend_from_slice(w.actuator.field());
                buf.extend_from_slice(&w.drum_speed.to_le_bytes());
            }
            InputCommand::Boom(b) => {
                put_head(buf, Kind::Boom, b.sequence, b.source_id);
                buf.extend_from_slice(&(b.targets.len() as u32).to_le_bytes());
                for t in &b.targets {
                    buf.extend_from_slice(t.actuator.field());
                    buf.extend_from_slice(&t.value.to_le_bytes());
                }
            }
            InputCommand::Actuator(a) => {
                put_head(buf, Kind::Actuator, a.sequence, a.source_id);
                buf.extend_from_slice(&[a.mode.code(), 0, 0, 0]);
                buf.extend_from_slice(a.actuator.field());
                buf.extend_from_slice(&a.value.to_le_bytes());
            }
        }
        header::set_payload_len(buf);
        Ok(())
    }

    /// Decodes and validates any of the four input kinds.
    pub fn decode(bytes: &[u8]) -> Result<InputCommand, DecodeError<InputError>> {
        let h = header::peek(bytes)?;
        let p = &bytes[HEADER_LEN..];
        let exact = |expected: usize| -> Result<(), FrameError> {
            if p.len() == expected {
                Ok(())
            } else {
                Err(FrameError::PayloadLength { kind: h.kind, expected, found: p.len() })
            }
        };
        let min = match h.kind {
            Kind::Joystick => JOYSTICK_LEN,
            Kind::Winch => WINCH_LEN,
            Kind::Actuator => ACTUATOR_LEN,
            Kind::Boom => BOOM_FIXED_LEN,
            found => return Err(FrameError::NotAnInput { found }.into()),
        };
        if p.len() < min {
            return Err(FrameError::PayloadLength { kind: h.kind, expected: min, found: p.len() }.into());
        }
        let (sequence, source_id) = (le::u64_at(p, 0), le::u32_at(p, 8));
        let inv = DecodeError::Invalid;
        let cmd = match h.kind {
            Kind::Joystick => {
                exact(JOYSTICK_LEN)?;
                header::check_reserved(p, 14..16, HEADER_LEN)?;
                InputCommand::Joystick(Joystick {
                    sequence,
                    source_id,
                    axis_count: p[12],
                    button_count: p[13],
                    buttons: le::u64_at(p, 16),
                    axes: std::array::from_fn(|i| le::f32_at(p, 24 + 4 * i)),
                })
            }
            Kind::Winch => {
                exact(WINCH_LEN)?;
                header::check_reserved(p, 12..16, HEADER_LEN)?;
                let actuator = name_at(p, 16, None).map_err(inv)?;
                InputCommand::Winch(WinchCommand {
                    sequence,
                    source_id,
                    actuator,
                    drum_speed: le::f64_at(p, 48),
                })
            }
            Kind::Actuator => {
                exact(ACTUATOR_LEN)?;
                let code = p[12];
                let mode = ActuatorMode::from_code(code).ok_or(inv(InputError::UnknownMode { code }))?;
                header::check_reserved(p, 13..16, HEADER_LEN)?;
                let actuator = name_at(p, 16, None).map_err(inv)?;
                InputCommand::Actuator(ActuatorCommand {
                    sequence,
                    source_id,
                    mode,
                    actuator,
                    value: le::f64_at(p, 48),
                })
            }
            // Kind::Boom, the only input kind left.
            _ => {
                let count = le::u32_at(p, 12) as usize;
                if count > MAX_BOOM_TARGETS {
                    return Err(inv(InputError::TooManyTargets { count }));
                }
                exact(BOOM_FIXED_LEN + BOOM_ENTRY_LEN * count)?;
                let mut targets = Vec::with_capacity(count);
                for i in 0..count {
                    let off = BOOM_FIXED_LEN + BOOM_ENTRY_LEN * i;
                    let actuator = name_at(p, off, Some(i)).map_err(inv)?;
                    targets.push(BoomTarget { actuator, value: le::f64_at(p, off + 32) });
                }
                InputCommand::Boom(BoomCommand { sequence, source_id, targets })
            }
        };
        cmd.validate().map_err(inv)?;
        Ok(cmd)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn name(s: &str) -> ActuatorName {
        ActuatorName::new(s).unwrap()
    }

    #[test]
    fn joystick_rules() {
        let mut j = Joystick::new(1, 2, &[0.5, -1.0, 1.0], 0b101, 3).unwrap();
        assert_eq!(j.validate(), Ok(()));
        assert!(j.button(2) && !j.button(1) && !j.button(40));
        j.buttons |= 1 << 3;
        assert_eq!(j.validate(), Err(InputError::UnusedButtons { buttons: 8 }));
        j.buttons = u64::MAX;
        j.button_count = 64;
        assert_eq!(j.validate(), Ok(()));
        j.axes[1] = -1.5;
        assert_eq!(j.validate(), Err(InputError::AxisOutOfRange { axis: 1, value: -1.5 }));
        j.axes[1] = f32::NAN;
        assert_eq!(j.validate(), Err(InputError::NonFinite { field: "axes", entry: Some(1) }));
        j.axes[1] = 0.0;
        j.axes[5] = -0.0;
        assert_eq!(j.validate(), Err(InputError::UnusedAxis { axis: 5 }));
        assert!(Joystick::new(0, 0, &[0.0; 33], 0, 0).is_none());
    }

    #[test]
    fn boom_rules_and_round_trip() {
        let t = |n: &str, v| BoomTarget { actuator: name(n), value: v };
        let mut b = BoomCommand { sequence: 4, source_id: 1, targets: vec![t("slew", 0.1), t("lift", -0.2)] };
        let cmd = InputCommand::Boom(b.clone());
        let mut buf = Vec::new();
        cmd.encode(&mut buf).unwrap();
        assert_eq!(buf.len(), HEADER_LEN + 16 + 80);
        assert_eq!(InputCommand::decode(&buf), Ok(cmd));
        b.targets.push(t("slew", 0.0));
        assert_eq!(b.validate(), Err(InputError::DuplicateTarget { name: "slew".into() }));
        b.targets = vec![t("a", 0.0); 17];
        assert_eq!(b.validate(), Err(InputError::TooManyTargets { count: 17 }));
    }

    #[test]
    fn reasons_cover_the_counters() {
        let e = InputError::Name { entry: None, source: NameError::TooLong { len: 40 } };
        assert_eq!(e.reject_reason(), RejectReason::Oversize);
        let d: DecodeError<InputError> = FrameError::UnknownKind { found: 9 }.into();
        assert_eq!(d.reject_reason(), RejectReason::Version);
        let d: DecodeError<InputError> = FrameError::Truncated { needed: 16, available: 0 }.into();
        assert_eq!(d.reject_reason(), RejectReason::Malformed);
    }
}
