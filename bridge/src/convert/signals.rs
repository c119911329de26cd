//! The operator signals: per-sensor wrenches in their joint frames, the channel array, contact arrows coloured by state, and events as `/rosout` lines.

use super::*;

/// Topic prefix of the per-sensor wrenches: `/pivotsim/signals/<sensor>`.
pub const WRENCH_TOPIC_PREFIX: &str = "/pivotsim/signals/";

/// At most this many wrench topics (publishers) exist at once; further force sensors are
/// counted in the bridge status (`wrench_sensors_refused`) and stay in `/pivotsim/signal_values`.
pub const MAX_WRENCH_TOPICS: usize = 64;

/// A sensor name as one ROS topic-name token (ROS 2 name rules: `[A-Za-z0-9_]`, not starting
/// with a digit, no repeated or trailing `_`): every other character (`.`, `-`, `/`) becomes `_`,
/// runs of `_` collapse into one, leading and trailing `_` are dropped, a leading digit gets an
/// `s` in front, and nothing left gives `sensor`. `hoist.rope-1` → `hoist_rope_1`, `2nd` → `s2nd`.
pub fn topic_token(name: &str) -> String {
    let mut out = String::with_capacity(name.len() + 1);
    for c in name.chars() {
        let c = if c.is_ascii_alphanumeric() { c } else { '_' };
        if c == '_' && (out.is_empty() || out.ends_with('_')) {
            continue;
        }
        out.push(c);
    }
    while out.ends_with('_') {
        out.pop();
    }
    if out.is_empty() {
        out.push_str("sensor");
    } else if out.starts_with(|c: char| c.is_ascii_digit()) {
        out.insert(0, 's');
    }
    out
}

/// The `/tf` frame id of a joint's frame (`joint/<joint name>`), published on `/tf_static` as a
/// child of the frame's body for every joint a joint, cylinder or drum sensor reads.
pub fn joint_frame_id(joint: &str) -> String {
    format!("joint/{joint}")
}

/// What a force sensor's wrench is, and in which frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WrenchKind {
    /// `fx fy fz tx ty tz`: a joint sensor, the joint's force and torque on the body its frame is
    /// fixed on (the joint's child, body `a` of the scene), torque about the anchor, in the
    /// joint's frame (x = the joint axis).
    Joint,
    /// `fx fy fz` without torques: a contact force sum, in the world frame.
    ContactSum,
    /// `force`: a cylinder sensor, the force along its joint's axis: the wrench's force is
    /// `(force, 0, 0)` in the joint's frame (the other components are not measured), torque 0.
    /// Only with a scene description that has sensors.
    Cylinder,
    /// `torque`: a drum sensor, the torque about its joint's axis: the wrench's torque is
    /// `(torque, 0, 0)` in the joint's frame (the other components are not measured), force 0.
    /// Only with a scene description that has sensors.
    Drum,
}

/// One force sensor of the signals frame and its wrench topic.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WrenchSensor {
    /// The sensor's name (the `{sensor}` of its channels).
    pub sensor: String,
    /// Topic: [`WRENCH_TOPIC_PREFIX`] + [`topic_token`] of the name (`_2`, `_3`, … appended when
    /// two names sanitize alike).
    pub topic: String,
    /// Joint reaction, contact sum, cylinder force or drum torque.
    pub kind: WrenchKind,
    /// The joint whose frame ([`joint_frame_id`]) the wrench is in, from the scene description;
    /// `None` for a contact sum, and for a joint sensor found without a description.
    pub joint: Option<String>,
    /// Channel indices of the wrench's `force.x force.y force.z torque.x torque.y torque.z`;
    /// `None`: not measured by this sensor, 0 in the wrench.
    pub channels: [Option<usize>; 6],
}

