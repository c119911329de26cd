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
//! **Sagging chains** ([`ChainBuilder::sag`]). A rope drawn straight between two attachments has no
//! slack: under its own weight it can only sag by stretching its rows, and it falls into that sag
//! with a snap; if one end then moves closer (a crane's tip settling under its own weight by a few
//! millimetres), the straight rope is a strut in compression, buckles and whips. With a sag `s > 0`
//! the same chord `p₀ … p₀ + N ℓ u` is spanned by the parabola `p(x) = p₀ + x u + 4 s (x/C)(1 − x/C) n`
//! (`C = N ℓ`, `n` the unit vector of `−z` across `u`: the rope hangs down from its chord), and the
//! joints are put on it at `N` equal chords `ℓ' > ℓ` (found by bisection), the segments along them.
//! A parabola is the equilibrium of a rope under a uniform load across its chord for the tension
//! `T = w⊥ C² / (8 s)` (`w⊥` the weight per metre across the chord), so the rope starts at rest in
//! (nearly) its hanging shape, with the slack `≈ 8 s² / (3 C)` to take up end motions. The segments
//! keep their mass; their length is `ℓ'`. A vertical chord hangs straight: it takes no sag.
//!
//! **Mass properties.** Each segment has mass `m` and the inertia of a solid capsule of radius `r`
//! around the segment axis ([`capsule_inertia`], cylinder `ℓ` long plus hemispherical caps: a
//! rope's segments overlap at the joints) or of a box of square cross-section `2w × 2w × ℓ`
//! ([`box_inertia`]: chain links).
//!
//! **Steel wire rope.** [`steel_rope_mass_per_metre`] gives the mass of a stranded steel rope of
//! diameter `d`: `μ = φ ρ π d² / 4` with steel's `ρ = 7850 kg/m³` and a metallic fill factor
//! `φ = 0.68` (a 1" 6 × 36 rope with a steel core: 2.70 kg/m, catalogue 1.85 lb/ft = 2.75 kg/m);
//! [`ChainBuilder::steel_rope`] makes the segments capsules of radius `d/2` with that mass.
//!
//! **Drum (winding in and paying out).** With [`ChainBuilder::drum`] the start is not a ball joint
//! but a *fairlead*: a prismatic joint `"{name}/fairlead"` between segment 0 and the drum hinge's
//! housing (its body B, or the world) along `−u`, into the drum, whose slide `s` (m wound in, from
//! 0 at build time, limits `[0, ℓ]`) is tied to the drum's rotation `θ` by a rack coupling
//! `"{name}/drum"` (`coupling.rs`): `ṡ = R θ̇`, `R` the drum's pitch radius. The drum's positive
//! rotation about its hinge axis winds the cable in, the negative pays it out; the cable's tension
//! `T` loads the drum with the torque `R T` through the coupling's impulse, so a motor on the
//! hinge sees the real load. The wound part leaves the scene along the fairlead line (it is not
//! laid on the drum's surface: no contact is involved), which bounds one build's winding to one
//! segment length `ℓ`; winding further needs the next segment moved onto the fairlead (not done).
//!
//! **Statics.** Hanging from a fixed point, the chain is a vertical line of length `N ℓ` plus the
//! compliance stretch: the ball joint `i` carries the weight of the segments below it, `(N − i) m g`,
//! and its rows (implicit springs of stiffness `1/c`, `rows.rs`) stretch by `c (N − i) m g`, so
//! `L = N ℓ + c m g N (N + 1) / 2`, and the top joint's reaction is `N m g`. Ball joints leave
//! the segments' twist about the cable free; optional body damping (`body.rs`) settles a swinging
//! cable without changing that equilibrium.

use nalgebra::{UnitQuaternion, Vector3};

use super::body::{BodyBuilder, box_inertia, capsule_inertia};
use super::coupling::CouplingBuilder;
use super::error::ChainError;
use super::ids::{BodyId, CouplingId, JointId};
use super::joint::{DEFAULT_COMPLIANCE, JointBuilder, JointKind};
use super::motor::JointLimit;
use super::world::World;

