//! `[[body]]` and its shapes.
//!
//! **Inertia from shapes.** A dynamic body without `inertia` spreads its `mass` over its bounded
//! shapes in proportion to their volumes (uniform density, overlaps counted twice) and sums their
//! inertia tensors about the body origin (the centre of mass by convention):
//! `I = Σ_i R_i I_i R_iᵀ + m_i (|d_i|² 𝟙 − d_i d_iᵀ)` with shape rotation `R_i`, offset `d_i`, and
//! `I_i` the solid's own principal moments. Its eigen-decomposition gives the principal moments
//! and the inertia frame.

use super::*;

impl Builder<'_> {
    pub(super) fn add_body(&mut self, span: &Range<usize>, d: &BodyDef, offset: Vector3<f64>) -> R<()> {
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
    pub(super) fn shape(&self, span: &Range<usize>, s: &ShapeDef) -> R<ShapeParts> {
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
            k if crate::scene::terrain::is_terrain(k) => &[],
            other => {
                return Err(self.invalid(
                    span,
                    "type",
                    format!(
                        "unknown shape type `{other}` (box, ball, capsule, cylinder, convex, plane{})",
                        crate::scene::terrain::KINDS.iter().map(|k| format!(", {k}")).collect::<String>()
                    ),
                ));
            }
        };
        let terrain = crate::scene::terrain::is_terrain(&s.kind);
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
            k => crate::scene::terrain::shape(self.src, span, k, s)?,
        };
        let pose = Isometry3::from_parts(
            Translation3::from(self.vec3(span, "position", s.position)?),
            self.rotation(span, s.rotation, None)?,
        );
        let mu = s.friction.map(|m| self.non_negative(span, "friction", m)).transpose()?;
        Ok((shape, pose, mu, s.material.clone()))
    }

    pub(super) fn inertia_from_shapes(
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
}
