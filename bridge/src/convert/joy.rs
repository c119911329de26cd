//! `sensor_msgs/Joy` → a pivotsim joystick frame, with the `/joy` path's counters.

use super::*;

/// Counters of the `/joy` path (bridge side), reported in the bridge's diagnostics and logs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct JoyCounters {
    /// Joy messages received from ROS.
    pub received: u64,
    /// Forwarded to the server as joystick frames.
    pub forwarded: u64,
    /// Rejected by the bridge, indexed by [`msgs::RejectReason::code`].
    pub rejected: [u64; msgs::REJECT_REASONS],
    /// Forwarded frames whose Zenoh put failed.
    pub put_failed: u64,
}

impl JoyCounters {
    /// All bridge-side rejections.
    pub fn rejected_total(&self) -> u64 {
        self.rejected.iter().sum()
    }

    /// Rejections for `reason`.
    pub fn rejected_for(&self, reason: msgs::RejectReason) -> u64 {
        self.rejected[reason.code() as usize]
    }
}

/// Turns `sensor_msgs/Joy` messages into joystick frames of one source: a fresh sequence number
/// per accepted message, the same validation as the server's (counts, finite, axes in [−1, 1],
/// buttons 0 or 1), rejections counted by reason.
#[derive(Debug, Clone)]
pub struct JoyTranslator {
    source_id: u32,
    sequence: u64,
    /// Counters so far.
    pub counters: JoyCounters,
}

impl JoyTranslator {
    /// A translator for frames of `source_id`.
    pub fn new(source_id: u32) -> JoyTranslator {
        JoyTranslator { source_id, sequence: 0, counters: JoyCounters::default() }
    }

    /// The source id of the frames.
    pub fn source_id(&self) -> u32 {
        self.source_id
    }

    /// Validates `joy` and encodes it as a joystick frame into `buf`, or counts and returns the
    /// reason it was rejected (`buf` is then empty).
    pub fn translate(&mut self, joy: &Joy, buf: &mut Vec<u8>) -> Result<(), msgs::RejectReason> {
        self.counters.received += 1;
        buf.clear();
        match self.frame(joy, buf) {
            Ok(()) => {
                self.counters.forwarded += 1;
                Ok(())
            }
            Err(reason) => {
                buf.clear();
                let c = &mut self.counters.rejected[reason.code() as usize];
                *c = c.saturating_add(1);
                Err(reason)
            }
        }
    }

    fn frame(&mut self, joy: &Joy, buf: &mut Vec<u8>) -> Result<(), msgs::RejectReason> {
        if joy.axes.len() > msgs::MAX_AXES || joy.buttons.len() > msgs::MAX_BUTTONS {
            return Err(msgs::RejectReason::Oversize);
        }
        if joy.axes.iter().any(|a| !a.is_finite()) {
            return Err(msgs::RejectReason::NonFinite);
        }
        if joy.axes.iter().any(|a| !(-1.0..=1.0).contains(a)) || joy.buttons.iter().any(|&b| b != 0 && b != 1)
        {
            return Err(msgs::RejectReason::OutOfRange);
        }
        let buttons = joy.buttons.iter().enumerate().fold(0u64, |m, (i, &b)| m | (u64::from(b == 1) << i));
        let j = msgs::Joystick::new(
            self.sequence + 1,
            self.source_id,
            &joy.axes,
            buttons,
            joy.buttons.len() as u8,
        )
        .ok_or(msgs::RejectReason::Oversize)?;
        msgs::InputCommand::Joystick(j).encode(buf).map_err(|e| e.reject_reason())?;
        self.sequence += 1;
        Ok(())
    }
}
