//! The decoy controller: a pure state machine (no hardware, no time source of its
//! own) that turns host messages into answers. The firmware wraps it with a UART
//! and SysTick; the host runs the same type as its reference.

use solver_core::profiles::{LevelAcceleration, LevelTurn, PullUp};
use solver_core::{
    AircraftState, Atmosphere, ConfigError, FlightPath, Model, ModelParams, Real, SolveError,
    Solver, State, Vec3,
};

use crate::geometry::{FlightPathFrame, Geometry, cable_plume_clearance, to_body};
use crate::lookahead::Lookahead;
use crate::monitor::{ManagementConfig, Measures, Monitors};
use crate::path::{FramePath, PathEnd, steady_flight};
use crate::validate::{is_finite, validate_streamed};
use decoy_link::{
    Advisories, AircraftStateFrame, BoardInfo, Command, Counters, DeviceMessage, Hello,
    HostMessage, Management, OutputFrame, PROTOCOL_VERSION, Profile, RejectReason, Rejected,
    StatusFlags, StatusFrame,
};
use decoy_link::{Decoder, FrameError};

/// The longest RK4 step, s: a frame interval dt is integrated in
/// n = ceil(dt / MAX_STEP_S - 1e-9) steps of dt / n, or more where the
/// wave-speed limit asks ([`WAVE_STEP_FACTOR`]). 2.5 ms (four steps per 10 ms
/// frame) is the accuracy step of the embedded model (12 graded 1.26): through a
/// snatch load it keeps the peak tension within 2 % of the host's converged
/// solution (issue 14, firmware/README.md "The worst frame and the accuracy"),
/// and the wave-speed limit of its 1.73 m shortest segment is not reached by
/// any shipped manoeuvre.
pub const MAX_STEP_S: f64 = 0.0025;
/// Safety factor of the wave-speed step limit: every RK4 step is at most
/// `WAVE_STEP_FACTOR` l_i / c_i for every segment i, c_i = sqrt(T_i / mu) the
/// transverse wave speed at its larger end tension: a thin rod pulled at both
/// ends swings at sqrt(12) c/l, and RK4 is stable to about 2.8 rad per step.
pub const WAVE_STEP_FACTOR: f64 = 0.8;
/// Most RK4 steps one frame may take (a floor of 0.5 ms on a 10 ms frame).
pub const MAX_STEPS_PER_FRAME: f64 = 20.0;
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

/// Altitude of the built-in profiles, m.
const PROFILE_ALTITUDE_M: f64 = 9000.0;

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

