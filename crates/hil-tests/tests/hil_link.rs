//! The firmware in the loop over the real link: the decoy controller firmware boots
//! on QEMU (`-icount shift=0`), its UART on a TCP port, and the host drives it frame
//! by frame at the 10 ms control period with the aircraft states of the paper's
//! scenarios (the profiles `decoy simulate` flies).
//!
//! Every f32 test runs on both f32 boards ([`F32_BOARDS`], one module each, the same
//! test bodies): the Cortex-M4F of `mps2-an386` (the default build) and the
//! STM32F405 on `netduinoplus2` (stm32f4xx-hal, SysTick at 168 MHz, the profile
//! `board-stm32f405`); so the STM32F405 must answer bit for bit as the host f32
//! controller and so as the M4, within the same instruction budgets. The M7
//! profile (f64) has its own test.
//!
//! What is asserted:
//!
//! - **Same answers as the host.** The host replays the very messages sent through
//!   `decoy_controller::Controller` (same configuration, same `FramePath`, same stepping
//!   rule) in this process: every build computes the target's maths (libm), so this
//!   is an ordinary workspace test. In f32 (the firmware's precision) every answer must be equal:
//!   outputs in every field but `instructions`, bit for bit
//!   ([`F32_RELATIVE_TOLERANCE`] = 0), rejections and status frames exactly; the M7
//!   profile (f64) likewise against the f64 reference. Against the host's f64
//!   solution the connection tension must agree within
//!   [`F64_CONNECTION_TOLERANCE`] (0.5 %) and the towing-point tension (about a
//!   fifth of it) within [`F64_TOW_TOLERANCE`] (1.5 %); through the pull-ups'
//!   snatch load, where f32 and f64 may take different step counts and the
//!   transient amplifies round-off, within [`SNATCH_TOLERANCES`] (2 % of the run's
//!   peak connection tension for both).
//! - **Instruction budget.** The solver's instructions per nominal 10 ms control
//!   step (four RK4 steps of 2.5 ms; the `step_instructions` field: SysTick under
//!   `-icount`, exact) at most [`CONTROL_STEP_TARGET`], the firmware issue's target
//!   (goal [`CONTROL_STEP_GOAL`]); per RK4 step of a nominal control step at most
//!   [`RK4_STEP_TARGET`], the benchmark issue's target; and the whole nominal frame
//!   (validation, steps, outputs) within [`FRAME_BUDGET`], a guard just above the
//!   measurement. The costliest frame over ALL the frames of each scenario,
//!   where the wave-speed limit takes more steps (docs/protocol.md §5) and the
//!   snatch loads included, within issue 14's target [`WORST_FRAME_TARGET`] and
//!   its [`WorstFrame`] guard (every frame of every manoeuvre takes the nominal
//!   four steps: 98,240 to 99,520 on the M4).
//! - **Determinism.** Two runs receive byte-identical streams (the instruction
//!   counts included, so on the STM32F405 the 168 MHz SysTick's conversion to
//!   instructions repeats too).
//! - **Hello.** Each board names itself and its core clock as
//!   `decoy_hil::qemu::Board::info` says.
//! - **Advisory line (STM32F405).** The firmware's log shows the line asserted at
//!   the first Output with a hazard flag and deasserted at the first without,
//!   exactly at the outputs where the hazard flags change.
//! - **Robustness.** Corrupted, truncated, garbage, oversize frames; non-finite and
//!   out-of-range values; a bad quaternion; time going backwards or jumping; link
//!   silence. Each gets its typed answer with the right counter (the same answers a
//!   host controller gives to the same bytes), QEMU keeps running, and the next
//!   valid frame is answered exactly as in an undisturbed run.
//!
//! Scenario lengths (test time): steady flight and the recorded flight for 10 s;
//! the acceleration for 10 s (its whole ramp, Mach
//! 0.6 to 0.8 from t = 2 s to about 8 s); the pull-ups at 0.05, 0.10 and 0.20
//! rad/s for 10 s (the rotation from 2 s to 7 s and the snatch load when the cable
//! is jerked taut at about 8.7 s, where the 16 graded 1.3 model's steps had to
//! shrink to the wave-speed limit and the 12 graded 1.26 model's need not); the
//! turns at 0.10 and 0.20 rad/s for 5 s.
//!
//! A missing QEMU, target or `defmt-print` fails with a message saying to run
//! `cargo xtask setup`: nothing is skipped. When a test fails, the firmware's
//! defmt log (decoded with `defmt-print`) and QEMU's stderr are printed with it.

use std::path::PathBuf;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use decoy_config::SystemConfig;
use decoy_hil::flight::{self, Exchange};
use decoy_hil::link::Session;
use decoy_hil::qemu::Board;
use decoy_hil::reference::Reference;
use decoy_hil::{defmt, firmware};
use decoy_link::{
    AircraftStateFrame, Command, DeviceMessage, HostMessage, OutputFrame, RejectReason, StatusFlags,
};
use decoy_sim::{RunOptions, Scenario};

/// Time limit of the firmware build (a cold build takes about a minute).
const BUILD_TIMEOUT: Duration = Duration::from_secs(900);

