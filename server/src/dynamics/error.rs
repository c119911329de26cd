//! Typed errors of the dynamics, one enum per operation (iceoryx2/faer style): building the world
//! ([`SettingsError`]), adding a body ([`BodyError`]), a joint ([`JointError`]), a coupling
//! ([`CouplingError`]), a chain ([`ChainError`]) or a force element ([`ForceError`]), changing a
//! body's state ([`StateError`]) or a control input ([`ControlError`]) and stepping ([`StepError`]).
//! [`ModelError`] joins the model-building ones for callers (scene loaders) that want one type.
//!
//! Every error names the offending item (body or joint name, or id when no name applies). Soft
//! outcomes of a step (solver hit its step cap, inexact residual) are not errors: they are in the
//! per-island stats.

use thiserror::Error;

use super::ids::{BodyId, CouplingId, JointId};
use super::motor::JointMotor;
use crate::solver::MlcpError;

/// Errors of [`World::new`](super::World::new).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SettingsError {
    /// The time step must be finite and positive.
    #[error("time step must be finite and > 0 (got {0})")]
    InvalidTimestep(f64),
    /// Gravity has a NaN or infinite component.
    #[error("gravity must be finite (got [{}, {}, {}])", .0[0], .0[1], .0[2])]
    NonFiniteGravity([f64; 3]),
    /// The solve time budget must be finite and positive.
    #[error("max_solve_us must be finite and > 0 (got {0})")]
    InvalidSolveBudget(f64),
    /// `max_substeps` must be 1 (never) to 64.
    #[error("max_substeps must be 1 to 64 (got {0})")]
    InvalidSubsteps(usize),
    /// The joint-error guard's tolerance must be finite and ≥ 0.
    #[error("joint_error_tolerance must be finite and >= 0 m (got {0})")]
    InvalidJointErrorTolerance(f64),
    /// An iteration count is unreasonably large (> 16).
    #[error("{what} must be at most 16 (got {value})")]
    TooManyIterations {
        /// Which setting.
        what: &'static str,
        /// The value.
        value: usize,
    },
}

/// Errors of [`World::add_body`](super::World::add_body): the body builder's validation.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum BodyError {
    /// Bodies need a non-empty name.
    #[error("a body needs a non-empty name")]
    EmptyName,
    /// Another body already has this name.
    #[error("body '{body}': the name is already taken")]
    DuplicateName {
        /// The name.
        body: String,
    },
    /// Mass of a dynamic body is zero, negative, NaN or infinite.
    #[error("body '{body}': mass must be finite and > 0 (got {mass})")]
    InvalidMass {
        /// Body name.
        body: String,
        /// The mass given.
        mass: f64,
    },
    /// A principal moment of inertia of a dynamic body is zero, negative, NaN or infinite.
    #[error("body '{body}': principal inertia must be finite and > 0 (got [{}, {}, {}])", .inertia[0], .inertia[1], .inertia[2])]
    InvalidInertia {
        /// Body name.
        body: String,
        /// The principal moments given.
        inertia: [f64; 3],
    },
    /// The principal moments violate the triangle inequality `I_i ≤ I_j + I_k` (no mass
    /// distribution has them).
    #[error("body '{body}': principal inertia [{}, {}, {}] violates I_i <= I_j + I_k", .inertia[0], .inertia[1], .inertia[2])]
    NonPhysicalInertia {
        /// Body name.
        body: String,
        /// The principal moments given.
        inertia: [f64; 3],
    },
    /// A quaternion (orientation or inertia frame) is not of unit norm (or has a NaN).
    #[error("body '{body}': {what} quaternion has norm {norm}, expected 1")]
    NonUnitQuaternion {
        /// Body name.
        body: String,
        /// `orientation` or `inertia frame`.
        what: &'static str,
        /// Its norm (NaN if a component is NaN).
        norm: f64,
    },
    /// A position or velocity component is NaN or infinite.
    #[error("body '{body}': {what} is not finite")]
    NonFinite {
        /// Body name.
        body: String,
        /// Which field.
        what: &'static str,
    },
    /// A damping rate is negative, NaN or infinite.
    #[error("body '{body}': {what} must be finite and >= 0 (got {value})")]
    InvalidDamping {
        /// Body name.
        body: String,
        /// `linear damping` or `angular damping`.
        what: &'static str,
        /// The value.
        value: f64,
    },
    /// A static body was given a velocity.
    #[error("body '{body}': a static body cannot move (give it kind Kinematic to script its motion)")]
    StaticBodyMoving {
        /// Body name.
        body: String,
    },
}

