//! Lyapunov-like barrier functions: the tube barrier `V_t` (eq:2-15-1) and the robot-robot
//! barrier `V_m` of the traditional virtual-tube controller (REFERENCE §2).
//!
//! Both have the form `V(d) = k sigma(d, r_s, r_a) / ((1 + eps) d - r_s s(d / r_s, eps_s))`:
//! zero for `d >= r_a`, growing without bound as `d` falls towards `r_s` and below.

use crate::smooth::{sigma, sigma_deriv, smooth_min, smooth_min_deriv};

/// Default small constants `eps_t`, `eps_m`, `eps_s` (REFERENCE §2: "~1e-6").
pub const DEFAULT_EPS: f32 = 1e-6;

/// Distances below `DISTANCE_FLOOR_FRACTION * r_s` are evaluated at that floor, so the
/// barrier stays finite (and keeps its sign) for a node on or beyond the boundary.
pub const DISTANCE_FLOOR_FRACTION: f32 = 1e-3;

/// Parameters of one barrier.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BarrierParams {
    /// Gain `k` (`k3` for the tube, `k2` for robots), m^2/s (velocity x distance).
    pub gain: f32,
    /// Safety distance `r_s`: the barrier's pole, m.
    pub r_safe_m: f32,
    /// Activation distance `r_a > r_s`: zero beyond, m.
    pub r_active_m: f32,
    /// `eps` in the denominator's `(1 + eps) d`.
    pub eps: f32,
    /// Rounding radius `eps_s` of the smooth minimum.
    pub eps_s: f32,
}

impl BarrierParams {
    /// Tube barrier eq:2-15-1 with gain `k3`, safety radius `r_s`, activation radius `r_a`
    /// (all in metres; `d` is the node's distance to the tube boundary `d_t`).
    pub const fn tube(k3: f32, r_s_m: f32, r_a_m: f32) -> Self {
        Self { gain: k3, r_safe_m: r_s_m, r_active_m: r_a_m, eps: DEFAULT_EPS, eps_s: DEFAULT_EPS }
    }

    /// Robot-robot barrier `V_m` (REFERENCE §2) with gain `k2` for robots of safety radius
    /// `r_s` and activation radius `r_a`: pole at `2 r_s`, zero beyond `r_a + r_s`
    /// (`d` is the centre-to-centre distance).
    pub const fn robot(k2: f32, r_s_m: f32, r_a_m: f32) -> Self {
        Self {
            gain: k2,
            r_safe_m: 2.0 * r_s_m,
            r_active_m: r_a_m + r_s_m,
            eps: DEFAULT_EPS,
            eps_s: DEFAULT_EPS,
        }
    }

    /// True when the parameters describe a usable barrier (finite, `0 < r_s < r_a`, `k >= 0`).
    pub fn is_valid(&self) -> bool {
        // The three finiteness tests as one sum (vt_fpu::zero_or_nan): it runs at every
        // evaluation, and `is_finite` is about ten integer instructions a value on the
        // Cortex-M4F.
        vt_fpu::zero_or_nan(self.gain) + vt_fpu::zero_or_nan(self.r_safe_m) + vt_fpu::zero_or_nan(self.r_active_m) == 0.0
            && self.gain >= 0.0
            && self.r_safe_m > 0.0
            && self.r_active_m > self.r_safe_m
            && self.eps > 0.0
            && self.eps_s > 0.0
    }

    /// Evaluates the barrier and its derivative at distance `d_m`.
    ///
    /// Distances below the floor `DISTANCE_FLOOR_FRACTION * r_s` (including `d <= 0`, a node
    /// outside the tube) are evaluated at the floor: finite, maximal repulsion.
    /// NaN `d_m` or invalid parameters give [`Barrier::ZERO`].
    #[inline]
    pub fn eval(&self, d_m: f32) -> Barrier {
        if d_m.is_nan() || !self.is_valid() {
            return Barrier::ZERO;
        }
        if d_m >= self.r_active_m {
            return Barrier::ZERO;
        }
        let r_s = self.r_safe_m;
        // `d_m` is not NaN and the floor is positive: `f32::max`'s value, without its call to
        // `fmaxf` on the Cortex-M4F.
        let d = vt_fpu::max(d_m, DISTANCE_FLOOR_FRACTION * r_s);
        let sig = sigma(d, r_s, self.r_active_m);
        let dsig = sigma_deriv(d, r_s, self.r_active_m);
        // Denominator D and its derivative D' (eq:2-15-1; REFERENCE §2).
        let den = (1.0 + self.eps) * d - r_s * smooth_min(d / r_s, self.eps_s);
        let dden = (1.0 + self.eps) - smooth_min_deriv(d / r_s, self.eps_s);
        if !(den > 0.0) {
            return Barrier::ZERO;
        }
        let value = self.gain * sig / den;
        let deriv = self.gain * (dsig * den - sig * dden) / (den * den);
        if vt_fpu::zero_or_nan(value) + vt_fpu::zero_or_nan(deriv) == 0.0 {
            Barrier { value, deriv }
        } else {
            // f32 overflow deep inside the safety zone: saturate, keep the repulsive sign.
            Barrier { value: f32::MAX, deriv: -f32::MAX }
        }
    }
}

