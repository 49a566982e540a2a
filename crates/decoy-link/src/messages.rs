//! The messages of the link, in both directions (serde; postcard on the wire).
//!
//! Units SI; world frame NED (flat earth, z down, altitude = -z); body frames FRD;
//! quaternions Hamilton, scalar first, body to NED. docs/protocol.md documents
//! every field; the field comments here are the short form.

use decoy_schema::{PerRequirement, Requirement};
use serde::{Deserialize, Serialize};

pub use crate::profile::{BuiltinProfile, Profile};

/// The protocol version, reported in [`Hello`], [`StatusFrame`] and [`DeviceMessage::Pong`].
pub const PROTOCOL_VERSION: u16 = 8;

/// Host to controller.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum HostMessage {
    /// The aircraft's state at one instant: advance the solver to it and answer
    /// with an [`OutputFrame`] (or a [`Rejected`]).
    State(AircraftStateFrame),
    /// A command, answered by a [`StatusFrame`] or a pong.
    Command(Command),
}

/// The aircraft's state at one instant, as the host's flight simulation knows it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AircraftStateFrame {
    /// Sequence number, echoed in the answer.
    pub seq: u32,
    /// Simulation time, s, strictly increasing from frame to frame.
    pub time_s: f64,
    /// Aircraft reference point, NED, m (altitude = -z).
    pub position_ned_m: [f64; 3],
    /// Velocity over the ground, NED, m/s.
    pub velocity_ned_mps: [f32; 3],
    /// Acceleration, NED, m/s^2.
    pub acceleration_ned_mps2: [f32; 3],
    /// Attitude, body (FRD) to NED, `[w, x, y, z]`; |q| within 1e-3 of 1 (the
    /// receiver normalises it).
    pub attitude_wxyz: [f32; 4],
    /// Angular velocity, body frame, rad/s.
    pub body_rate_radps: [f32; 3],
    /// Angular acceleration, body frame, rad/s^2.
    pub body_angular_acceleration_radps2: [f32; 3],
}

/// Commands from the host.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Command {
    /// The next State frame starts a new run from the trim at that state (also
    /// the state at boot). Answered by a Status frame.
    ResetToTrim,
    /// Fly a manoeuvre built in (or go back to streamed kinematics); implies
    /// [`Command::ResetToTrim`]. Answered by a Status frame.
    SelectProfile(Profile),
    /// Answered by a Status frame.
    GetStatus,
    /// Answered by a Pong carrying the same nonce.
    Ping {
        /// Any value; echoed.
        nonce: u32,
    },
}

/// Controller to host.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum DeviceMessage {
    /// The answer to an accepted State frame.
    Output(OutputFrame),
    /// A frame was rejected; the controller's state is untouched.
    Rejected(Rejected),
    /// The answer to a command, and sent once when the link falls silent.
    Status(StatusFrame),
    /// The answer to [`Command::Ping`].
    Pong {
        /// The ping's nonce.
        nonce: u32,
        /// [`PROTOCOL_VERSION`].
        protocol_version: u16,
    },
    /// Sent once at boot.
    Hello(Hello),
}

