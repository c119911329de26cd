//! The world's state: what changes as it steps, as opposed to its model (bodies' masses, joint
//! frames, shapes), which the scene file rebuilds. Taken by [`World::state`] and put back by
//! [`World::restore_state`] into a world built from the same scene, a restored world steps on bit
//! for bit as the original would have (`snapshot/` at the crate root; README "Rig control").
//!
//! What is in it, and why each part:
//! - time, steps and solves (the warm-start records' stamp, `step.rs` "Substeps");
//! - every body's pose and velocities;
//! - what of the model changes live: joints enabled (a break) and their motors (an actuator's
//!   command, a hose burst), clutch torque bounds, the solver variant (`set_variant`);
//! - the warm starts: every joint slot, coupling, spring and contact row's index state and impulse
//!   of the solve that wrote it (`rows.rs` `WarmRow`): step 5 starts from them, and the geometric
//!   stiffness of step 2 is computed from them;
//! - the narrow phase's manifolds and last points (`contact/collide.rs` `NarrowState`): parry seeds
//!   each query with the manifold's last normal;
//! - the last step's joint rows (their Jacobians at that step's poses): the joint wrenches the
//!   signals report between steps are summed from them and their impulses;
//! - each island solver's cost memory (`Solver::cost_memory`: recent GMRES iterations per coupled
//!   point and share of rejected direct points, which pick the method of the next coupled point),
//!   by island slot, of the step's solvers and the projection's;
//! - the work done by inputs (the watchdog's ledger) and the count of stiffness re-solves.
//!
//! What is not, because it cannot change a result: the islands, the assembled problems and every
//! solver buffer (rebuilt each step from the rows); the solvers' ordering caches (an ordering is a
//! function of the sparsity pattern, computed again on the first solve after a restore — the only
//! trace is that solve's `pattern_reused = false`); the shadow solvers (their answers are
//! discarded); the broad phase's sort order (its pairs come
//! out sorted whatever order it kept).

use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::World;
use crate::dynamics::contact::{NarrowPhase, NarrowState};
use crate::dynamics::joint::JOINT_SLOTS;
use crate::dynamics::motor::JointMotor;
use crate::dynamics::rows::{ConstraintRow, RowKey, WarmRow};
use crate::dynamics::step::IslandSlot;
use crate::solver::{Solver, Variant};

/// A body's pose and velocities: position, orientation `(i, j, k, w)`, linear and angular
/// velocity (world frame).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BodyState {
    /// Position of the centre of mass (m).
    pub position: [f64; 3],
    /// Orientation quaternion `(i, j, k, w)`, unit.
    pub orientation: [f64; 4],
    /// Linear velocity (m/s).
    pub linvel: [f64; 3],
    /// Angular velocity (rad/s).
    pub angvel: [f64; 3],
}

/// What of a joint changes live.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct JointState {
    /// Contributes rows (a broken rope does not).
    pub enabled: bool,
    /// Motors of its free axes.
    pub motors: [Option<JointMotor>; 2],
}

/// The world's state (module doc).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct WorldState {
    pub(crate) time: f64,
    pub(crate) steps: u64,
    pub(crate) solves: u64,
    pub(crate) variant: String,
    pub(crate) bodies: Vec<BodyState>,
    pub(crate) joints: Vec<JointState>,
    pub(crate) coupling_max_torque: Vec<Option<f64>>,
    pub(crate) warm: Vec<[WarmRow; JOINT_SLOTS]>,
    pub(crate) warm_couplings: Vec<WarmRow>,
    pub(crate) warm_forces: Vec<WarmRow>,
    /// Sorted by key, so that equal states encode to equal bytes.
    pub(crate) warm_contacts: Vec<(RowKey, WarmRow)>,
    pub(crate) narrow: NarrowState,
    /// The last step's joint rows.
    pub(crate) joint_rows: Vec<ConstraintRow>,
    /// Cost memory of the island solvers and of the projection's, by island slot.
    pub(crate) solver_memory: Vec<(f64, f64)>,
    pub(crate) projection_memory: Vec<(f64, f64)>,
    pub(crate) input_work: f64,
    pub(crate) gs_resolves: u64,
}

impl WorldState {
    /// Simulation time (s).
    pub fn time(&self) -> f64 {
        self.time
    }
    /// Steps taken.
    pub fn steps(&self) -> u64 {
        self.steps
    }
    /// The bodies' poses and velocities, by body id.
    pub fn bodies(&self) -> &[BodyState] {
        &self.bodies
    }
}

/// Why a state cannot be taken or put back.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum WorldStateError {
    /// The state has another number of items than this world (another scene).
    #[error("the state has {found} {what}, this world {expected}")]
    Count {
        /// Which items.
        what: &'static str,
        /// This world's.
        expected: usize,
        /// The state's.
        found: usize,
    },
    /// A number of the state is NaN or infinite, or a quaternion is not unit.
    #[error("the state's {what} of item {index} is not valid")]
    Invalid {
        /// What.
        what: &'static str,
        /// Index of the item.
        index: usize,
    },
    /// The variant name is not one of the solver's.
    #[error("unknown solver variant `{0}`")]
    Variant(String),
    /// A collider pair keeps parry state the snapshot cannot carry.
    #[error("colliders {0} and {1} keep a composite-shape workspace a snapshot cannot carry")]
    Unsupported(u32, u32),
}

