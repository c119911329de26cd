//! Joint model → constraint rows: violations and Jacobian blocks of the six joint kinds, the limit
//! rows and the motor rows (the row equation and its signs are in `rows.rs`, the motor law in
//! `motor.rs`).
//!
//! Notation (see `joint.rs`): body poses `(x_A, R_A)`, `(x_B, R_B)`; world joint frames
//! `W_a = X_A F_a`, `W_b = X_B F_b` with anchors `p_a`, `p_b`, axes `e₁, e₂, e₃` of `W_a` and
//! `f₁, f₂, f₃` of `W_b`; `d = p_b − p_a`.
//!
//! **Linear row along a unit axis `u = e_k` of frame a**: `φ = u · d`. Both `u` (turning with A) and
//! `d` move, and the exact time derivative is
//!
//! ```text
//!   φ̇ = u · (v_B + ω_B × r_B − v_A − ω_A × r_A),   r_B = p_b − x_B,   r_A = p_b − x_A,
//! ```
//!
//! i.e. `J_A = (−u, −r_A × u)`, `J_B = (u, r_B × u)`: the row applies equal and opposite forces at
//! the single point `p_b` (A's lever arm reaches `p_b`, not `p_a`, which also accounts for the
//! rotation of `u`), so it conserves linear and angular momentum exactly.
//!
//! **Angular lock of all three rotations** (fixed, prismatic): the error rotation `W_b W_aᵀ` as a
//! rotation vector `θ` (world); row `k`: `φ = e_k · θ`, `J_A = (0, −e_k)`, `J_B = (0, e_k)`
//! (`θ̇ = ω_B − ω_A` to first order in `θ`).
//!
//! **Perpendicularity rows** `φ = e_i · f_k` (zero at rest since the frames coincide): exactly
//! `φ̇ = (ω_A × e_i) · f_k + e_i · (ω_B × f_k) = ω_A · (e_i × f_k) + ω_B · (f_k × e_i)`, so
//! `J_A = (0, e_i × f_k)`, `J_B = (0, f_k × e_i)` — equal and opposite torques. Hinge and cylindrical
//! joints keep B's axis `f₁` perpendicular to `e₂` and `e₃` (`(i, k) = (2, 1), (3, 1)`: `e₁ ∥ f₁`); a
//! universal joint keeps its pins perpendicular, `e₁ · f₂ = 0`.
//!
//! **Free coordinates** `s` of A relative to B (B is the parent, or the world): angle
//! `s = −atan2(e₃·f₂, e₂·f₂)` with `ṡ = e₁ · (ω_A − ω_B)` (exact when the axes are aligned);
//! displacement `s = −e₁ · d` with the negated linear-row Jacobian of `u = e₁`. A cylindrical joint
//! has both. Lower limit: `φ = s − lower`, `J = J_s`; upper limit: `φ = upper − s`, `J = −J_s`; both
//! `λ ∈ [0, ∞)`, emitted when `min(φ, φ + h ṡ_toward) < margin` (with the free velocities, so a
//! joint about to cross its bound within the step is caught). Motor: velocity row
//! `J_s v⁺ + (c/h²) λ = u`, `λ ∈ [−F h, F h]`, with `u` the target speed of `motor.rs`.
//!
//! Each row is named by a [`JointRow`] slot and evaluated from a `RowDef` (which function of the
//! geometry it is), so the same definition serves any pose. The Jacobians are checked against
//! central differences of the violations in the tests below.

use nalgebra::Vector3;

use super::joint::{Joint, JointKind, JointRow};
use super::motor::FreeAxis;
use super::rows::{ConstraintRow, Jac6, RowKey, RowKind, Side};

/// World-frame geometry of a joint at given poses.
#[derive(Debug, Clone, Copy)]
pub(crate) struct JointGeometry {
    pub p_a: Vector3<f64>,
    pub p_b: Vector3<f64>,
    pub e: [Vector3<f64>; 3],
    pub f: [Vector3<f64>; 3],
    /// Rotation vector of `W_b W_aᵀ`.
    pub theta: Vector3<f64>,
    pub r_a: Vector3<f64>,
    pub r_b: Vector3<f64>,
}

impl JointGeometry {
    pub fn new(joint: &Joint, a: &Side, b: &Side) -> Self {
        let wa = a.q * joint.frame_a.rotation;
        let wb = b.q * joint.frame_b.rotation;
        let p_a = a.x + a.q * joint.frame_a.translation.vector;
        let p_b = b.x + b.q * joint.frame_b.translation.vector;
        let e = [wa * Vector3::x(), wa * Vector3::y(), wa * Vector3::z()];
        let f = [wb * Vector3::x(), wb * Vector3::y(), wb * Vector3::z()];
        let theta = (wb * wa.inverse()).scaled_axis();
        JointGeometry { p_a, p_b, e, f, theta, r_a: p_b - a.x, r_b: p_b - b.x }
    }

