//! The items in build order — bodies, joints and springs (plain, then `[[repeat]]` instances with
//! their names substituted), cables, buoyancy, couplings — and the `[[cable]]` and `[[buoyancy]]`
//! elements.

use super::*;

impl Builder<'_> {
    /// Bodies first (plain, then repeated), then joints and springs (plain, repeated), cables and
    /// couplings, so that any order of tables works.
    pub(super) fn add_items(&mut self, parsed: &SceneFile) -> R<()> {
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
    pub(super) fn repeat_offsets(&self, span: &Range<usize>, rd: &RepeatDef) -> R<Vec<Vector3<f64>>> {
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

    /// A `[[cable]]`: checked here (located errors), built by [`World::add_chain`].
    pub(super) fn add_cable(&mut self, span: &Range<usize>, d: &CableDef) -> R<()> {
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
        let chain = self.world.add_chain(cb).map_err(|e| self.model(span, &d.name, e))?;
        // The segments' capsules, drawn (they collide with nothing): along each segment's z, as
        // long as the anchor of its joint to the segment above is from its centre (ℓ/2, or the
        // lengthened chord's half of a sagging cable).
        for &body in &chain.bodies {
            let half = chain
                .joints
                .iter()
                .filter_map(|&j| self.world.joint(j))
                .find(|j| j.body_a() == body && j.kind() == crate::dynamics::JointKind::Ball)
                .map_or(ell / 2.0, |j| j.frame_a().translation.vector.norm());
            let radius = diameter / 2.0;
            let shape = if half > radius {
                Shape::Capsule { radius, half_length: half - radius }
            } else {
                Shape::Ball { radius }
            };
            self.visuals.push((body, shape, Isometry3::identity()));
        }
        Ok(())
    }

    /// A `[[buoyancy]]`: a box hull of full extents `size` centred at `centre` (body frame), sampled
    /// by a `grid` of vertical slabs ([`Buoyancy::box_grid`]), in water of `density` (default sea
    /// water, 1025 kg/m³) at `level`, with drag and an optional wave of the level (`period` in s,
    /// `phase` in degrees).
    pub(super) fn add_buoyancy(&mut self, span: &Range<usize>, d: &BuoyancyDef) -> R<()> {
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
