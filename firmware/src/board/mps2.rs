//! The board: QEMU's MPS2 AN386 (Cortex-M4F) or AN500 (Cortex-M7), both with a
//! 25 MHz core clock and the same memory map (`firmware/boards.toml`, rows `m4`
//! and `m7`), and how the application uses it. Everything hardware-specific
//! lives here.
//!
//! | role | peripheral |
//! |---|---|
//! | host link | CMSDK APB UART0 at 0x4000_4000 (`embedded-io` 0.7 [`Uart`]) |
//! | advisory line | none: [`AdvisoryPin`] is [`NoLine`], which does nothing |
//! | instruction counter, millisecond clock | SysTick on the core clock, free-running, extended in software ([`Clock`]) |
//! | logs | defmt over semihosting (feature `defmt-semihosting`) or RTT (`rtt`) |
//! | exit code (QEMU) | Arm semihosting `SYS_EXIT` (feature `qemu`) |
//! | stack high-water mark | stack painting (cortex-m-stack, cortex-m-rt's `_stack_end`) |
//!
//! Failures: a panic or a HardFault logs what it can, then, under QEMU (feature
//! `qemu`, the default) exits QEMU with status 1 so a test never hangs; without
//! `qemu` (hardware) it goes to the safe state: the UART's transmitter and
//! receiver are switched off (the host sees the link fall silent and its own
//! supervision takes over), interrupts are masked and the core is parked. A
//! watchdog, where the hardware has one, would then reset it.

use core::cell::{Cell, RefCell};

use super::common;
use super::row::CORE_CLOCK_HZ;
use crate::advisory::NoLine;

use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;

/// SysTick's reload value: the full 24-bit range.
const SYSTICK_RELOAD: u32 = 0x00FF_FFFF;
/// SysTick ticks per millisecond.
const TICKS_PER_MS: u64 = CORE_CLOCK_HZ as u64 / 1000;

/// Executed instructions per SysTick tick under `-icount shift=0`: virtual time
/// advances 1 ns per instruction and SysTick runs on the core clock (25 MHz), so
/// one tick (40 ns) is 40 instructions. Counts are therefore multiples of 40.
pub const INSTRUCTIONS_PER_TICK: u32 = 1_000_000_000 / CORE_CLOCK_HZ;
const _: () = assert!(
    1_000_000_000 % CORE_CLOCK_HZ == 0,
    "the MPS2 clock counts whole instructions per tick: the core clock must divide 1 GHz"
);

/// No advisory line on the MPS2 boards.
pub type AdvisoryPin = NoLine;

/// The register-level access to memory-mapped peripherals: the crate's only
/// unsafe code besides the HardFault handler cortex-m-rt requires.
mod mmio {
    /// Reads the 32-bit device register at `address`.
    #[inline(always)]
    #[allow(unsafe_code)]
    pub fn read(address: usize) -> u32 {
        // SAFETY: only called with the addresses of the CMSDK UART0 registers
        // (`super::uart_registers`), which are valid, aligned device memory on
        // both MPS2 boards; volatile, so every access reaches the device.
        unsafe { core::ptr::read_volatile(address as *const u32) }
    }

    /// Writes the 32-bit device register at `address`.
    #[inline(always)]
    #[allow(unsafe_code)]
    pub fn write(address: usize, value: u32) {
        // SAFETY: as in `read`.
        unsafe { core::ptr::write_volatile(address as *mut u32, value) }
    }
}

/// CMSDK APB UART0 registers (ARM DDI 0479, "APB UART").
mod uart_registers {
    /// Base address of UART0 on MPS2 AN386/AN500.
    pub const BASE: usize = 0x4000_4000;
    /// Received / to-transmit byte.
    pub const DATA: usize = BASE;
    /// bit 0 TX buffer full, bit 1 RX buffer full, bit 2 TX overrun, bit 3 RX overrun (write 1 to clear).
    pub const STATE: usize = BASE + 0x04;
    /// bit 0 TX enable, bit 1 RX enable (interrupts unused).
    pub const CTRL: usize = BASE + 0x08;
    /// Baud-rate divider (>= 16); QEMU ignores it.
    pub const BAUDDIV: usize = BASE + 0x10;

