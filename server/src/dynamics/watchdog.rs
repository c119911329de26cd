//! Instability watchdog: tells a world that is blowing up from one that is merely moving, while
//! every state is still finite (issue 12: a chain whose links fly at 1e9 m/s was reported
//! `finite: true`).
//!
//! Three checks after every step, against the state at the watchdog's start (time `t₀`):
//!
//! ```text
//!   energy:  E(t) − E(t₀) − W_in(t₀, t)  >  ε · max(K_max, |W_in|, m_tot |g| · 0.1 m)          (W1)
//!   speed:   max_k |v_k|  >  v_max                                                              (W2)
//!   joints:  max_j |(p_b − p_a)_⊥j|  >  e_max                                                   (W3)
//! ```
//!
//! with `E = K + U` the kinetic and gravitational potential energy of the dynamic bodies
//! ([`World::kinetic_energy`], [`World::potential_energy`]), `W_in` the work of the world's inputs
//! ([`World::input_work`]: motors, couplings, friction, springs, rows reaching kinematic or static
//! bodies, applied forces other than gravity) and `K_max` the largest kinetic energy seen. A stable
//! step can only lose energy apart from its inputs (implicit Euler and the constraint solve
//! dissipate; passive joint rows do no work in the limit); an unstable one gains it through its
//! passive rows — exactly what (W1) measures. The scale makes the margin `ε` (default 10 %)
//! relative to the energy in motion, with a floor (a body of the world's mass lifted 0.1 m) for
//! worlds at rest. `v_max` (default 100 m/s) is the scene's speed bound.
//!
//! (W3) is the joint drift of [`World::worst_joint_drift`]: the separation of an enabled joint's two
//! anchors across its locked directions (a prismatic or cylindrical joint's slide is its coordinate,
//! not an error) beyond its elastic deflection `|c λ / h|`. A joint held by an exact solve is off by
//! its compliance times its load — by design (paper eq. 1): a soft joint under a heavy load, or a
//! stiff one at an impact, gives by centimetres and is not broken — and by the second-order drift
//! `(h ω)² r / 2` of the step (`step.rs`), which the joint-error guard keeps below
//! `joint_error_tolerance`: micrometres to half a millimetre in the shipped scenes. A joint that opens by centimetres is a broken world even when (W1) and (W2) stay
//! quiet — energy pumped into one heavy joint's error can stay within the margin of a crane's energy
//! in motion — so the bound `e_max` (scene setting `max_joint_error`, default 1 cm) flags it and
//! names the joint. A joint disabled by a `break` fault is not watched. The watchdog only reports
//! (the runner's `stable: false`, the server's stats flag and count, a log warning); it never
//! changes the world.

use super::world::World;

/// Bounds of the watchdog (scene settings `max_speed`, `energy_margin`, `max_joint_error`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WatchdogSettings {
    /// Speed bound `v_max` (m/s) of (W2).
    pub max_speed: f64,
    /// Relative energy margin `ε` of (W1).
    pub energy_margin: f64,
    /// Joint error bound `e_max` (m) of (W3).
    pub max_joint_error: f64,
}

/// Default joint error bound `e_max` of (W3): 1 cm.
pub const DEFAULT_MAX_JOINT_ERROR: f64 = 0.01;

impl Default for WatchdogSettings {
    fn default() -> Self {
        WatchdogSettings { max_speed: 100.0, energy_margin: 0.1, max_joint_error: DEFAULT_MAX_JOINT_ERROR }
    }
}

/// What the watchdog found.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Instability {
    /// (W1): energy above the initial energy plus the inputs' work by more than the margin.
    EnergyGain {
        /// Simulated time (s).
        time: f64,
        /// `E − E₀ − W_in` (J).
        gain: f64,
        /// The allowed margin (J).
        margin: f64,
    },
    /// (W2): a body faster than the bound.
    Speed {
        /// Simulated time (s).
        time: f64,
        /// The body.
        body: String,
        /// Its speed (m/s).
        speed: f64,
        /// The bound (m/s).
        bound: f64,
    },
    /// (W3): a joint open beyond the bound.
    JointError {
        /// Simulated time (s).
        time: f64,
        /// The joint.
        joint: String,
        /// Its error (m).
        error: f64,
        /// The bound (m).
        bound: f64,
    },
}

