//! Read access to a [`World`]: items by id and name, joint coordinates and frames, the impulses and
//! reactions of the last step, islands and their stats, momentum.
//!
//! **Impulses and reactions.** A row's impulse `λ` of the last step (N s or N m s) is its mean force
//! (torque) over the step times `h`. A joint's *reaction* on its body A is the sum over all its
//! rows (locked, limits, motors) of `J_{i,A} λ_i / h`: the force through A's centre of mass and the
//! torque about it that the joint applied over the step (on B the opposite force at the anchor).
//! A hanging chain's top joint carries the weight of everything below it.

use nalgebra::Vector3;

use super::World;
use crate::dynamics::body::RigidBody;
use crate::dynamics::coupling::Coupling;
use crate::dynamics::force::ForceElement;
use crate::dynamics::ids::{BodyId, CouplingId, ForceId, JointId};
use crate::dynamics::island::Islands;
use crate::dynamics::joint::{Joint, JointRow};
use crate::dynamics::joint_rows::JointGeometry;
use crate::dynamics::motor::FreeAxis;
use crate::dynamics::rows::{ConstraintRow, RowKey, Side, WarmRow};
use crate::dynamics::stats::IslandStats;
use crate::solver::IndexState;

/// A joint's frames in world coordinates (see `joint.rs`): anchors `p_a`, `p_b` and x axes
/// `e₁` (of A's frame), `f₁` (of B's frame). A joint without violation has `p_a = p_b` (along the
/// free axis of a prismatic or cylindrical joint: up to the displacement) and, except for ball and
/// universal joints, `e₁ = f₁`.
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

/// What a joint applied to its body A over the last step (mean force and torque).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct JointReaction {
    /// Force on A (N), through its centre of mass.
    pub force: Vector3<f64>,
    /// Torque on A about its centre of mass (N m).
    pub torque: Vector3<f64>,
}

impl World {
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
    /// All couplings, indexed by [`CouplingId::index`].
    pub fn couplings(&self) -> &[Coupling] {
        &self.couplings
    }
    /// A coupling's id by name.
    pub fn coupling_id(&self, name: &str) -> Option<CouplingId> {
        self.coupling_names.get(name).copied()
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

    /// The warm-start record of a row if it was solved in the last step.
    pub(super) fn last_step_row(&self, key: RowKey) -> Option<&WarmRow> {
        let w = self.ws.warm_row(key)?;
        (self.solves > 0 && w.stamp == self.solves).then_some(w)
    }

    /// Impulse `λ` (N s or N m s) of a joint row in the last step (0 if the row was not emitted).
    /// The mean force over the step is `λ / h`.
    pub fn joint_impulse(&self, id: JointId, row: JointRow) -> f64 {
        self.last_step_row(RowKey::Joint { joint: id, row }).map_or(0.0, |w| w.lambda)
    }

    /// Impulse `λ` (N m s) of a coupling's row in the last step: the torque at its first shaft
    /// times `h` (`coupling.rs`).
    pub fn coupling_impulse(&self, id: CouplingId) -> f64 {
        self.last_step_row(RowKey::Coupling(id)).map_or(0.0, |w| w.lambda)
    }

    /// Impulse `λ` (N s) of a spring–damper's row in the last step: its force on body B along
    /// `n = (p_b − p_a)/|p_b − p_a|` times `h` (negative when it pulls; `force.rs`).
    pub fn force_impulse(&self, id: ForceId) -> f64 {
        self.last_step_row(RowKey::Force(id)).map_or(0.0, |w| w.lambda)
    }

    /// What a joint applied to its body A over the last step (module doc); `None` for an unknown
    /// joint, zero before the first step.
    pub fn joint_reaction(&self, id: JointId) -> Option<JointReaction> {
        self.joints.get(id.index())?;
        let h = self.settings.timestep;
        let mut r = JointReaction::default();
        for row in &self.ws.rows {
            if let RowKey::Joint { joint, .. } = row.key
                && joint == id
                && let Some(w) = self.last_step_row(row.key)
            {
                // Block 0 of a joint row is body A's (`ConstraintRow::pair`).
                r.force += row.jac[0].lin * (w.lambda / h);
                r.torque += row.jac[0].ang * (w.lambda / h);
            }
        }
        Some(r)
    }

    /// The joint rows of the last step with their impulses `λ` (N s or N m s) and final index
    /// states, in row order (a row whose island was not solved: `λ = 0`, `Free`). Allocation-free:
    /// the signals (`crate::signals`) sum them into joint wrenches every step.
    pub fn last_joint_rows(&self) -> impl Iterator<Item = (JointId, &ConstraintRow, f64, IndexState)> + '_ {
        self.ws.rows.iter().filter_map(move |row| match row.key {
            RowKey::Joint { joint, .. } => {
                let (lambda, state) =
                    self.last_step_row(row.key).map_or((0.0, IndexState::Free), |w| (w.lambda, w.state));
                Some((joint, row, lambda, state))
            }
            _ => None,
        })
    }

