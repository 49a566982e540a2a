//! Running QEMU (or any program) with a time limit.
//!
//! A [`Supervised`] child is killed when its time is up and when it is dropped, so a
//! firmware that never exits, or a test that panics, leaves no QEMU behind. Its
//! stdout and stderr are read on threads, so a chatty child cannot block on a full
//! pipe.
//!
//! Which QEMU runs: [`Qemu::new`] takes `$DECOY_QEMU` ([`QEMU_ENV`]: a path, or a
//! name looked up on `PATH`) if it is set, else `qemu-system-arm` from `PATH`;
//! [`Qemu::program`] chooses another binary for one launcher. `cargo xtask
//! setup` unpacks a second QEMU version for comparison under the workspace's
//! [`COMPARISON_DIR`] (never installed system-wide), which
//! [`comparison_binaries`] lists; [`version_of`] reads a binary's version.

use std::ffi::{OsStr, OsString};
use std::fmt;
use std::io::{self, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

/// The QEMU binary for the Cortex-M boards.
pub const QEMU: &str = "qemu-system-arm";

/// The environment variable naming the QEMU binary to run instead of [`QEMU`]
/// from `PATH` (a path, or a name looked up on `PATH`); read by [`Qemu::new`]
/// (so by `decoy hil`, `decoy bridge --backend qemu`, the benches and the HIL
/// tests) and by the firmware's cargo runner (`firmware/qemu-run.sh`, `cargo xtask
/// firmware qemu-run`). Unset or empty: [`QEMU`].
pub const QEMU_ENV: &str = "DECOY_QEMU";

/// Where `cargo xtask setup` unpacks a second QEMU version for comparison,
/// relative to the workspace root: `target/qemu/<Debian version>/`, the
/// package's files as `dpkg-deb -x` lays them out, the binary in
/// [`COMPARISON_BINARY`] (xtask's `qemu.rs` writes the same layout).
pub const COMPARISON_DIR: &str = "target/qemu";

/// The binary within one version's directory under [`COMPARISON_DIR`].
pub const COMPARISON_BINARY: &str = "usr/bin/qemu-system-arm";

/// The file in [`COMPARISON_DIR`] where setup says why it could not provide a
/// second QEMU version (removed when it could).
pub const COMPARISON_UNAVAILABLE: &str = "unavailable.txt";

/// The QEMU binary [`Qemu::new`] runs: `$DECOY_QEMU` ([`QEMU_ENV`]) if set and
/// not empty, else [`QEMU`] (looked up on `PATH`).
pub fn default_program() -> PathBuf {
    match std::env::var_os(QEMU_ENV) {
        Some(program) if !program.is_empty() => PathBuf::from(program),
        _ => PathBuf::from(QEMU),
    }
}

/// The comparison binaries `cargo xtask setup` unpacked under `root` (the
/// workspace root): every `target/qemu/*/usr/bin/qemu-system-arm` that exists,
/// sorted by path.
pub fn comparison_binaries(root: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(root.join(COMPARISON_DIR)) else {
        return Vec::new();
    };
    let mut binaries: Vec<PathBuf> = entries
        .filter_map(|entry| entry.ok())
        .map(|entry| entry.path().join(COMPARISON_BINARY))
        .filter(|binary| binary.is_file())
        .collect();
    binaries.sort();
    binaries
}

/// Why `cargo xtask setup` could not provide a second QEMU version under `root`,
/// if it said so ([`COMPARISON_UNAVAILABLE`]).
pub fn comparison_unavailable(root: &Path) -> Option<String> {
    std::fs::read_to_string(root.join(COMPARISON_DIR).join(COMPARISON_UNAVAILABLE))
        .ok()
        .map(|reason| reason.trim().to_owned())
}

/// A QEMU binary and the version it reports.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct QemuVersion {
    /// The binary.
    pub program: PathBuf,
    /// The version number, `10.0.2` in "QEMU emulator version 10.0.2 (Debian ...)".
    pub version: String,
    /// The first line of `--version`, as printed.
    pub line: String,
}

impl QemuVersion {
    /// The major version (`10` for `10.0.2`), if the number starts with one.
    pub fn major(&self) -> Option<u32> {
        self.version.split('.').next()?.parse().ok()
    }
}

