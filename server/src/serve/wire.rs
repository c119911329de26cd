//! Exhaustive conversions from the solver's and the world's types into the wire types of
//! `pivotsim-msgs` (and back where the wire names a solver setting). Every conversion is a `match`:
//! a new variant or status is a compile error here, never a silent default on the wire.

use pivotsim_msgs as msgs;

use crate::dynamics::IslandStats;
use crate::signals::{ContactStateKind, EventKind, Signals};
use crate::solver::{SolveStatus, Variant};

impl From<Variant> for msgs::SolverVariant {
    fn from(v: Variant) -> Self {
        match v {
            Variant::Full => msgs::SolverVariant::Full,
            Variant::Downdate => msgs::SolverVariant::Downdate,
            Variant::Skyline => msgs::SolverVariant::Skyline,
            Variant::SkylineRefactor => msgs::SolverVariant::SkylineRefactor,
            Variant::Incremental => msgs::SolverVariant::Incremental,
            Variant::Auto => msgs::SolverVariant::Auto,
            Variant::Pgs => msgs::SolverVariant::Pgs,
        }
    }
}

impl From<msgs::SolverVariant> for Variant {
    fn from(v: msgs::SolverVariant) -> Self {
        match v {
            msgs::SolverVariant::Full => Variant::Full,
            msgs::SolverVariant::Downdate => Variant::Downdate,
            msgs::SolverVariant::Skyline => Variant::Skyline,
            msgs::SolverVariant::SkylineRefactor => Variant::SkylineRefactor,
            msgs::SolverVariant::Incremental => Variant::Incremental,
            msgs::SolverVariant::Auto => Variant::Auto,
            msgs::SolverVariant::Pgs => Variant::Pgs,
        }
    }
}

impl From<SolveStatus> for msgs::SolveStatus {
    fn from(s: SolveStatus) -> Self {
        match s {
            SolveStatus::Converged => msgs::SolveStatus::Converged,
            SolveStatus::Inexact => msgs::SolveStatus::Inexact,
            SolveStatus::MaxSteps => msgs::SolveStatus::MaxSteps,
            SolveStatus::Empty => msgs::SolveStatus::Empty,
            SolveStatus::NonFinite => msgs::SolveStatus::NonFinite,
            SolveStatus::Budget => msgs::SolveStatus::Budget,
        }
    }
}

