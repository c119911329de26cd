//! The Foxglove channels of a world, one list for the live view (`foxglove`) and the recording
//! (`record`), so that one layout (`docs/foxglove/pivotsim-layout.json`) opens both.
//!
//! Topic names do not carry the world (it is in the server info and the MCAP metadata): a layout
//! then works for any world. They start with `/` as Foxglove's message paths expect.
//!
//! | topic | encoding | schema | content |
//! |---|---|---|---|
//! | `/tf` | protobuf | `foxglove.FrameTransforms` | every step: `world` → body name, one transform per body |
//! | `/pivotsim/scene` | protobuf | `foxglove.SceneUpdate` | the bodies' shapes, once per scene (and to each late subscriber) |
//! | `/pivotsim/description` | json | `pivotsim.SceneDescription` | the scene description, once per scene (and to each late subscriber) |
//! | `/pivotsim/poses` | json | `pivotsim.PoseFrame` | every step: every body's pose and velocities |
//! | `/pivotsim/stats` | json | `pivotsim.SolverStats` | every step: solver totals and islands, input counters (the Plot panel charts any number in it) |
//! | `/pivotsim/signals` | json | `pivotsim.Signals` | every step: the sensor channels, `values.<sensor>.<channel>` (null on a dropout), fault and event counters |
//! | `/pivotsim/contacts` | json | `pivotsim.Contacts` | every step: per contact the bodies, stick/slip/open, normal and friction force |
//! | `/pivotsim/contact_forces` | protobuf | `foxglove.SceneUpdate` | every step: the contact forces as arrows at the contact points (world frame) |
//! | `/pivotsim/events` | json | `pivotsim.Events` | each step that has events: name, kind, time, value, level |
//! | `/pivotsim/view_health` | json | `pivotsim.ViewHealth` | once a second (live view only): steps never received per stream, messages dropped towards viewers per topic, `lost` |
//! | `/pivotsim/cmd/joystick`, `…/winch`, `…/boom`, `…/actuator` | json | `pivotsim.Joystick`, … | operator inputs as seen (`record` only) |
//!
//! The signals, contacts and events messages are those of [`super::signals`].

use foxglove::{Encode, Schema};
use pivotsim_msgs::Topic;

use crate::tojson;

/// Body transforms.
pub const TF: &str = "/tf";
/// Body shapes as scene entities.
pub const SCENE: &str = "/pivotsim/scene";
/// The scene description.
pub const DESCRIPTION: &str = "/pivotsim/description";
/// Pose frames.
pub const POSES: &str = "/pivotsim/poses";
/// Solver stats.
pub const STATS: &str = "/pivotsim/stats";
/// The signals frame's channels as JSON (sensor values for the Plot panel).
pub const SIGNALS: &str = "/pivotsim/signals";
/// The signals frame's contact states as JSON.
pub const CONTACTS: &str = "/pivotsim/contacts";
/// The contact forces as arrows (`foxglove.SceneUpdate`).
pub const CONTACT_FORCES: &str = "/pivotsim/contact_forces";
/// The events frames as JSON.
pub const EVENTS: &str = "/pivotsim/events";
/// The live view's losses (live view only).
pub const VIEW_HEALTH: &str = "/pivotsim/view_health";

/// A channel: topic, message encoding and schema.
#[derive(Debug, Clone)]
pub struct ChannelSpec {
    /// Topic name.
    pub topic: String,
    /// Message encoding (`protobuf`, `json`).
    pub encoding: String,
    /// Schema (name, encoding, data).
    pub schema: Schema,
}

/// A channel of one of the SDK's well-known schemas (protobuf).
fn well_known<T: Encode>(topic: &str) -> ChannelSpec {
    ChannelSpec {
        topic: topic.to_string(),
        encoding: T::get_message_encoding(),
        schema: T::get_schema().expect("the SDK's well-known schemas carry their schema"),
    }
}

