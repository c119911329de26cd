//! The bodies' shapes as `visualization_msgs/Marker`s (`/pivotsim/markers`): primitives, hulls and height fields.

use super::*;

pub(super) fn color(kind: msgs::BodyKind) -> ColorRGBA {
    match kind {
        msgs::BodyKind::Static => ColorRGBA { r: 0.55, g: 0.55, b: 0.55, a: 1.0 },
        msgs::BodyKind::Dynamic => ColorRGBA { r: 0.95, g: 0.55, b: 0.1, a: 1.0 },
        msgs::BodyKind::Kinematic => ColorRGBA { r: 0.2, g: 0.5, b: 0.95, a: 1.0 },
    }
}

/// Rotates `v` by the unit quaternion `q = [x, y, z, w]`.
pub(super) fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let (u, w) = ([q[0], q[1], q[2]], q[3]);
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    };
    let t = cross(u, v).map(|c| 2.0 * c);
    let ut = cross(u, t);
    [v[0] + w * t[0] + ut[0], v[1] + w * t[1] + ut[1], v[2] + w * t[2] + ut[2]]
}

/// Convex hulls with at most this many vertices are drawn as triangles (the faces are found by
/// brute force, O(n⁴)); larger ones as a sphere list of their vertices.
pub const HULL_TRIANGULATE_MAX: usize = 48;

/// Heightfields are drawn with at most this many samples along each side (strided).
pub const HEIGHTFIELD_MAX_SIDE: usize = 129;

pub(super) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(super) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Outward triangles of the convex hull of `v` (brute force; coplanar faces may overlap, which
/// draws the same surface).
pub fn hull_triangles(v: &[[f64; 3]]) -> Vec<[usize; 3]> {
    let size = v.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-9);
    let eps = 1e-9 * size * size * size;
    let mut out = Vec::new();
    for i in 0..v.len() {
        for j in i + 1..v.len() {
            for k in j + 1..v.len() {
                let (e1, e2) = (sub(v[j], v[i]), sub(v[k], v[i]));
                let n = [
                    e1[1] * e2[2] - e1[2] * e2[1],
                    e1[2] * e2[0] - e1[0] * e2[2],
                    e1[0] * e2[1] - e1[1] * e2[0],
                ];
                if dot(n, n).sqrt() <= eps / size {
                    continue;
                }
                let (mut above, mut below) = (false, false);
                for p in v {
                    let d = dot(n, sub(*p, v[i]));
                    above |= d > eps;
                    below |= d < -eps;
                    if above && below {
                        break;
                    }
                }
                if !above {
                    out.push([i, j, k]);
                } else if !below {
                    out.push([i, k, j]);
                }
            }
        }
    }
    out
}

pub(super) fn marker(
    body: &msgs::BodyInfo,
    id: i32,
    type_: i32,
    position: [f64; 3],
    orientation: [f64; 4],
) -> Marker {
    Marker {
        header: Header { stamp: Time::default(), frame_id: body.name.clone() },
        ns: body.name.clone(),
        id,
        type_,
        action: Marker::ADD,
        pose: Pose {
            position: Point::from_array(position),
            orientation: Quaternion::from_array(orientation),
        },
        scale: Vector3 { x: 1.0, y: 1.0, z: 1.0 },
        color: color(body.kind),
        frame_locked: true,
        ..Marker::default()
    }
}

pub(super) fn triangles(points: &mut Vec<Point>, v: &[[f64; 3]], tris: impl Iterator<Item = [usize; 3]>) {
    for t in tris {
        if t.iter().all(|&i| i < v.len()) {
            points.extend(t.iter().map(|&i| Point::from_array(v[i])));
        }
    }
}

