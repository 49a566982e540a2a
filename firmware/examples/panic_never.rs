//! The link-time proof that the frame path cannot panic (issue 22), built with
//! feature `panic-never` (`cargo build --release --example panic_never
//! --features panic-never`): the serve loop over the board's UART and clock,
//! with the controller's `handle` and `background` on every frame, exactly as
//! `src/main.rs` runs them, linked with a panic handler that calls a function
//! defined nowhere. The link succeeds only if the optimiser removed every call
//! of the handler: no panic is reachable from the frame path.
//!
//! The controller's configuration (boot) is left out: the controller comes from
//! its `static` through `black_box`, so the optimiser knows nothing of its state
//! (configured or not, any model) and must keep every path of the frame code.
#![no_std]
#![no_main]

use cortex_m as _;
use cortex_m_rt::entry;
use decoy_controller::Controller;
use decoy_controller::serve;
use decoy_firmware::board::{self, Board};
use decoy_firmware::{SEGMENT_CAPACITY, Scalar};
use decoy_link::FrameDecoder;
use static_cell::ConstStaticCell;

type EmbeddedController = Controller<Scalar, SEGMENT_CAPACITY>;
static CONTROLLER: ConstStaticCell<EmbeddedController> =
    ConstStaticCell::new(EmbeddedController::UNCONFIGURED);
static DECODER: ConstStaticCell<FrameDecoder> = ConstStaticCell::new(FrameDecoder::new());

#[entry]
fn main() -> ! {
    let Some(board) = Board::take() else {
        board::fail()
    };
    let Board {
        mut uart, clock, ..
    } = board;
    let Some(controller) = CONTROLLER.try_take() else {
        board::fail()
    };
    let controller = core::hint::black_box(controller);
    let Some(decoder) = DECODER.try_take() else {
        board::fail()
    };
    let decoder = core::hint::black_box(decoder);
    serve::serve(controller, decoder, &mut uart, &clock, |event| {
        core::hint::black_box(&event);
    })
}
