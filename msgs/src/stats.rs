//! Solver statistics (kind `0x0002`): one frame per step, per-island records and step totals, plus
//! the health of the operator inputs.
//!
//! ```text
//! payload offset  size  field
//!              0     8  sequence          u64, the pose frame's sequence of the same step
//!              8     8  sim_time          f64, s (finite, ≥ 0)
//!             16     8  step_wall_us      f64, µs, wall time of the whole step
//!             24     4  island_count      u32, ≤ MAX_ISLANDS (65 535)
//!             28     4  overruns          u32, steps so far that missed their real-time slot
//!             32     4  total_rows        u32, Σ m
//!             36     4  total_bodies      u32, Σ bodies
//!             40     4  total_tight       u32, Σ tight (≤ total_rows)
//!             44     4  fallback_islands  u32, islands whose solve took a fallback
//!             48     8  total_pivot_steps u64
//!             56     8  total_solve_us    f64, µs
//!             64     8  max_residual_rel  f64
//!             72     8  inputs_accepted   u64, since start
//!             80    72  inputs_rejected   u64 × 9, since start, indexed by RejectReason code
//!            152     4  deadman_trips     u32, since start
//!            156     1  deadman_active    u8, 0 or 1: actuators are held at neutral now
//!            157     1  unstable          u8, 0 or 1: the server's instability watchdog flagged this step
//!            158     2  unstable_steps    u16, steps flagged since the scene was (re)loaded, saturating
//!            160     4  solves_capped     u32, island solves stopped by the pivot-step cap, since (re)load
//!            164     4  solves_inexact    u32, island solves that ended inexact, since (re)load
//!            168     4  solves_budget     u32, island solves stopped by the time budget, since (re)load
//!            172     4  solves_fallback   u32, island solves in which a safeguard ran, since (re)load
//!            176    40  island record × island_count
//!
//! island record   size  field
//!              0     1  variant           u8, SolverVariant code
//!              1     1  status            u8, SolveStatus code
//!              2     1  flags             u8: bit 0 fallback taken
//!              3     1  reserved          0
//!              4     4  rows              u32, m
//!              8     4  bodies            u32
//!             12     4  pivot_steps       u32
//!             16     4  tight             u32, ≤ rows
//!             20     4  iterations        u32, PGS sweeps (0 for pivoting variants)
//!             24     8  solve_us          f64, µs
//!             32     8  residual_rel      f64, ‖r‖∞ / ‖λ‖∞
//! ```
//!
//! Every `f64` is finite and ≥ 0. The totals are sent, not recomputed by the decoder (the server may
//! count work outside the listed islands); [`StepTotals::from_islands`] computes them.

use crate::codes::{REJECT_REASONS, RejectReason, SolveStatus, SolverVariant};
use crate::header::{self, DecodeError, FrameError, HEADER_LEN, Kind};
pub use crate::layout::{ISLAND_RECORD_LEN, MAX_ISLANDS, STATS_FIXED_LEN};
use crate::le;

/// Island flag: a fallback (projected Newton, Murty, semismooth Newton) ran.
pub const ISLAND_FALLBACK: u8 = 1;

/// One island's solve in the step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct IslandStats {
    /// Variant that solved it.
    pub variant: SolverVariant,
    /// How the solve ended.
    pub status: SolveStatus,
    /// A fallback ran.
    pub fallback: bool,
    /// Rows `m`.
    pub rows: u32,
    /// Bodies in the island.
    pub bodies: u32,
    /// Pivot steps.
    pub pivot_steps: u32,
    /// Tight rows of the solution.
    pub tight: u32,
    /// PGS sweeps (0 for pivoting variants).
    pub iterations: u32,
    /// Solver wall time (µs).
    pub solve_us: f64,
    /// Relative natural-map residual.
    pub residual_rel: f64,
}

/// Totals over the step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StepTotals {
    /// Σ rows.
    pub rows: u32,
    /// Σ bodies.
    pub bodies: u32,
    /// Σ tight.
    pub tight: u32,
    /// Islands with a fallback.
    pub fallback_islands: u32,
    /// Σ pivot steps.
    pub pivot_steps: u64,
    /// Σ solve time (µs).
    pub solve_us: f64,
    /// Largest relative residual.
    pub residual_rel_max: f64,
}

