//! Powertrain couplings between joints' rotations: a gear pair and a differential, each optionally
//! torque-bounded (a slipping clutch). The model and its validation; the row is built in
//! `coupling_rows.rs`.
//!
//! **Shaft speeds.** A coupling acts on the *angular free axis* of hinge (or cylindrical) joints:
//! shaft `t` turns at `ω_t = ṡ_t = e₁ · (ω_A − ω_B)`, its angle's rate of body A relative to body B
//! (`joint_rows.rs`), so a shaft may run in a moving housing (a gearbox on a chassis).
//!
//! **One velocity row** per coupling, `Σ_t k_t ω_t = 0`:
//!
//! | coupling | row | coefficients `k_t` |
//! |---|---|---|
//! | gear | `ω_a − ρ ω_b = 0` | `(1, −ρ)` |
//! | differential | `ω_in − ρ (ω_left + ω_right) / 2 = 0` | `(1, −ρ/2, −ρ/2)` |
//! | rack | `ṡ_rack − ρ ω_pinion = 0` | `(1, −ρ)` |
//!
//! A **rack** couples the *linear* free axis of a prismatic (or cylindrical) joint, `ṡ = −e₁ ·
//! (v_A − v_B)` at the anchor (`joint_rows.rs`), to a pinion's rotation with `ρ` its pitch radius
//! (m): a cable drum paying a cable in and out through its fairlead (`chain.rs`), a rack-and-pinion
//! steering. Its impulse is then a force `λ / h` on the rack and a torque `ρ λ / h` on the pinion.
//!
//! with the ratio `ρ > 0` (the sense of rotation is carried by the joint axes: to reverse it,
//! build one joint with the opposite axis). Its Jacobian is `J = Σ_t k_t J_{s,t}`, so its impulse
//! `λ` turns shaft `t` with torque `k_t λ / h` (and its housing with the opposite). When the row
//! holds it does no work (`λ J v⁺ = 0`: power in equals power out, with compliance up to the
//! damper's `c τ² / h`). A differential therefore splits its input torque equally between
//! the two outputs, `τ_left = τ_right = −(ρ/2) τ_in`, and lets them turn at different speeds whose
//! mean is `ω_in / ρ`: one output braked, the other turns at `2 ω_in / ρ`.
//!
//! The row is velocity-level (it holds speeds, not phases: the angle between two geared shafts
//! drifts by `∫ c τ / h dt` with compliance `c`, none with `c = 0`), which is also what a clutch
//! needs. **Clutch**: with a torque bound `τ_max` the row is boxed, `λ ∈ [−τ_max h, τ_max h]`,
//! bounding the torque at the first shaft (`ρ τ_max` at a gear's second). Below the bound the
//! shafts stay locked to the ratio; a load needing more makes the clutch slip, each side then
//! accelerating under `±τ_max` alone. The bound can be changed live
//! ([`World::set_coupling_max_torque`](super::World::set_coupling_max_torque)): engage, slip,
//! disengage (`0`).
//!
//! **Bodies.** A coupling's one row touches at most four bodies ([`MAX_COUPLING_BODIES`], which
//! sizes every row's blocks, `rows.rs`): a gear (two joints, four bodies at most) always fits; a
//! differential fits when its three shafts share their housing (or the world), as in a car's axle —
//! otherwise the model is refused ([`CouplingError::TooManyBodies`]).

use super::error::CouplingError;
use super::ids::{BodyId, CouplingId, JointId};
use super::joint::{DEFAULT_COMPLIANCE, Joint};
use super::motor::FreeAxis;

/// Most bodies one coupling joins (module doc); its row has a block for each.
pub(crate) const MAX_COUPLING_BODIES: usize = 4;

