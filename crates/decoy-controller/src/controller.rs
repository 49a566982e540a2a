//! The decoy controller: a pure state machine (no hardware, no time source of its
//! own) that turns host messages into answers. The firmware wraps it with a UART
//! and SysTick; the host runs the same type as its reference.

use decoy_schema::BUILTIN_ALTITUDE_M;
use solver_core::profiles::{LevelAcceleration, ManoeuvreParams, ManoeuvrePath};
use solver_core::{
    AircraftState, Atmosphere, ConfigError, Model, ModelParams, Real, SolveError, Solver, State,
    TrimTask, Vec3,
};

use crate::builtin;
use crate::envelope::OperatingEnvelope;
use crate::geometry::{FlightPathFrame, Geometry, cable_plume_clearance, to_body};
use crate::limits::{LimitMap, MapCover, MapManoeuvre};
use crate::lookahead::Lookahead;
use crate::monitor::{ManagementConfig, Measures, Monitors};
use crate::path::{FramePath, PathEnd, steady_flight};
use crate::validate::{is_finite, validate_streamed};
use crate::wave::{wave_rate_of, wave_steps};
use decoy_link::{
    Advisories, AircraftStateFrame, BoardInfo, Command, Counters, DeviceMessage, Hello,
    HostMessage, Limits, Management, OutputFrame, PROTOCOL_VERSION, Profile, RejectReason,
    Rejected, StatusFlags, StatusFrame,
};
use decoy_link::{Decoder, FrameError};

/// The longest RK4 step, s: a frame interval dt is integrated in
/// n = ceil(dt / MAX_STEP_S - 1e-9) steps of dt / n, or more where the
/// wave-speed limit asks ([`crate::wave::WAVE_STEP_FACTOR`]). 2.5 ms (four steps per 10 ms
/// frame) is the accuracy step of the embedded model (12 graded 1.26): through a
/// snatch load it keeps the peak tension within 2 % of the host's converged
/// solution (issue 14, firmware/README.md "The worst frame and the accuracy"),
/// and the wave-speed limit of its 1.73 m shortest segment is not reached by
/// any shipped manoeuvre.
pub const MAX_STEP_S: f64 = 0.0025;
/// Most RK4 steps one frame may take onboard (a floor of 0.5 ms on a 10 ms
/// frame; `ControllerConfig::max_steps_per_frame`'s value for the embedded
/// model).
pub const MAX_STEPS_PER_FRAME: u32 = 20;
/// Most RK4 steps one frame may take on a host that runs a finer model than the
/// embedded one (the bridge's host model, 300 uniform segments): its shortest
/// segment's wave-speed limit asks for up to about 150 steps in a 100 ms frame
/// and through the snatch after the 0.20 rad/s pull-up; no frame budget bounds
/// a host.
pub const HOST_MAX_STEPS_PER_FRAME: u32 = 4096;
/// The longest accepted interval between two State frames, s.
pub const MAX_TIME_JUMP_S: f64 = 0.1;
/// Rounding allowance of the time-jump check, s: an interval of exactly
/// [`MAX_TIME_JUMP_S`] computed as a difference of two times is accepted.
pub const TIME_TOLERANCE_S: f64 = 1e-9;
/// Link silence (no valid frame) after which the controller reports DEGRADED, ms.
pub const SILENCE_MS: u32 = 200;
/// The control period the host is expected to use, us (reported in Hello).
pub const CONTROL_PERIOD_US: u32 = 10_000;
/// Decoy-to-aircraft clearance below which DECOY_NEAR_AIRCRAFT is set, m.
pub const DECOY_NEAR_AIRCRAFT_M: f64 = 1.0;
/// The highest built-in profile rate accepted, mrad/s.
pub const MAX_PROFILE_RATE_MILLI_RADPS: u16 = 1000;

/// Segment capacity of the look-ahead's copy of the solution, a model of half
/// the controller's segments (`lookahead::prediction_params`; a model whose copy
/// needs more segments has no look-ahead).
pub const PREDICTION_CAPACITY: usize = 12;

/// Work units of the trim one State frame carries on while the controller
/// initialises ([`solver_core::TrimTask`]; a decoy moment is 8 units, a segment's
/// residual 1). A frame of the trim costs about 27,000 instructions on the
/// Cortex-M4F (validation, the output evaluation of the frame that completes
/// it) plus about 105 a unit: 480 units keep every frame of the trim near
/// 78,000, under the f32 boards' frame budget with margin for the unit's spread
/// (firmware/README.md, "The trim"; the budget in "Budgets and baselines"). The f32 trim takes 260 to 750 units over
/// the envelope (one or two frames). The f32 controllers' slice.
pub const TRIM_SLICE_UNITS: u32 = 480;

/// [`TRIM_SLICE_UNITS`] for an f64 controller (the Cortex-M7's double-precision
/// FPU, about three times the M4F's instructions a unit): 320 units keep every
/// frame of its trim within the M7's frame bound (firmware/README.md, "The
/// trim"); the f64 trim takes 670 to 1,630 units over the envelope (three to
/// six frames).
pub const TRIM_SLICE_UNITS_F64: u32 = 320;

/// The trim's slice of a controller in `T`: [`TRIM_SLICE_UNITS`] in f32,
/// [`TRIM_SLICE_UNITS_F64`] in f64.
pub fn trim_slice_units<T: Real>() -> u32 {
    if core::mem::size_of::<T>() == 8 {
        TRIM_SLICE_UNITS_F64
    } else {
        TRIM_SLICE_UNITS
    }
}

/// A source of instruction (or tick) counts for [`OutputFrame::instructions`].
pub trait InstructionCounter {
    /// The current count (a free-running, wrapping up-counter).
    fn now(&self) -> u32;
    /// The count since `start` (a reading of [`InstructionCounter::now`]).
    fn elapsed(&self, start: u32) -> u32 {
        self.now().wrapping_sub(start)
    }
}

/// A shared counter counts too (the firmware's clock also serves the silence timer).
impl<C: InstructionCounter + ?Sized> InstructionCounter for &C {
    fn now(&self) -> u32 {
        (**self).now()
    }
    fn elapsed(&self, start: u32) -> u32 {
        (**self).elapsed(start)
    }
}

/// A counter that always reads 0 (hosts that do not measure).
#[derive(Clone, Copy, Debug, Default)]
pub struct NoCounter;

impl InstructionCounter for NoCounter {
    fn now(&self) -> u32 {
        0
    }
}

