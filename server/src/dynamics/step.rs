//! One time step (paper eq. 1–3): forces, free velocities, rows, islands, one MLCP per island,
//! velocity update and integration.
//!
//! ```text
//!   1. f = m g + Σ force elements at the start of the step (time t), with the Jacobians D, K of
//!      the implicit ones (buoyancy and drag, force.rs)
//!   2. v₀ = v/(1 + h d),  ω₀ = ω̃/(1 + h d_ω)          (ω̃: implicit gyroscopic update, below;
//!                                                       d, d_ω: body damping rates, body.rs)
//!      v_free = v₀ + h f / m,  ω_free = ω₀ + h I_w⁻¹ τ, or with implicit elements
//!      (v_free, ω_free) = (v₀, ω₀) + (M − h D − h² K)⁻¹ (h f + h² K (v₀, ω₀));
//!      for a body whose joints are loaded, I_w → Ĩ = I_w + α h² K̃ (the joints' geometric
//!      stiffness from the previous step's impulses) and h τ → h τ − α h² K̃ ω₀ (the implicit
//!      mode; geometric_stiffness.rs, eq. G2–G4): M̃ replaces M in steps 5–6
//!   3. rows of every joint, coupling and spring at the current poses
//!                                                 (joint_rows.rs, coupling_rows.rs, force_rows.rs)
//!      then of every contact point (contact/)
//!   4. islands by union–find over rows joining dynamic bodies
//!   5. per island: A = J M̃⁻¹ Jᵀ + C/h², b = r − J v_free (eq. 2); solve the boxed MLCP (eq. 3)
//!      warm-started from the previous step's index set and impulses of the same rows
//!   6. v⁺ = v_free + M̃⁻¹ Jᵀ λ                          (eq. 1, first line); if the new impulses
//!      make a body's geometric stiffness outgrow the inertia it was solved with (a tension that
//!      jumps at an impact: eq. G6 of geometric_stiffness.rs), steps 2, 5 and 6 once more with
//!      K̃ from the new impulses (same rows, warm from the first solve)
//!   7. x⁺ = x + h v⁺,   q⁺ = normalize(exp(h ω⁺/2) ⊗ q)  (ω world frame; = q ⊗ exp(h ω_body/2))
//!   8. position projection (projection.rs): `projection_iterations` of them, then the
//!      joint-error guard's (while a joint is open beyond `joint_error_tolerance`); then commit,
//!      or the step re-run as substeps (below)
//! ```
//!
//! Each stage is a method of [`StepWorkspace`] over the world's items: `prepare_bodies` (1–2),
//! `push_rows` (3–4), `solve_islands` (5–6, per island slot: [`IslandSlot`]), `integrate` (7), `commit` (8);
//! [`World::step`](super::World::step) runs them in this order, with the projection between the
//! last two.
//!
//! This is the paper's single-step implicit Euler: velocities from the implicit constraint impulses,
//! positions from the new velocities (symplectic in the unconstrained case: free fall gives
//! `x_n = x₀ + v₀ t_n − g h² n(n+1)/2` exactly).
//!
//! **Drift.** The rows hold `J(x) v⁺ = −βφ/h`, linearized at the start of the step; integrating a
//! rotation along its chord leaves an anchor at lever arm `r` off by about `(h|ω|)² r / 2` at the
//! step's end. The next step removes it (it never accumulates); `projection_iterations > 0` removes
//! it within the step, and the joint-error guard wherever it exceeds `joint_error_tolerance`
//! (`projection.rs`).
//!
//! **Substeps.** A Gauss–Newton projection closes a drift that is small against the lever arms;
//! when a body turns by `θ = h|ω⁺|` of a large fraction of a radian (a slack rope whipped by a
//! falling boom: 0.8 rad per step, its joints opened by 3–15 cm) the drift `θ² r / 2` is too large
//! for it, and the step itself is too coarse for the motion. So when, after the guard, a joint is
//! still open beyond the tolerance and some body turned more than
//! [`SUBSTEP_TURN`](super::SUBSTEP_TURN) = 0.25 rad, the step is discarded and re-run from its
//! start as `k = ⌈θ_max / 0.25⌉` steps of `h/k` (2 ≤ k ≤ `max_substeps`), each with all eight
//! stages and committed in turn: the drift per substep falls by `k²` overall. Bookkeeping: the
//! attempt's impulses, an impulse over `h`, are scaled by `1/k` to warm-start the first substep,
//! and the last substep's by `k` so that the step's impulses read as before (mean force `λ/h`); the
//! attempt's input work is dropped; the warm-start records are stamped per solve
//! (`World::solves`), not per step. On an error in a substep the bodies return to the step's start.
//! The step's statistics are those of the last substep ([`World::last_substeps`](super::World::last_substeps)
//! tells how many there were).
//!
//! **Gyroscopic term.** A free body's angular momentum `L = R I_b ω_b` is constant while `ω`
//! changes (Euler's equation `I ω̇ + ω × I ω = τ`). With `gyroscopic` on, the torque-free part of the
//! step is the angular velocity `ω̃` whose rotation over the step carries the body-frame momentum
//! back to the old world momentum: `exp(h [ω̃_b]×) I_b ω̃_b = I_b ω_b` (a Lie-group implicit Euler
//! step, solved by Newton's method). Since the integrator rotates by exactly `exp(h ω̃)`, a free
//! body keeps `L` to round-off, at any spin (explicit `−h ω × I ω` gains energy; the one-step
//! linearization loses a few % of `L` over 10 s at 3 rad/s). It enters the paper's formulation as a
//! force `h f_gyro = I_w (ω̃ − ω)`. Off: `ω` is carried over unchanged (energy kept exactly, `L`
//! not conserved for asymmetric bodies).
//!
//! **Failure.** If a new state is not finite, the step returns [`StepError::NonFinite`] and leaves
//! the bodies unchanged. Solver soft outcomes (step cap, inexact) are in [`IslandStats`].
//!
//! **Islands in parallel.** Step 5 runs per island slot: the step's `s`-th island with rows owns
//! slot `s` — its solver (warm state, ordering and pattern reuse), its assembler and its problem —
//! and reads only what all islands share (rows, free motion, the warm-start records). With a solver
//! pool (`World::set_threads`, `--threads`) and at least two islands of [`PARALLEL_MIN_ROWS`] rows,
//! the slots are solved concurrently (rayon, one task per slot, work stealing); otherwise in turn.
//! Either way the answers are then taken in island order (`v⁺`, input work, statistics, warm
//! records), so the result is the same to the bit whatever the thread count, and a replay does not
//! depend on it. The islands share the step's time budget as one deadline, each against it.
//! Shadow solves (`shadow.rs`) keep the serial path: they are timed against the world's own solves.
//!
//! **Allocation.** Every buffer lives in [`StepWorkspace`] and is cleared and reused, and the island
//! problem is refilled in place ([`Mlcp::assign`](crate::solver::Mlcp::assign)): once the first
//! steps of a scene have sized them, a serial step allocates nothing. A parallel one allocates once
//! every 63 steps, on the stepping thread: rayon's injector queue, which takes the step's job, grows
//! by a block of 63 slots (`tests/dynamics_parallel_allocation.rs`).

