//! Constraint rows: what the models (joints, couplings, spring–dampers and contacts) hand to the
//! island assembly.
//!
//! **One row** `i` couples up to [`MAX_ROW_BODIES`] = 4 bodies `k` through Jacobian blocks
//! `J_{i,k} ∈ ℝ^{1×6}` (linear part, angular part; world frame), so that
//! `J_i v = Σ_k J_{i,k} (v_k, ω_k)`. A joint or spring row touches two bodies (block 0 is body A's,
//! block 1 body B's); a coupling row (gear, differential, `coupling.rs`) touches the bodies of the
//! joints it couples — up to four, each body once (blocks of the same body are summed when the row is
//! built). The world frame takes no block (its velocity is zero). A row carries a violation `φ_i`, a
//! compliance `c_i ≥ 0`, impulse bounds `lo_i ≤ hi_i` and a friction index (`None` for joints). With
//! the implicit step of paper eq. 1,
//!
//! ```text
//!   M v⁺ − Jᵀ λ = M v + h f                  (momentum; λ are impulses)
//!   J v⁺ + (C/h²) λ = r,     r_i = −β_i φ_i / h   for a position row
//!                            r_i = u_i           for a velocity row (motor target speed u_i)
//! ```
//!
//! and eliminating `v⁺ = v + M⁻¹(h f + Jᵀλ)` gives paper eq. 2 with the stabilized right-hand side,
//!
//! ```text
//!   A λ = b,   A = J M⁻¹ Jᵀ + C/h²,   b = r − J M⁻¹ (M v + h f) = r − J v_free,
//! ```
//!
//! `v_free = v + h M⁻¹ f` being the velocity the bodies would have without constraints; the
//! boxed MLCP (eq. 3) then reads `w = Aλ − b = J v⁺ + (C/h²) λ − r` with `w_i = 0` for a free row.
//!
//! **Why these signs.** To first order `φ⁺ = φ + h J v⁺`. With `β = 1`:
//! - `c = 0`: `J v⁺ = −φ/h`, so `φ⁺ = 0`: the violation is removed in one step (paper: `−φ/h`);
//! - `c > 0`: `φ⁺ = −c λ / h = −c F` with `F = λ/h` the mean constraint force over the step: the row
//!   is an implicit spring of stiffness `1/c` (at rest, `φ = −c F` exactly; the heavy-chain test
//!   holds a 1e6 kg load at this analytic stretch to 1e-11 m).
//!
//! `β < 1` removes only the fraction `β` of the violation per step (Baumgarte-like), which softens
//! the spring reading to `φ = −c F / β` at rest; a spring–damper's force row (`force.rs`) is exactly
//! such a row with `c = 1/(k + c_d/h)`, `β = k c`. A velocity row with compliance is a stiff damper:
//! at steady state `J v⁺ = r − c λ / h² = r − c F / h`. Impulses `λ` act on body `k` along
//! `+J_{i,k}`; a row of a joint pulls the two bodies with equal and opposite forces at one point (see
//! `joint_rows.rs`), so constraint impulses conserve linear and angular momentum.

use nalgebra::{UnitQuaternion, Vector3};

use super::coupling::MAX_COUPLING_BODIES;
use super::ids::{CouplingId, ForceId, JointId};
use super::joint::JointRow;
use crate::solver::IndexState;

/// Most bodies one row touches: a coupling's row (a differential couples three shafts hinged to
/// one housing); joint, spring and contact rows touch two.
pub const MAX_ROW_BODIES: usize = MAX_COUPLING_BODIES;

/// Jacobian block of one row on one body: `J v = lin · v + ang · ω`.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Jac6 {
    /// Linear part.
    pub lin: Vector3<f64>,
    /// Angular part.
    pub ang: Vector3<f64>,
}

impl Jac6 {
    /// A block.
    #[inline]
    pub fn new(lin: Vector3<f64>, ang: Vector3<f64>) -> Self {
        Jac6 { lin, ang }
    }
    /// `J · (v, ω)`.
    #[inline]
    pub fn dot(&self, v: &Vector3<f64>, w: &Vector3<f64>) -> f64 {
        self.lin.dot(v) + self.ang.dot(w)
    }
    /// Negated block.
    #[inline]
    pub fn neg(&self) -> Self {
        Jac6 { lin: -self.lin, ang: -self.ang }
    }
    /// `s J`.
    #[inline]
    pub fn scale(&self, s: f64) -> Self {
        Jac6 { lin: self.lin * s, ang: self.ang * s }
    }
}

/// What a row constrains: a position (stabilized by `−βφ/h`) or a velocity (target speed).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum RowKind {
    /// Position-level row (locked axes, limits, later contact normals).
    Position,
    /// Velocity-level row (motors, couplings, later friction).
    Velocity,
    /// An implicit force element (spring–damper, `force.rs`): `φ` is its deflection, not a
    /// violation; never projected.
    Force,
}

