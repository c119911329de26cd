//! Broad phase (sweep and prune over the colliders' AABBs grown by the margin, `broad.rs`) and
//! narrow phase (parry's persistent contact manifolds, one cache per pair of parts, reused from
//! step to step).
//!
//! Pair caches keep parry's manifolds and workspace; their points are cleared before each query,
//! so that parry's contact tracking copies an empty list (it clones the old points, an allocation
//! per pair and step otherwise; we track contacts by feature ids ourselves). A half-space against a
//! ball or a polygonal-feature shape (cuboid, capsule, cylinder, convex hull) is computed here, as
//! parry's `contact_manifold_halfspace_pfm` does (the support feature against the plane, one point
//! per vertex within the margin) but without its per-call reallocation: a persisting pair
//! allocates nothing once warm. Two convex parts that parry meets with `contact_manifold_pfm_pfm`
//! (GJK, EPA in penetration, support features clipped) are computed here with the same steps but a
//! reused EPA (parry builds a new one, allocating, at every overlapping call). Caches of pairs that
//! separated are dropped.
//!
//! **Terrain** (height field, triangle mesh) against a convex part is also computed here, with
//! parry's pieces but not its composite-shape driver: the triangles under the convex part's AABB
//! (in the terrain frame, grown by the margin; the height field's cells under it, the mesh's BVH
//! leaves) each get a convex–triangle manifold (ball and cuboid: parry's dedicated queries; the
//! other shapes: [`pfm_manifold`] with the reused EPA), with the triangle's pseudo-normals as
//! normal constraints so that internal edges do not catch, kept per triangle in a list sorted by
//! triangle index. Parry's driver for height fields moves its manifold vector out and rebuilds it
//! every call (an allocation per step for a resting body); this list keeps its manifolds in place
//! and recycles those of triangles left behind, so a persisting contact allocates nothing. The
//! triangle index tags the terrain side's feature ids (bits 2–29); a point that several triangles
//! produce (a shared edge or vertex, same normal) is kept once, from the lowest triangle.

use std::collections::{HashMap, HashSet};

use nalgebra::Vector3;
use parry3d_f64::bounding_volume::BoundingVolume;
use parry3d_f64::math::{Pose, Vector};
use parry3d_f64::query::details::{NormalConstraints, NormalConstraintsPair};
use parry3d_f64::query::epa::EPA;
use parry3d_f64::query::gjk::{self, CsoPoint, GJKResult, VoronoiSimplex};
use parry3d_f64::query::{
    ContactManifold, ContactManifoldsWorkspace, DefaultQueryDispatcher, PersistentQueryDispatcher,
    TrackedContact,
};
use parry3d_f64::shape::{
    HeightField, PackedFeatureId, PolygonalFeature, PolygonalFeatureMap, Shape as ParryShape, ShapeType,
    SharedShape, TriMesh, Triangle, TrianglePseudoNormals,
};

use super::Collider;
use super::broad::{Bounds, SweepAndPrune};
use super::convert::{from_vec, to_pose};
use super::shape::{PART_SHIFT, TRIANGLE_SHIFT};
use crate::dynamics::body::{BodyKind, RigidBody};
use crate::dynamics::joint::Joint;

/// One contact point of the current step (world frame).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub(crate) struct ContactPoint {
    /// Colliders A and B.
    pub ca: u32,
    pub cb: u32,
    /// Their bodies (world indices).
    pub a: usize,
    pub b: usize,
    /// parry feature ids of the point on A and on B.
    pub features: [u32; 2],
    /// Points on A and on B.
    pub pa: Vector3<f64>,
    pub pb: Vector3<f64>,
    /// Unit normal from A to B.
    pub n: Vector3<f64>,
    /// Signed gap (negative in penetration).
    pub dist: f64,
    /// Friction coefficient of the pair.
    pub mu: f64,
    /// Tangent basis (set by the row builder).
    pub t: [Vector3<f64>; 2],
}

type Manifold = ContactManifold<(), ()>;

