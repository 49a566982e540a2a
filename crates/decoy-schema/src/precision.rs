//! The solver's scalar: what a board's firmware, the bridge's host backend and
//! the reports call a precision.

use core::fmt;

/// The solver's scalar (solver-core is generic over `f32` and `f64`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Precision {
    /// f32: the Cortex-M4F's single-precision FPU (the host, with libm, gives
    /// the same bits).
    F32,
    /// f64: the host's reference model, and the firmware with feature `f64`
    /// (in hardware on the Cortex-M7's FPv5-D16).
    F64,
}

impl Precision {
    /// Bits of the scalar.
    pub fn bits(self) -> u8 {
        match self {
            Precision::F32 => 32,
            Precision::F64 => 64,
        }
    }
}

impl fmt::Display for Precision {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "f{}", self.bits())
    }
}

#[cfg(test)]
mod tests {
    use super::Precision;

    #[test]
    fn names_and_bits() {
        assert_eq!(Precision::F32.bits(), 32);
        assert_eq!(Precision::F64.bits(), 64);
        let mut name = heapless_name(Precision::F64);
        assert_eq!(name.as_str(), "f64");
        name = heapless_name(Precision::F32);
        assert_eq!(name.as_str(), "f32");
    }

    /// The Display form without a heap (the crate is `no_std`).
    fn heapless_name(p: Precision) -> Name {
        use core::fmt::Write;
        let mut n = Name::default();
        write!(n, "{p}").unwrap();
        n
    }

    #[derive(Default)]
    struct Name {
        bytes: [u8; 8],
        len: usize,
    }

    impl Name {
        fn as_str(&self) -> &str {
            core::str::from_utf8(&self.bytes[..self.len]).unwrap()
        }
    }

    impl core::fmt::Write for Name {
        fn write_str(&mut self, s: &str) -> core::fmt::Result {
            let end = self.len + s.len();
            self.bytes
                .get_mut(self.len..end)
                .ok_or(core::fmt::Error)?
                .copy_from_slice(s.as_bytes());
            self.len = end;
            Ok(())
        }
    }
}
