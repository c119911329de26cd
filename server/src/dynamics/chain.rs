//! Chain / cable helper: `N` rigid segments joined by ball joints, for crane cables and winch
//! chains ([`World::add_chain`]).
//!
//! **Geometry.** From a start point `p₀`, a unit direction `u`, a segment length `ℓ` and a count
//! `N`, segment `i` (`0..N`) spans `p₀ + i ℓ u … p₀ + (i+1) ℓ u`: its centre of mass is at
//! `p₀ + (i + ½) ℓ u` and its body `z` axis along `u`. Joint `i` (`1..N`) is a ball joint at
//! `p₀ + i ℓ u` with segment `i` as body A and segment `i − 1` as body B (the parent); the start may be
//! attached at `p₀` (to the world or a body: a crane's boom tip) and the end at `p₀ + N ℓ u` (a hook,
//! a load) by further ball joints. The segments' names are `"{name}/{i}"`, the joints'
//! `"{name}/start"`, `"{name}/{i}"` and `"{name}/end"`.
//!
//! **Mass properties.** Each segment has mass `m` and the inertia of a solid capsule of radius `r`
//! around the segment axis ([`capsule_inertia`], cylinder `ℓ` long plus hemispherical caps: a
//! rope's segments overlap at the joints) or of a box of square cross-section `2w × 2w × ℓ`
//! ([`box_inertia`]: chain links).
//!
//! **Statics.** Hanging from a fixed point, the chain is a vertical line of length `N ℓ` plus the
//! compliance stretch: the ball joint `i` carries the weight of the segments below it, `(N − i) m g`,
//! and its rows (implicit springs of stiffness `1/c`, `rows.rs`) stretch by `c (N − i) m g`, so
//! `L = N ℓ + c m g N (N + 1) / 2`, and the top joint's reaction is `N m g`. Ball joints leave
//! the segments' twist about the cable free; optional body damping (`body.rs`) settles a swinging
//! cable without changing that equilibrium.

use nalgebra::{UnitQuaternion, Vector3};

use super::body::{BodyBuilder, BodyId, box_inertia, capsule_inertia};
use super::error::ChainError;
use super::joint::{DEFAULT_COMPLIANCE, JointBuilder, JointId};
use super::world::World;

/// Cross-section of the segments.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ChainShape {
    /// Capsule of this radius (cables, ropes).
    Capsule {
        /// Radius `r > 0` (m).
        radius: f64,
    },
    /// Box of square cross-section `2w × 2w` (chain links).
    Box {
        /// Half width `w > 0` (m).
        half_width: f64,
    },
}

/// Where an end of the chain is attached.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ChainEnd {
    /// Not attached.
    Free,
    /// A ball joint to the world at the end point.
    World,
    /// A ball joint to a body at the end point.
    Body(BodyId),
}

/// Builder of a chain; validated by [`World::add_chain`].
#[derive(Debug, Clone)]
pub struct ChainBuilder {
    name: String,
    start: Vector3<f64>,
    direction: Vector3<f64>,
    segment_length: f64,
    segment_mass: f64,
    count: usize,
    shape: ChainShape,
    start_end: ChainEnd,
    end: ChainEnd,
    compliance: f64,
    linear_damping: f64,
    angular_damping: f64,
}

impl ChainBuilder {
    /// `count` capsule segments (radius `segment_length / 20`) of `segment_length` and
    /// `segment_mass` from `start` along the unit `direction`, the start attached to the world.
    pub fn new(
        name: &str,
        start: Vector3<f64>,
        direction: Vector3<f64>,
        segment_length: f64,
        segment_mass: f64,
        count: usize,
    ) -> Self {
        ChainBuilder {
            name: name.to_string(),
            start,
            direction,
            segment_length,
            segment_mass,
            count,
            shape: ChainShape::Capsule { radius: segment_length / 20.0 },
            start_end: ChainEnd::World,
            end: ChainEnd::Free,
            compliance: DEFAULT_COMPLIANCE,
            linear_damping: 0.0,
            angular_damping: 0.0,
        }
    }

    /// Segment cross-section.
    pub fn shape(mut self, shape: ChainShape) -> Self {
        self.shape = shape;
        self
    }

    /// Attachment of the start point (default: the world).
    pub fn attach_start(mut self, end: ChainEnd) -> Self {
        self.start_end = end;
        self
    }

    /// Attachment of the end point (default: free).
    pub fn attach_end(mut self, end: ChainEnd) -> Self {
        self.end = end;
        self
    }

    /// Compliance of every joint row (default `1e-10`).
    pub fn compliance(mut self, c: f64) -> Self {
        self.compliance = c;
        self
    }

    /// Body damping rates of every segment (1/s; `body.rs`).
    pub fn damping(mut self, linear: f64, angular: f64) -> Self {
        self.linear_damping = linear;
        self.angular_damping = angular;
        self
    }

