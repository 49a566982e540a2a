//! The wire types. `ZeroCopySend`'s derive writes an `unsafe impl` (the promise
//! that the type is self-contained: no pointers, `#[repr(C)]`), the one place
//! where this workspace allows `unsafe`.
#![allow(unsafe_code)]

use bytemuck::{Pod, Zeroable};
use iceoryx2_bb_derive_macros::ZeroCopySend;
use iceoryx2_bb_elementary_traits::zero_copy_send::ZeroCopySend;

use decoy_schema::{PerRequirement, Requirement};

use crate::PROTOCOL_VERSION;

/// The values of [`Header::kind`]: what a sample is.
pub mod kind {
    /// An [`crate::AircraftState`].
    pub const AIRCRAFT_STATE: u16 = 1;
    /// An [`crate::Answer`] carrying an output.
    pub const OUTPUT: u16 = 2;
    /// An [`crate::Answer`] carrying a rejection.
    pub const REJECTED: u16 = 3;
    /// A [`crate::Status`].
    pub const STATUS: u16 = 4;
    /// A [`crate::Command`].
    pub const COMMAND: u16 = 5;
    /// A [`crate::CommandReply`].
    pub const COMMAND_REPLY: u16 = 6;
    /// An [`crate::Answer`] to a state while the controller initialises (it is
    /// computing the trim its run will start from, docs/protocol.md §4): the
    /// output's `time_s`, `flags` (INITIALISING) and `instructions` are set, its
    /// solution is zero; a later state is answered by an output.
    pub const INITIALISING: u16 = 7;

    /// The name of a kind (`"?"` for an unknown one).
    pub fn name(kind: u16) -> &'static str {
        match kind {
            AIRCRAFT_STATE => "aircraft_state",
            OUTPUT => "output",
            REJECTED => "rejected",
            STATUS => "status",
            COMMAND => "command",
            COMMAND_REPLY => "command_reply",
            INITIALISING => "initialising",
            _ => "?",
        }
    }
}

/// The bits of [`crate::Output::flags`]: the link's status flags
/// (docs/protocol.md, `decoy_link::StatusFlags`) but for its supervision bits
/// (DEGRADED 2, RECOVERED 64), which never reach a bridge's clients.
pub mod flag {
    /// The controller is trimmed (a run is under way).
    pub const TRIMMED: u16 = 1;
    /// The connection tension is above the allowable tension.
    pub const OVER_TENSION: u16 = 4;
    /// Part of the cable is inside the exhaust plume.
    pub const CABLE_IN_PLUME: u16 = 8;
    /// The decoy is closer to the aircraft than its limit.
    pub const DECOY_NEAR_AIRCRAFT: u16 = 16;
    /// The controller flies a built-in profile.
    pub const PROFILE_BUILTIN: u16 = 32;
    /// The controller is computing its trim: the answer is [`super::kind::INITIALISING`].
    pub const INITIALISING: u16 = 128;
    /// The state is outside the operating envelope the configuration declares.
    pub const OUTSIDE_ENVELOPE: u16 = 256;
    /// The state took more RK4 steps than the nominal four (beyond the frame budget).
    pub const STEP_LIMITED: u16 = 512;
    /// Every flag, with its name.
    pub const ALL: [(&str, u16); 8] = [
        ("trimmed", TRIMMED),
        ("over_tension", OVER_TENSION),
        ("cable_in_plume", CABLE_IN_PLUME),
        ("decoy_near_aircraft", DECOY_NEAR_AIRCRAFT),
        ("profile_builtin", PROFILE_BUILTIN),
        ("initialising", INITIALISING),
        ("outside_envelope", OUTSIDE_ENVELOPE),
        ("step_limited", STEP_LIMITED),
    ];
}

/// The head of every sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ZeroCopySend, Pod, Zeroable)]
#[repr(C)]
#[type_name("decoy.bridge.v4.Header")]
pub struct Header {
    /// [`PROTOCOL_VERSION`] of the sender.
    pub protocol_version: u16,
    /// What the sample is ([`kind`]).
    pub kind: u16,
    /// The sender's sequence number on this service: +1 per sample, wrapping.
    /// For lockstep requests it is also the controller's frame `seq`, echoed in
    /// the answer's `request_seq`.
    pub seq: u32,
}

