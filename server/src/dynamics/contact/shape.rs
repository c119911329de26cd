//! Collision shapes in the dynamics' conventions (nalgebra, SI, body-frame, axial shapes along the
//! body `z` axis like [`capsule_inertia`](crate::dynamics::capsule_inertia) and
//! [`cylinder_inertia`](crate::dynamics::cylinder_inertia), terrain with `z` up), their validation,
//! and their parry counterpart.

use nalgebra::{Isometry3, Matrix3, Rotation3, UnitQuaternion, Vector3};
use parry3d_f64::shape::{HeightFieldFlags, SharedShape, TriMeshFlags};
use parry3d_f64::utils::Array2;

use super::ContactError;
use super::convert::to_vec;

/// A collision shape, in its collider's frame.
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    /// A ball of this radius about the origin.
    Ball {
        /// Radius (m).
        radius: f64,
    },
    /// A box with these half extents along x, y, z.
    Cuboid {
        /// Half extents (m).
        half_extents: Vector3<f64>,
    },
    /// A capsule along `z`: the segment `z ∈ [−half_length, half_length]` swept by a ball.
    Capsule {
        /// Radius (m).
        radius: f64,
        /// Half length of the axis segment (m); 0 gives a ball.
        half_length: f64,
    },
    /// A solid cylinder along `z`.
    Cylinder {
        /// Radius (m).
        radius: f64,
        /// Half length (m).
        half_length: f64,
    },
    /// The convex hull of these points (at least 4, not coplanar).
    ConvexHull {
        /// Vertices (m).
        points: Vec<Vector3<f64>>,
    },
    /// The half-space `n · x ≤ 0` (flat ground); only on static or kinematic bodies.
    HalfSpace {
        /// Outward unit normal (collider frame).
        normal: Vector3<f64>,
    },
    /// Several bounded shapes, each at its pose in the collider frame (1 to 1024 parts; no
    /// half-space, terrain or compound among them). Their union collides as one collider.
    Compound {
        /// The parts: pose in the collider frame and shape.
        parts: Vec<(Isometry3<f64>, Shape)>,
    },
    /// Terrain: a grid of heights over the collider's `x`–`y` plane, centred on its origin, `z` up
    /// (the convention of the scene format's heightfield). Sample `(r, c)` (row `r < rows` along
    /// `y`, column `c < cols` along `x`) is the vertex
    ///
    /// ```text
    /// x = (c / (cols − 1) − ½) · scale.x,   y = (r / (rows − 1) − ½) · scale.y,   z = heights[r · cols + c] · scale.z
    /// ```
    ///
    /// and each grid cell is two triangles. At least 2 rows and 2 columns, finite heights, scales
    /// finite and > 0. Only on **static** bodies ([`ContactError::TerrainNotStatic`]); its surface
    /// is one-sided (contacts come from above, `+z`), internal edges do not catch sliding bodies
    /// (parry's pseudo-normals). [`terrain`](crate::dynamics::terrain) builds common ones.
    HeightField {
        /// Number of rows (samples along `y`), ≥ 2.
        rows: usize,
        /// Number of columns (samples along `x`), ≥ 2.
        cols: usize,
        /// `rows · cols` heights, row-major (`heights[r · cols + c]`), multiplied by `scale.z`.
        heights: Vec<f64>,
        /// Extent along `x` and `y` (m) and the height factor along `z`.
        scale: Vector3<f64>,
    },
    /// Terrain: a triangle mesh in the collider frame. Triangles are counter-clockwise seen from
    /// the side that collides (`(b − a) × (c − a)` is the outward normal); the surface is
    /// one-sided and internal edges do not catch sliding bodies (parry's pseudo-normals; the
    /// vertices of shared edges are merged). At least one triangle, finite vertices, indices in
    /// range, no degenerate (zero-area) triangle. Only on **static** bodies
    /// ([`ContactError::TerrainNotStatic`]).
    TriMesh {
        /// Vertices (m).
        vertices: Vec<Vector3<f64>>,
        /// Triangles as vertex indices.
        indices: Vec<[u32; 3]>,
    },
}

