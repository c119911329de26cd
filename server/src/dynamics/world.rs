//! The world: settings, bodies, joints and force elements with their validation, and read access to
//! state and per-step results. Stepping is in `step.rs`, the optional position projection in
//! `projection.rs`.
//!
//! Ids are indices in creation order and stay valid for the world's life (nothing is removed yet).
//! Names are unique per kind of item and can be looked up.

use std::collections::HashMap;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use super::body::{BodyBuilder, BodyId, BodyKind, RigidBody};
use super::error::{BodyError, ControlError, ForceError, JointError, SettingsError, StateError};
use super::force::{ForceElement, ForceId};
use super::island::Islands;
use super::joint::{Joint, JointBuilder, JointFrames, JointId, JointKind, JointMotor, JointRow};
use super::stats::IslandStats;
use super::step::StepWorkspace;
use crate::solver::SolverOptions;

/// Settings of a [`World`].
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
    /// at every step end. Removes that error to round-off but dissipates energy at fast rotations.
    pub projection_iterations: usize,
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
        }
    }
}

impl WorldSettings {
    fn validate(&self) -> Result<(), SettingsError> {
        if !(self.timestep.is_finite() && self.timestep > 0.0) {
            return Err(SettingsError::InvalidTimestep(self.timestep));
        }
        if !self.gravity.iter().all(|g| g.is_finite()) {
            return Err(SettingsError::NonFiniteGravity(self.gravity.into()));
        }
        if self.projection_iterations > 16 {
            return Err(SettingsError::TooManyIterations {
                what: "projection_iterations",
                value: self.projection_iterations,
            });
        }
        Ok(())
    }
}

/// A joint's frames in world coordinates (see `joint.rs`): anchors `p_a`, `p_b` and x axes
/// `e₁` (of A's frame), `f₁` (of B's frame). A joint without violation has `p_a = p_b` (along the
/// free axis of a prismatic joint: up to the displacement) and, except for a ball joint,
/// `e₁ = f₁`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointFramesWorld {
    /// Anchor of A's frame.
    pub anchor_a: Vector3<f64>,
    /// Anchor of B's frame.
    pub anchor_b: Vector3<f64>,
    /// x axis of A's frame.
    pub axis_a: Vector3<f64>,
    /// x axis of B's frame.
    pub axis_b: Vector3<f64>,
}

/// A multibody world.
#[derive(Debug)]
pub struct World {
    pub(crate) settings: WorldSettings,
    pub(crate) bodies: Vec<RigidBody>,
    body_names: HashMap<String, BodyId>,
    pub(crate) joints: Vec<Joint>,
    joint_names: HashMap<String, JointId>,
    pub(crate) forces: Vec<ForceElement>,
    force_names: Vec<String>,
    pub(crate) time: f64,
    pub(crate) steps: u64,
    pub(crate) ws: StepWorkspace,
}

impl World {
    /// An empty world.
    pub fn new(settings: WorldSettings) -> Result<Self, SettingsError> {
        settings.validate()?;
        Ok(World {
            settings,
            bodies: Vec::new(),
            body_names: HashMap::new(),
            joints: Vec::new(),
            joint_names: HashMap::new(),
            forces: Vec::new(),
            force_names: Vec::new(),
            time: 0.0,
            steps: 0,
            ws: StepWorkspace::default(),
        })
    }

    /// Settings.
    pub fn settings(&self) -> &WorldSettings {
        &self.settings
    }

    /// Changes the settings (validated); solver options apply from the next step.
    pub fn set_settings(&mut self, settings: WorldSettings) -> Result<(), SettingsError> {
        settings.validate()?;
        self.settings = settings;
        for s in self.ws.solvers.iter_mut().chain(self.ws.proj_solvers.iter_mut()) {
            s.set_options(settings.solver);
        }
        Ok(())
    }

    /// Adds a body.
    pub fn add_body(&mut self, builder: BodyBuilder) -> Result<BodyId, BodyError> {
        if self.body_names.contains_key(builder.name()) {
            return Err(BodyError::DuplicateName { body: builder.name().to_string() });
        }
        let id = BodyId(self.bodies.len() as u32);
        let body = builder.build(id)?;
        self.body_names.insert(body.name().to_string(), id);
        self.bodies.push(body);
        Ok(id)
    }

