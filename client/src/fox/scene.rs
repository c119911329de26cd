//! The scene description as Foxglove's `foxglove.SceneUpdate`: one entity per body, drawn in the
//! body's own frame (`frame_id` = body name, frame-locked), so that the 3D panel moves it with the
//! body's transform and the entities need sending only once per scene.
//!
//! Shapes (`msgs/README.md`, scene description), each placed by its collider pose in the body
//! frame:
//!
//! | wire shape | primitives |
//! |---|---|
//! | `ball` | a sphere of diameter 2r |
//! | `box` | a cube of size 2·half_extents |
//! | `cylinder` | a cylinder (axis local z) of size (2r, 2r, 2·half_height) |
//! | `capsule` | that cylinder and a sphere at each end (±half_height along local z) |
//! | `convex_hull` | its outward faces as a triangle list (up to [`HULL_TRIANGULATE_MAX`] vertices, brute force); larger hulls as a sphere of 2 cm at each vertex |
//! | `heightfield` (inline) | a triangle list over the grid, thinned to at most [`HEIGHTFIELD_MAX_SIDE`] samples a side (edges kept), sample (r, c) at x = −e₀/2 + c·e₀/(cols−1), y = −e₁/2 + r·e₁/(rows−1) |
//! | `trimesh` (inline) | a triangle list: the vertices once, the triangles as indices |
//! | `trimesh` (reference) | a model primitive whose URL is the reference (Foxglove fetches it) |
//! | `heightfield` (reference) | not drawn (counted in [`SceneShapes::skipped`]) |
//!
//! Colours by body kind: static grey, dynamic orange, kinematic blue.

use foxglove::schemas::{
    ArrowPrimitive, Color, CubePrimitive, CylinderPrimitive, KeyValuePair, ModelPrimitive, Point3, Pose,
    Quaternion, SceneEntity, SceneEntityDeletion, SceneUpdate, SpherePrimitive, Timestamp,
    TriangleListPrimitive, Vector3, scene_entity_deletion,
};
use pivotsim_msgs as msgs;

/// Convex hulls with at most this many vertices are drawn as faces (found by brute force, O(n⁴)).
pub const HULL_TRIANGULATE_MAX: usize = 48;

/// Heightfields are drawn with at most this many samples along each side.
pub const HEIGHTFIELD_MAX_SIDE: usize = 129;

/// The update that draws a scene, with what it left out.
#[derive(Debug, Clone)]
pub struct SceneShapes {
    /// A deletion of every earlier entity of the topic (the previous scene), then one entity per
    /// body.
    pub update: SceneUpdate,
    /// Colliders not drawn (heightfields given by reference).
    pub skipped: usize,
}

fn color(kind: msgs::BodyKind) -> Color {
    match kind {
        msgs::BodyKind::Static => Color { r: 0.55, g: 0.55, b: 0.55, a: 1.0 },
        msgs::BodyKind::Dynamic => Color { r: 0.95, g: 0.55, b: 0.1, a: 1.0 },
        msgs::BodyKind::Kinematic => Color { r: 0.2, g: 0.5, b: 0.95, a: 1.0 },
    }
}

fn kind_name(kind: msgs::BodyKind) -> &'static str {
    match kind {
        msgs::BodyKind::Static => "static",
        msgs::BodyKind::Dynamic => "dynamic",
        msgs::BodyKind::Kinematic => "kinematic",
    }
}

fn vec3(v: [f64; 3]) -> Vector3 {
    Vector3 { x: v[0], y: v[1], z: v[2] }
}

fn point(v: [f64; 3]) -> Point3 {
    Point3 { x: v[0], y: v[1], z: v[2] }
}

/// A pose from a position and a quaternion `[x, y, z, w]`.
pub fn pose(p: [f64; 3], q: [f64; 4]) -> Pose {
    Pose { position: Some(vec3(p)), orientation: Some(Quaternion { x: q[0], y: q[1], z: q[2], w: q[3] }) }
}