/// Errors of [`World::add_joint`](super::World::add_joint).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum JointError {
    /// Joints need a non-empty name.
    #[error("a joint needs a non-empty name")]
    EmptyName,
    /// Another joint already has this name.
    #[error("joint '{joint}': the name is already taken")]
    DuplicateName {
        /// The name.
        joint: String,
    },
    /// A body id that the world does not hold.
    #[error("joint '{joint}': unknown body {body:?}")]
    UnknownBody {
        /// Joint name.
        joint: String,
        /// The id given.
        body: BodyId,
    },
    /// Both ends of the joint are the same body.
    #[error("joint '{joint}': joins body '{body}' to itself")]
    SelfJoint {
        /// Joint name.
        joint: String,
        /// Body name.
        body: String,
    },
    /// Neither end is a dynamic body: the joint could never act.
    #[error("joint '{joint}': neither body is dynamic")]
    NoDynamicBody {
        /// Joint name.
        joint: String,
    },
    /// A joint axis is not of unit length (within 1e-6) or has a NaN.
    #[error("joint '{joint}': axis has norm {norm}, expected 1")]
    NonUnitAxis {
        /// Joint name.
        joint: String,
        /// Its norm.
        norm: f64,
    },
    /// The two world axes of a frame (a universal joint's pins) are not perpendicular (within 1e-6).
    #[error("joint '{joint}': axes are not perpendicular (dot product {dot})")]
    NonPerpendicularAxes {
        /// Joint name.
        joint: String,
        /// Their dot product.
        dot: f64,
    },
    /// A local frame's rotation is not a unit quaternion (or has a NaN).
    #[error("joint '{joint}': {which} rotation has norm {norm}, expected 1")]
    NonUnitFrame {
        /// Joint name.
        joint: String,
        /// `frame_a` or `frame_b`.
        which: &'static str,
        /// Quaternion norm.
        norm: f64,
    },
    /// An anchor or frame translation is not finite.
    #[error("joint '{joint}': {what} is not finite")]
    NonFinite {
        /// Joint name.
        joint: String,
        /// Which field.
        what: &'static str,
    },
    /// A row compliance is negative, NaN or infinite.
    #[error("joint '{joint}': compliance of row {row} must be finite and >= 0 (got {value})")]
    InvalidCompliance {
        /// Joint name.
        joint: String,
        /// Row slot ([`JointRow::slot`](super::JointRow::slot): 0–5 locked rows, then lower
        /// limit, upper limit, motor of the linear axis (6–8) and of the angular axis (9–11)).
        row: usize,
        /// The value.
        value: f64,
    },
    /// The stabilization factor must lie in `[0, 1]`.
    #[error("joint '{joint}': stabilization must lie in [0, 1] (got {value})")]
    InvalidStabilization {
        /// Joint name.
        joint: String,
        /// The value.
        value: f64,
    },
    /// Limits or a motor on a joint without a free axis (fixed, ball, universal).
    #[error("joint '{joint}': a {kind} joint has no free axis for a limit or motor")]
    NoFreeAxis {
        /// Joint name.
        joint: String,
        /// Joint kind name.
        kind: &'static str,
    },
    /// `lower > upper`, a NaN bound, or a non-finite / negative activation margin.
    #[error("joint '{joint}': invalid limit [{lower}, {upper}] (margin {margin})")]
    InvalidLimit {
        /// Joint name.
        joint: String,
        /// Lower bound.
        lower: f64,
        /// Upper bound.
        upper: f64,
        /// Activation margin.
        margin: f64,
    },
    /// Limits or a motor on an axis the joint does not have free (a linear limit on a hinge).
    #[error("joint '{joint}': a {kind} joint has no free {axis} axis")]
    NoSuchAxis {
        /// Joint name.
        joint: String,
        /// Joint kind name.
        kind: &'static str,
        /// `linear` or `angular`.
        axis: &'static str,
    },
    /// A motor parameter is out of range: a non-finite target (speed or position), a negative or
    /// non-finite force bound, a speed bound not `> 0`, a gain outside `(0, 1]`.
    #[error("joint '{joint}': invalid motor {motor:?}")]
    InvalidMotor {
        /// Joint name.
        joint: String,
        /// The motor given.
        motor: JointMotor,
    },
}

