//! Frames as JSON values (for `watch --json` and the MCAP recording), and the JSON schemas of
//! those values (MCAP `jsonschema` schemas, which Foxglove reads to type the message fields).

use pivotsim_msgs as msgs;
use serde_json::{Value, json};

use crate::util::body_name;

/// A body pose record.
pub fn body_json(b: &msgs::BodyPose, scene: Option<&msgs::SceneDescription>) -> Value {
    json!({
        "id": b.id,
        "name": body_name(scene, b.id),
        "flags": b.flags,
        "position": {"x": b.position[0], "y": b.position[1], "z": b.position[2]},
        "orientation": {"x": b.orientation[0], "y": b.orientation[1], "z": b.orientation[2], "w": b.orientation[3]},
        "linear_velocity": {"x": b.linear_velocity[0], "y": b.linear_velocity[1], "z": b.linear_velocity[2]},
        "angular_velocity": {"x": b.angular_velocity[0], "y": b.angular_velocity[1], "z": b.angular_velocity[2]},
    })
}

/// A pose frame with the bodies `keep` selects.
pub fn pose_json(
    v: &msgs::PoseFrameView<'_>,
    scene: Option<&msgs::SceneDescription>,
    keep: impl Fn(&msgs::BodyPose) -> bool,
) -> Value {
    let bodies: Vec<Value> = v.bodies().filter(|b| keep(b)).map(|b| body_json(&b, scene)).collect();
    json!({
        "sequence": v.sequence(),
        "sim_time": v.sim_time(),
        "wall_time_ns": v.wall_time_ns(),
        "bodies": bodies,
    })
}

/// A solver stats frame.
pub fn stats_json(s: &msgs::SolverStats) -> Value {
    let rejected: serde_json::Map<String, Value> = msgs::RejectReason::ALL
        .iter()
        .map(|r| (r.name().to_string(), json!(s.inputs.rejected_for(*r))))
        .collect();
    let islands: Vec<Value> = s
        .islands
        .iter()
        .map(|i| {
            json!({
                "variant": i.variant.name(),
                "status": i.status.name(),
                "fallback": i.fallback,
                "rows": i.rows,
                "bodies": i.bodies,
                "pivot_steps": i.pivot_steps,
                "tight": i.tight,
                "iterations": i.iterations,
                "solve_us": i.solve_us,
                "residual_rel": i.residual_rel,
            })
        })
        .collect();
    json!({
        "sequence": s.sequence,
        "sim_time": s.sim_time,
        "step_wall_us": s.step_wall_us,
        "overruns": s.overruns,
        "total_rows": s.totals.rows,
        "total_bodies": s.totals.bodies,
        "total_tight": s.totals.tight,
        "fallback_islands": s.totals.fallback_islands,
        "total_pivot_steps": s.totals.pivot_steps,
        "total_solve_us": s.totals.solve_us,
        "max_residual_rel": s.totals.residual_rel_max,
        "inputs_accepted": s.inputs.accepted,
        "inputs_rejected": rejected,
        "inputs_rejected_total": s.inputs.rejected_total(),
        "deadman_trips": s.inputs.deadman_trips,
        "deadman_active": s.inputs.deadman_active,
        "islands": islands,
    })
}

/// An operator input.
pub fn input_json(c: &msgs::InputCommand) -> Value {
    match c {
        msgs::InputCommand::Joystick(j) => json!({
            "sequence": j.sequence,
            "source_id": j.source_id,
            "axes": j.axes(),
            "button_count": j.button_count,
            "buttons": j.buttons,
        }),
        msgs::InputCommand::Winch(w) => json!({
            "sequence": w.sequence,
            "source_id": w.source_id,
            "actuator": w.actuator.as_str(),
            "drum_speed": w.drum_speed,
        }),
        msgs::InputCommand::Boom(b) => json!({
            "sequence": b.sequence,
            "source_id": b.source_id,
            "targets": b.targets.iter().map(|t| json!({"actuator": t.actuator.as_str(), "value": t.value})).collect::<Vec<_>>(),
        }),
        msgs::InputCommand::Actuator(a) => json!({
            "sequence": a.sequence,
            "source_id": a.source_id,
            "actuator": a.actuator.as_str(),
            "mode": a.mode.name(),
            "value": a.value,
        }),
    }
}