#[derive(Default)]
struct PairCache {
    manifolds: Vec<Manifold>,
    workspace: Option<ContactManifoldsWorkspace>,
    /// Terrain pairs: the triangle of each manifold (ascending) and whether this step met it.
    triangles: Vec<(u32, bool)>,
    /// Terrain pairs: manifolds of triangles left behind, for reuse.
    spare: Vec<Manifold>,
    stamp: u64,
}

/// What of the narrow phase carries from one update to the next: the pairs' manifolds (parry seeds
/// a query with the manifold's last normal, so they shape the next points to the last bit) and the
/// points of the last update (reported between steps). Pairs sorted by key, so that equal states
/// encode to equal bytes. The broad phase's sorted order is not part of it: its pairs come out
/// sorted whatever order it kept.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub(crate) struct NarrowState {
    stamp: u64,
    pairs: Vec<((u32, u32, u32, u32), PairState)>,
    points: Vec<ContactPoint>,
}

/// A [`PairCache`] without its composite-shape workspace (never used: terrains are queried triangle
/// by triangle here, compounds part by part).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
struct PairState {
    manifolds: Vec<Manifold>,
    triangles: Vec<(u32, bool)>,
    spare: Vec<Manifold>,
    stamp: u64,
}

/// A pair whose parry workspace holds state the snapshot cannot carry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct UnsupportedPair(pub (u32, u32));

impl NarrowPhase {
    /// The state that carries over (see [`NarrowState`]).
    pub(crate) fn state(&self) -> Result<NarrowState, UnsupportedPair> {
        let mut pairs = Vec::with_capacity(self.pairs.len());
        for (&key, c) in &self.pairs {
            if c.workspace.is_some() {
                return Err(UnsupportedPair((key.0, key.1)));
            }
            let state = PairState {
                manifolds: c.manifolds.clone(),
                triangles: c.triangles.clone(),
                spare: c.spare.clone(),
                stamp: c.stamp,
            };
            pairs.push((key, state));
        }
        pairs.sort_unstable_by_key(|p| p.0);
        Ok(NarrowState { stamp: self.stamp, pairs, points: self.points.clone() })
    }

    /// Takes over `state`: the caches and points as they were when it was taken.
    pub(crate) fn restore(&mut self, state: &NarrowState) {
        self.stamp = state.stamp;
        self.pairs.clear();
        for (key, p) in &state.pairs {
            let cache = PairCache {
                manifolds: p.manifolds.clone(),
                workspace: None,
                triangles: p.triangles.clone(),
                spare: p.spare.clone(),
                stamp: p.stamp,
            };
            self.pairs.insert(*key, cache);
        }
        self.points.clone_from(&state.points);
    }

    /// Colliders a restored state may name (all of a pair's indices below it).
    pub(crate) fn state_colliders(state: &NarrowState) -> usize {
        let pairs = state.pairs.iter().map(|(k, _)| k.0.max(k.1) as usize + 1);
        let points = state.points.iter().map(|p| p.ca.max(p.cb) as usize + 1);
        pairs.chain(points).max().unwrap_or(0)
    }
}

impl std::fmt::Debug for NarrowPhase {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NarrowPhase")
            .field("pairs", &self.pairs.len())
            .field("points", &self.points.len())
            .finish()
    }
}

/// Broad and narrow phase buffers.
#[derive(Default)]
pub(crate) struct NarrowPhase {
    /// World poses of all colliders' parts, collider after collider.
    poses: Vec<Pose>,
    /// Index in `poses` of each collider's first part.
    first: Vec<usize>,
    /// Each collider's AABB (the union of its parts'), grown by half the margin; `None` if
    /// unbounded (half-space).
    bounds: Vec<Bounds>,
    /// Each collider's sweep bound of the step, `h (|v| + |ω| R)` (m): no point of it moves
    /// farther (`R` the farthest corner of its AABB from the body's centre).
    sweep: Vec<f64>,
    broad: SweepAndPrune,
    /// EPA buffers of the convex–triangle queries, reused (penetrating resting contacts need EPA).
    epa: EPA,
    /// Caches per (collider A, collider B, part of A, part of B).
    pairs: HashMap<(u32, u32, u32, u32), PairCache>,
    stamp: u64,
    /// The contact points of the last update.
    pub points: Vec<ContactPoint>,
}

