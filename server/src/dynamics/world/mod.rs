//! The world: its items (bodies, joints, couplings, force elements, colliders) with their
//! validation, its settings and the live control inputs, and the step that runs the stages of
//! `step.rs` on them. The rest of its API is in this folder: read access in `query.rs`, live model
//! changes in `control.rs`, colliders and friction in `colliders.rs`. The settings are in
//! `settings.rs`, the chain helper in `chain.rs`.
//!
//! Ids are indices in creation order and stay valid for the world's life (nothing is removed yet).
//! Names are unique per kind of item and can be looked up.

mod colliders;
mod control;
mod query;
mod state;

pub use query::{JointFramesWorld, JointReaction};
pub use state::{BodyState, JointState, WorldState, WorldStateError};

use std::collections::HashMap;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use super::body::{self, BodyBuilder, BodyKind, RigidBody};
use super::contact::ContactSet;
use super::coupling::{Coupling, CouplingBuilder, validate_max_torque};
use super::error::{
    BodyError, ControlError, CouplingError, ForceError, JointError, SettingsError, StateError, StepError,
    ThreadsError,
};
use super::force::ForceElement;
use super::ids::{BodyId, CouplingId, ForceId, JointId};
use super::joint::{Joint, JointBuilder, JointFrames, JointKind};
use super::motor::{FreeAxis, JointMotor};
use super::projection::project;
use super::settings::{GeometricStiffness, WorldSettings};
use super::step::StepWorkspace;

/// The turn of a body in one step (rad) beyond which an open joint is resolved by substeps.
pub const SUBSTEP_TURN: f64 = 0.25;

/// Most solver threads of a world ([`World::set_threads`]).
pub const MAX_THREADS: usize = 256;

