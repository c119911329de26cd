//! Force elements: applied forces `f` of paper eq. 1 (not constraints). Gravity is a world setting
//! (`f = m g` on every dynamic body); the elements here are evaluated at the start of the step
//! (explicitly) and enter the step through `h f` in `v_free = v + h M⁻¹ f`.
//!
//! **Linear spring–damper** between a point `p_a` on body A and `p_b` on body B (or a world point):
//! with `d = p_b − p_a`, `L = |d|`, `n = d / L` and the separation speed `L̇ = n · (v(p_b) − v(p_a))`,
//!
//! ```text
//!   F = k (L − L₀) + c L̇,     f_A = +F n at p_a,   f_B = −F n at p_b,
//! ```
//!
//! (torques `(p − x) × f`). A stretched spring pulls the ends together. Explicit evaluation is stable
//! for `h √(k/m) < 2` and `h c/m < 2` (m the smaller end mass); stiffer couplings belong in a
//! compliant joint row (`1/c` stiffness, implicit). For `L < 1e-12` the direction is undefined and
//! the element applies nothing.
//!
//! Later elements (hydrostatic buoyancy and drag against a water plane, for the offshore scene) are
//! further variants of [`ForceElement`] with the same `accumulate` contract.

use nalgebra::Vector3;

use super::body::{BodyId, RigidBody};
use super::error::ForceError;

/// Stable id of a force element in its [`World`](super::World).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ForceId(pub u32);

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
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ForceElement {
    /// Linear spring–damper.
    SpringDamper(SpringDamper),
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
        }
    }

    /// Adds the element's forces and torques (about each centre of mass, world frame) to the
    /// accumulators (indexed like `bodies`).
    pub(crate) fn accumulate(
        &self,
        bodies: &[RigidBody],
        force: &mut [Vector3<f64>],
        torque: &mut [Vector3<f64>],
    ) {
        match self {
            ForceElement::SpringDamper(s) => {
                let a = &bodies[s.body_a.index()];
                let p_a = a.point_world(s.anchor_a);
                let (p_b, v_b) = match s.body_b {
                    Some(id) => {
                        let b = &bodies[id.index()];
                        let p = b.point_world(s.anchor_b);
                        (p, b.point_velocity(p))
                    }
                    None => (s.anchor_b, Vector3::zeros()),
                };
                let d = p_b - p_a;
                let l = d.norm();
                if l < 1e-12 {
                    return;
                }
                let n = d / l;
                let l_dot = n.dot(&(v_b - a.point_velocity(p_a)));
                let f = n * (s.stiffness * (l - s.rest_length) + s.damping * l_dot);
                let ia = s.body_a.index();
                force[ia] += f;
                torque[ia] += (p_a - a.position()).cross(&f);
                if let Some(id) = s.body_b {
                    let ib = id.index();
                    force[ib] -= f;
                    torque[ib] -= (p_b - bodies[ib].position()).cross(&f);
                }
            }
        }
    }

    /// Potential energy stored in the element (for energy checks).
    pub fn potential_energy(&self, bodies: &[RigidBody]) -> f64 {
        match self {
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
