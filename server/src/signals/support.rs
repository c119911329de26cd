//! The support polygon and the tipping margin (the load-moment indicator).
//!
//! Points are projected on the plane perpendicular to gravity, with an orthonormal basis `(u, v)`
//! of that plane fixed at build time: `P(x) = (u·x, v·x)`. The support polygon is the convex hull
//! (Andrew's monotone chain, in place: sorted by `(x, y)`, lower and upper chains, counter-clockwise)
//! of the projected active support points. For an edge `e_i = (p_i, p_{i+1})` of a
//! counter-clockwise hull the signed distance of a point `c` to its line is
//!
//! ```text
//!   s_i(c) = ((p_{i+1} − p_i) × (c − p_i)) / |p_{i+1} − p_i|         (2-D cross product; > 0 inside)
//! ```
//!
//! The **margin** is `d = min_i s_i(c)` for the centre of mass `c` inside the polygon, and minus its
//! Euclidean distance to the polygon when outside (both continuous through zero on the boundary);
//! the **tipping edge** is the edge that attains it. About that edge, every body `k` of the machine
//! (mass `m_k`, centre `c_k`) stabilizes with `m_k g max(s(c_k), 0)` and overturns with
//! `m_k g max(−s(c_k), 0)`; their sums `M_s`, `M_o` give
//!
//! ```text
//!   percent = 100 (M_s − M_o) / M_s = 100 (1 − M_o / M_s)        (clamped to [−100, 100])
//! ```
//!
//! 100 % with no overturning moment, 0 % at the tipping point (`M_s − M_o = W d = 0`), negative
//! beyond. A polygon of one or two points (or none) has no inside: `d` is minus the distance to it
//! (0 without support), and the percent is 0 on it and −100 off it.

use nalgebra::{Vector2, Vector3};

/// Where the polygon and the centre of mass stand.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TippingMargin {
    /// Signed distance of the centre of mass to the polygon's boundary (m; > 0 inside).
    pub distance: f64,
    /// Stabilizing minus overturning moment about the tipping edge over the stabilizing one (%).
    pub percent: f64,
    /// Vertices of the support polygon.
    pub supports: usize,
    /// Stabilizing moment `M_s` about the tipping edge (N m).
    pub stabilizing: f64,
    /// Overturning moment `M_o` about the tipping edge (N m).
    pub overturning: f64,
}

/// A support polygon's workspace: the projection basis and the point buffer (reserved at build).
#[derive(Debug, Clone)]
pub struct SupportPolygon {
    u: Vector3<f64>,
    v: Vector3<f64>,
    points: Vec<Vector2<f64>>,
    hull: Vec<Vector2<f64>>,
    /// The tipping edge of the last evaluation (hull indices), for the moments.
    edge: Option<(Vector2<f64>, Vector2<f64>)>,
}