/// The controller's answer to an accepted State frame: the solver's outputs at
/// the frame's time.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct OutputFrame {
    /// `seq` of the State frame answered.
    pub seq: u32,
    /// Time of the outputs, s (the frame's `time_s`).
    pub time_s: f64,
    /// Cable tension at the connection point (joint 0), N, positive pulling.
    pub connection_tension_n: f32,
    /// Cable tension at the towing point (joint N), N, positive pulling.
    pub tow_tension_n: f32,
    /// Decoy CG relative to the aircraft reference point, flight-path frame
    /// (x along the aircraft velocity, y right, z down), m.
    pub decoy_position_fp_m: [f32; 3],
    /// Decoy roll, pitch, yaw (ZYX), rad, relative to the flight-path frame.
    pub decoy_euler_rel_rad: [f32; 3],
    /// Decoy total angle of attack, rad.
    pub angle_of_attack_rad: f32,
    /// Smallest distance from the cable (joints and segment midpoints) to the
    /// exhaust plume's surface, m (negative: inside).
    pub cable_clearance_exhaust_m: f32,
    /// Decoy CG to the aircraft's collision capsule, m (negative: inside).
    pub decoy_clearance_aircraft_m: f32,
    /// [`StatusFlags`] bits.
    pub flags: u16,
    /// Instructions (SysTick under QEMU `-icount`) spent on this frame:
    /// validation, all RK4 steps and the outputs.
    pub instructions: u32,
    /// Of [`OutputFrame::instructions`], those of the solver's integration: the
    /// frame's RK4 steps along the flight path (for the trim frame, the trim).
    pub step_instructions: u32,
    /// RK4 steps taken for this frame (0 for the frame that trimmed).
    pub steps: u16,
    /// Instructions of the decoy management since the last Output, run after
    /// the real-time solution is complete (not in [`OutputFrame::instructions`]):
    /// the look-ahead slice of the previous accepted frame (run after that
    /// frame's answer was sent), then this frame's monitors' measures and
    /// update and the prediction's start.
    pub management_instructions: u32,
    /// Look-ahead RK4 steps of the slice that ran since the last Output (the
    /// previous accepted frame's, run after its answer was sent).
    pub prediction_steps: u16,
    /// The decoy-management monitors and the look-ahead (docs/protocol.md §3,
    /// "Management").
    pub management: Management,
}

impl OutputFrame {
    /// An Output of zero values (the management's [`Management::ZERO`]): what
    /// the controller fills, and the base of a literal that sets a few fields.
    pub const ZERO: Self = OutputFrame {
        seq: 0,
        time_s: 0.0,
        connection_tension_n: 0.0,
        tow_tension_n: 0.0,
        decoy_position_fp_m: [0.0; 3],
        decoy_euler_rel_rad: [0.0; 3],
        angle_of_attack_rad: 0.0,
        cable_clearance_exhaust_m: 0.0,
        decoy_clearance_aircraft_m: 0.0,
        flags: 0,
        instructions: 0,
        step_instructions: 0,
        steps: 0,
        management_instructions: 0,
        prediction_steps: 0,
        management: Management::ZERO,
    };
}

/// The level of one monitor: its margin against the configured thresholds
/// (`[management]`), with hysteresis on the way down.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub enum MonitorLevel {
    /// Margin at or above the caution threshold.
    #[default]
    Normal,
    /// Margin below the caution threshold.
    Caution,
    /// Margin below the warning threshold.
    Warning,
    /// Margin below zero: the requirement is violated.
    Violated,
}

impl MonitorLevel {
    /// The level as a number: 0 normal, 1 caution, 2 warning, 3 violated.
    pub fn index(self) -> u8 {
        self as u8
    }

    /// The level's name in lower case.
    pub fn name(self) -> &'static str {
        match self {
            MonitorLevel::Normal => "normal",
            MonitorLevel::Caution => "caution",
            MonitorLevel::Warning => "warning",
            MonitorLevel::Violated => "violated",
        }
    }
}

/// One requirement's monitor and prediction, as reported in every Output.
///
/// The margin is in the requirement's own unit ([`Requirement::unit`]);
/// negative means violated.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MonitorReport {
    /// The level now.
    pub level: MonitorLevel,
    /// The margin now.
    pub margin: f32,
    /// The smallest margin since the run started (trim or reset).
    pub worst_margin: f32,
    /// Times the level rose to caution or worse since the run started.
    pub cautions: u32,
    /// Times the level rose to warning or worse since the run started.
    pub warnings: u32,
    /// Times the level rose to violated since the run started.
    pub violations: u32,
    /// The smallest margin the last completed look-ahead predicts over its
    /// horizon (the margin now if no prediction has completed yet).
    pub predicted_worst_margin: f32,
    /// Seconds from this frame's time until the last completed look-ahead
    /// predicts the margin to fall below zero; -1 when it predicts none within
    /// its horizon (or no prediction has completed yet).
    pub time_to_violation_s: f32,
}

