//! `f32` square root and Euclidean norms for the controller crates, in hardware where the MCU
//! has it.
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
        // FPU lacks, so the value travels in core registers and the one scratch register, s15,
        // is saved on the stack and restored: nothing the compiler owns is changed.
        #[allow(unsafe_code)]
        unsafe {
            core::arch::asm!(
                "vpush {{s15}}",
                "vmov s15, {x}",
                "vsqrt.f32 s15, s15",
                "vmov {r}, s15",
                "vpop {{s15}}",
                x = in(reg) x.to_bits(),
                r = lateout(reg) r,
                options(pure, nomem, preserves_flags),
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

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Vector2, Vector3};
    use proptest::prelude::*;

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

    proptest! {
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
