//! Control requests and replies (kinds `0x0100`, `0x0101`, JSON) for the `control` queryable.
//!
//! ```json
//! {"id":7,"command":{"op":"pause"}}
//! {"id":8,"command":{"op":"resume"}}
//! {"id":9,"command":{"op":"step","count":1}}
//! {"id":10,"command":{"op":"reset"}}
//! {"id":11,"command":{"op":"set_variant","variant":"skyline"}}
//! {"id":12,"command":{"op":"load_scene","scene":"winch"}}
//! {"id":13,"command":{"op":"fault","fault":"break","target":"rope/end","tension":25000.0}}
//! {"id":14,"command":{"op":"run_until","sim_time":12.5}}
//! {"id":15,"command":{"op":"snapshot","path":"debrief/t600.snap"}}
//! {"id":16,"command":{"op":"restore","path":"debrief/t600.snap"}}
//!
//! {"id":11,"outcome":{"ok":{"scene":"winch","paused":false,"sequence":420,"sim_time":7.0,"variant":"skyline"}}}
//! {"id":9,"outcome":{"ok":{"scene":"winch","paused":true,"sequence":421,"sim_time":7.0166,"variant":"skyline",
//!   "steps":{"count":1,"island_solves":3,"not_converged":0,"max_residual_rel":2.1e-13}}}}
//! {"id":11,"outcome":{"error":{"code":"unknown_variant","message":"no variant \"fast\""}}}
//! ```
//!
//! `id` is chosen by the client and echoed by the reply. `step` advances a paused world by `count`
//! steps (1 ..= 3600) and leaves it paused; `run_until` advances it to the step nearest
//! `sim_time` (at most 3600 steps ahead; `in_the_past` when that step is not ahead). Both are the
//! lockstep requests: every step's frames are published, and the reply is sent after the last
//! step's, with `steps` (how many were taken and how their island solves ended); on a running
//! world they are refused `busy`. `snapshot` writes the complete state to a file and `restore`
//! puts one back (paused, new sequence); both name a file relative to the server's snapshot
//! directory (`serve --snapshot-dir`; none: refused `load_refused`), 1 ..= 256 bytes, no control
//! characters, no `..`; `snapshot_failed` when the file cannot be written or read, or is of
//! another scene or format. `set_variant` takes one of the seven solver variant
//! names and applies from the next step. `load_scene` takes a built-in scene name or a path inside
//! the server's scene directories (1 ..= 256 bytes, no control characters) and starts it paused at
//! time 0, its first frames with a new sequence (last + 1). An `id` that is not a u64 (−1, 2^64)
//! makes the request undecodable: it is answered `invalid_request` with id 0. The reply's `ok`
//! carries the state after the request; `error` carries a code (`invalid_request`,
//! `unknown_variant`, `unknown_scene`, `scene_load_failed`, `load_refused`, `busy`,
//! `fault_rejected`, `internal`) and a message of at most 1024 bytes.
//! `fault` injects a fault (`break`, `hose_burst`, `brake_fade`, `stick_valve`, `dropout`) on a
//! named joint, actuator or sensor; the scene checks the target (`fault_rejected` if it refuses).

use crate::codes::SolverVariant;
use crate::header::{DecodeError, Kind};
use crate::json;

/// Most steps of one `step` request (one minute at 60 Hz).
pub const MAX_STEP_COUNT: u32 = 3600;
/// Longest scene name or path, in bytes.
pub const MAX_SCENE_REF_LEN: usize = 256;
/// Longest error message, in bytes.
pub const MAX_MESSAGE_LEN: usize = 1024;

/// A control request.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ControlRequest {
    /// Echoed by the reply (keep below 2^53 for JavaScript clients).
    pub id: u64,
    /// What to do.
    pub command: ControlCommand,
}