    /// Adds a joint.
    pub fn add_joint(&mut self, jb: JointBuilder) -> Result<JointId, JointError> {
        let joint = || jb.name.clone();
        if jb.name.is_empty() {
            return Err(JointError::EmptyName);
        }
        if self.joint_names.contains_key(&jb.name) {
            return Err(JointError::DuplicateName { joint: joint() });
        }
        let get = |id: BodyId| {
            self.bodies.get(id.index()).ok_or(JointError::UnknownBody { joint: joint(), body: id })
        };
        let a = get(jb.body_a)?;
        let b = jb.body_b.map(get).transpose()?;
        if jb.body_b == Some(jb.body_a) {
            return Err(JointError::SelfJoint { joint: joint(), body: a.name().to_string() });
        }
        if !a.is_dynamic() && !b.is_some_and(RigidBody::is_dynamic) {
            return Err(JointError::NoDynamicBody { joint: joint() });
        }
        let pose_b = b.map(RigidBody::pose).unwrap_or_else(Isometry3::identity);
        let (frame_a, frame_b) = match jb.frames {
            JointFrames::World { anchor, axis } => {
                if !anchor.iter().all(|c| c.is_finite()) {
                    return Err(JointError::NonFinite { joint: joint(), what: "anchor" });
                }
                let w = Isometry3::from_parts(Translation3::from(anchor), frame_rotation(&jb.name, axis)?);
                (a.pose().inverse() * w, pose_b.inverse() * w)
            }
            JointFrames::Local { frame_a, frame_b } => {
                (checked_frame(&jb.name, "frame_a", frame_a)?, checked_frame(&jb.name, "frame_b", frame_b)?)
            }
        };
        for (row, &c) in jb.compliance.iter().enumerate() {
            if !(c.is_finite() && c >= 0.0) {
                return Err(JointError::InvalidCompliance { joint: joint(), row, value: c });
            }
        }
        if !(0.0..=1.0).contains(&jb.stabilization) {
            return Err(JointError::InvalidStabilization { joint: joint(), value: jb.stabilization });
        }
        if jb.limit.is_some() && !jb.kind.has_free_axis() {
            return Err(JointError::NoFreeAxis { joint: joint(), kind: jb.kind.name() });
        }
        if let Some(l) = jb.limit
            && (l.lower.is_nan()
                || l.upper.is_nan()
                || l.lower > l.upper
                || !(l.margin.is_finite() && l.margin >= 0.0))
        {
            return Err(JointError::InvalidLimit {
                joint: joint(),
                lower: l.lower,
                upper: l.upper,
                margin: l.margin,
            });
        }
        if let Some(m) = jb.motor {
            validate_motor(&jb.name, jb.kind, m)?;
        }
        let id = JointId(self.joints.len() as u32);
        self.joint_names.insert(jb.name.clone(), id);
        self.joints.push(Joint {
            id,
            name: jb.name,
            kind: jb.kind,
            body_a: jb.body_a,
            body_b: jb.body_b,
            frame_a,
            frame_b,
            compliance: jb.compliance,
            stabilization: jb.stabilization,
            limit: jb.limit,
            motor: jb.motor,
        });
        Ok(id)
    }

    /// Adds a named force element.
    pub fn add_force(&mut self, name: &str, element: ForceElement) -> Result<ForceId, ForceError> {
        if name.is_empty() {
            return Err(ForceError::EmptyName);
        }
        if self.force_names.iter().any(|n| n == name) {
            return Err(ForceError::DuplicateName { force: name.to_string() });
        }
        element.validate(name, &self.bodies)?;
        self.forces.push(element);
        self.force_names.push(name.to_string());
        Ok(ForceId(self.forces.len() as u32 - 1))
    }