/// What a coupling couples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CouplingKind {
    /// `ω_a − ratio · ω_b = 0`.
    Gear {
        /// First shaft (its torque is the bounded one).
        joint_a: JointId,
        /// Second shaft.
        joint_b: JointId,
        /// Ratio `ρ > 0`.
        ratio: f64,
    },
    /// `ω_in − ratio · (ω_left + ω_right) / 2 = 0`.
    Differential {
        /// Input shaft (the carrier, driven by the pinion).
        input: JointId,
        /// Left output.
        left: JointId,
        /// Right output.
        right: JointId,
        /// Ratio `ρ > 0` (the final drive).
        ratio: f64,
    },
    /// `ṡ_rack − radius · ω_pinion = 0`: a linear free axis driven by a rotation.
    Rack {
        /// The prismatic (or cylindrical) joint whose slide is driven (its force is the bounded one).
        rack: JointId,
        /// The hinge (or cylindrical) joint that turns.
        pinion: JointId,
        /// Pitch radius `ρ > 0` (m).
        radius: f64,
    },
}

impl CouplingKind {
    /// Name used in reports and errors.
    pub fn name(&self) -> &'static str {
        match self {
            CouplingKind::Gear { .. } => "gear",
            CouplingKind::Differential { .. } => "differential",
            CouplingKind::Rack { .. } => "rack",
        }
    }

    /// The ratio `ρ`.
    pub fn ratio(&self) -> f64 {
        match *self {
            CouplingKind::Gear { ratio, .. } | CouplingKind::Differential { ratio, .. } => ratio,
            CouplingKind::Rack { radius, .. } => radius,
        }
    }

    /// The shafts' joints and row coefficients `k_t` (module table), up to three.
    fn terms(&self) -> ([(JointId, f64); 3], usize) {
        match *self {
            CouplingKind::Gear { joint_a, joint_b, ratio } => {
                ([(joint_a, 1.0), (joint_b, -ratio), (joint_b, 0.0)], 2)
            }
            CouplingKind::Differential { input, left, right, ratio } => {
                ([(input, 1.0), (left, -0.5 * ratio), (right, -0.5 * ratio)], 3)
            }
            CouplingKind::Rack { rack, pinion, radius } => {
                ([(rack, 1.0), (pinion, -radius), (pinion, 0.0)], 2)
            }
        }
    }

    /// The free axis of term `t` (a rack's first term is linear, every other term angular).
    pub fn axis(&self, t: usize) -> FreeAxis {
        match (self, t) {
            (CouplingKind::Rack { .. }, 0) => FreeAxis::Linear,
            _ => FreeAxis::Angular,
        }
    }
}

/// Builder of a coupling; validated by [`World::add_coupling`](super::World::add_coupling).
#[derive(Debug, Clone)]
pub struct CouplingBuilder {
    pub(crate) name: String,
    pub(crate) kind: CouplingKind,
    pub(crate) compliance: f64,
    pub(crate) max_torque: Option<f64>,
}

impl CouplingBuilder {
    /// A coupling of `kind` with the default compliance and no torque bound.
    pub fn new(name: &str, kind: CouplingKind) -> Self {
        CouplingBuilder { name: name.to_string(), kind, compliance: DEFAULT_COMPLIANCE, max_torque: None }
    }

    /// A gear pair `ω_a = ratio · ω_b` between the rotations of two hinge (or cylindrical) joints.
    pub fn gear(name: &str, joint_a: JointId, joint_b: JointId, ratio: f64) -> Self {
        Self::new(name, CouplingKind::Gear { joint_a, joint_b, ratio })
    }

    /// An open differential `ω_in = ratio · (ω_left + ω_right) / 2`.
    pub fn differential(name: &str, input: JointId, left: JointId, right: JointId, ratio: f64) -> Self {
        Self::new(name, CouplingKind::Differential { input, left, right, ratio })
    }

    /// A rack `ṡ_rack = radius · ω_pinion` between the slide of a prismatic (or cylindrical) joint
    /// and the rotation of a hinge (or cylindrical) joint.
    pub fn rack(name: &str, rack: JointId, pinion: JointId, radius: f64) -> Self {
        Self::new(name, CouplingKind::Rack { rack, pinion, radius })
    }

    /// Row compliance `c ≥ 0` (rad/(N m); a velocity row: `J v⁺ = −c τ / h` at steady state).
    pub fn compliance(mut self, c: f64) -> Self {
        self.compliance = c;
        self
    }

