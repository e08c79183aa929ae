//! Smooth scalar helpers of the virtual-tube method (REFERENCE §2) and the saturation eq:2-22.

use nalgebra::SVector;

/// `tan(67.5 deg) = 1 + sqrt(2)`, used by the smooth minimum [`smooth_min`].
const TAN_67_5_DEG: f32 = 2.414_213_6;
/// `sin(45 deg) = sqrt(2) / 2`.
const SIN_45_DEG: f32 = core::f32::consts::FRAC_1_SQRT_2;

/// `x` limited to `[lo, hi]`, without the bounds assertion of `f32::clamp` (no panic path on the
/// MCU, and about 22 KiB less flash): the same result as `f32::clamp` whenever that one does not
/// panic; a NaN `x` stays NaN (so it is caught downstream); an empty or NaN interval gives a
/// defined value instead of a panic (`lo` if `x < lo`, else `hi` if `x > hi`, else `x`).
///
/// ```
/// use vt_tube::limit;
/// assert_eq!(limit(3.0, -1.0, 1.0), 1.0);
/// assert_eq!(limit(-3.0, -1.0, 1.0), -1.0);
/// assert!(limit(f32::NAN, -1.0, 1.0).is_nan());
/// ```
#[inline]
pub fn limit(x: f32, lo: f32, hi: f32) -> f32 {
    let x = if x < lo { lo } else { x };
    if x > hi {
        hi
    } else {
        x
    }
}

/// Saturation eq:2-22: `u` if `|u| <= a`, else `a u / |u|` (direction kept).
///
/// The result's Euclidean norm never exceeds `a` (rounding is corrected), so a limit
/// enforced with `sat` is a hard limit. Degenerate input has a defined output:
/// a non-finite `u`, or `a` that is non-finite or `<= 0`, gives the zero vector.
///
/// # Examples
/// ```
/// use vt_tube::{sat, Vec2};
/// let v = sat(Vec2::new(3.0, 4.0), 1.0);
/// assert!((vt_fpu::norm(&v) - 1.0).abs() < 1e-6 && (v.x - 0.6).abs() < 1e-6);
/// assert_eq!(sat(Vec2::new(0.3, 0.4), 1.0), Vec2::new(0.3, 0.4));
/// ```
#[inline]
pub fn sat<const D: usize>(u: SVector<f32, D>, a: f32) -> SVector<f32, D> {
    let n2 = u.norm_squared();
    // `!n2.is_finite() || !a.is_finite() || a <= 0.0`, by one sum (vt_fpu::zero_or_nan):
    // `is_finite` is about ten integer instructions a value on the Cortex-M4F.
    if !(vt_fpu::zero_or_nan(n2) + vt_fpu::zero_or_nan(a) == 0.0 && a > 0.0) {
        return SVector::zeros();
    }
    if n2 <= a * a {
        return u;
    }
    let mut v = u * (a / vt_fpu::sqrt(n2));
    // Rounding may leave |v| an ulp above `a`; two shrink steps always suffice.
    for _ in 0..4 {
        if v.norm_squared() <= a * a {
            break;
        }
        v *= 1.0 - f32::EPSILON;
    }
    v
}

/// The switch function `sigma(x, d1, d2)` (REFERENCE §2): 1 for `x <= d1`, 0 for `x >= d2`,
/// a C^1 cubic in between with zero slope at both ends. Requires `d1 < d2`; otherwise it
/// degenerates to a step at `d1` (1 for `x <= d1`, else 0). Non-finite `x` gives 0.
#[inline]
pub fn sigma(x: f32, d1: f32, d2: f32) -> f32 {
    if x.is_nan() {
        return 0.0;
    }
    if x <= d1 {
        return 1.0;
    }
    if x >= d2 || d2 <= d1 {
        return 0.0;
    }
    // Normalised form of A x^3 + B x^2 + C x + D: with t = (x - d1)/(d2 - d1),
    // sigma = 1 - 3 t^2 + 2 t^3 (identical polynomial, better conditioned in f32).
    let t = (x - d1) / (d2 - d1);
    1.0 - t * t * (3.0 - 2.0 * t)
}

/// Derivative `d sigma / dx` of [`sigma`] (per unit of `x`); zero outside `(d1, d2)`.
#[inline]
pub fn sigma_deriv(x: f32, d1: f32, d2: f32) -> f32 {
    if !(x > d1 && x < d2) || d2 <= d1 {
        return 0.0;
    }
    let w = d2 - d1;
    let t = (x - d1) / w;
    -6.0 * t * (1.0 - t) / w
}

/// Arc-end abscissae `(x1, x2)` of the smooth minimum with rounding radius `eps`.
#[inline]
fn smooth_min_knots(eps: f32) -> (f32, f32) {
    let x2 = 1.0 + eps / TAN_67_5_DEG;
    (x2 - eps * SIN_45_DEG, x2)
}

