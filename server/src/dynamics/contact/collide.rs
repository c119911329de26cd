//! Broad phase (all collider pairs whose AABBs, grown by the margin, overlap) and narrow phase
//! (parry's persistent contact manifolds, one cache per pair, reused from step to step).
//!
//! The broad phase is `O(n²)` in the number of colliders (fine for the scenes of this slice; a BVH
//! or sweep and prune is issue 5's next step). Pair caches keep parry's manifolds and workspace;
//! their points are cleared before each query, so that parry's contact tracking copies an empty list
//! (it clones the old points, an allocation per pair and step otherwise; we track contacts by
//! feature ids ourselves). A half-space against a ball or a polygonal-feature shape (cuboid,
//! capsule, cylinder, convex hull) is computed here, as parry's `contact_manifold_halfspace_pfm`
//! does (the support feature against the plane, one point per vertex within the margin) but without
//! its per-call reallocation: a persisting pair allocates nothing once warm. Caches of pairs that
//! separated are dropped.

use std::collections::{HashMap, HashSet};

use nalgebra::Vector3;
use parry3d_f64::math::{Pose, Vector};
use parry3d_f64::query::{
    ContactManifold, ContactManifoldsWorkspace, DefaultQueryDispatcher, PersistentQueryDispatcher,
};
use parry3d_f64::shape::{PackedFeatureId, PolygonalFeature, SharedShape};

use super::Collider;
use super::convert::{from_vec, to_pose};
use super::shape::PART_SHIFT;
use crate::dynamics::body::{BodyKind, RigidBody};
use crate::dynamics::joint::Joint;

/// One contact point of the current step (world frame).
#[derive(Debug, Clone, Copy, PartialEq)]
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

#[derive(Default)]
struct PairCache {
    manifolds: Vec<ContactManifold<(), ()>>,
    workspace: Option<ContactManifoldsWorkspace>,
    stamp: u64,
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
    /// Each collider's AABB (the union of its parts'), grown by half the margin.
    aabbs: Vec<(Vector, Vector)>,
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

impl NarrowPhase {
    /// Finds the contact points of all collider pairs at the current poses within `margin`.
    pub fn update(
        &mut self,
        colliders: &[Collider],
        pair_friction: &HashMap<(u32, u32), f64>,
        bodies: &[RigidBody],
        joints: &[Joint],
        connected: &HashSet<u32>,
        margin: f64,
    ) {
        self.stamp += 1;
        self.points.clear();
        self.poses.clear();
        self.first.clear();
        self.aabbs.clear();
        let grow = Vector::splat(0.5 * margin);
        for c in colliders {
            self.first.push(self.poses.len());
            let body = bodies[c.body.index()].pose();
            let (mut lo, mut hi) = (Vector::splat(f64::INFINITY), Vector::splat(f64::NEG_INFINITY));
            for part in &c.parts {
                let pose = to_pose(&(body * part.local));
                let aabb = part.parry.compute_aabb(&pose);
                lo = lo.min(aabb.mins);
                hi = hi.max(aabb.maxs);
                self.poses.push(pose);
            }
            self.aabbs.push((lo - grow, hi + grow));
        }
        let dispatcher = DefaultQueryDispatcher;
        for i in 0..colliders.len() {
            for j in i + 1..colliders.len() {
                let (ci, cj) = (&colliders[i], &colliders[j]);
                let (bi, bj) = (ci.body.index(), cj.body.index());
                let (ai, aj) = (&self.aabbs[i], &self.aabbs[j]);
                let overlap = ai.0.cmple(aj.1).all() && aj.0.cmple(ai.1).all();
                if bi == bj
                    || !overlap
                    || !ci.groups.interacts_with(cj.groups)
                    || (bodies[bi].kind() != BodyKind::Dynamic && bodies[bj].kind() != BodyKind::Dynamic)
                    || jointed(joints, connected, bi, bj)
                {
                    continue;
                }
                let mu = match pair_friction.get(&(i as u32, j as u32)) {
                    Some(&mu) => mu,
                    None => (ci.material.friction * cj.material.friction).sqrt(),
                };
                for (k, part_i) in ci.parts.iter().enumerate() {
                    for (l, part_j) in cj.parts.iter().enumerate() {
                        let (pi, pj) = (self.poses[self.first[i] + k], self.poses[self.first[j] + l]);
                        // A compound's part index tags the feature ids (0 for other shapes).
                        let tags = [(k as u32) << PART_SHIFT, (l as u32) << PART_SHIFT];
                        let pair = Pair { ca: i as u32, cb: j as u32, a: bi, b: bj, mu, tags };
                        let (si, sj) = (&part_i.parry, &part_j.parry);
                        if halfspace_points(&pair, si, &pi, sj, &pj, margin, &mut self.points) {
                            continue;
                        }
                        let key = (i as u32, j as u32, k as u32, l as u32);
                        let cache = self.pairs.entry(key).or_default();
                        cache.stamp = self.stamp;
                        let pos12 = pi.inv_mul(&pj);
                        for m in cache.manifolds.iter_mut() {
                            m.points.clear();
                        }
                        let res = dispatcher.contact_manifolds(
                            &pos12,
                            si.as_ref(),
                            sj.as_ref(),
                            margin,
                            &mut cache.manifolds,
                            &mut cache.workspace,
                        );
                        if res.is_err() {
                            continue; // unsupported pair (none among this slice's shapes)
                        }
                        for m in &cache.manifolds {
                            let n = from_vec(pi.rotation * m.local_n1);
                            for p in &m.points {
                                if p.dist > margin {
                                    continue;
                                }
                                self.points.push(ContactPoint {
                                    ca: i as u32,
                                    cb: j as u32,
                                    a: bi,
                                    b: bj,
                                    features: [p.fid1.0 | tags[0], p.fid2.0 | tags[1]],
                                    pa: from_vec(pi.transform_point(p.local_p1)),
                                    pb: from_vec(pj.transform_point(p.local_p2)),
                                    n,
                                    dist: p.dist,
                                    mu,
                                    t: [Vector3::zeros(); 2],
                                });
                            }
                        }
                    }
                }
            }
        }
        let stamp = self.stamp;
        self.pairs.retain(|_, c| c.stamp == stamp);
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
        out.push(ContactPoint {
            ca: pair.ca,
            cb: pair.cb,
            a: pair.a,
            b: pair.b,
            features,
            pa: from_vec(pa),
            pb: from_vec(pb),
            n: from_vec(normal),
            dist: gap,
            mu: pair.mu,
            t: [Vector3::zeros(); 2],
        });
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