/// Saturating `usize` → `u32` (counts on the wire are `u32`).
fn count(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

impl From<&IslandStats> for msgs::IslandStats {
    fn from(s: &IslandStats) -> Self {
        // Every field of the world's island statistics is named here, so a new one is a compile
        // error until it is either sent or deliberately left off the wire.
        let IslandStats {
            island: _,
            bodies,
            rows,
            nnz: _,
            variant,
            status,
            fallback,
            pivot_steps,
            iterations,
            tight,
            residual: _,
            residual_rel,
            max_violation: _,
            assemble_us: _,
            solve_us,
            // The wall time goes on the wire; the CPU time is for the run summary and the report.
            solve_cpu_us: _,
            projection_us: _,
            // An offline measurement (`run --shadow`), not published.
            shadow: _,
        } = *s;
        msgs::IslandStats {
            variant: variant.into(),
            status: status.into(),
            fallback,
            rows: count(rows),
            bodies: count(bodies),
            pivot_steps: count(pivot_steps),
            tight: count(tight),
            iterations: count(iterations),
            solve_us: if solve_us.is_finite() { solve_us.max(0.0) } else { f64::MAX },
            // The wire wants finite values: a non-finite residual (a failed solve) is sent as the
            // largest one.
            residual_rel: if residual_rel.is_finite() { residual_rel.max(0.0) } else { f64::MAX },
        }
    }
}

impl From<ContactStateKind> for msgs::ContactCode {
    fn from(s: ContactStateKind) -> Self {
        match s {
            ContactStateKind::Open => msgs::ContactCode::Open,
            ContactStateKind::Stick => msgs::ContactCode::Stick,
            ContactStateKind::Slip => msgs::ContactCode::Slip,
        }
    }
}

impl From<EventKind> for msgs::EventCode {
    fn from(k: EventKind) -> Self {
        match k {
            EventKind::Raised => msgs::EventCode::Raised,
            EventKind::Cleared => msgs::EventCode::Cleared,
            EventKind::Fault => msgs::EventCode::Fault,
            EventKind::FaultRejected => msgs::EventCode::FaultRejected,
        }
    }
}

/// The wire names of a scene's channels (checked against the name rules when the scene was built;
/// a name that does not fit is replaced by `?`-free `invalid/{index}`).
pub(crate) fn channel_names(signals: &Signals) -> Vec<msgs::ActuatorName> {
    signals
        .channel_names()
        .iter()
        .enumerate()
        .map(|(i, n)| {
            msgs::ActuatorName::new(n)
                .or_else(|_| msgs::ActuatorName::new(&format!("invalid/{i}")))
                .expect("a short ASCII name")
        })
        .collect()
}

/// Fills `out` with the signals of the last step (reusing its vectors: no allocation once grown).
/// A non-finite reading (none is expected) is sent as a dropout.
pub(crate) fn fill_signals(
    signals: &Signals,
    names: &[msgs::ActuatorName],
    sequence: u64,
    sim_time: f64,
    out: &mut msgs::SignalsFrame,
) {
    out.sequence = sequence;
    out.sim_time = sim_time;
    out.events_total = signals.events_total();
    out.faults_applied = signals.faults_applied().min(u64::from(u32::MAX)) as u32;
    out.faults_rejected = signals.faults_rejected().min(u64::from(u32::MAX)) as u32;
    out.channels.clear();
    for ((name, &value), &valid) in names.iter().zip(signals.values()).zip(signals.valid()) {
        let ok = valid && value.is_finite();
        out.channels.push(msgs::SignalChannel {
            name: *name,
            dropout: !ok,
            value: if ok { value } else { 0.0 },
        });
    }
    out.contacts.clear();
    for c in signals.contacts().iter().take(msgs::MAX_CONTACTS) {
        let finite = |x: f64| if x.is_finite() { x } else { 0.0 };
        out.contacts.push(msgs::ContactRecord {
            body_a: c.bodies[0].0,
            body_b: c.bodies[1].0,
            state: c.state.into(),
            point: [finite(c.point.x), finite(c.point.y), finite(c.point.z)],
            normal_force: finite(c.normal_force).max(0.0),
            friction_force: finite(c.friction_force).max(0.0),
            normal: [finite(c.normal.x), finite(c.normal.y), finite(c.normal.z)],
            friction: [finite(c.friction.x), finite(c.friction.y), finite(c.friction.z)],
        });
    }
}

/// Fills `out` with the last step's events, at most [`msgs::MAX_EVENTS`], earliest first.
pub(crate) fn fill_events(signals: &Signals, sequence: u64, sim_time: f64, out: &mut msgs::EventsFrame) {
    out.sequence = sequence;
    out.sim_time = sim_time;
    out.events_total = signals.events_total();
    out.events.clear();
    push_events(signals, &mut out.events);
}

/// Appends the last step's events as wire records to `out`, up to [`msgs::MAX_EVENTS`] in all
/// (an event whose name is not a wire name is left out).
fn push_events(signals: &Signals, out: &mut Vec<msgs::EventRecord>) {
    for e in signals.events() {
        if out.len() >= msgs::MAX_EVENTS {
            break;
        }
        let finite = |x: f64| if x.is_finite() { x } else { 0.0 };
        let Ok(name) = msgs::ActuatorName::new(e.name.as_str()) else { continue };
        out.push(msgs::EventRecord {
            name,
            kind: e.kind.into(),
            time: finite(e.time).max(0.0),
            value: finite(e.value),
            level: finite(e.level),
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_solver_variant_list_is_the_wire_list() {
        let names: Vec<&str> = Variant::ALL.iter().map(|v| v.name()).collect();
        assert_eq!(names, msgs::SOLVER_VARIANTS);
        for (i, v) in Variant::ALL.into_iter().enumerate() {
            let w = msgs::SolverVariant::from(v);
            assert_eq!(usize::from(w.code()), i, "{v}: wire code");
            assert_eq!(w.name(), v.name());
            assert_eq!(Variant::from(w), v);
        }
        assert_eq!(msgs::SolverVariant::ALL.len(), Variant::ALL.len());
    }

    #[test]
    fn statuses_keep_their_names() {
        for s in [
            SolveStatus::Converged,
            SolveStatus::Inexact,
            SolveStatus::MaxSteps,
            SolveStatus::Empty,
            SolveStatus::NonFinite,
            SolveStatus::Budget,
        ] {
            assert_eq!(msgs::SolveStatus::from(s).name(), s.name());
        }
        assert_eq!(msgs::SolveStatus::ALL.len(), 6);
    }

    #[test]
    fn island_stats_carry_the_fallback_flag_and_stay_finite() {
        let mut s = IslandStats {
            bodies: 3,
            rows: 12,
            variant: Variant::Auto,
            status: SolveStatus::MaxSteps,
            fallback: true,
            pivot_steps: 35,
            tight: 4,
            solve_us: 12.5,
            residual_rel: 1e-3,
            ..Default::default()
        };
        let w = msgs::IslandStats::from(&s);
        assert!(w.fallback);
        assert_eq!(
            (w.variant, w.status, w.rows, w.bodies, w.pivot_steps, w.tight),
            (msgs::SolverVariant::Auto, msgs::SolveStatus::MaxSteps, 12, 3, 35, 4)
        );
        s.fallback = false;
        s.residual_rel = f64::NAN;
        let w = msgs::IslandStats::from(&s);
        assert!(!w.fallback);
        assert_eq!(w.residual_rel, f64::MAX);
    }
}
