//! From a parsed scene file to a [`World`] with its controls: repeats expanded, references
//! resolved, every number checked finite and in range, each error located at its table.
//!
//! **Inertia from shapes.** A dynamic body without `inertia` spreads its `mass` over its bounded
//! shapes in proportion to their volumes (uniform density, overlaps counted twice) and sums their
//! inertia tensors about the body origin (the centre of mass by convention):
//! `I = Σ_i R_i I_i R_iᵀ + m_i (|d_i|² 𝟙 − d_i d_iᵀ)` with shape rotation `R_i`, offset `d_i`, and
//! `I_i` the solid's own principal moments. Its eigen-decomposition gives the principal moments
//! and the inertia frame.

use std::collections::{HashMap, HashSet};
use std::ops::Range;

use nalgebra::{Isometry3, Matrix3, Quaternion, SymmetricEigen, Translation3, UnitQuaternion, Vector3};
use toml::Spanned;

use super::checks::{R, Source};
use super::controls::{
    Actuator, ActuatorFault, ActuatorKind, ActuatorTarget, AxisMode, ButtonAction, Controls, JoyAxis,
    JoyButton, JoystickMap, Neutral, RampProfile, SceneEvent, Script, ScriptEntry,
};
use super::format::*;
use super::{Scene, SceneError};
use crate::dynamics::{
    BodyBuilder, BodyId, Buoyancy, ChainBuilder, ChainEnd, ChainShape, ColliderBuilder, CollisionGroups,
    CouplingBuilder, CouplingId, ForceElement, FreeAxis, GeometricStiffness, JointBuilder, JointFrames,
    JointId, JointKind, JointLimit, JointMotor, Material, ModelError, Shape, SpringDamper, WatchdogSettings,
    Water, Wave, World, WorldSettings, box_inertia, capsule_inertia, cylinder_inertia, sphere_inertia,
};

/// Builder state: the world so far and name tables.
pub(super) struct Builder<'a> {
    src: &'a Source<'a>,
    world: World,
    default_mu: f64,
    default_compliance: f64,
    body_spans: HashMap<String, Range<usize>>,
}

/// A built shape: the shape, its pose in the body frame, its friction and its material name.
type ShapeParts = (Shape, Isometry3<f64>, Option<f64>, Option<String>);