/// What a control request asks for.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(tag = "op", rename_all = "snake_case")]
pub enum ControlCommand {
    /// Stop stepping (publishing continues with the last state).
    Pause,
    /// Step in real time again.
    Resume,
    /// Advance a paused world by `count` steps.
    Step {
        /// `1 ..= MAX_STEP_COUNT`.
        count: u32,
    },
    /// Restart the current scene, paused at time 0.
    Reset,
    /// Switch the solver variant live.
    SetVariant {
        /// New variant.
        variant: SolverVariant,
    },
    /// Load another scene by name or path, paused at time 0.
    LoadScene {
        /// Scene name or path.
        scene: String,
    },
    /// Advance a paused world to the step nearest `sim_time`.
    RunUntil {
        /// Target simulation time (s), finite and ≥ 0.
        sim_time: f64,
    },
    /// Write the complete state to a file in the server's snapshot directory.
    Snapshot {
        /// File name relative to that directory.
        path: String,
    },
    /// Put back the state of a snapshot file of the running scene (paused, new sequence).
    Restore {
        /// File name relative to the server's snapshot directory.
        path: String,
    },
    /// Publish a keyframe of the current state on `keyframes` (a recorder that starts asks so).
    Keyframe,
    /// Inject a fault (an instructor station): reported as an event of the next step.
    Fault {
        /// What breaks.
        fault: FaultKind,
        /// The joint (`break`), actuator (`hose_burst`, `brake_fade`, `stick_valve`) or sensor
        /// (`dropout`), by its scene name (1 ..= 64 bytes, no control characters).
        target: String,
        /// `break`: the rope parts when its tension exceeds this (N, > 0); absent: now.
        #[serde(skip_serializing_if = "Option::is_none")]
        tension: Option<f64>,
        /// `brake_fade`: final fraction of the brake's bound, in [0, 1] (absent: 0).
        #[serde(skip_serializing_if = "Option::is_none")]
        to: Option<f64>,
        /// `brake_fade`: seconds of the ramp, ≥ 0 (absent: 0).
        #[serde(skip_serializing_if = "Option::is_none")]
        ramp: Option<f64>,
    },
}

/// The faults an instructor can inject (`scenes/README.md`, `[[fault]]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FaultKind {
    /// A joint is disabled (a rope or cable parts).
    Break,
    /// An actuator goes limp.
    HoseBurst,
    /// A brake's force bound ramps down.
    BrakeFade,
    /// An actuator freezes at its applied value.
    StickValve,
    /// A sensor gives no reading.
    Dropout,
}

impl FaultKind {
    /// Every kind.
    pub const ALL: [FaultKind; 5] = [
        FaultKind::Break,
        FaultKind::HoseBurst,
        FaultKind::BrakeFade,
        FaultKind::StickValve,
        FaultKind::Dropout,
    ];

    /// The wire (and scene file) name.
    pub fn name(self) -> &'static str {
        match self {
            FaultKind::Break => "break",
            FaultKind::HoseBurst => "hose_burst",
            FaultKind::BrakeFade => "brake_fade",
            FaultKind::StickValve => "stick_valve",
            FaultKind::Dropout => "dropout",
        }
    }

    /// The kind of a name.
    pub fn from_name(s: &str) -> Option<FaultKind> {
        FaultKind::ALL.into_iter().find(|k| k.name() == s)
    }
}

/// Longest fault target name, in bytes (a scene's joint, actuator or sensor name).
pub const MAX_FAULT_TARGET_LEN: usize = 64;

/// A reply to a control request.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ControlReply {
    /// The request's id.
    pub id: u64,
    /// Success with the state after the request, or a typed failure.
    pub outcome: ControlOutcome,
}

/// Success or failure of a control request.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ControlOutcome {
    /// Done; the server's state afterwards.
    Ok(ServerStatus),
    /// Refused or failed.
    Error(ControlFailure),
}

