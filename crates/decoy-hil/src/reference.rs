//! The host reference: the firmware's controller (`decoy_controller::Controller`,
//! the firmware's capacity, the reference system's embedded model) run in this
//! process, in the firmware's precision.
//!
//! Every transcendental function of the solver and the controller goes to the
//! `libm` crate in every build (solver-core's `Real`, nalgebra's `libm-force`), so
//! this controller computes the target's bits: its f32 answers equal the M4
//! firmware's and its f64 answers the M7's, bit for bit. It is fed exactly what the
//! firmware is fed (wire bytes, and the link supervision's clock) and answers what
//! the firmware answers.

use std::fmt;

use decoy_config::SystemConfig;
use decoy_controller::{Controller, NoCounter};
use decoy_link::{DeviceMessage, FrameDecoder, HostMessage};

use crate::flight::{CONTROLLER_CAPACITY as CAPACITY, HostSetupError, host_controller};

/// Why the reference could not be built or used.
#[derive(Debug)]
pub enum ReferenceError {
    /// The configuration gives no controller (bad model, too many segments).
    Config(String),
    /// The precision is neither 32 nor 64 bits.
    Precision(u8),
    /// A message that cannot be encoded, or not exactly one answer to a message.
    Protocol(String),
}

impl fmt::Display for ReferenceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReferenceError::Config(e) => write!(f, "the host reference controller: {e}"),
            ReferenceError::Precision(bits) => {
                write!(
                    f,
                    "the host reference runs f32 or f64, not {bits}-bit floats"
                )
            }
            ReferenceError::Protocol(e) => write!(f, "the host reference answered badly: {e}"),
        }
    }
}

impl std::error::Error for ReferenceError {}

/// The controller in one of the two precisions (boxed: the solver is large).
enum Precision {
    F32(Box<Controller<f32, CAPACITY>>),
    F64(Box<Controller<f64, CAPACITY>>),
}

/// A host reference controller and the decoder of the bytes it receives.
pub struct Reference {
    controller: Precision,
    decoder: FrameDecoder,
}

impl Reference {
    /// A controller of `precision_bits` (32 or 64) for the built-in reference
    /// system with `segments` embedded segments.
    pub fn start(precision_bits: u8, segments: usize) -> Result<Self, ReferenceError> {
        let mut config =
            SystemConfig::builtin().map_err(|e| ReferenceError::Config(e.to_string()))?;
        config.solver.segments_embedded = segments;
        Self::for_config(&config, precision_bits)
    }

    /// A controller of `precision_bits` for `config`'s embedded model.
    pub fn for_config(config: &SystemConfig, precision_bits: u8) -> Result<Self, ReferenceError> {
        let bad = |e: HostSetupError| ReferenceError::Config(e.to_string());
        let controller = match precision_bits {
            32 => Precision::F32(host_controller(config).map_err(bad)?),
            64 => Precision::F64(host_controller(config).map_err(bad)?),
            other => return Err(ReferenceError::Precision(other)),
        };
        Ok(Reference {
            controller,
            decoder: FrameDecoder::new(),
        })
    }

    /// Feeds the bytes the controller receives; returns every answer they produce.
    pub fn feed(&mut self, bytes: &[u8]) -> Vec<DeviceMessage> {
        let mut answers = Vec::new();
        let decoder = &mut self.decoder;
        match &mut self.controller {
            Precision::F32(c) => {
                c.handle_bytes(decoder, bytes, &mut NoCounter, |a| answers.push(*a))
            }
            Precision::F64(c) => {
                c.handle_bytes(decoder, bytes, &mut NoCounter, |a| answers.push(*a))
            }
        }
        answers
    }

    /// The answer to one message, through the wire as the firmware receives it.
    pub fn handle(&mut self, message: &HostMessage) -> Result<DeviceMessage, ReferenceError> {
        let wire =
            crate::link::encode(message).map_err(|e| ReferenceError::Protocol(e.to_string()))?;
        let mut answers = self.feed(&wire);
        match (answers.pop(), answers.is_empty()) {
            (Some(answer), true) => Ok(answer),
            _ => Err(ReferenceError::Protocol(format!(
                "not one answer to {message:?}"
            ))),
        }
    }

    /// The answers to `messages`, one each.
    pub fn replay(
        &mut self,
        messages: &[HostMessage],
    ) -> Result<Vec<DeviceMessage>, ReferenceError> {
        messages.iter().map(|m| self.handle(m)).collect()
    }

    /// Polls the link supervision with the clock at `now_ms`.
    pub fn poll_silence(&mut self, now_ms: u32) -> Option<DeviceMessage> {
        match &mut self.controller {
            Precision::F32(c) => c.poll_silence(now_ms),
            Precision::F64(c) => c.poll_silence(now_ms),
        }
    }
}
