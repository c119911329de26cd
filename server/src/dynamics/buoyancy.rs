//! Hydrostatic buoyancy and hydrodynamic drag on sample points of a body, against a water plane
//! `z = z_w(t)` with an optional prescribed wave `z_w(t) = z₀ + A sin(ω t + ϕ)` (the offshore scene
//! floats a 5,500 t ship). A force element (`force.rs`), evaluated at the start of the step.
//!
//! **Sample points.** Body `k` carries points `i` at body-frame positions `ρ_i`, each standing for a
//! vertical slab of the hull: volume `V_i > 0` and height `H_i > 0`, centred at the point. At world
//! position `p_i = x + R ρ_i`, the slab's submerged fraction is the depth clamp
//!
//! ```text
//!   f_i = clamp((z_w − p_i,z) / H_i + 1/2, 0, 1)
//! ```
//!
//! (0 with the slab's bottom at the surface, 1 with its top under water, linear in between — exact
//! for an upright prism). The point receives the buoyancy (Archimedes: the weight of the displaced
//! water, opposite to gravity) and, when wet, a drag on its velocity relative to the water
//! (`ż_w` vertical, from the wave),
//!
//! ```text
//!   F_i = −ρ_w V_i f_i g  −  f_i V_i (c₁ u + c₂ |u| u),     u = v + ω × (p_i − x) − ż_w e_z,
//! ```
//!
//! with the water density `ρ_w`, the world gravity `g` and drag coefficients per unit submerged
//! volume `c₁` (kg/(m³ s)) and `c₂` (kg/m⁴). The torque about the centre of mass is
//! `(p_i − x) × F_i`, so an off-centre immersion rights (or capsizes) a hull.
//!
//! **Equilibrium** of an upright box of height `H` and density `ρ_b` split into one layer of points
//! of height `H` at mid-height: `Σ f_i ρ_w V_i g = ρ_w V g d / H` with the draft `d`, equal to the
//! weight `ρ_b V g` at `d = (ρ_b / ρ_w) H` (a body denser than water sinks, at the terminal speed
//! where `(ρ_b − ρ_w) g = c₁ u + c₂ u²`). Heave is a spring of stiffness `k = ρ_w g V / H` on the
//! water level: slow waves (`ω² ≪ k/m`) carry a floating body up and down with their amplitude.
//!
//! **Integration**: linearly implicit (`force.rs`): the element hands its drag Jacobian `D` and
//! buoyancy stiffness `K` (below) with its forces, so neither a stiff waterline (a light float) nor
//! strong drag can make the step diverge, while equilibria and terminal speeds stay exact.
//!
//! [`Buoyancy::box_grid`] builds the points of a box hull.

use nalgebra::{Matrix3, Matrix6x3, Vector3};

use super::accumulator::ForceAccumulator;
use super::body::RigidBody;
use super::error::ForceError;
use super::ids::BodyId;

/// One sample point of a hull: a vertical slab of volume `volume` and height `height` centred at
/// `position` (body frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BuoyancyPoint {
    /// Position in the body frame (m).
    pub position: Vector3<f64>,
    /// Volume `V_i > 0` (m³).
    pub volume: f64,
    /// Slab height `H_i > 0` (m) over which the point submerges.
    pub height: f64,
}

/// A prescribed wave of the water level: `A sin(ω t + ϕ)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wave {
    /// Amplitude `A ≥ 0` (m).
    pub amplitude: f64,
    /// Angular frequency `ω ≥ 0` (rad/s).
    pub angular_frequency: f64,
    /// Phase `ϕ` (rad).
    pub phase: f64,
}

/// The water: still level, density and an optional wave.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Water {
    /// Still-water level `z₀` (m).
    pub level: f64,
    /// Density `ρ_w > 0` (kg/m³; sea water ≈ 1025).
    pub density: f64,
    /// Prescribed wave, if any.
    pub wave: Option<Wave>,
}

impl Water {
    /// Still water at `level` with density `density`.
    pub fn still(level: f64, density: f64) -> Self {
        Water { level, density, wave: None }
    }

    /// The level `z_w(t)` and its rate `ż_w(t)`.
    pub fn surface(&self, t: f64) -> (f64, f64) {
        match self.wave {
            None => (self.level, 0.0),
            Some(w) => {
                let phase = w.angular_frequency * t + w.phase;
                (self.level + w.amplitude * phase.sin(), w.amplitude * w.angular_frequency * phase.cos())
            }
        }
    }
}

/// Buoyancy and drag of one body's sample points (see the module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct Buoyancy {
    /// The floating body (dynamic).
    pub body: BodyId,
    /// Its sample points (at least one).
    pub points: Vec<BuoyancyPoint>,
    /// The water.
    pub water: Water,
    /// Linear drag `c₁ ≥ 0` per unit submerged volume (kg/(m³ s)).
    pub linear_drag: f64,
    /// Quadratic drag `c₂ ≥ 0` per unit submerged volume (kg/m⁴).
    pub quadratic_drag: f64,
}

