//! Take-off cable calibration and the tension share (docs/design.md, "Calibration aboard").
//!
//! At the taut take-off every UAV knows its own position, the load's, and (from the team link)
//! every neighbour's. With what it knows on its own (the declared load mass, the nominal cable
//! stiffness, the plausible range of its cable) it computes:
//!
//! - the **tension share** `T = m_L g / sum_j cos(theta_j)`, `cos(theta_j) = (z_j - z_l) / d_j`,
//!   `d_j = |p_j - p_l|`: the equal tension that holds the load's weight with the team's measured
//!   leans (vertical balance of the load at rest, `sum_j T cos(theta_j) = m_L g`; REFERENCE §6
//!   for the equal-share take-off). For a symmetric formation at one lean this is the familiar
//!   `m_L g / (n cos(theta))`;
//! - the **static stretch** `e = T / k` of its cable under that share (Hooke, nominal `k`);
//! - its **cable length** `L = d_i - e`: the measured UAV-load distance less the stretch.
//!
//! The lean comes from the **measured geometry**, not from parameters: the share is about where
//! the cables physically are at take-off (the tray height `H` and the formation radius are the
//! controller's abstraction; the firmware does not even know the radius), every UAV computes it
//! from the same take-off data so the whole team agrees on one share, and a take-off that does
//! not match the plan shows up here instead of being assumed away.
//!
//! Implausible measurements (non-finite, a UAV not above the load, a cable flatter than
//! `min_cos_lean`, a stretch as long as the measured distance, a length outside the plausible
//! range) are typed errors: the mission does not start on them. Runs once, at mission start.

use crate::Vec3;
use core::fmt;

/// Standard gravity, m/s^2 (the value of vt-cfo and of host-sim's plant).
pub const GRAVITY_MPS2: f32 = 9.81;

/// Default flattest plausible take-off cable: cos of 60 degrees from vertical. A taut start
/// flatter than this is a wrong measurement (or a formation that cannot lift: half the tension
/// goes sideways).
pub const MIN_COS_LEAN: f32 = 0.5;

/// What one UAV knows before take-off, without measuring.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibrationParams {
    /// Declared load mass `m_L`, kg.
    pub load_mass_kg: f32,
    /// Nominal cable stiffness `k`, N/m.
    pub stiffness_n_per_m: f32,
    /// Shortest plausible cable, m (exclusive; the altitude law's height floor, which must be
    /// below the cable length).
    pub min_length_m: f32,
    /// Longest plausible cable, m (inclusive).
    pub max_length_m: f32,
    /// Flattest plausible lean, cos of the angle from vertical (default [`MIN_COS_LEAN`]).
    pub min_cos_lean: f32,
}

/// The calibration of one UAV's cable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Calibration {
    /// Cable length `L = d_i - e`, m.
    pub cable_length_m: f32,
    /// Static stretch `e = T / k` under the share, m.
    pub stretch_m: f32,
    /// Equal tension share `T = m_L g / sum_j cos(theta_j)`, N.
    pub tension_share_n: f32,
    /// The team's mean lean `sum_j cos(theta_j) / n` (cos of the angle from vertical).
    pub cos_lean: f32,
    /// Own measured UAV-load distance `d_i`, m.
    pub distance_m: f32,
}

/// Why a take-off measurement was refused.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CalibrationError {
    /// A parameter is NaN, infinite or out of range; names it.
    InvalidParameter(&'static str),
    /// The own index is not below the team size (or the team is empty).
    IdOutOfRange {
        /// The id given.
        id: usize,
        /// The team size.
        n_uavs: usize,
    },
    /// The load's measured position is non-finite.
    NonFiniteLoad,
    /// UAV `index`'s measured position is non-finite.
    NonFiniteUav {
        /// The UAV.
        index: usize,
    },
    /// UAV `index` is not above the load.
    NotAboveLoad {
        /// The UAV.
        index: usize,
    },
    /// UAV `index`'s cable leans flatter than `min_cos_lean`.
    TooFlat {
        /// The UAV.
        index: usize,
        /// Its measured lean, cos of the angle from vertical.
        cos_lean: f32,
    },
    /// The static stretch is not shorter than the measured distance (or is not finite).
    StretchExceedsDistance {
        /// The stretch, m.
        stretch_m: f32,
        /// The own measured distance, m.
        distance_m: f32,
    },
    /// The calibrated length is outside `(min_length_m, max_length_m]`.
    LengthOutOfRange {
        /// The calibrated length, m.
        length_m: f32,
        /// The shortest plausible cable (exclusive), m.
        min_m: f32,
        /// The longest plausible cable, m.
        max_m: f32,
    },
}

