//! The `[scene]` section: world settings, the watchdog's bounds, the scene-wide defaults of
//! friction and compliance, and the `[[material]]` table.

use super::*;

impl Builder<'_> {
    /// The world settings of the `[scene]` section (unset keys: the defaults).
    pub(super) fn world_settings(&self, sspan: &Range<usize>, sec: &SceneSection) -> R<WorldSettings> {
        let mut settings = WorldSettings::default();
        if let Some(h) = sec.timestep {
            settings.timestep = self.positive(sspan, "timestep", h)?;
        }
        if let Some(g) = sec.gravity {
            settings.gravity = self.vec3(sspan, "gravity", g)?;
        }
        if let Some(v) = &sec.variant {
            settings.solver.variant =
                v.parse().map_err(|e| self.invalid(sspan, "variant", format!("{e}")))?;
        }
        if let Some(n) = sec.max_pivot_steps {
            if n == 0 {
                return Err(self.invalid(sspan, "max_pivot_steps", "must be ≥ 1"));
            }
            settings.solver.max_steps = n;
        }
        if let Some(us) = sec.max_solve_us {
            settings.solver.max_solve_us = Some(self.positive(sspan, "max_solve_us", us)?);
        }
        if let Some(b) = sec.newton_first {
            settings.solver.newton_first = b;
        }
        if let Some(b) = sec.safeguard_after_update {
            settings.solver.safeguard_after_update = b;
        }
        if let Some(b) = sec.prox_outer {
            settings.solver.prox_outer = b;
        }
        if let Some(n) = sec.murty_after {
            settings.solver.murty_after = n;
        }
        if let Some(n) = sec.ipm_after {
            settings.solver.ipm_after = n;
        }
        if let Some(n) = sec.ipm_cold_after {
            settings.solver.ipm_cold_after = n;
        }
        if let Some(n) = sec.projected_arc {
            if n > 30 {
                return Err(self.invalid(
                    sspan,
                    "projected_arc",
                    "must be at most 30 (halvings of the step)",
                ));
            }
            settings.solver.projected_arc = n;
        }
        if let Some(n) = sec.polish_sweeps {
            settings.solver.polish_sweeps = n;
        }
        if let Some(b) = sec.exact_bilateral {
            settings.solver.exact_bilateral = b;
        }
        if let Some(n) = sec.pgs_sweeps {
            if n == 0 {
                return Err(self.invalid(sspan, "pgs_sweeps", "must be ≥ 1"));
            }
            settings.solver.pgs.max_iterations = n;
        }
        if let Some(n) = sec.projection_iterations {
            settings.projection_iterations = n;
        }
        if let Some(e) = sec.joint_error_tolerance {
            settings.joint_error_tolerance = self.non_negative(sspan, "joint_error_tolerance", e)?;
        }
        if let Some(n) = sec.max_substeps {
            if !(1..=64).contains(&n) {
                return Err(self.invalid(sspan, "max_substeps", "must be 1 (never) to 64"));
            }
            settings.max_substeps = n;
        }
        if let Some(g) = sec.gyroscopic {
            settings.gyroscopic = g;
        }
        if let Some(w) = sec.warm_start {
            settings.warm_start = w;
        }
        if let Some(g) = &sec.geometric_stiffness {
            settings.geometric_stiffness = GeometricStiffness::from_name(g).ok_or_else(|| {
                self.invalid(
                    sspan,
                    "geometric_stiffness",
                    format!("unknown mode `{g}` (implicit, inertial, off)"),
                )
            })?;
        }
        Ok(settings)
    }

    /// The watchdog's bounds of the `[scene]` section.
    pub(super) fn watchdog_settings(&self, sspan: &Range<usize>, sec: &SceneSection) -> R<WatchdogSettings> {
        let mut watchdog = WatchdogSettings::default();
        if let Some(v) = sec.max_speed {
            watchdog.max_speed = self.positive(sspan, "max_speed", v)?;
        }
        if let Some(e) = sec.energy_margin {
            watchdog.energy_margin = self.positive(sspan, "energy_margin", e)?;
        }
        if let Some(e) = sec.max_joint_error {
            watchdog.max_joint_error = self.positive(sspan, "max_joint_error", e)?;
        }
        Ok(watchdog)
    }

    /// The scene-wide defaults of the `[scene]` section: friction and compliance of the items that
    /// give none, the contact compliance and prediction margin.
    pub(super) fn scene_defaults(&mut self, sspan: &Range<usize>, sec: &SceneSection) -> R<()> {
        self.default_mu = self.non_negative(sspan, "friction", sec.friction.unwrap_or(1.0))?;
        self.default_compliance = self.non_negative(
            sspan,
            "compliance",
            sec.compliance.unwrap_or(crate::dynamics::DEFAULT_COMPLIANCE),
        )?;
        if let Some(c) = sec.contact_compliance {
            let mut cs = self.world.contact_settings();
            cs.compliance = self.positive(sspan, "contact_compliance", c)?;
            self.world
                .set_contact_settings(cs)
                .map_err(|e| self.invalid(sspan, "contact_compliance", e.to_string()))?;
        }
        if let Some(m) = sec.contact_margin {
            let mut cs = self.world.contact_settings();
            cs.margin = self.non_negative(sspan, "contact_margin", m)?;
            self.world
                .set_contact_settings(cs)
                .map_err(|e| self.invalid(sspan, "contact_margin", e.to_string()))?;
        }
        if let Some(b) = sec.swept_contacts {
            let mut cs = self.world.contact_settings();
            cs.swept = b;
            self.world
                .set_contact_settings(cs)
                .map_err(|e| self.invalid(sspan, "swept_contacts", e.to_string()))?;
        }
        Ok(())
    }

    /// A `[[material]]` pair's friction.
    pub(super) fn add_material(&mut self, span: &Range<usize>, d: &MaterialDef) -> R<()> {
        let mu = self.non_negative(span, "friction", d.friction)?;
        self.world
            .set_material_friction(&d.a, &d.b, mu)
            .map_err(|e| self.invalid(span, "friction", e.to_string()))
    }
}
