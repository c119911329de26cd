//! Payload sizes of the binary frame kinds, the lowest layer of the format: the header bounds
//! a frame's payload by them (`Kind::max_payload_len`) before any payload byte is read, and each
//! kind's codec lays its payload out by them. Specified byte by byte in `msgs/README.md`.

// Inputs (`input.rs`).
/// Joystick payload bytes.
pub const JOYSTICK_LEN: usize = 152;
/// Winch payload bytes.
pub const WINCH_LEN: usize = 56;
/// Actuator payload bytes.
pub const ACTUATOR_LEN: usize = 56;
/// Fixed part of a boom payload.
pub const BOOM_FIXED_LEN: usize = 16;
/// Bytes of one boom entry.
pub const BOOM_ENTRY_LEN: usize = 40;
/// Most entries of a boom command.
pub const MAX_BOOM_TARGETS: usize = 16;

// Pose frames (`pose.rs`).
/// Bytes of the fixed part of a pose frame's payload.
pub const POSE_FIXED_LEN: usize = 32;
/// Bytes of one body record.
pub const BODY_RECORD_LEN: usize = 112;
/// Most bodies in one frame.
pub const MAX_BODIES: usize = 65_535;

// Solver statistics (`stats.rs`).
/// Bytes of the fixed part of a stats frame's payload.
pub const STATS_FIXED_LEN: usize = 176;
/// Bytes of one island record.
pub const ISLAND_RECORD_LEN: usize = 40;
/// Most islands in one frame.
pub const MAX_ISLANDS: usize = 65_535;

// Signals and events (`signals.rs`).
/// Bytes of the fixed part of a signals frame's payload.
pub const SIGNALS_FIXED_LEN: usize = 40;
/// Bytes of one channel record.
pub const CHANNEL_RECORD_LEN: usize = 48;
/// Bytes of one contact record.
pub const CONTACT_RECORD_LEN: usize = 104;
/// Most channels in one frame.
pub const MAX_CHANNELS: usize = 4096;
/// Most contact records in one frame.
pub const MAX_CONTACTS: usize = 4096;
/// Bytes of the fixed part of an events frame's payload.
pub const EVENTS_FIXED_LEN: usize = 32;
/// Bytes of one event record.
pub const EVENT_RECORD_LEN: usize = 64;
/// Most events in one frame.
pub const MAX_EVENTS: usize = 1024;
