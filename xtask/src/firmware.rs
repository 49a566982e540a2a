//! The firmware, board by board, as `firmware/boards.toml` describes the boards
//! (crate `decoy-boards`):
//!
//! - the cargo commands of each board's builds ([`command`]): the test stages'
//!   firmware builds and lints, and `cargo xtask firmware build|clippy --board
//!   NAME`;
//! - `cargo xtask firmware run --board NAME`: the build, then the ELF under QEMU
//!   ([`boot`]);
//! - the cargo runner (`firmware/qemu-run.sh` runs `cargo xtask firmware
//!   qemu-run ELF`): the ELF under QEMU on the board its `_decoy_board_NAME`
//!   symbol names (or `$DECOY_BOARD`).
//!
//! Booting: QEMU (`$DECOY_QEMU`, else `qemu-system-arm` from `PATH`) with the
//! board's machine arguments and the arguments every board shares
//! (`decoy_boards::QEMU_COMMON_ARGS`: `-icount shift=0,align=off,sleep=off`, so
//! virtual time advances exactly 1 ns per executed instruction and SysTick counts
//! instructions deterministically; semihosting carries the defmt logs and the exit
//! code), UART0 (USART1 on the STM32F405) as the environment says, stopped after
//! `$QEMU_TIMEOUT` seconds (default 120), its defmt stream decoded by
//! `defmt-print -e ELF` unless `DEFMT_RAW=1`. Environment:
//!
//! - `DECOY_LINK_PORT`: the UART connects as a TCP client to 127.0.0.1:PORT,
//!   where the host must already listen (what the HIL tests and `decoy hil` do);
//! - `DECOY_LINK_LISTEN`: QEMU listens on 127.0.0.1:PORT and boots without
//!   waiting; connect any client that speaks docs/protocol.md;
//! - neither: the UART is not connected (the firmware boots, logs and idles).
//!
//! The exit code is QEMU's (the firmware's semihosting exit status on a failure;
//! 124 when the time limit stopped it), else `defmt-print`'s.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::thread;
use std::time::{Duration, Instant};

use decoy_boards::{BINARY, Board, BoardSpec, Build, QEMU_COMMON_ARGS, TARGET};

use crate::process::Result;
use crate::setup::Toolchain;

/// What a firmware command does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Task {
    /// `cargo build --release`.
    Build,
    /// `cargo clippy --release --all-targets ... -- -D warnings`.
    Clippy,
}

/// The firmware workspace.
pub fn dir(root: &Path) -> PathBuf {
    root.join("firmware")
}

/// The cargo arguments (after `cargo`) of `task` on `board`'s `build`, run in
/// `firmware/`, with `extra` cargo arguments (`--example NAME`, say); `None` if
/// the board has no such build.
pub fn cargo_args(
    task: Task,
    board: &BoardSpec,
    build: Build,
    extra: &[String],
) -> Option<Vec<String>> {
    let mut args: Vec<String> = match task {
        Task::Build => vec!["build".into(), "--release".into()],
        Task::Clippy => vec!["clippy".into(), "--release".into(), "--all-targets".into()],
    };
    args.extend(board.cargo_args(build)?);
    if let Some(subdir) = board.target_subdir(build) {
        args.extend(["--target-dir".to_owned(), subdir]);
    }
    args.extend(extra.iter().cloned());
    if task == Task::Clippy {
        args.extend(["--".into(), "-D".into(), "warnings".into()]);
    }
    Some(args)
}

/// The command of `task` on `board`'s `build` with `toolchain` (see
/// [`cargo_args`]); `None` if the board has no such build.
pub fn command(
    root: &Path,
    toolchain: Toolchain,
    task: Task,
    board: &BoardSpec,
    build: Build,
    extra: &[String],
) -> Option<Command> {
    let args = cargo_args(task, board, build, extra)?;
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let mut cmd = toolchain.cargo(&dir(root), &args);
    let_directory_choose_toolchain(&mut cmd);
    Some(cmd)
}

/// Drops the toolchain rustup chose by default for `cargo xtask`, so that a
/// `rust-toolchain.toml` in the command's directory applies. An explicit choice
/// (`cargo +name xtask`, `RUSTUP_TOOLCHAIN=...`) is kept.
pub fn let_directory_choose_toolchain(cmd: &mut Command) {
    let source = std::env::var("RUSTUP_TOOLCHAIN_SOURCE").unwrap_or_default();
    if source.is_empty() || source == "default" {
        cmd.env_remove("RUSTUP_TOOLCHAIN")
            .env_remove("RUSTUP_TOOLCHAIN_SOURCE");
    }
}