impl Builder<'_> {
    pub(super) fn invalid(&self, span: &Range<usize>, field: &str, message: impl Into<String>) -> SceneError {
        self.src.invalid(span, field, message)
    }

    fn model(&self, span: &Range<usize>, item: &str, e: impl Into<ModelError>) -> SceneError {
        self.src.model(span, item, e)
    }

    pub(super) fn finite(&self, span: &Range<usize>, field: &str, v: f64) -> R<f64> {
        self.src.finite(span, field, v)
    }

    pub(super) fn positive(&self, span: &Range<usize>, field: &str, v: f64) -> R<f64> {
        self.src.positive(span, field, v)
    }

    fn non_negative(&self, span: &Range<usize>, field: &str, v: f64) -> R<f64> {
        self.src.non_negative(span, field, v)
    }

    pub(super) fn vec3(&self, span: &Range<usize>, field: &str, v: [f64; 3]) -> R<Vector3<f64>> {
        self.src.vec3(span, field, v)
    }

    fn unit3(&self, span: &Range<usize>, field: &str, v: [f64; 3]) -> R<Vector3<f64>> {
        self.src.unit3(span, field, v)
    }

    /// `rotation` (roll, pitch, yaw in degrees, `R = R_z(yaw) R_y(pitch) R_x(roll)`) or
    /// `quaternion` (w, x, y, z; normalized), identity when both are absent.
    fn rotation(
        &self,
        span: &Range<usize>,
        rpy: Option<[f64; 3]>,
        quat: Option<[f64; 4]>,
    ) -> R<UnitQuaternion<f64>> {
        match (rpy, quat) {
            (Some(_), Some(_)) => {
                Err(self.invalid(span, "rotation", "give `rotation` or `quaternion`, not both"))
            }
            (Some(r), None) => {
                let r = self.vec3(span, "rotation", r)?.map(f64::to_radians);
                Ok(UnitQuaternion::from_euler_angles(r.x, r.y, r.z))
            }
            (None, Some(q)) => {
                for c in q {
                    self.finite(span, "quaternion", c)?;
                }
                let q = Quaternion::new(q[0], q[1], q[2], q[3]);
                if q.norm() < 1e-9 {
                    return Err(self.invalid(span, "quaternion", "the quaternion is zero"));
                }
                Ok(UnitQuaternion::from_quaternion(q))
            }
            (None, None) => Ok(UnitQuaternion::identity()),
        }
    }

    fn body(&self, span: &Range<usize>, field: &str, name: &str) -> R<BodyId> {
        self.world.body_id(name).ok_or_else(|| self.invalid(span, field, format!("no body named `{name}`")))
    }

    fn opt_body(&self, span: &Range<usize>, field: &str, name: Option<&str>) -> R<Option<BodyId>> {
        match name {
            None | Some("world") => Ok(None),
            Some(n) => self.body(span, field, n).map(Some),
        }
    }

    fn add_body(&mut self, span: &Range<usize>, d: &BodyDef, offset: Vector3<f64>) -> R<()> {
        if let Some(first) = self.body_spans.get(&d.name) {
            let first = self.src.at(first.clone());
            return Err(self.invalid(
                span,
                "name",
                format!("body `{}` is already defined at {first}", d.name),
            ));
        }
        let position = self.vec3(span, "position", d.position)? + offset;
        let q = self.rotation(span, d.rotation, d.quaternion)?;
        let kind = d.kind.as_deref().unwrap_or("dynamic");
        let shapes = d
            .shape
            .iter()
            .map(|s| Ok((s.span(), self.shape(&s.span(), s.get_ref())?)))
            .collect::<R<Vec<_>>>()?;
        let mut b = match kind {
            "dynamic" => {
                let mass = d.mass.ok_or_else(|| self.invalid(span, "mass", "a dynamic body needs a mass"))?;
                let mass = self.positive(span, "mass", mass)?;
                match d.inertia {
                    Some(i) => BodyBuilder::dynamic(&d.name, mass, self.vec3(span, "inertia", i)?),
                    None => {
                        let (moments, frame) = self.inertia_from_shapes(span, mass, &shapes)?;
                        BodyBuilder::dynamic(&d.name, mass, moments).inertia_frame(frame)
                    }
                }
            }
            "static" | "kinematic" => {
                if d.mass.is_some() || d.inertia.is_some() {
                    return Err(self.invalid(span, "mass", format!("a {kind} body has no mass or inertia")));
                }
                if kind == "static" {
                    BodyBuilder::static_body(&d.name)
                } else {
                    BodyBuilder::kinematic(&d.name)
                }
            }
            other => {
                return Err(self.invalid(
                    span,
                    "kind",
                    format!("unknown body kind `{other}` (dynamic, static, kinematic)"),
                ));
            }
        };
        b = b.position(position).orientation(q);
        if let Some(v) = d.velocity {
            b = b.linvel(self.vec3(span, "velocity", v)?);
        }
        if let Some(w) = d.angular_velocity {
            b = b.angvel(self.vec3(span, "angular_velocity", w)?);
        }
        if let Some([l, a]) = d.damping {
            b = b
                .linear_damping(self.non_negative(span, "damping", l)?)
                .angular_damping(self.non_negative(span, "damping", a)?);
        }
        let id = self.world.add_body(b).map_err(|e| self.model(span, &d.name, e))?;
        self.body_spans.insert(d.name.clone(), span.clone());
        let groups = d.groups.map(|[m, f]| CollisionGroups::new(m, f)).unwrap_or(CollisionGroups::ALL);
        let n_shapes = shapes.len();
        for (k, (sspan, (shape, pose, mu, material))) in shapes.into_iter().enumerate() {
            let name = if n_shapes == 1 { d.name.clone() } else { format!("{}#{k}", d.name) };
            let mut cb = ColliderBuilder::new(&name, id, shape)
                .offset(pose)
                .material(Material { friction: mu.unwrap_or(self.default_mu) })
                .groups(groups);
            if let Some(m) = material {
                cb = cb.material_name(&m);
            }
            self.world.add_collider(cb).map_err(|e| SceneError::Invalid {
                at: self.src.at(sspan.clone()),
                field: "shape".into(),
                message: e.to_string(),
            })?;
        }
        Ok(())
    }

    /// A shape definition → (shape, pose in the body frame, friction).
    fn shape(&self, span: &Range<usize>, s: &ShapeDef) -> R<ShapeParts> {
        let need = |v: Option<f64>, field: &str| {
            v.ok_or_else(|| self.invalid(span, field, format!("a {} needs `{field}`", s.kind)))
                .and_then(|v| self.positive(span, field, v))
        };
        let allowed: &[&str] = match s.kind.as_str() {
            "box" => &["size"],
            "ball" => &["radius"],
            "capsule" | "cylinder" => &["radius", "length"],
            "convex" => &["points"],
            "plane" => &["normal"],
            k if super::terrain::is_terrain(k) => &[],
            other => {
                return Err(self.invalid(
                    span,
                    "type",
                    format!(
                        "unknown shape type `{other}` (box, ball, capsule, cylinder, convex, plane{})",
                        super::terrain::KINDS.iter().map(|k| format!(", {k}")).collect::<String>()
                    ),
                ));
            }
        };
        let terrain = super::terrain::is_terrain(&s.kind);
        if let Some(f) = s.stray_field(allowed).filter(|_| !terrain) {
            return Err(self.invalid(span, f, format!("`{f}` does not apply to a {}", s.kind)));
        }
        let shape = match s.kind.as_str() {
            "box" => {
                let size = s.size.ok_or_else(|| self.invalid(span, "size", "a box needs `size`"))?;
                let size = self.vec3(span, "size", size)?;
                if size.iter().any(|&c| c <= 0.0) {
                    return Err(self.invalid(span, "size", "every side must be > 0"));
                }
                Shape::Cuboid { half_extents: size / 2.0 }
            }
            "ball" => Shape::Ball { radius: need(s.radius, "radius")? },
            "capsule" => Shape::Capsule {
                radius: need(s.radius, "radius")?,
                half_length: need(s.length, "length")? / 2.0,
            },
            "cylinder" => Shape::Cylinder {
                radius: need(s.radius, "radius")?,
                half_length: need(s.length, "length")? / 2.0,
            },
            "convex" => {
                let pts = s
                    .points
                    .as_ref()
                    .ok_or_else(|| self.invalid(span, "points", "a convex needs `points`"))?;
                Shape::ConvexHull {
                    points: pts.iter().map(|&p| self.vec3(span, "points", p)).collect::<R<_>>()?,
                }
            }
            "plane" => {
                Shape::HalfSpace { normal: self.unit3(span, "normal", s.normal.unwrap_or([0.0, 0.0, 1.0]))? }
            }
            k => super::terrain::shape(self.src, span, k, s)?,
        };
        let pose = Isometry3::from_parts(
            Translation3::from(self.vec3(span, "position", s.position)?),
            self.rotation(span, s.rotation, None)?,
        );
        let mu = s.friction.map(|m| self.non_negative(span, "friction", m)).transpose()?;
        Ok((shape, pose, mu, s.material.clone()))
    }

    fn inertia_from_shapes(
        &self,
        span: &Range<usize>,
        mass: f64,
        shapes: &[(Range<usize>, ShapeParts)],
    ) -> R<(Vector3<f64>, UnitQuaternion<f64>)> {
        use std::f64::consts::PI;
        let mut parts = Vec::new();
        for (sspan, (shape, pose, _, _)) in shapes {
            let (volume, unit): (f64, Vector3<f64>) = match shape {
                Shape::Ball { radius: r } => (4.0 / 3.0 * PI * r.powi(3), sphere_inertia(1.0, *r)),
                Shape::Cuboid { half_extents: e } => (8.0 * e.x * e.y * e.z, box_inertia(1.0, *e)),
                Shape::Capsule { radius: r, half_length: l } => {
                    (PI * r * r * (2.0 * l + 4.0 / 3.0 * r), capsule_inertia(1.0, *r, *l))
                }
                Shape::Cylinder { radius: r, half_length: l } => {
                    (PI * r * r * 2.0 * l, cylinder_inertia(1.0, *r, *l))
                }
                Shape::HalfSpace { .. } => continue,
                _ => {
                    return Err(self.invalid(
                        sspan,
                        "inertia",
                        "give the body an explicit `inertia`: it is not computed for this shape type",
                    ));
                }
            };
            parts.push((volume, unit, *pose));
        }
        let total: f64 = parts.iter().map(|p| p.0).sum();
        if parts.is_empty() || total <= 0.0 {
            return Err(self.invalid(span, "inertia", "a dynamic body needs `inertia` or a bounded shape"));
        }
        let mut inertia = Matrix3::zeros();
        for (volume, unit, pose) in parts {
            let m = mass * volume / total;
            let r = pose.rotation.to_rotation_matrix();
            let d = pose.translation.vector;
            inertia += r.matrix() * Matrix3::from_diagonal(&(unit * m)) * r.matrix().transpose()
                + m * (Matrix3::identity() * d.norm_squared() - d * d.transpose());
        }
        let eig = SymmetricEigen::new(inertia);
        let mut axes = eig.eigenvectors;
        if axes.determinant() < 0.0 {
            axes.column_mut(2).neg_mut();
        }
        let frame = UnitQuaternion::from_matrix(&axes);
        Ok((eig.eigenvalues, frame))
    }

    fn add_joint(&mut self, span: &Range<usize>, d: &JointDef, offset: Vector3<f64>) -> R<()> {
        let kind = match d.kind.as_str() {
            "fixed" => JointKind::Fixed,
            "hinge" => JointKind::Hinge,
            "prismatic" => JointKind::Prismatic,
            "ball" => JointKind::Ball,
            "cylindrical" => JointKind::Cylindrical,
            "universal" => JointKind::Universal,
            other => {
                return Err(self.invalid(
                    span,
                    "type",
                    format!(
                        "unknown joint type `{other}` (fixed, hinge, prismatic, ball, cylindrical, universal)"
                    ),
                ));
            }
        };
        let a = self.body(span, "a", &d.a)?;
        let b = self.opt_body(span, "b", d.b.as_deref())?;
        let anchor = self.vec3(span, "anchor", d.anchor)? + offset;
        let needs_axis = matches!(
            kind,
            JointKind::Hinge | JointKind::Prismatic | JointKind::Cylindrical | JointKind::Universal
        );
        let axis = match d.axis {
            Some(a) => self.unit3(span, "axis", a)?,
            None if needs_axis => {
                return Err(self.invalid(span, "axis", format!("a {} joint needs `axis`", d.kind)));
            }
            None => Vector3::x(),
        };
        let frames = match d.axis2 {
            Some(y) => JointFrames::WorldAxes { anchor, axis, secondary: self.unit3(span, "axis2", y)? },
            None => JointFrames::World { anchor, axis },
        };
        let mut jb = JointBuilder::new(&d.name, kind, a, b, frames)
            .compliance(self.non_negative(
                span,
                "compliance",
                d.compliance.unwrap_or(self.default_compliance),
            )?)
            .collide_connected(d.collide_connected)
            .enabled(d.enabled.unwrap_or(true));
        if let Some(beta) = d.stabilization {
            jb = jb.stabilization(beta);
        }
        if let Some([lo, hi]) = d.limits {
            if lo.is_nan() || hi.is_nan() {
                return Err(self.invalid(span, "limits", "limits must be numbers"));
            }
            jb = jb.limit(JointLimit::new(lo, hi));
        }
        if let Some(m) = &d.motor {
            let force = self.non_negative(span, "motor.max_force", m.max_force)?;
            let motor = match (m.speed, m.target) {
                (Some(u), None) => JointMotor::velocity(self.finite(span, "motor.speed", u)?, force),
                (None, Some(t)) => {
                    let max_speed = m.max_speed.unwrap_or(f64::INFINITY);
                    JointMotor::position(self.finite(span, "motor.target", t)?, max_speed, force)
                        .with_gain(m.gain.unwrap_or(crate::dynamics::DEFAULT_POSITION_GAIN))
                }
                _ => {
                    return Err(self.invalid(
                        span,
                        "motor",
                        "a motor needs exactly one of `speed` and `target`",
                    ));
                }
            };
            jb = jb.motor(motor);
        }
        self.world.add_joint(jb).map_err(|e| self.model(span, &d.name, e))?;
        Ok(())
    }

    fn add_spring(&mut self, span: &Range<usize>, d: &SpringDef, offset: Vector3<f64>) -> R<()> {
        let a = self.body(span, "a", &d.a)?;
        let b = self.opt_body(span, "b", d.b.as_deref())?;
        let pa = self.vec3(span, "anchor_a", d.anchor_a)? + offset;
        let pb = self.vec3(span, "anchor_b", d.anchor_b)? + offset;
        let local = |id: Option<BodyId>, p: Vector3<f64>| match id {
            Some(id) => {
                self.world.body(id).map(|b| b.pose().inverse_transform_point(&p.into()).coords).unwrap_or(p)
            }
            None => p,
        };
        let rest = match d.rest_length {
            Some(l) => self.non_negative(span, "rest_length", l)?,
            None => (pb - pa).norm(),
        };
        let s = SpringDamper {
            body_a: a,
            anchor_a: local(Some(a), pa),
            body_b: b,
            anchor_b: local(b, pb),
            rest_length: rest,
            stiffness: self.non_negative(span, "stiffness", d.stiffness)?,
            damping: self.non_negative(span, "damping", d.damping)?,
        };
        self.world
            .add_force(&d.name, ForceElement::SpringDamper(s))
            .map_err(|e| self.model(span, &d.name, e))?;
        Ok(())
    }
}