/// Whether a joint that does not opt in to collisions (`connected`: the ids of those that do) joins
/// bodies `a` and `b`.
fn jointed(joints: &[Joint], connected: &HashSet<u32>, a: usize, b: usize) -> bool {
    joints.iter().any(|j| {
        let (ja, jb) = (j.body_a.index(), j.body_b.map(|x| x.index()));
        ((ja == a && jb == Some(b)) || (ja == b && jb == Some(a))) && !connected.contains(&j.id.0)
    })
}

/// Whether colliders `ci` and `cj` may touch: different bodies, interacting groups, one body
/// dynamic, and no joint between them that keeps them apart.
fn may_touch(
    ci: &Collider,
    cj: &Collider,
    bodies: &[RigidBody],
    joints: &[Joint],
    connected: &HashSet<u32>,
) -> bool {
    let (bi, bj) = (ci.body.index(), cj.body.index());
    !(bi == bj
        || !ci.groups.interacts_with(cj.groups)
        || (bodies[bi].kind() != BodyKind::Dynamic && bodies[bj].kind() != BodyKind::Dynamic)
        || jointed(joints, connected, bi, bj))
}

impl NarrowPhase {
    /// Finds the contact points of all collider pairs at the current poses within `margin`, and
    /// within the swept margin of a pair that may close faster (module doc of `contact/mod.rs`,
    /// "Swept margin"; `h` the step).
    #[allow(clippy::too_many_arguments)]
    pub fn update(
        &mut self,
        colliders: &[Collider],
        mu_of: impl Fn(usize, usize) -> f64,
        bodies: &[RigidBody],
        joints: &[Joint],
        connected: &HashSet<u32>,
        margin: f64,
        h: f64,
    ) {
        self.stamp += 1;
        self.points.clear();
        self.place_parts(colliders, bodies, margin, h);
        self.broad.update(&self.bounds);
        for p in 0..self.broad.pairs().len() {
            let (i, j) = self.broad.pairs()[p];
            let (i, j) = (i as usize, j as usize);
            if may_touch(&colliders[i], &colliders[j], bodies, joints, connected) {
                let swept = self.sweep[i] + self.sweep[j];
                let first = self.points.len();
                self.collider_pair_points(colliders, i, j, mu_of(i, j), margin.max(swept));
                if swept > margin {
                    keep_closing_points(&mut self.points, first, bodies, margin, h);
                }
            }
        }
        let stamp = self.stamp;
        self.pairs.retain(|_, c| c.stamp == stamp);
    }

    /// The world pose of every collider part, each collider's sweep bound and its AABB grown by
    /// half the margin or by its sweep, whichever is larger.
    fn place_parts(&mut self, colliders: &[Collider], bodies: &[RigidBody], margin: f64, h: f64) {
        self.poses.clear();
        self.first.clear();
        self.bounds.clear();
        self.sweep.clear();
        for c in colliders {
            self.first.push(self.poses.len());
            let b = &bodies[c.body.index()];
            let body = b.pose();
            let (mut lo, mut hi) = (Vector::splat(f64::INFINITY), Vector::splat(f64::NEG_INFINITY));
            for part in &c.parts {
                let pose = to_pose(&(body * part.local));
                let aabb = part.parry.compute_aabb(&pose);
                lo = lo.min(aabb.mins);
                hi = hi.max(aabb.maxs);
                self.poses.push(pose);
            }
            let bounded = !c.shape.is_unbounded();
            let sweep = match bounded && b.kind() != BodyKind::Static {
                true => {
                    let (lo, hi) = (from_vec(lo) - b.position, from_vec(hi) - b.position);
                    let reach = lo.abs().sup(&hi.abs()).norm();
                    let s = h * (b.linvel.norm() + b.angvel.norm() * reach);
                    if s.is_finite() { s } else { 0.0 }
                }
                false => 0.0,
            };
            self.sweep.push(sweep);
            let grow = Vector::splat((0.5 * margin).max(sweep));
            self.bounds.push(bounded.then(|| (from_vec(lo - grow), from_vec(hi + grow))));
        }
    }

