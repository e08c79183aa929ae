//! The virtual tray: node projection (eq:2-4) and the velocity mapping back to the UAV
//! (eq:2-20), both with the printing errors corrected as in REFERENCE §3.
//!
//! The tray is the horizontal plane `z_u = z_l + H` (`H` = [`TrayParams::height_above_load_m`]).
//! UAV i's node is where the straight cable line from the load through the UAV meets it:
//! `q_i = p_l + H / (z_i - z_l) (p_i - p_l)` (horizontal part). eq:2-4 prints the ratio as
//! `|z_u - z_l| / |z_u - z_i|`, which does not put the node on the plane.
//! The inverse for velocities (altitudes held) is
//! `v_i,d = v_l + (z_i - z_l) / H (vbar_i,d - v_l)` (eq:2-20 prints the ratio inverted).

use crate::{ControlError, Vec2, Vec3};

/// Geometry of the virtual tray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrayParams {
    /// Height `H = z_u - z_l` of the tray plane above the load, m (> 0).
    pub height_above_load_m: f32,
    /// Smallest `z_i - z_l` used by the projection, m (> 0): a UAV at or below this height
    /// above the load is projected as if it were at this height (flagged).
    pub min_height_above_load_m: f32,
}

impl Default for TrayParams {
    /// Tray 10 m above the load (REFERENCE §6: 8.5 % capacity margin), floor 0.5 m.
    fn default() -> Self {
        Self { height_above_load_m: 10.0, min_height_above_load_m: 0.5 }
    }
}

impl TrayParams {
    /// Checks every field.
    ///
    /// # Errors
    /// [`ControlError::InvalidParameter`] naming the bad field.
    pub fn validate(&self) -> Result<(), ControlError> {
        if !(self.height_above_load_m.is_finite() && self.height_above_load_m > 0.0) {
            return Err(ControlError::InvalidParameter("tray.height_above_load_m"));
        }
        if !(self.min_height_above_load_m.is_finite() && self.min_height_above_load_m > 0.0) {
            return Err(ControlError::InvalidParameter("tray.min_height_above_load_m"));
        }
        Ok(())
    }

    /// Height of the UAV above the load used by the projection, m, and whether it was floored.
    #[inline]
    fn height(&self, uav_z_m: f32, load_z_m: f32) -> (f32, bool) {
        let dz = uav_z_m - load_z_m;
        if dz >= self.min_height_above_load_m {
            (dz, false)
        } else {
            (self.min_height_above_load_m, true)
        }
    }

    /// Node of a UAV at `uav_m` for a load at `load_m` (eq:2-4 corrected), m, and whether
    /// the height floor was used. Inputs must be finite (the controller checks).
    #[inline]
    pub fn project(&self, uav_m: &Vec3, load_m: &Vec3) -> (Vec2, bool) {
        let (dz, floored) = self.height(uav_m.z, load_m.z);
        let ratio = self.height_above_load_m / dz;
        let l = load_m.xy();
        (l + (uav_m.xy() - l) * ratio, floored)
    }

    /// Inverse of [`Self::project`]: the UAV's horizontal position for node `q_m` at
    /// altitude `uav_z_m`, m.
    #[inline]
    pub fn unproject(&self, q_m: &Vec2, uav_z_m: f32, load_m: &Vec3) -> Vec2 {
        let (dz, _) = self.height(uav_z_m, load_m.z);
        let l = load_m.xy();
        l + (q_m - l) * (dz / self.height_above_load_m)
    }