/// A multibody world.
#[derive(Debug)]
pub struct World {
    pub(crate) settings: WorldSettings,
    pub(crate) bodies: Vec<RigidBody>,
    pub(crate) body_names: HashMap<String, BodyId>,
    pub(crate) joints: Vec<Joint>,
    pub(crate) joint_names: HashMap<String, JointId>,
    pub(crate) couplings: Vec<Coupling>,
    pub(crate) coupling_names: HashMap<String, CouplingId>,
    pub(crate) forces: Vec<ForceElement>,
    pub(crate) force_names: Vec<String>,
    pub(crate) time: f64,
    pub(crate) steps: u64,
    /// Solves taken (the warm-start records' stamp): one per step, `1 + k` for a step re-run as
    /// `k` substeps (`substeps` in the module doc of `step.rs`).
    pub(crate) solves: u64,
    pub(crate) ws: StepWorkspace,
    /// Colliders, contact settings and the narrow phase (`contact/`).
    pub(crate) contacts: ContactSet,
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
            couplings: Vec::new(),
            coupling_names: HashMap::new(),
            forces: Vec::new(),
            force_names: Vec::new(),
            time: 0.0,
            steps: 0,
            solves: 0,
            ws: StepWorkspace::default(),
            contacts: ContactSet::default(),
        })
    }

    /// Solver threads: `1` (the default) solves a step's islands in turn on the calling thread;
    /// `n > 1` solves them on a pool of `n` threads, made here once and kept (`step.rs`, "Islands
    /// in parallel"). The result is the same to the bit either way. Only the islands of one step
    /// run concurrently, and only when at least two of them are worth a thread.
    pub fn set_threads(&mut self, threads: usize) -> Result<(), ThreadsError> {
        if threads == 0 || threads > MAX_THREADS {
            return Err(ThreadsError::Count { threads, max: MAX_THREADS });
        }
        self.ws.pool = if threads == 1 {
            None
        } else {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .thread_name(|i| format!("pivotsim-solve-{i}"))
                .build()
                .map_err(|e| ThreadsError::Spawn { threads, message: e.to_string() })?;
            Some(pool)
        };
        Ok(())
    }

    /// How many times a step's islands were solved on the pool ([`Self::set_threads`]) since the
    /// world was built (re-solves and substeps count once each).
    pub fn parallel_solves(&self) -> u64 {
        self.ws.parallel_solves
    }

    /// Solver threads ([`Self::set_threads`]).
    pub fn threads(&self) -> usize {
        self.ws.pool.as_ref().map_or(1, rayon::ThreadPool::current_num_threads)
    }

    /// Settings.
    pub fn settings(&self) -> &WorldSettings {
        &self.settings
    }

    /// Changes the settings (validated); solver options apply from the next step.
    pub fn set_settings(&mut self, settings: WorldSettings) -> Result<(), SettingsError> {
        settings.validate()?;
        self.settings = settings;
        for s in self.ws.slots.iter_mut().map(|s| &mut s.solver).chain(self.ws.proj_solvers.iter_mut()) {
            s.set_options(settings.solver);
        }
        self.ws.shadows.set_options(settings.solver);
        Ok(())
    }

    /// Advances the world by one time step `h`: the stages of `step.rs` in order (its module doc),
    /// re-run as substeps where the step turned a body too far to resolve (`step.rs`, "Substeps").
    /// On error the bodies keep their state.
    pub fn step(&mut self) -> Result<(), StepError> {
        let h = self.settings.timestep;
        let s = self.solves;
        let input_work_before = self.ws.input_work;
        self.ws.substeps = 1;
        self.stages(self.settings, self.time, s)?;
        match self.substeps_needed() {
            None => {
                self.ws.commit(&mut self.bodies)?;
                self.solves = s + 1;
            }
            Some(k) => {
                // The attempt's impulses become the first substep's warm start (over h/k), its
                // input work is dropped; the bodies are kept to restore them on error.
                self.ws.input_work = input_work_before;
                self.ws.scale_stamped(s + 1, 1.0 / k as f64);
                self.ws.save_bodies(&self.bodies);
                let sub = WorldSettings { timestep: h / k as f64, ..self.settings };
                for j in 0..k as u64 {
                    let t = self.time + j as f64 * sub.timestep;
                    let done = self.stages(sub, t, s + 1 + j).and_then(|()| self.ws.commit(&mut self.bodies));
                    if let Err(e) = done {
                        self.ws.restore_bodies(&mut self.bodies);
                        return Err(e);
                    }
                }
                // The last substep's impulses, over h/k, read as the step's (over h).
                self.ws.scale_stamped(s + 1 + k as u64, k as f64);
                self.solves = s + 1 + k as u64;
                self.ws.substeps = k;
            }
        }
        self.time += h;
        self.steps += 1;
        Ok(())
    }

    /// Steps 1–8 of `step.rs` but the commit, with `settings` (their time step), at `time`, as solve
    /// `solve` (records stamped `solve` are the last solve's).
    fn stages(&mut self, settings: WorldSettings, time: f64, solve: u64) -> Result<(), StepError> {
        let ws = &mut self.ws;
        let settings = &settings;
        ws.prepare_bodies(settings, &self.bodies, &self.joints, &self.forces, time, solve);
        ws.push_rows(
            settings.timestep,
            &self.bodies,
            &self.joints,
            &self.couplings,
            &self.forces,
            &mut self.contacts,
        );
        let input_work_before = ws.input_work;
        ws.solve_islands(settings, solve)?;
        if settings.geometric_stiffness != GeometricStiffness::Off
            && ws.stiffness_lags(settings, &self.bodies, &self.joints, solve)
        {
            ws.resolve_with_fresh_stiffness(
                settings,
                &self.bodies,
                &self.forces,
                time,
                solve,
                input_work_before,
            )?;
        }
        ws.integrate(settings, &self.bodies);
        if settings.projection_iterations > 0 || settings.joint_error_tolerance > 0.0 {
            project(settings, &self.bodies, &self.joints, ws, solve)?;
        }
        Ok(())
    }

    /// Substeps for the step just taken (not committed): `k = ⌈h |ω⁺|_max / θ⌉` (2 to
    /// `max_substeps`) when a joint is still open beyond the tolerance after the guard and some
    /// body turned more than `θ` = [`SUBSTEP_TURN`] rad in the step; `None` otherwise.
    fn substeps_needed(&self) -> Option<usize> {
        let settings = &self.settings;
        let tol = settings.joint_error_tolerance;
        if settings.max_substeps < 2 || tol <= 0.0 {
            return None;
        }
        let h = settings.timestep;
        let turn = (0..self.bodies.len())
            .filter(|&i| self.ws.dynamic[i])
            .map(|i| h * self.ws.w_new[i].norm())
            .fold(0.0, f64::max);
        // `turn` is a max over finite or infinite values (f64::max drops NaN).
        if turn <= SUBSTEP_TURN || self.ws.guard_drift <= tol {
            return None;
        }
        Some(((turn / SUBSTEP_TURN).ceil() as usize).clamp(2, settings.max_substeps))
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
        let world_frame = |anchor: Vector3<f64>, rotation: UnitQuaternion<f64>| {
            if !anchor.iter().all(|c| c.is_finite()) {
                return Err(JointError::NonFinite { joint: joint(), what: "anchor" });
            }
            let w = Isometry3::from_parts(Translation3::from(anchor), rotation);
            Ok((a.pose().inverse() * w, pose_b.inverse() * w))
        };
        let (frame_a, frame_b) = match jb.frames {
            JointFrames::World { anchor, axis } => world_frame(anchor, frame_rotation(&jb.name, axis)?)?,
            JointFrames::WorldAxes { anchor, axis, secondary } => {
                world_frame(anchor, frame_rotation_xy(&jb.name, axis, secondary)?)?
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
        for axis in FreeAxis::ALL {
            if let Some(l) = jb.limits[axis.index()] {
                check_axis(&jb.name, jb.kind, axis)?;
                if l.lower.is_nan()
                    || l.upper.is_nan()
                    || l.lower > l.upper
                    || !(l.margin.is_finite() && l.margin >= 0.0)
                {
                    return Err(JointError::InvalidLimit {
                        joint: joint(),
                        lower: l.lower,
                        upper: l.upper,
                        margin: l.margin,
                    });
                }
            }
            if let Some(m) = jb.motors[axis.index()] {
                validate_motor(&jb.name, jb.kind, axis, m)?;
            }
        }
        let id = JointId(self.joints.len() as u32);
        self.joint_names.insert(jb.name.clone(), id);
        if jb.collide_connected {
            self.contacts.connected.insert(id.0);
        }
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
            limits: jb.limits,
            motors: jb.motors,
            enabled: jb.enabled,
        });
        Ok(id)
    }

    /// Adds a coupling (gear, differential) between joints' rotations (`coupling.rs`).
    pub fn add_coupling(&mut self, cb: CouplingBuilder) -> Result<CouplingId, CouplingError> {
        if self.coupling_names.contains_key(cb.name()) {
            return Err(CouplingError::DuplicateName { coupling: cb.name().to_string() });
        }
        let id = CouplingId(self.couplings.len() as u32);
        let c = cb.build(id, &self.joints)?;
        self.coupling_names.insert(c.name.clone(), id);
        self.couplings.push(c);
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
        let q = body::unit(orientation.into_inner());
        match q {
            Some(q) if position.iter().all(|c| c.is_finite()) => {
                b.position = position;
                b.orientation = q;
                Ok(())
            }
            _ => Err(StateError::Invalid { body: b.name().to_string(), what: "pose" }),
        }
    }

    /// Changes (or removes) the motor of a joint's first free axis: the live control input.
    pub fn set_joint_motor(&mut self, id: JointId, motor: Option<JointMotor>) -> Result<(), ControlError> {
        let j = self.joints.get(id.index()).ok_or(ControlError::UnknownJoint(id))?;
        let axis = j
            .kind
            .first_axis()
            .ok_or_else(|| JointError::NoFreeAxis { joint: j.name.clone(), kind: j.kind.name() })?;
        self.set_joint_axis_motor(id, axis, motor)
    }

    /// Changes (or removes) the motor of a given free axis (a position motor's target moves a
    /// hydraulic cylinder).
    pub fn set_joint_axis_motor(
        &mut self,
        id: JointId,
        axis: FreeAxis,
        motor: Option<JointMotor>,
    ) -> Result<(), ControlError> {
        let j = self.joints.get_mut(id.index()).ok_or(ControlError::UnknownJoint(id))?;
        match motor {
            Some(m) => validate_motor(&j.name, j.kind, axis, m)?,
            None => check_axis(&j.name, j.kind, axis)?,
        }
        j.motors[axis.index()] = motor;
        Ok(())
    }

    /// Changes (or removes) a coupling's torque bound: engages (`None`: rigid), slips (`Some(τ)`)
    /// or disengages (`Some(0)`) a clutch.
    pub fn set_coupling_max_torque(
        &mut self,
        id: CouplingId,
        max_torque: Option<f64>,
    ) -> Result<(), ControlError> {
        let c = self.couplings.get_mut(id.index()).ok_or(ControlError::UnknownCoupling(id))?;
        if let Some(tau) = max_torque {
            validate_max_torque(&c.name, tau)?;
        }
        c.max_torque = max_torque;
        Ok(())
    }
}

