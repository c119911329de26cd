//! Position projection (post-stabilization, Cline & Pai 2003): an optional correction of the new
//! positions after the velocity step, leaving the velocities alone.
//!
//! **Why.** The velocity rows make `J(x) v⁺ = −βφ/h`, a condition linearized at the start of the
//! step. Integrating `x⁺ = x + h v⁺`, `q⁺ = exp(hω⁺/2) ⊗ q` then leaves a second-order error: a
//! body point at lever arm `r` from the centre of mass moves along the chord, not the arc, and a
//! joint anchor drifts by about `(h|ω|)² |r| / 2` per step (≈ 1 mm at `h = 1/60`, `ω = 3 rad/s`,
//! `r = 1 m`). The next step's `−φ/h` removes it again, so it does not accumulate, but it is there
//! at every step end.
//!
//! **How.** At the new poses, with the position rows `J⁺` (locked rows and near-active limits,
//! no motors), solve the same kind of MLCP as the velocity step with zero free velocity,
//!
//! ```text
//!   (J⁺ M̃⁻¹ J⁺ᵀ + C/h²) μ = −β (φ(x⁺) + c λ / h) / h,     μ ∈ [lo, hi],
//! ```
//!
//! and move the positions by `h M̃⁻¹ J⁺ᵀ μ` (translation `h δv`, rotation `exp(h δω/2) ⊗ q`), `M̃` the
//! velocity step's effective inertia: `Ĩ = I + s 𝟙` where the geometric stiffness raised a loaded
//! body's inertia (`geometric_stiffness.rs`; `K̃` is isotropic, so `Ĩ` is that at the new
//! orientation too), `M̃ = M` elsewhere. A Gauss–Newton step weighted by the plain `M` closes the
//! anchors of light links under a heavy load by turning them — the mode the velocity step had just
//! stiffened — and breaks the chain it should straighten; weighted by `M̃` its corrections go where
//! the velocity step's go. The
//! target `φ = −c λ / h` (λ the velocity step's impulse of the same row) keeps a compliant row at its
//! spring deflection instead of pulling it rigid; with `c → 0` the target is `φ = 0`. One iteration
//! is a Gauss–Newton step on the constraint manifold: the residual drops from `O((hω)² r)` to
//! `O((hω)⁴ r)`. The projection uses the same solver (with its own buffers), so limits stay
//! unilateral; motors and couplings (velocity rows) take no part.
//!
//! **Costs** (measured in `tests/dynamics_*.rs`). One more row evaluation, assembly and solve per
//! island per iteration. Velocities are left alone, so linear momentum is untouched, but they are no
//! longer tangent to the corrected configuration and the next step's constraint solve removes the
//! normal part: the projection dissipates energy at a rate `~(h ω_rel)²` per step, and its inward
//! corrections on spinning bodies act like a drag on angular momentum (a free-floating chain
//! spinning at 1–3 rad/s loses 22 % of `L` and 35 % of its energy over 10 s at `h = 1/60`, against
//! 0.9 % and 3 % without projection). A slow pendulum loses 0.13 % of its amplitude over 10 periods.
//! It therefore stays off by default; turn it on where joint drift matters more than energy.
//!
//! It is robust where the velocity-level alternatives are not: a chain pulled taut between two
//! fixed points (a near-singular `J`) stays bounded with it, whereas predicting the second-order
//! drift into the velocity rows' right-hand side (tried, and removed) blew up there.

use std::time::Instant;

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use super::assemble::BodyMotion;
use super::body::RigidBody;
use super::error::StepError;
use super::ids::BodyId;
use super::joint::Joint;
use super::joint_rows::{JointGeometry, push_joint_rows};
use super::rows::{RowKey, RowKind, Side};
use super::settings::WorldSettings;
use super::step::StepWorkspace;
use crate::solver::Solver;

/// Most projections the joint-error guard runs in one step.
pub const GUARD_ITERATIONS: usize = 4;

