//! Range scans on the wire (issue 28): MAVLink `OBSTACLE_DISTANCE` (330), the message PX4's and
//! ArduPilot's collision prevention read, to and from `vt_map::Scan` (docs/protocol.md, "Range
//! scans").
//!
//! The `mavlink` crate's common dialect carries the message's base fields only (no
//! `increment_f`, `angle_offset`, `frame` extensions), so the message's own convention holds:
//! - `distances[k]` is the sector whose centre bears `k * increment` degrees clockwise from
//!   north (world-fixed; the sensor's yaw is already taken out);
//! - one unit is a centimetre; `max_distance + 1` means nothing within range; `UINT16_MAX`
//!   means no reading; a value above `max_distance + 1` and below `UINT16_MAX` is treated as no
//!   reading too;
//! - a full turn of whole-degree sectors: `increment` divides 360 into at most 72 sectors.
//!
//! A `Scan` starts at east and turns counter-clockwise (ENU). Sector `k` of the wire is scan
//! beam `(90 / increment - k) mod n`, `n = 360 / increment`, so only increments that also divide
//! 90 are carried (5, 6, 9, 10, 15, 18, 30, 45 and 90 degrees). The message has no position:
//! the receiver gives the origin (its own position, or the sender's from the team link).
//!
//! Ranges and angles decode with the expressions the simulator uses to make them
//! ([`range_m`], [`sector_rad`]), so a scan that crosses the wire arrives bit for bit.

use crate::Vec3;
use mavlink::dialects::common::{MavDistanceSensor, OBSTACLE_DISTANCE_DATA};
use vt_map::{Return, Scan, MAX_BEAMS};

/// `distances` value of a sector with no reading.
pub const NO_READING: u16 = u16::MAX;

/// A range on the wire (whole centimetres) in metres.
#[inline]
pub fn range_m(cm: u16) -> f32 {
    f32::from(cm) * 0.01
}

/// A sector width of `deg` whole degrees in radians, as `f32` (computed in `f64` as
/// `f64::to_radians` does, then rounded once).
#[inline]
pub fn sector_rad(deg: u8) -> f32 {
    (f64::from(deg) * (core::f64::consts::PI / 180.0)) as f32
}

/// The sectors of a full turn at `increment_deg` that the wire can carry (`None`: the
/// increment does not divide 90, or a turn would need more than 72 sectors).
fn sectors(increment_deg: u8) -> Option<usize> {
    let inc = usize::from(increment_deg);
    (inc > 0 && 90 % inc == 0 && 360 / inc <= MAX_BEAMS).then(|| 360 / inc)
}

/// The scan beam of wire sector `k` (and back: the map is its own inverse).
fn beam_of(k: usize, n: usize, increment_deg: u8) -> usize {
    let east = 90 / usize::from(increment_deg.max(1));
    (east + n - k % n) % n
}

/// `scan` as `OBSTACLE_DISTANCE` (sensor `LASER`, sampled at `time_usec`), when it is a full
/// turn of whole-degree sectors starting at east counter-clockwise (the simulated LiDAR's
/// default), with `increment_deg` its sector width (`None`: the scan is not one the message
/// carries).
pub fn encode(scan: &Scan, increment_deg: u8, time_usec: u64) -> Option<OBSTACLE_DISTANCE_DATA> {
    let n = sectors(increment_deg)?;
    let max_cm = libm::roundf(scan.max_range_m * 100.0);
    if scan.returns.len() != n || scan.first_angle_rad != 0.0 || scan.increment_rad != sector_rad(increment_deg) || !(max_cm >= 1.0 && max_cm < f32::from(NO_READING - 1)) {
        return None;
    }
    let max = max_cm as u16;
    let mut msg = OBSTACLE_DISTANCE_DATA { time_usec, min_distance: 1, max_distance: max, sensor_type: MavDistanceSensor::MAV_DISTANCE_SENSOR_LASER, increment: increment_deg, ..OBSTACLE_DISTANCE_DATA::DEFAULT };
    for (k, slot) in msg.distances.iter_mut().enumerate() {
        *slot = if k < n {
            match scan.returns.get(beam_of(k, n, increment_deg)) {
                Some(Return::Hit(r)) if r.is_finite() && *r >= 0.0 => libm::roundf(r * 100.0).min(f32::from(max)) as u16,
                Some(Return::Clear) => max + 1,
                _ => NO_READING,
            }
        } else {
            NO_READING
        };
    }
    Some(msg)
}