/// Everything the controller is built from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControllerConfig<T: Real> {
    /// The solver's model (environment, connection point, cable, layout, decoy).
    pub params: ModelParams<T>,
    /// Exhaust plume and collision capsule, aircraft body frame.
    pub geometry: Geometry<T>,
    /// Allowable connection tension, N (OVER_TENSION above it).
    pub allowable_tension_n: T,
    /// The monitors' thresholds and the look-ahead's horizon and slice.
    pub management: ManagementConfig<T>,
    /// The operating envelope the controller guarantees (frames outside it are
    /// flagged [`StatusFlags::OUTSIDE_ENVELOPE`]).
    pub envelope: OperatingEnvelope<T>,
    /// The manoeuvre envelope map of the configuration (every Output reports
    /// its limits at the frame's flight condition).
    pub limits: LimitMap,
    /// Most RK4 steps one frame may take: [`MAX_STEPS_PER_FRAME`] onboard (the
    /// frame budget), [`HOST_MAX_STEPS_PER_FRAME`] for a host's finer model.
    pub max_steps_per_frame: u32,
    /// Work units of the trim each State frame carries on while the controller
    /// initialises: [`trim_slice_units`] onboard (the frame budget); a host
    /// reference that must start its run at the first frame, whatever its
    /// precision, takes `u32::MAX` (the whole trim in the first frame).
    pub trim_units_per_frame: u32,
}

/// Why a controller could not be built.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ControllerError {
    /// The model parameters are invalid.
    Config(ConfigError),
    /// The solver rejected its initial state.
    Solve(SolveError),
    /// The allowable tension is not a positive finite number.
    AllowableTension,
}

impl core::fmt::Display for ControllerError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ControllerError::Config(e) => write!(f, "model: {e}"),
            ControllerError::Solve(e) => write!(f, "solver: {e}"),
            ControllerError::AllowableTension => {
                f.write_str("allowable tension must be positive and finite")
            }
        }
    }
}

impl core::error::Error for ControllerError {}

/// A run after a State frame: its origin and start time, the RK4 steps taken,
/// and whether the wave-speed limit asked for more than the nominal steps.
type Advanced = ([f64; 3], f64, u16, bool);

/// What the controller integrates after a trim.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Run {
    /// The last accepted State frame.
    last: AircraftStateFrame,
    /// `time_s` of the frame the run was trimmed at (time 0 of a built-in profile).
    start_time_s: f64,
    /// Origin of the solver's positions, NED, m (horizontal position at the trim).
    origin: [f64; 3],
}

/// The last frame rejected for a time jump (`armed`), until a State frame is
/// accepted. Plain fields rather than an `Option<f64>`: the controller's
/// initial constant must be all zero bits to lie in `.bss`.
#[derive(Clone, Copy, Debug)]
struct PendingJump {
    armed: bool,
    time_s: f64,
}

impl PendingJump {
    const NONE: Self = PendingJump {
        armed: false,
        time_s: 0.0,
    };
}

/// A trim in progress: the controller answers each State frame with a Status
/// (INITIALISING) until it is complete, then the run starts.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Initialising<T: Real, const N: usize> {
    /// A trim is in progress.
    active: bool,
    /// The search.
    task: TrimTask<T, N>,
    /// The flown frame the trim is for (streamed: the first frame of the
    /// initialisation; built-in: the profile at 0).
    target: AircraftStateFrame,
    /// The last accepted State frame (the time rules of docs/protocol.md §4).
    last: AircraftStateFrame,
}

impl<T: Real, const N: usize> Initialising<T, N> {
    /// No trim in progress (all zero bits).
    const NONE: Self = Initialising {
        active: false,
        task: TrimTask::ZERO,
        target: ZERO_FRAME,
        last: ZERO_FRAME,
    };
}

/// A State frame of zero bits (a placeholder never flown).
const ZERO_FRAME: AircraftStateFrame = AircraftStateFrame {
    seq: 0,
    time_s: 0.0,
    position_ned_m: [0.0; 3],
    velocity_ned_mps: [0.0; 3],
    acceleration_ned_mps2: [0.0; 3],
    attitude_wxyz: [0.0; 4],
    body_rate_radps: [0.0; 3],
    body_angular_acceleration_radps2: [0.0; 3],
};

/// What a State frame's solution gives: an Output with its measures, the
/// aircraft and where the management's count starts; or an answer as it is (a
/// rejection, or the Status of a frame of the initialisation).
#[allow(clippy::large_enum_variant)]
enum Solved<T: Real> {
    Output(OutputFrame, Measures<T>, AircraftState<T>, u32),
    Answer(DeviceMessage),
}

/// Everything that decides the controller's next answers except the counters:
/// two controllers with equal snapshots answer the same frames identically.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControllerSnapshot<T: Real, const N: usize> {
    /// The solver state.
    pub state: State<T, N>,
    /// The selected profile.
    pub profile: Profile,
    /// The last accepted State frame, if trimmed.
    pub last_frame: Option<AircraftStateFrame>,
    /// Link silent.
    pub degraded: bool,
    /// The next Output carries RECOVERED.
    pub recovered_pending: bool,
    /// Hazard flags of the last Output.
    pub hazard_flags: u16,
    /// The wave-speed rate max_i c_i / l_i (1/s) of the last accepted frame's
    /// outputs, which sets the next frame's step count (docs/protocol.md §5).
    pub wave_rate: T,
    /// The monitors and look-ahead as the last Output reported them.
    pub management: Management,
}

/// The decoy controller with a solver of capacity `N` in precision `T`, and a
/// look-ahead copy of capacity `M`.
#[derive(Clone, Debug)]
pub struct Controller<T: Real, const N: usize, const M: usize = PREDICTION_CAPACITY> {
    solver: Solver<T, N>,
    management: ManagementConfig<T>,
    monitors: Monitors<T>,
    lookahead: Lookahead<T, M>,
    /// The management report of the last Output.
    last_management: Management,
    geometry: Geometry<T>,
    allowable_tension_n: T,
    envelope: OperatingEnvelope<T>,
    /// [`ControllerConfig::limits`].
    limits: LimitMap,
    /// Altitude (m) and Mach number of the last accepted frame's flown state,
    /// where the management looks the limits up; Mach NaN when it could not be
    /// formed (the limits are then unknown).
    condition: [T; 2],
    /// The limits at the flight condition where the aircraft entered its
    /// manoeuvre (the last frame in steady flight's, [`MapManoeuvre`], or the
    /// first Output's after the trim when the aircraft was manoeuvring already):
    /// what the map advises with.
    map_entry: Limits,
    /// `map_entry` was taken since the last trim or reset.
    map_entry_taken: bool,
    /// When `map_entry` was taken, s (the frame's time).
    map_entry_s: f64,
    /// Whether the map covers the flight (then the look-ahead's advisory bits
    /// are withheld).
    map_cover: MapCover,
    /// [`ControllerConfig::trim_units_per_frame`].
    trim_units_per_frame: u32,
    /// [`ControllerConfig::max_steps_per_frame`].
    max_steps_per_frame: u32,
    /// The time of the last frame rejected for a time jump, until a State frame
    /// is accepted: a next frame that follows it (later, within
    /// [`MAX_TIME_JUMP_S`]) confirms a gap in the stream (docs/protocol.md §4,
    /// "A gap").
    pending_jump: PendingJump,
    profile: Profile,
    /// The flight path of the selected built-in profile (None: streamed), made
    /// when the profile is selected.
    builtin: Option<ManoeuvrePath>,
    run: Option<Run>,
    /// The trim in progress before a run starts.
    init: Initialising<T, N>,
    /// The last frame's flight path, built in place every frame (about 110 words:
    /// not moved).
    path: FramePath<T>,
    /// Where the last streamed frame's path ended, for the next one to start
    /// from (a cache: the paths have the same bits without it).
    path_end: PathEnd<T>,
    counters: Counters,
    degraded: bool,
    recovered_pending: bool,
    hazard_flags: u16,
    /// The last accepted State frame was outside the operating envelope.
    outside_envelope: bool,
    /// max_i c_i / l_i (1/s) at the last accepted frame's outputs: the stepping
    /// rule's input, kept here rather than read from the solver's workspace, which
    /// a rejected frame's attempts overwrite.
    wave_rate: T,
    /// A valid frame arrived since the last [`Controller::poll_silence`].
    activity: bool,
    last_activity_ms: Option<u32>,
    /// The last accepted frame's look-ahead slice is still to run
    /// ([`Controller::background`]).
    slice_due: bool,
    /// Steps and instructions of the slice that ran since the last Output
    /// (reported, then cleared, by the next one).
    slice_steps: u32,
    slice_instructions: u32,
}

