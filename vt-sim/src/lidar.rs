//! Simulated planar LiDAR (issue 28): one 2-D range sensor per UAV, cast against the world's
//! true obstacles ([`Obstacles`]: the `[world]` list or the map file, plus the obstacles that
//! have appeared), with range noise, dropouts and the wire's centimetre resolution.
//!
//! A scan reaches the companion as MAVLink `OBSTACLE_DISTANCE` would carry it
//! (docs/protocol.md, "Range scans"): ranges in whole centimetres, `UINT16_MAX` for a beam with
//! no reading, `max_distance + 1` for a beam that saw nothing within range. The scan's origin is
//! the UAV's *measured* position (what its companion knows when the scan arrives), while the
//! beams leave the *true* one: a position error displaces what the map records, as it does on
//! an aircraft.
//!
//! The figures of a small 2-D LiDAR (Slamtec RPLIDAR S2: 360 deg, 0.05-30 m, 10 Hz, +-3 cm)
//! set the defaults, thinned to the 72 sectors of `OBSTACLE_DISTANCE` and a 15 m range.

use crate::disturbance::Noise;
use crate::obstacles::Obstacles;
use nalgebra::Vector2;
use serde::Deserialize;
use vt_map::{Return, Scan, MAX_BEAMS};

type V2 = Vector2<f64>;

/// Angle between the rays a sector's return is the closest of, deg (a 2-D LiDAR's angular
/// resolution: the RPLIDAR S2's 0.12 deg, thinned).
pub const RAY_SPACING_DEG: f64 = 0.5;

/// `[sensors.lidar]`: the planar range sensor every UAV carries.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LidarSpec {
    /// Field of view, deg (centred on east when below 360; default 360).
    #[serde(default = "default_fov")]
    pub fov_deg: f64,
    /// Beams per scan (1..=72, `OBSTACLE_DISTANCE`'s sectors; default 72).
    #[serde(default = "default_beams")]
    pub beams: usize,
    /// Maximum range, m (default 15).
    #[serde(default = "default_range")]
    pub range_m: f64,
    /// Scans per second (default 10; at most the high-level rate, which carries them).
    #[serde(default = "default_rate")]
    pub rate_hz: f64,
    /// Range noise, 1 sigma, m (default 0.03).
    #[serde(default = "default_noise")]
    pub noise_m: f64,
    /// Probability that a beam returns no reading (default 0).
    #[serde(default)]
    pub dropout: f64,
}

fn default_fov() -> f64 {
    360.0
}
fn default_beams() -> usize {
    MAX_BEAMS
}
fn default_range() -> f64 {
    15.0
}
fn default_rate() -> f64 {
    10.0
}
fn default_noise() -> f64 {
    0.03
}

impl Default for LidarSpec {
    fn default() -> Self {
        Self { fov_deg: default_fov(), beams: default_beams(), range_m: default_range(), rate_hz: default_rate(), noise_m: default_noise(), dropout: 0.0 }
    }
}

impl LidarSpec {
    /// The first field that is out of range and why (`None`: valid); `hl_hz` is the
    /// high-level rate, which carries the scans.
    pub fn invalid(&self, hl_hz: f64) -> Option<(&'static str, String)> {
        if !(self.fov_deg > 0.0 && self.fov_deg <= 360.0) {
            return Some(("fov_deg", format!("must be in (0, 360] deg (got {})", self.fov_deg)));
        }
        if !(1..=MAX_BEAMS).contains(&self.beams) {
            return Some(("beams", format!("must be 1..={MAX_BEAMS} (OBSTACLE_DISTANCE's sectors; got {})", self.beams)));
        }
        // OBSTACLE_DISTANCE carries centimetres in a u16 below its two reserved values.
        if !(self.range_m > 0.0 && self.range_m <= 600.0) {
            return Some(("range_m", format!("must be in (0, 600] m (got {})", self.range_m)));
        }
        if !(self.rate_hz > 0.0 && self.rate_hz <= hl_hz) {
            return Some(("rate_hz", format!("must be in (0, {hl_hz}] Hz, the high-level rate that carries the scans (got {})", self.rate_hz)));
        }
        if !(self.noise_m >= 0.0 && self.noise_m <= 1.0) {
            return Some(("noise_m", format!("must be in [0, 1] m (got {})", self.noise_m)));
        }
        if !(0.0..1.0).contains(&self.dropout) {
            return Some(("dropout", format!("must be in [0, 1) (got {})", self.dropout)));
        }
        None
    }

    /// Angle between beams, rad: the field of view over the beams (a full turn has no
    /// duplicate beam at 360 deg).
    pub fn increment_rad(&self) -> f64 {
        let fov = self.fov_deg.to_radians();
        if self.fov_deg >= 360.0 || self.beams < 2 {
            fov / self.beams as f64
        } else {
            fov / (self.beams - 1) as f64
        }
    }