fn vec3_schema() -> Value {
    json!({"type": "object", "properties": {"x": {"type": "number"}, "y": {"type": "number"}, "z": {"type": "number"}}})
}

fn quat_schema() -> Value {
    json!({"type": "object", "properties": {
        "x": {"type": "number"}, "y": {"type": "number"}, "z": {"type": "number"}, "w": {"type": "number"}}})
}

/// JSON schema of [`pose_json`].
pub fn pose_schema() -> Value {
    json!({
        "title": "pivotsim.PoseFrame",
        "description": "Every body's pose and velocity at the end of one step (world frame, SI units)",
        "type": "object",
        "properties": {
            "sequence": {"type": "integer"},
            "sim_time": {"type": "number"},
            "wall_time_ns": {"type": "integer"},
            "bodies": {"type": "array", "items": {"type": "object", "properties": {
                "id": {"type": "integer"},
                "name": {"type": "string"},
                "flags": {"type": "integer"},
                "position": vec3_schema(),
                "orientation": quat_schema(),
                "linear_velocity": vec3_schema(),
                "angular_velocity": vec3_schema(),
            }}},
        }
    })
}

/// JSON schema of [`stats_json`].
pub fn stats_schema() -> Value {
    let int = json!({"type": "integer"});
    let num = json!({"type": "number"});
    let rejected: serde_json::Map<String, Value> =
        msgs::RejectReason::ALL.iter().map(|r| (r.name().to_string(), int.clone())).collect();
    json!({
        "title": "pivotsim.SolverStats",
        "description": "Solver statistics of one step",
        "type": "object",
        "properties": {
            "sequence": int, "sim_time": num, "step_wall_us": num, "overruns": int,
            "total_rows": int, "total_bodies": int, "total_tight": int, "fallback_islands": int,
            "total_pivot_steps": int, "total_solve_us": num, "max_residual_rel": num,
            "inputs_accepted": int,
            "inputs_rejected": {"type": "object", "properties": rejected},
            "inputs_rejected_total": int,
            "deadman_trips": int, "deadman_active": {"type": "boolean"},
            "islands": {"type": "array", "items": {"type": "object", "properties": {
                "variant": {"type": "string"}, "status": {"type": "string"}, "fallback": {"type": "boolean"},
                "rows": int, "bodies": int, "pivot_steps": int, "tight": int, "iterations": int,
                "solve_us": num, "residual_rel": num,
            }}},
        }
    })
}