/// The scan an `OBSTACLE_DISTANCE` carries, taken at `origin_m` (world ENU; the receiver's
/// knowledge of where the sender was). `None` for a message the convention does not cover
/// (increment 0 or not dividing 90, `max_distance` 0 or reserved).
pub fn decode(msg: &OBSTACLE_DISTANCE_DATA, origin_m: &Vec3) -> Option<Scan> {
    let n = sectors(msg.increment)?;
    if msg.max_distance == 0 || msg.max_distance >= NO_READING - 1 {
        return None;
    }
    let mut scan = Scan::new(origin_m.xy(), 0.0, sector_rad(msg.increment), range_m(msg.max_distance));
    for j in 0..n {
        let cm = msg.distances.get(beam_of(j, n, msg.increment)).copied().unwrap_or(NO_READING);
        let r = match cm {
            c if c <= msg.max_distance => Return::Hit(range_m(c)),
            c if c == msg.max_distance + 1 => Return::Clear,
            _ => Return::Unknown,
        };
        scan.returns.push(r).ok()?;
    }
    Some(scan)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scan(returns: &[Return]) -> Scan {
        let mut s = Scan::new(vt_map::Vec2::new(3.0, -2.0), 0.0, sector_rad(5), range_m(1500));
        for r in returns {
            s.returns.push(*r).unwrap();
        }
        s
    }

    #[test]
    fn east_is_sector_18_north_is_sector_0_and_the_sectors_turn_clockwise() {
        let mut rs = [Return::Clear; 72];
        rs[0] = Return::Hit(range_m(400)); // east
        rs[18] = Return::Hit(range_m(250)); // north
        rs[19] = Return::Hit(range_m(260)); // 5 deg west of north
        rs[54] = Return::Unknown; // south
        let m = encode(&scan(&rs), 5, 7).unwrap();
        assert_eq!((m.distances[18], m.distances[0], m.distances[71], m.distances[36]), (400, 250, 260, NO_READING));
        assert_eq!((m.max_distance, m.distances[1], m.increment, m.time_usec), (1500, 1501, 5, 7));
    }

    #[test]
    fn a_scan_crosses_the_wire_bit_for_bit() {
        let rs: Vec<Return> = (0..72)
            .map(|k| match k % 4 {
                0 => Return::Hit(range_m(19 * k as u16 + 11)),
                1 => Return::Clear,
                2 => Return::Unknown,
                _ => Return::Hit(range_m(1500)),
            })
            .collect();
        let s = scan(&rs);
        let back = decode(&encode(&s, 5, 0).unwrap(), &Vec3::new(3.0, -2.0, 9.0)).unwrap();
        assert_eq!(back, s);
        for (a, b) in back.returns.iter().zip(&s.returns) {
            if let (Return::Hit(x), Return::Hit(y)) = (a, b) {
                assert_eq!(x.to_bits(), y.to_bits());
            }
        }
    }

    #[test]
    fn what_the_convention_does_not_cover_is_refused_or_unknown() {
        let s = scan(&[Return::Clear; 72]);
        assert!(encode(&s, 7, 0).is_none(), "7 deg does not divide 90");
        assert!(encode(&scan(&[Return::Clear; 36]), 5, 0).is_none(), "not a full turn");
        let mut m = encode(&s, 5, 0).unwrap();
        m.distances[3] = 1600; // above max + 1, below UINT16_MAX
        m.distances[4] = 0; // touching
        let d = decode(&m, &Vec3::zeros()).unwrap();
        assert_eq!(d.returns[(18 + 72 - 3) % 72], Return::Unknown);
        assert_eq!(d.returns[(18 + 72 - 4) % 72], Return::Hit(0.0));
        for bad in [0u8, 4, 7, 200] {
            m.increment = bad;
            assert!(decode(&m, &Vec3::zeros()).is_none(), "increment {bad}");
        }
        m.increment = 10;
        let d = decode(&m, &Vec3::zeros()).unwrap();
        assert_eq!(d.returns.len(), 36);
        m.max_distance = 0;
        assert!(decode(&m, &Vec3::zeros()).is_none());
    }
}
