//! Joint models: what a joint *is* (kind, bodies, frames, compliance, limits, motors). The rows it
//! produces for the solver are built in `joint_rows.rs` (the model is not the solver row, as rapier
//! keeps `GenericJoint` apart from its `JointConstraint`); limits and motors are in `motor.rs`.
//!
//! **Frames.** A joint holds a local frame on each body, `F_a` on body A and `F_b` on body B (or on
//! the world when B is absent). In world coordinates `W_a = X_a F_a` and `W_b = X_b F_b`, with
//! origins (anchors) `p_a`, `p_b`, axes `(e₁, e₂, e₃)` of `W_a` and `(f₁, f₂, f₃)` of `W_b`. The
//! *x axis* of the frames is the joint axis (hinge rotation axis, prismatic slide axis, both for a
//! cylindrical joint; a universal joint's cross pin on A). At rest (no violation) `W_a = W_b`,
//! except along the free axes.
//!
//! | kind | locked rows | free motion |
//! |---|---|---|
//! | fixed | 3 linear (`e₁, e₂, e₃`) + 3 angular | — |
//! | hinge | 3 linear + 2 angular (`e₂·f₁ = e₃·f₁ = 0`) | rotation about `e₁` |
//! | prismatic | 2 linear (`e₂, e₃`) + 3 angular | translation along `e₁` |
//! | cylindrical | 2 linear (`e₂, e₃`) + 2 angular (`e₂·f₁ = e₃·f₁ = 0`) | translation along and rotation about `e₁` |
//! | universal | 3 linear + 1 angular (`e₁·f₂ = 0`) | rotations about `e₁` (pin on A) and `f₂` (pin on B) |
//! | ball | 3 linear | all rotations |
//!
//! A **universal** (Cardan) joint is a cross whose pin `e₁` turns in A's fork and whose pin `f₂` turns
//! in B's fork; the pins stay perpendicular, `e₁ · f₂ = 0`, which blocks the relative twist about
//! `e₁ × f₂` and transmits torque about it (a drive shaft). Build it with
//! [`JointBuilder::universal`] from the two world pin directions.
//!
//! **Rows of a joint** are numbered by a slot ([`JointRow`]): `0..6` the locked rows in the order of
//! the table, then per free axis (linear `6..9`, angular `9..12`) the lower limit, the upper limit
//! and the motor. Compliance is given per slot; the slot is also the key under which the row's index
//! state and impulse persist between steps (warm start).
//!
//! **Free coordinates** (`motor.rs`): the displacement (m, along the axis) and the angle (rad,
//! right-handed about the axis) of body A relative to body B — B is the parent, or the world — zero
//! where the joint was built. Read them with `World::joint_coordinate` / `joint_axis_coordinate`.
//! [`JointBuilder::limit`] and [`JointBuilder::motor`] act on the joint's *first* free axis
//! ([`JointKind::free_axes`]: the rotation of a hinge, the translation of a prismatic or cylindrical
//! joint); [`JointBuilder::axis_limit`] / [`JointBuilder::axis_motor`] name the axis.
//!
//! **Compliance and stabilization** per row (paper eq. 1, `C` diagonal): see `rows.rs` for the row
//! equation. The default compliance `1e-10` is the stiff end of the paper's Table 1 range; the default
//! stabilization `β = 1` removes the whole violation in one step (paper: `−φ/h`).

use nalgebra::{Isometry3, Vector3};

use super::ids::{BodyId, JointId};
use super::motor::{FreeAxis, JointLimit, JointMotor};

/// Joint types.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum JointKind {
    /// Locks all six relative degrees of freedom.
    Fixed,
    /// Rotation about the frame x axis only.
    Hinge,
    /// Translation along the frame x axis only.
    Prismatic,
    /// Spherical: the anchors coincide, rotations are free.
    Ball,
    /// Translation along and rotation about the frame x axis.
    Cylindrical,
    /// Cardan joint: anchors coincide, A's x axis stays perpendicular to B's y axis.
    Universal,
}

impl JointKind {
    /// Every kind.
    pub const ALL: [JointKind; 6] = [
        JointKind::Fixed,
        JointKind::Hinge,
        JointKind::Prismatic,
        JointKind::Ball,
        JointKind::Cylindrical,
        JointKind::Universal,
    ];