    /// Position error `|p_b − p_a|` (m).
    pub fn anchor_error(&self) -> f64 {
        (self.p_b - self.p_a).norm()
    }

    /// Anchor separation across the locked directions only (m): for a joint of `kind` with a free
    /// linear axis (prismatic, cylindrical), the slide along that axis is the joint's coordinate,
    /// not an error, and is left out.
    pub fn locked_anchor_error(&self, kind: JointKind) -> f64 {
        let d = self.p_b - self.p_a;
        if kind.has_axis(FreeAxis::Linear) { (d - self.e[0] * self.e[0].dot(&d)).norm() } else { d.norm() }
    }

    /// Linear row along `u`: `(φ, J_A, J_B)`.
    fn linear(&self, u: Vector3<f64>) -> (f64, Jac6, Jac6) {
        let phi = u.dot(&(self.p_b - self.p_a));
        (phi, Jac6::new(-u, -self.r_a.cross(&u)), Jac6::new(u, self.r_b.cross(&u)))
    }

    /// Free coordinate of `axis`, of A relative to B (B is the parent or the world), and its
    /// Jacobian blocks `(s, J_A, J_B)`.
    pub fn free_coordinate(&self, axis: FreeAxis) -> (f64, Jac6, Jac6) {
        let (s, ja, jb) = match axis {
            FreeAxis::Linear => self.linear(self.e[0]),
            FreeAxis::Angular => {
                let s = self.e[2].dot(&self.f[1]).atan2(self.e[1].dot(&self.f[1]));
                (s, Jac6::new(Vector3::zeros(), -self.e[0]), Jac6::new(Vector3::zeros(), self.e[0]))
            }
        };
        // The expressions above measure B relative to A.
        (-s, ja.neg(), jb.neg())
    }
}

/// Which constraint function a row evaluates (so that the same definition can be evaluated at the
/// current and at the predicted poses).
#[derive(Debug, Clone, Copy)]
enum RowDef {
    /// Linear row along axis `e_k`.
    Linear(usize),
    /// Angular lock about `e_k` (rotation vector).
    Angular(usize),
    /// Perpendicularity row `e_i · f_k`.
    Perp(usize, usize),
    /// Free coordinate `s` of an axis (sign +1: lower limit `s − lower`; −1: upper limit `upper − s`).
    Free(FreeAxis, f64),
}

impl JointGeometry {
    /// `(φ, J_A, J_B)` of a row definition (free-coordinate rows: `±s` without the bound).
    fn eval(&self, def: RowDef) -> (f64, Jac6, Jac6) {
        let z = Vector3::zeros();
        match def {
            RowDef::Linear(k) => self.linear(self.e[k]),
            RowDef::Angular(k) => {
                let u = self.e[k];
                (u.dot(&self.theta), Jac6::new(z, -u), Jac6::new(z, u))
            }
            RowDef::Perp(i, k) => {
                let (u, f) = (self.e[i], self.f[k]);
                (u.dot(&f), Jac6::new(z, u.cross(&f)), Jac6::new(z, f.cross(&u)))
            }
            RowDef::Free(axis, sign) => {
                let (s, ja, jb) = self.free_coordinate(axis);
                if sign > 0.0 { (s, ja, jb) } else { (-s, ja.neg(), jb.neg()) }
            }
        }
    }
}

/// Row definition and bound offset of a position row slot of a joint (`None` for motors).
fn row_def(joint: &Joint, row: JointRow) -> Option<(RowDef, f64)> {
    let limit = |a: FreeAxis| joint.limits[a.index()].unwrap_or(super::motor::JointLimit::new(0.0, 0.0));
    Some(match (joint.kind, row) {
        (_, JointRow::Motor(_)) => return None,
        (_, JointRow::LowerLimit(a)) => (RowDef::Free(a, 1.0), limit(a).lower),
        (_, JointRow::UpperLimit(a)) => (RowDef::Free(a, -1.0), -limit(a).upper),
        (JointKind::Fixed, JointRow::Locked(k)) if k >= 3 => (RowDef::Angular(k as usize - 3), 0.0),
        (JointKind::Hinge, JointRow::Locked(k)) if k >= 3 => (RowDef::Perp(k as usize - 2, 0), 0.0),
        (JointKind::Prismatic, JointRow::Locked(k)) if k >= 2 => (RowDef::Angular(k as usize - 2), 0.0),
        (JointKind::Cylindrical, JointRow::Locked(k)) if k >= 2 => (RowDef::Perp(k as usize - 1, 0), 0.0),
        (JointKind::Universal, JointRow::Locked(3)) => (RowDef::Perp(0, 1), 0.0),
        (JointKind::Prismatic | JointKind::Cylindrical, JointRow::Locked(k)) => {
            (RowDef::Linear(k as usize + 1), 0.0)
        }
        (_, JointRow::Locked(k)) => (RowDef::Linear(k as usize), 0.0),
    })
}