/// `v` rotated by the unit quaternion `q = [x, y, z, w]` (v + 2w(u×v) + 2u×(u×v)).
fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    };
    let u = [q[0], q[1], q[2]];
    let t = cross(u, v).map(|c| 2.0 * c);
    let ut = cross(u, t);
    [0, 1, 2].map(|i| v[i] + q[3] * t[i] + ut[i])
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Outward faces of the convex hull of `v` as index triples: every triple whose plane has all
/// points on one side, oriented so that the points lie behind it. Coplanar faces may overlap,
/// which draws the same surface.
pub fn hull_faces(v: &[[f64; 3]]) -> Vec<[u32; 3]> {
    let scale = v.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-9);
    let tol = 1e-9 * scale;
    let mut faces = Vec::new();
    for i in 0..v.len() {
        for j in i + 1..v.len() {
            for k in j + 1..v.len() {
                let (a, b) = (sub(v[j], v[i]), sub(v[k], v[i]));
                let n = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
                let len = dot(n, n).sqrt();
                if len <= tol * scale {
                    continue;
                }
                let (mut front, mut back) = (false, false);
                for p in v {
                    let d = dot(n, sub(*p, v[i])) / len;
                    front |= d > tol;
                    back |= d < -tol;
                }
                let t = [i as u32, j as u32, k as u32];
                match (front, back) {
                    (false, _) => faces.push(t),
                    (true, false) => faces.push([t[0], t[2], t[1]]),
                    (true, true) => {}
                }
            }
        }
    }
    faces
}

/// A heightfield grid as points and triangle indices, thinned to at most
/// [`HEIGHTFIELD_MAX_SIDE`] samples a side; `None` unless it is at least 2 × 2 with one height per
/// sample.
pub fn heightfield_mesh(
    rows: usize,
    cols: usize,
    extent: [f64; 2],
    heights: &[f64],
) -> Option<(Vec<Point3>, Vec<u32>)> {
    if rows < 2 || cols < 2 || heights.len() != rows * cols {
        return None;
    }
    let samples = |n: usize| {
        let stride = (n - 1).div_ceil(HEIGHTFIELD_MAX_SIDE - 1).max(1);
        let mut v: Vec<usize> = (0..n).step_by(stride).collect();
        if v.last() != Some(&(n - 1)) {
            v.push(n - 1);
        }
        v
    };
    let (rs, cs) = (samples(rows), samples(cols));
    let mut points = Vec::with_capacity(rs.len() * cs.len());
    for &r in &rs {
        for &c in &cs {
            points.push(Point3 {
                x: -extent[0] / 2.0 + c as f64 * extent[0] / (cols - 1) as f64,
                y: -extent[1] / 2.0 + r as f64 * extent[1] / (rows - 1) as f64,
                z: heights[r * cols + c],
            });
        }
    }
    let w = cs.len() as u32;
    let mut indices = Vec::with_capacity(6 * (rs.len() - 1) * (cs.len() - 1));
    for r in 0..rs.len() as u32 - 1 {
        for c in 0..w - 1 {
            let (a, b, d, e) = (r * w + c, r * w + c + 1, (r + 1) * w + c + 1, (r + 1) * w + c);
            indices.extend([a, b, d, a, d, e]);
        }
    }
    Some((points, indices))
}

