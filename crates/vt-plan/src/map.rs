//! Clearance maps: the distance from a point to the nearest obstacle.
//!
//! Geometric obstacles ([`Obstacle`]) give exact Euclidean distances; occupancy grids give a
//! conservative one from a distance transform ([`crate::GridMap`]). The map's rectangle bounds
//! where the generator curve may go; its edges are not obstacles (docs/planning.md).

use crate::{Lattice, NodeIndex, SweepSpace, Vec2};

/// Anything the planner can ask "how far is the nearest obstacle from here?".
pub trait ClearanceMap {
    /// The map rectangle `(min corner, max corner)`, m (ENU).
    fn bounds_m(&self) -> (Vec2, Vec2);
    /// Distance from `p_m` to the nearest obstacle, m: positive in free space, `<= 0` inside
    /// an obstacle, `f32::INFINITY` when the map holds none. Never larger than the true
    /// distance (the planner's guarantees rest on this lower bound).
    fn clearance_m(&self, p_m: Vec2) -> f32;
    /// The clearance where it is below `cap_m`; elsewhere any lower bound of it that is at least
    /// `cap_m`, m. For callers that use `min(clearance, cap)` only; maps may answer it faster.
    fn clearance_capped_m(&self, p_m: Vec2, cap_m: f32) -> f32 {
        let _ = cap_m;
        self.clearance_m(p_m)
    }
    /// A lower and an upper bound of [`Self::clearance_capped_m`]'s answer at `p_m`, m,
    /// cheaper than the answer, where the map has them ([`Self::has_cheap_bounds`]; none by
    /// default: `(-inf, +inf)`); the map may stop tightening the lower one once it reaches
    /// `enough_m`.
    fn clearance_capped_bounds_m(&self, p_m: Vec2, cap_m: f32, enough_m: f32) -> (f32, f32) {
        let _ = (p_m, cap_m, enough_m);
        (f32::NEG_INFINITY, f32::INFINITY)
    }
    /// Whether [`Self::clearance_capped_bounds_m`] gives bounds worth asking for (false by
    /// default): the planner's fit then skips the queries they decide.
    fn has_cheap_bounds(&self) -> bool {
        false
    }
    /// The clearance at every node `k` of `lat`, m, handed to `out(k, c)`, when the map has a
    /// faster way than a query a node: each value never above the true distance, and at least
    /// [`Self::clearance_capped_m`]'s but for a rounding guard (1e-4 cells on a grid). False
    /// when it has none (the default) or `space` is too small (then `out` may have been
    /// called for some nodes).
    fn lattice_clearances_m<I: NodeIndex>(&self, lat: &Lattice, out: &mut impl FnMut(usize, f32), space: SweepSpace<'_, I>) -> bool {
        let _ = (lat, out, space);
        false
    }
    /// Whether `p_m` lies inside the map rectangle.
    fn contains(&self, p_m: Vec2) -> bool {
        let (lo, hi) = self.bounds_m();
        p_m.x >= lo.x && p_m.x <= hi.x && p_m.y >= lo.y && p_m.y <= hi.y
    }
}

/// One geometric obstacle (vertical prism, seen from above).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Obstacle<'a> {
    /// A disc (vertical cylinder).
    Circle {
        /// Centre, m.
        center_m: Vec2,
        /// Radius, m.
        radius_m: f32,
    },
    /// A simple polygon (convex or not), vertices in order (either orientation), closed
    /// implicitly.
    Polygon(&'a [Vec2]),
    /// A wall: the segment `a`-`b` thickened by `thickness_m / 2` on each side (rounded ends).
    Wall {
        /// First end, m.
        a_m: Vec2,
        /// Second end, m.
        b_m: Vec2,
        /// Full thickness, m.
        thickness_m: f32,
    },
}

/// Distance from `p` to the segment `a`-`b`, m.
pub fn segment_distance_m(p: Vec2, a: Vec2, b: Vec2) -> f32 {
    let e = b - a;
    let len2 = e.norm_squared();
    let t = if len2 > 0.0 { ((p - a).dot(&e) / len2).clamp(0.0, 1.0) } else { 0.0 };
    vt_fpu::norm(&(p - (a + e * t)))
}

/// Whether `p` lies inside the polygon (crossing-number rule, boundary counts as either).
pub fn polygon_contains(vertices: &[Vec2], p: Vec2) -> bool {
    let mut inside = false;
    let mut prev = match vertices.last() {
        Some(v) => *v,
        None => return false,
    };
    for &v in vertices {
        if (v.y > p.y) != (prev.y > p.y) {
            let x_cross = v.x + (p.y - v.y) * (prev.x - v.x) / (prev.y - v.y);
            if p.x < x_cross {
                inside = !inside;
            }
        }
        prev = v;
    }
    inside
}