    /// Contact points of colliders `i` and `j` (friction `mu`), part by part.
    fn collider_pair_points(&mut self, colliders: &[Collider], i: usize, j: usize, mu: f64, margin: f64) {
        let (ci, cj) = (&colliders[i], &colliders[j]);
        let (bi, bj) = (ci.body.index(), cj.body.index());
        for (k, part_i) in ci.parts.iter().enumerate() {
            for (l, part_j) in cj.parts.iter().enumerate() {
                let (pi, pj) = (self.poses[self.first[i] + k], self.poses[self.first[j] + l]);
                // A compound's part index tags the feature ids (0 for other shapes).
                let tags = [(k as u32) << PART_SHIFT, (l as u32) << PART_SHIFT];
                let pair = Pair { ca: i as u32, cb: j as u32, a: bi, b: bj, mu, tags };
                let key = (i as u32, j as u32, k as u32, l as u32);
                self.part_pair_points(&pair, key, (&part_i.parry, &pi), (&part_j.parry, &pj), margin);
            }
        }
    }

    /// Contact points of one pair of parts: a half-space, a terrain, or the cached manifolds of two
    /// convex parts.
    fn part_pair_points(
        &mut self,
        pair: &Pair,
        key: (u32, u32, u32, u32),
        (si, pi): (&SharedShape, &Pose),
        (sj, pj): (&SharedShape, &Pose),
        margin: f64,
    ) {
        if halfspace_points(pair, si, pi, sj, pj, margin, &mut self.points) {
            return;
        }
        let cache = self.pairs.entry(key).or_default();
        cache.stamp = self.stamp;
        let parts = [(si.as_ref(), pi), (sj.as_ref(), pj)];
        if terrain_points(pair, parts, margin, cache, &mut self.epa, &mut self.points) {
            return;
        }
        if !cache.convex_manifolds(&pi.inv_mul(pj), si.as_ref(), sj.as_ref(), margin, &mut self.epa) {
            return; // unsupported pair (none among this slice's shapes)
        }
        let first = self.points.len();
        for m in &cache.manifolds {
            push_manifold_points(pair, [pi, pj], m, margin, first, &mut self.points, |p| {
                [p.fid1.0 | pair.tags[0], p.fid2.0 | pair.tags[1]]
            });
        }
    }
}

/// Of the points from `first` on (one pair's, found within its swept margin), keeps those within
/// `margin` and those the pair would pass within the step: gap `≤ h · v_c`, `v_c` the closing
/// speed `−n · (v_B(p) − v_A(p))` at the point. A point the bodies pass by, move away from or
/// reach only in a later step (then within the margin) is dropped, so a fast part gets no
/// speculative rows beyond those that keep it from penetrating.
fn keep_closing_points(
    points: &mut Vec<ContactPoint>,
    first: usize,
    bodies: &[RigidBody],
    margin: f64,
    h: f64,
) {
    let mut kept = first;
    for k in first..points.len() {
        let p = points[k];
        let keep = p.dist <= margin || {
            let (ba, bb) = (&bodies[p.a], &bodies[p.b]);
            let va = ba.linvel + ba.angvel.cross(&(p.pa - ba.position));
            let vb = bb.linvel + bb.angvel.cross(&(p.pb - bb.position));
            p.dist <= h * (-p.n.dot(&(vb - va)))
        };
        if keep {
            points[kept] = p;
            kept += 1;
        }
    }
    points.truncate(kept);
}

impl PairCache {
    /// The manifolds of two convex parts at relative pose `pos12`; `false` for a pair parry does
    /// not support.
    fn convex_manifolds(
        &mut self,
        pos12: &Pose,
        si: &dyn ParryShape,
        sj: &dyn ParryShape,
        margin: f64,
        epa: &mut EPA,
    ) -> bool {
        for m in self.manifolds.iter_mut() {
            m.points.clear();
        }
        if let Some((f1, f2)) = pfm_pair(si, sj) {
            // What parry's dispatcher does for these shapes, with the reused EPA.
            if self.manifolds.is_empty() {
                self.manifolds.push(Manifold::new());
            }
            let m = &mut self.manifolds[0];
            pfm_manifold(pos12, f1, None, f2, None, margin, ClosestPoint::Always, epa, m);
            true
        } else {
            DefaultQueryDispatcher
                .contact_manifolds(pos12, si, sj, margin, &mut self.manifolds, &mut self.workspace)
                .is_ok()
        }
    }

