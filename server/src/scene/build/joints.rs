//! `[[joint]]`, `[[spring]]` and `[[coupling]]`: the items that join bodies.

use super::*;

impl Builder<'_> {
    pub(super) fn add_joint(&mut self, span: &Range<usize>, d: &JointDef, offset: Vector3<f64>) -> R<()> {
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

    pub(super) fn add_spring(&mut self, span: &Range<usize>, d: &SpringDef, offset: Vector3<f64>) -> R<()> {
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

    /// A `[[coupling]]` between named joints.
    pub(super) fn add_coupling(&mut self, span: &Range<usize>, d: &CouplingDef) -> R<()> {
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
