//! Contacts with Coulomb friction (issue 5): colliders attached to bodies, broad and narrow phase
//! through parry3d-f64, terrain, the friction table, and the contact rows of the step.
//!
//! | file | concept |
//! |---|---|
//! | `convert.rs` | the one nalgebra ↔ glam boundary (parry 0.31 uses glam types) |
//! | `shape.rs` | shapes (ball, cuboid, capsule, cylinder, convex hull, half-space, compound, height field, triangle mesh), validation |
//! | `terrain.rs` | ready-made terrain: hills and bumps from `f(x, y)`, a ramp, stairs, a flat deck |
//! | `broad.rs` | broad phase: sweep and prune ([`SweepAndPrune`]) |
//! | `collide.rs` | narrow phase: parry manifolds per pair of parts, half-space and terrain paths |
//! | `material.rs` | material names and the `μ` of a pair (precedence) |
//! | `rows.rs` | contact points → one normal and two friction rows each |
//!
//! **Rows** (`rows.rs`). Per contact point with normal `n` (from collider A to collider B) and gap
//! `φ` (the signed distance, negative in penetration) one normal row `J v = n·(v_B(p) − v_A(p))`,
//! `0 ≤ λ_n`, position kind with `r = −φ/h` for a gap inside the prediction margin (speculative
//! contact: the bodies may close the gap in one step, not more) and `r = −β φ / h` in penetration
//! (recovery of the fraction `β` per step); then two friction rows along an orthonormal tangent
//! basis `t₁, t₂` with `findex` → the normal row and coefficients `±μ` (`|λ_t| ≤ μ λ_n` with the
//! *final* `λ_n`, the box approximation of the Coulomb cone, paper §3). `t₁` follows the relative
//! sliding velocity when it exceeds [`ContactSettings::sliding_speed`] (so a sliding contact meets
//! the exact Coulomb force `μ λ_n` against its motion), otherwise a deterministic completion of `n`.
//!
//! **Swept margin** ([`ContactSettings::swept`], on by default). A speculative row stops a pair at
//! its gap only if the gap was found: a part that moves farther than the margin in one step passes
//! through a thin wall between two steps (the crane's hook, falling with its boom after a hose
//! burst, moved 8.7 cm per step through the pipe's 8.5 cm wall and wedged in it). Each collider
//! gets the sweep bound `s = h (|v| + |ω| R)` (`R` the farthest corner of its AABB from the body's
//! centre): no point of it moves farther in the step. Its AABB grows by `max(margin/2, s)`, a pair
//! is searched within `max(margin, s_A + s_B)`, and of the points beyond the margin it keeps only
//! those it would pass within the step, `φ ≤ h v_c` with `v_c = −n · (v_B(p) − v_A(p))` the
//! closing speed at the point: a point it reaches more slowly is found within the margin in a
//! later step, as without the sweep. A part slower than `margin / (2h)` (0.3 m/s at the default
//! 1 cm and `h = 1/60`) is searched exactly as without it.
//!
//! **Warm start.** A row's key is [`RowKey::Contact`](super::RowKey) with the collider pair and the
//! parry feature ids of the point, so a contact that persists (same features) is warm-started from
//! its last index state and impulse like a joint row.
//!
//! **Broad phase** (`broad.rs`). Sweep and prune on `x`: the colliders' AABBs (unions of their
//! parts', grown by half the margin) sorted by lower `x` bound in an index array kept from the last
//! step and re-sorted by insertion sort (`O(n + swaps)`, nearly `O(n)` under coherent motion); the
//! sweep tests each box against the following ones until their lower bound passes its upper bound,
//! then `y` and `z`. Unbounded colliders (half-spaces) are paired with every bounded collider. The
//! pairs are sorted, so the narrow phase meets them in the order of an all-pairs loop and
//! trajectories are bitwise those of the `O(n²)` test. Chosen over a BVH because bodies move every
//! step (a tree needs refits and one traversal per collider for the same answer) while the sorted
//! array is cheap to keep, allocation-free and deterministic.
//!
//! **Filtering.** Pairs on the same body, pairs without a dynamic body and pairs of bodies joined by
//! a joint do not collide (unless the joint opts in with
//! [`JointBuilder::collide_connected`](super::JointBuilder::collide_connected)); two colliders
//! collide only if each one's [`CollisionGroups::memberships`] intersect the other's
//! [`CollisionGroups::filter`] (default: all groups, all filters).
//!
//! **Friction** (`material.rs`). Colliders carry a material name ([`ColliderBuilder::material_name`],
//! default [`DEFAULT_MATERIAL`], interned to a small id) and a per-collider
//! [`Material::friction`] (default 1.0). `μ` of a pair, first match wins: the pair's own
//! ([`World::set_pair_friction`](super::World::set_pair_friction)); the material-pair table
//! ([`World::set_material_friction`](super::World::set_material_friction), symmetric, a material
//! with itself included); the geometric mean `√(μ_A μ_B)` of the colliders'.
//!
//! **Compliance.** Normal and friction rows carry [`ContactSettings::compliance`] (default 1e-10 m/N,
//! as joints): it keeps the redundant rows of a resting box (4 points, 12 rows for 6 dofs) regular
//! for the pivoting solver. Its price: a resting contact sinks by `c F / β`, and a sticking friction
//! row, a velocity row, creeps at `c λ_t / h²`; a position-level friction anchor would remove it.
//!
//! **Compounds.** A compound collider is its parts, each a parry shape at its pose in the body frame:
//! every part of one collider meets every part of the other (the colliders' AABBs, the unions of
//! their parts', must overlap), and a point's feature ids carry its part index in bits 20–29, so
//! the warm-start keys of two parts touching the ground stay apart.
//!
//! **Terrain** ([`Shape::HeightField`], [`Shape::TriMesh`]; static bodies only). A convex part
//! (ball, cuboid, capsule, cylinder, convex hull, or a compound's part) meets the triangles under its
//! AABB expressed in the terrain frame and grown by the margin: the height field's cells there, the
//! mesh's BVH leaves. Each triangle gets its own convex–triangle manifold, kept from step to step in
//! a list sorted by triangle index (`collide.rs`): ball and cuboid by parry's dedicated queries, the
//! other shapes by GJK (EPA in penetration, with one reused EPA) and clipping of the support
//! features. The triangle's pseudo-normals (parry's `FIX_INTERNAL_EDGES`: per edge the normalized
//! sum of the adjacent faces' normals) bound the contact normal to the cone the surface allows, so
//! an internal edge between coplanar triangles gives the face normal and a sliding box or rolling
//! ball does not catch on it; the surfaces are one-sided (contacts from the front only). A point
//! on an edge or vertex shared by several triangles comes from each of them; with equal normals
//! (within 1.4e-5 rad) and positions (within 1 nm) only the lowest triangle's is kept. On the
//! terrain side the feature id is parry's feature kind (bits 30–31), the triangle index (bits 2–29,
//! hence at most [`MAX_TERRAIN_TRIANGLES`]) and the triangle-local vertex, edge or face (bits 0–1),
//! so a contact keeps its key while the same features touch; points that a sliding box gets where
//! it crosses a triangle edge are new and start cold.
//!
//! **Allocation.** Pair caches (and per terrain pair its per-triangle manifolds, with those of
//! triangles left behind recycled), the point list, the broad phase's arrays, one EPA and the
//! warm-start map are reused: a step whose contacts persist allocates nothing, on a half-space
//! (`tests/dynamics_contact_allocation.rs`), on a height field or a mesh, for every convex shape,
//! and between convex shapes that need GJK/EPA (`tests/dynamics_contact_terrain_allocation.rs`); a
//! new pair or a new feature pair allocates once. The height-field path and the polygonal-feature
//! pairs (any pair with a capsule, cylinder or hull, but two capsules or a ball) therefore do not go
//! through parry's drivers, which allocate there at every step: they run the same algorithm here
//! (`collide.rs`: GJK, EPA, support features, clipping, the closest pair added), with the EPA
//! reused — bitwise the same points as parry's.
//!
//! **Not yet**: terrain on kinematic or dynamic bodies, two-sided meshes, voxels.
//!
//! Measurements (broad-phase timings, creep, cold starts on terrain, parry's allocations), the
//! history of these choices and the known flaws are in the notes, `docs/notes/contacts.md`.
//!
//! ```
//! use nalgebra::Vector3;
//! use pivotsim_server::dynamics::{BodyBuilder, ColliderBuilder, Shape, World, WorldSettings, box_inertia};
//!
//! let mut world = World::new(WorldSettings::default())?;
//! let ground = world.add_body(BodyBuilder::static_body("ground"))?;
//! world.add_collider(ColliderBuilder::new("ground", ground, Shape::HalfSpace { normal: Vector3::z() }))?;
//! let e = Vector3::new(0.2, 0.2, 0.1);
//! let crate_ = world.add_body(BodyBuilder::dynamic("crate", 2.0, box_inertia(2.0, e)).position(Vector3::new(0.0, 0.0, 0.1)))?;
//! world.add_collider(ColliderBuilder::new("crate", crate_, Shape::Cuboid { half_extents: e }).friction(0.6))?;
//! for _ in 0..60 {
//!     world.step()?;
//! }
//! // Four corners carry the weight: Σ λ_n = m g h.
//! let h = world.settings().timestep;
//! let sum: f64 = world.contacts().map(|c| c.normal_impulse).sum();
//! assert_eq!(world.contacts().count(), 4);
//! assert!((sum - 2.0 * 9.81 * h).abs() < 1e-9);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod broad;
mod collide;
mod convert;
mod material;
mod rows;

