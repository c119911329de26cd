//! `/tf`, `/tf_static` and `/pivotsim/pose_array`: bodies' transforms from a pose frame.

use super::*;

/// Whether a body of a pose frame is static (by its flags or the scene's kind).
pub fn is_static(scene: &SceneInfo, body: &msgs::BodyPose) -> bool {
    body.flags & msgs::BODY_STATIC != 0
        || scene.body(body.id).is_some_and(|b| b.kind == msgs::BodyKind::Static)
}

pub(super) fn transform(parent: &str, child: &str, stamp: Time, b: &msgs::BodyPose) -> TransformStamped {
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