/// The monitors of the decoy-management requirements and the state of the
/// look-ahead.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Management {
    /// One report per requirement ([`Requirement`], in its order; each margin in
    /// its [`Requirement::unit`]). On the wire the reports one after the other.
    pub reports: PerRequirement<MonitorReport>,
    /// [`Advisories`] bits: requirements the look-ahead predicts violated within
    /// its horizon if the aircraft holds its current manoeuvre, or that the map
    /// on board says the manoeuvre violates (then with [`Advisories::MAP`]).
    pub advisories: u8,
    /// Time of the frame whose state the last completed look-ahead started from,
    /// s (-1 before the first completes).
    pub prediction_from_s: f64,
    /// Horizon of the last completed look-ahead, s (0 before the first).
    pub prediction_horizon_s: f32,
    /// The manoeuvre limits the controller's map gives at this frame's flight
    /// condition (docs/protocol.md §3, "Limits").
    pub limits: Limits,
}

/// What limits a manoeuvre at the flight condition ([`Limits::limited_by`]).
pub mod limited_by {
    /// No limit known: the flight condition is outside the map's grid, or the
    /// controller has no map of that manoeuvre.
    pub const UNKNOWN: u8 = 0;
    /// A requirement: this code plus the requirement's index in
    /// `Requirement::ALL` (1 posture, 2 collision, 3 tension, 4 exhaust).
    pub const REQUIREMENT: u8 = 1;
    /// A bound of the declared operating envelope (load factor, body rate or
    /// along-path acceleration) caps the manoeuvre before any requirement.
    pub const BOUND: u8 = 0x80;
}

/// The largest manoeuvres the controller's envelope map allows at the frame's
/// altitude and Mach number: what the mission computer can cue before a
/// manoeuvre starts. Each interpolated bilinearly between the map's cells
/// around the flight condition, and the floor: the smallest of those cells,
/// the value to cue against where a limit must not be exceeded (between cells
/// the interpolation is not conservative: docs/envelope.md, "On board"). A
/// limit is -1 where it is not known (its code [`limited_by::UNKNOWN`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Limits {
    /// The largest clear pull-up rate (flight-path rotation up), rad/s.
    pub pull_up_radps: f32,
    /// The largest clear level-turn rate, rad/s.
    pub turn_radps: f32,
    /// The largest clear along-path acceleration, m/s².
    pub acceleration_mps2: f32,
    /// The pull-up's floor: the smallest limit of the map's cells around the
    /// flight condition, rad/s.
    pub pull_up_floor_radps: f32,
    /// The turn's floor, rad/s.
    pub turn_floor_radps: f32,
    /// The acceleration's floor, m/s².
    pub acceleration_floor_mps2: f32,
    /// What limits each (pull-up, turn, acceleration) at the nearest cell of
    /// the map: a [`limited_by`] code.
    pub limited_by: [u8; 3],
}

impl Limits {
    /// Every value zero: the controller's report before it is configured.
    pub const ZERO: Self = Limits {
        pull_up_radps: 0.0,
        turn_radps: 0.0,
        acceleration_mps2: 0.0,
        pull_up_floor_radps: 0.0,
        turn_floor_radps: 0.0,
        acceleration_floor_mps2: 0.0,
        limited_by: [0; 3],
    };

    /// No limit known.
    pub const UNKNOWN: Self = Limits {
        pull_up_radps: -1.0,
        turn_radps: -1.0,
        acceleration_mps2: -1.0,
        pull_up_floor_radps: -1.0,
        turn_floor_radps: -1.0,
        acceleration_floor_mps2: -1.0,
        limited_by: [limited_by::UNKNOWN; 3],
    };
}

impl Management {
    /// Every field zero (the `Default`), as a constant: a controller's report
    /// before it is configured.
    pub const ZERO: Self = Management {
        reports: PerRequirement::splat(MonitorReport {
            level: MonitorLevel::Normal,
            margin: 0.0,
            worst_margin: 0.0,
            cautions: 0,
            warnings: 0,
            violations: 0,
            predicted_worst_margin: 0.0,
            time_to_violation_s: 0.0,
        }),
        advisories: 0,
        prediction_from_s: 0.0,
        prediction_horizon_s: 0.0,
        limits: Limits::ZERO,
    };

    /// The highest level of the reports.
    pub fn worst_level(&self) -> MonitorLevel {
        self.reports
            .iter()
            .map(|(_, r)| r.level)
            .max()
            .unwrap_or(MonitorLevel::Normal)
    }