/// Adds the primitives of one collider to `e`; `false` when it is not drawn.
fn collider(e: &mut SceneEntity, c: &msgs::Collider, color: Color) -> bool {
    let (p, q) = (c.position, c.orientation);
    let sphere = |centre: [f64; 3], r: f64| SpherePrimitive {
        pose: Some(pose(centre, q)),
        size: Some(vec3([2.0 * r; 3])),
        color: Some(color),
    };
    match &c.shape {
        msgs::Shape::Ball { radius } => e.spheres.push(sphere(p, *radius)),
        msgs::Shape::Box { half_extents: h } => e.cubes.push(CubePrimitive {
            pose: Some(pose(p, q)),
            size: Some(vec3(h.map(|x| 2.0 * x))),
            color: Some(color),
        }),
        msgs::Shape::Cylinder { radius, half_height } | msgs::Shape::Capsule { radius, half_height } => {
            e.cylinders.push(CylinderPrimitive {
                pose: Some(pose(p, q)),
                size: Some(vec3([2.0 * radius, 2.0 * radius, 2.0 * half_height])),
                bottom_scale: 1.0,
                top_scale: 1.0,
                color: Some(color),
            });
            if matches!(c.shape, msgs::Shape::Capsule { .. }) {
                for s in [1.0, -1.0] {
                    let off = rotate(q, [0.0, 0.0, s * half_height]);
                    e.spheres.push(sphere([p[0] + off[0], p[1] + off[1], p[2] + off[2]], *radius));
                }
            }
        }
        msgs::Shape::ConvexHull { vertices } if vertices.len() <= HULL_TRIANGULATE_MAX => {
            e.triangles.push(TriangleListPrimitive {
                pose: Some(pose(p, q)),
                points: vertices.iter().map(|v| point(*v)).collect(),
                color: Some(color),
                colors: Vec::new(),
                indices: hull_faces(vertices).into_iter().flatten().collect(),
            });
        }
        msgs::Shape::ConvexHull { vertices } => {
            for v in vertices {
                let at = rotate(q, *v);
                e.spheres.push(sphere([p[0] + at[0], p[1] + at[1], p[2] + at[2]], 0.01));
            }
        }
        msgs::Shape::Heightfield { rows, cols, extent, heights: msgs::HeightData::Inline(h) } => {
            let Some((points, indices)) = heightfield_mesh(*rows as usize, *cols as usize, *extent, h) else {
                return false;
            };
            e.triangles.push(TriangleListPrimitive {
                pose: Some(pose(p, q)),
                points,
                color: Some(color),
                colors: Vec::new(),
                indices,
            });
        }
        msgs::Shape::Heightfield { heights: msgs::HeightData::Reference(_), .. } => return false,
        msgs::Shape::Trimesh { mesh: msgs::MeshData::Inline { vertices, triangles } } => {
            let n = vertices.len() as u32;
            e.triangles.push(TriangleListPrimitive {
                pose: Some(pose(p, q)),
                points: vertices.iter().map(|v| point(*v)).collect(),
                color: Some(color),
                colors: Vec::new(),
                indices: triangles.iter().filter(|t| t.iter().all(|&i| i < n)).flatten().copied().collect(),
            });
        }
        msgs::Shape::Trimesh { mesh: msgs::MeshData::Reference(url) } => e.models.push(ModelPrimitive {
            pose: Some(pose(p, q)),
            scale: Some(vec3([1.0; 3])),
            color: Some(color),
            override_color: false,
            url: url.clone(),
            media_type: String::new(),
            data: Default::default(),
        }),
    }
    true
}

/// One entity per body of `scene` (id = frame = body name, frame-locked, no lifetime), stamped
/// `stamp`, after a deletion of all earlier entities on the topic.
pub fn scene_update(scene: &msgs::SceneDescription, stamp: Timestamp) -> SceneShapes {
    let mut skipped = 0;
    let entities = scene
        .bodies
        .iter()
        .map(|b| {
            let mut e = SceneEntity {
                timestamp: Some(stamp),
                frame_id: b.name.clone(),
                id: b.name.clone(),
                frame_locked: true,
                metadata: vec![
                    KeyValuePair { key: "id".into(), value: b.id.to_string() },
                    KeyValuePair { key: "kind".into(), value: kind_name(b.kind).into() },
                    KeyValuePair { key: "mass".into(), value: b.mass.to_string() },
                ],
                ..SceneEntity::default()
            };
            for c in b.shapes() {
                if !collider(&mut e, c, color(b.kind)) {
                    skipped += 1;
                }
            }
            e
        })
        .collect();
    let clear = SceneEntityDeletion {
        timestamp: Some(stamp),
        r#type: scene_entity_deletion::Type::All as i32,
        id: String::new(),
    };
    SceneShapes { update: SceneUpdate { deletions: vec![clear], entities }, skipped }
}

/// Entity id of the contact-force arrows (the `/pivotsim/contact_forces` scene update).
pub const CONTACTS_ENTITY: &str = "contacts";