/// `axis` must be a free axis of `kind`.
fn check_axis(name: &str, kind: JointKind, axis: FreeAxis) -> Result<(), JointError> {
    if !kind.has_free_axis() {
        return Err(JointError::NoFreeAxis { joint: name.to_string(), kind: kind.name() });
    }
    if !kind.has_axis(axis) {
        return Err(JointError::NoSuchAxis { joint: name.to_string(), kind: kind.name(), axis: axis.name() });
    }
    Ok(())
}

pub(crate) fn validate_motor(
    name: &str,
    kind: JointKind,
    axis: FreeAxis,
    m: JointMotor,
) -> Result<(), JointError> {
    check_axis(name, kind, axis)?;
    if !m.is_valid() {
        return Err(JointError::InvalidMotor { joint: name.to_string(), motor: m });
    }
    Ok(())
}

/// `axis` validated unit.
fn unit_axis(name: &str, axis: Vector3<f64>) -> Result<Vector3<f64>, JointError> {
    let norm = axis.norm();
    if !(norm.is_finite() && (norm - 1.0).abs() <= 1e-6) {
        return Err(JointError::NonUnitAxis { joint: name.to_string(), norm });
    }
    Ok(axis / norm)
}

/// Rotation whose x axis is `axis` (validated unit), with a deterministic completion.
pub(crate) fn frame_rotation(name: &str, axis: Vector3<f64>) -> Result<UnitQuaternion<f64>, JointError> {
    let e1 = unit_axis(name, axis)?;
    let e2 = crate::dynamics::contact::orthogonal(&e1);
    let e3 = e1.cross(&e2);
    Ok(UnitQuaternion::from_basis_unchecked(&[e1, e2, e3]))
}