impl<T: Real, const N: usize, const M: usize> Controller<T, N, M> {
    /// A controller without a configuration yet, as a constant of all zero bits
    /// (its solver is [`Solver::UNCONFIGURED`]): for a controller that must not
    /// pass through the stack (37.5 KB in f64 with room for 64 segments), put this
    /// in its final place, for example
    /// `static C: ConstStaticCell<Controller<f64, 64>> = ConstStaticCell::new(Controller::UNCONFIGURED);`
    /// (a `static` of zero bits lies in `.bss`), and configure it there with
    /// [`Controller::configure`].
    ///
    /// Until configured it never trims: it answers commands, and every State frame
    /// gets a typed rejection ([`RejectReason::NotTrimmed`] where nothing else is
    /// wrong with it first), so it never steps its solver.
    pub const UNCONFIGURED: Self = Controller {
        solver: Solver::UNCONFIGURED,
        management: ManagementConfig::ZERO,
        monitors: Monitors::NEW,
        lookahead: Lookahead::UNCONFIGURED,
        last_management: Management::ZERO,
        geometry: Geometry::ZERO,
        allowable_tension_n: T::ZERO,
        envelope: OperatingEnvelope::ZERO,
        limits: LimitMap::EMPTY,
        condition: [T::ZERO; 2],
        map_entry: Limits::ZERO,
        map_entry_taken: false,
        map_entry_s: 0.0,
        map_cover: MapCover::SETTLED,
        trim_units_per_frame: 0,
        max_steps_per_frame: 0,
        pending_jump: PendingJump::NONE,
        profile: Profile::Streamed,
        // `Some` of a zero path rather than `None`, whose niche is nonzero bits: the
        // constant must be all zero bits to lie in `.bss` (checked by the HIL
        // tests). Never read: selecting a profile replaces it, `configure` clears
        // it, and an unconfigured controller never starts a run.
        builtin: Some(ManoeuvrePath::Level(LevelAcceleration {
            altitude: 0.0,
            initial_speed: 0.0,
            final_speed: 0.0,
            start: 0.0,
            acceleration: 0.0,
        })),
        run: None,
        init: Initialising::NONE,
        path: FramePath::ZERO,
        path_end: PathEnd::NONE,
        counters: Counters::ZERO,
        degraded: false,
        recovered_pending: false,
        hazard_flags: 0,
        outside_envelope: false,
        wave_rate: T::ZERO,
        activity: false,
        last_activity_ms: None,
        slice_due: false,
        slice_steps: 0,
        slice_instructions: 0,
    };

    /// A controller for `config`, waiting for its first State frame to trim at.
    pub fn new(config: ControllerConfig<T>) -> Result<Self, ControllerError> {
        let mut controller = Self::UNCONFIGURED;
        controller.configure(&config)?;
        Ok(controller)
    }

    /// [`Controller::new`] with an already built model (`config.params` is not
    /// used: `model` was built from it).
    pub fn from_model(
        model: Model<T, N>,
        config: &ControllerConfig<T>,
    ) -> Result<Self, ControllerError> {
        Self::new(ControllerConfig {
            params: *model.params(),
            ..*config
        })
    }

    /// Makes this the controller [`Controller::new`] builds for `config`, in place:
    /// its solver and model are built in the controller's own memory, and nothing
    /// controller-, solver- or model-sized passes through the stack (the firmware
    /// configures [`Controller::UNCONFIGURED`] in its `static` this way). Everything
    /// the controller held before is replaced: run, profile, counters, link state.
    ///
    /// On error the controller is left exactly as it was.
    pub fn configure(&mut self, config: &ControllerConfig<T>) -> Result<(), ControllerError> {
        let allowable_tension_n = config.allowable_tension_n;
        if !(allowable_tension_n.finite() && allowable_tension_n > T::zero()) {
            return Err(ControllerError::AllowableTension);
        }
        // The state at rest is never integrated: every run starts from a trim.
        self.solver
            .configure(&config.params)
            .map_err(ControllerError::Config)?;
        self.lookahead
            .configure(&config.params, config.management.prediction_segments);
        self.management = config.management;
        self.reset_management();
        self.geometry = config.geometry;
        self.allowable_tension_n = allowable_tension_n;
        self.envelope = config.envelope;
        self.limits = config.limits;
        self.condition = [T::zero(); 2];
        self.trim_units_per_frame = config.trim_units_per_frame;
        self.max_steps_per_frame = config.max_steps_per_frame.max(1);
        self.pending_jump = PendingJump::NONE;
        self.profile = Profile::Streamed;
        self.builtin = None;
        self.run = None;
        self.init = Initialising::NONE;
        self.path = FramePath::ZERO;
        self.path_end = PathEnd::NONE;
        self.counters = Counters::ZERO;
        self.degraded = false;
        self.recovered_pending = false;
        self.hazard_flags = 0;
        self.outside_envelope = false;
        self.wave_rate = T::zero();
        self.activity = false;
        self.last_activity_ms = None;
        Ok(())
    }

