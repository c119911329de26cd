//! `[[actuator]]`, `[joystick]` and `[[script]]`: the scene's inputs.

use super::*;

pub(super) fn actuators(b: &Builder, defs: &[Spanned<ActuatorDef>]) -> R<Controls> {
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
pub(super) fn actuator(
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
pub(super) fn actuator_kind(b: &Builder, span: &Range<usize>, kind: &str) -> R<ActuatorKind> {
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
pub(super) fn actuator_targets(
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
pub(super) fn actuator_coupling(
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
pub(super) fn actuator_range(
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

pub(super) fn event(b: &Builder, span: &Range<usize>, kind: &str, joint: Option<&str>) -> R<SceneEvent> {
    let name = joint.ok_or_else(|| b.invalid(span, "joint", format!("event `{kind}` needs `joint`")))?;
    let j =
        b.world.joint_id(name).ok_or_else(|| b.invalid(span, "joint", format!("no joint named `{name}`")))?;
    match kind {
        "attach" => Ok(SceneEvent::Attach(j)),
        "detach" => Ok(SceneEvent::Detach(j)),
        other => Err(b.invalid(span, "event", format!("unknown event `{other}` (attach, detach)"))),
    }
}

pub(super) fn actuator_index(
    b: &Builder,
    controls: &Controls,
    span: &Range<usize>,
    field: &str,
    name: &str,
) -> R<usize> {
    controls.index(name).ok_or_else(|| b.invalid(span, field, format!("no actuator named `{name}`")))
}

pub(super) fn joystick(b: &Builder, controls: &Controls, d: &JoystickDef) -> R<JoystickMap> {
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

pub(super) fn script(b: &Builder, controls: &Controls, defs: &[Spanned<ScriptDef>]) -> R<Script> {
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