    /// The manifold slot of terrain triangle `id`, marked met this step; a triangle not yet in the
    /// list gets a slot (a spare manifold when there is one) in index order.
    fn triangle_slot(&mut self, id: u32) -> usize {
        let slot = match self.triangles.binary_search_by_key(&id, |t| t.0) {
            Ok(slot) => slot,
            Err(slot) => {
                self.triangles.insert(slot, (id, false));
                self.manifolds.insert(slot, self.spare.pop().unwrap_or_default());
                slot
            }
        };
        self.triangles[slot].1 = true;
        slot
    }

    /// Moves the manifolds of the triangles this step did not meet to the spares.
    fn drop_unmet_triangles(&mut self) {
        for k in (0..self.triangles.len()).rev() {
            if !self.triangles[k].1 {
                self.triangles.remove(k);
                let mut m = self.manifolds.remove(k);
                m.points.clear();
                self.spare.push(m);
            }
        }
    }
}

/// Adds the points of manifold `m` (parts A and B at the poses `pi`, `pj`) within `margin` to
/// `out`, with the feature ids `features` gives; a point already in `out[first..]` (same points,
/// same normal) is left out: parry's manifolds of a round shape against a polygonal feature can
/// repeat a point (cylinder or hull against a capsule), and a point on an edge or vertex shared by
/// terrain triangles comes from each of them (the lowest triangle's is kept). Two identical rows
/// make A singular and the variants' round-off differ.
fn push_manifold_points(
    pair: &Pair,
    [pi, pj]: [&Pose; 2],
    m: &Manifold,
    margin: f64,
    first: usize,
    out: &mut Vec<ContactPoint>,
    features: impl Fn(&TrackedContact<()>) -> [u32; 2],
) {
    let n = from_vec(pi.rotation * m.local_n1);
    for p in &m.points {
        if p.dist > margin {
            continue;
        }
        let (pa, pb) = (from_vec(pi.transform_point(p.local_p1)), from_vec(pj.transform_point(p.local_p2)));
        let duplicate = out[first..].iter().any(|q| {
            (q.pa - pa).norm_squared() <= SAME_POINT_SQ
                && (q.pb - pb).norm_squared() <= SAME_POINT_SQ
                && q.n.dot(&n) >= SAME_NORMAL_COS
        });
        if duplicate {
            continue;
        }
        out.push(pair.point(features(p), pa, pb, n, p.dist));
    }
}

/// The identity of a collider pair.
struct Pair {
    ca: u32,
    cb: u32,
    a: usize,
    b: usize,
    mu: f64,
    /// Part tags of A's and B's feature ids.
    tags: [u32; 2],
}

impl Pair {
    /// A contact point of this pair.
    fn point(
        &self,
        features: [u32; 2],
        pa: Vector3<f64>,
        pb: Vector3<f64>,
        n: Vector3<f64>,
        dist: f64,
    ) -> ContactPoint {
        ContactPoint {
            ca: self.ca,
            cb: self.cb,
            a: self.a,
            b: self.b,
            features,
            pa,
            pb,
            n,
            dist,
            mu: self.mu,
            t: [Vector3::zeros(); 2],
        }
    }
}