impl Header {
    /// A header of this protocol version.
    pub const fn new(kind: u16, seq: u32) -> Self {
        Header {
            protocol_version: PROTOCOL_VERSION,
            kind,
            seq,
        }
    }
}

/// The aircraft's state at one instant (lockstep request, free-running sample).
///
/// The fields are those of the decoy link's `AircraftStateFrame`
/// (docs/protocol.md §3) in the same types, so the controller receives exactly
/// these bits. Validation is the controller's (docs/protocol.md §4).
#[derive(Clone, Copy, Debug, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[repr(C)]
#[type_name("decoy.bridge.v4.AircraftState")]
pub struct AircraftState {
    /// `kind` = [`kind::AIRCRAFT_STATE`]; `seq` = the frame's sequence number.
    pub header: Header,
    /// Simulation time, s, strictly increasing, at most 0.1 s after the previous.
    pub time_s: f64,
    /// Aircraft reference point, NED, m (altitude = -z).
    pub position_ned_m: [f64; 3],
    /// Velocity over the ground, NED, m/s.
    pub velocity_ned_mps: [f32; 3],
    /// Acceleration, NED, m/s².
    pub acceleration_ned_mps2: [f32; 3],
    /// Attitude, body (FRD) to NED, Hamilton `[w, x, y, z]`; |q| within 1e-3 of 1.
    pub attitude_wxyz: [f32; 4],
    /// Angular velocity, body frame (p, q, r), rad/s.
    pub body_rate_radps: [f32; 3],
    /// Angular acceleration, body frame, rad/s².
    pub body_angular_acceleration_radps2: [f32; 3],
}