impl Instability {
    /// Simulated time of the step that was flagged (s).
    pub fn time(&self) -> f64 {
        match self {
            Instability::EnergyGain { time, .. }
            | Instability::Speed { time, .. }
            | Instability::JointError { time, .. } => *time,
        }
    }
}

impl std::fmt::Display for Instability {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Instability::EnergyGain { time, gain, margin } => write!(
                f,
                "t = {time:.3} s: the world gained {gain:.4e} J beyond its initial energy and inputs \
                 (margin {margin:.4e} J)"
            ),
            Instability::Speed { time, body, speed, bound } => {
                write!(f, "t = {time:.3} s: body `{body}` moves at {speed:.4e} m/s (bound {bound} m/s)")
            }
            Instability::JointError { time, joint, error, bound } => {
                write!(f, "t = {time:.3} s: joint `{joint}` is open by {error:.4e} m (bound {bound} m)")
            }
        }
    }
}

/// The watchdog's state over a run.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct Watchdog {
    settings: WatchdogSettings,
    e0: f64,
    w0: f64,
    k_max: f64,
    floor: f64,
    first: Option<Instability>,
    count: u64,
}

impl Watchdog {
    /// Starts watching `world` from its current state.
    pub fn new(world: &World, settings: WatchdogSettings) -> Self {
        let g = world.settings().gravity.norm();
        let m: f64 = world.bodies().iter().filter(|b| b.is_dynamic()).map(|b| b.mass()).sum();
        let k = world.kinetic_energy();
        Watchdog {
            settings,
            e0: k + world.potential_energy(),
            w0: world.input_work(),
            k_max: k,
            floor: m * g * 0.1,
            first: None,
            count: 0,
        }
    }

    /// Checks the world after a step; returns what it found in this step (`None`: stable).
    pub fn check(&mut self, world: &World) -> Option<Instability> {
        let k = world.kinetic_energy();
        self.k_max = self.k_max.max(k);
        let w_in = world.input_work() - self.w0;
        let gain = k + world.potential_energy() - self.e0 - w_in;
        let margin = self.settings.energy_margin * self.k_max.max(w_in.abs()).max(self.floor);
        let time = world.time();
        let found = if gain.is_nan() || gain > margin {
            Some(Instability::EnergyGain { time, gain, margin })
        } else {
            let bound = self.settings.max_speed;
            world
                .bodies()
                .iter()
                .filter(|b| b.is_dynamic())
                .map(|b| (b, b.linvel().norm()))
                .find(|&(_, v)| v.is_nan() || v > bound)
                .map(|(b, speed)| Instability::Speed { time, body: b.name().to_string(), speed, bound })
                .or_else(|| self.joint_error(world, time))
        };
        if let Some(i) = &found {
            self.count += 1;
            if self.first.is_none() {
                self.first = Some(i.clone());
            }
        }
        found
    }

    /// (W3): the worst joint if its drift beyond its elastic deflection is beyond the bound (or
    /// NaN); the deflection is read only when an error exceeds the bound.
    fn joint_error(&self, world: &World, time: f64) -> Option<Instability> {
        let bound = self.settings.max_joint_error;
        let (id, error) = world.worst_joint_drift(bound)?;
        (error.is_nan() || error > bound).then(|| Instability::JointError {
            time,
            joint: world.joint(id).map_or("?", |j| j.name()).to_string(),
            error,
            bound,
        })
    }

    /// The first instability found, if any.
    pub fn first(&self) -> Option<&Instability> {
        self.first.as_ref()
    }

    /// Steps flagged so far.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// The settings.
    pub fn settings(&self) -> WatchdogSettings {
        self.settings
    }
}