    /// The Hello message of this controller on `board`.
    pub fn hello(&self, board: &BoardInfo) -> DeviceMessage {
        DeviceMessage::Hello(Hello {
            protocol_version: PROTOCOL_VERSION,
            board: board.name,
            core_clock_hz: board.core_clock_hz,
            precision_bits: (core::mem::size_of::<T>() * 8) as u8,
            segments: self.segments(),
            capacity: N as u16,
            control_period_us: CONTROL_PERIOD_US,
            max_step_us: libm::round(MAX_STEP_S * 1e6) as u32,
        })
    }

    /// The solver state.
    pub fn state(&self) -> &State<T, N> {
        self.solver.state()
    }

    /// The solver (model, state).
    pub fn solver(&self) -> &Solver<T, N> {
        &self.solver
    }

    /// The counters since construction.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// The selected profile.
    pub fn profile(&self) -> Profile {
        self.profile
    }

    /// True once a State frame has been trimmed at (until the next reset).
    pub fn is_trimmed(&self) -> bool {
        self.run.is_some()
    }

    /// Everything but the counters (see [`ControllerSnapshot`]).
    pub fn snapshot(&self) -> ControllerSnapshot<T, N> {
        ControllerSnapshot {
            state: *self.solver.state(),
            profile: self.profile,
            last_frame: self.run.map(|r| r.last),
            degraded: self.degraded,
            recovered_pending: self.recovered_pending,
            hazard_flags: self.hazard_flags,
            wave_rate: self.wave_rate,
            management: self.last_management,
        }
    }

    /// The monitors' and the look-ahead's report of the last Output.
    pub fn management(&self) -> &Management {
        &self.last_management
    }

    /// The look-ahead (its last completed prediction).
    pub fn lookahead(&self) -> &Lookahead<T, M> {
        &self.lookahead
    }

    /// Forgets the monitors' history and every prediction (a new run).
    fn reset_management(&mut self) {
        self.monitors.reset();
        self.lookahead.reset();
        self.map_entry = Limits::ZERO;
        self.map_entry_taken = false;
        self.map_cover = MapCover::SETTLED;
        self.slice_due = false;
        self.slice_steps = 0;
        self.slice_instructions = 0;
        self.last_management = self.monitors.report();
    }

    /// The current [`StatusFlags`] bits (as in a Status frame).
    pub fn flags(&self) -> u16 {
        let mut flags = self.hazard_flags;
        if self.run.is_some() {
            flags |= StatusFlags::TRIMMED;
        }
        if self.init.active {
            flags |= StatusFlags::INITIALISING;
        }
        if self.outside_envelope {
            flags |= StatusFlags::OUTSIDE_ENVELOPE;
        }
        if self.degraded {
            flags |= StatusFlags::DEGRADED;
        }
        if self.profile != Profile::Streamed {
            flags |= StatusFlags::PROFILE_BUILTIN;
        }
        flags
    }

    /// The Status frame now.
    pub fn status(&self) -> DeviceMessage {
        self.status_of(0)
    }

    /// The Status frame now, answering a State frame that took `instructions`
    /// (0 for a command).
    fn status_of(&self, instructions: u32) -> DeviceMessage {
        DeviceMessage::Status(StatusFrame {
            instructions,
            protocol_version: PROTOCOL_VERSION,
            flags: self.flags(),
            segments: self.segments(),
            time_s: match (&self.run, self.init.active) {
                (Some(run), _) => run.last.time_s,
                (None, true) => self.init.last.time_s,
                (None, false) => 0.0,
            },
            counters: self.counters,
        })
    }

    fn segments(&self) -> u16 {
        let model = self.solver.model();
        if model.is_configured() {
            model.segment_count() as u16
        } else {
            0
        }
    }

    /// Answers one decoded host message. `counter` measures the instructions a
    /// State frame costs.
    ///
    /// An accepted State frame's answer carries the solution and the monitors;
    /// the look-ahead's slice of prediction steps for that frame is left due, to
    /// run after the answer is sent ([`Controller::background`]). If it has not
    /// run when the next message comes, it runs first, here: the answers are the
    /// same bits whenever the slice runs (docs/protocol.md §3, "The look-ahead").
    pub fn handle(
        &mut self,
        message: HostMessage,
        counter: &mut impl InstructionCounter,
    ) -> DeviceMessage {
        self.background(counter);
        match message {
            HostMessage::State(frame) => self.on_state(&frame, counter),
            HostMessage::Command(command) => self.on_command(command),
        }
    }

    /// Runs the last accepted frame's look-ahead slice if it is due (at most
    /// `prediction_steps_per_frame` RK4 steps of the prediction model); the
    /// firmware calls this once the frame's answer is written, so that the
    /// answer does not wait for the prediction. Returns the steps taken.
    pub fn background(&mut self, counter: &mut impl InstructionCounter) -> u32 {
        if !self.slice_due {
            return 0;
        }
        self.slice_due = false;
        let start = counter.now();
        let steps = self.lookahead.advance(&self.geometry, &self.management);
        // The air columns next to the frame's, for the next frames (counted with
        // the slice: not part of a frame's own instructions).
        self.solver.prefetch_air();
        self.slice_steps = steps;
        self.slice_instructions = counter.elapsed(start);
        steps
    }

    /// The answer to a frame that could not be decoded: a Rejected with no seq.
    pub fn on_frame_error(&mut self, error: FrameError) -> DeviceMessage {
        let reason = match error {
            FrameError::Oversize => RejectReason::Oversize,
            FrameError::Cobs => RejectReason::Cobs,
            FrameError::Crc => RejectReason::Crc,
            FrameError::Truncated => RejectReason::Truncated,
            FrameError::Decode => RejectReason::Decode,
        };
        self.reject(None, reason)
    }

    /// Feeds received bytes through `decoder` and calls `answer` with the answer
    /// to every frame they complete (a decoded message or a frame error).
    pub fn handle_bytes<const CAP: usize>(
        &mut self,
        decoder: &mut Decoder<CAP>,
        bytes: &[u8],
        counter: &mut impl InstructionCounter,
        mut answer: impl FnMut(&DeviceMessage),
    ) {
        for &byte in bytes {
            let reply = match decoder.push::<HostMessage>(byte) {
                None => continue,
                Some(Ok(message)) => self.handle(message, counter),
                Some(Err(error)) => self.on_frame_error(error),
            };
            answer(&reply);
        }
    }

    /// Link supervision, called often with a millisecond clock: after
    /// [`SILENCE_MS`] with no valid frame it sets DEGRADED, counts a silence and
    /// returns one Status frame; nothing otherwise. The next valid frame clears
    /// DEGRADED and the next Output carries RECOVERED. The silence is measured
    /// from the poll that first saw the last valid frame; supervision starts with
    /// the first valid frame, so a host that is slow to start is not reported.
    pub fn poll_silence(&mut self, now_ms: u32) -> Option<DeviceMessage> {
        if self.activity {
            self.activity = false;
            self.last_activity_ms = Some(now_ms);
            return None;
        }
        let last = self.last_activity_ms?;
        if !self.degraded && now_ms.wrapping_sub(last) >= SILENCE_MS {
            self.degraded = true;
            self.counters.silences = self.counters.silences.wrapping_add(1);
            return Some(self.status());
        }
        None
    }