    /// Islands of the last step.
    pub fn islands(&self) -> &Islands {
        &self.ws.islands
    }

    /// Per-island stats of the last step (islands with rows only, in island order).
    pub fn island_stats(&self) -> &[IslandStats] {
        &self.ws.stats
    }

    /// Dynamic bodies whose effective inertia the geometric stiffness raised in the last step
    /// (`geometric_stiffness.rs`).
    pub fn geometric_stiffness_bodies(&self) -> usize {
        self.ws.gs_bodies
    }

    /// Steps solved a second time since the world was built because a tension jumped beyond what
    /// the geometric stiffness of the step had assumed (eq. G6 of `geometric_stiffness.rs`).
    pub fn geometric_stiffness_resolves(&self) -> u64 {
        self.ws.gs_resolves
    }

    /// Kinetic energy of the dynamic bodies (J).
    pub fn kinetic_energy(&self) -> f64 {
        self.bodies.iter().map(RigidBody::kinetic_energy).sum()
    }

    /// Gravitational potential energy of the dynamic bodies, `−Σ m g · x` (J; zero at the origin).
    pub fn potential_energy(&self) -> f64 {
        let g = self.settings.gravity;
        self.bodies.iter().filter(|b| b.is_dynamic()).map(|b| -b.mass() * g.dot(&b.position())).sum()
    }

    /// Work done on the dynamic bodies since the world was built by its inputs (J): motors,
    /// couplings, friction and spring rows, rows reaching kinematic or static bodies (a driven
    /// winch, a moving platform, the ground), and applied forces other than gravity. Without the
    /// passive joint rows' numerical work, `kinetic + potential` energy stays at its initial value
    /// plus this; the watchdog (`watchdog.rs`) checks that it does not climb above.
    pub fn input_work(&self) -> f64 {
        self.ws.input_work
    }

    /// Total linear momentum of the dynamic bodies.
    pub fn linear_momentum(&self) -> Vector3<f64> {
        self.bodies.iter().map(RigidBody::linear_momentum).sum()
    }

    /// Total angular momentum of the dynamic bodies about the world point `o`.
    pub fn angular_momentum(&self, o: Vector3<f64>) -> Vector3<f64> {
        self.bodies.iter().map(|b| b.angular_momentum(o)).sum()
    }

    /// Largest anchor separation `|p_b − p_a|` over all joints at the current poses (m); along a
    /// prismatic or cylindrical joint's axis the separation is its free displacement.
    pub fn max_anchor_error(&self) -> f64 {
        self.joints
            .iter()
            .filter(|j| j.enabled)
            .map(|j| self.joint_geometry(j).anchor_error())
            .fold(0.0, f64::max)
    }

    /// Substeps the last step was solved in (1: none; `step.rs`, "Substeps").
    pub fn last_substeps(&self) -> usize {
        self.ws.substeps
    }

    /// Position projections the joint-error guard ran in the last step (0 while every joint held
    /// within [`WorldSettings::joint_error_tolerance`](super::WorldSettings::joint_error_tolerance)).
    pub fn last_guard_projections(&self) -> usize {
        self.ws.guard_iterations
    }

    /// Largest position error over all enabled joints at the current poses (m): the anchor
    /// separation across each joint's locked directions (a prismatic or cylindrical joint's slide
    /// is its coordinate, not an error). This is the runner's and the tests' joint error.
    pub fn max_joint_error(&self) -> f64 {
        self.worst_joint_error().map_or(0.0, |(_, e)| e)
    }

    /// The enabled joint with the largest position error (as [`World::max_joint_error`]) and that
    /// error (m); `None` without enabled joints. The first of equal errors; NaN wins (a joint whose
    /// bodies left the finite numbers is the worst). Allocation-free: the watchdog calls it every
    /// step.
    pub fn worst_joint_error(&self) -> Option<(JointId, f64)> {
        let mut worst: Option<(JointId, f64)> = None;
        for j in self.joints.iter().filter(|j| j.enabled) {
            let e = self.joint_geometry(j).locked_anchor_error(j.kind);
            match worst {
                Some((_, w)) if w.is_nan() || !(e.is_nan() || e > w) => {}
                _ => worst = Some((j.id, e)),
            }
        }
        worst
    }