/// Contact points of a half-space against a ball or a polygonal-feature shape (either order);
/// `false` if the pair is not of that kind.
fn halfspace_points(
    pair: &Pair,
    ci: &SharedShape,
    pi: &Pose,
    cj: &SharedShape,
    pj: &Pose,
    margin: f64,
    out: &mut Vec<ContactPoint>,
) -> bool {
    let (hs, ph, other, po, flipped) = match (ci.as_halfspace(), cj.as_halfspace()) {
        (Some(h), None) => (h, pi, cj, pj, false),
        (None, Some(h)) => (h, pj, ci, pi, true),
        _ => return false,
    };
    let n = ph.rotation * hs.normal;
    let face = PackedFeatureId::face(0).0;
    let mut push = |p_other: Vector, p_plane: Vector, gap: f64, fid: u32| {
        let (pa, pb, normal, [fa, fb]) =
            if flipped { (p_other, p_plane, -n, [fid, face]) } else { (p_plane, p_other, n, [face, fid]) };
        let features = [fa | pair.tags[0], fb | pair.tags[1]];
        out.push(pair.point(features, from_vec(pa), from_vec(pb), from_vec(normal), gap));
    };
    if let Some(ball) = other.as_ball() {
        let c = po.translation;
        let d = n.dot(c - ph.translation);
        let gap = d - ball.radius;
        if gap <= margin {
            push(c - n * ball.radius, c - n * d, gap, face);
        }
        return true;
    }
    let Some((pfm, border)) = other.as_polygonal_feature_map() else { return false };
    let mut feature = PolygonalFeature::default();
    pfm.local_support_feature(po.rotation.inverse() * -n, &mut feature);
    for k in 0..feature.num_vertices {
        let v = po.transform_point(feature.vertices[k]);
        let d = n.dot(v - ph.translation);
        let gap = d - border;
        if gap <= margin {
            push(v - n * border, v - n * d, gap, feature.vids[k].0);
        }
    }
    true
}

