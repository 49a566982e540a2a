//! What every board module shares, whatever its peripherals: the failure path
//! (panic and HardFault handlers, the safe state), stack painting, the blocking
//! `embedded-io` read and write loops over a UART that moves one byte at a time,
//! and the defmt transport. A board module supplies the byte-level access and
//! `uart_off`.

use cortex_m_rt::{ExceptionFrame, exception};

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

/// Ends the program after a failure: under QEMU, exit status 1; on hardware the
/// safe state (the board's host UART off, interrupts masked, core parked).
pub fn fail() -> ! {
    super::uart_off();
    cortex_m::interrupt::disable();
    #[cfg(feature = "qemu")]
    cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}

#[cfg(not(feature = "panic-never"))]
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::error!("panic: {}", defmt::Display2Format(info));
    fail()
}

// Feature `panic-never` (examples/panic_never.rs, a link-time check): the panic
// handler calls a function that exists nowhere, so the build links only if the
// optimiser removed every call of the handler, i.e. no panic is reachable.
#[cfg(feature = "panic-never")]
#[allow(unsafe_code)]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    unsafe extern "Rust" {
        /// Defined nowhere: a reachable panic fails the link with this name.
        fn a_panic_is_reachable_from_the_frame_path() -> !;
    }
    // SAFETY: never runs; the link fails if a call of it remains.
    unsafe { a_panic_is_reachable_from_the_frame_path() }
}

// cortex-m-rt requires the HardFault handler to be an `unsafe fn` (it runs on a
// possibly corrupt stack); it does nothing unsafe: it logs the faulting address
// and fails.
#[allow(unsafe_code)]
#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    defmt::error!(
        "hardfault: pc={=u32:#x} lr={=u32:#x}",
        frame.pc(),
        frame.lr()
    );
    fail()
}
