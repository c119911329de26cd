//! Material names (interned to small ids) and the friction table: the `μ` of a collider pair.
//!
//! Precedence, first match wins:
//! 1. the pair's own `μ` ([`World::set_pair_friction`](crate::dynamics::World::set_pair_friction));
//! 2. the material-pair table entry of the two colliders' material names
//!    ([`World::set_material_friction`](crate::dynamics::World::set_material_friction), symmetric;
//!    a material with itself is a pair too);
//! 3. the geometric mean `√(μ_A μ_B)` of the colliders' [`Material::friction`](super::Material)
//!    (default 1.0 each, so 1.0).

use std::collections::HashMap;

use super::Collider;

/// The material name of colliders that were not given one.
pub const DEFAULT_MATERIAL: &str = "default";

/// Interned material names and the material-pair friction table.
#[derive(Debug)]
pub(crate) struct Materials {
    ids: HashMap<String, u32>,
    names: Vec<String>,
    /// `μ` per material pair `(lower id, higher id)`.
    table: HashMap<(u32, u32), f64>,
}

impl Default for Materials {
    fn default() -> Self {
        let mut m = Materials { ids: HashMap::new(), names: Vec::new(), table: HashMap::new() };
        m.intern(DEFAULT_MATERIAL);
        m
    }
}

/// Key of an unordered pair.
fn key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

impl Materials {
    /// The id of `name`, interned if new.
    pub fn intern(&mut self, name: &str) -> u32 {
        if let Some(&id) = self.ids.get(name) {
            return id;
        }
        let id = self.names.len() as u32;
        self.ids.insert(name.to_string(), id);
        self.names.push(name.to_string());
        id
    }

    /// The id of `name` if known.
    pub fn id(&self, name: &str) -> Option<u32> {
        self.ids.get(name).copied()
    }

    /// Sets (`Some`) or clears (`None`) the table entry of a material pair.
    pub fn set(&mut self, a: u32, b: u32, mu: Option<f64>) {
        match mu {
            Some(mu) => {
                self.table.insert(key(a, b), mu);
            }
            None => {
                self.table.remove(&key(a, b));
            }
        }
    }

    /// The table entry of a material pair.
    pub fn get(&self, a: u32, b: u32) -> Option<f64> {
        self.table.get(&key(a, b)).copied()
    }
}

/// `μ` of colliders `i < j` by the precedence of the module doc.
pub(crate) fn pair_mu(
    colliders: &[Collider],
    pair_friction: &HashMap<(u32, u32), f64>,
    materials: &Materials,
    i: usize,
    j: usize,
) -> f64 {
    if let Some(&mu) = pair_friction.get(&key(i as u32, j as u32)) {
        return mu;
    }
    let (ci, cj) = (&colliders[i], &colliders[j]);
    materials
        .get(ci.material_id, cj.material_id)
        .unwrap_or_else(|| (ci.material.friction * cj.material.friction).sqrt())
}