// `Output`, with a report field per requirement: generated from the requirement
// list (`decoy_schema::for_each_requirement!`) rather than written out, so that
// a requirement is added in one place. `ZeroCopySend` needs `#[repr(C)]` fields
// of the type's own, so the generic `PerRequirement` cannot be a field here:
// `Output::reports` gives the reports as one.
macro_rules! output {
    ($(($variant:ident, $field:ident, $unit:literal, $file_unit:literal,
        $title:literal, $margin:literal)),* $(,)?) => {
        /// The controller's outputs at a state's time (docs/protocol.md `OutputFrame`,
        /// docs/outputs.md for the quantities), ending with one [`MonitorReport`] per
        /// requirement, in the list's order. Fields are only appended (with a
        /// protocol version), never moved.
        #[derive(Clone, Copy, Debug, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
        #[repr(C)]
        #[type_name("decoy.bridge.v4.Output")]
        pub struct Output {
            /// Time of the outputs, s (the state's `time_s`).
            pub time_s: f64,
            /// `header.seq` of the state answered.
            pub request_seq: u32,
            /// Cable tension at the connection point (joint 0), N, positive pulling.
            pub connection_tension_n: f32,
            /// Cable tension at the towing point (joint N), N, positive pulling.
            pub tow_tension_n: f32,
            /// Decoy CG minus the aircraft reference point, flight-path frame (x along
            /// the aircraft velocity, y horizontal right, z down), m.
            pub decoy_position_fp_m: [f32; 3],
            /// Decoy roll, pitch, yaw (ZYX) relative to the flight-path frame, rad.
            pub decoy_euler_rel_rad: [f32; 3],
            /// Decoy total angle of attack, rad.
            pub angle_of_attack_rad: f32,
            /// Smallest distance from the cable to the exhaust plume's surface, m
            /// (negative: inside).
            pub cable_clearance_exhaust_m: f32,
            /// Decoy CG to the aircraft's collision capsule, m (negative: inside).
            pub decoy_clearance_aircraft_m: f32,
            /// Status flags ([`flag`], docs/protocol.md: TRIMMED 1, OVER_TENSION 4,
            /// CABLE_IN_PLUME 8, DECOY_NEAR_AIRCRAFT 16, PROFILE_BUILTIN 32,
            /// INITIALISING 128, OUTSIDE_ENVELOPE 256, STEP_LIMITED 512). The link
            /// supervision bits (DEGRADED 2, RECOVERED 64) are never set here: the
            /// bridge reports its clients' silence in [`Status::health`].
            pub flags: u16,
            /// RK4 steps taken for this state (0 for the state that trimmed).
            pub steps: u16,
            /// Instructions the controller spent on this state (the qemu backend, exact
            /// under `-icount`; 0 from the host backend).
            pub instructions: u32,
            /// Of `instructions`, the solver's integration alone.
            pub step_instructions: u32,
            /// Instructions of the decoy management after the solution (the monitors
            /// and one look-ahead slice; qemu backend, 0 from the host); not in
            /// `instructions`.
            pub management_instructions: u32,
            /// Time of the state the last completed look-ahead started from, s (-1
            /// before the first completes).
            pub prediction_from_s: f64,
            /// Horizon of the last completed look-ahead, s (0 before the first).
            pub prediction_horizon_s: f32,
            /// Look-ahead RK4 steps taken in this frame's slice.
            pub prediction_steps: u16,
            /// Requirements the look-ahead predicts violated within its horizon if
            /// the aircraft holds its manoeuvre (bit k: the k-th requirement of the
            /// list, `decoy_schema::Requirement::bit`).
            pub advisories: u8,
            /// Zero.
            pub reserved: u8,
            $(
                #[doc = concat!($title, ": the monitor's report, margin in ", $unit, ".")]
                pub $field: MonitorReport,
            )*
            /// The largest clear pull-up rate the controller's envelope map gives
            /// at this state's altitude and Mach number (interpolated), rad/s; -1
            /// where not known (docs/protocol.md §3, "Limits").
            pub limit_pull_up_radps: f32,
            /// The largest clear level-turn rate there, rad/s; -1 where not known.
            pub limit_turn_radps: f32,
            /// The largest clear along-path acceleration there, m/s²; -1 where not
            /// known.
            pub limit_acceleration_mps2: f32,
            /// The pull-up's floor: the smallest limit of the map's cells around
            /// the state's flight condition (the value to cue against: between
            /// cells the interpolation is not conservative), rad/s; -1 where not
            /// known.
            pub floor_pull_up_radps: f32,
            /// The turn's floor, rad/s; -1 where not known.
            pub floor_turn_radps: f32,
            /// The acceleration's floor, m/s²; -1 where not known.
            pub floor_acceleration_mps2: f32,
            /// What limits each of the three (pull-up, turn, acceleration) at the
            /// map's nearest cell: 0 not known, 1 + the requirement's index (1
            /// posture, 2 collision, 3 tension, 4 exhaust), 128 a bound of the
            /// declared envelope (`decoy_link::limited_by`).
            pub limited_by: [u8; 3],
            /// Zero.
            pub reserved_limits: [u8; 5],
        }

        impl Output {
            /// The report of `requirement`.
            pub fn report(&self, requirement: Requirement) -> &MonitorReport {
                match requirement {
                    $(Requirement::$variant => &self.$field,)*
                }
            }

            /// The report of `requirement`, mutable.
            pub fn report_mut(&mut self, requirement: Requirement) -> &mut MonitorReport {
                match requirement {
                    $(Requirement::$variant => &mut self.$field,)*
                }
            }

            /// Every requirement's report.
            pub fn reports(&self) -> PerRequirement<MonitorReport> {
                PerRequirement {
                    $($field: self.$field,)*
                }
            }
        }
    };
}

decoy_schema::for_each_requirement!(output);

/// One requirement's monitor and prediction in an [`Output`] (docs/management.md,
/// "Margins"): the margin in the requirement's own unit, negative
/// when violated.
#[derive(Clone, Copy, Debug, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[repr(C)]
#[type_name("decoy.bridge.v4.MonitorReport")]
pub struct MonitorReport {
    /// The margin now.
    pub margin: f32,
    /// The smallest margin since the run started (trim or reset).
    pub worst_margin: f32,
    /// The smallest margin the last completed look-ahead predicts over its
    /// horizon (the margin now before one completes).
    pub predicted_worst_margin: f32,
    /// Seconds from this frame until the predicted violation; -1 for none.
    pub time_to_violation_s: f32,
    /// Rises to caution or worse since the run started.
    pub cautions: u32,
    /// Rises to warning or worse since the run started.
    pub warnings: u32,
    /// Rises to violated since the run started.
    pub violations: u32,
    /// The level now: 0 normal, 1 caution, 2 warning, 3 violated.
    pub level: u8,
    /// Zero.
    pub reserved: [u8; 3],
}

