//! pivotsim frames → ROS messages, and `sensor_msgs/Joy` → a pivotsim joystick frame. Pure
//! functions and small state (no DDS, no Zenoh): unit-tested here, used by the bridge loop.

use std::collections::HashMap;

use pivotsim_msgs as msgs;

use crate::ros_msgs::*;

/// Which clock stamps `/tf`, `/pivotsim/pose_array` and the diagnostics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StampSource {
    /// Simulation time (as on `/clock`; ROS nodes run with `use_sim_time:=true`).
    #[default]
    Sim,
    /// The server's wall clock at the end of the step (the pose frame's `wall_time_ns`).
    Wall,
}

impl StampSource {
    /// The stamp of a pose frame.
    pub fn stamp(self, sim_time: f64, wall_time_ns: u64) -> Time {
        match self {
            StampSource::Sim => Time::from_secs_f64(sim_time),
            StampSource::Wall => Time::from_nanos(wall_time_ns.min(i64::MAX as u64) as i64),
        }
    }
}

/// What the bridge knows of the served scene: body names and kinds by id, and its markers.
#[derive(Debug, Clone)]
pub struct SceneInfo {
    /// The description as received.
    pub description: msgs::SceneDescription,
    names: HashMap<u32, usize>,
}

impl SceneInfo {
    /// Indexes a description.
    pub fn new(description: msgs::SceneDescription) -> SceneInfo {
        let names = description.bodies.iter().enumerate().map(|(i, b)| (b.id, i)).collect();
        SceneInfo { description, names }
    }

    /// The body with this id.
    pub fn body(&self, id: u32) -> Option<&msgs::BodyInfo> {
        self.names.get(&id).map(|&i| &self.description.bodies[i])
    }

    /// Whether a pose frame's bodies are exactly this scene's (same ids, same count).
    pub fn matches(&self, frame: &msgs::PoseFrame) -> bool {
        frame.bodies.len() == self.description.bodies.len()
            && frame.bodies.iter().all(|b| self.names.contains_key(&b.id))
    }
}

/// Whether a body of a pose frame is static (by its flags or the scene's kind).
pub fn is_static(scene: &SceneInfo, body: &msgs::BodyPose) -> bool {
    body.flags & msgs::BODY_STATIC != 0
        || scene.body(body.id).is_some_and(|b| b.kind == msgs::BodyKind::Static)
}

fn transform(parent: &str, child: &str, stamp: Time, b: &msgs::BodyPose) -> TransformStamped {
    TransformStamped {
        header: Header { stamp, frame_id: parent.to_string() },
        child_frame_id: child.to_string(),
        transform: Transform {
            translation: Vector3 { x: b.position[0], y: b.position[1], z: b.position[2] },
            rotation: Quaternion::from_array(b.orientation),
        },
    }
}

/// The `/tf` message (moving bodies) and the `/tf_static` one (static bodies) of a pose frame:
/// one transform per body, `world_frame` → body name. Bodies unknown to the scene are skipped.
pub fn transforms(
    scene: &SceneInfo,
    frame: &msgs::PoseFrame,
    stamp: Time,
    world_frame: &str,
) -> (TFMessage, TFMessage) {
    let (mut moving, mut fixed) = (TFMessage::default(), TFMessage::default());
    for b in &frame.bodies {
        let Some(info) = scene.body(b.id) else { continue };
        let t = transform(world_frame, &info.name, stamp, b);
        if is_static(scene, b) { fixed.transforms.push(t) } else { moving.transforms.push(t) }
    }
    (moving, fixed)
}

/// `/pivotsim/pose_array`: every body's pose in the pose frame's order, in `world_frame`.
pub fn pose_array(frame: &msgs::PoseFrame, stamp: Time, world_frame: &str) -> PoseArray {
    PoseArray {
        header: Header { stamp, frame_id: world_frame.to_string() },
        poses: frame
            .bodies
            .iter()
            .map(|b| Pose {
                position: Point::from_array(b.position),
                orientation: Quaternion::from_array(b.orientation),
            })
            .collect(),
    }
}

fn color(kind: msgs::BodyKind) -> ColorRGBA {
    match kind {
        msgs::BodyKind::Static => ColorRGBA { r: 0.55, g: 0.55, b: 0.55, a: 1.0 },
        msgs::BodyKind::Dynamic => ColorRGBA { r: 0.95, g: 0.55, b: 0.1, a: 1.0 },
        msgs::BodyKind::Kinematic => ColorRGBA { r: 0.2, g: 0.5, b: 0.95, a: 1.0 },
    }
}

/// Rotates `v` by the unit quaternion `q = [x, y, z, w]`.
fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let (u, w) = ([q[0], q[1], q[2]], q[3]);
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    };
    let t = cross(u, v).map(|c| 2.0 * c);
    let ut = cross(u, t);
    [v[0] + w * t[0] + ut[0], v[1] + w * t[1] + ut[1], v[2] + w * t[2] + ut[2]]
}

/// Convex hulls with at most this many vertices are drawn as triangles (the faces are found by
/// brute force, O(n⁴)); larger ones as a sphere list of their vertices.
pub const HULL_TRIANGULATE_MAX: usize = 48;

/// Heightfields are drawn with at most this many samples along each side (strided).
pub const HEIGHTFIELD_MAX_SIDE: usize = 129;

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Outward triangles of the convex hull of `v` (brute force; coplanar faces may overlap, which
/// draws the same surface).
pub fn hull_triangles(v: &[[f64; 3]]) -> Vec<[usize; 3]> {
    let size = v.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-9);
    let eps = 1e-9 * size * size * size;
    let mut out = Vec::new();
    for i in 0..v.len() {
        for j in i + 1..v.len() {
            for k in j + 1..v.len() {
                let (e1, e2) = (sub(v[j], v[i]), sub(v[k], v[i]));
                let n = [
                    e1[1] * e2[2] - e1[2] * e2[1],
                    e1[2] * e2[0] - e1[0] * e2[2],
                    e1[0] * e2[1] - e1[1] * e2[0],
                ];
                if dot(n, n).sqrt() <= eps / size {
                    continue;
                }
                let (mut above, mut below) = (false, false);
                for p in v {
                    let d = dot(n, sub(*p, v[i]));
                    above |= d > eps;
                    below |= d < -eps;
                    if above && below {
                        break;
                    }
                }
                if !above {
                    out.push([i, j, k]);
                } else if !below {
                    out.push([i, k, j]);
                }
            }
        }
    }
    out
}

