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

/// One transform `world` → body name per body of the frame, stamped with the server's wall time
/// (bodies the scene does not name are `body<id>`).
pub fn frame_transforms(
    v: &msgs::PoseFrameView<'_>,
    scene: Option<&msgs::SceneDescription>,
) -> FrameTransforms {
    frame_transforms_at(v, scene, v.wall_time_ns())
}

/// [`frame_transforms`] stamped with `stamp_ns`.
pub fn frame_transforms_at(
    v: &msgs::PoseFrameView<'_>,
    scene: Option<&msgs::SceneDescription>,
    stamp_ns: u64,
) -> FrameTransforms {
    let stamp = timestamp(stamp_ns);
    FrameTransforms {
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
    }
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
        let t = frame_transforms(&v, None);
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

    #[test]
    fn simulation_time_in_ns() {
        assert_eq!(sim_ns(1.5), 1_500_000_000);
        assert_eq!(sim_ns(0.001), 1_000_000);
        assert_eq!((sim_ns(-1.0), sim_ns(f64::NAN), sim_ns(f64::INFINITY)), (0, 0, 0));
    }
}
