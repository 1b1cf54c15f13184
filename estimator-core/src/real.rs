//! The scalar type of the per-sample path: `f32` on the target, `f64` on the host.
//!
//! A small trait of our own (rather than `num_traits::Float`) so that every operation the
//! estimator uses is listed here, maps to `libm` without `std`, and has no fallible conversion.

use core::fmt::Debug;
use core::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Sub, SubAssign};

/// A real scalar: `f32` or `f64`.
pub trait Real:
    Copy
    + Default
    + Debug
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + DivAssign
    + 'static
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// Machine epsilon.
    const EPSILON: Self;
    /// Converts from `f64` (rounding to nearest).
    fn of(x: f64) -> Self;
    /// Converts to `f64` (exact).
    fn to_f64(self) -> f64;
    /// Square root (NaN for negative input; callers guard).
    fn sqrt(self) -> Self;
    /// Cube root.
    fn cbrt(self) -> Self;
    /// Absolute value.
    fn abs(self) -> Self;
    /// Arc cosine.
    fn acos(self) -> Self;
    /// Cosine.
    fn cos(self) -> Self;
    /// True unless NaN or infinite.
    fn is_finite(self) -> bool;
    /// Natural logarithm to about 1e-4 absolute (exponent from the bit pattern, a short series
    /// for the mantissa): cheap enough for the tracker's likelihood terms. Positive input only;
    /// non-positive input gives a large negative number.
    fn ln_approx(self) -> Self;
    /// The larger of two values (NaN-free inputs assumed).
    #[inline]
    fn max(self, other: Self) -> Self {
        if self >= other {
            self
        } else {
            other
        }
    }
    /// The smaller of two values.
    #[inline]
    fn min(self, other: Self) -> Self {
        if self <= other {
            self
        } else {
            other
        }
    }
    /// `x * x`.
    #[inline]
    fn sq(self) -> Self {
        self * self
    }
}

impl Real for f32 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const EPSILON: Self = f32::EPSILON;
    #[inline]
    fn of(x: f64) -> Self {
        x as f32
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self as f64
    }
    #[inline]
    fn sqrt(self) -> Self {
        sqrt_f32(self)
    }
    #[inline]
    fn cbrt(self) -> Self {
        cbrt_f32(self)
    }
    #[inline]
    fn abs(self) -> Self {
        libm::fabsf(self)
    }
    #[inline]
    fn acos(self) -> Self {
        libm::acosf(self)
    }
    #[inline]
    fn cos(self) -> Self {
        libm::cosf(self)
    }
    #[inline]
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
    #[inline]
    fn ln_approx(self) -> Self {
        if !(self > f32::MIN_POSITIVE) {
            return -87.0;
        }
        let bits = self.to_bits();
        let e = ((bits >> 23) & 0xff) as i32 - 127;
        let m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000); // [1, 2)
        (e as f32 + log2_mantissa(m)) * core::f32::consts::LN_2
    }
}

/// `log2(m)` for `m` in [1, 2); error below 1e-4.
#[inline]
fn log2_mantissa<T: Real>(m: T) -> T {
    // ln(m) = 2 atanh((m−1)/(m+1)), |y| ≤ 1/3: four terms of the series.
    let y = (m - T::ONE) / (m + T::ONE);
    let y2 = y * y;
    let series = T::ONE + y2 * (T::of(1.0 / 3.0) + y2 * (T::of(0.2) + y2 * T::of(1.0 / 7.0)));
    T::of(2.0 * core::f64::consts::LOG2_E) * y * series
}

/// Cube root in single precision without the double-precision kernel of `libm::cbrtf` (soft
/// double on a Cortex-M4F): an initial guess from the bit pattern (exponent divided by three),
/// then three Newton steps.
#[inline]
fn cbrt_f32(x: f32) -> f32 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let a = libm::fabsf(x);
    let mut y = f32::from_bits(a.to_bits() / 3 + 0x2a51_67a0);
    for _ in 0..3 {
        y -= (y * y * y - a) / (3.0 * y * y);
    }
    if x < 0.0 {
        -y
    } else {
        y
    }
}

