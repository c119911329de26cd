//! The settings of a world: time step, gravity, solver options, and which refinements of the
//! paper's step are on (gyroscopic term, warm start, position projection, geometric stiffness).
//!
//! **Position projection — the default and its trade.** `projection_iterations` is 0 by default: the
//! paper's formulation alone (eq. 1–3), one MLCP per island per step. Its velocity-level rows leave
//! the chord error of integrating a rotation, `≈ (h ω)² r / 2` at an anchor at lever arm `r` (0.6 mm
//! for a hinged plate swinging at 3 rad/s with `r = 0.8 m`, `h = 1/60`); the next step removes it,
//! so it never accumulates, and joint *axes* (angular rows) hold to ~1e-9 regardless. With one
//! projection iteration anchors hold to ~1e-8 m (the drift bound of 1e-6 m over 20 s is met
//! only with it, `tests/dynamics_joint_drift.rs`), at the price of a second solve per island and
//! step and of dissipation at fast relative rotations (a free-floating chain spinning at 1–3 rad/s
//! loses 22 % of its angular momentum over 10 s, against 0.9 % without; a slow pendulum 0.13 % of
//! its amplitude over 10 periods). We keep the paper's formulation as the default — conservation and
//! cost over sub-millimetre gaps — and recommend `projection_iterations = 1` for machines whose
//! joints must not visibly open (fast linkages, long booms).

use nalgebra::Vector3;

use super::error::SettingsError;
use crate::solver::SolverOptions;

/// Settings of a [`World`](super::World).
#[derive(Debug, Clone, Copy)]
pub struct WorldSettings {
    /// Time step `h` (s); paper: 1/60.
    pub timestep: f64,
    /// Gravity (m/s²); z up.
    pub gravity: Vector3<f64>,
    /// Solver options of every island (variant default [`Variant::Skyline`](crate::solver::Variant)).
    pub solver: SolverOptions,
    /// Gyroscopic term: torque-free rotation that conserves angular momentum (see `step.rs`); off:
    /// `ω` carried over unchanged.
    pub gyroscopic: bool,
    /// Warm-start each island from the previous step's index set and impulses of persistent rows.
    pub warm_start: bool,
    /// Position projection (post-stabilization, `projection.rs`) iterations after the velocity
    /// step; 0 (default) = the paper's formulation alone, which leaves an `O((hω)² r)` anchor error
    /// at every step end. 1 removes that error to ~1e-8 m but costs a second solve per step and
    /// dissipates energy at fast rotations (module doc).
    pub projection_iterations: usize,
    /// The joint-error guard (m; 0 = off): after the velocity step and any `projection_iterations`,
    /// while the worst locked-anchor error of an enabled joint at the new poses exceeds this, one
    /// more projection, at most [`GUARD_ITERATIONS`](super::projection::GUARD_ITERATIONS) and only
    /// while each halves the error (`projection.rs`). Default [`DEFAULT_JOINT_ERROR_TOLERANCE`]: the
    /// nominal runs of the shipped scenes stay below it, so it costs one error evaluation per step
    /// there and acts at the events (a part freed by a break, a boom falling after a hose burst).
    pub joint_error_tolerance: f64,
    /// Most substeps a step may be re-run in (1 = never): when a joint is still open beyond
    /// `joint_error_tolerance` after the guard and a body turned more than
    /// [`SUBSTEP_TURN`](super::SUBSTEP_TURN) in the step, the step is re-run as `k` steps of `h/k`
    /// (`step.rs`, "Substeps"). Default 8.
    pub max_substeps: usize,
    /// Geometric stiffness of loaded joints (`geometric_stiffness.rs`): implicit by default (it
    /// only acts on bodies whose joint loads make the step unstable); `Off` is the paper's step as
    /// published.
    pub geometric_stiffness: GeometricStiffness,
}

impl Default for WorldSettings {
    fn default() -> Self {
        WorldSettings {
            timestep: 1.0 / 60.0,
            gravity: Vector3::new(0.0, 0.0, -9.81),
            solver: SolverOptions::default(),
            gyroscopic: true,
            warm_start: true,
            projection_iterations: 0,
            joint_error_tolerance: DEFAULT_JOINT_ERROR_TOLERANCE,
            max_substeps: 8,
            geometric_stiffness: GeometricStiffness::Implicit,
        }
    }
}

impl WorldSettings {
    pub(crate) fn validate(&self) -> Result<(), SettingsError> {
        if !(self.timestep.is_finite() && self.timestep > 0.0) {
            return Err(SettingsError::InvalidTimestep(self.timestep));
        }
        if !self.gravity.iter().all(|g| g.is_finite()) {
            return Err(SettingsError::NonFiniteGravity(self.gravity.into()));
        }
        if let Some(us) = self.solver.max_solve_us
            && !(us.is_finite() && us > 0.0)
        {
            return Err(SettingsError::InvalidSolveBudget(us));
        }
        if self.projection_iterations > 16 {
            return Err(SettingsError::TooManyIterations {
                what: "projection_iterations",
                value: self.projection_iterations,
            });
        }
        if self.max_substeps == 0 || self.max_substeps > 64 {
            return Err(SettingsError::InvalidSubsteps(self.max_substeps));
        }
        if !(self.joint_error_tolerance.is_finite() && self.joint_error_tolerance >= 0.0) {
            return Err(SettingsError::InvalidJointErrorTolerance(self.joint_error_tolerance));
        }
        Ok(())
    }
}

/// Default of [`WorldSettings::joint_error_tolerance`] (m): half a millimetre.
pub const DEFAULT_JOINT_ERROR_TOLERANCE: f64 = 5e-4;

/// How the geometric stiffness of loaded joints enters the step (`geometric_stiffness.rs`, eq. G3/G4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum GeometricStiffness {
    /// Not at all: the paper's step as published (joints' lever arms frozen at the step start).
    Off,
    /// Linearly implicit (G3), as Tournier et al. / Andrews et al.: energy only decays (default).
    #[default]
    Implicit,
    /// As added inertia against the change of velocity only (G4): no added damping; the energy
    /// oscillates by a few % about its initial value.
    Inertial,
}

impl GeometricStiffness {
    /// Every mode.
    pub const ALL: [GeometricStiffness; 3] =
        [GeometricStiffness::Off, GeometricStiffness::Implicit, GeometricStiffness::Inertial];

    /// The name in scene files.
    pub fn name(self) -> &'static str {
        match self {
            GeometricStiffness::Off => "off",
            GeometricStiffness::Implicit => "implicit",
            GeometricStiffness::Inertial => "inertial",
        }
    }

    /// The mode of a scene-file name.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }
}
