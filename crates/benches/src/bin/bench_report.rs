//! Writes `docs/benchmarks.md`, `docs/figures/bench-scaling.{png,svg}` and
//! `docs/figures/envelope-worst-frame.{png,svg}` from the results of one
//! benchmark run. Run by `cargo xtask bench-report`, after it ran
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
    self, EnvelopeBoard, EnvelopeFlight, FirmwareCounts, FirmwareRow, Inputs, Machine,
    read_criterion, read_gungraun,
};
use decoy_hil::firmware;
use decoy_hil::flight;
use decoy_hil::link::Session;
use decoy_hil::qemu::{Board, Precision};
use decoy_hil::step_cost::StepCost;
use decoy_hil::sweep;

/// Time limit of one firmware build.
const BUILD_TIMEOUT: Duration = Duration::from_secs(600);
/// Simulated time of the acceleration flown for the instruction counts, s.
const FIRMWARE_RUN_S: f64 = 3.0;

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
    // A renamed or missing benchmark is an error here, not an "n/a" in the document.
    report::check_complete(&wall, &instructions).map_err(|e| e.to_string())?;

    let solver = decoy_config::SystemConfig::builtin()
        .map_err(|e| e.to_string())?
        .solver;
    let embedded = (solver.segments_embedded, solver.grading_ratio_embedded);
    let sizes = report::firmware_segments(embedded.0);
    // The report's firmware tables: the default board (the M4, f32) and the
    // first f64 board of firmware/boards.toml (the M7).
    let f64_board = Board::with_precision(Precision::F64)
        .first()
        .copied()
        .ok_or("no f64 board in firmware/boards.toml")?;
    let (firmware, firmware_m7) = if firmware_runs {
        (
            sizes
                .iter()
                .map(|&n| firmware_row(Board::default(), n))
                .collect(),
            sizes.iter().map(|&n| firmware_row(f64_board, n)).collect(),
        )
    } else {
        (Vec::new(), Vec::new())
    };
    let step_cost = if firmware_runs {
        [Board::default(), f64_board].map(|board| {
            let cost = decoy_hil::step_cost::measure(board).map(|f| StepCost::of(&f));
            match &cost {
                Ok(c) => println!(
                    "firmware: {}, one RK4 step (examples/step_cost.rs): four stages {} max, \
                     first stage reused {} max",
                    board.name(),
                    c.four_stages,
                    c.first_stage_reused
                ),
                Err(e) => println!("firmware: {}, step cost not measured: {e}", board.name()),
            }
            cost
        })
    } else {
        [Err("not run".to_owned()), Err("not run".to_owned())]
    };
    let [step_cost, step_cost_m7] = step_cost;
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

    let envelope = if firmware_runs {
        Board::all().iter().copied().map(envelope_board).collect()
    } else {
        Vec::new()
    };

    let inputs = Inputs {
        machine: machine(),
        wall,
        instructions,
        firmware,
        firmware_m7,
        step_cost,
        step_cost_m7,
        pinocchio,
        envelope,
        embedded,
    };
    let docs = root.join("docs");
    let figure = docs.join("figures").join("bench-scaling");
    decoy_plots::write_stacked(&report::scaling_plot(&inputs), &figure)
        .map_err(|e| e.to_string())?;
    let envelope_plots = report::envelope_plot(&inputs);
    if !envelope_plots.is_empty() {
        let stem = docs.join("figures").join("envelope-worst-frame");
        decoy_plots::write_stacked(&envelope_plots, &stem).map_err(|e| e.to_string())?;
        println!("wrote {}.{{png,svg}}", stem.display());
    }
    let out = docs.join("benchmarks.md");
    // The host bridge's section is measured by its own benchmark: kept as it is.
    let existing = std::fs::read_to_string(&out).unwrap_or_default();
    let document = report::with_kept_section(&report::render(&inputs), &existing);
    std::fs::write(&out, document).map_err(|e| format!("cannot write {}: {e}", out.display()))?;
    println!(
        "wrote {} and {}.{{png,svg}}",
        out.display(),
        figure.display()
    );
    Ok(())
}

/// The envelope sweep's full grid on `board` (two QEMU sessions at once), each
/// flight summarised.
fn envelope_board(board: Board) -> EnvelopeBoard {
    let bound = decoy_hil::budgets::frame(board).limit;
    let flights = (|| -> Result<Vec<EnvelopeFlight>, String> {
        let config = decoy_config::SystemConfig::builtin().map_err(|e| e.to_string())?;
        let cases = sweep::cases(&config, sweep::Grid::Full).map_err(|e| e.to_string())?;
        let elf = firmware::build_board(board, BUILD_TIMEOUT).map_err(|e| e.to_string())?;
        let total = cases.len();
        println!("envelope: {board}, {total} flights (two QEMU sessions at once)");
        let flown = sweep::fly_all(&elf, board, &cases, 2, |f, done| {
            let m = f.measured();
            println!(
                "envelope: {board} {done}/{total} {}: worst frame {}, mean {:.0}, trim {} frame(s) max {}",
                f.case.label,
                m.stats.worst_frame(),
                m.stats.mean,
                m.stats.trim_frames,
                m.stats.trim_max
            );
        })?;
        Ok(flown
            .iter()
            .map(|f| {
                let m = f.measured();
                EnvelopeFlight {
                    label: f.case.label.clone(),
                    group: f.case.group.name().to_owned(),
                    frames: f.sent.len().saturating_sub(1),
                    worst: m.stats.worst_frame(),
                    mean: m.stats.mean,
                    trim: (m.stats.trim_frames, m.stats.trim_max),
                    bands: m.bands.iter().map(|&(b, w)| (b, w)).collect(),
                    outside_envelope: m.outside_envelope,
                    step_limited: m.step_limited,
                }
            })
            .collect())
    })();
    if let Err(e) = &flights {
        println!("envelope: {board}: {e}");
    }
    EnvelopeBoard {
        board: board.label().to_owned(),
        bound,
        flights,
    }
}