impl fmt::Display for CalibrationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::InvalidParameter(name) => write!(f, "invalid calibration parameter `{name}`"),
            Self::IdOutOfRange { id, n_uavs } => write!(f, "UAV id {id} out of range for {n_uavs} UAVs"),
            Self::NonFiniteLoad => write!(f, "the load's take-off position is non-finite"),
            Self::NonFiniteUav { index } => write!(f, "UAV {index}'s take-off position is non-finite"),
            Self::NotAboveLoad { index } => write!(f, "UAV {index} is not above the load at take-off"),
            Self::TooFlat { index, cos_lean } => {
                write!(f, "UAV {index}'s cable leans too flat at take-off (cos {cos_lean:.3} from vertical)")
            }
            Self::StretchExceedsDistance { stretch_m, distance_m } => {
                write!(f, "static stretch {stretch_m:.3} m not below the measured UAV-load distance {distance_m:.3} m")
            }
            Self::LengthOutOfRange { length_m, min_m, max_m } => {
                write!(f, "calibrated cable length {length_m:.3} m outside ({min_m:.3}, {max_m:.3}] m")
            }
        }
    }
}

impl core::error::Error for CalibrationError {}

impl CalibrationParams {
    /// Checks every field.
    ///
    /// # Errors
    /// [`CalibrationError::InvalidParameter`] naming the field.
    pub fn validate(&self) -> Result<(), CalibrationError> {
        let pos = |x: f32| x.is_finite() && x > 0.0;
        let checks: [(bool, &'static str); 5] = [
            (pos(self.load_mass_kg), "calibration.load_mass_kg"),
            (pos(self.stiffness_n_per_m), "calibration.stiffness_n_per_m"),
            (pos(self.min_length_m), "calibration.min_length_m"),
            (self.max_length_m.is_finite() && self.max_length_m > self.min_length_m, "calibration.max_length_m"),
            (self.min_cos_lean > 0.0 && self.min_cos_lean <= 1.0, "calibration.min_cos_lean"),
        ];
        for (ok, name) in checks {
            if !ok {
                return Err(CalibrationError::InvalidParameter(name));
            }
        }
        Ok(())
    }
}

/// Calibrates UAV `id`'s cable from the team's measured take-off positions `uav_pos_m` (world
/// ENU, m; one per UAV, own included) and the load's `load_pos_m` (docs/design.md, "Calibration
/// aboard"). The sum over the team runs in index order, so every UAV computes the same share
/// from the same data, bit for bit.
///
/// # Errors
/// [`CalibrationError`]: invalid parameters or an implausible measurement.
pub fn calibrate(id: usize, uav_pos_m: &[Vec3], load_pos_m: &Vec3, p: &CalibrationParams) -> Result<Calibration, CalibrationError> {
    p.validate()?;
    let n = uav_pos_m.len();
    if id >= n {
        return Err(CalibrationError::IdOutOfRange { id, n_uavs: n });
    }
    if !load_pos_m.iter().all(|x| x.is_finite()) {
        return Err(CalibrationError::NonFiniteLoad);
    }
    let mut sum_cos = 0.0f32;
    let mut distance_m = 0.0f32;
    for (j, pos) in uav_pos_m.iter().enumerate() {
        if !pos.iter().all(|x| x.is_finite()) {
            return Err(CalibrationError::NonFiniteUav { index: j });
        }
        let d = pos - load_pos_m;
        if !(d.z > 0.0) {
            return Err(CalibrationError::NotAboveLoad { index: j });
        }
        let dist = vt_fpu::sqrt(d.norm_squared());
        let cos_lean = d.z / dist;
        // `!(>=)`: a NaN lean (an overflowing distance) is refused too.
        if !(cos_lean >= p.min_cos_lean) {
            return Err(CalibrationError::TooFlat { index: j, cos_lean });
        }
        sum_cos += cos_lean;
        if j == id {
            distance_m = dist;
        }
    }
    // Vertical balance of the load at rest under equal tensions (module docs).
    let tension_share_n = p.load_mass_kg * GRAVITY_MPS2 / sum_cos;
    let stretch_m = tension_share_n / p.stiffness_n_per_m;
    if !(stretch_m < distance_m) {
        return Err(CalibrationError::StretchExceedsDistance { stretch_m, distance_m });
    }
    let cable_length_m = distance_m - stretch_m;
    if !(cable_length_m > p.min_length_m && cable_length_m <= p.max_length_m) {
        return Err(CalibrationError::LengthOutOfRange { length_m: cable_length_m, min_m: p.min_length_m, max_m: p.max_length_m });
    }
    Ok(Calibration { cable_length_m, stretch_m, tension_share_n, cos_lean: sum_cos / n as f32, distance_m })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn params() -> CalibrationParams {
        CalibrationParams { load_mass_kg: 4.0, stiffness_n_per_m: 500.0, min_length_m: 1.0, max_length_m: 20.0, min_cos_lean: MIN_COS_LEAN }
    }

    /// Four UAVs on 3-4-5 triangles around a load at (1, 2, 3): every cable 5 m from the load,
    /// 4 m above it, lean cos 0.8.
    fn square() -> (Vec<Vec3>, Vec3) {
        let load = Vec3::new(1.0, 2.0, 3.0);
        let uavs = [(3.0, 0.0), (0.0, 3.0), (-3.0, 0.0), (0.0, -3.0)].iter().map(|&(x, y)| load + Vec3::new(x, y, 4.0)).collect();
        (uavs, load)
    }

    #[test]
    fn nominal_geometry_gives_the_textbook_values() {
        let (uavs, load) = square();
        let p = params();
        for id in 0..4 {
            let c = calibrate(id, &uavs, &load, &p).unwrap();
            // Every difference and distance is exact in f32 here (d = 5); each lean is 4/5
            // correctly rounded, summed in index order.
            assert_eq!(c.distance_m, 5.0);
            let sum = 0.8f32 + 0.8 + 0.8 + 0.8;
            assert_eq!(c.cos_lean, sum / 4.0);
            // T = m g / (n cos) = 4 * 9.81 / 3.2 = 12.2625 N; e = T / k; L = d - e.
            let share = 4.0 * GRAVITY_MPS2 / sum;
            assert_eq!(c.tension_share_n, share);
            assert!((share - 12.2625).abs() < 2e-6, "{share}");
            assert_eq!(c.stretch_m, share / 500.0);
            assert_eq!(c.cable_length_m, 5.0 - share / 500.0);
            // Vertical balance: n T cos = m g.
            assert!((4.0 * c.tension_share_n * 0.8 - 4.0 * GRAVITY_MPS2).abs() < 1e-5);
        }
    }

    #[test]
    fn uneven_leans_share_the_weight_by_the_sum_of_cosines() {
        let load = Vec3::zeros();
        // cos 0.8 (3-4-5) and cos 0.6 (4-3-5).
        let uavs = [Vec3::new(3.0, 0.0, 4.0), Vec3::new(-4.0, 0.0, 3.0)];
        let c = calibrate(1, &uavs, &load, &params()).unwrap();
        let expected = 4.0 * GRAVITY_MPS2 / (4.0f32 / 5.0 + 3.0f32 / 5.0);
        assert_eq!(c.tension_share_n, expected);
        assert_eq!(c.cos_lean, (4.0f32 / 5.0 + 3.0f32 / 5.0) / 2.0);
        assert_eq!(c.cable_length_m, 5.0 - expected / 500.0);
    }

    #[test]
    fn each_implausible_measurement_has_its_error() {
        let (uavs, load) = square();
        let p = params();
        let with = |k: usize, v: Vec3| {
            let mut u = uavs.clone();
            u[k] = v;
            u
        };
        assert_eq!(calibrate(4, &uavs, &load, &p), Err(CalibrationError::IdOutOfRange { id: 4, n_uavs: 4 }));
        assert_eq!(calibrate(0, &[], &load, &p), Err(CalibrationError::IdOutOfRange { id: 0, n_uavs: 0 }));
        assert_eq!(calibrate(0, &uavs, &Vec3::new(f32::NAN, 0.0, 0.0), &p), Err(CalibrationError::NonFiniteLoad));
        let nan = with(2, Vec3::new(0.0, f32::INFINITY, 7.0));
        assert_eq!(calibrate(0, &nan, &load, &p), Err(CalibrationError::NonFiniteUav { index: 2 }));
        let below = with(1, load + Vec3::new(0.0, 3.0, -4.0));
        assert_eq!(calibrate(0, &below, &load, &p), Err(CalibrationError::NotAboveLoad { index: 1 }));
        let level = with(3, load + Vec3::new(0.0, -3.0, 0.0));
        assert_eq!(calibrate(0, &level, &load, &p), Err(CalibrationError::NotAboveLoad { index: 3 }));
        // 4-3-5 is cos 0.6: refused at a 0.7 floor.
        let flat = with(1, load + Vec3::new(0.0, 4.0, 3.0));
        let p07 = CalibrationParams { min_cos_lean: 0.7, ..p };
        assert_eq!(calibrate(0, &flat, &load, &p07), Err(CalibrationError::TooFlat { index: 1, cos_lean: 3.0 / 5.0 }));
        // A soft cable on a heavy load: the stretch swallows the distance.
        let soft = CalibrationParams { stiffness_n_per_m: 1.0, load_mass_kg: 100.0, ..p };
        assert!(matches!(calibrate(0, &uavs, &load, &soft), Err(CalibrationError::StretchExceedsDistance { distance_m, .. }) if distance_m == 5.0));
        // 4.975 m of cable against a 5 m floor, then a 4 m ceiling.
        let short = CalibrationParams { min_length_m: 5.0, max_length_m: 30.0, ..p };
        assert!(matches!(calibrate(0, &uavs, &load, &short), Err(CalibrationError::LengthOutOfRange { min_m, .. }) if min_m == 5.0));
        let long = CalibrationParams { min_length_m: 1.0, max_length_m: 4.0, ..p };
        assert!(matches!(calibrate(0, &uavs, &load, &long), Err(CalibrationError::LengthOutOfRange { max_m, .. }) if max_m == 4.0));
    }

    #[test]
    fn invalid_parameters_are_named() {
        let (uavs, load) = square();
        let cases: [(CalibrationParams, &str); 6] = [
            (CalibrationParams { load_mass_kg: 0.0, ..params() }, "calibration.load_mass_kg"),
            (CalibrationParams { load_mass_kg: f32::NAN, ..params() }, "calibration.load_mass_kg"),
            (CalibrationParams { stiffness_n_per_m: -1.0, ..params() }, "calibration.stiffness_n_per_m"),
            (CalibrationParams { min_length_m: 0.0, ..params() }, "calibration.min_length_m"),
            (CalibrationParams { max_length_m: 1.0, ..params() }, "calibration.max_length_m"),
            (CalibrationParams { min_cos_lean: 1.5, ..params() }, "calibration.min_cos_lean"),
        ];
        for (p, name) in cases {
            assert_eq!(calibrate(0, &uavs, &load, &p), Err(CalibrationError::InvalidParameter(name)));
        }
    }

    proptest! {
        /// Any input: a calibration that is consistent (length + stretch = distance to
        /// rounding, the share holds the weight, every value finite and in range) or an error;
        /// never a panic. Every UAV of the team computes the same share.
        #[test]
        fn any_take_off_gives_a_consistent_calibration_or_an_error(
            raw in proptest::collection::vec((-50.0f32..50.0, -50.0f32..50.0, -5.0f32..40.0), 1..12),
            load in (-50.0f32..50.0, -50.0f32..50.0, -5.0f32..5.0),
            mass in 0.1f32..200.0,
            k in 1.0f32..5000.0,
            nan_at in proptest::option::of(0usize..12),
        ) {
            let load = Vec3::new(load.0, load.1, load.2);
            let mut uavs: Vec<Vec3> = raw.iter().map(|&(x, y, z)| Vec3::new(x, y, z)).collect();
            if let Some(k) = nan_at.filter(|&k| k < uavs.len()) {
                uavs[k].y = f32::NAN;
            }
            let p = CalibrationParams { load_mass_kg: mass, stiffness_n_per_m: k, min_length_m: 0.5, max_length_m: 100.0, min_cos_lean: MIN_COS_LEAN };
            let results: Vec<_> = (0..uavs.len()).map(|id| calibrate(id, &uavs, &load, &p)).collect();
            for (id, r) in results.iter().enumerate() {
                match r {
                    Ok(c) => {
                        prop_assert!(nan_at.is_none_or(|k| k >= uavs.len()));
                        prop_assert!(c.cable_length_m > 0.5 && c.cable_length_m <= 100.0);
                        prop_assert!(c.stretch_m > 0.0 && c.tension_share_n > 0.0);
                        prop_assert!((c.cable_length_m + c.stretch_m - c.distance_m).abs() <= 1e-5 * c.distance_m.max(1.0));
                        prop_assert!((c.distance_m - (uavs[id] - load).norm()).abs() <= 1e-5 * c.distance_m);
                        let weight = c.tension_share_n * c.cos_lean * uavs.len() as f32;
                        prop_assert!((weight - mass * GRAVITY_MPS2).abs() <= 1e-4 * mass * GRAVITY_MPS2);
                        prop_assert!(c.cos_lean >= MIN_COS_LEAN && c.cos_lean <= 1.0);
                        prop_assert_eq!(c.tension_share_n.to_bits(), results.iter().find_map(|r| r.as_ref().ok()).map(|c| c.tension_share_n.to_bits()).unwrap_or(0));
                    }
                    Err(CalibrationError::InvalidParameter(_) | CalibrationError::IdOutOfRange { .. } | CalibrationError::NonFiniteLoad) => {
                        prop_assert!(false, "unexpected error {:?}", r);
                    }
                    Err(_) => {}
                }
            }
        }
    }
}