    /// Sets a body's velocities (dynamic: an instantaneous change; kinematic: the scripted motion).
    pub fn set_velocity(
        &mut self,
        id: BodyId,
        linvel: Vector3<f64>,
        angvel: Vector3<f64>,
    ) -> Result<(), StateError> {
        let b = self.bodies.get_mut(id.index()).ok_or(StateError::UnknownBody(id))?;
        if b.kind() == BodyKind::Static {
            return Err(StateError::StaticBody(b.name().to_string()));
        }
        if !linvel.iter().chain(angvel.iter()).all(|c| c.is_finite()) {
            return Err(StateError::Invalid { body: b.name().to_string(), what: "velocity" });
        }
        b.linvel = linvel;
        b.angvel = angvel;
        Ok(())
    }

    /// Teleports a body (joints attached to it will pull it back).
    pub fn set_pose(
        &mut self,
        id: BodyId,
        position: Vector3<f64>,
        orientation: UnitQuaternion<f64>,
    ) -> Result<(), StateError> {
        let b = self.bodies.get_mut(id.index()).ok_or(StateError::UnknownBody(id))?;
        if b.kind() == BodyKind::Static {
            return Err(StateError::StaticBody(b.name().to_string()));
        }
        let q = super::body::unit(orientation.into_inner());
        match q {
            Some(q) if position.iter().all(|c| c.is_finite()) => {
                b.position = position;
                b.orientation = q;
                Ok(())
            }
            _ => Err(StateError::Invalid { body: b.name().to_string(), what: "pose" }),
        }
    }

    /// Changes (or removes) a joint's motor: the live control input of the free axis.
    pub fn set_joint_motor(&mut self, id: JointId, motor: Option<JointMotor>) -> Result<(), ControlError> {
        let j = self.joints.get_mut(id.index()).ok_or(ControlError::UnknownJoint(id))?;
        if let Some(m) = motor {
            validate_motor(&j.name, j.kind, m)?;
        }
        j.motor = motor;
        Ok(())
    }

    /// All bodies, indexed by [`BodyId::index`].
    pub fn bodies(&self) -> &[RigidBody] {
        &self.bodies
    }
    /// A body.
    pub fn body(&self, id: BodyId) -> Option<&RigidBody> {
        self.bodies.get(id.index())
    }
    /// A body's id by name.
    pub fn body_id(&self, name: &str) -> Option<BodyId> {
        self.body_names.get(name).copied()
    }
    /// All joints, indexed by [`JointId::index`].
    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }
    /// A joint.
    pub fn joint(&self, id: JointId) -> Option<&Joint> {
        self.joints.get(id.index())
    }
    /// A joint's id by name.
    pub fn joint_id(&self, name: &str) -> Option<JointId> {
        self.joint_names.get(name).copied()
    }
    /// Force elements, indexed by [`ForceId`].
    pub fn forces(&self) -> &[ForceElement] {
        &self.forces
    }
    /// Simulated time (s).
    pub fn time(&self) -> f64 {
        self.time
    }
    /// Steps taken.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Impulse `λ` (N s or N m s) of a joint row in the last step (0 if the row was not emitted).
    /// The mean force over the step is `λ / h`.
    pub fn joint_impulse(&self, id: JointId, row: JointRow) -> f64 {
        self.ws
            .warm
            .get(id.index())
            .map(|w| &w[row.slot()])
            .filter(|w| self.steps > 0 && w.stamp == self.steps)
            .map_or(0.0, |w| w.lambda)
    }

    /// Islands of the last step.
    pub fn islands(&self) -> &Islands {
        &self.ws.islands
    }

    /// Per-island stats of the last step (islands with rows only, in island order).
    pub fn island_stats(&self) -> &[IslandStats] {
        &self.ws.stats
    }

    /// Total linear momentum of the dynamic bodies.
    pub fn linear_momentum(&self) -> Vector3<f64> {
        self.bodies.iter().map(RigidBody::linear_momentum).sum()
    }

    /// Total angular momentum of the dynamic bodies about the world point `o`.
    pub fn angular_momentum(&self, o: Vector3<f64>) -> Vector3<f64> {
        self.bodies.iter().map(|b| b.angular_momentum(o)).sum()
    }

    /// Largest anchor separation `|p_b − p_a|` over all joints at the current poses (m).
    pub fn max_anchor_error(&self) -> f64 {
        self.joints.iter().map(|j| self.joint_geometry(j).anchor_error()).fold(0.0, f64::max)
    }

    pub(crate) fn joint_geometry(&self, j: &Joint) -> super::joint_rows::JointGeometry {
        let (a, b) = (self.side(Some(j.body_a)), self.side(j.body_b));
        super::joint_rows::JointGeometry::new(j, &a, &b)
    }

    /// World-frame anchors and axes of a joint at the current poses.
    pub fn joint_frames_world(&self, id: JointId) -> Option<JointFramesWorld> {
        let g = self.joint_geometry(self.joints.get(id.index())?);
        Some(JointFramesWorld { anchor_a: g.p_a, anchor_b: g.p_b, axis_a: g.e[0], axis_b: g.f[0] })
    }

    /// Free coordinate of a hinge (angle, rad) or prismatic joint (displacement, m).
    pub fn joint_coordinate(&self, id: JointId) -> Option<f64> {
        let j = self.joints.get(id.index())?;
        j.kind.has_free_axis().then(|| self.joint_geometry(j).free_coordinate(j.kind).0)
    }

    /// Relative speed along the free axis (rad/s or m/s).
    pub fn joint_speed(&self, id: JointId) -> Option<f64> {
        let j = self.joints.get(id.index())?;
        if !j.kind.has_free_axis() {
            return None;
        }
        let (a, b) = (self.side(Some(j.body_a)), self.side(j.body_b));
        let (_, ja, jb) = self.joint_geometry(j).free_coordinate(j.kind);
        Some(ja.dot(&a.v, &a.w) + jb.dot(&b.v, &b.w))
    }

    pub(crate) fn side(&self, id: Option<BodyId>) -> super::joint_rows::Side {
        match id {
            None => super::joint_rows::Side::world(),
            Some(id) => {
                let b = &self.bodies[id.index()];
                super::joint_rows::Side {
                    index: Some(id.index()),
                    x: b.position,
                    q: b.orientation,
                    v: b.linvel,
                    w: b.angvel,
                }
            }
        }
    }
}