/// A terrain shape.
#[derive(Clone, Copy)]
enum Terrain<'a> {
    Field(&'a HeightField),
    Mesh(&'a TriMesh),
}

impl<'a> Terrain<'a> {
    fn of(shape: &'a dyn ParryShape) -> Option<Self> {
        shape.as_heightfield().map(Terrain::Field).or_else(|| shape.as_trimesh().map(Terrain::Mesh))
    }

    /// Calls `f` with the index, the triangle and its pseudo-normals of every triangle that may meet
    /// the local AABB `aabb`.
    fn for_each_triangle(
        self,
        aabb: &parry3d_f64::bounding_volume::Aabb,
        f: &mut impl FnMut(u32, &Triangle, Option<TrianglePseudoNormals>),
    ) {
        match self {
            Terrain::Field(hf) => hf.map_elements_in_local_aabb(aabb, &mut |id, tri| {
                f(id, tri, hf.triangle_normal_constraints(id))
            }),
            Terrain::Mesh(mesh) => {
                let n = mesh.num_triangles() as u32;
                // The BVH may return padding indices past the last triangle (parry's SIMD lanes).
                for id in mesh.bvh().intersect_aabb(aabb).filter(|&id| id < n) {
                    f(id, &mesh.triangle(id), mesh.triangle_normal_constraints(id));
                }
            }
        }
    }
}

/// The feature id of a triangle's feature tagged with the triangle index.
fn triangle_feature(fid: u32, triangle: u32) -> u32 {
    const KIND: u32 = 0b11 << 30;
    (fid & KIND) | (triangle << TRIANGLE_SHIFT) | (fid & ((1 << TRIANGLE_SHIFT) - 1))
}

/// Contact points of a terrain part against a convex part (either order), triangle by triangle
/// (module doc); `false` if neither part is terrain.
fn terrain_points(
    pair: &Pair,
    [(si, pi), (sj, pj)]: [(&dyn ParryShape, &Pose); 2],
    margin: f64,
    cache: &mut PairCache,
    epa: &mut EPA,
    out: &mut Vec<ContactPoint>,
) -> bool {
    let (terrain, pt, other, po, flipped) = match (Terrain::of(si), Terrain::of(sj)) {
        (Some(t), None) => (t, pi, sj, pj, false),
        (None, Some(t)) => (t, pj, si, pi, true),
        _ => return false,
    };
    let pos12 = pi.inv_mul(pj);
    let aabb = other.compute_aabb(&pt.inv_mul(po)).loosened(margin);
    let other_pfm = match (other.as_ball(), other.as_cuboid()) {
        (None, None) => other.as_polygonal_feature_map(),
        _ => None,
    };
    for t in cache.triangles.iter_mut() {
        t.1 = false;
    }
    terrain.for_each_triangle(&aabb, &mut |id, tri, normals| {
        let slot = cache.triangle_slot(id);
        let manifold = &mut cache.manifolds[slot];
        manifold.points.clear();
        let normals = normals.as_ref().map(|n| n as &dyn NormalConstraints);
        let convex = Convex { shape: other, pfm: other_pfm, flipped };
        triangle_manifold(&pos12, convex, tri, normals, margin, epa, manifold);
    });
    cache.drop_unmet_triangles();
    let first = out.len();
    for (&(triangle, _), m) in cache.triangles.iter().zip(cache.manifolds.iter()) {
        push_manifold_points(pair, [pi, pj], m, margin, first, out, |p| {
            if flipped {
                [p.fid1.0 | pair.tags[0], triangle_feature(p.fid2.0, triangle)]
            } else {
                [triangle_feature(p.fid1.0, triangle), p.fid2.0 | pair.tags[1]]
            }
        });
    }
    true
}

/// The convex part of a terrain pair: its shape, its polygonal-feature map unless it is a ball or
/// a cuboid, and whether it is part A (the terrain then B).
#[derive(Clone, Copy)]
struct Convex<'a> {
    shape: &'a dyn ParryShape,
    pfm: Option<(&'a dyn PolygonalFeatureMap, f64)>,
    flipped: bool,
}

/// The manifold of terrain triangle `tri` (pseudo-normals `normals`) against the convex part, at
/// relative pose `pos12` of A and B.
fn triangle_manifold(
    pos12: &Pose,
    convex: Convex<'_>,
    tri: &Triangle,
    normals: Option<&dyn NormalConstraints>,
    margin: f64,
    epa: &mut EPA,
    manifold: &mut Manifold,
) {
    let tri_pfm = (tri as &dyn PolygonalFeatureMap, 0.0);
    let other = convex.shape;
    let closest = ClosestPoint::IfNoneClipped;
    match convex.pfm {
        // Polygonal-feature shapes other than the cuboid go through GJK/EPA with a reused EPA.
        Some(pfm) if convex.flipped => {
            pfm_manifold(pos12, pfm, None, tri_pfm, normals, margin, closest, epa, manifold)
        }
        Some(pfm) => pfm_manifold(pos12, tri_pfm, normals, pfm, None, margin, closest, epa, manifold),
        // Ball and cuboid: parry's dedicated queries (no EPA). Unsupported pairs (none among
        // the convex shapes) leave the manifold empty.
        None if convex.flipped => {
            let _ = DefaultQueryDispatcher
                .contact_manifold_convex_convex(pos12, other, tri, None, normals, margin, manifold);
        }
        None => {
            let _ = DefaultQueryDispatcher
                .contact_manifold_convex_convex(pos12, tri, other, normals, None, margin, manifold);
        }
    }
}

/// Squared distance (m²) under which two terrain contact points are one (1 nm).
const SAME_POINT_SQ: f64 = 1e-18;
/// Cosine above which two terrain contact normals are one (≈ 1.4e-5 rad).
const SAME_NORMAL_COS: f64 = 1.0 - 1e-10;

/// Whether [`pfm_manifold`] adds the closest pair of points (unknown features) to the clipped ones.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ClosestPoint {
    /// Always (parry's `contact_manifold_pfm_pfm`; two convex colliders).
    Always,
    /// Only if clipping found no point (terrain triangles).
    IfNoneClipped,
}

/// The two polygonal-feature maps (with their round borders) of a pair of convex shapes that
/// parry's dispatcher sends to `contact_manifold_pfm_pfm` (neither a ball, nor two cuboids, nor two
/// capsules, none a half-space or composite); `None` for the other pairs.
#[allow(clippy::type_complexity)]
fn pfm_pair<'a>(
    s1: &'a dyn ParryShape,
    s2: &'a dyn ParryShape,
) -> Option<((&'a dyn PolygonalFeatureMap, f64), (&'a dyn PolygonalFeatureMap, f64))> {
    let (t1, t2) = (s1.shape_type(), s2.shape_type());
    let special = t1 == ShapeType::Ball
        || t2 == ShapeType::Ball
        || t1 == ShapeType::HalfSpace
        || t2 == ShapeType::HalfSpace
        || (t1 == ShapeType::Cuboid && t2 == ShapeType::Cuboid)
        || (t1 == ShapeType::Capsule && t2 == ShapeType::Capsule)
        || s1.as_composite_shape().is_some()
        || s2.as_composite_shape().is_some();
    if special {
        return None;
    }
    Some((s1.as_polygonal_feature_map()?, s2.as_polygonal_feature_map()?))
}

