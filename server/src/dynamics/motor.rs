//! Free axes of a joint and what may act on them: limits and motors (velocity or position target).
//!
//! **Free axes.** A hinge rotates about its frame x axis, a prismatic joint slides along it, a
//! cylindrical joint does both ([`FreeAxis::Linear`] and [`FreeAxis::Angular`]). The free
//! coordinate `s` of an axis is the displacement (m) or angle (rad, in `(−π, π]`) of body A relative
//! to body B (the parent, or the world), zero where the joint was built; `ṡ = J_s v` with the blocks
//! of `joint_rows.rs`. Each free axis may carry one [`JointLimit`] and one [`JointMotor`].
//!
//! **Limits**: `lower ≤ s ≤ upper`, unilateral rows `λ ∈ [0, ∞)` emitted only while the coordinate is
//! within `margin` of a bound or predicted to cross it within the step.
//!
//! **Velocity motor**: one velocity row on the axis,
//!
//! ```text
//!   J_s v⁺ + (c/h²) λ = u,     λ ∈ [−F_max h, F_max h]         (a boxed row, paper eq. 3)
//! ```
//!
//! with `u` the target speed: the motor reaches `u` if a force (torque) within `±F_max` suffices and
//! otherwise pushes at its bound (it stalls).
//!
//! **Position motor** (hydraulic cylinders, boom joints, servos): the same row with a target speed
//! recomputed every step from the position error `e = s* − s` (wrapped to `(−π, π]` on an angular
//! axis, so an angle servo turns the short way),
//!
//! ```text
//!   u = clamp(g e / h, −u_max, u_max),     0 < g ≤ 1.
//! ```
//!
//! Unsaturated, the implicit row gives `s⁺ = s + h u = s + g e`, i.e. `e⁺ = (1 − g) e`: the gain `g`
//! is the fraction of the error removed per step (like the stabilization `β` of a locked row; `g = 1`,
//! the default, lands on the target in one step). Far from the target the axis runs at `±u_max`; when
//! the load needs more than `F_max` the motor stalls where its bound balances the load (a boom lifted
//! by an undersized cylinder stops at `F_max = m g r cos θ`). At the target it holds the load exactly,
//! offset only by the row's compliance: at rest `g e / h = c λ / h²`, so `s = s* − c F / g` with
//! `F = λ / h` the holding force.

/// A free axis of a joint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum FreeAxis {
    /// Translation along the joint's x axis (prismatic, cylindrical).
    Linear,
    /// Rotation about the joint's x axis (hinge, cylindrical).
    Angular,
}

impl FreeAxis {
    /// Both axes, in index order.
    pub const ALL: [FreeAxis; 2] = [FreeAxis::Linear, FreeAxis::Angular];

    /// Index `0` (linear) or `1` (angular) in per-axis arrays.
    #[inline]
    pub fn index(self) -> usize {
        match self {
            FreeAxis::Linear => 0,
            FreeAxis::Angular => 1,
        }
    }

    /// Name used in errors.
    pub fn name(self) -> &'static str {
        match self {
            FreeAxis::Linear => "linear",
            FreeAxis::Angular => "angular",
        }
    }

    /// The position error `target − s`, wrapped to `(−π, π]` on an angular axis.
    pub fn error(self, target: f64, s: f64) -> f64 {
        let e = target - s;
        match self {
            FreeAxis::Linear => e,
            FreeAxis::Angular => wrap_angle(e),
        }
    }
}

/// `x` wrapped to `(−π, π]`.
pub fn wrap_angle(x: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    let r = x - TAU * (x / TAU).round();
    if r <= -PI { r + TAU } else { r }
}

/// Lower/upper limit of a free coordinate (rad for rotations, m for translations).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct JointLimit {
    /// Lower bound (may be `−∞`).
    pub lower: f64,
    /// Upper bound (may be `+∞`).
    pub upper: f64,
    /// A limit row is emitted while the coordinate is within this distance of the bound.
    pub margin: f64,
}

impl JointLimit {
    /// Limits with the default activation margin (0.01 rad or m).
    pub fn new(lower: f64, upper: f64) -> Self {
        JointLimit { lower, upper, margin: 0.01 }
    }
}

/// Default gain `g` of a position motor: the whole error per step (see the module doc).
pub const DEFAULT_POSITION_GAIN: f64 = 1.0;

