//! Per-step frames as Foxglove messages: a pose frame's bodies as `foxglove.FrameTransforms`.

use foxglove::schemas::{FrameTransform, FrameTransforms, Quaternion, Timestamp, Vector3};
use pivotsim_msgs as msgs;

use super::WORLD_FRAME;
use crate::util::body_name;

/// A time in ns since the UNIX epoch as a Foxglove timestamp (saturating past 2106).
pub fn timestamp(ns: u64) -> Timestamp {
    let sec = (ns / 1_000_000_000).min(u64::from(u32::MAX)) as u32;
    Timestamp::new(sec, (ns % 1_000_000_000) as u32)
}

/// A simulation time (s) as ns, the stamp of the simulation clock (`/clock` on the ROS 2 path):
/// negative or not finite is 0, past 2106 saturates.
pub fn sim_ns(sim_time: f64) -> u64 {
    if sim_time.is_finite() && sim_time > 0.0 {
        (sim_time * 1e9).round().min(u64::MAX as f64) as u64
    } else {
        0
    }
}

/// One transform `world` → body name per body of the frame, stamped with `stamp_ns` (the
/// view's [`super::Clock`]; bodies the scene does not name are `body<id>`), followed by the
/// scene's [`joint_frames`].
pub fn frame_transforms_at(
    v: &msgs::PoseFrameView<'_>,
    scene: Option<&msgs::SceneDescription>,
    stamp_ns: u64,
) -> FrameTransforms {
    let stamp = timestamp(stamp_ns);
    let mut t = FrameTransforms {
        transforms: v
            .bodies()
            .map(|b| FrameTransform {
                timestamp: Some(stamp),
                parent_frame_id: WORLD_FRAME.to_string(),
                child_frame_id: body_name(scene, b.id),
                translation: Some(Vector3 { x: b.position[0], y: b.position[1], z: b.position[2] }),
                rotation: Some(Quaternion {
                    x: b.orientation[0],
                    y: b.orientation[1],
                    z: b.orientation[2],
                    w: b.orientation[3],
                }),
            })
            .collect(),
    };
    if let Some(d) = scene {
        t.transforms.extend(joint_frames(d, stamp));
    }
    t
}

/// Name of a joint's frame, as on the ROS 2 path's `/tf_static`: `joint/<joint name>`.
pub fn joint_frame_id(joint: &str) -> String {
    format!("joint/{joint}")
}

