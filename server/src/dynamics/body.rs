//! Rigid bodies: the model (mass properties, kind, name) and the state (pose, velocities).
//!
//! **Frames and state.** A body's frame has its origin at the centre of mass. The state is the
//! position `x ∈ ℝ³` of that origin, the orientation `q` (unit quaternion, rotation matrix `R`,
//! body → world), the linear velocity `v` of the centre of mass and the angular velocity `ω`, both
//! in world coordinates. The generalized velocity of the paper (eq. 1) is `(v, ω) ∈ ℝ⁶` per body.
//!
//! **Mass properties.** Mass `m > 0` and the inertia tensor about the centre of mass, given as its
//! principal moments `(I₁, I₂, I₃)` and the rotation `P` of the principal frame relative to the
//! body frame: `I_body = P diag(I₁, I₂, I₃) Pᵀ`. The block of `M` for a dynamic body is
//! `diag(m 𝟙₃, I_w)` with the world inertia `I_w = R I_body Rᵀ`, so
//!
//! ```text
//!   M⁻¹ = diag(m⁻¹ 𝟙₃, I_w⁻¹),   I_w⁻¹ = R I_body⁻¹ Rᵀ,   I_body⁻¹ = P diag(1/I₁, 1/I₂, 1/I₃) Pᵀ.
//! ```
//!
//! **Damping** (optional, per body, rates `d ≥ 0` in 1/s, as rapier's `linear_damping`): the
//! velocity carried into the step decays as `v_free = v / (1 + h d) + h f / m` (and likewise `ω`), an
//! unconditionally stable implicit decay of rate `d`. Only the carried velocity is damped, not the
//! applied forces, so a body at rest under load feels its full weight and its joints carry exactly
//! the static reactions.
//!
//! **Kinds.** `Dynamic` bodies are moved by forces and constraints. `Kinematic` bodies follow a
//! scripted velocity (infinite mass: constraints do not change it, but it enters `b` of eq. 2 through
//! `J v`). `Static` bodies never move. Neither of the last two joins islands.
//!
//! Validation (in [`BodyBuilder::build`]): mass and principal moments finite and `> 0` for dynamic
//! bodies, moments satisfying the triangle inequality, quaternions of unit norm within `1e-6`
//! (then renormalized), every number finite, static bodies at rest.

use nalgebra::{Isometry3, Matrix3, Quaternion, Translation3, UnitQuaternion, Vector3};

use super::error::BodyError;
use super::ids::BodyId;

/// How a body moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum BodyKind {
    /// Moved by forces and constraints.
    #[default]
    Dynamic,
    /// Follows a scripted velocity; infinite mass.
    Kinematic,
    /// Never moves; infinite mass.
    Static,
}

impl BodyKind {
    /// Name used in reports.
    pub fn name(self) -> &'static str {
        match self {
            BodyKind::Dynamic => "dynamic",
            BodyKind::Kinematic => "kinematic",
            BodyKind::Static => "static",
        }
    }
}

/// Principal moments of a solid box of half extents `(a, b, c)` about its centre.
pub fn box_inertia(mass: f64, half_extents: Vector3<f64>) -> Vector3<f64> {
    let [a, b, c] = [half_extents.x, half_extents.y, half_extents.z].map(|e| 4.0 * e * e);
    Vector3::new(b + c, a + c, a + b) * (mass / 12.0)
}

/// Principal moments of a solid sphere about its centre.
pub fn sphere_inertia(mass: f64, radius: f64) -> Vector3<f64> {
    Vector3::repeat(0.4 * mass * radius * radius)
}

/// Principal moments of a solid cylinder along the body `z` axis about its centre.
pub fn cylinder_inertia(mass: f64, radius: f64, half_length: f64) -> Vector3<f64> {
    let t = mass * (3.0 * radius * radius + 4.0 * half_length * half_length) / 12.0;
    Vector3::new(t, t, 0.5 * mass * radius * radius)
}

