//! Elastic cable joining one UAV to the load (REFERENCE §1, eq:1-1 .. eq:1-4).
//!
//! A cable is a one-sided spring-damper: it pulls when stretched beyond its rest length and does
//! nothing at all when slack (it neither pushes nor lets its damper pull). Its tension is capped
//! at `f_max`, the model of the UAV's lifting capacity. World frame ENU, SI units.

use nalgebra::Vector3;

/// Endpoint separation below which the cable direction is undefined and the force is zero, m.
pub const MIN_CABLE_LENGTH_M: f64 = 1e-9;

/// Physical parameters of one cable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CableParams {
    /// Unstretched length `len0`, m.
    pub rest_length_m: f64,
    /// Spring stiffness `k`, N/m.
    pub stiffness_n_per_m: f64,
    /// Damping coefficient `b` on the length rate, N s/m.
    pub damping_ns_per_m: f64,
    /// Tension cap `f_max`, N; `f64::INFINITY` means no cap.
    pub f_max_n: f64,
}

impl CableParams {
    /// True when the parameters can give a force: rest length, stiffness and damping finite,
    /// `f_max` not NaN ([`cable_force`]'s test; `&`, not `&&`: cheap pure tests, no branches).
    #[inline]
    pub(crate) fn usable(&self) -> bool {
        self.rest_length_m.is_finite() & self.stiffness_n_per_m.is_finite() & self.damping_ns_per_m.is_finite() & !self.f_max_n.is_nan()
    }

    /// Elastic energy stored at length `length_m` (m), J: `0.5 k (len - len0)^2` when taut,
    /// 0 when slack. This is the potential of the uncapped spring; once the `f_max` cap is active
    /// the cable force is no longer conservative and this is not its potential. Non-finite
    /// input gives 0.
    #[must_use]
    pub fn elastic_energy_j(&self, length_m: f64) -> f64 {
        let stretch_m = length_m - self.rest_length_m;
        let energy_j = 0.5 * self.stiffness_n_per_m * stretch_m * stretch_m;
        if stretch_m > 0.0 && energy_j.is_finite() {
            energy_j
        } else {
            0.0
        }
    }
}

/// Result of [`cable_force`]: the tension and the forces it exerts on both ends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CableForce {
    /// Tension `tau`, N, in `[0, f_max]`.
    pub tension_n: f64,
    /// Force on the UAV, N: `-tau u` (towards the load).
    pub on_uav_n: Vector3<f64>,
    /// Force on the load, N: `+tau u` (towards the UAV); always `-on_uav_n`.
    pub on_load_n: Vector3<f64>,
    /// Distance between the endpoints `|p_uav - p_load|`, m (0 when the input is non-finite).
    pub length_m: f64,
}

impl CableForce {
    /// No tension, no force; `length_m` is the endpoint distance, m.
    #[must_use]
    pub fn slack(length_m: f64) -> Self {
        Self {
            tension_n: 0.0,
            on_uav_n: Vector3::zeros(),
            on_load_n: Vector3::zeros(),
            length_m,
        }
    }
}

/// True when every component is finite. Written out with non-short-circuit `&` (no iterator,
/// no branches): it runs several times per cable per plant sub-step.
#[inline]
pub(crate) fn all_finite(v: &Vector3<f64>) -> bool {
    v.x.is_finite() & v.y.is_finite() & v.z.is_finite()
}

/// True when a cable of rest length `rest_length_m` pulls at a finite endpoint distance
/// `length_m` (m): not below [`MIN_CABLE_LENGTH_M`] (no direction) and longer than at rest.
#[inline]
pub(crate) fn taut(length_m: f64, rest_length_m: f64) -> bool {
    !(length_m < MIN_CABLE_LENGTH_M || length_m <= rest_length_m)
}