    fn reject(&mut self, seq: Option<u32>, reason: RejectReason) -> DeviceMessage {
        let count = self.counters.count(reason);
        DeviceMessage::Rejected(Rejected { seq, reason, count })
    }

    /// A valid frame arrived: counts it and ends a silence.
    fn accepted(&mut self) {
        self.counters.frames_ok = self.counters.frames_ok.wrapping_add(1);
        self.activity = true;
        if self.degraded {
            self.degraded = false;
            self.recovered_pending = true;
        }
    }

    fn on_command(&mut self, command: Command) -> DeviceMessage {
        match command {
            Command::ResetToTrim => {
                self.run = None;
                self.init = Initialising::NONE;
                self.pending_jump = PendingJump::NONE;
                self.reset_management();
            }
            Command::SelectProfile(profile) => {
                let rate = match profile {
                    Profile::Builtin(b) => b.rate_milli_radps(),
                    Profile::Streamed => 0,
                };
                if rate > MAX_PROFILE_RATE_MILLI_RADPS {
                    return self.reject(None, RejectReason::OutOfRange);
                }
                self.profile = profile;
                self.builtin = self.builtin_path();
                self.run = None;
                self.init = Initialising::NONE;
                self.pending_jump = PendingJump::NONE;
                self.reset_management();
            }
            Command::GetStatus => {}
            Command::Ping { nonce } => {
                self.accepted();
                return DeviceMessage::Pong {
                    nonce,
                    protocol_version: PROTOCOL_VERSION,
                };
            }
        }
        self.accepted();
        self.status()
    }

    /// A State frame's answer: the real-time solution ([`Controller::solve`]),
    /// then, for an accepted frame, the decoy management ([`Controller::manage`]).
    /// Two calls, not nested, so that the solution's frame (with the solver
    /// state saved for a rejection) is off the stack while the look-ahead flies
    /// (the Cortex-M7's 64 KiB).
    fn on_state(
        &mut self,
        frame: &AircraftStateFrame,
        counter: &mut impl InstructionCounter,
    ) -> DeviceMessage {
        match self.solve(frame, counter) {
            Solved::Output(mut output, measures, aircraft, start) => {
                self.manage(&mut output, &measures, &aircraft, frame.time_s);
                output.management_instructions = counter
                    .elapsed(start)
                    .wrapping_add(core::mem::take(&mut self.slice_instructions));
                DeviceMessage::Output(output)
            }
            Solved::Answer(answer) => answer,
        }
    }

    /// Decoy management after an accepted frame's solution: the monitors take
    /// its `measures`, a prediction starts from it if none is under way, and
    /// the report goes into `output`, with the steps of the look-ahead slice
    /// that ran since the last Output (the previous accepted frame's). This
    /// frame's slice is left due ([`Controller::background`]).
    #[inline(never)]
    fn manage(
        &mut self,
        output: &mut OutputFrame,
        measures: &Measures<T>,
        aircraft: &AircraftState<T>,
        now: f64,
    ) {
        self.monitors.update(measures, &self.management);
        self.lookahead.begin(
            self.solver.state(),
            self.solver.model().lengths(),
            aircraft,
            self.wave_rate,
            measures,
            &self.management,
        );
        output.prediction_steps = core::mem::take(&mut self.slice_steps) as u16;
        output.management = self.management_report(now);
        let [altitude, mach] = self.condition;
        output.management.limits = self.limits.at(altitude, mach);
        // The map's advisories: with the limits where the manoeuvre was entered.
        let manoeuvre = MapManoeuvre::of(aircraft);
        // (Retaken when older than the map's longest manoeuvre: a flight
        // never steady for that long, in turbulence, is judged where it is.)
        let stale = now - self.map_entry_s > self.limits.longest_manoeuvre_s();
        if manoeuvre.steady || !self.map_entry_taken || stale {
            self.map_entry = output.management.limits;
            self.map_entry_taken = true;
            self.map_entry_s = now;
        }
        // Where the map covers the flight it advises alone (its runs are
        // the host's 300 segments; the look-ahead's time to violation and
        // predicted margins stay in the report).
        let map_advisories = manoeuvre.advisories(&self.map_entry);
        let covered = self
            .map_cover
            .update(now, &manoeuvre, &self.limits, &self.map_entry);
        if covered {
            output.management.advisories = 0;
        }
        output.management.advisories |= map_advisories;
        self.last_management = output.management;
        // The slice runs after the answer (the look-ahead's steps, if it has any
        // to fly, and the air columns' prefetch).
        self.slice_due = true;
    }