impl fmt::Display for QemuVersion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "QEMU {} ({})", self.version, self.program.display())
    }
}

/// Why a QEMU binary's version could not be read.
#[derive(Debug)]
pub enum VersionError {
    /// The binary could not be run (missing, or it timed out).
    Run(RunError),
    /// It ran and failed (a missing library, for example).
    Failed {
        /// The binary.
        program: PathBuf,
        /// What it printed.
        output: Captured,
    },
    /// Its first line is not "QEMU emulator version X.Y.Z ...".
    Unrecognised {
        /// The binary.
        program: PathBuf,
        /// The first line it printed.
        line: String,
    },
}

impl fmt::Display for VersionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            VersionError::Run(e) => write!(f, "reading the QEMU version: {e}"),
            VersionError::Failed { program, output } => write!(
                f,
                "`{} --version` failed\n{}",
                program.display(),
                output.describe()
            ),
            VersionError::Unrecognised { program, line } => write!(
                f,
                "`{} --version` printed `{line}`, not \"QEMU emulator version X.Y.Z\"",
                program.display()
            ),
        }
    }
}

impl std::error::Error for VersionError {}

/// Runs `program --version` and reads its version.
pub fn version_of(program: &Path) -> Result<QemuVersion, VersionError> {
    let output = run_with_timeout(
        Command::new(program).arg("--version"),
        Duration::from_secs(30),
        QEMU_MISSING_HINT,
    )
    .map_err(VersionError::Run)?;
    if !output.status.success() {
        return Err(VersionError::Failed {
            program: program.to_owned(),
            output,
        });
    }
    let line = output
        .stdout_text()
        .lines()
        .next()
        .unwrap_or_default()
        .trim()
        .to_owned();
    match parse_version(&line) {
        Some(version) => Ok(QemuVersion {
            program: program.to_owned(),
            version: version.to_owned(),
            line,
        }),
        None => Err(VersionError::Unrecognised {
            program: program.to_owned(),
            line,
        }),
    }
}

/// The version number in `--version`'s first line ("QEMU emulator version
/// 10.0.2 (Debian 1:10.0.2+ds-2+deb13u1~bpo12+1)" gives `10.0.2`).
fn parse_version(line: &str) -> Option<&str> {
    let version = line
        .strip_prefix("QEMU emulator version ")?
        .split_whitespace()
        .next()?;
    version
        .starts_with(|c: char| c.is_ascii_digit())
        .then_some(version)
}

/// The boards, each described once in `firmware/boards.toml` (crate
/// `decoy-boards`): [`Board::all`], [`Board::by_name`], [`Board::default`],
/// [`Board::with_precision`]; a board's QEMU machine arguments
/// (`Board::qemu_args`), Hello (`Board::info`), RAM budget (`Board::ram_budget`).
pub use decoy_boards::{Board, Precision, UnknownBoard};

/// No display or monitor; semihosting on (console and exit code to the host);
/// virtual time 1 ns per executed instruction, so SysTick counts instructions
/// deterministically: every board's QEMU arguments after its machine's
/// (`decoy_boards::QEMU_COMMON_ARGS`, which the cargo runner uses too).
pub const HEADLESS_ARGS: &[&str] = decoy_boards::QEMU_COMMON_ARGS;

/// Pause between polls of a running child.
const POLL: Duration = Duration::from_millis(5);

/// What went wrong running a program.
#[derive(Debug)]
pub enum RunError {
    /// The program is not installed (or not on `PATH`).
    NotFound {
        /// The program.
        program: String,
        /// What to do about it.
        hint: &'static str,
    },
    /// The program could not be started or watched.
    Io {
        /// The program.
        program: String,
        /// The underlying error.
        error: io::Error,
    },
    /// The program ran out of time and was killed.
    TimedOut {
        /// The program.
        program: String,
        /// The time limit.
        timeout: Duration,
        /// What it printed before it was killed.
        output: Captured,
    },
}

