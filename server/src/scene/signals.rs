//! `[[sensor]]`, `[[event]]` and `[[fault]]`: the scene's signals (`crate::signals`) and faults
//! (`faults.rs`), checked and resolved against the built world with located errors.

use std::collections::HashSet;
use std::ops::Range;

use toml::Spanned;

use super::checks::{R, Source};
use super::controls::Controls;
use super::faults::{FaultRequest, Faults};
use super::format::{EventDef, FaultDef, SensorDef};
use crate::dynamics::{BodyId, JointKind, World};
use crate::signals::{BodySet, EventName, Sensor, SensorKind, Signals, Threshold, ThresholdDir};

/// Default `touch` of a tipping sensor (m): contacts this close count as support.
pub const DEFAULT_TOUCH: f64 = 1e-3;

/// Builds the signals of the scene's sensors and events.
pub(super) fn build_signals(
    src: &Source<'_>,
    world: &World,
    sensors: &[Spanned<SensorDef>],
    events: &[Spanned<EventDef>],
) -> R<Signals> {
    let mut list = Vec::with_capacity(sensors.len());
    let mut names = HashSet::new();
    for s in sensors {
        let (span, d) = (s.span(), s.get_ref());
        if !names.insert(d.name.as_str()) {
            return Err(src.invalid(&span, "name", format!("sensor `{}` is already defined", d.name)));
        }
        let kind = sensor_kind(src, world, &span, d)?;
        for k in 0..kind.channels() {
            let ch = format!("{}/{}", d.name, kind.channel_name(k));
            pivotsim_msgs::validate_actuator_name(&ch).map_err(|e| {
                src.invalid(
                    &span,
                    "name",
                    format!(
                        "channel `{ch}`: {e} (a channel name is the wire's 1 to 32 bytes of [A-Za-z0-9_.-/])"
                    ),
                )
            })?;
        }
        list.push(Sensor { name: d.name.clone(), kind });
    }
    let mut signals =
        Signals::new(list, world.joints().len(), world.bodies().len(), world.settings().gravity);
    for e in events {
        let (span, d) = (e.span(), e.get_ref());
        pivotsim_msgs::validate_actuator_name(&d.name)
            .map_err(|err| src.invalid(&span, "name", format!("event name: {err}")))?;
        let channel = signals
            .channel(&d.channel)
            .ok_or_else(|| src.invalid(&span, "channel", format!("no sensor channel `{}`", d.channel)))?;
        let (dir, level) = match (d.above, d.below) {
            (Some(l), None) => (ThresholdDir::Above, src.finite(&span, "above", l)?),
            (None, Some(l)) => (ThresholdDir::Below, src.finite(&span, "below", l)?),
            _ => return Err(src.invalid(&span, "above", "give exactly one of `above` and `below`")),
        };
        let hysteresis = src.non_negative(&span, "hysteresis", d.hysteresis.unwrap_or(0.0))?;
        let hold = src.non_negative(&span, "hold", d.hold.unwrap_or(0.0))?;
        signals.add_threshold(Threshold {
            name: EventName::new(&d.name),
            channel,
            dir,
            level,
            hysteresis,
            hold,
            active: false,
            since: None,
        });
    }
    Ok(signals)
}

fn body_set(
    src: &Source<'_>,
    world: &World,
    span: &Range<usize>,
    field: &str,
    names: &[String],
    exclude: Option<&[String]>,
) -> R<BodySet> {
    if names.is_empty() {
        return Err(src.invalid(span, field, "name at least one body"));
    }
    let all = names.len() == 1 && names[0] == "*";
    if let Some(ex) = exclude {
        if !all {
            return Err(src.invalid(
                span,
                "exclude",
                format!("`exclude` applies to `{field} = [\"*\"]` only"),
            ));
        }
        if let Some(n) = ex.iter().find(|n| world.body_id(n).is_none()) {
            return Err(src.invalid(span, "exclude", format!("no body named `{n}`")));
        }
    }
    if all {
        // Every body that can move: a whole machine with its load, but for the bodies excluded
        // (a load resting on the ground, another machine).
        let out = |b: &crate::dynamics::RigidBody| exclude.is_some_and(|ex| ex.iter().any(|n| n == b.name()));
        let ids: Vec<BodyId> =
            world.bodies().iter().filter(|b| b.is_dynamic() && !out(b)).map(|b| b.id()).collect();
        if ids.is_empty() {
            return Err(src.invalid(span, "exclude", "no dynamic body is left"));
        }
        return Ok(BodySet::new(world.bodies().len(), &ids));
    }
    let ids = names
        .iter()
        .map(|n| world.body_id(n).ok_or_else(|| src.invalid(span, field, format!("no body named `{n}`"))))
        .collect::<R<Vec<BodyId>>>()?;
    Ok(BodySet::new(world.bodies().len(), &ids))
}

