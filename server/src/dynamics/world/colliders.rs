//! The world's collider API: adding colliders, the friction table, collision groups, contact
//! settings, and the contacts of the last step. The contact model, its maths and the narrow phase
//! are in `contact/`; this file is how a world's user reaches them.

use super::World;
use crate::dynamics::contact::{
    Collider, ColliderBuilder, CollisionGroups, ContactError, ContactReport, ContactSettings,
};
use crate::dynamics::ids::{BodyId, ColliderId};
use crate::dynamics::rows::RowKey;
use crate::solver::IndexState;

impl World {
    /// Adds a collider (validated; degenerate shapes are refused with a typed error).
    pub fn add_collider(&mut self, cb: ColliderBuilder) -> Result<ColliderId, ContactError> {
        if self.contacts.names.contains_key(cb.name()) {
            return Err(ContactError::DuplicateName { collider: cb.name().to_string() });
        }
        let id = ColliderId(self.contacts.colliders.len() as u32);
        let collider = cb.build(&self.bodies, &mut self.contacts.materials)?;
        self.contacts.names.insert(collider.name.clone(), id);
        self.contacts.colliders.push(collider);
        Ok(id)
    }

    /// The colliders.
    pub fn colliders(&self) -> &[Collider] {
        &self.contacts.colliders
    }

    /// A collider by name.
    pub fn collider_id(&self, name: &str) -> Option<ColliderId> {
        self.contacts.names.get(name).copied()
    }

    /// Sets (`Some(μ)`) or clears (`None`: back to the geometric mean of the materials) the friction
    /// coefficient of the pair `a`, `b`; it applies from the next step.
    pub fn set_pair_friction(
        &mut self,
        a: ColliderId,
        b: ColliderId,
        mu: Option<f64>,
    ) -> Result<(), ContactError> {
        for id in [a, b] {
            if id.index() >= self.contacts.colliders.len() {
                return Err(ContactError::UnknownCollider(id));
            }
        }
        let key = (a.0.min(b.0), a.0.max(b.0));
        match mu {
            Some(mu) if mu.is_finite() && mu >= 0.0 => {
                self.contacts.pair_friction.insert(key, mu);
            }
            Some(mu) => {
                let name = format!(
                    "{}/{}",
                    self.contacts.colliders[a.index()].name,
                    self.contacts.colliders[b.index()].name
                );
                return Err(ContactError::InvalidFriction { collider: name, value: mu });
            }
            None => {
                self.contacts.pair_friction.remove(&key);
            }
        }
        Ok(())
    }

    /// Sets the friction coefficient of the material pair `a`, `b` (names, in either order; a
    /// material with itself is a pair too); it applies from the next step to every collider pair
    /// of these materials without a pair override. Precedence: [`World::set_pair_friction`] over
    /// this table over the geometric mean of the colliders' [`Material::friction`](crate::dynamics::Material::friction).
    pub fn set_material_friction(&mut self, a: &str, b: &str, mu: f64) -> Result<(), ContactError> {
        if a.is_empty() || b.is_empty() {
            return Err(ContactError::EmptyMaterialName);
        }
        if !(mu.is_finite() && mu >= 0.0) {
            return Err(ContactError::InvalidMaterialFriction {
                a: a.to_string(),
                b: b.to_string(),
                value: mu,
            });
        }
        let (ia, ib) = (self.contacts.materials.intern(a), self.contacts.materials.intern(b));
        self.contacts.materials.set(ia, ib, Some(mu));
        Ok(())
    }

    /// Removes the material pair `a`, `b` from the friction table (no-op if absent).
    pub fn clear_material_friction(&mut self, a: &str, b: &str) {
        let m = &mut self.contacts.materials;
        if let (Some(ia), Some(ib)) = (m.id(a), m.id(b)) {
            m.set(ia, ib, None);
        }
    }

    /// The friction table's entry for the material pair `a`, `b`, if any.
    pub fn material_friction(&self, a: &str, b: &str) -> Option<f64> {
        let m = &self.contacts.materials;
        m.get(m.id(a)?, m.id(b)?)
    }

    /// The friction coefficient the colliders `a` and `b` get when they touch (pair override,
    /// else material-pair table, else geometric mean: [`World::set_material_friction`]).
    pub fn pair_friction(&self, a: ColliderId, b: ColliderId) -> Result<f64, ContactError> {
        for id in [a, b] {
            if id.index() >= self.contacts.colliders.len() {
                return Err(ContactError::UnknownCollider(id));
            }
        }
        Ok(self.contacts.pair_mu(a.index(), b.index()))
    }

    /// Changes a collider's collision groups; it applies from the next step.
    pub fn set_collision_groups(
        &mut self,
        id: ColliderId,
        groups: CollisionGroups,
    ) -> Result<(), ContactError> {
        let c = self.contacts.colliders.get_mut(id.index()).ok_or(ContactError::UnknownCollider(id))?;
        c.groups = groups;
        Ok(())
    }

    /// Contact settings.
    pub fn contact_settings(&self) -> ContactSettings {
        self.contacts.settings
    }

    /// Changes the contact settings (validated).
    pub fn set_contact_settings(&mut self, s: ContactSettings) -> Result<(), ContactError> {
        let bad = |what, value| Err(ContactError::InvalidSetting { what, value });
        if !(s.margin.is_finite() && s.margin >= 0.0) {
            return bad("margin", s.margin);
        }
        if !(s.compliance.is_finite() && s.compliance >= 0.0) {
            return bad("compliance", s.compliance);
        }
        if !(s.stabilization > 0.0 && s.stabilization <= 1.0) {
            return bad("stabilization", s.stabilization);
        }
        if !(s.sliding_speed.is_finite() && s.sliding_speed >= 0.0) {
            return bad("sliding_speed", s.sliding_speed);
        }
        self.contacts.settings = s;
        Ok(())
    }

    /// The contact points of the last step with their impulses (zero impulses before the first
    /// step or for a point whose island was not solved).
    pub fn contacts(&self) -> impl Iterator<Item = ContactReport> + '_ {
        self.contacts.phase.points.iter().map(move |p| {
            let record = |row: u8| {
                let key = RowKey::Contact { colliders: [p.ca, p.cb], features: p.features, row };
                self.last_step_row(key).map_or((0.0, IndexState::Free), |w| (w.lambda, w.state))
            };
            let rows = [record(0), record(1), record(2)];
            ContactReport {
                collider_a: ColliderId(p.ca),
                collider_b: ColliderId(p.cb),
                point_a: p.pa,
                point_b: p.pb,
                normal: p.n,
                gap: p.dist,
                normal_impulse: rows[0].0,
                friction_impulse: [rows[1].0, rows[2].0],
                tangents: p.t,
                bodies: [BodyId(p.a as u32), BodyId(p.b as u32)],
                mu: p.mu,
                states: [rows[0].1, rows[1].1, rows[2].1],
            }
        })
    }
}
