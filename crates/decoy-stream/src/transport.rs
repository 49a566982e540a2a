//! What carries a streamed run to a decoy controller and its answers back: a
//! [`Transport`] (the firmware's UART, `crate::uart`; a bridge,
//! `crate::bridge`), whose answers the pipeline reads through [`FrameAnswer`],
//! each in the transport's own form (the decoy link's message, the bridge's
//! answer), so that nothing is converted that the summaries do not read.

use std::time::Duration;

use decoy_link::{AircraftStateFrame, OutputFrame};

/// The host's end of a link to a decoy controller.
pub trait Transport {
    /// An answer as the transport delivers it.
    type Answer: FrameAnswer;
    /// Why the transport failed.
    type Error;

    /// Sends the command `ResetToTrim` and takes its reply: the next State
    /// frame starts a new run from the trim at that frame.
    fn reset(&mut self) -> Result<(), Self::Error>;

    /// Sends one State frame and receives its answer within the transport's
    /// deadline (lockstep); a missing answer is an error.
    fn step(&mut self, frame: &AircraftStateFrame) -> Result<Self::Answer, Self::Error>;

    /// The transport's free-running side, if it has one (a bridge does; the
    /// UART is lockstep only).
    fn free_running(
        &mut self,
    ) -> Option<&mut dyn FreeRunning<Answer = Self::Answer, Error = Self::Error>> {
        None
    }
}

/// A transport that also carries State frames without waiting for their
/// answers, which come back on their own, matched by sequence number.
pub trait FreeRunning {
    /// An answer as the transport delivers it.
    type Answer: FrameAnswer;
    /// Why the transport failed.
    type Error;

    /// Sends one State frame; its answer comes later ([`FreeRunning::take`]).
    fn publish(&mut self, frame: &AircraftStateFrame) -> Result<(), Self::Error>;

    /// Every answer received since the last call, in order.
    fn take(&mut self) -> Result<Vec<Self::Answer>, Self::Error>;

    /// Blocks until the controller's side signals something or `within` passes.
    fn wait(&mut self, within: Duration) -> Result<(), Self::Error>;
}

/// What the pipeline reads of an answer to a State frame.
pub trait FrameAnswer: Copy {
    /// The sequence number of the State frame it answers, where it says.
    fn seq(&self) -> Option<u32>;

    /// The controller's Output, if it is one.
    fn output(&self) -> Option<OutputFrame>;

    /// Whether the frame was taken by the controller's initialisation (the
    /// trim spread over the first frames).
    fn is_initialising(&self) -> bool;

    /// Why the frame was rejected, in the transport's words, and how many
    /// frames the controller has rejected so far; `None` if it was not.
    fn rejection(&self) -> Option<(String, u64)>;

    /// The time of the frame the controller took (an Output's, or the
    /// initialisation's); `None` for a rejection.
    fn time_s(&self) -> Option<f64>;
}