    /// Name used in reports and errors.
    pub fn name(self) -> &'static str {
        match self {
            JointKind::Fixed => "fixed",
            JointKind::Hinge => "hinge",
            JointKind::Prismatic => "prismatic",
            JointKind::Ball => "ball",
            JointKind::Cylindrical => "cylindrical",
            JointKind::Universal => "universal",
        }
    }

    /// Number of locked (bilateral) rows.
    pub fn locked_rows(self) -> usize {
        match self {
            JointKind::Fixed => 6,
            JointKind::Hinge | JointKind::Prismatic => 5,
            JointKind::Cylindrical | JointKind::Universal => 4,
            JointKind::Ball => 3,
        }
    }

    /// The free axes that may carry a limit and a motor, first axis first.
    pub fn free_axes(self) -> &'static [FreeAxis] {
        match self {
            JointKind::Hinge => &[FreeAxis::Angular],
            JointKind::Prismatic => &[FreeAxis::Linear],
            JointKind::Cylindrical => &[FreeAxis::Linear, FreeAxis::Angular],
            JointKind::Fixed | JointKind::Ball | JointKind::Universal => &[],
        }
    }

    /// Whether the joint has a free axis that may carry a limit and a motor.
    pub fn has_free_axis(self) -> bool {
        !self.free_axes().is_empty()
    }

    /// Whether `axis` is one of the joint's free axes.
    pub fn has_axis(self, axis: FreeAxis) -> bool {
        self.free_axes().contains(&axis)
    }

    /// The first free axis (what [`JointBuilder::limit`] and [`JointBuilder::motor`] act on).
    pub fn first_axis(self) -> Option<FreeAxis> {
        self.free_axes().first().copied()
    }
}

/// The row slots of a joint (also its warm-start keys).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum JointRow {
    /// Locked row `k` (`0..6`, see the module table).
    Locked(u8),
    /// Lower limit of a free axis.
    LowerLimit(FreeAxis),
    /// Upper limit of a free axis.
    UpperLimit(FreeAxis),
    /// Motor of a free axis.
    Motor(FreeAxis),
}

/// Number of row slots per joint.
pub const JOINT_SLOTS: usize = 12;

impl JointRow {
    /// Slot index `0..JOINT_SLOTS`.
    #[inline]
    pub fn slot(self) -> usize {
        match self {
            JointRow::Locked(k) => k as usize,
            JointRow::LowerLimit(a) => 6 + 3 * a.index(),
            JointRow::UpperLimit(a) => 7 + 3 * a.index(),
            JointRow::Motor(a) => 8 + 3 * a.index(),
        }
    }
}

/// Default row compliance (paper Table 1, stiff end).
pub const DEFAULT_COMPLIANCE: f64 = 1e-10;

/// How the joint frames are given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum JointFrames {
    /// One world frame at the bodies' current poses: origin `anchor`, x axis `axis` (unit), y and z
    /// completed deterministically. Both local frames are derived from it, so the joint starts
    /// without violation.
    World {
        /// Anchor point (world).
        anchor: Vector3<f64>,
        /// Joint axis (world, unit; ignored by ball joints but still validated).
        axis: Vector3<f64>,
    },
    /// One world frame with both x and y axes given (unit, perpendicular; z = x × y).
    WorldAxes {
        /// Anchor point (world).
        anchor: Vector3<f64>,
        /// x axis (world, unit).
        axis: Vector3<f64>,
        /// y axis (world, unit, perpendicular to `axis`).
        secondary: Vector3<f64>,
    },
    /// Local frames on each body (frame x axis = joint axis).
    Local {
        /// Frame on body A, in A's frame.
        frame_a: Isometry3<f64>,
        /// Frame on body B, in B's frame (world frame when B is absent).
        frame_b: Isometry3<f64>,
    },
}

/// Builder of a joint; validated by [`World::add_joint`](super::World::add_joint).
#[derive(Debug, Clone)]
pub struct JointBuilder {
    pub(crate) name: String,
    pub(crate) kind: JointKind,
    pub(crate) body_a: BodyId,
    pub(crate) body_b: Option<BodyId>,
    pub(crate) frames: JointFrames,
    pub(crate) compliance: [f64; JOINT_SLOTS],
    pub(crate) stabilization: f64,
    /// Per free axis ([`FreeAxis::index`]).
    pub(crate) limits: [Option<JointLimit>; 2],
    pub(crate) motors: [Option<JointMotor>; 2],
    /// Whether the joined bodies' colliders collide with each other (default false).
    pub(crate) collide_connected: bool,
    /// Whether the joint starts enabled (default true; see [`World::set_joint_enabled`](super::World::set_joint_enabled)).
    pub(crate) enabled: bool,
}

