//! Altitude law (the paper gives none; decision recorded in `docs/design.md`).
//!
//! Each UAV holds the altitude at which its own cable is taut with the load at its reference
//! altitude, given the current horizontal offset `r` between UAV and load:
//! `z_ref = z_l,ref + sqrt(max(L_e^2 - r^2, h_min^2))`, `L_e = L + stretch` (cable length
//! plus its static stretch under an equal share of the load). A P law turns the error into a
//! vertical velocity command for the velocity loop: `v_z = clamp(k_z (z_ref - z), +-v_z,max)`.
//! When the formation flattens in a narrow passage, `r` changes and every UAV climbs or sinks
//! so that its cable stays taut instead of going slack (which would drop the load).
//!
//! # Load sharing (beyond the paper)
//! Ten stiff cables on one 3-DOF load over-constrain it: centimetre altitude errors move
//! newtons of tension between cables. [`VerticalLoop`] adds an altitude offset `dz` per UAV,
//! integrated from the UAV's own cable-tension estimate `T_hat = f_hat . u` (the CFO's force
//! estimate along the cable, REFERENCE §4) and the load's altitude error:
//! `dz' = -k_T (T_hat - T_share) + k_L (z_l,ref - z_l)`, `|dz| <= dz_max`.
//! At equilibrium every UAV sees `k_T (T_hat_i - T_share) = k_L e_l`: all cables carry the same
//! tension, and the common mode (all UAVs up or down together, which tension cannot see) is
//! fixed by the load altitude error `e_l`. Only own and load data are used (Remark 2).

use crate::ControlError;

/// Parameters of one UAV's altitude law.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VerticalParams {
    /// Load altitude reference `z_l,ref`, m.
    pub load_altitude_ref_m: f32,
    /// This UAV's cable length `L`, m.
    pub cable_length_m: f32,
    /// Expected static cable stretch, m (0 if unknown: the load then hangs that much lower).
    pub cable_stretch_m: f32,
    /// Proportional gain `k_z`, 1/s.
    pub kz_per_s: f32,
    /// Vertical speed limit, m/s.
    pub vz_max_mps: f32,
    /// Smallest height of the UAV above the load reference, m.
    pub min_height_m: f32,
    /// Nominal tension share `T_share` of this cable, N (0 disables load sharing).
    pub tension_share_n: f32,
    /// Load-sharing gain `k_T`, (m/s)/N.
    pub share_gain_mps_per_n: f32,
    /// Load-altitude gain `k_L` of the sharing integrator, 1/s.
    pub load_altitude_gain_per_s: f32,
    /// Bound on the sharing offset `|dz|`, m.
    pub share_offset_max_m: f32,
}

impl Default for VerticalParams {
    /// 8 m cable, load held at 5 m, `k_z` = 1/s, 1 m/s limit.
    fn default() -> Self {
        Self {
            load_altitude_ref_m: 5.0,
            cable_length_m: 8.0,
            cable_stretch_m: 0.0,
            kz_per_s: 1.0,
            vz_max_mps: 1.0,
            min_height_m: 1.0,
            tension_share_n: 0.0,
            share_gain_mps_per_n: 0.0,
            load_altitude_gain_per_s: 0.0,
            share_offset_max_m: 0.0,
        }
    }
}

