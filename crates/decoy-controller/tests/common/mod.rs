//! Shared helpers: the reference system's controller and steady-flight frames.
#![allow(dead_code)]

use decoy_config::SystemConfig;
use decoy_controller::{Controller, ControllerConfig, NoCounter};
use decoy_link::{AircraftStateFrame, DeviceMessage, HostMessage, OutputFrame};
use solver_core::Real;

/// Capacity of the test controllers (the firmware's).
pub const CAPACITY: usize = 64;
/// Flight speed of the test frames, m/s (Mach 0.6 at 9 km).
pub const SPEED: f64 = 182.0;
/// Altitude of the test frames, m.
pub const ALTITUDE: f64 = 9000.0;

/// The reference system's controller configuration in `T` (its embedded model).
pub fn config<T: Real>() -> ControllerConfig<T> {
    let system = SystemConfig::builtin().unwrap();
    system.controller_config(system.embedded_layout()).unwrap()
}

/// A fresh f32 controller (the firmware's precision).
pub fn controller() -> Controller<f32, CAPACITY> {
    Controller::new(config()).unwrap()
}

/// Steady level flight heading north at [`SPEED`], frame `seq` at `time_s`.
pub fn frame(seq: u32, time_s: f64) -> AircraftStateFrame {
    AircraftStateFrame {
        seq,
        time_s,
        position_ned_m: [SPEED * time_s + 1000.0, -250.0, -ALTITUDE],
        velocity_ned_mps: [SPEED as f32, 0.0, 0.0],
        acceleration_ned_mps2: [0.0; 3],
        attitude_wxyz: [1.0, 0.0, 0.0, 0.0],
        body_rate_radps: [0.0; 3],
        body_angular_acceleration_radps2: [0.0; 3],
    }
}

/// Sends a State frame, returns the answer.
pub fn send<T: Real, const N: usize>(
    c: &mut Controller<T, N>,
    f: AircraftStateFrame,
) -> DeviceMessage {
    c.handle(HostMessage::State(f), &mut NoCounter)
}

/// The Output of an answer (panics otherwise: tests only).
pub fn output(answer: DeviceMessage) -> OutputFrame {
    match answer {
        DeviceMessage::Output(o) => o,
        other => panic!("expected an Output, got {other:?}"),
    }
}

/// The Output of an answer, or `None` for the Status answering a State frame
/// while the controller initialises (panics otherwise: tests only).
pub fn output_or_initialising(answer: DeviceMessage) -> Option<OutputFrame> {
    match answer {
        DeviceMessage::Output(o) => Some(o),
        DeviceMessage::Status(s)
            if decoy_link::StatusFlags(s.flags).contains(decoy_link::StatusFlags::INITIALISING) =>
        {
            None
        }
        other => panic!("expected an Output or the initialisation's Status, got {other:?}"),
    }
}

/// Sends the frames `frame(k)` for k = 0, 1, ... while the controller
/// initialises; returns the first Output and its k (the frames after it are
/// answered by Outputs).
pub fn initialise<T: Real, const N: usize>(
    c: &mut Controller<T, N>,
    frame: impl Fn(u32) -> AircraftStateFrame,
) -> (OutputFrame, u32) {
    for k in 0..64 {
        if let Some(o) = output_or_initialising(send(c, frame(k))) {
            return (o, k);
        }
    }
    panic!("the controller was still initialising after 64 frames");
}

/// A controller trimmed at t = 0 (initialised over its first frames) and stepped
/// through `frames` 10 ms frames (answered by Outputs from the trim on).
pub fn running(frames: u32) -> Controller<f32, CAPACITY> {
    running_in(frames)
}

/// [`running`] in precision `T`.
pub fn running_in<T: Real>(frames: u32) -> Controller<T, CAPACITY> {
    let mut c = Controller::new(config::<T>()).unwrap();
    let (_, first) = initialise(&mut c, |k| frame(k, 0.01 * f64::from(k)));
    assert!(
        first <= frames,
        "initialised at frame {first}, after {frames}"
    );
    for k in first + 1..=frames {
        output(send(&mut c, frame(k, 0.01 * f64::from(k))));
    }
    c
}