    /// A State frame's real-time solution: the accepted Output (its management
    /// still to fill), its measures, the aircraft at its time and the counter's
    /// reading where the management starts; or the answer as it is: a rejection,
    /// or, while the controller initialises, its Status.
    #[inline(never)]
    fn solve(
        &mut self,
        frame: &AircraftStateFrame,
        counter: &mut impl InstructionCounter,
    ) -> Solved<T> {
        let start = counter.now();
        let seq = Some(frame.seq);
        let environment = &self.solver.model().params().environment;
        let checked = match self.profile {
            Profile::Streamed => {
                validate_streamed(frame, &environment.atmosphere, &environment.wind).map(Some)
            }
            _ if is_finite(frame) => Ok(None),
            _ => Err(RejectReason::NonFinite),
        };
        let mach = match checked {
            Ok(mach) => mach,
            Err(reason) => return Solved::Answer(self.reject(seq, reason)),
        };
        // The time rules, from the last accepted State frame of the run or of the
        // initialisation. On their bits (positive doubles order as their bit
        // patterns; a soft-float compare costs about 30 instructions on the M4F).
        let last_time = match (&self.run, self.init.active) {
            (Some(run), _) => Some(run.last.time_s),
            (None, true) => Some(self.init.last.time_s),
            (None, false) => None,
        };
        let mut interval = 0.0;
        if let Some(t0) = last_time {
            interval = frame.time_s - t0;
            if !(interval > 0.0) {
                return Solved::Answer(self.reject(seq, RejectReason::TimeNotIncreasing));
            }
            if interval.to_bits() > MAX_INTERVAL_BITS {
                // A gap. This frame is rejected, as a stray time would be; a
                // next frame that follows it (later, within the jump limit)
                // confirms that the stream went on without the controller (lost
                // samples, a failed frame's gap): the run ends and the
                // controller initialises at that frame (docs/protocol.md §4).
                let follows = self.pending_jump.armed && {
                    let d = frame.time_s - self.pending_jump.time_s;
                    d > 0.0 && d.to_bits() <= MAX_INTERVAL_BITS
                };
                if !follows {
                    self.pending_jump = PendingJump {
                        armed: true,
                        time_s: frame.time_s,
                    };
                    return Solved::Answer(self.reject(seq, RejectReason::TimeJump));
                }
                self.run = None;
                self.init = Initialising::NONE;
                self.pending_jump = PendingJump::NONE;
                self.reset_management();
                self.counters.gap_restarts = self.counters.gap_restarts.wrapping_add(1);
                interval = 0.0;
            }
        }
        // The used part only (the rest of `saved` stays zero, as the solver's).
        let mut saved = State::ZERO;
        saved.copy_used(self.solver.state(), self.solver.model().segment_count());
        // Without a run, the initialisation's too (a run's frames leave it alone).
        let saved_init = self.run.is_none().then_some(self.init);
        let integration = counter.now();
        // The frame the solver flies: the frame itself, or the built-in profile's.
        let generated;
        let flown = match (&self.builtin, &self.run) {
            (Some(path), Some(run)) => {
                generated = builtin::frame::<T>(
                    path,
                    frame.seq,
                    frame.time_s,
                    frame.time_s - run.start_time_s,
                );
                &generated
            }
            (Some(path), None) => {
                generated = builtin::frame::<T>(path, frame.seq, frame.time_s, 0.0);
                &generated
            }
            (None, _) => frame,
        };
        let (inside, mach) = self.inside_envelope(flown, mach);
        let result = match self.run {
            None => self.initialise(frame, flown),
            Some(run) => self.advance(&run, flown, interval, &saved).map(Some),
        };
        let step_instructions = counter.elapsed(integration);
        let (origin, start_time_s, steps, limited) = match result {
            Ok(Some(advanced)) => advanced,
            Ok(None) => {
                // A frame of the initialisation: accepted, answered by the Status.
                self.pending_jump = PendingJump::NONE;
                self.accepted();
                self.outside_envelope = !inside;
                return Solved::Answer(self.status_of(step_instructions));
            }
            Err(reason) => {
                self.roll_back(&saved, saved_init);
                return Solved::Answer(self.reject(seq, reason));
            }
        };
        let mut output = OutputFrame::ZERO;
        let Ok(aircraft) = self.output(frame, steps, &mut output) else {
            self.roll_back(&saved, saved_init);
            return Solved::Answer(self.reject(seq, RejectReason::SolverFailure));
        };
        if limited {
            output.flags |= StatusFlags::STEP_LIMITED;
        }
        if !inside {
            output.flags |= StatusFlags::OUTSIDE_ENVELOPE;
        }
        let solution_instructions = counter.elapsed(start);
        // Decoy management, after the real-time solution is complete (counted
        // apart): the measures of the output evaluation, the monitors, then one
        // slice of the look-ahead.
        let management = counter.now();
        let measures = Measures::of(
            &self.solver.last_outputs(),
            &aircraft,
            &self.geometry,
            &self.management,
        );
        if !measures.is_finite(&self.management) {
            self.roll_back(&saved, saved_init);
            return Solved::Answer(self.reject(seq, RejectReason::SolverFailure));
        }
        self.run = Some(Run {
            last: *flown,
            start_time_s,
            origin,
        });
        self.path.end_into(&mut self.path_end, flown, origin);
        self.wave_rate = self.last_wave_rate();
        self.pending_jump = PendingJump::NONE;
        self.accepted();
        self.hazard_flags = output.flags
            & (StatusFlags::OVER_TENSION
                | StatusFlags::CABLE_IN_PLUME
                | StatusFlags::DECOY_NEAR_AIRCRAFT);
        self.outside_envelope = !inside;
        if self.recovered_pending {
            self.recovered_pending = false;
            output.flags |= StatusFlags::RECOVERED;
        }
        output.instructions = solution_instructions;
        output.step_instructions = step_instructions;
        self.condition = [
            T::lit(-flown.position_ned_m[2]),
            mach.unwrap_or(T::lit(f64::NAN)),
        ];
        Solved::Output(output, measures, aircraft, management)
    }

    /// The model's connection point (aircraft body frame), whose kinematics the
    /// frame path interpolates ([`FramePath::towing`]).
    fn connection_point(&self) -> Vec3<T> {
        self.solver.model().params().connection_point
    }

    fn restore(&mut self, saved: &State<T, N>) {
        // `saved` was the solver's own state, so it is finite and accepted.
        let _ = self.solver.set_state(*saved);
    }

    /// Undoes a rejected frame: the solver's state, and the initialisation when
    /// there was no run.
    fn roll_back(&mut self, saved: &State<T, N>, init: Option<Initialising<T, N>>) {
        self.restore(saved);
        if let Some(init) = init {
            self.init = init;
        }
    }

    /// The built-in profile's flight path, if one is selected: its manoeuvre's
    /// built-in flight (`decoy_schema::ManoeuvreInfo::builtin`) at
    /// [`BUILTIN_ALTITUDE_M`], its Mach numbers as speeds with the model's
    /// atmosphere in f64, at the command's rate.
    fn builtin_path(&self) -> Option<ManoeuvrePath> {
        let Profile::Builtin(profile) = self.profile else {
            return None;
        };
        let manoeuvre = profile.manoeuvre();
        let flight = &manoeuvre.info().builtin;
        let env = self.solver.model().params().environment;
        let atmosphere = match env.atmosphere {
            Atmosphere::Isa1976 {
                gas_constant,
                gamma,
                gravity,
            } => Atmosphere::<f64>::Isa1976 {
                gas_constant: gas_constant.to_f64(),
                gamma: gamma.to_f64(),
                gravity: gravity.to_f64(),
            },
            Atmosphere::Vacuum => Atmosphere::Vacuum,
        };
        let a = atmosphere
            .at(BUILTIN_ALTITUDE_M)
            .map_or(0.0, |air| air.speed_of_sound);
        Some(ManoeuvrePath::new(
            manoeuvre,
            &ManoeuvreParams {
                altitude: BUILTIN_ALTITUDE_M,
                speed: flight.mach * a,
                final_speed: flight.final_mach * a,
                start: flight.start_s,
                acceleration: flight.acceleration_mps2,
                rate: f64::from(profile.rate_milli_radps()) * 1e-3,
                duration: flight.duration_s,
                gravity: env.gravity.to_f64(),
            },
        ))
    }

    /// True when the flown frame is inside the operating envelope, and its
    /// Mach number; `mach` its Mach number when validation computed it
    /// (streamed), else computed here.
    fn inside_envelope(&self, flown: &AircraftStateFrame, mach: Option<T>) -> (bool, Option<T>) {
        let env = &self.solver.model().params().environment;
        let mach = match mach {
            Some(mach) => Some(mach),
            None => crate::validate::mach_of(flown, &env.atmosphere, &env.wind),
        };
        let inside = mach.is_some_and(|mach| self.envelope.contains(flown, mach, env.gravity));
        (inside, mach)
    }