/// The quaternion `[x, y, z, w]` that turns +x onto the unit vector `d` (Foxglove's arrows point
/// along +x of their pose).
fn x_onto(d: [f64; 3]) -> [f64; 4] {
    // q ∝ (x × d, 1 + x·d); opposite vectors: a half turn about z.
    let q = [0.0, -d[2], d[1], 1.0 + d[0]];
    let n = dot([q[0], q[1], q[2]], [q[0], q[1], q[2]]) + q[3] * q[3];
    if n < 1e-12 { [0.0, 0.0, 1.0, 0.0] } else { q.map(|c| c / n.sqrt()) }
}

/// Colour of a sticking contact's arrow: green, as the ROS 2 bridge's `/pivotsim/contact_markers`.
pub const STICK_COLOR: Color = Color { r: 0.1, g: 0.8, b: 0.1, a: 1.0 };
/// Colour of a slipping contact's arrow: orange, as the ROS 2 bridge's.
pub const SLIP_COLOR: Color = Color { r: 1.0, g: 0.45, b: 0.0, a: 1.0 };

/// Contact forces as arrows in the world frame, one entity [`CONTACTS_ENTITY`] replaced at each
/// call: an arrow per `(point, force, colour)` (m, N), tail at the point, along the force,
/// `|f| · metres_per_newton` long; forces below 1e-9 N are left out. The live view and `record`
/// publish it on `/pivotsim/contact_forces` for every signals frame
/// ([`super::signals::contact_forces`]: sticking points [`STICK_COLOR`], slipping ones
/// [`SLIP_COLOR`]).
pub fn force_arrows(
    forces: impl IntoIterator<Item = ([f64; 3], [f64; 3], Color)>,
    metres_per_newton: f64,
    stamp: Timestamp,
) -> SceneUpdate {
    let arrows = forces
        .into_iter()
        .filter_map(|(p, f, color)| {
            let n = dot(f, f).sqrt();
            (n > 1e-9 && n.is_finite()).then(|| {
                let len = n * metres_per_newton;
                ArrowPrimitive {
                    pose: Some(pose(p, x_onto(f.map(|c| c / n)))),
                    shaft_length: 0.8 * len,
                    shaft_diameter: 0.02,
                    head_length: 0.2 * len,
                    head_diameter: 0.05,
                    color: Some(color),
                }
            })
        })
        .collect();
    SceneUpdate {
        deletions: Vec::new(),
        entities: vec![SceneEntity {
            timestamp: Some(stamp),
            frame_id: super::WORLD_FRAME.to_string(),
            id: CONTACTS_ENTITY.to_string(),
            arrows,
            ..SceneEntity::default()
        }],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn body(id: u32, name: &str, shape: msgs::Shape) -> msgs::BodyInfo {
        msgs::BodyInfo {
            id,
            name: name.into(),
            kind: msgs::BodyKind::Dynamic,
            mass: 1.0,
            visuals: Vec::new(),
            colliders: vec![msgs::Collider {
                shape,
                position: [0.0, 0.0, 1.0],
                orientation: [0.0, 0.0, 0.0, 1.0],
            }],
        }
    }

    #[test]
    fn each_shape_gives_its_primitives() {
        let tetra = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let scene = msgs::SceneDescription {
            bodies: vec![
                body(0, "ball", msgs::Shape::Ball { radius: 0.5 }),
                body(1, "box", msgs::Shape::Box { half_extents: [1.0, 2.0, 3.0] }),
                body(2, "cyl", msgs::Shape::Cylinder { radius: 0.3, half_height: 0.5 }),
                body(3, "cap", msgs::Shape::Capsule { radius: 0.1, half_height: 0.2 }),
                body(4, "hull", msgs::Shape::ConvexHull { vertices: tetra }),
                body(
                    5,
                    "hf",
                    msgs::Shape::Heightfield {
                        rows: 3,
                        cols: 4,
                        extent: [3.0, 2.0],
                        heights: msgs::HeightData::Inline((0..12).map(f64::from).collect()),
                    },
                ),
                body(
                    6,
                    "hfref",
                    msgs::Shape::Heightfield {
                        rows: 3,
                        cols: 4,
                        extent: [3.0, 2.0],
                        heights: msgs::HeightData::Reference("t.f64".into()),
                    },
                ),
            ],
            ..Default::default()
        };
        let s = scene_update(&scene, Timestamp::new(1, 0));
        let e = &s.update.entities;
        assert_eq!(e.len(), 7);
        assert_eq!(s.skipped, 1);
        assert_eq!(s.update.deletions.len(), 1);
        assert!(e.iter().all(|e| e.frame_locked && e.frame_id == e.id));
        assert_eq!(e[0].spheres[0].size.unwrap().x, 1.0);
        assert_eq!(e[1].cubes[0].size.unwrap().z, 6.0);
        assert_eq!(e[2].cylinders[0].size.unwrap().z, 1.0);
        assert_eq!((e[3].cylinders.len(), e[3].spheres.len()), (1, 2));
        let ends: Vec<f64> = e[3].spheres.iter().map(|s| s.pose.unwrap().position.unwrap().z).collect();
        assert_eq!(ends, [1.2, 0.8]);
        assert_eq!(e[4].triangles[0].indices.len(), 4 * 3, "a tetrahedron has 4 faces");
        let hf = &e[5].triangles[0];
        assert_eq!(hf.points.len(), 12);
        assert_eq!(hf.indices.len(), 2 * 3 * 6);
        assert_eq!((hf.points[0].x, hf.points[0].y, hf.points[11].z), (-1.5, -1.0, 11.0));
        assert!(e[6].triangles.is_empty());
    }

    /// The tips of a capsule (`msgs` convention: axis z, `half_height` of the straight part) in
    /// the world, for a body at `pose` (position, quaternion).
    fn capsule_tips(c: &msgs::Collider, position: [f64; 3], q: [f64; 4]) -> [[f64; 3]; 2] {
        let msgs::Shape::Capsule { radius, half_height } = c.shape else { panic!("{:?}", c.shape) };
        [1.0, -1.0].map(|s| {
            let local = rotate(c.orientation, [0.0, 0.0, s * (half_height + radius)]);
            let body = [0, 1, 2].map(|i| c.position[i] + local[i]);
            let w = rotate(q, body);
            [0, 1, 2].map(|i| position[i] + w[i])
        })
    }

    /// Every dynamic body of every shipped scene is drawn: its entity has at least one primitive
    /// (the crane's and the offshore crane's rope segments through their visual-only capsules).
    /// And a rope is drawn unbroken: after 2 s of its scene, the nearer tips of two segments joined
    /// by a ball joint are within 1 cm of each other in the world (from the engine's pose frame).
    #[test]
    fn every_dynamic_body_of_every_shipped_scene_is_drawn() {
        use std::time::{Duration, Instant};
        for b in pivotsim_server::scene::BUILTIN {
            let world = msgs::WorldName::new(format!("drawn-{}", b.name)).unwrap();
            let mut e = pivotsim_server::serve::Engine::new(b.name, world, Duration::from_secs(60)).unwrap();
            let t0 = Instant::now();
            for i in 0..120 {
                assert!(e.tick(t0 + Duration::from_secs_f64(i as f64 / 60.0)), "{}", b.name);
            }
            let d = msgs::SceneDescription::decode(e.description()).unwrap();
            let s = scene_update(&d, Timestamp::new(0, 0));
            assert_eq!(s.skipped, 0, "{}", b.name);
            let mut dynamic = 0;
            for (body, ent) in d.bodies.iter().zip(&s.update.entities) {
                assert_eq!(body.name, ent.id);
                if body.kind != msgs::BodyKind::Dynamic {
                    continue;
                }
                dynamic += 1;
                let primitives = ent.spheres.len()
                    + ent.cubes.len()
                    + ent.cylinders.len()
                    + ent.triangles.len()
                    + ent.models.len()
                    + ent.lines.len();
                assert!(primitives > 0, "{}: body {} is not drawn", b.name, body.name);
            }
            assert!(dynamic > 0, "{}", b.name);
            // Ropes: the segments with visuals, joined by ball joints.
            let poses = msgs::PoseFrame::decode(e.pose_frame()).unwrap();
            let pose_of = |id: u32| {
                let p = poses.bodies.iter().find(|p| p.id == id).unwrap();
                (p.position, p.orientation)
            };
            let mut joined = 0;
            for j in d.joints.iter().filter(|j| j.kind == msgs::JointKind::Ball) {
                let Some(parent) = j.parent else { continue };
                let (Some(a), Some(c)) = (d.body(parent), d.body(j.child)) else { continue };
                let (Some(va), Some(vc)) = (a.visuals.first(), c.visuals.first()) else { continue };
                let (pa, qa) = pose_of(a.id);
                let (pc, qc) = pose_of(c.id);
                let gap = capsule_tips(va, pa, qa)
                    .iter()
                    .flat_map(|x| capsule_tips(vc, pc, qc).map(|y| dot(sub(*x, y), sub(*x, y)).sqrt()))
                    .fold(f64::INFINITY, f64::min);
                assert!(gap < 0.01, "{}: joint {} gap {gap} m", b.name, j.name);
                joined += 1;
            }
            // Segment `i` of cable `c` is the body `c/i`: each cable has one pair fewer than segments.
            let drawn: Vec<&str> =
                d.bodies.iter().filter(|b| !b.visuals.is_empty()).map(|b| b.name.as_str()).collect();
            let mut cables: Vec<&str> =
                drawn.iter().filter_map(|n| n.rsplit_once('/').map(|(c, _)| c)).collect();
            cables.dedup();
            let segments = drawn.len();
            assert_eq!(joined + cables.len(), segments, "{}: every pair of neighbouring segments", b.name);
            println!(
                "{}: {dynamic} dynamic bodies drawn, {segments} rope segments, {joined} joints checked",
                b.name
            );
        }
    }

    #[test]
    fn force_arrows_point_along_the_force() {
        let u = force_arrows(
            [
                ([1.0, 0.0, 0.0], [0.0, 0.0, 100.0], STICK_COLOR),
                ([0.0; 3], [-5.0, 0.0, 0.0], SLIP_COLOR),
                ([0.0; 3], [0.0; 3], STICK_COLOR),
            ],
            0.01,
            Timestamp::new(0, 0),
        );
        let a = &u.entities[0].arrows;
        assert_eq!(a.len(), 2, "the zero force is left out");
        assert_eq!((a[0].color, a[1].color), (Some(STICK_COLOR), Some(SLIP_COLOR)));
        assert!((a[0].shaft_length + a[0].head_length - 1.0).abs() < 1e-12);
        for (arrow, dir) in a.iter().zip([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]]) {
            let q = arrow.pose.unwrap().orientation.unwrap();
            let x = rotate([q.x, q.y, q.z, q.w], [1.0, 0.0, 0.0]);
            assert!((0..3).all(|i| (x[i] - dir[i]).abs() < 1e-12), "{x:?} vs {dir:?}");
        }
    }

    #[test]
    fn hull_faces_point_outward() {
        let cube: Vec<[f64; 3]> =
            (0..8).map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64]).collect();
        let faces = hull_faces(&cube);
        assert!(faces.len() >= 12);
        for f in faces {
            let [a, b, c] = f.map(|i| cube[i as usize]);
            let (u, v) = (sub(b, a), sub(c, a));
            let n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
            assert!(dot(n, sub(a, [0.5; 3])) > 0.0, "face {f:?} points inward");
        }
    }

    #[test]
    fn large_heightfields_are_thinned_with_edges_kept() {
        let n = 300;
        let (points, indices) = heightfield_mesh(n, n, [10.0, 10.0], &vec![0.0; n * n]).unwrap();
        let side = (points.len() as f64).sqrt() as usize;
        assert!(side <= HEIGHTFIELD_MAX_SIDE + 1, "{side}");
        assert_eq!(points.last().unwrap().x, 5.0);
        assert_eq!(indices.len(), 6 * (side - 1) * (side - 1));
        assert!(heightfield_mesh(1, 4, [1.0, 1.0], &[0.0; 4]).is_none());
    }
}