    /// Whether the advisory line is asserted for this report: a monitor at
    /// warning or worse, or a look-ahead advisory (firmware/src/advisory.rs
    /// drives the line with this; docs/protocol.md §3).
    pub fn advisory_line(&self) -> bool {
        self.worst_level() >= MonitorLevel::Warning || self.advisories != 0
    }
}

/// The bits of [`Management::advisories`]: bit k for the requirement at index
/// k of [`Requirement::ALL`] ([`Requirement::bit`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Advisories(pub u8);

impl Advisories {
    /// Set with a requirement's bit when the map on board advises against
    /// the manoeuvre: its rate is above the map's limit (the floor) at the
    /// flight condition where it was entered, and the map's limit there is that
    /// requirement's (docs/protocol.md §3, "Advisories"). The look-ahead's
    /// advisories set the requirement's bit alone.
    pub const MAP: u8 = 0x80;

    /// The bit of `requirement`: continuing the manoeuvre violates it.
    pub const fn bit(requirement: Requirement) -> u8 {
        requirement.bit()
    }

    /// Whether the bit of `requirement` is set.
    pub const fn contains(self, requirement: Requirement) -> bool {
        self.0 & requirement.bit() != 0
    }
}

/// A rejected frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Rejected {
    /// `seq` of the rejected State frame; `None` if the frame could not be decoded
    /// or was a command.
    pub seq: Option<u32>,
    /// Why.
    pub reason: RejectReason,
    /// The counter of that reason, this rejection included.
    pub count: u32,
}

/// Why a frame was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum RejectReason {
    /// Longer than [`crate::framing::MAX_FRAME_BYTES`] between delimiters.
    Oversize,
    /// Not valid COBS.
    Cobs,
    /// CRC-32 mismatch.
    Crc,
    /// Shorter than the CRC.
    Truncated,
    /// The payload is not a postcard-encoded host message (or has trailing bytes).
    Decode,
    /// A field is NaN or infinite.
    NonFinite,
    /// Altitude outside -500 m..20 km or Mach outside (0, 2].
    OutOfRange,
    /// `time_s` not after the previous accepted frame's.
    TimeNotIncreasing,
    /// `time_s` more than [`crate::MAX_TIME_JUMP_S`] after the previous accepted frame's.
    TimeJump,
    /// No trim exists at that state.
    NotTrimmed,
    /// The solver failed on the way to that frame; the state is the previous frame's.
    SolverFailure,
    /// The frame does not fit the controller's mode.
    WrongMode,
    /// |q| outside [0.999, 1.001].
    BadQuaternion,
}

/// The controller's status.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct StatusFrame {
    /// [`PROTOCOL_VERSION`].
    pub protocol_version: u16,
    /// [`StatusFlags`] bits.
    pub flags: u16,
    /// Segments of the model.
    pub segments: u16,
    /// Time of the last accepted State frame, s (0 before any).
    pub time_s: f64,
    /// Every counter.
    pub counters: Counters,
    /// For the Status answering a State frame while the controller initialises
    /// ([`StatusFlags::INITIALISING`]): the instructions it spent on that frame
    /// (as [`OutputFrame::instructions`]); 0 otherwise.
    pub instructions: u32,
}

/// Counters since boot (wrapping at 2^32).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Counters {
    /// Accepted frames (State frames answered by an Output or, while the
    /// controller initialises, by a Status; and commands).
    pub frames_ok: u32,
    /// [`RejectReason::Oversize`] rejections.
    pub oversize: u32,
    /// [`RejectReason::Cobs`] rejections.
    pub cobs: u32,
    /// [`RejectReason::Crc`] rejections.
    pub crc: u32,
    /// [`RejectReason::Truncated`] rejections.
    pub truncated: u32,
    /// [`RejectReason::Decode`] rejections.
    pub decode: u32,
    /// [`RejectReason::NonFinite`] rejections.
    pub non_finite: u32,
    /// [`RejectReason::OutOfRange`] rejections.
    pub out_of_range: u32,
    /// [`RejectReason::TimeNotIncreasing`] rejections.
    pub time_not_increasing: u32,
    /// [`RejectReason::TimeJump`] rejections.
    pub time_jump: u32,
    /// [`RejectReason::NotTrimmed`] rejections.
    pub not_trimmed: u32,
    /// [`RejectReason::SolverFailure`] rejections.
    pub solver_failure: u32,
    /// [`RejectReason::WrongMode`] rejections.
    pub wrong_mode: u32,
    /// [`RejectReason::BadQuaternion`] rejections.
    pub bad_quaternion: u32,
    /// Silences: times the link fell silent for [`crate::SILENCE_MS`].
    pub silences: u32,
    /// Gaps: times a frame that followed one rejected for a time jump ended
    /// the run and started the initialisation afresh (docs/protocol.md §4).
    pub gap_restarts: u32,
}