    /// Torque bound `τ_max ≥ 0` at the first shaft: a slipping clutch.
    pub fn max_torque(mut self, tau: f64) -> Self {
        self.max_torque = Some(tau);
        self
    }

    /// The name given.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Validates against the world's joints and builds the coupling with id `id` (the name's
    /// uniqueness is checked by the world).
    pub(crate) fn build(self, id: CouplingId, joints: &[Joint]) -> Result<Coupling, CouplingError> {
        let coupling = || self.name.clone();
        if self.name.is_empty() {
            return Err(CouplingError::EmptyName);
        }
        let ratio = self.kind.ratio();
        if !(ratio.is_finite() && ratio > 0.0) {
            return Err(CouplingError::InvalidRatio { coupling: coupling(), ratio });
        }
        let (terms, n_terms) = self.kind.terms();
        let mut bodies: Vec<BodyId> = Vec::with_capacity(2 * n_terms);
        for (t, &(id, _)) in terms[..n_terms].iter().enumerate() {
            let j = joints
                .get(id.index())
                .ok_or(CouplingError::UnknownJoint { coupling: coupling(), joint: id })?;
            if terms[..t].iter().any(|&(other, _)| other == id) {
                return Err(CouplingError::RepeatedJoint { coupling: coupling(), joint: j.name.clone() });
            }
            if self.kind.axis(t) == FreeAxis::Linear && !j.kind.has_axis(FreeAxis::Linear) {
                return Err(CouplingError::NotLinear {
                    coupling: coupling(),
                    joint: j.name.clone(),
                    kind: j.kind.name(),
                });
            }
            if self.kind.axis(t) == FreeAxis::Angular && !j.kind.has_axis(FreeAxis::Angular) {
                return Err(CouplingError::NotRotational {
                    coupling: coupling(),
                    joint: j.name.clone(),
                    kind: j.kind.name(),
                });
            }
            for b in std::iter::once(j.body_a).chain(j.body_b) {
                if !bodies.contains(&b) {
                    bodies.push(b);
                }
            }
        }
        if bodies.len() > MAX_COUPLING_BODIES {
            return Err(CouplingError::TooManyBodies { coupling: coupling(), bodies: bodies.len() });
        }
        if !(self.compliance.is_finite() && self.compliance >= 0.0) {
            return Err(CouplingError::InvalidCompliance { coupling: coupling(), value: self.compliance });
        }
        if let Some(tau) = self.max_torque {
            validate_max_torque(&self.name, tau)?;
        }
        Ok(Coupling {
            id,
            name: self.name,
            kind: self.kind,
            compliance: self.compliance,
            max_torque: self.max_torque,
            terms,
            n_terms,
        })
    }
}

/// Checks a clutch bound: finite and `≥ 0`.
pub(crate) fn validate_max_torque(name: &str, tau: f64) -> Result<(), CouplingError> {
    if tau.is_finite() && tau >= 0.0 {
        Ok(())
    } else {
        Err(CouplingError::InvalidMaxTorque { coupling: name.to_string(), value: tau })
    }
}

/// A validated coupling (the model). Built by [`World::add_coupling`](super::World::add_coupling).
#[derive(Debug, Clone)]
pub struct Coupling {
    pub(crate) id: CouplingId,
    pub(crate) name: String,
    pub(crate) kind: CouplingKind,
    pub(crate) compliance: f64,
    pub(crate) max_torque: Option<f64>,
    terms: [(JointId, f64); 3],
    n_terms: usize,
}

impl Coupling {
    /// Id.
    pub fn id(&self) -> CouplingId {
        self.id
    }
    /// Name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// Kind, joints and ratio.
    pub fn kind(&self) -> &CouplingKind {
        &self.kind
    }
    /// Row compliance.
    pub fn compliance(&self) -> f64 {
        self.compliance
    }
    /// Clutch torque bound, if any.
    pub fn max_torque(&self) -> Option<f64> {
        self.max_torque
    }
    /// The shafts' joints and their row coefficients `k_t` (module table).
    pub fn terms(&self) -> &[(JointId, f64)] {
        &self.terms[..self.n_terms]
    }
}
