//! The board: an STM32F405 (Cortex-M4F, 168 MHz, 1 MiB flash, 128 KiB SRAM + 64 KiB
//! CCM), brought up through `stm32f4xx-hal` (embedded-hal 1.0 traits), and how the
//! application uses it. Under QEMU it is `-M netduinoplus2`. Everything
//! hardware-specific lives here.
//!
//! | role | peripheral |
//! |---|---|
//! | host link | USART1 (TX PA9, RX PA10), 115,200 baud 8N1, polled, wrapped as `embedded-io` 0.7 [`Uart`] |
//! | advisory line to the mission computer | PA5, push-pull, `embedded_hal::digital::OutputPin` ([`AdvisoryPin`]) |
//! | instruction counter, millisecond clock | SysTick on the core clock, free-running, extended in software ([`Clock`]) |
//! | logs | defmt over semihosting (feature `defmt-semihosting`) or RTT (`rtt`) |
//! | exit code (QEMU) | Arm semihosting `SYS_EXIT` (feature `qemu`) |
//! | stack high-water mark | stack painting (cortex-m-stack, cortex-m-rt's `_stack_end`) |
//!
//! Clocks. With feature `qemu` the clock tree is left on the 16 MHz HSI
//! (`rcc.freeze(Config::hsi())`): QEMU does not model the RCC's clocks (7.2 none
//! of the RCC, 9 and later only its reset and enable registers), so any HSE or
//! PLL setup waits forever for its ready bits. USART1's divider is then computed
//! for 16 MHz, which QEMU ignores (it moves bytes as fast as its chardev does),
//! while QEMU runs SysTick at 168 MHz whatever is configured. Without `qemu` (the
//! real part) the core runs from the PLL at [`CORE_CLOCK_HZ`] off an `HSE_HZ`
//! crystal (the Netduino Plus 2's); that path cannot run under QEMU and is
//! untested here.
//!
//! The host link under QEMU. Without `qemu` USART1 is the HAL's serial driver.
//! With `qemu` it is brought up at the register level (module `usart1`), doing what the HAL's `Serial::new` does except the RCC reset pulse of
//! USART1, which crashes QEMU 10 (a segmentation fault of QEMU itself at boot),
//! and polled with the same register accesses as the HAL's driver; so the board
//! runs under QEMU 7.2 and 10 alike, with the same answers and instruction
//! counts. The clocks, the GPIO and the advisory pin stay on the HAL in both
//! builds.
//!
//! Memory. The real part's map is its row in `firmware/boards.toml` (flash 1 MiB
//! at 0x0800_0000, SRAM 128 KiB at 0x2000_0000). The 64 KiB CCM at 0x1000_0000 is not used: QEMU
//! does not map it (an access is a BusFault), and the firmware fits the SRAM.
//!
//! Failures: a panic or a HardFault logs what it can, then, under QEMU (feature
//! `qemu`) exits QEMU with status 1 so a test never hangs; without `qemu`
//! (hardware) it goes to the safe state: USART1 is switched off (the host sees the
//! link fall silent and its own supervision takes over), interrupts are masked and
//! the core is parked. The independent watchdog, once enabled, would then reset it.

use core::cell::{Cell, RefCell};

use super::common;
use super::row::CORE_CLOCK_HZ;
use crate::advisory::LinePin;

use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;
use stm32f4xx_hal::gpio::{Output, PA5, PushPull};
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Config as RccConfig;

/// SysTick's reload value: the full 24-bit range.
const SYSTICK_RELOAD: u32 = 0x00FF_FFFF;
/// The external crystal of the real board (without feature `qemu`), Hz.
#[cfg(not(feature = "qemu"))]
pub const HSE_HZ: u32 = 25_000_000;
/// SysTick ticks per millisecond.
const TICKS_PER_MS: u64 = CORE_CLOCK_HZ as u64 / 1000;
/// The host link's baud rate.
pub const BAUD_RATE: u32 = 115_200;