impl Counters {
    /// Every counter zero ([`Counters::default`]), as a constant (for a controller
    /// built in a `static`).
    pub const ZERO: Self = Counters {
        frames_ok: 0,
        oversize: 0,
        cobs: 0,
        crc: 0,
        truncated: 0,
        decode: 0,
        non_finite: 0,
        out_of_range: 0,
        time_not_increasing: 0,
        time_jump: 0,
        not_trimmed: 0,
        solver_failure: 0,
        wrong_mode: 0,
        bad_quaternion: 0,
        silences: 0,
        gap_restarts: 0,
    };

    /// Counts one rejection for `reason` and returns the new count.
    pub fn count(&mut self, reason: RejectReason) -> u32 {
        let counter = match reason {
            RejectReason::Oversize => &mut self.oversize,
            RejectReason::Cobs => &mut self.cobs,
            RejectReason::Crc => &mut self.crc,
            RejectReason::Truncated => &mut self.truncated,
            RejectReason::Decode => &mut self.decode,
            RejectReason::NonFinite => &mut self.non_finite,
            RejectReason::OutOfRange => &mut self.out_of_range,
            RejectReason::TimeNotIncreasing => &mut self.time_not_increasing,
            RejectReason::TimeJump => &mut self.time_jump,
            RejectReason::NotTrimmed => &mut self.not_trimmed,
            RejectReason::SolverFailure => &mut self.solver_failure,
            RejectReason::WrongMode => &mut self.wrong_mode,
            RejectReason::BadQuaternion => &mut self.bad_quaternion,
        };
        *counter = counter.wrapping_add(1);
        *counter
    }

    /// The counter of `reason`.
    pub fn of(&self, reason: RejectReason) -> u32 {
        let mut copy = *self;
        copy.count(reason).wrapping_sub(1)
    }
}

/// Longest board name, bytes.
pub const BOARD_NAME_CAPACITY: usize = 24;

/// The name of the controller's board (for example `mps2-an386`): ASCII, 1 to
/// [`BOARD_NAME_CAPACITY`] bytes, on the wire a postcard string (varint length,
/// bytes). A name rather than an enum, so that a new board needs no protocol change.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct BoardName {
    len: u8,
    bytes: [u8; BOARD_NAME_CAPACITY],
}

impl BoardName {
    /// `name` if it is 1 to [`BOARD_NAME_CAPACITY`] printable ASCII bytes.
    pub const fn new(name: &str) -> Option<Self> {
        let src = name.as_bytes();
        if src.is_empty() || src.len() > BOARD_NAME_CAPACITY {
            return None;
        }
        let mut bytes = [0u8; BOARD_NAME_CAPACITY];
        let mut i = 0;
        while i < src.len() {
            if !src[i].is_ascii_graphic() {
                return None;
            }
            bytes[i] = src[i];
            i += 1;
        }
        Some(BoardName {
            len: src.len() as u8,
            bytes,
        })
    }

    /// The name.
    pub fn as_str(&self) -> &str {
        // Only ASCII is ever stored (`new` and deserialisation check it), at
        // most the capacity (`get`: no panic either way).
        self.bytes
            .get(..usize::from(self.len))
            .and_then(|b| core::str::from_utf8(b).ok())
            .unwrap_or("")
    }
}

impl core::fmt::Debug for BoardName {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        core::fmt::Debug::fmt(self.as_str(), f)
    }
}

impl core::fmt::Display for BoardName {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl Serialize for BoardName {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.as_str())
    }
}