/// Principal moments of a solid capsule along the body `z` axis about its centre: a cylinder of
/// radius `radius` and length `2 half_length` capped by two hemispheres (uniform density). With
/// `m_c`, `m_s` the masses of the cylinder and of the two caps (in the ratio of their volumes
/// `π r² ℓ : 4/3 π r³`, `ℓ = 2 half_length`),
///
/// ```text
///   I_z = m_c r²/2 + 2 m_s r²/5,
///   I_x = I_y = m_c (r²/4 + ℓ²/12) + m_s (2r²/5 + ℓ²/4 + 3ℓr/8)
/// ```
///
/// (each cap: `2/5 m r²` about its flat face, moved to the centre through its centroid at `3r/8`).
pub fn capsule_inertia(mass: f64, radius: f64, half_length: f64) -> Vector3<f64> {
    let (r, l) = (radius, 2.0 * half_length);
    let (v_c, v_s) = (l, 4.0 / 3.0 * r);
    let (m_c, m_s) = (mass * v_c / (v_c + v_s), mass * v_s / (v_c + v_s));
    let t = m_c * (r * r / 4.0 + l * l / 12.0) + m_s * (0.4 * r * r + l * l / 4.0 + 0.375 * l * r);
    Vector3::new(t, t, 0.5 * m_c * r * r + 0.4 * m_s * r * r)
}

/// Builder of a rigid body; validated by [`World::add_body`](super::World::add_body).
#[derive(Debug, Clone)]
pub struct BodyBuilder {
    name: String,
    kind: BodyKind,
    mass: f64,
    principal_inertia: Vector3<f64>,
    inertia_frame: Quaternion<f64>,
    position: Vector3<f64>,
    orientation: Quaternion<f64>,
    linvel: Vector3<f64>,
    angvel: Vector3<f64>,
    linear_damping: f64,
    angular_damping: f64,
}

impl BodyBuilder {
    fn new(name: &str, kind: BodyKind, mass: f64, principal_inertia: Vector3<f64>) -> Self {
        BodyBuilder {
            name: name.to_string(),
            kind,
            mass,
            principal_inertia,
            inertia_frame: Quaternion::identity(),
            position: Vector3::zeros(),
            orientation: Quaternion::identity(),
            linvel: Vector3::zeros(),
            angvel: Vector3::zeros(),
            linear_damping: 0.0,
            angular_damping: 0.0,
        }
    }

    /// A dynamic body of mass `mass` and principal moments `principal_inertia` (body frame axes
    /// unless [`inertia_frame`](Self::inertia_frame) is given).
    pub fn dynamic(name: &str, mass: f64, principal_inertia: Vector3<f64>) -> Self {
        Self::new(name, BodyKind::Dynamic, mass, principal_inertia)
    }

    /// A kinematic body (scripted velocity, infinite mass).
    pub fn kinematic(name: &str) -> Self {
        Self::new(name, BodyKind::Kinematic, f64::INFINITY, Vector3::repeat(f64::INFINITY))
    }

    /// A static body (never moves).
    pub fn static_body(name: &str) -> Self {
        Self::new(name, BodyKind::Static, f64::INFINITY, Vector3::repeat(f64::INFINITY))
    }

    /// Rotation of the principal inertia frame relative to the body frame (validated unit).
    pub fn inertia_frame(mut self, p: UnitQuaternion<f64>) -> Self {
        self.inertia_frame = p.into_inner();
        self
    }

    /// Position of the centre of mass (world).
    pub fn position(mut self, x: Vector3<f64>) -> Self {
        self.position = x;
        self
    }

    /// Orientation (body → world).
    pub fn orientation(mut self, q: UnitQuaternion<f64>) -> Self {
        self.orientation = q.into_inner();
        self
    }

    /// Orientation from a raw quaternion, validated to be of unit norm within `1e-6`.
    pub fn orientation_quaternion(mut self, q: Quaternion<f64>) -> Self {
        self.orientation = q;
        self
    }

    /// Linear velocity of the centre of mass (world).
    pub fn linvel(mut self, v: Vector3<f64>) -> Self {
        self.linvel = v;
        self
    }

    /// Angular velocity (world).
    pub fn angvel(mut self, w: Vector3<f64>) -> Self {
        self.angvel = w;
        self
    }

    /// Linear damping rate `d ≥ 0` (1/s; see the module doc).
    pub fn linear_damping(mut self, d: f64) -> Self {
        self.linear_damping = d;
        self
    }