impl Builder<'_> {
    /// A `[[cable]]`: checked here (located errors), built by [`World::add_chain`].
    fn add_cable(&mut self, span: &Range<usize>, d: &CableDef) -> R<()> {
        let start = self.vec3(span, "start", d.start)?;
        let direction = self.unit3(span, "direction", d.direction)?;
        let length = self.positive(span, "length", d.length)?;
        let diameter = self.positive(span, "diameter", d.diameter)?;
        if d.segments == 0 || d.segments > 10_000 {
            return Err(self.invalid(
                span,
                "segments",
                format!("{} segments (1 to 10000 allowed)", d.segments),
            ));
        }
        let ell = length / d.segments as f64;
        let mut cb = match d.mass {
            // A given total mass (a rope with a fibre core, a chain) over capsules of the diameter.
            Some(m) => {
                let m = self.positive(span, "mass", m)?;
                ChainBuilder::new(&d.name, start, direction, ell, m / d.segments as f64, d.segments)
                    .shape(ChainShape::Capsule { radius: diameter / 2.0 })
            }
            None => ChainBuilder::new(&d.name, start, direction, ell, 1.0, d.segments).steel_rope(diameter),
        };
        let end = |name: Option<&str>, field: &str, absent: ChainEnd| -> R<ChainEnd> {
            Ok(match name {
                None => absent,
                Some("world") => ChainEnd::World,
                Some(n) => ChainEnd::Body(self.body(span, field, n)?),
            })
        };
        cb = cb
            .attach_start(end(d.a.as_deref(), "a", ChainEnd::World)?)
            .attach_end(end(d.b.as_deref(), "b", ChainEnd::Free)?)
            .compliance(self.non_negative(
                span,
                "compliance",
                d.compliance.unwrap_or(self.default_compliance),
            )?);
        if let Some(sag) = d.sag {
            let sag = self.non_negative(span, "sag", sag)?;
            let chord = d.length;
            if sag > chord / 4.0 || (sag > 0.0 && direction.cross(&Vector3::z()).norm() <= 1e-6) {
                return Err(self.invalid(
                    span,
                    "sag",
                    format!("a sag of {sag} m: at most a quarter of the chord, and none on a vertical cable"),
                ));
            }
            cb = cb.sag(sag);
        }
        if let Some([l, a]) = d.damping {
            cb = cb.damping(self.non_negative(span, "damping", l)?, self.non_negative(span, "damping", a)?);
        }
        match (&d.drum, d.drum_radius) {
            (Some(n), Some(r)) => {
                let hinge = self
                    .world
                    .joint_id(n)
                    .ok_or_else(|| self.invalid(span, "drum", format!("no joint named `{n}`")))?;
                if d.a.is_some() {
                    return Err(self.invalid(
                        span,
                        "a",
                        "a cable on a drum starts at the drum's fairlead: drop `a`",
                    ));
                }
                cb = cb.drum(hinge, self.positive(span, "drum_radius", r)?);
            }
            (None, None) => {}
            _ => return Err(self.invalid(span, "drum", "give both `drum` and `drum_radius`")),
        }
        self.world.add_chain(cb).map_err(|e| self.model(span, &d.name, e))?;
        Ok(())
    }
}