/// Largest relative tension difference from the host controller in f32: none, the
/// same code in the same precision gives the same bits.
const F32_RELATIVE_TOLERANCE: f64 = 0.0;
/// Largest relative difference of the connection tension from the host
/// controller in f64.
const F64_CONNECTION_TOLERANCE: f64 = 5e-3;
/// Largest relative difference of the towing-point tension (about 50 N, a fifth of
/// the connection tension, so f32 round-off weighs more) from the host in f64.
const F64_TOW_TOLERANCE: f64 = 1.5e-2;
/// The connection and towing-point tolerances against the host's f64 through a
/// snatch load, relative to the run's peak connection tension (`true`): the
/// towing-point tension falls to about 15 N between the jerks, where a 1.7 N
/// difference (measured at 0.10 rad/s) is 6 % of it but 0.4 % of the peak.
const SNATCH_TOLERANCES: (f64, f64, bool) = (2e-2, 2e-2, true);
/// The same for the recorded flight (a pull-up into a climbing turn): measured
/// 1.27 % of the peak at the connection and 1.29 % at the towing point (6.3 N
/// and 6.4 N at the cable's jerk at about 5.8 s). Both runs are deterministic,
/// so these are exact numbers, not a noise band. With the earlier embedded model
/// (16 graded 1.3, its snatch integrated at the wave-speed stability limit, the
/// step counts of f32 and f64 parting at the jerk) the bound had to be 22 %.
const RECORDED_TOLERANCES: (f64, f64, bool) = (2e-2, 2e-2, true);

/// Instructions a whole nominal 10 ms frame (four RK4 steps of 2.5 ms, the frame's
/// validation, flight path and outputs with the clearances) may execute, M4: a
/// guard just above the measurement (max 99,520, in the pull-up at 0.20 rad/s;
/// the STM32F405 reads 99,595; the test prints it), so that a regression fails;
/// lower it as the controller gets faster.
const FRAME_BUDGET: u32 = 99_900;
/// The same guard for the M7 profile (f64 in hardware): measured at most 160,080.
const FRAME_BUDGET_M7: u32 = 160_500;
/// The firmware issue's target per control step, for the solver's share
/// (`step_instructions`) of a nominal step; measured 87,600 to 88,840 on the M4.
const CONTROL_STEP_TARGET: u32 = 100_000;
/// Most instructions of decoy management (monitors and one look-ahead slice)
/// per 10 ms frame on the M4 (issue 13: at most 400,000 of prediction per frame).
const MANAGEMENT_BUDGET: u32 = 400_000;
/// The benchmark issue's target per RK4 step (f32, M4), for the RK4 steps of a
/// nominal control step (`step_instructions / 4`; the first stage of a frame
/// reuses the previous frame's output evaluation, `Solver::step`); measured at
/// most 22,210. (`tests/step_cost.rs` checks a step that evaluates all four
/// stages.)
const RK4_STEP_TARGET: u32 = 40_000;
/// The goal per control step.
const CONTROL_STEP_GOAL: u32 = 40_000;
/// Issue 14's target for every frame of every shipped manoeuvre, the snatch
/// loads included, asserted on the costliest one of each scenario (met: 99,520
/// at most on the M4; each scenario is also held to a guard just above its
/// measurement, [`WorstFrame`]).
const WORST_FRAME_TARGET: u32 = 100_000;

/// The guard on the costliest frame of a scenario over ALL its frames (M4 and
/// STM32F405, whole frames: validation, every RK4 step the stepping rule took,
/// retries included, outputs): about 400 above the measurement when this was
/// written and never above issue 14's [`WORST_FRAME_TARGET`] (`cargo decoy hil
/// --scenario NAME --json`, `instructions_per_step_max`, and this test's output,
/// M4: steady 98,240, acceleration 98,440, pull-ups 99,160, 99,200 and 99,520,
/// turns 98,840 and 99,000, recorded flight 99,400; the STM32F405 within 100 of
/// them). Every frame takes the nominal
/// four RK4 steps: the embedded model's 1.73 m shortest segment keeps the
/// wave-speed limit above them in every shipped manoeuvre, snatches included,
/// so the worst frame is the mean frame plus about 1 % (firmware/README.md,
/// "The worst frame and the accuracy"). Before issue 14's model change the
/// limit on the 0.46 m segment took up to 14 steps (677,080 at 0.20 rad/s).
#[derive(Clone, Copy, Debug)]
struct WorstFrame(u32);

/// The boards of the f32 controller, each with the whole f32 suite.
const F32_BOARDS: [Board; 2] = [Board::M4, Board::Stm32f405];

/// The firmware ELF of `board`, built once per test binary. Checks `defmt-print`
/// first.
fn elf(board: Board) -> &'static PathBuf {
    static ELFS: [OnceLock<PathBuf>; Board::ALL.len()] = [const { OnceLock::new() }; 3];
    let index = Board::ALL
        .iter()
        .position(|&b| b == board)
        .unwrap_or_else(|| unreachable!("Board::ALL lists every board"));
    ELFS[index].get_or_init(|| {
        defmt::require().unwrap_or_else(|e| panic!("{e}"));
        let started = Instant::now();
        let elf = firmware::build_board(board, BUILD_TIMEOUT).unwrap_or_else(|e| panic!("{e}"));
        let memory = firmware::memory_usage(&elf).unwrap_or_else(|e| panic!("{e}"));
        println!(
            "{board} firmware built in {:.1} s: {}; {memory}",
            started.elapsed().as_secs_f64(),
            elf.display()
        );
        elf
    })
}

/// A fresh firmware session on `board`, whose Hello must name the board and its
/// core clock.
fn session(board: Board) -> Session {
    let s = Session::start(elf(board), board).unwrap_or_else(|e| panic!("{e}"));
    let info = board.info();
    assert_eq!(s.hello.board, info.name, "{board}: Hello's board name");
    assert_eq!(
        s.hello.core_clock_hz, info.core_clock_hz,
        "{board}: Hello's core clock"
    );
    s
}

fn config() -> &'static SystemConfig {
    static CONFIG: OnceLock<SystemConfig> = OnceLock::new();
    CONFIG.get_or_init(|| SystemConfig::builtin().expect("the built-in configuration"))
}

/// The host reference in f32: the firmware's controller in this process, with the
/// maths every build uses (libm).
fn host32() -> Reference {
    Reference::for_config(config(), 32).unwrap_or_else(|e| panic!("{e}"))
}