    /// Angular damping rate `d ≥ 0` (1/s).
    pub fn angular_damping(mut self, d: f64) -> Self {
        self.angular_damping = d;
        self
    }

    /// The name given.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Validates and builds the body with id `id`.
    pub fn build(self, id: BodyId) -> Result<RigidBody, BodyError> {
        let body = || self.name.clone();
        if self.name.is_empty() {
            return Err(BodyError::EmptyName);
        }
        let (mass, inv_mass, inertia_body, inv_inertia_body, inertia_frame) = match self.kind {
            BodyKind::Dynamic => {
                if !(self.mass.is_finite() && self.mass > 0.0) {
                    return Err(BodyError::InvalidMass { body: body(), mass: self.mass });
                }
                let i = self.principal_inertia;
                if !i.iter().all(|&v| v.is_finite() && v > 0.0) {
                    return Err(BodyError::InvalidInertia { body: body(), inertia: i.into() });
                }
                // Triangle inequality, with a relative slack for rounding (thin rods and plates sit on it).
                let slack = 1e-9 * i.sum();
                if i.x > i.y + i.z + slack || i.y > i.x + i.z + slack || i.z > i.x + i.y + slack {
                    return Err(BodyError::NonPhysicalInertia { body: body(), inertia: i.into() });
                }
                let p = unit(self.inertia_frame)
                    .ok_or_else(|| non_unit(body(), "inertia frame", self.inertia_frame))?;
                let pm = p.to_rotation_matrix().into_inner();
                let ib = pm * Matrix3::from_diagonal(&i) * pm.transpose();
                let ib_inv = pm * Matrix3::from_diagonal(&i.map(|v| 1.0 / v)) * pm.transpose();
                (self.mass, 1.0 / self.mass, ib, ib_inv, p)
            }
            BodyKind::Kinematic | BodyKind::Static => {
                (f64::INFINITY, 0.0, Matrix3::zeros(), Matrix3::zeros(), UnitQuaternion::identity())
            }
        };
        let orientation =
            unit(self.orientation).ok_or_else(|| non_unit(body(), "orientation", self.orientation))?;
        for (what, v) in
            [("position", self.position), ("linear velocity", self.linvel), ("angular velocity", self.angvel)]
        {
            if !v.iter().all(|c| c.is_finite()) {
                return Err(BodyError::NonFinite { body: body(), what });
            }
        }
        for (what, d) in [("linear damping", self.linear_damping), ("angular damping", self.angular_damping)]
        {
            if !(d.is_finite() && d >= 0.0) {
                return Err(BodyError::InvalidDamping { body: body(), what, value: d });
            }
        }
        if self.kind == BodyKind::Static
            && (self.linvel != Vector3::zeros() || self.angvel != Vector3::zeros())
        {
            return Err(BodyError::StaticBodyMoving { body: body() });
        }
        Ok(RigidBody {
            id,
            name: self.name,
            kind: self.kind,
            mass,
            inv_mass,
            principal_inertia: self.principal_inertia,
            inertia_frame,
            inertia_body,
            inv_inertia_body,
            position: self.position,
            orientation,
            linvel: self.linvel,
            angvel: self.angvel,
            linear_damping: self.linear_damping,
            angular_damping: self.angular_damping,
        })
    }
}

/// Unit quaternion from `q` if its norm is within `1e-6` of 1 (renormalized), else `None`.
pub(crate) fn unit(q: Quaternion<f64>) -> Option<UnitQuaternion<f64>> {
    let n = q.norm();
    (n.is_finite() && (n - 1.0).abs() <= 1e-6).then(|| UnitQuaternion::new_normalize(q))
}

fn non_unit(body: String, what: &'static str, q: Quaternion<f64>) -> BodyError {
    BodyError::NonUnitQuaternion { body, what, norm: q.norm() }
}