/// Most parts of a [`Shape::Compound`] (the part index takes bits 20–29 of a contact's feature ids).
pub(crate) const MAX_PARTS: usize = 1024;

/// Bit of a contact feature id where the part index of a compound starts.
pub(crate) const PART_SHIFT: u32 = 20;

/// Most triangles of a terrain shape (the triangle index takes bits 2–29 of a contact's feature
/// ids on the terrain side).
pub const MAX_TERRAIN_TRIANGLES: usize = 1 << 28;

/// Bit of a terrain contact's feature id where the triangle index starts (bits 0–1 keep the
/// triangle-local vertex, edge or face index, bits 30–31 parry's feature kind).
pub(crate) const TRIANGLE_SHIFT: u32 = 2;

/// One parry shape of a collider at its pose in the body frame (one per part of a compound).
#[derive(Debug, Clone)]
pub(crate) struct ColliderPart {
    /// Pose of parry's shape frame in the body frame (offsets ∘ shape rotation).
    pub local: Isometry3<f64>,
    pub parry: SharedShape,
}

/// Whether an isometry has a finite translation and a unit rotation quaternion.
pub(crate) fn valid_isometry(iso: &Isometry3<f64>) -> bool {
    let qn = iso.rotation.into_inner().norm();
    iso.translation.vector.iter().all(|c| c.is_finite()) && qn.is_finite() && (qn - 1.0).abs() <= 1e-6
}