use std::collections::HashMap;
use std::time::Instant;

use nalgebra::{Matrix3, Matrix6, UnitQuaternion, Vector3, Vector6};

use super::accumulator::ForceAccumulator;
use super::assemble::{Assembler, BodyMotion};
use super::body::{BodyKind, RigidBody};
use super::contact::ContactSet;
use super::coupling::Coupling;
use super::coupling_rows::push_coupling_row;
use super::error::StepError;
use super::force::ForceElement;
use super::force_rows::push_spring_row;
use super::geometric_stiffness;
use super::ids::{BodyId, ForceId};
use super::island::Islands;
use super::joint::{JOINT_SLOTS, Joint};
use super::joint_rows::push_joint_rows;
use super::rows::{ConstraintRow, RowKey, RowKind, Side, WarmRow};
use super::settings::{GeometricStiffness, WorldSettings};
use super::shadow::Shadows;
use super::stats::IslandStats;
use crate::solver::{IndexState, Mlcp, SolveStats, SolveStatus, Solver};

/// Fewest rows of an island that is worth a solver thread (`parallel_worth_it`).
pub const PARALLEL_MIN_ROWS: usize = 24;

/// Reusable buffers of the step.
/// A body's position, orientation, linear and angular velocity.
type BodyState = (Vector3<f64>, UnitQuaternion<f64>, Vector3<f64>, Vector3<f64>);