/// Mass per metre (kg/m) of a stranded steel wire rope of diameter `d` (m): `0.68 · 7850 · π d²/4`
/// (module doc).
pub fn steel_rope_mass_per_metre(diameter: f64) -> f64 {
    0.68 * 7850.0 * std::f64::consts::PI * diameter * diameter / 4.0
}

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
    drum: Option<(JointId, f64)>,
    sag: f64,
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
            drum: None,
            sag: 0.0,
        }
    }

    /// Steel wire rope of diameter `d`: capsule segments of radius `d/2` and the rope's mass
    /// ([`steel_rope_mass_per_metre`]) per segment length.
    pub fn steel_rope(mut self, diameter: f64) -> Self {
        self.shape = ChainShape::Capsule { radius: diameter / 2.0 };
        self.segment_mass = steel_rope_mass_per_metre(diameter) * self.segment_length;
        self
    }

    /// Wound on the drum turning on the hinge `hinge`, of pitch radius `radius` (m): the start is
    /// a fairlead tied to the drum by a rack coupling (module doc); replaces the start attachment.
    pub fn drum(mut self, hinge: JointId, radius: f64) -> Self {
        self.drum = Some((hinge, radius));
        self
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

    /// Hang the chain from its chord with a mid-span sag `s` (m) below it (module doc); default 0
    /// (straight). The chord must not be vertical, and `s ≤ C / 4`.
    pub fn sag(mut self, s: f64) -> Self {
        self.sag = s;
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
            ("sag", self.sag),
            ("compliance", self.compliance),
            ("linear damping", self.linear_damping),
            ("angular damping", self.angular_damping),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(what, v);
            }
        }
        if let Some((hinge, radius)) = self.drum {
            if !(radius.is_finite() && radius > 0.0) {
                return bad("drum radius", radius);
            }
            if world.joint(hinge).is_none() {
                return Err(ChainError::UnknownJoint { chain: chain(), joint: hinge });
            }
            for name in ["fairlead", "drum"].map(|s| format!("{}/{s}", self.name)) {
                if world.joint_id(&name).is_some() || world.coupling_id(&name).is_some() {
                    return Err(ChainError::NameTaken { chain: chain(), name });
                }
            }
        }
        let far = self.count as f64 * self.segment_length;
        if self.count == 0 || !(self.start + self.direction * far).iter().all(|c| c.is_finite()) {
            return bad("count", self.count as f64);
        }
        if self.sag > 0.0 && (self.sag > far / 4.0 || sag_direction(&(self.direction / norm)).is_none()) {
            return bad("sag", self.sag);
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

/// The unit vector of `−z` across the unit chord direction `u`; `None` for a vertical chord.
fn sag_direction(u: &Vector3<f64>) -> Option<Vector3<f64>> {
    let down = -Vector3::z();
    let across = down - u * u.dot(&down);
    (across.norm() > 1e-6).then(|| across.normalize())
}

/// The `N + 1` joint points of a chain from `start` along the unit `u`: straight (`sag = 0`), or
/// on the parabola of mid-span sag `sag` below the chord `C = N ℓ` at `N` equal chords (module
/// doc), with the chord length.
fn chain_points(
    start: Vector3<f64>,
    u: Vector3<f64>,
    l: f64,
    n: usize,
    sag: f64,
) -> (Vec<Vector3<f64>>, f64) {
    let c = n as f64 * l;
    let straight = |i: usize| start + u * (i as f64 * l);
    let Some(across) = sag_direction(&u).filter(|_| sag > 0.0) else {
        return ((0..=n).map(straight).collect(), l);
    };
    let p = |x: f64| start + u * x + across * (4.0 * sag * (x / c) * (1.0 - x / c));
    // March N chords of length `chord` along the parabola (extended past C if need be): the
    // abscissa where the last one ends. The distance from p(x₀) grows with x, and p(x₀ + chord)
    // is at least `chord` away, so each next point is bracketed in [x₀, x₀ + chord].
    let march = |chord: f64, points: &mut Vec<Vector3<f64>>| -> f64 {
        points.clear();
        points.push(start);
        let mut x = 0.0;
        for _ in 0..n {
            let from = p(x);
            let (mut lo, mut hi) = (x, x + chord);
            for _ in 0..80 {
                let mid = 0.5 * (lo + hi);
                if (p(mid) - from).norm() < chord {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            x = 0.5 * (lo + hi);
            points.push(p(x));
        }
        x
    };
    let mut points = Vec::with_capacity(n + 1);
    // The arc is at most C + 2 · 4 sag (the chord plus twice the bulge): bisect the chord length.
    let (mut lo, mut hi) = (l, (c + 8.0 * sag) / n as f64);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if march(mid, &mut points) < c {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let chord = 0.5 * (lo + hi);
    march(chord, &mut points);
    points[n] = straight(n);
    (points, chord)
}

/// The items of a chain, in order from its start.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Chain {
    /// Segment bodies `0..N`.
    pub bodies: Vec<BodyId>,
    /// Ball joints: the start attachment (if any), the `N − 1` joints between segments, the end
    /// attachment (if any); with a drum the fairlead (prismatic) comes first.
    pub joints: Vec<JointId>,
    /// The rack coupling of the drum, if wound on one.
    pub drum: Option<CouplingId>,
}

impl World {
    /// Adds a chain of segments joined by ball joints (`chain.rs`). Everything is validated first:
    /// a refused chain adds nothing.
    pub fn add_chain(&mut self, cb: ChainBuilder) -> Result<Chain, ChainError> {
        cb.validate(self)?;
        let u = cb.direction.normalize();
        let (points, l) = chain_points(cb.start, u, cb.segment_length, cb.count, cb.sag);
        let inertia = match cb.shape {
            ChainShape::Capsule { radius } => capsule_inertia(cb.segment_mass, radius, l / 2.0),
            ChainShape::Box { half_width } => {
                box_inertia(cb.segment_mass, Vector3::new(half_width, half_width, l / 2.0))
            }
        };
        // Body z axis along its chord (a half turn about x when it points straight down).
        let axis = |i: usize| (points[i + 1] - points[i]).normalize();
        let orientation = |d: &Vector3<f64>| {
            UnitQuaternion::rotation_between(&Vector3::z(), d)
                .unwrap_or_else(|| UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI))
        };
        let mut chain = Chain {
            bodies: Vec::with_capacity(cb.count),
            joints: Vec::with_capacity(cb.count + 1),
            drum: None,
        };
        for i in 0..cb.count {
            let body = BodyBuilder::dynamic(&cb.segment_name(i), cb.segment_mass, inertia)
                .position((points[i] + points[i + 1]) / 2.0)
                .orientation(orientation(&axis(i)))
                .linear_damping(cb.linear_damping)
                .angular_damping(cb.angular_damping);
            chain.bodies.push(self.add_body(body)?);
        }
        let attach = |end: ChainEnd| match end {
            ChainEnd::Free => None,
            ChainEnd::World => Some(None),
            ChainEnd::Body(b) => Some(Some(b)),
        };
        let ball = |name: String, a: BodyId, b: Option<BodyId>, at: usize| {
            JointBuilder::at(&name, JointKind::Ball, a, b, points[at], u).compliance(cb.compliance)
        };
        if let Some((hinge, radius)) = cb.drum {
            let housing = self.joint(hinge).and_then(|j| j.body_b());
            let fairlead = JointBuilder::at(
                &format!("{}/fairlead", cb.name),
                JointKind::Prismatic,
                chain.bodies[0],
                housing,
                cb.start,
                -axis(0),
            )
            .compliance(cb.compliance)
            .limit(JointLimit::new(0.0, l));
            let fairlead = self.add_joint(fairlead)?;
            chain.joints.push(fairlead);
            let rack = CouplingBuilder::rack(&format!("{}/drum", cb.name), fairlead, hinge, radius)
                .compliance(cb.compliance);
            chain.drum = Some(self.add_coupling(rack)?);
        } else if let Some(parent) = attach(cb.start_end) {
            chain.joints.push(self.add_joint(ball(
                format!("{}/start", cb.name),
                chain.bodies[0],
                parent,
                0,
            ))?);
        }
        for i in 1..cb.count {
            let j = ball(cb.segment_name(i), chain.bodies[i], Some(chain.bodies[i - 1]), i);
            chain.joints.push(self.add_joint(j)?);
        }
        if let Some(other) = attach(cb.end) {
            let last = chain.bodies[cb.count - 1];
            chain.joints.push(self.add_joint(ball(format!("{}/end", cb.name), last, other, cb.count))?);
        }
        Ok(chain)
    }
}
