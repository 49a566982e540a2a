//! Flying a scenario over the link: aircraft state frames every control period from
//! the same flight profiles `decoy simulate` flies, sent in lock step to the
//! firmware, and the host's replay of the very same messages through
//! `decoy_controller::Controller` (f32 and f64) for comparison.

use std::time::{Duration, Instant};

use decoy_config::SystemConfig;
use decoy_controller::path::steady_flight;
use decoy_controller::{Controller, FramePath, NoCounter};
use decoy_link::{
    AircraftStateFrame, Command, DeviceMessage, HostMessage, OutputFrame, StatusFlags, StatusFrame,
};
use decoy_schema::Manoeuvre;
use decoy_sim::{RunOptions, RunPlan, Scenario, ScenarioKind, SimError};
use solver_core::{FlightPath, Real, SegmentLayout, Solver};

use crate::link::{LinkError, Session};

/// The controller's period: one aircraft state frame every 10 ms of simulated time.
pub const CONTROL_PERIOD_S: f64 = 0.01;

/// Segment capacity of the controller on the target and on the host.
pub const CONTROLLER_CAPACITY: usize = 64;

/// The aircraft state of `path` at `time_s` as a frame numbered `seq` (the
/// controller crate's conversion, which `decoy simulate` uses too).
pub use decoy_controller::path::state_frame;

/// Frames `0..=count` of `path`, frame k at t = k [`CONTROL_PERIOD_S`] (computed
/// as a product, not a running sum, so the times carry no accumulated error).
pub fn scenario_frames<P: FlightPath<f64>>(path: &P, count: u32) -> Vec<AircraftStateFrame> {
    (0..=count)
        .map(|k| {
            let t = f64::from(k) * CONTROL_PERIOD_S;
            state_frame(k, t, &path.state_at(t))
        })
        .collect()
}

/// Frames needed to fly `t_end` seconds: the last one at or just after `t_end`
/// (for a `t_end` of at most [`MAX_FRAMES`] frames; a run's, from the user,
/// goes through [`checked_frame_count`]).
pub fn frame_count(t_end: f64) -> u32 {
    (t_end / CONTROL_PERIOD_S - 1e-9).ceil().max(1.0) as u32
}

/// The most frames one run of `decoy hil` or `decoy feed` flies: 10 000 s of
/// 10 ms frames (2.8 h). Every frame, its answers and the host's replay are
/// kept in memory until the files are written.
pub const MAX_FRAMES: u32 = 1_000_000;

/// [`frame_count`] of a run's `t_end`, checked: a message for a usage error
/// when it needs more than [`MAX_FRAMES`] (never a saturated count).
/// `from_flag`: `t_end` is `--t-end`'s (else the scenario's `t_end_s`), for the
/// message.
pub fn checked_frame_count(t_end: f64, from_flag: bool) -> Result<u32, String> {
    let frames = (t_end / CONTROL_PERIOD_S - 1e-9).ceil().max(1.0);
    if frames.is_finite() && frames <= f64::from(MAX_FRAMES) {
        return Ok(frames as u32);
    }
    Err(format!(
        "{} {} s needs {} frames of {} s, more than the {MAX_FRAMES} ({} s) one run flies",
        if from_flag {
            "--t-end"
        } else {
            "the scenario's t_end_s"
        },
        decoy_sim::format::format_number(t_end),
        decoy_sim::format::format_number(frames),
        decoy_sim::format::format_number(CONTROL_PERIOD_S),
        decoy_sim::format::format_number(f64::from(MAX_FRAMES) * CONTROL_PERIOD_S),
    ))
}

/// Every manoeuvre the product ships, as issue 14's accuracy and worst-frame
/// studies fly them: (the kind, whose shipped scenario is flown; its rate;
/// simulated seconds). Every kind is here, a rate exactly for the manoeuvres
/// with one (tested).
pub const SHIPPED_MANOEUVRES: [(ScenarioKind, Option<f64>, f64); 8] = [
    (ScenarioKind::Manoeuvre(Manoeuvre::Steady), None, 10.0),
    (ScenarioKind::Manoeuvre(Manoeuvre::Acceleration), None, 12.0),
    (ScenarioKind::Manoeuvre(Manoeuvre::PullUp), Some(0.05), 10.0),
    (ScenarioKind::Manoeuvre(Manoeuvre::PullUp), Some(0.10), 10.0),
    (ScenarioKind::Manoeuvre(Manoeuvre::PullUp), Some(0.20), 10.0),
    (ScenarioKind::Manoeuvre(Manoeuvre::Turn), Some(0.10), 10.0),
    (ScenarioKind::Manoeuvre(Manoeuvre::Turn), Some(0.20), 10.0),
    (ScenarioKind::Recorded, None, 10.0),
];

