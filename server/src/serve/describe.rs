//! The scene description a renderer or console needs ([`SceneDescription`](pivotsim_msgs::SceneDescription) of `pivotsim-msgs`),
//! built from a loaded scene: bodies with their shapes, the joint tree with each joint's frame on
//! its body A (the child; the frame its joint sensors report in), the actuators in wire units, the
//! default joystick bindings and the sensors.
//!
//! Wire units: an actuator's value `u` (scene units, e.g. a stick deflection in `[−1, 1]`) is
//! `s₁ · u` on the wire (`s₁` the scale of its first joint: rad/s, m/s, rad or m); brakes and
//! clutches take an effort in N or N m (`u · max_force`). The ground half-space has no wire shape:
//! it is described as a 200 m × 200 m slab 1 cm thick whose top face is the plane.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use pivotsim_msgs as msgs;

use crate::dynamics::{BodyKind, JointKind, Shape, World};
use crate::scene::{ActuatorKind, AxisMode, ButtonAction, Scene};
use crate::signals::{BodySet, SensorKind};

/// Half thickness of the slab that stands for a half-space.
const SLAB_HALF: f64 = 0.005;

/// The wire mode of an actuator.
pub fn actuator_mode(kind: ActuatorKind) -> msgs::ActuatorMode {
    match kind {
        ActuatorKind::Velocity => msgs::ActuatorMode::Velocity,
        ActuatorKind::Position => msgs::ActuatorMode::Position,
        ActuatorKind::Brake | ActuatorKind::Clutch => msgs::ActuatorMode::Effort,
    }
}

fn quat_xyzw(q: &UnitQuaternion<f64>) -> [f64; 4] {
    [q.i, q.j, q.k, q.w]
}

fn collider(shape: &Shape, pose: &Isometry3<f64>, out: &mut Vec<msgs::Collider>) {
    let put = |shape: msgs::Shape, pose: &Isometry3<f64>, out: &mut Vec<msgs::Collider>| {
        out.push(msgs::Collider {
            shape,
            position: pose.translation.vector.into(),
            orientation: quat_xyzw(&pose.rotation),
        });
    };
    let s = match shape {
        Shape::Ball { radius } => msgs::Shape::Ball { radius: *radius },
        Shape::Cuboid { half_extents } => msgs::Shape::Box { half_extents: (*half_extents).into() },
        Shape::Capsule { radius, half_length } => {
            msgs::Shape::Capsule { radius: *radius, half_height: *half_length }
        }
        Shape::Cylinder { radius, half_length } => {
            msgs::Shape::Cylinder { radius: *radius, half_height: *half_length }
        }
        Shape::ConvexHull { points } => {
            msgs::Shape::ConvexHull { vertices: points.iter().map(|p| (*p).into()).collect() }
        }
        Shape::HalfSpace { normal } => {
            // The slab's top face is the plane: centre below it along the normal.
            let rot = UnitQuaternion::rotation_between(&Vector3::z(), normal)
                .unwrap_or_else(|| UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI));
            let slab = pose * Isometry3::from_parts(Translation3::from(-normal * SLAB_HALF), rot);
            put(msgs::Shape::Box { half_extents: [100.0, 100.0, SLAB_HALF] }, &slab, out);
            return;
        }
        Shape::Compound { parts } => {
            for (p, s) in parts {
                collider(s, &(pose * p), out);
            }
            return;
        }
        Shape::HeightField { rows, cols, heights, scale } => msgs::Shape::Heightfield {
            rows: *rows as u32,
            cols: *cols as u32,
            extent: [scale.x, scale.y],
            heights: msgs::HeightData::Inline(heights.iter().map(|h| h * scale.z).collect()),
        },
        Shape::TriMesh { vertices, indices } => msgs::Shape::Trimesh {
            mesh: msgs::MeshData::Inline {
                vertices: vertices.iter().map(|v| (*v).into()).collect(),
                triangles: indices.clone(),
            },
        },
    };
    put(s, pose, out);
}

/// The wire description of `scene` in world `world`.
pub fn describe(scene: &Scene, world_name: &str) -> msgs::SceneDescription {
    let w: &World = &scene.world;
    let g = w.settings().gravity;
    msgs::SceneDescription {
        world: world_name.to_string(),
        scene: scene.name.clone(),
        timestep: w.settings().timestep,
        gravity: [g.x, g.y, g.z],
        bodies: scene_bodies(scene),
        joints: joint_infos(w),
        actuators: actuator_infos(scene),
        joystick: joystick_bindings(scene),
        sensors: sensor_infos(scene),
    }
}

/// Every body with its kind, mass and colliders.
fn body_infos(w: &World) -> Vec<msgs::BodyInfo> {
    let mut bodies: Vec<msgs::BodyInfo> = w
        .bodies()
        .iter()
        .enumerate()
        .map(|(i, b)| msgs::BodyInfo {
            id: i as u32,
            name: b.name().to_string(),
            kind: match b.kind() {
                BodyKind::Dynamic => msgs::BodyKind::Dynamic,
                BodyKind::Kinematic => msgs::BodyKind::Kinematic,
                BodyKind::Static => msgs::BodyKind::Static,
            },
            mass: if b.is_dynamic() { b.mass() } else { 0.0 },
            visuals: Vec::new(),
            colliders: Vec::new(),
        })
        .collect();
    for c in w.colliders() {
        collider(c.shape(), &c.offset(), &mut bodies[c.body().index()].colliders);
    }
    bodies
}

