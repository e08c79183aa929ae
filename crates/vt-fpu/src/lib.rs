//! `f32` square root and Euclidean norms for the controller crates, and a four-lane byte add for
//! the onboard map, in hardware where the MCU has it; short sine, cosine and arc tangent
//! ([`trig`]).
//!
//! `libm::sqrtf` (and nalgebra's `norm()`, which calls it under `no_std`) is a software routine
//! of about 55 instructions on a Cortex-M4F, which has a single-precision `VSQRT.F32`. Stable
//! `core` does not expose that instruction (`f32::sqrt` is `std`), so on `arm` targets with a
//! hardware-float ABI (`thumbv7em-none-eabihf`: Cortex-M4F/M7) [`sqrt`] issues it with one line
//! of inline assembly; everywhere else it is `libm::sqrtf` (on x86-64 itself a single `SQRTSS`).
//! Both are IEEE 754 correctly rounded, so results are bit-identical across targets: the PIL
//! comparison of firmware and host twin (`host-sim pil`) checks exactly that.
#![no_std]
#![deny(missing_docs)]

use nalgebra::SVector;

pub mod trig;
pub use trig::{atan2, sin_cos};

/// Correctly rounded square root (IEEE 754): NaN for negative input or NaN, `-0.0` for `-0.0`,
/// `+inf` for `+inf`.
#[inline(always)]
#[must_use]
pub fn sqrt(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        let r: u32;
        // SAFETY: VSQRT.F32 is defined for every input and touches only FPU registers (and the
        // FPSCR exception flags, which nothing reads); the eabihf ABI guarantees the FPU is
        // present and enabled (cortex-m-rt enables it before `main`). rustc only accepts FPU
        // register operands with the double-precision `vfp2` feature, which this single-precision
        // FPU lacks, so the value travels in core registers through the one scratch register,
        // s15, declared clobbered: the compiler keeps nothing of its own there across the block
        // (s15 is caller-saved), which costs nothing where a `vpush`/`vpop` pair cost two
        // instructions a square root.
        #[allow(unsafe_code)]
        unsafe {
            core::arch::asm!(
                "vmov s15, {x}",
                "vsqrt.f32 s15, s15",
                "vmov {r}, s15",
                x = in(reg) x.to_bits(),
                r = lateout(reg) r,
                out("s15") _,
                options(pure, nomem, nostack, preserves_flags),
            );
        }
        f32::from_bits(r)
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        libm::sqrtf(x)
    }
}

/// Euclidean norm `sqrt(v . v)`, the same value as nalgebra's `v.norm()` (which computes
/// exactly this), with the hardware square root.
#[inline(always)]
#[must_use]
pub fn norm<const D: usize>(v: &SVector<f32, D>) -> f32 {
    sqrt(v.norm_squared())
}

/// `v / |v|` and `|v|`, or `None` when `|v|` is zero or not finite (the caller's degenerate
/// case); the division is the same as nalgebra's `normalize()`.
#[inline]
#[must_use]
pub fn direction<const D: usize>(v: &SVector<f32, D>) -> Option<(SVector<f32, D>, f32)> {
    let n = norm(v);
    (n > 0.0 && n.is_finite()).then(|| (v / n, n))
}

/// `x - x`: exactly `+0.0` when `x` is finite, NaN when it is infinite or NaN. Sums of these
/// compared with zero test several values at once (`zero_or_nan(a) + zero_or_nan(b) == 0.0`
/// is `a.is_finite() && b.is_finite()`): a subtraction and an addition a value and one
/// comparison, where `f32::is_finite` is about ten integer instructions a value on the
/// Cortex-M4F and five on x86-64, each with its own branch.
#[inline(always)]
#[must_use]
#[allow(clippy::eq_op)] // `x - x` is the point: `+0.0`, or NaN for an infinity or a NaN
pub fn zero_or_nan(x: f32) -> f32 {
    x - x
}

/// `f32::is_finite`'s answer for every `x`, by [`zero_or_nan`].
#[inline(always)]
#[must_use]
pub fn is_finite(x: f32) -> bool {
    zero_or_nan(x) == 0.0
}

