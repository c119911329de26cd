//! Signals and events frames as plottable JSON messages, with their JSON schemas: the channels
//! `/pivotsim/signals`, `/pivotsim/events` and `/pivotsim/contacts` of the live view and the
//! recording.
//!
//! A channel `{sensor}/{channel}` of the signals frame becomes the number
//! `values.{sensor}.{channel}` (a Foxglove message path such as
//! `/pivotsim/signals.values.forks_load.normal`); a channel without a `/` sits directly under
//! `values`. A dropped-out channel is `null` (a gap in the plot) and its name is listed in
//! `dropout`. The scene decides the sensor names, so the schema types `values` by its pattern
//! (objects of numbers) rather than by field.

use pivotsim_msgs as msgs;
use serde_json::{Map, Value, json};

use foxglove::schemas::{SceneUpdate, Timestamp};

use crate::util::body_name;

/// Length of the largest contact-force arrow of a frame (m): the arrows of a frame share one scale.
pub const LONGEST_ARROW: f64 = 0.5;

/// `{sensor}/{channel}` split at the first `/` (a name without one: `(None, name)`).
fn split(name: &str) -> (Option<&str>, &str) {
    match name.split_once('/') {
        Some((s, c)) => (Some(s), c),
        None => (None, name),
    }
}

/// The signals frame's channels: `values` by sensor and channel, the dropped-out names, counters.
pub fn signals_json(s: &msgs::SignalsFrame) -> Value {
    let mut values = Map::new();
    let mut dropout = Vec::new();
    for c in &s.channels {
        let v = if c.dropout {
            dropout.push(Value::from(c.name.as_str()));
            Value::Null
        } else {
            json!(c.value)
        };
        match split(c.name.as_str()) {
            (Some(sensor), channel) => {
                let entry = values.entry(sensor.to_string()).or_insert_with(|| Value::Object(Map::new()));
                if let Value::Object(m) = entry {
                    m.insert(channel.to_string(), v);
                }
            }
            (None, channel) => {
                values.insert(channel.to_string(), v);
            }
        }
    }
    json!({
        "sequence": s.sequence,
        "sim_time": s.sim_time,
        "events_total": s.events_total,
        "faults_applied": s.faults_applied,
        "faults_rejected": s.faults_rejected,
        "channel_count": s.channels.len(),
        "dropout_count": dropout.len(),
        "dropout": dropout,
        "values": values,
    })
}

/// JSON schema of [`signals_json`].
pub fn signals_schema() -> Value {
    let int = json!({"type": "integer"});
    let reading = json!({"type": ["number", "null"], "description": "the reading; null on a dropout"});
    json!({
        "title": "pivotsim.Signals",
        "description": "The sensor channels of one step (values.<sensor>.<channel>; null on a dropout)",
        "type": "object",
        "properties": {
            "sequence": int, "sim_time": {"type": "number"}, "events_total": int,
            "faults_applied": int, "faults_rejected": int, "channel_count": int, "dropout_count": int,
            "dropout": {"type": "array", "items": {"type": "string"}},
            "values": {
                "type": "object",
                "additionalProperties": {
                    "oneOf": [reading.clone(), {"type": "object", "additionalProperties": reading}]
                }
            },
        }
    })
}

/// The events frame: its events in order (one message per frame that carries events).
pub fn events_json(e: &msgs::EventsFrame) -> Value {
    let events: Vec<Value> = e
        .events
        .iter()
        .map(|r| {
            json!({"name": r.name.as_str(), "kind": r.kind.name(), "time": r.time, "value": r.value,
                "level": r.level})
        })
        .collect();
    json!({
        "sequence": e.sequence,
        "sim_time": e.sim_time,
        "events_total": e.events_total,
        "events": events,
    })
}

/// JSON schema of [`events_json`].
pub fn events_schema() -> Value {
    let int = json!({"type": "integer"});
    let num = json!({"type": "number"});
    let kinds: Vec<&str> = [
        msgs::EventCode::Raised,
        msgs::EventCode::Cleared,
        msgs::EventCode::Fault,
        msgs::EventCode::FaultRejected,
    ]
    .iter()
    .map(|k| k.name())
    .collect();
    json!({
        "title": "pivotsim.Events",
        "description": "Threshold crossings and faults of one step",
        "type": "object",
        "properties": {
            "sequence": int, "sim_time": num, "events_total": int,
            "events": {"type": "array", "items": {"type": "object", "properties": {
                "name": {"type": "string"}, "kind": {"type": "string", "enum": kinds},
                "time": num, "value": num, "level": num,
            }}},
        }
    })
}