/// The greatest common divisor of `a` and `b` (Euclid's).
const fn gcd(mut a: u32, mut b: u32) -> u32 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// Under `-icount shift=0` one instruction is 1 ns and SysTick ticks at the core
/// clock (168 MHz), so [`TICK_GROUP`] ticks (125 ns) are exactly
/// [`INSTRUCTIONS_PER_GROUP`] instructions: 1e9 / 168e6 = 125 / 21 instructions
/// per tick.
pub const INSTRUCTIONS_PER_GROUP: u32 = 1_000_000_000 / gcd(1_000_000_000, CORE_CLOCK_HZ);
/// Ticks in one group of [`INSTRUCTIONS_PER_GROUP`] instructions.
pub const TICK_GROUP: u32 = CORE_CLOCK_HZ / gcd(1_000_000_000, CORE_CLOCK_HZ);

/// The advisory line's pin (PA5, push-pull output).
pub type AdvisoryPin = PA5<Output<PushPull>>;

impl LinePin for AdvisoryPin {
    const WIRED: bool = true;
}

/// Takes the core and device peripherals and sets them up; `None` if already
/// taken or if USART1 cannot be set up for the bus clock (`usart1::Port::new`).
pub(super) fn take() -> Option<(Uart, Clock, AdvisoryPin)> {
    let core = cortex_m::Peripherals::take()?;
    let device = pac::Peripherals::take()?;
    let mut rcc = device.RCC.freeze(clock_config());
    let gpioa = device.GPIOA.split(&mut rcc);
    let mut advisory = gpioa.pa5.into_push_pull_output();
    advisory.set_low();
    let port = usart1::Port::new(device.USART1, gpioa.pa9, gpioa.pa10, &mut rcc)?;
    Some((Uart { port }, Clock::new(core.SYST), advisory))
}

/// The clock tree under QEMU: the HSI as it comes out of reset (QEMU does not
/// model the RCC's ready bits, so nothing else returns).
#[cfg(feature = "qemu")]
fn clock_config() -> RccConfig {
    RccConfig::hsi()
}

/// The clock tree of the real part: the PLL from the crystal, at the full 168 MHz.
#[cfg(not(feature = "qemu"))]
fn clock_config() -> RccConfig {
    RccConfig::hse(HSE_HZ.Hz()).sysclk(CORE_CLOCK_HZ.Hz())
}

/// The host link's UART: USART1 polled a byte at a time (`usart1::Port`),
/// offered as `embedded-io` 0.7 (the HAL implements neither `Read` nor 0.7).
pub struct Uart {
    port: usart1::Port,
}

/// What can go wrong on the UART (the HAL's receive errors).
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum UartError {
    /// A received byte was lost because the previous one had not been read (the
    /// frame it belonged to will fail its CRC).
    RxOverrun,
    /// A byte arrived with a framing, parity or noise error (its frame will fail
    /// its CRC).
    RxLine,
}

impl core::fmt::Display for UartError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            UartError::RxOverrun => f.write_str("UART receive overrun: a byte was lost"),
            UartError::RxLine => f.write_str("UART framing, parity or noise error"),
        }
    }
}

impl core::error::Error for UartError {}

impl embedded_io::Error for UartError {
    fn kind(&self) -> embedded_io::ErrorKind {
        embedded_io::ErrorKind::Other
    }
}

/// USART1 on the real part (without feature `qemu`): the HAL's serial driver,
/// brought up by `Serial::new` (clock enable, the RCC reset pulse, divider, frame
/// format) and polled through its embedded-hal-nb traits.
#[cfg(not(feature = "qemu"))]
mod usart1 {
    use stm32f4xx_hal::gpio::{PA9, PA10};
    use stm32f4xx_hal::pac;
    use stm32f4xx_hal::prelude::*;
    use stm32f4xx_hal::rcc::Rcc;
    use stm32f4xx_hal::serial::{self, Rx, RxISR, Tx, TxISR};

    use super::{BAUD_RATE, UartError};

    impl From<serial::Error> for UartError {
        fn from(error: serial::Error) -> Self {
            match error {
                serial::Error::Overrun => UartError::RxOverrun,
                _ => UartError::RxLine,
            }
        }
    }

    /// USART1's two halves from the HAL.
    pub(super) struct Port {
        tx: Tx<pac::USART1, u8>,
        rx: Rx<pac::USART1, u8>,
    }

    impl Port {
        /// USART1 on PA9 (TX) and PA10 (RX) at [`BAUD_RATE`], 8N1; `None` if the
        /// HAL rejects the configuration for the bus clock.
        pub(super) fn new(usart: pac::USART1, tx: PA9, rx: PA10, rcc: &mut Rcc) -> Option<Self> {
            let config = serial::Config::default().baudrate(BAUD_RATE.bps());
            let (tx, rx) = usart.serial::<u8>((tx, rx), config, rcc).ok()?.split();
            Some(Port { tx, rx })
        }