/// Errors of [`World::add_coupling`](super::World::add_coupling).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CouplingError {
    /// Couplings need a non-empty name.
    #[error("a coupling needs a non-empty name")]
    EmptyName,
    /// Another coupling already has this name.
    #[error("coupling '{coupling}': the name is already taken")]
    DuplicateName {
        /// The name.
        coupling: String,
    },
    /// The ratio is zero, negative, NaN or infinite.
    #[error(
        "coupling '{coupling}': ratio must be finite and > 0 (got {ratio}); reverse a shaft through its joint axis"
    )]
    InvalidRatio {
        /// Coupling name.
        coupling: String,
        /// The ratio.
        ratio: f64,
    },
    /// A joint id that the world does not hold.
    #[error("coupling '{coupling}': unknown joint {joint:?}")]
    UnknownJoint {
        /// Coupling name.
        coupling: String,
        /// The id given.
        joint: JointId,
    },
    /// The same joint is given for two shafts.
    #[error("coupling '{coupling}': joint '{joint}' is used for two shafts")]
    RepeatedJoint {
        /// Coupling name.
        coupling: String,
        /// Joint name.
        joint: String,
    },
    /// A shaft's joint has no free rotation (only hinge and cylindrical joints have one).
    #[error("coupling '{coupling}': joint '{joint}' is a {kind} joint, which has no free rotation to couple")]
    NotRotational {
        /// Coupling name.
        coupling: String,
        /// Joint name.
        joint: String,
        /// Its kind.
        kind: &'static str,
    },
    /// A rack's joint has no free slide (only prismatic and cylindrical joints have one).
    #[error("coupling '{coupling}': joint '{joint}' is a {kind} joint, which has no free slide to drive")]
    NotLinear {
        /// Coupling name.
        coupling: String,
        /// Joint name.
        joint: String,
        /// Its kind.
        kind: &'static str,
    },
    /// The shafts' joints touch more bodies than one row holds (4): give a differential's shafts
    /// a common housing.
    #[error(
        "coupling '{coupling}': its joints touch {bodies} bodies, at most 4 fit one row (give the shafts a common housing)"
    )]
    TooManyBodies {
        /// Coupling name.
        coupling: String,
        /// Distinct bodies touched.
        bodies: usize,
    },
    /// The compliance is negative, NaN or infinite.
    #[error("coupling '{coupling}': compliance must be finite and >= 0 (got {value})")]
    InvalidCompliance {
        /// Coupling name.
        coupling: String,
        /// The value.
        value: f64,
    },
    /// The clutch torque bound is negative, NaN or infinite.
    #[error("coupling '{coupling}': max torque must be finite and >= 0 (got {value})")]
    InvalidMaxTorque {
        /// Coupling name.
        coupling: String,
        /// The value.
        value: f64,
    },
}

/// Errors of [`World::add_chain`](super::World::add_chain). A refused chain adds nothing.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ChainError {
    /// Chains need a non-empty name (the prefix of their bodies' and joints' names).
    #[error("a chain needs a non-empty name")]
    EmptyName,
    /// A parameter is NaN, infinite or out of range.
    #[error("chain '{chain}': {what} = {value} is not allowed")]
    InvalidParameter {
        /// Chain name.
        chain: String,
        /// Which parameter.
        what: &'static str,
        /// The value.
        value: f64,
    },
    /// The direction is not of unit length (within 1e-6) or has a NaN.
    #[error("chain '{chain}': direction has norm {norm}, expected 1")]
    NonUnitDirection {
        /// Chain name.
        chain: String,
        /// Its norm.
        norm: f64,
    },
    /// A segment or joint name the chain would create is taken.
    #[error("chain '{chain}': the name '{name}' is already taken")]
    NameTaken {
        /// Chain name.
        chain: String,
        /// The taken body or joint name.
        name: String,
    },
    /// An end is attached to a body that the world does not hold.
    #[error("chain '{chain}': unknown body {body:?}")]
    UnknownBody {
        /// Chain name.
        chain: String,
        /// The id given.
        body: BodyId,
    },
    /// The drum's hinge is not a joint of the world.
    #[error("chain '{chain}': unknown drum joint {joint:?}")]
    UnknownJoint {
        /// Chain name.
        chain: String,
        /// The id given.
        joint: JointId,
    },
    /// Both ends are attached to the same body.
    #[error("chain '{chain}': both ends are attached to body '{body}'")]
    EndsOnOneBody {
        /// Chain name.
        chain: String,
        /// Body name.
        body: String,
    },
    /// A segment was refused (not expected after the chain's own validation).
    #[error(transparent)]
    Body(#[from] BodyError),
    /// A joint was refused (not expected after the chain's own validation).
    #[error(transparent)]
    Joint(#[from] JointError),
    /// The drum's coupling was refused (the hinge has no free rotation).
    #[error(transparent)]
    Coupling(#[from] CouplingError),
}

/// Errors of [`World::add_force`](super::World::add_force).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ForceError {
    /// Force elements need a non-empty name.
    #[error("a force element needs a non-empty name")]
    EmptyName,
    /// Another force element already has this name.
    #[error("force '{force}': the name is already taken")]
    DuplicateName {
        /// The name.
        force: String,
    },
    /// A body id that the world does not hold.
    #[error("force '{force}': unknown body {body:?}")]
    UnknownBody {
        /// Force element name.
        force: String,
        /// The id given.
        body: BodyId,
    },
    /// A spring from a body to itself.
    #[error("force '{force}': attaches body '{body}' to itself")]
    SelfAttached {
        /// Force element name.
        force: String,
        /// Body name.
        body: String,
    },
    /// Neither end is dynamic: the element could never act.
    #[error("force '{force}': no dynamic body to act on")]
    NoDynamicBody {
        /// Force element name.
        force: String,
    },
    /// A parameter is NaN, infinite or out of range.
    #[error("force '{force}': {what} = {value} is not allowed")]
    InvalidParameter {
        /// Force element name.
        force: String,
        /// Which parameter.
        what: &'static str,
        /// The value.
        value: f64,
    },
    /// A buoyancy element without sample points.
    #[error("force '{force}': a buoyancy element needs at least one sample point")]
    NoSamplePoints {
        /// Force element name.
        force: String,
    },
    /// A sample point's position is not finite or its volume or height is not `> 0`.
    #[error("force '{force}': sample point {point}: {what} = {value} is not allowed")]
    InvalidPoint {
        /// Force element name.
        force: String,
        /// Index of the point.
        point: usize,
        /// `position`, `volume` or `height`.
        what: &'static str,
        /// The value.
        value: f64,
    },
}

/// Errors of changing a body's state ([`World::set_velocity`](super::World::set_velocity),
/// [`World::set_pose`](super::World::set_pose)).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum StateError {
    /// A body id that the world does not hold.
    #[error("unknown body {0:?}")]
    UnknownBody(BodyId),
    /// Static bodies do not move.
    #[error("body '{0}' is static")]
    StaticBody(String),
    /// A NaN or infinite component, or a non-unit quaternion.
    #[error("body '{body}': {what} is not finite or not a unit quaternion")]
    Invalid {
        /// Body name.
        body: String,
        /// Which value.
        what: &'static str,
    },
}

