//! Geometric stiffness of loaded joints: the stiffness that a joint's constraint force has because
//! its lever arms turn with the bodies, added to the bodies' effective inertia so that a light link
//! under a heavy tension stays stable at `h = 1/60` (issue 12).
//!
//! **What is missing without it.** The rows of a step are linearized at the start of the step
//! (paper eq. 1): `J(x)` is frozen while the bodies turn by `h ω⁺`. The constraint force of a
//! joint, `F` at the anchor `p` with lever arm `r = p − x` on a body, exerts the torque `τ = r × F`;
//! turning the body by `δθ` turns the lever arm, `δr = δθ × r`, and with `F` held
//!
//! ```text
//!   δτ = (δθ × r) × F = K δθ,       K = [F]× [r]× = r Fᵀ − (F · r) 𝟙                         (G1)
//! ```
//!
//! (Andrews, Teichmann and Kry 2017 derive the same blocks from `∂(Jᵀλ)/∂x`; Tournier et al. 2015
//! add `h² K` to the system matrix). For a link hanging from its top (`F` pulls outward along `r`,
//! tension `T = |F|`, `|r| = ℓ/2`) `K = −T ℓ/2 (𝟙 − r̂ r̂ᵀ)`: a restoring stiffness against tilt. Left
//! at the start of the step, it acts explicitly — a symplectic Euler step on a spring of stiffness
//! `k = Σ T |r|` over both ends against the link's inertia `I`, which is stable only while
//! `h² k / I < 4`. A 0.5 kg capsule link of 0.1 m (`I ≈ 5e-4 kg m²`) loses that at `T ≈ 70 N`; its
//! zig-zag mode then grows every step until the chain whips (measured in the issue note).
//!
//! **What we add.** Per dynamic body `k`, summed over the joints at it (their linear rows: the
//! anchor force, from the previous step's impulses `λ̄` — the warm start — as `F = Σ λ̄_i u_i / h`),
//! the isotropic positive semidefinite stiffness
//!
//! ```text
//!   K̃_k = Σ_joints |F| |r| 𝟙   ⪰   Σ_joints |sym(K)|,     sym(K) = (r Fᵀ + F rᵀ)/2 − (F · r) 𝟙     (G2)
//! ```
//!
//! (the eigenvalues of `sym(K)` are `−F·r` and `(−F·r ± |F||r|)/2`, all of modulus `≤ |F||r|`; the
//! antisymmetric part cancels over a body in equilibrium and is dropped). It raises the body's
//! rotational inertia to `Ĩ_k = I_k + α_k h² K̃_k` and with it the effective mass matrix
//! `M̃ = M + h² K̃` of eq. 1–2: `A = J M̃⁻¹ Jᵀ + C/h²`, `v⁺ = v_free + M̃⁻¹ Jᵀ λ`. `M̃` is block
//! diagonal per body like `M` (rotation–rotation block only, `F` being held in world), so `A` keeps
//! its sparsity and stays symmetric positive definite; the solver is untouched. Cross-body terms
//! (the change of `F` with the other body's rotation) would put fill into `M̃⁻¹` and `A`; they are
//! left out. Isotropic, `Ĩ` keeps `I`'s principal axes: the exact `|sym(K)|` (Andrews et al.'s
//! absolute eigenvalues) has no stiffness along a link's axis, and a `K̃` slightly off that axis
//! then steers the large tilt impulses into the link's tiny twist inertia (`m r²/2`): links spun at
//! 50–75 rad/s about their axes and the joint error reached 1.6 mm at a mass ratio of 1e4 (0.02 mm
//! with the isotropic bound).
//!
//! Two ways to put `M̃` into the momentum equation (`[scene] geometric_stiffness`):
//!
//! ```text
//!   implicit (default):  M̃ v⁺ = M v₀ + h f + Jᵀ λ,      v_free = v₀ + M̃⁻¹ (h f − h² K̃ v₀)     (G3)
//!   inertial:            M̃ (v⁺ − v₀) = h f + Jᵀ λ,      v_free = v₀ + M̃⁻¹ h f                 (G4)
//! ```
//!
//! (G3) is the linearly implicit step of Tournier et al. and Andrews et al., `F(x⁺) ≈ F(x) +
//! h K v⁺` with `K → −K̃`: it damps every rotation of a loaded body, the rigid swing of a loaded
//! chain included — for a chain pendulum of length `L` about `h² T L ω²` per step against
//! `½ m L² ω²`, a rate `≈ 2 h g / L` independent of the load (the rig of 2 m keeps 12–17 % of its
//! swing energy after 20 s), while its energy never rises and its period stays within 1 % of the
//! compound pendulum's. (G4) charges the stiffness only against the velocity change within the
//! step: the stiff mode sees the inertia `I + h² k`, so `h² k / (I + h² k) < 1` and the explicit
//! part stays stable, while a steady rotation is not dragged (the rig keeps its energy to a few %,
//! period within 0.5 %); but the energy oscillates up to 1.7–3.7 % above its initial value. The
//! default is (G3), whose energy only decays; measurements in the issue note and
//! `tests/dynamics_swinging_load.rs`.
//!
//! **Where it applies.** Only where it matters: the weight `α_k = clamp(ρ_k / ρ₀ − 1, 0, 1)` with
//!
//! ```text
//!   ρ_k = h² ‖K̃_k‖_F / (I_min,k + m_k r²_max,k)                                                   (G5)
//! ```
//!
//! — the stiffness ratio of the body's tilt about a loaded anchor (its inertia there by parallel
//! axes, `r_max` its longest loaded lever arm; the Frobenius norm bounds the largest eigenvalue) —
//! and `ρ₀ = 0.25` ([`RHO_START`]) ramps the correction in between a sixteenth and an eighth of
//! the explicit bound `ρ = 4`. A chain link of mass `m` and length `ℓ` under tension `T` has
//! `ρ ≈ 3√3 h² T / (m ℓ)`: 1.7 for the rig's 0.5 kg links of 0.1 m under the 60 N of a 5 kg load,
//! which broke. A point-like bob on a 1 m arm (`I ≈ 0`, `m r² = 1 kg m²`, `T = 10 N`) has `ρ ≈ 0.005`
//! and is left alone: charging the tilt against `I` alone would have damped its swing to 23 % of
//! its amplitude in 10 periods (`tests/dynamics_pendulum.rs`). Light machines and free-floating
//! bodies (where the exact momentum balance of the plain step matters,
//! `tests/dynamics_momentum.rs`) are left exactly as before. Halving `α` on the rig lets it break
//! again at a mass ratio of 1,000.
//!
//! **When the load jumps.** `K̃` comes from the previous step's impulses. At an impact a tension can
//! jump by orders of magnitude within one step: a crane's hook, its rope slack after the load
//! landed (180 N), strikes the load and the rope's top links carry 1.2e5 N in the next step. They
//! are then solved with the inertia of the slack rope, `ρ ≈ 600` against the explicit bound 4, and
//! turn by 1.2–1.6 rad within the step: the joints open by 0.3 m (the crane's hose burst,
//! `tests/dynamics_hose_burst.rs`). After each solve the step therefore checks, per dynamic body,
//! `K̃_new` from the impulses just solved against the inertia the body was solved with,
//!
//! ```text
//!   h² ‖K̃_new‖_F  >  2 (I_min + m r²_max + α h² ‖K̃_used‖_F)                                      (G6)
//! ```
//!
//! (`ρ > 2` on the corrected inertia: half the explicit bound) while the body turns by more than
//! `h |ω⁺| > 0.1 rad` in the step — the symptom, as the rope's 1.2–1.6 rad above; a grasp whose
//! squeeze jumps but whose claws barely move is left alone — for bodies whose island's
//! solve settled (a solve stopped at its cap returns a safe iterate, not the step's forces; chasing
//! its impulses moved the forwarder's capped grasp). If any body lags, the step
//! is solved once more — free velocities with `K̃_new`, the same rows, warm-started from the first
//! solve, the first solve's input work taken back — and the second answer is kept. A load that
//! changes smoothly does not trigger it (`K̃_new ≈ K̃_used` gives `ρ ≈ ρ_used / (1 + α ρ_used) ≤ 1`
//! once `α = 1`: the tension must double within a step, more for a body not yet corrected); the
//! count is [`World::geometric_stiffness_resolves`](super::World::geometric_stiffness_resolves).
//!
//! **Cost.** Per joint with linear rows and valid warm impulses: its world geometry and two norms;
//! per corrected body one 3 × 3 inverse. Nothing
//! is allocated (one reusable `Vec<Matrix3>` per world).