/// The plan (`decoy simulate`'s, with `config`) and the frames of built-in
/// scenario `name` at `rate` over `t_end` seconds.
pub fn builtin_frames(
    config: &SystemConfig,
    name: &str,
    rate: Option<f64>,
    t_end: f64,
) -> Result<(RunPlan, Vec<AircraftStateFrame>), SimError> {
    let plan = Scenario::builtin(name)?.plan(
        config,
        &RunOptions {
            rate,
            t_end: Some(t_end),
            plots: false,
            ..RunOptions::default()
        },
    )?;
    let frames = scenario_frames(&plan.profile, frame_count(t_end));
    Ok((plan, frames))
}

/// A run's messages: `ResetToTrim`, then every frame (the first one trims).
pub fn scenario_messages(frames: &[AircraftStateFrame]) -> Vec<HostMessage> {
    std::iter::once(HostMessage::Command(Command::ResetToTrim))
        .chain(frames.iter().copied().map(HostMessage::State))
        .collect()
}

/// One message sent and the firmware's answer.
#[derive(Clone, Debug, PartialEq)]
pub struct Exchange {
    /// What the host sent.
    pub sent: HostMessage,
    /// What the firmware answered.
    pub answer: DeviceMessage,
}

/// A flown sequence of messages.
#[derive(Clone, Debug)]
pub struct Flown {
    /// Every message and its answer, in order.
    pub exchanges: Vec<Exchange>,
    /// Wall-clock time of the exchanges.
    pub wall: Duration,
}

impl Flown {
    /// The answers, in order.
    pub fn answers(&self) -> Vec<DeviceMessage> {
        self.exchanges.iter().map(|e| e.answer).collect()
    }

    /// Round trips per second of wall-clock time.
    pub fn frames_per_second(&self) -> f64 {
        self.exchanges.len() as f64 / self.wall.as_secs_f64().max(1e-9)
    }
}

/// Sends each message in lock step (the next one only after the answer to the
/// previous one), calling `progress` with the fraction done now and then.
pub fn fly(
    session: &mut Session,
    messages: &[HostMessage],
    mut progress: impl FnMut(f64),
) -> Result<Flown, LinkError> {
    let started = Instant::now();
    let mut exchanges = Vec::with_capacity(messages.len());
    let every = (messages.len() / 200).max(1);
    for (i, message) in messages.iter().enumerate() {
        let answer = session.link.request(message)?;
        exchanges.push(Exchange {
            sent: *message,
            answer,
        });
        if i % every == 0 {
            progress(i as f64 / messages.len() as f64);
        }
    }
    progress(1.0);
    Ok(Flown {
        exchanges,
        wall: started.elapsed(),
    })
}

/// Why the host controller could not be built.
#[derive(Debug)]
pub struct HostSetupError(pub String);

impl std::fmt::Display for HostSetupError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "cannot build the host controller: {}", self.0)
    }
}

impl std::error::Error for HostSetupError {}

/// The host's copy of the controller the firmware runs, in precision `T`, built
/// from `config` (its embedded segment layout).
pub fn host_controller<T: Real>(
    config: &SystemConfig,
) -> Result<Box<Controller<T, CONTROLLER_CAPACITY>>, HostSetupError> {
    let controller_config = config
        .controller_config::<T>(config.embedded_layout())
        .map_err(|e| HostSetupError(e.to_string()))?;
    Controller::new(controller_config)
        .map(Box::new)
        .map_err(|e| HostSetupError(e.to_string()))
}

