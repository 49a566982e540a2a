//! The one mapping between the bridge's wire types and the decoy link's messages,
//! which the controller (host backend) and the firmware (qemu backend) take: a
//! wire state becomes the link's `AircraftStateFrame` field for field (same
//! types, same bits), so validation is exactly the controller's.

use bridge_types::{
    AircraftState, Answer, Header, MonitorReport, Output, PROTOCOL_VERSION, Rejection, command,
    kind, profile, reason,
};
use decoy_link::{
    AircraftStateFrame, Command, Limits, Management, MonitorLevel,
    MonitorReport as LinkMonitorReport, OutputFrame, Profile, RejectReason, StatusFlags,
};

/// The link's State frame carrying `state` (its `header.seq` as the frame's seq).
pub fn to_link_frame(state: &AircraftState) -> AircraftStateFrame {
    AircraftStateFrame {
        seq: state.header.seq,
        time_s: state.time_s,
        position_ned_m: state.position_ned_m,
        velocity_ned_mps: state.velocity_ned_mps,
        acceleration_ned_mps2: state.acceleration_ned_mps2,
        attitude_wxyz: state.attitude_wxyz,
        body_rate_radps: state.body_rate_radps,
        body_angular_acceleration_radps2: state.body_angular_acceleration_radps2,
    }
}

/// The wire state of a link State frame (the inverse of [`to_link_frame`]).
pub fn from_link_frame(frame: &AircraftStateFrame) -> AircraftState {
    AircraftState {
        header: Header::new(kind::AIRCRAFT_STATE, frame.seq),
        time_s: frame.time_s,
        position_ned_m: frame.position_ned_m,
        velocity_ned_mps: frame.velocity_ned_mps,
        acceleration_ned_mps2: frame.acceleration_ned_mps2,
        attitude_wxyz: frame.attitude_wxyz,
        body_rate_radps: frame.body_rate_radps,
        body_angular_acceleration_radps2: frame.body_angular_acceleration_radps2,
    }
}

/// The link-supervision bits, which describe the bridge's link to a firmware and
/// never reach the bridge's clients (docs/bridge.md, the lockstep rule).
pub const LINK_SUPERVISION_FLAGS: u16 = StatusFlags::DEGRADED | StatusFlags::RECOVERED;

// The wire's flag bits are the link's (bridge-types does not depend on the link).
const _: () = {
    use bridge_types::flag;
    assert!(flag::TRIMMED == StatusFlags::TRIMMED);
    assert!(flag::OVER_TENSION == StatusFlags::OVER_TENSION);
    assert!(flag::CABLE_IN_PLUME == StatusFlags::CABLE_IN_PLUME);
    assert!(flag::DECOY_NEAR_AIRCRAFT == StatusFlags::DECOY_NEAR_AIRCRAFT);
    assert!(flag::PROFILE_BUILTIN == StatusFlags::PROFILE_BUILTIN);
    assert!(flag::INITIALISING == StatusFlags::INITIALISING);
    assert!(flag::OUTSIDE_ENVELOPE == StatusFlags::OUTSIDE_ENVELOPE);
    assert!(flag::STEP_LIMITED == StatusFlags::STEP_LIMITED);
};

/// The wire output of a link output frame (the supervision bits cleared).
pub fn output_from_link(out: &OutputFrame) -> Output {
    let mut wire = Output {
        time_s: out.time_s,
        request_seq: out.seq,
        connection_tension_n: out.connection_tension_n,
        tow_tension_n: out.tow_tension_n,
        decoy_position_fp_m: out.decoy_position_fp_m,
        decoy_euler_rel_rad: out.decoy_euler_rel_rad,
        angle_of_attack_rad: out.angle_of_attack_rad,
        cable_clearance_exhaust_m: out.cable_clearance_exhaust_m,
        decoy_clearance_aircraft_m: out.decoy_clearance_aircraft_m,
        flags: out.flags & !LINK_SUPERVISION_FLAGS,
        steps: out.steps,
        instructions: out.instructions,
        step_instructions: out.step_instructions,
        management_instructions: out.management_instructions,
        prediction_from_s: out.management.prediction_from_s,
        prediction_horizon_s: out.management.prediction_horizon_s,
        prediction_steps: out.prediction_steps,
        advisories: out.management.advisories,
        reserved: 0,
        limit_pull_up_radps: out.management.limits.pull_up_radps,
        limit_turn_radps: out.management.limits.turn_radps,
        limit_acceleration_mps2: out.management.limits.acceleration_mps2,
        floor_pull_up_radps: out.management.limits.pull_up_floor_radps,
        floor_turn_radps: out.management.limits.turn_floor_radps,
        floor_acceleration_mps2: out.management.limits.acceleration_floor_mps2,
        limited_by: out.management.limits.limited_by,
        reserved_limits: [0; 5],
        // The reports, one field per requirement, below.
        ..Output::default()
    };
    for (requirement, report) in out.management.reports.iter() {
        *wire.report_mut(requirement) = report_from_link(report);
    }
    wire
}

