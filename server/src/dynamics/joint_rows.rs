//! Joint model → constraint rows: violations and Jacobian blocks of the four joint kinds, the limit
//! rows and the motor row (the row equation and its signs are in `rows.rs`).
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
//! **Hinge angular rows** keep B's axis `f₁` perpendicular to `e₂` and `e₃`: `φ = u · f₁` for
//! `u ∈ {e₂, e₃}`, exactly `φ̇ = ω_A · (u × f₁) + ω_B · (f₁ × u)`, so `J_A = (0, u × f₁)`,
//! `J_B = (0, f₁ × u)`.
//!
//! **Free coordinate** `s` of A relative to B (B is the parent, or the world): hinge angle
//! `s = −atan2(e₃·f₂, e₂·f₂)` with `ṡ = e₁ · (ω_A − ω_B)` (exact when the axes are aligned);
//! prismatic displacement `s = −e₁ · d` with the negated linear-row Jacobian of `u = e₁`.
//! Lower limit: `φ = s − lower`, `J = J_s`; upper limit: `φ = upper − s`, `J = −J_s`; both
//! `λ ∈ [0, ∞)`, emitted when `min(φ, φ + h ṡ_toward) < margin` (with the free velocities, so a
//! joint about to cross its bound within the step is caught). Motor: velocity row
//! `J_s v⁺ + (c/h²) λ = target_speed`, `λ ∈ [−F h, F h]`.
//!
//! Each row is named by a [`JointRow`] slot and evaluated from a `RowDef` (which function of the
//! geometry it is), so the same definition serves any pose. The Jacobians are checked against
//! central differences of the violations in the tests below.

use nalgebra::{UnitQuaternion, Vector3};

use super::joint::{Joint, JointKind, JointRow};
use super::rows::{ConstraintRow, Jac6, RowKey, RowKind};

/// Pose and velocity of one end of a joint (`index: None` is the world frame, at rest).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Side {
    pub index: Option<usize>,
    pub x: Vector3<f64>,
    pub q: UnitQuaternion<f64>,
    pub v: Vector3<f64>,
    pub w: Vector3<f64>,
}