impl JointBuilder {
    /// A joint of `kind` between `body_a` and `body_b` (`None`: the world), with frames `frames`.
    pub fn new(
        name: &str,
        kind: JointKind,
        body_a: BodyId,
        body_b: Option<BodyId>,
        frames: JointFrames,
    ) -> Self {
        JointBuilder {
            name: name.to_string(),
            kind,
            body_a,
            body_b,
            frames,
            compliance: [DEFAULT_COMPLIANCE; JOINT_SLOTS],
            stabilization: 1.0,
            limits: [None; 2],
            motors: [None; 2],
            collide_connected: false,
            enabled: true,
        }
    }

    /// A joint whose frame is given in world coordinates at the current poses.
    pub fn at(
        name: &str,
        kind: JointKind,
        body_a: BodyId,
        body_b: Option<BodyId>,
        anchor: Vector3<f64>,
        axis: Vector3<f64>,
    ) -> Self {
        Self::new(name, kind, body_a, body_b, JointFrames::World { anchor, axis })
    }

    /// Fixed joint at a world anchor.
    pub fn fixed(name: &str, a: BodyId, b: Option<BodyId>, anchor: Vector3<f64>) -> Self {
        Self::at(name, JointKind::Fixed, a, b, anchor, Vector3::x())
    }

    /// Hinge about the world line through `anchor` along `axis`.
    pub fn hinge(name: &str, a: BodyId, b: Option<BodyId>, anchor: Vector3<f64>, axis: Vector3<f64>) -> Self {
        Self::at(name, JointKind::Hinge, a, b, anchor, axis)
    }

    /// Prismatic joint sliding along the world direction `axis` through `anchor`.
    pub fn prismatic(
        name: &str,
        a: BodyId,
        b: Option<BodyId>,
        anchor: Vector3<f64>,
        axis: Vector3<f64>,
    ) -> Self {
        Self::at(name, JointKind::Prismatic, a, b, anchor, axis)
    }

    /// Cylindrical joint: slides along and turns about the world line through `anchor` along `axis`
    /// (a hydraulic cylinder's piston in its barrel).
    pub fn cylindrical(
        name: &str,
        a: BodyId,
        b: Option<BodyId>,
        anchor: Vector3<f64>,
        axis: Vector3<f64>,
    ) -> Self {
        Self::at(name, JointKind::Cylindrical, a, b, anchor, axis)
    }

    /// Universal (Cardan) joint at `anchor` with its cross pin `pin_a` turning in body A and
    /// `pin_b` in body B (world directions, unit and perpendicular).
    pub fn universal(
        name: &str,
        a: BodyId,
        b: Option<BodyId>,
        anchor: Vector3<f64>,
        pin_a: Vector3<f64>,
        pin_b: Vector3<f64>,
    ) -> Self {
        let frames = JointFrames::WorldAxes { anchor, axis: pin_a, secondary: pin_b };
        Self::new(name, JointKind::Universal, a, b, frames)
    }

    /// Ball joint at a world anchor.
    pub fn ball(name: &str, a: BodyId, b: Option<BodyId>, anchor: Vector3<f64>) -> Self {
        Self::at(name, JointKind::Ball, a, b, anchor, Vector3::x())
    }

    /// Same compliance `c ≥ 0` (m/N or rad/(N m)) on every row.
    pub fn compliance(mut self, c: f64) -> Self {
        self.compliance = [c; JOINT_SLOTS];
        self
    }

    /// Compliance of one row slot.
    pub fn row_compliance(mut self, row: JointRow, c: f64) -> Self {
        self.compliance[row.slot()] = c;
        self
    }

    /// Stabilization factor `β ∈ [0, 1]`: the fraction of the violation the row removes per step.
    pub fn stabilization(mut self, beta: f64) -> Self {
        self.stabilization = beta;
        self
    }

    /// Limits on the first free axis (see the module doc).
    pub fn limit(self, limit: JointLimit) -> Self {
        let axis = self.kind.first_axis().unwrap_or(FreeAxis::Linear);
        self.axis_limit(axis, limit)
    }

    /// Motor on the first free axis (see the module doc).
    pub fn motor(self, motor: JointMotor) -> Self {
        let axis = self.kind.first_axis().unwrap_or(FreeAxis::Linear);
        self.axis_motor(axis, motor)
    }