    /// A joint's elastic deflection in the last step (m): `|c_k λ_k / h|` over its locked linear
    /// rows (slots 0..3, or 0..2 for a joint that slides; `joint.rs`'s table) — the give a row of
    /// compliance `c` has by design under its load (paper eq. 1). `None` for an unknown joint.
    pub fn joint_elastic_deflection(&self, id: JointId) -> Option<f64> {
        let j = self.joints.get(id.index())?;
        Some(j.elastic_deflection(self.settings.timestep, |row| self.joint_impulse(id, row)))
    }

    /// A joint's drift (m): its error ([`World::joint_error`]) beyond its elastic deflection
    /// ([`World::joint_elastic_deflection`]), never negative; NaN stays NaN. `None` for an unknown
    /// joint.
    pub fn joint_drift(&self, id: JointId) -> Option<f64> {
        let e = self.joint_error(id)?;
        let d = self.joint_elastic_deflection(id)?;
        Some(if e.is_nan() { e } else { (e - d).max(0.0) })
    }

    /// The enabled joint with the largest drift ([`World::joint_drift`]) among those whose error
    /// exceeds `above` (m), and that drift; `None` if no joint's error exceeds it. NaN wins.
    /// Allocation-free; it reads impulses only of the joints past `above`.
    pub fn worst_joint_drift(&self, above: f64) -> Option<(JointId, f64)> {
        let mut worst: Option<(JointId, f64)> = None;
        for j in self.joints.iter().filter(|j| j.enabled) {
            let e = self.joint_geometry(j).locked_anchor_error(j.kind);
            if !(e.is_nan() || e > above) {
                continue;
            }
            let d = self.joint_drift(j.id).unwrap_or(f64::NAN);
            match worst {
                Some((_, w)) if w.is_nan() || !(d.is_nan() || d > w) => {}
                _ => worst = Some((j.id, d)),
            }
        }
        worst
    }

    /// Position error of one joint at the current poses (m; as [`World::max_joint_error`], also for
    /// a disabled joint); `None` for an unknown joint.
    pub fn joint_error(&self, id: JointId) -> Option<f64> {
        let j = self.joints.get(id.index())?;
        Some(self.joint_geometry(j).locked_anchor_error(j.kind))
    }

    fn joint_geometry(&self, j: &Joint) -> JointGeometry {
        let (a, b) = (self.side(Some(j.body_a)), self.side(j.body_b));
        JointGeometry::new(j, &a, &b)
    }

    /// World-frame anchors and axes of a joint at the current poses.
    pub fn joint_frames_world(&self, id: JointId) -> Option<JointFramesWorld> {
        let g = self.joint_geometry(self.joints.get(id.index())?);
        Some(JointFramesWorld { anchor_a: g.p_a, anchor_b: g.p_b, axis_a: g.e[0], axis_b: g.f[0] })
    }

    /// Free coordinate of a joint's first free axis: hinge angle (rad), prismatic or cylindrical
    /// displacement (m).
    pub fn joint_coordinate(&self, id: JointId) -> Option<f64> {
        let j = self.joints.get(id.index())?;
        self.joint_axis_coordinate(id, j.kind.first_axis()?)
    }

    /// Free coordinate of a given free axis (`None` if the joint does not have it).
    pub fn joint_axis_coordinate(&self, id: JointId, axis: FreeAxis) -> Option<f64> {
        let j = self.joints.get(id.index())?;
        j.kind.has_axis(axis).then(|| self.joint_geometry(j).free_coordinate(axis).0)
    }

    /// Relative speed along/about a joint's first free axis (m/s or rad/s).
    pub fn joint_speed(&self, id: JointId) -> Option<f64> {
        let j = self.joints.get(id.index())?;
        self.joint_axis_speed(id, j.kind.first_axis()?)
    }

    /// Relative speed along/about a given free axis (`None` if the joint does not have it).
    pub fn joint_axis_speed(&self, id: JointId, axis: FreeAxis) -> Option<f64> {
        let j = self.joints.get(id.index())?;
        if !j.kind.has_axis(axis) {
            return None;
        }
        let (a, b) = (self.side(Some(j.body_a)), self.side(j.body_b));
        let (_, ja, jb) = self.joint_geometry(j).free_coordinate(axis);
        Some(ja.dot(&a.v, &a.w) + jb.dot(&b.v, &b.w))
    }

    fn side(&self, id: Option<BodyId>) -> Side {
        match id {
            None => Side::world(),
            Some(id) => {
                let b = &self.bodies[id.index()];
                Side { index: Some(id.index()), x: b.position, q: b.orientation, v: b.linvel, w: b.angvel }
            }
        }
    }
}
