//! Terrain shape types of scene files (static bodies only; built by
//! [`dynamics::terrain`](crate::dynamics::terrain) and validated by the contacts module):
//!
//! | `type` | fields | shape |
//! |---|---|---|
//! | `heightfield` | `heights` (rows of equal length, ≥ 2 × 2), `size = [x, y, z-scale]` | height field centred on the origin |
//! | `hills` | `size = [x, y, _]`, `cells`, `amplitude`, `wavelength` | `amplitude · sin(2πx/λ) · cos(2πy/λ)` sampled on a `(cells+1)²` grid |
//! | `stairs` | `steps`, `rise`, `run`, `size = [_, width, _]` | a staircase climbing toward +x from the origin |
//! | `trimesh` | `vertices`, `triangles` | a triangle mesh |

use std::ops::Range;

use nalgebra::Vector3;

use super::checks::{R, Source};
use super::format::ShapeDef;
use crate::dynamics::{Shape, terrain};

/// Terrain shape types.
pub(crate) const KINDS: &[&str] = &["heightfield", "hills", "stairs", "trimesh"];

pub(crate) fn is_terrain(kind: &str) -> bool {
    KINDS.contains(&kind)
}

/// Fields each terrain type takes (others are refused).
fn allowed(kind: &str) -> &'static [&'static str] {
    match kind {
        "heightfield" => &["heights", "size"],
        "hills" => &["size", "cells", "amplitude", "wavelength"],
        "stairs" => &["steps", "rise", "run", "size"],
        _ => &["vertices", "triangles"],
    }
}

pub(crate) fn shape(b: &Source, span: &Range<usize>, kind: &str, s: &ShapeDef) -> R<Shape> {
    if let Some(f) = s.stray_field(allowed(kind)) {
        return Err(b.invalid(span, f, format!("`{f}` does not apply to a {kind}")));
    }
    let need = |v: Option<f64>, field: &str| {
        v.ok_or_else(|| b.invalid(span, field, format!("a {kind} needs `{field}`")))
            .and_then(|v| b.positive(span, field, v))
    };
    let size = |b: &Source| -> R<Vector3<f64>> {
        let v = s.size.ok_or_else(|| b.invalid(span, "size", format!("a {kind} needs `size`")))?;
        b.vec3(span, "size", v)
    };
    Ok(match kind {
        "heightfield" => {
            let rows = s.heights.as_ref().ok_or_else(|| b.invalid(span, "heights", "needs `heights`"))?;
            let cols = rows.first().map_or(0, Vec::len);
            if rows.iter().any(|r| r.len() != cols) {
                return Err(b.invalid(span, "heights", "every row needs the same number of heights"));
            }
            let heights: Vec<f64> = rows.iter().flatten().copied().collect();
            Shape::HeightField { rows: rows.len(), cols, heights, scale: size(b)? }
        }
        "hills" => {
            let sz = size(b)?;
            let cells = s.cells.ok_or_else(|| b.invalid(span, "cells", "a hills needs `cells`"))?;
            if !(1..=1024).contains(&cells) {
                return Err(b.invalid(span, "cells", "must be in 1..=1024"));
            }
            let (a, l) =
                (b.finite(span, "amplitude", s.amplitude.unwrap_or(0.0))?, need(s.wavelength, "wavelength")?);
            let k = std::f64::consts::TAU / l;
            terrain::hills(cells + 1, cells + 1, sz.x, sz.y, |x, y| a * (k * x).sin() * (k * y).cos())
        }
        "stairs" => {
            let steps = s.steps.ok_or_else(|| b.invalid(span, "steps", "stairs need `steps`"))?;
            if !(1..=1000).contains(&steps) {
                return Err(b.invalid(span, "steps", "must be in 1..=1000"));
            }
            terrain::stairs(steps, need(s.rise, "rise")?, need(s.run, "run")?, size(b)?.y)
        }
        _ => {
            let v = s
                .vertices
                .as_ref()
                .ok_or_else(|| b.invalid(span, "vertices", "a trimesh needs `vertices`"))?;
            let t = s
                .triangles
                .as_ref()
                .ok_or_else(|| b.invalid(span, "triangles", "a trimesh needs `triangles`"))?;
            Shape::TriMesh {
                vertices: v.iter().map(|&p| b.vec3(span, "vertices", p)).collect::<R<_>>()?,
                indices: t.clone(),
            }
        }
    })
}