impl VerticalParams {
    /// Checks every field.
    ///
    /// # Errors
    /// [`ControlError::InvalidParameter`] naming the bad field.
    pub fn validate(&self) -> Result<(), ControlError> {
        let nonneg = |x: f32| x.is_finite() && x >= 0.0;
        let checks: [(bool, &'static str); 10] = [
            (self.load_altitude_ref_m.is_finite(), "vertical.load_altitude_ref_m"),
            (self.cable_length_m.is_finite() && self.cable_length_m > 0.0, "vertical.cable_length_m"),
            (self.cable_stretch_m.is_finite() && self.cable_stretch_m >= 0.0, "vertical.cable_stretch_m"),
            (self.kz_per_s.is_finite() && self.kz_per_s > 0.0, "vertical.kz_per_s"),
            (self.vz_max_mps.is_finite() && self.vz_max_mps > 0.0, "vertical.vz_max_mps"),
            (
                self.min_height_m.is_finite() && self.min_height_m > 0.0 && self.min_height_m < self.cable_length_m,
                "vertical.min_height_m",
            ),
            (nonneg(self.tension_share_n), "vertical.tension_share_n"),
            (nonneg(self.share_gain_mps_per_n), "vertical.share_gain_mps_per_n"),
            (nonneg(self.load_altitude_gain_per_s), "vertical.load_altitude_gain_per_s"),
            (nonneg(self.share_offset_max_m), "vertical.share_offset_max_m"),
        ];
        for (ok, name) in checks {
            if !ok {
                return Err(ControlError::InvalidParameter(name));
            }
        }
        Ok(())
    }

    /// Altitude reference for a horizontal UAV-load offset `offset_m`, m.
    #[inline]
    pub fn altitude_ref_m(&self, offset_m: f32) -> f32 {
        let le = self.cable_length_m + self.cable_stretch_m;
        let h2 = (le * le - offset_m * offset_m).max(self.min_height_m * self.min_height_m);
        self.load_altitude_ref_m + vt_fpu::sqrt(h2)
    }

    /// Vertical velocity command for a UAV at altitude `z_m`, m/s.
    #[inline]
    pub fn vertical_velocity_mps(&self, z_m: f32, offset_m: f32) -> f32 {
        vt_tube::limit(self.kz_per_s * (self.altitude_ref_m(offset_m) - z_m), -self.vz_max_mps, self.vz_max_mps)
    }
}

/// What the load-sharing integrator integrates ([`VerticalLoop::set_load_altitude_ref`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sharing {
    /// Nothing: the offset is held (a load on the ground, slack cables).
    Off,
    /// The own tension's error alone: the offsets even the cables out, their common mode is
    /// held (a descent: the load lags a falling reference, and the load-altitude term would
    /// wind the offsets down into the touchdown; docs/design.md, "The descent shares the load").
    Tension,
    /// The tension's error and the load's altitude error (the law above; climb and transport).
    Full,
}

/// The altitude law with its load-sharing integrator (one per UAV).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VerticalLoop {
    params: VerticalParams,
    offset_m: f32,
    sharing: Sharing,
}

impl VerticalLoop {
    /// A loop with zero sharing offset.
    pub fn new(params: VerticalParams) -> Self {
        Self { params, offset_m: 0.0, sharing: Sharing::Full }
    }

    /// Moves the load altitude reference to `z_m` (the ground sequence's ramp,
    /// [`crate::phases`]) and sets what the sharing integrator integrates (off: the offset is
    /// held; a load resting on the ground or slack cables must not wind it up).
    pub fn set_load_altitude_ref(&mut self, z_m: f32, sharing: Sharing) {
        if z_m.is_finite() {
            self.params.load_altitude_ref_m = z_m;
        }
        self.sharing = sharing;
    }

    /// The parameters.
    pub fn params(&self) -> &VerticalParams {
        &self.params
    }

    /// Current load-sharing offset `dz`, m.
    pub fn offset_m(&self) -> f32 {
        self.offset_m
    }