impl fmt::Display for RunError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RunError::NotFound { program, hint } => write!(f, "`{program}` not found: {hint}"),
            RunError::Io { program, error } => write!(f, "cannot run `{program}`: {error}"),
            RunError::TimedOut {
                program,
                timeout,
                output,
            } => write!(
                f,
                "`{program}` did not finish within {timeout:?} and was killed\n{}",
                output.describe()
            ),
        }
    }
}

impl std::error::Error for RunError {}

/// What a finished program printed, and how it ended.
#[derive(Clone, Debug)]
pub struct Captured {
    /// Exit status (for a killed program, the status after the kill).
    pub status: ExitStatus,
    /// Everything written to stdout.
    pub stdout: Vec<u8>,
    /// Everything written to stderr.
    pub stderr: Vec<u8>,
    /// Wall-clock time from spawn to exit.
    pub elapsed: Duration,
}

impl Captured {
    /// Stdout as text (invalid UTF-8 replaced).
    pub fn stdout_text(&self) -> String {
        String::from_utf8_lossy(&self.stdout).into_owned()
    }

    /// Stderr as text (invalid UTF-8 replaced).
    pub fn stderr_text(&self) -> String {
        String::from_utf8_lossy(&self.stderr).into_owned()
    }

    /// Status, stdout and stderr, for failure messages.
    pub fn describe(&self) -> String {
        format!(
            "status: {}\n--- stdout ---\n{}--- stderr ---\n{}",
            self.status,
            self.stdout_text(),
            self.stderr_text()
        )
    }
}

/// A running child with a deadline; killed on timeout and on drop.
pub struct Supervised {
    program: String,
    child: Child,
    started: Instant,
    timeout: Duration,
    stdout: Option<JoinHandle<Vec<u8>>>,
    stderr: Option<JoinHandle<Vec<u8>>>,
}

impl Supervised {
    /// Spawns `cmd` with stdout and stderr captured (stdin closed) and `timeout`
    /// to live. `hint` tells the user what to do if the program is missing.
    pub fn spawn(
        cmd: &mut Command,
        timeout: Duration,
        hint: &'static str,
    ) -> Result<Self, RunError> {
        Self::spawn_with_stdin(cmd, Stdio::null(), timeout, hint)
    }

    /// [`Supervised::spawn`] with `stdin` as the child's standard input (a file to
    /// feed it, for example).
    pub fn spawn_with_stdin(
        cmd: &mut Command,
        stdin: Stdio,
        timeout: Duration,
        hint: &'static str,
    ) -> Result<Self, RunError> {
        let program = cmd.get_program().to_string_lossy().into_owned();
        let mut child = cmd
            .stdin(stdin)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|error| match error.kind() {
                io::ErrorKind::NotFound => RunError::NotFound {
                    program: program.clone(),
                    hint,
                },
                _ => RunError::Io {
                    program: program.clone(),
                    error,
                },
            })?;
        let stdout = child.stdout.take().map(reader);
        let stderr = child.stderr.take().map(reader);
        Ok(Supervised {
            program,
            child,
            started: Instant::now(),
            timeout,
            stdout,
            stderr,
        })
    }

    /// The child's process id.
    pub fn id(&self) -> u32 {
        self.child.id()
    }

    /// Time left before the deadline.
    pub fn remaining(&self) -> Duration {
        self.timeout.saturating_sub(self.started.elapsed())
    }

    /// Waits for the child to exit, killing it at the deadline, and returns what it printed.
    pub fn wait(mut self) -> Result<Captured, RunError> {
        loop {
            let polled = self.child.try_wait();
            match polled {
                Ok(Some(status)) => return Ok(self.collect(status)),
                Ok(None) if self.started.elapsed() >= self.timeout => {
                    let status = self.kill().map_err(|error| self.io_error(error))?;
                    let output = self.collect(status);
                    return Err(RunError::TimedOut {
                        program: self.program.clone(),
                        timeout: self.timeout,
                        output,
                    });
                }
                Ok(None) => thread::sleep(POLL.min(self.remaining())),
                Err(error) => {
                    // Best effort: the error being reported is the first one.
                    let _ = self.kill();
                    return Err(self.io_error(error));
                }
            }
        }
    }

    /// Whether the child is still running (an error to watch it counts as not).
    pub fn is_running(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(None))
    }

    /// Kills the child if it still runs, and returns what it printed: for programs
    /// such as the firmware under QEMU that run until stopped.
    pub fn stop(mut self) -> Result<Captured, RunError> {
        let status = self.kill().map_err(|error| self.io_error(error))?;
        Ok(self.collect(status))
    }

    /// Kills the child (if still running) and reaps it. Only the child itself: the
    /// processes a killed `cargo` started (rustc) finish on their own.
    fn kill(&mut self) -> io::Result<ExitStatus> {
        // Killing a child that already exited fails harmlessly; `wait` reaps it either way.
        let _ = self.child.kill();
        self.child.wait()
    }

    fn io_error(&self, error: io::Error) -> RunError {
        RunError::Io {
            program: self.program.clone(),
            error,
        }
    }

    /// Joins the reader threads (their pipes close when the child exits).
    fn collect(&mut self, status: ExitStatus) -> Captured {
        let join =
            |h: Option<JoinHandle<Vec<u8>>>| h.and_then(|h| h.join().ok()).unwrap_or_default();
        Captured {
            status,
            stdout: join(self.stdout.take()),
            stderr: join(self.stderr.take()),
            elapsed: self.started.elapsed(),
        }
    }
}

