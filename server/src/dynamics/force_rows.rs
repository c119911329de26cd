//! Force element → its row: a spring–damper's implicit force row (`force.rs` for the law and the
//! row's derivation). Buoyancy and drag have no row; they enter the free velocities.

use super::force::SpringDamper;
use super::ids::ForceId;
use super::rows::{ConstraintRow, Jac6, RowKey, RowKind, Side};

/// Appends the force row of spring `s` (element `id`) to `out`, with the ends `a` (body A) and `b`
/// at the current poses; nothing for a spring of zero length or with `k = c = 0`.
pub(crate) fn push_spring_row(
    s: &SpringDamper,
    id: ForceId,
    a: &Side,
    b: &Side,
    h: f64,
    out: &mut Vec<ConstraintRow>,
) {
    let (k, c) = (s.stiffness, s.damping);
    if k == 0.0 && c == 0.0 {
        return;
    }
    let p_a = a.x + a.q * s.anchor_a;
    let p_b = b.x + b.q * s.anchor_b;
    let d = p_b - p_a;
    let l = d.norm();
    if l < 1e-12 {
        return;
    }
    let n = d / l;
    let j_a = Jac6::new(-n, -(p_a - a.x).cross(&n));
    let j_b = Jac6::new(n, (p_b - b.x).cross(&n));
    let mut r = ConstraintRow::pair(RowKey::Force(id), RowKind::Force, a.index, j_a, b.index, j_b);
    // c_row = 1/(k + c/h), β = k c_row = h k / (h k + c).
    let compliance = 1.0 / (k + c / h);
    let beta = k * compliance;
    r.phi = l - s.rest_length;
    r.compliance = compliance;
    r.rhs = -beta * r.phi / h;
    out.push(r);
}
