//! One planar range scan in the world frame, as MAVLink `OBSTACLE_DISTANCE` carries it.
//!
//! Beam `k` leaves [`Scan::origin_m`] in the direction `first_angle_rad + k * increment_rad`
//! (ENU: counter-clockwise from east, radians) and reports a [`Return`]. The sensor's yaw is
//! already folded into `first_angle_rad`: the scan is in the world frame, not the body frame.

use crate::Vec2;

/// Beams per scan: the 72 sectors of MAVLink `OBSTACLE_DISTANCE` (5 degrees each over a turn).
pub const MAX_BEAMS: usize = 72;

/// What one beam saw.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Return {
    /// An obstacle at this range, m. Usable when finite and in `(0, max_range_m]`.
    Hit(f32),
    /// Nothing within the sensor's maximum range.
    Clear,
    /// No reading (dropout); the beam is ignored.
    Unknown,
}

/// One planar range scan in the world frame (ENU, metres, radians).
#[derive(Debug, Clone, PartialEq)]
pub struct Scan {
    /// Sensor position, world ENU, m.
    pub origin_m: Vec2,
    /// Direction of beam 0, ENU (counter-clockwise from east), rad.
    pub first_angle_rad: f32,
    /// Angle from one beam to the next, rad (counter-clockwise positive).
    pub increment_rad: f32,
    /// Sensor range, m: a [`Return::Clear`] beam frees cells out to here.
    pub max_range_m: f32,
    /// One return per beam, beam 0 first.
    pub returns: heapless::Vec<Return, MAX_BEAMS>,
}

impl Scan {
    /// A scan with no beams yet; push [`Return`]s onto [`Scan::returns`].
    pub const fn new(
        origin_m: Vec2,
        first_angle_rad: f32,
        increment_rad: f32,
        max_range_m: f32,
    ) -> Self {
        Self {
            origin_m,
            first_angle_rad,
            increment_rad,
            max_range_m,
            returns: heapless::Vec::new(),
        }
    }

    /// Whether origin, angles and range are finite and the range positive; a scan that fails
    /// this is skipped whole by [`crate::OccupancyGrid::integrate`].
    pub fn is_geometry_valid(&self) -> bool {
        self.origin_m.x.is_finite()
            && self.origin_m.y.is_finite()
            && self.first_angle_rad.is_finite()
            && self.increment_rad.is_finite()
            && self.max_range_m.is_finite()
            && self.max_range_m > 0.0
    }

    /// Direction of beam `k`, ENU (counter-clockwise from east), rad.
    pub fn beam_angle_rad(&self, k: usize) -> f32 {
        self.first_angle_rad + k as f32 * self.increment_rad
    }

    /// Unit vector along beam `k`, world ENU (NaN components when the angles are not finite).
    pub fn beam_direction(&self, k: usize) -> Vec2 {
        let a = self.beam_angle_rad(k);
        Vec2::new(libm::cosf(a), libm::sinf(a))
    }

    /// Beam `k`'s return when the map can use it: `Hit(r)` with finite `0 < r <= max_range_m`,
    /// or `Clear`; `None` for `Unknown`, a bad range, a missing beam or invalid geometry.
    pub fn usable_return(&self, k: usize) -> Option<Return> {
        if !self.is_geometry_valid() {
            return None;
        }
        match self.returns.get(k).copied()? {
            Return::Hit(r) if r.is_finite() && r > 0.0 && r <= self.max_range_m => {
                Some(Return::Hit(r))
            }
            Return::Clear => Some(Return::Clear),
            Return::Hit(_) | Return::Unknown => None,
        }
    }

    /// Where beam `k`'s ray ends, world ENU, m: the hit point, or the max-range point of a
    /// `Clear` beam; `None` when the beam is not usable ([`Scan::usable_return`]).
    pub fn end_point_m(&self, k: usize) -> Option<Vec2> {
        let range_m = match self.usable_return(k)? {
            Return::Hit(r) => r,
            Return::Clear | Return::Unknown => self.max_range_m,
        };
        Some(self.origin_m + self.beam_direction(k) * range_m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FIVE_DEG_RAD: f32 = 5.0 * core::f32::consts::PI / 180.0;

    fn scan_of(returns: &[Return]) -> Scan {
        let mut s = Scan::new(Vec2::new(1.0, 2.0), 0.0, FIVE_DEG_RAD, 10.0);
        for r in returns {
            s.returns.push(*r).unwrap();
        }
        s
    }

    #[test]
    fn beam_directions_turn_counter_clockwise() {
        let s = scan_of(&[]);
        let d = s.beam_direction(18); // 90 degrees: north
        assert!(d.x.abs() < 1e-6 && (d.y - 1.0).abs() < 1e-6);
        assert!((s.beam_direction(0) - Vec2::new(1.0, 0.0)).norm() < 1e-7);
    }

    #[test]
    fn bad_ranges_are_not_usable() {
        let s = scan_of(&[
            Return::Hit(3.0),
            Return::Hit(f32::NAN),
            Return::Hit(-1.0),
            Return::Hit(0.0),
            Return::Hit(f32::INFINITY),
            Return::Hit(10.5),
            Return::Clear,
            Return::Unknown,
        ]);
        let usable: Vec<bool> = (0..9).map(|k| s.usable_return(k).is_some()).collect();
        assert_eq!(
            usable,
            [true, false, false, false, false, false, true, false, false]
        );
        let end = s.end_point_m(0).unwrap();
        assert!((end - Vec2::new(4.0, 2.0)).norm() < 1e-6);
        let far = s.end_point_m(6).unwrap();
        assert!((far - s.origin_m).norm() - 10.0 < 1e-5);
    }

    #[test]
    fn invalid_geometry_makes_every_beam_unusable() {
        for bad in [f32::NAN, f32::INFINITY] {
            let mut s = scan_of(&[Return::Hit(3.0), Return::Clear]);
            s.increment_rad = bad;
            assert!(s.usable_return(0).is_none() && s.usable_return(1).is_none());
        }
        let mut s = scan_of(&[Return::Clear]);
        s.max_range_m = 0.0;
        assert!(s.usable_return(0).is_none());
        let mut s = scan_of(&[Return::Clear]);
        s.origin_m.y = f32::NAN;
        assert!(s.end_point_m(0).is_none());
    }
}