impl Drop for Supervised {
    fn drop(&mut self) {
        if matches!(self.child.try_wait(), Ok(None)) {
            // Nothing to report from a destructor; the child is gone either way.
            let _ = self.kill();
        }
    }
}

/// Reads a pipe to its end on a thread.
fn reader<R: Read + Send + 'static>(mut pipe: R) -> JoinHandle<Vec<u8>> {
    thread::spawn(move || {
        let mut buf = Vec::new();
        // A read error ends the capture; what was read so far is kept.
        let _ = pipe.read_to_end(&mut buf);
        buf
    })
}

/// Runs `cmd` to completion within `timeout`, capturing its output.
pub fn run_with_timeout(
    cmd: &mut Command,
    timeout: Duration,
    hint: &'static str,
) -> Result<Captured, RunError> {
    Supervised::spawn(cmd, timeout, hint)?.wait()
}

/// What to tell the user when QEMU is missing.
pub const QEMU_MISSING_HINT: &str = "QEMU for Arm is not installed; run `cargo xtask setup` (it installs \
     qemu-system-arm), or check the binary `$DECOY_QEMU` names";

/// A QEMU invocation on the firmware's board.
#[derive(Clone, Debug)]
pub struct Qemu {
    program: PathBuf,
    board: Board,
    timeout: Duration,
    serial: OsString,
    extra: Vec<OsString>,
}

impl Default for Qemu {
    fn default() -> Self {
        Self::new()
    }
}

impl Qemu {
    /// The [`default_program`] (`$DECOY_QEMU`, else `qemu-system-arm` from
    /// `PATH`) on the default board ([`Board::default`]), 120 s time limit,
    /// UART0 unconnected.
    pub fn new() -> Self {
        Qemu {
            program: default_program(),
            board: Board::default(),
            timeout: Duration::from_secs(120),
            serial: OsString::from("none"),
            extra: Vec::new(),
        }
    }

    /// Sets the QEMU binary (a path, or a name looked up on `PATH`; default
    /// [`default_program`]).
    pub fn program(mut self, program: impl Into<PathBuf>) -> Self {
        self.program = program.into();
        self
    }

    /// The QEMU binary this launcher runs.
    pub fn get_program(&self) -> &Path {
        &self.program
    }

    /// Sets the board (default [`Board::default`]).
    pub fn board(mut self, board: Board) -> Self {
        self.board = board;
        self
    }

    /// The board this launcher boots.
    pub fn get_board(&self) -> Board {
        self.board
    }

    /// Sets the time limit of a run.
    pub fn timeout(mut self, timeout: Duration) -> Self {
        self.timeout = timeout;
        self
    }

    /// Connects UART0 (QEMU's `-serial` value, for example
    /// `tcp:127.0.0.1:PORT,nodelay=on`; default `none`).
    pub fn serial(mut self, spec: impl AsRef<OsStr>) -> Self {
        self.serial = spec.as_ref().to_owned();
        self
    }