/// Errors of live control inputs ([`World::set_joint_motor`](super::World::set_joint_motor),
/// [`World::set_coupling_max_torque`](super::World::set_coupling_max_torque)).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ControlError {
    /// A joint id that the world does not hold.
    #[error("unknown joint {0:?}")]
    UnknownJoint(JointId),
    /// A coupling id that the world does not hold.
    #[error("unknown coupling {0:?}")]
    UnknownCoupling(CouplingId),
    /// The joint has no such free axis, or the motor is invalid.
    #[error(transparent)]
    Joint(#[from] JointError),
    /// The clutch bound is invalid.
    #[error(transparent)]
    Coupling(#[from] CouplingError),
}

/// Errors of [`World::step`](super::World::step). On error the world state is left as it was
/// before the step.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum StepError {
    /// The island's MLCP failed validation (a bug in the row assembly, or non-finite input).
    #[error("island {island}: MLCP assembly failed: {source}")]
    Assembly {
        /// Island index in this step.
        island: usize,
        /// The solver's validation error.
        source: MlcpError,
    },
    /// The new state of a body would not be finite.
    #[error("body '{body}': the step produced a non-finite state")]
    NonFinite {
        /// Body name.
        body: String,
    },
}

/// Any model-building error: what a scene loader reports.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ModelError {
    /// World settings.
    #[error(transparent)]
    Settings(#[from] SettingsError),
    /// A body.
    #[error(transparent)]
    Body(#[from] BodyError),
    /// A joint.
    #[error(transparent)]
    Joint(#[from] JointError),
    /// A coupling.
    #[error(transparent)]
    Coupling(#[from] CouplingError),
    /// A chain.
    #[error(transparent)]
    Chain(#[from] ChainError),
    /// A force element.
    #[error(transparent)]
    Force(#[from] ForceError),
}

/// Errors of [`World::set_threads`](super::World::set_threads).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ThreadsError {
    /// `0`, or more than [`MAX_THREADS`](super::MAX_THREADS).
    #[error("solver threads must be 1 ..= {max}, got {threads}")]
    Count {
        /// What was asked for.
        threads: usize,
        /// The most allowed.
        max: usize,
    },
    /// The operating system refused the pool's threads.
    #[error("cannot start {threads} solver threads: {message}")]
    Spawn {
        /// What was asked for.
        threads: usize,
        /// The thread pool's error.
        message: String,
    },
}