    pub const STATE_TX_FULL: u32 = 1 << 0;
    pub const STATE_RX_FULL: u32 = 1 << 1;
    pub const STATE_RX_OVERRUN: u32 = 1 << 3;
    pub const CTRL_TX_ENABLE: u32 = 1 << 0;
    pub const CTRL_RX_ENABLE: u32 = 1 << 1;
}

/// Takes the core peripherals and sets up the UART, the clock and the advisory
/// pin (`Board::take`); `None` if already taken.
pub(super) fn take() -> Option<(Uart, Clock, AdvisoryPin)> {
    let peripherals = cortex_m::Peripherals::take()?;
    Some((Uart::new(), Clock::new(peripherals.SYST), NoLine))
}

/// The host link's UART: CMSDK APB UART0, polled, 115,200 baud on hardware
/// (QEMU's model moves bytes as fast as its chardev does).
pub struct Uart {
    _private: (),
}

/// What can go wrong on the UART.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum UartError {
    /// A received byte was lost because the previous one had not been read (the
    /// frame it belonged to will fail its CRC).
    RxOverrun,
}

impl core::fmt::Display for UartError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            UartError::RxOverrun => f.write_str("UART receive overrun: a byte was lost"),
        }
    }
}

impl core::error::Error for UartError {}

impl embedded_io::Error for UartError {
    fn kind(&self) -> embedded_io::ErrorKind {
        embedded_io::ErrorKind::Other
    }
}

/// Core clock / 115,200 baud.
const BAUD_DIVIDER: u32 = CORE_CLOCK_HZ / 115_200;

impl Uart {
    /// Enables UART0's transmitter and receiver. The one dummy DATA read after
    /// enabling RX avoids QEMU's one-second stall on the first received frame
    /// (docs/toolchain.md §4).
    fn new() -> Self {
        use uart_registers::*;
        mmio::write(BAUDDIV, BAUD_DIVIDER);
        mmio::write(CTRL, CTRL_TX_ENABLE | CTRL_RX_ENABLE);
        let _ = mmio::read(DATA);
        mmio::write(STATE, STATE_RX_OVERRUN);
        Uart { _private: () }
    }

    fn state() -> u32 {
        mmio::read(uart_registers::STATE)
    }

    /// Reads one byte if one is waiting.
    fn try_read_byte(&mut self) -> Result<Option<u8>, UartError> {
        use uart_registers::*;
        let state = Self::state();
        if state & STATE_RX_OVERRUN != 0 {
            mmio::write(STATE, STATE_RX_OVERRUN);
            return Err(UartError::RxOverrun);
        }
        if state & STATE_RX_FULL == 0 {
            return Ok(None);
        }
        Ok(Some(mmio::read(DATA) as u8))
    }

    /// Writes one byte if the transmit buffer has room.
    fn try_write_byte(&mut self, byte: u8) -> bool {
        use uart_registers::*;
        if Self::state() & STATE_TX_FULL != 0 {
            return false;
        }
        mmio::write(DATA, u32::from(byte));
        true
    }
}

/// Switches the UART off (the safe state: nothing more goes to the host).
pub(super) fn uart_off() {
    mmio::write(uart_registers::CTRL, 0);
}

impl embedded_io::ErrorType for Uart {
    type Error = UartError;
}

impl embedded_io::Read for Uart {
    /// Blocks until at least one byte is available, then returns those waiting
    /// (the receive buffer holds one byte).
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, UartError> {
        common::read_blocking(buf, || self.try_read_byte())
    }
}

impl embedded_io::ReadReady for Uart {
    fn read_ready(&mut self) -> Result<bool, UartError> {
        Ok(Self::state() & uart_registers::STATE_RX_FULL != 0)
    }
}