/// The locked linear rows of a joint kind as `(slot, k)`: the row along axis `e_k` of frame a
/// (what [`row_def`] maps to `RowDef::Linear(k)`); the geometric stiffness reads their impulses.
pub(crate) fn linear_row_axes(kind: JointKind) -> &'static [(usize, usize)] {
    match kind {
        JointKind::Prismatic | JointKind::Cylindrical => &[(0, 1), (1, 2)],
        JointKind::Fixed | JointKind::Hinge | JointKind::Ball | JointKind::Universal => {
            &[(0, 0), (1, 1), (2, 2)]
        }
    }
}

/// Appends the rows of `joint` at the poses of `a` and `b` (time step `h`) to `out`. The sides'
/// velocities (the free velocities of the step) decide limit activation.
pub(crate) fn push_joint_rows(joint: &Joint, a: &Side, b: &Side, h: f64, out: &mut Vec<ConstraintRow>) {
    let g = JointGeometry::new(joint, a, b);
    let beta = joint.stabilization;
    let inf = f64::INFINITY;
    let make = |row: JointRow, lo: f64, hi: f64| {
        let (def, offset) = row_def(joint, row).expect("position row");
        let (raw, j_a, j_b) = g.eval(def);
        let phi = raw - offset;
        let mut r = ConstraintRow::pair(
            RowKey::Joint { joint: joint.id, row },
            RowKind::Position,
            a.index,
            j_a,
            b.index,
            j_b,
        );
        r.phi = phi;
        r.rhs = -beta * phi / h;
        r.compliance = joint.compliance[row.slot()];
        r.lo = lo;
        r.hi = hi;
        r
    };
    for k in 0..joint.kind.locked_rows() {
        out.push(make(JointRow::Locked(k as u8), -inf, inf));
    }
    for &axis in joint.kind.free_axes() {
        let (limit, motor) = (joint.limits[axis.index()], joint.motors[axis.index()]);
        if limit.is_none() && motor.is_none() {
            continue;
        }
        let (s, js_a, js_b) = g.free_coordinate(axis);
        let s_dot = js_a.dot(&a.v, &a.w) + js_b.dot(&b.v, &b.w);
        if let Some(l) = limit {
            let phi = s - l.lower;
            if phi.min(phi + h * s_dot) < l.margin {
                out.push(make(JointRow::LowerLimit(axis), 0.0, inf));
            }
            let phi = l.upper - s;
            if phi.min(phi - h * s_dot) < l.margin {
                out.push(make(JointRow::UpperLimit(axis), 0.0, inf));
            }
        }
        if let Some(m) = motor {
            let row = JointRow::Motor(axis);
            let bound = m.max_force * h;
            let mut r = ConstraintRow::pair(
                RowKey::Joint { joint: joint.id, row },
                RowKind::Velocity,
                a.index,
                js_a,
                b.index,
                js_b,
            );
            r.rhs = m.target_speed(axis, s, h);
            r.compliance = joint.compliance[row.slot()];
            r.lo = -bound;
            r.hi = bound;
            out.push(r);
        }
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{Isometry3, Translation3, UnitQuaternion};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::dynamics::ids::{BodyId, JointId};
    use crate::dynamics::joint::{DEFAULT_COMPLIANCE, JOINT_SLOTS};
    use crate::dynamics::motor::{JointLimit, JointMotor};

    fn joint(kind: JointKind, fa: Isometry3<f64>, fb: Isometry3<f64>) -> Joint {
        // Limits (always active: huge margin) and motors on every free axis of the kind.
        let mut limits = [None; 2];
        let mut motors = [None; 2];
        for &axis in kind.free_axes() {
            limits[axis.index()] = Some(JointLimit { lower: -10.0, upper: 10.0, margin: 100.0 });
            motors[axis.index()] = Some(JointMotor::position(0.5, 1.0, 1.0));
        }
        Joint {
            id: JointId(0),
            name: "j".into(),
            kind,
            body_a: BodyId(0),
            body_b: Some(BodyId(1)),
            frame_a: fa,
            frame_b: fb,
            compliance: [DEFAULT_COMPLIANCE; JOINT_SLOTS],
            stabilization: 1.0,
            limits,
            motors,
            enabled: true,
        }
    }

    fn v3(rng: &mut ChaCha8Rng, s: f64) -> Vector3<f64> {
        if s == 0.0 {
            return Vector3::zeros();
        }
        Vector3::new(rng.random_range(-s..s), rng.random_range(-s..s), rng.random_range(-s..s))
    }

    fn advance(s: &Side, t: f64) -> Side {
        Side { x: s.x + s.v * t, q: UnitQuaternion::from_scaled_axis(s.w * t) * s.q, ..*s }
    }

    fn rows(j: &Joint, a: &Side, b: &Side) -> Vec<ConstraintRow> {
        let mut out = Vec::new();
        push_joint_rows(j, a, b, 0.01, &mut out);
        out
    }

    /// Rows counted per kind: locked rows, plus two limits and a motor per free axis.
    #[test]
    fn row_counts_per_kind() {
        let a = Side { index: Some(0), ..Side::world() };
        for (kind, expected) in [
            (JointKind::Fixed, 6),
            (JointKind::Hinge, 8),
            (JointKind::Prismatic, 8),
            (JointKind::Ball, 3),
            (JointKind::Cylindrical, 10),
            (JointKind::Universal, 4),
        ] {
            let j = joint(kind, Isometry3::identity(), Isometry3::identity());
            let r = rows(&j, &a, &Side::world());
            assert_eq!(r.len(), expected, "{kind:?}");
            let mut slots: Vec<usize> = r
                .iter()
                .map(|r| match r.key {
                    RowKey::Joint { row, .. } => row.slot(),
                    _ => unreachable!(),
                })
                .collect();
            slots.dedup();
            assert_eq!(slots.len(), expected, "{kind:?}: distinct slots");
            assert!(slots.iter().all(|&s| s < JOINT_SLOTS));
        }
    }

    /// `J v` equals the central difference of `φ` along the motion, for every row of every kind:
    /// the Jacobians are the exact derivatives of the violations (angular locks of all three axes
    /// only near zero error, where the rotation-vector map is linear; free angles exactly when the
    /// axes are aligned).
    #[test]
    fn jacobians_are_derivatives_of_violations() {
        let mut rng = ChaCha8Rng::seed_from_u64(42);
        for trial in 0..40 {
            for kind in JointKind::ALL {
                let a = Side {
                    index: Some(0),
                    x: v3(&mut rng, 2.0),
                    q: UnitQuaternion::from_scaled_axis(v3(&mut rng, 2.0)),
                    v: v3(&mut rng, 1.0),
                    w: v3(&mut rng, 1.0),
                };
                let fa = Isometry3::from_parts(
                    Translation3::from(v3(&mut rng, 1.0)),
                    UnitQuaternion::from_scaled_axis(v3(&mut rng, 2.0)),
                );
                // Frame b placed so that the joint is near its rest configuration (small errors),
                // except along the free axis.
                let wa = Isometry3::from_parts(Translation3::from(a.x), a.q) * fa;
                let small = if trial % 2 == 0 { 1e-3 } else { 0.0 };
                let rest = wa
                    * Isometry3::from_parts(
                        Translation3::from(v3(&mut rng, small)),
                        UnitQuaternion::from_scaled_axis(v3(&mut rng, small)),
                    );
                let b = Side {
                    index: Some(1),
                    x: v3(&mut rng, 2.0),
                    q: UnitQuaternion::from_scaled_axis(v3(&mut rng, 2.0)),
                    v: v3(&mut rng, 1.0),
                    w: v3(&mut rng, 1.0),
                };
                let xb = Isometry3::from_parts(Translation3::from(b.x), b.q);
                let fb = xb.inverse() * rest;
                let j = joint(kind, fa, fb);
                let r0 = rows(&j, &a, &b);
                let eps = 1e-6;
                let (rp, rm) = (
                    rows(&j, &advance(&a, eps), &advance(&b, eps)),
                    rows(&j, &advance(&a, -eps), &advance(&b, -eps)),
                );
                assert_eq!(r0.len(), rp.len());
                let v = [a.v, b.v];
                let w = [a.w, b.w];
                for (i, r) in r0.iter().enumerate() {
                    if r.kind == RowKind::Velocity {
                        continue;
                    }
                    let fd = (rp[i].phi - rm[i].phi) / (2.0 * eps);
                    let jv = r.velocity(&v, &w);
                    // Rotation-vector rows are first-order exact; free angles exact when aligned.
                    let RowKey::Joint { row, .. } = r.key else { unreachable!() };
                    let exact = match row {
                        JointRow::Locked(k) => {
                            !(kind == JointKind::Fixed && k >= 3 || kind == JointKind::Prismatic && k >= 2)
                        }
                        JointRow::LowerLimit(ax) | JointRow::UpperLimit(ax) => ax == FreeAxis::Linear,
                        JointRow::Motor(_) => unreachable!(),
                    };
                    let spin = (a.w - b.w).norm() + a.w.norm() + b.w.norm();
                    let tol = if exact { 1e-7 } else { 2.0 * small * spin + 1e-7 };
                    assert!((fd - jv).abs() < tol, "{kind:?} row {i} ({:?}): fd {fd} vs Jv {jv}", r.key);
                }
            }
        }
    }

    /// At rest (frames coincide) every locked row has zero violation.
    #[test]
    fn rest_configuration_has_zero_violation() {
        let a = Side {
            index: Some(0),
            x: Vector3::new(1.0, 2.0, 3.0),
            q: UnitQuaternion::from_euler_angles(0.1, 0.2, 0.3),
            ..Side::world()
        };
        let fa = Isometry3::translation(0.5, 0.0, 0.0);
        let wa = Isometry3::from_parts(Translation3::from(a.x), a.q) * fa;
        for kind in JointKind::ALL {
            let j = joint(kind, fa, wa); // body B is the world
            for r in rows(&j, &a, &Side::world()) {
                if let RowKey::Joint { row: JointRow::Locked(_), .. } = r.key {
                    assert!(r.phi.abs() < 1e-15, "{kind:?}: {}", r.phi);
                }
            }
        }
    }

    /// A cylindrical joint's free motion (slide along and turn about `e₁`) leaves its locked rows
    /// at zero and shows up in its two free coordinates; a universal joint's (turns about both pins)
    /// leaves its locked rows at zero, while a twist about the shaft axis `e₃` violates its angular row.
    #[test]
    fn free_motions_leave_locked_rows_alone() {
        let fa = Isometry3::from_parts(
            Translation3::new(0.2, -0.1, 0.3),
            UnitQuaternion::from_euler_angles(0.4, -0.3, 1.0),
        );
        let wa = Isometry3::from_parts(
            Translation3::from(Vector3::new(1.0, 0.5, 2.0)),
            UnitQuaternion::identity(),
        ) * fa;
        let (e1, e2, e3) =
            (wa.rotation * Vector3::x(), wa.rotation * Vector3::y(), wa.rotation * Vector3::z());
        let b = Side::world();
        // Body A at its rest pose, then moved by a rigid motion about the joint frame.
        let move_a = |m: Isometry3<f64>| {
            let pose = m * Isometry3::from_parts(
                Translation3::from(Vector3::new(1.0, 0.5, 2.0)),
                UnitQuaternion::identity(),
            );
            Side { index: Some(0), x: pose.translation.vector, q: pose.rotation, ..Side::world() }
        };
        let about = |axis: Vector3<f64>, angle: f64| {
            let r = UnitQuaternion::from_scaled_axis(axis * angle);
            Isometry3::from_parts(Translation3::from(wa.translation.vector - r * wa.translation.vector), r)
        };
        let cyl = joint(JointKind::Cylindrical, fa, wa);
        let a = move_a(
            Isometry3::from_parts(Translation3::from(e1 * 0.7), UnitQuaternion::identity()) * about(e1, 0.6),
        );
        let g = JointGeometry::new(&cyl, &a, &b);
        assert!((g.free_coordinate(FreeAxis::Linear).0 - 0.7).abs() < 1e-12);
        assert!((g.free_coordinate(FreeAxis::Angular).0 - 0.6).abs() < 1e-12);
        for r in rows(&cyl, &a, &b)
            .iter()
            .filter(|r| matches!(r.key, RowKey::Joint { row: JointRow::Locked(_), .. }))
        {
            assert!(r.phi.abs() < 1e-12, "{:?}: {}", r.key, r.phi);
        }
        let uni = joint(JointKind::Universal, fa, wa);
        // Turning A about its pin e₁ and then about B's pin e₂ keeps the pins perpendicular.
        let a = move_a(about(e2, 0.5) * about(e1, 0.8));
        assert!(rows(&uni, &a, &b).iter().all(|r| r.phi.abs() < 1e-12));
        let a = move_a(about(e3, 0.1));
        let twist = rows(&uni, &a, &b)[3].phi;
        assert!((twist.abs() - 0.1f64.sin()).abs() < 1e-12, "{twist}");
    }
}