impl Side {
    /// The world frame.
    pub fn world() -> Self {
        Side {
            index: None,
            x: Vector3::zeros(),
            q: UnitQuaternion::identity(),
            v: Vector3::zeros(),
            w: Vector3::zeros(),
        }
    }
}

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

    /// Linear row along `u`: `(φ, J_A, J_B)`.
    fn linear(&self, u: Vector3<f64>) -> (f64, Jac6, Jac6) {
        let phi = u.dot(&(self.p_b - self.p_a));
        (phi, Jac6::new(-u, -self.r_a.cross(&u)), Jac6::new(u, self.r_b.cross(&u)))
    }

    /// Free coordinate of a hinge or prismatic joint, of A relative to B (B is the parent or the
    /// world), and its Jacobian blocks `(s, J_A, J_B)`.
    pub fn free_coordinate(&self, kind: JointKind) -> (f64, Jac6, Jac6) {
        let (s, ja, jb) = match kind {
            JointKind::Prismatic => self.linear(self.e[0]),
            _ => {
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
    /// Hinge angular row `e_k · f₁`.
    HingeAxis(usize),
    /// Free coordinate `s` (sign +1: lower limit `s − lower`; −1: upper limit `upper − s`).
    Free(f64),
}

impl JointGeometry {
    /// `(φ, J_A, J_B)` of a row definition (free-coordinate rows: `±s` without the bound).
    fn eval(&self, kind: JointKind, def: RowDef) -> (f64, Jac6, Jac6) {
        let z = Vector3::zeros();
        match def {
            RowDef::Linear(k) => self.linear(self.e[k]),
            RowDef::Angular(k) => {
                let u = self.e[k];
                (u.dot(&self.theta), Jac6::new(z, -u), Jac6::new(z, u))
            }
            RowDef::HingeAxis(k) => {
                let (u, f1) = (self.e[k], self.f[0]);
                (u.dot(&f1), Jac6::new(z, u.cross(&f1)), Jac6::new(z, f1.cross(&u)))
            }
            RowDef::Free(sign) => {
                let (s, ja, jb) = self.free_coordinate(kind);
                if sign > 0.0 { (s, ja, jb) } else { (-s, ja.neg(), jb.neg()) }
            }
        }
    }
}

/// Row definition and bound offset of a position row slot of a joint (`None` for the motor).
fn row_def(joint: &Joint, row: JointRow) -> Option<(RowDef, f64)> {
    let lim = joint.limit.unwrap_or(super::joint::JointLimit::new(0.0, 0.0));
    Some(match (joint.kind, row) {
        (_, JointRow::Motor) => return None,
        (_, JointRow::LowerLimit) => (RowDef::Free(1.0), lim.lower),
        (_, JointRow::UpperLimit) => (RowDef::Free(-1.0), -lim.upper),
        (JointKind::Fixed, JointRow::Locked(k)) if k >= 3 => (RowDef::Angular(k as usize - 3), 0.0),
        (JointKind::Hinge, JointRow::Locked(k)) if k >= 3 => (RowDef::HingeAxis(k as usize - 2), 0.0),
        (JointKind::Prismatic, JointRow::Locked(k)) if k >= 2 => (RowDef::Angular(k as usize - 2), 0.0),
        (JointKind::Prismatic, JointRow::Locked(k)) => (RowDef::Linear(k as usize + 1), 0.0),
        (_, JointRow::Locked(k)) => (RowDef::Linear(k as usize), 0.0),
    })
}

/// Appends the rows of `joint` at the poses of `a` and `b` (time step `h`) to `out`. The sides'
/// velocities (the free velocities of the step) decide limit activation.
pub(crate) fn push_joint_rows(joint: &Joint, a: &Side, b: &Side, h: f64, out: &mut Vec<ConstraintRow>) {
    let g = JointGeometry::new(joint, a, b);
    let beta = joint.stabilization;
    let kind = joint.kind;
    let inf = f64::INFINITY;
    let mut push = |row: JointRow, lo: f64, hi: f64| {
        let (def, offset) = row_def(joint, row).expect("position row");
        let (raw, j_a, j_b) = g.eval(kind, def);
        let phi = raw - offset;
        out.push(ConstraintRow {
            key: RowKey::Joint { joint: joint.id, row },
            kind: RowKind::Position,
            body_a: a.index,
            body_b: b.index,
            j_a,
            j_b,
            phi,
            rhs: -beta * phi / h,
            compliance: joint.compliance[row.slot()],
            lo,
            hi,
            findex: None,
        });
    };
    for k in 0..kind.locked_rows() {
        push(JointRow::Locked(k as u8), -inf, inf);
    }
    if !kind.has_free_axis() || (joint.limit.is_none() && joint.motor.is_none()) {
        return;
    }
    let (s, js_a, js_b) = g.free_coordinate(kind);
    let s_dot = js_a.dot(&a.v, &a.w) + js_b.dot(&b.v, &b.w);
    if let Some(l) = joint.limit {
        let phi = s - l.lower;
        if phi.min(phi + h * s_dot) < l.margin {
            push(JointRow::LowerLimit, 0.0, inf);
        }
        let phi = l.upper - s;
        if phi.min(phi - h * s_dot) < l.margin {
            push(JointRow::UpperLimit, 0.0, inf);
        }
    }
    if let Some(m) = joint.motor {
        let bound = m.max_force * h;
        out.push(ConstraintRow {
            key: RowKey::Joint { joint: joint.id, row: JointRow::Motor },
            kind: RowKind::Velocity,
            body_a: a.index,
            body_b: b.index,
            j_a: js_a,
            j_b: js_b,
            phi: 0.0,
            rhs: m.target_speed,
            compliance: joint.compliance[JointRow::Motor.slot()],
            lo: -bound,
            hi: bound,
            findex: None,
        });
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{Isometry3, Translation3};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;
    use crate::dynamics::body::BodyId;
    use crate::dynamics::joint::{DEFAULT_COMPLIANCE, JOINT_SLOTS, JointId, JointLimit, JointMotor};

    fn joint(kind: JointKind, fa: Isometry3<f64>, fb: Isometry3<f64>) -> Joint {
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
            limit: Some(JointLimit { lower: -10.0, upper: 10.0, margin: 100.0 }),
            motor: Some(JointMotor { target_speed: 0.0, max_force: 1.0 }),
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

    /// `J v` equals the central difference of `φ` along the motion, for every row of every kind:
    /// the Jacobians are the exact derivatives of the violations (angular locks of all three axes
    /// only near zero error, where the rotation-vector map is linear).
    #[test]
    fn jacobians_are_derivatives_of_violations() {
        let mut rng = ChaCha8Rng::seed_from_u64(42);
        for trial in 0..40 {
            for kind in [JointKind::Fixed, JointKind::Hinge, JointKind::Prismatic, JointKind::Ball] {
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
                for (i, r) in r0.iter().enumerate() {
                    if r.kind == RowKind::Velocity {
                        continue;
                    }
                    let fd = (rp[i].phi - rm[i].phi) / (2.0 * eps);
                    let jv = r.j_a.dot(&a.v, &a.w) + r.j_b.dot(&b.v, &b.w);
                    // Rotation-vector rows are first-order exact; hinge free angle exact when aligned.
                    let exact = matches!(r.key, RowKey::Joint { row: JointRow::Locked(k), .. }
                        if !(matches!(kind, JointKind::Fixed) && k >= 3 || matches!(kind, JointKind::Prismatic) && k >= 2));
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
        for kind in [JointKind::Fixed, JointKind::Hinge, JointKind::Prismatic, JointKind::Ball] {
            let j = joint(kind, fa, wa); // body B is the world
            for r in rows(&j, &a, &Side::world()) {
                if let RowKey::Joint { row: JointRow::Locked(_), .. } = r.key {
                    assert!(r.phi.abs() < 1e-15, "{kind:?}: {}", r.phi);
                }
            }
        }
    }
}
