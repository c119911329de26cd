//! Constraint rows: what the models (joints now, contacts later) hand to the island assembly.
//!
//! **One row** `i` couples at most two bodies A and B through Jacobian blocks `J_{i,A}, J_{i,B} ∈ ℝ^{1×6}`
//! (linear part, angular part; world frame), so that `J_i v = J_{i,A} (v_A, ω_A) + J_{i,B} (v_B, ω_B)`.
//! It carries a violation `φ_i`, a compliance `c_i ≥ 0`, impulse bounds `lo_i ≤ hi_i` and a
//! friction index (`None` for joints). With the implicit step of paper eq. 1,
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
//! the spring reading to `φ = −c F / β` at rest. Impulses `λ` act on B along `+J_B` and on A along
//! `+J_A`; a row of a joint pulls the two bodies with equal and opposite forces at one point (see
//! `joint_rows.rs`), so constraint impulses conserve linear and angular momentum.

use nalgebra::Vector3;

use super::joint::{JointId, JointRow};

/// Jacobian block of one row on one body: `J v = lin · v + ang · ω`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
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
}

/// What a row constrains: a position (stabilized by `−βφ/h`) or a velocity (target speed).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RowKind {
    /// Position-level row (locked axes, limits, later contact normals).
    Position,
    /// Velocity-level row (motors, later friction).
    Velocity,
}

/// Identity of a row that persists from step to step (warm start, reporting).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RowKey {
    /// A row of a joint.
    Joint {
        /// The joint.
        joint: JointId,
        /// Which of its rows.
        row: JointRow,
    },
}

/// One constraint row (solver side). Body indices are world body indices; `None` is the world frame
/// (and a non-dynamic body is recognised through its kind at assembly).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConstraintRow {
    /// Persistent identity.
    pub key: RowKey,
    /// Position or velocity row.
    pub kind: RowKind,
    /// Body A (world index), `None` for the world.
    pub body_a: Option<usize>,
    /// Body B (world index), `None` for the world.
    pub body_b: Option<usize>,
    /// Jacobian block on A.
    pub j_a: Jac6,
    /// Jacobian block on B.
    pub j_b: Jac6,
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
