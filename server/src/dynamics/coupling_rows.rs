//! Coupling model → its velocity row (`coupling.rs` for the maths).
//!
//! ```text
//!   J = Σ_t k_t J_{s,t},     J v⁺ + (c/h²) λ = 0,     λ ∈ [−τ_max h, τ_max h]  (or unbounded)
//! ```
//!
//! where `J_{s,t} = ((0, e₁ᵗ) on A_t, (0, −e₁ᵗ) on B_t)` is the angular free-coordinate Jacobian of
//! shaft `t`'s joint at the current poses (`joint_rows.rs`; a rack's first term: the linear one). Blocks of a body shared by several
//! shafts (a common housing) are summed into one, so the row touches each body once and at most
//! four bodies (checked when the coupling is built).

use super::coupling::Coupling;
use super::joint::Joint;
use super::joint_rows::JointGeometry;
use super::rows::{ConstraintRow, RowKey, RowKind, Side};

/// Appends the row of `coupling` to `out`; `side(joint)` gives the joint's two ends `(A, B)` at the
/// current poses.
pub(crate) fn push_coupling_row(
    coupling: &Coupling,
    joints: &[Joint],
    side: impl Fn(&Joint) -> (Side, Side),
    h: f64,
    out: &mut Vec<ConstraintRow>,
) {
    let mut row = ConstraintRow::new(RowKey::Coupling(coupling.id), RowKind::Velocity);
    for (t, &(jid, k)) in coupling.terms().iter().enumerate() {
        let joint = &joints[jid.index()];
        let (a, b) = side(joint);
        let (_, ja, jb) = JointGeometry::new(joint, &a, &b).free_coordinate(coupling.kind.axis(t));
        let fits = row.add_block(a.index, ja.scale(k)) && row.add_block(b.index, jb.scale(k));
        debug_assert!(fits, "coupling '{}' touches more bodies than a row holds", coupling.name);
    }
    row.compliance = coupling.compliance;
    if let Some(tau) = coupling.max_torque {
        row.lo = -tau * h;
        row.hi = tau * h;
    }
    out.push(row);
}

#[cfg(test)]
mod tests {
    use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::dynamics::coupling::CouplingBuilder;
    use crate::dynamics::error::CouplingError;
    use crate::dynamics::ids::{BodyId, CouplingId, JointId};
    use crate::dynamics::joint::{DEFAULT_COMPLIANCE, JOINT_SLOTS, JointKind};
    use crate::dynamics::motor::FreeAxis;
    use crate::dynamics::rows::MAX_ROW_BODIES;

    fn v3(rng: &mut ChaCha8Rng, s: f64) -> Vector3<f64> {
        Vector3::new(rng.random_range(-s..s), rng.random_range(-s..s), rng.random_range(-s..s))
    }