/// A barrier's value and slope at one distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Barrier {
    /// `V(d)`, m^2/s.
    pub value: f32,
    /// `dV/dd`, m/s; never positive.
    pub deriv: f32,
}

impl Barrier {
    /// An inactive barrier.
    pub const ZERO: Self = Self { value: 0.0, deriv: 0.0 };
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;

    const TUBE: BarrierParams = BarrierParams::tube(1.0, 0.5, 1.5);

    /// `is_valid` as first written (`is_finite` tests), for the sum form's truth table.
    fn is_valid_literal(b: &BarrierParams) -> bool {
        b.gain.is_finite()
            && b.gain >= 0.0
            && b.r_safe_m.is_finite()
            && b.r_active_m.is_finite()
            && b.r_safe_m > 0.0
            && b.r_active_m > b.r_safe_m
            && b.eps > 0.0
            && b.eps_s > 0.0
    }

    #[test]
    fn validity_is_the_literal_test_for_special_values() {
        let v = [f32::NEG_INFINITY, -1.0, -0.0, 0.0, 1e-30, 0.5, 1.5, f32::MAX, f32::INFINITY, f32::NAN];
        for gain in v {
            for r_safe_m in v {
                for r_active_m in v {
                    let b = BarrierParams { gain, r_safe_m, r_active_m, ..TUBE };
                    assert_eq!(b.is_valid(), is_valid_literal(&b), "{b:?}");
                }
            }
        }
    }

    #[test]
    fn zero_beyond_activation_radius() {
        assert_eq!(TUBE.eval(1.5), Barrier::ZERO);
        assert_eq!(TUBE.eval(10.0), Barrier::ZERO);
    }

    #[test]
    fn value_by_hand_between_radii() {
        // d = 1.0: sigma = 0.5, D = (1 + 1e-6) * 1.0 - 0.5 * 1 = 0.500001 -> V = 0.999998.
        let b = TUBE.eval(1.0);
        assert_relative_eq!(b.value, 0.5 / 0.500_001, epsilon = 1e-5);
        // d / r_s = 2 lies past the smooth minimum's arc, so s' = 0 and D' = 1 + eps:
        // dV/dd = (sigma' D - sigma D') / D^2 = (-1.5 * 0.500001 - 0.5 * 1.000001) / 0.500001^2.
        let expect = (-1.5 * 0.500_001 - 0.5 * 1.000_001) / (0.500_001f32 * 0.500_001);
        assert_relative_eq!(b.deriv, expect, epsilon = 1e-4);
    }

    #[test]
    fn derivative_matches_finite_difference() {
        for k in 1..40 {
            let d = 0.55 + 0.9 * k as f32 / 40.0;
            let h = 1e-3;
            let fd = (TUBE.eval(d + h).value - TUBE.eval(d - h).value) / (2.0 * h);
            let an = TUBE.eval(d).deriv;
            assert_relative_eq!(an, fd, max_relative = 2e-2, epsilon = 1e-3);
        }
    }

    #[test]
    fn robot_barrier_radii() {
        let p = BarrierParams::robot(1.0, 0.5, 0.7);
        assert_relative_eq!(p.r_safe_m, 1.0);
        assert_relative_eq!(p.r_active_m, 1.2);
        assert_eq!(p.eval(1.2), Barrier::ZERO);
        assert!(p.eval(1.1).deriv < 0.0);
    }

    #[test]
    fn degenerate_distances_are_finite_and_repulsive() {
        for d in [0.0, -1.0, -1e30, 1e-9, 0.25, f32::NEG_INFINITY] {
            let b = TUBE.eval(d);
            assert!(b.value.is_finite() && b.deriv.is_finite(), "d = {d}: {b:?}");
            assert!(b.deriv < 0.0, "d = {d}: not repulsive");
        }
        assert_eq!(TUBE.eval(f32::NAN), Barrier::ZERO);
        assert_eq!(BarrierParams::tube(1.0, 1.0, 0.5).eval(0.7), Barrier::ZERO);
    }

    proptest! {
        #[test]
        fn barrier_derivative_is_never_positive(d in -2.0f32..3.0, k in 0.0f32..10.0,
                                               rs in 0.05f32..2.0, w in 0.05f32..3.0) {
            let p = BarrierParams::tube(k, rs, rs + w);
            let b = p.eval(d);
            prop_assert!(b.deriv <= 0.0, "dV/dd = {} at d = {}", b.deriv, d);
            prop_assert!(b.value >= 0.0 && b.value.is_finite());
        }

        #[test]
        fn barrier_value_falls_with_distance(d in 0.0f32..3.0, dd in 1e-3f32..1.0) {
            prop_assert!(TUBE.eval(d + dd).value <= TUBE.eval(d).value);
        }
    }
}