pub(crate) use collide::{NarrowPhase, NarrowState};
pub(crate) use rows::orthogonal;
mod shape;
pub mod terrain;

use std::collections::{HashMap, HashSet};

use nalgebra::{Isometry3, Vector3};
use thiserror::Error;

pub use broad::{Bounds, SweepAndPrune};
pub use material::DEFAULT_MATERIAL;
pub use shape::{MAX_TERRAIN_TRIANGLES, Shape};

use super::body::{BodyKind, RigidBody};
use super::ids::{BodyId, ColliderId};
use super::joint::Joint;
use super::rows::ConstraintRow;
use crate::solver::IndexState;

/// Default compliance of contact rows (m/N), as joints'.
pub const DEFAULT_CONTACT_COMPLIANCE: f64 = 1e-10;

/// Surface material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// Coulomb friction coefficient `μ ≥ 0` (paper Table 1: 1.0).
    pub friction: f64,
}

impl Default for Material {
    fn default() -> Self {
        Material { friction: 1.0 }
    }
}

/// Collision groups of a collider: 32 groups as bits. Colliders `a` and `b` collide only if
/// `a.memberships & b.filter != 0` and `b.memberships & a.filter != 0`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct CollisionGroups {
    /// The groups the collider belongs to.
    pub memberships: u32,
    /// The groups it may collide with.
    pub filter: u32,
}