impl<'de> Deserialize<'de> for BoardName {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl serde::de::Visitor<'_> for Visitor {
            type Value = BoardName;
            fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                write!(f, "1 to {BOARD_NAME_CAPACITY} printable ASCII bytes")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<BoardName, E> {
                BoardName::new(v)
                    .ok_or_else(|| E::invalid_value(serde::de::Unexpected::Str(v), &self))
            }
        }
        deserializer.deserialize_str(Visitor)
    }
}

/// What the controller runs on, as Hello describes it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BoardInfo {
    /// The board's name.
    pub name: BoardName,
    /// The core clock, Hz.
    pub core_clock_hz: u32,
}

/// Sent once at boot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Hello {
    /// [`PROTOCOL_VERSION`].
    pub protocol_version: u16,
    /// The board's name (for example `mps2-an386`, `netduinoplus2`).
    pub board: BoardName,
    /// The core clock, Hz.
    pub core_clock_hz: u32,
    /// Bits of the solver's scalar: 32 or 64.
    pub precision_bits: u8,
    /// Segments of the model.
    pub segments: u16,
    /// Segment capacity of the solver (compile time).
    pub capacity: u16,
    /// The control period the host is expected to use, us.
    pub control_period_us: u32,
    /// The longest RK4 step, us ([`crate::MAX_STEP_S`]).
    pub max_step_us: u32,
}

/// The bits of `flags` in [`OutputFrame`] and [`StatusFrame`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct StatusFlags(pub u16);

impl StatusFlags {
    /// The solver runs from a trim (cleared by a reset until the next State frame).
    pub const TRIMMED: u16 = 1;
    /// The link has been silent longer than [`crate::SILENCE_MS`].
    pub const DEGRADED: u16 = 2;
    /// Connection tension above the cable's allowable tension.
    pub const OVER_TENSION: u16 = 4;
    /// The cable is inside the exhaust plume (clearance < 0).
    pub const CABLE_IN_PLUME: u16 = 8;
    /// The decoy CG is less than [`crate::DECOY_NEAR_AIRCRAFT_M`] from the aircraft's capsule.
    pub const DECOY_NEAR_AIRCRAFT: u16 = 16;
    /// A built-in profile drives the aircraft.
    pub const PROFILE_BUILTIN: u16 = 32;
    /// The first answer after a silence.
    pub const RECOVERED: u16 = 64;
    /// The controller is computing the trim its run will start from (a Status
    /// answers each State frame meanwhile; docs/protocol.md §4).
    pub const INITIALISING: u16 = 128;
    /// The aircraft state of this frame is outside the operating envelope the
    /// configuration declares (`[envelope]`): the frame is answered as usual, but
    /// the frame-cost bound and the accuracy are guaranteed only inside it.
    pub const OUTSIDE_ENVELOPE: u16 = 256;
    /// This frame took more RK4 steps than the nominal four (the wave-speed
    /// limit of docs/protocol.md §5 at a tension beyond the envelope's): its
    /// cost exceeds the frame budget.
    pub const STEP_LIMITED: u16 = 512;

    /// True when every bit of `bits` is set.
    pub fn contains(self, bits: u16) -> bool {
        self.0 & bits == bits
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn board_names_are_short_printable_ascii_and_round_trip_as_strings() {
        assert!(BoardName::new("").is_none());
        assert!(BoardName::new("a board").is_none());
        assert!(BoardName::new("mps2-än386").is_none());
        assert!(BoardName::new(&"x".repeat(BOARD_NAME_CAPACITY + 1)).is_none());
        let name = BoardName::new("netduinoplus2").unwrap();
        assert_eq!(name.as_str(), "netduinoplus2");
        let mut buf = [0u8; 64];
        let wire = postcard::to_slice(&name, &mut buf).unwrap();
        // A postcard string: length, then the bytes.
        assert_eq!(wire[0] as usize, "netduinoplus2".len());
        assert_eq!(&wire[1..], b"netduinoplus2");
        assert_eq!(postcard::from_bytes::<BoardName>(wire).unwrap(), name);
        let bad = postcard::to_slice("two words", &mut buf).unwrap();
        assert!(postcard::from_bytes::<BoardName>(bad).is_err());
    }
}