/// `vsqrt.f32` on Cortex-M4F/M7 (one instruction behind a call), `libm` elsewhere.
#[inline]
fn sqrt_f32(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        // SAFETY: `ballisto_vsqrtf` (below) follows the hard-float AAPCS: argument and result in
        // s0, touches nothing else.
        unsafe { ballisto_vsqrtf(x) }
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        libm::sqrtf(x)
    }
}

// The FPU's square root. `asm!` cannot name FPU registers without the unstable `vfp2` target
// feature, so it is a two-instruction function in the hard-float calling convention.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
core::arch::global_asm!(
    ".section .text.ballisto_vsqrtf,\"ax\",%progbits",
    ".fpu fpv4-sp-d16",
    ".thumb_func",
    ".global ballisto_vsqrtf",
    "ballisto_vsqrtf:",
    "vsqrt.f32 s0, s0",
    "bx lr",
);

#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
extern "C" {
    fn ballisto_vsqrtf(x: f32) -> f32;
}

/// `vsqrt.f64` where the board declares a double-precision FPU (feature `double-fpu`: the
/// Cortex-M7's FPv5-D16), `libm` elsewhere. The set-up code (SVD, projections) takes every
/// square root in `f64`.
#[inline]
fn sqrt_f64(x: f64) -> f64 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf", feature = "double-fpu"))]
    {
        // SAFETY: `ballisto_vsqrt` (below) follows the hard-float AAPCS: argument and result in
        // d0, touches nothing else.
        unsafe { ballisto_vsqrt(x) }
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf", feature = "double-fpu")))]
    {
        libm::sqrt(x)
    }
}

#[cfg(all(target_arch = "arm", target_abi = "eabihf", feature = "double-fpu"))]
core::arch::global_asm!(
    ".section .text.ballisto_vsqrt,\"ax\",%progbits",
    ".fpu fpv5-d16",
    ".thumb_func",
    ".global ballisto_vsqrt",
    "ballisto_vsqrt:",
    "vsqrt.f64 d0, d0",
    "bx lr",
);

#[cfg(all(target_arch = "arm", target_abi = "eabihf", feature = "double-fpu"))]
extern "C" {
    fn ballisto_vsqrt(x: f64) -> f64;
}

impl Real for f64 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const EPSILON: Self = f64::EPSILON;
    #[inline]
    fn of(x: f64) -> Self {
        x
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline]
    fn sqrt(self) -> Self {
        sqrt_f64(self)
    }
    #[inline]
    fn cbrt(self) -> Self {
        libm::cbrt(self)
    }
    #[inline]
    fn abs(self) -> Self {
        libm::fabs(self)
    }
    #[inline]
    fn acos(self) -> Self {
        libm::acos(self)
    }
    #[inline]
    fn cos(self) -> Self {
        libm::cos(self)
    }
    #[inline]
    fn is_finite(self) -> bool {
        f64::is_finite(self)
    }
    #[inline]
    fn ln_approx(self) -> Self {
        if !(self > f64::MIN_POSITIVE) {
            return -708.0;
        }
        let bits = self.to_bits();
        let e = ((bits >> 52) & 0x7ff) as i64 - 1023;
        let m = f64::from_bits((bits & 0x000f_ffff_ffff_ffff) | 0x3ff0_0000_0000_0000);
        (e as f64 + log2_mantissa(m)) * core::f64::consts::LN_2
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ln_approx_is_close() {
        for &x in &[1e-12, 1e-3, 0.5, 1.0, 1.5, 1.999, 2.0, 3.7, 1e6] {
            assert!((Real::ln_approx(x) - libm::log(x)).abs() < 1e-4, "{x}");
            assert!(
                ((x as f32).ln_approx() as f64 - libm::log(x)).abs() < 1e-4,
                "{x}"
            );
        }
    }

    #[test]
    fn cbrt_f32_is_accurate() {
        for &x in &[
            -27.0f32, -1e-6, 1e-30, 0.001, 0.5, 1.0, 2.0, 8.0, 123.456, 3e20,
        ] {
            let want = libm::cbrt(x as f64);
            assert!(
                ((cbrt_f32(x) as f64 - want) / want).abs() < 1e-6,
                "{x}: {} vs {want}",
                cbrt_f32(x)
            );
        }
    }
}