impl WrenchSensor {
    /// The `frame_id` of its wrench: `world_frame` for a contact sum; for the others the joint's
    /// frame `joint/<joint>` (on `/tf_static`). A joint sensor found without a scene description
    /// gets `joint_frame/<token>`, a frame on no `/tf`.
    pub fn frame_id(&self, world_frame: &str) -> String {
        match (self.kind, &self.joint) {
            (WrenchKind::ContactSum, _) => world_frame.to_string(),
            (_, Some(joint)) => joint_frame_id(joint),
            (_, None) => format!("joint_frame/{}", &self.topic[WRENCH_TOPIC_PREFIX.len()..]),
        }
    }
}

/// The channel layout of a scene's signals frames: the channel names in order (the frames of one
/// scene all have them), the force sensors found in them, and the names as one text.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SignalLayout {
    names: Vec<msgs::ActuatorName>,
    /// Force sensors, in channel order, at most [`MAX_WRENCH_TOPICS`].
    pub wrenches: Vec<WrenchSensor>,
    /// Force sensors beyond [`MAX_WRENCH_TOPICS`] (no topic).
    pub wrenches_refused: usize,
}

impl SignalLayout {
    /// The layout of `frame`'s channels, with the force sensors found in them.
    ///
    /// A sensor that `scene` lists is classified by its kind: `joint` (channels `fx fy fz tx ty
    /// tz`, in its joint's frame), `contact_sum` (`fx fy fz`, world frame), `cylinder` (`force`
    /// along its joint's axis) and `drum` (`torque` about it) are force sensors; the others
    /// (`tension`, `cable`, `tipping`, `contacts`) are not. A sensor the description does not list
    /// (no description, or one of an older server without sensors) is classified by its channel
    /// names: with `fx`, `fy` and `fz` it is a force sensor, with `tx`, `ty` and `tz` too a joint
    /// sensor in a frame the bridge does not know, without them a contact sum. A listed sensor
    /// whose channels are not those of its kind is no force sensor.
    pub fn new(frame: &msgs::SignalsFrame, scene: Option<&msgs::SceneDescription>) -> SignalLayout {
        let names: Vec<msgs::ActuatorName> = frame.channels.iter().map(|c| c.name).collect();
        // Sensors in order of first appearance, with the index of each of their channels.
        let mut sensors: Vec<(&str, HashMap<&str, usize>)> = Vec::new();
        for (i, n) in names.iter().enumerate() {
            let Some((sensor, channel)) = n.as_str().rsplit_once('/') else { continue };
            match sensors.iter_mut().find(|(s, _)| *s == sensor) {
                Some((_, m)) => {
                    m.entry(channel).or_insert(i);
                }
                None => sensors.push((sensor, HashMap::from([(channel, i)]))),
            }
        }
        let mut layout = SignalLayout::default();
        let mut taken: Vec<String> = Vec::new();
        for (sensor, ch) in &sensors {
            let get = |names: [&str; 6]| names.map(|n| if n.is_empty() { None } else { ch.get(n).copied() });
            let all = |c: &[Option<usize>; 6], n: usize| c.iter().filter(|i| i.is_some()).count() == n;
            let six = get(["fx", "fy", "fz", "tx", "ty", "tz"]);
            let three = get(["fx", "fy", "fz", "", "", ""]);
            let found = match scene.and_then(|d| d.sensor(sensor)) {
                Some(msgs::SensorInfo::Joint { joint, .. }) if all(&six, 6) => {
                    Some((WrenchKind::Joint, Some(joint.clone()), six))
                }
                Some(msgs::SensorInfo::ContactSum { .. }) if all(&three, 3) => {
                    Some((WrenchKind::ContactSum, None, three))
                }
                Some(msgs::SensorInfo::Cylinder { joint, .. }) => {
                    let c = get(["force", "", "", "", "", ""]);
                    all(&c, 1).then(|| (WrenchKind::Cylinder, Some(joint.clone()), c))
                }
                Some(msgs::SensorInfo::Drum { joint, .. }) => {
                    let c = get(["", "", "", "torque", "", ""]);
                    all(&c, 1).then(|| (WrenchKind::Drum, Some(joint.clone()), c))
                }
                Some(_) => None,
                None if all(&six, 6) => Some((WrenchKind::Joint, None, six)),
                None if all(&three, 3) => Some((WrenchKind::ContactSum, None, three)),
                None => None,
            };
            let Some((kind, joint, channels)) = found else { continue };
            if layout.wrenches.len() == MAX_WRENCH_TOPICS {
                layout.wrenches_refused += 1;
                continue;
            }
            let base = topic_token(sensor);
            let mut token = base.clone();
            let mut k = 1;
            while taken.contains(&token) {
                k += 1;
                token = format!("{base}_{k}");
            }
            taken.push(token.clone());
            layout.wrenches.push(WrenchSensor {
                sensor: sensor.to_string(),
                topic: format!("{WRENCH_TOPIC_PREFIX}{token}"),
                kind,
                joint,
                channels,
            });
        }
        layout.names = names;
        layout
    }