/// A JSON channel with its JSON schema.
fn json(topic: &str, name: &str, schema: &serde_json::Value) -> ChannelSpec {
    ChannelSpec {
        topic: topic.to_string(),
        encoding: "json".to_string(),
        schema: Schema::new(name, "jsonschema", serde_json::to_vec(schema).expect("a JSON value serializes")),
    }
}

/// `/tf`: `foxglove.FrameTransforms`.
pub fn tf() -> ChannelSpec {
    well_known::<foxglove::schemas::FrameTransforms>(TF)
}

/// `/pivotsim/scene`: `foxglove.SceneUpdate`.
pub fn scene() -> ChannelSpec {
    well_known::<foxglove::schemas::SceneUpdate>(SCENE)
}

/// `/pivotsim/description`: `pivotsim.SceneDescription` (JSON).
pub fn description() -> ChannelSpec {
    json(DESCRIPTION, "pivotsim.SceneDescription", &tojson::scene_schema())
}

/// `/pivotsim/poses`: `pivotsim.PoseFrame` (JSON).
pub fn poses() -> ChannelSpec {
    json(POSES, "pivotsim.PoseFrame", &tojson::pose_schema())
}

/// `/pivotsim/stats`: `pivotsim.SolverStats` (JSON).
pub fn stats() -> ChannelSpec {
    json(STATS, "pivotsim.SolverStats", &tojson::stats_schema())
}

/// `/pivotsim/signals`: `pivotsim.Signals` (JSON).
pub fn signals() -> ChannelSpec {
    json(SIGNALS, "pivotsim.Signals", &super::signals::signals_schema())
}

/// `/pivotsim/contacts`: `pivotsim.Contacts` (JSON).
pub fn contacts() -> ChannelSpec {
    json(CONTACTS, "pivotsim.Contacts", &super::signals::contacts_schema())
}

/// `/pivotsim/contact_forces`: `foxglove.SceneUpdate`.
pub fn contact_forces() -> ChannelSpec {
    well_known::<foxglove::schemas::SceneUpdate>(CONTACT_FORCES)
}

/// `/pivotsim/events`: `pivotsim.Events` (JSON).
pub fn events() -> ChannelSpec {
    json(EVENTS, "pivotsim.Events", &super::signals::events_schema())
}

/// `/pivotsim/view_health`: `pivotsim.ViewHealth` (JSON, live view only, once a second): per
/// stream the frames received and the steps never received, the inbox's drops, per topic the
/// messages relayed to and dropped towards viewers, and `lost` (all of it).
pub fn view_health() -> ChannelSpec {
    let count = serde_json::json!({"type": "integer", "minimum": 0});
    let stream =
        serde_json::json!({"type": "object", "properties": {"received": count, "never_received": count}});
    let topic = serde_json::json!({"type": "object", "properties": {"relayed": count, "dropped": count}});
    json(
        VIEW_HEALTH,
        "pivotsim.ViewHealth",
        &serde_json::json!({
            "type": "object",
            "properties": {
                "streams": {"type": "object", "properties": {"poses": stream, "stats": stream, "signals": stream}},
                "inbox_dropped": count,
                "viewers": {"type": "object", "additionalProperties": topic},
                "clients": count,
                "lost": count,
            },
        }),
    )
}

/// `/pivotsim/cmd/<input>`: the input topic's JSON channel.
pub fn input(topic: Topic) -> ChannelSpec {
    json(
        &format!("/pivotsim/{}", topic.suffix()),
        tojson::input_schema_name(topic),
        &tojson::input_schema(topic),
    )
}