    fn validate(&self, world: &World) -> Result<(), ChainError> {
        let chain = || self.name.clone();
        if self.name.is_empty() {
            return Err(ChainError::EmptyName);
        }
        let bad = |what, value| Err(ChainError::InvalidParameter { chain: chain(), what, value });
        if let Some(&c) = self.start.iter().find(|c| !c.is_finite()) {
            return bad("start", c);
        }
        let norm = self.direction.norm();
        if !(norm.is_finite() && (norm - 1.0).abs() <= 1e-6) {
            return Err(ChainError::NonUnitDirection { chain: chain(), norm });
        }
        let width = match self.shape {
            ChainShape::Capsule { radius } => ("radius", radius),
            ChainShape::Box { half_width } => ("half width", half_width),
        };
        for (what, v) in [("segment length", self.segment_length), ("segment mass", self.segment_mass), width]
        {
            if !(v.is_finite() && v > 0.0) {
                return bad(what, v);
            }
        }
        for (what, v) in [
            ("compliance", self.compliance),
            ("linear damping", self.linear_damping),
            ("angular damping", self.angular_damping),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(what, v);
            }
        }
        let far = self.count as f64 * self.segment_length;
        if self.count == 0 || !(self.start + self.direction * far).iter().all(|c| c.is_finite()) {
            return bad("count", self.count as f64);
        }
        for end in [self.start_end, self.end] {
            if let ChainEnd::Body(b) = end
                && world.body(b).is_none()
            {
                return Err(ChainError::UnknownBody { chain: chain(), body: b });
            }
        }
        if let (ChainEnd::Body(a), ChainEnd::Body(b)) = (self.start_end, self.end)
            && a == b
        {
            let body = world.body(a).map(|b| b.name().to_string()).unwrap_or_default();
            return Err(ChainError::EndsOnOneBody { chain: chain(), body });
        }
        for i in 0..self.count {
            let name = self.segment_name(i);
            if world.body_id(&name).is_some() {
                return Err(ChainError::NameTaken { chain: chain(), name });
            }
        }
        let joint_names = (1..self.count)
            .map(|i| self.segment_name(i))
            .chain(["start", "end"].map(|s| format!("{}/{s}", self.name)));
        for name in joint_names {
            if world.joint_id(&name).is_some() {
                return Err(ChainError::NameTaken { chain: chain(), name });
            }
        }
        Ok(())
    }

    fn segment_name(&self, i: usize) -> String {
        format!("{}/{i}", self.name)
    }
}

/// The items of a chain, in order from its start.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Chain {
    /// Segment bodies `0..N`.
    pub bodies: Vec<BodyId>,
    /// Ball joints: the start attachment (if any), the `N − 1` joints between segments, the end
    /// attachment (if any).
    pub joints: Vec<JointId>,
}

impl World {
    /// Adds a chain of segments joined by ball joints (`chain.rs`). Everything is validated first:
    /// a refused chain adds nothing.
    pub fn add_chain(&mut self, cb: ChainBuilder) -> Result<Chain, ChainError> {
        cb.validate(self)?;
        let u = cb.direction.normalize();
        let l = cb.segment_length;
        let inertia = match cb.shape {
            ChainShape::Capsule { radius } => capsule_inertia(cb.segment_mass, radius, l / 2.0),
            ChainShape::Box { half_width } => {
                box_inertia(cb.segment_mass, Vector3::new(half_width, half_width, l / 2.0))
            }
        };
        // Body z axis along u (a half turn about x when u points straight down).
        let q = UnitQuaternion::rotation_between(&Vector3::z(), &u)
            .unwrap_or_else(|| UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI));
        let mut chain =
            Chain { bodies: Vec::with_capacity(cb.count), joints: Vec::with_capacity(cb.count + 1) };
        for i in 0..cb.count {
            let body = BodyBuilder::dynamic(&cb.segment_name(i), cb.segment_mass, inertia)
                .position(cb.start + u * ((i as f64 + 0.5) * l))
                .orientation(q)
                .linear_damping(cb.linear_damping)
                .angular_damping(cb.angular_damping);
            chain.bodies.push(self.add_body(body)?);
        }
        let attach = |end: ChainEnd| match end {
            ChainEnd::Free => None,
            ChainEnd::World => Some(None),
            ChainEnd::Body(b) => Some(Some(b)),
        };
        let ball = |name: String, a: BodyId, b: Option<BodyId>, at: f64| {
            JointBuilder::at(&name, super::JointKind::Ball, a, b, cb.start + u * at, u)
                .compliance(cb.compliance)
        };
        if let Some(parent) = attach(cb.start_end) {
            chain.joints.push(self.add_joint(ball(
                format!("{}/start", cb.name),
                chain.bodies[0],
                parent,
                0.0,
            ))?);
        }
        for i in 1..cb.count {
            let j = ball(cb.segment_name(i), chain.bodies[i], Some(chain.bodies[i - 1]), i as f64 * l);
            chain.joints.push(self.add_joint(j)?);
        }
        if let Some(other) = attach(cb.end) {
            let last = chain.bodies[cb.count - 1];
            chain.joints.push(self.add_joint(ball(
                format!("{}/end", cb.name),
                last,
                other,
                cb.count as f64 * l,
            ))?);
        }
        Ok(chain)
    }
}
