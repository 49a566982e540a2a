//! The correctly rounded (IEEE 754 round-to-nearest) f32 square root, the same
//! bits on every platform: one `VSQRT.F32` on hard-float ARM (the Cortex-M4F's
//! FPv4-SP, the Cortex-M7's FPv5), libm's `sqrtf` elsewhere (on x86-64 the SSE
//! `sqrtss`).
//!
//! Why a crate of its own: the solver takes about 300 roots in a 10 ms control
//! frame; stable `no_std` Rust has no `f32::sqrt` and libm's portable `sqrtf` is a
//! bitwise loop of about 60 instructions on the M4F. The hardware root needs inline
//! assembly, which is `unsafe`, and the workspace forbids `unsafe` everywhere else
//! (`unsafe_code = "forbid"`); here it is denied too, and allowed on the one block.
//!
//! Both forms are correctly rounded, so a host (x86-64, libm) and the firmware
//! compute the same bits for every finite or infinite argument, zero, subnormal or
//! normal (the M4F's FPSCR keeps its reset value: round to nearest, no flush to
//! zero, no default-NaN mode). Negative arguments and NaN give a NaN on both, whose
//! payload and sign may differ (the solver rejects a non-finite result before it
//! reaches an output).

#![no_std]

/// √x, correctly rounded: `VSQRT.F32` (one instruction, 14 cycles on the M4F).
///
/// The operand goes through `s0`, which the block saves and restores on the stack
/// (stable Rust cannot name an FPU register class for this target without the
/// unstable `vfp2` feature, so the compiler passes `x` and takes the result in
/// core registers): seven instructions in all, where the portable root is about 60.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[inline(always)]
pub fn sqrt(x: f32) -> f32 {
    let root: f32;
    // SAFETY: the block moves `x` into s0, takes its root there and moves it back
    // out, and restores s0 from the stack it pushed it to (8-byte aligned stack, 4
    // bytes below sp, popped before the block ends): no register or memory the
    // compiler sees changes besides `root`. VSQRT sets only FPSCR's cumulative
    // exception flags, as any float operation does (hence no `preserves_flags`).
    #[allow(unsafe_code)]
    unsafe {
        core::arch::asm!(
            "vpush {{s0}}",
            "vmov s0, {x}",
            "vsqrt.f32 s0, s0",
            "vmov {root}, s0",
            "vpop {{s0}}",
            x = in(reg) x,
            root = lateout(reg) root,
            options(pure, nomem),
        );
    }
    root
}

/// √x, correctly rounded: libm's `sqrtf` (the SSE `sqrtss` on x86-64).
#[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
#[inline(always)]
pub fn sqrt(x: f32) -> f32 {
    libm::sqrtf(x)
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::sqrt;

    /// Correctly rounded: the f64 root of an f32 rounded once to f32 is the
    /// correctly rounded f32 root (f64 has more than 2 * 24 + 2 bits), over the
    /// whole range, subnormals and the IEEE special cases included.
    #[test]
    fn the_root_is_correctly_rounded() {
        let mut bits: u32 = 1;
        while bits < 0x7f80_0000 {
            let x = f32::from_bits(bits);
            let exact = (x as f64).sqrt() as f32;
            assert_eq!(sqrt(x).to_bits(), exact.to_bits(), "sqrt({x:e})");
            bits += 997;
        }
        assert_eq!(sqrt(0.0).to_bits(), 0.0f32.to_bits());
        assert_eq!(sqrt(-0.0).to_bits(), (-0.0f32).to_bits());
        assert_eq!(sqrt(f32::INFINITY), f32::INFINITY);
        assert_eq!(
            sqrt(f32::MIN_POSITIVE * 4.0),
            f32::MIN_POSITIVE.sqrt() * 2.0
        );
        assert!(sqrt(-1.0).is_nan() && sqrt(f32::NAN).is_nan() && sqrt(f32::NEG_INFINITY).is_nan());
        assert_eq!(sqrt(4.0), 2.0);
    }
}
