//! Force elements: applied force laws `f` of paper eq. 1 (not constraints). Gravity is a world
//! setting (`f = m g` on every dynamic body, explicit, exact for a constant force). The elements
//! here are stiff or dissipative, so both are integrated *implicitly* — an explicit evaluation
//! diverges once `h √(k/m)` or `h c/m` exceeds 2, which a light body on an ordinary spring (or a
//! light float in water) easily reaches.
//!
//! **Linear spring–damper** between a point `p_a` on body A and `p_b` on body B (or a world point):
//! with `d = p_b − p_a`, `L = |d|`, `n = d / L`, the law is `F = k (L − L₀) + c L̇` pulling the ends
//! together. It is handed to the solver as one *force row* on the pair (the soft-constraint form of
//! ODE's ERP/CFM), with `φ = L − L₀` and the exact `L̇ = J v`, `J_A = (−n, −(p_a − x_A) × n)`,
//! `J_B = (n, (p_b − x_B) × n)`. Requiring the law at the end of the step,
//! `λ = −h (k (φ + h L̇⁺) + c L̇⁺)`, is the row equation of `rows.rs`,
//!
//! ```text
//!   J v⁺ + (c_row / h²) λ = −β φ / h,     c_row = 1 / (k + c/h),     β = h k / (h k + c),
//! ```
//!
//! unbounded. So the spring is integrated by implicit Euler together with the joints: stable for any
//! stiffness and mass, exact at rest (`λ / h = −k φ`: the static deflection is `F / k`), and a spring
//! between two dynamic bodies joins their islands. Its rows are [`RowKind::Force`]: not projected, not
//! counted as violations. For `L < 1e-12` the direction is undefined and the element applies nothing.
//!
//! **Buoyancy and drag** on sample points against a water plane with optional waves (`buoyancy.rs`):
//! evaluated at the step's start (time `t`) with their Jacobians — the drag's `D = ∂f/∂v` and the
//! buoyancy stiffness `K = ∂f/∂x` per body — and integrated linearly implicitly (Baraff–Witkin): the
//! body's unconstrained velocity change solves the 6 × 6 system
//!
//! ```text
//!   (M − h D − h² K) Δv = h f + h² K v,     v_free = v + Δv,
//! ```
//!
//! then the constraints act with `M` as usual. Equilibria (`f = 0`) and steady speeds are those of
//! the force law exactly; the scheme is unconditionally stable for the linear part.

use nalgebra::{Matrix6, Vector3};

use super::body::{BodyId, RigidBody};
use super::buoyancy::Buoyancy;
use super::error::ForceError;
use super::joint_rows::Side;
use super::rows::{ConstraintRow, Jac6, RowKey, RowKind};

/// Stable id of a force element in its [`World`](super::World).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ForceId(pub u32);

impl ForceId {
    /// Index in the world's force list.
    #[inline]
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// Per-body accumulators of the applied forces of a step (world-indexed, reused): force, torque about
/// the centre of mass, and for bodies with implicit elements (`implicit[i]`) the 6 × 6 Jacobians
/// `D = ∂f/∂(v, ω)` and `K = ∂f/∂(x, θ)` (module doc).
#[derive(Debug, Default)]
pub(crate) struct ForceAccumulator {
    pub force: Vec<Vector3<f64>>,
    pub torque: Vec<Vector3<f64>>,
    pub damping: Vec<Matrix6<f64>>,
    pub stiffness: Vec<Matrix6<f64>>,
    pub implicit: Vec<bool>,
}

impl ForceAccumulator {
    /// Zeroes everything for `n` bodies.
    pub fn reset(&mut self, n: usize) {
        for (v, zero) in [(&mut self.force, Vector3::zeros()), (&mut self.torque, Vector3::zeros())] {
            v.clear();
            v.resize(n, zero);
        }
        for m in [&mut self.damping, &mut self.stiffness] {
            m.clear();
            m.resize(n, Matrix6::zeros());
        }
        self.implicit.clear();
        self.implicit.resize(n, false);
    }
}

/// Linear spring–damper between two body points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpringDamper {
    /// Body A.
    pub body_a: BodyId,
    /// Attachment on A, in A's frame.
    pub anchor_a: Vector3<f64>,
    /// Body B (`None`: the world).
    pub body_b: Option<BodyId>,
    /// Attachment on B, in B's frame (world point when B is absent).
    pub anchor_b: Vector3<f64>,
    /// Rest length `L₀ ≥ 0` (m).
    pub rest_length: f64,
    /// Stiffness `k ≥ 0` (N/m).
    pub stiffness: f64,
    /// Damping `c ≥ 0` (N s/m).
    pub damping: f64,
}

