//! Project automation, run as `cargo xtask <command>` from anywhere in the repo.
//!
//! - `setup`: install what the project needs (Rust target `thumbv7em-none-eabihf`,
//!   QEMU, the Python environment `.venv/`) and say what was found and what was
//!   installed.
//! - `test`: `setup`, then every test stage (fmt, clippy, host tests, the solver's
//!   no_std cross build, each board's firmware build and lints), failing fast;
//!   `test --list` prints the stages and their commands without running them.
//! - `run`: the main job on the built-in reference system (see [`main_job`]).
//! - `bench-report`: run the benchmarks and write `docs/benchmarks.md` and
//!   `docs/host-steps.md` (see
//!   [`bench_report`]), then the bridge's soak.
//! - `soak`: the bridge's soak alone (see [`soak`]): `docs/soak.md`, `docs/soak.json`.
//! - `firmware build|clippy|run --board NAME`: a board's firmware as
//!   `firmware/boards.toml` describes it (module `firmware`); `firmware qemu-run
//!   ELF` is the firmware's cargo runner (`firmware/qemu-run.sh`).
//! - `check-refs`: the references stage alone ([`refs`]): every repository file
//!   and section the text cites exists.
//! - `check-layering`: the layering stage alone ([`layering`]): the crates'
//!   dependencies, no `#[path]`, no file cycle ([`modules`]).
//! - `bless [--only NAME]`: measure the HIL tests' baselines again and write
//!   them, `crates/hil-tests/baselines.toml`, and the documents' tables generated
//!   from them (see [`bless`]).

mod apt;
mod firmware;
mod layering;
mod modules;
mod process;
mod python;
mod qemu;
mod refs;
mod setup;

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::{Duration, Instant};

use clap::builder::PossibleValuesParser;
use clap::{Parser, Subcommand};
use decoy_boards::{Board, Build};

use firmware::Task;
use process::Result;
use setup::{Scope, TARGET, Toolchain};

/// The main job: `decoy` invocations on the built-in reference system, run in
/// order by `cargo xtask run`: its trim at 9 km and Mach 0.8 with the host model
/// and with the embedded model (the configuration's `solver.segments_embedded`
/// graded by `solver.grading_ratio_embedded`, read from it), then the paper's
/// acceleration. Each entry is the command line after `decoy`, split on
/// whitespace (so no argument may contain a space).
fn main_job() -> Result<Vec<String>> {
    let solver = decoy_config::SystemConfig::builtin()
        .map_err(|e| format!("the built-in configuration: {e}"))?
        .solver;
    Ok(vec![
        "trim --altitude 9000 --mach 0.8".to_owned(),
        format!(
            "trim --altitude 9000 --mach 0.8 --segments {} --grading {}",
            solver.segments_embedded, solver.grading_ratio_embedded
        ),
        "simulate --scenario acceleration --out out/acceleration".to_owned(),
    ])
}

/// How `cargo` runs the `decoy` binary; a [`main_job`] entry is appended.
const DECOY: &str = "run --release -p decoy-cli --bin decoy --";

/// Command line of the xtask.
#[derive(Parser)]
#[command(name = "xtask", bin_name = "cargo xtask", about = "Project automation")]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

/// The xtask's subcommands.
#[derive(Subcommand)]
enum Cmd {
    /// Install what the project needs (target toolchain, QEMU) and report it.
    Setup,
    /// Run setup, then every test stage; stops at the first failing stage.
    Test {
        /// Print the stages and their commands instead of running them (no setup).
        #[arg(long)]
        list: bool,
    },
    /// Run the main job on the built-in reference system.
    Run,
    /// Run the wall-clock and instruction-count benchmarks and the firmware under
    /// QEMU, and write docs/benchmarks.md and docs/figures/bench-scaling.{png,svg};
    /// then the bridge's soak (docs/soak.md).
    BenchReport,
    /// The bridge's soak alone: `decoy bridge` serving lockstep, a free-running
    /// flood and commands side by side; writes docs/soak.md and docs/soak.json.
    Soak {
        /// How long the bridge serves (e.g. 30s, 10m, 1h; default 10m).
        #[arg(long, value_name = "DURATION", default_value = SOAK_DURATION)]
        duration: String,
    },
    /// Check that every repository file and section the text cites exists (the
    /// references stage of `test`, alone).
    CheckRefs,
    /// The layering stage alone: crate dependencies, `#[path]`, file cycles.
    CheckLayering,
    /// Measure the HIL tests' baselines again (the tests with DECOY_BLESS=1) and
    /// write crates/hil-tests/baselines.toml and the documents' tables generated
    /// from it; the budgets are asserted as ever. About 16 minutes in all, most of
    /// it the envelope sweep.
    Bless {
        /// Only these sections of the file (repeatable): step_cost, memory,
        /// panic_sites, envelope, host_accuracy. The others are kept.
        #[arg(long, value_name = "NAME",
              value_parser = PossibleValuesParser::new(BLESSED.iter().map(|b| b.section)))]
        only: Vec<String>,
    },
    /// A board's firmware (firmware/boards.toml): build, lint or run it.
    Firmware {
        #[command(subcommand)]
        command: FirmwareCmd,
    },
}