#[derive(Debug, Default)]
pub(crate) struct StepWorkspace {
    pub forces: ForceAccumulator,
    pub motion: Vec<BodyMotion>,
    pub dynamic: Vec<bool>,
    pub rows: Vec<ConstraintRow>,
    pub islands: Islands,
    /// The projection's assembly and island problem (`projection.rs`), refilled per island.
    pub asm: Assembler,
    pub problem: Mlcp,
    /// One slot per island with rows, in island order: its solver, assembly and problem.
    pub slots: Vec<IslandSlot>,
    /// Slot → island of this step.
    slot_island: Vec<usize>,
    /// The solver threads (`None`: every island on the calling thread; `World::set_threads`).
    pub pool: Option<rayon::ThreadPool>,
    /// Island solves (first solves, re-solves and substeps' solves) whose islands ran on the
    /// pool, since the world was built.
    pub parallel_solves: u64,
    /// Other variants solving the same island problems for comparison (`shadow.rs`; none by default).
    pub shadows: Shadows,
    pub v_new: Vec<Vector3<f64>>,
    pub w_new: Vec<Vector3<f64>>,
    pub x_new: Vec<Vector3<f64>>,
    pub q_new: Vec<UnitQuaternion<f64>>,
    pub warm: Vec<[WarmRow; JOINT_SLOTS]>,
    pub warm_couplings: Vec<WarmRow>,
    pub warm_forces: Vec<WarmRow>,
    /// Contact rows by key (collider pair, feature ids, row); entries not solved in the last step
    /// are dropped after it.
    pub warm_contacts: HashMap<RowKey, WarmRow>,
    pub stats: Vec<IslandStats>,
    /// Island index → index in `stats` (`usize::MAX` for islands without rows).
    pub stat_of_island: Vec<usize>,
    /// When on, a copy of every island's MLCP of the last step (for `--dump-mlcp`; allocates).
    pub capture: bool,
    /// The captured problems, in the order of `stats`.
    pub captured: Vec<Mlcp>,
    pub proj_rows: Vec<ConstraintRow>,
    pub proj_islands: Islands,
    pub proj_solvers: Vec<Solver>,
    pub proj_motion: Vec<BodyMotion>,
    /// Projections the joint-error guard ran in the last step (`projection.rs`).
    pub guard_iterations: usize,
    /// The worst joint drift the guard left at the new poses (m; 0 with the guard off).
    pub guard_drift: f64,
    /// Substeps of the last step (1: none).
    pub substeps: usize,
    /// The bodies' state before a step re-run as substeps: position, orientation, velocities.
    saved: Vec<BodyState>,
    pub dv: Vec<Vector3<f64>>,
    pub dw: Vec<Vector3<f64>>,
    /// Geometric stiffness `K̃` per body and its largest loaded lever arm squared (world-indexed;
    /// `geometric_stiffness.rs`).
    pub stiffness: Vec<(Matrix3<f64>, f64)>,
    /// Bodies whose inertia the geometric stiffness raised in the last step.
    pub gs_bodies: usize,
    /// The isotropic term `α h² ‖K̃‖/√3` each body's inertia was raised by in this step
    /// (`Ĩ = I + s 𝟙`, world-indexed; 0 where none): the projection uses the same inertia.
    pub gs_iso: Vec<f64>,
    /// `K̃` from the impulses just solved (the lag check, `geometric_stiffness.rs` eq. G6).
    pub stiffness_fresh: Vec<(Matrix3<f64>, f64)>,
    /// Steps solved a second time because the stiffness lagged the impulses (G6), since the world
    /// was built.
    pub gs_resolves: u64,
    /// Work done on the dynamic bodies since the world was built by everything that is not
    /// gravity or a passive joint row (J; see [`World::input_work`](super::World::input_work)).
    pub input_work: f64,
}

/// `ω̃`: torque-free rotation over the step that conserves the angular momentum exactly (see the
/// module doc): solves `I_b ω' = exp(−h [ω']×) I_b ω_b` in the body frame by Newton's method with
/// the Jacobian `I_b − h [exp(−h [ω']×) L_b]×`.
fn gyroscopic(b: &RigidBody, h: f64) -> Vector3<f64> {
    let wb = b.orientation.inverse_transform_vector(&b.angvel);
    let ib = b.inertia_body();
    let l = ib * wb;
    let tol = 1e-15 * l.norm();
    let mut w = wb;
    for _ in 0..GYRO_ITERATIONS {
        let rl = UnitQuaternion::from_scaled_axis(-w * h) * l;
        let g = ib * w - rl;
        if g.norm() <= tol {
            break;
        }
        match (ib - rl.cross_matrix() * h).try_inverse() {
            Some(inv) => w -= inv * g,
            None => return b.angvel,
        }
    }
    if w.iter().all(|c| c.is_finite()) { b.orientation * w } else { b.angvel }
}

/// Unconstrained velocity change `(Δv, Δω)` of body `i` with implicit force elements: solves
/// `(M − h D − h² K) Δ = h f + h² K (v₀, ω₀)` (`force.rs`); explicit `h M⁻¹ f` if singular.
///
/// `gs` is the geometric-stiffness term `α h² K̃` of the body (zero when off) and `drag` its
/// velocity term (`−α h² K̃ ω₀` in the implicit mode, eq. G3 of `geometric_stiffness.rs`; zero in
/// the inertial mode, G4).
#[allow(clippy::too_many_arguments)]
fn implicit_change(
    b: &RigidBody,
    acc: &ForceAccumulator,
    i: usize,
    h: f64,
    v0: Vector3<f64>,
    w0: Vector3<f64>,
    gs: &Matrix3<f64>,
    drag: Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>) {
    let mut m = Matrix6::zeros();
    m.fixed_view_mut::<3, 3>(0, 0).fill_diagonal(b.mass());
    m.fixed_view_mut::<3, 3>(3, 3).copy_from(&(b.inertia_world() + gs));
    let (d, k) = (&acc.damping[i], &acc.stiffness[i]);
    let lhs = m - d * h - k * (h * h);
    let vel = Vector6::new(v0.x, v0.y, v0.z, w0.x, w0.y, w0.z);
    let f = acc.force[i];
    let t = acc.torque[i] * h + drag;
    let rhs = Vector6::new(f.x * h, f.y * h, f.z * h, t.x, t.y, t.z) + k * vel * (h * h);
    match lhs.lu().solve(&rhs).filter(|x| x.iter().all(|c| c.is_finite())) {
        Some(x) => (x.fixed_rows::<3>(0).into_owned(), x.fixed_rows::<3>(3).into_owned()),
        None => (f * (h * b.inv_mass()), b.inv_inertia_world() * t),
    }
}