impl Buoyancy {
    /// Points of a box hull of half extents `half` (body frame, z up in the body): an `nx × ny` grid
    /// at mid-height, each of height `2 half.z` and volume `8 half.x half.y half.z / (nx ny)`. No drag.
    pub fn box_grid(body: BodyId, half: Vector3<f64>, nx: usize, ny: usize, water: Water) -> Self {
        let n = (nx * ny).max(1) as f64;
        let volume = 8.0 * half.x * half.y * half.z / n;
        let mut points = Vec::with_capacity(nx * ny);
        for i in 0..nx {
            for j in 0..ny {
                let x = -half.x + (2 * i + 1) as f64 * half.x / nx as f64;
                let y = -half.y + (2 * j + 1) as f64 * half.y / ny as f64;
                points.push(BuoyancyPoint {
                    position: Vector3::new(x, y, 0.0),
                    volume,
                    height: 2.0 * half.z,
                });
            }
        }
        Buoyancy { body, points, water, linear_drag: 0.0, quadratic_drag: 0.0 }
    }

    /// The same element with drag coefficients `c₁`, `c₂`.
    pub fn with_drag(mut self, linear: f64, quadratic: f64) -> Self {
        self.linear_drag = linear;
        self.quadratic_drag = quadratic;
        self
    }

    /// Submerged fraction of point `p` (world) at water level `z_w`.
    #[inline]
    pub fn fraction(p: &BuoyancyPoint, world_z: f64, z_w: f64) -> f64 {
        ((z_w - world_z) / p.height + 0.5).clamp(0.0, 1.0)
    }

    /// Submerged volume `Σ f_i V_i` of the body at time `t` (m³).
    pub fn submerged_volume(&self, bodies: &[RigidBody], t: f64) -> f64 {
        let b = &bodies[self.body.index()];
        let (z_w, _) = self.water.surface(t);
        self.points.iter().map(|p| p.volume * Self::fraction(p, b.point_world(p.position).z, z_w)).sum()
    }

    pub(crate) fn validate(&self, force: &str, bodies: &[RigidBody]) -> Result<(), ForceError> {
        let name = || force.to_string();
        let b = bodies
            .get(self.body.index())
            .ok_or(ForceError::UnknownBody { force: name(), body: self.body })?;
        if !b.is_dynamic() {
            return Err(ForceError::NoDynamicBody { force: name() });
        }
        if self.points.is_empty() {
            return Err(ForceError::NoSamplePoints { force: name() });
        }
        for (i, p) in self.points.iter().enumerate() {
            let bad = |what, value| Err(ForceError::InvalidPoint { force: name(), point: i, what, value });
            if let Some(&c) = p.position.iter().find(|c| !c.is_finite()) {
                return bad("position", c);
            }
            if !(p.volume.is_finite() && p.volume > 0.0) {
                return bad("volume", p.volume);
            }
            if !(p.height.is_finite() && p.height > 0.0) {
                return bad("height", p.height);
            }
        }
        let w = &self.water;
        let wave = w.wave.unwrap_or(Wave { amplitude: 0.0, angular_frequency: 0.0, phase: 0.0 });
        for (what, v, positive) in [
            ("water level", w.level, None),
            ("water density", w.density, Some(true)),
            ("wave amplitude", wave.amplitude, Some(false)),
            ("wave angular frequency", wave.angular_frequency, Some(false)),
            ("wave phase", wave.phase, None),
            ("linear drag", self.linear_drag, Some(false)),
            ("quadratic drag", self.quadratic_drag, Some(false)),
        ] {
            let ok = v.is_finite()
                && match positive {
                    None => true,
                    Some(true) => v > 0.0,
                    Some(false) => v >= 0.0,
                };
            if !ok {
                return Err(ForceError::InvalidParameter { force: name(), what, value: v });
            }
        }
        Ok(())
    }