impl embedded_io::Write for Uart {
    /// Blocks until the transmit buffer takes the first byte, then writes as many
    /// as it takes without waiting again.
    fn write(&mut self, buf: &[u8]) -> Result<usize, UartError> {
        Ok(common::write_blocking(buf, |byte| {
            self.try_write_byte(byte)
        }))
    }

    /// Waits until the transmit buffer has room, i.e. the last byte is on its way.
    fn flush(&mut self) -> Result<(), UartError> {
        while Self::state() & uart_registers::STATE_TX_FULL != 0 {}
        Ok(())
    }
}

impl embedded_io::WriteReady for Uart {
    fn write_ready(&mut self) -> Result<bool, UartError> {
        Ok(Self::state() & uart_registers::STATE_TX_FULL == 0)
    }
}

/// SysTick as a free-running counter of executed instructions (under QEMU
/// `-icount shift=0,align=off,sleep=off`, where virtual time advances exactly 1 ns
/// per instruction; on hardware, core cycles / 40), extended to 64 bits in
/// software, and the millisecond clock derived from it.
///
/// The 24-bit counter wraps every 2^24 ticks (671 M instructions, 0.67 s); each
/// reading adds the ticks since the previous one, so it must be read at least
/// that often. The application's idle loop reads it every few dozen
/// instructions, and the longest work between two readings (a trim, about 1.3 M
/// instructions) is far shorter.
pub struct Clock {
    systick: RefCell<SYST>,
    last_reading: Cell<u32>,
    ticks: Cell<u64>,
}

impl Clock {
    /// Starts SysTick on the core clock, counting down from [`SYSTICK_RELOAD`],
    /// without interrupts.
    fn new(mut systick: SYST) -> Self {
        systick.disable_interrupt();
        systick.set_clock_source(SystClkSource::Core);
        systick.set_reload(SYSTICK_RELOAD);
        systick.clear_current();
        systick.enable_counter();
        Clock {
            systick: RefCell::new(systick),
            last_reading: Cell::new(SYST::get_current()),
            ticks: Cell::new(0),
        }
    }

    /// Ticks since the clock started.
    #[inline(always)]
    fn ticks(&self) -> u64 {
        let now = SYST::get_current();
        let elapsed = self.last_reading.get().wrapping_sub(now) & SYSTICK_RELOAD;
        self.last_reading.set(now);
        let ticks = self.ticks.get() + u64::from(elapsed);
        self.ticks.set(ticks);
        ticks
    }

    /// Restarts SysTick's tick phase at this instant, keeping the clock's count.
    ///
    /// A tick is 40 instructions, and how long the idle loop polled before a frame
    /// arrived depends on the host, so a free-running counter would start each
    /// measurement at a different phase within its tick and a count could differ by
    /// one tick from run to run. Writing SYST_CVR restarts the count from the reload
    /// value at the write (QEMU anchors the tick period there), so a measurement
    /// that starts a fixed number of instructions after this call reads the same
    /// count in every run. The clock loses less than one tick per call.
    pub fn align(&self) {
        self.ticks();
        // Never borrowed elsewhere (single core, no interrupt uses it):
        // `try_borrow_mut` rather than a borrow that could panic.
        if let Ok(mut systick) = self.systick.try_borrow_mut() {
            systick.clear_current();
        }
        self.last_reading.set(SYST::get_current());
    }

    /// Milliseconds since the clock started (wrapping after 49 days).
    pub fn now_ms(&self) -> u32 {
        (self.ticks() / TICKS_PER_MS) as u32
    }
}

impl decoy_controller::serve::Clock for Clock {
    fn now_ms(&self) -> u32 {
        Clock::now_ms(self)
    }
    fn align(&self) {
        Clock::align(self)
    }
}

impl decoy_controller::InstructionCounter for Clock {
    /// Instructions since the clock started, wrapping at 2^32, in multiples of
    /// `INSTRUCTIONS_PER_TICK`.
    #[inline(always)]
    fn now(&self) -> u32 {
        (self.ticks() as u32).wrapping_mul(INSTRUCTIONS_PER_TICK)
    }
}