impl Shape {
    /// Short name of the kind.
    pub fn kind_name(&self) -> &'static str {
        match self {
            Shape::Ball { .. } => "ball",
            Shape::Cuboid { .. } => "cuboid",
            Shape::Capsule { .. } => "capsule",
            Shape::Cylinder { .. } => "cylinder",
            Shape::ConvexHull { .. } => "convex hull",
            Shape::HalfSpace { .. } => "half-space",
            Shape::Compound { .. } => "compound",
            Shape::HeightField { .. } => "height field",
            Shape::TriMesh { .. } => "triangle mesh",
        }
    }

    /// Whether the shape has infinite extent (needs a non-dynamic body).
    pub fn is_unbounded(&self) -> bool {
        matches!(self, Shape::HalfSpace { .. })
    }

    /// Whether the shape is terrain (height field or triangle mesh: static bodies only).
    pub fn is_terrain(&self) -> bool {
        matches!(self, Shape::HeightField { .. } | Shape::TriMesh { .. })
    }

    /// Validates the shape and builds its parts for a collider at `offset` in the body frame (one
    /// part unless a compound).
    pub(crate) fn build_parts(
        &self,
        collider: &str,
        offset: &Isometry3<f64>,
    ) -> Result<Vec<ColliderPart>, ContactError> {
        let bad = |reason| ContactError::InvalidCompound { collider: collider.to_string(), reason };
        let Shape::Compound { parts } = self else {
            let (parry, rot) = self.build(collider)?;
            return Ok(vec![ColliderPart { local: parry_offset(offset, &rot), parry }]);
        };
        if parts.is_empty() || parts.len() > MAX_PARTS {
            return Err(bad("needs 1 to 1024 parts"));
        }
        let mut out = Vec::with_capacity(parts.len());
        for (pose, part) in parts {
            if part.is_unbounded() {
                return Err(bad("a part cannot be a half-space"));
            }
            if part.is_terrain() {
                return Err(bad("a part cannot be a height field or a triangle mesh"));
            }
            if !valid_isometry(pose) {
                return Err(bad("a part's pose is invalid"));
            }
            let (parry, rot) = part.build(collider)?;
            out.push(ColliderPart { local: parry_offset(&(offset * pose), &rot), parry });
        }
        Ok(out)
    }

    /// Validates a shape other than a compound and builds its parry counterpart with the rotation
    /// from the collider frame to parry's shape frame (parry's cylinder is along `y`).
    fn build(&self, collider: &str) -> Result<(SharedShape, UnitQuaternion<f64>), ContactError> {
        let size = |what: &'static str, value: f64, zero_ok: bool| {
            let ok = value.is_finite() && (value > 0.0 || (zero_ok && value == 0.0));
            if ok {
                Ok(value)
            } else {
                Err(ContactError::InvalidSize { collider: collider.to_string(), what, value })
            }
        };
        let id = UnitQuaternion::identity();
        Ok(match self {
            Shape::Ball { radius } => (SharedShape::ball(size("radius", *radius, false)?), id),
            Shape::Cuboid { half_extents: e } => {
                let (x, y, z) = (
                    size("half extent x", e.x, false)?,
                    size("half extent y", e.y, false)?,
                    size("half extent z", e.z, false)?,
                );
                (SharedShape::cuboid(x, y, z), id)
            }
            Shape::Capsule { radius, half_length } => {
                let r = size("radius", *radius, false)?;
                let l = size("half length", *half_length, true)?;
                (SharedShape::capsule_z(l, r), id)
            }
            Shape::Cylinder { radius, half_length } => {
                let r = size("radius", *radius, false)?;
                let l = size("half length", *half_length, false)?;
                // parry's cylinder is along y; a rotation of +90° about x carries y to z.
                let rot = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2);
                (SharedShape::cylinder(l, r), rot)
            }
            Shape::ConvexHull { points } => {
                for (index, p) in points.iter().enumerate() {
                    if !p.iter().all(|c| c.is_finite()) {
                        return Err(ContactError::NonFiniteVertex { collider: collider.to_string(), index });
                    }
                }
                if !spans_volume(points) {
                    return Err(ContactError::DegenerateHull {
                        collider: collider.to_string(),
                        points: points.len(),
                    });
                }
                let pts: Vec<_> = points.iter().map(to_vec).collect();
                let hull = SharedShape::convex_hull(&pts).ok_or_else(|| ContactError::DegenerateHull {
                    collider: collider.to_string(),
                    points: points.len(),
                })?;
                (hull, id)
            }
            Shape::HalfSpace { normal } => {
                let norm = normal.norm();
                if !(norm.is_finite() && (norm - 1.0).abs() <= 1e-6) {
                    return Err(ContactError::NonUnitNormal { collider: collider.to_string(), norm });
                }
                (SharedShape::halfspace(to_vec(&(normal / norm))), id)
            }
            Shape::Compound { .. } => {
                return Err(ContactError::InvalidCompound {
                    collider: collider.to_string(),
                    reason: "a part cannot be a compound",
                });
            }
            Shape::HeightField { rows, cols, heights, scale } => {
                (build_heightfield(collider, *rows, *cols, heights, scale)?, heightfield_rotation())
            }
            Shape::TriMesh { vertices, indices } => (build_trimesh(collider, vertices, indices)?, id),
        })
    }
}

/// The rotation from parry's height-field frame (`y` up, columns along `x`, rows along `z`) to the
/// collider frame (`z` up): parry `x → y`, `y → z`, `z → x` (120° about `(1, 1, 1)`). Parry's
/// row `i` (along its `z`) is then our column `c` (along `x`) and its column `j` our row `r`.
pub(crate) fn heightfield_rotation() -> UnitQuaternion<f64> {
    let m = Matrix3::from_columns(&[Vector3::y(), Vector3::z(), Vector3::x()]);
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(m))
}