/// [`body_infos`] with the scene's display-only shapes ([`Scene::visuals`]).
fn scene_bodies(scene: &Scene) -> Vec<msgs::BodyInfo> {
    let mut bodies = body_infos(&scene.world);
    for (body, shape, pose) in &scene.visuals {
        if let Some(b) = bodies.get_mut(body.index()) {
            collider(shape, pose, &mut b.visuals);
        }
    }
    bodies
}

/// The joint tree: every joint with its kind, parent and child body.
fn joint_infos(w: &World) -> Vec<msgs::JointInfo> {
    w.joints()
        .iter()
        .map(|j| msgs::JointInfo {
            name: j.name().to_string(),
            kind: match j.kind() {
                JointKind::Fixed => msgs::JointKind::Fixed,
                JointKind::Hinge => msgs::JointKind::Hinge,
                JointKind::Prismatic => msgs::JointKind::Prismatic,
                JointKind::Ball => msgs::JointKind::Ball,
                _ => msgs::JointKind::Other,
            },
            parent: j.body_b().map(|b| b.0),
            child: j.body_a().0,
            // The joint sensors report the reaction on A in A's joint frame (`crate::signals`).
            frame: Some(msgs::JointFrame {
                body: Some(j.body_a().0),
                position: j.frame_a().translation.vector.into(),
                orientation: quat_xyzw(&j.frame_a().rotation),
            }),
        })
        .collect()
}

/// Every sensor with what it reads: joints by name, body sets as ids (`["*"]` resolved).
fn sensor_infos(scene: &Scene) -> Vec<msgs::SensorInfo> {
    let w: &World = &scene.world;
    let joint = |id| w.joint(id).map(|j| j.name().to_string()).unwrap_or_default();
    let ids = |set: &BodySet| set.members().map(|b| b.0).collect::<Vec<u32>>();
    scene
        .signals
        .sensors()
        .iter()
        .map(|s| {
            let name = s.name.clone();
            match &s.kind {
                SensorKind::Joint { joint: j } => msgs::SensorInfo::Joint { name, joint: joint(*j) },
                SensorKind::Tension { joint: j } => msgs::SensorInfo::Tension { name, joint: joint(*j) },
                SensorKind::Cylinder { joint: j } => msgs::SensorInfo::Cylinder { name, joint: joint(*j) },
                SensorKind::Drum { joint: j } => msgs::SensorInfo::Drum { name, joint: joint(*j) },
                SensorKind::Cable { joints } => {
                    msgs::SensorInfo::Cable { name, joints: joints.iter().map(|j| joint(*j)).collect() }
                }
                SensorKind::ContactSum { bodies, with } => {
                    msgs::SensorInfo::ContactSum { name, bodies: ids(bodies), with: with.as_ref().map(ids) }
                }
                SensorKind::Tipping { bodies, touch } => {
                    msgs::SensorInfo::Tipping { name, bodies: ids(bodies), touch: *touch }
                }
                SensorKind::Contacts { bodies } => msgs::SensorInfo::Contacts { name, bodies: ids(bodies) },
            }
        })
        .collect()
}

/// Every actuator with its joint, wire mode and limits in wire units.
fn actuator_infos(scene: &Scene) -> Vec<msgs::ActuatorInfo> {
    let w: &World = &scene.world;
    scene
        .controls
        .actuators()
        .iter()
        .map(|a| {
            let s = a.unit_scale();
            let (lo, hi) = a.range();
            let limits = match a.kind() {
                ActuatorKind::Brake | ActuatorKind::Clutch => Some([lo * a.max_force(), hi * a.max_force()]),
                _ if lo.is_finite() && hi.is_finite() => Some([(lo * s).min(hi * s), (lo * s).max(hi * s)]),
                _ => None,
            };
            msgs::ActuatorInfo {
                name: a.name().to_string(),
                kind: if a.is_winch() { msgs::ActuatorKind::Winch } else { msgs::ActuatorKind::Motor },
                joint: a.targets().first().and_then(|t| w.joint(t.joint)).map(|j| j.name().to_string()),
                mode: actuator_mode(a.kind()),
                limits,
            }
        })
        .collect()
}

/// The default joystick bindings in wire units: the stick axes, then the buttons that set a value.
fn joystick_bindings(scene: &Scene) -> Vec<msgs::JoystickBinding> {
    let acts = scene.controls.actuators();
    let mut joystick: Vec<msgs::JoystickBinding> = scene
        .joystick
        .axes
        .iter()
        .filter(|m| m.index < msgs::MAX_AXES)
        .map(|m| {
            let a = &acts[m.actuator];
            msgs::JoystickBinding {
                input: msgs::JoystickInput::Axis(m.index as u8),
                actuator: a.name().to_string(),
                mode: match m.mode {
                    AxisMode::Direct => actuator_mode(a.kind()),
                    AxisMode::Rate => msgs::ActuatorMode::Velocity,
                },
                scale: m.scale * a.unit_scale(),
            }
        })
        .collect();
    for b in &scene.joystick.buttons {
        if let ButtonAction::Set { actuator, value } = b.action {
            let a = &acts[actuator];
            joystick.push(msgs::JoystickBinding {
                input: msgs::JoystickInput::Button(b.index as u8),
                actuator: a.name().to_string(),
                mode: actuator_mode(a.kind()),
                scale: value * a.unit_scale(),
            });
        }
    }
    joystick
}
