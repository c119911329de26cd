//! Multibody dynamics on top of the solver (paper §3, eq. 1–3): rigid bodies, force elements,
//! joints as models, their constraint rows, islands and the implicit step.
//!
//! One step solves, per island of dynamic bodies,
//!
//! ```text
//!   [ M   −Jᵀ  ] [ v⁺ ]   [ M v + h f ]
//!   [ J  C/h²  ] [ λ  ] = [    r      ]      r = −βφ/h (position rows) or a target speed (motors)  (eq. 1)
//!
//!   A λ = b,   A = J M⁻¹ Jᵀ + C/h²,   b = r − J M⁻¹ (M v + h f)                                   (eq. 2)
//! ```
//!
//! as the boxed MLCP of eq. 3 with the solver's [`Variant`](crate::solver::Variant) of choice, then
//! `v⁺ = v + M⁻¹ (h f + Jᵀ λ)` and `x⁺ = x + h v⁺`, `q⁺ = normalize(exp(h ω⁺/2) ⊗ q)`.
//!
//! | file | concept |
//! |---|---|
//! | `body.rs` | rigid bodies: mass properties, kinds, state, builder and validation |
//! | `force.rs` | applied-force elements (spring–damper; gravity is a world setting) |
//! | `joint.rs` | joint models: kinds, frames, compliance, stabilization, limits, motors |
//! | `rows.rs` | the constraint row handed to the assembly; the row equation and its signs |
//! | `joint_rows.rs` | joint → rows: violations and Jacobians of each joint kind |
//! | `island.rs` | union–find islands over dynamic bodies |
//! | `assemble.rs` | per-island `A`, `b` from body-pair blocks; `v⁺ = v_free + M⁻¹Jᵀλ` |
//! | `step.rs` | the time step and its integrator |
//! | `projection.rs` | optional position projection (post-stabilization) |
//! | `world.rs` | the world: settings, adding and validating items, queries |
//! | `stats.rs` | per-island statistics of a step |
//! | `error.rs` | typed errors, one enum per operation |
//!
//! Conventions: SI units, z up, f64 throughout; a body's frame has its origin at the centre of mass;
//! velocities are world-frame; a joint's free coordinate is that of body A relative to body B (B the
//! parent or the world). Items get stable ids and unique names; bad input is refused at build time
//! with typed errors ([`BodyError`], [`JointError`], …) and a step never writes a non-finite state.
//!
//! ```
//! use nalgebra::Vector3;
//! use pivotsim_server::dynamics::{BodyBuilder, JointBuilder, World, WorldSettings, sphere_inertia};
//!
//! let mut world = World::new(WorldSettings::default())?;
//! let bob = world.add_body(
//!     BodyBuilder::dynamic("bob", 1.0, sphere_inertia(1.0, 0.05)).position(Vector3::new(1.0, 0.0, 2.0)),
//! )?;
//! // A pendulum: a hinge about y through (0, 0, 2), to the world.
//! let pivot = world.add_joint(JointBuilder::hinge("pivot", bob, None, Vector3::new(0.0, 0.0, 2.0), Vector3::y()))?;
//! for _ in 0..60 {
//!     world.step()?;
//! }
//! assert!(world.joint_coordinate(pivot).unwrap() > 0.5); // swung down
//! assert_eq!(world.island_stats()[0].rows, 5);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! The solver never imports this module.

mod assemble;
mod body;
mod error;
mod force;
mod island;
mod joint;
mod joint_rows;
mod projection;
mod rows;
mod stats;
mod step;
mod world;

pub use body::{BodyBuilder, BodyId, BodyKind, RigidBody, box_inertia, cylinder_inertia, sphere_inertia};
pub use error::{
    BodyError, ControlError, ForceError, JointError, ModelError, SettingsError, StateError, StepError,
};
pub use force::{ForceElement, ForceId, SpringDamper};
pub use island::Islands;
pub use joint::{
    DEFAULT_COMPLIANCE, JOINT_SLOTS, Joint, JointBuilder, JointFrames, JointId, JointKind, JointLimit,
    JointMotor, JointRow,
};
pub use rows::{ConstraintRow, Jac6, RowKey, RowKind};
pub use stats::IslandStats;
pub use world::{JointFramesWorld, World, WorldSettings};