impl Obstacle<'_> {
    /// Signed distance from `p_m` to this obstacle, m (negative inside).
    pub fn signed_distance_m(&self, p_m: Vec2) -> f32 {
        match *self {
            Self::Circle { center_m, radius_m } => vt_fpu::norm(&(p_m - center_m)) - radius_m,
            Self::Wall { a_m, b_m, thickness_m } => segment_distance_m(p_m, a_m, b_m) - 0.5 * thickness_m,
            Self::Polygon(vertices) => {
                let mut d = f32::INFINITY;
                let mut prev = match vertices.last() {
                    Some(v) => *v,
                    None => return f32::INFINITY,
                };
                for &v in vertices {
                    d = d.min(segment_distance_m(p_m, prev, v));
                    prev = v;
                }
                if polygon_contains(vertices, p_m) {
                    -d
                } else {
                    d
                }
            }
        }
    }
}

/// A rectangle of geometric obstacles with exact clearance.
#[derive(Debug, Clone, Copy)]
pub struct ObstacleMap<'a> {
    /// Lower-left corner, m.
    pub min_m: Vec2,
    /// Upper-right corner, m.
    pub max_m: Vec2,
    /// The obstacles.
    pub obstacles: &'a [Obstacle<'a>],
}

impl ClearanceMap for ObstacleMap<'_> {
    fn bounds_m(&self) -> (Vec2, Vec2) {
        (self.min_m, self.max_m)
    }

    fn clearance_m(&self, p_m: Vec2) -> f32 {
        self.obstacles.iter().map(|o| o.signed_distance_m(p_m)).fold(f32::INFINITY, f32::min)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SQUARE: [Vec2; 4] = [Vec2::new(0.0, 0.0), Vec2::new(2.0, 0.0), Vec2::new(2.0, 2.0), Vec2::new(0.0, 2.0)];

    #[test]
    fn distances_by_hand() {
        let c = Obstacle::Circle { center_m: Vec2::new(1.0, 1.0), radius_m: 0.5 };
        assert!((c.signed_distance_m(Vec2::new(4.0, 5.0)) - 4.5).abs() < 1e-6);
        let w = Obstacle::Wall { a_m: Vec2::new(0.0, 0.0), b_m: Vec2::new(10.0, 0.0), thickness_m: 0.4 };
        assert!((w.signed_distance_m(Vec2::new(5.0, 3.0)) - 2.8).abs() < 1e-6);
        assert!((w.signed_distance_m(Vec2::new(13.0, 4.0)) - 4.8).abs() < 1e-6);
        let p = Obstacle::Polygon(&SQUARE);
        assert!((p.signed_distance_m(Vec2::new(5.0, 1.0)) - 3.0).abs() < 1e-6);
        assert!((p.signed_distance_m(Vec2::new(1.0, 1.5)) + 0.5).abs() < 1e-6);
    }

    #[test]
    fn non_convex_polygon_inside_test() {
        // A "U": the notch (1.5, 2.5) is outside, the arms are inside.
        let u = [
            Vec2::new(0.0, 0.0), Vec2::new(3.0, 0.0), Vec2::new(3.0, 3.0), Vec2::new(2.0, 3.0),
            Vec2::new(2.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 3.0), Vec2::new(0.0, 3.0),
        ];
        assert!(!polygon_contains(&u, Vec2::new(1.5, 2.5)));
        assert!(polygon_contains(&u, Vec2::new(0.5, 2.5)));
        assert!(polygon_contains(&u, Vec2::new(1.5, 0.5)));
        let d = Obstacle::Polygon(&u).signed_distance_m(Vec2::new(1.5, 2.5));
        assert!((d - 0.5).abs() < 1e-6);
    }

    #[test]
    fn map_clearance_is_the_nearest_obstacle() {
        let obs = [
            Obstacle::Circle { center_m: Vec2::new(0.0, 0.0), radius_m: 1.0 },
            Obstacle::Circle { center_m: Vec2::new(10.0, 0.0), radius_m: 2.0 },
        ];
        let m = ObstacleMap { min_m: Vec2::new(-5.0, -5.0), max_m: Vec2::new(15.0, 5.0), obstacles: &obs };
        assert!((m.clearance_m(Vec2::new(6.0, 0.0)) - 2.0).abs() < 1e-6);
        assert!(m.contains(Vec2::new(0.0, 0.0)) && !m.contains(Vec2::new(0.0, 6.0)));
        let empty = ObstacleMap { obstacles: &[], ..m };
        assert_eq!(empty.clearance_m(Vec2::zeros()), f32::INFINITY);
    }
}