    /// UAV horizontal velocity for node velocity `vbar_mps` (eq:2-20 corrected), m/s.
    #[inline]
    pub fn node_velocity_to_uav(&self, vbar_mps: &Vec2, uav_z_m: f32, load_m: &Vec3, load_vel_mps: &Vec3) -> Vec2 {
        let (dz, _) = self.height(uav_z_m, load_m.z);
        let vl = load_vel_mps.xy();
        vl + (vbar_mps - vl) * (dz / self.height_above_load_m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;

    const TRAY: TrayParams = TrayParams { height_above_load_m: 10.0, min_height_above_load_m: 0.5 };

    #[test]
    fn node_lies_on_the_cable_line_in_the_tray_plane() {
        // Load at origin, UAV 8 m up and 2.4 m east: the cable line reaches z = 10 at x = 3.
        let load = Vec3::new(0.0, 0.0, 0.0);
        let uav = Vec3::new(2.4, 0.0, 8.0);
        let (q, floored) = TRAY.project(&uav, &load);
        assert!(!floored);
        assert_relative_eq!(q, Vec2::new(3.0, 0.0), epsilon = 1e-6);
        // The 3-D point (q, z_l + H) is collinear with load and UAV.
        let node3 = Vec3::new(q.x, q.y, 10.0);
        assert_relative_eq!((node3 - load).cross(&(uav - load)).norm(), 0.0, epsilon = 1e-5);
    }

    #[test]
    fn uav_on_the_tray_plane_is_its_own_node() {
        let load = Vec3::new(1.0, 2.0, 3.0);
        let uav = Vec3::new(4.0, -1.0, 13.0);
        assert_relative_eq!(TRAY.project(&uav, &load).0, uav.xy(), epsilon = 1e-6);
    }

    #[test]
    fn uav_at_or_below_the_load_is_floored_and_finite() {
        let load = Vec3::new(0.0, 0.0, 5.0);
        for z in [5.0, 4.0, -100.0, 5.2] {
            let (q, floored) = TRAY.project(&Vec3::new(1.0, 0.0, z), &load);
            assert!(floored, "z = {z}");
            assert!(q.x.is_finite() && q.y.is_finite());
            assert_relative_eq!(q.x, 1.0 * 10.0 / 0.5, epsilon = 1e-4);
        }
    }

    #[test]
    fn velocity_mapping_by_hand() {
        // UAV at 8 m above the load, node moving at 1 m/s east, load still: UAV moves 0.8 m/s.
        let v = TRAY.node_velocity_to_uav(&Vec2::new(1.0, 0.0), 8.0, &Vec3::zeros(), &Vec3::zeros());
        assert_relative_eq!(v, Vec2::new(0.8, 0.0), epsilon = 1e-6);
        // Everything translating with the load at (0.5, 0.5): the UAV follows exactly.
        let vl = Vec3::new(0.5, 0.5, 0.0);
        let v = TRAY.node_velocity_to_uav(&Vec2::new(0.5, 0.5), 8.0, &Vec3::zeros(), &vl);
        assert_relative_eq!(v, Vec2::new(0.5, 0.5), epsilon = 1e-6);
    }

    proptest! {
        #[test]
        fn projection_round_trip(x in -50f32..50.0, y in -50f32..50.0, dz in 0.6f32..20.0,
                                 lx in -50f32..50.0, ly in -50f32..50.0, lz in -5f32..20.0) {
            let load = Vec3::new(lx, ly, lz);
            let uav = Vec3::new(x, y, lz + dz);
            let (q, _) = TRAY.project(&uav, &load);
            let back = TRAY.unproject(&q, uav.z, &load);
            prop_assert!((back - uav.xy()).norm() <= 1e-4 * (1.0 + uav.xy().norm()));
        }

        #[test]
        fn velocity_mapping_is_the_derivative_of_the_projection(
            x in -10f32..10.0, y in -10f32..10.0, dz in 1.0f32..15.0,
            vx in -2f32..2.0, vy in -2f32..2.0, lvx in -2f32..2.0, lvy in -2f32..2.0,
        ) {
            // Move the node by vbar dt with the load moving by v_l dt at constant altitudes:
            // the UAV must move by the mapped velocity times dt.
            let dt = 1e-2;
            let load0 = Vec3::new(0.0, 0.0, 0.0);
            let vl = Vec3::new(lvx, lvy, 0.0);
            let uav0 = Vec3::new(x, y, dz);
            let (q0, _) = TRAY.project(&uav0, &load0);
            let vbar = Vec2::new(vx, vy);
            let load1 = load0 + vl * dt;
            let uav1_xy = TRAY.unproject(&(q0 + vbar * dt), dz, &load1);
            let v_uav = TRAY.node_velocity_to_uav(&vbar, dz, &load0, &vl);
            prop_assert!(((uav1_xy - uav0.xy()) / dt - v_uav).norm() < 2e-2);
        }
    }
}