/// Why a state or a command was rejected.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ZeroCopySend, Pod, Zeroable)]
#[repr(C)]
#[type_name("decoy.bridge.v4.Rejection")]
pub struct Rejection {
    /// `header.seq` of the rejected request.
    pub request_seq: u32,
    /// Why ([`reason`]).
    pub reason: u16,
    /// Zero.
    pub reserved: u16,
    /// The bridge's counter of that reason, this rejection included.
    pub count: u64,
}

/// The answer to one aircraft state: an [`Output`] (`header.kind` =
/// [`kind::OUTPUT`]), a [`Rejection`] (`header.kind` = [`kind::REJECTED`]), or,
/// while the controller initialises, an [`Output`] with only its time, flags and
/// instructions set (`header.kind` = [`kind::INITIALISING`]); the other part is
/// all zero. The lockstep service's response and the outputs service's sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[repr(C)]
#[type_name("decoy.bridge.v4.Answer")]
pub struct Answer {
    /// `kind` = [`kind::OUTPUT`], [`kind::REJECTED`] or [`kind::INITIALISING`]; `seq` = the bridge's
    /// answer number (+1 per answer on the service, wrapping; a gap on the
    /// outputs service is a lost sample).
    pub header: Header,
    /// Set when rejected.
    pub rejection: Rejection,
    /// Set when accepted.
    pub output: Output,
}

/// The counters of a bridge since it started (u64, never reset).
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, ZeroCopySend, Pod, Zeroable, serde::Serialize,
)]
#[repr(C)]
#[type_name("decoy.bridge.v4.Counters")]
pub struct Counters {
    /// States answered by an output.
    pub accepted: u64,
    /// Commands answered (accepted or rejected).
    pub commands: u64,
    /// Lockstep requests received.
    pub lockstep_requests: u64,
    /// Free-running samples received.
    pub free_samples: u64,
    /// Rejections: a field is NaN or infinite.
    pub non_finite: u64,
    /// Rejections: outside the physical envelope (docs/protocol.md §4), or a
    /// profile rate above 1 rad/s.
    pub out_of_range: u64,
    /// Rejections: |q| outside [0.999, 1.001].
    pub bad_quaternion: u64,
    /// Rejections: time not after the previous accepted state's.
    pub time_not_increasing: u64,
    /// Rejections: time more than 0.1 s after the previous accepted state's.
    pub time_jump: u64,
    /// Rejections: no trim at the state.
    pub not_trimmed: u64,
    /// Rejections: the solver failed on the way to the state.
    pub solver_failure: u64,
    /// Rejections: the controller's mode does not take the frame.
    pub wrong_mode: u64,
    /// Rejections: the header's protocol version is not this bridge's.
    pub wrong_version: u64,
    /// Rejections: the header's kind does not fit the service, or an unknown
    /// command or profile code.
    pub wrong_type: u64,
    /// Rejections: the firmware link failed (qemu backend) or the firmware
    /// rejected a frame as undecodable.
    pub backend_failure: u64,
    /// Free-running samples processed after a later one had already arrived (the
    /// bridge fell behind; each is still processed, in order).
    pub overruns: u64,
    /// Free-running samples never processed: gaps in their `header.seq` (the
    /// subscriber's buffer overflowed), counted per missing number.
    pub lost: u64,
    /// Silences: the input stopped for longer than the silence time while a run was active.
    pub silences: u64,
}

