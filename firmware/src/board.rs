//! The board: QEMU's MPS2 AN386 (Cortex-M4F, 25 MHz core clock), and how the
//! application uses it. Everything hardware-specific lives here.
//!
//! | role | peripheral |
//! |---|---|
//! | instruction counter | SysTick on the core clock, counting down from 0xFF_FFFF |
//! | console and exit code | Arm semihosting (`hprintln!`, `debug::exit`) |
//! | stack high-water mark | stack painting (cortex-m-stack, cortex-m-rt's `_stack_end`) |
//!
//! Failures (panics, HardFaults) print through semihosting and exit QEMU with a
//! failure code, so a test run never hangs on them.

use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::{ExceptionFrame, exception};
use cortex_m_semihosting::{debug, hprintln};

/// SysTick's reload value: the full 24-bit range.
const SYSTICK_RELOAD: u32 = 0x00FF_FFFF;

/// Executed instructions per SysTick tick under `-icount shift=0`: virtual time
/// advances 1 ns per instruction and SysTick runs on the 25 MHz core clock, so one
/// tick (40 ns) is 40 instructions. Measured: a 200,002-instruction delay loop
/// reads 5,000 ticks. Counts are therefore multiples of 40.
pub const INSTRUCTIONS_PER_TICK: u32 = 40;

/// The peripherals the application uses.
pub struct Board {
    /// Counts executed instructions (under QEMU `-icount`).
    pub instructions: InstructionCounter,
}

impl Board {
    /// Takes the core peripherals and sets them up; `None` if already taken.
    pub fn take() -> Option<Self> {
        let peripherals = cortex_m::Peripherals::take()?;
        Some(Board {
            instructions: InstructionCounter::new(peripherals.SYST),
        })
    }
}

/// A reading of the instruction counter, see [`InstructionCounter::now`].
#[derive(Clone, Copy, Debug)]
pub struct Instant(u32);

/// SysTick as a free-running down-counter of executed instructions.
///
/// Under QEMU `-icount shift=0,align=off,sleep=off` virtual time advances exactly
/// 1 ns per executed instruction, so the count is deterministic run to run and
/// independent of host load. On real hardware it would count core cycles / 40.
pub struct InstructionCounter {
    _systick: SYST,
}

impl InstructionCounter {
    /// Starts SysTick on the core clock, counting down from [`SYSTICK_RELOAD`],
    /// without interrupts.
    fn new(mut systick: SYST) -> Self {
        systick.disable_interrupt();
        systick.set_clock_source(SystClkSource::Core);
        systick.set_reload(SYSTICK_RELOAD);
        systick.clear_current();
        systick.enable_counter();
        InstructionCounter { _systick: systick }
    }

    /// The current reading.
    #[inline(always)]
    pub fn now(&self) -> Instant {
        Instant(SYST::get_current())
    }

    /// Instructions executed since `start`, in multiples of
    /// [`INSTRUCTIONS_PER_TICK`].
    ///
    /// The counter wraps every 2^24 ticks (671 M instructions); the modular
    /// difference is right for any interval shorter than that, which a control
    /// step (about 10^5) and the trim (about 10^7) are by far.
    #[inline(always)]
    pub fn since(&self, start: Instant) -> u32 {
        let ticks = start.0.wrapping_sub(SYST::get_current()) & SYSTICK_RELOAD;
        ticks * INSTRUCTIONS_PER_TICK
    }
}

/// Paints the unused stack so that [`stack_high_water`] can find how deep it got.
pub fn paint_stack() {
    cortex_m_stack::repaint_stack();
}

/// Bytes of stack used at the deepest point since [`paint_stack`], out of
/// [`stack_size`] (an estimate: the first unpainted word from the bottom).
pub fn stack_high_water() -> u32 {
    cortex_m_stack::stack_size() - cortex_m_stack::stack_painted()
}

/// Bytes of RAM the stack may grow into (all RAM above `.bss`).
pub fn stack_size() -> u32 {
    cortex_m_stack::stack_size()
}

/// Ends the run: QEMU exits with status 0.
pub fn exit_success() -> ! {
    debug::exit(debug::EXIT_SUCCESS);
    unreachable_exit()
}

/// Ends the run: QEMU exits with status 1.
pub fn exit_failure() -> ! {
    debug::exit(debug::EXIT_FAILURE);
    unreachable_exit()
}

/// Semihosting exit returns only without a debugger or QEMU; park the core.
fn unreachable_exit() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    hprintln!("panic: {}", info);
    exit_failure()
}

// cortex-m-rt requires the HardFault handler to be an `unsafe fn` (it runs on a
// possibly corrupt stack); this is the crate's only unsafe code, and it does nothing
// unsafe: it prints the stacked frame and exits.
#[allow(unsafe_code)]
#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    hprintln!("hardfault: {:?}", frame);
    exit_failure()
}