/// JSON schema of the scene description (`msgs::SceneDescription` as it serializes; the field
/// rules are those of `msgs/README.md`).
pub fn scene_schema() -> Value {
    let int = json!({"type": "integer"});
    let num = json!({"type": "number"});
    let s = json!({"type": "string"});
    let nums = |n: usize| json!({"type": "array", "items": num, "minItems": n, "maxItems": n});
    let names = |v: &[&str]| json!({"type": "string", "enum": v});
    let modes: Vec<&str> = msgs::ActuatorMode::ALL.iter().map(|m| m.name()).collect();
    let shape = |kind: &str, props: Value| {
        let mut p = props.as_object().cloned().unwrap_or_default();
        p.insert("type".into(), json!({"const": kind}));
        let required: Vec<String> = p.keys().cloned().collect();
        json!({"type": "object", "properties": p, "required": required})
    };
    let reference = json!({"type": "object", "properties": {"reference": s}, "required": ["reference"]});
    let inline_heights = json!({"type": "object", "properties": {"inline": {"type": "array", "items": num}}, "required": ["inline"]});
    let inline_mesh = json!({"type": "object", "required": ["inline"], "properties": {"inline": {"type": "object",
        "properties": {"vertices": {"type": "array", "items": nums(3)},
                       "triangles": {"type": "array", "items": {"type": "array", "items": int}}}}}});
    let shapes = vec![
        shape("ball", json!({"radius": num})),
        shape("box", json!({"half_extents": nums(3)})),
        shape("capsule", json!({"radius": num, "half_height": num})),
        shape("cylinder", json!({"radius": num, "half_height": num})),
        shape("convex_hull", json!({"vertices": {"type": "array", "items": nums(3)}})),
        shape(
            "heightfield",
            json!({"rows": int, "cols": int, "extent": nums(2), "heights": {"oneOf": [inline_heights, reference.clone()]}}),
        ),
        shape("trimesh", json!({"mesh": {"oneOf": [inline_mesh, reference]}})),
    ];
    let collider = json!({"type": "object", "properties": {
        "shape": {"oneOf": shapes}, "position": nums(3), "orientation": nums(4)}});
    let body = json!({"type": "object", "properties": {
        "id": int, "name": s, "kind": names(&["dynamic", "kinematic", "static"]), "mass": num,
        "colliders": {"type": "array", "items": collider}, "visuals": {"type": "array", "items": collider}}});
    let frame = json!({"type": "object", "properties": {
        "body": {"type": ["integer", "null"]}, "position": nums(3), "orientation": nums(4)}});
    let joint = json!({"type": "object", "properties": {
        "name": s, "kind": names(&["fixed", "hinge", "prismatic", "ball", "other"]),
        "parent": {"type": ["integer", "null"]}, "child": int, "frame": frame}});
    let ints = json!({"type": "array", "items": int});
    let sensor = json!({"type": "object", "properties": {
        "name": s,
        "kind": names(&["joint", "tension", "cylinder", "drum", "cable", "contact_sum", "tipping", "contacts"]),
        "joint": s, "joints": {"type": "array", "items": s}, "bodies": ints,
        "with": {"oneOf": [ints, {"type": "null"}]}, "touch": num}});
    let actuator = json!({"type": "object", "properties": {
        "name": s, "kind": names(&["motor", "winch"]), "joint": {"type": ["string", "null"]},
        "mode": names(&modes), "limits": {"oneOf": [nums(2), {"type": "null"}]}}});
    let input = json!({"oneOf": [
        {"type": "object", "properties": {"axis": int}, "required": ["axis"]},
        {"type": "object", "properties": {"button": int}, "required": ["button"]}]});
    let binding = json!({"type": "object", "properties": {
        "input": input, "actuator": s, "mode": names(&modes), "scale": num}});
    json!({
        "title": "pivotsim.SceneDescription",
        "description": "Everything a renderer needs about a world: bodies with their collision shapes, joints, actuators, the joystick mapping (SI units, z up; msgs/README.md)",
        "type": "object",
        "properties": {
            "world": s, "scene": s, "timestep": num, "gravity": nums(3),
            "bodies": {"type": "array", "items": body},
            "joints": {"type": "array", "items": joint},
            "actuators": {"type": "array", "items": actuator},
            "joystick": {"type": "array", "items": binding},
            "sensors": {"type": "array", "items": sensor},
        },
        "required": ["world", "scene", "timestep", "gravity", "bodies", "joints", "actuators", "joystick"],
    })
}

/// JSON schema of [`input_json`] for an input topic.
pub fn input_schema(topic: msgs::Topic) -> Value {
    let int = json!({"type": "integer"});
    let num = json!({"type": "number"});
    let s = json!({"type": "string"});
    let (title, props) = match topic {
        msgs::Topic::Joystick => (
            "pivotsim.Joystick",
            json!({"sequence": int, "source_id": int, "axes": {"type": "array", "items": num},
                   "button_count": int, "buttons": int}),
        ),
        msgs::Topic::Winch => (
            "pivotsim.WinchCommand",
            json!({"sequence": int, "source_id": int, "actuator": s, "drum_speed": num}),
        ),
        msgs::Topic::Boom => (
            "pivotsim.BoomCommand",
            json!({"sequence": int, "source_id": int, "targets": {"type": "array", "items": {"type": "object",
                   "properties": {"actuator": s, "value": num}}}}),
        ),
        _ => (
            "pivotsim.ActuatorCommand",
            json!({"sequence": int, "source_id": int, "actuator": s, "mode": s, "value": num}),
        ),
    };
    json!({"title": title, "type": "object", "properties": props})
}