/// The bridge's status: published on the status service (history 1) and in every
/// command reply.
#[derive(Clone, Copy, Debug, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[repr(C)]
#[type_name("decoy.bridge.v4.Status")]
pub struct Status {
    /// `kind` = [`kind::STATUS`]; `seq` = the bridge's status number.
    pub header: Header,
    /// Time of the last accepted state, s (0 before any).
    pub time_s: f64,
    /// Seconds since the bridge started.
    pub uptime_s: f64,
    /// Seconds since the last valid state (-1 before any).
    pub input_age_s: f64,
    /// Every counter.
    pub counters: Counters,
    /// Length ratio of neighbouring segments (1: uniform; the embedded model: graded, short at the decoy).
    pub grading_ratio: f64,
    /// Cable segments of the model.
    pub segments: u16,
    /// Segment capacity of the controller's solver.
    pub capacity: u16,
    /// Bits of the solver's scalar: 32 or 64.
    pub precision_bits: u8,
    /// [`backend`].
    pub backend: u8,
    /// [`health`].
    pub health: u8,
    /// Zero.
    pub reserved0: u8,
    /// The controller's status flags now (docs/protocol.md).
    pub controller_flags: u16,
    /// The decoy link's protocol version the controller speaks.
    pub link_protocol_version: u16,
    /// Zero.
    pub reserved1: u32,
    /// The board (qemu backend: its name, e.g. `mps2-an386`; host backend:
    /// `host`), ASCII, zero padded.
    pub board: [u8; 24],
    /// The bridge instance's name, ASCII, zero padded.
    pub instance: [u8; 32],
}

/// A command (request of the commands service).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ZeroCopySend, Pod, Zeroable)]
#[repr(C)]
#[type_name("decoy.bridge.v4.Command")]
pub struct Command {
    /// `kind` = [`kind::COMMAND`].
    pub header: Header,
    /// [`command`].
    pub command: u16,
    /// [`profile`] (`SELECT_PROFILE` only).
    pub profile: u16,
    /// Rate of a pull-up or turn profile, mrad/s (at most 1000).
    pub rate_milli_radps: u16,
    /// Zero.
    pub reserved: u16,
    /// Echoed in the reply (`PING`).
    pub nonce: u32,
    /// Zero.
    pub reserved1: u32,
}

/// The reply to a [`Command`].
#[derive(Clone, Copy, Debug, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[repr(C)]
#[type_name("decoy.bridge.v4.CommandReply")]
pub struct CommandReply {
    /// `kind` = [`kind::COMMAND_REPLY`]; `seq` = the bridge's reply number.
    pub header: Header,
    /// `header.seq` of the command.
    pub request_seq: u32,
    /// The command's code.
    pub command: u16,
    /// [`result`].
    pub result: u16,
    /// [`reason`] when rejected, 0 otherwise.
    pub reason: u16,
    /// Zero.
    pub reserved: u16,
    /// The command's nonce.
    pub nonce: u32,
    /// The status after the command.
    pub status: Status,
}

/// [`Command::command`] codes.
pub mod command {
    /// The next state starts a new run from the trim at that state.
    pub const RESET_TO_TRIM: u16 = 0;
    /// Fly a built-in profile (or back to streamed); implies a reset.
    pub const SELECT_PROFILE: u16 = 1;
    /// Reply with the status only.
    pub const GET_STATUS: u16 = 2;
    /// Reply echoing the nonce (and the status).
    pub const PING: u16 = 3;
}

/// [`Command::profile`] codes (docs/protocol.md `Profile`): the streamed
/// kinematics, or one of `decoy_schema`'s manoeuvres flown built in, numbered
/// as the decoy link numbers them. `decoy bridge-layout --json` lists each
/// under its identifier (`pull_up`).
pub mod profile {
    use decoy_schema::{Manoeuvre, STREAMED_PROFILE_CODE};

    /// The states' kinematics (the normal mode).
    pub const STREAMED: u16 = STREAMED_PROFILE_CODE;

    /// The code of `manoeuvre`'s built-in profile (its rate in
    /// `rate_milli_radps` for a pull-up or a turn).
    pub const fn of(manoeuvre: Manoeuvre) -> u16 {
        manoeuvre.profile_code()
    }

