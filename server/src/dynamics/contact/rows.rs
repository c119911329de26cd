//! Contact points → constraint rows: per point one normal row and two friction rows (module doc of
//! `contact/mod.rs` for the equations).

use nalgebra::Vector3;

use super::ContactSettings;
use super::collide::ContactPoint;
use crate::dynamics::body::{BodyKind, RigidBody};
use crate::dynamics::rows::{ConstraintRow, Jac6, RowKey, RowKind};

/// A deterministic unit vector orthogonal to `n` (from the world axis least aligned with `n`).
pub(crate) fn orthogonal(n: &Vector3<f64>) -> Vector3<f64> {
    let helper = if n.x.abs() <= n.y.abs() && n.x.abs() <= n.z.abs() {
        Vector3::x()
    } else if n.y.abs() <= n.z.abs() {
        Vector3::y()
    } else {
        Vector3::z()
    };
    (helper - n * n.dot(&helper)).normalize()
}

/// Appends the rows of every point (normal row first, then its two friction rows with `findex` →
/// the normal row) and records each point's tangent basis.
pub(crate) fn push_contact_rows(
    points: &mut [ContactPoint],
    bodies: &[RigidBody],
    settings: &ContactSettings,
    h: f64,
    rows: &mut Vec<ConstraintRow>,
) {
    for p in points.iter_mut() {
        let (ba, bb) = (&bodies[p.a], &bodies[p.b]);
        let slot = |b: &RigidBody, i: usize| (b.kind() != BodyKind::Static).then_some(i);
        let (sa, sb) = (slot(ba, p.a), slot(bb, p.b));
        let (ra, rb) = (p.pa - ba.position, p.pb - bb.position);
        let n = p.n;
        let vrel = (bb.linvel + bb.angvel.cross(&rb)) - (ba.linvel + ba.angvel.cross(&ra));
        let vt = vrel - n * n.dot(&vrel);
        let speed = vt.norm();
        let t1 = if speed > settings.sliding_speed { vt / speed } else { orthogonal(&n) };
        let t2 = n.cross(&t1);
        p.t = [t1, t2];
        let jac = |d: &Vector3<f64>| (Jac6::new(-d, -ra.cross(d)), Jac6::new(*d, rb.cross(d)));
        let key = |row: u8| RowKey::Contact { colliders: [p.ca, p.cb], features: p.features, row };

        let normal = rows.len();
        let (ja, jb) = jac(&n);
        let mut r = ConstraintRow::pair(key(0), RowKind::Position, sa, ja, sb, jb);
        // φ is the violation: a speculative gap (> 0) is no violation (stats report penetration).
        r.phi = p.dist.min(0.0);
        let beta = if p.dist >= 0.0 { 1.0 } else { settings.stabilization };
        r.rhs = -beta * p.dist / h;
        r.compliance = settings.compliance;
        r.lo = 0.0;
        r.hi = f64::INFINITY;
        rows.push(r);
        for (k, t) in [t1, t2].iter().enumerate() {
            let (ja, jb) = jac(t);
            let mut r = ConstraintRow::pair(key(1 + k as u8), RowKind::Velocity, sa, ja, sb, jb);
            r.compliance = settings.compliance;
            r.lo = -p.mu;
            r.hi = p.mu;
            r.findex = Some(normal);
            rows.push(r);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tangent_basis_is_orthonormal() {
        for n in [Vector3::z(), Vector3::new(0.3, -0.5, 0.8).normalize(), -Vector3::x()] {
            let t = orthogonal(&n);
            let t2 = n.cross(&t);
            assert!((t.norm() - 1.0).abs() < 1e-15 && t.dot(&n).abs() < 1e-15);
            assert!((t2.norm() - 1.0).abs() < 1e-15 && t2.dot(&t).abs() < 1e-15);
        }
    }
}