impl CollisionGroups {
    /// Member of all groups, colliding with all (the default).
    pub const ALL: CollisionGroups = CollisionGroups { memberships: u32::MAX, filter: u32::MAX };

    /// Groups `memberships`, colliding with `filter`.
    pub fn new(memberships: u32, filter: u32) -> Self {
        CollisionGroups { memberships, filter }
    }

    /// Whether colliders with groups `self` and `other` may collide (symmetric).
    pub fn interacts_with(self, other: CollisionGroups) -> bool {
        self.memberships & other.filter != 0 && other.memberships & self.filter != 0
    }
}

impl Default for CollisionGroups {
    fn default() -> Self {
        CollisionGroups::ALL
    }
}

/// Contact settings of a world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactSettings {
    /// Prediction margin (m): pairs closer than this get (speculative) contact rows.
    pub margin: f64,
    /// Compliance of normal and friction rows (m/N); > 0 keeps redundant contacts regular.
    pub compliance: f64,
    /// Fraction `β ∈ (0, 1]` of a penetration removed per step.
    pub stabilization: f64,
    /// Relative tangential speed (m/s) above which `t₁` follows the sliding direction.
    pub sliding_speed: f64,
    /// Swept margin (default on): a pair whose parts may move farther than the margin in one step
    /// is searched within that sweep and keeps the points it closes on (module doc).
    pub swept: bool,
}

impl Default for ContactSettings {
    fn default() -> Self {
        ContactSettings {
            margin: 0.01,
            compliance: DEFAULT_CONTACT_COMPLIANCE,
            stabilization: 0.2,
            sliding_speed: 1e-3,
            swept: true,
        }
    }
}