        /// Reads one byte if one is waiting (the HAL clears an error flag by reading it).
        pub(super) fn try_read_byte(&mut self) -> Result<Option<u8>, UartError> {
            match embedded_hal_nb::serial::Read::read(&mut self.rx) {
                Ok(byte) => Ok(Some(byte)),
                Err(nb::Error::WouldBlock) => Ok(None),
                Err(nb::Error::Other(e)) => Err(e.into()),
            }
        }

        /// Writes one byte if the transmit register has room.
        pub(super) fn try_write_byte(&mut self, byte: u8) -> bool {
            // The HAL's transmit path has no error other than "would block".
            embedded_hal_nb::serial::Write::write(&mut self.tx, byte).is_ok()
        }

        /// Whether the last byte has left the shift register.
        pub(super) fn transmission_complete(&mut self) -> bool {
            embedded_hal_nb::serial::Write::flush(&mut self.tx).is_ok()
        }

        /// Whether a received byte is waiting.
        pub(super) fn rx_not_empty(&self) -> bool {
            self.rx.is_rx_not_empty()
        }

        /// Whether the transmit register has room.
        pub(super) fn tx_empty(&self) -> bool {
            self.tx.is_tx_empty()
        }
    }
}

/// USART1 under QEMU (feature `qemu`): brought up at the register level without
/// the RCC reset pulse of the HAL's `Serial::new`, then polled with the same
/// register accesses as the HAL's driver.
///
/// Why. `Serial::new` (`stm32f4xx-hal/src/serial.rs` of version 0.23, `_new`) enables
/// USART1's clock and then resets it: it sets and clears bit 4 (USART1RST) of
/// RCC_APB2RSTR. QEMU 7.2 has no RCC model and ignores both writes. QEMU 9 added
/// one for the STM32F4 (`hw/misc/stm32_rcc.c`: "only reset and enable registers
/// are implemented") that raises the peripheral's reset line on the falling edge
/// of a reset bit; on `netduinoplus2` the edge of USART1's bit makes QEMU 10.0.2
/// itself die of a segmentation fault at boot (`qemu_set_irq` from
/// `memory_region_dispatch_write`; GPIOA's reset, AHB1RSTR bit 0, does not). The
/// HAL has no constructor without the pulse (`Tx::new` and `Rx::new` are private
/// to the crate), and after a reset of the chip USART1's registers hold their
/// reset values anyway.
///
/// What. Everything `Serial::new` does but the pulse, in its order: USART1's
/// clock enabled through the HAL's `rcc::Enable` (the same write); BRR from the
/// bus clock with 16x oversampling, rounded as the HAL's `calculate_brr`
/// rounds; CR2 and CR3 to their reset values; CR1 with UE, TE and RE (8 data
/// bits, no parity); CR2 with one stop bit; then PA9 and PA10 to alternate
/// function 7 through the HAL's GPIO. The byte access repeats the HAL's
/// (`stm32f4xx-hal/src/serial/uart_impls.rs`: `read_u16`, `write_u16`, `flush` and the status
/// flags): the same reads and writes of SR and DR in the same order, so the
/// link behaves as the hardware build's, and the answers and instruction counts
/// are those of the HAL build under QEMU 7.2 (checked bit for bit: a `decoy hil`
/// run's time series, counts included, is byte-identical).
#[cfg(feature = "qemu")]
mod usart1 {
    use stm32f4xx_hal::gpio::{Alternate, PA9, PA10};
    use stm32f4xx_hal::pac;
    use stm32f4xx_hal::rcc::{self, Rcc};

    use super::{BAUD_RATE, UartError};

    /// USART1's alternate function on PA9 and PA10.
    const USART1_AF: u8 = 7;

    /// USART1 and its pins, configured.
    pub(super) struct Port {
        usart: pac::USART1,
        _tx: PA9<Alternate<USART1_AF>>,
        _rx: PA10<Alternate<USART1_AF>>,
    }

