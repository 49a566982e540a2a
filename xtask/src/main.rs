//! Project automation, run as `cargo xtask <command>` from anywhere in the repo.
//!
//! - `setup`: install what the project needs (Rust target `thumbv7em-none-eabihf`,
//!   QEMU, the Python environment `.venv/`) and say what was found and what was
//!   installed.
//! - `test`: `setup`, then every test stage (fmt, clippy, host tests, the solver's
//!   no_std cross build, the firmware build), failing fast.
//! - `run`: the main job on the built-in reference system (see [`main_job`]).
//! - `bench-report`: run the benchmarks and write `docs/benchmarks.md` (see
//!   [`bench_report`]), then the bridge's soak.
//! - `soak`: the bridge's soak alone (see [`soak`]): `docs/soak.md`, `docs/soak.json`.
//! - `check-refs`: the references stage alone ([`refs`]): every repository file
//!   and section the text cites exists.

mod apt;
mod layering;
mod process;
mod python;
mod qemu;
mod refs;
mod setup;

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::{Duration, Instant};

use clap::{Parser, Subcommand};

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
    Test,
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
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let root = workspace_root();
    let result = match cli.command {
        Cmd::Setup => setup::setup(&root, Scope::Full).map(drop),
        Cmd::Test => test(&root),
        Cmd::Run => run(&root),
        Cmd::BenchReport => bench_report(&root).and_then(|()| soak(&root, SOAK_DURATION)),
        Cmd::Soak { duration } => soak(&root, &duration),
        Cmd::CheckRefs => refs::check(&root),
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

/// One test stage: a command to run, or the reason it is skipped.
struct Stage {
    name: &'static str,
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
                skipped.push(stage.name);
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

    let firmware_dir = root.join("firmware");
    let firmware_build = |args: &[&str]| {
        if firmware_dir.join("Cargo.toml").is_file() {
            let mut cmd = toolchain.cargo(&firmware_dir, args);
            let_directory_choose_toolchain(&mut cmd);
            Action::Run(cmd)
        } else {
            Action::Skip("firmware/Cargo.toml does not exist yet".into())
        }
    };
    let firmware = firmware_build(&["build", "--release"]);
    let firmware_clippy = firmware_build(&[
        "clippy",
        "--release",
        "--all-targets",
        "--",
        "-D",
        "warnings",
    ]);
    // The Cortex-M7 f64 profile (alias in firmware/.cargo/config.toml).
    let firmware_m7 = firmware_build(&["build-m7"]);
    // The STM32F405 (stm32f4xx-hal): the QEMU profile built (alias) and linted, and
    // the real part's configuration (PLL clocks, RTT logs) linted, each in the
    // target directory of its own that the alias and the HIL library use.
    let firmware_stm32f405 = firmware_build(&["build-stm32f405"]);
    let firmware_clippy_stm32f405 = firmware_build(&[
        "clippy",
        "--release",
        "--all-targets",
        "--no-default-features",
        "--features",
        "qemu,defmt-semihosting,board-stm32f405",
        "--target-dir",
        "target/stm32f405",
        "--",
        "-D",
        "warnings",
    ]);
    let firmware_clippy_stm32f405_hardware = firmware_build(&[
        "clippy",
        "--release",
        "--all-targets",
        "--no-default-features",
        "--features",
        "rtt,board-stm32f405",
        "--target-dir",
        "target/stm32f405-hw",
        "--",
        "-D",
        "warnings",
    ]);

    vec![
        Stage {
            name: "fmt",
            action: fmt,
        },
        Stage {
            name: "clippy",
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
            name: "unused dependencies (cargo machete: workspace and firmware)",
            action: Action::Run({
                let mut cmd = Command::new(setup::CARGO_MACHETE.0);
                cmd.current_dir(root);
                cmd
            }),
        },
        Stage {
            name: "layering (cargo tree, sources)",
            action: Action::Check(layering::check),
        },
        Stage {
            name: "references (cited files and sections exist)",
            action: Action::Check(refs::check),
        },
        Stage {
            name: "host tests",
            action: Action::Run(cargo(root, &["test", "--workspace"])),
        },
        Stage {
            name: "python client (pytest: layout, lockstep, JSBSim F-16)",
            action: Action::Check(python::test_stage),
        },
        Stage {
            name: "solver no_std cross build",
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
            name: "protocol and controller no_std cross build",
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
        Stage {
            name: "firmware build",
            action: firmware,
        },
        Stage {
            name: "firmware clippy",
            action: firmware_clippy,
        },
        Stage {
            name: "firmware build (Cortex-M7, f64)",
            action: firmware_m7,
        },
        Stage {
            name: "firmware build (STM32F405)",
            action: firmware_stm32f405,
        },
        Stage {
            name: "firmware clippy (STM32F405 under QEMU)",
            action: firmware_clippy_stm32f405,
        },
        Stage {
            name: "firmware clippy (STM32F405 hardware configuration)",
            action: firmware_clippy_stm32f405_hardware,
        },
    ]
}

/// Drops the toolchain rustup chose by default for `cargo xtask`, so that a
/// `rust-toolchain.toml` in the command's directory applies. An explicit choice
/// (`cargo +name xtask`, `RUSTUP_TOOLCHAIN=...`) is kept.
fn let_directory_choose_toolchain(cmd: &mut Command) {
    let source = std::env::var("RUSTUP_TOOLCHAIN_SOURCE").unwrap_or_default();
    if source.is_empty() || source == "default" {
        cmd.env_remove("RUSTUP_TOOLCHAIN")
            .env_remove("RUSTUP_TOOLCHAIN_SOURCE");
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
/// segment counts and writes `docs/benchmarks.md` and the scaling figure.
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
