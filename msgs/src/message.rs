//! Any frame: decode by the header's kind, for recorders, bridges and tests.
//!
//! Subscribers that know what a key carries call the message's own decoder
//! ([`PoseFrameView::parse`](crate::PoseFrameView::parse), [`InputCommand::decode`], …), which also
//! rejects a frame of the wrong kind. [`Message::decode`] accepts every kind.

use crate::control::{ControlError, ControlReply, ControlRequest};
use crate::header::{self, DecodeError, FrameError, Kind};
use crate::input::{InputCommand, InputError};
use crate::journal::{AppliedFrame, JournalError, KeyframeReason, KeyframeView};
use crate::pose::{PoseError, PoseFrame};
use crate::scene::{SceneDescription, SceneError};
use crate::signals::{EventsFrame, SignalsError, SignalsFrame};
use crate::stats::{SolverStats, StatsError};

/// A decoded frame of any kind.
#[derive(Debug, Clone, PartialEq)]
pub enum Message {
    /// `0x0001`.
    Pose(PoseFrame),
    /// `0x0002`.
    Stats(SolverStats),
    /// `0x0003`.
    Signals(SignalsFrame),
    /// `0x0004`.
    Events(EventsFrame),
    /// `0x0005`.
    Applied(AppliedFrame),
    /// `0x0006`, owning its snapshot bytes.
    Keyframe {
        /// The state the snapshot holds.
        sequence: u64,
        /// Its time (s).
        sim_time: f64,
        /// Why it was taken.
        reason: KeyframeReason,
        /// The snapshot file.
        snapshot: Vec<u8>,
    },
    /// `0x0010..=0x0013`.
    Input(InputCommand),
    /// `0x0100`.
    ControlRequest(ControlRequest),
    /// `0x0101`.
    ControlReply(ControlReply),
    /// `0x0102`.
    Scene(SceneDescription),
}

/// Why a frame of any kind did not decode or encode.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MessageError {
    /// Header, length or payload layout.
    #[error(transparent)]
    Frame(#[from] FrameError),
    /// Pose frame content.
    #[error(transparent)]
    Pose(#[from] PoseError),
    /// Stats content.
    #[error(transparent)]
    Stats(#[from] StatsError),
    /// Signals or events content.
    #[error(transparent)]
    Signals(#[from] SignalsError),
    /// Journal content.
    #[error(transparent)]
    Journal(#[from] JournalError),
    /// Input content.
    #[error(transparent)]
    Input(#[from] InputError),
    /// Control request or reply content.
    #[error(transparent)]
    Control(#[from] ControlError),
    /// Scene description content.
    #[error(transparent)]
    Scene(#[from] SceneError),
}

impl<E> From<DecodeError<E>> for MessageError
where
    E: std::error::Error + 'static,
    MessageError: From<E>,
{
    fn from(e: DecodeError<E>) -> Self {
        match e {
            DecodeError::Frame(f) => MessageError::Frame(f),
            DecodeError::Invalid(e) => e.into(),
        }
    }
}

impl Message {
    /// Frame kind.
    pub fn kind(&self) -> Kind {
        match self {
            Message::Pose(_) => Kind::PoseFrame,
            Message::Stats(_) => Kind::SolverStats,
            Message::Signals(_) => Kind::Signals,
            Message::Events(_) => Kind::Events,
            Message::Applied(_) => Kind::Applied,
            Message::Keyframe { .. } => Kind::Keyframe,
            Message::Input(i) => i.kind(),
            Message::ControlRequest(_) => Kind::ControlRequest,
            Message::ControlReply(_) => Kind::ControlReply,
            Message::Scene(_) => Kind::SceneDescription,
        }
    }

    /// Decodes and validates a frame of any kind.
    pub fn decode(bytes: &[u8]) -> Result<Message, MessageError> {
        Ok(match header::peek(bytes)?.kind {
            Kind::PoseFrame => Message::Pose(PoseFrame::decode(bytes)?),
            Kind::SolverStats => Message::Stats(SolverStats::decode(bytes)?),
            Kind::Signals => Message::Signals(SignalsFrame::decode(bytes)?),
            Kind::Events => Message::Events(EventsFrame::decode(bytes)?),
            Kind::Applied => Message::Applied(AppliedFrame::decode(bytes)?),
            Kind::Keyframe => {
                let k = KeyframeView::parse(bytes)?;
                Message::Keyframe {
                    sequence: k.sequence,
                    sim_time: k.sim_time,
                    reason: k.reason,
                    snapshot: k.snapshot.to_vec(),
                }
            }
            Kind::Joystick | Kind::Winch | Kind::Boom | Kind::Actuator => {
                Message::Input(InputCommand::decode(bytes)?)
            }
            Kind::ControlRequest => Message::ControlRequest(ControlRequest::decode(bytes)?),
            Kind::ControlReply => Message::ControlReply(ControlReply::decode(bytes)?),
            Kind::SceneDescription => Message::Scene(SceneDescription::decode(bytes)?),
        })
    }

    /// Clears `buf` and writes the frame. On error `buf` is left empty.
    pub fn encode(&self, buf: &mut Vec<u8>) -> Result<(), MessageError> {
        match self {
            Message::Pose(m) => m.encode(buf)?,
            Message::Stats(m) => m.encode(buf)?,
            Message::Signals(m) => m.encode(buf)?,
            Message::Events(m) => m.encode(buf)?,
            Message::Applied(m) => m.encode(buf)?,
            Message::Keyframe { sequence, sim_time, reason, snapshot } => {
                KeyframeView { sequence: *sequence, sim_time: *sim_time, reason: *reason, snapshot }
                    .encode(buf)?
            }
            Message::Input(m) => m.encode(buf)?,
            Message::ControlRequest(m) => m.encode(buf)?,
            Message::ControlReply(m) => m.encode(buf)?,
            Message::Scene(m) => m.encode(buf)?,
        }
        Ok(())
    }
}