    /// The BRR value for `baud` from the bus clock `pclk_hz` with 16x oversampling
    /// (OVER8 = 0), rounded to the nearest as the HAL's `calculate_brr` does;
    /// `None` where 16x oversampling cannot reach the rate (the HAL would fall
    /// back to 8x, which no clock of this firmware needs).
    const fn divider(pclk_hz: u32, baud: u32) -> Option<u16> {
        if baud == 0 || pclk_hz / 16 < baud {
            return None;
        }
        let div = (pclk_hz + baud / 2) / baud;
        if div > u16::MAX as u32 {
            None
        } else {
            Some(div as u16)
        }
    }

    impl Port {
        /// USART1 on PA9 (TX) and PA10 (RX) at [`BAUD_RATE`], 8N1, without the
        /// RCC reset pulse; `None` if the bus clock cannot give the rate.
        pub(super) fn new(usart: pac::USART1, tx: PA9, rx: PA10, rcc: &mut Rcc) -> Option<Self> {
            let pclk_hz = <pac::USART1 as rcc::BusClock>::clock(&rcc.clocks).raw();
            let div = divider(pclk_hz, BAUD_RATE)?;
            <pac::USART1 as rcc::Enable>::enable(rcc);
            usart.brr().write(|w| {
                w.div_mantissa().set(div >> 4);
                w.div_fraction().set((div & 0xF) as u8)
            });
            usart.cr2().reset();
            usart.cr3().reset();
            usart.cr1().write(|w| {
                w.ue().set_bit();
                w.over8().clear_bit();
                w.te().set_bit();
                w.re().set_bit();
                w.m().clear_bit();
                w.pce().clear_bit();
                w.ps().clear_bit()
            });
            usart.cr2().write(|w| w.stop().stop1());
            Some(Port {
                usart,
                _tx: tx.into_alternate::<USART1_AF>(),
                _rx: rx.into_alternate::<USART1_AF>(),
            })
        }

        /// Reads one byte if one is waiting. A parity, framing, noise or overrun
        /// flag is cleared by reading the data register and reported, in the HAL's
        /// order of precedence (parity, framing, noise, then overrun).
        pub(super) fn try_read_byte(&mut self) -> Result<Option<u8>, UartError> {
            let sr = self.usart.sr().read();
            let line_error = sr.pe().bit_is_set() || sr.fe().bit_is_set() || sr.nf().bit_is_set();
            if line_error || sr.ore().bit_is_set() {
                self.usart.dr().read();
                return Err(if line_error {
                    UartError::RxLine
                } else {
                    UartError::RxOverrun
                });
            }
            if sr.rxne().bit_is_set() {
                // Eight data bits: the ninth bit of DR is zero.
                Ok(Some(self.usart.dr().read().dr().bits() as u8))
            } else {
                Ok(None)
            }
        }

        /// Writes one byte if the transmit register has room.
        pub(super) fn try_write_byte(&mut self, byte: u8) -> bool {
            if self.usart.sr().read().txe().bit_is_set() {
                self.usart.dr().write(|w| w.dr().set(u16::from(byte)));
                true
            } else {
                false
            }
        }

        /// Whether the last byte has left the shift register.
        pub(super) fn transmission_complete(&mut self) -> bool {
            self.usart.sr().read().tc().bit_is_set()
        }

        /// Whether a received byte is waiting.
        pub(super) fn rx_not_empty(&self) -> bool {
            self.usart.sr().read().rxne().bit_is_set()
        }

        /// Whether the transmit register has room.
        pub(super) fn tx_empty(&self) -> bool {
            self.usart.sr().read().txe().bit_is_set()
        }
    }
}

impl embedded_io::ErrorType for Uart {
    type Error = UartError;
}

impl embedded_io::Read for Uart {
    /// Blocks until at least one byte is available, then returns those waiting
    /// (the receive register holds one byte).
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, UartError> {
        common::read_blocking(buf, || self.port.try_read_byte())
    }
}

impl embedded_io::ReadReady for Uart {
    fn read_ready(&mut self) -> Result<bool, UartError> {
        Ok(self.port.rx_not_empty())
    }
}

impl embedded_io::Write for Uart {
    /// Blocks until the transmit register takes the first byte, then writes as many
    /// as it takes without waiting again.
    fn write(&mut self, buf: &[u8]) -> Result<usize, UartError> {
        Ok(common::write_blocking(buf, |byte| {
            self.port.try_write_byte(byte)
        }))
    }

    /// Waits until the last byte has left the shift register.
    fn flush(&mut self) -> Result<(), UartError> {
        while !self.port.transmission_complete() {}
        Ok(())
    }
}