/// A rigid body: model and state. Read through the accessors; change the state through the
/// [`World`](super::World) (which validates).
#[derive(Debug, Clone)]
pub struct RigidBody {
    id: BodyId,
    name: String,
    kind: BodyKind,
    mass: f64,
    inv_mass: f64,
    principal_inertia: Vector3<f64>,
    inertia_frame: UnitQuaternion<f64>,
    inertia_body: Matrix3<f64>,
    inv_inertia_body: Matrix3<f64>,
    pub(crate) position: Vector3<f64>,
    pub(crate) orientation: UnitQuaternion<f64>,
    pub(crate) linvel: Vector3<f64>,
    pub(crate) angvel: Vector3<f64>,
    linear_damping: f64,
    angular_damping: f64,
}

impl RigidBody {
    /// Id.
    pub fn id(&self) -> BodyId {
        self.id
    }
    /// Name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// Kind.
    pub fn kind(&self) -> BodyKind {
        self.kind
    }
    /// Whether the body is dynamic.
    #[inline]
    pub fn is_dynamic(&self) -> bool {
        self.kind == BodyKind::Dynamic
    }
    /// Mass (`∞` for kinematic and static bodies).
    pub fn mass(&self) -> f64 {
        self.mass
    }
    /// `1/m` (0 for kinematic and static bodies).
    #[inline]
    pub fn inv_mass(&self) -> f64 {
        self.inv_mass
    }
    /// Principal moments of inertia.
    pub fn principal_inertia(&self) -> Vector3<f64> {
        self.principal_inertia
    }
    /// Principal frame relative to the body frame.
    pub fn inertia_frame(&self) -> UnitQuaternion<f64> {
        self.inertia_frame
    }
    /// Inertia tensor in the body frame, `P diag(I) Pᵀ` (zero for non-dynamic bodies).
    pub fn inertia_body(&self) -> &Matrix3<f64> {
        &self.inertia_body
    }
    /// Inverse inertia tensor in the body frame (zero for non-dynamic bodies).
    pub fn inv_inertia_body(&self) -> &Matrix3<f64> {
        &self.inv_inertia_body
    }
    /// Position of the centre of mass.
    pub fn position(&self) -> Vector3<f64> {
        self.position
    }
    /// Orientation (body → world).
    pub fn orientation(&self) -> UnitQuaternion<f64> {
        self.orientation
    }
    /// Pose as an isometry (body → world).
    pub fn pose(&self) -> Isometry3<f64> {
        Isometry3::from_parts(Translation3::from(self.position), self.orientation)
    }
    /// Linear velocity of the centre of mass (world).
    pub fn linvel(&self) -> Vector3<f64> {
        self.linvel
    }
    /// Linear damping rate (1/s).
    pub fn linear_damping(&self) -> f64 {
        self.linear_damping
    }
    /// Angular damping rate (1/s).
    pub fn angular_damping(&self) -> f64 {
        self.angular_damping
    }
    /// Angular velocity (world).
    pub fn angvel(&self) -> Vector3<f64> {
        self.angvel
    }
    /// World inertia `I_w = R I_body Rᵀ`.
    pub fn inertia_world(&self) -> Matrix3<f64> {
        let r = self.orientation.to_rotation_matrix().into_inner();
        r * self.inertia_body * r.transpose()
    }
    /// World inverse inertia `I_w⁻¹ = R I_body⁻¹ Rᵀ` (zero for non-dynamic bodies).
    #[inline]
    pub fn inv_inertia_world(&self) -> Matrix3<f64> {
        let r = self.orientation.to_rotation_matrix().into_inner();
        r * self.inv_inertia_body * r.transpose()
    }
    /// World position of a point given in the body frame.
    pub fn point_world(&self, local: Vector3<f64>) -> Vector3<f64> {
        self.position + self.orientation * local
    }
    /// Velocity of the body-fixed point currently at world position `p`.
    pub fn point_velocity(&self, p: Vector3<f64>) -> Vector3<f64> {
        self.linvel + self.angvel.cross(&(p - self.position))
    }
    /// Linear momentum `m v` (zero for non-dynamic bodies).
    pub fn linear_momentum(&self) -> Vector3<f64> {
        if self.is_dynamic() { self.linvel * self.mass } else { Vector3::zeros() }
    }
    /// Angular momentum about the world point `o`: `(x − o) × m v + I_w ω` (zero for non-dynamic
    /// bodies).
    pub fn angular_momentum(&self, o: Vector3<f64>) -> Vector3<f64> {
        if !self.is_dynamic() {
            return Vector3::zeros();
        }
        (self.position - o).cross(&(self.linvel * self.mass)) + self.inertia_world() * self.angvel
    }
    /// Kinetic energy `½ m v·v + ½ ω·I_w ω` (zero for non-dynamic bodies).
    pub fn kinetic_energy(&self) -> f64 {
        if !self.is_dynamic() {
            return 0.0;
        }
        0.5 * self.mass * self.linvel.norm_squared()
            + 0.5 * self.angvel.dot(&(self.inertia_world() * self.angvel))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn world_inverse_inertia_is_inverse_of_world_inertia() {
        let p = UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1);
        let q = UnitQuaternion::from_euler_angles(-0.7, 0.4, 0.25);
        let b = BodyBuilder::dynamic("b", 2.0, Vector3::new(1.0, 2.0, 2.5))
            .inertia_frame(p)
            .orientation(q)
            .build(BodyId(0))
            .unwrap();
        let prod = b.inertia_world() * b.inv_inertia_world();
        assert!((prod - Matrix3::identity()).norm() < 1e-14, "{prod}");
        // The principal axes rotated to world are eigenvectors of I_w.
        let axis = q * (p * Vector3::y());
        assert!((b.inertia_world() * axis - 2.0 * axis).norm() < 1e-14);
    }

