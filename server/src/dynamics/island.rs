//! Islands: the connected components of dynamic bodies under the constraint rows.
//!
//! Rows couple only bodies they touch, so `A = J M⁻¹ Jᵀ + C/h²` (paper eq. 2) is block diagonal over
//! the components of the graph whose vertices are the *dynamic* bodies and whose edges are rows
//! joining dynamic bodies (a coupling row on several bodies joins all of them). Static and kinematic bodies have infinite mass (`M⁻¹ = 0`): a row
//! through one of them couples nothing through it, so they never join two islands (two chains hanging
//! from one static ceiling are two islands). Each island is one MLCP, solved independently (in a
//! loop now; the islands share no data, so they may later be solved in parallel).
//!
//! Union–find with union by size and path halving; island numbers follow the smallest body index
//! of each island, so they are stable while the topology is. A dynamic body without rows is an
//! island of its own (no rows, nothing to solve). Buffers are reused: no allocation once they have
//! grown to the scene's size.

use super::rows::ConstraintRow;

const NONE: u32 = u32::MAX;

/// Island partition of bodies and rows (CSR-like lists, reused from step to step).
#[derive(Debug, Default, Clone)]
pub struct Islands {
    parent: Vec<u32>,
    size: Vec<u32>,
    body_island: Vec<u32>,
    body_local: Vec<u32>,
    bodies_start: Vec<usize>,
    bodies: Vec<usize>,
    rows_start: Vec<usize>,
    rows: Vec<usize>,
    fill: Vec<usize>,
}

/// The first dynamic body a row touches.
#[inline]
fn first_dynamic(r: &ConstraintRow, dynamic: &[bool]) -> Option<usize> {
    r.blocks().map(|(b, _)| b).find(|&b| dynamic[b])
}

impl Islands {
    fn find(&mut self, mut i: u32) -> u32 {
        while self.parent[i as usize] != i {
            let gp = self.parent[self.parent[i as usize] as usize];
            self.parent[i as usize] = gp;
            i = gp;
        }
        i
    }

    fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra == rb {
            return;
        }
        let (big, small) = if self.size[ra as usize] >= self.size[rb as usize] { (ra, rb) } else { (rb, ra) };
        self.parent[small as usize] = big;
        self.size[big as usize] += self.size[small as usize];
    }

    /// Partitions the bodies (`dynamic[i]` tells whether body `i` is dynamic) and the rows. A row
    /// must touch at least one dynamic body.
    pub fn build(&mut self, dynamic: &[bool], rows: &[ConstraintRow]) {
        let n = dynamic.len();
        self.parent.clear();
        self.parent.extend(0..n as u32);
        self.size.clear();
        self.size.resize(n, 1);
        for r in rows {
            let mut first = None;
            for (b, _) in r.blocks().filter(|&(b, _)| dynamic[b]) {
                match first {
                    None => first = Some(b as u32),
                    Some(a) => self.union(a, b as u32),
                }
            }
        }
        // Number islands in order of their smallest body; count bodies per island.
        self.body_island.clear();
        self.body_island.resize(n, NONE);
        self.body_local.clear();
        self.body_local.resize(n, NONE);
        self.bodies_start.clear();
        self.bodies_start.push(0);
        let mut count = 0u32;
        for i in 0..n {
            if !dynamic[i] {
                continue;
            }
            let root = self.find(i as u32) as usize;
            if self.body_island[root] == NONE {
                self.body_island[root] = count;
                count += 1;
                self.bodies_start.push(0);
            }
            let isl = self.body_island[root];
            self.body_island[i] = isl;
            self.body_local[i] = self.bodies_start[isl as usize + 1] as u32;
            self.bodies_start[isl as usize + 1] += 1;
        }
        let k = count as usize;
        for j in 0..k {
            self.bodies_start[j + 1] += self.bodies_start[j];
        }
        self.bodies.clear();
        self.bodies.resize(self.bodies_start[k], 0);
        for i in 0..n {
            if dynamic[i] {
                let isl = self.body_island[i] as usize;
                self.bodies[self.bodies_start[isl] + self.body_local[i] as usize] = i;
            }
        }
        // Rows: counting sort by island.
        self.rows_start.clear();
        self.rows_start.resize(k + 1, 0);
        for r in rows {
            let b = first_dynamic(r, dynamic).expect("a row touches a dynamic body");
            self.rows_start[self.body_island[b] as usize + 1] += 1;
        }
        for j in 0..k {
            self.rows_start[j + 1] += self.rows_start[j];
        }
        self.fill.clear();
        self.fill.extend_from_slice(&self.rows_start[..k]);
        self.rows.clear();
        self.rows.resize(rows.len(), 0);
        for (ri, r) in rows.iter().enumerate() {
            let b = first_dynamic(r, dynamic).unwrap();
            let isl = self.body_island[b] as usize;
            self.rows[self.fill[isl]] = ri;
            self.fill[isl] += 1;
        }
    }

    /// Number of islands (including single bodies without rows).
    pub fn len(&self) -> usize {
        self.bodies_start.len().saturating_sub(1)
    }

    /// Whether there is no dynamic body.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// World indices of the bodies of island `k`, ascending.
    pub fn bodies(&self, k: usize) -> &[usize] {
        &self.bodies[self.bodies_start[k]..self.bodies_start[k + 1]]
    }

    /// World indices of the rows of island `k`, ascending.
    pub fn rows(&self, k: usize) -> &[usize] {
        &self.rows[self.rows_start[k]..self.rows_start[k + 1]]
    }

    /// Island of body `i` (`None` for non-dynamic bodies).
    pub fn island_of(&self, i: usize) -> Option<usize> {
        self.body_island.get(i).copied().filter(|&k| k != NONE).map(|k| k as usize)
    }

    /// Position of body `i` in [`bodies`](Self::bodies) of its island.
    pub fn local_index(&self, i: usize) -> Option<usize> {
        self.body_local.get(i).copied().filter(|&k| k != NONE).map(|k| k as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::ids::{CouplingId, JointId};
    use crate::dynamics::joint::JointRow;
    use crate::dynamics::rows::{Jac6, RowKey, RowKind};

    fn row(a: Option<usize>, b: Option<usize>) -> ConstraintRow {
        let key = RowKey::Joint { joint: JointId(0), row: JointRow::Locked(0) };
        ConstraintRow::pair(key, RowKind::Position, a, Jac6::default(), b, Jac6::default())
    }

    #[test]
    fn static_bodies_do_not_merge_islands() {
        // 0: static; 1-2 chain on 0; 3-4 chain on 0; 5 lone; 6 kinematic joined to 5 and 1.
        let dynamic = [false, true, true, true, true, true, false];
        let rows = [
            row(Some(0), Some(1)),
            row(Some(1), Some(2)),
            row(Some(0), Some(3)),
            row(Some(3), Some(4)),
            row(Some(6), Some(5)),
            row(Some(1), Some(6)),
            row(Some(4), None),
        ];
        let mut isl = Islands::default();
        isl.build(&dynamic, &rows);
        assert_eq!(isl.len(), 3);
        assert_eq!(isl.bodies(0), &[1, 2]);
        assert_eq!(isl.bodies(1), &[3, 4]);
        assert_eq!(isl.bodies(2), &[5]);
        assert_eq!(isl.rows(0), &[0, 1, 5]);
        assert_eq!(isl.rows(1), &[2, 3, 6]);
        assert_eq!(isl.rows(2), &[4]);
        assert_eq!(isl.island_of(0), None);
        assert_eq!(isl.island_of(4), Some(1));
        assert_eq!(isl.local_index(4), Some(1));
        // Rebuilding with a bridging row merges, reusing the buffers.
        let mut more = rows.to_vec();
        more.push(row(Some(2), Some(5)));
        isl.build(&dynamic, &more);
        assert_eq!(isl.len(), 2);
        assert_eq!(isl.bodies(0), &[1, 2, 5]);
        // A coupling row on three bodies (through the static body 0) merges what it touches.
        let mut gear = ConstraintRow::new(RowKey::Coupling(CouplingId(0)), RowKind::Velocity);
        for b in [0, 4, 5] {
            assert!(gear.add_block(Some(b), Jac6::default()));
        }
        let mut more = rows.to_vec();
        more.push(gear);
        isl.build(&dynamic, &more);
        assert_eq!(isl.len(), 2);
        assert_eq!(isl.bodies(1), &[3, 4, 5]);
        assert_eq!(isl.rows(1), &[2, 3, 4, 6, 7]);
    }
}