/// A message of a well-known schema, encoded (protobuf).
pub fn encode<T: Encode>(msg: &T) -> Vec<u8> {
    let mut buf = Vec::with_capacity(msg.encoded_len().unwrap_or(256));
    // Encoding into a growable vector cannot run out of space.
    let _ = msg.encode(&mut buf);
    buf
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shipped layout plots only fields that its channels have: stats, signals and contacts
    /// fields of their schemas, and `values.<sensor>.<channel>` of sensors the shipped scenes
    /// declare; it shows the scene and the contact forces in the 3D panel.
    #[test]
    fn the_layout_plots_fields_of_its_channels() {
        let layout: serde_json::Value =
            serde_json::from_str(include_str!("../../../docs/foxglove/pivotsim-layout.json")).unwrap();
        let scenes = [
            include_str!("../../../scenes/forklift.toml"),
            include_str!("../../../scenes/crane.toml"),
            include_str!("../../../scenes/winch.toml"),
        ];
        let schemas = [
            (STATS, tojson::stats_schema()),
            (SIGNALS, super::super::signals::signals_schema()),
            (CONTACTS, super::super::signals::contacts_schema()),
        ];
        let (mut plotted, mut sensors) = (0, 0);
        for (id, panel) in layout["configById"].as_object().unwrap() {
            for p in panel["paths"].as_array().into_iter().flatten() {
                let path = p["value"].as_str().unwrap();
                let (schema, field) = schemas
                    .iter()
                    .find_map(|(t, s)| path.strip_prefix(&format!("{t}.")).map(|f| (s, f)))
                    .unwrap_or_else(|| panic!("{id}: {path} is on no channel of the layout"));
                if let Some(rest) = field.strip_prefix("values.") {
                    let (sensor, channel) = rest.split_once('.').unwrap();
                    let declared = format!("name = \"{sensor}\"");
                    assert!(scenes.iter().any(|s| s.contains(&declared)), "{id}: no sensor {sensor}");
                    assert!(!channel.is_empty() && !channel.contains('.'), "{id}: {path}");
                    sensors += 1;
                } else {
                    assert!(schema["properties"].get(field).is_some(), "{id}: {field} is not in the schema");
                }
                plotted += 1;
            }
        }
        assert!(plotted >= 10 && sensors >= 5, "{plotted} paths, {sensors} sensor channels");
        assert_eq!(layout["configById"]["3D!pivotsim"]["topics"][SCENE]["visible"], true);
        assert_eq!(layout["configById"]["3D!pivotsim"]["topics"][CONTACT_FORCES]["visible"], true);
        assert_eq!(layout["configById"]["3D!pivotsim"]["followTf"], crate::fox::WORLD_FRAME);
    }

    /// Every channel of the live view and the recording (the inputs of `record` too).
    fn all_channels() -> Vec<ChannelSpec> {
        let mut c = vec![
            tf(),
            scene(),
            description(),
            poses(),
            stats(),
            signals(),
            contacts(),
            contact_forces(),
            events(),
            view_health(),
        ];
        c.extend(Topic::INPUTS.iter().map(|t| input(*t)));
        c
    }

    /// The shipped live-view layout resolves against what this path publishes: its 3D topics are
    /// channels of the view, and each Plot path reaches a plottable value in the JSON messages the
    /// view makes from 2 s of at least one shipped scene (the server's engine, no transport) — the
    /// stats in every scene, the "contacts slipping" count too (every shipped scene with contacts
    /// declares a `contacts` sensor, and they have contact records).
    #[test]
    fn the_live_layout_resolves_against_what_the_view_publishes() {
        use pivotsim_tests::layout::{layout_refs, parse, plottable, resolve};
        use std::time::{Duration, Instant};
        let layout: serde_json::Value =
            serde_json::from_str(include_str!("../../../docs/foxglove/pivotsim-layout.json")).unwrap();
        let refs = layout_refs(&layout);
        let channels: Vec<String> = all_channels().into_iter().map(|c| c.topic).collect();
        for t in &refs.topics {
            assert!(channels.contains(t), "3D topic {t} is no channel of the view");
        }
        let mut scenes = Vec::new();
        for b in pivotsim_server::scene::BUILTIN {
            let world = pivotsim_msgs::WorldName::new(format!("live-layout-{}", b.name)).unwrap();
            let mut e = pivotsim_server::serve::Engine::new(b.name, world, Duration::from_secs(60)).unwrap();
            let t0 = Instant::now();
            for i in 0..120 {
                assert!(e.tick(t0 + Duration::from_secs_f64(i as f64 / 60.0)));
            }
            let d = pivotsim_msgs::SceneDescription::decode(e.description()).unwrap();
            let stats = pivotsim_msgs::SolverStats::decode(e.stats_frame()).unwrap();
            let sig = pivotsim_msgs::SignalsFrame::decode(e.signals_frame()).unwrap();
            let m: Vec<(&str, serde_json::Value)> = vec![
                (STATS, tojson::stats_json(&stats)),
                (SIGNALS, super::super::signals::signals_json(&sig)),
                (CONTACTS, super::super::signals::contacts_json(&sig, Some(&d))),
            ];
            scenes.push((b.name, m, sig.contacts.len()));
        }
        for (scene, _, contacts) in &scenes {
            println!("{scene}: {contacts} contact records");
            // The pendulum and the hanging chain touch nothing (and declare no `contacts` sensor).
            assert!(
                *contacts > 0 || matches!(*scene, "pendulum" | "hanging_chain"),
                "{scene}: no contact records"
            );
        }
        for (p, _) in &refs.plot_paths {
            let mp = parse(p).unwrap_or_else(|e| panic!("{e}"));
            assert!(channels.contains(&mp.topic), "{p}: no channel {}", mp.topic);
            let every = mp.topic == STATS || mp.topic == CONTACTS;
            let found: Vec<&str> = scenes
                .iter()
                .filter(|(scene, m, _)| {
                    let ok = m
                        .iter()
                        .filter(|(t, _)| *t == mp.topic)
                        .any(|(_, msg)| resolve(msg, &mp.steps).into_iter().any(plottable));
                    assert!(ok || !every, "{p}: nothing plottable in {scene}");
                    ok
                })
                .map(|(s, _, _)| *s)
                .collect();
            assert!(!found.is_empty(), "{p}: resolves in no shipped scene");
        }
        assert!(refs.plot_paths.len() >= 19, "{}", refs.plot_paths.len());
    }

    /// One topic name never carries two types across the two viewer paths: no topic of the live
    /// view or the recording is a topic of the ROS 2 bridge, but `/tf` — each path's transform
    /// tree (`foxglove.FrameTransforms` here, `tf2_msgs/msg/TFMessage` there), which Foxglove's 3D
    /// panel reads in either form.
    #[test]
    fn no_topic_carries_two_types_across_the_live_view_and_the_ros2_bridge() {
        let ros = pivotsim_ros2_bridge::topics::published();
        for c in all_channels() {
            let shared: Vec<&(&str, String)> = ros.iter().filter(|(t, _)| *t == c.topic).collect();
            if c.topic == TF {
                assert_eq!(shared.len(), 1);
                continue;
            }
            assert!(
                shared.is_empty(),
                "{} is {} here and {:?} on the ROS 2 path",
                c.topic,
                c.schema.name,
                shared
            );
            assert!(
                !c.topic.starts_with(pivotsim_ros2_bridge::topics::WRENCH_PREFIX),
                "{} is under the ROS 2 path's wrench topics",
                c.topic
            );
        }
    }

    #[test]
    fn well_known_channels_carry_protobuf_schemas() {
        for (spec, name) in [
            (tf(), "foxglove.FrameTransforms"),
            (scene(), "foxglove.SceneUpdate"),
            (contact_forces(), "foxglove.SceneUpdate"),
        ] {
            assert_eq!((spec.encoding.as_str(), spec.schema.encoding.as_str()), ("protobuf", "protobuf"));
            assert_eq!(spec.schema.name, name);
            assert!(!spec.schema.data.is_empty());
        }
        for spec in [description(), poses(), stats(), signals(), contacts(), events(), input(Topic::Boom)] {
            assert_eq!((spec.encoding.as_str(), spec.schema.encoding.as_str()), ("json", "jsonschema"));
            serde_json::from_slice::<serde_json::Value>(&spec.schema.data).unwrap();
        }
        assert_eq!(input(Topic::Winch).topic, "/pivotsim/cmd/winch");
    }
}
