//! Terrain shape types of scene files and the material-pair table (wired to the contacts module).

use std::ops::Range;

use nalgebra::Isometry3;

use super::build::{Builder, R};
use super::format::ShapeDef;
use crate::dynamics::Shape;

/// Terrain shape types.
pub(crate) const KINDS: &[&str] = &[];

pub(crate) fn is_terrain(kind: &str) -> bool {
    KINDS.contains(&kind)
}

pub(crate) fn shape(b: &Builder, span: &Range<usize>, kind: &str, _s: &ShapeDef) -> R<Shape> {
    let _ = Isometry3::<f64>::identity();
    Err(b.invalid(span, "type", format!("terrain type `{kind}` is not available")))
}