    /// The manoeuvre whose built-in profile has `code`; `None` for
    /// [`STREAMED`] and for codes of no profile.
    pub const fn manoeuvre(code: u16) -> Option<Manoeuvre> {
        Manoeuvre::from_profile_code(code)
    }
}

/// [`CommandReply::result`] codes.
pub mod result {
    /// Done.
    pub const OK: u16 = 0;
    /// Refused; see `reason`.
    pub const REJECTED: u16 = 1;
}

/// [`Status::backend`] codes.
pub mod backend {
    /// The controller in the bridge's process.
    pub const HOST: u8 = 0;
    /// The firmware under QEMU, over its UART.
    pub const QEMU: u8 = 1;

    /// The backend's name.
    pub fn name(code: u8) -> &'static str {
        match code {
            HOST => "host",
            QEMU => "qemu",
            _ => "?",
        }
    }
}

/// [`Status::health`] codes.
pub mod health {
    /// No run: waiting for the state to trim at (after start or a reset).
    pub const WAITING: u8 = 0;
    /// A run is active and states arrive.
    pub const RUNNING: u8 = 1;
    /// A run is active but no valid state came for the silence time.
    pub const DEGRADED: u8 = 2;
    /// States arrive again after a silence of this run.
    pub const RECOVERED: u8 = 3;

    /// The health's name.
    pub fn name(code: u8) -> &'static str {
        match code {
            WAITING => "waiting",
            RUNNING => "running",
            DEGRADED => "degraded",
            RECOVERED => "recovered",
            _ => "?",
        }
    }
}

/// [`Rejection::reason`] codes: 0 to 12 are the decoy link's `RejectReason`
/// indices (docs/protocol.md), 32 and up the bridge's own.
pub mod reason {
    /// Link framing (qemu backend only): frame too long.
    pub const OVERSIZE: u16 = 0;
    /// Link framing: bad COBS.
    pub const COBS: u16 = 1;
    /// Link framing: CRC mismatch.
    pub const CRC: u16 = 2;
    /// Link framing: shorter than its CRC.
    pub const TRUNCATED: u16 = 3;
    /// Link framing: not a message.
    pub const DECODE: u16 = 4;
    /// A field is NaN or infinite.
    pub const NON_FINITE: u16 = 5;
    /// Outside the physical envelope.
    pub const OUT_OF_RANGE: u16 = 6;
    /// Time not after the previous accepted state's.
    pub const TIME_NOT_INCREASING: u16 = 7;
    /// Time more than 0.1 s after the previous accepted state's.
    pub const TIME_JUMP: u16 = 8;
    /// No trim at the state.
    pub const NOT_TRIMMED: u16 = 9;
    /// The solver failed; the state is the previous accepted one's.
    pub const SOLVER_FAILURE: u16 = 10;
    /// The frame does not fit the controller's mode.
    pub const WRONG_MODE: u16 = 11;
    /// |q| outside [0.999, 1.001].
    pub const BAD_QUATERNION: u16 = 12;
    /// The header's protocol version is not the bridge's.
    pub const WRONG_VERSION: u16 = 32;
    /// The header's kind does not fit the service, or an unknown code.
    pub const WRONG_TYPE: u16 = 33;
    /// The backend failed (the firmware link: timeout, closed).
    pub const BACKEND_FAILURE: u16 = 34;

    /// Every reason, in code order.
    pub const ALL: [u16; 16] = [
        OVERSIZE,
        COBS,
        CRC,
        TRUNCATED,
        DECODE,
        NON_FINITE,
        OUT_OF_RANGE,
        TIME_NOT_INCREASING,
        TIME_JUMP,
        NOT_TRIMMED,
        SOLVER_FAILURE,
        WRONG_MODE,
        BAD_QUATERNION,
        WRONG_VERSION,
        WRONG_TYPE,
        BACKEND_FAILURE,
    ];