impl StepTotals {
    /// Totals of `islands` (saturating).
    pub fn from_islands(islands: &[IslandStats]) -> StepTotals {
        let mut t = StepTotals::default();
        for i in islands {
            t.rows = t.rows.saturating_add(i.rows);
            t.bodies = t.bodies.saturating_add(i.bodies);
            t.tight = t.tight.saturating_add(i.tight);
            t.fallback_islands += u32::from(i.fallback);
            t.pivot_steps += u64::from(i.pivot_steps);
            t.solve_us += i.solve_us;
            t.residual_rel_max = t.residual_rel_max.max(i.residual_rel);
        }
        t
    }
}

/// Counters of the input path since the server started.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct InputHealth {
    /// Inputs that reached the world.
    pub accepted: u64,
    /// Rejected inputs, indexed by [`RejectReason::code`].
    pub rejected: [u64; REJECT_REASONS],
    /// Times the deadman fired.
    pub deadman_trips: u32,
    /// The deadman holds every actuator at neutral now.
    pub deadman_active: bool,
}

impl InputHealth {
    /// Counts one rejection.
    pub fn reject(&mut self, reason: RejectReason) {
        let c = &mut self.rejected[reason.code() as usize];
        *c = c.saturating_add(1);
    }

    /// Rejections for `reason`.
    pub fn rejected_for(&self, reason: RejectReason) -> u64 {
        self.rejected[reason.code() as usize]
    }

    /// All rejections.
    pub fn rejected_total(&self) -> u64 {
        self.rejected.iter().fold(0u64, |a, &b| a.saturating_add(b))
    }
}

/// An owned stats frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SolverStats {
    /// Step sequence number (same as the step's pose frame).
    pub sequence: u64,
    /// Simulation time (s).
    pub sim_time: f64,
    /// Wall time of the step (µs).
    pub step_wall_us: f64,
    /// Overrun steps since start.
    pub overruns: u32,
    /// Totals over the islands.
    pub totals: StepTotals,
    /// Input counters.
    pub inputs: InputHealth,
    /// Per-island records.
    pub islands: Vec<IslandStats>,
    /// The server's instability watchdog flagged this step (energy gained beyond the initial
    /// energy and the inputs' work, or a body beyond the scene's speed bound).
    pub unstable: bool,
    /// Steps the watchdog flagged since the scene was (re)loaded, saturating at 65 535.
    pub unstable_steps: u16,
    /// Degraded island solves since the scene was (re)loaded: none is silent.
    pub degraded: DegradedSolves,
}

/// Island solves that did not end exact, counted since the scene was (re)loaded (saturating), so
/// that a receiver that drops frames still sees every one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DegradedSolves {
    /// Stopped by the pivot-step cap (status `max-steps`).
    pub capped: u32,
    /// Ended inexact.
    pub inexact: u32,
    /// Stopped by the time budget (status `budget`).
    pub budget: u32,
    /// A safeguard of the pivoting ran (the island's fallback flag).
    pub fallback: u32,
}

impl DegradedSolves {
    /// Counts one island's solve (saturating).
    pub fn count(&mut self, status: SolveStatus, fallback: bool) {
        let add = |c: &mut u32, yes: bool| *c = c.saturating_add(u32::from(yes));
        add(&mut self.capped, status == SolveStatus::MaxSteps);
        add(&mut self.inexact, status == SolveStatus::Inexact);
        add(&mut self.budget, status == SolveStatus::Budget);
        add(&mut self.fallback, fallback);
    }
}