    #[test]
    fn shape_inertias() {
        let i = box_inertia(12.0, Vector3::new(0.5, 1.0, 1.5));
        assert!((i - Vector3::new(13.0, 10.0, 5.0)).norm() < 1e-12);
        assert_eq!(sphere_inertia(10.0, 1.0), Vector3::repeat(4.0));
        let c = cylinder_inertia(12.0, 1.0, 1.0);
        assert!((c - Vector3::new(7.0, 7.0, 6.0)).norm() < 1e-12);
        // Capsule limits: a thin rod (m ℓ²/12, ~0) and a sphere (2/5 m r²).
        let rod = capsule_inertia(3.0, 1e-9, 1.0);
        assert!((rod.x - 3.0 * 4.0 / 12.0).abs() < 1e-8 && rod.z < 1e-15);
        let ball = capsule_inertia(5.0, 0.5, 0.0);
        assert!((ball - sphere_inertia(5.0, 0.5)).norm() < 1e-15);
        // And against a numerical integration over the solid (midpoint rule on a grid).
        let (m, r, hl) = (2.0, 0.3, 0.5);
        let cap = capsule_inertia(m, r, hl);
        let n = 120;
        let (mut vol, mut ix, mut iz) = (0.0, 0.0, 0.0);
        let (ex, ez) = (r, hl + r);
        let (dx, dz) = (2.0 * ex / n as f64, 2.0 * ez / n as f64);
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    let p = Vector3::new(
                        -ex + (i as f64 + 0.5) * dx,
                        -ex + (j as f64 + 0.5) * dx,
                        -ez + (k as f64 + 0.5) * dz,
                    );
                    let axial = (p.z.abs() - hl).max(0.0);
                    if p.x * p.x + p.y * p.y + axial * axial <= r * r {
                        vol += 1.0;
                        ix += p.y * p.y + p.z * p.z;
                        iz += p.x * p.x + p.y * p.y;
                    }
                }
            }
        }
        let (ix, iz) = (m * ix / vol, m * iz / vol);
        assert!((cap.x - ix).abs() < 2e-3 * ix && (cap.z - iz).abs() < 2e-3 * iz, "{cap} vs {ix}, {iz}");
    }

    #[test]
    fn kinematic_and_static_have_no_inverse_mass() {
        let k = BodyBuilder::kinematic("k").linvel(Vector3::x()).build(BodyId(0)).unwrap();
        assert_eq!(k.inv_mass(), 0.0);
        assert_eq!(k.inv_inertia_world(), Matrix3::zeros());
        assert_eq!(k.linear_momentum(), Vector3::zeros());
        let s = BodyBuilder::static_body("s").build(BodyId(1)).unwrap();
        assert_eq!(s.kind(), BodyKind::Static);
    }
}