/// `cargo xtask firmware ...`.
#[derive(Subcommand)]
enum FirmwareCmd {
    /// Build the board's firmware (release), as the test stage does; further cargo
    /// arguments after `--` (`-- --example step_cost`).
    Build {
        #[command(flatten)]
        board: BoardArgs,
        /// The real hardware's build instead of the QEMU build.
        #[arg(long)]
        hardware: bool,
        /// Further cargo arguments.
        #[arg(last = true)]
        cargo_args: Vec<String>,
    },
    /// Lint the board's firmware with clippy (-D warnings), as the test stage does.
    Clippy {
        #[command(flatten)]
        board: BoardArgs,
        /// The real hardware's build instead of the QEMU build.
        #[arg(long)]
        hardware: bool,
    },
    /// Build the board's firmware and boot it under QEMU (DECOY_LINK_PORT,
    /// DECOY_LINK_LISTEN, DECOY_QEMU, QEMU_TIMEOUT, DEFMT_RAW: see firmware/README.md).
    Run {
        #[command(flatten)]
        board: BoardArgs,
        /// Further cargo arguments of the build.
        #[arg(last = true)]
        cargo_args: Vec<String>,
    },
    /// The firmware's cargo runner (firmware/qemu-run.sh): boot ELF under QEMU on
    /// the board it was built for (its `_decoy_board_NAME` symbol, or $DECOY_BOARD).
    QemuRun {
        /// The firmware ELF.
        elf: PathBuf,
    },
}

/// `--board NAME`: a board of firmware/boards.toml.
#[derive(clap::Args)]
struct BoardArgs {
    /// The board (firmware/boards.toml).
    #[arg(long, value_name = "NAME", default_value = Board::default().spec().name(),
          value_parser = PossibleValuesParser::new(Board::all().iter().map(|b| b.spec().name())))]
    board: String,
}