/// What is wrong with the content of a stats frame.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StatsError {
    /// More than [`MAX_ISLANDS`] islands.
    #[error("{count} islands in one frame (at most {MAX_ISLANDS})")]
    TooManyIslands {
        /// Islands in the frame.
        count: usize,
    },
    /// NaN or ±Inf (`island` is the record index, `None` for the frame's fields).
    #[error("non-finite {field} (island record {island:?})")]
    NonFinite {
        /// Record index.
        island: Option<usize>,
        /// Field name.
        field: &'static str,
    },
    /// A time or residual below zero.
    #[error("negative {field} {value} (island record {island:?})")]
    Negative {
        /// Record index.
        island: Option<usize>,
        /// Field name.
        field: &'static str,
        /// The value.
        value: f64,
    },
    /// Variant code outside `0..=6`.
    #[error("island record {island}: unknown solver variant code {code}")]
    UnknownVariant {
        /// Record index.
        island: usize,
        /// The code.
        code: u8,
    },
    /// Status code outside `0..=4`.
    #[error("island record {island}: unknown solve status code {code}")]
    UnknownStatus {
        /// Record index.
        island: usize,
        /// The code.
        code: u8,
    },
    /// Undefined island flag bits.
    #[error("island record {island}: undefined flags 0x{flags:02x}")]
    IslandFlags {
        /// Record index.
        island: usize,
        /// The flags.
        flags: u8,
    },
    /// More tight rows than rows.
    #[error("tight {tight} > rows {rows} (island record {island:?})")]
    TightExceedsRows {
        /// Record index, `None` for the totals.
        island: Option<usize>,
        /// Tight count.
        tight: u32,
        /// Rows.
        rows: u32,
    },
    /// `deadman_active` byte neither 0 nor 1.
    #[error("deadman_active byte {value} (must be 0 or 1)")]
    DeadmanFlag {
        /// The byte.
        value: u8,
    },
    /// `unstable` byte neither 0 nor 1.
    #[error("unstable byte {value} (must be 0 or 1)")]
    UnstableFlag {
        /// The byte.
        value: u8,
    },
}

fn non_negative(island: Option<usize>, field: &'static str, value: f64) -> Result<(), StatsError> {
    if !value.is_finite() {
        return Err(StatsError::NonFinite { island, field });
    }
    if value < 0.0 {
        return Err(StatsError::Negative { island, field, value });
    }
    Ok(())
}

impl IslandStats {
    /// Checks the record (`index` names it in errors).
    pub fn validate(&self, index: usize) -> Result<(), StatsError> {
        let i = Some(index);
        if self.tight > self.rows {
            return Err(StatsError::TightExceedsRows { island: i, tight: self.tight, rows: self.rows });
        }
        non_negative(i, "solve_us", self.solve_us)?;
        non_negative(i, "residual_rel", self.residual_rel)
    }

    fn read(r: &[u8], index: usize) -> Result<IslandStats, DecodeError<StatsError>> {
        let inv = DecodeError::Invalid;
        let code = r[0];
        let variant =
            SolverVariant::from_code(code).ok_or(inv(StatsError::UnknownVariant { island: index, code }))?;
        let code = r[1];
        let status =
            SolveStatus::from_code(code).ok_or(inv(StatsError::UnknownStatus { island: index, code }))?;
        let flags = r[2];
        if flags & !ISLAND_FALLBACK != 0 {
            return Err(inv(StatsError::IslandFlags { island: index, flags }));
        }
        Ok(IslandStats {
            variant,
            status,
            fallback: flags & ISLAND_FALLBACK != 0,
            rows: le::u32_at(r, 4),
            bodies: le::u32_at(r, 8),
            pivot_steps: le::u32_at(r, 12),
            tight: le::u32_at(r, 16),
            iterations: le::u32_at(r, 20),
            solve_us: le::f64_at(r, 24),
            residual_rel: le::f64_at(r, 32),
        })
    }

    fn write(&self, buf: &mut Vec<u8>) {
        let flags = if self.fallback { ISLAND_FALLBACK } else { 0 };
        buf.extend_from_slice(&[self.variant.code(), self.status.code(), flags, 0]);
        for v in [self.rows, self.bodies, self.pivot_steps, self.tight, self.iterations] {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        le::put_f64s(buf, &[self.solve_us, self.residual_rel]);
    }
}

impl SolverStats {
    /// Frame length in bytes: `16 + 160 + 40 · islands`.
    pub fn encoded_len(&self) -> usize {
        HEADER_LEN + STATS_FIXED_LEN + ISLAND_RECORD_LEN * self.islands.len()
    }

    /// Checks every rule a decoder checks.
    pub fn validate(&self) -> Result<(), StatsError> {
        if self.islands.len() > MAX_ISLANDS {
            return Err(StatsError::TooManyIslands { count: self.islands.len() });
        }
        self.validate_fixed()?;
        self.islands.iter().enumerate().try_for_each(|(i, s)| s.validate(i))
    }

    fn validate_fixed(&self) -> Result<(), StatsError> {
        non_negative(None, "sim_time", self.sim_time)?;
        non_negative(None, "step_wall_us", self.step_wall_us)?;
        non_negative(None, "total_solve_us", self.totals.solve_us)?;
        non_negative(None, "max_residual_rel", self.totals.residual_rel_max)?;
        let t = &self.totals;
        if t.tight > t.rows {
            return Err(StatsError::TightExceedsRows { island: None, tight: t.tight, rows: t.rows });
        }
        Ok(())
    }

