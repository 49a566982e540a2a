//! The firmware in the loop: build it, run the acceleration case on QEMU's
//! Cortex-M4F with `-icount`, and check what it prints against the host solver.
//!
//! (a) it exits with success after printing `done`; (b) every reported connection
//! and tow tension is within 0.5 % of the host solver run in f32 on the same model,
//! path and steps; (c) a control step stays within the instruction budget;
//! (d) two runs print byte-identical output.
//!
//! A missing `qemu-system-arm` or target fails the tests with a message saying to
//! run `cargo xtask setup`: nothing is skipped silently.

use std::sync::OnceLock;
use std::time::{Duration, Instant};

use decoy_config::SystemConfig;
use hil_tests::firmware::{self, MemoryUsage};
use hil_tests::qemu::{Captured, Qemu};
use hil_tests::report::{self, Report};
use hil_tests::scenario::{
    Acceleration, CONTROL_STEPS, REPORT_EVERY, SEGMENT_CAPACITY, SUBSTEPS, substep_s,
};
use solver_core::{FlightPath, Real, Solver, trim};

/// Time limit of the firmware build (a cold build takes about 30 s).
const BUILD_TIMEOUT: Duration = Duration::from_secs(600);
/// Time limit of one QEMU run (a run takes well under a second).
const QEMU_TIMEOUT: Duration = Duration::from_secs(120);
/// Largest relative difference allowed between firmware and host tensions.
const TENSION_TOLERANCE: f64 = 5e-3;

/// Instructions one control step (two RK4 steps of 5 ms) may execute.
///
/// The firmware issue's target is 100,000 (goal 40,000 per RK4 step, 80,000 per
/// control step); measured: 87,720 max, 86,242 mean (one RK4 step ~43,900: the 17
/// joint eliminations ~3,900 and the 16 segments' kinematics and drag ~3,300 per
/// dynamics evaluation, four evaluations per step, plus the f64 flight-path samples).
/// This guard sits just above the measurement so that regressions fail; lower it as
/// the solver gets faster. The count is exact and deterministic under `-icount`, so it
/// may be asserted (TOOLCHAIN.md); wall-clock time may not.
const CONTROL_STEP_BUDGET: u64 = 89_000;
/// The target for one control step, printed for comparison.
const CONTROL_STEP_TARGET: u64 = 100_000;

/// One firmware build and run, shared by the tests.
struct FirmwareRun {
    elf: std::path::PathBuf,
    memory: MemoryUsage,
    output: Captured,
    report: Report,
}

/// Builds the firmware and runs it once; every test starts from here.
fn firmware_run() -> &'static FirmwareRun {
    static RUN: OnceLock<FirmwareRun> = OnceLock::new();
    RUN.get_or_init(|| {
        let started = Instant::now();
        let elf = firmware::build_release(BUILD_TIMEOUT).unwrap_or_else(|e| panic!("{e}"));
        let built = started.elapsed();
        let memory = firmware::memory_usage(&elf).unwrap_or_else(|e| panic!("{e}"));
        let output = Qemu::new()
            .timeout(QEMU_TIMEOUT)
            .run(&elf)
            .unwrap_or_else(|e| panic!("{e}"));
        // (a) A successful exit, after `done`.
        assert!(
            output.status.success(),
            "the firmware failed under QEMU\n{}",
            output.describe()
        );
        let report = report::parse(&output.stdout_text())
            .unwrap_or_else(|e| panic!("{e}\n{}", output.describe()));
        println!(
            "firmware: built in {:.1} s, ran in {:.2} s; {memory}",
            built.as_secs_f64(),
            output.elapsed.as_secs_f64()
        );
        println!(
            "firmware: solver {} B in .bss, stack used {} B",
            report.memory.solver_bytes, report.memory.stack_used
        );
        FirmwareRun {
            elf,
            memory,
            output,
            report,
        }
    })
}

/// A host sample: time, connection tension, tow tension, pitch (degrees).
type HostSample = (f64, f32, f32, f32);