/// A run after a State frame: the run, the RK4 steps taken, and the streamed
/// path they followed (None for a built-in profile).
type Advanced = (Run, u16);

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
    profile: Profile,
    /// The flight path of the selected built-in profile (None: streamed), made
    /// when the profile is selected.
    builtin: Option<BuiltinPath>,
    run: Option<Run>,
    /// Where the last streamed frame's path ended, for the next one to start
    /// from (a cache: the paths have the same bits without it).
    path_end: PathEnd<T>,
    counters: Counters,
    degraded: bool,
    recovered_pending: bool,
    hazard_flags: u16,
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
        profile: Profile::Streamed,
        // `Some` of a zero path rather than `None`, whose niche is nonzero bits: the
        // constant must be all zero bits to lie in `.bss` (checked by the HIL
        // tests). Never read: selecting a profile replaces it, `configure` clears
        // it, and an unconfigured controller never starts a run.
        builtin: Some(BuiltinPath::Level(LevelAcceleration {
            altitude: 0.0,
            initial_speed: 0.0,
            final_speed: 0.0,
            start: 0.0,
            acceleration: 0.0,
        })),
        run: None,
        path_end: PathEnd::NONE,
        counters: Counters::ZERO,
        degraded: false,
        recovered_pending: false,
        hazard_flags: 0,
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
        self.profile = Profile::Streamed;
        self.builtin = None;
        self.run = None;
        self.path_end = PathEnd::NONE;
        self.counters = Counters::ZERO;
        self.degraded = false;
        self.recovered_pending = false;
        self.hazard_flags = 0;
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
        DeviceMessage::Status(StatusFrame {
            protocol_version: PROTOCOL_VERSION,
            flags: self.flags(),
            segments: self.segments(),
            time_s: self.run.map_or(0.0, |r| r.last.time_s),
            counters: self.counters,
        })
    }

    fn segments(&self) -> u16 {
        self.solver.model().segment_count() as u16
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
                self.reset_management();
            }
            Command::SelectProfile(profile) => {
                let rate = match profile {
                    Profile::PullUp { rate_milli_radps } | Profile::Turn { rate_milli_radps } => {
                        rate_milli_radps
                    }
                    _ => 0,
                };
                if rate > MAX_PROFILE_RATE_MILLI_RADPS {
                    return self.reject(None, RejectReason::OutOfRange);
                }
                self.profile = profile;
                self.builtin = self.builtin_path();
                self.run = None;
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
            Ok((mut output, measures, aircraft, start)) => {
                self.manage(&mut output, &measures, &aircraft, frame.time_s);
                output.management_instructions = counter
                    .elapsed(start)
                    .wrapping_add(core::mem::take(&mut self.slice_instructions));
                DeviceMessage::Output(output)
            }
            Err(answer) => answer,
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
        self.last_management = output.management;
        self.slice_due = self.lookahead.available();
    }

    /// A State frame's real-time solution: the accepted Output (its management
    /// still to fill), its measures, the aircraft at its time and the counter's
    /// reading where the management starts; or the rejection.
    #[inline(never)]
    #[allow(clippy::type_complexity, clippy::result_large_err)]
    fn solve(
        &mut self,
        frame: &AircraftStateFrame,
        counter: &mut impl InstructionCounter,
    ) -> Result<(OutputFrame, Measures<T>, AircraftState<T>, u32), DeviceMessage> {
        let start = counter.now();
        let seq = Some(frame.seq);
        let environment = &self.solver.model().params().environment;
        let checked = match self.profile {
            Profile::Streamed => {
                validate_streamed(frame, &environment.atmosphere, &environment.wind)
            }
            _ if is_finite(frame) => Ok(()),
            _ => Err(RejectReason::NonFinite),
        };
        if let Err(reason) = checked {
            return Err(self.reject(seq, reason));
        }
        if let Some(run) = &self.run {
            let dt = frame.time_s - run.last.time_s;
            if !(dt > 0.0) {
                return Err(self.reject(seq, RejectReason::TimeNotIncreasing));
            }
            if dt > MAX_TIME_JUMP_S + TIME_TOLERANCE_S {
                return Err(self.reject(seq, RejectReason::TimeJump));
            }
        }
        // The used part only (the rest of `saved` stays zero, as the solver's).
        let mut saved = State::ZERO;
        saved.copy_used(self.solver.state(), self.solver.model().segment_count());
        let integration = counter.now();
        // A streamed run's path, built in place by `start_run` or `advance`.
        let mut path = None;
        let result = match self.run {
            None => self.start_run(frame, &mut path),
            Some(run) => self.advance(&run, frame, &saved, &mut path),
        };
        let step_instructions = counter.elapsed(integration);
        match result {
            Ok((run, steps)) => match self.output(frame, steps, path.as_ref()) {
                Ok((mut output, aircraft)) => {
                    let solution_instructions = counter.elapsed(start);
                    // Decoy management, after the real-time solution is complete
                    // (counted apart): the measures of the output evaluation,
                    // the monitors, then one slice of the look-ahead.
                    let management = counter.now();
                    let measures = Measures::of(
                        &self.solver.last_outputs(),
                        &aircraft,
                        &self.geometry,
                        &self.management,
                    );
                    if !measures.is_finite(&self.management) {
                        self.restore(&saved);
                        return Err(self.reject(seq, RejectReason::SolverFailure));
                    }
                    self.run = Some(run);
                    self.wave_rate = self.last_wave_rate();
                    self.accepted();
                    self.hazard_flags = output.flags
                        & (StatusFlags::OVER_TENSION
                            | StatusFlags::CABLE_IN_PLUME
                            | StatusFlags::DECOY_NEAR_AIRCRAFT);
                    if self.recovered_pending {
                        self.recovered_pending = false;
                        output.flags |= StatusFlags::RECOVERED;
                    }
                    output.instructions = solution_instructions;
                    output.step_instructions = step_instructions;
                    Ok((output, measures, aircraft, management))
                }
                Err(_) => {
                    self.restore(&saved);
                    Err(self.reject(seq, RejectReason::SolverFailure))
                }
            },
            Err(reason) => {
                self.restore(&saved);
                Err(self.reject(seq, reason))
            }
        }
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

    /// The built-in profile's flight path, if one is selected.
    fn builtin_path(&self) -> Option<BuiltinPath> {
        if self.profile == Profile::Streamed {
            return None;
        }
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
            .at(PROFILE_ALTITUDE_M)
            .map_or(0.0, |air| air.speed_of_sound);
        let h = PROFILE_ALTITUDE_M;
        Some(match self.profile {
            Profile::Streamed => return None,
            Profile::Steady => BuiltinPath::Level(LevelAcceleration::steady(h, 0.8 * a)),
            Profile::Acceleration => BuiltinPath::Level(LevelAcceleration {
                altitude: h,
                initial_speed: 0.6 * a,
                final_speed: 0.8 * a,
                start: 2.0,
                acceleration: 10.0,
            }),
            Profile::PullUp { rate_milli_radps } => BuiltinPath::PullUp(PullUp {
                altitude: h,
                speed: 0.6 * a,
                start: 2.0,
                rate: f64::from(rate_milli_radps) * 1e-3,
                duration: 5.0,
            }),
            Profile::Turn { rate_milli_radps } => BuiltinPath::Turn(LevelTurn {
                altitude: h,
                speed: 0.8 * a,
                start: 0.0,
                rate: f64::from(rate_milli_radps) * 1e-3,
                gravity: env.gravity.to_f64(),
            }),
        })
    }

    /// Trims at the frame (streamed) or at the profile's start (built-in).
    ///
    /// Returns the new run, 0 steps and (streamed) the constant path at the frame.
    fn start_run(
        &mut self,
        frame: &AircraftStateFrame,
        streamed: &mut Option<FramePath<T>>,
    ) -> Result<Advanced, RejectReason> {
        // Unconfigured (`Controller::UNCONFIGURED`): no model to trim.
        if self.solver.model().segment_count() == 0 {
            return Err(RejectReason::NotTrimmed);
        }
        let run = Run {
            last: *frame,
            start_time_s: frame.time_s,
            origin: FramePath::<T>::run_origin(frame),
        };
        let (aircraft, time): (AircraftState<T>, f64) = match self.builtin {
            Some(path) => (path.state_at(0.0), 0.0),
            None => {
                let path = streamed.insert(
                    FramePath::<T>::single(frame, run.origin).towing(self.connection_point()),
                );
                self.path_end = path.end(frame, run.origin);
                (path.state_at(frame.time_s), frame.time_s)
            }
        };
        // In place (the caller restores its saved state on error).
        self.solver
            .trim(&steady_flight(&aircraft), time)
            .map_err(|_| RejectReason::NotTrimmed)?;
        Ok((run, 0))
    }

    /// Integrates from the run's last frame to `frame`.
    ///
    /// Returns the run, the RK4 steps taken and (streamed) the path integrated
    /// along, on which the outputs are evaluated.
    fn advance(
        &mut self,
        run: &Run,
        frame: &AircraftStateFrame,
        saved: &State<T, N>,
        streamed: &mut Option<FramePath<T>>,
    ) -> Result<Advanced, RejectReason> {
        let dt = frame.time_s - run.last.time_s;
        let steps = self.step_count(dt);
        let next = Run {
            last: *frame,
            ..*run
        };
        let failure = |_: SolveError| RejectReason::SolverFailure;
        let steps = match self.builtin {
            Some(path) => {
                let (t0, t1) = (
                    run.last.time_s - run.start_time_s,
                    frame.time_s - run.start_time_s,
                );
                self.integrate_checked(saved, &path, t0, t1, steps)
                    .map_err(failure)?
            }
            None => {
                // Built in the caller's slot, where the outputs read it (not moved).
                let point = self.connection_point();
                let path = streamed.insert(
                    FramePath::<T>::after(&self.path_end, &run.last, frame, run.origin)
                        .towing(point),
                );
                self.path_end = path.end(frame, run.origin);
                self.integrate_checked(saved, path, run.last.time_s, frame.time_s, steps)
                    .map_err(failure)?
            }
        };
        Ok((next, steps as u16))
    }

    /// The RK4 steps for a frame `dt` seconds after the last one: enough for steps of
    /// at most [`MAX_STEP_S`] and, with the tensions of the last evaluation (the
    /// previous frame's outputs), at most [`WAVE_STEP_FACTOR`] l_i / c_i on every
    /// segment; at most [`MAX_STEPS_PER_FRAME`]. In steady flight the first limit
    /// decides (four steps per 10 ms frame for the reference system); a snatch load
    /// (the cable jerked taut after a pull-up) raises the tension, and with it the
    /// wave speed, tenfold for a moment, and the step shrinks with it.
    fn step_count(&self, dt: f64) -> f64 {
        // dt / MAX_STEP_S as dt times its reciprocal (400 for 2.5 ms), a soft-float
        // multiply rather than a divide on the M4F (the quotient and the product
        // differ by at most an ulp, far inside the 1e-9 allowance); the floor of
        // one step by comparison.
        let periods = libm::ceil(dt * (1.0 / MAX_STEP_S) - 1e-9);
        let by_period = if periods > 1.0 { periods } else { 1.0 };
        let by_wave = wave_steps(dt, self.wave_rate);
        let steps = if by_wave > by_period {
            by_wave
        } else {
            by_period
        };
        steps.min(MAX_STEPS_PER_FRAME)
    }

    /// max_i c_i / l_i (1/s), c_i = sqrt(T_i / mu) at the larger end tension of
    /// segment i, with the tensions of the solver's last evaluation.
    fn last_wave_rate(&self) -> T {
        crate::lookahead::wave_rate_of(&self.solver)
    }

    /// [`Controller::integrate`] with `steps` steps, again with more when a step
    /// fails or when the tensions at the end of the frame ask for more steps than
    /// were taken (they rose within the frame), doubling each time up to
    /// [`MAX_STEPS_PER_FRAME`]; each attempt starts from the frame's initial state.
    /// Returns the steps of the attempt that stood. Deterministic: the same state
    /// and frames take the same attempts.
    fn integrate_checked<P: FlightPath<T>>(
        &mut self,
        start: &State<T, N>,
        path: &P,
        t0: f64,
        t1: f64,
        mut steps: f64,
    ) -> Result<f64, SolveError> {
        loop {
            let attempt = self.integrate(path, t0, t1, steps);
            let wanted = match attempt {
                Ok(()) => wave_steps(t1 - t0, self.last_wave_rate()),
                Err(_) => 2.0 * steps,
            };
            if wanted <= steps || steps >= MAX_STEPS_PER_FRAME {
                return attempt.map(|()| steps);
            }
            // `start` was the solver's own state: finite and accepted.
            let _ = self.solver.set_state(*start);
            let doubled = 2.0 * steps;
            steps = (if wanted > doubled { wanted } else { doubled }).min(MAX_STEPS_PER_FRAME);
        }
    }

    /// `steps` RK4 steps of (t1 - t0) / steps, ending exactly at t1.
    fn integrate<P: FlightPath<T>>(
        &mut self,
        path: &P,
        t0: f64,
        t1: f64,
        steps: f64,
    ) -> Result<(), SolveError> {
        let h = (t1 - t0) / steps;
        self.solver.steps(path, h, steps as u32)?;
        self.solver.set_time(t1);
        Ok(())
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
        for (k, r) in report.reports_mut().into_iter().enumerate() {
            if let Some(p) = last {
                r.predicted_worst_margin = p.worst[k].to_f64() as f32;
            }
            // The prediction under way, from a later state, first; else the
            // last completed one.
            if let Some(at) = running[k].or(last.and_then(|p| p.violation_at[k])) {
                r.time_to_violation_s = (at - now).max(0.0) as f32;
                advisories |= Advisories::bit(k);
            }
        }
        report.advisories = advisories;
        report
    }

    /// The Output frame at the solver's current state and the aircraft's state.
    ///
    /// `streamed` is the path of a streamed run (None: the built-in profile's).
    fn output(
        &mut self,
        frame: &AircraftStateFrame,
        steps: u16,
        streamed: Option<&FramePath<T>>,
    ) -> Result<(OutputFrame, AircraftState<T>), SolveError> {
        let t = self.solver.state().time;
        let builtin = self.builtin;
        let (aircraft, out) = match (&builtin, streamed) {
            (Some(path), _) => (path.state_at(t), self.solver.outputs(path)?),
            (None, Some(path)) => (path.state_at(t), self.solver.outputs(path)?),
            (None, None) => return Err(SolveError::NonFinite { joint: 0 }),
        };
        let geometry = self.geometry;
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
        if builtin.is_some() {
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
        let output = OutputFrame {
            seq: frame.seq,
            time_s: frame.time_s,
            connection_tension_n: narrow(connection_tension),
            tow_tension_n: narrow(out.tow_tension()),
            decoy_position_fp_m: position,
            decoy_euler_rel_rad: euler,
            angle_of_attack_rad: aoa,
            cable_clearance_exhaust_m: narrow(cable_clearance),
            decoy_clearance_aircraft_m: narrow(decoy_clearance),
            flags,
            instructions: 0,
            step_instructions: 0,
            steps,
            management_instructions: 0,
            prediction_steps: 0,
            management: Management::default(),
        };
        // Never a non-finite value in an accepted frame, whatever the precision
        // (narrowing an f64 beyond f32's range included): the frame is rejected as
        // a solver failure and the state rolled back.
        if !output_is_finite(&output, has_decoy) {
            return Err(SolveError::NonFinite { joint: 0 });
        }
        Ok((output, aircraft))
    }
}

/// The steps of `dt` the wave-speed limit asks for at the wave-speed rate `rate`
/// (max_i c_i / l_i, 1/s): ceil(dt rate / [`WAVE_STEP_FACTOR`]); 0 if not finite.
fn wave_steps<T: Real>(dt: f64, rate: T) -> f64 {
    // In T (f64 is emulated on the M4F); an exact integer here is a tie of no
    // consequence either way.
    let steps = (T::lit(dt) * rate * T::lit(1.0 / WAVE_STEP_FACTOR)).ceil();
    if steps.finite() { steps.to_f64() } else { 0.0 }
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

/// A built-in profile's flight path.
#[derive(Clone, Copy, Debug, PartialEq)]
enum BuiltinPath {
    Level(LevelAcceleration),
    PullUp(PullUp),
    Turn(LevelTurn),
}

impl<T: Real> FlightPath<T> for BuiltinPath {
    fn state_at(&self, t: f64) -> AircraftState<T> {
        match self {
            BuiltinPath::Level(p) => p.state_at(t),
            BuiltinPath::PullUp(p) => p.state_at(t),
            BuiltinPath::Turn(p) => p.state_at(t),
        }
    }
}