/// `0.0` when every component of `v` is finite, NaN when one is infinite or NaN: the sum of
/// [`zero_or_nan`] over the components. Sums of these compared with zero test several vectors
/// at once: `zero_if_finite(&a) + zero_if_finite(&b) == 0.0` is
/// `all_finite(&a) && all_finite(&b)`. Subtractions and additions, no branch per component:
/// about half the instructions of `iter().all(is_finite)` on the Cortex-M4F and on x86-64.
#[inline(always)]
#[must_use]
pub fn zero_if_finite<const D: usize>(v: &SVector<f32, D>) -> f32 {
    // `-0.0 + x` is `x` for every `x`, so the start adds no instruction.
    v.iter().fold(-0.0, |acc, &c| acc + zero_or_nan(c))
}

/// True when every component of `v` is finite: `v.iter().all(|c| c.is_finite())`, the same
/// answer for every input, by [`zero_if_finite`].
#[inline(always)]
#[must_use]
pub fn all_finite<const D: usize>(v: &SVector<f32, D>) -> bool {
    zero_if_finite(v) == 0.0
}

/// `x.is_finite() && x > 0.0` (a step length, a gain), by [`is_finite`]: a subtraction and
/// two float comparisons; the compiler turns the literal form (or
/// `x > 0.0 && x < f32::INFINITY`) into about 20 integer instructions on the Cortex-M4F and 13
/// on x86-64.
#[inline(always)]
#[must_use]
pub fn positive_finite(x: f32) -> bool {
    is_finite(x) && x > 0.0
}

/// `max(sat(c + add), floor)` on each of the four `i8` lanes of `w` (little-endian bytes),
/// `add4` and `floor4` holding one `i8` per lane: a saturating add and a clamp from below. On
/// hard-float ARM (the Cortex-M4F's DSP extension, ARMv7E-M) three instructions, `QADD8`,
/// `SSUB8` and `SEL`, which stable `core` does not expose; elsewhere lane by lane. Both give the
/// same bits for every input (tests), so SIL and PIL agree.
#[inline(always)]
#[must_use]
pub fn i8x4_add_sat_max(w: u32, add4: u32, floor4: u32) -> u32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        let r: u32;
        // SAFETY: QADD8 (saturating signed add per byte), SSUB8 (per-byte signed compare into
        // the APSR.GE flags) and SEL (per-byte select on GE) exist on every hard-float ARM core
        // this builds for (ARMv7E-M, ARMv7-A); they touch only the named core registers and
        // APSR.GE, which the compiler never reads across an asm block (flags not preserved).
        #[allow(unsafe_code)]
        unsafe {
            core::arch::asm!(
                "qadd8 {s}, {w}, {a}",
                "ssub8 {t}, {s}, {f}",
                "sel {s}, {s}, {f}",
                w = in(reg) w,
                a = in(reg) add4,
                f = in(reg) floor4,
                s = out(reg) r,
                t = out(reg) _,
                options(pure, nomem, nostack),
            );
        }
        r
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        let (a, f) = (add4.to_le_bytes(), floor4.to_le_bytes());
        let mut out = w.to_le_bytes();
        for ((c, a), f) in out.iter_mut().zip(a).zip(f) {
            let sum = (*c as i8).saturating_add(a as i8);
            *c = sum.max(f as i8) as u8;
        }
        u32::from_le_bytes(out)
    }
}

/// The smaller of `a` and `b` by one comparison: `f32::min`'s value for every pair without a
/// NaN (and for `+0.0` against `+0.0`). On the Cortex-M4F, `f32::min` is a call to `fminf`
/// (about 15 instructions: the NaN rules need ARMv8's `VMINNM`); this is a compare and a select.
/// A NaN in `b` gives `a`, in `a` gives `a`: callers pass no NaN.
#[inline(always)]
#[must_use]
pub fn min(a: f32, b: f32) -> f32 {
    if b < a { b } else { a }
}