/// Errors of adding a collider or changing the contact settings; degenerate shapes are refused here.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ContactError {
    /// Colliders need a non-empty name.
    #[error("a collider needs a non-empty name")]
    EmptyName,
    /// Another collider has this name.
    #[error("collider '{collider}': the name is already taken")]
    DuplicateName {
        /// The name.
        collider: String,
    },
    /// The body does not exist.
    #[error("collider '{collider}': unknown body {body:?}")]
    UnknownBody {
        /// Collider name.
        collider: String,
        /// The id given.
        body: BodyId,
    },
    /// A size is zero, negative, NaN or infinite.
    #[error("collider '{collider}': {what} must be finite and > 0 (got {value})")]
    InvalidSize {
        /// Collider name.
        collider: String,
        /// Which size.
        what: &'static str,
        /// The value.
        value: f64,
    },
    /// A hull vertex is NaN or infinite.
    #[error("collider '{collider}': vertex {index} is not finite")]
    NonFiniteVertex {
        /// Collider name.
        collider: String,
        /// Vertex index.
        index: usize,
    },
    /// The hull's points do not span a volume (fewer than 4, or coplanar).
    #[error("collider '{collider}': the {points} hull points do not span a volume")]
    DegenerateHull {
        /// Collider name.
        collider: String,
        /// Number of points.
        points: usize,
    },
    /// A half-space normal is not unit.
    #[error("collider '{collider}': the half-space normal must be unit (norm {norm})")]
    NonUnitNormal {
        /// Collider name.
        collider: String,
        /// Its norm.
        norm: f64,
    },
    /// An unbounded shape (half-space) on a dynamic body.
    #[error("collider '{collider}': a {shape} needs a static or kinematic body")]
    UnboundedOnDynamic {
        /// Collider name.
        collider: String,
        /// The shape kind.
        shape: &'static str,
    },
    /// The friction coefficient is negative or not finite.
    #[error("collider '{collider}': friction must be finite and ≥ 0 (got {value})")]
    InvalidFriction {
        /// Collider name.
        collider: String,
        /// The value.
        value: f64,
    },
    /// The offset has a non-finite translation or a non-unit rotation.
    #[error("collider '{collider}': invalid offset")]
    InvalidOffset {
        /// Collider name.
        collider: String,
    },
    /// A compound shape is malformed (no parts, too many, a half-space, compound or invalid pose
    /// among them).
    #[error("collider '{collider}': invalid compound: {reason}")]
    InvalidCompound {
        /// Collider name.
        collider: String,
        /// What is wrong.
        reason: &'static str,
    },
    /// A terrain shape (height field, triangle mesh) on a dynamic or kinematic body.
    #[error("collider '{collider}': a {shape} needs a static body")]
    TerrainNotStatic {
        /// Collider name.
        collider: String,
        /// The shape kind.
        shape: &'static str,
    },
    /// A height field with fewer than 2 rows or columns.
    #[error(
        "collider '{collider}': a height field needs at least 2 × 2 samples (got {rows} rows, {cols} columns)"
    )]
    HeightFieldTooSmall {
        /// Collider name.
        collider: String,
        /// Rows given.
        rows: usize,
        /// Columns given.
        cols: usize,
    },
    /// The number of heights is not `rows · cols`.
    #[error("collider '{collider}': {heights} heights for {rows} × {cols} samples")]
    HeightFieldSize {
        /// Collider name.
        collider: String,
        /// Rows given.
        rows: usize,
        /// Columns given.
        cols: usize,
        /// Heights given.
        heights: usize,
    },
    /// A height is NaN or infinite.
    #[error("collider '{collider}': height at row {row}, column {col} is not finite")]
    NonFiniteHeight {
        /// Collider name.
        collider: String,
        /// Its row.
        row: usize,
        /// Its column.
        col: usize,
    },
    /// A triangle mesh without triangles or without vertices.
    #[error("collider '{collider}': the triangle mesh is empty")]
    EmptyMesh {
        /// Collider name.
        collider: String,
    },
    /// A triangle refers to a vertex that does not exist.
    #[error("collider '{collider}': triangle {triangle} refers to vertex {index} of {vertices}")]
    TriangleIndexOutOfRange {
        /// Collider name.
        collider: String,
        /// Triangle index.
        triangle: usize,
        /// The vertex index.
        index: u32,
        /// Number of vertices.
        vertices: usize,
    },
    /// A triangle has (nearly) zero area: repeated or collinear vertices.
    #[error("collider '{collider}': triangle {triangle} is degenerate (zero area)")]
    DegenerateTriangle {
        /// Collider name.
        collider: String,
        /// Triangle index.
        triangle: usize,
    },
    /// More triangles than contact feature ids can tell apart ([`MAX_TERRAIN_TRIANGLES`]).
    #[error("collider '{collider}': {triangles} triangles exceed the limit of 2^28")]
    TerrainTooLarge {
        /// Collider name.
        collider: String,
        /// Number of triangles.
        triangles: usize,
    },
    /// A material name is empty.
    #[error("a material needs a non-empty name")]
    EmptyMaterialName,
    /// A material-pair friction coefficient is negative or not finite.
    #[error("materials '{a}'/'{b}': friction must be finite and ≥ 0 (got {value})")]
    InvalidMaterialFriction {
        /// First material.
        a: String,
        /// Second material.
        b: String,
        /// The value.
        value: f64,
    },
    /// The collider does not exist.
    #[error("unknown collider {0:?}")]
    UnknownCollider(ColliderId),
    /// A contact setting is out of range.
    #[error("contact setting {what} out of range (got {value})")]
    InvalidSetting {
        /// Which setting.
        what: &'static str,
        /// The value.
        value: f64,
    },
}

