//! What of the signals carries from one step to the next (a snapshot, `snapshot/`): the sensors
//! that dropped out, each threshold's raised flag and debounce clock, the events of the last step
//! and those queued for the next, the counters. The channel values and contact records are not in
//! it: [`Signals::evaluate`] computes them from the world alone.

use serde::{Deserialize, Serialize};

use super::{Event, MAX_QUEUED_EVENTS, Signals};

/// The signals' state (module doc).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SignalsState {
    dropout: Vec<bool>,
    /// Per threshold: raised, and since when the condition that would change that has held.
    thresholds: Vec<(bool, Option<f64>)>,
    fired: Vec<Event>,
    queued: Vec<Event>,
    events_total: u64,
    faults_applied: u64,
    faults_rejected: u64,
}

/// A signals state for another scene (other sensors or thresholds).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("the state has {found} {what}, the scene {expected}")]
pub struct SignalsStateError {
    /// Sensors or thresholds.
    pub what: &'static str,
    /// The scene's.
    pub expected: usize,
    /// The state's.
    pub found: usize,
}

impl Signals {
    /// The state (module doc).
    pub fn state(&self) -> SignalsState {
        SignalsState {
            dropout: self.dropout.clone(),
            thresholds: self.thresholds.iter().map(|t| (t.active, t.since)).collect(),
            fired: self.fired.clone(),
            queued: self.queued.clone(),
            events_total: self.events_total,
            faults_applied: self.faults_applied,
            faults_rejected: self.faults_rejected,
        }
    }

    /// Puts `state` back, checked first against the scene's sensors and thresholds (nothing
    /// changes on an error); call [`Signals::evaluate`] after the world's restore to recompute the
    /// channels.
    pub fn restore_state(&mut self, state: &SignalsState) -> Result<(), SignalsStateError> {
        self.check_state(state)?;
        self.dropout.clone_from(&state.dropout);
        for (t, &(active, since)) in self.thresholds.iter_mut().zip(&state.thresholds) {
            (t.active, t.since) = (active, since);
        }
        self.fired.clone_from(&state.fired);
        self.queued.clone_from(&state.queued);
        self.events_total = state.events_total;
        self.faults_applied = state.faults_applied;
        self.faults_rejected = state.faults_rejected;
        Ok(())
    }

    /// Whether `state` fits these signals (the same sensors and thresholds, a bounded queue).
    pub fn check_state(&self, state: &SignalsState) -> Result<(), SignalsStateError> {
        let check = |what, expected: usize, found: usize| match expected == found {
            true => Ok(()),
            false => Err(SignalsStateError { what, expected, found }),
        };
        check("sensors", self.dropout.len(), state.dropout.len())?;
        check("thresholds", self.thresholds.len(), state.thresholds.len())?;
        match state.queued.len() <= MAX_QUEUED_EVENTS {
            true => Ok(()),
            false => Err(SignalsStateError {
                what: "queued events",
                expected: MAX_QUEUED_EVENTS,
                found: state.queued.len(),
            }),
        }
    }
}
