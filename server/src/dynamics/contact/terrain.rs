//! Ready-made terrain shapes for scenes: height fields sampled from a function (hills, bumps, a
//! ramp), a staircase and a flat deck as triangle meshes. Each returns a [`Shape`] for a collider
//! on a **static** body, in the collider frame with `z` up; its validation happens, as for any
//! shape, in [`World::add_collider`](crate::dynamics::World::add_collider).
//!
//! ```
//! use nalgebra::Vector3;
//! use pivotsim_server::dynamics::{BodyBuilder, ColliderBuilder, World, WorldSettings, terrain};
//!
//! let mut world = World::new(WorldSettings::default())?;
//! let ground = world.add_body(BodyBuilder::static_body("ground"))?;
//! // 40 m × 40 m of gentle hills, 1 m grid.
//! let hills = terrain::hills(41, 41, 40.0, 40.0, |x, y| 0.5 * (0.3 * x).sin() * (0.2 * y).cos());
//! world.add_collider(ColliderBuilder::new("hills", ground, hills))?;
//! let stairs = world.add_body(BodyBuilder::static_body("stairs").position(Vector3::new(30.0, 0.0, 0.0)))?;
//! world.add_collider(ColliderBuilder::new("stairs", stairs, terrain::stairs(5, 0.17, 0.3, 1.2)))?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use nalgebra::Vector3;

use super::Shape;

/// A height field of `cols × rows` samples over `[−size_x/2, size_x/2] × [−size_y/2, size_y/2]`
/// with the height `f(x, y)` (m) at each sample (collider frame, `scale.z = 1`). `rows`, `cols` ≥ 2
/// make a valid grid; `f` must be finite there.
pub fn hills(cols: usize, rows: usize, size_x: f64, size_y: f64, f: impl Fn(f64, f64) -> f64) -> Shape {
    let coord = |k: usize, n: usize, size: f64| {
        if n < 2 { 0.0 } else { (k as f64 / (n - 1) as f64 - 0.5) * size }
    };
    let mut heights = Vec::with_capacity(rows * cols);
    for r in 0..rows {
        for c in 0..cols {
            heights.push(f(coord(c, cols, size_x), coord(r, rows, size_y)));
        }
    }
    Shape::HeightField { rows, cols, heights, scale: Vector3::new(size_x, size_y, 1.0) }
}

/// Sinusoidal bumps `amplitude · sin(2πx/wavelength) · sin(2πy/wavelength)` on a square of side
/// `size` sampled every `spacing` metres (at least 2 samples a side).
pub fn bumps(size: f64, spacing: f64, amplitude: f64, wavelength: f64) -> Shape {
    let n = ((size / spacing).round().max(1.0) as usize) + 1;
    let k = std::f64::consts::TAU / wavelength;
    hills(n, n, size, size, |x, y| amplitude * (k * x).sin() * (k * y).sin())
}

/// A plane ramp `z = x · tan θ` over a `size_x × size_y` rectangle centred on the origin, as a
/// height field of `cols × rows` samples (rising towards `+x`).
pub fn ramp(cols: usize, rows: usize, size_x: f64, size_y: f64, theta: f64) -> Shape {
    let slope = theta.tan();
    hills(cols, rows, size_x, size_y, |x, _| x * slope)
}

