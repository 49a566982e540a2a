//! The same firmware under every QEMU version this machine has: the system's
//! (`qemu-system-arm` from `PATH`, and `$DECOY_QEMU` if it names another) and
//! the second version `cargo xtask setup` unpacks under `target/qemu/`
//! (bookworm's 7.2 beside the backports' 10, or the reverse;
//! `decoy_hil::qemu::comparison_binaries`).
//!
//! On each board of `firmware/boards.toml` (the M4, the STM32F405 and the M7
//! in f64; the f32 boards in one test, the f64 ones in another) one short frame
//! sequence, [`SCENARIO`] at [`RATE`] for [`T_END`] s (the trim, steady flight,
//! then the first second of the rotation), is flown under each QEMU, and
//! everything the firmware says must be the same under all of them: the Hello,
//! every answer (every output field, the instruction counts `instructions`,
//! `step_instructions` and `management_instructions` included), the bytes
//! received after Hello, and the decoded defmt log (its stack high-water marks
//! and, on a board with the advisory line, its changes). Under `-icount
//! shift=0` an instruction is 1 ns of virtual time on every version, so a
//! difference is a change in how a QEMU version executes or times the firmware.
//!
//! Without a second version the tests pass with a message on stderr saying why
//! (the reason `cargo xtask setup` left in `target/qemu/unavailable.txt`, or
//! that setup has not run); a second version that is there but does not run
//! fails them.

mod common;

use std::io::Write as _;
use std::path::Path;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use common::{boards_in, elf, on_each};
use decoy_config::SystemConfig;
use decoy_hil::firmware;
use decoy_hil::flight::{self, Exchange};
use decoy_hil::link::Session;
use decoy_hil::qemu::{self, Board, Precision, Qemu, QemuVersion};
use decoy_link::{DeviceMessage, HostMessage, StatusFlags};

/// The scenario flown: a pull-up, whose rotation starts at t = 2 s.
const SCENARIO: &str = "pull-up";
/// Its rate, rad/s: the fastest shipped.
const RATE: f64 = 0.20;
/// Simulated seconds per board and QEMU version (301 frames and the ResetToTrim).
const T_END: f64 = 3.0;

/// The QEMU versions to compare, one binary per version, the default one first
/// ([`qemu::default_program`]: `$DECOY_QEMU`, else `qemu-system-arm`), then
/// `qemu-system-arm` from `PATH` if `$DECOY_QEMU` named another, then the copies
/// under `target/qemu/`; `None` (after saying so on stderr) when all are of one
/// version.
fn qemus() -> Option<&'static [QemuVersion]> {
    static QEMUS: OnceLock<Option<Vec<QemuVersion>>> = OnceLock::new();
    QEMUS
        .get_or_init(|| {
            let default = qemu::default_program();
            let system =
                qemu::version_of(&default).unwrap_or_else(|e| panic!("the system's QEMU: {e}"));
            let mut versions = vec![system];
            let mut add = |version: QemuVersion| {
                if versions.iter().all(|v| v.version != version.version) {
                    versions.push(version);
                }
            };
            if default != Path::new(qemu::QEMU) {
                // $DECOY_QEMU chose the default; the one on PATH is another, if any.
                if let Ok(on_path) = qemu::version_of(Path::new(qemu::QEMU)) {
                    add(on_path);
                }
            }
            let root = firmware::workspace_root();
            let copies = qemu::comparison_binaries(&root);
            for binary in &copies {
                add(qemu::version_of(binary).unwrap_or_else(|e| {
                    panic!("the comparison QEMU {} does not run: {e}", binary.display())
                }));
            }
            if versions.len() > 1 {
                return Some(versions);
            }
            let why = match qemu::comparison_unavailable(&root) {
                Some(reason) => reason,
                None if copies.is_empty() => format!(
                    "none under {} (run `cargo xtask setup`, which unpacks one there)",
                    root.join(qemu::COMPARISON_DIR).display()
                ),
                None => format!(
                    "the copies under {} are of the same version",
                    root.join(qemu::COMPARISON_DIR).display()
                ),
            };
            // Written to the process's stderr, not through `eprintln!`, so that
            // the test harness does not capture it: a skip must show.
            let _ = writeln!(
                std::io::stderr(),
                "qemu_versions: SKIPPED, no second QEMU version beside {}: {why}",
                versions[0]
            );
            None
        })
        .as_deref()
}

fn config() -> &'static SystemConfig {
    static CONFIG: OnceLock<SystemConfig> = OnceLock::new();
    CONFIG.get_or_init(|| SystemConfig::builtin().expect("the built-in configuration"))
}

/// [`SCENARIO`]'s messages: ResetToTrim, then the frames of [`T_END`] s as the
/// embedded model flies them.
fn messages() -> &'static [HostMessage] {
    static MESSAGES: OnceLock<Vec<HostMessage>> = OnceLock::new();
    MESSAGES.get_or_init(|| {
        let (_, frames) = flight::builtin_frames(config(), SCENARIO, Some(RATE), T_END)
            .unwrap_or_else(|e| panic!("{e}"));
        flight::scenario_messages(&frames)
    })
}