/// The contact manifold of two polygonal-feature shapes (two convex parts, or one and a terrain
/// triangle):
/// GJK for the closest points within `prediction` (EPA in penetration, with the caller's reused
/// EPA: parry's `contact_manifold_pfm_pfm` makes a new one, i.e. allocates, every time the shapes
/// overlap, at every step of a resting contact), the normal projected into the normal cones
/// (`nc1`, `nc2`: the triangle's pseudo-normals), then the support features of both shapes along
/// it clipped against each other (parry's `PolygonalFeature::contacts`), round borders added.
#[allow(clippy::too_many_arguments)]
fn pfm_manifold(
    pos12: &Pose,
    (pfm1, border1): (&dyn PolygonalFeatureMap, f64),
    nc1: Option<&dyn NormalConstraints>,
    (pfm2, border2): (&dyn PolygonalFeatureMap, f64),
    nc2: Option<&dyn NormalConstraints>,
    prediction: f64,
    closest: ClosestPoint,
    epa: &mut EPA,
    manifold: &mut Manifold,
) {
    manifold.points.clear();
    // Start GJK from the last normal (coherence), else along the centres.
    let dir0 =
        manifold.local_n1.try_normalize().or_else(|| pos12.translation.try_normalize()).unwrap_or(Vector::X);
    let mut simplex = VoronoiSimplex::new();
    simplex.reset(CsoPoint::from_shapes(pos12, pfm1, pfm2, dir0));
    let reach = prediction + border1 + border2;
    let found = match gjk::closest_points(pos12, pfm1, pfm2, reach, true, &mut simplex) {
        GJKResult::Intersection => epa
            .closest_points(pos12, pfm1, pfm2, &simplex)
            .map_or(GJKResult::NoIntersection(Vector::X), |(p1, p2, n)| GJKResult::ClosestPoints(p1, p2, n)),
        other => other,
    };
    let (p1, p2_1, dir) = match found {
        GJKResult::ClosestPoints(p1, p2_1, dir) => (p1, p2_1, dir),
        GJKResult::NoIntersection(dir) => {
            manifold.local_n1 = dir;
            return;
        }
        _ => {
            manifold.local_n1 = Vector::ZERO;
            return;
        }
    };
    // Signed distance of the cores (before the borders) along the unconstrained normal.
    let depth = (p2_1 - p1).dot(dir);
    let (mut n1, mut n2) = (dir, pos12.rotation.inverse() * -dir);
    if !(nc1, nc2).project_local_normals(pos12, &mut n1, &mut n2) {
        return; // the normal leaves the triangle's cone: no contact from this triangle
    }
    let (mut f1, mut f2) = (PolygonalFeature::default(), PolygonalFeature::default());
    pfm1.local_support_feature_toward(n1, p1, &mut f1);
    pfm2.local_support_feature_toward(n2, pos12.inverse_transform_point(p2_1), &mut f2);
    PolygonalFeature::contacts(pos12, &pos12.inverse(), n1, n2, &f1, &f2, manifold, false);
    if (closest == ClosestPoint::Always || manifold.points.is_empty()) && n1 == dir {
        // The closest pair itself (for terrain only if clipping found nothing, e.g. against a
        // curved feature's approximation: it duplicates a clipped point or adds an interior one).
        let p2 = pos12.inverse_transform_point(p2_1);
        let unknown = PackedFeatureId::UNKNOWN;
        manifold.points.push(TrackedContact::new(p1, p2, unknown, unknown, depth));
    }
    if nc1.is_some() || nc2.is_some() {
        // A projected normal can make clipped points far deeper than the true penetration (the
        // other shape extends far along it): drop those.
        manifold.points.retain(|p| depth >= 0.0 || p.dist >= 0.0 || p.dist >= 5.0 * depth);
    }
    for p in manifold.points.iter_mut() {
        p.local_p1 += n1 * border1;
        p.local_p2 += n2 * border2;
        p.dist -= border1 + border2;
    }
    manifold.local_n1 = n1;
    manifold.local_n2 = n2;
}