impl Builder<'_> {
    /// A `[[buoyancy]]`: a box hull of full extents `size` centred at `centre` (body frame), sampled
    /// by a `grid` of vertical slabs ([`Buoyancy::box_grid`]), in water of `density` (default sea
    /// water, 1025 kg/m³) at `level`, with drag and an optional wave of the level (`period` in s,
    /// `phase` in degrees).
    fn add_buoyancy(&mut self, span: &Range<usize>, d: &BuoyancyDef) -> R<()> {
        let body = self.body(span, "body", &d.body)?;
        let mut half = self.vec3(span, "size", d.size)? / 2.0;
        for c in half.iter_mut() {
            *c = self.positive(span, "size", *c)?;
        }
        let centre = self.vec3(span, "centre", d.centre)?;
        if d.grid[0] == 0 || d.grid[1] == 0 || d.grid[0] * d.grid[1] > 10_000 {
            return Err(self.invalid(span, "grid", "1 to 10000 sample points in all"));
        }
        let mut water = Water::still(
            self.finite(span, "level", d.level)?,
            self.positive(span, "density", d.density.unwrap_or(1025.0))?,
        );
        if let Some(w) = &d.wave {
            let period = self.positive(span, "wave", w.period)?;
            water.wave = Some(Wave {
                amplitude: self.non_negative(span, "wave", w.amplitude)?,
                angular_frequency: std::f64::consts::TAU / period,
                phase: self.finite(span, "wave", w.phase)?.to_radians(),
            });
        }
        let mut el = Buoyancy::box_grid(body, half, d.grid[0], d.grid[1], water).with_drag(
            self.non_negative(span, "linear_drag", d.linear_drag)?,
            self.non_negative(span, "quadratic_drag", d.quadratic_drag)?,
        );
        for p in &mut el.points {
            p.position += centre;
        }
        self.world
            .add_force(&d.name, ForceElement::Buoyancy(el))
            .map_err(|e| self.model(span, &d.name, e))?;
        Ok(())
    }
}

/// `{i}`, `{i-1}`, `{i+1}` in names of instance `i`.
fn subst(s: &str, i: usize) -> String {
    if !s.contains('{') {
        return s.to_string();
    }
    s.replace("{i}", &i.to_string())
        .replace("{i-1}", &i.wrapping_sub(1).to_string())
        .replace("{i+1}", &(i + 1).to_string())
}

fn subst_body(d: &BodyDef, i: usize) -> BodyDef {
    BodyDef { name: subst(&d.name, i), ..d.clone() }
}

fn subst_joint(d: &JointDef, i: usize) -> JointDef {
    JointDef { name: subst(&d.name, i), a: subst(&d.a, i), b: d.b.as_ref().map(|b| subst(b, i)), ..d.clone() }
}