    /// Appends further QEMU arguments.
    pub fn arg(mut self, arg: impl AsRef<OsStr>) -> Self {
        self.extra.push(arg.as_ref().to_owned());
        self
    }

    /// The command line that boots `elf`.
    pub fn command(&self, elf: &Path) -> Command {
        let mut cmd = Command::new(&self.program);
        cmd.args(self.board.qemu_args())
            .args(HEADLESS_ARGS)
            .arg("-serial")
            .arg(&self.serial)
            .args(&self.extra)
            .arg("-kernel")
            .arg(elf);
        cmd
    }

    /// Boots `elf` and leaves it running (for tests that talk to it while it runs).
    pub fn spawn(&self, elf: &Path) -> Result<Supervised, RunError> {
        Supervised::spawn(&mut self.command(elf), self.timeout, QEMU_MISSING_HINT)
    }

    /// Boots `elf` and waits for it to exit (through semihosting) or time out.
    pub fn run(&self, elf: &Path) -> Result<Captured, RunError> {
        self.spawn(elf)?.wait()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn board(name: &str) -> Board {
        Board::by_name(name).unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn every_board_has_its_own_name_machine_and_hello() {
        let all = Board::all();
        for (i, a) in all.iter().enumerate() {
            for b in &all[i + 1..] {
                assert_ne!(a.name(), b.name());
                assert_ne!(a.qemu_args(), b.qemu_args());
                assert_ne!(a.info().name, b.info().name);
            }
            assert_eq!(a.qemu_args()[0], "-M", "{a}");
        }
        // The Netduino Plus 2 fixes its CPU; the STM32F405 runs at 168 MHz.
        let stm32 = board("stm32f405");
        assert_eq!(stm32.qemu_args(), ["-M", "netduinoplus2"]);
        assert_eq!(stm32.info().core_clock_hz, 168_000_000);
        assert_eq!(stm32.info().name.as_str(), "stm32f405");
    }

    #[test]
    fn captures_output_and_status() {
        let out = run_with_timeout(
            Command::new("sh").args(["-c", "echo out; echo err >&2; exit 3"]),
            Duration::from_secs(10),
            "",
        )
        .unwrap();
        assert_eq!(out.stdout_text(), "out\n");
        assert_eq!(out.stderr_text(), "err\n");
        assert_eq!(out.status.code(), Some(3));
    }

    #[test]
    fn kills_on_timeout() {
        let started = Instant::now();
        let err = run_with_timeout(
            Command::new("sh").args(["-c", "echo before; exec sleep 30"]),
            Duration::from_millis(200),
            "",
        )
        .unwrap_err();
        assert!(started.elapsed() < Duration::from_secs(10));
        match err {
            RunError::TimedOut { output, .. } => assert_eq!(output.stdout_text(), "before\n"),
            other => panic!("expected a timeout, got {other}"),
        }
    }

    #[test]
    fn kills_on_drop() {
        let child = Supervised::spawn(Command::new("sleep").arg("30"), Duration::from_secs(60), "")
            .unwrap();
        let pid = child.id();
        drop(child);
        // The process is reaped by the drop: no /proc entry, or not our sleep any more.
        let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
        assert!(!cmdline.starts_with(b"sleep"), "pid {pid} still runs");
    }

    #[test]
    fn missing_program_says_what_to_do() {
        let err = run_with_timeout(
            &mut Command::new("definitely-not-installed-hil"),
            Duration::from_secs(1),
            "install it",
        )
        .unwrap_err();
        assert!(err.to_string().contains("install it"), "{err}");
    }

    #[test]
    fn qemu_command_line() {
        let cmd = Qemu::new().command(Path::new("fw.elf"));
        let args: Vec<_> = cmd
            .get_args()
            .map(|a| a.to_string_lossy().into_owned())
            .collect();
        let line = args.join(" ");
        assert!(line.starts_with("-M mps2-an386 -cpu cortex-m4"), "{line}");
        assert!(
            line.contains("-icount shift=0,align=off,sleep=off"),
            "{line}"
        );
        assert!(line.contains("-serial none"), "{line}");
        assert!(line.ends_with("-kernel fw.elf"), "{line}");
    }

    #[test]
    fn the_binary_can_be_chosen() {
        let qemu = Qemu::new()
            .program("/opt/qemu-7.2/bin/qemu-system-arm")
            .board(board("stm32f405"));
        assert_eq!(
            qemu.get_program(),
            Path::new("/opt/qemu-7.2/bin/qemu-system-arm")
        );
        assert_eq!(qemu.get_board(), board("stm32f405"));
        let cmd = qemu.command(Path::new("fw.elf"));
        assert_eq!(cmd.get_program(), "/opt/qemu-7.2/bin/qemu-system-arm");
        assert_eq!(cmd.get_args().next().unwrap(), "-M");
    }

    #[test]
    fn version_lines() {
        assert_eq!(
            parse_version("QEMU emulator version 10.0.2 (Debian 1:10.0.2+ds-2+deb13u1~bpo12+1)"),
            Some("10.0.2")
        );
        assert_eq!(
            parse_version("QEMU emulator version 7.2.22 (Debian 1:7.2+dfsg-7+deb12u18+b3)"),
            Some("7.2.22")
        );
        assert_eq!(parse_version("QEMU emulator version 9.1.0"), Some("9.1.0"));
        assert_eq!(parse_version("qemu-img version 10.0.2"), None);
        assert_eq!(parse_version("QEMU emulator version (none)"), None);
        let v = QemuVersion {
            program: PathBuf::from("qemu-system-arm"),
            version: "10.0.2".into(),
            line: String::new(),
        };
        assert_eq!(v.major(), Some(10));
    }

    #[test]
    fn a_binary_that_is_not_qemu_is_named() {
        let err = version_of(Path::new("/bin/true")).unwrap_err();
        assert!(matches!(err, VersionError::Unrecognised { .. }), "{err}");
        let err = version_of(Path::new("definitely-not-installed-qemu")).unwrap_err();
        assert!(err.to_string().contains("DECOY_QEMU"), "{err}");
    }

    #[test]
    fn comparison_copies_are_found_where_setup_puts_them() {
        let root = std::env::temp_dir().join(format!("decoy-hil-qemu-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        assert!(comparison_binaries(&root).is_empty());
        assert_eq!(comparison_unavailable(&root), None);
        let version = root.join(COMPARISON_DIR).join("7.2+dfsg-7+deb12u18+b3");
        std::fs::create_dir_all(version.join("usr/bin")).unwrap();
        std::fs::create_dir_all(root.join(COMPARISON_DIR).join("empty")).unwrap();
        std::fs::write(version.join(COMPARISON_BINARY), b"").unwrap();
        std::fs::write(
            root.join(COMPARISON_DIR).join(COMPARISON_UNAVAILABLE),
            "no apt-get\n",
        )
        .unwrap();
        assert_eq!(
            comparison_binaries(&root),
            [version.join(COMPARISON_BINARY)]
        );
        assert_eq!(comparison_unavailable(&root).as_deref(), Some("no apt-get"));
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn m7_board_and_tcp_serial() {
        let cmd = Qemu::new()
            .board(board("m7"))
            .serial("tcp:127.0.0.1:4567,nodelay=on")
            .command(Path::new("fw.elf"));
        let line = cmd
            .get_args()
            .map(|a| a.to_string_lossy().into_owned())
            .collect::<Vec<_>>()
            .join(" ");
        assert!(line.starts_with("-M mps2-an500 -cpu cortex-m7"), "{line}");
        assert!(
            line.contains("-serial tcp:127.0.0.1:4567,nodelay=on"),
            "{line}"
        );
        assert!(
            line.contains("-semihosting-config enable=on,target=native"),
            "{line}"
        );
    }

    #[test]
    fn stop_kills_a_running_child_and_keeps_its_output() {
        let mut child = Supervised::spawn(
            Command::new("sh").args(["-c", "echo up; exec sleep 30"]),
            Duration::from_secs(60),
            "",
        )
        .unwrap();
        thread::sleep(Duration::from_millis(200));
        assert!(child.is_running());
        let out = child.stop().unwrap();
        assert_eq!(out.stdout_text(), "up\n");
    }
}
