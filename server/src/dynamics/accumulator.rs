//! The per-body sums of the applied forces of one step, which gravity (the step) and the force
//! elements (`force.rs`, `buoyancy.rs`) write and the free-velocity update reads (`step.rs`).

use nalgebra::{Matrix6, Vector3};

/// Per-body accumulators of the applied forces of a step (world-indexed, reused): force, torque about
/// the centre of mass, and for bodies with implicit elements (`implicit[i]`) the 6 × 6 Jacobians
/// `D = ∂f/∂(v, ω)` and `K = ∂f/∂(x, θ)` (`force.rs`).
#[derive(Debug, Default)]
pub(crate) struct ForceAccumulator {
    pub force: Vec<Vector3<f64>>,
    pub torque: Vec<Vector3<f64>>,
    pub damping: Vec<Matrix6<f64>>,
    pub stiffness: Vec<Matrix6<f64>>,
    pub implicit: Vec<bool>,
}

impl ForceAccumulator {
    /// Zeroes everything for `n` bodies.
    pub fn reset(&mut self, n: usize) {
        for (v, zero) in [(&mut self.force, Vector3::zeros()), (&mut self.torque, Vector3::zeros())] {
            v.clear();
            v.resize(n, zero);
        }
        for m in [&mut self.damping, &mut self.stiffness] {
            m.clear();
            m.resize(n, Matrix6::zeros());
        }
        self.implicit.clear();
        self.implicit.resize(n, false);
    }
}