fn subst_spring(d: &SpringDef, i: usize) -> SpringDef {
    SpringDef {
        name: subst(&d.name, i),
        a: subst(&d.a, i),
        b: d.b.as_ref().map(|b| subst(b, i)),
        ..d.clone()
    }
}

/// Parses and builds a scene; `file` labels error locations. Every stage checks what it reads, in
/// the order of the file's sections, so the first error met is the one reported.
pub(crate) fn build(file: &str, text: &str) -> R<Scene> {
    let src = Source::new(file, text);
    let parsed: SceneFile = toml::from_str(text).map_err(|e| SceneError::Syntax {
        at: src.at(e.span().unwrap_or(0..0)),
        message: e.message().to_string(),
    })?;
    let sspan = parsed.scene.span();
    let sec = parsed.scene.get_ref();
    let mut b = Builder::new(&src);
    let settings = b.world_settings(&sspan, sec)?;
    let watchdog = b.watchdog_settings(&sspan, sec)?;
    let duration = b.positive(&sspan, "duration", sec.duration.unwrap_or(20.0))?;
    if sec.name.trim().is_empty() {
        return Err(b.invalid(&sspan, "name", "the scene needs a name"));
    }
    b.world.set_settings(settings).map_err(|e| b.model(&sspan, "scene", e))?;
    b.scene_defaults(&sspan, sec)?;
    for m in &parsed.material {
        b.add_material(&m.span(), m.get_ref())?;
    }
    b.add_items(&parsed)?;
    let controls = actuators(&b, &parsed.actuator)?;
    let joystick = match &parsed.joystick {
        Some(j) => joystick(&b, &controls, j.get_ref())?,
        None => JoystickMap::default(),
    };
    let script = script(&b, &controls, &parsed.script)?;
    let mut signals = super::signals::build_signals(&src, &b.world, &parsed.sensor, &parsed.event)?;
    let faults = super::signals::build_faults(&src, &b.world, &controls, &mut signals, &parsed.fault)?;
    let declared_faults = faults.list().len();
    let mut world = b.world;
    let mut controls = controls;
    // The initial actuator values are in force from the first step on.
    controls.apply(&mut world, settings.timestep).map_err(|e| SceneError::Invalid {
        at: src.at(sspan.clone()),
        field: "actuator".into(),
        message: e.to_string(),
    })?;
    Ok(Scene {
        name: sec.name.clone(),
        description: sec.description.clone(),
        source: file.to_string(),
        duration,
        world,
        controls,
        script,
        joystick,
        watchdog,
        signals,
        faults,
        declared_faults,
    })
}

/// The stages of [`build`]: the `[scene]` section, then the items in an order that lets the
/// tables come in any order in the file.
impl<'a> Builder<'a> {
    /// An empty world with default settings (the scene's replace them once checked) and defaults.
    fn new(src: &'a Source<'a>) -> Self {
        Builder {
            src,
            world: World::new(WorldSettings::default()).expect("default settings are valid"),
            default_mu: 1.0,
            default_compliance: crate::dynamics::DEFAULT_COMPLIANCE,
            body_spans: HashMap::new(),
        }
    }

    /// The world settings of the `[scene]` section (unset keys: the defaults).
    fn world_settings(&self, sspan: &Range<usize>, sec: &SceneSection) -> R<WorldSettings> {
        let mut settings = WorldSettings::default();
        if let Some(h) = sec.timestep {
            settings.timestep = self.positive(sspan, "timestep", h)?;
        }
        if let Some(g) = sec.gravity {
            settings.gravity = self.vec3(sspan, "gravity", g)?;
        }
        if let Some(v) = &sec.variant {
            settings.solver.variant =
                v.parse().map_err(|e| self.invalid(sspan, "variant", format!("{e}")))?;
        }
        if let Some(n) = sec.max_pivot_steps {
            if n == 0 {
                return Err(self.invalid(sspan, "max_pivot_steps", "must be ≥ 1"));
            }
            settings.solver.max_steps = n;
        }
        if let Some(us) = sec.max_solve_us {
            settings.solver.max_solve_us = Some(self.positive(sspan, "max_solve_us", us)?);
        }
        if let Some(b) = sec.newton_first {
            settings.solver.newton_first = b;
        }
        if let Some(b) = sec.safeguard_after_update {
            settings.solver.safeguard_after_update = b;
        }
        if let Some(n) = sec.murty_after {
            settings.solver.murty_after = n;
        }
        if let Some(n) = sec.ipm_after {
            settings.solver.ipm_after = n;
        }
        if let Some(n) = sec.ipm_cold_after {
            settings.solver.ipm_cold_after = n;
        }
        if let Some(n) = sec.projected_arc {
            if n > 30 {
                return Err(self.invalid(
                    sspan,
                    "projected_arc",
                    "must be at most 30 (halvings of the step)",
                ));
            }
            settings.solver.projected_arc = n;
        }
        if let Some(n) = sec.polish_sweeps {
            settings.solver.polish_sweeps = n;
        }
        if let Some(b) = sec.exact_bilateral {
            settings.solver.exact_bilateral = b;
        }
        if let Some(n) = sec.pgs_sweeps {
            if n == 0 {
                return Err(self.invalid(sspan, "pgs_sweeps", "must be ≥ 1"));
            }
            settings.solver.pgs.max_iterations = n;
        }
        if let Some(n) = sec.projection_iterations {
            settings.projection_iterations = n;
        }
        if let Some(g) = sec.gyroscopic {
            settings.gyroscopic = g;
        }
        if let Some(w) = sec.warm_start {
            settings.warm_start = w;
        }
        if let Some(g) = &sec.geometric_stiffness {
            settings.geometric_stiffness = GeometricStiffness::from_name(g).ok_or_else(|| {
                self.invalid(
                    sspan,
                    "geometric_stiffness",
                    format!("unknown mode `{g}` (implicit, inertial, off)"),
                )
            })?;
        }
        Ok(settings)
    }

