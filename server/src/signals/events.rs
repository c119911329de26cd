//! Threshold events on channels (a tipping margin below 10 %, a rope over its rating, a load
//! slipping on the forks) and the event records faults add, with the simulation time.
//!
//! A threshold `above L` (`below L`) is *raised* at the first step whose value is `> L` (`< L`) and
//! *cleared* at the first later step whose value is back `≤ L − hyst` (`≥ L + hyst`); a dropped-out
//! channel neither raises nor clears. Each raise and clear is one [`Event`] of that step. With a
//! hold `τ > 0` the raise (clear) condition must hold at every step from some time `t₀` to the
//! step at `t ≥ t₀ + τ`, which then fires; a step without it starts the count again (a debounce:
//! a 0/1 flag that flickers raises one event, which a hysteresis cannot give a flag).

use super::eval::Signals;
use super::event::{Event, EventKind, Threshold, ThresholdDir};

impl Signals {
    /// Declares a threshold (the scene builder; sizes the event buffer).
    pub fn add_threshold(&mut self, t: Threshold) {
        self.thresholds.push(t);
        self.fired.reserve(2);
    }

    /// Room for events of `n` more faults per step (the scene builder).
    pub fn reserve_events(&mut self, n: usize) {
        self.fired.reserve(n);
    }

    /// Clears the last step's events (called before a step's faults and thresholds); the events
    /// queued since ([`Signals::queue_event`]) become this step's first.
    pub fn begin_events(&mut self) {
        self.fired.clear();
        self.fired.append(&mut self.queued);
    }

    /// Records an event between steps (a refused request): counted now, listed with the next
    /// step's events (the first [`MAX_QUEUED_EVENTS`](super::MAX_QUEUED_EVENTS) of them).
    pub fn queue_event(&mut self, e: Event) {
        self.count(e.kind);
        if self.queued.len() < self.queued.capacity() {
            self.queued.push(e);
        }
    }

    fn count(&mut self, kind: EventKind) {
        self.events_total += 1;
        match kind {
            EventKind::Fault => self.faults_applied += 1,
            EventKind::FaultRejected => self.faults_rejected += 1,
            EventKind::Raised | EventKind::Cleared => {}
        }
    }

    /// Records an event of this step.
    pub fn push_event(&mut self, e: Event) {
        self.fired.push(e);
        self.count(e.kind);
    }

    /// Checks every threshold on the values of this step at time `time`.
    pub fn check_thresholds(&mut self, time: f64) {
        for i in 0..self.thresholds.len() {
            let t = &self.thresholds[i];
            if !self.valid[t.channel] {
                continue;
            }
            let v = self.values[t.channel];
            let (raise, clear) = match t.dir {
                ThresholdDir::Above => (v > t.level, v <= t.level - t.hysteresis),
                ThresholdDir::Below => (v < t.level, v >= t.level + t.hysteresis),
            };
            let (kind, holds) =
                if t.active { (EventKind::Cleared, clear) } else { (EventKind::Raised, raise) };
            let (name, level, hold) = (t.name, t.level, t.hold);
            if !holds {
                self.thresholds[i].since = None;
                continue;
            }
            let since = *self.thresholds[i].since.get_or_insert(time);
            // A hold of k steps is met at the k-th step's time, up to rounding of the sum.
            if time - since < hold - 1e-9 {
                continue;
            }
            self.thresholds[i].active = kind == EventKind::Raised;
            self.thresholds[i].since = None;
            self.push_event(Event { kind, name, time, value: v, level });
        }
    }

    /// Back to the state at load: thresholds lowered, counters and dropouts cleared.
    pub fn reset(&mut self) {
        for t in &mut self.thresholds {
            t.active = false;
            t.since = None;
        }
        self.fired.clear();
        self.queued.clear();
        self.dropout.fill(false);
        self.events_total = 0;
        self.faults_applied = 0;
        self.faults_rejected = 0;
    }
}