/// The wire form of one monitor's report (the level as its index).
fn report_from_link(r: &LinkMonitorReport) -> MonitorReport {
    MonitorReport {
        margin: r.margin,
        worst_margin: r.worst_margin,
        predicted_worst_margin: r.predicted_worst_margin,
        time_to_violation_s: r.time_to_violation_s,
        cautions: r.cautions,
        warnings: r.warnings,
        violations: r.violations,
        level: r.level.index(),
        reserved: [0; 3],
    }
}

/// The link form of a wire monitor report (an unknown level reads as violated).
fn report_to_link(r: &MonitorReport) -> LinkMonitorReport {
    LinkMonitorReport {
        level: match r.level {
            0 => MonitorLevel::Normal,
            1 => MonitorLevel::Caution,
            2 => MonitorLevel::Warning,
            _ => MonitorLevel::Violated,
        },
        margin: r.margin,
        worst_margin: r.worst_margin,
        cautions: r.cautions,
        warnings: r.warnings,
        violations: r.violations,
        predicted_worst_margin: r.predicted_worst_margin,
        time_to_violation_s: r.time_to_violation_s,
    }
}

/// The link output frame a wire output carries (the supervision bits as sent: clear).
pub fn output_to_link(out: &Output) -> OutputFrame {
    OutputFrame {
        seq: out.request_seq,
        time_s: out.time_s,
        connection_tension_n: out.connection_tension_n,
        tow_tension_n: out.tow_tension_n,
        decoy_position_fp_m: out.decoy_position_fp_m,
        decoy_euler_rel_rad: out.decoy_euler_rel_rad,
        angle_of_attack_rad: out.angle_of_attack_rad,
        cable_clearance_exhaust_m: out.cable_clearance_exhaust_m,
        decoy_clearance_aircraft_m: out.decoy_clearance_aircraft_m,
        flags: out.flags,
        instructions: out.instructions,
        step_instructions: out.step_instructions,
        steps: out.steps,
        management_instructions: out.management_instructions,
        prediction_steps: out.prediction_steps,
        management: Management {
            reports: out.reports().map(|r| report_to_link(&r)),
            advisories: out.advisories,
            prediction_from_s: out.prediction_from_s,
            prediction_horizon_s: out.prediction_horizon_s,
            limits: Limits {
                pull_up_radps: out.limit_pull_up_radps,
                turn_radps: out.limit_turn_radps,
                acceleration_mps2: out.limit_acceleration_mps2,
                pull_up_floor_radps: out.floor_pull_up_radps,
                turn_floor_radps: out.floor_turn_radps,
                acceleration_floor_mps2: out.floor_acceleration_mps2,
                limited_by: out.limited_by,
            },
        },
    }
}

/// The wire code of a link rejection reason (the same index).
pub fn reason_code(r: RejectReason) -> u16 {
    match r {
        RejectReason::Oversize => reason::OVERSIZE,
        RejectReason::Cobs => reason::COBS,
        RejectReason::Crc => reason::CRC,
        RejectReason::Truncated => reason::TRUNCATED,
        RejectReason::Decode => reason::DECODE,
        RejectReason::NonFinite => reason::NON_FINITE,
        RejectReason::OutOfRange => reason::OUT_OF_RANGE,
        RejectReason::TimeNotIncreasing => reason::TIME_NOT_INCREASING,
        RejectReason::TimeJump => reason::TIME_JUMP,
        RejectReason::NotTrimmed => reason::NOT_TRIMMED,
        RejectReason::SolverFailure => reason::SOLVER_FAILURE,
        RejectReason::WrongMode => reason::WRONG_MODE,
        RejectReason::BadQuaternion => reason::BAD_QUATERNION,
    }
}