    /// Whether `frame` has exactly these channels (same names, same order).
    pub fn matches(&self, frame: &msgs::SignalsFrame) -> bool {
        self.names.len() == frame.channels.len()
            && self.names.iter().zip(&frame.channels).all(|(n, c)| *n == c.name)
    }

    /// The channel names, one per line, line `i` naming `data[i]` of `/pivotsim/signal_values`
    /// (published latched on `/pivotsim/signal_names`).
    pub fn names_text(&self) -> String {
        let names: Vec<&str> = self.names.iter().map(|n| n.as_str()).collect();
        names.join("\n")
    }
}

/// The joint frames on `/tf_static`: for every joint that a `joint`, `cylinder` or `drum` sensor
/// of the description reads (once per joint, in sensor order), its frame as a child of the frame's
/// body (`<body name>` → [`joint_frame_id`]), or of `world_frame` for a frame on the world.
/// Joints without a frame, or on a body the description does not have, are left out.
pub fn joint_frame_transforms(scene: &SceneInfo, stamp: Time, world_frame: &str) -> Vec<TransformStamped> {
    let frames = scene.description.sensed_joint_frames();
    frames
        .into_iter()
        .map(|(body, joint, f)| TransformStamped {
            header: Header {
                stamp,
                frame_id: body.map_or_else(|| world_frame.to_string(), |b| b.name.clone()),
            },
            child_frame_id: joint_frame_id(joint),
            transform: Transform {
                translation: Vector3 { x: f.position[0], y: f.position[1], z: f.position[2] },
                rotation: Quaternion::from_array(f.orientation),
            },
        })
        .collect()
}

/// The wrench of a force sensor in `frame` (N, N m; components its sensor does not measure are
/// 0), or `None` while one of its channels drops out (no reading) or the frame is not of the
/// layout's scene.
pub fn wrench(
    sensor: &WrenchSensor,
    frame: &msgs::SignalsFrame,
    stamp: Time,
    world_frame: &str,
) -> Option<WrenchStamped> {
    let mut v = [0.0; 6];
    for (k, i) in sensor.channels.iter().enumerate() {
        if let Some(i) = *i {
            let c = frame.channels.get(i)?;
            if c.dropout {
                return None;
            }
            v[k] = c.value;
        }
    }
    Some(WrenchStamped {
        header: Header { stamp, frame_id: sensor.frame_id(world_frame) },
        wrench: Wrench {
            force: Vector3 { x: v[0], y: v[1], z: v[2] },
            torque: Vector3 { x: v[3], y: v[4], z: v[5] },
        },
    })
}

/// `/pivotsim/signal_values`: every channel's value in channel order (`data[i]` is line `i` of
/// `/pivotsim/signal_names`), NaN while a channel drops out (a gap in a plot); one dimension
/// labelled `channels`. Reuses `out`'s vectors.
pub fn signals_array(frame: &msgs::SignalsFrame, out: &mut Float64MultiArray) {
    let n = frame.channels.len() as u32;
    out.layout.data_offset = 0;
    if out.layout.dim.len() == 1 && out.layout.dim[0].label == "channels" {
        out.layout.dim[0].size = n;
        out.layout.dim[0].stride = n;
    } else {
        out.layout.dim.clear();
        out.layout.dim.push(MultiArrayDimension { label: "channels".into(), size: n, stride: n });
    }
    out.data.clear();
    out.data.extend(frame.channels.iter().map(|c| if c.dropout { f64::NAN } else { c.value }));
}

