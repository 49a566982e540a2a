//! What every board module shares, whatever its peripherals: stack painting,
//! the blocking `embedded-io` read and write loops over a UART that moves one
//! byte at a time, and the defmt transport. A board module supplies the
//! byte-level access. (The failure path, which ends in the board's `uart_off`,
//! is `failure.rs`.)

#[cfg(all(feature = "defmt-semihosting", feature = "rtt"))]
compile_error!("choose one defmt transport: `defmt-semihosting` (QEMU) or `rtt` (hardware)");
#[cfg(not(any(feature = "defmt-semihosting", feature = "rtt")))]
compile_error!("a defmt transport is needed: feature `defmt-semihosting` or `rtt`");

#[cfg(feature = "rtt")]
use defmt_rtt as _;
#[cfg(feature = "defmt-semihosting")]
use defmt_semihosting as _;

/// Fills `buf` from `try_read_byte`, blocking until at least one byte is
/// available, then returning those waiting (`embedded_io::Read::read`'s contract
/// for a receive register that holds one byte).
pub(super) fn read_blocking<E>(
    buf: &mut [u8],
    mut try_read_byte: impl FnMut() -> Result<Option<u8>, E>,
) -> Result<usize, E> {
    if buf.is_empty() {
        return Ok(0);
    }
    let mut count = 0;
    while count < buf.len() {
        match try_read_byte()? {
            Some(byte) => {
                buf[count] = byte;
                count += 1;
            }
            None if count > 0 => break,
            None => {}
        }
    }
    Ok(count)
}

/// Writes `buf` through `try_write_byte` (false: the transmit register is full),
/// blocking until the first byte is taken, then writing as many as are taken
/// without waiting again (`embedded_io::Write::write`'s contract).
pub(super) fn write_blocking(buf: &[u8], mut try_write_byte: impl FnMut(u8) -> bool) -> usize {
    let mut count = 0;
    for &byte in buf {
        if !try_write_byte(byte) {
            if count > 0 {
                break;
            }
            while !try_write_byte(byte) {}
        }
        count += 1;
    }
    count
}

/// Paints the unused stack so that [`stack_high_water`] can find how deep it got.
pub fn paint_stack() {
    cortex_m_stack::repaint_stack();
}

/// Bytes of stack used at the deepest point since [`paint_stack`].
pub fn stack_high_water() -> u32 {
    cortex_m_stack::stack_size() - cortex_m_stack::stack_painted()
}

/// Bytes of RAM the stack may grow into (all RAM above `.bss`).
pub fn stack_size() -> u32 {
    cortex_m_stack::stack_size()
}