/// The ELF of `board`'s QEMU build (`firmware/target/[NAME/]thumbv7em-none-eabihf/release/decoy-firmware`).
pub fn elf(root: &Path, board: &BoardSpec) -> PathBuf {
    let target = match board.target_subdir(Build::Qemu) {
        Some(subdir) => dir(root).join(subdir),
        None => dir(root).join("target"),
    };
    target.join(TARGET).join("release").join(BINARY)
}

/// The board an ELF is booted on: `$DECOY_BOARD` (a name of the table) if set,
/// else the board its symbol names.
pub fn board_of(elf: &Path) -> Result<Board> {
    match std::env::var("DECOY_BOARD") {
        Ok(name) if !name.is_empty() => {
            Board::by_name(&name).map_err(|e| format!("DECOY_BOARD={name}: {e}"))
        }
        _ => Board::of_elf(elf)
            .map_err(|e| e.to_string())?
            .ok_or_else(|| {
                format!(
                    "{} names no board (no `{}NAME` symbol: built before the board table?): \
                 rebuild it, or set DECOY_BOARD to one of {}",
                    elf.display(),
                    decoy_boards::SYMBOL_PREFIX,
                    Board::names().join(", ")
                )
            }),
    }
}

/// The QEMU binary: `$DECOY_QEMU` if set, else `qemu-system-arm` from `PATH`.
fn qemu_program() -> (String, bool) {
    match std::env::var("DECOY_QEMU") {
        Ok(program) if !program.is_empty() => (program, true),
        _ => (crate::qemu::BINARY.to_owned(), false),
    }
}

/// QEMU's `-serial` value from the environment (see the module's documentation).
fn serial() -> Result<String> {
    let port = |var: &str| -> Result<Option<u16>> {
        match std::env::var(var) {
            Ok(text) if !text.is_empty() => text
                .parse()
                .map(Some)
                .map_err(|_| format!("{var}={text}: not a TCP port")),
            _ => Ok(None),
        }
    };
    Ok(
        match (port("DECOY_LINK_PORT")?, port("DECOY_LINK_LISTEN")?) {
            (Some(port), _) => format!("tcp:127.0.0.1:{port},nodelay=on"),
            (None, Some(port)) => format!("tcp:127.0.0.1:{port},server=on,wait=off,nodelay=on"),
            (None, None) => "null".to_owned(),
        },
    )
}

/// QEMU's time limit: `$QEMU_TIMEOUT` seconds, default 120.
fn time_limit() -> Result<Duration> {
    match std::env::var("QEMU_TIMEOUT") {
        Ok(text) if !text.is_empty() => text
            .parse()
            .map(Duration::from_secs)
            .map_err(|_| format!("QEMU_TIMEOUT={text}: not a number of seconds")),
        _ => Ok(Duration::from_secs(120)),
    }
}

/// The exit code of a process killed at its time limit (`timeout`'s).
const TIMED_OUT: u8 = 124;
/// The exit code when a program to run is missing (the shell's).
const MISSING: u8 = 127;

/// The exit code a status stands for (128 + the signal for a killed process).
fn code(status: ExitStatus) -> u8 {
    use std::os::unix::process::ExitStatusExt;
    match (status.code(), status.signal()) {
        (Some(code), _) => u8::try_from(code).unwrap_or(1),
        (None, Some(signal)) => u8::try_from(128 + signal).unwrap_or(1),
        (None, None) => 1,
    }
}

