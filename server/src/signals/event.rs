//! The events of a step and the thresholds that raise them: plain data, no evaluation (that is
//! `events.rs`, on [`super::Signals`]'s channels).

/// Which side of the level raises a threshold.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ThresholdDir {
    /// Raised above the level.
    Above,
    /// Raised below the level.
    Below,
}

/// A declared threshold on a channel.
#[derive(Debug, Clone, PartialEq)]
pub struct Threshold {
    /// Event name (wire name rules: 1 to 32 bytes of `[A-Za-z0-9_.-/]`).
    pub name: EventName,
    /// The channel's index in the signals' channel names (`Signals::channel_names`).
    pub channel: usize,
    /// Side.
    pub dir: ThresholdDir,
    /// Level, in the channel's unit.
    pub level: f64,
    /// Hysteresis of the clear (≥ 0).
    pub hysteresis: f64,
    /// Seconds the raise (or the clear) condition must hold without a break before the event
    /// fires (≥ 0; 0: at the first step): a channel that flickers across its level, like a
    /// contact's `sliding` flag while a load creeps, raises one event, not one per flicker.
    pub hold: f64,
    /// Raised now.
    pub active: bool,
    /// Since when the condition that would change `active` has held (`None`: it does not hold).
    pub since: Option<f64>,
}

/// What happened.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum EventKind {
    /// A threshold was crossed.
    Raised,
    /// A threshold's channel came back.
    Cleared,
    /// A fault took effect.
    Fault,
    /// A fault request was refused (unknown target, bad value).
    FaultRejected,
}

/// An event name stored inline (at most 32 bytes: no allocation per event).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(into = "String", from = "String")]
pub struct EventName {
    bytes: [u8; 32],
    len: u8,
}

impl EventName {
    /// The name as a wire name (`msgs/README.md`, events: 1 to 32 bytes of `[A-Za-z0-9_.\-/]`):
    /// every character outside that set becomes one `_`, an empty name is `_`, and a name of more
    /// than 32 characters keeps its first 30 and ends in `..`, so that a refused fault's target of
    /// any length or spelling still gives a record, marked where it was changed.
    pub fn new(s: &str) -> Self {
        let mapped = s.chars().map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '_' | '.' | '-' | '/') { c as u8 } else { b'_' }
        });
        let mut bytes = [0; 32];
        let mut len = 0;
        if s.chars().count() > 32 {
            for (dst, b) in bytes.iter_mut().zip(mapped.take(30)) {
                *dst = b;
            }
            bytes[30] = b'.';
            bytes[31] = b'.';
            len = 32;
        } else {
            for b in mapped {
                bytes[len] = b;
                len += 1;
            }
        }
        if len == 0 {
            bytes[0] = b'_';
            len = 1;
        }
        EventName { bytes, len: len as u8 }
    }
    /// As text.
    pub fn as_str(&self) -> &str {
        std::str::from_utf8(&self.bytes[..self.len as usize]).unwrap_or("")
    }
}

/// One event of a step.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Event {
    /// What.
    pub kind: EventKind,
    /// The threshold's or fault's name.
    pub name: EventName,
    /// Simulation time at the end of the step (s).
    pub time: f64,
    /// The channel's value (a tension that broke a rope; 0 when there is none).
    pub value: f64,
    /// The threshold's level (a fault's limit; 0 when there is none).
    pub level: f64,
}

/// A name read back (a snapshot) passes through [`EventName::new`]'s rules again.
impl From<String> for EventName {
    fn from(s: String) -> Self {
        EventName::new(&s)
    }
}

impl From<EventName> for String {
    fn from(n: EventName) -> Self {
        n.as_str().to_string()
    }
}