/// The frames of a shipped scenario (optionally at another rate) for `t_end` s, as
/// `decoy simulate` would fly it with the embedded layout.
fn frames(name: &str, rate: Option<f64>, t_end: f64) -> Vec<AircraftStateFrame> {
    let config = config();
    let plan = Scenario::builtin(name)
        .and_then(|s| {
            s.plan(
                config,
                &RunOptions {
                    segments: Some(config.solver.segments_embedded),
                    grading: Some(config.solver.grading_ratio_embedded),
                    rate,
                    t_end: Some(t_end),
                    plots: false,
                    ..RunOptions::default()
                },
            )
        })
        .unwrap_or_else(|e| panic!("{e}"));
    flight::scenario_frames(&plan.profile, flight::frame_count(t_end))
}

/// Flies `frames` (after ResetToTrim) on a fresh session on `board`; returns the
/// exchanges, the bytes received after Hello, the round trips per second and the
/// firmware's log.
fn fly(board: Board, frames: &[AircraftStateFrame]) -> (Vec<Exchange>, Vec<u8>, f64, String) {
    let mut s = session(board);
    let boot_bytes = s.link.received().len();
    let flown = flight::fly(&mut s, &flight::scenario_messages(frames), |_| {})
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(s.device_running(), "QEMU exited during the run");
    let received = s.link.received()[boot_bytes..].to_vec();
    let fps = flown.frames_per_second();
    let log = s.finish();
    assert!(log.was_running, "QEMU exited during the run");
    (flown.exchanges, received, fps, log.log)
}

/// Flies a scenario and checks it against the host in f32 and f64 and the
/// instruction budget. `outputs_at_least`: outputs the run must give (the frames
/// before the step rule diverges).
fn check_scenario(
    board: Board,
    label: &str,
    frames: &[AircraftStateFrame],
    outputs_at_least: usize,
    worst: WorstFrame,
) {
    check_scenario_within(
        board,
        label,
        frames,
        outputs_at_least,
        (F64_CONNECTION_TOLERANCE, F64_TOW_TOLERANCE, false),
        worst,
    );
}

/// [`check_scenario`] with the (connection, towing-point) tolerances against f64.
fn check_scenario_within(
    board: Board,
    label: &str,
    frames: &[AircraftStateFrame],
    outputs_at_least: usize,
    (connection_tolerance, tow_tolerance, against_peak): (f64, f64, bool),
    worst: WorstFrame,
) {
    let label = &format!("{board}: {label}");
    let (exchanges, _, fps, log) = fly(board, frames);
    let sent: Vec<HostMessage> = exchanges.iter().map(|e| e.sent).collect();
    let answers: Vec<DeviceMessage> = exchanges.iter().map(|e| e.answer).collect();
    assert!(
        matches!(answers[0], DeviceMessage::Status(_)),
        "{label}: ResetToTrim answered by {:?}",
        answers[0]
    );

    let host32 = host32().replay(&sent).unwrap_or_else(|e| panic!("{e}"));
    let (agreement, mismatches) = flight::compare(&answers, &host32);
    assert!(
        mismatches.is_empty(),
        "{label}: {} answers differ from the host controller's (f32); first: {:#?}",
        mismatches.len(),
        mismatches[0]
    );
    assert!(
        agreement.outputs >= outputs_at_least,
        "{label}: {} outputs, expected at least {outputs_at_least}",
        agreement.outputs
    );
    assert!(
        agreement.max_relative_tension <= F32_RELATIVE_TOLERANCE,
        "{label}: tensions differ from the host's f32 by up to {:.3e} relative ({} of {} outputs identical)",
        agreement.max_relative_tension,
        agreement.identical,
        agreement.outputs
    );
    assert_eq!(
        agreement.identical, agreement.outputs,
        "{label}: outputs not bit-identical to the host's f32 ones: {agreement:?}"
    );

    let mut controller64 =
        flight::host_controller::<f64>(config()).unwrap_or_else(|e| panic!("{e}"));
    let host64 = flight::replay(&mut controller64, &sent);
    let firmware_outputs = flight::outputs(&answers);
    let host_outputs = flight::outputs(&host64);
    // Worst relative difference (and its absolute value, seq) of the connection
    // and of the towing-point tension: relative to the host's value, or with
    // `against_peak` to the run's peak connection tension.
    let peak = host_outputs
        .iter()
        .map(|h| f64::from(h.connection_tension_n))
        .fold(0.0, f64::max);
    let mut worst64 = [(0.0f64, 0.0f64, 0u32); 2];
    for out in &firmware_outputs {
        let Some(h) = host_outputs.iter().find(|h| h.seq == out.seq) else {
            continue;
        };
        for (worst, (a, b)) in worst64.iter_mut().zip([
            (out.connection_tension_n, h.connection_tension_n),
            (out.tow_tension_n, h.tow_tension_n),
        ]) {
            let diff = (f64::from(a) - f64::from(b)).abs();
            let relative = diff
                / if against_peak {
                    peak
                } else {
                    f64::from(b).abs()
                };
            if relative > worst.0 {
                *worst = (relative, diff, out.seq);
            }
        }
    }
    for ((relative, diff, seq), (what, tolerance)) in worst64.iter().zip([
        ("connection", connection_tolerance),
        ("towing-point", tow_tolerance),
    ]) {
        assert!(
            *relative <= tolerance,
            "{label}: the {what} tension differs from the host's f64 by {:.3} % ({diff:.3} N at seq {seq})",
            relative * 100.0,
        );
    }
    let stats = flight::instruction_stats(&answers);
    println!(
        "{label}: {} frames at {fps:.0} frames/s; {} outputs bit-identical to the host f32; \
         vs host f64: connection tension max {:.3} % ({:.3} N), towing point {:.3} % ({:.3} N); \
         solver instructions per nominal control step max {} (target {CONTROL_STEP_TARGET}, \
         goal {CONTROL_STEP_GOAL}), per RK4 step max {}; whole frames max {} (seq {}), mean {:.0}; \
         {} of {} control steps nominal, at most {} RK4 steps",
        exchanges.len(),
        agreement.identical,
        worst64[0].0 * 100.0,
        worst64[0].1,
        worst64[1].0 * 100.0,
        worst64[1].1,
        stats.nominal_solver_max,
        stats.per_rk4_step_max,
        stats.max,
        stats.max_seq,
        stats.mean,
        stats.nominal_steps,
        stats.steps,
        stats.most_rk4_steps,
    );
    println!(
        "{label}: nominal frames max {}",
        nominal_frame_max(&answers)
    );
    check_budget(label, &answers, FRAME_BUDGET);
    check_worst_frame(label, &answers, worst);
    if board == Board::Stm32f405 {
        check_advisory_log(label, &answers, &log);
    }
}