/// What a motor drives toward.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum MotorMode {
    /// A target speed (rad/s or m/s) of A relative to B about/along the axis, positive in the
    /// sense of the axis.
    Velocity {
        /// Target speed `u`.
        target_speed: f64,
    },
    /// A target coordinate, reached through the velocity row with `u = clamp(g e / h, ±u_max)`.
    Position {
        /// Target coordinate `s*` (rad or m).
        target: f64,
        /// Speed bound `u_max > 0` (may be `+∞`).
        max_speed: f64,
        /// Gain `g ∈ (0, 1]`: fraction of the error removed per step.
        gain: f64,
    },
}

/// A motor on a free axis: a mode and a force (torque) bound.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct JointMotor {
    /// Velocity or position target.
    pub mode: MotorMode,
    /// Force (N) or torque (N m) bound `F_max ≥ 0`.
    pub max_force: f64,
}

impl JointMotor {
    /// A velocity motor.
    pub fn velocity(target_speed: f64, max_force: f64) -> Self {
        JointMotor { mode: MotorMode::Velocity { target_speed }, max_force }
    }

    /// A position motor with the default gain.
    pub fn position(target: f64, max_speed: f64, max_force: f64) -> Self {
        JointMotor { mode: MotorMode::Position { target, max_speed, gain: DEFAULT_POSITION_GAIN }, max_force }
    }

    /// The same motor with gain `g` (position motors; a velocity motor is returned unchanged).
    pub fn with_gain(mut self, g: f64) -> Self {
        if let MotorMode::Position { gain, .. } = &mut self.mode {
            *gain = g;
        }
        self
    }

    /// Target speed `u` of the motor row at coordinate `s` (time step `h`).
    pub fn target_speed(&self, axis: FreeAxis, s: f64, h: f64) -> f64 {
        match self.mode {
            MotorMode::Velocity { target_speed } => target_speed,
            MotorMode::Position { target, max_speed, gain } => {
                (gain * axis.error(target, s) / h).clamp(-max_speed, max_speed)
            }
        }
    }

    /// Whether every parameter is in range (see [`JointError::InvalidMotor`](super::JointError)).
    pub(crate) fn is_valid(&self) -> bool {
        let force_ok = self.max_force.is_finite() && self.max_force >= 0.0;
        force_ok
            && match self.mode {
                MotorMode::Velocity { target_speed } => target_speed.is_finite(),
                MotorMode::Position { target, max_speed, gain } => {
                    target.is_finite() && max_speed > 0.0 && !max_speed.is_nan() && gain > 0.0 && gain <= 1.0
                }
            }
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use super::*;

    #[test]
    fn angles_wrap_to_the_half_open_interval() {
        for (x, w) in
            [(0.0, 0.0), (PI, PI), (-PI, PI), (3.0 * PI, PI), (2.0 * PI + 0.5, 0.5), (-7.0, -7.0 + 2.0 * PI)]
        {
            assert!((wrap_angle(x) - w).abs() < 1e-12, "{x}: {} vs {w}", wrap_angle(x));
        }
        // An angle servo turns the short way across ±π; a linear one does not wrap.
        assert!((FreeAxis::Angular.error(3.0, -3.0) - (6.0 - 2.0 * PI)).abs() < 1e-12);
        assert_eq!(FreeAxis::Linear.error(3.0, -3.0), 6.0);
    }

    #[test]
    fn position_target_speed_is_the_clamped_error_rate() {
        let h = 0.01;
        let m = JointMotor::position(1.0, 2.0, 10.0).with_gain(0.5);
        assert!((m.target_speed(FreeAxis::Linear, 0.99, h) - 0.5).abs() < 1e-12);
        assert_eq!(m.target_speed(FreeAxis::Linear, 0.0, h), 2.0);
        assert_eq!(m.target_speed(FreeAxis::Linear, 3.0, h), -2.0);
        assert_eq!(
            JointMotor::velocity(0.3, 1.0).with_gain(0.1).target_speed(FreeAxis::Angular, 5.0, h),
            0.3
        );
        assert!(JointMotor::position(0.0, f64::INFINITY, 1.0).is_valid());
        for bad in [
            JointMotor::position(0.0, 0.0, 1.0),
            JointMotor::position(0.0, 1.0, 1.0).with_gain(1.5),
            JointMotor::position(0.0, 1.0, 1.0).with_gain(0.0),
            JointMotor::position(f64::NAN, 1.0, 1.0),
            JointMotor::velocity(0.0, -1.0),
        ] {
            assert!(!bad.is_valid(), "{bad:?}");
        }
    }
}