/// Validates a height field and builds parry's (in parry's frame, [`heightfield_rotation`]).
fn build_heightfield(
    collider: &str,
    rows: usize,
    cols: usize,
    heights: &[f64],
    scale: &Vector3<f64>,
) -> Result<SharedShape, ContactError> {
    let name = || collider.to_string();
    if rows < 2 || cols < 2 {
        return Err(ContactError::HeightFieldTooSmall { collider: name(), rows, cols });
    }
    let triangles = 2usize.saturating_mul(rows - 1).saturating_mul(cols - 1);
    if triangles > MAX_TERRAIN_TRIANGLES {
        return Err(ContactError::TerrainTooLarge { collider: name(), triangles });
    }
    if rows.checked_mul(cols) != Some(heights.len()) {
        return Err(ContactError::HeightFieldSize { collider: name(), rows, cols, heights: heights.len() });
    }
    if let Some(index) = heights.iter().position(|h| !h.is_finite()) {
        return Err(ContactError::NonFiniteHeight { collider: name(), row: index / cols, col: index % cols });
    }
    for (what, value) in [("scale x", scale.x), ("scale y", scale.y), ("scale z", scale.z)] {
        if !(value.is_finite() && value > 0.0) {
            return Err(ContactError::InvalidSize { collider: name(), what, value });
        }
    }
    // Parry's `heights_zx` is column-major with `cols` rows (along its z = our x) and `rows`
    // columns: entry (i = c, j = r) at `c + r · cols`, which is our row-major layout.
    let grid = Array2::new(cols, rows, heights.to_vec());
    let parry_scale = parry3d_f64::math::Vector::new(scale.y, scale.z, scale.x);
    Ok(SharedShape::heightfield_with_flags(grid, parry_scale, HeightFieldFlags::FIX_INTERNAL_EDGES))
}

/// Validates a triangle mesh and builds parry's.
fn build_trimesh(
    collider: &str,
    vertices: &[Vector3<f64>],
    indices: &[[u32; 3]],
) -> Result<SharedShape, ContactError> {
    let name = || collider.to_string();
    if indices.is_empty() || vertices.is_empty() {
        return Err(ContactError::EmptyMesh { collider: name() });
    }
    if indices.len() > MAX_TERRAIN_TRIANGLES {
        return Err(ContactError::TerrainTooLarge { collider: name(), triangles: indices.len() });
    }
    if let Some(index) = vertices.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(ContactError::NonFiniteVertex { collider: name(), index });
    }
    for (triangle, tri) in indices.iter().enumerate() {
        if let Some(&index) = tri.iter().find(|&&i| i as usize >= vertices.len()) {
            return Err(ContactError::TriangleIndexOutOfRange {
                collider: name(),
                triangle,
                index,
                vertices: vertices.len(),
            });
        }
        let [a, b, c] = tri.map(|i| vertices[i as usize]);
        let longest = (b - a).norm_squared().max((c - b).norm_squared()).max((a - c).norm_squared());
        // Twice the area against the squared longest edge: ≤ 1e-12 is a needle or a point.
        if (b - a).cross(&(c - a)).norm() <= 1e-12 * longest || longest == 0.0 {
            return Err(ContactError::DegenerateTriangle { collider: name(), triangle });
        }
    }
    let verts = vertices.iter().map(to_vec).collect();
    // FIX_INTERNAL_EDGES merges duplicate vertices and computes the edge pseudo-normals.
    SharedShape::trimesh_with_flags(verts, indices.to_vec(), TriMeshFlags::FIX_INTERNAL_EDGES)
        .map_err(|_| ContactError::EmptyMesh { collider: name() })
}

/// Whether the points span a volume (a tetrahedron of relative volume > 1e-9 exists): the far
/// point from the first, the far point from that line, the far point from that plane.
fn spans_volume(points: &[Vector3<f64>]) -> bool {
    let Some(&p0) = points.first() else { return false };
    let far = |f: &dyn Fn(&Vector3<f64>) -> f64| {
        points.iter().copied().max_by(|a, b| f(a).total_cmp(&f(b))).unwrap_or(p0)
    };
    let p1 = far(&|p| (p - p0).norm());
    let scale = (p1 - p0).norm();
    if scale <= 0.0 {
        return false;
    }
    let d = (p1 - p0) / scale;
    let p2 = far(&|p| (p - p0).cross(&d).norm());
    let n = (p2 - p0).cross(&d);
    if n.norm() <= 1e-9 * scale {
        return false;
    }
    let n = n.normalize();
    let p3 = far(&|p| (p - p0).dot(&n).abs());
    (p3 - p0).dot(&n).abs() > 1e-9 * scale
}

/// The collider's pose in its body's frame composed with the shape's parry rotation.
fn parry_offset(offset: &Isometry3<f64>, rot: &UnitQuaternion<f64>) -> Isometry3<f64> {
    offset * Isometry3::from_parts(nalgebra::Translation3::identity(), *rot)
}
