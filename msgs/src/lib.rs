//! Wire types of pivotsim: plain data shared by the server, its clients and bridges (no nalgebra,
//! nothing of the server).
//!
//! Every message is a *frame*: a 16-byte header (magic `PVSM`, format version, kind, payload
//! length, flags; see [`header`]) followed by the payload. The high-rate frames — [`PoseFrame`]
//! and [`SolverStats`] — and the operator inputs ([`InputCommand`]) have compact little-endian
//! binary payloads of fixed-size records, so the same bytes travel over Zenoh and in iceoryx2
//! `[u8]` samples. The low-rate frames — [`ControlRequest`], [`ControlReply`] and
//! [`SceneDescription`] — carry JSON in the same header. `msgs/README.md` documents every byte.
//!
//! Each message family has `encode(&self, &mut Vec<u8>)` (the buffer is cleared and reused: no
//! allocation once it has grown; the content is validated first) and `decode(&[u8])` (validated,
//! typed errors: [`DecodeError<E>`] is a [`FrameError`] or the family's content error `E`).
//! [`PoseFrameView`] iterates the bodies of a pose frame straight from the received bytes without
//! allocating; [`PoseFrameWriter`] writes them without an intermediate vector.
//!
//! Key expressions and iceoryx2 service names are built by [`WorldName::key`] from a [`Topic`].

pub mod header;

mod codes;
mod control;
mod input;
mod journal;
mod json;
mod keys;
mod layout;
mod le;
mod message;
mod name;
mod pose;
mod scene;
mod signals;
mod stats;

pub use codes::{ActuatorMode, REJECT_REASONS, RejectReason, SolveStatus, SolverVariant};
pub use control::{
    ControlCommand, ControlError, ControlErrorCode, ControlFailure, ControlOutcome, ControlReply,
    ControlRequest, FaultKind, MAX_FAULT_TARGET_LEN, MAX_MESSAGE_LEN, MAX_SCENE_REF_LEN, MAX_STEP_COUNT,
    ServerStatus, StepReport,
};
pub use header::{DecodeError, FORMAT_VERSION, FrameError, HEADER_LEN, Header, Kind, MAGIC, MAX_FRAME_LEN};
pub use input::{
    ACTUATOR_LEN, ActuatorCommand, BOOM_ENTRY_LEN, BOOM_FIXED_LEN, BoomCommand, BoomTarget, InputCommand,
    InputError, JOYSTICK_LEN, Joystick, MAX_AXES, MAX_BOOM_TARGETS, MAX_BUTTONS, WINCH_LEN, WinchCommand,
};
pub use journal::{
    APPLIED_FIXED_LEN, APPLIED_RECORD_HEAD_LEN, AppliedFrame, AppliedKind, AppliedRecord, JournalError,
    KEYFRAME_FIXED_LEN, KeyframeReason, KeyframeView, MAX_APPLIED, MAX_APPLIED_RECORD_LEN,
    RECORD_TOPIC_APPLIED, RECORD_TOPIC_KEYFRAMES, RECORD_TOPIC_POSES, RECORD_WIRE_ENCODING, SNAPSHOT_MAGIC,
};
pub use keys::{
    CONTROLLER_TOKENS, DEFAULT_WORLD, IOX_INPUT_SERVICE, IOX_SUBSCRIBER_BUFFER, KEY_PREFIX, KeyError,
    MAX_WORLD_NAME_LEN, SERVER_TOKEN, Topic, WorldName, inputs_wildcard, parse_key,
};
pub use message::{Message, MessageError};
pub use name::{ActuatorName, MAX_ACTUATOR_NAME_LEN, NameError, is_name_byte, validate_actuator_name};
pub use pose::{
    BODY_ASLEEP, BODY_FLAGS_KNOWN, BODY_KINEMATIC, BODY_RECORD_LEN, BODY_STATIC, BodyIter, BodyPose,
    MAX_BODIES, POSE_FIXED_LEN, PoseError, PoseFrame, PoseFrameView, PoseFrameWriter, QUAT_NORM_TOLERANCE,
};
pub use scene::*;
pub use signals::{
    CHANNEL_DROPOUT, CHANNEL_RECORD_LEN, CONTACT_RECORD_LEN, ContactCode, ContactRecord, EVENT_RECORD_LEN,
    EVENTS_FIXED_LEN, EventCode, EventRecord, EventsFrame, MAX_CHANNELS, MAX_CONTACTS, MAX_EVENTS,
    SIGNALS_FIXED_LEN, SignalChannel, SignalsError, SignalsFrame,
};
pub use stats::{
    DegradedSolves, ISLAND_FALLBACK, ISLAND_RECORD_LEN, InputHealth, IslandStats, MAX_ISLANDS,
    STATS_FIXED_LEN, SolverStats, StatsError, StepTotals,
};

/// Solver variant names as they appear on the wire, in the CLI and in reports.
pub const SOLVER_VARIANTS: [&str; 7] =
    ["full", "downdate", "skyline", "skyline-refactor", "incremental", "auto", "pgs"];