fn finite(v: &[f64]) -> bool {
    v.iter().all(|c| c.is_finite())
}

impl World {
    /// The world's state (module doc). Fails only for a collider pair whose parry query keeps a
    /// composite-shape workspace (none of the shapes the scenes build).
    pub fn state(&self) -> Result<WorldState, WorldStateError> {
        let bodies = self
            .bodies
            .iter()
            .map(|b| BodyState {
                position: b.position.into(),
                orientation: b.orientation.coords.into(),
                linvel: b.linvel.into(),
                angvel: b.angvel.into(),
            })
            .collect();
        let joints =
            self.joints.iter().map(|j| JointState { enabled: j.enabled, motors: j.motors }).collect();
        let mut warm_contacts: Vec<_> = self.ws.warm_contacts.iter().map(|(k, w)| (*k, *w)).collect();
        warm_contacts.sort_unstable_by_key(|a| row_key_order(&a.0));
        let narrow = self.contacts.phase.state().map_err(|e| WorldStateError::Unsupported(e.0.0, e.0.1))?;
        Ok(WorldState {
            time: self.time,
            steps: self.steps,
            solves: self.solves,
            variant: self.settings.solver.variant.name().to_string(),
            bodies,
            joints,
            coupling_max_torque: self.couplings.iter().map(|c| c.max_torque).collect(),
            warm: self.ws.warm.clone(),
            warm_couplings: self.ws.warm_couplings.clone(),
            warm_forces: self.ws.warm_forces.clone(),
            warm_contacts,
            narrow,
            joint_rows: self
                .ws
                .rows
                .iter()
                .filter(|r| matches!(r.key, RowKey::Joint { .. }))
                .copied()
                .collect(),
            solver_memory: self.ws.slots.iter().map(|s| s.solver.cost_memory()).collect(),
            projection_memory: self.ws.proj_solvers.iter().map(Solver::cost_memory).collect(),
            input_work: self.ws.input_work,
            gs_resolves: self.ws.gs_resolves,
        })
    }

    /// Puts `state` back (module doc). The state is checked against this world first (item counts,
    /// finite numbers, unit quaternions, the variant's name); on an error nothing has changed.
    pub fn restore_state(&mut self, state: &WorldState) -> Result<(), WorldStateError> {
        self.check_state(state)?;
        let variant: Variant =
            state.variant.parse().map_err(|_| WorldStateError::Variant(state.variant.clone()))?;
        let mut settings = self.settings;
        settings.solver.variant = variant;
        self.set_settings(settings).map_err(|_| WorldStateError::Variant(state.variant.clone()))?;
        for (b, s) in self.bodies.iter_mut().zip(&state.bodies) {
            b.position = Vector3::from(s.position);
            b.orientation = UnitQuaternion::new_unchecked(Quaternion::from(s.orientation));
            b.linvel = Vector3::from(s.linvel);
            b.angvel = Vector3::from(s.angvel);
        }
        for (j, s) in self.joints.iter_mut().zip(&state.joints) {
            j.enabled = s.enabled;
            j.motors = s.motors;
        }
        for (c, &t) in self.couplings.iter_mut().zip(&state.coupling_max_torque) {
            c.max_torque = t;
        }
        self.time = state.time;
        self.steps = state.steps;
        self.solves = state.solves;
        let ws = &mut self.ws;
        ws.warm.clone_from(&state.warm);
        ws.warm_couplings.clone_from(&state.warm_couplings);
        ws.warm_forces.clone_from(&state.warm_forces);
        ws.warm_contacts.clear();
        ws.warm_contacts.extend(state.warm_contacts.iter().copied());
        ws.rows.clone_from(&state.joint_rows);
        ws.input_work = state.input_work;
        ws.gs_resolves = state.gs_resolves;
        let options = settings.solver;
        restore_memory(&mut ws.slots, &state.solver_memory, || IslandSlot::new(options), |s| &mut s.solver);
        restore_memory(&mut ws.proj_solvers, &state.projection_memory, || Solver::new(options), |s| s);
        self.contacts.phase.restore(&state.narrow);
        Ok(())
    }