use nalgebra::{Matrix3, Vector3};

use super::body::RigidBody;
use super::ids::BodyId;
use super::joint::{JOINT_SLOTS, Joint};
use super::joint_rows::{JointGeometry, linear_row_axes};
use super::rows::{Side, WarmRow};

/// Stiffness ratio `ρ₀ = h² ‖K̃‖ / I_min` at which the correction starts (module doc); full from `2 ρ₀`.
pub const RHO_START: f64 = 0.25;

/// `| sym(r Fᵀ) − (F·r) 𝟙 |` (eq. G2) of a force `f` at lever arm `r`.
#[cfg(test)]
fn abs_sym_stiffness(r: &Vector3<f64>, f: &Vector3<f64>) -> Matrix3<f64> {
    let rf = r * f.transpose();
    let s = (rf + rf.transpose()) * 0.5 - Matrix3::identity() * f.dot(r);
    let eig = s.symmetric_eigen();
    let abs = eig.eigenvalues.map(f64::abs);
    eig.eigenvectors * Matrix3::from_diagonal(&abs) * eig.eigenvectors.transpose()
}

/// `|F| |r| 𝟙`: the isotropic upper bound of `|sym(K)|` (eq. G2) of a force `f` at lever arm `r`.
#[inline]
pub(crate) fn bound_stiffness(r: &Vector3<f64>, f: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::identity() * (f.norm() * r.norm())
}