/// Newton iterations of the gyroscopic update (converges in 2–4 for `h |ω|` up to ~1).
const GYRO_ITERATIONS: usize = 8;

/// Side of a joint at the current poses with the velocities `(v[i], w[i])`.
fn side_of(bodies: &[RigidBody], v: &[Vector3<f64>], w: &[Vector3<f64>], id: Option<BodyId>) -> Side {
    match id {
        None => Side::world(),
        Some(id) => {
            let (i, b) = (id.index(), &bodies[id.index()]);
            Side { index: Some(i), x: b.position, q: b.orientation, v: v[i], w: w[i] }
        }
    }
}

/// The statistics of island `k` (`bodies` bodies, `rows` rows) from its solve.
fn island_stats(
    k: usize,
    bodies: usize,
    rows: usize,
    s: &SolveStats,
    max_violation: f64,
    assemble_us: f64,
) -> IslandStats {
    IslandStats {
        island: k,
        bodies,
        rows,
        nnz: s.nnz,
        variant: s.variant,
        status: s.status,
        fallback: s.fallback,
        pivot_steps: s.pivot_steps,
        iterations: s.iterations,
        tight: s.tight,
        residual: s.residual,
        residual_rel: s.residual_rel,
        max_violation,
        assemble_us,
        solve_us: s.total_us,
        solve_cpu_us: s.cpu_us,
        projection_us: 0.0,
        shadow: Default::default(),
    }
}

/// The warm-start records of the rows: read by the islands' solves, written after them.
#[derive(Clone, Copy)]
struct WarmView<'a> {
    joints: &'a [[WarmRow; JOINT_SLOTS]],
    couplings: &'a [WarmRow],
    forces: &'a [WarmRow],
    contacts: &'a HashMap<RowKey, WarmRow>,
}

impl<'a> WarmView<'a> {
    fn row(self, key: RowKey) -> Option<&'a WarmRow> {
        match key {
            RowKey::Joint { joint, row } => self.joints.get(joint.index()).map(|w| &w[row.slot()]),
            RowKey::Coupling(c) => self.couplings.get(c.index()),
            RowKey::Force(f) => self.forces.get(f.index()),
            RowKey::Contact { .. } => self.contacts.get(&key),
        }
    }
}

/// What every island's solve reads (shared by the solver threads).
struct SlotInput<'a> {
    islands: &'a Islands,
    rows: &'a [ConstraintRow],
    motion: &'a [BodyMotion],
    warm: WarmView<'a>,
    h: f64,
    warm_start: bool,
    warm_stamp: u64,
    deadline: Option<Instant>,
}

/// One island with rows of a step: its solver (slot `s` is the step's `s`-th island with rows,
/// the same solver from step to step, as warm starts and pattern reuse need), its own assembly
/// and problem buffers, so that slots solve concurrently, and what its last solve left.
#[derive(Debug)]
pub(crate) struct IslandSlot {
    pub solver: Solver,
    asm: Assembler,
    problem: Mlcp,
    stats: IslandStats,
    error: Option<StepError>,
    /// The shadows solved this slot's problem before the world's own solve.
    shadows_done: bool,
}

impl IslandSlot {
    pub(crate) fn new(options: crate::solver::SolverOptions) -> Self {
        IslandSlot {
            solver: Solver::new(options),
            asm: Assembler::default(),
            problem: Mlcp::default(),
            stats: IslandStats::default(),
            error: None,
            shadows_done: false,
        }
    }

    /// Island `k`'s MLCP (step 5): assembly and the warm start (the rows' records stamped
    /// `warm_stamp`) into the slot's problem; an assembly error is kept for `finish_island`.
    fn prepare(&mut self, k: usize, inp: &SlotInput<'_>) {
        let t = Instant::now();
        self.error = None;
        self.asm.assemble(k, inp.islands, inp.rows, inp.motion, inp.h);
        let max_violation = self.load_warm_start(k, inp);
        let m = inp.islands.rows(k).len();
        self.asm.lambda.clear();
        self.asm.lambda.resize(m, 0.0);
        if let Err(source) = self.asm.fill_mlcp(&mut self.problem, inp.warm_start) {
            self.error = Some(StepError::Assembly { island: k, source });
        }
        self.stats.island = k;
        self.stats.bodies = inp.islands.bodies(k).len();
        self.stats.rows = m;
        self.stats.max_violation = max_violation;
        self.stats.assemble_us = t.elapsed().as_secs_f64() * 1e6;
    }

    /// Solves the prepared problem (step 5's MLCP) into `asm.lambda`, with its statistics.
    fn solve_prepared(&mut self, inp: &SlotInput<'_>) {
        if self.error.is_some() {
            return;
        }
        self.solver.set_deadline(inp.deadline);
        let s = self.solver.solve(&self.problem, &mut self.asm.lambda);
        let st = &self.stats;
        self.stats = island_stats(st.island, st.bodies, st.rows, s, st.max_violation, st.assemble_us);
    }