/// The advisory line's changes the firmware logged (`advisory line asserted:
/// seq=N ...` or `deasserted`), as (seq, asserted), must be exactly the outputs at
/// which the management report's advisory line (a monitor at warning or worse, or
/// a look-ahead advisory: `Management::advisory_line`) goes from clear to set or
/// back (the line starts low).
fn check_advisory_log(label: &str, answers: &[DeviceMessage], log: &str) {
    let logged: Vec<(u32, bool)> = log
        .lines()
        .filter_map(|line| {
            let (_, rest) = line.split_once("advisory line ")?;
            let (level, rest) = rest.split_once(": seq=")?;
            let seq = rest.split_whitespace().next()?.parse().ok()?;
            Some((seq, level == "asserted"))
        })
        .collect();
    let mut expected = Vec::new();
    let mut asserted = false;
    for out in flight::outputs(answers) {
        let line = out.management.advisory_line();
        if line != asserted {
            expected.push((out.seq, line));
            asserted = line;
        }
    }
    assert_eq!(
        logged, expected,
        "{label}: the advisory line's logged changes (seq, asserted) differ from the management reports' changes"
    );
    println!(
        "{label}: advisory line changes {logged:?} (seq, asserted), as the management reports"
    );
}

/// The most instructions a whole nominal frame took.
fn nominal_frame_max(answers: &[DeviceMessage]) -> u32 {
    flight::outputs(answers)
        .into_iter()
        .filter(|out| out.steps == flight::NOMINAL_RK4_STEPS)
        .map(|out| out.instructions)
        .max()
        .unwrap_or(0)
}

/// The instruction budgets of a run (see the module's documentation).
fn check_budget(label: &str, answers: &[DeviceMessage], frame_budget: u32) {
    let stats = flight::instruction_stats(answers);
    assert!(stats.nominal_steps > 0, "{label}: no nominal control step");
    // Decoy management (the monitors and the look-ahead's slice, after the
    // solution) within its budget on every frame, whatever the manoeuvre; and it
    // does run (a slice of look-ahead steps on every frame after the trim).
    let outputs = flight::outputs(answers);
    let worst = outputs
        .iter()
        .max_by_key(|o| o.management_instructions)
        .map(|o| (o.management_instructions, o.seq, o.prediction_steps))
        .unwrap_or_default();
    println!(
        "{label}: decoy management at most {} instructions per frame (seq {}, {} look-ahead steps), budget {MANAGEMENT_BUDGET}",
        worst.0, worst.1, worst.2
    );
    assert!(
        worst.0 <= MANAGEMENT_BUDGET,
        "{label}: decoy management took {} instructions at seq {}, over {MANAGEMENT_BUDGET}",
        worst.0,
        worst.1
    );
    assert!(
        outputs
            .iter()
            .skip(1)
            .all(|o| o.prediction_steps > 0 || o.management_instructions == 0),
        "{label}: a frame ran no look-ahead step"
    );
    assert!(
        stats.nominal_solver_max <= CONTROL_STEP_TARGET,
        "{label}: the solver took {} instructions in a nominal control step, over {CONTROL_STEP_TARGET}",
        stats.nominal_solver_max
    );
    for out in flight::outputs(answers) {
        if out.steps == flight::NOMINAL_RK4_STEPS {
            let per_step = out.step_instructions / u32::from(out.steps);
            assert!(
                per_step <= RK4_STEP_TARGET,
                "{label}: nominal frame seq {} took {per_step} instructions per RK4 step, over {RK4_STEP_TARGET}",
                out.seq,
            );
            assert!(
                out.instructions <= frame_budget,
                "{label}: nominal frame seq {} took {} instructions, over the guard of {frame_budget}",
                out.seq,
                out.instructions
            );
        }
    }
}

/// The costliest frame of a run, over every frame (not only the nominal ones),
/// against its guard; printed against [`WORST_FRAME_TARGET`].
fn check_worst_frame(label: &str, answers: &[DeviceMessage], WorstFrame(guard): WorstFrame) {
    let stats = flight::instruction_stats(answers);
    let verdict = if stats.max <= WORST_FRAME_TARGET {
        "met"
    } else {
        "NOT met"
    };
    println!(
        "{label}: worst frame over all {} frames {} instructions (seq {}, at most {} RK4 steps), \
         mean {:.0}; issue 14's target {WORST_FRAME_TARGET}: {verdict}",
        stats.steps, stats.max, stats.max_seq, stats.most_rk4_steps, stats.mean
    );
    assert!(
        stats.max <= WORST_FRAME_TARGET,
        "{label}: frame seq {} took {} instructions, over issue 14's target of {WORST_FRAME_TARGET}",
        stats.max_seq,
        stats.max
    );
    assert!(
        stats.max <= guard,
        "{label}: frame seq {} took {} instructions, over the worst-frame guard of {guard}",
        stats.max_seq,
        stats.max
    );
}

fn steady_matches_the_host_and_fits_the_budget(board: Board) {
    let frames = frames("steady", None, 10.0);
    let count = frames.len();
    check_scenario(board, "steady (10 s)", &frames, count, WorstFrame(98_700));
}