    /// Direction of beam 0, ENU, rad (the field of view centred on east).
    pub fn first_angle_rad(&self) -> f64 {
        if self.fov_deg >= 360.0 {
            0.0
        } else {
            -0.5 * self.fov_deg.to_radians()
        }
    }
}

/// A range on the wire: whole centimetres (`OBSTACLE_DISTANCE.distances`), m: the companion's
/// decoder itself (`vt_companion::scans::range_m`), so SIL and the wire agree bit for bit.
pub fn wire_range_m(cm: u16) -> f32 {
    vt_companion::scans::range_m(cm)
}

/// The sensors of a team: one per UAV, seeded.
#[derive(Debug, Clone)]
pub struct Lidar {
    spec: LidarSpec,
    noise: Noise,
}

impl Lidar {
    /// The team's sensors for `spec`, noise stream of `seed`.
    pub fn new(spec: LidarSpec, seed: u64) -> Self {
        Self { spec, noise: Noise::new(seed, 0x11DA_5CA7) }
    }

    /// The sensor's figures.
    pub fn spec(&self) -> &LidarSpec {
        &self.spec
    }

    /// One scan from the true position `true_m`, reported at the measured position
    /// `measured_m` (both horizontal, m) against `world`.
    pub fn scan(&mut self, world: &Obstacles, true_m: V2, measured_m: V2) -> Scan {
        let s = &self.spec;
        let (first, inc) = (s.first_angle_rad(), s.increment_rad());
        let mut out = Scan::new(vt_map::Vec2::new(measured_m.x as f32, measured_m.y as f32), first as f32, inc as f32, wire_range_m(range_cm(s.range_m)));
        // Each beam is a sector: the closest return of rays across it, as a 2-D LiDAR's points
        // are thinned into OBSTACLE_DISTANCE's sectors (PX4 keeps the minimum per sector).
        let rays = (inc.abs().to_degrees() / RAY_SPACING_DEG).ceil().max(1.0) as usize;
        for k in 0..s.beams.min(MAX_BEAMS) {
            let centre = first + k as f64 * inc;
            let truth = (0..rays)
                .filter_map(|u| {
                    let a = centre + inc * ((u as f64 + 0.5) / rays as f64 - 0.5);
                    world.ray_m(true_m, V2::new(a.cos(), a.sin()), s.range_m)
                })
                .reduce(f64::min);
            // Draw both every beam, hit or not, so one beam's outcome never shifts the others'.
            let (dropped, n) = (self.noise.uniform() < s.dropout, self.noise.gauss() * s.noise_m);
            let r = if dropped {
                Return::Unknown
            } else {
                match truth {
                    Some(t) => {
                        let cm = ((t + n).max(0.01) * 100.0).round();
                        if cm > f64::from(range_cm(s.range_m)) {
                            Return::Clear
                        } else {
                            Return::Hit(wire_range_m(cm as u16))
                        }
                    }
                    None => Return::Clear,
                }
            };
            // MAX_BEAMS bounds the loop: the push cannot fail.
            let _ = out.returns.push(r);
        }
        out
    }
}

