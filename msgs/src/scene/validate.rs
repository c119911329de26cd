//! Validation of a scene description: bounds, finiteness, unit quaternions, unique names and ids,
//! and references between bodies, joints, actuators and joystick bindings.
//!
//! Errors name the offending element by a JSON-like path (`bodies[3].colliders[0].shape.radius`).

use std::collections::HashSet;

use super::error::SceneError;
use super::types::*;
use crate::control::check_scene_ref;
use crate::input::{MAX_AXES, MAX_BUTTONS};
use crate::keys::WorldName;
use crate::name::validate_actuator_name;
use crate::pose::QUAT_NORM_TOLERANCE;

fn finite(path: impl FnOnce() -> String, x: &[f64]) -> Result<(), SceneError> {
    if x.iter().all(|v| v.is_finite()) { Ok(()) } else { Err(SceneError::NonFinite { path: path() }) }
}

fn positive(path: impl FnOnce() -> String, v: f64) -> Result<(), SceneError> {
    if !v.is_finite() {
        return Err(SceneError::NonFinite { path: path() });
    }
    if v > 0.0 { Ok(()) } else { Err(SceneError::NonPositive { path: path(), value: v }) }
}

fn at_most(path: impl FnOnce() -> String, count: usize, max: usize) -> Result<(), SceneError> {
    if count <= max { Ok(()) } else { Err(SceneError::TooMany { path: path(), count, max }) }
}

fn text(path: impl FnOnce() -> String, s: &str, max: usize) -> Result<(), SceneError> {
    if s.is_empty() {
        return Err(SceneError::EmptyName { path: path() });
    }
    if s.len() > max {
        return Err(SceneError::NameTooLong { path: path(), len: s.len(), max });
    }
    match s.char_indices().find(|(_, c)| c.is_control()) {
        Some((index, _)) => Err(SceneError::NameChar { path: path(), index }),
        None => Ok(()),
    }
}

fn pose(path: &str, position: &[f64; 3], q: &[f64; 4]) -> Result<(), SceneError> {
    finite(|| format!("{path}.position"), position)?;
    finite(|| format!("{path}.orientation"), q)?;
    let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    if (norm - 1.0).abs() > QUAT_NORM_TOLERANCE {
        return Err(SceneError::NonUnitQuaternion { path: format!("{path}.orientation"), norm });
    }
    Ok(())
}

fn points(path: &str, v: &[[f64; 3]]) -> Result<(), SceneError> {
    match v.iter().position(|p| !p.iter().all(|x| x.is_finite())) {
        Some(i) => Err(SceneError::NonFinite { path: format!("{path}[{i}]") }),
        None => Ok(()),
    }
}

fn shape(p: &str, s: &Shape) -> Result<(), SceneError> {
    match s {
        Shape::Ball { radius } => positive(|| format!("{p}.radius"), *radius),
        Shape::Box { half_extents } => half_extents
            .iter()
            .enumerate()
            .try_for_each(|(i, &h)| positive(|| format!("{p}.half_extents[{i}]"), h)),
        Shape::Capsule { radius, half_height } | Shape::Cylinder { radius, half_height } => {
            positive(|| format!("{p}.radius"), *radius)?;
            positive(|| format!("{p}.half_height"), *half_height)
        }
        Shape::ConvexHull { vertices } => {
            let path = || format!("{p}.vertices");
            at_most(path, vertices.len(), MAX_HULL_VERTICES)?;
            if vertices.len() < 4 {
                return Err(SceneError::TooFew { path: path(), count: vertices.len(), min: 4 });
            }
            points(&path(), vertices)
        }
        Shape::Heightfield { rows, cols, extent, heights } => {
            let (r, c) = (*rows, *cols);
            let dims_ok = (2..=MAX_HEIGHTFIELD_DIM).contains(&r) && (2..=MAX_HEIGHTFIELD_DIM).contains(&c);
            let samples = match heights {
                HeightData::Inline(h) => Some(h.len()),
                HeightData::Reference(_) => None,
            };
            let count_ok =
                samples.is_none_or(|n| n == r as usize * c as usize && n <= MAX_HEIGHTFIELD_SAMPLES);
            if !dims_ok || !count_ok {
                return Err(SceneError::HeightfieldSize { path: p.to_owned(), rows: r, cols: c, samples });
            }
            extent.iter().enumerate().try_for_each(|(i, &e)| positive(|| format!("{p}.extent[{i}]"), e))?;
            match heights {
                HeightData::Inline(h) => finite(|| format!("{p}.heights"), h),
                HeightData::Reference(u) => text(|| format!("{p}.heights.reference"), u, MAX_REFERENCE_LEN),
            }
        }
        Shape::Trimesh { mesh: MeshData::Reference(u) } => {
            text(|| format!("{p}.mesh.reference"), u, MAX_REFERENCE_LEN)
        }
        Shape::Trimesh { mesh: MeshData::Inline { vertices, triangles } } => {
            at_most(|| format!("{p}.mesh.vertices"), vertices.len(), MAX_MESH_VERTICES)?;
            at_most(|| format!("{p}.mesh.triangles"), triangles.len(), MAX_MESH_TRIANGLES)?;
            if triangles.is_empty() {
                return Err(SceneError::TooFew { path: format!("{p}.mesh.triangles"), count: 0, min: 1 });
            }
            points(&format!("{p}.mesh.vertices"), vertices)?;
            for (t, tri) in triangles.iter().enumerate() {
                if let Some(&index) = tri.iter().find(|&&i| i as usize >= vertices.len()) {
                    let path = format!("{p}.mesh.triangles[{t}]");
                    return Err(SceneError::MeshIndex { path, index, vertices: vertices.len() });
                }
            }
            Ok(())
        }
    }
}