fn acceleration_matches_the_host_and_fits_the_budget(board: Board) {
    check_scenario(
        board,
        "acceleration (10 s)",
        &frames("acceleration", None, 10.0),
        1001,
        WorstFrame(98_900),
    );
}

fn pull_ups_match_the_host_and_fit_the_budget(board: Board) {
    for (rate, t_end, worst) in [
        (0.05, 10.0, 99_600),
        (0.10, 10.0, 99_700),
        (0.20, 10.0, 99_900),
    ] {
        let frames = frames("pull-up", Some(rate), t_end);
        let count = frames.len();
        check_scenario_within(
            board,
            &format!("pull-up {rate} rad/s ({t_end} s)"),
            &frames,
            count,
            SNATCH_TOLERANCES,
            WorstFrame(worst),
        );
    }
}

fn turns_match_the_host_and_fit_the_budget(board: Board) {
    for (rate, worst) in [(0.10, 99_300), (0.20, 99_500)] {
        let frames = frames("turn", Some(rate), 5.0);
        let count = frames.len();
        check_scenario(
            board,
            &format!("turn {rate} rad/s (5 s)"),
            &frames,
            count,
            WorstFrame(worst),
        );
    }
}

fn recorded_flight_matches_the_host_and_fits_the_budget(board: Board) {
    let frames = frames("recorded", None, 10.0);
    let count = frames.len();
    check_scenario_within(
        board,
        "recorded flight (10 s)",
        &frames,
        count,
        RECORDED_TOLERANCES,
        WorstFrame(99_900),
    );
}

/// The M7 profile (Cortex-M7, f64 in hardware, `mps2-an500`): the same answers as
/// the host reference in f64 with the target's maths, bit for bit.
#[test]
fn m7_profile_matches_the_host_in_f64() {
    defmt::require().unwrap_or_else(|e| panic!("{e}"));
    let elf = firmware::build_board(Board::M7, BUILD_TIMEOUT).unwrap_or_else(|e| panic!("{e}"));
    let mut s = Session::start(&elf, Board::M7).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.hello.board, Board::M7.info().name);
    assert_eq!(s.hello.core_clock_hz, 25_000_000);
    assert_eq!(s.hello.precision_bits, 64);
    let messages = flight::scenario_messages(&frames("acceleration", None, 3.0));
    let flown = flight::fly(&mut s, &messages, |_| {}).unwrap_or_else(|e| panic!("{e}"));
    assert!(s.device_running());
    let answers = flown.answers();
    let mut reference = Reference::for_config(config(), 64).unwrap_or_else(|e| panic!("{e}"));
    let host = reference
        .replay(&messages)
        .unwrap_or_else(|e| panic!("{e}"));
    let (agreement, mismatches) = flight::compare(&answers, &host);
    assert!(mismatches.is_empty(), "{:#?}", mismatches[0]);
    assert_eq!(agreement.outputs, messages.len() - 1);
    assert_eq!(
        agreement.identical, agreement.outputs,
        "M7 outputs not bit-identical to the host's f64 ones: {agreement:?}"
    );
    let stats = flight::instruction_stats(&answers);
    println!(
        "M7 (f64) acceleration 3 s: {} outputs bit-identical to the host f64 reference; \
         whole frames max {}, mean {:.0}; nominal frames max {}; solver per nominal control \
         step max {}; {:.0} frames/s",
        agreement.identical,
        stats.max,
        stats.mean,
        nominal_frame_max(&answers),
        stats.nominal_solver_max,
        flown.frames_per_second()
    );
    for out in flight::outputs(&answers) {
        if out.steps == flight::NOMINAL_RK4_STEPS {
            assert!(
                out.instructions <= FRAME_BUDGET_M7,
                "M7: nominal frame seq {} took {} instructions, over {FRAME_BUDGET_M7}",
                out.seq,
                out.instructions
            );
        }
    }
}

/// Memory at every moment fits the board: static RAM (`.data` + `.bss`) plus the
/// deepest stack, at boot (building the controller) or in the link loop (the
/// trim and 300 frames of the acceleration), at most the board's RAM
/// ([`Board::ram_budget`]); the controller, built in place in its `static`, lies
/// in `.bss` and never on the stack: the boot's stack is smaller than the
/// controller (a copy of it on the stack would make it larger).
fn ram_peak_fits_the_board(board: Board) {
    let memory = firmware::memory_usage(elf(board)).unwrap_or_else(|e| panic!("{e}"));
    let (exchanges, _, _, log) = fly(board, &frames("acceleration", None, 3.0));
    let answers: Vec<DeviceMessage> = exchanges.iter().map(|e| e.answer).collect();
    assert_eq!(flight::outputs(&answers).len(), 301, "{board}: outputs");
    let marks = firmware::stack_marks(&log).unwrap_or_else(|e| panic!("{board}: {e}"));
    let link = marks.link.unwrap_or_else(|| {
        panic!("{board}: no stack high-water reported in the link loop:\n{log}")
    });
    let peak = memory.ram() + marks.peak();
    let budget = board.ram_budget();
    println!(
        "{board}: {memory}; controller {} B; stack: boot {} B, link loop {link} B; \
         RAM peak {peak} B of {budget} B ({:.0} %)",
        marks.controller,
        marks.boot,
        100.0 * peak as f64 / budget as f64
    );
    assert!(
        peak <= budget,
        "{board}: RAM peak {peak} B (static {} B + stack {} B) over the board's {budget} B",
        memory.ram(),
        marks.peak()
    );
    assert!(
        memory.bss >= marks.controller,
        "{board}: the controller ({} B) is not in .bss ({} B): its `static` has an initial value (flash and a copy at boot)",
        marks.controller,
        memory.bss
    );
    assert!(
        marks.boot < marks.controller,
        "{board}: the boot's stack ({} B) is as large as the controller ({} B): it was built on the stack",
        marks.boot,
        marks.controller
    );
}