/// The server's state, as reported by a successful control reply.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ServerStatus {
    /// Scene name or path.
    pub scene: String,
    /// Stepping is paused.
    pub paused: bool,
    /// Sequence of the last published step.
    pub sequence: u64,
    /// Simulation time (s).
    pub sim_time: f64,
    /// Solver variant in use.
    pub variant: SolverVariant,
    /// The steps a lockstep request (`step`, `run_until`) took; absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub steps: Option<StepReport>,
}

/// The steps one lockstep request took and how their island solves ended.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StepReport {
    /// Steps taken (fewer than asked only when a step failed: the world is then paused at its last
    /// good state and the reply says so in `not_converged` and the server's log).
    pub count: u32,
    /// Island solves over those steps.
    pub island_solves: u32,
    /// Of them, solves that did not end converged (capped, inexact, fell back).
    pub not_converged: u32,
    /// Largest relative natural-map residual of an island solve.
    pub max_residual_rel: f64,
}

/// Why a control request failed.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControlFailure {
    /// Machine-readable reason.
    pub code: ControlErrorCode,
    /// Human-readable detail (≤ [`MAX_MESSAGE_LEN`] bytes).
    pub message: String,
}

/// Machine-readable reason of a failed control request.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ControlErrorCode {
    /// The request frame did not decode.
    InvalidRequest,
    /// `set_variant` with a name the server does not know.
    UnknownVariant,
    /// `load_scene` with a scene that does not exist.
    UnknownScene,
    /// The scene exists but did not load.
    SceneLoadFailed,
    /// `load_scene` refused before reading: a path outside the server's scene directories, a file
    /// that is not a regular file (FIFO, device, directory), or one above the server's size bound.
    LoadRefused,
    /// The server cannot do it now (e.g. `step` while running).
    Busy,
    /// `run_until` a time whose step is not ahead of the world's.
    InThePast,
    /// `snapshot` or `restore` failed: the file could not be written or read, or it is of another
    /// scene or format (the world is unchanged).
    SnapshotFailed,
    /// A `fault` the scene refused: an unknown target, a target of the wrong kind, a value out of
    /// range (counted as a `fault-rejected` event).
    FaultRejected,
    /// Anything else.
    Internal,
}

/// What is wrong with the content of a control request or reply.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ControlError {
    /// Not one of the seven solver variant names.
    #[error("unknown solver variant {name:?}")]
    UnknownVariant {
        /// The name sent.
        name: String,
    },
    /// `step` count of 0 or above [`MAX_STEP_COUNT`].
    #[error("step count {count} outside 1..={MAX_STEP_COUNT}")]
    StepCount {
        /// The count sent.
        count: u32,
    },
    /// Empty scene name or path.
    #[error("empty scene name")]
    EmptyScene,
    /// Scene name or path above [`MAX_SCENE_REF_LEN`] bytes.
    #[error("scene name of {len} bytes (at most {MAX_SCENE_REF_LEN})")]
    SceneTooLong {
        /// Length in bytes.
        len: usize,
    },
    /// A control character (including NUL) in a scene name or path.
    #[error("control character at byte {index} of the scene name")]
    SceneChar {
        /// Byte offset.
        index: usize,
    },
    /// Failure message above [`MAX_MESSAGE_LEN`] bytes.
    #[error("message of {len} bytes (at most {MAX_MESSAGE_LEN})")]
    MessageTooLong {
        /// Length in bytes.
        len: usize,
    },
    /// A snapshot file name that is empty, too long, absolute, has a control character or `..`.
    #[error(
        "snapshot path of {len} bytes (1 ..= {MAX_SCENE_REF_LEN}, relative, no control characters, no `..`)"
    )]
    SnapshotPath {
        /// Length in bytes.
        len: usize,
    },
    /// `sim_time` not finite or negative.
    #[error("sim_time {value} is not a finite non-negative number")]
    SimTime {
        /// The value.
        value: f64,
    },
    /// Not one of the fault kinds.
    #[error("unknown fault kind {name:?}")]
    UnknownFault {
        /// The name sent.
        name: String,
    },
    /// An empty or too long fault target, or one with a control character.
    #[error("fault target of {len} bytes (1 ..= {MAX_FAULT_TARGET_LEN}, no control characters)")]
    FaultTarget {
        /// Length in bytes.
        len: usize,
    },
    /// A fault value that is not finite or out of its range.
    #[error("fault `{field}` = {value} is out of range")]
    FaultValue {
        /// The field.
        field: &'static str,
        /// The value.
        value: f64,
    },
    /// The encoded payload exceeds the kind's maximum (encode only).
    #[error("encoded payload of {len} bytes exceeds the maximum")]
    TooLarge {
        /// Payload length.
        len: usize,
    },
}