/// The contact states of the signals frame (bodies named by the scene when known).
pub fn contacts_json(s: &msgs::SignalsFrame, scene: Option<&msgs::SceneDescription>) -> Value {
    let mut count = [0u32; 3];
    let contacts: Vec<Value> = s
        .contacts
        .iter()
        .map(|c| {
            count[c.state as usize] += 1;
            json!({
                "body_a": body_name(scene, c.body_a), "body_b": body_name(scene, c.body_b),
                "a": c.body_a, "b": c.body_b, "state": c.state.name(),
                "point": {"x": c.point[0], "y": c.point[1], "z": c.point[2]},
                "normal_force": c.normal_force, "friction_force": c.friction_force,
                "normal": {"x": c.normal[0], "y": c.normal[1], "z": c.normal[2]},
                "friction": {"x": c.friction[0], "y": c.friction[1], "z": c.friction[2]},
            })
        })
        .collect();
    json!({
        "sequence": s.sequence,
        "sim_time": s.sim_time,
        "open": count[msgs::ContactCode::Open as usize],
        "stick": count[msgs::ContactCode::Stick as usize],
        "slip": count[msgs::ContactCode::Slip as usize],
        "contacts": contacts,
    })
}

/// The contact forces on body B of each contact (`normal_force · normal + friction`, N) as arrows
/// at the contact points ([`super::scene::force_arrows`]), scaled so that the largest is
/// [`LONGEST_ARROW`] long, coloured by state as the ROS 2 bridge colours them: stick green, slip
/// orange; open contacts carry no force and draw nothing.
pub fn contact_forces(s: &msgs::SignalsFrame, stamp: Timestamp) -> SceneUpdate {
    use super::scene::{SLIP_COLOR, STICK_COLOR};
    let largest = s
        .contacts
        .iter()
        .map(|c| c.force().iter().map(|x| x * x).sum::<f64>().sqrt())
        .filter(|n| n.is_finite())
        .fold(0.0, f64::max);
    let scale = if largest > 1e-9 { LONGEST_ARROW / largest } else { 0.0 };
    let arrows = s.contacts.iter().filter_map(|c| match c.state {
        msgs::ContactCode::Open => None,
        msgs::ContactCode::Stick => Some((c.point, c.force(), STICK_COLOR)),
        msgs::ContactCode::Slip => Some((c.point, c.force(), SLIP_COLOR)),
    });
    super::scene::force_arrows(arrows, scale, stamp)
}