fn marker(body: &msgs::BodyInfo, id: i32, type_: i32, position: [f64; 3], orientation: [f64; 4]) -> Marker {
    Marker {
        header: Header { stamp: Time::default(), frame_id: body.name.clone() },
        ns: body.name.clone(),
        id,
        type_,
        action: Marker::ADD,
        pose: Pose {
            position: Point::from_array(position),
            orientation: Quaternion::from_array(orientation),
        },
        scale: Vector3 { x: 1.0, y: 1.0, z: 1.0 },
        color: color(body.kind),
        frame_locked: true,
        ..Marker::default()
    }
}

fn triangles(points: &mut Vec<Point>, v: &[[f64; 3]], tris: impl Iterator<Item = [usize; 3]>) {
    for t in tris {
        if t.iter().all(|&i| i < v.len()) {
            points.extend(t.iter().map(|&i| Point::from_array(v[i])));
        }
    }
}

/// The markers of one body: one or more per collider, in the body's frame (`frame_id` = body
/// name, `ns` = body name, id = 4 · collider index + part, frame-locked, stamp 0 = latest
/// transform). Shapes given by reference: meshes as `MESH_RESOURCE` with the reference as URI,
/// heightfields not drawn.
pub fn body_markers(body: &msgs::BodyInfo, out: &mut Vec<Marker>) {
    for (ci, c) in body.shapes().enumerate() {
        let id = 4 * ci as i32;
        let (p, q) = (c.position, c.orientation);
        match &c.shape {
            msgs::Shape::Ball { radius } => {
                let mut m = marker(body, id, Marker::SPHERE, p, q);
                m.scale = Vector3 { x: 2.0 * radius, y: 2.0 * radius, z: 2.0 * radius };
                out.push(m);
            }
            msgs::Shape::Box { half_extents: h } => {
                let mut m = marker(body, id, Marker::CUBE, p, q);
                m.scale = Vector3 { x: 2.0 * h[0], y: 2.0 * h[1], z: 2.0 * h[2] };
                out.push(m);
            }
            msgs::Shape::Cylinder { radius, half_height } | msgs::Shape::Capsule { radius, half_height } => {
                let mut m = marker(body, id, Marker::CYLINDER, p, q);
                m.scale = Vector3 { x: 2.0 * radius, y: 2.0 * radius, z: 2.0 * half_height };
                out.push(m);
                if matches!(c.shape, msgs::Shape::Capsule { .. }) {
                    for (part, s) in [(1, 1.0), (2, -1.0)] {
                        let off = rotate(q, [0.0, 0.0, s * half_height]);
                        let centre = [p[0] + off[0], p[1] + off[1], p[2] + off[2]];
                        let mut m = marker(body, id + part, Marker::SPHERE, centre, q);
                        m.scale = Vector3 { x: 2.0 * radius, y: 2.0 * radius, z: 2.0 * radius };
                        out.push(m);
                    }
                }
            }
            msgs::Shape::ConvexHull { vertices } => out.push(hull_marker(body, id, p, q, vertices)),
            msgs::Shape::Heightfield { rows, cols, extent, heights: msgs::HeightData::Inline(h) } => {
                let grid = (*rows as usize, *cols as usize, *extent);
                if let Some(m) = heightfield_marker(body, id, p, q, grid, h) {
                    out.push(m);
                }
            }
            msgs::Shape::Heightfield { heights: msgs::HeightData::Reference(_), .. } => {}
            msgs::Shape::Trimesh { mesh: msgs::MeshData::Inline { vertices, triangles: tris } } => {
                let mut m = marker(body, id, Marker::TRIANGLE_LIST, p, q);
                triangles(&mut m.points, vertices, tris.iter().map(|t| t.map(|i| i as usize)));
                out.push(m);
            }
            msgs::Shape::Trimesh { mesh: msgs::MeshData::Reference(uri) } => {
                let mut m = marker(body, id, Marker::MESH_RESOURCE, p, q);
                m.mesh_resource = uri.clone();
                out.push(m);
            }
        }
    }
}

/// A convex hull's marker: its faces when it has few vertices, else its vertices as dots.
fn hull_marker(body: &msgs::BodyInfo, id: i32, p: [f64; 3], q: [f64; 4], vertices: &[[f64; 3]]) -> Marker {
    if vertices.len() <= HULL_TRIANGULATE_MAX {
        let mut m = marker(body, id, Marker::TRIANGLE_LIST, p, q);
        triangles(&mut m.points, vertices, hull_triangles(vertices).into_iter());
        m
    } else {
        let mut m = marker(body, id, Marker::SPHERE_LIST, p, q);
        m.scale = Vector3 { x: 0.02, y: 0.02, z: 0.02 };
        m.points = vertices.iter().map(|v| Point::from_array(*v)).collect();
        m
    }
}

/// A heightfield's marker (`grid` = rows, cols, extent; `h` the heights): two triangles per cell
/// of the grid thinned to at most `HEIGHTFIELD_MAX_SIDE` samples a side (edges kept); `None`
/// unless the grid is at least 2 × 2 with one height per sample.
fn heightfield_marker(
    body: &msgs::BodyInfo,
    id: i32,
    p: [f64; 3],
    q: [f64; 4],
    (rows, cols, extent): (usize, usize, [f64; 2]),
    h: &[f64],
) -> Option<Marker> {
    if rows < 2 || cols < 2 || h.len() != rows * cols {
        return None;
    }
    let step = |n: usize| (n - 1).div_ceil(HEIGHTFIELD_MAX_SIDE - 1).max(1);
    let idx = |n: usize, s: usize| {
        let mut v: Vec<usize> = (0..n).step_by(s).collect();
        if *v.last().unwrap_or(&0) != n - 1 {
            v.push(n - 1);
        }
        v
    };
    let (rs, cs) = (idx(rows, step(rows)), idx(cols, step(cols)));
    let at = |r: usize, c: usize| {
        [
            -extent[0] / 2.0 + c as f64 * extent[0] / (cols - 1) as f64,
            -extent[1] / 2.0 + r as f64 * extent[1] / (rows - 1) as f64,
            h[r * cols + c],
        ]
    };
    let mut m = marker(body, id, Marker::TRIANGLE_LIST, p, q);
    for w in rs.windows(2) {
        for u in cs.windows(2) {
            let (a, b, c, d) = (at(w[0], u[0]), at(w[0], u[1]), at(w[1], u[1]), at(w[1], u[0]));
            for v in [a, b, c, a, c, d] {
                m.points.push(Point::from_array(v));
            }
        }
    }
    Some(m)
}

/// `/pivotsim/markers`: a `DELETEALL` (when `clear`: the scene changed) followed by every body's
/// markers.
pub fn scene_markers(scene: &SceneInfo, clear: bool) -> MarkerArray {
    let mut markers = Vec::new();
    if clear {
        markers.push(Marker { action: Marker::DELETEALL, ..Marker::default() });
    }
    for b in &scene.description.bodies {
        body_markers(b, &mut markers);
    }
    MarkerArray { markers }
}

