//! The world's real obstacles (issues 27 and 28): the geometry the true clearances and the
//! simulated LiDAR measure against. Obstacles are prisms from the ground to the ceiling, as the
//! planner treats them: circles, polygons and walls (capsules, as in `vt_plan`) are exact; an
//! occupancy grid gives the distance transform's lower bound for distances and its occupied
//! squares for rays.

use crate::map::{Grid, LoadedMap, Map, Shape};
use crate::scenario::LoadedScenario;
use nalgebra::Vector2;
use vt_plan::ClearanceMap;

type V2 = Vector2<f64>;


/// Distance from `p` to the segment `a`-`b`, m.
fn point_segment_m(p: V2, a: V2, b: V2) -> f64 {
    let ab = b - a;
    let len2 = ab.norm_squared();
    let t = if len2 > 0.0 { ((p - a).dot(&ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
    (p - (a + ab * t)).norm()
}


/// True when the segments `a`-`b` and `c`-`d` cross or touch.
fn segments_cross(a: V2, b: V2, c: V2, d: V2) -> bool {
    let cross = |o: V2, p: V2, q: V2| (p - o).perp(&(q - o));
    let (d1, d2) = (cross(c, d, a), cross(c, d, b));
    let (d3, d4) = (cross(a, b, c), cross(a, b, d));
    d1 * d2 <= 0.0 && d3 * d4 <= 0.0
}

/// Distance between two segments, m (0 when they cross).
fn segment_segment_m(a: V2, b: V2, c: V2, d: V2) -> f64 {
    if segments_cross(a, b, c, d) {
        return 0.0;
    }
    point_segment_m(a, c, d).min(point_segment_m(b, c, d)).min(point_segment_m(c, a, b)).min(point_segment_m(d, a, b))
}

/// Even-odd point-in-polygon test.
fn inside(poly: &[V2], p: V2) -> bool {
    let mut c = false;
    let mut j = poly.len().wrapping_sub(1);
    for (i, vi) in poly.iter().enumerate() {
        if let Some(vj) = poly.get(j) {
            if (vi.y > p.y) != (vj.y > p.y) && p.x < (vj.x - vi.x) * (p.y - vi.y) / (vj.y - vi.y) + vi.x {
                c = !c;
            }
        }
        j = i;
    }
    c
}

/// Each edge of a closed polygon.
fn edges(poly: &[V2]) -> impl Iterator<Item = (V2, V2)> + '_ {
    poly.iter().zip(poly.iter().cycle().skip(1)).map(|(a, b)| (*a, *b))
}

/// Distance along the ray `o + t d` (`d` unit) to the circle of centre `c`, radius `r`, m
/// (`Some(0)` from inside).
fn ray_circle_m(o: V2, d: V2, c: V2, r: f64) -> Option<f64> {
    let oc = o - c;
    let c2 = oc.norm_squared() - r * r;
    if c2 <= 0.0 {
        return Some(0.0);
    }
    // t^2 + 2 b t + c2 = 0 with b = d.(o - c); both roots positive when b < 0.
    let b = d.dot(&oc);
    let disc = b * b - c2;
    (b < 0.0 && disc >= 0.0).then(|| -b - disc.sqrt())
}

/// Distance along the ray `o + t d` to the segment `a`-`b`, m (`None`: missed or parallel).
fn ray_segment_m(o: V2, d: V2, a: V2, b: V2) -> Option<f64> {
    let e = b - a;
    let den = d.perp(&e);
    if den == 0.0 {
        return None;
    }
    let ao = a - o;
    let t = ao.perp(&e) / den;
    let u = ao.perp(&d) / den;
    (t >= 0.0 && (0.0..=1.0).contains(&u)).then_some(t)
}

/// Distance along the ray `o + t d` (`d` unit), up to `max_m`, to the first occupied square of
/// a grid, m: Amanatides and Woo's cell traversal ("A Fast Voxel Traversal Algorithm for Ray
/// Tracing", Eurographics 1987). Outside the grid there is nothing.
fn ray_grid_m(g: &Grid, o: V2, d: V2, max_m: f64) -> Option<f64> {
    let res = g.resolution_m;
    let (w, h) = (g.width as i64, g.height as i64);
    let occupied = |i: i64, j: i64| i >= 0 && j >= 0 && i < w && j < h && g.occupied.get((j * w + i) as usize).copied().unwrap_or(false);
    // Local coordinates in cells; clip the ray to the grid's rectangle first.
    let lo = V2::new(o.x - g.origin_m[0], o.y - g.origin_m[1]) / res;
    let (size_x, size_y) = (w as f64, h as f64);
    let mut t_in = 0.0_f64;
    let mut t_out = max_m / res;
    for (p, dd, size) in [(lo.x, d.x, size_x), (lo.y, d.y, size_y)] {
        if dd == 0.0 {
            if p < 0.0 || p > size {
                return None;
            }
        } else {
            let (a, b) = ((0.0 - p) / dd, (size - p) / dd);
            t_in = t_in.max(a.min(b));
            t_out = t_out.min(a.max(b));
        }
    }
    if t_in > t_out {
        return None;
    }
    let start = lo + d * t_in;
    let mut i = (start.x.floor() as i64).clamp(0, w - 1);
    let mut j = (start.y.floor() as i64).clamp(0, h - 1);
    let step = |dd: f64| if dd > 0.0 { 1 } else { -1 };
    let (si, sj) = (step(d.x), step(d.y));
    let next = |p: f64, c: i64, dd: f64| {
        if dd > 0.0 {
            ((c + 1) as f64 - p) / dd
        } else if dd < 0.0 {
            (c as f64 - p) / dd
        } else {
            f64::INFINITY
        }
    };
    let mut tx = t_in + next(start.x, i, d.x);
    let mut ty = t_in + next(start.y, j, d.y);
    let (dtx, dty) = (if d.x != 0.0 { 1.0 / d.x.abs() } else { f64::INFINITY }, if d.y != 0.0 { 1.0 / d.y.abs() } else { f64::INFINITY });
    let mut t = t_in;
    while t <= t_out {
        if occupied(i, j) {
            return Some(t * res);
        }
        if tx < ty {
            t = tx;
            tx += dtx;
            i += si;
        } else {
            t = ty;
            ty += dty;
            j += sj;
        }
        if i < 0 || j < 0 || i >= w || j >= h {
            return None;
        }
    }
    None
}

/// One obstacle of the world, in the form the clearances need.
#[derive(Debug, Clone)]
enum Body {
    Circle(V2, f64),
    Polygon(Vec<V2>),
    Wall(V2, V2, f64),
}

impl Body {
    /// The body of a map file's shape.
    fn of(s: &Shape) -> Self {
        let v = |p: &[f64; 2]| V2::new(p[0], p[1]);
        match s {
            Shape::Circle { center_m, radius_m } => Self::Circle(v(center_m), *radius_m),
            Shape::Polygon(p) => Self::Polygon(p.iter().map(v).collect()),
            Shape::Wall { from_m, to_m, thickness_m } => Self::Wall(v(from_m), v(to_m), *thickness_m),
        }
    }

    /// Signed horizontal distance from `p`, m (negative inside).
    fn point_m(&self, p: V2) -> f64 {
        match self {
            Self::Circle(c, r) => (p - c).norm() - r,
            Self::Wall(a, b, t) => point_segment_m(p, *a, *b) - 0.5 * t,
            Self::Polygon(v) => {
                let d = edges(v).map(|(a, b)| point_segment_m(p, a, b)).fold(f64::INFINITY, f64::min);
                if inside(v, p) { -d } else { d }
            }
        }
    }

    /// Distance along the ray `o + t d` (`d` a unit vector) to this obstacle's surface, m:
    /// the smallest `t >= 0` on it (`Some(0)` from inside), `None` when the ray misses.
    fn ray_m(&self, o: V2, d: V2) -> Option<f64> {
        match self {
            Self::Circle(c, r) => ray_circle_m(o, d, *c, *r),
            Self::Polygon(v) => {
                if inside(v, o) {
                    return Some(0.0);
                }
                edges(v).filter_map(|(a, b)| ray_segment_m(o, d, a, b)).reduce(f64::min)
            }
            Self::Wall(a, b, t) => {
                // A capsule: the two end discs and the two sides of the swept segment.
                let h = 0.5 * t;
                if point_segment_m(o, *a, *b) <= h {
                    return Some(0.0);
                }
                let ab = b - a;
                let n = if ab.norm() > 0.0 { V2::new(-ab.y, ab.x) / ab.norm() * h } else { V2::zeros() };
                [ray_circle_m(o, d, *a, h), ray_circle_m(o, d, *b, h), ray_segment_m(o, d, a + n, b + n), ray_segment_m(o, d, a - n, b - n)]
                    .into_iter()
                    .flatten()
                    .reduce(f64::min)
            }
        }
    }

    /// Smallest signed horizontal distance of the segment `a`-`b`, m (negative: it enters).
    fn segment_m(&self, a: V2, b: V2) -> f64 {
        match self {
            Self::Circle(c, r) => point_segment_m(*c, a, b) - r,
            Self::Wall(p, q, t) => segment_segment_m(a, b, *p, *q) - 0.5 * t,
            Self::Polygon(v) => {
                if inside(v, a) || inside(v, b) {
                    return self.point_m(a).min(self.point_m(b)).min(0.0);
                }
                edges(v).map(|(p, q)| segment_segment_m(a, b, p, q)).fold(f64::INFINITY, f64::min)
            }
        }
    }
}

/// The real obstacles of a scenario's world: its planning map when the tube was planned on
/// one, else its `[world]` obstacles.
#[derive(Debug, Clone)]
pub struct Obstacles {
    bodies: Vec<Body>,
    grid: Option<Grid>,
}

impl Obstacles {
    /// The obstacles of `ls`.
    pub fn of(ls: &LoadedScenario) -> Self {
        match &ls.plan {
            Some(p) => Self::of_map(&p.map),
            None => Self::of_map(&LoadedMap::from_world(&ls.scenario, &ls.source_name)),
        }
    }

    /// Geometric obstacles only.
    pub fn of_shapes(shapes: &[Shape]) -> Self {
        Self { bodies: shapes.iter().map(Body::of).collect(), grid: None }
    }

    /// The obstacles of a map.
    pub fn of_map(m: &LoadedMap) -> Self {
        match &m.map {
            Map::Geometric { shapes, .. } => Self::of_shapes(shapes),
            Map::Grid(g) => Self { bodies: Vec::new(), grid: Some(g.clone()) },
        }
    }

    /// Distance along the ray from `o` in direction `d` (normalised here) to the first
    /// obstacle within `max_m`, m (`None`: nothing within range; `Some(0)` from inside one).
    pub fn ray_m(&self, o: V2, d: V2, max_m: f64) -> Option<f64> {
        let n = d.norm();
        if !(n > 0.0 && n.is_finite() && max_m > 0.0) {
            return None;
        }
        let d = d / n;
        let mut best = self.bodies.iter().filter_map(|b| b.ray_m(o, d)).reduce(f64::min);
        if let Some(g) = &self.grid {
            if let Some(t) = ray_grid_m(g, o, d, best.unwrap_or(max_m).min(max_m)) {
                best = Some(best.map_or(t, |b| b.min(t)));
            }
        }
        best.filter(|t| *t <= max_m)
    }

    /// Adds an obstacle (one that appears in flight, `[[world.appear]]`).
    pub fn add(&mut self, s: &Shape) {
        self.bodies.push(Body::of(s));
    }

    /// Horizontal clearance of the point `p` (m; negative inside an obstacle, infinite when
    /// there is none).
    pub fn point_m(&self, p: V2) -> f64 {
        let d = self.bodies.iter().map(|b| b.point_m(p)).fold(f64::INFINITY, f64::min);
        match &self.grid {
            Some(g) => d.min(f64::from(g.view().clearance_m(vt_plan::Vec2::new(p.x as f32, p.y as f32)))),
            None => d,
        }
    }

    /// Horizontal clearance of the segment `a`-`b`, m (a lower bound on a grid).
    pub fn segment_m(&self, a: V2, b: V2) -> f64 {
        let mut d = self.bodies.iter().map(|o| o.segment_m(a, b)).fold(f64::INFINITY, f64::min);
        if let Some(g) = &self.grid {
            let spacing = 0.5 * g.resolution_m;
            let samples = ((b - a).norm() / spacing).ceil().max(1.0) as usize;
            let view = g.view();
            for k in 0..=samples {
                let p = a + (b - a) * (k as f64 / samples as f64);
                let c = f64::from(view.clearance_m(vt_plan::Vec2::new(p.x as f32, p.y as f32)));
                d = d.min(c - 0.5 * spacing);
            }
        }
        d
    }
}


#[cfg(test)]
mod tests {
    use super::*;

    fn sq() -> Body {
        Body::Polygon(vec![V2::new(0.0, 0.0), V2::new(2.0, 0.0), V2::new(2.0, 2.0), V2::new(0.0, 2.0)])
    }

    #[test]
    fn point_distances_by_hand() {
        assert!((Body::Circle(V2::new(0.0, 0.0), 1.0).point_m(V2::new(3.0, 4.0)) - 4.0).abs() < 1e-12);
        assert!((sq().point_m(V2::new(3.0, 1.0)) - 1.0).abs() < 1e-12);
        assert!((sq().point_m(V2::new(1.0, 1.5)) + 0.5).abs() < 1e-12, "inside: negative depth");
        assert!((Body::Wall(V2::new(0.0, 0.0), V2::new(4.0, 0.0), 0.4).point_m(V2::new(2.0, 1.0)) - 0.8).abs() < 1e-12);
    }

    #[test]
    fn a_cable_passing_an_obstacle_is_closer_than_its_ends() {
        let c = Body::Circle(V2::new(0.0, 0.0), 1.0);
        // Ends 5 m from the centre, the segment passes 2 m from it.
        let (a, b) = (V2::new(-4.58, 2.0), V2::new(4.58, 2.0));
        assert!((c.point_m(a) - 4.0).abs() < 0.01);
        assert!((c.segment_m(a, b) - 1.0).abs() < 1e-12);
        // Through the square: 0 (crossing), and a wall crossed gives minus its half thickness.
        assert_eq!(sq().segment_m(V2::new(-1.0, 1.0), V2::new(3.0, 1.0)), 0.0);
        assert!((Body::Wall(V2::new(0.0, -1.0), V2::new(0.0, 1.0), 0.4).segment_m(V2::new(-1.0, 0.0), V2::new(1.0, 0.0)) + 0.2).abs() < 1e-12);
    }

    #[test]
    fn a_grid_gives_a_lower_bound_along_a_cable() {
        // One occupied cell at (5, 5) of a 10 x 10 grid of 0.5 m cells: its square spans
        // [2.5, 3.0] x [2.5, 3.0] m.
        let mut occ = vec![false; 100];
        occ[5 * 10 + 5] = true;
        let g = Grid::new(10, 10, 0.5, [0.0, 0.0], occ).unwrap();
        let o = Obstacles { bodies: Vec::new(), grid: Some(g) };
        let exact = Body::Polygon(vec![V2::new(2.5, 2.5), V2::new(3.0, 2.5), V2::new(3.0, 3.0), V2::new(2.5, 3.0)]);
        for (a, b) in [((0.2, 1.0), (4.8, 1.0)), ((0.5, 4.5), (4.5, 0.5)), ((1.0, 4.0), (1.0, 4.0))] {
            let (a, b) = (V2::new(a.0, a.1), V2::new(b.0, b.1));
            let lb = o.segment_m(a, b);
            let truth = exact.segment_m(a, b);
            assert!(lb <= truth + 1e-6 && lb > truth - 0.6, "{lb} vs {truth}");
        }
    }

    #[test]
    fn rays_by_hand() {
        let o = V2::new(-5.0, 0.0);
        let east = V2::new(1.0, 0.0);
        let c = Body::Circle(V2::new(0.0, 0.0), 1.0);
        assert!((c.ray_m(o, east).unwrap() - 4.0).abs() < 1e-12);
        assert_eq!(c.ray_m(o, -east), None, "behind the sensor");
        assert_eq!(c.ray_m(V2::new(0.5, 0.0), east), Some(0.0), "from inside");
        assert_eq!(c.ray_m(V2::new(-5.0, 1.01), east), None, "passes above");
        assert!((sq().ray_m(V2::new(-1.0, 1.0), east).unwrap() - 1.0).abs() < 1e-12);
        assert!((sq().ray_m(V2::new(1.0, 5.0), V2::new(0.0, -1.0)).unwrap() - 3.0).abs() < 1e-12);
        // A wall 0.4 m thick along y = 0: hit its side at y = 0.2, and its round end at x = 4.2.
        let w = Body::Wall(V2::new(0.0, 0.0), V2::new(4.0, 0.0), 0.4);
        assert!((w.ray_m(V2::new(2.0, 3.0), V2::new(0.0, -1.0)).unwrap() - 2.8).abs() < 1e-12);
        assert!((w.ray_m(V2::new(10.0, 0.0), -east).unwrap() - 5.8).abs() < 1e-12);
    }

    #[test]
    fn a_ray_stops_where_the_clearance_reaches_zero() {
        let bodies = vec![Body::Circle(V2::new(3.0, 2.0), 0.7), sq(), Body::Wall(V2::new(-3.0, -4.0), V2::new(-1.0, 3.0), 0.3)];
        let o = Obstacles { bodies, grid: None };
        let origin = V2::new(-1.5, -1.0);
        let mut hits = 0;
        for k in 0..360 {
            let a = (k as f64).to_radians();
            let d = V2::new(a.cos(), a.sin());
            match o.ray_m(origin, d, 20.0) {
                Some(t) => {
                    hits += 1;
                    assert!(o.point_m(origin + d * t).abs() < 1e-9, "surface at {k} deg");
                    // Nothing nearer along the ray: the clearance never reaches zero before.
                    for f in 1..50 {
                        assert!(o.point_m(origin + d * (t * f as f64 / 50.0)) > 0.0, "{k} deg, {f}/50");
                    }
                }
                None => {
                    for f in 0..=200 {
                        assert!(o.point_m(origin + d * (20.0 * f as f64 / 200.0)) > 0.0, "missed at {k} deg");
                    }
                }
            }
        }
        assert!(hits > 60 && hits < 340, "{hits}");
        assert_eq!(o.ray_m(origin, V2::new(1.0, 0.0), 0.1), None, "beyond the range");
        assert_eq!(o.ray_m(origin, V2::zeros(), 5.0), None, "no direction");
    }

    #[test]
    fn a_ray_on_a_grid_stops_at_the_first_occupied_square() {
        let mut occ = vec![false; 100];
        occ[5 * 10 + 5] = true; // [2.5, 3.0] x [2.5, 3.0] m
        let g = Grid::new(10, 10, 0.5, [0.0, 0.0], occ).unwrap();
        let o = Obstacles { bodies: Vec::new(), grid: Some(g) };
        let cell = Body::Polygon(vec![V2::new(2.5, 2.5), V2::new(3.0, 2.5), V2::new(3.0, 3.0), V2::new(2.5, 3.0)]);
        for (org, dir) in [((0.1, 2.7), (1.0, 0.0)), ((0.2, 0.3), (1.0, 1.0)), ((4.9, 4.8), (-1.0, -0.9)), ((-3.0, 2.6), (1.0, 0.0)), ((2.75, 9.0), (0.0, -1.0))] {
            let (org, dir) = (V2::new(org.0, org.1), V2::new(dir.0, dir.1));
            let exact = cell.ray_m(org, dir.normalize());
            let grid = o.ray_m(org, dir, 50.0);
            assert!(exact.is_some() && (grid.unwrap() - exact.unwrap()).abs() < 1e-9, "{org:?} {dir:?}: {grid:?} vs {exact:?}");
        }
        assert_eq!(o.ray_m(V2::new(0.1, 0.1), V2::new(1.0, 0.0), 50.0), None);
        assert_eq!(o.ray_m(V2::new(0.1, 2.7), V2::new(1.0, 0.0), 2.0), None, "out of range");
    }
}
