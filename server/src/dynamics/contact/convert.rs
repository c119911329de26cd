//! The one boundary between the dynamics' nalgebra types and parry3d-f64's glam types
//! (`parry3d_f64::math::{Vector, Pose, Rot3}` are glam's `DVec3`, `DPose3`, `DQuat`).
//! Nothing else in the dynamics touches a glam type.

use nalgebra::{Isometry3, UnitQuaternion, Vector3};
#[cfg(test)]
use nalgebra::{Quaternion, Translation3};
use parry3d_f64::math::{Pose, Rot3, Vector};

/// nalgebra → glam vector.
#[inline]
pub(crate) fn to_vec(v: &Vector3<f64>) -> Vector {
    Vector::new(v.x, v.y, v.z)
}

/// glam → nalgebra vector.
#[inline]
pub(crate) fn from_vec(v: Vector) -> Vector3<f64> {
    Vector3::new(v.x, v.y, v.z)
}

/// nalgebra → glam rotation.
#[inline]
pub(crate) fn to_rot(q: &UnitQuaternion<f64>) -> Rot3 {
    let c = q.quaternion().coords;
    Rot3::from_xyzw(c.x, c.y, c.z, c.w)
}

/// glam → nalgebra rotation.
#[cfg(test)]
#[inline]
pub(crate) fn from_rot(q: Rot3) -> UnitQuaternion<f64> {
    UnitQuaternion::new_unchecked(Quaternion::new(q.w, q.x, q.y, q.z))
}

/// nalgebra → glam pose.
#[inline]
pub(crate) fn to_pose(p: &Isometry3<f64>) -> Pose {
    Pose::from_parts(to_vec(&p.translation.vector), to_rot(&p.rotation))
}

/// glam → nalgebra pose.
#[cfg(test)]
#[inline]
pub(crate) fn from_pose(p: &Pose) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::from(from_vec(p.translation)), from_rot(p.rotation))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip() {
        let p = Isometry3::from_parts(
            Translation3::new(1.0, -2.0, 3.5),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.3, -0.2, 0.9)),
        );
        let back = from_pose(&to_pose(&p));
        assert!((back.translation.vector - p.translation.vector).norm() < 1e-15);
        assert!(back.rotation.angle_to(&p.rotation) < 1e-15);
        let x = Vector3::new(0.1, 0.2, -0.7);
        let a = p * nalgebra::Point3::from(x);
        let b = from_vec(to_pose(&p).transform_point(to_vec(&x)));
        assert!((a.coords - b).norm() < 1e-14);
    }
}