/// Cable force for the UAV at `p_uav` (m) moving at `v_uav` (m/s) and the load at `p_load` (m)
/// moving at `v_load` (m/s).
///
/// With `d = p_uav - p_load`, `len = |d|`, `u = d / len` and `len' = u . (v_uav - v_load)`:
/// `tau = clamp(k (len - len0) + b len', 0, f_max)` if `len > len0`, else `tau = 0`.
/// The UAV receives `-tau u`, the load `+tau u`.
///
/// Total and NaN-free: coincident endpoints (`len < MIN_CABLE_LENGTH_M`), any non-finite input
/// (positions, velocities, `len0`, `k`, `b`, or a NaN `f_max`), or arithmetic overflow for absurdly
/// large finite input all give the zero force. A negative `f_max` acts as 0.
#[must_use]
#[inline]
pub fn cable_force(
    p_uav: Vector3<f64>,
    v_uav: Vector3<f64>,
    p_load: Vector3<f64>,
    v_load: Vector3<f64>,
    params: &CableParams,
) -> CableForce {
    // `&`, not `&&`: every operand is a cheap pure test, so evaluate all without branching.
    let inputs_finite = all_finite(&p_uav) & all_finite(&v_uav) & all_finite(&p_load) & all_finite(&v_load) & params.usable();
    if !inputs_finite {
        return CableForce::slack(0.0);
    }
    let d = p_uav - p_load;
    let length_m = d.norm();
    if !length_m.is_finite() {
        return CableForce::slack(0.0);
    }
    if !taut(length_m, params.rest_length_m) {
        return CableForce::slack(length_m);
    }
    // One division for the three components.
    let u = d * (1.0 / length_m);
    let length_rate_mps = u.dot(&(v_uav - v_load));
    let raw_n = params.stiffness_n_per_m * (length_m - params.rest_length_m)
        + params.damping_ns_per_m * length_rate_mps;
    // Not f64::clamp: it panics when the bounds are NaN or reversed.
    let tension_n = raw_n.max(0.0).min(params.f_max_n.max(0.0));
    let on_load_n = u * tension_n;
    if !(tension_n.is_finite() & all_finite(&on_load_n)) {
        return CableForce::slack(length_m);
    }
    CableForce {
        tension_n,
        on_uav_n: -on_load_n,
        on_load_n,
        length_m,
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::panic)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;

    fn params(f_max_n: f64) -> CableParams {
        CableParams {
            rest_length_m: 8.0,
            stiffness_n_per_m: 500.0,
            damping_ns_per_m: 30.0,
            f_max_n,
        }
    }

    #[test]
    fn taut_cable_tension_matches_hand_computation() {
        // d = (0, 3, 8.4) - (0, -1, 0.4) = (0, 4, 8) -> len = sqrt(80), u = (0, 4, 8)/sqrt(80).
        // v_rel = (0, 0, 0.5) -> len' = 4/sqrt(80).
        // tau = 500 (sqrt(80) - 8) + 30 * 4/sqrt(80).
        let p_uav = Vector3::new(0.0, 3.0, 8.4);
        let p_load = Vector3::new(0.0, -1.0, 0.4);
        let v_uav = Vector3::new(1.0, 0.0, 0.5);
        let v_load = Vector3::new(1.0, 0.0, 0.0);
        let f = cable_force(p_uav, v_uav, p_load, v_load, &params(f64::INFINITY));
        let len = 80.0_f64.sqrt();
        let expected = 500.0 * (len - 8.0) + 30.0 * 4.0 / len;
        assert_relative_eq!(f.length_m, len, epsilon = 1e-12);
        assert_relative_eq!(f.tension_n, expected, epsilon = 1e-9);
        let u = Vector3::new(0.0, 4.0, 8.0) / len;
        assert_relative_eq!(f.on_load_n, u * expected, epsilon = 1e-9);
        assert_relative_eq!(f.on_uav_n, -u * expected, epsilon = 1e-9);
    }

    #[test]
    fn slack_cable_exerts_no_force() {
        let f = cable_force(
            Vector3::new(0.0, 0.0, 7.0),
            Vector3::zeros(),
            Vector3::zeros(),
            Vector3::zeros(),
            &params(f64::INFINITY),
        );
        assert_eq!(f.tension_n, 0.0);
        assert_eq!(f.on_uav_n, Vector3::zeros());
        assert_eq!(f.on_load_n, Vector3::zeros());
        assert_relative_eq!(f.length_m, 7.0);
    }

    #[test]
    fn tension_is_capped_at_f_max() {
        // 1 m stretch -> 500 N uncapped.
        let f = cable_force(
            Vector3::new(0.0, 0.0, 9.0),
            Vector3::zeros(),
            Vector3::zeros(),
            Vector3::zeros(),
            &params(20.0),
        );
        assert_eq!(f.tension_n, 20.0);
        assert_relative_eq!(f.on_load_n, Vector3::new(0.0, 0.0, 20.0));
        assert_relative_eq!(f.on_uav_n, Vector3::new(0.0, 0.0, -20.0));
    }

    #[test]
    fn damper_cannot_pull_a_slack_cable() {
        // Slack (len 7 < 8) and the ends separating fast: the damper term would be positive.
        let f = cable_force(
            Vector3::new(0.0, 0.0, 7.0),
            Vector3::new(0.0, 0.0, 10.0),
            Vector3::zeros(),
            Vector3::zeros(),
            &params(f64::INFINITY),
        );
        assert_eq!(f.tension_n, 0.0);
        assert_eq!(f.on_uav_n, Vector3::zeros());
    }

    #[test]
    fn damper_cannot_push_a_taut_cable() {
        // Slightly taut but closing fast: k*stretch + b*len' < 0 -> tension 0, not negative.
        let f = cable_force(
            Vector3::new(0.0, 0.0, 8.01),
            Vector3::new(0.0, 0.0, -10.0),
            Vector3::zeros(),
            Vector3::zeros(),
            &params(f64::INFINITY),
        );
        assert_eq!(f.tension_n, 0.0);
    }

    #[test]
    fn coincident_endpoints_give_zero_force_not_nan() {
        let p = Vector3::new(1.0, 2.0, 3.0);
        let mut zero_rest = params(f64::INFINITY);
        zero_rest.rest_length_m = 0.0;
        let f = cable_force(
            p,
            Vector3::new(1.0, 0.0, 0.0),
            p,
            Vector3::zeros(),
            &zero_rest,
        );
        assert_eq!(f.tension_n, 0.0);
        assert_eq!(f.on_uav_n, Vector3::zeros());
        assert_eq!(f.length_m, 0.0);
    }

    #[test]
    fn non_finite_input_gives_zero_force() {
        let bad = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY];
        for x in bad {
            let f = cable_force(
                Vector3::new(0.0, 0.0, x),
                Vector3::zeros(),
                Vector3::zeros(),
                Vector3::zeros(),
                &params(20.0),
            );
            assert_eq!(f, CableForce::slack(0.0));
            let mut p = params(20.0);
            p.stiffness_n_per_m = x;
            let f = cable_force(
                Vector3::new(0.0, 0.0, 9.0),
                Vector3::zeros(),
                Vector3::zeros(),
                Vector3::zeros(),
                &p,
            );
            assert_eq!(f, CableForce::slack(0.0));
        }
        // Huge but finite positions whose difference overflows.
        let f = cable_force(
            Vector3::new(0.0, 0.0, 1e308),
            Vector3::zeros(),
            Vector3::new(0.0, 0.0, -1e308),
            Vector3::zeros(),
            &params(f64::INFINITY),
        );
        assert_eq!(f.tension_n, 0.0);
    }

    #[test]
    fn elastic_energy_is_zero_when_slack() {
        let p = params(f64::INFINITY);
        assert_eq!(p.elastic_energy_j(7.5), 0.0);
        assert_relative_eq!(p.elastic_energy_j(8.2), 0.5 * 500.0 * 0.04, epsilon = 1e-9);
    }

    fn vec3(range: f64) -> impl Strategy<Value = Vector3<f64>> {
        (-range..range, -range..range, -range..range).prop_map(|(x, y, z)| Vector3::new(x, y, z))
    }

    fn any_finite() -> impl Strategy<Value = f64> {
        proptest::num::f64::NORMAL
            | proptest::num::f64::SUBNORMAL
            | proptest::num::f64::ZERO
            | proptest::num::f64::NEGATIVE
            | proptest::num::f64::POSITIVE
    }

    fn vec3_any_finite() -> impl Strategy<Value = Vector3<f64>> {
        (any_finite(), any_finite(), any_finite()).prop_map(|(x, y, z)| Vector3::new(x, y, z))
    }

    fn cable_params() -> impl Strategy<Value = CableParams> {
        (
            0.0..20.0,
            0.0..1e4,
            0.0..200.0,
            prop_oneof![Just(f64::INFINITY), 0.0..500.0],
        )
            .prop_map(
                |(rest_length_m, stiffness_n_per_m, damping_ns_per_m, f_max_n)| CableParams {
                    rest_length_m,
                    stiffness_n_per_m,
                    damping_ns_per_m,
                    f_max_n,
                },
            )
    }

    proptest! {
        #[test]
        fn prop_tension_within_zero_and_f_max(
            pu in vec3(30.0), vu in vec3(20.0), pl in vec3(30.0), vl in vec3(20.0),
            p in cable_params(),
        ) {
            let f = cable_force(pu, vu, pl, vl, &p);
            prop_assert!(f.tension_n >= 0.0);
            prop_assert!(f.tension_n <= p.f_max_n);
        }

        #[test]
        fn prop_zero_tension_when_not_stretched(
            pl in vec3(30.0), dir in vec3(1.0), frac in 0.0..=1.0f64,
            vu in vec3(20.0), vl in vec3(20.0), p in cable_params(),
        ) {
            // Place the UAV at a distance frac * len0 <= len0 from the load.
            let n = dir.norm();
            prop_assume!(n > 1e-6);
            let pu = pl + dir / n * (frac * p.rest_length_m);
            let f = cable_force(pu, vu, pl, vl, &p);
            prop_assert!(f.length_m <= p.rest_length_m + 1e-9);
            if f.length_m <= p.rest_length_m {
                prop_assert_eq!(f.tension_n, 0.0);
                prop_assert_eq!(f.on_uav_n, Vector3::zeros());
                prop_assert_eq!(f.on_load_n, Vector3::zeros());
            }
        }

        #[test]
        fn prop_forces_equal_and_opposite_along_cable(
            pu in vec3(30.0), vu in vec3(20.0), pl in vec3(30.0), vl in vec3(20.0),
            p in cable_params(),
        ) {
            let f = cable_force(pu, vu, pl, vl, &p);
            prop_assert_eq!(f.on_uav_n + f.on_load_n, Vector3::zeros());
            // Force on the load has magnitude tau and points from the load to the UAV.
            prop_assert!((f.on_load_n.norm() - f.tension_n).abs() <= 1e-9 * (1.0 + f.tension_n));
            if f.tension_n > 0.0 {
                prop_assert!(f.on_load_n.dot(&(pu - pl)) > 0.0);
            }
        }

        #[test]
        fn prop_coincident_endpoints_no_nan(
            p0 in vec3(1e3), off in vec3(1e-10), vu in vec3(20.0), vl in vec3(20.0),
            mut p in cable_params(),
            rest_zero in any::<bool>(),
        ) {
            if rest_zero { p.rest_length_m = 0.0; }
            let f = cable_force(p0 + off, vu, p0, vl, &p);
            prop_assert!(f.tension_n.is_finite() && f.length_m.is_finite());
            prop_assert!(f.on_uav_n.iter().all(|c| c.is_finite()));
            prop_assert!(f.on_load_n.iter().all(|c| c.is_finite()));
        }

        #[test]
        fn prop_any_finite_input_no_nan(
            pu in vec3_any_finite(), vu in vec3_any_finite(),
            pl in vec3_any_finite(), vl in vec3_any_finite(),
            rest in any_finite(), k in any_finite(), b in any_finite(),
            f_max in prop_oneof![Just(f64::INFINITY), any_finite()],
        ) {
            let p = CableParams {
                rest_length_m: rest, stiffness_n_per_m: k, damping_ns_per_m: b, f_max_n: f_max,
            };
            let f = cable_force(pu, vu, pl, vl, &p);
            prop_assert!(f.tension_n.is_finite() && f.tension_n >= 0.0);
            prop_assert!(f.tension_n <= f_max.max(0.0));
            prop_assert!(f.length_m.is_finite());
            prop_assert!(f.on_uav_n.iter().all(|c| c.is_finite()));
            prop_assert!(f.on_load_n.iter().all(|c| c.is_finite()));
            prop_assert_eq!(f.on_uav_n + f.on_load_n, Vector3::zeros());
        }
    }
}