fn unique<'a>(
    seen: &mut HashSet<&'a str>,
    name: &'a str,
    path: impl FnOnce() -> String,
) -> Result<(), SceneError> {
    if seen.insert(name) {
        Ok(())
    } else {
        Err(SceneError::DuplicateName { path: path(), name: name.to_owned() })
    }
}

impl SceneDescription {
    /// Checks every rule a decoder checks.
    pub fn validate(&self) -> Result<(), SceneError> {
        WorldName::new(self.world.as_str())?;
        check_scene_ref(&self.scene).map_err(SceneError::Scene)?;
        positive(|| "timestep".into(), self.timestep)?;
        finite(|| "gravity".into(), &self.gravity)?;
        at_most(|| "bodies".into(), self.bodies.len(), MAX_SCENE_BODIES)?;
        at_most(|| "joints".into(), self.joints.len(), MAX_SCENE_JOINTS)?;
        at_most(|| "actuators".into(), self.actuators.len(), MAX_SCENE_ACTUATORS)?;
        at_most(|| "joystick".into(), self.joystick.len(), MAX_BINDINGS)?;

        let mut ids = HashSet::with_capacity(self.bodies.len());
        let mut names = HashSet::with_capacity(self.bodies.len());
        for (i, b) in self.bodies.iter().enumerate() {
            let p = format!("bodies[{i}]");
            if !ids.insert(b.id) {
                return Err(SceneError::DuplicateBodyId { id: b.id });
            }
            text(|| format!("{p}.name"), &b.name, MAX_NAME_LEN)?;
            unique(&mut names, &b.name, || format!("{p}.name"))?;
            if !b.mass.is_finite() {
                return Err(SceneError::NonFinite { path: format!("{p}.mass") });
            }
            if b.mass < 0.0 || (b.kind == BodyKind::Dynamic && b.mass <= 0.0) {
                return Err(SceneError::NonPositive { path: format!("{p}.mass"), value: b.mass });
            }
            for (field, list) in [("colliders", &b.colliders), ("visuals", &b.visuals)] {
                at_most(|| format!("{p}.{field}"), list.len(), MAX_COLLIDERS_PER_BODY)?;
                for (j, c) in list.iter().enumerate() {
                    let cp = format!("{p}.{field}[{j}]");
                    pose(&cp, &c.position, &c.orientation)?;
                    shape(&format!("{cp}.shape"), &c.shape)?;
                }
            }
        }

        let mut joints = HashSet::with_capacity(self.joints.len());
        for (i, j) in self.joints.iter().enumerate() {
            let p = format!("joints[{i}]");
            text(|| format!("{p}.name"), &j.name, MAX_NAME_LEN)?;
            unique(&mut joints, &j.name, || format!("{p}.name"))?;
            for (field, id) in [("parent", j.parent), ("child", Some(j.child))] {
                if let Some(id) = id.filter(|id| !ids.contains(id)) {
                    return Err(SceneError::UnknownBody { path: format!("{p}.{field}"), id });
                }
            }
            if j.parent == Some(j.child) {
                return Err(SceneError::SelfJoint { path: p });
            }
            if let Some(f) = &j.frame {
                if f.body != Some(j.child) && f.body != j.parent {
                    return Err(SceneError::FrameBody { path: format!("{p}.frame.body"), body: f.body });
                }
                pose(&format!("{p}.frame"), &f.position, &f.orientation)?;
            }
        }

        let mut actuators = HashSet::with_capacity(self.actuators.len());
        for (i, a) in self.actuators.iter().enumerate() {
            let p = format!("actuators[{i}]");
            validate_actuator_name(&a.name)
                .map_err(|source| SceneError::ActuatorName { path: format!("{p}.name"), source })?;
            unique(&mut actuators, &a.name, || format!("{p}.name"))?;
            if let Some(joint) = a.joint.as_deref().filter(|j| !joints.contains(j)) {
                return Err(SceneError::UnknownJoint { path: format!("{p}.joint"), name: joint.to_owned() });
            }
            if let Some([lo, hi]) = a.limits {
                finite(|| format!("{p}.limits"), &[lo, hi])?;
                if lo > hi {
                    return Err(SceneError::Limits { path: format!("{p}.limits"), lo, hi });
                }
            }
        }

        for (i, b) in self.joystick.iter().enumerate() {
            let p = format!("joystick[{i}]");
            let (index, max) = match b.input {
                JoystickInput::Axis(a) => (a, MAX_AXES),
                JoystickInput::Button(k) => (k, MAX_BUTTONS),
            };
            if index as usize >= max {
                return Err(SceneError::BindingIndex { path: format!("{p}.input"), index, max });
            }
            if !actuators.contains(b.actuator.as_str()) {
                return Err(SceneError::UnknownActuator {
                    path: format!("{p}.actuator"),
                    name: b.actuator.clone(),
                });
            }
            finite(|| format!("{p}.scale"), &[b.scale])?;
        }
        self.validate_sensors(&ids)
    }