    /// Limits on a given free axis.
    pub fn axis_limit(mut self, axis: FreeAxis, limit: JointLimit) -> Self {
        self.limits[axis.index()] = Some(limit);
        self
    }

    /// Motor on a given free axis.
    pub fn axis_motor(mut self, axis: FreeAxis, motor: JointMotor) -> Self {
        self.motors[axis.index()] = Some(motor);
        self
    }

    /// Whether the colliders of the two joined bodies collide with each other (default `false`:
    /// jointed bodies do not collide).
    pub fn collide_connected(mut self, collide: bool) -> Self {
        self.collide_connected = collide;
        self
    }

    /// Builds the joint disabled (`false`): it adds no rows until
    /// [`World::set_joint_enabled`](super::World::set_joint_enabled) latches it.
    pub fn enabled(mut self, enabled: bool) -> Self {
        self.enabled = enabled;
        self
    }

    /// The name given.
    pub fn name(&self) -> &str {
        &self.name
    }
}

/// A validated joint (the model). Built by [`World::add_joint`](super::World::add_joint).
#[derive(Debug, Clone)]
pub struct Joint {
    pub(crate) id: JointId,
    pub(crate) name: String,
    pub(crate) kind: JointKind,
    pub(crate) body_a: BodyId,
    pub(crate) body_b: Option<BodyId>,
    pub(crate) frame_a: Isometry3<f64>,
    pub(crate) frame_b: Isometry3<f64>,
    pub(crate) compliance: [f64; JOINT_SLOTS],
    pub(crate) stabilization: f64,
    pub(crate) limits: [Option<JointLimit>; 2],
    pub(crate) motors: [Option<JointMotor>; 2],
    /// A disabled joint contributes no rows (a hook not yet latched, a released grapple).
    pub(crate) enabled: bool,
}

impl Joint {
    /// The joint's elastic deflection (m) under the impulses `impulse(row)` of a step of length
    /// `h`: `|c_k λ_k / h|` over its locked linear rows (slots 0..3, or 0..2 for a joint that
    /// slides: the module table) — the give a row of compliance `c` has by design under its load
    /// (paper eq. 1). Shared by the world's drift queries and the joint-error guard.
    pub(crate) fn elastic_deflection(&self, h: f64, impulse: impl Fn(JointRow) -> f64) -> f64 {
        let linear = if self.kind.has_axis(FreeAxis::Linear) { 2 } else { 3 };
        let sum: f64 = (0..linear)
            .map(|k| {
                let row = JointRow::Locked(k);
                let d = self.compliance[row.slot()] * impulse(row) / h;
                d * d
            })
            .sum();
        sum.sqrt()
    }

    /// Whether the joint currently contributes rows.
    pub fn is_enabled(&self) -> bool {
        self.enabled
    }

    /// Id.
    pub fn id(&self) -> JointId {
        self.id
    }
    /// Name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// Kind.
    pub fn kind(&self) -> JointKind {
        self.kind
    }
    /// First body.
    pub fn body_a(&self) -> BodyId {
        self.body_a
    }
    /// Second body (`None`: the world).
    pub fn body_b(&self) -> Option<BodyId> {
        self.body_b
    }
    /// Local frame on body A.
    pub fn frame_a(&self) -> &Isometry3<f64> {
        &self.frame_a
    }
    /// Local frame on body B (world frame when B is absent).
    pub fn frame_b(&self) -> &Isometry3<f64> {
        &self.frame_b
    }
    /// Compliance of a row slot.
    pub fn compliance(&self, row: JointRow) -> f64 {
        self.compliance[row.slot()]
    }
    /// Stabilization factor `β`.
    pub fn stabilization(&self) -> f64 {
        self.stabilization
    }
    /// Limits of the first free axis, if any.
    pub fn limit(&self) -> Option<JointLimit> {
        self.kind.first_axis().and_then(|a| self.axis_limit(a))
    }
    /// Motor of the first free axis, if any.
    pub fn motor(&self) -> Option<JointMotor> {
        self.kind.first_axis().and_then(|a| self.axis_motor(a))
    }
    /// Limits of a free axis, if any.
    pub fn axis_limit(&self, axis: FreeAxis) -> Option<JointLimit> {
        self.limits[axis.index()]
    }
    /// Motor of a free axis, if any.
    pub fn axis_motor(&self, axis: FreeAxis) -> Option<JointMotor> {
        self.motors[axis.index()]
    }
}