/// [`ram_peak_fits_the_board`] on the M7 (f64: the largest controller, 64 KiB).
#[test]
fn m7_ram_peak_fits_the_board() {
    ram_peak_fits_the_board(Board::M7);
}

fn two_runs_receive_identical_bytes(board: Board) {
    let frames = frames("acceleration", None, 3.0);
    let (first, bytes_a, _, _) = fly(board, &frames);
    let (second, bytes_b, _, _) = fly(board, &frames);
    assert_eq!(first.len(), frames.len() + 1);
    assert!(!bytes_a.is_empty());
    assert_eq!(
        bytes_a.len(),
        bytes_b.len(),
        "the two runs received streams of different lengths"
    );
    for (a, b) in first.iter().zip(&second) {
        assert_eq!(a.answer, b.answer, "the two runs answered differently");
    }
    assert!(bytes_a == bytes_b, "the two runs' byte streams differ");
    println!(
        "{board}: two runs: {} bytes received each, byte-identical",
        bytes_a.len()
    );
}

/// A firmware session with two host controllers beside it: `mirror` gets every
/// byte the firmware gets (and must answer alike), `undisturbed` only the valid
/// frames (the firmware's outputs must equal its outputs: state kept).
struct Probe {
    session: Session,
    mirror: Reference,
    undisturbed: Reference,
    frames: Vec<AircraftStateFrame>,
    next: usize,
}

impl Probe {
    /// A session on `board` trimmed on the acceleration scenario and flown
    /// `warm_up` frames.
    fn new(board: Board, warm_up: usize) -> Self {
        let mut probe = Probe {
            session: session(board),
            mirror: host32(),
            undisturbed: host32(),
            frames: frames("acceleration", None, 4.0),
            next: 0,
        };
        let reset = HostMessage::Command(Command::ResetToTrim);
        let answers = probe.raw(&encode(&reset));
        assert!(
            matches!(answers[..], [DeviceMessage::Status(_)]),
            "{answers:?}"
        );
        probe.undisturbed(&reset);
        probe.valid(warm_up);
        probe
    }

    /// Sends raw bytes; returns the firmware's answers, which must equal the
    /// mirror's for the same bytes (but for `instructions`).
    fn raw(&mut self, bytes: &[u8]) -> Vec<DeviceMessage> {
        let expected = self.mirror.feed(bytes);
        self.session
            .link
            .send_raw(bytes)
            .unwrap_or_else(|e| panic!("{e}"));
        let got: Vec<DeviceMessage> = expected
            .iter()
            .map(|_| self.session.link.recv().unwrap_or_else(|e| panic!("{e}")))
            .collect();
        assert!(
            !self
                .session
                .link
                .poll(Duration::from_millis(20))
                .unwrap_or_else(|e| panic!("{e}")),
            "the firmware answered more than the host controller"
        );
        for (g, e) in got.iter().zip(&expected) {
            assert_eq!(
                &without_instructions(*g),
                &without_instructions(*e),
                "the firmware's answer differs from the host controller's"
            );
        }
        got
    }

    /// Sends the next `n` valid frames; each must be answered by an Output equal
    /// to the undisturbed run's (but for RECOVERED and `instructions`).
    fn valid(&mut self, n: usize) -> Vec<OutputFrame> {
        (0..n)
            .map(|_| {
                let frame = self.frames[self.next];
                self.next += 1;
                let message = HostMessage::State(frame);
                let answers = self.raw(&encode(&message));
                let undisturbed = self.undisturbed(&message);
                let [DeviceMessage::Output(out)] = answers[..] else {
                    panic!("frame {} answered by {answers:?}", frame.seq);
                };
                let DeviceMessage::Output(reference) = undisturbed else {
                    panic!(
                        "the undisturbed host run rejected frame {}: {undisturbed:?}",
                        frame.seq
                    );
                };
                let mut masked = out;
                masked.instructions = 0;
                masked.step_instructions = 0;
                masked.management_instructions = 0;
                masked.flags &= !StatusFlags::RECOVERED;
                assert_eq!(
                    masked, reference,
                    "frame {}: the output differs from an undisturbed run's",
                    frame.seq
                );
                out
            })
            .collect()
    }

    /// The next valid frame, changed by `change`, which must be rejected with
    /// `reason` as the `count`-th such rejection.
    fn invalid(
        &mut self,
        reason: RejectReason,
        count: u32,
        change: impl FnOnce(&mut AircraftStateFrame),
    ) {
        let mut frame = self.frames[self.next];
        change(&mut frame);
        let answers = self.raw(&encode(&HostMessage::State(frame)));
        match answers[..] {
            [DeviceMessage::Rejected(r)] => {
                assert_eq!(r.reason, reason, "{frame:?}");
                assert_eq!(r.count, count, "{reason:?} counter");
                assert_eq!(r.seq, Some(frame.seq));
            }
            _ => panic!("{reason:?} expected, got {answers:?} for {frame:?}"),
        }
    }

    /// Bytes that must be rejected as undecodable with `reason`, the
    /// `count`-th time.
    fn malformed(&mut self, bytes: &[u8], reason: RejectReason, count: u32) {
        let answers = self.raw(bytes);
        match answers[..] {
            [DeviceMessage::Rejected(r)] => {
                assert_eq!((r.seq, r.reason, r.count), (None, reason, count));
            }
            _ => panic!("{reason:?} expected, got {answers:?}"),
        }
    }

    /// The firmware's status now (which the mirror must give too).
    fn status(&mut self) -> decoy_link::StatusFrame {
        let answers = self.raw(&encode(&HostMessage::Command(Command::GetStatus)));
        match answers[..] {
            [DeviceMessage::Status(s)] => s,
            _ => panic!("Status expected, got {answers:?}"),
        }
    }