impl SupportPolygon {
    /// A workspace for gravity `g` (non-zero; along −z if zero) with room for `capacity` points.
    pub fn new(g: Vector3<f64>, capacity: usize) -> Self {
        let down = if g.norm() > 0.0 { g.normalize() } else { -Vector3::z() };
        let helper = if down.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() };
        let u = (helper - down * down.dot(&helper)).normalize();
        let v = down.cross(&u);
        SupportPolygon {
            u,
            v,
            points: Vec::with_capacity(capacity),
            hull: Vec::with_capacity(capacity + 1),
            edge: None,
        }
    }

    /// Projects a world point on the ground plane.
    #[inline]
    pub fn project(&self, x: &Vector3<f64>) -> Vector2<f64> {
        Vector2::new(self.u.dot(x), self.v.dot(x))
    }

    /// Empties the point set.
    pub fn clear(&mut self) {
        self.points.clear();
    }

    /// Adds a support point (world).
    pub fn push(&mut self, x: &Vector3<f64>) {
        let p = self.project(x);
        self.points.push(p);
    }

    /// The hull of the points (counter-clockwise), computed by [`SupportPolygon::margin`].
    pub fn hull(&self) -> &[Vector2<f64>] {
        &self.hull
    }

    /// Builds the hull in place (Andrew's monotone chain).
    fn build_hull(&mut self) {
        self.hull.clear();
        let pts = &mut self.points;
        pts.sort_unstable_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
        // Points closer than 1e-9 m are one (a box corner reported by two triangles).
        let close = |a: &Vector2<f64>, b: &Vector2<f64>| (a - b).norm() <= 1e-9;
        let cross = |o: &Vector2<f64>, a: &Vector2<f64>, b: &Vector2<f64>| {
            (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x)
        };
        for i in 0..pts.len() {
            let p = pts[i];
            if i > 0 && close(&pts[i - 1], &p) {
                continue;
            }
            while self.hull.len() >= 2
                && cross(&self.hull[self.hull.len() - 2], &self.hull[self.hull.len() - 1], &p) <= 1e-12
            {
                self.hull.pop();
            }
            self.hull.push(p);
        }
        let lower = self.hull.len() + 1;
        for i in (0..pts.len().saturating_sub(1)).rev() {
            let p = pts[i];
            if close(&pts[i + 1], &p) {
                continue;
            }
            while self.hull.len() >= lower
                && cross(&self.hull[self.hull.len() - 2], &self.hull[self.hull.len() - 1], &p) <= 1e-12
            {
                self.hull.pop();
            }
            self.hull.push(p);
        }
        if self.hull.len() > 1 {
            self.hull.pop(); // the first point, again
        }
    }

    /// The margin of the centre of mass `com` (world) and the moments about the tipping edge of the
    /// bodies `(mass, centre)` under gravity magnitude `g` (module doc).
    pub fn margin(
        &mut self,
        com: &Vector3<f64>,
        g: f64,
        bodies: impl Iterator<Item = (f64, Vector3<f64>)>,
    ) -> TippingMargin {
        self.build_hull();
        let c = self.project(com);
        let n = self.hull.len();
        self.edge = None;
        if n == 0 {
            return TippingMargin { percent: -100.0, ..TippingMargin::default() };
        }
        let seg_dist = |a: &Vector2<f64>, b: &Vector2<f64>, p: &Vector2<f64>| {
            let ab = b - a;
            let l2 = ab.norm_squared();
            let t = if l2 > 0.0 { ((p - a).dot(&ab) / l2).clamp(0.0, 1.0) } else { 0.0 };
            (a + ab * t - p).norm()
        };
        if n < 3 {
            let d =
                if n == 1 { (self.hull[0] - c).norm() } else { seg_dist(&self.hull[0], &self.hull[1], &c) };
            let percent = if d <= 1e-12 { 0.0 } else { -100.0 };
            return TippingMargin { distance: -d, percent, supports: n, stabilizing: 0.0, overturning: 0.0 };
        }
        let signed = |a: &Vector2<f64>, b: &Vector2<f64>, p: &Vector2<f64>| {
            let e = b - a;
            (e.x * (p.y - a.y) - e.y * (p.x - a.x)) / e.norm()
        };
        let (mut inside, mut best_in, mut best_out) = (true, (f64::INFINITY, 0), (f64::INFINITY, 0));
        for i in 0..n {
            let (a, b) = (&self.hull[i], &self.hull[(i + 1) % n]);
            let s = signed(a, b, &c);
            if s < 0.0 {
                inside = false;
            }
            if s < best_in.0 {
                best_in = (s, i);
            }
            let d = seg_dist(a, b, &c);
            if d < best_out.0 {
                best_out = (d, i);
            }
        }
        let (distance, edge) = if inside { best_in } else { (-best_out.0, best_out.1) };
        let (a, b) = (self.hull[edge], self.hull[(edge + 1) % n]);
        self.edge = Some((a, b));
        let (mut ms, mut mo) = (0.0, 0.0);
        for (m, x) in bodies {
            let s = signed(&a, &b, &self.project(&x));
            if s >= 0.0 {
                ms += m * g * s;
            } else {
                mo -= m * g * s;
            }
        }
        let percent = if ms > 0.0 { (100.0 * (1.0 - mo / ms)).clamp(-100.0, 100.0) } else { -100.0 };
        TippingMargin { distance, percent, supports: n, stabilizing: ms, overturning: mo }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> SupportPolygon {
        let mut s = SupportPolygon::new(Vector3::new(0.0, 0.0, -9.81), 16);
        for (x, y) in [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0), (0.0, 0.0), (1.0, 1.0)] {
            s.push(&Vector3::new(x, y, 0.0));
        }
        s
    }

    #[test]
    fn hull_drops_inner_and_repeated_points() {
        let mut s = square();
        s.margin(&Vector3::zeros(), 9.81, std::iter::empty());
        assert_eq!(s.hull().len(), 4);
    }

    #[test]
    fn margin_inside_outside_and_moments() {
        let mut s = square();
        let m =
            s.margin(&Vector3::new(0.25, 0.0, 3.0), 10.0, [(1.0, Vector3::new(0.25, 0.0, 0.0))].into_iter());
        assert!((m.distance.abs() - 0.75).abs() < 1e-12 && m.distance > 0.0);
        assert!((m.percent - 100.0).abs() < 1e-12 && (m.stabilizing - 7.5).abs() < 1e-12);
        s.clear();
        let mut s = square();
        let bodies = [(3.0, Vector3::new(0.0, 0.0, 0.0)), (1.0, Vector3::new(4.0, 0.0, 0.0))];
        let m = s.margin(&Vector3::new(1.0, 0.0, 0.0), 10.0, bodies.into_iter());
        assert!(m.distance.abs() < 1e-12, "{m:?}");
        assert!(m.percent.abs() < 1e-12, "{m:?}");
        let mut s = square();
        let m = s.margin(&Vector3::new(2.0, 0.5, 0.0), 10.0, std::iter::empty());
        assert!((m.distance + 1.0).abs() < 1e-12, "{m:?}");
    }
}