/// What one QEMU version's run gave.
struct Run {
    hello: decoy_link::Hello,
    exchanges: Vec<Exchange>,
    received: Vec<u8>,
    log: String,
    wall: Duration,
}

/// Flies [`messages`] on `board` under `version`.
fn fly(board: Board, version: &QemuVersion) -> Run {
    let elf = elf(board);
    let started = Instant::now();
    let launcher = Qemu::new().program(&version.program).board(board);
    let mut session = Session::start_with(elf, launcher)
        .unwrap_or_else(|e| panic!("{board} under {version}: {e}"));
    let boot_bytes = session.link.received().len();
    let flown = flight::fly(&mut session, messages(), |_| {})
        .unwrap_or_else(|e| panic!("{board} under {version}: {e}"));
    assert!(
        session.device_running(),
        "{board} under {version}: QEMU exited during the run"
    );
    let hello = session.hello;
    let received = session.link.received()[boot_bytes..].to_vec();
    let log = session.finish();
    assert!(
        log.was_running,
        "{board} under {version}: QEMU exited during the run"
    );
    Run {
        hello,
        exchanges: flown.exchanges,
        received,
        log: log.log,
        wall: started.elapsed(),
    }
}

/// Flies the frames on `board` under every QEMU version and requires the same
/// Hello, answers, bytes and log from each.
fn same_under_every_qemu(board: Board) {
    let Some(versions) = qemus() else {
        return;
    };
    let runs: Vec<Run> = versions.iter().map(|v| fly(board, v)).collect();
    let (reference, reference_run) = (&versions[0], &runs[0]);
    for (version, run) in versions.iter().zip(&runs).skip(1) {
        let label = format!("{board}: {version} against {reference}");
        assert_eq!(run.hello, reference_run.hello, "{label}: Hello differs");
        assert_eq!(
            run.exchanges.len(),
            reference_run.exchanges.len(),
            "{label}: answers"
        );
        if let Some((i, (a, b))) = run
            .exchanges
            .iter()
            .zip(&reference_run.exchanges)
            .enumerate()
            .find(|(_, (a, b))| a.answer != b.answer)
        {
            panic!(
                "{label}: answer {i} (to {:?}) differs:\n{:#?}\nagainst\n{:#?}",
                a.sent, a.answer, b.answer
            );
        }
        assert!(
            run.received == reference_run.received,
            "{label}: the bytes received after Hello differ ({} against {} bytes)",
            run.received.len(),
            reference_run.received.len()
        );
        assert_eq!(run.log, reference_run.log, "{label}: the defmt logs differ");
    }
    let answers: Vec<DeviceMessage> = reference_run.exchanges.iter().map(|e| e.answer).collect();
    let outputs = flight::outputs(&answers);
    let stats = flight::instruction_stats(&answers);
    let total: u64 = outputs.iter().map(|o| u64::from(o.instructions)).sum();
    let management: u64 = outputs
        .iter()
        .map(|o| u64::from(o.management_instructions))
        .sum();
    let shown: Vec<String> = versions
        .iter()
        .zip(&runs)
        .map(|(v, r)| format!("QEMU {} ({:.1} s)", v.version, r.wall.as_secs_f64()))
        .collect();
    println!(
        "{board}: {} answers, {} bytes and the log identical under {}: {} outputs, \
         {total} instructions in all (frames max {}, mean {:.0}), {management} of management",
        reference_run.exchanges.len(),
        reference_run.received.len(),
        shown.join(" and "),
        outputs.len(),
        stats.max,
        stats.mean,
    );
    // Every State frame answered: by a Status with INITIALISING while the trim
    // runs over its first frames (one in f32, a few in f64: docs/protocol.md §4,
    // "The initialisation"), then by an Output; none rejected.
    let states: Vec<&DeviceMessage> = reference_run
        .exchanges
        .iter()
        .filter(|e| matches!(e.sent, HostMessage::State(_)))
        .map(|e| &e.answer)
        .collect();
    let initialising = states
        .iter()
        .take_while(
            |a| matches!(a, DeviceMessage::Status(s) if s.flags & StatusFlags::INITIALISING != 0),
        )
        .count();
    assert!(
        initialising < 8,
        "{board}: {initialising} frames of initialisation"
    );
    assert!(
        states[initialising..]
            .iter()
            .all(|a| matches!(a, DeviceMessage::Output(_))),
        "{board}: every state frame after the initialisation answered by an output"
    );
    assert_eq!(outputs.len(), states.len() - initialising);
}

/// Every f32 board in turn.
#[test]
fn f32_boards_answer_and_count_the_same_under_every_qemu_version() {
    on_each(&boards_in(Precision::F32), same_under_every_qemu);
}

/// Every f64 board in turn (a test of its own, so that the harness runs it
/// beside the f32 boards').
#[test]
fn f64_boards_answer_and_count_the_same_under_every_qemu_version() {
    on_each(&boards_in(Precision::F64), same_under_every_qemu);
}
