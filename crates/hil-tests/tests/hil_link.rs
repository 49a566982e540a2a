//! The firmware in the loop over the real link: the decoy controller firmware boots
//! on QEMU (`-icount shift=0`), its UART on a TCP port, and the host drives it frame
//! by frame at the 10 ms control period with the aircraft states of the paper's
//! scenarios (the profiles `decoy simulate` flies).
//!
//! The boards come from `firmware/boards.toml` by role: every f32 test runs on
//! every f32 board (module `f32_boards`, each test over each board in turn):
//! today the Cortex-M4F of `mps2-an386` (the default build) and the STM32F405
//! on `netduinoplus2` (stm32f4xx-hal, SysTick at 168 MHz); so the STM32F405 must
//! answer bit for bit as the host f32 controller and so as the M4, within the
//! same instruction budgets. The f64 boards (the M7) have their own tests.
//!
//! What is asserted here (the scenarios themselves, every shipped manoeuvre at
//! its full duration with their answers, accuracy and instruction budget, are
//! flown by `tests/envelope.rs` over the whole operating envelope):
//!
//! - **Same answers as the host.** The host replays the very messages sent through
//!   `decoy_controller::Controller` (same configuration, same `FramePath`, same
//!   stepping rule) in this process: every build computes the target's maths
//!   (libm), so every answer must be equal: outputs in every field but the
//!   instruction counts, bit for bit, rejections and status frames exactly; the
//!   f64 boards (the M7) against the f64 reference, their nominal frames
//!   within the board's frame budget ([`budgets::frame`]).
//! - **Memory.** The RAM peak (static RAM plus the deepest stack, at boot or in
//!   the link loop) within the board's budget ([`budgets::ram_peak`]: its RAM,
//!   `firmware/boards.toml`, and on the M7 issue 22's 8 KiB left), then the
//!   flash, the static RAM, both stack peaks and the RAM peak against their
//!   baselines (`crates/hil-tests/baselines.toml`, `[memory.BOARD]`; written
//!   with `DECOY_BLESS=1`, `cargo xtask bless`); the controller in `.bss`,
//!   never on the stack.
//! - **Determinism.** Two runs receive byte-identical streams (the instruction
//!   counts included, so on the STM32F405 the 168 MHz SysTick's conversion to
//!   instructions repeats too).
//! - **Hello.** Each board names itself and its core clock as
//!   `firmware/boards.toml` says (`decoy_hil::qemu::Board::info`).
//! - **Robustness.** Corrupted, truncated, garbage, oversize frames; non-finite and
//!   out-of-range values; a bad quaternion; time going backwards or jumping; link
//!   silence. Each gets its typed answer with the right counter (the same answers a
//!   host controller gives to the same bytes), QEMU keeps running, and the next
//!   valid frame is answered exactly as in an undisturbed run.
//!
//! A missing QEMU, target or `defmt-print` fails with a message saying to run
//! `cargo xtask setup`: nothing is skipped. When a test fails, the firmware's
//! defmt log (decoded with `defmt-print`) and QEMU's stderr are printed with it.

mod common;

use std::sync::OnceLock;
use std::time::{Duration, Instant};

use common::baselines::{self, Margin, Ratchet};
use common::{boards_in, elf, on_each};
use decoy_config::SystemConfig;
use decoy_hil::flight::{self, Exchange};
use decoy_hil::link::Session;
use decoy_hil::qemu::{Board, Precision};
use decoy_hil::reference::Reference;
use decoy_hil::{budgets, firmware};
use decoy_link::{
    AircraftStateFrame, Command, DeviceMessage, HostMessage, OutputFrame, RejectReason, StatusFlags,
};
use decoy_sim::{RunOptions, Scenario};

/// The section of the baselines.
const SECTION: &str = "memory";
/// How much the flash may exceed its baseline: its constants hold the source
/// paths of a few third-party panic locations, under Cargo's home, whose
/// length differs between machines; everything else is exact.
const FLASH_MARGIN: Margin = Margin::Relative(0.01);

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

/// The most instructions a whole nominal frame took.
fn nominal_frame_max(answers: &[DeviceMessage]) -> u32 {
    flight::outputs(answers)
        .into_iter()
        .filter(|out| out.steps == flight::NOMINAL_RK4_STEPS)
        .map(|out| out.instructions)
        .max()
        .unwrap_or(0)
}

/// The f64 boards (the M7: Cortex-M7, f64 in hardware, `mps2-an500`): the same
/// answers as the host reference in f64 with the target's maths, bit for bit.
#[test]
fn f64_boards_match_the_host_in_f64() {
    on_each(
        &boards_in(Precision::F64),
        f64_board_matches_the_host_in_f64,
    );
}