    /// Vertical velocity command, m/s: the taut-cable altitude law plus the sharing offset.
    ///
    /// `uav_m`/`load_m` are own and load positions (finite; the caller checks), `force_n` the
    /// CFO's estimate of the cable force on this UAV (`None` or non-finite: the integrator
    /// holds). `dt_s` is the step (non-finite or <= 0: the integrator holds).
    pub fn update(&mut self, uav_m: &crate::Vec3, load_m: &crate::Vec3, force_n: Option<crate::Vec3>, dt_s: f32) -> f32 {
        let p = &self.params;
        let d = uav_m - load_m;
        let offset = vt_fpu::sqrt(d.x * d.x + d.y * d.y);
        let sharing = self.sharing != Sharing::Off && p.tension_share_n > 0.0 && p.share_gain_mps_per_n > 0.0;
        if let (true, Some(f), true) = (sharing, force_n, vt_fpu::positive_finite(dt_s)) {
            let len = vt_fpu::sqrt(d.norm_squared());
            if vt_fpu::all_finite(&f) && len > 0.0 {
                let tension = f.dot(&d) / len;
                let even = -p.share_gain_mps_per_n * (tension - p.tension_share_n);
                let rate = if self.sharing == Sharing::Full { even + p.load_altitude_gain_per_s * (p.load_altitude_ref_m - load_m.z) } else { even };
                let next = vt_tube::limit(self.offset_m + rate * dt_s, -p.share_offset_max_m, p.share_offset_max_m);
                if next.is_finite() {
                    self.offset_m = next;
                }
            }
        }
        let z_ref = p.altitude_ref_m(offset) + self.offset_m;
        vt_tube::limit(p.kz_per_s * (z_ref - uav_m.z), -p.vz_max_mps, p.vz_max_mps)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn taut_cable_altitude_by_hand() {
        let p = VerticalParams { cable_length_m: 5.0, load_altitude_ref_m: 2.0, ..Default::default() };
        // 3-4-5 triangle: offset 3 m -> 4 m above the load.
        assert_relative_eq!(p.altitude_ref_m(3.0), 6.0, epsilon = 1e-6);
        assert_relative_eq!(p.vertical_velocity_mps(5.5, 3.0), 0.5, epsilon = 1e-6);
        assert_relative_eq!(p.vertical_velocity_mps(0.0, 3.0), 1.0);
        // Offset beyond the cable: floor at min_height.
        assert_relative_eq!(p.altitude_ref_m(10.0), 3.0, epsilon = 1e-6);
    }

    fn sharing() -> VerticalParams {
        VerticalParams {
            cable_length_m: 5.0,
            load_altitude_ref_m: 2.0,
            tension_share_n: 10.0,
            share_gain_mps_per_n: 0.01,
            load_altitude_gain_per_s: 0.5,
            share_offset_max_m: 0.3,
            ..Default::default()
        }
    }

    #[test]
    fn overloaded_cable_lowers_its_uav() {
        let mut v = VerticalLoop::new(sharing());
        let load = crate::Vec3::new(0.0, 0.0, 2.0);
        let uav = crate::Vec3::new(3.0, 0.0, 6.0); // on its reference: 3-4-5
        // Cable force 15 N along the cable (share 10 N): the offset integrates downwards.
        let f = (uav - load).normalize() * 15.0;
        for _ in 0..10 {
            v.update(&uav, &load, Some(f), 0.1);
        }
        assert_relative_eq!(v.offset_m(), -0.05, epsilon = 1e-5);
        assert!(v.update(&uav, &load, Some(f), 0.1) < 0.0);
    }

    /// The descent's sharing (`Sharing::Tension`) evens the cables out as the full law does,
    /// but a load lagging above a falling reference winds nothing down; `Off` holds.
    #[test]
    fn the_descent_s_sharing_evens_the_tensions_and_leaves_the_common_mode() {
        let load = crate::Vec3::new(0.0, 0.0, 2.5); // 0.5 m above its reference (lagging the ramp)
        let uav = crate::Vec3::new(3.0, 0.0, 6.5);
        let u = (uav - load).normalize();
        let offset = |mode: Sharing, tension_n: f32| {
            let mut v = VerticalLoop::new(sharing());
            v.set_load_altitude_ref(2.0, mode);
            for _ in 0..10 {
                v.update(&uav, &load, Some(u * tension_n), 0.1);
            }
            v.offset_m()
        };
        // At its share: the full law winds the offset down with the load's error, the
        // descent's holds it.
        assert_relative_eq!(offset(Sharing::Full, 10.0), -0.25, epsilon = 1e-5);
        assert_eq!(offset(Sharing::Tension, 10.0), 0.0);
        // A slack cable (0 N of a 10 N share) climbs to take its share; an overloaded one sinks.
        assert_relative_eq!(offset(Sharing::Tension, 0.0), 0.1, epsilon = 1e-5);
        assert_relative_eq!(offset(Sharing::Tension, 15.0), -0.05, epsilon = 1e-5);
        assert_eq!(offset(Sharing::Off, 0.0), 0.0);
    }

    #[test]
    fn low_load_raises_everyone_and_offset_is_bounded() {
        let mut v = VerticalLoop::new(sharing());
        let load = crate::Vec3::new(0.0, 0.0, 1.0); // 1 m below its reference
        let uav = crate::Vec3::new(3.0, 0.0, 6.0);
        let f = (uav - load).normalize() * 10.0;
        for _ in 0..100 {
            v.update(&uav, &load, Some(f), 0.1);
        }
        assert_relative_eq!(v.offset_m(), 0.3, epsilon = 1e-6);
        // Missing or NaN estimate: the integrator holds.
        v.update(&uav, &load, None, 0.1);
        v.update(&uav, &load, Some(crate::Vec3::repeat(f32::NAN)), 0.1);
        assert_relative_eq!(v.offset_m(), 0.3, epsilon = 1e-6);
    }

    #[test]
    fn invalid_fields_are_named() {
        let p = VerticalParams { kz_per_s: f32::NAN, ..Default::default() };
        assert_eq!(p.validate(), Err(ControlError::InvalidParameter("vertical.kz_per_s")));
        let p = VerticalParams { min_height_m: 9.0, ..Default::default() };
        assert_eq!(p.validate(), Err(ControlError::InvalidParameter("vertical.min_height_m")));
    }
}