    /// The undisturbed run's answer to `message`.
    fn undisturbed(&mut self, message: &HostMessage) -> DeviceMessage {
        self.undisturbed
            .handle(message)
            .unwrap_or_else(|e| panic!("{e}"))
    }

    /// Checks QEMU runs, then ends the session.
    fn finish(mut self) {
        assert!(self.session.device_running(), "QEMU is not running");
        let log = self.session.finish();
        assert!(log.was_running, "QEMU exited");
    }
}

fn encode(message: &HostMessage) -> Vec<u8> {
    decoy_hil::link::encode(message).unwrap_or_else(|e| panic!("{e}"))
}

/// The index of a COBS data byte (not a code byte, not a delimiter) in the middle
/// of a wire frame.
fn cobs_data_byte(wire: &[u8]) -> usize {
    let mut codes = Vec::new();
    let mut at = 1;
    while at < wire.len() - 1 {
        codes.push(at);
        at += usize::from(wire[at]);
    }
    (wire.len() / 2..wire.len() - 1)
        .find(|i| !codes.contains(i))
        .unwrap_or_else(|| panic!("no data byte in {wire:?}"))
}

fn without_instructions(mut m: DeviceMessage) -> DeviceMessage {
    if let DeviceMessage::Output(o) = &mut m {
        o.instructions = 0;
        o.step_instructions = 0;
        o.management_instructions = 0;
    }
    m
}

fn malformed_frames_are_rejected_and_the_state_is_kept(board: Board) {
    let mut p = Probe::new(board, 20);
    let next = HostMessage::State(p.frames[p.next]);
    let good = encode(&next);

    // A corrupted CRC: one data byte changed, the COBS structure intact.
    let mut corrupted = good.clone();
    let i = cobs_data_byte(&corrupted);
    corrupted[i] = if corrupted[i] == 1 {
        2
    } else {
        corrupted[i] ^ 1
    };
    p.malformed(&corrupted, RejectReason::Crc, 1);
    p.valid(1);

    // Shorter than the CRC: one COBS group of two bytes.
    p.malformed(&[0x00, 0x03, 0x01, 0x02, 0x00], RejectReason::Truncated, 1);
    p.valid(1);

    // A frame cut short: its first half, ended by a 0x00 (normally the next
    // frame's leading one).
    let mut cut = encode(&HostMessage::State(p.frames[p.next]))[..good.len() / 2].to_vec();
    cut.push(0x00);
    let answers = p.raw(&cut);
    assert!(
        matches!(answers[..], [DeviceMessage::Rejected(r)] if r.seq.is_none()
            && matches!(r.reason, RejectReason::Cobs | RejectReason::Crc | RejectReason::Truncated)),
        "{answers:?}"
    );
    p.valid(1);
    let counters = p.status().counters;
    assert_eq!(
        counters.crc + counters.cobs + counters.truncated,
        3,
        "the cut frame counts once: {counters:?}"
    );

    // Garbage between frames (no 0x00 in it): one undecodable chunk, then the
    // frame is decoded as usual.
    let garbage: Vec<u8> = (1..=40u8).map(|b| b.wrapping_mul(37) | 1).collect();
    let before = p.status().counters;
    let answers = p.raw(&garbage);
    assert!(answers.is_empty());
    let next = HostMessage::State(p.frames[p.next]);
    let answers = p.raw(&encode(&next));
    assert!(
        matches!(answers[..], [DeviceMessage::Rejected(r), DeviceMessage::Output(_)] if r.seq.is_none()),
        "{answers:?}"
    );
    p.next += 1;
    p.undisturbed(&next);
    let after = p.status().counters;
    assert_eq!(
        (after.cobs + after.crc + after.truncated + after.decode)
            - (before.cobs + before.crc + before.truncated + before.decode),
        1
    );
    p.valid(2);

    // Oversize: 300 bytes without a delimiter.
    let mut oversize = vec![0x00];
    oversize.extend(std::iter::repeat_n(0x42, 300));
    oversize.push(0x00);
    p.malformed(&oversize, RejectReason::Oversize, 1);
    p.valid(1);

    // A well-formed frame of something that is not a host message.
    let not_a_message =
        decoy_link::encode_vec(&(7u8, 1.5f64, [3u32; 9])).unwrap_or_else(|e| panic!("{e}"));
    p.malformed(&not_a_message, RejectReason::Decode, 1);
    p.valid(5);
    let status = p.status();
    assert_eq!(status.counters.oversize, 1);
    assert_eq!(status.counters.decode, 1);
    p.finish();
}

fn invalid_values_are_rejected_with_their_reason(board: Board) {
    let mut p = Probe::new(board, 10);
    p.invalid(RejectReason::NonFinite, 1, |f| {
        f.velocity_ned_mps[0] = f32::NAN
    });
    p.valid(1);
    p.invalid(RejectReason::NonFinite, 2, |f| {
        f.position_ned_m[2] = f64::INFINITY
    });
    p.invalid(RejectReason::NonFinite, 3, |f| f.time_s = f64::NAN);
    p.invalid(RejectReason::NonFinite, 4, |f| {
        f.body_angular_acceleration_radps2[1] = f32::NEG_INFINITY
    });
    p.valid(1);
    // Mach above 2 at 9 km (speed of sound about 303 m/s).
    p.invalid(RejectReason::OutOfRange, 1, |f| {
        f.velocity_ned_mps = [700.0, 0.0, 0.0]
    });
    // Above and below the atmosphere model (-500 m to 20 km).
    p.invalid(RejectReason::OutOfRange, 2, |f| {
        f.position_ned_m[2] = -25_000.0
    });
    p.invalid(RejectReason::OutOfRange, 3, |f| {
        f.position_ned_m[2] = 1_000.0
    });
    // No airspeed: zero dynamic pressure.
    p.invalid(RejectReason::OutOfRange, 4, |f| {
        f.velocity_ned_mps = [0.0; 3]
    });
    p.valid(1);
    p.invalid(RejectReason::BadQuaternion, 1, |f| {
        f.attitude_wxyz = [1.1, 0.0, 0.0, 0.0]
    });
    p.invalid(RejectReason::BadQuaternion, 2, |f| {
        f.attitude_wxyz = [0.0; 4]
    });
    p.valid(3);
    let status = p.status();
    assert_eq!(status.counters.non_finite, 4);
    assert_eq!(status.counters.out_of_range, 4);
    assert_eq!(status.counters.bad_quaternion, 2);
    assert_ne!(status.flags & StatusFlags::TRIMMED, 0);
    p.finish();
}