/// Builder of a collider: a shape and material attached to a body at an offset.
#[derive(Debug, Clone)]
pub struct ColliderBuilder {
    name: String,
    body: BodyId,
    shape: Shape,
    offset: Isometry3<f64>,
    material: Material,
    material_name: String,
    groups: CollisionGroups,
}

impl ColliderBuilder {
    /// A collider `name` of `shape` on `body`, at the body's frame, default material (named
    /// [`DEFAULT_MATERIAL`], `μ = 1`).
    pub fn new(name: &str, body: BodyId, shape: Shape) -> Self {
        ColliderBuilder {
            name: name.to_string(),
            body,
            shape,
            offset: Isometry3::identity(),
            material: Material::default(),
            material_name: DEFAULT_MATERIAL.to_string(),
            groups: CollisionGroups::ALL,
        }
    }
    /// The material name (non-empty), the key of the material-pair friction table
    /// ([`World::set_material_friction`](super::World::set_material_friction)); default
    /// [`DEFAULT_MATERIAL`].
    pub fn material_name(mut self, name: &str) -> Self {
        self.material_name = name.to_string();
        self
    }
    /// The collider's pose in the body frame.
    pub fn offset(mut self, offset: Isometry3<f64>) -> Self {
        self.offset = offset;
        self
    }
    /// The material.
    pub fn material(mut self, material: Material) -> Self {
        self.material = material;
        self
    }
    /// The friction coefficient.
    pub fn friction(mut self, mu: f64) -> Self {
        self.material.friction = mu;
        self
    }
    /// The collision groups (default [`CollisionGroups::ALL`]).
    pub fn groups(mut self, groups: CollisionGroups) -> Self {
        self.groups = groups;
        self
    }
    /// The name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The collider, validated against the world's `bodies` (degenerate shapes are refused with a
    /// typed error), its material name interned in `materials`. Called by
    /// [`World::add_collider`](super::World::add_collider), which checks first that the name is new.
    pub(crate) fn build(
        self,
        bodies: &[RigidBody],
        materials: &mut material::Materials,
    ) -> Result<Collider, ContactError> {
        let name = || self.name.clone();
        if self.name.is_empty() {
            return Err(ContactError::EmptyName);
        }
        let body = bodies
            .get(self.body.index())
            .ok_or(ContactError::UnknownBody { collider: name(), body: self.body })?;
        if self.shape.is_unbounded() && body.is_dynamic() {
            return Err(ContactError::UnboundedOnDynamic { collider: name(), shape: self.shape.kind_name() });
        }
        if self.shape.is_terrain() && body.kind() != BodyKind::Static {
            return Err(ContactError::TerrainNotStatic { collider: name(), shape: self.shape.kind_name() });
        }
        if self.material_name.is_empty() {
            return Err(ContactError::EmptyMaterialName);
        }
        let mu = self.material.friction;
        if !(mu.is_finite() && mu >= 0.0) {
            return Err(ContactError::InvalidFriction { collider: name(), value: mu });
        }
        if !shape::valid_isometry(&self.offset) {
            return Err(ContactError::InvalidOffset { collider: name() });
        }
        let parts = self.shape.build_parts(&self.name, &self.offset)?;
        let material_id = materials.intern(&self.material_name);
        Ok(Collider {
            name: self.name,
            body: self.body,
            shape: self.shape,
            material: self.material,
            material_id,
            material_name: self.material_name,
            groups: self.groups,
            parts,
            offset: self.offset,
        })
    }
}

