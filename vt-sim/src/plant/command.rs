//! What the plant's autopilot receives: the firmware's `SET_ATTITUDE_TARGET`
//! ([`Setpoint`]: FRD-to-NED quaternion, collective in `[0, 1]` of the UAV's maximum thrust),
//! in the simulator's frames.

use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use vt_companion::flight::Setpoint;
use vt_companion::frames::ned_frd_quaternion;

/// Body (FLU) to world (ENU) attitude of a setpoint, or `None` when it is not finite or not
/// a rotation (norm far from 1).
///
/// The firmware forms its FRD-to-NED quaternion with `vt_companion::frames::ned_frd_quaternion`
/// (`q' = (w + z, x + y, x - y, w - z) / sqrt 2`); that map is its own inverse, so the same
/// function converts the setpoint back to FLU-to-ENU.
pub fn attitude_enu_flu(sp: &Setpoint) -> Option<UnitQuaternion<f64>> {
    let [w, x, y, z] = sp.q_ned;
    // `new_unchecked`: the map is linear and defined for any quaternion; the norm is checked
    // below, on the converted value.
    let back = ned_frd_quaternion(&UnitQuaternion::new_unchecked(Quaternion::new(w, x, y, z)));
    let [w, x, y, z] = back.map(f64::from);
    let q = Quaternion::new(w, x, y, z);
    let norm = q.norm();
    if !(norm.is_finite() && (norm - 1.0).abs() < 1e-3) {
        return None;
    }
    Some(UnitQuaternion::from_quaternion(q))
}

/// Normalised collective of a setpoint in `[0, 1]`, or `None` when it is not finite.
pub fn collective(sp: &Setpoint) -> Option<f64> {
    let c = f64::from(sp.thrust);
    c.is_finite().then(|| c.clamp(0.0, 1.0))
}

/// The thrust vector a setpoint asks of a point-mass UAV, world ENU, N:
/// `collective * thrust_max * R(q) e_z` (the inverse of `vt_cfo::thrust_to_attitude`), or
/// `None` for a setpoint that is not finite.
pub fn thrust_vector_n(sp: &Setpoint, thrust_max_n: f64) -> Option<Vector3<f64>> {
    let q = attitude_enu_flu(sp)?;
    let c = collective(sp)?;
    Some(q * Vector3::z() * (c * thrust_max_n))
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::{UnitVector2, Vector2};
    use vt_companion::frames::ned_frd_quaternion;

    #[test]
    fn wire_setpoint_round_trips_to_the_commanded_thrust() {
        let heading = UnitVector2::new_normalize(Vector2::new(1.0f32, 0.0));
        for t in [Vector3::new(3.0f32, -4.0, 20.0), Vector3::new(0.0, 0.0, 19.6), Vector3::new(-8.0, 2.0, 30.0)] {
            let att = vt_cfo::thrust_to_attitude(t, heading, 50.0);
            let sp = Setpoint { q_ned: ned_frd_quaternion(&att.attitude), thrust: att.collective };
            let back = thrust_vector_n(&sp, 50.0).unwrap_or_else(Vector3::zeros);
            assert_relative_eq!(back, t.cast::<f64>(), max_relative = 1e-5);
            // The attitude itself comes back too (body z along the thrust).
            let q = attitude_enu_flu(&sp).unwrap_or_else(UnitQuaternion::identity);
            assert_relative_eq!(q.cast::<f32>(), att.attitude, epsilon = 1e-6);
        }
    }

    #[test]
    fn non_finite_or_non_unit_setpoints_are_refused() {
        assert!(attitude_enu_flu(&Setpoint { q_ned: [f32::NAN, 0.0, 0.0, 0.0], thrust: 0.5 }).is_none());
        assert!(attitude_enu_flu(&Setpoint { q_ned: [0.0; 4], thrust: 0.5 }).is_none());
        assert!(thrust_vector_n(&Setpoint { q_ned: [1.0, 0.0, 0.0, 0.0], thrust: f32::INFINITY }, 50.0).is_none());
        // Out-of-range collectives are clamped to [0, 1].
        let up = thrust_vector_n(&Setpoint { q_ned: [0.0, 1.0, 0.0, 0.0], thrust: 2.0 }, 50.0);
        assert!(up.is_some_and(|v| (v.norm() - 50.0).abs() < 1e-9));
    }
}