/// The host solver on the same model, path and steps, in f32, sampled where the
/// firmware reports.
fn host_run() -> Vec<HostSample> {
    let config = SystemConfig::builtin().expect("the built-in configuration");
    let model = config
        .model::<f32, SEGMENT_CAPACITY>(config.embedded_layout())
        .expect("the reference model");
    let path = Acceleration::new(&model.params().environment.atmosphere).expect("the scenario");
    let start = trim(&model, &FlightPath::<f32>::state_at(&path, 0.0)).expect("trim");
    let mut solver = Solver::new(model, start).expect("solver");
    let mut samples = Vec::new();
    for step in 1..=CONTROL_STEPS {
        for _ in 0..SUBSTEPS {
            solver.step(&path, substep_s()).expect("step");
        }
        if step % REPORT_EVERY == 0 {
            let out = solver.outputs(&path).expect("outputs");
            let pitch = out.decoy().expect("a decoy").euler.1.to_degrees();
            samples.push((
                out.time(),
                out.connection_tension(),
                out.tow_tension(),
                pitch,
            ));
        }
    }
    samples
}

#[test]
fn firmware_runs_to_completion_and_reports_every_tenth_step() {
    let run = firmware_run();
    let report = &run.report;
    assert_eq!(report.done.steps, CONTROL_STEPS as u64);
    assert_eq!(report.samples.len(), CONTROL_STEPS / REPORT_EVERY);
    for (k, sample) in report.samples.iter().enumerate() {
        let expected = ((k + 1) * REPORT_EVERY) as f64 * substep_s() * SUBSTEPS as f64;
        assert!(
            (sample.time - expected).abs() < 1e-9,
            "sample {k} at t = {}, expected {expected}",
            sample.time
        );
    }
    assert!(run.memory.flash() < 4 << 20, "flash: {}", run.memory);
    assert!(
        run.memory.ram() + report.memory.stack_used < 4 << 20,
        "RAM: {}, stack {} B",
        run.memory,
        report.memory.stack_used
    );
}

#[test]
fn firmware_tensions_match_the_host_solver() {
    let run = firmware_run();
    let host = host_run();
    assert_eq!(run.report.samples.len(), host.len());
    let (mut worst, mut worst_pitch, mut identical) = (0.0f64, 0.0f64, 0);
    for (target, &(time, t0, tn, pitch)) in run.report.samples.iter().zip(&host) {
        assert!(
            (target.time - time).abs() < 1e-9,
            "{} vs {time}",
            target.line
        );
        let host_line = format!(
            "t={time:.4} T0={t0:.4} TN={tn:.4} pitch={pitch:.4} instr={}",
            target.instructions
        );
        if host_line == target.line {
            identical += 1;
        }
        for (name, firmware_value, host_value) in [
            ("T0", target.connection_tension, t0.to_f64()),
            ("TN", target.tow_tension, tn.to_f64()),
        ] {
            let relative = (firmware_value - host_value).abs() / host_value.abs();
            worst = worst.max(relative);
            assert!(
                relative < TENSION_TOLERANCE,
                "{name} at t = {time:.2}: firmware {firmware_value} N, host {host_value} N \
                 ({:.3} % apart)",
                relative * 100.0
            );
        }
        worst_pitch = worst_pitch.max((target.pitch_deg - pitch.to_f64()).abs());
    }
    println!(
        "firmware vs host f32: worst tension difference {:.2e} relative, worst pitch \
         difference {worst_pitch:.2e} deg; {identical}/{} lines identical",
        worst,
        host.len()
    );
}

#[test]
fn control_step_fits_the_instruction_budget() {
    let done = firmware_run().report.done;
    println!(
        "instructions per control step ({SUBSTEPS} RK4 steps of {} ms): max {}, mean {}; \
         budget {CONTROL_STEP_BUDGET}, target {CONTROL_STEP_TARGET}; trim {}",
        substep_s() * 1e3,
        done.max_instructions,
        done.mean_instructions,
        firmware_run().report.trim_instructions
    );
    assert!(
        done.max_instructions < CONTROL_STEP_BUDGET,
        "a control step took {} instructions, over the budget of {CONTROL_STEP_BUDGET}",
        done.max_instructions
    );
}

#[test]
fn two_runs_print_identical_bytes() {
    let run = firmware_run();
    let again = Qemu::new()
        .timeout(QEMU_TIMEOUT)
        .run(&run.elf)
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(again.status.success(), "{}", again.describe());
    assert!(
        again.stdout == run.output.stdout,
        "the second run printed different output\n--- first ---\n{}--- second ---\n{}",
        run.output.stdout_text(),
        again.stdout_text()
    );
}
