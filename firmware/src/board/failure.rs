//! The failure path every board shares: the panic and HardFault handlers and
//! [`fail`], the safe state (the board module's host UART off, through its
//! `uart_off`, interrupts masked, the core parked; under QEMU exit status 1).

use cortex_m_rt::{ExceptionFrame, exception};

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