/// Identity of a row that persists from step to step (warm start, reporting).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum RowKey {
    /// A row of a joint.
    Joint {
        /// The joint.
        joint: JointId,
        /// Which of its rows.
        row: JointRow,
    },
    /// The row of a coupling (gear, differential).
    Coupling(CouplingId),
    /// The row of a force element (spring–damper).
    Force(ForceId),
    /// A row of a contact point (`contact/`): the collider pair, the parry feature ids of the point
    /// on each collider (stable while the same features touch) and the row (0 normal, 1–2 friction).
    Contact {
        /// Collider indices (A, B).
        colliders: [u32; 2],
        /// Feature ids on A and on B.
        features: [u32; 2],
        /// 0: normal; 1, 2: friction along `t₁`, `t₂`.
        row: u8,
    },
}

/// What persists of a row under its [`RowKey`] (a joint's slot, a coupling, a spring, a contact): the
/// index state and impulse of the step it was last solved in (warm start, reporting).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub(crate) struct WarmRow {
    /// `World::steps` after the step that wrote it.
    pub stamp: u64,
    pub state: IndexState,
    pub lambda: f64,
}

/// One constraint row (solver side). Body indices are world body indices; a `None` entry of
/// `bodies` is an unused block (its Jacobian is zero). A non-dynamic body is recognised through its
/// kind at assembly.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ConstraintRow {
    /// Persistent identity.
    pub key: RowKey,
    /// Position or velocity row.
    pub kind: RowKind,
    /// Bodies touched (world indices), each at most once; joint rows: `[A, B, None, None]`.
    pub bodies: [Option<usize>; MAX_ROW_BODIES],
    /// Jacobian block on each body of `bodies` (zero where the body is `None`).
    pub jac: [Jac6; MAX_ROW_BODIES],
    /// Violation `φ` (position rows; 0 for velocity rows).
    pub phi: f64,
    /// Right-hand side `r` of the row equation `J v⁺ + (c/h²) λ = r`.
    pub rhs: f64,
    /// Compliance `c ≥ 0`.
    pub compliance: f64,
    /// Lower impulse bound.
    pub lo: f64,
    /// Upper impulse bound.
    pub hi: f64,
    /// Friction index: the (world) row index of the normal row (contacts; `None` for joints).
    pub findex: Option<usize>,
}

impl ConstraintRow {
    /// A row of `kind` without blocks, `φ = r = c = 0`, unbounded.
    pub fn new(key: RowKey, kind: RowKind) -> Self {
        ConstraintRow {
            key,
            kind,
            bodies: [None; MAX_ROW_BODIES],
            jac: [Jac6::default(); MAX_ROW_BODIES],
            phi: 0.0,
            rhs: 0.0,
            compliance: 0.0,
            lo: f64::NEG_INFINITY,
            hi: f64::INFINITY,
            findex: None,
        }
    }

    /// A two-body row with blocks `j_a` on `a` and `j_b` on `b` (`None`: the world, no block; the
    /// slots stay `[a, b]` so that block 0 is always body A's).
    pub fn pair(
        key: RowKey,
        kind: RowKind,
        a: Option<usize>,
        j_a: Jac6,
        b: Option<usize>,
        j_b: Jac6,
    ) -> Self {
        let mut r = Self::new(key, kind);
        r.bodies[0] = a;
        r.bodies[1] = b;
        if a.is_some() {
            r.jac[0] = j_a;
        }
        if b.is_some() {
            r.jac[1] = j_b;
        }
        r
    }

    /// Adds `j` to the block of `body` (summing with an existing block of the same body; the world
    /// takes none). Returns `false` if all [`MAX_ROW_BODIES`] slots hold other bodies.
    pub fn add_block(&mut self, body: Option<usize>, j: Jac6) -> bool {
        let Some(b) = body else { return true };
        if let Some(s) = self.bodies.iter().position(|&x| x == Some(b)) {
            self.jac[s].lin += j.lin;
            self.jac[s].ang += j.ang;
            return true;
        }
        match self.bodies.iter().position(Option::is_none) {
            Some(s) => {
                self.bodies[s] = Some(b);
                self.jac[s] = j;
                true
            }
            None => false,
        }
    }

    /// The blocks `(body, J)` of the row.
    #[inline]
    pub fn blocks(&self) -> impl Iterator<Item = (usize, &Jac6)> + '_ {
        self.bodies.iter().zip(self.jac.iter()).filter_map(|(b, j)| b.map(|b| (b, j)))
    }

    /// `J v` for velocities indexed like the world's bodies.
    #[inline]
    pub fn velocity(&self, v: &[Vector3<f64>], w: &[Vector3<f64>]) -> f64 {
        self.blocks().map(|(b, j)| j.dot(&v[b], &w[b])).sum()
    }
}

/// Pose and velocity of one end of a two-body row: a joint's, a coupling shaft's or a spring's body
/// at the poses the rows are built at (`index: None` is the world frame, at rest).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Side {
    pub index: Option<usize>,
    pub x: Vector3<f64>,
    pub q: UnitQuaternion<f64>,
    pub v: Vector3<f64>,
    pub w: Vector3<f64>,
}

impl Side {
    /// The world frame.
    pub fn world() -> Self {
        Side {
            index: None,
            x: Vector3::zeros(),
            q: UnitQuaternion::identity(),
            v: Vector3::zeros(),
            w: Vector3::zeros(),
        }
    }
}
