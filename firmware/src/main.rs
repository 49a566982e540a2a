//! The decoy controller firmware: [`decoy_controller::Controller`] on the board's
//! UART.
//!
//! At boot it builds the controller from the reference system embedded by
//! `build.rs` (from `config/`), sends Hello, then runs the controller's serve loop
//! (`decoy_controller::serve`): bytes from the UART go through the frame decoder
//! into the controller, every answer is encoded and written back, and the link's
//! silence is supervised with the millisecond clock. On a board with the advisory
//! line (the STM32F405), the line follows each Output's hazard flags
//! (`decoy_firmware::advisory`), and each change is logged; on a board without it
//! the board's pin does nothing and the update compiles to nothing. The solver
//! lives inside the controller in a `static`; nothing is allocated. Hardware is in
//! the board module only (`src/board/`, chosen by `firmware/boards.toml` and the
//! board's feature); precision by feature `f64`.
#![no_std]
#![no_main]

// Links cortex-m's `critical-section` implementation (used by defmt and semihosting).
use cortex_m as _;
use cortex_m_rt::entry;
use decoy_controller::Controller;
use decoy_controller::serve::{self, Event};
use decoy_firmware::advisory::Advisory;
use decoy_firmware::board::{self, Board};
use decoy_firmware::{SEGMENT_CAPACITY, Scalar, reference};
use decoy_link::{DeviceMessage, FrameDecoder};
use static_cell::ConstStaticCell;

/// Log a line every this many accepted State frames.
const LOG_EVERY_FRAMES: u32 = 100;

/// The controller, with its solver, in static memory (`.bss`): a constant of zero
/// bits ([`Controller::UNCONFIGURED`]) until `build_controller` configures it in
/// place, so that it never passes through the stack (37.5 KB in f64, with the
/// M7's 64 KiB of RAM).
type EmbeddedController = Controller<Scalar, SEGMENT_CAPACITY>;
static CONTROLLER: ConstStaticCell<EmbeddedController> =
    ConstStaticCell::new(EmbeddedController::UNCONFIGURED);
/// The frame decoder's buffer, in static memory (`.bss`).
static DECODER: ConstStaticCell<FrameDecoder> = ConstStaticCell::new(FrameDecoder::new());

#[entry]
fn main() -> ! {
    board::paint_stack();
    let Some(board) = Board::take() else {
        defmt::error!("the board's peripherals are already taken or cannot be set up");
        board::fail()
    };
    let Board {
        mut uart,
        clock,
        advisory,
    } = board;
    let advisory = match Advisory::new(advisory) {
        Ok(advisory) => advisory,
        Err(never) => match never {},
    };
    let controller = match build_controller() {
        Ok(controller) => controller,
        Err(e) => {
            defmt::error!("cannot build the controller: {}", defmt::Display2Format(&e));
            board::fail()
        }
    };
    let Some(decoder) = DECODER.try_take() else {
        defmt::error!("the frame decoder was already taken");
        board::fail()
    };
    defmt::info!(
        "decoy controller: board {=str}, f{=usize}, {=usize} segments (capacity {=usize}), controller {=usize} B, stack room {=u32} B, protocol {=u16}",
        board::INFO.name.as_str(),
        core::mem::size_of::<Scalar>() * 8,
        controller.solver().model().segment_count(),
        SEGMENT_CAPACITY,
        core::mem::size_of::<EmbeddedController>(),
        board::stack_size(),
        decoy_link::PROTOCOL_VERSION
    );
    // The boot's stack peak (building the controller) is over; measure the
    // link's own from here.
    defmt::info!("boot stack high-water {=u32} B", board::stack_high_water());
    board::paint_stack();
    if let Err(e) = serve::send(&mut uart, &controller.hello(&board::INFO)) {
        defmt::warn!("uart: {}", defmt::Debug2Format(&e));
    }

    run(controller, decoder, &mut uart, &clock, advisory)
}