/// Colour of a contact arrow: stick green, slip orange, open grey (open contacts are not drawn).
pub fn contact_color(state: msgs::ContactCode) -> ColorRGBA {
    match state {
        msgs::ContactCode::Stick => ColorRGBA { r: 0.1, g: 0.8, b: 0.1, a: 1.0 },
        msgs::ContactCode::Slip => ColorRGBA { r: 1.0, g: 0.45, b: 0.0, a: 1.0 },
        msgs::ContactCode::Open => ColorRGBA { r: 0.5, g: 0.5, b: 0.5, a: 1.0 },
    }
}

/// Namespace of the contact arrows on `/pivotsim/contact_markers`.
pub const CONTACTS_NS: &str = "contacts";

/// `/pivotsim/contact_markers`: a `DELETEALL` of namespace [`CONTACTS_NS`] (so that contacts that
/// vanished disappear), then one `ARROW` per pressed contact (stick or slip) in `world_frame`:
/// from the contact point to the point + force on B · `metres_per_newton`, shaft 1 cm, head 2 cm
/// wide, coloured by state ([`contact_color`]), id = the record's index. Open contacts and
/// forces under 1e-9 N are left out.
pub fn contact_markers(
    frame: &msgs::SignalsFrame,
    metres_per_newton: f64,
    stamp: Time,
    world_frame: &str,
) -> MarkerArray {
    let header = Header { stamp, frame_id: world_frame.to_string() };
    let mut markers = Vec::with_capacity(frame.contacts.len() + 1);
    markers.push(Marker {
        header: header.clone(),
        ns: CONTACTS_NS.into(),
        action: Marker::DELETEALL,
        ..Marker::default()
    });
    for (i, c) in frame.contacts.iter().enumerate() {
        let f = c.force();
        let n = dot(f, f).sqrt();
        if c.state == msgs::ContactCode::Open || !(n > 1e-9 && n.is_finite()) {
            continue;
        }
        let tip = std::array::from_fn(|k| c.point[k] + f[k] * metres_per_newton);
        markers.push(Marker {
            header: header.clone(),
            ns: CONTACTS_NS.into(),
            id: i as i32,
            type_: Marker::ARROW,
            action: Marker::ADD,
            scale: Vector3 { x: 0.01, y: 0.02, z: 0.0 },
            color: contact_color(c.state),
            points: vec![Point::from_array(c.point), Point::from_array(tip)],
            ..Marker::default()
        });
    }
    MarkerArray { markers }
}

/// The `/rosout` level of an event: a threshold raised, a fault, a refused fault or a lost
/// controller WARN, a threshold cleared or a controller joining INFO.
pub fn event_level(kind: msgs::EventCode) -> u8 {
    match kind {
        msgs::EventCode::Cleared | msgs::EventCode::ControllerJoined => Log::INFO,
        msgs::EventCode::Raised
        | msgs::EventCode::Fault
        | msgs::EventCode::FaultRejected
        | msgs::EventCode::ControllerLost => Log::WARN,
    }
}

/// One event as a `/rosout` line of logger `logger`: `pivotsim event <name> <kind> at t = <time> s:
/// value <value>, level <level>`, stamped `stamp`.
pub fn event_log(e: &msgs::EventRecord, stamp: Time, logger: &str) -> Log {
    Log {
        stamp,
        level: event_level(e.kind),
        name: logger.to_string(),
        msg: format!(
            "pivotsim event {} {} at t = {:.3} s: value {}, level {}",
            e.name.as_str(),
            e.kind.name(),
            e.time,
            e.value,
            e.level
        ),
        ..Log::default()
    }
}