/// The answer carrying `output`, numbered `seq`.
pub fn output_answer(seq: u32, output: Output) -> Answer {
    Answer {
        header: Header::new(kind::OUTPUT, seq),
        rejection: Rejection::default(),
        output,
    }
}

/// The answer to state `request_seq` while the controller initialises: the
/// Status that answered it (its time, flags but the link supervision's, and
/// instructions in the output), numbered `seq`.
pub fn initialising_answer(seq: u32, request_seq: u32, status: &decoy_link::StatusFrame) -> Answer {
    Answer {
        header: Header::new(kind::INITIALISING, seq),
        rejection: Rejection::default(),
        output: Output {
            time_s: status.time_s,
            request_seq,
            flags: status.flags & !LINK_SUPERVISION_FLAGS,
            instructions: status.instructions,
            ..Output::default()
        },
    }
}

/// The answer rejecting request `request_seq` for `code` (the `count`-th time), numbered `seq`.
pub fn rejected_answer(seq: u32, request_seq: u32, code: u16, count: u64) -> Answer {
    Answer {
        header: Header::new(kind::REJECTED, seq),
        rejection: Rejection {
            request_seq,
            reason: code,
            reserved: 0,
            count,
        },
        output: Output::default(),
    }
}

/// Why a header is not acceptable on a service expecting `expected` (None: fine).
pub fn check_header(header: &Header, expected: u16) -> Option<u16> {
    if header.protocol_version != PROTOCOL_VERSION {
        Some(reason::WRONG_VERSION)
    } else if header.kind != expected {
        Some(reason::WRONG_TYPE)
    } else {
        None
    }
}

/// The link command of a wire command; `Err(WRONG_TYPE)` for an unknown command
/// or profile code.
pub fn to_link_command(c: &bridge_types::Command) -> Result<Command, u16> {
    match c.command {
        command::RESET_TO_TRIM => Ok(Command::ResetToTrim),
        command::GET_STATUS => Ok(Command::GetStatus),
        command::PING => Ok(Command::Ping { nonce: c.nonce }),
        command::SELECT_PROFILE => {
            let rate_milli_radps = c.rate_milli_radps;
            let p = match (c.profile, profile::manoeuvre(c.profile)) {
                (profile::STREAMED, _) => Profile::Streamed,
                (_, Some(manoeuvre)) => Profile::builtin(manoeuvre, rate_milli_radps),
                (_, None) => return Err(reason::WRONG_TYPE),
            };
            Ok(Command::SelectProfile(p))
        }
        _ => Err(reason::WRONG_TYPE),
    }
}