/// Counters of the `/joy` path (bridge side), reported in the bridge's diagnostics and logs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct JoyCounters {
    /// Joy messages received from ROS.
    pub received: u64,
    /// Forwarded to the server as joystick frames.
    pub forwarded: u64,
    /// Rejected by the bridge, indexed by [`msgs::RejectReason::code`].
    pub rejected: [u64; msgs::REJECT_REASONS],
    /// Forwarded frames whose Zenoh put failed.
    pub put_failed: u64,
}

impl JoyCounters {
    /// All bridge-side rejections.
    pub fn rejected_total(&self) -> u64 {
        self.rejected.iter().sum()
    }

    /// Rejections for `reason`.
    pub fn rejected_for(&self, reason: msgs::RejectReason) -> u64 {
        self.rejected[reason.code() as usize]
    }
}

/// Turns `sensor_msgs/Joy` messages into joystick frames of one source: a fresh sequence number
/// per accepted message, the same validation as the server's (counts, finite, axes in [−1, 1],
/// buttons 0 or 1), rejections counted by reason.
#[derive(Debug, Clone)]
pub struct JoyTranslator {
    source_id: u32,
    sequence: u64,
    /// Counters so far.
    pub counters: JoyCounters,
}

impl JoyTranslator {
    /// A translator for frames of `source_id`.
    pub fn new(source_id: u32) -> JoyTranslator {
        JoyTranslator { source_id, sequence: 0, counters: JoyCounters::default() }
    }

    /// The source id of the frames.
    pub fn source_id(&self) -> u32 {
        self.source_id
    }

    /// Validates `joy` and encodes it as a joystick frame into `buf`, or counts and returns the
    /// reason it was rejected (`buf` is then empty).
    pub fn translate(&mut self, joy: &Joy, buf: &mut Vec<u8>) -> Result<(), msgs::RejectReason> {
        self.counters.received += 1;
        buf.clear();
        match self.frame(joy, buf) {
            Ok(()) => {
                self.counters.forwarded += 1;
                Ok(())
            }
            Err(reason) => {
                buf.clear();
                let c = &mut self.counters.rejected[reason.code() as usize];
                *c = c.saturating_add(1);
                Err(reason)
            }
        }
    }

    fn frame(&mut self, joy: &Joy, buf: &mut Vec<u8>) -> Result<(), msgs::RejectReason> {
        if joy.axes.len() > msgs::MAX_AXES || joy.buttons.len() > msgs::MAX_BUTTONS {
            return Err(msgs::RejectReason::Oversize);
        }
        if joy.axes.iter().any(|a| !a.is_finite()) {
            return Err(msgs::RejectReason::NonFinite);
        }
        if joy.axes.iter().any(|a| !(-1.0..=1.0).contains(a)) || joy.buttons.iter().any(|&b| b != 0 && b != 1)
        {
            return Err(msgs::RejectReason::OutOfRange);
        }
        let buttons = joy.buttons.iter().enumerate().fold(0u64, |m, (i, &b)| m | (u64::from(b == 1) << i));
        let j = msgs::Joystick::new(
            self.sequence + 1,
            self.source_id,
            &joy.axes,
            buttons,
            joy.buttons.len() as u8,
        )
        .ok_or(msgs::RejectReason::Oversize)?;
        msgs::InputCommand::Joystick(j).encode(buf).map_err(|e| e.reject_reason())?;
        self.sequence += 1;
        Ok(())
    }
}

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
    let d = &scene.description;
    let mut out: Vec<TransformStamped> = Vec::new();
    for s in &d.sensors {
        let (msgs::SensorInfo::Joint { joint, .. }
        | msgs::SensorInfo::Cylinder { joint, .. }
        | msgs::SensorInfo::Drum { joint, .. }) = s
        else {
            continue;
        };
        let child = joint_frame_id(joint);
        if out.iter().any(|t| t.child_frame_id == child) {
            continue;
        }
        let Some(f) = d.joint(joint).and_then(|j| j.frame.as_ref()) else { continue };
        let parent = match f.body {
            Some(id) => match scene.body(id) {
                Some(b) => b.name.clone(),
                None => continue,
            },
            None => world_frame.to_string(),
        };
        out.push(TransformStamped {
            header: Header { stamp, frame_id: parent },
            child_frame_id: child,
            transform: Transform {
                translation: Vector3 { x: f.position[0], y: f.position[1], z: f.position[2] },
                rotation: Quaternion::from_array(f.orientation),
            },
        });
    }
    out
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

fn kv(key: impl Into<String>, value: impl ToString) -> KeyValue {
    KeyValue { key: key.into(), value: value.to_string() }
}

/// Name of the solver status in `/pivotsim/diagnostics`.
pub const DIAG_SOLVER: &str = "pivotsim: solver";
/// Name of the server's input status in `/pivotsim/diagnostics`.
pub const DIAG_INPUTS: &str = "pivotsim: inputs";
/// Name of the signals status in `/pivotsim/diagnostics`: every channel `{sensor}/{channel}` → value.
pub const DIAG_SIGNALS: &str = "pivotsim: signals";
/// Name of the bridge's own status in `/pivotsim/diagnostics`.
pub const DIAG_BRIDGE: &str = "pivotsim-ros2-bridge";

/// What the bridge reports about itself.
#[derive(Debug, Clone, Default)]
pub struct BridgeHealth {
    /// World name.
    pub world: String,
    /// Scene name, once described.
    pub scene: Option<String>,
    /// Pose frames received over Zenoh.
    pub pose_frames: u64,
    /// Pose frames replaced before the ROS side took them (latest wins).
    pub pose_frames_skipped: u64,
    /// Seconds since the last frame from the server (`None`: none yet).
    pub server_silent_s: Option<f64>,
    /// ROS publishes that failed (would block, I/O).
    pub ros_publish_failed: u64,
    /// `/joy` counters.
    pub joy: JoyCounters,
    /// Joystick source id of the bridge.
    pub source_id: u32,
    /// Signals and events counters.
    pub signals: SignalCounters,
}

/// Counters of the signals and events path (bridge side).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SignalCounters {
    /// Signals frames received over Zenoh.
    pub signals_frames: u64,
    /// Signals frames replaced before the ROS side took them (latest wins).
    pub signals_frames_skipped: u64,
    /// Signals frames that did not decode (counted, dropped).
    pub signals_decode_failed: u64,
    /// Events frames received over Zenoh.
    pub events_frames: u64,
    /// Events frames dropped because the bridge's queue of them was full.
    pub events_frames_dropped: u64,
    /// Events frames that did not decode.
    pub events_decode_failed: u64,
    /// Events published on `/rosout`.
    pub events_logged: u64,
    /// Wrench topics (one per force sensor) that exist.
    pub wrench_topics: u64,
    /// Force sensors without a topic (beyond [`MAX_WRENCH_TOPICS`], or whose publisher failed).
    pub wrench_sensors_refused: u64,
}