fn time_going_backwards_or_jumping_is_rejected(board: Board) {
    let mut p = Probe::new(board, 10);
    let last = p.frames[p.next - 1];
    p.invalid(RejectReason::TimeNotIncreasing, 1, |f| {
        f.time_s = last.time_s
    });
    p.invalid(RejectReason::TimeNotIncreasing, 2, |f| {
        f.time_s = last.time_s - 0.05
    });
    p.valid(1);
    p.invalid(RejectReason::TimeJump, 1, |f| f.time_s += 0.5);
    p.invalid(RejectReason::TimeJump, 2, |f| f.time_s += 1e6);
    p.valid(2);
    let status = p.status();
    assert_eq!(status.counters.time_not_increasing, 2);
    assert_eq!(status.counters.time_jump, 2);
    p.finish();
}

fn link_silence_degrades_and_recovers(board: Board) {
    let mut p = Probe::new(board, 10);
    // Silence: SILENCE_MS = 200 ms of virtual time (200 M instructions under
    // -icount), 1 to 4 s of wall-clock time on the M4 and 3 to 10 s on the
    // STM32F405 here (QEMU runs its idle loop more slowly), so the deadline is
    // generous; the firmware sends one Status frame with DEGRADED.
    let silent = Instant::now();
    let status = p
        .session
        .link
        .recv_within(Duration::from_secs(60), "the silence Status")
        .unwrap_or_else(|e| panic!("{e}"));
    let waited = silent.elapsed();
    let DeviceMessage::Status(status) = status else {
        panic!("Status expected after the silence, got {status:?}");
    };
    assert_ne!(status.flags & StatusFlags::DEGRADED, 0, "{status:?}");
    assert_eq!(status.counters.silences, 1);
    // Only one Status however long the silence lasts.
    assert!(
        !p.session
            .link
            .poll(Duration::from_secs(2))
            .unwrap_or_else(|e| panic!("{e}")),
        "more than one Status for one silence"
    );
    // The host mirror sees the same silence (its clock is polled by hand).
    let mut poll = |ms| p.mirror.poll_silence(ms);
    assert!(poll(0).is_none());
    let mirrored = poll(decoy_controller::SILENCE_MS);
    assert_eq!(mirrored, Some(DeviceMessage::Status(status)));

    // Resume: the next frame is answered as in an undisturbed run, with RECOVERED.
    let outputs = p.valid(3);
    assert_ne!(
        outputs[0].flags & StatusFlags::RECOVERED,
        0,
        "{:?}",
        outputs[0]
    );
    assert_eq!(outputs[1].flags & StatusFlags::RECOVERED, 0);
    let status = p.status();
    assert_eq!(status.flags & StatusFlags::DEGRADED, 0);
    assert_eq!(status.counters.silences, 1);
    println!(
        "{board}: silence: the DEGRADED status came {:.2} s (wall clock) after the last frame",
        waited.as_secs_f64()
    );
    p.finish();
}

/// The f32 suite, once per board of [`F32_BOARDS`]: a module per board whose tests
/// call the functions above with it.
macro_rules! f32_suite {
    ($($module:ident => $board:expr),* $(,)?) => {$(
        mod $module {
            use super::*;

            /// The board of this module's tests.
            const BOARD: Board = $board;

            #[test]
            fn steady_matches_the_host_and_fits_the_budget() {
                super::steady_matches_the_host_and_fits_the_budget(BOARD);
            }

            #[test]
            fn recorded_flight_matches_the_host_and_fits_the_budget() {
                super::recorded_flight_matches_the_host_and_fits_the_budget(BOARD);
            }

            #[test]
            fn acceleration_matches_the_host_and_fits_the_budget() {
                super::acceleration_matches_the_host_and_fits_the_budget(BOARD);
            }

            #[test]
            fn pull_ups_match_the_host_and_fit_the_budget() {
                super::pull_ups_match_the_host_and_fit_the_budget(BOARD);
            }

            #[test]
            fn turns_match_the_host_and_fit_the_budget() {
                super::turns_match_the_host_and_fit_the_budget(BOARD);
            }

            #[test]
            fn ram_peak_fits_the_board() {
                super::ram_peak_fits_the_board(BOARD);
            }

            #[test]
            fn two_runs_receive_identical_bytes() {
                super::two_runs_receive_identical_bytes(BOARD);
            }

            #[test]
            fn malformed_frames_are_rejected_and_the_state_is_kept() {
                super::malformed_frames_are_rejected_and_the_state_is_kept(BOARD);
            }

            #[test]
            fn invalid_values_are_rejected_with_their_reason() {
                super::invalid_values_are_rejected_with_their_reason(BOARD);
            }

            #[test]
            fn time_going_backwards_or_jumping_is_rejected() {
                super::time_going_backwards_or_jumping_is_rejected(BOARD);
            }

            #[test]
            fn link_silence_degrades_and_recovers() {
                super::link_silence_degrades_and_recovers(BOARD);
            }
        }
    )*};
}

f32_suite! {
    m4 => F32_BOARDS[0],
    stm32f405 => F32_BOARDS[1],
}
