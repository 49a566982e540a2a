//! The firmware's UART as a [`Transport`]: `decoy_hil::link`'s [`Session`] (the
//! firmware under QEMU, or the controller emulated on the host behind the
//! same TCP link), lockstep, every answer within the link's deadline; its
//! answers are the decoy link's messages as the controller sent them.

use decoy_hil::link::{LinkError, Session};
use decoy_link::{
    AircraftStateFrame, Command, DeviceMessage, HostMessage, OutputFrame, StatusFlags,
};

use crate::transport::{FrameAnswer, Transport};

impl Transport for Session {
    type Answer = DeviceMessage;
    type Error = LinkError;

    fn reset(&mut self) -> Result<(), LinkError> {
        match self
            .link
            .request(&HostMessage::Command(Command::ResetToTrim))?
        {
            DeviceMessage::Status(_) => Ok(()),
            other => Err(LinkError::Unexpected {
                expected: "the Status answering ResetToTrim",
                got: Box::new(other),
            }),
        }
    }

    fn step(&mut self, frame: &AircraftStateFrame) -> Result<DeviceMessage, LinkError> {
        self.link.request(&HostMessage::State(*frame))
    }
}

/// The Status answering a State frame the initialisation took.
fn initialising(message: &DeviceMessage) -> Option<f64> {
    match message {
        DeviceMessage::Status(s) if StatusFlags(s.flags).contains(StatusFlags::INITIALISING) => {
            Some(s.time_s)
        }
        _ => None,
    }
}

impl FrameAnswer for DeviceMessage {
    fn seq(&self) -> Option<u32> {
        match self {
            DeviceMessage::Output(o) => Some(o.seq),
            DeviceMessage::Rejected(r) => r.seq,
            _ => None,
        }
    }

    fn output(&self) -> Option<OutputFrame> {
        match self {
            DeviceMessage::Output(o) => Some(*o),
            _ => None,
        }
    }

    fn is_initialising(&self) -> bool {
        initialising(self).is_some()
    }

    fn rejection(&self) -> Option<(String, u64)> {
        match self {
            DeviceMessage::Rejected(r) => Some((format!("{:?}", r.reason), u64::from(r.count))),
            _ => None,
        }
    }

    fn time_s(&self) -> Option<f64> {
        match self {
            DeviceMessage::Output(o) => Some(o.time_s),
            other => initialising(other),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use decoy_config::SystemConfig;
    use decoy_hil::flight::{self, host_controller, replay, scenario_frames};
    use solver_core::profiles::LevelAcceleration;

    /// The UART transport against the host controller on the other end of a
    /// real TCP link: reset, then every frame stepped, answers exactly those
    /// of a replay of the same messages.
    #[test]
    fn an_emulated_device_answers_the_transport_as_the_replay() {
        let config = SystemConfig::builtin().unwrap();
        let path = LevelAcceleration {
            altitude: 9000.0,
            initial_speed: 182.0,
            final_speed: 243.0,
            start: 0.2,
            acceleration: 10.0,
        };
        let frames = scenario_frames(&path, 30);
        let mut session = Session::emulated(
            host_controller::<f32>(&config).unwrap(),
            decoy_hil::qemu::Board::default(),
        )
        .unwrap();
        session.reset().unwrap();
        let answers: Vec<DeviceMessage> = frames.iter().map(|f| session.step(f).unwrap()).collect();
        let replayed = replay(
            &mut host_controller::<f32>(&config).unwrap(),
            &flight::scenario_messages(&frames),
        );
        assert_eq!(answers, replayed[1..]);
        assert!(answers.iter().all(|a| a.output().is_some()));
        assert_eq!(answers[7].seq(), Some(7));
        assert_eq!(answers[7].time_s(), Some(0.07));
        assert_eq!(answers[7].rejection(), None);
    }
}
