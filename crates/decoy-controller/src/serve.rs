//! The controller's main loop over a byte link and a clock: what the firmware
//! runs, written once against traits so that the same loop also runs on the host
//! (a test drives it through an in-memory loopback).
//!
//! The link is any `embedded-io` byte stream that can say whether a byte is ready
//! (`Read + ReadReady + Write`: a UART); the clock is a [`Clock`], an instruction
//! counter with a millisecond reading for the link supervision. One [`poll`]
//! takes at most one received byte through the frame decoder into the
//! controller, writes the answer of a completed frame, and supervises the link's
//! silence; [`serve`] polls forever. Nothing is allocated.

use decoy_link::{Decoder, DeviceMessage, HostMessage, MAX_WIRE_BYTES, encode};
use embedded_io::{Error as _, ErrorKind, Read, ReadReady, Write};
use solver_core::Real;

use crate::controller::{Controller, InstructionCounter};

/// The controller's time source: instructions (or ticks) for the Output frames'
/// measurements, milliseconds for the link supervision.
pub trait Clock: InstructionCounter {
    /// A free-running millisecond reading (wrapping).
    fn now_ms(&self) -> u32;
    /// Called just before a received frame is handled, so that every measurement
    /// starts at the same phase of a coarse tick (a no-op where counts are exact).
    fn align(&self) {}
}

/// What one [`poll`] did that its caller may want to log.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event<'a> {
    /// A frame was completed and this answer written.
    Answered(&'a DeviceMessage),
    /// The link fell silent: this Status (DEGRADED) was written.
    Silent(&'a DeviceMessage),
    /// Reading the link failed.
    ReadFailed(ErrorKind),
    /// Writing an answer failed (the answer is lost; the controller's state is not).
    WriteFailed(ErrorKind),
}

/// Encodes `message` and writes the whole frame to `link`.
pub fn send<W: Write>(link: &mut W, message: &DeviceMessage) -> Result<(), ErrorKind> {
    let mut wire = [0u8; MAX_WIRE_BYTES];
    // Every DeviceMessage fits a frame (decoy-link's tests encode the largest).
    let length = encode(message, &mut wire).map_err(|_| ErrorKind::InvalidData)?;
    let mut rest = wire.get(..length).ok_or(ErrorKind::InvalidData)?;
    // `Write::write_all` panics on a write of 0 bytes: here that is an error,
    // and no slice can panic (firmware/README.md, "No panic in flight").
    while !rest.is_empty() {
        match link.write(rest) {
            Ok(0) => return Err(ErrorKind::WriteZero),
            Ok(n) => rest = rest.get(n..).unwrap_or(&[]),
            Err(e) => return Err(e.kind()),
        }
    }
    Ok(())
}

/// One turn of the loop: at most one byte from `link` through `decoder` into
/// `controller`, the answer to a completed frame written back and then the
/// frame's look-ahead slice run ([`Controller::background`]: the answer does not
/// wait for the prediction), then the silence supervision at `clock.now_ms()`.
/// `observe` sees what happened.
pub fn poll<T, const N: usize, const CAP: usize, L, C>(
    controller: &mut Controller<T, N>,
    decoder: &mut Decoder<CAP>,
    link: &mut L,
    clock: &C,
    observe: &mut impl FnMut(Event<'_>),
) where
    T: Real,
    L: Read + ReadReady + Write,
    C: Clock,
{
    match link.read_ready() {
        Ok(true) => {
            let mut byte = [0u8; 1];
            match link.read(&mut byte) {
                Ok(1) => {
                    if let Some(frame) = decoder.push::<HostMessage>(byte[0]) {
                        clock.align();
                        let mut counter = clock;
                        let answer = match frame {
                            Ok(message) => controller.handle(message, &mut counter),
                            Err(error) => controller.on_frame_error(error),
                        };
                        match send(link, &answer) {
                            Ok(()) => observe(Event::Answered(&answer)),
                            Err(kind) => observe(Event::WriteFailed(kind)),
                        }
                        // The frame's look-ahead slice, once its answer is out.
                        controller.background(&mut counter);
                    }
                }
                Ok(_) => {}
                Err(e) => observe(Event::ReadFailed(e.kind())),
            }
        }
        Ok(false) => {}
        Err(e) => observe(Event::ReadFailed(e.kind())),
    }
    if let Some(status) = controller.poll_silence(clock.now_ms()) {
        match send(link, &status) {
            Ok(()) => observe(Event::Silent(&status)),
            Err(kind) => observe(Event::WriteFailed(kind)),
        }
    }
}

/// [`poll`] forever: the firmware's main loop.
pub fn serve<T, const N: usize, const CAP: usize, L, C>(
    controller: &mut Controller<T, N>,
    decoder: &mut Decoder<CAP>,
    link: &mut L,
    clock: &C,
    mut observe: impl FnMut(Event<'_>),
) -> !
where
    T: Real,
    L: Read + ReadReady + Write,
    C: Clock,
{
    loop {
        poll(controller, decoder, link, clock, &mut observe);
    }
}