/// The larger of `a` and `b` by one comparison ([`min`]'s counterpart).
#[inline(always)]
#[must_use]
pub fn max(a: f32, b: f32) -> f32 {
    if b > a { b } else { a }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Vector2, Vector3};

    #[test]
    fn byte_lanes_add_saturate_and_clamp_each_lane_alone() {
        let lanes = |v: [i8; 4]| u32::from_le_bytes(v.map(|x| x as u8));
        let w = lanes([-128, 127, 5, -30]);
        assert_eq!(i8x4_add_sat_max(w, lanes([-1, 1, -14, -14]), lanes([-128, -128, -32, -32])), lanes([-128, 127, -9, -32]));
        for c in i8::MIN..=i8::MAX {
            let want = i16::from(c).saturating_add(-14).clamp(-128, 127).max(-32) as i8;
            let got = i8x4_add_sat_max(lanes([c; 4]), lanes([-14; 4]), lanes([-32; 4]));
            assert_eq!(got, lanes([want; 4]), "{c}");
        }
    }
    use proptest::prelude::*;

    #[test]
    fn min_and_max_equal_the_library_s_without_nan() {
        let v = [f32::NEG_INFINITY, -3.5, -f32::MIN_POSITIVE, 0.0, 1e-30, 2.0, f32::MAX, f32::INFINITY];
        for a in v {
            for b in v {
                assert_eq!(min(a, b).to_bits(), a.min(b).to_bits(), "{a} {b}");
                assert_eq!(max(a, b).to_bits(), a.max(b).to_bits(), "{a} {b}");
            }
        }
    }

    #[test]
    fn special_values() {
        assert!(sqrt(-1.0).is_nan());
        assert!(sqrt(f32::NAN).is_nan());
        assert_eq!(sqrt(-0.0).to_bits(), (-0.0f32).to_bits());
        assert_eq!(sqrt(0.0), 0.0);
        assert_eq!(sqrt(f32::INFINITY), f32::INFINITY);
        assert_eq!(sqrt(4.0), 2.0);
        assert_eq!(sqrt(f32::MIN_POSITIVE / 4.0), libm::sqrtf(f32::MIN_POSITIVE / 4.0)); // subnormal
        assert_eq!(direction(&Vector2::new(0.0, 0.0)), None);
        assert_eq!(direction(&Vector2::new(f32::NAN, 0.0)), None);
        assert_eq!(direction(&Vector2::new(3.0, 4.0)), Some((Vector2::new(0.6, 0.8), 5.0)));
    }

    #[test]
    fn all_finite_is_the_componentwise_test_for_special_values() {
        let v = [f32::NEG_INFINITY, -f32::MAX, -1.5, -0.0, 0.0, f32::MIN_POSITIVE / 8.0, 1e38, f32::MAX, f32::INFINITY, f32::NAN, -f32::NAN];
        for a in v {
            for b in v {
                for c in v {
                    let x = Vector3::new(a, b, c);
                    assert_eq!(all_finite(&x), x.iter().all(|c| c.is_finite()), "{x:?}");
                    let y = Vector2::new(c, a);
                    let both = zero_if_finite(&x) + zero_if_finite(&y) == 0.0;
                    assert_eq!(both, x.iter().chain(y.iter()).all(|c| c.is_finite()), "{x:?} {y:?}");
                }
            }
        }
    }

    #[test]
    fn positive_finite_is_the_literal_test() {
        let v = [f32::NEG_INFINITY, -f32::MAX, -1.5, -f32::MIN_POSITIVE / 8.0, -0.0, 0.0, f32::MIN_POSITIVE / 8.0, 0.002, f32::MAX, f32::INFINITY, f32::NAN, -f32::NAN];
        for x in v {
            assert_eq!(positive_finite(x), x.is_finite() && x > 0.0, "{x}");
        }
    }

    proptest! {
        #[test]
        fn positive_finite_is_the_literal_test_for_any_bits(bits in any::<u32>()) {
            let x = f32::from_bits(bits);
            prop_assert_eq!(positive_finite(x), x.is_finite() && x > 0.0);
        }

        #[test]
        fn all_finite_is_the_componentwise_test(a in any::<u32>(), b in any::<u32>(), c in any::<u32>(), d in any::<u32>()) {
            let v = nalgebra::Vector4::new(f32::from_bits(a), f32::from_bits(b), f32::from_bits(c), f32::from_bits(d));
            prop_assert_eq!(all_finite(&v), v.iter().all(|c| c.is_finite()));
        }

        /// Correctly rounded: bit-identical to libm's (and nalgebra's) for every input.
        #[test]
        fn sqrt_is_libm_bit_for_bit(bits in any::<u32>()) {
            let x = f32::from_bits(bits);
            let (a, b) = (sqrt(x), libm::sqrtf(x));
            prop_assert!(a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()));
        }

        #[test]
        fn norm_is_nalgebra_bit_for_bit(x in -1e6f32..1e6, y in -1e6f32..1e6, z in -1e6f32..1e6) {
            let v = Vector3::new(x, y, z);
            prop_assert_eq!(norm(&v).to_bits(), v.norm().to_bits());
            if let Some((u, n)) = direction(&v) {
                prop_assert_eq!(n.to_bits(), v.norm().to_bits());
                prop_assert_eq!(u, v.normalize());
            }
        }
    }
}
