//! Sine, cosine and arc tangent in `f32` by short polynomials: `libm`'s `sinf`/`cosf` bring
//! their full range reduction (`rem_pio2f`, about 7 KiB of flash on the Cortex-M4 with both),
//! which angles of a few turns do not need.

use core::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// `(sin x, cos x)` for `|x|` up to about 1e9 rad (`None` beyond, or for a non-finite `x`):
/// reduced to `[-pi/4, pi/4]` by quarter turns (Cody and Waite's split of `pi/2`) and the
/// minimax polynomials of Moshier's Cephes `sinf.c` / `cosf.c` there; within 2e-7 of the true
/// values for `|x| <= 100` (test).
#[must_use]
pub fn sin_cos(x: f32) -> Option<(f32, f32)> {
    const TWO_OVER_PI: f32 = core::f32::consts::FRAC_2_PI;
    // pi/2 = PIO2_HI + PIO2_LO, PIO2_HI with trailing zero bits so `k PIO2_HI` is exact.
    const PIO2_HI: f32 = 1.570_312_5;
    const PIO2_LO: f32 = 4.838_268e-4;
    let q = x * TWO_OVER_PI;
    let k = if q >= 0.0 { (q + 0.5) as i32 } else { (q - 0.5) as i32 };
    let kf = k as f32;
    let r = (x - kf * PIO2_HI) - kf * PIO2_LO;
    if r.is_nan() || libm::fabsf(r) > 1.0 {
        return None;
    }
    let z = r * r;
    let sin = r + r * z * (-1.666_665_5e-1 + z * (8.332_161e-3 + z * -1.951_529_6e-4));
    let cos = 1.0 - 0.5 * z + z * z * (4.166_664_6e-2 + z * (-1.388_731_6e-3 + z * 2.443_315_7e-5));
    Some(match k & 3 {
        0 => (sin, cos),
        1 => (cos, -sin),
        2 => (-sin, -cos),
        _ => (-cos, sin),
    })
}

/// `atan2(y, x)` in `(-pi, pi]`, rad: Moshier's Cephes `atanf.c` (the smaller of `|x|`, `|y|` over the
/// larger, reduced at `tan(pi/8)`; a degree-9 odd polynomial) and the quadrants; within 3e-7 rad of the true
/// angle (test). `(0, 0)` gives 0; a NaN gives NaN.
#[must_use]
pub fn atan2(y: f32, x: f32) -> f32 {
    let (ax, ay) = (libm::fabsf(x), libm::fabsf(y));
    if ax == 0.0 && ay == 0.0 {
        return 0.0;
    }
    // atan of the smaller over the larger, t in [0, 1], reduced at tan(pi/8).
    let swap = ay > ax;
    let t = if swap { ax / ay } else { ay / ax };
    let a = if t > 0.414_213_57 { FRAC_PI_4 + odd_poly((t - 1.0) / (t + 1.0)) } else { odd_poly(t) };
    quadrant(if swap { FRAC_PI_2 - a } else { a }, x, y)
}

/// Cephes `atanf`'s polynomial: `atan(t)` for `|t| <= tan(pi/8)`.
fn odd_poly(t: f32) -> f32 {
    let z = t * t;
    (((8.053_744_5e-2 * z - 1.387_768_6e-1) * z + 1.997_771_1e-1) * z - 3.333_295e-1) * z * t + t
}

/// The first-quadrant angle `a` moved to the quadrant of `(x, y)`.
fn quadrant(a: f32, x: f32, y: f32) -> f32 {
    let a = if x < 0.0 { PI - a } else { a };
    if y < 0.0 { -a } else { a }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn sin_cos_is_within_2e7_of_the_truth() {
        let mut worst = 0f64;
        for k in -200_000..=200_000 {
            let x = k as f32 * 5e-4;
            let (s, c) = sin_cos(x).unwrap();
            let x64 = f64::from(x);
            worst = worst.max((f64::from(s) - x64.sin()).abs()).max((f64::from(c) - x64.cos()).abs());
        }
        assert!(worst < 2e-7, "{worst}");
        for x in [f32::MAX, -1e30, f32::NAN, f32::INFINITY] {
            assert!(sin_cos(x).is_none(), "{x}");
        }
        assert!(sin_cos(1e5).is_some());
    }

    #[test]
    fn atan2_is_within_3e7_of_the_truth_in_every_quadrant() {
        let mut worst = 0f64;
        for i in 0..20_000 {
            // Every quadrant, short of the cut at +-pi (where the sign of a zero decides).
            let a = 0.9999 * (-core::f64::consts::PI + core::f64::consts::TAU * f64::from(i) / 20_000.0);
            for r in [1e-3_f64, 0.7, 1.0, 3.0, 250.0] {
                let (y, x) = ((r * a.sin()) as f32, (r * a.cos()) as f32);
                let truth = f64::from(y).atan2(f64::from(x));
                worst = worst.max((f64::from(atan2(y, x)) - truth).abs());
            }
        }
        assert!(worst < 3e-7, "{worst}");
        assert_eq!(atan2(0.0, 0.0), 0.0);
        assert_eq!(atan2(0.0, -2.0), PI);
        assert_eq!(atan2(1.0, 0.0), FRAC_PI_2);
        assert_eq!(atan2(-1.0, 0.0), -FRAC_PI_2);
        assert!(atan2(f32::NAN, 1.0).is_nan() && atan2(1.0, f32::NAN).is_nan());
    }
}