fn f64_board_matches_the_host_in_f64(board: Board) {
    let mut s = session(board);
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
    let stats = flight::instruction_stats(&answers);
    // ResetToTrim's Status, the initialisation's (a frame or two in f64), then
    // an Output for every frame.
    assert_eq!(
        agreement.outputs + stats.trim_frames - 1,
        messages.len() - 1
    );
    assert_eq!(
        agreement.identical, agreement.outputs,
        "{board}: outputs not bit-identical to the host's f64 ones: {agreement:?}"
    );
    println!(
        "{board} (f64) acceleration 3 s: {} outputs bit-identical to the host f64 reference; \
         whole frames max {}, mean {:.0}; nominal frames max {}; solver per nominal control \
         step max {}; {:.0} frames/s",
        agreement.identical,
        stats.max,
        stats.mean,
        nominal_frame_max(&answers),
        stats.nominal_solver_max,
        flown.frames_per_second()
    );
    let budget = budgets::frame(board);
    for out in flight::outputs(&answers) {
        if out.steps == flight::NOMINAL_RK4_STEPS {
            budget
                .check(&format!("{board}: seq {}", out.seq), out.instructions)
                .unwrap_or_else(|e| panic!("{e}"));
        }
    }
}

/// Memory at every moment fits the board: static RAM (`.data` + `.bss`) plus the
/// deepest stack, at boot (building the controller) or in the link loop (the
/// trim and 300 frames of the acceleration), within [`budgets::ram_peak`], and
/// each quantity within its baseline; the controller, built in place in its
/// `static`, lies in `.bss` and never on the stack: the boot's stack is smaller
/// than the controller (a copy of it on the stack would make it larger).
fn ram_peak_fits_the_board(board: Board) {
    let memory = firmware::memory_usage(elf(board)).unwrap_or_else(|e| panic!("{e}"));
    let (exchanges, _, _, log) = fly(board, &frames("acceleration", None, 3.0));
    let answers: Vec<DeviceMessage> = exchanges.iter().map(|e| e.answer).collect();
    // After ResetToTrim's Status, the 301 frames are answered by the
    // initialisation's Status (a frame or two in f64) and then by Outputs.
    let stats = flight::instruction_stats(&answers);
    assert_eq!(
        flight::outputs(&answers).len() + stats.trim_frames - 1,
        301,
        "{board}: outputs"
    );
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
    budgets::ram_peak(board)
        .check(
            &format!(
                "{board}: static {} B + stack {} B",
                memory.ram(),
                marks.peak()
            ),
            peak,
        )
        .unwrap_or_else(|e| panic!("{e}"));
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
    let measured = [
        ("flash", memory.flash()),
        ("text", memory.text),
        ("data", memory.data),
        ("bss", memory.bss),
        ("static_ram", memory.ram()),
        ("controller", marks.controller),
        ("stack_boot", marks.boot),
        ("stack_link", link),
        ("ram_peak", peak),
    ];
    let path = [SECTION, board.name()];
    if baselines::blessing() {
        baselines::record(&path, |t| {
            t.clear();
            for (name, bytes) in measured {
                t.insert(name.into(), baselines::int(bytes));
            }
        });
        return;
    }
    let mut ratchet = Ratchet::new(&path, board.to_string());
    ratchet.at_most("flash", memory.flash() as f64, FLASH_MARGIN);
    for (name, bytes) in measured {
        if !["flash", "text", "data", "bss"].contains(&name) {
            ratchet.count(name, bytes);
        }
    }
    ratchet.finish();
}

/// [`ram_peak_fits_the_board`] on the f64 boards (the M7: the largest
/// controller, 64 KiB).
#[test]
fn f64_boards_ram_peak_fits_the_board() {
    on_each(&boards_in(Precision::F64), ram_peak_fits_the_board);
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

    // Oversize: more bytes than a frame may have without a delimiter.
    let mut oversize = vec![0x00];
    oversize.extend(std::iter::repeat_n(0x42, decoy_link::MAX_FRAME_BYTES + 44));
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

/// The f32 suite: each test on every f32 board of `firmware/boards.toml`, one
/// after the other (the harness runs two tests at once).
mod f32_boards {
    use super::*;

    /// Runs `check` on every f32 board.
    fn on_f32(check: fn(Board)) {
        on_each(&boards_in(Precision::F32), check);
    }

    #[test]
    fn ram_peak_fits_the_board() {
        on_f32(super::ram_peak_fits_the_board);
    }

    #[test]
    fn two_runs_receive_identical_bytes() {
        on_f32(super::two_runs_receive_identical_bytes);
    }

    #[test]
    fn malformed_frames_are_rejected_and_the_state_is_kept() {
        on_f32(super::malformed_frames_are_rejected_and_the_state_is_kept);
    }

    #[test]
    fn invalid_values_are_rejected_with_their_reason() {
        on_f32(super::invalid_values_are_rejected_with_their_reason);
    }

    #[test]
    fn time_going_backwards_or_jumping_is_rejected() {
        on_f32(super::time_going_backwards_or_jumping_is_rejected);
    }

    #[test]
    fn link_silence_degrades_and_recovers() {
        on_f32(super::link_silence_degrades_and_recovers);
    }
}