/// Accumulates `K̃_k` (eq. G2) of every body, with the largest squared lever arm `r²` of its loaded
/// joint ends, into `out` (world-indexed, reset here) from the enabled
/// joints' linear rows and their impulses of the previous step (`warm[j][slot]` with
/// `stamp == step`; none on the first step).
pub(crate) fn accumulate(
    bodies: &[RigidBody],
    joints: &[Joint],
    warm: &[[WarmRow; JOINT_SLOTS]],
    step: u64,
    h: f64,
    out: &mut Vec<(Matrix3<f64>, f64)>,
) {
    out.clear();
    out.resize(bodies.len(), (Matrix3::zeros(), 0.0));
    if step == 0 {
        return;
    }
    let side = |id: Option<BodyId>| match id {
        None => Side::world(),
        Some(id) => {
            let b = &bodies[id.index()];
            Side { index: Some(id.index()), x: b.position, q: b.orientation, ..Side::world() }
        }
    };
    for j in joints.iter().filter(|j| j.enabled) {
        let Some(w) = warm.get(j.id.index()) else { continue };
        let (a, b) = (side(Some(j.body_a)), side(j.body_b));
        let dyn_a = bodies[j.body_a.index()].is_dynamic();
        let dyn_b = j.body_b.is_some_and(|id| bodies[id.index()].is_dynamic());
        if !dyn_a && !dyn_b {
            continue;
        }
        let mut geometry = None;
        let mut force = Vector3::zeros();
        for &(slot, axis) in linear_row_axes(j.kind) {
            let wr = &w[slot];
            if wr.stamp != step || wr.lambda == 0.0 {
                continue;
            }
            let g = geometry.get_or_insert_with(|| JointGeometry::new(j, &a, &b));
            force += g.e[axis] * (wr.lambda / h);
        }
        let Some(g) = geometry else { continue };
        if !force.iter().all(|c| c.is_finite()) {
            continue;
        }
        // Body B receives +F at p_b (lever r_B), body A −F at p_b (lever r_A): see joint_rows.rs.
        if dyn_a {
            let o = &mut out[j.body_a.index()];
            o.0 += bound_stiffness(&g.r_a, &force);
            o.1 = o.1.max(g.r_a.norm_squared());
        }
        if let (true, Some(id)) = (dyn_b, j.body_b) {
            let o = &mut out[id.index()];
            o.0 += bound_stiffness(&g.r_b, &force);
            o.1 = o.1.max(g.r_b.norm_squared());
        }
    }
}

/// The weight `α` of the correction (module doc) for a body of mass `mass` and principal moments
/// `principal` with stiffness `k` (eq. G2, world) at lever arms up to `√r2`, at step `h`.
pub(crate) fn weight(k: &Matrix3<f64>, r2: f64, mass: f64, principal: &Vector3<f64>, h: f64) -> f64 {
    // Inertia of the body's tilt about a joint anchor (parallel axes): the mode the stiffness acts on.
    let inertia = principal.min() + mass * r2;
    if inertia.is_nan() || inertia <= 0.0 {
        return 0.0;
    }
    // The Frobenius norm bounds λ_max of the PSD K̃ from above, cheaply.
    let rho = h * h * k.norm() / inertia;
    (rho / RHO_START - 1.0).clamp(0.0, 1.0)
}

/// The stiffness ratio on the corrected inertia beyond which a step is solved again (eq. G6): half
/// the explicit bound 4.
pub const LAG_RATIO: f64 = 2.0;

/// The turn `h |ω⁺|` (rad) within the step beyond which a lagging body calls for a second solve
/// (eq. G6): the chord drift `(h ω)² r / 2` of its anchors is then above 0.5 % of its lever arm.
pub const LAG_TURN: f64 = 0.1;

/// (G6): whether the stiffness `fresh` (lever arms up to `√r2`) from the impulses just solved
/// outgrows the inertia the body was solved with, `used` at weight `alpha`.
pub(crate) fn lags(
    fresh: &Matrix3<f64>,
    r2: f64,
    used: &Matrix3<f64>,
    alpha: f64,
    mass: f64,
    principal: &Vector3<f64>,
    h: f64,
) -> bool {
    let h2 = h * h;
    let inertia = principal.min() + mass * r2 + alpha * h2 * used.norm();
    inertia > 0.0 && h2 * fresh.norm() > LAG_RATIO * inertia
}