/// The host's f64 accuracy reference for a controller's outputs: the
/// controller of [`host_controller`] in f64, except that it completes its trim
/// in the first State frame (`trim_units_per_frame` unlimited) whatever the
/// work, as an f32 controller does at the reference condition. An f64
/// controller with the onboard slice ([`decoy_controller::TRIM_SLICE_UNITS`])
/// takes about twice the f32 work (a tolerance of 16 f64 roundings) and starts
/// its run a frame or two later: through a manoeuvre under way from the first
/// frame (the turn) that lag alone moves the towing-point tension by 2 %,
/// which is not the precision's error this reference measures.
pub fn accuracy_controller(
    config: &SystemConfig,
) -> Result<Box<Controller<f64, CONTROLLER_CAPACITY>>, HostSetupError> {
    let mut controller_config = config
        .controller_config::<f64>(config.embedded_layout())
        .map_err(|e| HostSetupError(e.to_string()))?;
    controller_config.trim_units_per_frame = u32::MAX;
    Controller::new(controller_config)
        .map(Box::new)
        .map_err(|e| HostSetupError(e.to_string()))
}

/// Segment capacity of [`frame_reference`] (the host model's 300 segments).
pub const REFERENCE_CAPACITY: usize = 512;

/// The host's converged solution along the very frames a controller receives:
/// the model of `config` with `layout` in f64, trimmed at the first frame as the
/// controller trims (steady straight flight at that frame, positions relative
/// to its horizontal position), then integrated frame by frame along the same
/// [`decoy_controller::FramePath`] the controller integrates along, with fixed
/// RK4 steps of at most `max_step_s` (no wave-speed rule: choose the step
/// small enough to converge). Returns the connection tension (N) at every
/// frame's time, one per frame, the first the trim's.
///
/// This separates the embedded model's error (segments, steps, f32) from the
/// input's: a controller sees the aircraft only every 10 ms, while
/// `decoy simulate` integrates the scenario's analytic flight path, and through
/// a snatch load the two inputs alone move the peak by a few percent
/// (`hil-tests/tests/host_accuracy.rs`).
pub fn frame_reference(
    config: &SystemConfig,
    frames: &[AircraftStateFrame],
    layout: SegmentLayout<f64>,
    max_step_s: f64,
) -> Result<Vec<f64>, HostSetupError> {
    let params = config
        .controller_config::<f64>(layout)
        .map_err(|e| HostSetupError(e.to_string()))?
        .params;
    let frames = frames.to_vec();
    // The solver of 512 segments is large: built in place on the heap, run on
    // a thread with room for the solver's temporaries.
    std::thread::Builder::new()
        .stack_size(64 << 20)
        .spawn(move || -> Result<Vec<f64>, HostSetupError> {
            let fail = |what: &str, e: &dyn std::fmt::Display| {
                HostSetupError(format!("the frame reference: {what}: {e}"))
            };
            let Some(first) = frames.first() else {
                return Ok(Vec::new());
            };
            let mut solver: Box<Solver<f64, REFERENCE_CAPACITY>> = Box::new(Solver::UNCONFIGURED);
            solver
                .configure(&params)
                .map_err(|e| fail("configure", &e))?;
            let origin = FramePath::<f64>::run_origin(first);
            // The controller's path: the connection point interpolated directly.
            let point = solver.model().params().connection_point;
            let start = FramePath::<f64>::single(first, origin).towing(point);
            solver
                .trim(&steady_flight(&start.state_at(first.time_s)), first.time_s)
                .map_err(|e| fail("trim", &e))?;
            let mut tensions = vec![
                solver
                    .outputs(&start)
                    .map_err(|e| fail("outputs", &e))?
                    .connection_tension(),
            ];
            for pair in frames.windows(2) {
                let (from, to) = (&pair[0], &pair[1]);
                let path = FramePath::<f64>::new(from, to, origin).towing(point);
                let span = to.time_s - from.time_s;
                let steps = (span / max_step_s - 1e-9).ceil().max(1.0);
                let h = span / steps;
                for _ in 0..steps as u32 {
                    solver
                        .step(&path, h)
                        .map_err(|e| fail(&format!("t = {} s", to.time_s), &e))?;
                }
                solver.set_time(to.time_s);
                tensions.push(
                    solver
                        .outputs(&path)
                        .map_err(|e| fail("outputs", &e))?
                        .connection_tension(),
                );
            }
            Ok(tensions)
        })
        .map_err(|e| HostSetupError(format!("cannot start the reference's thread: {e}")))?
        .join()
        .map_err(|_| HostSetupError("the frame reference panicked".to_owned()))?
}