    /// Fills the assembler's warm start (`lambda0`, `index0`) of island `k` from the rows' records
    /// stamped `warm_stamp` (the last step's; a re-solve's: this step's first solve); returns the
    /// island's largest position violation `|φ|`.
    fn load_warm_start(&mut self, k: usize, inp: &SlotInput<'_>) -> f64 {
        self.asm.lambda0.clear();
        self.asm.index0.clear();
        let mut max_violation: f64 = 0.0;
        for &ri in inp.islands.rows(k) {
            let r = &inp.rows[ri];
            if r.kind == RowKind::Position {
                max_violation = max_violation.max(r.phi.abs());
            }
            let w = inp.warm.row(r.key).copied().unwrap_or_default();
            let valid = inp.warm_stamp > 0 && w.stamp == inp.warm_stamp;
            self.asm.lambda0.push(if valid { w.lambda } else { 0.0 });
            self.asm.index0.push(if valid { w.state } else { IndexState::Free });
        }
        max_violation
    }
}

impl StepWorkspace {
    /// The warm-start record of a row (`None` for an item the cache has not seen).
    pub fn warm_row(&self, key: RowKey) -> Option<&WarmRow> {
        self.warm_view().row(key)
    }

    /// Whether a step's `n` islands with rows go to the pool: at least two of them have
    /// [`PARALLEL_MIN_ROWS`] rows (smaller ones cost less than waking a thread), and no shadow
    /// solves run (they are timed against the world's own solves, which must not share the cores).
    fn parallel_worth_it(&self, n: usize) -> bool {
        self.pool.is_some()
            && self.shadows.is_empty()
            && self.slot_island[..n]
                .iter()
                .filter(|&&k| self.islands.rows(k).len() >= PARALLEL_MIN_ROWS)
                .count()
                >= 2
    }