    /// Adds the buoyancy and drag forces and their torques (about the centre of mass) at time `t`,
    /// and their Jacobians for the linearly implicit step (`force.rs`): with `P_i = [𝟙; [r_i]×]`
    /// mapping the body's `(v, ω)` to the point velocity (`u_i = P_iᵀ (v, ω)`) and a point force
    /// `F` to the body's `(F, r_i × F)`,
    ///
    /// ```text
    ///   D = −Σ_i f_i V_i P_i (c₁ 𝟙 + c₂ |u| (𝟙 + û ûᵀ)) P_iᵀ,
    ///   K = Σ_{i : 0 < f_i < 1} (ρ_w V_i / H_i) (P_i g)(P_i e_z)ᵀ
    /// ```
    ///
    /// (the buoyancy `−ρ_w V_i f_i g` changes with the point's height at the rate `−1/H_i` of `f_i`;
    /// the rotation of the lever arms is neglected).
    pub(crate) fn accumulate(
        &self,
        bodies: &[RigidBody],
        t: f64,
        gravity: &Vector3<f64>,
        acc: &mut ForceAccumulator,
    ) {
        let k = self.body.index();
        let b = &bodies[k];
        let (z_w, zdot_w) = self.water.surface(t);
        let water_velocity = Vector3::new(0.0, 0.0, zdot_w);
        for p in &self.points {
            let pw = b.point_world(p.position);
            let f = Self::fraction(p, pw.z, z_w);
            if f <= 0.0 {
                continue;
            }
            let vol = f * p.volume;
            let u = b.point_velocity(pw) - water_velocity;
            let speed = u.norm();
            let fi = -gravity * (self.water.density * vol)
                - u * (vol * (self.linear_drag + self.quadratic_drag * speed));
            let r = pw - b.position();
            acc.force[k] += fi;
            acc.torque[k] += r.cross(&fi);
            // P_i as a 6 × 3 block [𝟙; [r]×].
            let mut pm = Matrix6x3::zeros();
            pm.fixed_view_mut::<3, 3>(0, 0).copy_from(&Matrix3::identity());
            pm.fixed_view_mut::<3, 3>(3, 0).copy_from(&r.cross_matrix());
            let mut dfdu = Matrix3::identity() * (vol * self.linear_drag);
            if speed > 0.0 {
                let uh = u / speed;
                dfdu += (Matrix3::identity() + uh * uh.transpose()) * (vol * self.quadratic_drag * speed);
            }
            acc.damping[k] -= pm * dfdu * pm.transpose();
            if f < 1.0 {
                let kappa = self.water.density * p.volume / p.height;
                acc.stiffness[k] += (pm * gravity) * (pm * Vector3::z()).transpose() * kappa;
            }
            acc.implicit[k] = true;
        }
    }

    /// Potential energy of the buoyancy in still water at `z₀` (waves make it time-dependent; drag
    /// has none): `Σ ρ_w |g| V_i G(p_i,z)` with `G' = −f`, `G = 0` above the slab,
    /// `G = u² / (2H)` for the immersion depth `u = z₀ + H/2 − z ∈ [0, H]`, `H/2 + (u − H)` below.
    pub fn potential_energy(&self, bodies: &[RigidBody], gravity: &Vector3<f64>) -> f64 {
        let b = &bodies[self.body.index()];
        let g = gravity.norm();
        self.points
            .iter()
            .map(|p| {
                let u = (self.water.level + 0.5 * p.height - b.point_world(p.position).z).max(0.0);
                let depth =
                    if u <= p.height { u * u / (2.0 * p.height) } else { 0.5 * p.height + (u - p.height) };
                self.water.density * g * p.volume * depth
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::body::{BodyBuilder, box_inertia};

    /// The buoyant force is minus the derivative of the potential along z (central differences),
    /// across the slab's three regimes; the box grid's submerged volume is the prism's.
    #[test]
    fn force_is_the_gradient_of_the_potential() {
        let half = Vector3::new(1.0, 0.5, 0.4);
        let g = Vector3::new(0.0, 0.0, -9.81);
        let el = Buoyancy::box_grid(BodyId(0), half, 3, 2, Water::still(0.0, 1025.0));
        for z in [-2.0, -0.35, -0.1, 0.0, 0.2, 0.39, 1.0] {
            let body = |z: f64| {
                vec![
                    BodyBuilder::dynamic("b", 1.0, box_inertia(1.0, half))
                        .position(Vector3::new(0.0, 0.0, z))
                        .build(crate::dynamics::BodyId(0))
                        .unwrap(),
                ]
            };
            let mut acc = ForceAccumulator::default();
            acc.reset(1);
            el.accumulate(&body(z), 0.0, &g, &mut acc);
            let (f, t) = (&acc.force, &acc.torque);
            let eps = 1e-6;
            let fd = -(el.potential_energy(&body(z + eps), &g) - el.potential_energy(&body(z - eps), &g))
                / (2.0 * eps);
            assert!((f[0].z - fd).abs() < 1e-5 * (1.0 + fd.abs()), "z {z}: {} vs {fd}", f[0].z);
            assert!(f[0].x == 0.0 && f[0].y == 0.0 && t[0].norm() < 1e-9);
            let draft = (0.4 - z).clamp(0.0, 0.8);
            let expected = 4.0 * half.x * half.y * draft;
            assert!((el.submerged_volume(&body(z), 0.0) - expected).abs() < 1e-12);
        }
    }
}