    /// The sensors: names, the joints and bodies they name, their joints' frames and kinds.
    fn validate_sensors(&self, ids: &HashSet<u32>) -> Result<(), SceneError> {
        at_most(|| "sensors".into(), self.sensors.len(), MAX_SCENE_SENSORS)?;
        let mut names = HashSet::with_capacity(self.sensors.len());
        for (i, s) in self.sensors.iter().enumerate() {
            let p = format!("sensors[{i}]");
            validate_actuator_name(s.name())
                .map_err(|source| SceneError::ActuatorName { path: format!("{p}.name"), source })?;
            unique(&mut names, s.name(), || format!("{p}.name"))?;
            let joint = |path: String, name: &str| {
                self.joint(name).ok_or_else(|| SceneError::UnknownJoint { path, name: name.to_owned() })
            };
            match s {
                SensorInfo::Joint { joint: j, .. }
                | SensorInfo::Cylinder { joint: j, .. }
                | SensorInfo::Drum { joint: j, .. } => {
                    let info = joint(format!("{p}.joint"), j)?;
                    if info.frame.is_none() {
                        return Err(SceneError::NoJointFrame { path: format!("{p}.joint"), name: j.clone() });
                    }
                    let fits = match s {
                        SensorInfo::Cylinder { .. } => {
                            matches!(info.kind, JointKind::Prismatic | JointKind::Other)
                        }
                        SensorInfo::Drum { .. } => matches!(info.kind, JointKind::Hinge | JointKind::Other),
                        _ => true,
                    };
                    if !fits {
                        return Err(SceneError::SensorJointKind {
                            path: format!("{p}.joint"),
                            sensor: s.kind_name(),
                            joint: joint_kind_name(info.kind),
                        });
                    }
                }
                SensorInfo::Tension { joint: j, .. } => {
                    joint(format!("{p}.joint"), j)?;
                }
                SensorInfo::Cable { joints, .. } => {
                    at_most(|| format!("{p}.joints"), joints.len(), MAX_SCENE_JOINTS)?;
                    if joints.is_empty() {
                        return Err(SceneError::TooFew { path: format!("{p}.joints"), count: 0, min: 1 });
                    }
                    for (k, j) in joints.iter().enumerate() {
                        joint(format!("{p}.joints[{k}]"), j)?;
                    }
                }
                SensorInfo::ContactSum { bodies, with, .. } => {
                    body_list(&format!("{p}.bodies"), bodies, ids)?;
                    if let Some(w) = with {
                        body_list(&format!("{p}.with"), w, ids)?;
                    }
                }
                SensorInfo::Tipping { bodies, touch, .. } => {
                    body_list(&format!("{p}.bodies"), bodies, ids)?;
                    finite(|| format!("{p}.touch"), &[*touch])?;
                    if *touch < 0.0 {
                        return Err(SceneError::Negative { path: format!("{p}.touch"), value: *touch });
                    }
                }
                SensorInfo::Contacts { bodies, .. } => body_list(&format!("{p}.bodies"), bodies, ids)?,
            }
        }
        Ok(())
    }
}

fn joint_kind_name(k: JointKind) -> &'static str {
    match k {
        JointKind::Fixed => "fixed",
        JointKind::Hinge => "hinge",
        JointKind::Prismatic => "prismatic",
        JointKind::Ball => "ball",
        JointKind::Other => "other",
    }
}

/// A sensor's body list: 1..=65 535 ids of `bodies`, none twice.
fn body_list(path: &str, list: &[u32], ids: &HashSet<u32>) -> Result<(), SceneError> {
    at_most(|| path.to_owned(), list.len(), MAX_SCENE_BODIES)?;
    if list.is_empty() {
        return Err(SceneError::TooFew { path: path.to_owned(), count: 0, min: 1 });
    }
    let mut seen = HashSet::with_capacity(list.len());
    for (k, &id) in list.iter().enumerate() {
        if !ids.contains(&id) {
            return Err(SceneError::UnknownBody { path: format!("{path}[{k}]"), id });
        }
        if !seen.insert(id) {
            return Err(SceneError::RepeatedBody { path: format!("{path}[{k}]"), id });
        }
    }
    Ok(())
}
