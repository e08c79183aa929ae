//! The corridor: a chain of overlapping free discs along the searched path, and the centres
//! of their intersections (the generator curve's waypoints).

use crate::Vec2;

/// Most discs a corridor may hold (the tube's waypoints are the `MAX_DISCS - 1` intersection
/// centres plus start, goal and refinements, within `vt_tube::tube::MAX_WAYPOINTS`).
pub const MAX_DISCS: usize = 48;
/// Consecutive discs must overlap so their lens holds a disc of this fraction of the smaller
/// radius (and at least the required half-width): the curve then runs well inside both.
pub const LENS_FRACTION: f32 = 0.5;

/// One free disc of the corridor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Disc {
    /// Centre, m.
    pub center_m: Vec2,
    /// Radius (clearance less the margin, capped), m.
    pub radius_m: f32,
    /// Index of the centre along the searched path (0 = start).
    pub path_index: usize,
}

impl Disc {
    /// Whether `p_m` lies in the closed disc.
    pub fn contains(&self, p_m: Vec2) -> bool {
        (p_m - self.center_m).norm_squared() <= self.radius_m * self.radius_m
    }

    /// Radius of the largest disc inside the intersection with `other` (`(r1 + r2 - d) / 2`,
    /// capped by the smaller radius), m; negative when they do not meet.
    pub fn lens_radius_m(&self, other: &Disc) -> f32 {
        let d = vt_fpu::norm(&(other.center_m - self.center_m));
        (0.5 * (self.radius_m + other.radius_m - d)).min(self.radius_m.min(other.radius_m))
    }

    /// Centre of the intersection with `other`: the midpoint of the lens along the centre
    /// line, i.e. the centre of the largest disc inside the lens, m.
    pub fn lens_center_m(&self, other: &Disc) -> Vec2 {
        let e = other.center_m - self.center_m;
        let d = vt_fpu::norm(&e);
        if d <= 0.0 {
            return self.center_m;
        }
        let u = e / d;
        // The lens spans [max(d - r2, -r1), min(r1, d + r2)] along u from c1.
        let lo = (d - other.radius_m).max(-self.radius_m);
        let hi = self.radius_m.min(d + other.radius_m);
        self.center_m + u * (0.5 * (lo + hi))
    }

    /// Whether `other` may follow this disc in a corridor that needs `need_m` of half-width.
    pub fn chains_to(&self, other: &Disc, need_m: f32) -> bool {
        self.lens_radius_m(other) >= need_m.max(LENS_FRACTION * self.radius_m.min(other.radius_m))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lens_by_hand() {
        let a = Disc { center_m: Vec2::new(0.0, 0.0), radius_m: 2.0, path_index: 0 };
        let b = Disc { center_m: Vec2::new(3.0, 0.0), radius_m: 2.0, path_index: 1 };
        assert!((a.lens_radius_m(&b) - 0.5).abs() < 1e-6);
        assert!((a.lens_center_m(&b) - Vec2::new(1.5, 0.0)).norm() < 1e-6);
        // A small disc inside a big one: the lens is the small disc.
        let big = Disc { center_m: Vec2::zeros(), radius_m: 5.0, path_index: 0 };
        let small = Disc { center_m: Vec2::new(1.0, 0.0), radius_m: 1.0, path_index: 1 };
        assert!((big.lens_radius_m(&small) - 1.0).abs() < 1e-6);
        assert!((big.lens_center_m(&small) - small.center_m).norm() < 1e-6);
        assert!(big.chains_to(&small, 0.9) && !a.chains_to(&b, 0.9));
    }
}