fn sensor_kind(src: &Source<'_>, world: &World, span: &Range<usize>, d: &SensorDef) -> R<SensorKind> {
    let need = |v: &Option<String>, f: &str| {
        v.clone().ok_or_else(|| src.invalid(span, f, format!("a {} sensor needs `{f}`", d.kind)))
    };
    let joint = |want: &[JointKind]| -> R<_> {
        let n = need(&d.joint, "joint")?;
        let id =
            world.joint_id(&n).ok_or_else(|| src.invalid(span, "joint", format!("no joint named `{n}`")))?;
        let kind = world.joint(id).map(|j| j.kind()).unwrap_or(JointKind::Fixed);
        if !want.is_empty() && !want.contains(&kind) {
            return Err(src.invalid(
                span,
                "joint",
                format!(
                    "`{n}` is a {} joint, a {} sensor needs {}",
                    kind.name(),
                    d.kind,
                    want.iter().map(|k| k.name()).collect::<Vec<_>>().join(" or ")
                ),
            ));
        }
        Ok(id)
    };
    let bodies =
        |f: &str| body_set(src, world, span, f, d.bodies.as_deref().unwrap_or(&[]), d.exclude.as_deref());
    let unused = |fields: &[(&str, bool)]| match fields.iter().find(|(_, set)| *set) {
        Some((f, _)) => Err(src.invalid(span, f, format!("`{f}` does not apply to a {} sensor", d.kind))),
        None => Ok(()),
    };
    let (j, c, b, w, t) =
        (d.joint.is_some(), d.cable.is_some(), d.bodies.is_some(), d.with.is_some(), d.touch.is_some());
    let x = d.exclude.is_some();
    Ok(match d.kind.as_str() {
        "joint" => {
            unused(&[("cable", c), ("bodies", b), ("exclude", x), ("with", w), ("touch", t)])?;
            SensorKind::Joint { joint: joint(&[])? }
        }
        "cylinder" => {
            unused(&[("cable", c), ("bodies", b), ("exclude", x), ("with", w), ("touch", t)])?;
            SensorKind::Cylinder { joint: joint(&[JointKind::Prismatic, JointKind::Cylindrical])? }
        }
        "tension" => {
            unused(&[("cable", c), ("bodies", b), ("exclude", x), ("with", w), ("touch", t)])?;
            SensorKind::Tension { joint: joint(&[])? }
        }
        "drum" => {
            unused(&[("cable", c), ("bodies", b), ("exclude", x), ("with", w), ("touch", t)])?;
            SensorKind::Drum { joint: joint(&[JointKind::Hinge, JointKind::Cylindrical])? }
        }
        "cable" => {
            unused(&[("joint", j), ("bodies", b), ("exclude", x), ("with", w), ("touch", t)])?;
            let n = need(&d.cable, "cable")?;
            let mut joints: Vec<_> = world.joint_id(&format!("{n}/start")).into_iter().collect();
            joints.extend((1..).map_while(|i| world.joint_id(&format!("{n}/{i}"))));
            joints.extend(world.joint_id(&format!("{n}/end")));
            if joints.is_empty() {
                return Err(src.invalid(span, "cable", format!("no cable named `{n}`")));
            }
            SensorKind::Cable { joints }
        }
        "contact_sum" => {
            unused(&[("joint", j), ("cable", c), ("touch", t)])?;
            let with = match &d.with {
                Some(names) => Some(body_set(src, world, span, "with", names, None)?),
                None => None,
            };
            SensorKind::ContactSum { bodies: bodies("bodies")?, with }
        }
        "tipping" => {
            unused(&[("joint", j), ("cable", c), ("with", w)])?;
            let touch = src.non_negative(span, "touch", d.touch.unwrap_or(DEFAULT_TOUCH))?;
            SensorKind::Tipping { bodies: bodies("bodies")?, touch }
        }
        "contacts" => {
            unused(&[("joint", j), ("cable", c), ("with", w), ("touch", t)])?;
            SensorKind::Contacts { bodies: bodies("bodies")? }
        }
        other => {
            return Err(src.invalid(
                span,
                "type",
                format!("unknown sensor type `{other}` (joint, tension, cylinder, drum, cable, contact_sum, tipping, contacts)"),
            ));
        }
    })
}

/// Builds the scene's declared faults.
pub(super) fn build_faults(
    src: &Source<'_>,
    world: &World,
    controls: &Controls,
    signals: &mut Signals,
    defs: &[Spanned<FaultDef>],
) -> R<Faults> {
    let mut faults = Faults::default();
    for f in defs {
        let (span, d) = (f.span(), f.get_ref());
        pivotsim_msgs::validate_actuator_name(&d.name)
            .map_err(|err| src.invalid(&span, "name", format!("fault name: {err}")))?;
        let (field, target) = match (&d.joint, &d.actuator, &d.sensor) {
            (Some(j), None, None) => ("joint", j),
            (None, Some(a), None) => ("actuator", a),
            (None, None, Some(s)) => ("sensor", s),
            _ => {
                return Err(src.invalid(&span, "joint", "give exactly one of `joint`, `actuator`, `sensor`"));
            }
        };
        let want = match d.kind.as_str() {
            "break" => "joint",
            "dropout" => "sensor",
            _ => "actuator",
        };
        if field != want {
            return Err(src.invalid(&span, field, format!("a {} fault acts on a {want}", d.kind)));
        }
        if d.t.is_none() && d.tension.is_none() {
            return Err(src.invalid(&span, "t", "a scripted fault needs `t` (or `tension` for a break)"));
        }
        let req = FaultRequest {
            kind: d.kind.clone(),
            target: target.clone(),
            tension: d.tension,
            to: d.to,
            ramp: d.ramp,
        };
        let mut fault = Faults::resolve(&req, world, controls, signals, d.t)
            .map_err(|e| src.invalid(&span, "type", e.to_string()))?;
        fault.name = EventName::new(&d.name);
        faults.push(fault, signals).map_err(|e| src.invalid(&span, "name", e.to_string()))?;
    }
    Ok(faults)
}