/// Feeds `messages` to the host controller and returns its answers, one per
/// message, as the firmware gives them.
pub fn replay<T: Real>(
    controller: &mut Controller<T, CONTROLLER_CAPACITY>,
    messages: &[HostMessage],
) -> Vec<DeviceMessage> {
    messages
        .iter()
        .map(|m| controller.handle(*m, &mut NoCounter))
        .collect()
}

/// The largest differences between the firmware's outputs and the host's.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Agreement {
    /// Output frames compared.
    pub outputs: usize,
    /// Of these, frames equal in every field but `instructions`.
    pub identical: usize,
    /// Largest relative difference of either tension.
    pub max_relative_tension: f64,
    /// Largest absolute difference of either tension, N.
    pub max_tension_diff_n: f64,
    /// Largest difference of a decoy Euler angle or the angle of attack, rad.
    pub max_angle_diff_rad: f64,
    /// Largest difference of a decoy position component, m.
    pub max_position_diff_m: f64,
}

/// An answer that is not of the same kind, or not the same value (ignoring
/// the instruction counts: the host counts none), on both sides.
#[derive(Clone, Debug, PartialEq)]
pub struct Mismatch {
    /// Index of the exchange.
    pub index: usize,
    /// The firmware's answer (`None`: it gave fewer answers).
    pub firmware: Option<DeviceMessage>,
    /// The host's answer (`None`: it gave fewer answers).
    pub host: Option<DeviceMessage>,
}

/// Compares the firmware's answers with the host's. Outputs are compared field by
/// field; every other answer (rejections, status) must be equal, a Status's
/// `instructions` aside.
pub fn compare(firmware: &[DeviceMessage], host: &[DeviceMessage]) -> (Agreement, Vec<Mismatch>) {
    let mut agreement = Agreement::default();
    let mut mismatches = Vec::new();
    if firmware.len() != host.len() {
        let index = firmware.len().min(host.len());
        mismatches.push(Mismatch {
            index,
            firmware: firmware.get(index).copied(),
            host: host.get(index).copied(),
        });
    }
    for (index, (f, h)) in firmware.iter().zip(host).enumerate() {
        match (f, h) {
            (DeviceMessage::Output(a), DeviceMessage::Output(b)) => {
                agreement.outputs += 1;
                let mut a_masked = *a;
                a_masked.instructions = b.instructions;
                a_masked.management_instructions = b.management_instructions;
                a_masked.step_instructions = b.step_instructions;
                if a_masked == *b {
                    agreement.identical += 1;
                }
                if a.seq != b.seq || a.steps != b.steps || a.flags != b.flags {
                    mismatches.push(Mismatch {
                        index,
                        firmware: Some(*f),
                        host: Some(*h),
                    });
                }
                accumulate(&mut agreement, a, b);
            }
            (DeviceMessage::Status(a), DeviceMessage::Status(b))
                if StatusFrame {
                    instructions: b.instructions,
                    ..*a
                } == *b => {}
            _ if f == h => {}
            _ => mismatches.push(Mismatch {
                index,
                firmware: Some(*f),
                host: Some(*h),
            }),
        }
    }
    (agreement, mismatches)
}

fn accumulate(agreement: &mut Agreement, a: &OutputFrame, b: &OutputFrame) {
    for (x, y) in [
        (a.connection_tension_n, b.connection_tension_n),
        (a.tow_tension_n, b.tow_tension_n),
    ] {
        let (x, y) = (f64::from(x), f64::from(y));
        let diff = (x - y).abs();
        agreement.max_tension_diff_n = agreement.max_tension_diff_n.max(diff);
        agreement.max_relative_tension = agreement
            .max_relative_tension
            .max(diff / y.abs().max(1e-30));
    }
    let angles = a
        .decoy_euler_rel_rad
        .iter()
        .zip(&b.decoy_euler_rel_rad)
        .chain(std::iter::once((
            &a.angle_of_attack_rad,
            &b.angle_of_attack_rad,
        )));
    for (x, y) in angles {
        agreement.max_angle_diff_rad = agreement
            .max_angle_diff_rad
            .max(f64::from(wrap_pi(x - y)).abs());
    }
    for (x, y) in a.decoy_position_fp_m.iter().zip(&b.decoy_position_fp_m) {
        agreement.max_position_diff_m = agreement.max_position_diff_m.max(f64::from(x - y).abs());
    }
}