/// Rotation with x axis `x` and y axis `y` (validated unit and perpendicular within 1e-6; `y` is
/// re-orthogonalized).
fn frame_rotation_xy(
    name: &str,
    x: Vector3<f64>,
    y: Vector3<f64>,
) -> Result<UnitQuaternion<f64>, JointError> {
    let e1 = unit_axis(name, x)?;
    let y = unit_axis(name, y)?;
    let dot = e1.dot(&y);
    if dot.abs() > 1e-6 {
        return Err(JointError::NonPerpendicularAxes { joint: name.to_string(), dot });
    }
    let e2 = (y - e1 * dot).normalize();
    Ok(UnitQuaternion::from_basis_unchecked(&[e1, e2, e1.cross(&e2)]))
}

fn checked_frame(name: &str, which: &'static str, f: Isometry3<f64>) -> Result<Isometry3<f64>, JointError> {
    if !f.translation.vector.iter().all(|c| c.is_finite()) {
        return Err(JointError::NonFinite { joint: name.to_string(), what: which });
    }
    let q = f.rotation.into_inner();
    let q =
        body::unit(q).ok_or(JointError::NonUnitFrame { joint: name.to_string(), which, norm: q.norm() })?;
    Ok(Isometry3::from_parts(f.translation, q))
}
