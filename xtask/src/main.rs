//! Project automation, run as `cargo xtask <command>` from anywhere in the repo.
//!
//! - `setup`: install what the project needs (Rust target `thumbv7em-none-eabihf`,
//!   QEMU) and say what was found and what was installed.
//! - `test`: `setup`, then every test stage (fmt, clippy, host tests, the solver's
//!   no_std cross build, the firmware build), failing fast.
//! - `run`: the main job on the built-in reference system (see [`MAIN_JOB`]).

mod process;
mod setup;

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::Instant;

use clap::{Parser, Subcommand};

use process::Result;
use setup::{Scope, TARGET, Toolchain};

/// The main job: `decoy` invocations on the built-in reference system, run in
/// order by `cargo xtask run`. Each entry is the command line after `decoy`,
/// split on whitespace (so no argument may contain a space).
const MAIN_JOB: &[&str] = &[
    "trim --altitude 9000 --mach 0.8",
    "trim --altitude 9000 --mach 0.8 --segments 16 --grading 1.3",
    "simulate --scenario acceleration --out out/acceleration",
];

/// How `cargo` runs the `decoy` binary; a [`MAIN_JOB`] entry is appended.
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
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let root = workspace_root();
    let result = match cli.command {
        Cmd::Setup => setup::setup(&root, Scope::Full).map(drop),
        Cmd::Test => test(&root),
        Cmd::Run => run(&root),
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
        let mut cmd = match stage.action {
            Action::Skip(reason) => {
                println!("<== {}: skipped ({reason})", stage.name);
                skipped.push(stage.name);
                continue;
            }
            Action::Run(cmd) => cmd,
        };
        let start = Instant::now();
        let outcome = process::run(&mut cmd);
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
    let firmware = if firmware_dir.join("Cargo.toml").is_file() {
        let mut cmd = toolchain.cargo(&firmware_dir, &["build", "--release"]);
        let_directory_choose_toolchain(&mut cmd);
        Action::Run(cmd)
    } else {
        Action::Skip("firmware/Cargo.toml does not exist yet".into())
    };

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
            name: "host tests",
            action: Action::Run(cargo(root, &["test", "--workspace"])),
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
            name: "firmware build",
            action: firmware,
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
    for (i, job) in MAIN_JOB.iter().enumerate() {
        println!();
        println!("==> main job {}/{}: decoy {job}", i + 1, MAIN_JOB.len());
        let args: Vec<&str> = DECOY
            .split_whitespace()
            .chain(job.split_whitespace())
            .collect();
        process::run(&mut cargo(root, &args))?;
    }
    Ok(())
}
