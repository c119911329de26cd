//! Symmetric reordering for envelope (skyline) factorization: Cuthill–McKee and reverse Cuthill–McKee
//! (paper §3.4, Fig. 5/6), and the bandwidth / envelope measures they reduce.
//!
//! **Graph.** The graph `G(A)` of a symmetric `A ∈ ℝ^{n×n}` has one vertex per row and an edge
//! `{i, j}` for every stored off-diagonal entry `A_ij ≠ 0` (`i ≠ j`); the diagonal is ignored. The
//! degree of `i` is the number of its off-diagonal entries. A symmetric permutation `P A Pᵀ` only
//! relabels the vertices; we write it as `perm[new] = old` and `inv[old] = new`.
//!
//! **Cuthill–McKee (CM).** Each connected component is numbered by a breadth-first search from a
//! *pseudo-peripheral* vertex (one of near-maximal eccentricity, found by George–Liu's heuristic: start at
//! the component's smallest vertex `r`, build its rooted level structure, take a vertex `x` of minimum
//! degree in the last level (ties: smallest index), build the level structure at `x`; while the
//! eccentricity of `x` exceeds that of `r`, set `r ← x` and repeat; return the last `x`). When a vertex
//! is processed, its not yet numbered neighbours are numbered next in increasing order of degree, ties
//! broken by vertex index so that the result is deterministic. Every vertex then sits in a level `ℓ` of
//! the level structure and only has neighbours in levels `ℓ − 1, ℓ, ℓ + 1`, so the bandwidth is bounded
//! by about twice the widest level; starting at a peripheral vertex makes the levels many and narrow.
//! Components are numbered one after another in order of their smallest vertex index (an isolated vertex
//! is a component of its own), which makes `P A Pᵀ` block diagonal.
//!
//! **Reverse Cuthill–McKee (RCM)** reverses the CM numbering inside each component (components keep
//! their order). The bandwidth is unchanged, and the envelope is never larger than CM's (Liu and
//! Sherman, 1976: with CM the first neighbour `f_i` of row `i` is its BFS parent, which is
//! non-decreasing in `i`; from this every envelope cell of the reversed order maps to a distinct
//! envelope cell of the CM order).
//!
//! **Measures.** With `f_i = min({i} ∪ {j : A_ij ≠ 0})` the first stored column of row `i`,
//!
//! ```text
//!   bandwidth β(A) = max_{A_ij ≠ 0} |i − j|,        envelope |Env(A)| = Σ_i (i − f_i)
//! ```
//!
//! (the envelope counts the strictly lower cells `f_i ≤ j < i`, whether or not they are zero).
//!
//! **Why the envelope matters.** Cholesky `A = L Lᵀ` creates no fill outside the envelope: `L_ij = 0`
//! for `j < f_i`, because row `i` of `L` is obtained by a forward substitution whose right-hand side
//! (row `i` of `A`) starts at `f_i`. An envelope factor therefore stores `n + |Env|` numbers and costs
//! `O(Σ_i (i − f_i)²)` flops instead of `n³/3`. The paper's skyline `s_j` (Fig. 6: last non-zero row of
//! column `j` of `L`) is the column view of this region: the smallest column profile containing it is
//! `s_j = max{i : f_i ≤ j}`, which covers exactly the same cells when `f_i` is non-decreasing in `i` (as
//! with CM) and possibly a few more otherwise. Removing row/column `i` from the factor (paper Alg. 3,
//! DOWNDATE) is a rank-one modification of the trailing block that only touches, in each later column
//! `k`, the cells between the diagonal and `s_k`; the work per deletion is thus about `Σ_{k > i} (s_k − k)`,
//! the part of the envelope after `i`, and the triangular solves cost `O(n + |Env|)`. Because the
//! pivoting loop only ever deletes rows and columns of `A`, the envelope of every `A_FF` lies inside that
//! of `A`, so one ordering computed once per solve serves every pivot step (Fig. 5 shows the reordered
//! matrices).

use super::{OrderingKind, SymCsr};