    /// A State frame with no run: starts the trim at it if none is in progress
    /// (streamed: at its steady state; built-in: at the profile's start; `flown`
    /// is the frame the solver flies), then carries the trim on by
    /// [`TRIM_SLICE_UNITS`]. `Ok(None)` while it is not complete; once it is, the
    /// run starts at this frame: the run's origin and start time, 0 steps, and
    /// the controller's path the constant path at `flown`. A streamed trim is for
    /// the first frame of the initialisation and is turned, when it completes, to
    /// this frame's heading (of the velocity through the air): the
    /// initialisation takes a few frames, and a heading is the one change a trim
    /// in still air follows exactly.
    fn initialise(
        &mut self,
        frame: &AircraftStateFrame,
        flown: &AircraftStateFrame,
    ) -> Result<Option<Advanced>, RejectReason> {
        // Unconfigured (`Controller::UNCONFIGURED`): no model to trim.
        if !self.solver.model().is_configured() {
            return Err(RejectReason::NotTrimmed);
        }
        if !self.init.active {
            let origin = FramePath::<T>::run_origin(flown);
            let aircraft = FramePath::<T>::single(flown, origin).end_state();
            let task = self
                .solver
                .start_trim(&steady_flight(&aircraft))
                .map_err(|_| RejectReason::NotTrimmed)?;
            self.init = Initialising {
                active: true,
                task,
                target: *flown,
                last: *frame,
            };
        }
        let done = self
            .solver
            .advance_trim(&mut self.init.task, self.trim_units_per_frame, frame.time_s)
            .map_err(|_| RejectReason::NotTrimmed)?;
        self.init.last = *frame;
        if !done {
            return Ok(None);
        }
        if self.builtin.is_none() {
            let from = self.init.target.velocity_ned_mps;
            self.turn_to_heading(&from, &flown.velocity_ned_mps);
        }
        self.init = Initialising::NONE;
        let origin = FramePath::<T>::run_origin(flown);
        let point = self.connection_point();
        self.path.set_after(&PathEnd::NONE, flown, flown, origin);
        self.path.set_towing(point);
        self.solver
            .outputs(&self.path)
            .map_err(|_| RejectReason::SolverFailure)?;
        Ok(Some((origin, frame.time_s, 0, false)))
    }

    /// Turns the solver's state about the vertical from the heading of the air
    /// velocity `from` to that of `to` (NED, m/s over the ground; the wind
    /// subtracted). Nothing when either has no horizontal airspeed or they are
    /// the same.
    fn turn_to_heading(&mut self, from: &[f32; 3], to: &[f32; 3]) {
        let wind = self.solver.model().params().environment.wind;
        let air = |v: &[f32; 3]| {
            (
                T::lit(f64::from(v[0])) - wind.x,
                T::lit(f64::from(v[1])) - wind.y,
            )
        };
        let ((x0, y0), (x1, y1)) = (air(from), air(to));
        let (dot, cross) = (x0 * x1 + y0 * y1, x0 * y1 - y0 * x1);
        let length = (dot * dot + cross * cross).square_root();
        if !(length > T::zero()) || (cross == T::zero() && dot > T::zero()) {
            return;
        }
        self.solver
            .turn_about_vertical(dot / length, cross / length);
    }

    /// Integrates from the run's last frame to `flown` (the frame the solver
    /// flies), `interval` seconds later, along the controller's path, built in
    /// place. Returns the run's origin and start time (unchanged), the RK4 steps
    /// taken and whether the wave-speed limit asked for more than the nominal
    /// steps.
    fn advance(
        &mut self,
        run: &Run,
        flown: &AircraftStateFrame,
        interval: f64,
        saved: &State<T, N>,
    ) -> Result<Advanced, RejectReason> {
        let nominal = nominal_steps(interval);
        let steps = self.step_count(interval, nominal);
        let point = self.connection_point();
        self.path
            .set_after(&self.path_end, &run.last, flown, run.origin);
        self.path.set_towing(point);
        let steps = Self::integrate_checked(
            &mut self.solver,
            &self.path,
            saved,
            flown.time_s,
            steps,
            self.max_steps_per_frame,
        )
        .map_err(|_: SolveError| RejectReason::SolverFailure)?;
        Ok((run.origin, run.start_time_s, steps as u16, steps > nominal))
    }

    /// The RK4 steps for a frame `interval` seconds after the last one, whose
    /// [`nominal_steps`] are `nominal`: those and, with the tensions of the last
    /// evaluation (the previous frame's outputs), at most [`crate::wave::WAVE_STEP_FACTOR`]
    /// l_i / c_i on every segment; at most `max_steps_per_frame`. In steady
    /// flight the first limit decides (four steps per 10 ms frame for the
    /// reference system); a snatch load (the cable jerked taut after a pull-up)
    /// raises the tension, and with it the wave speed, tenfold for a moment, and
    /// the step shrinks with it.
    fn step_count(&self, interval: f64, nominal: u32) -> u32 {
        let max = self.max_steps_per_frame;
        let by_wave = wave_steps(interval, self.wave_rate, max);
        let steps = if by_wave > nominal { by_wave } else { nominal };
        if steps < max { steps } else { max }
    }

    /// max_i c_i / l_i (1/s), c_i = sqrt(T_i / mu) at the larger end tension of
    /// segment i, with the tensions of the solver's last evaluation.
    fn last_wave_rate(&self) -> T {
        wave_rate_of(&self.solver)
    }

    /// `steps` RK4 steps over `path` ending exactly at `t1` and the output
    /// evaluation there ([`Solver::outputs`]), again with more steps when a step
    /// or the evaluation fails or when the tensions at the end of the frame ask
    /// for more steps than were taken (they rose within the frame), doubling each
    /// time up to `max` steps; each attempt starts from the frame's
    /// initial state `start`. Returns the steps of the attempt that stood.
    /// Deterministic: the same state and frames take the same attempts.
    fn integrate_checked(
        solver: &mut Solver<T, N>,
        path: &FramePath<T>,
        start: &State<T, N>,
        t1: f64,
        mut steps: u32,
        max: u32,
    ) -> Result<u32, SolveError> {
        loop {
            // The steps, then the output evaluation at the frame's end, whose
            // tensions decide whether the frame asks for more steps.
            let attempt = solver
                .steps_on(path, steps, t1)
                .and_then(|()| solver.outputs(path).map(drop));
            let wanted = match attempt {
                Ok(()) => wave_steps(path.span_s(), wave_rate_of(solver), max),
                Err(_) => 2 * steps,
            };
            if wanted <= steps || steps >= max {
                return attempt.map(|()| steps);
            }
            // `start` was the solver's own state: finite and accepted.
            let _ = solver.set_state(*start);
            let doubled = 2 * steps;
            steps = (if wanted > doubled { wanted } else { doubled }).min(max);
        }
    }