/// The smooth `min(x, 1)` of REFERENCE §2 (`s(x, eps)`): `x` up to `x1`, a circular arc of
/// radius `eps` on `[x1, x2]`, then 1. Continuous with slope in `[0, 1]`.
/// A non-positive or non-finite `eps` gives the plain `min(x, 1)`; NaN `x` gives NaN.
#[inline]
pub fn smooth_min(x: f32, eps: f32) -> f32 {
    if !vt_fpu::positive_finite(eps) {
        return if x < 1.0 { x } else { 1.0 };
    }
    let (x1, x2) = smooth_min_knots(eps);
    if x <= x1 {
        x
    } else if x >= x2 {
        1.0
    } else {
        let dx = x - x2;
        (1.0 - eps) + vt_fpu::sqrt((eps * eps - dx * dx).max(0.0))
    }
}

/// Derivative of [`smooth_min`] with respect to `x`, in `[0, 1]`.
#[inline]
pub fn smooth_min_deriv(x: f32, eps: f32) -> f32 {
    if !vt_fpu::positive_finite(eps) {
        return if x < 1.0 { 1.0 } else { 0.0 };
    }
    let (x1, x2) = smooth_min_knots(eps);
    if x <= x1 {
        1.0
    } else if x >= x2 {
        0.0
    } else {
        let dx = x - x2;
        let root = vt_fpu::sqrt((eps * eps - dx * dx).max(0.0));
        if root <= 0.0 {
            1.0
        } else {
            (-dx / root).clamp(0.0, 1.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Vec2;
    use approx::assert_relative_eq;
    use nalgebra::Vector3;
    use proptest::prelude::*;

    proptest! {
        /// `limit` is `f32::clamp` bit for bit wherever `clamp` is defined (lo <= hi, no NaN
        /// bound), NaN `x` included; elsewhere it still returns one of `x`, `lo`, `hi`.
        #[test]
        fn limit_matches_clamp_and_never_panics(x in prop::num::f32::ANY, lo in prop::num::f32::ANY, hi in prop::num::f32::ANY) {
            let y = limit(x, lo, hi);
            if lo <= hi {
                prop_assert_eq!(y.to_bits(), x.clamp(lo, hi).to_bits());
            } else {
                prop_assert!(y.to_bits() == x.to_bits() || y.to_bits() == lo.to_bits() || y.to_bits() == hi.to_bits());
            }
        }
    }

    /// `sat`'s degenerate cases as first written (`is_finite` tests): the zero vector for
    /// exactly the same inputs, `u` or its scaled copy otherwise.
    #[test]
    fn sat_degenerate_cases_are_the_literal_tests() {
        let v = [f32::NEG_INFINITY, -1.0, -0.0, 0.0, 1e-30, 0.5, 3.0, 1e20, f32::MAX, f32::INFINITY, f32::NAN];
        for x in v {
            for a in v {
                let u = Vec2::new(x, 0.25);
                let n2 = u.norm_squared();
                let zero = !n2.is_finite() || !a.is_finite() || a <= 0.0;
                let got = sat(u, a);
                if zero {
                    assert_eq!(got, Vec2::zeros(), "{x} {a}");
                } else {
                    assert!(vt_fpu::norm(&got) <= a, "{x} {a} {got:?}");
                }
            }
            assert_eq!(smooth_min(0.5, x).to_bits(), if x > 0.0 && x.is_finite() { smooth_min(0.5, x) } else { 0.5 }.to_bits());
        }
    }

    /// The cubic of REFERENCE §2 in its printed (expanded) form.
    fn sigma_printed(x: f64, d1: f64, d2: f64) -> f64 {
        let den = (d1 - d2).powi(3);
        let a = -2.0 / den;
        let b = 3.0 * (d1 + d2) / den;
        let c = -6.0 * d1 * d2 / den;
        let d = d2 * d2 * (3.0 * d1 - d2) / den;
        a * x.powi(3) + b * x * x + c * x + d
    }

    #[test]
    fn sigma_matches_printed_cubic() {
        for &(d1, d2) in &[(0.5_f32, 0.7_f32), (0.5, 1.5), (1.0, 1.2), (0.0, 3.0)] {
            for k in 0..=20 {
                let x = d1 + (d2 - d1) * k as f32 / 20.0;
                let printed = sigma_printed(x as f64, d1 as f64, d2 as f64) as f32;
                assert_relative_eq!(sigma(x, d1, d2), printed, epsilon = 2e-5);
            }
        }
    }

    #[test]
    fn sigma_ends_and_midpoint() {
        assert_eq!(sigma(0.4, 0.5, 1.5), 1.0);
        assert_eq!(sigma(1.6, 0.5, 1.5), 0.0);
        assert_relative_eq!(sigma(1.0, 0.5, 1.5), 0.5);
        assert_relative_eq!(sigma_deriv(1.0, 0.5, 1.5), -1.5);
        assert_eq!(sigma(f32::NAN, 0.5, 1.5), 0.0);
    }

    #[test]
    fn sigma_deriv_matches_finite_difference() {
        let (d1, d2) = (0.5, 1.5);
        let h = 1e-3;
        for k in 1..20 {
            let x = d1 + (d2 - d1) * k as f32 / 20.0;
            let fd = (sigma(x + h, d1, d2) - sigma(x - h, d1, d2)) / (2.0 * h);
            assert_relative_eq!(sigma_deriv(x, d1, d2), fd, epsilon = 2e-3);
        }
    }

    #[test]
    fn smooth_min_knots_by_hand() {
        // eps = 0.1: x2 = 1 + 0.1/2.41421 = 1.041421, x1 = x2 - 0.070711 = 0.970711.
        let (x1, x2) = smooth_min_knots(0.1);
        assert_relative_eq!(x2, 1.041_421, epsilon = 1e-5);
        assert_relative_eq!(x1, 0.970_711, epsilon = 1e-5);
        // Value and slope are continuous at both knots.
        assert_relative_eq!(smooth_min(x1, 0.1), x1, epsilon = 1e-6);
        assert_relative_eq!(smooth_min(x2, 0.1), 1.0, epsilon = 1e-6);
        assert_relative_eq!(smooth_min_deriv(x1 + 1e-6, 0.1), 1.0, epsilon = 1e-3);
        assert_relative_eq!(smooth_min_deriv(x2 - 1e-6, 0.1), 0.0, epsilon = 1e-2);
    }

    #[test]
    fn sat_degenerate_inputs_give_zero() {
        let z = Vec2::zeros();
        assert_eq!(sat(Vec2::new(f32::NAN, 1.0), 1.0), z);
        assert_eq!(sat(Vec2::new(f32::INFINITY, 1.0), 1.0), z);
        assert_eq!(sat(Vec2::new(1.0, 1.0), 0.0), z);
        assert_eq!(sat(Vec2::new(1.0, 1.0), f32::NAN), z);
        assert_eq!(sat(Vec2::new(1.0, 1.0), -1.0), z);
        // Huge but finite: norm^2 overflows to inf -> defined zero output.
        assert_eq!(sat(Vec2::new(3e38, 3e38), 1.0), z);
    }

    proptest! {
        #[test]
        fn sat_never_exceeds_limit_and_keeps_direction(
            x in -1e6f32..1e6, y in -1e6f32..1e6, z in -1e6f32..1e6, a in 1e-3f32..1e3,
        ) {
            let u = Vector3::new(x, y, z);
            let v = sat(u, a);
            prop_assert!(v.norm() <= a, "|sat| = {} > a = {}", v.norm(), a);
            if u.norm() <= a {
                prop_assert_eq!(v, u);
            } else if u.norm() > 0.0 {
                // Same direction: parallel and pointing the same way.
                let cos = u.dot(&v) / (u.norm() * v.norm());
                prop_assert!(cos > 1.0 - 1e-5, "direction changed: cos = {}", cos);
                prop_assert!((v.norm() - a).abs() <= a * 1e-5);
            }
        }

        #[test]
        fn sat_is_identity_below_limit(x in -10f32..10.0, y in -10f32..10.0, margin in 0.0f32..10.0) {
            let u = Vec2::new(x, y);
            let a = u.norm() + margin + 1e-3;
            prop_assert_eq!(sat(u, a), u);
        }

        #[test]
        fn sigma_in_unit_interval_and_monotone(
            d1 in -5f32..5.0, w in 1e-2f32..5.0, x in -10f32..10.0, dx in 0f32..1.0,
        ) {
            let d2 = d1 + w;
            let a = sigma(x, d1, d2);
            let b = sigma(x + dx, d1, d2);
            prop_assert!((0.0..=1.0).contains(&a));
            prop_assert!(b <= a + 1e-6, "sigma increased: {} -> {}", a, b);
            prop_assert!(sigma_deriv(x, d1, d2) <= 0.0);
        }

        #[test]
        fn smooth_min_continuous_with_unit_slope_bound(
            x in -2f32..3.0, eps in 1e-3f32..0.5, h in 1e-5f32..1e-3,
        ) {
            let a = smooth_min(x, eps);
            let b = smooth_min(x + h, eps);
            // Slope within [0, 1] (with float slack proportional to the step).
            prop_assert!(b >= a - 1e-6, "decreasing: {} -> {}", a, b);
            prop_assert!(b - a <= h * (1.0 + 1e-3) + 1e-6, "slope > 1: {}", (b - a) / h);
            let d = smooth_min_deriv(x, eps);
            prop_assert!((0.0..=1.0).contains(&d));
            prop_assert!(a <= x.min(1.0) + 1e-6, "smooth min above min(x,1)");
        }
    }
}
