//! Writes `docs/benchmarks.md` and `docs/figures/bench-scaling.{png,svg}` from the
//! results of one benchmark run. Run by `cargo xtask bench-report`, after it ran
//! the criterion and gungraun benchmarks; this binary also builds and runs the
//! firmware under QEMU for each segment count of the report.
//!
//! Usage: `bench-report [--no-firmware] [--pinocchio FILE]`. `--pinocchio` names a
//! file holding the result line of `crates/benches/pinocchio/aba_300.py` (absent or
//! empty: not measured). Paths are relative to the workspace root.

use std::path::PathBuf;
use std::process::{Command, ExitCode};
use std::time::Duration;

use benches::report::{
    self, FIRMWARE_SEGMENTS, FirmwareRow, Inputs, Machine, read_criterion, read_gungraun,
};
use hil_tests::firmware;
use hil_tests::qemu::Qemu;

/// Time limit of one firmware build.
const BUILD_TIMEOUT: Duration = Duration::from_secs(600);
/// Time limit of one QEMU run.
const QEMU_TIMEOUT: Duration = Duration::from_secs(300);

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("bench-report: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<(), String> {
    let mut firmware_runs = true;
    let mut pinocchio_file: Option<PathBuf> = None;
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--no-firmware" => firmware_runs = false,
            "--pinocchio" => {
                pinocchio_file = Some(args.next().ok_or("--pinocchio needs a file")?.into())
            }
            other => {
                return Err(format!(
                    "unknown argument `{other}`; usage: bench-report [--no-firmware] [--pinocchio FILE]"
                ));
            }
        }
    }
    let root = firmware::workspace_root();
    let target = root.join("target");

    let wall = read_criterion(&target.join("criterion"))
        .map_err(|e| format!("{e} (run `{}` first)", report::CRITERION_COMMAND))?;
    println!("criterion: {} results", wall.len());
    let instructions = read_gungraun(&target.join("gungraun"))
        .map_err(|e| format!("{e} (run `{}` first)", report::GUNGRAUN_COMMAND))?;
    println!("gungraun: {} results", instructions.len());

    let firmware = if firmware_runs {
        FIRMWARE_SEGMENTS.iter().map(|&n| firmware_row(n)).collect()
    } else {
        Vec::new()
    };
    let pinocchio = match &pinocchio_file {
        None => Err(
            "no result given (`cargo xtask bench-report` runs it when the Python \
                     package `pin` is installed)"
                .to_owned(),
        ),
        Some(path) => match std::fs::read_to_string(root.join(path)) {
            Ok(text) if !text.trim().is_empty() => Ok(text.trim().to_owned()),
            Ok(_) => Err("the script printed nothing".to_owned()),
            Err(_) => Err("Pinocchio is not installed here (`pip install pin`)".to_owned()),
        },
    };

    let inputs = Inputs {
        machine: machine(),
        wall,
        instructions,
        firmware,
        // The Cortex-M7 (f64) firmware measurement is not wired up yet: rendered as
        // "not measured".
        firmware_m7: Vec::new(),
        pinocchio,
    };
    let docs = root.join("docs");
    let figure = docs.join("figures").join("bench-scaling");
    decoy_plots::write_stacked(&report::scaling_plot(&inputs), &figure)
        .map_err(|e| e.to_string())?;
    let out = docs.join("benchmarks.md");
    std::fs::write(&out, report::render(&inputs))
        .map_err(|e| format!("cannot write {}: {e}", out.display()))?;
    println!(
        "wrote {} and {}.{{png,svg}}",
        out.display(),
        figure.display()
    );
    Ok(())
}

/// Builds the firmware with `segments` segments and runs it once under QEMU.
fn firmware_row(segments: usize) -> FirmwareRow {
    println!("firmware: {segments} segments: building and running under QEMU");
    let outcome = firmware_counts(segments);
    match &outcome {
        Ok((max, mean)) => println!(
            "firmware: {segments} segments: {max} max, {mean} mean instructions per control step"
        ),
        Err(e) => println!("firmware: {segments} segments: {e}"),
    }
    FirmwareRow { segments, outcome }
}

fn firmware_counts(segments: usize) -> Result<(u64, u64), String> {
    let elf = firmware::build_with_segments(segments, BUILD_TIMEOUT).map_err(|e| e.to_string())?;
    let output = Qemu::new()
        .timeout(QEMU_TIMEOUT)
        .run(&elf)
        .map_err(|e| e.to_string())?;
    if !output.status.success() {
        let last = output
            .stdout_text()
            .lines()
            .last()
            .unwrap_or("no output")
            .to_owned();
        return Err(format!(
            "pending firmware issue: the firmware stops with `{last}`. Its scenario \
             (firmware/src/scenario.rs) fixes the RK4 step at 5 ms, which is unstable \
             with this many segments; measuring it needs a firmware option for the step \
             (or a steady-flight benchmark mode)"
        ));
    }
    let parsed = hil_tests::report::parse(&output.stdout_text()).map_err(|e| e.to_string())?;
    Ok((parsed.done.max_instructions, parsed.done.mean_instructions))
}

/// First line of a command's stdout, or `unknown`.
fn first_line(program: &str, args: &[&str]) -> String {
    Command::new(program)
        .args(args)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| {
            String::from_utf8_lossy(&o.stdout)
                .lines()
                .next()
                .map(|l| l.trim().to_owned())
        })
        .unwrap_or_else(|| "unknown".into())
}

/// CPU, cores, OS and tool versions.
fn machine() -> Machine {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let cpu = cpuinfo
        .lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split_once(':'))
        .map(|(_, v)| v.trim().to_owned())
        .unwrap_or_else(|| "unknown".into());
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    let os = std::fs::read_to_string("/etc/os-release")
        .unwrap_or_default()
        .lines()
        .find_map(|l| l.strip_prefix("PRETTY_NAME="))
        .map(|v| v.trim_matches('"').to_owned())
        .unwrap_or_else(|| "unknown".into());
    Machine {
        cpu,
        cores,
        os,
        rustc: first_line("rustc", &["--version"]),
        valgrind: first_line("valgrind", &["--version"]),
        qemu: first_line(hil_tests::qemu::QEMU, &["--version"]),
    }
}