#[cfg(test)]
mod tests {
    use super::*;

    /// (G1) against a central difference of `τ(δθ) = (R(δθ) r) × F`, and (G2)'s closed-form
    /// eigenvalues for a hanging link: `T|r|` twice across the arm, 0 along it.
    #[test]
    fn stiffness_matches_finite_differences() {
        let r = Vector3::new(0.1, -0.3, 0.45);
        let f = Vector3::new(20.0, 5.0, -40.0);
        let k = r * f.transpose() - Matrix3::identity() * f.dot(&r);
        let eps = 1e-6;
        for c in 0..3 {
            let mut d = Vector3::zeros();
            d[c] = eps;
            let tau = |d: Vector3<f64>| (nalgebra::UnitQuaternion::from_scaled_axis(d) * r).cross(&f);
            let fd = (tau(d) - tau(-d)) / (2.0 * eps);
            assert!((fd - k.column(c)).norm() < 1e-6, "{fd} vs {}", k.column(c));
        }
        let up = Vector3::new(0.0, 0.0, 0.05);
        let kt = abs_sym_stiffness(&up, &Vector3::new(0.0, 0.0, 1000.0));
        let expect = Matrix3::from_diagonal(&Vector3::new(50.0, 50.0, 0.0));
        assert!((kt - expect).norm() < 1e-9, "{kt}");
        // PSD for any force and arm, and below the isotropic bound used.
        let ks = abs_sym_stiffness(&r, &f);
        assert!(ks.symmetric_eigen().eigenvalues.min() > -1e-9);
        assert!((ks - ks.transpose()).norm() < 1e-12);
        let gap = bound_stiffness(&r, &f) - ks;
        assert!(gap.symmetric_eigen().eigenvalues.min() > -1e-9, "{gap}");
    }

    /// (G6) on a 0.5 kg link of 0.1 m (`I_min ≈ 4e-4`) at `h = 1/60`: a tension that holds or grows
    /// by half does not lag the stiffness it was solved with (α = 1), one that jumps from a slack
    /// 2 N to 6e4 N does; the bound is `2 (I + m r² + α h² ‖K̃_used‖)` exactly.
    #[test]
    fn a_jump_of_the_tension_lags_and_a_steady_one_does_not() {
        let (m, p, h) = (0.5, Vector3::new(4e-4, 4e-4, 2.5e-5), 1.0 / 60.0);
        let r2 = 0.05f64 * 0.05;
        let k = |t: f64| Matrix3::identity() * (t * 0.05);
        let alpha = |t: f64| weight(&k(t), r2, m, &p, h);
        assert_eq!(alpha(6e4), 1.0);
        assert!(!lags(&k(6e4), r2, &k(6e4), alpha(6e4), m, &p, h));
        assert!(!lags(&k(9e4), r2, &k(6e4), alpha(6e4), m, &p, h));
        assert!(lags(&k(6e4), r2, &k(2.0), alpha(2.0), m, &p, h));
        // At the bound: ‖K̃‖_F = √3 T |r|.
        let inertia = p.min() + m * r2 + alpha(6e4) * h * h * k(6e4).norm();
        let t_bound = LAG_RATIO * inertia / (h * h * 3f64.sqrt() * 0.05);
        assert!(!lags(&k(t_bound * (1.0 - 1e-9)), r2, &k(6e4), alpha(6e4), m, &p, h));
        assert!(lags(&k(t_bound * (1.0 + 1e-9)), r2, &k(6e4), alpha(6e4), m, &p, h));
    }

    #[test]
    fn weight_ramps_between_one_and_two_rho_start() {
        let i = Vector3::new(1.0, 1.0, 1.0);
        let h: f64 = 0.1;
        let k = |rho: f64| Matrix3::identity() * (rho / (h * h) / 3f64.sqrt());
        assert_eq!(weight(&k(0.1), 0.0, 1.0, &i, h), 0.0);
        assert!((weight(&k(1.5 * RHO_START), 0.0, 1.0, &i, h) - 0.5).abs() < 1e-12);
        assert_eq!(weight(&k(10.0), 0.0, 1.0, &i, h), 1.0);
        assert_eq!(weight(&k(10.0), 0.0, 1.0, &Vector3::zeros(), h), 0.0);
        // A point-like bob on a long lever: its tilt moves its mass, ρ = h² ‖K̃‖ / (I + m r²).
        assert!((weight(&k(1.5 * RHO_START), 1.0, 1.0, &Vector3::zeros(), h) - 0.5).abs() < 1e-12);
        assert_eq!(weight(&k(1.5 * RHO_START), 1.0, 1.0, &i, h), 0.0);
    }
}
