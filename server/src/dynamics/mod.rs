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
//! `v⁺ = v + M⁻¹ (h f + Jᵀ λ)` and `x⁺ = x + h v⁺`, `q⁺ = normalize(exp(h ω⁺/2) ⊗ q)`. The rows are
//! those of joints (locked axes, limits, velocity and position motors), couplings (gears,
//! differentials, clutches: one row on up to four bodies) and spring–dampers (implicit force rows);
//! buoyancy and drag enter `f` linearly implicitly (`force.rs`). Bodies whose joints carry loads
//! large enough to make the step unstable get the joints' geometric stiffness in their effective
//! mass, `M̃ = M + h² K̃` (`geometric_stiffness.rs`), in place of `M` above.
//!
//! The files come in four layers, each importing only from the layers before it: the model (what
//! the items *are*), their rows (what they hand the solver), the step's pipeline (islands, assembly,
//! the stages of a step) and the world (the items together, the step run on them, the API).
//!
//! | layer | file | concept |
//! |---|---|---|
//! | model | `ids.rs` | stable ids of bodies, joints, couplings, force elements and colliders |
//! | | `error.rs` | typed errors, one enum per operation |
//! | | `body.rs` | rigid bodies: mass properties, kinds, damping, state, builder and validation |
//! | | `motor.rs` | free axes, limits, velocity and position-target motors |
//! | | `joint.rs` | joint models: kinds, frames, compliance, stabilization |
//! | | `coupling.rs` | powertrain couplings: gear pairs, differentials, clutches |
//! | | `force.rs` | applied-force elements (spring–damper; gravity is a world setting) |
//! | | `buoyancy.rs` | hydrostatic buoyancy and drag on sample points, water plane with waves |
//! | | `accumulator.rs` | per-body sums of a step's applied forces and their Jacobians |
//! | | `settings.rs` | world settings (and the projection default), the geometric-stiffness modes |
//! | rows | `rows.rs` | the constraint row handed to the assembly, its key and warm-start record; the row equation and its signs |
//! | | `joint_rows.rs` | joint → rows: violations and Jacobians of each joint kind |
//! | | `coupling_rows.rs` | coupling → its velocity row on up to four bodies |
//! | | `force_rows.rs` | spring–damper → its implicit force row |
//! | | `contact/` | colliders, broad and narrow phase (parry3d-f64), contact and friction rows |
//! | pipeline | `island.rs` | union–find islands over dynamic bodies |
//! | | `geometric_stiffness.rs` | geometric stiffness of loaded joints: `M̃ = M + h² K̃` per body |
//! | | `assemble.rs` | per-island `A`, `b` from body blocks; `v⁺ = v_free + M⁻¹Jᵀλ` |
//! | | `stats.rs` | per-island statistics of a step |
//! | | `shadow.rs` | shadow solves: other variants on the same island problems, for paired timing and agreement |
//! | | `step.rs` | the stages of a time step and its integrator, on reusable buffers |
//! | | `projection.rs` | optional position projection (post-stabilization) |
//! | world | `world/mod.rs` | the world: adding and validating items, controls, the step |
//! | | `world/query.rs` | read access: coordinates, impulses, reactions, islands, momentum |
//! | | `world/control.rs` | live model changes: latching/releasing joints, capturing island problems |
//! | | `world/colliders.rs` | colliders, the friction table, contact settings, the last step's contacts |
//! | | `chain.rs` | chain/cable helper: segments joined by ball joints |
//! | | `watchdog.rs` | instability watchdog: energy gain beyond the inputs' work, speed bound |
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

mod accumulator;
mod assemble;
mod body;
mod buoyancy;
mod chain;
mod contact;
mod coupling;
mod coupling_rows;
mod error;
mod force;
mod force_rows;
mod geometric_stiffness;
mod ids;
mod island;
mod joint;
mod joint_rows;
mod motor;
mod projection;
mod rows;
mod settings;
mod shadow;
mod stats;
mod step;
mod watchdog;
mod world;

pub use body::{
    BodyBuilder, BodyKind, RigidBody, box_inertia, capsule_inertia, cylinder_inertia, sphere_inertia,
};
pub use buoyancy::{Buoyancy, BuoyancyPoint, Water, Wave};
pub use chain::{Chain, ChainBuilder, ChainEnd, ChainShape, steel_rope_mass_per_metre};
pub use contact::{
    Bounds, Collider, ColliderBuilder, CollisionGroups, ContactError, ContactReport, ContactSettings,
    DEFAULT_CONTACT_COMPLIANCE, DEFAULT_MATERIAL, MAX_TERRAIN_TRIANGLES, Material, Shape, SweepAndPrune,
    terrain,
};
pub use coupling::{Coupling, CouplingBuilder, CouplingKind};
pub use error::{
    BodyError, ChainError, ControlError, CouplingError, ForceError, JointError, ModelError, SettingsError,
    StateError, StepError, ThreadsError,
};
pub use force::{ForceElement, SpringDamper};
pub use geometric_stiffness::RHO_START;
pub use ids::{BodyId, ColliderId, CouplingId, ForceId, JointId};
pub use island::Islands;
pub use joint::{DEFAULT_COMPLIANCE, JOINT_SLOTS, Joint, JointBuilder, JointFrames, JointKind, JointRow};
pub use motor::{DEFAULT_POSITION_GAIN, FreeAxis, JointLimit, JointMotor, MotorMode, wrap_angle};
pub use projection::GUARD_ITERATIONS;
pub use rows::{ConstraintRow, Jac6, MAX_ROW_BODIES, RowKey, RowKind};
pub use settings::{DEFAULT_JOINT_ERROR_TOLERANCE, GeometricStiffness, WorldSettings};
pub use shadow::TooManyShadows;
pub use stats::{IslandStats, MAX_SHADOWS, ShadowSolve};
pub use watchdog::{DEFAULT_MAX_JOINT_ERROR, Instability, Watchdog, WatchdogSettings};
pub use world::{BodyState, JointFramesWorld, JointReaction, JointState, World, WorldState, WorldStateError};
pub use world::{MAX_THREADS, SUBSTEP_TURN};