impl SpringDamper {
    /// Appends the spring's force row (module doc) to `out`, with the ends `a` (body A) and `b` at
    /// the current poses; nothing for a spring of zero length or with `k = c = 0`.
    pub(crate) fn push_row(&self, id: ForceId, a: &Side, b: &Side, h: f64, out: &mut Vec<ConstraintRow>) {
        let (k, c) = (self.stiffness, self.damping);
        if k == 0.0 && c == 0.0 {
            return;
        }
        let p_a = a.x + a.q * self.anchor_a;
        let p_b = b.x + b.q * self.anchor_b;
        let d = p_b - p_a;
        let l = d.norm();
        if l < 1e-12 {
            return;
        }
        let n = d / l;
        let j_a = Jac6::new(-n, -(p_a - a.x).cross(&n));
        let j_b = Jac6::new(n, (p_b - b.x).cross(&n));
        let mut r = ConstraintRow::pair(RowKey::Force(id), RowKind::Force, a.index, j_a, b.index, j_b);
        // c_row = 1/(k + c/h), β = k c_row = h k / (h k + c).
        let compliance = 1.0 / (k + c / h);
        let beta = k * compliance;
        r.phi = l - self.rest_length;
        r.compliance = compliance;
        r.rhs = -beta * r.phi / h;
        out.push(r);
    }
}

/// An applied-force element.
#[derive(Debug, Clone, PartialEq)]
pub enum ForceElement {
    /// Linear spring–damper.
    SpringDamper(SpringDamper),
    /// Hydrostatic buoyancy and drag on a body's sample points.
    Buoyancy(Buoyancy),
}

impl ForceElement {
    /// Checks the element against the world's bodies.
    pub(crate) fn validate(&self, name: &str, bodies: &[RigidBody]) -> Result<(), ForceError> {
        let force = || name.to_string();
        match self {
            ForceElement::SpringDamper(s) => {
                let get = |id: BodyId| {
                    bodies.get(id.index()).ok_or_else(|| ForceError::UnknownBody { force: force(), body: id })
                };
                let a = get(s.body_a)?;
                let b = s.body_b.map(get).transpose()?;
                if s.body_b == Some(s.body_a) {
                    return Err(ForceError::SelfAttached { force: force(), body: a.name().to_string() });
                }
                if !a.is_dynamic() && !b.is_some_and(RigidBody::is_dynamic) {
                    return Err(ForceError::NoDynamicBody { force: force() });
                }
                for (what, v) in [("anchor_a", s.anchor_a), ("anchor_b", s.anchor_b)] {
                    if let Some(&c) = v.iter().find(|c| !c.is_finite()) {
                        return Err(ForceError::InvalidParameter { force: force(), what, value: c });
                    }
                }
                for (what, v) in
                    [("rest_length", s.rest_length), ("stiffness", s.stiffness), ("damping", s.damping)]
                {
                    if !(v.is_finite() && v >= 0.0) {
                        return Err(ForceError::InvalidParameter { force: force(), what, value: v });
                    }
                }
                Ok(())
            }
            ForceElement::Buoyancy(b) => b.validate(name, bodies),
        }
    }

    /// Adds the explicit part and the Jacobians of the element at time `t` under gravity `gravity`
    /// to the accumulators (springs act through their rows instead, [`SpringDamper::push_row`]).
    pub(crate) fn accumulate(
        &self,
        bodies: &[RigidBody],
        t: f64,
        gravity: &Vector3<f64>,
        acc: &mut ForceAccumulator,
    ) {
        match self {
            ForceElement::Buoyancy(b) => b.accumulate(bodies, t, gravity, acc),
            ForceElement::SpringDamper(_) => {}
        }
    }

    /// Potential energy stored in the element (for energy checks; buoyancy: in still water under
    /// `gravity`).
    pub fn potential_energy(&self, bodies: &[RigidBody], gravity: &Vector3<f64>) -> f64 {
        match self {
            ForceElement::Buoyancy(b) => b.potential_energy(bodies, gravity),
            ForceElement::SpringDamper(s) => {
                let p_a = bodies[s.body_a.index()].point_world(s.anchor_a);
                let p_b = match s.body_b {
                    Some(id) => bodies[id.index()].point_world(s.anchor_b),
                    None => s.anchor_b,
                };
                let e = (p_b - p_a).norm() - s.rest_length;
                0.5 * s.stiffness * e * e
            }
        }
    }
}