impl embedded_io::WriteReady for Uart {
    fn write_ready(&mut self) -> Result<bool, UartError> {
        Ok(self.port.tx_empty())
    }
}

/// Switches USART1 off (the safe state: nothing more goes to the host).
pub(super) fn uart_off() {
    // SAFETY: called only from `fail`, which then masks interrupts and never
    // returns, so no other owner of USART1 runs again; clearing CR1.UE is a single
    // write to a valid device register.
    #[allow(unsafe_code)]
    let usart = unsafe { pac::USART1::steal() };
    usart.cr1().modify(|_, w| w.ue().clear_bit());
}

/// SysTick as a free-running counter of executed instructions (under QEMU
/// `-icount shift=0,align=off,sleep=off`, where virtual time advances exactly 1 ns
/// per instruction and SysTick runs at 168 MHz), extended in software, and the
/// millisecond clock derived from it.
///
/// Ticks convert to instructions exactly as 125 per 21 ticks, without 64-bit
/// division (a library call whose instruction count depends on its operands,
/// which would make the counts vary): the clock keeps the instructions of whole
/// 21-tick groups (wrapping u32) and the ticks of the unfinished group (< 21);
/// a reading is `groups + rest * 125 / 21`, rounded down, with one 32-bit
/// division (a single instruction). Counts are therefore exact to within one
/// tick (6 instructions) and repeat from run to run (see [`Clock::align`]).
///
/// The 24-bit counter wraps every 2^24 ticks (0.1 s at 168 MHz, 99.9 M
/// instructions); each reading adds the ticks since the previous one, so it must
/// be read at least that often. The application's idle loop reads it every few
/// dozen instructions, and the longest work between two readings (a trim, about
/// 1.3 M instructions) is far shorter.
pub struct Clock {
    systick: RefCell<SYST>,
    last_reading: Cell<u32>,
    ticks: Cell<u64>,
    group_instructions: Cell<u32>,
    rest_ticks: Cell<u32>,
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
            group_instructions: Cell::new(0),
            rest_ticks: Cell::new(0),
        }
    }

    /// Adds the ticks since the previous reading, and returns the ticks since the
    /// clock started.
    #[inline(always)]
    fn ticks(&self) -> u64 {
        let now = SYST::get_current();
        let elapsed = self.last_reading.get().wrapping_sub(now) & SYSTICK_RELOAD;
        self.last_reading.set(now);
        let ticks = self.ticks.get() + u64::from(elapsed);
        self.ticks.set(ticks);
        // At most 20 + 2^24 - 1: no overflow.
        let rest = self.rest_ticks.get() + elapsed;
        let groups = rest / TICK_GROUP;
        self.rest_ticks.set(rest - groups * TICK_GROUP);
        self.group_instructions.set(
            self.group_instructions
                .get()
                .wrapping_add(groups.wrapping_mul(INSTRUCTIONS_PER_GROUP)),
        );
        ticks
    }

    /// Restarts SysTick's tick phase and the tick group at this instant, keeping
    /// the clock's count.
    ///
    /// How long the idle loop polled before a frame arrived depends on the host, so
    /// a free-running counter would start each measurement at a different phase
    /// within its tick and within its 21-tick group, and a count could differ by a
    /// few instructions from run to run. Writing SYST_CVR restarts the count from
    /// the reload value at the write (QEMU anchors the tick period there), and the
    /// unfinished group is completed, so a measurement that starts a fixed number
    /// of instructions after this call reads the same count in every run. The clock
    /// gains less than one group (125 ns) per call.
    pub fn align(&self) {
        self.ticks();
        let rest = self.rest_ticks.get();
        if rest > 0 {
            self.ticks
                .set(self.ticks.get() + u64::from(TICK_GROUP - rest));
            self.rest_ticks.set(0);
            self.group_instructions.set(
                self.group_instructions
                    .get()
                    .wrapping_add(INSTRUCTIONS_PER_GROUP),
            );
        }
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
    /// Instructions since the clock started, wrapping at 2^32: 125 per 21 ticks,
    /// rounded down.
    #[inline(always)]
    fn now(&self) -> u32 {
        self.ticks();
        self.group_instructions
            .get()
            .wrapping_add(self.rest_ticks.get() * INSTRUCTIONS_PER_GROUP / TICK_GROUP)
    }
}