    /// The watchdog's bounds of the `[scene]` section.
    fn watchdog_settings(&self, sspan: &Range<usize>, sec: &SceneSection) -> R<WatchdogSettings> {
        let mut watchdog = WatchdogSettings::default();
        if let Some(v) = sec.max_speed {
            watchdog.max_speed = self.positive(sspan, "max_speed", v)?;
        }
        if let Some(e) = sec.energy_margin {
            watchdog.energy_margin = self.positive(sspan, "energy_margin", e)?;
        }
        if let Some(e) = sec.max_joint_error {
            watchdog.max_joint_error = self.positive(sspan, "max_joint_error", e)?;
        }
        Ok(watchdog)
    }

    /// The scene-wide defaults of the `[scene]` section: friction and compliance of the items that
    /// give none, the contact compliance and prediction margin.
    fn scene_defaults(&mut self, sspan: &Range<usize>, sec: &SceneSection) -> R<()> {
        self.default_mu = self.non_negative(sspan, "friction", sec.friction.unwrap_or(1.0))?;
        self.default_compliance = self.non_negative(
            sspan,
            "compliance",
            sec.compliance.unwrap_or(crate::dynamics::DEFAULT_COMPLIANCE),
        )?;
        if let Some(c) = sec.contact_compliance {
            let mut cs = self.world.contact_settings();
            cs.compliance = self.positive(sspan, "contact_compliance", c)?;
            self.world
                .set_contact_settings(cs)
                .map_err(|e| self.invalid(sspan, "contact_compliance", e.to_string()))?;
        }
        if let Some(m) = sec.contact_margin {
            let mut cs = self.world.contact_settings();
            cs.margin = self.non_negative(sspan, "contact_margin", m)?;
            self.world
                .set_contact_settings(cs)
                .map_err(|e| self.invalid(sspan, "contact_margin", e.to_string()))?;
        }
        Ok(())
    }

    /// A `[[material]]` pair's friction.
    fn add_material(&mut self, span: &Range<usize>, d: &MaterialDef) -> R<()> {
        let mu = self.non_negative(span, "friction", d.friction)?;
        self.world
            .set_material_friction(&d.a, &d.b, mu)
            .map_err(|e| self.invalid(span, "friction", e.to_string()))
    }

    /// Bodies first (plain, then repeated), then joints and springs (plain, repeated), cables and
    /// couplings, so that any order of tables works.
    fn add_items(&mut self, parsed: &SceneFile) -> R<()> {
        let zero = Vector3::zeros();
        for d in &parsed.body {
            self.add_body(&d.span(), d.get_ref(), zero)?;
        }
        let mut instances = Vec::new();
        for r in &parsed.repeat {
            let offsets = self.repeat_offsets(&r.span(), r.get_ref())?;
            for (i, &o) in offsets.iter().enumerate() {
                for d in &r.get_ref().body {
                    self.add_body(&d.span(), &subst_body(d.get_ref(), i), o)?;
                }
            }
            instances.push(offsets);
        }
        for d in &parsed.joint {
            self.add_joint(&d.span(), d.get_ref(), zero)?;
        }
        for (r, offsets) in parsed.repeat.iter().zip(&instances) {
            for (i, &o) in offsets.iter().enumerate() {
                for d in &r.get_ref().joint {
                    if i >= d.get_ref().from.unwrap_or(0) {
                        self.add_joint(&d.span(), &subst_joint(d.get_ref(), i), o)?;
                    }
                }
                for d in &r.get_ref().spring {
                    self.add_spring(&d.span(), &subst_spring(d.get_ref(), i), o)?;
                }
            }
        }
        for d in &parsed.spring {
            self.add_spring(&d.span(), d.get_ref(), zero)?;
        }
        for d in &parsed.cable {
            self.add_cable(&d.span(), d.get_ref())?;
        }
        for d in &parsed.buoyancy {
            self.add_buoyancy(&d.span(), d.get_ref())?;
        }
        for c in &parsed.coupling {
            self.add_coupling(&c.span(), c.get_ref())?;
        }
        Ok(())
    }

    /// The offsets of a `[[repeat]]`'s instances: `offsets`, or `count` multiples of `step`.
    fn repeat_offsets(&self, span: &Range<usize>, rd: &RepeatDef) -> R<Vec<Vector3<f64>>> {
        let offsets: Vec<Vector3<f64>> = match (&rd.offsets, rd.count) {
            (Some(list), None) => list.iter().map(|&o| self.vec3(span, "offsets", o)).collect::<R<_>>()?,
            (None, Some(n)) => {
                let step = self.vec3(span, "step", rd.step.unwrap_or([0.0; 3]))?;
                (0..n).map(|i| step * i as f64).collect()
            }
            _ => {
                return Err(self.invalid(
                    span,
                    "count",
                    "a repeat needs either `count` (with `step`) or `offsets`",
                ));
            }
        };
        if offsets.is_empty() || offsets.len() > 10_000 {
            return Err(self.invalid(
                span,
                "count",
                format!("{} instances (1 to 10000 allowed)", offsets.len()),
            ));
        }
        Ok(offsets)
    }

    /// A `[[coupling]]` between named joints.
    fn add_coupling(&mut self, span: &Range<usize>, d: &CouplingDef) -> R<()> {
        let joint = |n: &String| {
            self.world
                .joint_id(n)
                .ok_or_else(|| self.invalid(span, "joints", format!("no joint named `{n}`")))
        };
        let js = d.joints.iter().map(joint).collect::<R<Vec<_>>>()?;
        let ratio = self.finite(span, "ratio", d.ratio)?;
        let mut cb = match (d.kind.as_str(), js.as_slice()) {
            ("gear", &[x, y]) => CouplingBuilder::gear(&d.name, x, y, ratio),
            ("differential", &[i, l, r]) => CouplingBuilder::differential(&d.name, i, l, r, ratio),
            ("rack", &[r, p]) => CouplingBuilder::rack(&d.name, r, p, ratio),
            ("gear" | "differential" | "rack", _) => {
                return Err(self.invalid(
                    span,
                    "joints",
                    "a gear couples 2 joints [a, b]; a differential 3 [input, left, right]; a rack 2 \
                     [slide, pinion]",
                ));
            }
            (other, _) => {
                return Err(self.invalid(
                    span,
                    "type",
                    format!("unknown coupling type `{other}` (gear, differential, rack)"),
                ));
            }
        };
        if let Some(t) = d.max_torque {
            cb = cb.max_torque(self.non_negative(span, "max_torque", t)?);
        }
        if let Some(cc) = d.compliance {
            cb = cb.compliance(self.non_negative(span, "compliance", cc)?);
        }
        self.world.add_coupling(cb).map_err(|e| self.model(span, &d.name, e))?;
        Ok(())
    }
}