/// Boots `elf` under QEMU on `board` (see the module's documentation) and
/// returns the exit code.
pub fn boot(elf: &Path, board: Board) -> Result<u8> {
    let (program, chosen) = qemu_program();
    if crate::process::which(&program).is_none() && !Path::new(&program).is_file() {
        eprintln!(
            "{}",
            if chosen {
                format!("DECOY_QEMU={program}: no such QEMU binary")
            } else {
                format!("{program} not found: run `cargo xtask setup`")
            }
        );
        return Ok(MISSING);
    }
    let raw = std::env::var("DEFMT_RAW").is_ok_and(|v| v == "1");
    if !raw && crate::process::which("defmt-print").is_none() {
        eprintln!("defmt-print not found: cargo install defmt-print --locked (or DEFMT_RAW=1)");
        return Ok(MISSING);
    }
    let mut qemu = Command::new(&program);
    qemu.args(board.qemu_args())
        .args(QEMU_COMMON_ARGS)
        .arg("-serial")
        .arg(serial()?)
        .arg("-kernel")
        .arg(elf);
    if !raw {
        qemu.stdout(Stdio::piped());
    }
    eprintln!("{board}: $ {}", crate::process::display(&qemu));
    let mut qemu_child = qemu
        .spawn()
        .map_err(|e| format!("cannot start {program}: {e}"))?;
    let mut decoder = match qemu_child.stdout.take() {
        Some(stdout) => Some(
            Command::new("defmt-print")
                .arg("-e")
                .arg(elf)
                .stdin(Stdio::from(stdout))
                .spawn()
                .map_err(|e| format!("cannot start defmt-print: {e}"))?,
        ),
        None => None,
    };
    let qemu_code = wait_within(&mut qemu_child, time_limit()?)?;
    let decoder_code = match decoder.as_mut() {
        Some(child) => code(
            child
                .wait()
                .map_err(|e| format!("waiting for defmt-print: {e}"))?,
        ),
        None => 0,
    };
    // As a shell pipeline with `pipefail`: QEMU's failure first.
    Ok(if qemu_code != 0 {
        qemu_code
    } else {
        decoder_code
    })
}

/// Waits for `child` to exit, killing it at `limit` ([`TIMED_OUT`]).
fn wait_within(child: &mut Child, limit: Duration) -> Result<u8> {
    let started = Instant::now();
    loop {
        match child.try_wait() {
            Ok(Some(status)) => return Ok(code(status)),
            Ok(None) if started.elapsed() >= limit => {
                eprintln!("QEMU stopped after {} s (QEMU_TIMEOUT)", limit.as_secs());
                // It may have exited in the meantime; it is gone either way.
                let _ = child.kill();
                let _ = child.wait();
                return Ok(TIMED_OUT);
            }
            Ok(None) => thread::sleep(Duration::from_millis(20)),
            Err(e) => return Err(format!("waiting for QEMU: {e}")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strings(args: &[&str]) -> Vec<String> {
        args.iter().map(|&a| a.to_owned()).collect()
    }

    /// The test stages' commands, as they were before the board table (the same
    /// configurations in the same target directories), now from the table.
    #[test]
    fn the_commands_of_the_boards() {
        let table = decoy_boards::Table::builtin().unwrap();
        let m4 = table.get("m4").unwrap();
        assert_eq!(
            cargo_args(Task::Build, m4, Build::Qemu, &[]).unwrap(),
            strings(&[
                "build",
                "--release",
                "--no-default-features",
                "--features",
                "qemu,defmt-semihosting,board-mps2-an386"
            ])
        );
        let stm32 = table.get("stm32f405").unwrap();
        assert_eq!(
            cargo_args(Task::Clippy, stm32, Build::Hardware, &[]).unwrap(),
            strings(&[
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
                "warnings"
            ])
        );
        let m7 = table.get("m7").unwrap();
        assert_eq!(
            cargo_args(
                Task::Build,
                m7,
                Build::Qemu,
                &strings(&["--example", "step_cost"])
            )
            .unwrap(),
            strings(&[
                "build",
                "--release",
                "--no-default-features",
                "--features",
                "qemu,defmt-semihosting,board-mps2-an500,f64",
                "--config",
                "target.thumbv7em-none-eabihf.rustflags=[\"-C\", \"target-cpu=cortex-m7\"]",
                "--target-dir",
                "target/m7",
                "--example",
                "step_cost"
            ])
        );
        assert_eq!(cargo_args(Task::Build, m4, Build::Hardware, &[]), None);
        assert!(
            elf(Path::new("/r"), m7)
                .ends_with("firmware/target/m7/thumbv7em-none-eabihf/release/decoy-firmware")
        );
        assert!(
            elf(Path::new("/r"), m4)
                .ends_with("firmware/target/thumbv7em-none-eabihf/release/decoy-firmware")
        );
    }
}