/// A staircase of `steps` steps climbing towards `+x`: step `k` (0-based) has its tread at height
/// `(k + 1) · rise` over `x ∈ [k · run, (k + 1) · run]` and its riser at `x = k · run`, all across
/// `y ∈ [−width/2, width/2]`; the floor in front of it is `z = 0` (add ground there). Treads and
/// risers only (no side walls), as one triangle mesh whose steps share their nosing edges.
pub fn stairs(steps: usize, rise: f64, run: f64, width: f64) -> Shape {
    let w = 0.5 * width;
    let mut vertices = Vec::with_capacity(4 * steps);
    let mut indices = Vec::with_capacity(4 * steps);
    // Per step k: riser bottom (k·run, ·, k·rise), riser top = tread front ((k·run, ·, (k+1)·rise)),
    // tread back ((k+1)·run, ·, (k+1)·rise), which is the next riser's bottom edge.
    let mut push = |x: f64, z: f64| {
        vertices.push(Vector3::new(x, -w, z));
        vertices.push(Vector3::new(x, w, z));
        (vertices.len() - 2) as u32
    };
    let mut bottom = push(0.0, 0.0);
    for k in 0..steps {
        let x0 = k as f64 * run;
        let z1 = (k + 1) as f64 * rise;
        let top = push(x0, z1);
        let back = push(x0 + run, z1);
        // Riser facing −x (from +y to −y along the bottom, then up).
        quad(&mut indices, bottom + 1, bottom, top, top + 1);
        // Tread facing +z.
        quad(&mut indices, top, back, back + 1, top + 1);
        bottom = back;
    }
    Shape::TriMesh { vertices, indices }
}

/// A flat deck: the top face `z = 0` of `[−half_x, half_x] × [−half_y, half_y]` as a triangle mesh
/// of `divisions × divisions` quads (two triangles each; `divisions ≥ 1`), normal `+z`.
pub fn deck(half_x: f64, half_y: f64, divisions: usize) -> Shape {
    let n = divisions.max(1);
    let mut vertices = Vec::with_capacity((n + 1) * (n + 1));
    for r in 0..=n {
        for c in 0..=n {
            let (u, v) = (c as f64 / n as f64, r as f64 / n as f64);
            vertices.push(Vector3::new((2.0 * u - 1.0) * half_x, (2.0 * v - 1.0) * half_y, 0.0));
        }
    }
    let id = |r: usize, c: usize| (r * (n + 1) + c) as u32;
    let mut indices = Vec::with_capacity(2 * n * n);
    for r in 0..n {
        for c in 0..n {
            quad(&mut indices, id(r, c), id(r, c + 1), id(r + 1, c + 1), id(r + 1, c));
        }
    }
    Shape::TriMesh { vertices, indices }
}

/// Two triangles of the quad `a b c d` (counter-clockwise seen from the side it faces).
fn quad(indices: &mut Vec<[u32; 3]>, a: u32, b: u32, c: u32, d: u32) {
    indices.push([a, b, c]);
    indices.push([a, c, d]);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Normals of a triangle mesh's triangles.
    fn normals(s: &Shape) -> Vec<Vector3<f64>> {
        let Shape::TriMesh { vertices, indices } = s else { panic!("not a mesh") };
        indices
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| vertices[i as usize]);
                (b - a).cross(&(c - a)).normalize()
            })
            .collect()
    }

    #[test]
    fn stairs_face_up_and_towards_minus_x() {
        let s = stairs(3, 0.2, 0.3, 1.0);
        let n = normals(&s);
        assert_eq!(n.len(), 12);
        for (k, n) in n.iter().enumerate() {
            let want = if (k / 2) % 2 == 0 { -Vector3::x() } else { Vector3::z() };
            assert!((n - want).norm() < 1e-12, "triangle {k}: {n:?}");
        }
        let Shape::TriMesh { vertices, .. } = &s else { unreachable!() };
        let top = vertices.iter().map(|v| v.z).fold(f64::MIN, f64::max);
        assert!((top - 0.6).abs() < 1e-12);
    }

    #[test]
    fn deck_faces_up() {
        let s = deck(1.0, 2.0, 3);
        assert!(normals(&s).iter().all(|n| (n - Vector3::z()).norm() < 1e-12));
    }

    #[test]
    fn hills_sample_the_function_row_major() {
        let Shape::HeightField { rows, cols, heights, scale } = hills(3, 2, 4.0, 2.0, |x, y| x + 10.0 * y)
        else {
            panic!()
        };
        assert_eq!((rows, cols), (2, 3));
        assert_eq!(scale, Vector3::new(4.0, 2.0, 1.0));
        assert_eq!(heights, vec![-12.0, -10.0, -8.0, 8.0, 10.0, 12.0]);
    }
}