fn actuators(b: &Builder, defs: &[Spanned<ActuatorDef>]) -> R<Controls> {
    let mut controls = Controls::default();
    let mut driven = HashSet::new();
    for a in defs {
        let (span, d) = (a.span(), a.get_ref());
        if controls.names.contains_key(&d.name) {
            return Err(b.invalid(&span, "name", format!("actuator `{}` is already defined", d.name)));
        }
        let act = actuator(b, &span, d, &mut driven)?;
        controls.names.insert(d.name.clone(), controls.actuators.len());
        controls.actuators.push(act);
    }
    Ok(controls)
}

/// One `[[actuator]]`, checked; `driven` holds the joint axes earlier actuators drive.
fn actuator(
    b: &Builder,
    span: &Range<usize>,
    d: &ActuatorDef,
    driven: &mut HashSet<(JointId, FreeAxis)>,
) -> R<Actuator> {
    let kind = actuator_kind(b, span, &d.kind)?;
    let targets = actuator_targets(b, span, d, driven)?;
    let coupling = actuator_coupling(b, span, d.coupling.as_deref(), kind, &targets)?;
    let max_force = b.non_negative(span, "max_force", d.max_force)?;
    let max_speed = match d.max_speed {
        Some(v) => b.positive(span, "max_speed", v)?,
        None => f64::INFINITY,
    };
    let range = actuator_range(b, span, d.range, kind)?;
    let neutral = match (d.neutral, kind) {
        (Some(v), _) => Neutral::Value(b.finite(span, "neutral", v)?),
        (None, ActuatorKind::Position) => Neutral::Hold,
        (None, ActuatorKind::Brake) => Neutral::Value(1.0),
        (None, _) => Neutral::Value(0.0),
    };
    let rate = d.rate.map(|r| b.positive(span, "rate", r)).transpose()?;
    if d.winch && kind != ActuatorKind::Velocity {
        return Err(b.invalid(span, "winch", "only a velocity actuator can be a winch"));
    }
    let initial = match (d.initial, neutral) {
        (Some(v), _) => b.finite(span, "initial", v)?,
        (None, Neutral::Value(v)) => v,
        (None, Neutral::Hold) => {
            let t = targets[0];
            b.world.joint_axis_coordinate(t.joint, t.axis).unwrap_or(0.0) / t.scale
        }
    };
    let initial = initial.clamp(range.0, range.1);
    Ok(Actuator {
        name: d.name.clone(),
        kind,
        targets,
        coupling,
        max_force,
        max_speed,
        range,
        neutral,
        rate,
        winch: d.winch,
        value: initial,
        applied: initial,
        initial,
        fault: ActuatorFault::None,
    })
}

/// An actuator's `type`.
fn actuator_kind(b: &Builder, span: &Range<usize>, kind: &str) -> R<ActuatorKind> {
    match kind {
        "velocity" => Ok(ActuatorKind::Velocity),
        "position" => Ok(ActuatorKind::Position),
        "brake" => Ok(ActuatorKind::Brake),
        "clutch" => Ok(ActuatorKind::Clutch),
        other => Err(b.invalid(
            span,
            "type",
            format!("unknown actuator type `{other}` (velocity, position, brake, clutch)"),
        )),
    }
}

/// An actuator's joint axes with their scales; each axis must exist and be driven by no other
/// actuator (recorded in `driven`).
fn actuator_targets(
    b: &Builder,
    span: &Range<usize>,
    d: &ActuatorDef,
    driven: &mut HashSet<(JointId, FreeAxis)>,
) -> R<Vec<ActuatorTarget>> {
    let scales = d.scale.clone().unwrap_or_else(|| vec![1.0]);
    if scales.len() != 1 && scales.len() != d.joints.len() {
        return Err(b.invalid(span, "scale", "give one scale, or one per joint"));
    }
    let mut targets = Vec::new();
    for (k, n) in d.joints.iter().enumerate() {
        let joint =
            b.world.joint_id(n).ok_or_else(|| b.invalid(span, "joints", format!("no joint named `{n}`")))?;
        let jk = b.world.joint(joint).map(|j| j.kind()).expect("joint exists");
        let axis = match d.axis.as_deref() {
            Some("linear") => FreeAxis::Linear,
            Some("angular") => FreeAxis::Angular,
            Some(other) => {
                return Err(b.invalid(span, "axis", format!("unknown axis `{other}` (linear, angular)")));
            }
            None => jk.first_axis().ok_or_else(|| {
                b.invalid(span, "joints", format!("joint `{n}` ({}) has no free axis to drive", jk.name()))
            })?,
        };
        if !jk.has_axis(axis) {
            return Err(b.invalid(
                span,
                "axis",
                format!("joint `{n}` ({}) has no {} axis", jk.name(), axis.name()),
            ));
        }
        if !driven.insert((joint, axis)) {
            return Err(b.invalid(
                span,
                "joints",
                format!("joint `{n}` is already driven by another actuator"),
            ));
        }
        let scale = scales[if scales.len() == 1 { 0 } else { k }];
        if !(scale.is_finite() && scale != 0.0) {
            return Err(b.invalid(span, "scale", "scales must be finite and non-zero"));
        }
        targets.push(ActuatorTarget { joint, axis, scale });
    }
    Ok(targets)
}