/// `/pivotsim/diagnostics`: the server's solver and input statistics (from its latest stats frame, if
/// any), its sensor channels (from its latest signals frame, if any) and the bridge's own counters.
pub fn diagnostics(
    stats: Option<&msgs::SolverStats>,
    signals: Option<&msgs::SignalsFrame>,
    bridge: &BridgeHealth,
    stamp: Time,
) -> DiagnosticArray {
    let mut status = Vec::new();
    let hw = format!("pivotsim/{}", bridge.world);
    if let Some(s) = stats {
        let t = &s.totals;
        status.push(DiagnosticStatus {
            level: DiagnosticStatus::OK,
            name: DIAG_SOLVER.into(),
            message: format!("step {} at t = {:.3} s, {} islands", s.sequence, s.sim_time, s.islands.len()),
            hardware_id: hw.clone(),
            values: vec![
                kv("sequence", s.sequence),
                kv("sim_time_s", s.sim_time),
                kv("step_wall_us", s.step_wall_us),
                kv("overruns", s.overruns),
                kv("islands", s.islands.len()),
                kv("rows", t.rows),
                kv("bodies", t.bodies),
                kv("tight", t.tight),
                kv("fallback_islands", t.fallback_islands),
                kv("pivot_steps", t.pivot_steps),
                kv("solve_us", t.solve_us),
                kv("max_residual_rel", t.residual_rel_max),
            ],
        });
        let h = &s.inputs;
        let mut values = vec![kv("accepted", h.accepted), kv("rejected", h.rejected_total())];
        for r in msgs::RejectReason::ALL {
            values.push(kv(format!("rejected.{}", r.name()), h.rejected_for(*r)));
        }
        values.push(kv("deadman_trips", h.deadman_trips));
        values.push(kv("deadman_active", h.deadman_active));
        status.push(DiagnosticStatus {
            level: DiagnosticStatus::OK,
            name: DIAG_INPUTS.into(),
            message: if h.deadman_active {
                "deadman: actuators at neutral".into()
            } else {
                "operator input live".into()
            },
            hardware_id: hw.clone(),
            values,
        });
    }
    if let Some(f) = signals {
        let dropouts = f.channels.iter().filter(|c| c.dropout).count();
        let mut values = vec![kv("sequence", f.sequence), kv("sim_time_s", f.sim_time)];
        values.extend(
            f.channels
                .iter()
                .map(|c| kv(c.name.as_str(), if c.dropout { "dropout".into() } else { c.value.to_string() })),
        );
        values.push(kv("contacts", f.contacts.len()));
        for (key, state) in
            [("contacts_stick", msgs::ContactCode::Stick), ("contacts_slip", msgs::ContactCode::Slip)]
        {
            values.push(kv(key, f.contacts.iter().filter(|c| c.state == state).count()));
        }
        values.push(kv("dropout_count", dropouts));
        values.push(kv("events_total", f.events_total));
        values.push(kv("faults_applied", f.faults_applied));
        values.push(kv("faults_rejected", f.faults_rejected));
        status.push(DiagnosticStatus {
            level: if dropouts > 0 { DiagnosticStatus::WARN } else { DiagnosticStatus::OK },
            name: DIAG_SIGNALS.into(),
            message: if dropouts > 0 {
                format!("{} channels, {dropouts} dropped out", f.channels.len())
            } else {
                format!("{} channels, {} contacts", f.channels.len(), f.contacts.len())
            },
            hardware_id: hw.clone(),
            values,
        });
    }
    let j = &bridge.joy;
    let stale = bridge.server_silent_s.is_none_or(|s| s > 1.0);
    let mut values = vec![
        kv("world", &bridge.world),
        kv("scene", bridge.scene.as_deref().unwrap_or("")),
        kv(
            "server_silent_s",
            bridge.server_silent_s.map_or("never heard".to_string(), |s| format!("{s:.3}")),
        ),
        kv("pose_frames", bridge.pose_frames),
        kv("pose_frames_skipped", bridge.pose_frames_skipped),
        kv("ros_publish_failed", bridge.ros_publish_failed),
        kv("joy_source_id", bridge.source_id),
        kv("joy_received", j.received),
        kv("joy_forwarded", j.forwarded),
        kv("joy_put_failed", j.put_failed),
        kv("joy_rejected", j.rejected_total()),
    ];
    for r in msgs::RejectReason::ALL {
        values.push(kv(format!("joy_rejected.{}", r.name()), j.rejected_for(*r)));
    }
    let g = &bridge.signals;
    values.extend([
        kv("signals_frames", g.signals_frames),
        kv("signals_frames_skipped", g.signals_frames_skipped),
        kv("signals_decode_failed", g.signals_decode_failed),
        kv("events_frames", g.events_frames),
        kv("events_frames_dropped", g.events_frames_dropped),
        kv("events_decode_failed", g.events_decode_failed),
        kv("events_logged", g.events_logged),
        kv("wrench_topics", g.wrench_topics),
        kv("wrench_sensors_refused", g.wrench_sensors_refused),
    ]);
    status.push(DiagnosticStatus {
        level: if stale { DiagnosticStatus::STALE } else { DiagnosticStatus::OK },
        name: DIAG_BRIDGE.into(),
        message: if stale { "no frames from the server".into() } else { "bridging".into() },
        hardware_id: hw,
        values,
    });
    DiagnosticArray { header: Header { stamp, frame_id: String::new() }, status }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn joy(axes: Vec<f32>, buttons: Vec<i32>) -> Joy {
        Joy { header: Header::default(), axes, buttons }
    }

    #[test]
    fn joy_becomes_a_joystick_frame_with_fresh_sequences() {
        let mut t = JoyTranslator::new(77);
        let mut buf = Vec::new();
        t.translate(&joy(vec![0.5, -1.0], vec![0, 1, 1]), &mut buf).unwrap();
        let msgs::InputCommand::Joystick(j) = msgs::InputCommand::decode(&buf).unwrap() else { panic!() };
        assert_eq!(
            (j.sequence, j.source_id, j.axes(), j.buttons, j.button_count),
            (1, 77, &[0.5, -1.0][..], 0b110, 3)
        );
        t.translate(&joy(vec![], vec![]), &mut buf).unwrap();
        assert_eq!(msgs::InputCommand::decode(&buf).unwrap().sequence(), 2);
        assert_eq!(t.counters.forwarded, 2);
    }

    #[test]
    fn malformed_joy_is_rejected_and_counted_by_reason() {
        let mut t = JoyTranslator::new(1);
        let mut buf = Vec::new();
        let r = msgs::RejectReason::Oversize;
        assert_eq!(t.translate(&joy(vec![0.0; 33], vec![]), &mut buf), Err(r));
        assert!(buf.is_empty());
        assert_eq!(t.translate(&joy(vec![], vec![0; 65]), &mut buf), Err(r));
        assert_eq!(
            t.translate(&joy(vec![0.0, f32::NAN], vec![]), &mut buf),
            Err(msgs::RejectReason::NonFinite)
        );
        assert_eq!(
            t.translate(&joy(vec![f32::INFINITY], vec![]), &mut buf),
            Err(msgs::RejectReason::NonFinite)
        );
        assert_eq!(t.translate(&joy(vec![1.5], vec![]), &mut buf), Err(msgs::RejectReason::OutOfRange));
        assert_eq!(t.translate(&joy(vec![], vec![2]), &mut buf), Err(msgs::RejectReason::OutOfRange));
        assert_eq!(t.counters.rejected_for(r), 2);
        assert_eq!(t.counters.rejected_for(msgs::RejectReason::NonFinite), 2);
        assert_eq!(t.counters.rejected_total(), 6);
        assert_eq!((t.counters.received, t.counters.forwarded), (6, 0));
        // 32 axes is the most a frame carries: accepted, sequence 1.
        t.translate(&joy(vec![0.25; 32], vec![1; 64]), &mut buf).unwrap();
        assert_eq!(msgs::InputCommand::decode(&buf).unwrap().sequence(), 1);
    }

    #[test]
    fn hull_of_a_tetrahedron_has_four_outward_faces() {
        let v = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let t = hull_triangles(&v);
        assert_eq!(t.len(), 4);
        let c = [0.25, 0.25, 0.25];
        for [a, b, d] in t {
            let (e1, e2) = (sub(v[b], v[a]), sub(v[d], v[a]));
            let n =
                [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
            assert!(dot(n, sub(v[a], c)) > 0.0, "outward");
        }
    }

    #[test]
    fn rotate_turns_z_onto_minus_y_about_x() {
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let r = rotate([h, 0.0, 0.0, h], [0.0, 0.0, 1.0]);
        assert!((r[0]).abs() < 1e-12 && (r[1] + 1.0).abs() < 1e-12 && r[2].abs() < 1e-12, "{r:?}");
    }

    #[test]
    fn markers_cover_every_shape_in_the_body_frame() {
        let q = [0.0, 0.0, 0.0, 1.0];
        let col = |shape| msgs::Collider { shape, position: [0.0, 0.0, 0.5], orientation: q };
        let body = msgs::BodyInfo {
            id: 3,
            name: "hook".into(),
            kind: msgs::BodyKind::Dynamic,
            mass: 1.0,
            visuals: Vec::new(),
            colliders: vec![
                col(msgs::Shape::Box { half_extents: [1.0, 2.0, 3.0] }),
                col(msgs::Shape::Capsule { radius: 0.1, half_height: 0.2 }),
                col(msgs::Shape::Heightfield {
                    rows: 2,
                    cols: 3,
                    extent: [2.0, 1.0],
                    heights: msgs::HeightData::Inline(vec![0.0; 6]),
                }),
                col(msgs::Shape::Trimesh { mesh: msgs::MeshData::Reference("file:///m.stl".into()) }),
            ],
        };
        let mut m = Vec::new();
        body_markers(&body, &mut m);
        let kinds: Vec<_> = m.iter().map(|m| (m.id, m.type_)).collect();
        assert_eq!(
            kinds,
            [
                (0, Marker::CUBE),
                (4, Marker::CYLINDER),
                (5, Marker::SPHERE),
                (6, Marker::SPHERE),
                (8, Marker::TRIANGLE_LIST),
                (12, Marker::MESH_RESOURCE)
            ]
        );
        assert_eq!(m[0].scale, Vector3 { x: 2.0, y: 4.0, z: 6.0 });
        assert!(m.iter().all(|m| m.header.frame_id == "hook" && m.ns == "hook" && m.frame_locked));
        assert!((m[2].pose.position.z - 0.7).abs() < 1e-12 && (m[3].pose.position.z - 0.3).abs() < 1e-12);
        assert_eq!(m[4].points.len(), 2 * 2 * 3);
        assert_eq!(m[5].mesh_resource, "file:///m.stl");
    }

    fn channel(name: &str, value: f64) -> msgs::SignalChannel {
        msgs::SignalChannel { name: msgs::ActuatorName::new(name).unwrap(), dropout: false, value }
    }

    /// A joint sensor `hoist.rope`, a contact sum `support`, a scalar tension and a cylinder
    /// force, with one stick, one slip and one open contact.
    fn signals_frame() -> msgs::SignalsFrame {
        let mut channels = Vec::new();
        for (c, v) in [("fx", 1.0), ("fy", -2.0), ("fz", 49.05), ("tx", 0.5), ("ty", 0.25), ("tz", -0.125)] {
            channels.push(channel(&format!("hoist.rope/{c}"), v));
        }
        for (c, v) in
            [("fx", 3.0), ("fy", 0.0), ("fz", 98.1), ("normal", 98.1), ("friction", 3.0), ("points", 4.0)]
        {
            channels.push(channel(&format!("support/{c}"), v));
        }
        channels.push(channel("rope/tension", 49.1));
        channels.push(channel("lift/force", 1200.0));
        let contact = |state, point: [f64; 3], normal_force, friction: [f64; 3]| msgs::ContactRecord {
            body_a: 1,
            body_b: 2,
            state,
            point,
            normal_force,
            friction_force: friction.iter().map(|x| x * x).sum::<f64>().sqrt(),
            normal: [0.0, 0.0, 1.0],
            friction,
        };
        msgs::SignalsFrame {
            sequence: 9,
            sim_time: 1.5,
            channels,
            contacts: vec![
                contact(msgs::ContactCode::Stick, [1.0, 2.0, 0.5], 100.0, [0.0, 0.0, 0.0]),
                contact(msgs::ContactCode::Slip, [-1.0, 0.0, 0.0], 50.0, [20.0, -10.0, 0.0]),
                contact(msgs::ContactCode::Open, [0.0, 0.0, 0.0], 0.0, [0.0, 0.0, 0.0]),
            ],
            ..Default::default()
        }
    }

    #[test]
    fn sensor_names_become_valid_topic_tokens() {
        assert_eq!(topic_token("hoist.rope-1"), "hoist_rope_1");
        assert_eq!(topic_token("forks_load"), "forks_load");
        assert_eq!(topic_token("2nd"), "s2nd");
        assert_eq!(topic_token("a//b"), "a_b");
        assert_eq!(topic_token("_x__y_"), "x_y");
        assert_eq!(topic_token("-./"), "sensor");
        assert_eq!(crate::topics::wrench("boom/left"), "/pivotsim/signals/boom_left");
        for name in ["hoist.rope-1", "2nd", "a//b", "-./", "x"] {
            let t = crate::topics::wrench(name);
            assert!(ros2_name_ok(&t), "{t}");
        }
    }

    /// The ROS 2 topic name rules the tokens must meet.
    fn ros2_name_ok(t: &str) -> bool {
        t.starts_with('/')
            && !t.ends_with('/')
            && !t.contains("//")
            && !t.contains("__")
            && t.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '/')
            && t[1..].split('/').all(|tok| !tok.is_empty() && !tok.starts_with(|c: char| c.is_ascii_digit()))
    }

    /// The channel indices of a wrench of force channels `f` and torque channels `t`.
    fn ch(f: Option<[usize; 3]>, t: Option<[usize; 3]>) -> [Option<usize>; 6] {
        let mut c = [None; 6];
        for (k, i) in f.into_iter().flatten().chain(t.into_iter().flatten()).enumerate() {
            c[if f.is_some() { k } else { k + 3 }] = Some(i);
        }
        c
    }

    #[test]
    fn without_a_description_force_sensors_are_found_by_their_channels() {
        let f = signals_frame();
        let l = SignalLayout::new(&f, None);
        assert!(l.matches(&f));
        assert_eq!(l.wrenches_refused, 0);
        assert_eq!(
            l.wrenches,
            [
                WrenchSensor {
                    sensor: "hoist.rope".into(),
                    topic: "/pivotsim/signals/hoist_rope".into(),
                    kind: WrenchKind::Joint,
                    joint: None,
                    channels: ch(Some([0, 1, 2]), Some([3, 4, 5])),
                },
                WrenchSensor {
                    sensor: "support".into(),
                    topic: "/pivotsim/signals/support".into(),
                    kind: WrenchKind::ContactSum,
                    joint: None,
                    channels: ch(Some([6, 7, 8]), None),
                },
            ]
        );
        assert_eq!(l.wrenches[0].frame_id("world"), "joint_frame/hoist_rope");
        assert_eq!(l.wrenches[1].frame_id("map"), "map");
        let names = l.names_text();
        assert_eq!(names.split('\n').count(), 14, "one line per channel, no trailing newline");
        assert_eq!(names.lines().nth(12), Some("rope/tension"));
        // Another order of the same names is another layout.
        let mut g = f.clone();
        g.channels.swap(12, 13);
        assert!(!l.matches(&g));
        g.channels.pop();
        assert!(!l.matches(&g));
        // A description without sensors (an older server): the same.
        let d = description();
        let old = msgs::SceneDescription { sensors: vec![], ..d };
        assert_eq!(SignalLayout::new(&f, Some(&old)), l);
    }

    /// The scene of [`signals_frame`]: a static `beam`, a `hook` hanging from it on the ball joint
    /// `rope` (frame on the hook, rotated), a `crate`, a `cylinder` body on the prismatic `lift`
    /// to the world (frame on the world), a `drum` on the hinge `reel`, and sensors of several
    /// kinds (two joint sensors on `rope`).
    fn description() -> msgs::SceneDescription {
        let body = |id, name: &str, kind| msgs::BodyInfo {
            id,
            name: name.into(),
            kind,
            mass: if kind == msgs::BodyKind::Dynamic { 1.0 } else { 0.0 },
            visuals: Vec::new(),
            colliders: vec![],
        };
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let d = msgs::SceneDescription {
            world: "w".into(),
            scene: "s".into(),
            timestep: 0.01,
            gravity: [0.0, 0.0, -9.81],
            bodies: vec![
                body(4, "beam", msgs::BodyKind::Static),
                body(5, "hook", msgs::BodyKind::Dynamic),
                body(6, "crate", msgs::BodyKind::Dynamic),
                body(7, "cylinder", msgs::BodyKind::Dynamic),
                body(8, "drum", msgs::BodyKind::Dynamic),
            ],
            joints: vec![
                msgs::JointInfo {
                    name: "rope".into(),
                    kind: msgs::JointKind::Ball,
                    parent: Some(4),
                    child: 5,
                    frame: Some(msgs::JointFrame {
                        body: Some(5),
                        position: [0.0, 0.0, 1.0],
                        orientation: [0.0, h, 0.0, h],
                    }),
                },
                msgs::JointInfo {
                    name: "lift".into(),
                    kind: msgs::JointKind::Prismatic,
                    parent: None,
                    child: 7,
                    frame: Some(msgs::JointFrame {
                        body: None,
                        position: [3.0, 0.0, 0.5],
                        orientation: [0.0, 0.0, 0.0, 1.0],
                    }),
                },
                msgs::JointInfo {
                    name: "reel".into(),
                    kind: msgs::JointKind::Hinge,
                    parent: None,
                    child: 8,
                    frame: Some(msgs::JointFrame {
                        body: Some(8),
                        position: [0.0; 3],
                        orientation: [0.0, 0.0, 0.0, 1.0],
                    }),
                },
            ],
            sensors: vec![
                msgs::SensorInfo::Joint { name: "hoist.rope".into(), joint: "rope".into() },
                msgs::SensorInfo::ContactSum { name: "support".into(), bodies: vec![6], with: None },
                msgs::SensorInfo::Tension { name: "rope".into(), joint: "rope".into() },
                msgs::SensorInfo::Cylinder { name: "lift".into(), joint: "lift".into() },
                msgs::SensorInfo::Drum { name: "spool".into(), joint: "reel".into() },
                msgs::SensorInfo::Joint { name: "rope.again".into(), joint: "rope".into() },
            ],
            ..Default::default()
        };
        d.validate().unwrap_or_else(|e| panic!("{e}"));
        d
    }

    #[test]
    fn with_a_description_force_sensors_are_classified_by_their_kind() {
        let f = signals_frame();
        let d = description();
        let l = SignalLayout::new(&f, Some(&d));
        let got: Vec<_> =
            l.wrenches.iter().map(|w| (w.sensor.as_str(), w.kind, w.joint.as_deref())).collect();
        assert_eq!(
            got,
            [
                ("hoist.rope", WrenchKind::Joint, Some("rope")),
                ("support", WrenchKind::ContactSum, None),
                ("lift", WrenchKind::Cylinder, Some("lift")),
            ]
        );
        assert_eq!(l.wrenches[0].channels, ch(Some([0, 1, 2]), Some([3, 4, 5])));
        assert_eq!(l.wrenches[2].channels, [Some(13), None, None, None, None, None]);
        let frames: Vec<String> = l.wrenches.iter().map(|w| w.frame_id("world")).collect();
        assert_eq!(frames, ["joint/rope", "world", "joint/lift"]);
        // The tension is no wrench though it has a joint; the drum `spool` has no channel here.
        // A listed sensor whose channels are not those of its kind is no force sensor; one the
        // description does not list falls back to the channel names.
        let mut d2 = d.clone();
        d2.sensors[0] =
            msgs::SensorInfo::ContactSum { name: "hoist.rope".into(), bodies: vec![6], with: None };
        d2.sensors[1] = msgs::SensorInfo::Joint { name: "other".into(), joint: "rope".into() };
        let l2 = SignalLayout::new(&f, Some(&d2));
        let got: Vec<_> =
            l2.wrenches.iter().map(|w| (w.sensor.as_str(), w.kind, w.joint.as_deref())).collect();
        assert_eq!(
            got,
            [
                ("hoist.rope", WrenchKind::ContactSum, None),
                ("support", WrenchKind::ContactSum, None),
                ("lift", WrenchKind::Cylinder, Some("lift")),
            ]
        );
        let mut d3 = d.clone();
        d3.sensors[0] = msgs::SensorInfo::Tipping { name: "hoist.rope".into(), bodies: vec![5], touch: 0.0 };
        assert!(SignalLayout::new(&f, Some(&d3)).wrenches.iter().all(|w| w.sensor != "hoist.rope"));
    }

    #[test]
    fn joint_frames_go_on_tf_static_under_their_body_once_each() {
        let d = description();
        let scene = SceneInfo::new(d);
        let stamp = Time { sec: 2, nanosec: 0 };
        let t = joint_frame_transforms(&scene, stamp, "map");
        let h = std::f64::consts::FRAC_1_SQRT_2;
        // `rope` once (two joint sensors read it), `lift` under the world frame, `reel` for the drum.
        assert_eq!(
            t,
            [
                TransformStamped {
                    header: Header { stamp, frame_id: "hook".into() },
                    child_frame_id: "joint/rope".into(),
                    transform: Transform {
                        translation: Vector3 { x: 0.0, y: 0.0, z: 1.0 },
                        rotation: Quaternion::from_array([0.0, h, 0.0, h]),
                    },
                },
                TransformStamped {
                    header: Header { stamp, frame_id: "map".into() },
                    child_frame_id: "joint/lift".into(),
                    transform: Transform {
                        translation: Vector3 { x: 3.0, y: 0.0, z: 0.5 },
                        rotation: Quaternion::from_array([0.0, 0.0, 0.0, 1.0]),
                    },
                },
                TransformStamped {
                    header: Header { stamp, frame_id: "drum".into() },
                    child_frame_id: "joint/reel".into(),
                    transform: Transform {
                        translation: Vector3::default(),
                        rotation: Quaternion::from_array([0.0, 0.0, 0.0, 1.0]),
                    },
                },
            ]
        );
        // Without sensors, or without frames, no joint frames.
        let mut d = scene.description.clone();
        d.joints.iter_mut().for_each(|j| j.frame = None);
        d.sensors.retain(|s| matches!(s, msgs::SensorInfo::ContactSum { .. }));
        assert!(joint_frame_transforms(&SceneInfo::new(d), stamp, "map").is_empty());
    }

    #[test]
    fn alike_names_get_distinct_topics_and_the_count_is_bounded() {
        let mut f = msgs::SignalsFrame::default();
        for s in ["a-b", "a.b"] {
            for c in ["fx", "fy", "fz"] {
                f.channels.push(channel(&format!("{s}/{c}"), 0.0));
            }
        }
        let l = SignalLayout::new(&f, None);
        let topics: Vec<&str> = l.wrenches.iter().map(|w| w.topic.as_str()).collect();
        assert_eq!(topics, ["/pivotsim/signals/a_b", "/pivotsim/signals/a_b_2"]);
        let mut f = msgs::SignalsFrame::default();
        for i in 0..MAX_WRENCH_TOPICS + 6 {
            for c in ["fx", "fy", "fz"] {
                f.channels.push(channel(&format!("s{i}/{c}"), 0.0));
            }
        }
        let l = SignalLayout::new(&f, None);
        assert_eq!((l.wrenches.len(), l.wrenches_refused), (MAX_WRENCH_TOPICS, 6));
    }

    #[test]
    fn wrench_carries_the_channels_in_their_frame() {
        let f = signals_frame();
        let l = SignalLayout::new(&f, None);
        let stamp = Time { sec: 1, nanosec: 500_000_000 };
        let w = wrench(&l.wrenches[0], &f, stamp, "world").unwrap();
        assert_eq!(
            w,
            WrenchStamped {
                header: Header { stamp, frame_id: "joint_frame/hoist_rope".into() },
                wrench: Wrench {
                    force: Vector3 { x: 1.0, y: -2.0, z: 49.05 },
                    torque: Vector3 { x: 0.5, y: 0.25, z: -0.125 },
                },
            }
        );
        let w = wrench(&l.wrenches[1], &f, stamp, "world").unwrap();
        assert_eq!(w.header.frame_id, "world");
        assert_eq!(
            w.wrench,
            Wrench { force: Vector3 { x: 3.0, y: 0.0, z: 98.1 }, torque: Vector3::default() }
        );
        // A dropped-out channel: no wrench.
        let mut g = f.clone();
        g.channels[4] = msgs::SignalChannel { dropout: true, value: 0.0, ..g.channels[4] };
        assert!(wrench(&l.wrenches[0], &g, stamp, "world").is_none());
        assert!(wrench(&l.wrenches[1], &g, stamp, "world").is_some());
        // A frame of fewer channels than the layout: no wrench, no panic.
        g.channels.truncate(7);
        assert!(wrench(&l.wrenches[1], &g, stamp, "world").is_none());
    }

    #[test]
    fn described_wrenches_are_in_the_joint_frames_and_axial_ones_along_x() {
        let mut f = signals_frame();
        f.channels.push(channel("spool/torque", -250.0));
        let l = SignalLayout::new(&f, Some(&description()));
        let stamp = Time { sec: 1, nanosec: 0 };
        let by =
            |n: &str| wrench(l.wrenches.iter().find(|w| w.sensor == n).unwrap(), &f, stamp, "world").unwrap();
        let rope = by("hoist.rope");
        assert_eq!(rope.header.frame_id, "joint/rope");
        assert_eq!(rope.wrench.force, Vector3 { x: 1.0, y: -2.0, z: 49.05 });
        let lift = by("lift");
        assert_eq!(lift.header.frame_id, "joint/lift");
        assert_eq!(
            lift.wrench,
            Wrench { force: Vector3 { x: 1200.0, y: 0.0, z: 0.0 }, torque: Vector3::default() }
        );
        let spool = by("spool");
        assert_eq!(spool.header.frame_id, "joint/reel");
        assert_eq!(
            spool.wrench,
            Wrench { force: Vector3::default(), torque: Vector3 { x: -250.0, y: 0.0, z: 0.0 } }
        );
        // A drum that drops out: none.
        let last = f.channels.len() - 1;
        f.channels[last].dropout = true;
        f.channels[last].value = 0.0;
        let w = l.wrenches.iter().find(|w| w.sensor == "spool").unwrap();
        assert!(wrench(w, &f, stamp, "world").is_none());
    }

    #[test]
    fn signals_array_is_the_channels_in_order_with_nan_on_dropout() {
        let mut f = signals_frame();
        f.channels[13] = msgs::SignalChannel { dropout: true, value: 0.0, ..f.channels[13] };
        let mut a = Float64MultiArray::default();
        signals_array(&f, &mut a);
        assert_eq!(
            a.layout,
            MultiArrayLayout {
                dim: vec![MultiArrayDimension { label: "channels".into(), size: 14, stride: 14 }],
                data_offset: 0
            }
        );
        assert_eq!(a.data.len(), 14);
        assert_eq!(&a.data[..3], &[1.0, -2.0, 49.05]);
        assert_eq!(a.data[12], 49.1);
        assert!(a.data[13].is_nan());
        // Reused for a smaller frame.
        f.channels.truncate(2);
        signals_array(&f, &mut a);
        assert_eq!((a.data.as_slice(), a.layout.dim.len(), a.layout.dim[0].size), (&[1.0, -2.0][..], 1, 2));
    }

    #[test]
    fn contact_arrows_run_from_the_point_along_the_force_coloured_by_state() {
        let f = signals_frame();
        let stamp = Time { sec: 1, nanosec: 500_000_000 };
        let m = contact_markers(&f, 0.01, stamp, "world");
        assert_eq!(m.markers.len(), 3, "DELETEALL, stick, slip; the open contact is not drawn");
        let clear = &m.markers[0];
        assert_eq!(
            (clear.action, clear.ns.as_str(), clear.header.frame_id.as_str()),
            (Marker::DELETEALL, CONTACTS_NS, "world")
        );
        let (stick, slip) = (&m.markers[1], &m.markers[2]);
        for (a, id) in [(stick, 0), (slip, 1)] {
            assert_eq!(
                (a.type_, a.action, a.id, a.ns.as_str()),
                (Marker::ARROW, Marker::ADD, id, CONTACTS_NS)
            );
            assert_eq!(a.header, Header { stamp, frame_id: "world".into() });
            assert_eq!(a.scale, Vector3 { x: 0.01, y: 0.02, z: 0.0 });
        }
        // 100 N up at (1, 2, 0.5), 0.01 m/N: 1 m long.
        assert_eq!(stick.points, [Point { x: 1.0, y: 2.0, z: 0.5 }, Point { x: 1.0, y: 2.0, z: 1.5 }]);
        // 50 N up + (20, −10, 0) N friction at (−1, 0, 0).
        assert_eq!(slip.points, [Point { x: -1.0, y: 0.0, z: 0.0 }, Point { x: -0.8, y: -0.1, z: 0.5 }]);
        assert_eq!(stick.color, ColorRGBA { r: 0.1, g: 0.8, b: 0.1, a: 1.0 });
        assert_eq!(slip.color, ColorRGBA { r: 1.0, g: 0.45, b: 0.0, a: 1.0 });
        assert_eq!(contact_color(msgs::ContactCode::Open), ColorRGBA { r: 0.5, g: 0.5, b: 0.5, a: 1.0 });
        // No contacts: only the DELETEALL, so the previous arrows vanish.
        let empty = contact_markers(&msgs::SignalsFrame::default(), 0.01, stamp, "world");
        assert_eq!(empty.markers.len(), 1);
    }

    #[test]
    fn events_are_log_lines_warn_for_raised_and_faults() {
        let e = msgs::EventRecord {
            name: msgs::ActuatorName::new("hoist-overload").unwrap(),
            kind: msgs::EventCode::Raised,
            time: 2.5,
            value: 31000.0,
            level: 30000.0,
        };
        let stamp = Time { sec: 2, nanosec: 500_000_000 };
        let l = event_log(&e, stamp, "pivotsim_bridge");
        assert_eq!(
            l,
            Log {
                stamp,
                level: Log::WARN,
                name: "pivotsim_bridge".into(),
                msg: "pivotsim event hoist-overload raised at t = 2.500 s: value 31000, level 30000".into(),
                ..Log::default()
            }
        );
        assert_eq!(event_level(msgs::EventCode::Cleared), Log::INFO);
        assert_eq!(event_level(msgs::EventCode::Fault), Log::WARN);
        assert_eq!(event_level(msgs::EventCode::FaultRejected), Log::WARN);
    }

    #[test]
    fn diagnostics_list_every_channel_and_the_signal_counters() {
        let mut f = signals_frame();
        let h = BridgeHealth {
            signals: SignalCounters { signals_decode_failed: 3, wrench_topics: 2, ..Default::default() },
            ..Default::default()
        };
        let a = diagnostics(None, Some(&f), &h, Time::default());
        let s = a.get(DIAG_SIGNALS).unwrap();
        assert_eq!(s.level, DiagnosticStatus::OK);
        assert_eq!(s.value("support/fz"), Some("98.1"));
        assert_eq!(s.value("contacts"), Some("3"));
        assert_eq!((s.value("contacts_stick"), s.value("contacts_slip")), (Some("1"), Some("1")));
        assert_eq!(s.value("dropout_count"), Some("0"));
        let b = a.get(DIAG_BRIDGE).unwrap();
        assert_eq!((b.value("signals_decode_failed"), b.value("wrench_topics")), (Some("3"), Some("2")));
        f.channels[12] = msgs::SignalChannel { dropout: true, value: 0.0, ..f.channels[12] };
        let a = diagnostics(None, Some(&f), &h, Time::default());
        let s = a.get(DIAG_SIGNALS).unwrap();
        assert_eq!((s.level, s.value("rope/tension")), (DiagnosticStatus::WARN, Some("dropout")));
        assert_eq!(s.value("dropout_count"), Some("1"));
        assert!(diagnostics(None, None, &h, Time::default()).get(DIAG_SIGNALS).is_none());
    }
}
