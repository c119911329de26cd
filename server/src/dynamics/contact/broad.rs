//! Broad phase: sweep and prune on `x` with a persistent order, plus unbounded volumes.
//!
//! **Why sweep and prune rather than a BVH.** The boxes change every step (bodies move) and the
//! number of colliders is moderate (10²–10⁴). A sorted array of AABB lower bounds on `x`, kept from
//! the last step and re-sorted by insertion sort, costs `O(n + s)` per step for `s` swaps — nearly
//! `O(n)` under coherent motion — and the sweep `O(n + k)` for `k` overlaps on `x`; it allocates
//! nothing once warm and its output is trivially deterministic. A BVH would need a refit or rebuild
//! per step and a traversal per collider for the same answer. The cost of SAP is a degenerate
//! axis: colliders spread along `y` only all overlap on `x` (the sweep becomes all pairs again);
//! scenes of vehicles on terrain spread on `x`–`y`, and the axis is a constant away from changing.
//!
//! Unbounded volumes (half-spaces) are not swept: each is paired with every bounded one (the
//! narrow phase then tests the plane), never with another unbounded one.

use nalgebra::Vector3;

/// The AABB of one entry of [`SweepAndPrune::update`]: `None` for an unbounded volume.
pub type Bounds = Option<(Vector3<f64>, Vector3<f64>)>;

/// Sweep-and-prune broad phase: given one AABB per entry (or `None` for an unbounded volume), the
/// pairs `(i, j)`, `i < j`, whose boxes overlap (closed intervals on all three axes) or of which one
/// is unbounded and the other not, sorted. The order on `x` persists from one call to the next, so
/// coherent motion re-sorts in nearly linear time; nothing is allocated once the buffers have
/// grown.
///
/// ```
/// use nalgebra::Vector3;
/// use pivotsim_server::dynamics::SweepAndPrune;
///
/// let b = |x: f64| Some((Vector3::new(x, 0.0, 0.0), Vector3::new(x + 1.0, 1.0, 1.0)));
/// let mut sap = SweepAndPrune::new();
/// assert_eq!(sap.update(&[b(0.0), b(2.5), b(0.5), None]), &[(0, 2), (0, 3), (1, 3), (2, 3)]);
/// ```
#[derive(Debug, Clone, Default)]
pub struct SweepAndPrune {
    /// Bounded entries sorted by the lower bound on `x` (kept between calls).
    order: Vec<u32>,
    /// Whether each entry was bounded at the last call (a change rebuilds `order`).
    bounded: Vec<bool>,
    /// Unbounded entries.
    unbounded: Vec<u32>,
    pairs: Vec<(u32, u32)>,
}

impl SweepAndPrune {
    /// An empty broad phase.
    pub fn new() -> Self {
        SweepAndPrune::default()
    }

    /// The candidate pairs of `bounds` (see the type's doc), sorted; also kept for
    /// [`pairs`](Self::pairs).
    pub fn update(&mut self, bounds: &[Bounds]) -> &[(u32, u32)] {
        self.pairs.clear();
        let same = self.bounded.len() == bounds.len()
            && self.bounded.iter().zip(bounds).all(|(&was, b)| was == b.is_some());
        if !same {
            self.bounded.clear();
            self.bounded.extend(bounds.iter().map(Option::is_some));
            self.order.clear();
            self.unbounded.clear();
            for (k, b) in bounds.iter().enumerate() {
                if b.is_some() {
                    self.order.push(k as u32);
                } else {
                    self.unbounded.push(k as u32);
                }
            }
        }
        let lo = |k: u32| bounds[k as usize].as_ref().map_or(f64::NEG_INFINITY, |b| b.0.x);
        if !same {
            // A new set of entries: sort from scratch (insertion sort is for small changes).
            self.order.sort_unstable_by(|&a, &b| lo(a).total_cmp(&lo(b)));
        }
        // Insertion sort on the lower x bound: O(n + swaps), stable.
        for p in 1..self.order.len() {
            let k = self.order[p];
            let key = lo(k);
            let mut q = p;
            while q > 0 && lo(self.order[q - 1]) > key {
                self.order[q] = self.order[q - 1];
                q -= 1;
            }
            self.order[q] = k;
        }
        // Sweep: each box meets the following ones whose lower x bound is within its upper one.
        for p in 0..self.order.len() {
            let a = self.order[p];
            let Some((amin, amax)) = &bounds[a as usize] else { continue };
            for &b in &self.order[p + 1..] {
                let Some((bmin, bmax)) = &bounds[b as usize] else { continue };
                if bmin.x > amax.x {
                    break;
                }
                if bmin.y <= amax.y && amin.y <= bmax.y && bmin.z <= amax.z && amin.z <= bmax.z {
                    self.pairs.push((a.min(b), a.max(b)));
                }
            }
        }
        for &u in &self.unbounded {
            for &b in &self.order {
                self.pairs.push((u.min(b), u.max(b)));
            }
        }
        self.pairs.sort_unstable();
        &self.pairs
    }

    /// The pairs of the last [`update`](Self::update).
    pub fn pairs(&self) -> &[(u32, u32)] {
        &self.pairs
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The same pairs by testing all of them (the reference of the tests).
    fn all_pairs(bounds: &[Bounds]) -> Vec<(u32, u32)> {
        let mut out = Vec::new();
        for i in 0..bounds.len() {
            for j in i + 1..bounds.len() {
                let hit = match (&bounds[i], &bounds[j]) {
                    (Some((amin, amax)), Some((bmin, bmax))) => {
                        (0..3).all(|k| amin[k] <= bmax[k] && bmin[k] <= amax[k])
                    }
                    (None, None) => false,
                    _ => true,
                };
                if hit {
                    out.push((i as u32, j as u32));
                }
            }
        }
        out
    }

    #[test]
    fn touching_boxes_overlap_and_order_persists() {
        let b = |x: f64, y: f64| Some((Vector3::new(x, y, 0.0), Vector3::new(x + 1.0, y + 1.0, 1.0)));
        let mut sap = SweepAndPrune::new();
        let mut boxes = vec![b(3.0, 0.0), b(0.0, 0.0), b(1.0, 0.0), b(0.0, 5.0)];
        assert_eq!(sap.update(&boxes), all_pairs(&boxes).as_slice());
        assert_eq!(sap.pairs(), &[(1, 2)]);
        boxes[0] = b(-0.5, 0.5);
        assert_eq!(sap.update(&boxes), all_pairs(&boxes).as_slice());
        boxes.push(None);
        assert_eq!(sap.update(&boxes), all_pairs(&boxes).as_slice());
    }
}
