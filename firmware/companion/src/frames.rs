//! Conversions between the wire's frames (MAVLink: local NED, body FRD) and the controllers'
//! (world ENU, body FLU).
//!
//! Vectors: `ENU = (N_east, N_north, -N_down)`, i.e. swap x/y and negate z. These are exact in
//! `f32` (no rounding), so a value survives the round trip bit for bit.
//!
//! Attitude: with `q` rotating FLU body vectors into ENU (Hamilton, `v_enu = q v_flu`), the
//! quaternion rotating FRD into NED is `q' = P q F` with `P` the ENU-to-NED rotation (180 deg
//! about `(1, 1, 0)/sqrt 2`) and `F` the FRD-to-FLU one (180 deg about x). Expanded:
//! `q' = (w + z, x + y, x - y, w - z) / sqrt 2` (sign chosen so that `q'.w >= 0` when
//! `q.w + q.z >= 0`). This one rounds (sums and a scale), identically on every IEEE target.

use crate::Vec3;
use nalgebra::UnitQuaternion;

/// `1/sqrt(2)` in `f32`.
const FRAC_1_SQRT_2: f32 = core::f32::consts::FRAC_1_SQRT_2;

/// ENU vector from NED components `[north, east, down]` (exact).
#[inline]
pub fn enu_from_ned(north: f32, east: f32, down: f32) -> Vec3 {
    Vec3::new(east, north, -down)
}

/// NED components `[north, east, down]` of an ENU vector (exact).
#[inline]
pub fn ned_from_enu(v: &Vec3) -> [f32; 3] {
    [v.y, v.x, -v.z]
}

/// MAVLink attitude quaternion `[w, x, y, z]` (FRD body to NED) from the controllers' FLU-to-ENU
/// attitude.
#[inline]
pub fn ned_frd_quaternion(q: &UnitQuaternion<f32>) -> [f32; 4] {
    let (w, x, y, z) = (q.w, q.i, q.j, q.k);
    [(w + z) * FRAC_1_SQRT_2, (x + y) * FRAC_1_SQRT_2, (x - y) * FRAC_1_SQRT_2, (w - z) * FRAC_1_SQRT_2]
}

/// True when every component is finite (`vt_fpu::all_finite`: no branch per component).
#[inline]
pub fn finite3(v: &Vec3) -> bool {
    vt_fpu::all_finite(v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Quaternion, Vector3};

    /// ENU -> NED axis permutation.
    fn p() -> Matrix3<f32> {
        Matrix3::new(0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0)
    }

    /// FRD -> FLU axis flip.
    fn f() -> Matrix3<f32> {
        Matrix3::new(1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0)
    }

    #[test]
    fn vector_round_trip_is_exact() {
        let v = Vec3::new(1.234_567, -8.765_432e-3, 3.0e7);
        let n = ned_from_enu(&v);
        assert_eq!(enu_from_ned(n[0], n[1], n[2]), v);
    }

    #[test]
    fn quaternion_matches_the_rotation_matrices() {
        let qs = [
            UnitQuaternion::identity(),
            UnitQuaternion::from_euler_angles(0.1, -0.2, 0.3),
            UnitQuaternion::from_euler_angles(-0.4, 0.25, 2.9),
            UnitQuaternion::from_euler_angles(0.0, 0.0, -1.5),
        ];
        for q in qs {
            let expected = p() * q.to_rotation_matrix().matrix() * f();
            let [w, x, y, z] = ned_frd_quaternion(&q);
            let got = UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z));
            let diff = (got.to_rotation_matrix().matrix() - expected).abs().max();
            assert!(diff < 1e-6, "rotation mismatch {diff}");
            assert!((Quaternion::new(w, x, y, z).norm() - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn level_nose_east_is_yaw_90_deg_in_ned() {
        // FLU body x along ENU east: in NED that is yaw +90 deg about down.
        let [w, x, y, z] = ned_frd_quaternion(&UnitQuaternion::identity());
        let q = UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z));
        let fwd = q * Vector3::x();
        assert!((fwd - Vector3::new(0.0, 1.0, 0.0)).norm() < 1e-6);
    }
}