/// Schema name of an input topic's channel.
pub fn input_schema_name(topic: msgs::Topic) -> &'static str {
    match topic {
        msgs::Topic::Joystick => "pivotsim.Joystick",
        msgs::Topic::Winch => "pivotsim.WinchCommand",
        msgs::Topic::Boom => "pivotsim.BoomCommand",
        _ => "pivotsim.ActuatorCommand",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scene_schema_names_every_field_of_a_description() {
        let scene = msgs::SceneDescription {
            world: "w".into(),
            scene: "s".into(),
            timestep: 0.01,
            bodies: vec![msgs::BodyInfo {
                id: 1,
                name: "b".into(),
                kind: msgs::BodyKind::Dynamic,
                mass: 1.0,
                visuals: Vec::new(),
                colliders: vec![msgs::Collider {
                    shape: msgs::Shape::Ball { radius: 0.5 },
                    position: [0.0; 3],
                    orientation: [0.0, 0.0, 0.0, 1.0],
                }],
            }],
            joints: vec![msgs::JointInfo {
                name: "j".into(),
                kind: msgs::JointKind::Hinge,
                parent: None,
                child: 1,
                frame: Some(msgs::JointFrame {
                    body: Some(1),
                    position: [0.0; 3],
                    orientation: [0.0, 0.0, 0.0, 1.0],
                }),
            }],
            actuators: vec![msgs::ActuatorInfo {
                name: "a".into(),
                kind: msgs::ActuatorKind::Motor,
                joint: Some("j".into()),
                mode: msgs::ActuatorMode::Velocity,
                limits: None,
            }],
            joystick: vec![msgs::JoystickBinding {
                input: msgs::JoystickInput::Axis(0),
                actuator: "a".into(),
                mode: msgs::ActuatorMode::Velocity,
                scale: 1.0,
            }],
            sensors: vec![msgs::SensorInfo::ContactSum { name: "c".into(), bodies: vec![1], with: None }],
            ..Default::default()
        };
        let v = serde_json::to_value(&scene).unwrap();
        let schema = scene_schema();
        let props = &schema["properties"];
        for (k, field) in v.as_object().unwrap() {
            let p = props.get(k).unwrap_or_else(|| panic!("{k} not in the schema"));
            if let Some(item) = field.as_array().and_then(|a| a.first()).and_then(|x| x.as_object()) {
                for kk in item.keys() {
                    assert!(p["items"]["properties"].get(kk).is_some(), "{k}.{kk} not in the schema");
                }
            }
        }
        let j = &v["joints"][0]["frame"];
        for kk in j.as_object().unwrap().keys() {
            assert!(
                props["joints"]["items"]["properties"]["frame"]["properties"].get(kk).is_some(),
                "frame.{kk}"
            );
        }
        // Every field but the optional `sensors` is required.
        let required = schema["required"].as_array().unwrap();
        assert_eq!(required.len() + 1, v.as_object().unwrap().len());
        assert!(!required.contains(&json!("sensors")));
    }

    #[test]
    fn pose_json_has_the_schema_fields() {
        let f = msgs::PoseFrame {
            sequence: 3,
            sim_time: 0.05,
            wall_time_ns: 7,
            bodies: vec![msgs::BodyPose { id: 1, position: [1.0, 2.0, 3.0], ..Default::default() }],
        };
        let mut buf = Vec::new();
        f.encode(&mut buf).unwrap();
        let v = msgs::PoseFrameView::parse(&buf).unwrap();
        let j = pose_json(&v, None, |_| true);
        assert_eq!(j["sequence"], 3);
        assert_eq!(j["bodies"][0]["name"], "body1");
        assert_eq!(j["bodies"][0]["position"]["z"], 3.0);
        let props = &pose_schema()["properties"];
        for k in j.as_object().unwrap().keys() {
            assert!(props.get(k).is_some(), "{k} not in the schema");
        }
    }

    #[test]
    fn stats_json_keys_are_in_the_schema() {
        let s = msgs::SolverStats::default();
        let j = stats_json(&s);
        let props = &stats_schema()["properties"];
        for k in j.as_object().unwrap().keys() {
            assert!(props.get(k).is_some(), "{k} not in the schema");
        }
    }
}
