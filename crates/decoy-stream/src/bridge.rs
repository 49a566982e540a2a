//! A bridge as a [`Transport`]: host-bridge's [`BridgeClient`], lockstep (a
//! request with the client's deadline) or free-running (published states, the
//! answers from the outputs service, matched by sequence number); its answers
//! are the bridge's wire answers.

use std::time::Duration;

use bridge_types::{Answer, command, kind, reason, result};
use decoy_link::{AircraftStateFrame, OutputFrame};
use host_bridge::BridgeError;
use host_bridge::client::BridgeClient;
use host_bridge::convert::{from_link_frame, output_to_link};

use crate::transport::{FrameAnswer, FreeRunning, Transport};

impl Transport for BridgeClient {
    type Answer = Answer;
    type Error = BridgeError;

    fn reset(&mut self) -> Result<(), BridgeError> {
        let reply = self.simple_command(command::RESET_TO_TRIM)?;
        if reply.result == result::OK {
            Ok(())
        } else {
            Err(BridgeError::Backend(format!(
                "the bridge refused the reset: {}",
                reason::name(reply.reason)
            )))
        }
    }

    fn step(&mut self, frame: &AircraftStateFrame) -> Result<Answer, BridgeError> {
        BridgeClient::step(self, &from_link_frame(frame))
    }

    fn free_running(
        &mut self,
    ) -> Option<&mut dyn FreeRunning<Answer = Answer, Error = BridgeError>> {
        Some(self)
    }
}

impl FreeRunning for BridgeClient {
    type Answer = Answer;
    type Error = BridgeError;

    fn publish(&mut self, frame: &AircraftStateFrame) -> Result<(), BridgeError> {
        BridgeClient::publish(self, &from_link_frame(frame))
    }

    fn take(&mut self) -> Result<Vec<Answer>, BridgeError> {
        self.take_outputs()
    }

    fn wait(&mut self, within: Duration) -> Result<(), BridgeError> {
        self.wait_event(within)
    }
}

impl FrameAnswer for Answer {
    fn seq(&self) -> Option<u32> {
        Some(if self.header.kind == kind::REJECTED {
            self.rejection.request_seq
        } else {
            self.output.request_seq
        })
    }

    fn output(&self) -> Option<OutputFrame> {
        (self.header.kind == kind::OUTPUT).then(|| output_to_link(&self.output))
    }

    fn is_initialising(&self) -> bool {
        self.header.kind == kind::INITIALISING
    }

    fn rejection(&self) -> Option<(String, u64)> {
        (self.header.kind == kind::REJECTED).then(|| {
            (
                reason::name(self.rejection.reason).to_owned(),
                self.rejection.count,
            )
        })
    }

    fn time_s(&self) -> Option<f64> {
        (self.header.kind != kind::REJECTED).then_some(self.output.time_s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use decoy_link::StatusFrame;
    use host_bridge::convert::{
        initialising_answer, output_answer, output_from_link, rejected_answer,
    };

    /// Each kind of wire answer reads as the answer it is, the frame it
    /// answers named by its own sequence number.
    #[test]
    fn wire_answers_read_by_kind() {
        let out = OutputFrame {
            seq: 7,
            time_s: 0.07,
            connection_tension_n: 900.0,
            tow_tension_n: 40.0,
            decoy_position_fp_m: [100.0, 0.0, 12.0],
            angle_of_attack_rad: 0.01,
            cable_clearance_exhaust_m: 1.5,
            decoy_clearance_aircraft_m: 99.0,
            flags: 1,
            steps: 4,
            ..OutputFrame::ZERO
        };
        let output = output_answer(1, output_from_link(&out));
        assert_eq!(output.seq(), Some(7));
        assert_eq!(output.output(), Some(out));
        assert_eq!((output.time_s(), output.rejection()), (Some(0.07), None));
        assert!(!output.is_initialising());

        let status = StatusFrame {
            instructions: 120_000,
            protocol_version: decoy_link::PROTOCOL_VERSION,
            flags: decoy_link::StatusFlags::INITIALISING,
            segments: 12,
            time_s: 0.01,
            counters: Default::default(),
        };
        let init = initialising_answer(2, 1, &status);
        assert_eq!((init.seq(), init.output()), (Some(1), None));
        assert!(init.is_initialising());
        assert_eq!(init.time_s(), Some(0.01));

        let rejected = rejected_answer(3, 9, reason::TIME_JUMP, 2);
        assert_eq!(rejected.seq(), Some(9));
        assert_eq!(rejected.rejection(), Some(("time_jump".to_owned(), 2)));
        assert_eq!((rejected.output(), rejected.time_s()), (None, None));
        assert!(!rejected.is_initialising());
    }
}