impl ControlError {
    /// The reply code for a request that failed with this error: `unknown_variant` for a variant
    /// name the server does not know, `invalid_request` for everything else.
    pub fn code(&self) -> ControlErrorCode {
        match self {
            ControlError::UnknownVariant { .. } => ControlErrorCode::UnknownVariant,
            ControlError::StepCount { .. }
            | ControlError::EmptyScene
            | ControlError::SceneTooLong { .. }
            | ControlError::SceneChar { .. }
            | ControlError::MessageTooLong { .. }
            | ControlError::SimTime { .. }
            | ControlError::SnapshotPath { .. }
            | ControlError::UnknownFault { .. }
            | ControlError::FaultTarget { .. }
            | ControlError::FaultValue { .. }
            | ControlError::TooLarge { .. } => ControlErrorCode::InvalidRequest,
        }
    }
}

pub(crate) fn check_scene_ref(s: &str) -> Result<(), ControlError> {
    if s.is_empty() {
        return Err(ControlError::EmptyScene);
    }
    if s.len() > MAX_SCENE_REF_LEN {
        return Err(ControlError::SceneTooLong { len: s.len() });
    }
    match s.bytes().position(|b| b.is_ascii_control()) {
        Some(index) => Err(ControlError::SceneChar { index }),
        None => Ok(()),
    }
}

/// A snapshot path: relative, 1 ..= [`MAX_SCENE_REF_LEN`] bytes, no control character, no `..`
/// component (the server joins it to its snapshot directory).
pub(crate) fn check_snapshot_path(s: &str) -> Result<(), ControlError> {
    let bad = s.is_empty()
        || s.len() > MAX_SCENE_REF_LEN
        || s.bytes().any(|b| b.is_ascii_control())
        || s.starts_with('/')
        || s.starts_with('\\')
        || s.split(['/', '\\']).any(|c| c == "..");
    if bad { Err(ControlError::SnapshotPath { len: s.len() }) } else { Ok(()) }
}

fn variant(name: String) -> Result<SolverVariant, ControlError> {
    SolverVariant::from_name(&name).ok_or(ControlError::UnknownVariant { name })
}

/// Mirrors of the public types with names as plain strings, so that an unknown variant name is a
/// typed [`ControlError`] rather than a JSON schema error.
mod raw {
    #[derive(serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    pub(super) struct Request {
        pub id: u64,
        pub command: Command,
    }

    #[derive(serde::Deserialize)]
    #[serde(tag = "op", rename_all = "snake_case", deny_unknown_fields)]
    pub(super) enum Command {
        // Empty struct variants (not unit variants) so that `deny_unknown_fields` rejects extra
        // fields next to the tag.
        Pause {},
        Resume {},
        Step {
            count: u32,
        },
        Reset {},
        SetVariant {
            variant: String,
        },
        LoadScene {
            scene: String,
        },
        RunUntil {
            sim_time: f64,
        },
        Snapshot {
            path: String,
        },
        Restore {
            path: String,
        },
        Keyframe {},
        Fault {
            fault: String,
            target: String,
            #[serde(default)]
            tension: Option<f64>,
            #[serde(default)]
            to: Option<f64>,
            #[serde(default)]
            ramp: Option<f64>,
        },
    }

    #[derive(serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    pub(super) struct Reply {
        pub id: u64,
        pub outcome: Outcome,
    }

    #[derive(serde::Deserialize)]
    #[serde(rename_all = "snake_case")]
    pub(super) enum Outcome {
        Ok(Status),
        Error(super::ControlFailure),
    }

    #[derive(serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    pub(super) struct Status {
        pub scene: String,
        pub paused: bool,
        pub sequence: u64,
        pub sim_time: f64,
        pub variant: String,
        #[serde(default)]
        pub steps: Option<super::StepReport>,
    }
}

