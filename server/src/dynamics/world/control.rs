//! Live model changes between steps that a scene script or an operator triggers: latching and
//! releasing joints (a hook latching onto a load, a grapple letting go) and capturing the island
//! problems of a step for offline study (`pivotsim-server run --dump-mlcp`), and shadow solves of
//! them by other variants (`run --shadow`, `shadow.rs`).
//!
//! **Latching.** A disabled joint adds no rows. Enabling it with `rebase = true` first moves its
//! frame on body B to where body A's frame is now, `F_B ← X_B⁻¹ X_A F_A` (poses `X`), so the joint
//! latches the bodies where they are without a violation (no impulse spike); with `rebase = false`
//! it pulls the bodies back to its original frames through the stabilization term `−βφ/h`.

use nalgebra::Isometry3;

use super::World;
use crate::dynamics::error::ControlError;
use crate::dynamics::ids::JointId;
use crate::dynamics::shadow::TooManyShadows;
use crate::solver::{Mlcp, Variant};

impl World {
    /// Enables or disables a joint; `rebase` (when enabling) latches it at the current relative
    /// pose (module doc). The warm start of its rows is dropped by the step (their keys were not
    /// solved in the last step).
    pub fn set_joint_enabled(
        &mut self,
        id: JointId,
        enabled: bool,
        rebase: bool,
    ) -> Result<(), ControlError> {
        let j = self.joints.get(id.index()).ok_or(ControlError::UnknownJoint(id))?;
        let (a, b) = (j.body_a, j.body_b);
        let pose_a = self.bodies[a.index()].pose();
        let pose_b = b.map(|b| self.bodies[b.index()].pose()).unwrap_or_else(Isometry3::identity);
        let j = &mut self.joints[id.index()];
        if enabled && !j.enabled && rebase {
            j.frame_b = pose_b.inverse() * pose_a * j.frame_a;
        }
        j.enabled = enabled;
        Ok(())
    }

    /// Has every island problem also solved by each of `variants` (at most
    /// [`MAX_SHADOWS`](crate::dynamics::MAX_SHADOWS)), their answers discarded and their time,
    /// pivot steps, status and deviation from the world's own answer recorded in
    /// [`IslandStats::shadow`](crate::dynamics::IslandStats::shadow) (`shadow.rs`). An empty list
    /// turns it off (the default). The trajectory does not change.
    pub fn set_shadow_variants(&mut self, variants: &[Variant]) -> Result<(), TooManyShadows> {
        self.ws.shadows.set_variants(variants)
    }

    /// The shadow variants, in the order of [`IslandStats::shadow`](crate::dynamics::IslandStats::shadow).
    pub fn shadow_variants(&self) -> impl Iterator<Item = Variant> + '_ {
        self.ws.shadows.variants()
    }

    /// Turns capturing of the island problems on or off (off by default; on, every step clones
    /// each island's MLCP, which allocates).
    pub fn set_capture_problems(&mut self, on: bool) {
        self.ws.capture = on;
        if !on {
            self.ws.captured.clear();
        }
    }

    /// The island problems of the last step (empty unless capturing), in the order of
    /// [`World::island_stats`].
    pub fn captured_problems(&self) -> &[Mlcp] {
        &self.ws.captured
    }
}
