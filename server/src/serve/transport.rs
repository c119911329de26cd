//! What the loop and its transports share: the bounded inbox ([`Inbound`] items, the
//! transports' [`InboxSender`]), one step's encoded [`Frames`], the [`Transport`] trait, and the
//! [`ErrorThrottle`] for publisher failures.

use pivotsim_msgs as msgs;
use tracing::warn;

/// Inbox capacity (inputs and control requests waiting for the loop).
pub const INBOX_CAPACITY: usize = 1024;

/// Something a transport received for the loop.
pub enum Inbound {
    /// An input frame on a topic (`None`: the frame's own kind decides).
    Input {
        /// Topic it arrived on.
        topic: Option<msgs::Topic>,
        /// The frame.
        bytes: Vec<u8>,
    },
    /// A lockstep controller's liveliness token appeared (`present`) or went away.
    Controller {
        /// Its id (the token's last key segment).
        id: String,
        /// Whether it is there.
        present: bool,
    },
    /// A control request and where its reply goes.
    Control {
        /// The request frame.
        bytes: Vec<u8>,
        /// Sends the encoded reply.
        reply: Box<dyn FnOnce(Vec<u8>) + Send>,
    },
}

impl std::fmt::Debug for Inbound {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Inbound::Input { topic, bytes } => write!(f, "Input({topic:?}, {} bytes)", bytes.len()),
            Inbound::Control { bytes, .. } => write!(f, "Control({} bytes)", bytes.len()),
            Inbound::Controller { id, present } => write!(f, "Controller({id}, {present})"),
        }
    }
}

/// The transports' side of the inbox (`pivotsim_link::inbox`): never blocks; drops are counted,
/// and a dropped control request is answered `busy` at once.
#[derive(Debug, Clone)]
pub struct InboxSender(pivotsim_link::InboxSender<Inbound>);

impl InboxSender {
    /// Offers an item; `false` (and a counted drop) when the inbox is full or closed.
    pub fn offer(&self, item: Inbound) -> bool {
        match self.0.offer(item) {
            Ok(()) => true,
            Err(Inbound::Control { bytes, reply }) => {
                let id = msgs::ControlRequest::peek_id(&bytes).unwrap_or(0);
                let r = msgs::ControlReply::error(id, msgs::ControlErrorCode::Busy, "server inbox full");
                let mut buf = Vec::new();
                if r.encode(&mut buf).is_ok() {
                    reply(buf);
                }
                false
            }
            Err(Inbound::Input { .. } | Inbound::Controller { .. }) => false,
        }
    }
}

/// A bounded inbox of [`INBOX_CAPACITY`]: the sender for transports, the receiver for the loop.
pub fn inbox() -> (InboxSender, pivotsim_link::Inbox<Inbound>) {
    let (tx, rx) = pivotsim_link::inbox(INBOX_CAPACITY);
    (InboxSender(tx), rx)
}

/// One step's encoded frames, as the transports publish them.
#[derive(Debug, Clone, Copy)]
pub struct Frames<'a> {
    /// Pose frame (`poses`).
    pub poses: &'a [u8],
    /// Solver stats (`stats`).
    pub stats: &'a [u8],
    /// Signals (`signals`).
    pub signals: &'a [u8],
    /// Events (`events`); empty when the step had none: nothing is published.
    pub events: &'a [u8],
    /// Applied frames (`applied`, Zenoh only): none when the step applied nothing.
    pub applied: &'a [Vec<u8>],
    /// Keyframe (`keyframes`, Zenoh only); empty when none was due.
    pub keyframe: &'a [u8],
}

/// A transport as the loop sees it.
pub trait Transport {
    /// Publishes one step's frames; never blocks on subscribers.
    fn publish(&mut self, frames: Frames<'_>);
    /// Hands over inputs and control requests received since the last call (transports that
    /// poll), and sends the replies the loop produced since.
    fn poll(&mut self, _inbox: &InboxSender) {}
    /// Sends the control replies the loop produced since the last call, when the transport sends
    /// them itself rather than in the reply closure (iceoryx2); the loop calls it after answering.
    fn flush(&mut self) {}
    /// Whether inputs reach the loop only through [`Transport::poll`] (nothing wakes the loop
    /// for them): a paused loop then polls at short intervals while a controller is active.
    fn polled(&self) -> bool {
        false
    }
    /// Inputs refused before they reached the loop since the last call (Zenoh's access control);
    /// the loop counts them as `other`. Reading it allocates nothing.
    fn take_refused(&mut self) -> u64 {
        0
    }
    /// The scene description changed (load, reset).
    fn set_description(&mut self, _bytes: &[u8]) {}
    /// A short status for the status line.
    fn status(&mut self) -> String;
    /// One line for the start message: the transport, where it listens, its keys or services.
    fn describe(&self) -> String;
}

/// Rate-limited warning for publisher failures: logs the first and then every 1000th.
#[derive(Debug, Default)]
pub struct ErrorThrottle {
    count: u64,
}

impl ErrorThrottle {
    /// Records a failure; logs it when due.
    pub fn fail(&mut self, what: &str, e: &dyn std::fmt::Display) {
        if self.count.is_multiple_of(1000) {
            warn!("{what}: {e} ({} failures so far; retrying every step)", self.count + 1);
        }
        self.count += 1;
    }
}