impl ControlRequest {
    /// Checks every rule a decoder checks.
    pub fn validate(&self) -> Result<(), ControlError> {
        match &self.command {
            ControlCommand::Step { count } if *count == 0 || *count > MAX_STEP_COUNT => {
                Err(ControlError::StepCount { count: *count })
            }
            ControlCommand::LoadScene { scene } => check_scene_ref(scene),
            ControlCommand::RunUntil { sim_time } if !(sim_time.is_finite() && *sim_time >= 0.0) => {
                Err(ControlError::SimTime { value: *sim_time })
            }
            ControlCommand::Snapshot { path } | ControlCommand::Restore { path } => check_snapshot_path(path),
            ControlCommand::Fault { target, tension, to, ramp, .. } => {
                if target.is_empty()
                    || target.len() > MAX_FAULT_TARGET_LEN
                    || target.bytes().any(|b| b.is_ascii_control())
                {
                    return Err(ControlError::FaultTarget { len: target.len() });
                }
                let check = |field, v: Option<f64>, ok: fn(f64) -> bool| match v {
                    Some(value) if !ok(value) => Err(ControlError::FaultValue { field, value }),
                    _ => Ok(()),
                };
                check("tension", *tension, |x| x.is_finite() && x > 0.0)?;
                check("to", *to, |x| (0.0..=1.0).contains(&x))?;
                check("ramp", *ramp, |x| x.is_finite() && x >= 0.0)
            }
            _ => Ok(()),
        }
    }

    /// Clears `buf` and writes the frame. On error `buf` is left empty.
    pub fn encode(&self, buf: &mut Vec<u8>) -> Result<(), ControlError> {
        buf.clear();
        self.validate()?;
        json::encode(buf, Kind::ControlRequest, self).map_err(|len| ControlError::TooLarge { len })
    }

    /// The `id` of a request frame that may not decode as a whole (an unknown op, a bad field),
    /// so that the failure reply can echo it: the header must be a control request's and the
    /// payload a JSON object with an integer `id`; otherwise `None` (the reply then carries 0).
    pub fn peek_id(bytes: &[u8]) -> Option<u64> {
        #[derive(serde::Deserialize)]
        struct Id {
            id: u64,
        }
        json::decode::<Id>(bytes, Kind::ControlRequest).ok().map(|r| r.id)
    }

    /// The failure reply to a request frame that did not decode: the request's id when it can be
    /// read ([`ControlRequest::peek_id`]), and the code of the error ([`ControlError::code`]).
    pub fn rejection(bytes: &[u8], error: &DecodeError<ControlError>) -> ControlReply {
        let code = error.invalid().map_or(ControlErrorCode::InvalidRequest, ControlError::code);
        ControlReply::error(ControlRequest::peek_id(bytes).unwrap_or(0), code, error.to_string())
    }