/// An angle difference brought into (-pi, pi].
fn wrap_pi(d: f32) -> f32 {
    let two_pi = 2.0 * core::f32::consts::PI;
    let mut d = d % two_pi;
    if d > core::f32::consts::PI {
        d -= two_pi;
    } else if d <= -core::f32::consts::PI {
        d += two_pi;
    }
    d
}

/// Instructions per control step over a run's outputs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct InstructionStats {
    /// Control steps counted (outputs that integrated at least one RK4 step).
    pub steps: usize,
    /// Most instructions in one control step (the whole frame: validation, RK4
    /// steps, outputs).
    pub max: u32,
    /// Mean instructions per control step (whole frames).
    pub mean: f64,
    /// The `seq` of the costliest step.
    pub max_seq: u32,
    /// Control steps that took the nominal four RK4 steps of 2.5 ms.
    pub nominal_steps: usize,
    /// Most solver instructions (`step_instructions`: the RK4 steps) in a nominal
    /// control step.
    pub nominal_solver_max: u32,
    /// Most solver instructions per RK4 step in any control step.
    pub per_rk4_step_max: u32,
    /// Most RK4 steps one control step took (the wave-speed limit, docs/protocol.md §5).
    pub most_rk4_steps: u16,
    /// Frames of the initialisation: those answered by its Status
    /// ([`decoy_link::StatusFlags::INITIALISING`]) and the Output that
    /// completes the trim (0 RK4 steps).
    pub trim_frames: usize,
    /// Most instructions in one frame of the initialisation.
    pub trim_max: u32,
    /// Index among the answers of the costliest frame of the initialisation.
    pub trim_max_index: usize,
}

impl InstructionStats {
    /// Most instructions in any State frame of the run: a control step or a
    /// frame of the initialisation.
    pub fn worst_frame(&self) -> u32 {
        self.max.max(self.trim_max)
    }
}

/// RK4 steps of a nominal 10 ms control step (four of `decoy_controller::MAX_STEP_S`).
pub const NOMINAL_RK4_STEPS: u16 = 4;

// A nominal control step is the period in steps of the controller's largest step.
const _: () = assert!(NOMINAL_RK4_STEPS as f64 * decoy_controller::MAX_STEP_S == CONTROL_PERIOD_S);

/// The instruction statistics of `answers`: the control steps (outputs that
/// integrated) and, apart, the frames of the initialisation (the Status answers
/// while it lasts and the Output completing the trim, with no RK4 step).
pub fn instruction_stats(answers: &[DeviceMessage]) -> InstructionStats {
    let mut stats = InstructionStats::default();
    let mut total = 0u64;
    for (index, answer) in answers.iter().enumerate() {
        let trim_frame = match answer {
            DeviceMessage::Status(s)
                if StatusFlags(s.flags).contains(StatusFlags::INITIALISING) =>
            {
                Some(s.instructions)
            }
            DeviceMessage::Output(out) if out.steps == 0 => Some(out.instructions),
            _ => None,
        };
        if let Some(instructions) = trim_frame {
            stats.trim_frames += 1;
            if instructions > stats.trim_max {
                stats.trim_max = instructions;
                stats.trim_max_index = index;
            }
        }
        if let DeviceMessage::Output(out) = answer
            && out.steps > 0
        {
            stats.steps += 1;
            total += u64::from(out.instructions);
            if out.instructions > stats.max {
                stats.max = out.instructions;
                stats.max_seq = out.seq;
            }
            if out.steps == NOMINAL_RK4_STEPS {
                stats.nominal_steps += 1;
                stats.nominal_solver_max = stats.nominal_solver_max.max(out.step_instructions);
            }
            stats.per_rk4_step_max = stats
                .per_rk4_step_max
                .max(out.step_instructions / u32::from(out.steps));
            stats.most_rk4_steps = stats.most_rk4_steps.max(out.steps);
        }
    }
    if stats.steps > 0 {
        stats.mean = total as f64 / stats.steps as f64;
    }
    stats
}