    /// The management report at frame time `now`: the monitors, and the last
    /// completed prediction (times to violation from `now`).
    fn management_report(&self, now: f64) -> Management {
        let mut report = self.monitors.report();
        let running = self.lookahead.running_violations();
        let last = self.lookahead.last();
        if let Some(p) = last {
            report.prediction_from_s = p.from;
            report.prediction_horizon_s = p.horizon as f32;
        }
        let mut advisories = 0;
        for (requirement, r) in report.reports.iter_mut() {
            if let Some(p) = last {
                r.predicted_worst_margin = p.worst[requirement].to_f64() as f32;
            }
            // The prediction under way, from a later state, first; else the
            // last completed one.
            if let Some(at) =
                running[requirement].or(last.and_then(|p| p.violation_at[requirement]))
            {
                r.time_to_violation_s = (at - now).max(0.0) as f32;
                advisories |= Advisories::bit(requirement);
            }
        }
        report.advisories = advisories;
        report
    }

    /// The Output frame at the solver's current state on the controller's path
    /// (the frame's), from its output evaluation, written into `output`; returns
    /// the aircraft's state there.
    fn output(
        &mut self,
        frame: &AircraftStateFrame,
        steps: u16,
        output: &mut OutputFrame,
    ) -> Result<AircraftState<T>, SolveError> {
        // The output evaluation at the frame's end, made with the frame's
        // integration (`integrate_checked`) or trim (`initialise`).
        let aircraft = self.path.end_state();
        let out = self.solver.last_outputs();
        let geometry = &self.geometry;
        let fp = FlightPathFrame::of(&aircraft);
        let n = out.segment_count();
        let (cable_clearance, _) = cable_plume_clearance(
            &geometry.plume,
            &aircraft,
            (0..=n).map(|j| out.joint_position(j)),
        );
        let narrow = |v: T| v.to_f64() as f32;
        let (position, euler, aoa, decoy_clearance, has_decoy) = match out.decoy() {
            Some(d) => {
                let c = fp.components(&(d.cg_position - aircraft.position));
                let (roll, pitch, yaw) = fp.relative_euler(&d.attitude);
                (
                    [narrow(c.x), narrow(c.y), narrow(c.z)],
                    [narrow(roll), narrow(pitch), narrow(yaw)],
                    narrow(d.angle_of_attack),
                    geometry
                        .envelope
                        .clearance(&to_body(&aircraft, &d.cg_position)),
                    true,
                )
            }
            None => (
                [f32::NAN; 3],
                [f32::NAN; 3],
                f32::NAN,
                T::lit(f64::INFINITY),
                false,
            ),
        };
        let connection_tension = out.connection_tension();
        let mut flags = StatusFlags::TRIMMED;
        if self.builtin.is_some() {
            flags |= StatusFlags::PROFILE_BUILTIN;
        }
        if connection_tension > self.allowable_tension_n {
            flags |= StatusFlags::OVER_TENSION;
        }
        if cable_clearance < T::zero() {
            flags |= StatusFlags::CABLE_IN_PLUME;
        }
        if decoy_clearance < T::lit(DECOY_NEAR_AIRCRAFT_M) {
            flags |= StatusFlags::DECOY_NEAR_AIRCRAFT;
        }
        output.seq = frame.seq;
        output.time_s = frame.time_s;
        output.connection_tension_n = narrow(connection_tension);
        output.tow_tension_n = narrow(out.tow_tension());
        output.decoy_position_fp_m = position;
        output.decoy_euler_rel_rad = euler;
        output.angle_of_attack_rad = aoa;
        output.cable_clearance_exhaust_m = narrow(cable_clearance);
        output.decoy_clearance_aircraft_m = narrow(decoy_clearance);
        output.flags = flags;
        output.steps = steps;
        // Never a non-finite value in an accepted frame, whatever the precision
        // (narrowing an f64 beyond f32's range included): the frame is rejected as
        // a solver failure and the state rolled back.
        if !output_is_finite(output, has_decoy) {
            return Err(SolveError::NonFinite { joint: 0 });
        }
        Ok(aircraft)
    }
}

/// The bits of the longest accepted interval between two State frames,
/// [`MAX_TIME_JUMP_S`] plus [`TIME_TOLERANCE_S`] (positive doubles order as their
/// bit patterns).
const MAX_INTERVAL_BITS: u64 = (MAX_TIME_JUMP_S + TIME_TOLERANCE_S).to_bits();

/// The bits of the frame intervals at which the nominal step count goes up: an
/// interval of up to `STEP_THRESHOLDS[k]` seconds takes k + 1 steps, n steps for
/// an interval dt the smallest n with dt <= (n + 1e-9) [`MAX_STEP_S`]
/// (ceil(dt / MAX_STEP_S - 1e-9), formed without f64 arithmetic).
const STEP_THRESHOLDS: [u64; 64] = {
    let mut bits = [u64::MAX; 64];
    let mut k = 0;
    while k < 64 {
        bits[k] = ((k as f64 + 1.0 + 1e-9) * MAX_STEP_S).to_bits();
        k += 1;
    }
    bits
};

/// The nominal RK4 steps of a frame `interval` seconds after the last one
/// (positive, at most [`MAX_TIME_JUMP_S`] plus the tolerance): the smallest n
/// with interval <= (n + 1e-9) [`MAX_STEP_S`], at least 1 (four for a 10 ms
/// frame). A binary search of six comparisons over [`STEP_THRESHOLDS`]: the
/// same cost for every interval.
fn nominal_steps(interval: f64) -> u32 {
    let bits = interval.to_bits();
    let (mut lo, mut width) = (0usize, 64usize);
    while width > 1 {
        width /= 2;
        if STEP_THRESHOLDS[lo + width - 1] < bits {
            lo += width;
        }
    }
    lo as u32 + 1
}

/// True when every value of an Output frame is finite (the decoy's position,
/// attitude, angle of attack and clearance only when there is a decoy: without
/// one they are NaN and infinity by definition).
fn output_is_finite(o: &OutputFrame, has_decoy: bool) -> bool {
    let always = [
        o.connection_tension_n,
        o.tow_tension_n,
        o.cable_clearance_exhaust_m,
    ];
    let decoy = o
        .decoy_position_fp_m
        .iter()
        .chain(&o.decoy_euler_rel_rad)
        .chain([&o.angle_of_attack_rad, &o.decoy_clearance_aircraft_m]);
    always.iter().all(|v| v.is_finite()) && (!has_decoy || decoy.into_iter().all(|v| v.is_finite()))
}