/// The serve loop, logging what it does. Not inlined into `main`, so that its
/// stack and the boot's (building the controller) do not add up.
#[inline(never)]
fn run(
    controller: &mut EmbeddedController,
    decoder: &mut FrameDecoder,
    uart: &mut board::Uart,
    clock: &board::Clock,
    mut advisory: Advisory<board::AdvisoryPin>,
) -> ! {
    let mut accepted: u32 = 0;
    serve::serve(controller, decoder, uart, clock, |event| match event {
        Event::Answered(answer) => {
            log_answer(answer, &mut accepted);
            drive_advisory(&mut advisory, answer);
        }
        Event::Silent(_) => defmt::warn!("link silent: degraded"),
        Event::ReadFailed(kind) | Event::WriteFailed(kind) => {
            defmt::warn!("uart: {}", defmt::Debug2Format(&kind))
        }
    })
}

/// Configures the controller in its `static`, in place: the reference system's
/// configuration (a few KB, the aerodynamic table included) is the largest value
/// on the stack, never the controller or its solver.
#[inline(never)]
fn build_controller() -> Result<&'static mut EmbeddedController, BuildError> {
    let controller = CONTROLLER.try_take().ok_or(BuildError::Taken)?;
    let system = &reference::SYSTEM;
    let config = system
        .controller_config::<Scalar>(system.embedded_layout())
        .map_err(BuildError::AeroTable)?;
    controller
        .configure(&config)
        .map_err(BuildError::Controller)?;
    Ok(controller)
}

/// Why the controller could not be built (a configuration the solver rejects).
#[derive(Debug)]
enum BuildError {
    /// The controller's `static` was already taken (built twice).
    Taken,
    /// The aerodynamic table is unusable.
    AeroTable(solver_core::AeroTableError),
    /// The controller rejected its configuration (the model's parameters or the
    /// allowable tension).
    Controller(decoy_controller::ControllerError),
}

impl core::fmt::Display for BuildError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            BuildError::Taken => f.write_str("the controller was already built"),
            BuildError::AeroTable(e) => write!(f, "aerodynamic table: {e}"),
            BuildError::Controller(e) => write!(f, "controller: {e}"),
        }
    }
}

/// Logs rejections, and one line every [`LOG_EVERY_FRAMES`] outputs.
fn log_answer(answer: &DeviceMessage, accepted: &mut u32) {
    match answer {
        DeviceMessage::Output(o) => {
            *accepted = accepted.wrapping_add(1);
            if accepted.is_multiple_of(LOG_EVERY_FRAMES) || o.steps == 0 {
                defmt::info!(
                    "seq={=u32} t={=f64} T0={=f32} TN={=f32} steps={=u16} instr={=u32} step_instr={=u32} flags={=u16:#x} stack={=u32}",
                    o.seq,
                    o.time_s,
                    o.connection_tension_n,
                    o.tow_tension_n,
                    o.steps,
                    o.instructions,
                    o.step_instructions,
                    o.flags,
                    board::stack_high_water()
                );
            }
        }
        DeviceMessage::Rejected(r) => {
            defmt::warn!(
                "rejected seq={} reason={} count={=u32}",
                r.seq,
                defmt::Debug2Format(&r.reason),
                r.count
            );
        }
        _ => {}
    }
}

/// Drives the advisory line from an Output's management report and logs each change (under
/// QEMU, whose GPIO is a stub, the log is the only trace of the line). Nothing on a
/// board without the line: its pin is not wired, so the update never changes it.
fn drive_advisory(advisory: &mut Advisory<board::AdvisoryPin>, answer: &DeviceMessage) {
    let DeviceMessage::Output(o) = answer else {
        return;
    };
    match advisory.update(&o.management) {
        Ok(Some(true)) => defmt::info!(
            "advisory line asserted: seq={=u32} level={=u8} advisories={=u8:#x}",
            o.seq,
            o.management.worst_level().index(),
            o.management.advisories
        ),
        Ok(Some(false)) => defmt::info!(
            "advisory line deasserted: seq={=u32} level={=u8} advisories={=u8:#x}",
            o.seq,
            o.management.worst_level().index(),
            o.management.advisories
        ),
        Ok(None) => {}
        Err(never) => match never {},
    }
}
