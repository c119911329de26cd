//! Joint models: what a joint *is* (kind, bodies, frames, compliance, limits, motor). The rows it
//! produces for the solver are built in `joint_rows.rs` (the model is not the solver row, as rapier
//! keeps `GenericJoint` apart from its `JointConstraint`).
//!
//! **Frames.** A joint holds a local frame on each body, `F_a` on body A and `F_b` on body B (or on
//! the world when B is absent). In world coordinates `W_a = X_a F_a` and `W_b = X_b F_b`, with
//! origins (anchors) `p_a`, `p_b` and axes `(e₁, e₂, e₃)` of `W_a`. The *x axis* of the frames is the
//! joint axis (hinge rotation axis, prismatic slide axis). At rest (no violation) `W_a = W_b`, except
//! along the free axis.
//!
//! | kind | locked rows | free axis |
//! |---|---|---|
//! | fixed | 3 linear (`e₁, e₂, e₃`) + 3 angular | — |
//! | hinge | 3 linear + 2 angular (`e₂, e₃` against B's x axis) | rotation about `e₁` |
//! | prismatic | 2 linear (`e₂, e₃`) + 3 angular | translation along `e₁` |
//! | ball | 3 linear | all rotations |
//!
//! **Rows of a joint** are numbered by a slot ([`JointRow`]): `0..6` the locked rows in the order of
//! the table, 6 the lower limit, 7 the upper limit, 8 the motor. Compliance is given per slot; the
//! slot is also the key under which the row's index state and impulse persist between steps (warm
//! start).
//!
//! **Free coordinate** (hinge, prismatic): the angle (rad, right-handed about the axis) or the
//! displacement (m, along the axis) of body A relative to body B — B is the parent, or the world —
//! zero where the joint was built. Read it with `World::joint_coordinate` / `joint_speed`.
//!
//! **Limits**: `lower ≤ s ≤ upper` on the free coordinate (hinge limits within `(−π, π]`). A
//! unilateral row `λ ∈ [0, ∞)` is emitted only while the coordinate is within `margin` of a bound or
//! predicted to cross it in the step. **Motor**: a velocity row on the free
//! axis driving the relative speed to `target_speed`, with impulse bounds `±max_force · h` (a boxed
//! row: the motor stalls at its force/torque bound).
//!
//! **Compliance and stabilization** per row (paper eq. 1, `C` diagonal): see `rows.rs` for the row
//! equation. The default compliance `1e-10` is the stiff end of the paper's Table 1 range; the default
//! stabilization `β = 1` removes the whole violation in one step (paper: `−φ/h`).

use nalgebra::{Isometry3, Vector3};

use super::body::BodyId;

/// Stable id of a joint in its [`World`](super::World) (index in creation order).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct JointId(pub u32);

impl JointId {
    /// Index in the world's joint list.
    #[inline]
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

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
}

impl JointKind {
    /// Name used in reports and errors.
    pub fn name(self) -> &'static str {
        match self {
            JointKind::Fixed => "fixed",
            JointKind::Hinge => "hinge",
            JointKind::Prismatic => "prismatic",
            JointKind::Ball => "ball",
        }
    }

    /// Number of locked (bilateral) rows.
    pub fn locked_rows(self) -> usize {
        match self {
            JointKind::Fixed => 6,
            JointKind::Hinge | JointKind::Prismatic => 5,
            JointKind::Ball => 3,
        }
    }

    /// Whether the joint has one free axis that may carry a limit and a motor.
    pub fn has_free_axis(self) -> bool {
        matches!(self, JointKind::Hinge | JointKind::Prismatic)
    }
}

/// The row slots of a joint (also its warm-start keys).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum JointRow {
    /// Locked row `k` (`0..6`, see the module table).
    Locked(u8),
    /// Lower limit of the free axis.
    LowerLimit,
    /// Upper limit of the free axis.
    UpperLimit,
    /// Motor of the free axis.
    Motor,
}

/// Number of row slots per joint.
pub const JOINT_SLOTS: usize = 9;

impl JointRow {
    /// Slot index `0..JOINT_SLOTS`.
    #[inline]
    pub fn slot(self) -> usize {
        match self {
            JointRow::Locked(k) => k as usize,
            JointRow::LowerLimit => 6,
            JointRow::UpperLimit => 7,
            JointRow::Motor => 8,
        }
    }
}

/// Default row compliance (paper Table 1, stiff end).
pub const DEFAULT_COMPLIANCE: f64 = 1e-10;

/// Lower/upper limit of the free coordinate (rad for hinges, m for prismatic joints).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointLimit {
    /// Lower bound (may be `−∞`).
    pub lower: f64,
    /// Upper bound (may be `+∞`).
    pub upper: f64,
    /// A limit row is emitted while the coordinate is within this distance of the bound.
    pub margin: f64,
}

impl JointLimit {
    /// Limits with the default activation margin (0.01 rad or m).
    pub fn new(lower: f64, upper: f64) -> Self {
        JointLimit { lower, upper, margin: 0.01 }
    }
}

/// Velocity motor on the free axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointMotor {
    /// Target speed (rad/s or m/s) of A relative to B about/along the axis (B is the parent or the
    /// world), positive in the sense of the axis.
    pub target_speed: f64,
    /// Force (N) or torque (N m) bound, `≥ 0`.
    pub max_force: f64,
}

/// How the joint frames are given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum JointFrames {
    /// One world frame at the bodies' current poses: origin `anchor`, x axis `axis` (unit). Both
    /// local frames are derived from it, so the joint starts without violation.
    World {
        /// Anchor point (world).
        anchor: Vector3<f64>,
        /// Joint axis (world, unit; ignored by ball joints but still validated).
        axis: Vector3<f64>,
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
    pub(crate) limit: Option<JointLimit>,
    pub(crate) motor: Option<JointMotor>,
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
            limit: None,
            motor: None,
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

    /// Limits on the free axis.
    pub fn limit(mut self, limit: JointLimit) -> Self {
        self.limit = Some(limit);
        self
    }

    /// Velocity motor on the free axis.
    pub fn motor(mut self, motor: JointMotor) -> Self {
        self.motor = Some(motor);
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
    pub(crate) limit: Option<JointLimit>,
    pub(crate) motor: Option<JointMotor>,
}

impl Joint {
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
    /// Limits, if any.
    pub fn limit(&self) -> Option<JointLimit> {
        self.limit
    }
    /// Motor, if any.
    pub fn motor(&self) -> Option<JointMotor> {
        self.motor
    }
}
