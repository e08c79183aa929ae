//! Altitude law (the paper gives none; decision recorded in `docs/design.md`).
//!
//! Each UAV holds the altitude at which its own cable is taut with the load at its reference
//! altitude, given the current horizontal offset `r` between UAV and load:
//! `z_ref = z_l,ref + sqrt(max(L_e^2 - r^2, h_min^2))`, `L_e = L + stretch` (cable length
//! plus its static stretch under an equal share of the load). A P law turns the error into a
//! vertical velocity command for the velocity loop: `v_z = clamp(k_z (z_ref - z), +-v_z,max)`.
//! When the formation flattens in a narrow passage, `r` changes and every UAV climbs or sinks
//! so that its cable stays taut instead of going slack (which would drop the load).

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
        }
    }
}

impl VerticalParams {
    /// Checks every field.
    ///
    /// # Errors
    /// [`ControlError::InvalidParameter`] naming the bad field.
    pub fn validate(&self) -> Result<(), ControlError> {
        let checks: [(bool, &'static str); 6] = [
            (self.load_altitude_ref_m.is_finite(), "vertical.load_altitude_ref_m"),
            (self.cable_length_m.is_finite() && self.cable_length_m > 0.0, "vertical.cable_length_m"),
            (self.cable_stretch_m.is_finite() && self.cable_stretch_m >= 0.0, "vertical.cable_stretch_m"),
            (self.kz_per_s.is_finite() && self.kz_per_s > 0.0, "vertical.kz_per_s"),
            (self.vz_max_mps.is_finite() && self.vz_max_mps > 0.0, "vertical.vz_max_mps"),
            (
                self.min_height_m.is_finite() && self.min_height_m > 0.0 && self.min_height_m < self.cable_length_m,
                "vertical.min_height_m",
            ),
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
        self.load_altitude_ref_m + libm::sqrtf(h2)
    }

    /// Vertical velocity command for a UAV at altitude `z_m`, m/s.
    #[inline]
    pub fn vertical_velocity_mps(&self, z_m: f32, offset_m: f32) -> f32 {
        (self.kz_per_s * (self.altitude_ref_m(offset_m) - z_m)).clamp(-self.vz_max_mps, self.vz_max_mps)
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

    #[test]
    fn invalid_fields_are_named() {
        let p = VerticalParams { kz_per_s: f32::NAN, ..Default::default() };
        assert_eq!(p.validate(), Err(ControlError::InvalidParameter("vertical.kz_per_s")));
        let p = VerticalParams { min_height_m: 9.0, ..Default::default() };
        assert_eq!(p.validate(), Err(ControlError::InvalidParameter("vertical.min_height_m")));
    }
}
