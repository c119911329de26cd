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
//! between two dynamic bodies joins their islands. Its rows (built in `force_rows.rs`) are
//! [`RowKind::Force`](super::RowKind::Force): not projected, not counted as violations. For
//! `L < 1e-12` the direction is undefined and the element applies nothing.
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

use nalgebra::Vector3;

use super::accumulator::ForceAccumulator;
use super::body::RigidBody;
use super::buoyancy::Buoyancy;
use super::error::ForceError;
use super::ids::BodyId;

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
    /// to the accumulators (springs act through their rows instead, `force_rows.rs`).
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