/// The output frames among `answers`.
pub fn outputs(answers: &[DeviceMessage]) -> Vec<OutputFrame> {
    answers
        .iter()
        .filter_map(|a| match a {
            DeviceMessage::Output(o) => Some(*o),
            _ => None,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use decoy_schema::Parameter;

    /// Every kind of scenario is among the shipped manoeuvres, with a rate
    /// exactly when it has one.
    #[test]
    fn every_kind_is_a_shipped_manoeuvre() {
        for kind in ScenarioKind::ALL {
            assert!(
                SHIPPED_MANOEUVRES.iter().any(|(k, _, _)| *k == kind),
                "{} is not flown by the studies",
                kind.name()
            );
        }
        for (kind, rate, _) in SHIPPED_MANOEUVRES {
            assert_eq!(
                rate.is_some(),
                kind.need(Parameter::Rate).is_some(),
                "{}",
                kind.name()
            );
        }
    }

    use super::*;
    use solver_core::profiles::LevelAcceleration;

    #[test]
    fn frames_follow_the_profile_every_period() {
        let path = LevelAcceleration {
            altitude: 9000.0,
            initial_speed: 182.0,
            final_speed: 243.0,
            start: 2.0,
            acceleration: 10.0,
        };
        let frames = scenario_frames(&path, frame_count(3.0));
        assert_eq!(frames.len(), 301);
        assert_eq!(frames[0].seq, 0);
        assert_eq!(frames[0].time_s, 0.0);
        assert_eq!(frames[300].time_s, 3.0);
        assert_eq!(frames[250].seq, 250);
        assert_eq!(frames[250].time_s, 2.5);
        assert_eq!(frames[250].position_ned_m[2], -9000.0);
        assert_eq!(frames[250].acceleration_ned_mps2, [10.0, 0.0, 0.0]);
        assert_eq!(frames[250].velocity_ned_mps[0], 187.0);
        assert_eq!(frames[100].velocity_ned_mps[0], 182.0);
        assert_eq!(frames[100].attitude_wxyz, [1.0, 0.0, 0.0, 0.0]);
        let messages = scenario_messages(&frames);
        assert_eq!(messages.len(), 302);
        assert_eq!(messages[0], HostMessage::Command(Command::ResetToTrim));
        assert_eq!(messages[1], HostMessage::State(frames[0]));
    }

    #[test]
    fn frame_count_reaches_the_end() {
        assert_eq!(frame_count(10.0), 1000);
        assert_eq!(frame_count(0.015), 2);
        assert_eq!(frame_count(0.0), 1);
        assert_eq!(checked_frame_count(10.0, true), Ok(1000));
        assert_eq!(checked_frame_count(10_000.0, true), Ok(MAX_FRAMES));
        let e = checked_frame_count(1e7, false).unwrap_err();
        assert!(
            e.starts_with("the scenario's t_end_s 1e7 s needs 1e9 frames"),
            "{e}"
        );
    }

    /// The harness against the host controller on the other end of a real TCP
    /// link: lock-step exchanges give exactly the answers of a replay.
    #[test]
    fn an_emulated_device_answers_as_the_replay() {
        let config = SystemConfig::builtin().unwrap();
        let path = LevelAcceleration {
            altitude: 9000.0,
            initial_speed: 182.0,
            final_speed: 243.0,
            start: 0.2,
            acceleration: 10.0,
        };
        let messages = scenario_messages(&scenario_frames(&path, 50));
        let mut session = Session::emulated(
            host_controller::<f32>(&config).unwrap(),
            crate::qemu::Board::default(),
        )
        .unwrap();
        assert_eq!(session.hello.precision_bits, 32);
        assert_eq!(usize::from(session.hello.capacity), CONTROLLER_CAPACITY);
        let flown = fly(&mut session, &messages, |_| {}).unwrap();
        let replayed = replay(&mut host_controller::<f32>(&config).unwrap(), &messages);
        assert_eq!(flown.answers(), replayed);
        let (agreement, mismatches) = compare(&flown.answers(), &replayed);
        assert!(mismatches.is_empty());
        assert_eq!(agreement.outputs, 51);
        assert_eq!(agreement.identical, 51);
        assert!(session.device_running());
        assert!(session.finish().was_running);

        let mut f64_host = accuracy_controller(&config).unwrap();
        let (close, _) = compare(&flown.answers(), &replay(&mut f64_host, &messages));
        assert!(close.max_relative_tension < 1e-2, "{close:?}");
        assert!(close.max_relative_tension > 0.0);
    }

    #[test]
    fn angle_differences_wrap() {
        assert!((wrap_pi(2.0 * core::f32::consts::PI - 0.1) + 0.1).abs() < 1e-5);
        assert_eq!(wrap_pi(0.25), 0.25);
    }
}