/// A wire command (sequence number `seq`).
pub fn command(seq: u32, code: u16) -> bridge_types::Command {
    bridge_types::Command {
        header: Header::new(kind::COMMAND, seq),
        command: code,
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use decoy_link::{PerRequirement, Requirement};
    use decoy_schema::Manoeuvre;

    #[test]
    fn states_map_field_for_field_both_ways() {
        let frame = AircraftStateFrame {
            seq: 7,
            time_s: 1.25,
            position_ned_m: [1.0, 2.0, -9000.0],
            velocity_ned_mps: [240.0, 1.5, -0.25],
            acceleration_ned_mps2: [0.5, 0.0, 0.125],
            attitude_wxyz: [1.0, 0.0, 0.0, 0.0],
            body_rate_radps: [0.01, 0.02, 0.03],
            body_angular_acceleration_radps2: [0.0, -0.5, 0.0],
        };
        let wire = from_link_frame(&frame);
        assert_eq!(wire.header, Header::new(kind::AIRCRAFT_STATE, 7));
        assert_eq!(to_link_frame(&wire), frame);
    }

    #[test]
    fn every_link_reason_keeps_its_index_and_name() {
        use RejectReason::*;
        let all = [
            Oversize,
            Cobs,
            Crc,
            Truncated,
            Decode,
            NonFinite,
            OutOfRange,
            TimeNotIncreasing,
            TimeJump,
            NotTrimmed,
            SolverFailure,
            WrongMode,
            BadQuaternion,
        ];
        for (i, r) in all.into_iter().enumerate() {
            assert_eq!(usize::from(reason_code(r)), i);
            assert_ne!(reason::name(reason_code(r)), "?");
        }
    }

    #[test]
    fn supervision_bits_never_reach_a_client() {
        let frame = OutputFrame {
            seq: 3,
            time_s: 0.5,
            connection_tension_n: 900.0,
            tow_tension_n: 850.0,
            decoy_position_fp_m: [-100.0, 0.0, 8.0],
            decoy_euler_rel_rad: [0.0, 0.01, 0.0],
            angle_of_attack_rad: 0.02,
            cable_clearance_exhaust_m: 1.5,
            decoy_clearance_aircraft_m: 90.0,
            flags: StatusFlags::TRIMMED | StatusFlags::RECOVERED | StatusFlags::OVER_TENSION,
            instructions: 5,
            step_instructions: 4,
            steps: 2,
            management_instructions: 7,
            prediction_steps: 3,
            management: Management {
                reports: PerRequirement::from_fn(|r| LinkMonitorReport {
                    level: if r == Requirement::Exhaust {
                        MonitorLevel::Warning
                    } else {
                        MonitorLevel::Caution
                    },
                    margin: 0.4 + r.index() as f32,
                    worst_margin: 0.3,
                    cautions: 2,
                    warnings: 1,
                    violations: r.index() as u32,
                    predicted_worst_margin: -0.2,
                    time_to_violation_s: 1.5,
                }),
                advisories: 8,
                prediction_from_s: 0.25,
                prediction_horizon_s: 3.0,
                limits: Limits {
                    pull_up_radps: 0.15,
                    turn_radps: 0.1,
                    acceleration_mps2: -1.0,
                    pull_up_floor_radps: 0.12,
                    turn_floor_radps: 0.09,
                    acceleration_floor_mps2: -1.0,
                    limited_by: [4, 128, 0],
                },
            },
        };
        let out = output_from_link(&frame);
        assert_eq!(
            (out.exhaust.level, out.advisories, out.tension.level),
            (2, 8, 1)
        );
        assert_eq!((out.posture.margin, out.collision.violations), (0.4, 1));
        assert_eq!(out.flags, StatusFlags::TRIMMED | StatusFlags::OVER_TENSION);
        let mut back = frame;
        back.flags = out.flags;
        assert_eq!(output_to_link(&out), back);
    }

    #[test]
    fn headers_and_commands_are_checked() {
        assert_eq!(
            check_header(&Header::new(kind::AIRCRAFT_STATE, 1), kind::AIRCRAFT_STATE),
            None
        );
        let mut h = Header::new(kind::AIRCRAFT_STATE, 1);
        h.protocol_version = 99;
        assert_eq!(
            check_header(&h, kind::AIRCRAFT_STATE),
            Some(reason::WRONG_VERSION)
        );
        assert_eq!(
            check_header(&Header::new(kind::STATUS, 1), kind::AIRCRAFT_STATE),
            Some(reason::WRONG_TYPE)
        );
        let mut c = command(1, command::SELECT_PROFILE);
        c.rate_milli_radps = 100;
        c.profile = profile::STREAMED;
        assert_eq!(
            to_link_command(&c),
            Ok(Command::SelectProfile(Profile::Streamed))
        );
        for manoeuvre in Manoeuvre::ALL {
            c.profile = profile::of(manoeuvre);
            assert_eq!(
                to_link_command(&c),
                Ok(Command::SelectProfile(Profile::builtin(manoeuvre, 100)))
            );
        }
        c.profile = 77;
        assert_eq!(to_link_command(&c), Err(reason::WRONG_TYPE));
        assert_eq!(to_link_command(&command(1, 9)), Err(reason::WRONG_TYPE));
    }
}