    fn check_state(&self, s: &WorldState) -> Result<(), WorldStateError> {
        let count = |what, expected: usize, found: usize| match expected == found {
            true => Ok(()),
            false => Err(WorldStateError::Count { what, expected, found }),
        };
        count("bodies", self.bodies.len(), s.bodies.len())?;
        count("joints", self.joints.len(), s.joints.len())?;
        count("couplings", self.couplings.len(), s.coupling_max_torque.len())?;
        // Records are sized at the first step: none before it, one per item after.
        let records = |what, items: usize, found: usize| match found == 0 || found == items {
            true => Ok(()),
            false => Err(WorldStateError::Count { what, expected: items, found }),
        };
        records("joint warm-start records", self.joints.len(), s.warm.len())?;
        records("coupling warm-start records", self.couplings.len(), s.warm_couplings.len())?;
        records("force warm-start records", self.forces.len(), s.warm_forces.len())?;
        let named = NarrowPhase::state_colliders(&s.narrow);
        if named > self.contacts.colliders.len() {
            return Err(WorldStateError::Count {
                what: "colliders",
                expected: self.contacts.colliders.len(),
                found: named,
            });
        }
        let invalid = |what, index| Err(WorldStateError::Invalid { what, index });
        if !(s.time.is_finite() && s.input_work.is_finite()) {
            return invalid("time or input work", 0);
        }
        // One solver per island slot: never more islands than bodies.
        for (what, memory) in
            [("solver memory", &s.solver_memory), ("projection memory", &s.projection_memory)]
        {
            if memory.len() > self.bodies.len().max(1) {
                return Err(WorldStateError::Count {
                    what,
                    expected: self.bodies.len(),
                    found: memory.len(),
                });
            }
            if let Some(i) = memory.iter().position(|&(a, b)| !(a.is_finite() && b.is_finite())) {
                return invalid(what, i);
            }
        }
        for (i, b) in s.bodies.iter().enumerate() {
            if !(finite(&b.position) && finite(&b.linvel) && finite(&b.angvel)) {
                return invalid("pose or velocity", i);
            }
            let n2: f64 = b.orientation.iter().map(|c| c * c).sum();
            if !(n2 - 1.0).abs().lt(&1e-9) {
                return invalid("orientation", i);
            }
        }
        for (i, r) in s.joint_rows.iter().enumerate() {
            // A row slot out of its range would index past the joint's warm-start records.
            let joint_ok = matches!(r.key, RowKey::Joint { joint, row }
                if joint.index() < self.joints.len()
                    && !matches!(row, crate::dynamics::joint::JointRow::Locked(k) if k >= 6));
            let bodies_ok = r.bodies.iter().flatten().all(|&b| b < self.bodies.len());
            if !(joint_ok && bodies_ok && r.findex.is_none()) {
                return invalid("joint row", i);
            }
        }
        let warm = s.warm.iter().flatten().chain(&s.warm_couplings).chain(&s.warm_forces);
        if let Some(i) =
            warm.chain(s.warm_contacts.iter().map(|(_, w)| w)).position(|w| !w.lambda.is_finite())
        {
            return invalid("warm-start impulse", i);
        }
        Ok(())
    }
}

/// A total order on row keys (for a canonical encoding; the map itself has none).
fn row_key_order(k: &RowKey) -> (u8, [u32; 5]) {
    match *k {
        RowKey::Joint { joint, row } => (0, [joint.0, row.slot() as u32, 0, 0, 0]),
        RowKey::Coupling(c) => (1, [c.0, 0, 0, 0, 0]),
        RowKey::Force(f) => (2, [f.0, 0, 0, 0, 0]),
        RowKey::Contact { colliders, features, row } => {
            (3, [colliders[0], colliders[1], features[0], features[1], row as u32])
        }
    }
}

/// Sets each island slot's solver memory; slots the state has not seen forget theirs (a new
/// solver would have none), and missing slots get a new solver so that the memory has a home.
fn restore_memory<T>(
    items: &mut Vec<T>,
    memory: &[(f64, f64)],
    new: impl Fn() -> T,
    solver: impl Fn(&mut T) -> &mut Solver,
) {
    while items.len() < memory.len() {
        items.push(new());
    }
    for (i, item) in items.iter_mut().enumerate() {
        let s = solver(item);
        match memory.get(i) {
            Some(&m) => s.set_cost_memory(m),
            None => s.forget_history(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::joint::JointRow;

    /// A state whose joint row names a slot past the joint's warm-start records (a damaged
    /// snapshot) is refused before anything is restored, and the world still answers queries.
    #[test]
    fn a_joint_row_slot_out_of_range_is_refused() {
        let mut scene = crate::scene::load("winch").unwrap();
        for _ in 0..5 {
            scene.world.step().unwrap();
        }
        let mut state = scene.world.state().unwrap();
        let i = state.joint_rows.iter().position(|r| matches!(r.key, RowKey::Joint { .. })).unwrap();
        let RowKey::Joint { joint, .. } = state.joint_rows[i].key else { unreachable!() };
        state.joint_rows[i].key = RowKey::Joint { joint, row: JointRow::Locked(164) };
        let before = scene.world.time();
        assert!(matches!(
            scene.world.restore_state(&state),
            Err(WorldStateError::Invalid { what: "joint row", .. })
        ));
        assert_eq!(scene.world.time(), before);
        assert!(scene.world.last_joint_rows().count() > 0);
        // In range it restores.
        state.joint_rows[i].key = RowKey::Joint { joint, row: JointRow::Locked(0) };
        assert!(scene.world.restore_state(&state).is_ok());
    }
}