/// Runs `settings.projection_iterations` projections on `ws.x_new`, `ws.q_new` (step `step`), then
/// the joint-error guard: while the worst joint error at the new poses exceeds
/// `settings.joint_error_tolerance` beyond its elastic deflection and the last projection cut it by
/// a quarter, one more (at most
/// [`GUARD_ITERATIONS`]). The guard's count is left in `ws.guard_iterations`, the drift it ended
/// with (0 with the guard off) in `ws.guard_drift`.
pub(crate) fn project(
    settings: &WorldSettings,
    bodies: &[RigidBody],
    joints: &[Joint],
    ws: &mut StepWorkspace,
    step: u64,
) -> Result<(), StepError> {
    for _ in 0..settings.projection_iterations {
        project_once(settings, bodies, joints, ws, step)?;
    }
    ws.guard_iterations = 0;
    ws.guard_drift = 0.0;
    let tol = settings.joint_error_tolerance;
    if tol > 0.0 {
        let h = settings.timestep;
        let mut error = worst_new_joint_drift(joints, ws, step, h, tol);
        while error > tol && ws.guard_iterations < GUARD_ITERATIONS {
            project_once(settings, bodies, joints, ws, step)?;
            ws.guard_iterations += 1;
            let after = worst_new_joint_drift(joints, ws, step, h, tol);
            // A projection that does not cut the drift by a quarter meets what it cannot remove (a
            // limit against a contact, a drift too large to linearize): stop rather than spend the
            // budget.
            let progress = after < 0.75 * error;
            error = after;
            if !progress {
                break;
            }
        }
        ws.guard_drift = error;
    }
    Ok(())
}

/// The worst drift of the enabled joints at the new poses `ws.x_new`, `ws.q_new` (m): the
/// locked-anchor error (as [`World::max_joint_error`](super::World::max_joint_error) reads it after
/// the step) less the joint's elastic deflection `|c λ / h|` over its locked linear rows, `λ` this
/// step's impulses (stamped `step + 1`) — what a projection can remove; a soft joint's give under
/// its load is its target. The deflection is read only for joints whose error exceeds `above`
/// (the others count with their error). NaN counts as infinitely large.
fn worst_new_joint_drift(joints: &[Joint], ws: &StepWorkspace, step: u64, h: f64, above: f64) -> f64 {
    let mut worst = 0.0f64;
    for j in joints.iter().filter(|j| j.enabled) {
        let (a, b) = (new_side(Some(j.body_a), ws), new_side(j.body_b, ws));
        let e = JointGeometry::new(j, &a, &b).locked_anchor_error(j.kind);
        if e.is_nan() {
            return f64::INFINITY;
        }
        let drift = if e > above { (e - elastic_deflection(j, ws, step, h)).max(0.0) } else { e };
        worst = worst.max(drift);
    }
    worst
}

/// Joint `j`'s elastic deflection under its impulses of this step (stamped `step + 1`; 0 for a
/// row not solved in it).
fn elastic_deflection(j: &Joint, ws: &StepWorkspace, step: u64, h: f64) -> f64 {
    j.elastic_deflection(h, |row| match ws.warm_row(RowKey::Joint { joint: j.id, row }) {
        Some(w) if w.stamp == step + 1 => w.lambda,
        _ => 0.0,
    })
}

/// A joint's side at the new poses, at rest (the projection moves positions only).
fn new_side(id: Option<BodyId>, ws: &StepWorkspace) -> Side {
    match id {
        None => Side::world(),
        Some(id) => Side {
            index: Some(id.index()),
            x: ws.x_new[id.index()],
            q: ws.q_new[id.index()],
            v: Vector3::zeros(),
            w: Vector3::zeros(),
        },
    }
}