impl BoardArgs {
    fn board(&self) -> Result<Board> {
        Board::by_name(&self.board).map_err(|e| e.to_string())
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let root = workspace_root();
    let result = match cli.command {
        Cmd::Setup => setup::setup(&root, Scope::Full).map(drop),
        Cmd::Test { list: true } => {
            list_stages(&root);
            Ok(())
        }
        Cmd::Test { list: false } => test(&root),
        Cmd::Run => run(&root),
        Cmd::BenchReport => bench_report(&root).and_then(|()| soak(&root, SOAK_DURATION)),
        Cmd::Soak { duration } => soak(&root, &duration),
        Cmd::CheckRefs => refs::check(&root),
        Cmd::CheckLayering => layering::check(&root),
        Cmd::Bless { only } => bless(&root, &only),
        Cmd::Firmware { command } => match firmware_command(&root, command) {
            // The runner's exit code is QEMU's.
            Ok(code) => return ExitCode::from(code),
            Err(e) => Err(e),
        },
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The workspace root: the parent of this crate's directory.
fn workspace_root() -> PathBuf {
    let manifest_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    manifest_dir.parent().unwrap_or(manifest_dir).to_path_buf()
}

/// A host `cargo` command run in `dir`.
fn cargo(dir: &Path, args: &[&str]) -> Command {
    let mut cmd = Command::new("cargo");
    cmd.args(args).current_dir(dir);
    cmd
}

/// `cargo xtask firmware ...`; returns the exit code.
fn firmware_command(root: &Path, command: FirmwareCmd) -> Result<u8> {
    let build_of = |hardware: bool| {
        if hardware {
            Build::Hardware
        } else {
            Build::Qemu
        }
    };
    let run_task = |task: Task, board: &BoardArgs, hardware: bool, extra: &[String]| {
        let board = board.board()?;
        let build = build_of(hardware);
        let toolchain = setup::Toolchain::recorded(root);
        let mut cmd =
            firmware::command(root, toolchain, task, &board, build, extra).ok_or_else(|| {
                format!("board `{board}` has no {build} build (firmware/boards.toml)")
            })?;
        process::run(&mut cmd)?;
        Ok(board)
    };
    match command {
        FirmwareCmd::Build {
            board,
            hardware,
            cargo_args,
        } => run_task(Task::Build, &board, hardware, &cargo_args).map(|_| 0),
        FirmwareCmd::Clippy { board, hardware } => {
            run_task(Task::Clippy, &board, hardware, &[]).map(|_| 0)
        }
        FirmwareCmd::Run { board, cargo_args } => {
            let board = run_task(Task::Build, &board, false, &cargo_args)?;
            firmware::boot(&firmware::elf(root, &board), board)
        }
        FirmwareCmd::QemuRun { elf } => {
            let board = firmware::board_of(&elf)?;
            firmware::boot(&elf, board)
        }
    }
}

/// One test stage: a command to run, or the reason it is skipped.
struct Stage {
    name: String,
    action: Action,
}

/// What a [`Stage`] does.
enum Action {
    Run(Command),
    /// A check done by the xtask itself, on the repository root.
    Check(fn(&Path) -> Result<()>),
    Skip(String),
}

/// `cargo xtask test`.
fn test(root: &Path) -> Result<()> {
    let toolchain = setup::setup(root, Scope::Full)
        .map_err(|e| format!("stage `setup` failed: {e}"))?
        .unwrap_or(Toolchain::Rustup);

    let stages = stages(root, toolchain);
    let total = stages.len();
    let (mut passed, mut skipped) = (0usize, Vec::new());
    for (i, stage) in stages.into_iter().enumerate() {
        println!();
        println!("==> stage {}/{total}: {}", i + 1, stage.name);
        let start = Instant::now();
        let outcome = match stage.action {
            Action::Skip(reason) => {
                println!("<== {}: skipped ({reason})", stage.name);
                skipped.push(stage.name.clone());
                continue;
            }
            Action::Run(mut cmd) => process::run(&mut cmd),
            Action::Check(check) => check(root),
        };
        let secs = start.elapsed().as_secs_f64();
        if let Err(e) = outcome {
            println!("<== {}: FAILED after {secs:.1} s", stage.name);
            println!();
            println!("{passed} passed, 1 failed");
            return Err(format!("stage `{}` failed: {e}", stage.name));
        }
        println!("<== {}: passed in {secs:.1} s", stage.name);
        passed += 1;
    }
    println!();
    if !skipped.is_empty() {
        println!("skipped: {}", skipped.join(", "));
    }
    println!("{passed} passed, 0 failed");
    Ok(())
}

/// The test stages, in order.
fn stages(root: &Path, toolchain: Toolchain) -> Vec<Stage> {
    let fmt = if process::succeeds(Command::new("cargo").args(["fmt", "--version"])) {
        Action::Run(cargo(root, &["fmt", "--all", "--check"]))
    } else {
        Action::Skip("rustfmt is not installed".into())
    };

    // Each board's firmware (firmware/boards.toml): its QEMU build built and
    // linted, its hardware build (where it has one) linted, each in its own
    // target directory, the one the HIL library and `cargo xtask firmware` use.
    let have_firmware = firmware::dir(root).join("Cargo.toml").is_file();
    let mut firmware_stages = Vec::new();
    for &board in Board::all() {
        for build in board.builds() {
            let tasks: &[Task] = match build {
                Build::Qemu => &[Task::Build, Task::Clippy],
                Build::Hardware => &[Task::Clippy],
            };
            for &task in tasks {
                let what = match task {
                    Task::Build => "build",
                    Task::Clippy => "clippy",
                };
                let precision = board.precision();
                let name = match build {
                    Build::Qemu => format!("firmware {what} ({board}, {precision})"),
                    Build::Hardware => {
                        format!("firmware {what} ({board}, {precision}, hardware configuration)")
                    }
                };
                let action = if !have_firmware {
                    Action::Skip("firmware/Cargo.toml does not exist yet".into())
                } else {
                    match firmware::command(root, toolchain, task, &board, build, &[]) {
                        Some(cmd) => Action::Run(cmd),
                        None => continue,
                    }
                };
                firmware_stages.push(Stage { name, action });
            }
        }
    }

    let mut stages = vec![
        Stage {
            name: "fmt".into(),
            action: fmt,
        },
        Stage {
            name: "clippy".into(),
            action: Action::Run(cargo(
                root,
                &[
                    "clippy",
                    "--workspace",
                    "--all-targets",
                    "--",
                    "-D",
                    "warnings",
                ],
            )),
        },
        Stage {
            name: "unused dependencies (cargo machete: workspace and firmware)".into(),
            action: Action::Run({
                let mut cmd = Command::new(setup::CARGO_MACHETE.0);
                cmd.current_dir(root);
                cmd
            }),
        },
        Stage {
            name: "layering (cargo tree, sources)".into(),
            action: Action::Check(layering::check),
        },
        Stage {
            name: "references (cited files and sections exist)".into(),
            action: Action::Check(refs::check),
        },
        Stage {
            name: "host tests".into(),
            action: Action::Run(cargo(root, &["test", "--workspace"])),
        },
        Stage {
            name: "python client (pytest: layout, lockstep, JSBSim F-16)".into(),
            action: Action::Check(python::test_stage),
        },
        Stage {
            name: "solver no_std cross build".into(),
            action: Action::Run(toolchain.cargo(
                root,
                &[
                    "build",
                    "-p",
                    "solver-core",
                    "--no-default-features",
                    "--target",
                    TARGET,
                    "--release",
                ],
            )),
        },
        Stage {
            name: "protocol and controller no_std cross build".into(),
            action: Action::Run(toolchain.cargo(
                root,
                &[
                    "build",
                    "-p",
                    "decoy-link",
                    "-p",
                    "decoy-controller",
                    "--target",
                    TARGET,
                    "--release",
                ],
            )),
        },
    ];
    stages.extend(firmware_stages);
    stages
}

/// `cargo xtask test --list`: the stages and their commands, without running them
/// (nor setup: the toolchain is the one setup recorded).
fn list_stages(root: &Path) {
    let stages = stages(root, Toolchain::recorded(root));
    let total = stages.len();
    for (i, stage) in stages.into_iter().enumerate() {
        let what = match &stage.action {
            Action::Run(cmd) => process::display(cmd),
            Action::Check(_) => "(a check done by the xtask itself)".to_owned(),
            Action::Skip(reason) => format!("(skipped: {reason})"),
        };
        println!("stage {}/{total}: {}\n    {what}", i + 1, stage.name);
    }
}

/// `cargo xtask run`: the main job on the built-in reference system.
fn run(root: &Path) -> Result<()> {
    setup::setup(root, Scope::Host)?;
    let jobs = main_job()?;
    for (i, job) in jobs.iter().enumerate() {
        println!();
        println!("==> main job {}/{}: decoy {job}", i + 1, jobs.len());
        let args: Vec<&str> = DECOY
            .split_whitespace()
            .chain(job.split_whitespace())
            .collect();
        process::run(&mut cargo(root, &args))?;
    }
    Ok(())
}

/// One measuring run of `cargo xtask bless`: a HIL test that writes a section of
/// `crates/hil-tests/baselines.toml` when `DECOY_BLESS` is set.
struct Blessed {
    /// The section it writes (`--only NAME`).
    section: &'static str,
    /// The test target (`crates/hil-tests/tests/NAME.rs`).
    test: &'static str,
    /// The test filter that selects the measuring tests, if not all of them.
    filter: Option<&'static str>,
}

/// The measuring runs of `cargo xtask bless`, in order: each a test binary run
/// as the tests run (the harness's two threads, the envelope in its shards).
const BLESSED: &[Blessed] = &[
    Blessed {
        section: "step_cost",
        test: "step_cost",
        filter: None,
    },
    Blessed {
        section: "memory",
        test: "hil_link",
        filter: Some("ram_peak"),
    },
    Blessed {
        section: "panic_sites",
        test: "panic_free",
        filter: Some("frame_path"),
    },
    Blessed {
        section: "host_accuracy",
        test: "host_accuracy",
        filter: None,
    },
    Blessed {
        section: "envelope",
        test: "envelope",
        filter: None,
    },
];

/// `cargo xtask bless [--only NAME]...`: runs the measuring tests of [`BLESSED`]
/// (those of `only`, or all) with `DECOY_BLESS=1`, which write their sections
/// of `crates/hil-tests/baselines.toml` (each measurement still held to its
/// budget: one over it fails the run and is not written), then the baselines
/// test with `DECOY_BLESS=1`, which rewrites the documents' generated tables and
/// checks the file.
fn bless(root: &Path, only: &[String]) -> Result<()> {
    let command = std::iter::once("cargo xtask bless".to_owned())
        .chain(only.iter().map(|s| format!("--only {s}")))
        .collect::<Vec<String>>()
        .join(" ");
    let started = Instant::now();
    let runs = BLESSED
        .iter()
        .filter(|b| only.is_empty() || only.iter().any(|o| o == b.section));
    for run in runs {
        println!();
        println!("==> bless {} (tests/{}.rs)", run.section, run.test);
        let start = Instant::now();
        let mut args = vec!["test", "-p", "hil-tests", "--test", run.test];
        if let Some(filter) = run.filter {
            args.extend(["--", filter]);
        }
        let mut cmd = cargo(root, &args);
        cmd.env("DECOY_BLESS", "1")
            .env("DECOY_BLESS_COMMAND", &command);
        process::run(&mut cmd)?;
        println!(
            "<== {}: written in {:.1} s",
            run.section,
            start.elapsed().as_secs_f64()
        );
    }
    println!();
    println!("==> the documents' tables and the file's check (tests/baselines.rs)");
    let mut cmd = cargo(root, &["test", "-p", "hil-tests", "--test", "baselines"]);
    cmd.env("DECOY_BLESS", "1");
    process::run(&mut cmd)?;
    println!();
    println!(
        "blessed in {:.1} min: crates/hil-tests/baselines.toml and the tables of README.md and \
         firmware/README.md (review with `git diff`, commit with the change)",
        started.elapsed().as_secs_f64() / 60.0
    );
    Ok(())
}

/// The criterion run of `cargo xtask bench-report` (arguments after `cargo`).
const BENCH_WALL: &[&str] = &[
    "bench",
    "-p",
    "benches",
    "--bench",
    "rk4_step",
    "--",
    "--warm-up-time",
    "1",
    "--measurement-time",
    "3",
];

/// The gungraun run of `cargo xtask bench-report`: summaries saved as JSON.
const BENCH_INSTRUCTIONS: &[&str] = &[
    "bench",
    "-p",
    "benches",
    "--bench",
    "instructions",
    "--",
    "--save-summary=json",
];

/// The optional Pinocchio reference, relative to the root.
const PINOCCHIO_SCRIPT: &str = "crates/benches/pinocchio/aba_300.py";
/// Where its result line goes, relative to the root.
const PINOCCHIO_RESULT: &str = "target/bench-report/pinocchio.txt";
/// Time limit of the Pinocchio script.
const PINOCCHIO_TIMEOUT: Duration = Duration::from_secs(300);

/// The soak's default duration.
const SOAK_DURATION: &str = "10m";

/// `cargo xtask soak` (and the last stage of `cargo xtask bench-report`): builds
/// `decoy` (release), then runs `crates/host-bridge/examples/soak.rs` against
/// it for `duration`; the example writes `docs/soak.md` and `docs/soak.json`.
fn soak(root: &Path, duration: &str) -> Result<()> {
    println!();
    println!("==> bridge soak ({duration})");
    process::run(&mut cargo(
        root,
        &["build", "--release", "-p", "decoy-cli", "--bin", "decoy"],
    ))?;
    let decoy = root.join("target/release/decoy");
    let decoy = decoy.to_string_lossy();
    process::run(&mut cargo(
        root,
        &[
            "run",
            "--release",
            "-p",
            "host-bridge",
            "--example",
            "soak",
            "--",
            "--duration",
            duration,
            "--decoy",
            &decoy,
        ],
    ))
}

/// `cargo xtask bench-report`: setup (target toolchain and QEMU for the firmware,
/// `gungraun-runner` of the library's version), the criterion and gungraun
/// benchmarks, the optional Pinocchio reference (when `import pinocchio` works),
/// then the `bench_report` binary, which runs the firmware under QEMU for several
/// segment counts and writes `docs/benchmarks.md` and the scaling figure, and the
/// `host_steps` binary, which writes `docs/host-steps.md` (the host's adaptive
/// steps against fixed ones).
fn bench_report(root: &Path) -> Result<()> {
    setup::setup(root, Scope::Full)?;
    setup::gungraun_runner()?;

    // The report takes every result it finds and refuses unknown ones: results of
    // an earlier run (a renamed bench, say) must not be mixed with this run's.
    for dir in ["criterion", "gungraun"] {
        let stale = root.join("target").join(dir);
        if stale.exists() {
            std::fs::remove_dir_all(&stale).map_err(|e| {
                format!("cannot remove the earlier results {}: {e}", stale.display())
            })?;
            println!("removed the earlier results in {}", stale.display());
        }
    }

    println!();
    println!("==> wall clock (criterion)");
    process::run(&mut cargo(root, BENCH_WALL))?;
    println!();
    println!("==> instruction counts (gungraun)");
    process::run(&mut cargo(root, BENCH_INSTRUCTIONS))?;

    println!();
    println!("==> external reference (Pinocchio, optional)");
    let result = root.join(PINOCCHIO_RESULT);
    // A stale result must not be reported as this run's.
    let _ = std::fs::remove_file(&result);
    if process::succeeds(Command::new("python3").args(["-c", "import pinocchio"])) {
        let mut cmd = Command::new("python3");
        cmd.arg(PINOCCHIO_SCRIPT).current_dir(root);
        match process::output_with_timeout(&mut cmd, PINOCCHIO_TIMEOUT) {
            Ok(line) => {
                print!("{line}");
                if let Some(dir) = result.parent() {
                    std::fs::create_dir_all(dir)
                        .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
                }
                std::fs::write(&result, line)
                    .map_err(|e| format!("cannot write {}: {e}", result.display()))?;
            }
            Err(e) => println!("warning: the Pinocchio reference failed, not reported: {e}"),
        }
    } else {
        println!("skipped: the Python package `pin` is not installed (`pip install pin`)");
    }

    println!();
    println!("==> firmware under QEMU, report");
    process::run(&mut cargo(
        root,
        &[
            "run",
            "--release",
            "-p",
            "benches",
            "--bin",
            "bench_report",
            "--",
            "--pinocchio",
            PINOCCHIO_RESULT,
        ],
    ))?;

    println!();
    println!("==> host steps, adaptive against fixed (docs/host-steps.md)");
    process::run(&mut cargo(
        root,
        &["run", "--release", "-p", "benches", "--bin", "host_steps"],
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The main job's second trim flies exactly the configuration's embedded
    /// model; the first, the host model (no layout flags).
    #[test]
    fn the_second_trim_is_the_configured_embedded_model() {
        let jobs = main_job().unwrap();
        let flag = |job: &str, name: &str| -> Option<String> {
            let words: Vec<&str> = job.split_whitespace().collect();
            words
                .iter()
                .position(|w| *w == name)
                .map(|i| words[i + 1].to_owned())
        };
        let solver = decoy_config::SystemConfig::builtin().unwrap().solver;
        assert!(jobs[0].starts_with("trim ") && flag(&jobs[0], "--segments").is_none());
        assert!(jobs[1].starts_with("trim "));
        assert_eq!(
            flag(&jobs[1], "--segments")
                .unwrap()
                .parse::<usize>()
                .unwrap(),
            solver.segments_embedded
        );
        assert_eq!(
            flag(&jobs[1], "--grading").unwrap().parse::<f64>().unwrap(),
            solver.grading_ratio_embedded
        );
    }
}