pub(crate) fn validate_motor(name: &str, kind: JointKind, m: JointMotor) -> Result<(), JointError> {
    if !kind.has_free_axis() {
        return Err(JointError::NoFreeAxis { joint: name.to_string(), kind: kind.name() });
    }
    if !(m.target_speed.is_finite() && m.max_force.is_finite() && m.max_force >= 0.0) {
        return Err(JointError::InvalidMotor {
            joint: name.to_string(),
            target_speed: m.target_speed,
            max_force: m.max_force,
        });
    }
    Ok(())
}

/// Rotation whose x axis is `axis` (validated unit), with a deterministic completion.
fn frame_rotation(name: &str, axis: Vector3<f64>) -> Result<UnitQuaternion<f64>, JointError> {
    let norm = axis.norm();
    if !(norm.is_finite() && (norm - 1.0).abs() <= 1e-6) {
        return Err(JointError::NonUnitAxis { joint: name.to_string(), norm });
    }
    let e1 = axis / norm;
    // Helper: the world axis least aligned with e1.
    let helper = if e1.x.abs() <= e1.y.abs() && e1.x.abs() <= e1.z.abs() {
        Vector3::x()
    } else if e1.y.abs() <= e1.z.abs() {
        Vector3::y()
    } else {
        Vector3::z()
    };
    let e2 = (helper - e1 * e1.dot(&helper)).normalize();
    let e3 = e1.cross(&e2);
    Ok(UnitQuaternion::from_basis_unchecked(&[e1, e2, e3]))
}

fn checked_frame(name: &str, which: &'static str, f: Isometry3<f64>) -> Result<Isometry3<f64>, JointError> {
    if !f.translation.vector.iter().all(|c| c.is_finite()) {
        return Err(JointError::NonFinite { joint: name.to_string(), what: which });
    }
    let q = f.rotation.into_inner();
    let q = super::body::unit(q).ok_or(JointError::NonUnitFrame {
        joint: name.to_string(),
        which,
        norm: q.norm(),
    })?;
    Ok(Isometry3::from_parts(f.translation, q))
}