/// Builds the firmware for `board` with `segments` segments and runs it once under
/// QEMU.
fn firmware_row(board: Board, segments: usize) -> FirmwareRow {
    println!("firmware: {board}, {segments} segments: building and running under QEMU");
    let grading = decoy_config::SystemConfig::builtin()
        .map(|config| grading_for(&config, segments))
        .unwrap_or(f64::NAN);
    let outcome = firmware_counts(board, segments);
    match &outcome {
        Ok(c) => println!(
            "firmware: {board}, {segments} segments: control step {} max, {} mean; \
             solver {} max, {} mean per RK4 step; {} to {} RK4 steps per control step",
            c.frame_max,
            c.frame_mean,
            c.rk4_step_max,
            c.rk4_step_mean,
            c.rk4_steps.0,
            c.rk4_steps.1
        ),
        Err(e) => println!("firmware: {board}, {segments} segments: {e}"),
    }
    FirmwareRow {
        segments,
        grading,
        outcome,
    }
}

/// Builds the firmware for `board` with `segments` segments, boots it under QEMU
/// and flies 3 s of the acceleration scenario over the decoy link (frames every
/// 10 ms); returns its instruction counts.
fn firmware_counts(board: Board, segments: usize) -> Result<FirmwareCounts, String> {
    let mut config = decoy_config::SystemConfig::builtin().map_err(|e| e.to_string())?;
    let grading = grading_for(&config, segments);
    let elf = firmware::build_board_with_layout(board, segments, grading, BUILD_TIMEOUT)
        .map_err(|e| e.to_string())?;
    config.solver.segments_embedded = segments;
    config.solver.grading_ratio_embedded = grading;
    let plan = decoy_sim::Scenario::builtin("acceleration")
        .and_then(|s| {
            s.plan(
                &config,
                &decoy_sim::RunOptions {
                    segments: Some(segments),
                    grading: Some(config.solver.grading_ratio_embedded),
                    t_end: Some(FIRMWARE_RUN_S),
                    plots: false,
                    ..decoy_sim::RunOptions::default()
                },
            )
        })
        .map_err(|e| e.to_string())?;
    let frames = flight::scenario_frames(&plan.profile, flight::frame_count(FIRMWARE_RUN_S));
    let messages = flight::scenario_messages(&frames);
    let mut session = Session::start(&elf, board).map_err(|e| e.to_string())?;
    let flown = flight::fly(&mut session, &messages, |_| {}).map_err(|e| e.to_string())?;
    let answers = flown.answers();
    if let Some(rejected) = answers.iter().find_map(|a| match a {
        decoy_link::DeviceMessage::Rejected(r) => Some(*r),
        _ => None,
    }) {
        return Err(format!(
            "the firmware rejected frame {:?} ({:?})",
            rejected.seq, rejected.reason
        ));
    }
    let stats = flight::instruction_stats(&answers);
    let outputs: Vec<_> = flight::outputs(&answers)
        .into_iter()
        .filter(|o| o.steps > 0)
        .collect();
    let fewest = outputs.iter().map(|o| o.steps).min().unwrap_or(0);
    let most = outputs.iter().map(|o| o.steps).max().unwrap_or(0);
    let per_step: Vec<u64> = outputs
        .iter()
        .filter(|o| o.steps == fewest)
        .map(|o| u64::from(o.step_instructions / u32::from(o.steps)))
        .collect();
    let rk4_step_max = per_step.iter().copied().max().unwrap_or(0);
    let rk4_step_mean = per_step.iter().sum::<u64>() / per_step.len().max(1) as u64;
    Ok(FirmwareCounts {
        frame_max: u64::from(stats.max),
        frame_mean: stats.mean.round() as u64,
        rk4_steps: (fewest, most),
        rk4_step_max,
        rk4_step_mean,
    })
}

/// The grading ratio of the `segments`-segment model of the report: the configured
/// ratio, or less where that would make the shortest segment shorter than the
/// configured embedded model's (its RK4 step, set by the waves on the shortest
/// segment, would shrink and the rows would measure the step count, not the cost
/// per step): larger counts are graded less, down to uniform (docs/benchmarks.md's
/// firmware rows give the ratios).
fn grading_for(config: &decoy_config::SystemConfig, segments: usize) -> f64 {
    let length = config.cable.length;
    let shortest = |ratio: f64, n: usize| {
        if ratio == 1.0 {
            length / n as f64
        } else {
            length * (ratio - 1.0) / (ratio.powi(n as i32) - 1.0)
        }
    };
    let configured = config.solver.grading_ratio_embedded;
    let target = shortest(configured, config.solver.segments_embedded);
    if shortest(configured, segments) >= target {
        return configured;
    }
    if shortest(1.0, segments) < target {
        return 1.0;
    }
    // Bisection: the shortest segment falls as the ratio grows.
    let (mut low, mut high) = (1.0, configured);
    for _ in 0..60 {
        let mid = 0.5 * (low + high);
        if shortest(mid, segments) >= target {
            low = mid;
        } else {
            high = mid;
        }
    }
    (low * 1e4).floor() / 1e4
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
        qemu: first_line(
            &decoy_hil::qemu::default_program().to_string_lossy(),
            &["--version"],
        ),
    }
}