/// A collider of the world.
#[derive(Debug, Clone)]
pub struct Collider {
    pub(crate) name: String,
    pub(crate) body: BodyId,
    pub(crate) shape: Shape,
    pub(crate) material: Material,
    /// Its material name's interned id.
    pub(crate) material_id: u32,
    pub(crate) material_name: String,
    pub(crate) groups: CollisionGroups,
    /// Its parry shapes (one unless a compound) at their poses in the body frame.
    pub(crate) parts: Vec<shape::ColliderPart>,
    /// Pose of the collider frame in the body frame.
    pub(crate) offset: Isometry3<f64>,
}

impl Collider {
    /// Name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// The body it is attached to.
    pub fn body(&self) -> BodyId {
        self.body
    }
    /// Its shape.
    pub fn shape(&self) -> &Shape {
        &self.shape
    }
    /// Its material.
    pub fn material(&self) -> Material {
        self.material
    }
    /// Its material name.
    pub fn material_name(&self) -> &str {
        &self.material_name
    }
    /// Its collision groups.
    pub fn groups(&self) -> CollisionGroups {
        self.groups
    }

    /// Pose of the collider frame (where [`Collider::shape`] is given) in the body frame.
    pub fn offset(&self) -> Isometry3<f64> {
        self.offset
    }
}

/// The contact state of a world: colliders, settings, pair caches, the last step's points.
#[derive(Debug, Default)]
pub(crate) struct ContactSet {
    pub colliders: Vec<Collider>,
    pub names: HashMap<String, ColliderId>,
    pub settings: ContactSettings,
    /// Friction coefficients set per collider pair `(lower index, higher index)`.
    pub pair_friction: HashMap<(u32, u32), f64>,
    /// Material names and the material-pair friction table.
    pub materials: material::Materials,
    /// Ids of the joints whose bodies collide with each other (`collide_connected`).
    pub connected: HashSet<u32>,
    pub phase: collide::NarrowPhase,
}

impl ContactSet {
    /// The friction coefficient of the colliders `a` and `b` (indices; `material.rs`).
    pub fn pair_mu(&self, a: usize, b: usize) -> f64 {
        material::pair_mu(&self.colliders, &self.pair_friction, &self.materials, a, b)
    }

    /// The step's hook: finds the contact points at the current poses and appends their rows.
    pub fn push_rows(
        &mut self,
        bodies: &[RigidBody],
        joints: &[Joint],
        h: f64,
        rows: &mut Vec<ConstraintRow>,
    ) {
        if self.colliders.is_empty() {
            return;
        }
        let (colliders, pair_friction, materials) = (&self.colliders, &self.pair_friction, &self.materials);
        self.phase.update(
            colliders,
            |i, j| material::pair_mu(colliders, pair_friction, materials, i, j),
            bodies,
            joints,
            &self.connected,
            self.settings.margin,
            if self.settings.swept { h } else { 0.0 },
        );
        rows::push_contact_rows(&mut self.phase.points, bodies, &self.settings, h, rows);
    }
}

/// One contact point of the last step with its impulses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactReport {
    /// Collider A (the normal points from A to B).
    pub collider_a: ColliderId,
    /// Collider B.
    pub collider_b: ColliderId,
    /// Contact point on A (world).
    pub point_a: Vector3<f64>,
    /// Contact point on B (world).
    pub point_b: Vector3<f64>,
    /// Unit normal from A to B (world).
    pub normal: Vector3<f64>,
    /// Signed gap (m), negative in penetration.
    pub gap: f64,
    /// Normal impulse on B (N s; A receives the opposite).
    pub normal_impulse: f64,
    /// Friction impulses on B along `tangents` (N s).
    pub friction_impulse: [f64; 2],
    /// The tangent basis used.
    pub tangents: [Vector3<f64>; 2],
    /// The bodies of collider A and of collider B.
    pub bodies: [BodyId; 2],
    /// Friction coefficient of the pair (the friction rows' bound is `μ λ_n`).
    pub mu: f64,
    /// Final index states of the normal row and the two friction rows in the solver's last index
    /// set (`Free` for a point whose island was not solved).
    pub states: [IndexState; 3],
}