/// The coupling a clutch drives (only a clutch has one); any other actuator needs a joint.
fn actuator_coupling(
    b: &Builder,
    span: &Range<usize>,
    coupling: Option<&str>,
    kind: ActuatorKind,
    targets: &[ActuatorTarget],
) -> R<Option<CouplingId>> {
    match (coupling, kind) {
        (Some(n), ActuatorKind::Clutch) => Ok(Some(
            b.world
                .coupling_id(n)
                .ok_or_else(|| b.invalid(span, "coupling", format!("no coupling named `{n}`")))?,
        )),
        (None, ActuatorKind::Clutch) => Err(b.invalid(span, "coupling", "a clutch needs `coupling`")),
        (Some(_), _) => Err(b.invalid(span, "coupling", "only a clutch drives a coupling")),
        (None, _) => {
            if targets.is_empty() {
                return Err(b.invalid(span, "joints", "an actuator needs at least one joint"));
            }
            Ok(None)
        }
    }
}

/// An actuator's value range: as given, or its kind's default; brakes and clutches stay in [0, 1].
fn actuator_range(
    b: &Builder,
    span: &Range<usize>,
    range: Option<[f64; 2]>,
    kind: ActuatorKind,
) -> R<(f64, f64)> {
    let unit = matches!(kind, ActuatorKind::Brake | ActuatorKind::Clutch);
    let range = match range {
        Some([lo, hi]) if !lo.is_nan() && !hi.is_nan() && lo <= hi => (lo, hi),
        Some(_) => return Err(b.invalid(span, "range", "range must be [low, high] with low ≤ high")),
        None if unit => (0.0, 1.0),
        None if kind == ActuatorKind::Velocity => (-1.0, 1.0),
        None => (f64::NEG_INFINITY, f64::INFINITY),
    };
    if unit && (range.0 < 0.0 || range.1 > 1.0) {
        return Err(b.invalid(span, "range", "brakes and clutches take values in [0, 1]"));
    }
    Ok(range)
}

fn event(b: &Builder, span: &Range<usize>, kind: &str, joint: Option<&str>) -> R<SceneEvent> {
    let name = joint.ok_or_else(|| b.invalid(span, "joint", format!("event `{kind}` needs `joint`")))?;
    let j =
        b.world.joint_id(name).ok_or_else(|| b.invalid(span, "joint", format!("no joint named `{name}`")))?;
    match kind {
        "attach" => Ok(SceneEvent::Attach(j)),
        "detach" => Ok(SceneEvent::Detach(j)),
        other => Err(b.invalid(span, "event", format!("unknown event `{other}` (attach, detach)"))),
    }
}

fn actuator_index(
    b: &Builder,
    controls: &Controls,
    span: &Range<usize>,
    field: &str,
    name: &str,
) -> R<usize> {
    controls.index(name).ok_or_else(|| b.invalid(span, field, format!("no actuator named `{name}`")))
}

fn joystick(b: &Builder, controls: &Controls, d: &JoystickDef) -> R<JoystickMap> {
    let mut axes = Vec::new();
    for a in &d.axis {
        let (span, a) = (a.span(), a.get_ref());
        let deadzone = a.deadzone.unwrap_or(0.05);
        if !(0.0..1.0).contains(&deadzone) {
            return Err(b.invalid(&span, "deadzone", "must be in [0, 1)"));
        }
        let mode = match a.mode.as_deref() {
            None | Some("direct") => AxisMode::Direct,
            Some("rate") => AxisMode::Rate,
            Some(other) => {
                return Err(b.invalid(&span, "mode", format!("unknown mode `{other}` (direct, rate)")));
            }
        };
        if a.index >= 64 {
            return Err(b.invalid(&span, "index", "axis index must be < 64"));
        }
        axes.push(JoyAxis {
            index: a.index,
            actuator: actuator_index(b, controls, &span, "actuator", &a.actuator)?,
            scale: b.finite(&span, "scale", a.scale.unwrap_or(1.0))?,
            deadzone,
            mode,
        });
    }
    let mut buttons = Vec::new();
    for x in &d.button {
        let (span, x) = (x.span(), x.get_ref());
        if x.index >= 64 {
            return Err(b.invalid(&span, "index", "button index must be < 64"));
        }
        let action = match (&x.actuator, &x.event) {
            (Some(a), None) => ButtonAction::Set {
                actuator: actuator_index(b, controls, &span, "actuator", a)?,
                value: b.finite(
                    &span,
                    "value",
                    x.value.ok_or_else(|| b.invalid(&span, "value", "needs `value`"))?,
                )?,
            },
            (None, Some(e)) => ButtonAction::Event(event(b, &span, e, x.joint.as_deref())?),
            _ => {
                return Err(b.invalid(
                    &span,
                    "actuator",
                    "a button needs `actuator` (with `value`) or `event`",
                ));
            }
        };
        buttons.push(JoyButton { index: x.index, action });
    }
    Ok(JoystickMap::new(axes, buttons))
}

fn script(b: &Builder, controls: &Controls, defs: &[Spanned<ScriptDef>]) -> R<Script> {
    let mut entries = Vec::new();
    for e in defs {
        let (span, d) = (e.span(), e.get_ref());
        let t = b.non_negative(&span, "t", d.t)?;
        let ramp = b.non_negative(&span, "ramp", d.ramp.unwrap_or(0.0))?;
        let profile = match d.profile.as_deref() {
            None | Some("smooth") => RampProfile::Smooth,
            Some("linear") => RampProfile::Linear,
            Some(other) => {
                return Err(b.invalid(
                    &span,
                    "profile",
                    format!("unknown ramp profile `{other}` (smooth, linear)"),
                ));
            }
        };
        let mut set = Vec::new();
        for (name, &v) in &d.set {
            set.push((actuator_index(b, controls, &span, "set", name)?, b.finite(&span, "set", v)?));
        }
        let event = match &d.event {
            Some(k) => Some(event(b, &span, k, d.joint.as_deref())?),
            None if d.joint.is_some() => return Err(b.invalid(&span, "joint", "`joint` without `event`")),
            None => None,
        };
        entries.push(ScriptEntry { t, set, ramp, profile, event });
    }
    Ok(Script::new(entries, controls.actuators.len()))
}