/// One Gauss–Newton projection of `ws.x_new`, `ws.q_new` onto the joints' position rows.
fn project_once(
    settings: &WorldSettings,
    bodies: &[RigidBody],
    joints: &[Joint],
    ws: &mut StepWorkspace,
    step: u64,
) -> Result<(), StepError> {
    let h = settings.timestep;
    let n = bodies.len();
    {
        ws.proj_motion.clear();
        for (i, b) in bodies.iter().enumerate() {
            let mut m = BodyMotion { dynamic: b.is_dynamic(), inv_mass: b.inv_mass(), ..Default::default() };
            if m.dynamic {
                // The inertia of the velocity step: raised by the geometric stiffness where it was.
                let r = ws.q_new[i].to_rotation_matrix().into_inner();
                let s = ws.gs_iso.get(i).copied().unwrap_or(0.0);
                let inv_b = match s > 0.0 {
                    true => (b.inertia_body() + Matrix3::identity() * s)
                        .try_inverse()
                        .unwrap_or(*b.inv_inertia_body()),
                    false => *b.inv_inertia_body(),
                };
                m.inv_inertia = r * inv_b * r.transpose();
            }
            ws.proj_motion.push(m);
        }
        ws.proj_rows.clear();
        for j in joints.iter().filter(|j| j.enabled) {
            let (a, b) = (new_side(Some(j.body_a), ws), new_side(j.body_b, ws));
            push_joint_rows(j, &a, &b, h, &mut ws.proj_rows);
        }
        ws.proj_rows.retain(|r| r.kind == RowKind::Position);
        for i in 0..ws.proj_rows.len() {
            let r = ws.proj_rows[i];
            let RowKey::Joint { joint, .. } = r.key else { continue };
            let w = ws.warm_row(r.key).copied().unwrap_or_default();
            let lambda = if w.stamp == step + 1 { w.lambda } else { 0.0 };
            ws.proj_rows[i].rhs =
                -joints[joint.index()].stabilization * (r.phi + r.compliance * lambda / h) / h;
        }
        ws.proj_islands.build(&ws.dynamic, &ws.proj_rows);
        ws.dv.clear();
        ws.dv.resize(n, Vector3::zeros());
        ws.dw.clear();
        ws.dw.resize(n, Vector3::zeros());
        let mut solved = 0;
        for k in 0..ws.proj_islands.len() {
            let m = ws.proj_islands.rows(k).len();
            if m == 0 {
                continue;
            }
            let t = Instant::now();
            ws.asm.assemble(k, &ws.proj_islands, &ws.proj_rows, &ws.proj_motion, h);
            ws.asm
                .fill_mlcp(&mut ws.problem, false)
                .map_err(|source| StepError::Assembly { island: k, source })?;
            if ws.proj_solvers.len() <= solved {
                ws.proj_solvers.push(Solver::new(settings.solver));
            }
            ws.asm.lambda.clear();
            ws.asm.lambda.resize(m, 0.0);
            ws.proj_solvers[solved].solve(&ws.problem, &mut ws.asm.lambda);
            ws.asm.apply_impulses(k, &ws.proj_islands, &ws.proj_rows, &mut ws.dv, &mut ws.dw);
            // A projection island lies within one velocity island (couplings, velocity rows, may
            // join several projection islands into one): charge the time to that one.
            let body = ws.proj_islands.bodies(k)[0];
            if let Some(s) = ws.islands.island_of(body).and_then(|v| ws.stat_of_island.get(v).copied())
                && let Some(st) = ws.stats.get_mut(s)
            {
                st.projection_us += t.elapsed().as_secs_f64() * 1e6;
            }
            solved += 1;
        }
        for i in 0..n {
            if ws.dynamic[i] {
                ws.x_new[i] += ws.dv[i] * h;
                let q = UnitQuaternion::from_scaled_axis(ws.dw[i] * h) * ws.q_new[i];
                ws.q_new[i] = UnitQuaternion::new_normalize(q.into_inner());
            }
        }
    }
    Ok(())
}