/// The frames the scene's joint, cylinder and drum sensors report in (once per joint, in sensor
/// order; joints without a frame in the description left out): `<body>` (or `world`) →
/// `joint/<joint>`, origin at the anchor, x = the joint axis — the ROS 2 bridge's `/tf_static`
/// frames. Fixed on their bodies, they go with every `/tf` message, so a viewer that joins late
/// has them at once and a plot or a 3D panel can place a sensor's wrench (channels `fx … tz`) in
/// its frame.
pub fn joint_frames(d: &msgs::SceneDescription, stamp: foxglove::schemas::Timestamp) -> Vec<FrameTransform> {
    let frames = d.sensed_joint_frames();
    frames
        .into_iter()
        .map(|(body, joint, f)| {
            let (p, q) = (f.position, f.orientation);
            FrameTransform {
                timestamp: Some(stamp),
                parent_frame_id: body.map_or_else(|| WORLD_FRAME.to_string(), |b| b.name.clone()),
                child_frame_id: joint_frame_id(joint),
                translation: Some(Vector3 { x: p[0], y: p[1], z: p[2] }),
                rotation: Some(Quaternion { x: q[0], y: q[1], z: q[2], w: q[3] }),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_transform_per_body_under_world() {
        let f = msgs::PoseFrame {
            sequence: 3,
            sim_time: 0.05,
            wall_time_ns: 1_500_000_007,
            bodies: vec![
                msgs::BodyPose { id: 1, position: [1.0, 2.0, 3.0], ..Default::default() },
                msgs::BodyPose { id: 4, ..Default::default() },
            ],
        };
        let mut buf = Vec::new();
        f.encode(&mut buf).unwrap();
        let v = msgs::PoseFrameView::parse(&buf).unwrap();
        let t = frame_transforms_at(&v, None, v.wall_time_ns());
        assert_eq!(t.transforms.len(), 2);
        assert_eq!(t.transforms[0].child_frame_id, "body1");
        assert_eq!(t.transforms[0].parent_frame_id, "world");
        assert_eq!(t.transforms[0].translation.unwrap().z, 3.0);
        assert_eq!(t.transforms[1].rotation.unwrap().w, 1.0);
        let s = t.transforms[0].timestamp.unwrap();
        assert_eq!((s.sec(), s.nsec()), (1, 500_000_007));
        let s = frame_transforms_at(&v, None, sim_ns(v.sim_time())).transforms[1].timestamp.unwrap();
        assert_eq!((s.sec(), s.nsec()), (0, 50_000_000));
    }

    /// `q v q*` for a unit quaternion `[x, y, z, w]`.
    fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
        let (u, w) = ([q[0], q[1], q[2]], q[3]);
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
        };
        let t = cross(u, v).map(|x| 2.0 * x);
        let c = cross(u, t);
        [0, 1, 2].map(|i| v[i] + w * t[i] + c[i])
    }

    /// The joint frames on `/tf` of the shipped scenes with joint, cylinder and drum sensors: one
    /// per sensed joint, under the joint's child, named as on the ROS 2 path. Composed with the
    /// child's transform of the same message, a frame's x axis is the joint's axis as the other
    /// body (the parent) holds it in the server's world (its `frame_b`), and a hinge's origin is
    /// the parent's anchor: within 1e-3 (the joints' elastic give).
    #[test]
    fn tf_carries_the_sensed_joint_frames_where_the_joints_are() {
        use std::time::{Duration, Instant};
        for (scene, joints) in
            [("crane", &["luff", "hoist"][..]), ("forklift", &["lift_l", "lift_r"]), ("winch", &["winch"])]
        {
            let world = msgs::WorldName::new(format!("jf-{scene}")).unwrap();
            let mut e = pivotsim_server::serve::Engine::new(scene, world, Duration::from_secs(60)).unwrap();
            let t0 = Instant::now();
            for i in 0..60 {
                assert!(e.tick(t0 + Duration::from_secs_f64(i as f64 / 60.0)));
            }
            let d = msgs::SceneDescription::decode(e.description()).unwrap();
            let v = msgs::PoseFrameView::parse(e.pose_frame()).unwrap();
            let tf = frame_transforms_at(&v, Some(&d), 0).transforms;
            let frames: Vec<&FrameTransform> =
                tf.iter().filter(|t| t.child_frame_id.starts_with("joint/")).collect();
            let names: Vec<&str> = frames.iter().map(|t| t.child_frame_id.as_str()).collect();
            let want: Vec<String> = joints.iter().map(|j| joint_frame_id(j)).collect();
            assert_eq!(names, want, "{scene}");
            let w = &e.scene().world;
            for (f, name) in frames.iter().zip(joints.iter()) {
                let id = w.joint_id(name).unwrap();
                let joint = w.joint(id).unwrap();
                let child = w.body(joint.body_a()).unwrap();
                assert_eq!(f.parent_frame_id, child.name(), "{scene}: {name}");
                let body = tf.iter().find(|t| t.child_frame_id == f.parent_frame_id).unwrap();
                let (bp, bq) = (body.translation.unwrap(), body.rotation.unwrap());
                let bq = [bq.x, bq.y, bq.z, bq.w];
                let (fp, fq) = (f.translation.unwrap(), f.rotation.unwrap());
                let fq = [fq.x, fq.y, fq.z, fq.w];
                let o = rotate(bq, [fp.x, fp.y, fp.z]);
                let origin = [bp.x + o[0], bp.y + o[1], bp.z + o[2]];
                let x = rotate(bq, rotate(fq, [1.0, 0.0, 0.0]));
                // The parent's view of the joint: its pose times frame_b.
                let parent = match joint.body_b() {
                    Some(b) => w.body(b).unwrap().pose() * joint.frame_b(),
                    None => *joint.frame_b(),
                };
                let m = parent.rotation.to_rotation_matrix();
                let px = [m[(0, 0)], m[(1, 0)], m[(2, 0)]];
                let dx = (0..3).map(|i| (x[i] - px[i]).abs()).fold(0.0, f64::max);
                assert!(dx < 1e-3, "{scene}: {name}: x axis {x:?} vs the parent's {px:?}");
                if joint.kind() == pivotsim_server::dynamics::JointKind::Hinge {
                    let t = parent.translation.vector;
                    let d = (0..3).map(|i| (origin[i] - t[i]).abs()).fold(0.0, f64::max);
                    assert!(d < 1e-3, "{scene}: {name}: origin {origin:?} vs the parent's anchor {t:?}");
                }
            }
        }
    }

    #[test]
    fn simulation_time_in_ns() {
        assert_eq!(sim_ns(1.5), 1_500_000_000);
        assert_eq!(sim_ns(0.001), 1_000_000);
        assert_eq!((sim_ns(-1.0), sim_ns(f64::NAN), sim_ns(f64::INFINITY)), (0, 0, 0));
    }
}