/// JSON schema of [`contacts_json`].
pub fn contacts_schema() -> Value {
    let int = json!({"type": "integer"});
    let num = json!({"type": "number"});
    json!({
        "title": "pivotsim.Contacts",
        "description": "Per contact point of one step: bodies, stick/slip/open, normal and friction force (N)",
        "type": "object",
        "properties": {
            "sequence": int, "sim_time": num, "open": int, "stick": int, "slip": int,
            "contacts": {"type": "array", "items": {"type": "object", "properties": {
                "body_a": {"type": "string"}, "body_b": {"type": "string"}, "a": int, "b": int,
                "state": {"type": "string", "enum": ["open", "stick", "slip"]},
                "point": {"type": "object", "properties": {"x": num, "y": num, "z": num}},
                "normal_force": num, "friction_force": num,
                "normal": {"type": "object", "properties": {"x": num, "y": num, "z": num}},
                "friction": {"type": "object", "properties": {"x": num, "y": num, "z": num}},
            }}},
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn name(s: &str) -> msgs::ActuatorName {
        msgs::ActuatorName::new(s).unwrap()
    }

    #[test]
    fn channels_nest_by_sensor_and_dropouts_are_null() {
        let s = msgs::SignalsFrame {
            sequence: 7,
            sim_time: 0.35,
            channels: vec![
                msgs::SignalChannel { name: name("forks_load/normal"), dropout: false, value: 4905.0 },
                msgs::SignalChannel { name: name("lift_l/force"), dropout: true, value: 0.0 },
                msgs::SignalChannel { name: name("bare"), dropout: false, value: 1.5 },
            ],
            contacts: vec![msgs::ContactRecord {
                body_a: 3,
                body_b: 0,
                state: msgs::ContactCode::Slip,
                point: [1.0, 2.0, 0.0],
                normal_force: 10.0,
                friction_force: 4.0,
                normal: [0.0, 0.0, 1.0],
                friction: [-4.0, 0.0, 0.0],
            }],
            ..Default::default()
        };
        let j = signals_json(&s);
        assert_eq!(j["values"]["forks_load"]["normal"], 4905.0);
        assert!(j["values"]["lift_l"]["force"].is_null());
        assert_eq!(j["values"]["bare"], 1.5);
        assert_eq!(j["dropout"], json!(["lift_l/force"]));
        assert_eq!((j["sequence"].as_u64(), j["dropout_count"].as_u64()), (Some(7), Some(1)));
        let c = contacts_json(&s, None);
        assert_eq!((c["slip"].as_u64(), c["stick"].as_u64()), (Some(1), Some(0)));
        assert_eq!(c["contacts"][0]["body_a"], "body3");
        assert_eq!(c["contacts"][0]["state"], "slip");
        assert_eq!(c["contacts"][0]["friction"]["x"], -4.0);
        // One arrow, at the point, along the total force (-4, 0, 10), the longest length.
        let u = contact_forces(&s, Timestamp::new(1, 0));
        let arrows = &u.entities[0].arrows;
        assert_eq!(arrows.len(), 1);
        let a = &arrows[0];
        assert!((a.shaft_length + a.head_length - LONGEST_ARROW).abs() < 1e-12);
        // Slipping: orange, as the ROS 2 path's (1, 0.45, 0); sticking: green (0.1, 0.8, 0.1).
        let slip = a.color.unwrap();
        assert_eq!((slip.r, slip.g, slip.b, slip.a), (1.0, 0.45, 0.0, 1.0));
        let mut stuck = s.clone();
        stuck.contacts[0].state = msgs::ContactCode::Stick;
        let green = contact_forces(&stuck, Timestamp::new(1, 0)).entities[0].arrows[0].color.unwrap();
        assert_eq!((green.r, green.g, green.b, green.a), (0.1, 0.8, 0.1, 1.0));
        let mut open = s.clone();
        open.contacts[0].state = msgs::ContactCode::Open;
        assert!(contact_forces(&open, Timestamp::new(1, 0)).entities[0].arrows.is_empty(), "open: no arrow");
        let p = a.pose.as_ref().unwrap().position.as_ref().unwrap();
        assert_eq!((p.x, p.y, p.z), (1.0, 2.0, 0.0));
        // The arrow's +x turned by its orientation is the force's direction.
        let q = a.pose.as_ref().unwrap().orientation.as_ref().unwrap();
        let x_axis = [
            1.0 - 2.0 * (q.y * q.y + q.z * q.z),
            2.0 * (q.x * q.y + q.w * q.z),
            2.0 * (q.x * q.z - q.w * q.y),
        ];
        let f = [-4.0, 0.0, 10.0f64];
        let n = (16.0f64 + 100.0).sqrt();
        for i in 0..3 {
            assert!((x_axis[i] - f[i] / n).abs() < 1e-12, "{x_axis:?}");
        }
        // Every field the messages carry is in the schemas.
        for (msg, schema) in [(&j, signals_schema()), (&c, contacts_schema())] {
            for k in msg.as_object().unwrap().keys() {
                assert!(schema["properties"].get(k).is_some(), "{k} not in {}", schema["title"]);
            }
        }
    }

    #[test]
    fn events_carry_name_kind_time_value_level() {
        let e = msgs::EventsFrame {
            sequence: 2,
            sim_time: 1.0,
            events_total: 1,
            events: vec![msgs::EventRecord {
                name: name("load-slipping"),
                kind: msgs::EventCode::Raised,
                time: 1.0,
                value: 1.0,
                level: 0.5,
            }],
        };
        let j = events_json(&e);
        assert_eq!(
            j["events"][0],
            json!({"name": "load-slipping", "kind": "raised", "time": 1.0, "value": 1.0, "level": 0.5})
        );
        let schema = events_schema();
        for k in j["events"][0].as_object().unwrap().keys() {
            assert!(schema["properties"]["events"]["items"]["properties"].get(k).is_some(), "{k}");
        }
    }
}