/// Marker for a vertex not yet numbered (in `inv` while ordering).
const UNPLACED: usize = usize::MAX;

/// Reusable buffers; after the first call for a given size, [`order`](Self::order) performs no heap
/// allocation.
#[derive(Debug, Default)]
pub struct OrderingWorkspace {
    /// Off-diagonal degree of every vertex.
    degree: Vec<usize>,
    /// BFS visit stamps of the pseudo-peripheral search (`mark[v] == stamp` ⇔ reached by the current BFS).
    mark: Vec<usize>,
    /// Current BFS stamp.
    stamp: usize,
    /// BFS queue of the pseudo-peripheral search; holds the level structure, level by level.
    queue: Vec<usize>,
}

impl OrderingWorkspace {
    /// An empty workspace.
    pub fn new() -> Self {
        Self::default()
    }

    /// Writes the permutation `perm[new] = old` and its inverse `inv[old] = new` (both resized to `n`,
    /// reusing their capacity). [`OrderingKind::Natural`] gives the identity. Components are ordered one
    /// after another (each started at its own pseudo-peripheral vertex; components in order of their
    /// smallest vertex index); isolated vertices are components of size 1.
    pub fn order(&mut self, a: &SymCsr, kind: OrderingKind, perm: &mut Vec<usize>, inv: &mut Vec<usize>) {
        let n = a.n();
        perm.clear();
        inv.clear();
        if kind == OrderingKind::Natural {
            perm.extend(0..n);
            inv.extend(0..n);
            return;
        }
        perm.resize(n, 0);
        inv.resize(n, UNPLACED);
        self.prepare(a);

        let mut tail = 0;
        for s in 0..n {
            if inv[s] != UNPLACED {
                continue;
            }
            // `s` is the smallest vertex of a component not numbered yet.
            let root = self.pseudo_peripheral(a, s);
            let start = tail;
            perm[tail] = root;
            inv[root] = tail;
            tail += 1;
            let mut head = start;
            while head < tail {
                let v = perm[head];
                head += 1;
                let first = tail;
                for &u in a.row(v).0 {
                    if inv[u] == UNPLACED {
                        perm[tail] = u;
                        inv[u] = tail; // provisional: only marks `u` as numbered
                        tail += 1;
                    }
                }
                let degree = &self.degree;
                perm[first..tail].sort_unstable_by_key(|&u| (degree[u], u));
                for p in first..tail {
                    inv[perm[p]] = p;
                }
            }
            if kind == OrderingKind::ReverseCuthillMcKee {
                perm[start..tail].reverse();
                for p in start..tail {
                    inv[perm[p]] = p;
                }
            }
        }
        debug_assert_eq!(tail, n);
    }

    /// Sizes the buffers for `a` and computes the degrees.
    fn prepare(&mut self, a: &SymCsr) {
        let n = a.n();
        self.degree.clear();
        self.degree.extend((0..n).map(|i| a.row(i).0.iter().filter(|&&j| j != i).count()));
        self.mark.clear();
        self.mark.resize(n, 0);
        self.stamp = 0;
        self.queue.clear();
        self.queue.resize(n, 0);
    }

    /// George–Liu pseudo-peripheral vertex of the component of `s`.
    fn pseudo_peripheral(&mut self, a: &SymCsr, s: usize) -> usize {
        if self.degree[s] == 0 {
            return s;
        }
        let (mut ecc, mut lo, mut hi) = self.level_structure(a, s);
        loop {
            let degree = &self.degree;
            let x = self.queue[lo..hi]
                .iter()
                .copied()
                .min_by_key(|&u| (degree[u], u))
                .expect("a level is never empty");
            let (e, l, h) = self.level_structure(a, x);
            if e <= ecc {
                return x;
            }
            (ecc, lo, hi) = (e, l, h);
        }
    }

