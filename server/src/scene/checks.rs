//! Where a scene file's values come from and the checks every stage of the build shares: each
//! error names its file, line and column (from the span of its table) and the field.

use std::ops::Range;

use nalgebra::Vector3;

use super::{Location, SceneError};
use crate::dynamics::ModelError;

/// The result of a build stage.
pub(crate) type R<T> = Result<T, SceneError>;

/// Source text with a line index, for locating spans.
pub(crate) struct Source<'a> {
    pub file: &'a str,
    line_starts: Vec<usize>,
}

impl<'a> Source<'a> {
    pub fn new(file: &'a str, text: &str) -> Self {
        let mut line_starts = vec![0];
        line_starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        Source { file, line_starts }
    }

    pub fn at(&self, span: Range<usize>) -> Location {
        let line = self.line_starts.partition_point(|&s| s <= span.start).max(1);
        let column = span.start - self.line_starts[line - 1] + 1;
        Location { file: self.file.to_string(), line, column }
    }
}

impl Source<'_> {
    pub(crate) fn invalid(&self, span: &Range<usize>, field: &str, message: impl Into<String>) -> SceneError {
        SceneError::Invalid { at: self.at(span.clone()), field: field.to_string(), message: message.into() }
    }

    pub(crate) fn model(&self, span: &Range<usize>, item: &str, e: impl Into<ModelError>) -> SceneError {
        SceneError::Model { at: self.at(span.clone()), item: item.to_string(), source: Box::new(e.into()) }
    }

    pub(crate) fn finite(&self, span: &Range<usize>, field: &str, v: f64) -> R<f64> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.invalid(span, field, format!("{v} is not a finite number")))
        }
    }

    pub(crate) fn positive(&self, span: &Range<usize>, field: &str, v: f64) -> R<f64> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(self.invalid(span, field, format!("{v} must be a finite number > 0")))
        }
    }

    pub(crate) fn non_negative(&self, span: &Range<usize>, field: &str, v: f64) -> R<f64> {
        if v.is_finite() && v >= 0.0 {
            Ok(v)
        } else {
            Err(self.invalid(span, field, format!("{v} must be a finite number ≥ 0")))
        }
    }

    pub(crate) fn vec3(&self, span: &Range<usize>, field: &str, v: [f64; 3]) -> R<Vector3<f64>> {
        for c in v {
            self.finite(span, field, c)?;
        }
        Ok(Vector3::from(v))
    }

    pub(crate) fn unit3(&self, span: &Range<usize>, field: &str, v: [f64; 3]) -> R<Vector3<f64>> {
        let v = self.vec3(span, field, v)?;
        let n = v.norm();
        if n < 1e-12 {
            return Err(self.invalid(span, field, "the direction is zero"));
        }
        Ok(v / n)
    }
}