/// A range in whole centimetres (the validated range is at most 600 m: no overflow).
fn range_cm(m: f64) -> u16 {
    (m * 100.0).round().clamp(1.0, 60_000.0) as u16
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::Shape;

    #[test]
    fn a_scan_sees_a_circle_where_it_is() {
        let world = Obstacles::of_shapes(&[Shape::Circle { center_m: [5.0, 0.0], radius_m: 1.0 }]);
        let mut l = Lidar::new(LidarSpec { noise_m: 0.0, ..LidarSpec::default() }, 1);
        let s = l.scan(&world, V2::zeros(), V2::zeros());
        assert_eq!(s.returns.len(), 72);
        // Beam 0 points east: 4 m to the surface.
        assert_eq!(s.returns[0], Return::Hit(wire_range_m(400)));
        // The circle subtends +-11.5 deg: the sectors of beams 0, +-1, +-2 (+-12.5 deg) see it.
        let hits: Vec<usize> = (0..72).filter(|k| matches!(s.returns[*k], Return::Hit(_))).collect();
        assert_eq!(hits, vec![0, 1, 2, 70, 71]);
        // Beam 2's sector (7.5-12.5 deg) sees the circle first along its 7.75 deg ray:
        // 5 cos a - sqrt(1 - 25 sin^2 a) = 4.217 m.
        assert_eq!(s.returns[2], Return::Hit(wire_range_m(422)));
        assert_eq!(s.returns[36], Return::Clear);
        assert!((s.increment_rad - 5f32.to_radians()).abs() < 1e-6);
    }

    #[test]
    fn noise_and_dropouts_have_their_statistics_and_a_seed_repeats_them() {
        // A ring of 36 thin walls 8 m around the sensor: every beam hits.
        let ring: Vec<Shape> = (0..36)
            .map(|k| {
                let (a, b) = ((k as f64 * 10.0).to_radians(), ((k + 1) as f64 * 10.0).to_radians());
                Shape::Wall { from_m: [8.0 * a.cos(), 8.0 * a.sin()], to_m: [8.0 * b.cos(), 8.0 * b.sin()], thickness_m: 0.0 }
            })
            .collect();
        let world = Obstacles::of_shapes(&ring);
        let spec = LidarSpec { noise_m: 0.05, dropout: 0.2, ..LidarSpec::default() };
        let mut l = Lidar::new(spec.clone(), 7);
        let (mut n, mut dropped, mut sum, mut sum2) = (0, 0, 0.0, 0.0);
        let mut first = None;
        for _ in 0..200 {
            let s = l.scan(&world, V2::zeros(), V2::zeros());
            first.get_or_insert_with(|| s.clone());
            for r in &s.returns {
                match r {
                    Return::Unknown => dropped += 1,
                    Return::Hit(m) => {
                        // The chord of a 10 deg arc lies 8 cos(5 deg) to 8 m out.
                        n += 1;
                        sum += f64::from(*m);
                        sum2 += f64::from(*m) * f64::from(*m);
                    }
                    Return::Clear => panic!("the ring is within range"),
                }
            }
        }
        let total = 200 * 72;
        let rate = dropped as f64 / total as f64;
        assert!((rate - 0.2).abs() < 0.02, "dropout {rate}");
        let mean = sum / n as f64;
        let sd = (sum2 / n as f64 - mean * mean).sqrt();
        assert!(mean > 7.95 && mean < 8.0, "{mean}");
        assert!(sd > 0.04 && sd < 0.07, "{sd}");
        let again = Lidar::new(spec, 7).scan(&world, V2::zeros(), V2::zeros());
        assert_eq!(Some(again), first);
    }

    #[test]
    fn the_report_is_at_the_measured_position_and_ranges_are_whole_centimetres() {
        let world = Obstacles::of_shapes(&[Shape::Circle { center_m: [5.0, 0.0], radius_m: 1.0 }]);
        let mut l = Lidar::new(LidarSpec { noise_m: 0.0, fov_deg: 90.0, beams: 3, ..LidarSpec::default() }, 1);
        let s = l.scan(&world, V2::new(0.0, 0.123), V2::new(0.5, 0.0));
        assert_eq!(s.origin_m, vt_map::Vec2::new(0.5, 0.0));
        assert!((s.first_angle_rad + 45f32.to_radians()).abs() < 1e-6);
        assert!((s.increment_rad - 45f32.to_radians()).abs() < 1e-6);
        match s.returns[1] {
            // The sector's closest return: the circle's nearest point (4.0015 m away, 1.4 deg
            // south of east) lies in the sector, and the rays 0.5 deg apart miss it by < 1 cm.
            Return::Hit(m) => assert_eq!(m, wire_range_m(400)),
            r => panic!("{r:?}"),
        }
    }

    /// The default scan crosses `OBSTACLE_DISTANCE` bit for bit: its sector width is the one the
    /// companion decodes (`vt_companion::scans`, docs/protocol.md "Range scans").
    #[test]
    fn the_default_scan_crosses_the_wire_bit_for_bit() {
        let world = Obstacles::of_shapes(&[Shape::Circle { center_m: [5.0, 1.0], radius_m: 1.0 }, Shape::Wall { from_m: [-6.0, -9.0], to_m: [-6.0, 9.0], thickness_m: 0.2 }]);
        let mut l = Lidar::new(LidarSpec { dropout: 0.1, ..LidarSpec::default() }, 3);
        for k in 0..20 {
            let s = l.scan(&world, V2::new(0.1 * f64::from(k), 0.0), V2::new(0.1 * f64::from(k), 0.05));
            let origin = vt_companion::Vec3::new(s.origin_m.x, s.origin_m.y, 4.0);
            let msg = vt_companion::scans::encode(&s, 5, 0).expect("carried");
            assert_eq!(vt_companion::scans::decode(&msg, &origin), Some(s));
        }
    }

    #[test]
    fn bad_figures_are_named() {
        let bad = |f: fn(&mut LidarSpec)| {
            let mut s = LidarSpec::default();
            f(&mut s);
            s.invalid(50.0).map(|(field, _)| field)
        };
        assert_eq!(bad(|_| {}), None);
        assert_eq!(bad(|s| s.beams = 73), Some("beams"));
        assert_eq!(bad(|s| s.beams = 0), Some("beams"));
        assert_eq!(bad(|s| s.fov_deg = 0.0), Some("fov_deg"));
        assert_eq!(bad(|s| s.range_m = f64::NAN), Some("range_m"));
        assert_eq!(bad(|s| s.rate_hz = 60.0), Some("rate_hz"));
        assert_eq!(bad(|s| s.noise_m = -1.0), Some("noise_m"));
        assert_eq!(bad(|s| s.dropout = 1.0), Some("dropout"));
    }
}