    fn warm_view(&self) -> WarmView<'_> {
        WarmView {
            joints: &self.warm,
            couplings: &self.warm_couplings,
            forces: &self.warm_forces,
            contacts: &self.warm_contacts,
        }
    }

    /// Forces, free velocities and predicted velocities of every body (steps 1–2).
    pub fn prepare_bodies(
        &mut self,
        settings: &WorldSettings,
        bodies: &[RigidBody],
        joints: &[Joint],
        forces: &[ForceElement],
        time: f64,
        step: u64,
    ) {
        let h = settings.timestep;
        if settings.geometric_stiffness == GeometricStiffness::Off {
            self.stiffness.clear();
        } else {
            geometric_stiffness::accumulate(bodies, joints, &self.warm, step, h, &mut self.stiffness);
        }
        self.free_motion(settings, bodies, forces, time);
    }

    /// Step 2 with the stiffness `K̃` in `self.stiffness`: forces, free velocities and effective
    /// inverse inertias of every body; `v_new`, `w_new` start as the free velocities.
    fn free_motion(
        &mut self,
        settings: &WorldSettings,
        bodies: &[RigidBody],
        forces: &[ForceElement],
        time: f64,
    ) {
        let (h, n) = (settings.timestep, bodies.len());
        self.gs_bodies = 0;
        self.gs_iso.clear();
        self.gs_iso.resize(n, 0.0);
        self.forces.reset(n);
        for (i, b) in bodies.iter().enumerate() {
            if b.is_dynamic() {
                self.forces.force[i] = settings.gravity * b.mass();
            }
        }
        for f in forces {
            f.accumulate(bodies, time, &settings.gravity, &mut self.forces);
        }
        self.motion.clear();
        self.dynamic.clear();
        for (i, b) in bodies.iter().enumerate() {
            let m = match b.kind() {
                BodyKind::Dynamic => {
                    let mut inv_inertia = b.inv_inertia_world();
                    let w0 = if settings.gyroscopic { gyroscopic(b, h) } else { b.angvel };
                    let (v0, w0) =
                        (b.linvel / (1.0 + h * b.linear_damping()), w0 / (1.0 + h * b.angular_damping()));
                    // Geometric stiffness (geometric_stiffness.rs, G2–G3): Ĩ = I + α h² K̃.
                    let mut gs = Matrix3::zeros();
                    if let Some((k, r2)) = self.stiffness.get(i) {
                        let alpha = geometric_stiffness::weight(k, *r2, b.mass(), &b.principal_inertia(), h);
                        if alpha > 0.0
                            && let Some(inv) = (b.inertia_world() + k * (alpha * h * h)).try_inverse()
                        {
                            gs = k * (alpha * h * h);
                            inv_inertia = inv;
                            self.gs_bodies += 1;
                            // K̃ is isotropic (`bound_stiffness`): its diagonal is all of it.
                            self.gs_iso[i] = gs[(0, 0)];
                        }
                    }
                    let drag = match settings.geometric_stiffness {
                        GeometricStiffness::Implicit => -(gs * w0),
                        GeometricStiffness::Inertial | GeometricStiffness::Off => Vector3::zeros(),
                    };
                    let (dv, dw) = match self.forces.implicit[i] {
                        true => implicit_change(b, &self.forces, i, h, v0, w0, &gs, drag),
                        false => (
                            self.forces.force[i] * (h * b.inv_mass()),
                            inv_inertia * (self.forces.torque[i] * h + drag),
                        ),
                    };
                    BodyMotion { dynamic: true, inv_mass: b.inv_mass(), inv_inertia, v: v0 + dv, w: w0 + dw }
                }
                BodyKind::Kinematic => BodyMotion { v: b.linvel, w: b.angvel, ..Default::default() },
                BodyKind::Static => BodyMotion::default(),
            };
            self.motion.push(m);
            self.dynamic.push(b.is_dynamic());
        }
        // v_new / w_new start as the free velocities (bodies without rows keep them).
        self.v_new.clear();
        self.v_new.extend(self.motion.iter().map(|m| m.v));
        self.w_new.clear();
        self.w_new.extend(self.motion.iter().map(|m| m.w));
    }

    /// Whether the stiffness `K̃` of this step lags the impulses just solved (eq. G6 of
    /// `geometric_stiffness.rs`): `K̃` from the new impulses (stamp `step + 1`) into
    /// `stiffness_fresh`, then for every dynamic body whose island's solve settled (converged or
    /// inexact, not stopped at its cap or budget) `h² ‖K̃_new‖ > 2 (I_min + m r²_max + α h² ‖K̃_used‖)`
    /// while the body turns by more than `LAG_TURN` within the step.
    pub fn stiffness_lags(
        &mut self,
        settings: &WorldSettings,
        bodies: &[RigidBody],
        joints: &[Joint],
        step: u64,
    ) -> bool {
        let h = settings.timestep;
        geometric_stiffness::accumulate(bodies, joints, &self.warm, step + 1, h, &mut self.stiffness_fresh);
        // A solve stopped at its cap or budget returns a safe iterate, not the step's forces: its
        // impulses do not call for a second solve.
        let settled = |i: usize| {
            self.islands
                .island_of(i)
                .and_then(|k| self.stat_of_island.get(k))
                .and_then(|&s| self.stats.get(s))
                .is_some_and(|st| matches!(st.status, SolveStatus::Converged | SolveStatus::Inexact))
        };
        bodies.iter().enumerate().filter(|&(i, b)| b.is_dynamic() && settled(i)).any(|(i, b)| {
            let (used, r2_used) = self.stiffness.get(i).copied().unwrap_or((Matrix3::zeros(), 0.0));
            let (fresh, r2) = self.stiffness_fresh[i];
            let p = b.principal_inertia();
            let alpha = geometric_stiffness::weight(&used, r2_used, b.mass(), &p, h);
            geometric_stiffness::lags(&fresh, r2, &used, alpha, b.mass(), &p, h)
                && self.w_new[i].norm() * h > geometric_stiffness::LAG_TURN
        })
    }

    /// Solves the step again with `K̃` from the impulses just solved (eq. G6; `stiffness_lags`
    /// filled it): the input work of the first solve is taken back (`input_work_before`), the free
    /// motion recomputed, the islands (same rows) solved warm from the first solve's impulses.
    pub fn resolve_with_fresh_stiffness(
        &mut self,
        settings: &WorldSettings,
        bodies: &[RigidBody],
        forces: &[ForceElement],
        time: f64,
        step: u64,
        input_work_before: f64,
    ) -> Result<(), StepError> {
        std::mem::swap(&mut self.stiffness, &mut self.stiffness_fresh);
        self.input_work = input_work_before;
        self.gs_resolves += 1;
        self.free_motion(settings, bodies, forces, time);
        self.solve_islands_from(settings, step, step + 1)
    }

    /// Takes island `k`'s answer out of its slot `slot` (solved by [`IslandSlot::solve`]): `v⁺` of
    /// its bodies into `v_new`/`w_new`, its input work, its statistics (and shadow solves) and its
    /// impulses and index states as the next step's warm start. Called in island order.
    fn finish_island(
        &mut self,
        settings: &WorldSettings,
        k: usize,
        slot: usize,
        step: u64,
    ) -> Result<(), StepError> {
        let sl = &mut self.slots[slot];
        if let Some(e) = sl.error.take() {
            return Err(e);
        }
        if self.capture {
            self.captured.push(sl.problem.clone());
        }
        let mut st = sl.stats;
        if !self.shadows.is_empty() {
            if !sl.shadows_done {
                self.shadows.solve(&sl.problem, slot, settings.solver);
            }
            self.shadows.record(&mut st, &sl.asm.lambda);
        }
        sl.asm.apply_impulses(k, &self.islands, &self.rows, &mut self.v_new, &mut self.w_new);
        self.add_input_work(k, slot);
        self.stat_of_island[k] = slot;
        self.stats.push(st);
        self.store_warm_start(k, slot, step);
        Ok(())
    }

    /// Adds the work the input rows of island `k` did on its dynamic bodies (the watchdog's energy
    /// budget) to `input_work`.
    fn add_input_work(&mut self, k: usize, slot: usize) {
        let lambda = &self.slots[slot].asm.lambda;
        // Inputs: motors, couplings, friction and force rows (velocity and force rows), and every
        // row that reaches a kinematic or static body. Passive position rows between dynamic bodies
        // are not inputs: energy they add is what the watchdog looks for.
        for (i, &ri) in self.islands.rows(k).iter().enumerate() {
            let r = &self.rows[ri];
            let input = r.kind != RowKind::Position || r.blocks().any(|(b, _)| !self.motion[b].dynamic);
            if input {
                let jv: f64 = r
                    .blocks()
                    .filter(|&(b, _)| self.motion[b].dynamic)
                    .map(|(b, j)| j.dot(&self.v_new[b], &self.w_new[b]))
                    .sum();
                self.input_work += lambda[i] * jv;
            }
        }
    }

    /// Records the impulses and index states of island `k` (solved by solver `solved`) as the warm
    /// start of the next step.
    fn store_warm_start(&mut self, k: usize, slot: usize, step: u64) {
        let sl = &self.slots[slot];
        let states = sl.solver.index_set();
        for (i, &ri) in self.islands.rows(k).iter().enumerate() {
            let state = states.get(i).copied().unwrap_or_default();
            let lambda = sl.asm.lambda[i];
            let slot = match self.rows[ri].key {
                RowKey::Joint { joint, row } => &mut self.warm[joint.index()][row.slot()],
                RowKey::Coupling(c) => &mut self.warm_couplings[c.index()],
                RowKey::Force(f) => &mut self.warm_forces[f.index()],
                key @ RowKey::Contact { .. } => self.warm_contacts.entry(key).or_default(),
            };
            *slot = WarmRow { stamp: step + 1, state, lambda };
        }
    }

    /// Rows of every enabled joint, coupling, spring and contact point at the current poses with
    /// the free velocities, and the islands they make (steps 3–4).
    pub fn push_rows(
        &mut self,
        h: f64,
        bodies: &[RigidBody],
        joints: &[Joint],
        couplings: &[Coupling],
        forces: &[ForceElement],
        contacts: &mut ContactSet,
    ) {
        let (v, w) = (&self.v_new, &self.w_new);
        self.rows.clear();
        for j in joints.iter().filter(|j| j.enabled) {
            let a = side_of(bodies, v, w, Some(j.body_a));
            let b = side_of(bodies, v, w, j.body_b);
            push_joint_rows(j, &a, &b, h, &mut self.rows);
        }
        // A coupling relates joint coordinates; a disabled (broken) joint has none, so a coupling
        // takes part only while every joint it names is enabled.
        for c in couplings.iter().filter(|c| c.terms().iter().all(|&(j, _)| joints[j.index()].enabled)) {
            let sides = |j: &Joint| (side_of(bodies, v, w, Some(j.body_a)), side_of(bodies, v, w, j.body_b));
            push_coupling_row(c, joints, sides, h, &mut self.rows);
        }
        for (i, f) in forces.iter().enumerate() {
            if let ForceElement::SpringDamper(s) = f {
                let a = side_of(bodies, v, w, Some(s.body_a));
                let b = side_of(bodies, v, w, s.body_b);
                push_spring_row(s, ForceId(i as u32), &a, &b, h, &mut self.rows);
            }
        }
        contacts.push_rows(bodies, joints, h, &mut self.rows);
        self.islands.build(&self.dynamic, &self.rows);
        self.warm.resize(joints.len(), [WarmRow::default(); JOINT_SLOTS]);
        self.warm_couplings.resize(couplings.len(), WarmRow::default());
        self.warm_forces.resize(forces.len(), WarmRow::default());
    }

    /// One MLCP per island with rows, `v⁺ = v_free + M⁻¹ Jᵀ λ` (steps 5–6; bodies without rows keep
    /// `v_free`); the islands share the time budget of the step's solves (`max_solve_us`). Contact
    /// rows not solved in this step leave the warm-start cache.
    pub fn solve_islands(&mut self, settings: &WorldSettings, step: u64) -> Result<(), StepError> {
        self.solve_islands_from(settings, step, step)
    }

    /// [`Self::solve_islands`] warm-started from the records stamped `warm_stamp`.
    fn solve_islands_from(
        &mut self,
        settings: &WorldSettings,
        step: u64,
        warm_stamp: u64,
    ) -> Result<(), StepError> {
        self.stats.clear();
        self.captured.clear();
        self.stat_of_island.clear();
        self.stat_of_island.resize(self.islands.len(), usize::MAX);
        let deadline = settings.solver.max_solve_us.and_then(|us| {
            Instant::now().checked_add(std::time::Duration::try_from_secs_f64(us * 1e-6).ok()?)
        });
        self.slot_island.clear();
        self.slot_island.extend((0..self.islands.len()).filter(|&k| !self.islands.rows(k).is_empty()));
        let n = self.slot_island.len();
        while self.slots.len() < n {
            self.slots.push(IslandSlot::new(settings.solver));
        }
        let parallel = self.parallel_worth_it(n);
        // What every island's solve reads, borrowed field by field (the slots are written meanwhile).
        macro_rules! input {
            () => {
                SlotInput {
                    islands: &self.islands,
                    rows: &self.rows,
                    motion: &self.motion,
                    warm: WarmView {
                        joints: &self.warm,
                        couplings: &self.warm_couplings,
                        forces: &self.warm_forces,
                        contacts: &self.warm_contacts,
                    },
                    h: settings.timestep,
                    warm_start: settings.warm_start,
                    warm_stamp,
                    deadline,
                }
            };
        }
        match (&self.pool, parallel) {
            (Some(pool), true) => {
                use rayon::prelude::*;
                self.parallel_solves += 1;
                let of = &self.slot_island;
                let input = &input!();
                // One task per slot (work stealing balances one large island against small ones).
                pool.install(|| {
                    self.slots[..n].par_iter_mut().with_max_len(1).enumerate().for_each(|(s, slot)| {
                        slot.prepare(of[s], input);
                        slot.solve_prepared(input);
                        slot.shadows_done = false;
                    })
                });
                for s in 0..n {
                    self.finish_island(settings, self.slot_island[s], s, step)?;
                }
            }
            _ => {
                // Serial: island by island, each taken before the next is solved (odd steps the
                // shadows first, `shadow.rs`: they keep one answer per variant, read at the take).
                // Islands own disjoint rows, so taking one (its warm records) changes nothing the
                // next reads: the order is the parallel path's.
                let shadows_first = !self.shadows.is_empty() && deadline.is_none() && step % 2 == 1;
                for s in 0..n {
                    let k = self.slot_island[s];
                    {
                        let input = input!();
                        let slot = &mut self.slots[s];
                        slot.prepare(k, &input);
                        slot.shadows_done = shadows_first && slot.error.is_none();
                        if slot.shadows_done {
                            self.shadows.solve(&slot.problem, s, settings.solver);
                        }
                        slot.solve_prepared(&input);
                    }
                    self.finish_island(settings, k, s, step)?;
                }
            }
        }
        let solved = step + 1;
        self.warm_contacts.retain(|_, w| w.stamp == solved);
        Ok(())
    }

    /// The new poses `x⁺`, `q⁺` from `v⁺` (step 7), and the work of the applied forces other than
    /// gravity (buoyancy, drag, force elements) over the step.
    pub fn integrate(&mut self, settings: &WorldSettings, bodies: &[RigidBody]) {
        let h = settings.timestep;
        self.x_new.clear();
        self.q_new.clear();
        for (i, b) in bodies.iter().enumerate() {
            if b.kind() == BodyKind::Static {
                self.x_new.push(b.position);
                self.q_new.push(b.orientation);
                continue;
            }
            self.x_new.push(b.position + self.v_new[i] * h);
            let q = UnitQuaternion::from_scaled_axis(self.w_new[i] * h) * b.orientation;
            self.q_new.push(UnitQuaternion::new_normalize(q.into_inner()));
        }
        for (i, b) in bodies.iter().enumerate().filter(|(_, b)| b.is_dynamic()) {
            let f = self.forces.force[i] - settings.gravity * b.mass();
            let w = h * (f.dot(&self.v_new[i]) + self.forces.torque[i].dot(&self.w_new[i]));
            if w.is_finite() {
                self.input_work += w;
            }
        }
    }

    /// Multiplies the impulses of every record stamped `stamp` by `factor` (substeps: an impulse
    /// over `h` read as one over `h/k` and back).
    pub fn scale_stamped(&mut self, stamp: u64, factor: f64) {
        let rows = self.warm.iter_mut().flat_map(|w| w.iter_mut());
        let rows = rows.chain(self.warm_couplings.iter_mut()).chain(self.warm_forces.iter_mut());
        for w in rows.chain(self.warm_contacts.values_mut()).filter(|w| w.stamp == stamp) {
            w.lambda *= factor;
        }
    }

    /// Keeps the bodies' state (allocation-free once the buffer has grown).
    pub fn save_bodies(&mut self, bodies: &[RigidBody]) {
        self.saved.clear();
        self.saved.extend(bodies.iter().map(|b| (b.position, b.orientation, b.linvel, b.angvel)));
    }

    /// Puts back the state [`Self::save_bodies`] kept.
    pub fn restore_bodies(&self, bodies: &mut [RigidBody]) {
        for (b, &(x, q, v, w)) in bodies.iter_mut().zip(&self.saved) {
            (b.position, b.orientation, b.linvel, b.angvel) = (x, q, v, w);
        }
    }

    /// Writes the new state into the bodies (step 8, after the optional projection), or nothing
    /// with [`StepError::NonFinite`] if any of it is not finite.
    pub fn commit(&self, bodies: &mut [RigidBody]) -> Result<(), StepError> {
        for (i, b) in bodies.iter().enumerate() {
            let ok = self.v_new[i]
                .iter()
                .chain(self.w_new[i].iter())
                .chain(self.x_new[i].iter())
                .all(|c| c.is_finite())
                && self.q_new[i].coords.iter().all(|c| c.is_finite());
            if !ok {
                return Err(StepError::NonFinite { body: b.name().to_string() });
            }
        }
        for (i, b) in bodies.iter_mut().enumerate() {
            if b.kind() == BodyKind::Static {
                continue;
            }
            b.position = self.x_new[i];
            b.orientation = self.q_new[i];
            b.linvel = self.v_new[i];
            b.angvel = self.w_new[i];
        }
        Ok(())
    }
}