    /// Breadth-first level structure rooted at `root`, left in `queue[..]` level by level. Returns the
    /// eccentricity of `root` (the number of levels minus one) and the range of the last level in `queue`.
    fn level_structure(&mut self, a: &SymCsr, root: usize) -> (usize, usize, usize) {
        self.stamp += 1;
        let stamp = self.stamp;
        let (queue, mark) = (&mut self.queue, &mut self.mark);
        queue[0] = root;
        mark[root] = stamp;
        let (mut lo, mut hi, mut tail, mut ecc) = (0, 1, 1, 0);
        loop {
            for h in lo..hi {
                let v = queue[h];
                for &u in a.row(v).0 {
                    if mark[u] != stamp {
                        mark[u] = stamp;
                        queue[tail] = u;
                        tail += 1;
                    }
                }
            }
            if tail == hi {
                return (ecc, lo, hi);
            }
            (lo, hi, ecc) = (hi, tail, ecc + 1);
        }
    }
}

/// `max |i − j|` over stored off-diagonal entries (0 for a diagonal matrix).
pub fn bandwidth(a: &SymCsr) -> usize {
    let mut b = 0;
    for i in 0..a.n() {
        let c = a.row(i).0;
        if let (Some(&first), Some(&last)) = (c.first(), c.last()) {
            b = b.max(i.abs_diff(first)).max(i.abs_diff(last));
        }
    }
    b
}

/// The bandwidth of `P A Pᵀ` without building it (`inv[old] = new`).
pub fn bandwidth_permuted(a: &SymCsr, inv: &[usize]) -> usize {
    assert_eq!(inv.len(), a.n(), "permutation length");
    let mut b = 0;
    for i in 0..a.n() {
        let r = inv[i];
        for &j in a.row(i).0 {
            b = b.max(r.abs_diff(inv[j]));
        }
    }
    b
}

/// Envelope (profile) below the diagonal: `Σ_i (i − f_i)`, `f_i` the smallest column with a stored entry
/// in row `i` (`f_i ≤ i`).
pub fn envelope(a: &SymCsr) -> usize {
    (0..a.n()).map(|i| i - a.row(i).0.first().map_or(i, |&f| f.min(i))).sum()
}