    /// Decodes and validates a request frame.
    pub fn decode(bytes: &[u8]) -> Result<ControlRequest, DecodeError<ControlError>> {
        let r: raw::Request = json::decode(bytes, Kind::ControlRequest)?;
        let command = match r.command {
            raw::Command::Pause {} => ControlCommand::Pause,
            raw::Command::Resume {} => ControlCommand::Resume,
            raw::Command::Step { count } => ControlCommand::Step { count },
            raw::Command::Reset {} => ControlCommand::Reset,
            raw::Command::SetVariant { variant: v } => {
                ControlCommand::SetVariant { variant: variant(v).map_err(DecodeError::Invalid)? }
            }
            raw::Command::LoadScene { scene } => ControlCommand::LoadScene { scene },
            raw::Command::RunUntil { sim_time } => ControlCommand::RunUntil { sim_time },
            raw::Command::Snapshot { path } => ControlCommand::Snapshot { path },
            raw::Command::Restore { path } => ControlCommand::Restore { path },
            raw::Command::Keyframe {} => ControlCommand::Keyframe,
            raw::Command::Fault { fault, target, tension, to, ramp } => ControlCommand::Fault {
                fault: FaultKind::from_name(&fault)
                    .ok_or(DecodeError::Invalid(ControlError::UnknownFault { name: fault }))?,
                target,
                tension,
                to,
                ramp,
            },
        };
        let req = ControlRequest { id: r.id, command };
        req.validate().map_err(DecodeError::Invalid)?;
        Ok(req)
    }
}

impl ControlReply {
    /// A success reply.
    pub fn ok(id: u64, status: ServerStatus) -> ControlReply {
        ControlReply { id, outcome: ControlOutcome::Ok(status) }
    }

    /// A failure reply; `message` is cut to [`MAX_MESSAGE_LEN`] bytes at a character boundary.
    pub fn error(id: u64, code: ControlErrorCode, message: impl Into<String>) -> ControlReply {
        let mut message = message.into();
        if message.len() > MAX_MESSAGE_LEN {
            let mut end = MAX_MESSAGE_LEN;
            while !message.is_char_boundary(end) {
                end -= 1;
            }
            message.truncate(end);
        }
        ControlReply { id, outcome: ControlOutcome::Error(ControlFailure { code, message }) }
    }

    /// Checks every rule a decoder checks.
    pub fn validate(&self) -> Result<(), ControlError> {
        match &self.outcome {
            ControlOutcome::Ok(s) => {
                if !s.sim_time.is_finite() || s.sim_time < 0.0 {
                    return Err(ControlError::SimTime { value: s.sim_time });
                }
                if let Some(r) = s.steps
                    && !(r.max_residual_rel.is_finite() && r.max_residual_rel >= 0.0)
                {
                    return Err(ControlError::SimTime { value: r.max_residual_rel });
                }
                check_scene_ref(&s.scene)
            }
            ControlOutcome::Error(f) if f.message.len() > MAX_MESSAGE_LEN => {
                Err(ControlError::MessageTooLong { len: f.message.len() })
            }
            ControlOutcome::Error(_) => Ok(()),
        }
    }

    /// Clears `buf` and writes the frame. On error `buf` is left empty.
    pub fn encode(&self, buf: &mut Vec<u8>) -> Result<(), ControlError> {
        buf.clear();
        self.validate()?;
        json::encode(buf, Kind::ControlReply, self).map_err(|len| ControlError::TooLarge { len })
    }