    /// Clears `buf` and writes the frame; allocates only if `buf` must grow. On error `buf` is
    /// left empty.
    pub fn encode(&self, buf: &mut Vec<u8>) -> Result<(), StatsError> {
        buf.clear();
        self.validate()?;
        buf.reserve(self.encoded_len());
        header::begin(buf, Kind::SolverStats);
        let t = &self.totals;
        buf.extend_from_slice(&self.sequence.to_le_bytes());
        le::put_f64s(buf, &[self.sim_time, self.step_wall_us]);
        for v in [self.islands.len() as u32, self.overruns, t.rows, t.bodies, t.tight, t.fallback_islands] {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        buf.extend_from_slice(&t.pivot_steps.to_le_bytes());
        le::put_f64s(buf, &[t.solve_us, t.residual_rel_max]);
        buf.extend_from_slice(&self.inputs.accepted.to_le_bytes());
        for v in self.inputs.rejected {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        buf.extend_from_slice(&self.inputs.deadman_trips.to_le_bytes());
        buf.extend_from_slice(&[u8::from(self.inputs.deadman_active), u8::from(self.unstable)]);
        buf.extend_from_slice(&self.unstable_steps.to_le_bytes());
        let d = &self.degraded;
        for v in [d.capped, d.inexact, d.budget, d.fallback] {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        for i in &self.islands {
            i.write(buf);
        }
        header::set_payload_len(buf);
        Ok(())
    }

    /// Decodes and validates a frame.
    pub fn decode(bytes: &[u8]) -> Result<SolverStats, DecodeError<StatsError>> {
        let mut s = SolverStats::default();
        s.decode_into(bytes)?;
        Ok(s)
    }

    /// Decodes into `self`, reusing its island vector (no allocation once it has grown). On error
    /// `self` is unspecified but valid to reuse.
    pub fn decode_into(&mut self, bytes: &[u8]) -> Result<(), DecodeError<StatsError>> {
        let p = header::expect(bytes, Kind::SolverStats)?;
        let kind = Kind::SolverStats;
        if p.len() < STATS_FIXED_LEN {
            return Err(FrameError::PayloadLength { kind, expected: STATS_FIXED_LEN, found: p.len() }.into());
        }
        let count = le::u32_at(p, 24) as usize;
        if count > MAX_ISLANDS {
            return Err(DecodeError::Invalid(StatsError::TooManyIslands { count }));
        }
        let expected = STATS_FIXED_LEN + ISLAND_RECORD_LEN * count;
        if p.len() != expected {
            return Err(FrameError::PayloadLength { kind, expected, found: p.len() }.into());
        }
        let deadman = p[156];
        if deadman > 1 {
            return Err(DecodeError::Invalid(StatsError::DeadmanFlag { value: deadman }));
        }
        let unstable = p[157];
        if unstable > 1 {
            return Err(DecodeError::Invalid(StatsError::UnstableFlag { value: unstable }));
        }
        self.unstable = unstable == 1;
        self.unstable_steps = u16::from_le_bytes([p[158], p[159]]);
        self.degraded = DegradedSolves {
            capped: le::u32_at(p, 160),
            inexact: le::u32_at(p, 164),
            budget: le::u32_at(p, 168),
            fallback: le::u32_at(p, 172),
        };
        self.sequence = le::u64_at(p, 0);
        self.sim_time = le::f64_at(p, 8);
        self.step_wall_us = le::f64_at(p, 16);
        self.overruns = le::u32_at(p, 28);
        self.totals = StepTotals {
            rows: le::u32_at(p, 32),
            bodies: le::u32_at(p, 36),
            tight: le::u32_at(p, 40),
            fallback_islands: le::u32_at(p, 44),
            pivot_steps: le::u64_at(p, 48),
            solve_us: le::f64_at(p, 56),
            residual_rel_max: le::f64_at(p, 64),
        };
        self.inputs = InputHealth {
            accepted: le::u64_at(p, 72),
            rejected: std::array::from_fn(|i| le::u64_at(p, 80 + 8 * i)),
            deadman_trips: le::u32_at(p, 152),
            deadman_active: deadman == 1,
        };
        self.validate_fixed().map_err(DecodeError::Invalid)?;
        self.islands.clear();
        for (i, r) in p[STATS_FIXED_LEN..].chunks_exact(ISLAND_RECORD_LEN).enumerate() {
            let base = HEADER_LEN + STATS_FIXED_LEN + i * ISLAND_RECORD_LEN;
            header::check_reserved(r, 3..4, base)?;
            let s = IslandStats::read(r, i)?;
            s.validate(i).map_err(DecodeError::Invalid)?;
            self.islands.push(s);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn island(rows: u32, tight: u32) -> IslandStats {
        IslandStats {
            variant: SolverVariant::Auto,
            status: SolveStatus::Inexact,
            fallback: true,
            rows,
            bodies: 3,
            pivot_steps: 4,
            tight,
            iterations: 0,
            solve_us: 12.5,
            residual_rel: 1e-10,
        }
    }

    #[test]
    fn round_trip_and_totals() {
        let islands = vec![island(10, 4), island(6, 6)];
        let mut s = SolverStats {
            sequence: 3,
            sim_time: 0.05,
            step_wall_us: 800.0,
            overruns: 1,
            totals: StepTotals::from_islands(&islands),
            inputs: InputHealth::default(),
            islands,
            ..Default::default()
        };
        s.inputs.reject(RejectReason::Stale);
        s.inputs.deadman_active = true;
        assert_eq!(s.totals.rows, 16);
        assert_eq!(s.totals.fallback_islands, 2);
        let mut buf = Vec::new();
        s.encode(&mut buf).unwrap();
        assert_eq!(buf.len(), s.encoded_len());
        assert_eq!(SolverStats::decode(&buf).unwrap(), s);
        assert_eq!(s.inputs.rejected_for(RejectReason::Stale), 1);
        assert_eq!(s.inputs.rejected_total(), 1);
    }

    #[test]
    fn watchdog_and_degraded_counts_round_trip_and_a_bad_flag_is_refused() {
        let mut degraded = DegradedSolves::default();
        degraded.count(SolveStatus::MaxSteps, true);
        degraded.count(SolveStatus::Budget, false);
        degraded.count(SolveStatus::Inexact, true);
        degraded.count(SolveStatus::Converged, false);
        assert_eq!(degraded, DegradedSolves { capped: 1, inexact: 1, budget: 1, fallback: 2 });
        let s = SolverStats { unstable: true, unstable_steps: 65_535, degraded, ..Default::default() };
        let mut b = Vec::new();
        s.encode(&mut b).unwrap();
        assert_eq!(b.len(), HEADER_LEN + STATS_FIXED_LEN);
        assert_eq!(SolverStats::decode(&b).unwrap(), s);
        b[HEADER_LEN + 157] = 2;
        assert_eq!(SolverStats::decode(&b), Err(DecodeError::Invalid(StatsError::UnstableFlag { value: 2 })));
    }

    #[test]
    fn decoder_rejects_bad_codes() {
        let s = SolverStats { islands: vec![island(2, 1)], ..Default::default() };
        let mut buf = Vec::new();
        s.encode(&mut buf).unwrap();
        let rec = HEADER_LEN + STATS_FIXED_LEN;
        let mut b = buf.clone();
        b[rec] = 7;
        assert_eq!(
            SolverStats::decode(&b),
            Err(DecodeError::Invalid(StatsError::UnknownVariant { island: 0, code: 7 }))
        );
        let mut b = buf.clone();
        b[rec + 1] = 6;
        assert!(matches!(
            SolverStats::decode(&b),
            Err(DecodeError::Invalid(StatsError::UnknownStatus { .. }))
        ));
        let mut b = buf.clone();
        b[rec + 2] = 2;
        assert!(matches!(SolverStats::decode(&b), Err(DecodeError::Invalid(StatsError::IslandFlags { .. }))));
        let mut b = buf.clone();
        b[rec + 3] = 1;
        assert_eq!(SolverStats::decode(&b), Err(FrameError::ReservedNonZero { offset: rec + 3 }.into()));
        let mut b = buf.clone();
        b[HEADER_LEN + 156] = 2;
        assert!(matches!(
            SolverStats::decode(&b),
            Err(DecodeError::Invalid(StatsError::DeadmanFlag { value: 2 }))
        ));
    }
}