    fn iso(rng: &mut ChaCha8Rng) -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::from(v3(rng, 1.0)),
            UnitQuaternion::from_scaled_axis(v3(rng, 2.0)),
        )
    }

    fn joint(
        id: u32,
        kind: JointKind,
        a: u32,
        b: Option<u32>,
        fa: Isometry3<f64>,
        fb: Isometry3<f64>,
    ) -> Joint {
        Joint {
            id: JointId(id),
            name: format!("j{id}"),
            kind,
            body_a: BodyId(a),
            body_b: b.map(BodyId),
            frame_a: fa,
            frame_b: fb,
            compliance: [DEFAULT_COMPLIANCE; JOINT_SLOTS],
            stabilization: 1.0,
            limits: [None; 2],
            motors: [None; 2],
            enabled: true,
        }
    }

    /// A body's pose and velocity (world index `i`).
    fn body(rng: &mut ChaCha8Rng, i: usize) -> Side {
        Side {
            index: Some(i),
            x: v3(rng, 2.0),
            q: UnitQuaternion::from_scaled_axis(v3(rng, 2.0)),
            v: v3(rng, 1.0),
            w: v3(rng, 1.0),
        }
    }

    /// `J v` of a differential whose shafts share one housing equals `ω_in − ρ (ω_l + ω_r)/2` with
    /// each shaft speed the central difference of its free angle along the motion (hinges and a
    /// cylindrical joint, aligned axes): the blocks of the shared housing are summed correctly.
    #[test]
    fn differential_row_is_the_combination_of_shaft_speeds() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for _ in 0..20 {
            // Bodies 0 (housing), 1 (input), 2 (left), 3 (right).
            let sides: Vec<Side> = (0..4).map(|i| body(&mut rng, i)).collect();
            let pose = |s: &Side| Isometry3::from_parts(Translation3::from(s.x), s.q);
            let mut joints = Vec::new();
            for (t, kind) in
                [JointKind::Hinge, JointKind::Hinge, JointKind::Cylindrical].into_iter().enumerate()
            {
                // Aligned frames: the same world frame seen from the shaft and from the housing.
                let wf = iso(&mut rng);
                let shaft = &sides[t + 1];
                joints.push(joint(
                    t as u32,
                    kind,
                    t as u32 + 1,
                    Some(0),
                    pose(shaft).inverse() * wf,
                    pose(&sides[0]).inverse() * wf,
                ));
            }
            let ratio = rng.random_range(0.5..4.0);
            let c = CouplingBuilder::differential("d", JointId(0), JointId(1), JointId(2), ratio)
                .max_torque(3.0)
                .build(CouplingId(0), &joints)
                .unwrap();
            let side_at = |t: f64| {
                let sides = sides.clone();
                move |j: &Joint| {
                    let adv = |s: &Side| Side {
                        x: s.x + s.v * t,
                        q: UnitQuaternion::from_scaled_axis(s.w * t) * s.q,
                        ..*s
                    };
                    (adv(&sides[j.body_a.index()]), adv(&sides[j.body_b.unwrap().index()]))
                }
            };
            let mut out = Vec::new();
            push_coupling_row(&c, &joints, side_at(0.0), 0.01, &mut out);
            let r = &out[0];
            assert_eq!(r.blocks().count(), MAX_ROW_BODIES);
            assert_eq!((r.lo, r.hi), (-0.03, 0.03));
            let eps = 1e-6;
            let speed = |t: usize| {
                let s = |dt: f64| {
                    let (a, b) = side_at(dt)(&joints[t]);
                    JointGeometry::new(&joints[t], &a, &b).free_coordinate(FreeAxis::Angular).0
                };
                (s(eps) - s(-eps)) / (2.0 * eps)
            };
            let expected = speed(0) - ratio * (speed(1) + speed(2)) / 2.0;
            let v: Vec<_> = sides.iter().map(|s| s.v).collect();
            let w: Vec<_> = sides.iter().map(|s| s.w).collect();
            let jv = r.velocity(&v, &w);
            assert!((jv - expected).abs() < 1e-7, "{jv} vs {expected}");
        }
    }

    /// Bad couplings are refused with the error that names the problem.
    #[test]
    fn bad_couplings() {
        let id = Isometry3::identity();
        let joints = vec![
            joint(0, JointKind::Hinge, 0, None, id, id),
            joint(1, JointKind::Hinge, 1, Some(0), id, id),
            joint(2, JointKind::Prismatic, 2, None, id, id),
            joint(3, JointKind::Hinge, 3, Some(4), id, id),
            joint(4, JointKind::Hinge, 5, Some(6), id, id),
        ];
        let j = JointId;
        let build = |b: CouplingBuilder| b.build(CouplingId(0), &joints).unwrap_err();
        assert!(matches!(build(CouplingBuilder::gear("", j(0), j(1), 1.0)), CouplingError::EmptyName));
        for ratio in [0.0, -2.0, f64::NAN, f64::INFINITY] {
            let e = build(CouplingBuilder::gear("g", j(0), j(1), ratio));
            assert!(matches!(e, CouplingError::InvalidRatio { .. }), "{e:?}");
        }
        let e = build(CouplingBuilder::gear("g", j(0), j(9), 1.0));
        assert!(matches!(e, CouplingError::UnknownJoint { joint: JointId(9), .. }), "{e:?}");
        let e = build(CouplingBuilder::gear("g", j(1), j(1), 1.0));
        assert!(matches!(e, CouplingError::RepeatedJoint { .. }), "{e:?}");
        let e = build(CouplingBuilder::gear("g", j(0), j(2), 1.0));
        assert!(matches!(e, CouplingError::NotRotational { kind: "prismatic", .. }), "{e:?}");
        let e = build(CouplingBuilder::differential("d", j(1), j(3), j(4), 1.0));
        assert!(matches!(e, CouplingError::TooManyBodies { bodies: 6, .. }), "{e:?}");
        let e = build(CouplingBuilder::gear("g", j(0), j(1), 1.0).compliance(-1.0));
        assert!(matches!(e, CouplingError::InvalidCompliance { .. }), "{e:?}");
        let e = build(CouplingBuilder::gear("g", j(0), j(1), 1.0).max_torque(f64::NAN));
        assert!(matches!(e, CouplingError::InvalidMaxTorque { .. }), "{e:?}");
        // A gear on four distinct bodies fits.
        CouplingBuilder::gear("g", j(3), j(4), 2.0).build(CouplingId(0), &joints).unwrap();
    }
}