    /// The reason's name (snake case, as in the JSON summaries).
    pub fn name(code: u16) -> &'static str {
        match code {
            OVERSIZE => "oversize",
            COBS => "cobs",
            CRC => "crc",
            TRUNCATED => "truncated",
            DECODE => "decode",
            NON_FINITE => "non_finite",
            OUT_OF_RANGE => "out_of_range",
            TIME_NOT_INCREASING => "time_not_increasing",
            TIME_JUMP => "time_jump",
            NOT_TRIMMED => "not_trimmed",
            SOLVER_FAILURE => "solver_failure",
            WRONG_MODE => "wrong_mode",
            BAD_QUATERNION => "bad_quaternion",
            WRONG_VERSION => "wrong_version",
            WRONG_TYPE => "wrong_type",
            BACKEND_FAILURE => "backend_failure",
            _ => "?",
        }
    }
}

impl Counters {
    /// Counts one rejection for `reason` and returns the new count. The link's
    /// framing reasons (which only a firmware can report) count as
    /// `backend_failure`.
    pub fn count_rejection(&mut self, code: u16) -> u64 {
        let counter = match code {
            reason::NON_FINITE => &mut self.non_finite,
            reason::OUT_OF_RANGE => &mut self.out_of_range,
            reason::BAD_QUATERNION => &mut self.bad_quaternion,
            reason::TIME_NOT_INCREASING => &mut self.time_not_increasing,
            reason::TIME_JUMP => &mut self.time_jump,
            reason::NOT_TRIMMED => &mut self.not_trimmed,
            reason::SOLVER_FAILURE => &mut self.solver_failure,
            reason::WRONG_MODE => &mut self.wrong_mode,
            reason::WRONG_VERSION => &mut self.wrong_version,
            reason::WRONG_TYPE => &mut self.wrong_type,
            _ => &mut self.backend_failure,
        };
        *counter += 1;
        *counter
    }

    /// Every rejection counted.
    pub fn rejected(&self) -> u64 {
        self.non_finite
            + self.out_of_range
            + self.bad_quaternion
            + self.time_not_increasing
            + self.time_jump
            + self.not_trimmed
            + self.solver_failure
            + self.wrong_mode
            + self.wrong_version
            + self.wrong_type
            + self.backend_failure
    }
}

/// `text` as a zero-padded ASCII field (cut at the field's length).
pub fn ascii_field<const N: usize>(text: &str) -> [u8; N] {
    let mut out = [0u8; N];
    for (o, b) in out.iter_mut().zip(text.bytes().filter(u8::is_ascii)) {
        *o = b;
    }
    out
}

/// The text of a zero-padded ASCII field.
pub fn field_text(bytes: &[u8]) -> String {
    bytes
        .iter()
        .take_while(|&&b| b != 0)
        .map(|&b| char::from(b))
        .collect()
}

/// The iceoryx2 type name of `T` (what `#[type_name]` gave it).
pub fn type_name_of<T: ZeroCopySend>() -> &'static str {
    // SAFETY: `type_name` is an `unsafe fn` of the trait only because a wrong
    // name breaks iceoryx2's type check; reading it has no precondition.
    unsafe { <T as ZeroCopySend>::type_name() }
}

/// A service's payload as bytes, for a transport other than shared memory (the
/// bridge across hosts over Zenoh, docs/bridge.md "Across hosts"): exactly the
/// bytes the type has in shared memory (no implicit padding, so every byte is a
/// field, `Pod` checks it at compile time), sent with its [`Wire::tag`] (the
/// iceoryx2 type name and the size, `decoy.bridge.v4.Answer/272`), which the
/// receiver checks as iceoryx2 checks a port's type.
pub trait Wire: Pod + ZeroCopySend {
    /// The bytes of `self`.
    fn as_wire_bytes(&self) -> &[u8] {
        bytemuck::bytes_of(self)
    }

    /// The value `bytes` hold; `None` when their length is not the type's size.
    fn from_wire_bytes(bytes: &[u8]) -> Option<Self> {
        bytemuck::try_pod_read_unaligned(bytes).ok()
    }

    /// The type's tag: `<type name>/<size in bytes>`.
    fn tag() -> String {
        format!(
            "{}/{}",
            type_name_of::<Self>(),
            core::mem::size_of::<Self>()
        )
    }
}

impl Wire for AircraftState {}
impl Wire for Answer {}
impl Wire for Status {}
impl Wire for Command {}
impl Wire for CommandReply {}