    /// Decodes and validates a reply frame.
    pub fn decode(bytes: &[u8]) -> Result<ControlReply, DecodeError<ControlError>> {
        let r: raw::Reply = json::decode(bytes, Kind::ControlReply)?;
        let outcome = match r.outcome {
            raw::Outcome::Ok(s) => ControlOutcome::Ok(ServerStatus {
                scene: s.scene,
                paused: s.paused,
                sequence: s.sequence,
                sim_time: s.sim_time,
                variant: variant(s.variant).map_err(DecodeError::Invalid)?,
                steps: s.steps,
            }),
            raw::Outcome::Error(f) => ControlOutcome::Error(f),
        };
        let reply = ControlReply { id: r.id, outcome };
        reply.validate().map_err(DecodeError::Invalid)?;
        Ok(reply)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::header::{self, FrameError};

    fn frame(kind: Kind, json: &str) -> Vec<u8> {
        let mut b = Vec::new();
        header::begin(&mut b, kind);
        b.extend_from_slice(json.as_bytes());
        header::set_payload_len(&mut b);
        b
    }

    #[test]
    fn json_shape_is_the_documented_one() {
        let mut buf = Vec::new();
        let r = ControlRequest {
            id: 11,
            command: ControlCommand::SetVariant { variant: SolverVariant::Skyline },
        };
        r.encode(&mut buf).unwrap();
        assert_eq!(&buf[16..], br#"{"id":11,"command":{"op":"set_variant","variant":"skyline"}}"#);
        let r = ControlRequest { id: 7, command: ControlCommand::Pause };
        r.encode(&mut buf).unwrap();
        assert_eq!(&buf[16..], br#"{"id":7,"command":{"op":"pause"}}"#);
        let e = ControlReply::error(11, ControlErrorCode::UnknownVariant, "no");
        e.encode(&mut buf).unwrap();
        assert_eq!(&buf[16..], br#"{"id":11,"outcome":{"error":{"code":"unknown_variant","message":"no"}}}"#);
        assert_eq!(ControlReply::decode(&buf), Ok(e));
    }

    #[test]
    fn unknown_variant_is_typed() {
        let b = frame(Kind::ControlRequest, r#"{"id":1,"command":{"op":"set_variant","variant":"fast"}}"#);
        assert_eq!(
            ControlRequest::decode(&b),
            Err(DecodeError::Invalid(ControlError::UnknownVariant { name: "fast".into() }))
        );
    }

    #[test]
    fn a_failing_request_is_answered_with_its_id_and_code() {
        let cases = [
            (
                r#"{"id":41,"command":{"op":"set_variant","variant":"fast"}}"#,
                41,
                ControlErrorCode::UnknownVariant,
            ),
            (r#"{"id":42,"command":{"op":"explode"}}"#, 42, ControlErrorCode::InvalidRequest),
            (r#"{"id":43,"command":{"op":"step","count":0}}"#, 43, ControlErrorCode::InvalidRequest),
            (r#"{"id":44,"command":{"op":"pause"},"extra":true}"#, 44, ControlErrorCode::InvalidRequest),
            (r#"{"command":{"op":"pause"}}"#, 0, ControlErrorCode::InvalidRequest),
            (r#"{"id":-1,"command":{"op":"pause"}}"#, 0, ControlErrorCode::InvalidRequest),
            ("not json", 0, ControlErrorCode::InvalidRequest),
        ];
        for (j, id, code) in cases {
            let b = frame(Kind::ControlRequest, j);
            let e = ControlRequest::decode(&b).unwrap_err();
            let r = ControlRequest::rejection(&b, &e);
            assert_eq!(r.id, id, "{j}");
            match r.outcome {
                ControlOutcome::Error(f) => assert_eq!(f.code, code, "{j}"),
                ControlOutcome::Ok(_) => panic!("{j}: ok"),
            }
        }
        // Another kind's frame: no id is read from it.
        assert_eq!(ControlRequest::peek_id(&frame(Kind::ControlReply, r#"{"id":5}"#)), None);
    }

    #[test]
    fn unknown_fields_and_ops_are_json_errors() {
        for j in [
            r#"{"id":1,"command":{"op":"pause","x":1}}"#,
            r#"{"id":1,"command":{"op":"explode"}}"#,
            r#"{"id":1,"command":{"op":"pause"},"extra":true}"#,
            r#"{"id":-1,"command":{"op":"pause"}}"#,
        ] {
            let r = ControlRequest::decode(&frame(Kind::ControlRequest, j));
            assert!(matches!(r, Err(DecodeError::Frame(FrameError::Json { .. }))), "{j}: {r:?}");
        }
    }

    #[test]
    fn long_messages_are_cut_at_a_char_boundary() {
        let r = ControlReply::error(1, ControlErrorCode::Internal, "é".repeat(600));
        let ControlOutcome::Error(f) = &r.outcome else { unreachable!() };
        assert_eq!(f.message.len(), 1024);
        assert_eq!(r.validate(), Ok(()));
    }
}