/// The markers of one body: one or more per collider, in the body's frame (`frame_id` = body
/// name, `ns` = body name, id = 4 · collider index + part, frame-locked, stamp 0 = latest
/// transform). Shapes given by reference: meshes as `MESH_RESOURCE` with the reference as URI,
/// heightfields not drawn.
pub fn body_markers(body: &msgs::BodyInfo, out: &mut Vec<Marker>) {
    for (ci, c) in body.shapes().enumerate() {
        let id = 4 * ci as i32;
        let (p, q) = (c.position, c.orientation);
        match &c.shape {
            msgs::Shape::Ball { radius } => {
                let mut m = marker(body, id, Marker::SPHERE, p, q);
                m.scale = Vector3 { x: 2.0 * radius, y: 2.0 * radius, z: 2.0 * radius };
                out.push(m);
            }
            msgs::Shape::Box { half_extents: h } => {
                let mut m = marker(body, id, Marker::CUBE, p, q);
                m.scale = Vector3 { x: 2.0 * h[0], y: 2.0 * h[1], z: 2.0 * h[2] };
                out.push(m);
            }
            msgs::Shape::Cylinder { radius, half_height } | msgs::Shape::Capsule { radius, half_height } => {
                let mut m = marker(body, id, Marker::CYLINDER, p, q);
                m.scale = Vector3 { x: 2.0 * radius, y: 2.0 * radius, z: 2.0 * half_height };
                out.push(m);
                if matches!(c.shape, msgs::Shape::Capsule { .. }) {
                    for (part, s) in [(1, 1.0), (2, -1.0)] {
                        let off = rotate(q, [0.0, 0.0, s * half_height]);
                        let centre = [p[0] + off[0], p[1] + off[1], p[2] + off[2]];
                        let mut m = marker(body, id + part, Marker::SPHERE, centre, q);
                        m.scale = Vector3 { x: 2.0 * radius, y: 2.0 * radius, z: 2.0 * radius };
                        out.push(m);
                    }
                }
            }
            msgs::Shape::ConvexHull { vertices } => out.push(hull_marker(body, id, p, q, vertices)),
            msgs::Shape::Heightfield { rows, cols, extent, heights: msgs::HeightData::Inline(h) } => {
                let grid = (*rows as usize, *cols as usize, *extent);
                if let Some(m) = heightfield_marker(body, id, p, q, grid, h) {
                    out.push(m);
                }
            }
            msgs::Shape::Heightfield { heights: msgs::HeightData::Reference(_), .. } => {}
            msgs::Shape::Trimesh { mesh: msgs::MeshData::Inline { vertices, triangles: tris } } => {
                let mut m = marker(body, id, Marker::TRIANGLE_LIST, p, q);
                triangles(&mut m.points, vertices, tris.iter().map(|t| t.map(|i| i as usize)));
                out.push(m);
            }
            msgs::Shape::Trimesh { mesh: msgs::MeshData::Reference(uri) } => {
                let mut m = marker(body, id, Marker::MESH_RESOURCE, p, q);
                m.mesh_resource = uri.clone();
                out.push(m);
            }
        }
    }
}

/// A convex hull's marker: its faces when it has few vertices, else its vertices as dots.
pub(super) fn hull_marker(
    body: &msgs::BodyInfo,
    id: i32,
    p: [f64; 3],
    q: [f64; 4],
    vertices: &[[f64; 3]],
) -> Marker {
    if vertices.len() <= HULL_TRIANGULATE_MAX {
        let mut m = marker(body, id, Marker::TRIANGLE_LIST, p, q);
        triangles(&mut m.points, vertices, hull_triangles(vertices).into_iter());
        m
    } else {
        let mut m = marker(body, id, Marker::SPHERE_LIST, p, q);
        m.scale = Vector3 { x: 0.02, y: 0.02, z: 0.02 };
        m.points = vertices.iter().map(|v| Point::from_array(*v)).collect();
        m
    }
}

/// A heightfield's marker (`grid` = rows, cols, extent; `h` the heights): two triangles per cell
/// of the grid thinned to at most `HEIGHTFIELD_MAX_SIDE` samples a side (edges kept); `None`
/// unless the grid is at least 2 × 2 with one height per sample.
pub(super) fn heightfield_marker(
    body: &msgs::BodyInfo,
    id: i32,
    p: [f64; 3],
    q: [f64; 4],
    (rows, cols, extent): (usize, usize, [f64; 2]),
    h: &[f64],
) -> Option<Marker> {
    if rows < 2 || cols < 2 || h.len() != rows * cols {
        return None;
    }
    let step = |n: usize| (n - 1).div_ceil(HEIGHTFIELD_MAX_SIDE - 1).max(1);
    let idx = |n: usize, s: usize| {
        let mut v: Vec<usize> = (0..n).step_by(s).collect();
        if *v.last().unwrap_or(&0) != n - 1 {
            v.push(n - 1);
        }
        v
    };
    let (rs, cs) = (idx(rows, step(rows)), idx(cols, step(cols)));
    let at = |r: usize, c: usize| {
        [
            -extent[0] / 2.0 + c as f64 * extent[0] / (cols - 1) as f64,
            -extent[1] / 2.0 + r as f64 * extent[1] / (rows - 1) as f64,
            h[r * cols + c],
        ]
    };
    let mut m = marker(body, id, Marker::TRIANGLE_LIST, p, q);
    for w in rs.windows(2) {
        for u in cs.windows(2) {
            let (a, b, c, d) = (at(w[0], u[0]), at(w[0], u[1]), at(w[1], u[1]), at(w[1], u[0]));
            for v in [a, b, c, a, c, d] {
                m.points.push(Point::from_array(v));
            }
        }
    }
    Some(m)
}

/// `/pivotsim/markers`: a `DELETEALL` (when `clear`: the scene changed) followed by every body's
/// markers.
pub fn scene_markers(scene: &SceneInfo, clear: bool) -> MarkerArray {
    let mut markers = Vec::new();
    if clear {
        markers.push(Marker { action: Marker::DELETEALL, ..Marker::default() });
    }
    for b in &scene.description.bodies {
        body_markers(b, &mut markers);
    }
    MarkerArray { markers }
}