/// The envelope of `P A Pᵀ` without building it (`inv[old] = new`).
pub fn envelope_permuted(a: &SymCsr, inv: &[usize]) -> usize {
    assert_eq!(inv.len(), a.n(), "permutation length");
    let mut e = 0;
    for i in 0..a.n() {
        let r = inv[i];
        let f = a.row(i).0.iter().map(|&j| inv[j]).fold(r, usize::min);
        e += r - f;
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::seq::SliceRandom;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    const KINDS: [OrderingKind; 3] =
        [OrderingKind::Natural, OrderingKind::CuthillMcKee, OrderingKind::ReverseCuthillMcKee];

    /// Diagonally dominant symmetric matrix with the given off-diagonal values (`(i, j, v)`, `i ≠ j`,
    /// each unordered pair once).
    fn from_edges(n: usize, edges: &[(usize, usize, f64)]) -> SymCsr {
        let mut diag = vec![1.0; n];
        let mut t = Vec::with_capacity(2 * edges.len() + n);
        for &(i, j, v) in edges {
            assert_ne!(i, j);
            t.push((i, j, v));
            t.push((j, i, v));
            diag[i] += v.abs();
            diag[j] += v.abs();
        }
        t.extend(diag.iter().enumerate().map(|(i, &d)| (i, i, d)));
        SymCsr::from_triplets(n, &t).unwrap()
    }

    fn unit_edges(edges: &[(usize, usize)]) -> Vec<(usize, usize, f64)> {
        edges.iter().map(|&(i, j)| (i, j, -1.0)).collect()
    }

    fn random_value(rng: &mut ChaCha8Rng) -> f64 {
        let v: f64 = rng.random_range(0.1..1.0);
        if rng.random_bool(0.5) { v } else { -v }
    }

    /// Random graph: Erdős–Rényi edges among the first `n − isolated` vertices (so it may be
    /// disconnected), then vertex labels shuffled so the isolated vertices land anywhere.
    fn random_graph(rng: &mut ChaCha8Rng, n: usize, p: f64, isolated: usize) -> SymCsr {
        let mut label: Vec<usize> = (0..n).collect();
        label.shuffle(rng);
        let mut edges = Vec::new();
        for i in 0..n.saturating_sub(isolated) {
            for j in i + 1..n.saturating_sub(isolated) {
                if rng.random_bool(p) {
                    edges.push((label[i], label[j], random_value(rng)));
                }
            }
        }
        from_edges(n, &edges)
    }

    /// `Q A Qᵀ` for a uniformly random permutation `Q`.
    fn shuffled(rng: &mut ChaCha8Rng, a: &SymCsr) -> SymCsr {
        let n = a.n();
        let mut perm: Vec<usize> = (0..n).collect();
        perm.shuffle(rng);
        let mut inv = vec![0; n];
        for (new, &old) in perm.iter().enumerate() {
            inv[old] = new;
        }
        let mut b = SymCsr::default();
        b.permuted_from(a, &perm, &inv);
        b
    }

    fn assert_inverse_permutations(perm: &[usize], inv: &[usize], n: usize) {
        assert_eq!(perm.len(), n);
        assert_eq!(inv.len(), n);
        let mut seen = vec![false; n];
        for (new, &old) in perm.iter().enumerate() {
            assert!(old < n && !seen[old], "perm is not a permutation: {perm:?}");
            seen[old] = true;
            assert_eq!(inv[old], new);
        }
    }

    /// Connected-component id of every vertex (ids are the smallest vertex of the component).
    fn components(a: &SymCsr) -> Vec<usize> {
        let n = a.n();
        let mut comp = vec![usize::MAX; n];
        let mut stack = Vec::new();
        for s in 0..n {
            if comp[s] != usize::MAX {
                continue;
            }
            comp[s] = s;
            stack.push(s);
            while let Some(v) = stack.pop() {
                for &u in a.row(v).0 {
                    if comp[u] == usize::MAX {
                        comp[u] = s;
                        stack.push(u);
                    }
                }
            }
        }
        comp
    }

    /// Orders `a` with every kind and checks the invariants that hold for any graph. Returns
    /// `(bandwidth, envelope)` for CM and RCM.
    fn check_all_kinds(ws: &mut OrderingWorkspace, a: &SymCsr) -> [(usize, usize); 2] {
        let n = a.n();
        let (mut perm, mut inv) = (Vec::new(), Vec::new());
        let comp = components(a);
        let mut out = [(0, 0); 2];
        for kind in KINDS {
            ws.order(a, kind, &mut perm, &mut inv);
            assert_inverse_permutations(&perm, &inv, n);
            match kind {
                OrderingKind::Natural => assert!(perm.iter().enumerate().all(|(k, &v)| k == v)),
                _ => {
                    // Components are contiguous and come in order of their smallest vertex.
                    let mut last = None;
                    for &v in &perm {
                        if last != Some(comp[v]) {
                            assert!(last.is_none_or(|l| l < comp[v]), "component split or out of order");
                            last = Some(comp[v]);
                        }
                    }
                    let k = (kind == OrderingKind::ReverseCuthillMcKee) as usize;
                    out[k] = (bandwidth_permuted(a, &inv), envelope_permuted(a, &inv));
                }
            }
        }
        // Reversal inside components keeps the bandwidth; Liu–Sherman: RCM never has a larger envelope.
        assert_eq!(out[0].0, out[1].0, "RCM changed the bandwidth");
        assert!(out[1].1 <= out[0].1, "RCM envelope {} > CM envelope {}", out[1].1, out[0].1);
        out
    }

    #[test]
    fn perm_and_inv_are_inverse_on_random_graphs() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x0bde_41e5);
        let mut ws = OrderingWorkspace::new();
        for _ in 0..300 {
            let n = rng.random_range(0..80usize);
            let p = rng.random_range(0.0..0.15);
            let isolated = rng.random_range(0..=n.min(5));
            let a = random_graph(&mut rng, n, p, isolated);
            check_all_kinds(&mut ws, &a);
        }
    }

    #[test]
    fn empty_and_diagonal_matrices() {
        let mut ws = OrderingWorkspace::new();
        let (mut perm, mut inv) = (vec![7; 3], vec![7; 3]);
        let empty = SymCsr::diagonal(&[]).unwrap();
        for kind in KINDS {
            ws.order(&empty, kind, &mut perm, &mut inv);
            assert!(perm.is_empty() && inv.is_empty());
        }
        let d = SymCsr::diagonal(&[1.0, 2.0, 3.0, 4.0]).unwrap();
        assert_eq!((bandwidth(&d), envelope(&d)), (0, 0));
        for kind in KINDS {
            // Every vertex is its own component, taken in index order: identity.
            ws.order(&d, kind, &mut perm, &mut inv);
            assert_eq!(perm, [0, 1, 2, 3]);
            assert_eq!(inv, [0, 1, 2, 3]);
        }
    }

    #[test]
    fn full_band_is_recovered() {
        let mut rng = ChaCha8Rng::seed_from_u64(0xba4d);
        let mut ws = OrderingWorkspace::new();
        let (mut perm, mut inv) = (Vec::new(), Vec::new());
        for k in 1..=10 {
            for _ in 0..8 {
                let n = rng.random_range(20..=300usize);
                let mut edges = Vec::new();
                for i in 0..n {
                    for j in i + 1..(i + k + 1).min(n) {
                        edges.push((i, j, random_value(&mut rng)));
                    }
                }
                let a = from_edges(n, &edges);
                assert_eq!(bandwidth(&a), k);
                let b = shuffled(&mut rng, &a);
                let [(bw_cm, env_cm), (bw_rcm, env_rcm)] = check_all_kinds(&mut ws, &b);
                assert!(bw_cm <= k && bw_rcm <= k, "k = {k}, n = {n}: CM {bw_cm}, RCM {bw_rcm}");
                // With n ≥ 2k some vertex has degree ≥ 2k − 1, which forces bandwidth ≥ k: exactly k.
                assert_eq!(bw_cm, k);
                // A full band has envelope k(k+1)/2 + (n − k − 1)k in its natural order; CM recovers it.
                assert!(env_rcm <= env_cm && env_cm <= envelope(&a), "k = {k}, n = {n}");
                ws.order(&b, OrderingKind::CuthillMcKee, &mut perm, &mut inv);
                assert_eq!(bandwidth_permuted(&b, &inv), bw_cm);
            }
        }
    }

    #[test]
    fn sparse_band_is_not_worse_than_shuffled() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x5ba4);
        let mut ws = OrderingWorkspace::new();
        let (mut within_k, mut total, mut worst_ratio) = (0, 0, 0.0f64);
        for k in 1..=10 {
            for _ in 0..8 {
                let n = rng.random_range(20..=300usize);
                let mut edges = Vec::new();
                for i in 0..n {
                    for j in i + 1..(i + k + 1).min(n) {
                        if rng.random_bool(0.5) {
                            edges.push((i, j, random_value(&mut rng)));
                        }
                    }
                }
                let a = from_edges(n, &edges);
                let b = shuffled(&mut rng, &a);
                let [(bw_cm, env_cm), (bw_rcm, env_rcm)] = check_all_kinds(&mut ws, &b);
                let (bw_in, env_in) = (bandwidth(&b), envelope(&b));
                assert!(bw_cm <= bw_in && bw_rcm <= bw_in, "k = {k}, n = {n}: {bw_cm} > {bw_in}");
                assert!(env_rcm <= env_in, "k = {k}, n = {n}: RCM envelope {env_rcm} > {env_in}");
                let band = bandwidth(&a);
                total += 1;
                within_k += (bw_cm <= band) as usize;
                worst_ratio = worst_ratio.max(bw_cm as f64 / band.max(1) as f64);
                if n >= 250 {
                    eprintln!(
                        "sparse band k = {k:2}, n = {n:3}: bandwidth original {band:2} shuffled {bw_in:3} \
                         CM/RCM {bw_cm:2}; envelope original {:5} shuffled {env_in:5} CM {env_cm:5} \
                         RCM {env_rcm:5}",
                        envelope(&a)
                    );
                }
            }
        }
        eprintln!(
            "sparse bands: CM bandwidth <= original band in {within_k}/{total} cases, \
             worst ratio {worst_ratio:.2}"
        );
    }

    #[test]
    fn scrambled_path_comes_back_as_path() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x9a7);
        let mut ws = OrderingWorkspace::new();
        let (mut perm, mut inv) = (Vec::new(), Vec::new());
        for n in [2, 3, 10, 57, 200] {
            let mut label: Vec<usize> = (0..n).collect();
            label.shuffle(&mut rng);
            let edges: Vec<_> = (0..n - 1).map(|i| (label[i], label[i + 1], -1.0)).collect();
            let a = from_edges(n, &edges);
            assert!(n < 10 || bandwidth(&a) > 1);
            for kind in [OrderingKind::CuthillMcKee, OrderingKind::ReverseCuthillMcKee] {
                ws.order(&a, kind, &mut perm, &mut inv);
                assert_eq!(bandwidth_permuted(&a, &inv), 1, "n = {n}, {kind:?}");
                assert_eq!(envelope_permuted(&a, &inv), n - 1);
                // It starts at an end of the path.
                assert!(perm[0] == label[0] || perm[0] == label[n - 1]);
            }
        }
    }

    #[test]
    fn star_exact() {
        // Centre 0, leaves 1..=5. George–Liu: BFS(0) has eccentricity 1; leaf 1 has eccentricity 2; leaf 2
        // (minimum degree, smallest index in the last level of leaf 1) has eccentricity 2 too: root 2.
        let a = from_edges(6, &unit_edges(&[(0, 1), (0, 2), (0, 3), (0, 4), (0, 5)]));
        assert_eq!((bandwidth(&a), envelope(&a)), (5, 15));
        let mut ws = OrderingWorkspace::new();
        let (mut perm, mut inv) = (Vec::new(), Vec::new());
        ws.order(&a, OrderingKind::CuthillMcKee, &mut perm, &mut inv);
        assert_eq!(perm, [2, 0, 1, 3, 4, 5]);
        assert_eq!((bandwidth_permuted(&a, &inv), envelope_permuted(&a, &inv)), (4, 11));
        ws.order(&a, OrderingKind::ReverseCuthillMcKee, &mut perm, &mut inv);
        assert_eq!(perm, [5, 4, 3, 1, 0, 2]);
        assert_eq!((bandwidth_permuted(&a, &inv), envelope_permuted(&a, &inv)), (4, 5));
    }

    #[test]
    fn grid_5x5_exact() {
        // Vertex r·5 + c. The root is the corner 24 (the far corner from vertex 0); the levels are the
        // anti-diagonals, neighbours taken by degree (corner 2 < edge 3 < interior 4), then index.
        let mut edges = Vec::new();
        for r in 0..5 {
            for c in 0..5 {
                let v = r * 5 + c;
                if c + 1 < 5 {
                    edges.push((v, v + 1));
                }
                if r + 1 < 5 {
                    edges.push((v, v + 5));
                }
            }
        }
        let a = from_edges(25, &unit_edges(&edges));
        assert_eq!(bandwidth(&a), 5);
        assert_eq!(envelope(&a), 4 + 20 * 5); // grid row 0: 1 per vertex after the first; later rows: 5 each
        let mut ws = OrderingWorkspace::new();
        let (mut perm, mut inv) = (Vec::new(), Vec::new());
        ws.order(&a, OrderingKind::CuthillMcKee, &mut perm, &mut inv);
        let expected =
            [24, 19, 23, 14, 18, 22, 9, 13, 17, 21, 4, 8, 12, 16, 20, 3, 7, 11, 15, 2, 6, 10, 1, 5, 0];
        assert_eq!(perm, expected);
        assert_eq!(bandwidth_permuted(&a, &inv), 5);
        let env_cm = envelope_permuted(&a, &inv);
        ws.order(&a, OrderingKind::ReverseCuthillMcKee, &mut perm, &mut inv);
        assert_eq!(bandwidth_permuted(&a, &inv), 5);
        let env_rcm = envelope_permuted(&a, &inv);
        assert!(env_rcm <= env_cm && env_cm < envelope(&a), "{env_rcm} {env_cm}");
    }

    #[test]
    fn disconnected_components_exact() {
        // Components by smallest vertex: {0}, {1, 3}, {2}, {4}, {5, 6}. Each pair is rooted at its larger
        // vertex (George–Liu returns the far end of the second BFS).
        let a = from_edges(7, &unit_edges(&[(5, 6), (1, 3)]));
        let mut ws = OrderingWorkspace::new();
        let (mut perm, mut inv) = (Vec::new(), Vec::new());
        ws.order(&a, OrderingKind::CuthillMcKee, &mut perm, &mut inv);
        assert_eq!(perm, [0, 3, 1, 2, 4, 6, 5]);
        ws.order(&a, OrderingKind::ReverseCuthillMcKee, &mut perm, &mut inv);
        assert_eq!(perm, [0, 1, 3, 2, 4, 5, 6]);
        assert_eq!(inv, [0, 1, 3, 2, 4, 5, 6]);
        assert_eq!((bandwidth_permuted(&a, &inv), envelope_permuted(&a, &inv)), (1, 2));
        assert_eq!((bandwidth(&a), envelope(&a)), (2, 3));
    }

    #[test]
    fn permuted_measures_agree_with_built_matrix() {
        let mut rng = ChaCha8Rng::seed_from_u64(0xface);
        let mut ws = OrderingWorkspace::new();
        let (mut perm, mut inv) = (Vec::new(), Vec::new());
        let mut built = SymCsr::default();
        for _ in 0..100 {
            let n = rng.random_range(1..60usize);
            let (p, isolated) = (rng.random_range(0.0..0.3), rng.random_range(0..=n.min(3)));
            let a = random_graph(&mut rng, n, p, isolated);
            for kind in KINDS {
                ws.order(&a, kind, &mut perm, &mut inv);
                built.permuted_from(&a, &perm, &inv);
                assert_eq!(bandwidth_permuted(&a, &inv), bandwidth(&built));
                assert_eq!(envelope_permuted(&a, &inv), envelope(&built));
            }
            // An arbitrary permutation too, not only the orderings' own.
            perm.shuffle(&mut rng);
            for (new, &old) in perm.iter().enumerate() {
                inv[old] = new;
            }
            built.permuted_from(&a, &perm, &inv);
            assert_eq!(bandwidth_permuted(&a, &inv), bandwidth(&built));
            assert_eq!(envelope_permuted(&a, &inv), envelope(&built));
        }
    }

    #[test]
    fn second_call_does_not_grow_buffers() {
        let mut rng = ChaCha8Rng::seed_from_u64(0xa110c);
        let a = random_graph(&mut rng, 500, 0.01, 20);
        let small = random_graph(&mut rng, 100, 0.05, 5);
        let mut ws = OrderingWorkspace::new();
        let (mut perm, mut inv) = (Vec::new(), Vec::new());
        let caps = |ws: &OrderingWorkspace, perm: &Vec<usize>, inv: &Vec<usize>| {
            [ws.degree.capacity(), ws.mark.capacity(), ws.queue.capacity(), perm.capacity(), inv.capacity()]
        };
        for kind in [OrderingKind::ReverseCuthillMcKee, OrderingKind::CuthillMcKee] {
            ws.order(&a, kind, &mut perm, &mut inv);
        }
        let before = caps(&ws, &perm, &inv);
        assert!(before.iter().all(|&c| c >= 500));
        for kind in KINDS {
            ws.order(&a, kind, &mut perm, &mut inv);
            assert_eq!(caps(&ws, &perm, &inv), before, "{kind:?}");
            ws.order(&small, kind, &mut perm, &mut inv);
            assert_eq!(caps(&ws, &perm, &inv), before, "{kind:?} (smaller matrix)");
        }
    }
}
