//! `cargo xtask setup`: make the machine ready and say what was found and done.
//!
//! Target code (`thumbv7em-none-eabihf`) is built with the rustup toolchain when
//! `rustup target add` works. When it cannot download, the Debian compiler is
//! installed and linked as the rustup toolchain `debian`, and `core` is built from
//! source (docs/toolchain.md §1). The chosen mode is written to
//! `target/xtask-toolchain` (`rustup` or `debian`) for later tools.
//!
//! `XTASK_TOOLCHAIN=debian` forces the Debian fallback (to exercise it in CI).
//!
//! Packages are installed through `apt.rs`, which never removes one: every
//! install is simulated first and run with `--no-remove`. QEMU (`qemu.rs`):
//! the system's `qemu-system-arm`, of the installed QEMU packages' version when
//! Debian's candidate would remove one of them, and a second QEMU version for
//! comparison, unpacked privately under `target/qemu/`.

use std::fs;
use std::path::Path;
use std::process::Command;
use std::time::Duration;

use crate::apt::Apt;
use crate::process::{self, Result};
use crate::qemu;

/// The bare-metal target of the firmware and of the solver's no_std build
/// (every board's: `firmware/boards.toml`, crate `decoy-boards`).
pub use decoy_boards::TARGET;

/// Time limit of one `rustup target add` / `rustup component add` attempt.
const RUSTUP_TIMEOUT: Duration = Duration::from_secs(90);
/// Attempts of `rustup target add` before falling back (one once stalled > 60 s).
const RUSTUP_ATTEMPTS: u32 = 2;

/// Debian packages of the fallback cross toolchain.
const DEBIAN_TOOLCHAIN_PACKAGES: &[&str] = &[
    "rustc-web",
    "cargo-web",
    "rust-web-src",
    "binutils-arm-none-eabi",
];

/// Name under which the Debian compiler is linked into rustup.
const DEBIAN_TOOLCHAIN: &str = "debian";

/// `-Z` flags the Debian toolchain needs to build `core` for the target.
const BUILD_STD_FLAGS: &[&str] = &[
    "-Z",
    "build-std=core,compiler_builtins",
    "-Z",
    "build-std-features=compiler-builtins-mem",
];

/// Which compiler builds target code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Toolchain {
    /// The rustup toolchain with the prebuilt `thumbv7em-none-eabihf` standard library.
    Rustup,
    /// Debian's compiler (rustup toolchain `debian`), `core` built from source.
    Debian,
}

impl Toolchain {
    /// The mode `cargo xtask setup` recorded in `target/xtask-toolchain` under
    /// `root`; the rustup toolchain if setup has not run (it says so).
    pub fn recorded(root: &Path) -> Toolchain {
        let file = root.join("target").join("xtask-toolchain");
        match fs::read_to_string(&file) {
            Ok(mode) if mode.trim() == DEBIAN_TOOLCHAIN => Toolchain::Debian,
            Ok(_) => Toolchain::Rustup,
            Err(_) => {
                eprintln!(
                    "{} does not exist (`cargo xtask setup` writes it): using the rustup toolchain",
                    file.display()
                );
                Toolchain::Rustup
            }
        }
    }

    fn name(self) -> &'static str {
        match self {
            Toolchain::Rustup => "rustup",
            Toolchain::Debian => "debian",
        }
    }

    /// A `cargo` command for target code, run in `dir`, whose subcommand and
    /// arguments are `args`; the Debian mode adds `RUSTC_BOOTSTRAP=1` and the
    /// `-Z build-std` flags.
    pub fn cargo(self, dir: &Path, args: &[&str]) -> Command {
        let mut cmd = match self {
            Toolchain::Rustup => {
                let mut cmd = Command::new("cargo");
                cmd.args(args);
                cmd
            }
            Toolchain::Debian => {
                let mut cmd = Command::new("rustup");
                cmd.args(["run", DEBIAN_TOOLCHAIN, "cargo"])
                    .args(args)
                    .args(BUILD_STD_FLAGS)
                    .env("RUSTC_BOOTSTRAP", "1");
                cmd
            }
        };
        cmd.current_dir(dir);
        cmd
    }
}

/// How much of the machine to prepare.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scope {
    /// Host tools only (the main job needs neither the target nor QEMU).
    Host,
    /// Everything: lint components, the target toolchain and QEMU.
    Full,
}

/// What setup found and did, for the summary.
#[derive(Default)]
struct Report {
    installed: Vec<String>,
    present: Vec<String>,
    missing: Vec<String>,
}

/// First line of `<program> <args>`'s output, if it runs.
fn version(program: &str, args: &[&str]) -> Option<String> {
    let out = process::output(Command::new(program).args(args)).ok()?;
    out.lines().next().map(|l| l.trim().to_owned())
}

/// Prepares the machine for `scope`; returns the toolchain mode for target code
/// (`None` for [`Scope::Host`]).
pub fn setup(root: &Path, scope: Scope) -> Result<Option<Toolchain>> {
    println!("== setup ({})", root.display());
    let mut report = Report::default();
    let mut apt = Apt::default();

    let cargo = version("cargo", &["--version"])
        .ok_or("`cargo --version` does not run: is Rust installed (https://rustup.rs)?")?;
    println!("found: {cargo}");
    report.present.push("cargo".into());

    let toolchain = match scope {
        Scope::Host => {
            println!("host job: the target toolchain and QEMU are not needed");
            None
        }
        Scope::Full => {
            components(&mut report);
            let toolchain = target(root, &mut report, &mut apt)?;
            qemus(root, &mut report, &mut apt)?;
            defmt_print(&mut report)?;
            cargo_machete(&mut report)?;
            python_env(root, &mut report)?;
            Some(toolchain)
        }
    };

    let list = |v: &[String]| {
        if v.is_empty() {
            "nothing".to_owned()
        } else {
            v.join(", ")
        }
    };
    println!("installed: {}", list(&report.installed));
    println!("already present: {}", list(&report.present));
    if !report.missing.is_empty() {
        println!(
            "not available (stages needing them are skipped): {}",
            list(&report.missing)
        );
    }
    if let Some(tc) = toolchain {
        println!("target code toolchain: {}", tc.name());
    }
    Ok(toolchain)
}

/// The Python environment `.venv/` (the bridge's Python client, the solver's
/// package `decoy`, JSBSim, plots, pytest).
fn python_env(root: &Path, report: &mut Report) -> Result<()> {
    match crate::python::ensure(root)? {
        crate::python::Outcome::Present(holds) => {
            report.present.push(format!("Python .venv ({holds})"))
        }
        crate::python::Outcome::Installed(holds) => {
            report.installed.push(format!("Python .venv ({holds})"))
        }
    }
    Ok(())
}

/// rustfmt and clippy: try `rustup component add`; their absence is not fatal here
/// (`test` skips fmt without rustfmt, and the clippy stage reports its own failure).
fn components(report: &mut Report) {
    for (component, probe) in [("rustfmt", "fmt"), ("clippy", "clippy")] {
        if process::succeeds(Command::new("cargo").args([probe, "--version"])) {
            println!("found: {component}");
            report.present.push(component.into());
            continue;
        }
        println!("missing: {component}; installing it with rustup");
        let added = process::which("rustup").is_some()
            && process::run_with_timeout(
                Command::new("rustup").args(["component", "add", component]),
                RUSTUP_TIMEOUT,
            )
            .inspect_err(|e| println!("warning: {e}"))
            .is_ok();
        if added {
            report
                .installed
                .push(format!("{component} (rustup component)"));
        } else {
            println!(
                "warning: {component} is not available; install it with `rustup component add {component}`"
            );
            report.missing.push(component.into());
        }
    }
}

/// Makes `thumbv7em-none-eabihf` buildable; rustup first, Debian as fallback.
fn target(root: &Path, report: &mut Report, apt: &mut Apt) -> Result<Toolchain> {
    let forced = std::env::var("XTASK_TOOLCHAIN").is_ok_and(|v| v == "debian");
    let rustup = if forced {
        Err("XTASK_TOOLCHAIN=debian is set".to_owned())
    } else {
        rustup_target(report)
    };
    let toolchain = match rustup {
        Ok(()) => Toolchain::Rustup,
        Err(e) => {
            println!("rustup cannot provide {TARGET}: {e}");
            println!("falling back to the Debian toolchain (core built from source)");
            debian_toolchain(report, apt)?;
            Toolchain::Debian
        }
    };
    record(root, toolchain)?;
    Ok(toolchain)
}

fn rustup_target(report: &mut Report) -> Result<()> {
    if process::which("rustup").is_none() {
        return Err("rustup not found on PATH".into());
    }
    let installed =
        process::output(Command::new("rustup").args(["target", "list", "--installed"]))?;
    if installed.lines().any(|l| l.trim() == TARGET) {
        println!("found: Rust target {TARGET} (rustup)");
        report.present.push(format!("{TARGET} (rustup)"));
        return Ok(());
    }
    println!("missing: Rust target {TARGET}; installing it with rustup");
    let mut last = String::new();
    for attempt in 1..=RUSTUP_ATTEMPTS {
        match process::run_with_timeout(
            Command::new("rustup").args(["target", "add", TARGET]),
            RUSTUP_TIMEOUT,
        ) {
            Ok(()) => {
                report.installed.push(format!("{TARGET} (rustup)"));
                return Ok(());
            }
            Err(e) => {
                println!("attempt {attempt}/{RUSTUP_ATTEMPTS} failed: {e}");
                last = e;
            }
        }
    }
    Err(last)
}

fn debian_toolchain(report: &mut Report, apt: &mut Apt) -> Result<()> {
    let missing: Vec<&str> = DEBIAN_TOOLCHAIN_PACKAGES
        .iter()
        .copied()
        .filter(|p| !crate::apt::installed(p))
        .collect();
    for p in DEBIAN_TOOLCHAIN_PACKAGES
        .iter()
        .filter(|p| !missing.contains(p))
    {
        println!("found: Debian package {p}");
        report.present.push(format!("{p} (apt)"));
    }
    if !missing.is_empty() {
        println!(
            "missing: Debian packages {}; installing them",
            missing.join(" ")
        );
        apt.install(None, None, &missing)
            .map_err(|e| format!("cannot install the fallback toolchain: {e}"))?;
        report
            .installed
            .extend(missing.iter().map(|p| format!("{p} (apt)")));
    }

    let toolchains = process::output(Command::new("rustup").args(["toolchain", "list"]))?;
    let linked = toolchains
        .lines()
        .any(|l| l.split_whitespace().next() == Some(DEBIAN_TOOLCHAIN));
    if linked {
        println!("found: rustup toolchain `{DEBIAN_TOOLCHAIN}`");
        report
            .present
            .push(format!("rustup toolchain {DEBIAN_TOOLCHAIN}"));
    } else {
        process::run(Command::new("rustup").args(["toolchain", "link", DEBIAN_TOOLCHAIN, "/usr"]))?;
        report
            .installed
            .push(format!("rustup toolchain {DEBIAN_TOOLCHAIN} -> /usr"));
    }
    let rustc = process::output(Command::new("rustup").args([
        "run",
        DEBIAN_TOOLCHAIN,
        "rustc",
        "--version",
    ]))
    .map_err(|e| format!("the Debian toolchain does not run: {e}"))?;
    println!("using: {} (toolchain `{DEBIAN_TOOLCHAIN}`)", rustc.trim());
    Ok(())
}

/// Writes the chosen mode to `target/xtask-toolchain`.
fn record(root: &Path, toolchain: Toolchain) -> Result<()> {
    let dir = root.join("target");
    let file = dir.join("xtask-toolchain");
    fs::create_dir_all(&dir)
        .and_then(|()| fs::write(&file, format!("{}\n", toolchain.name())))
        .map_err(|e| format!("cannot write {}: {e}", file.display()))
}

/// The system's QEMU (installed without removing anything when missing) and a
/// second QEMU version for comparison, unpacked privately under `target/qemu/`
/// (see `qemu.rs`); a missing second version is reported, not fatal.
fn qemus(root: &Path, report: &mut Report, apt: &mut Apt) -> Result<()> {
    let (system, outcome) = qemu::system(apt)?;
    record_outcome(report, outcome);
    match qemu::comparison(root, &system, apt) {
        Ok(outcome) => record_outcome(report, outcome),
        Err(reason) => {
            println!(
                "warning: no second QEMU version for comparison: {reason} (the HIL tests' \
                 version comparison will skip, saying so)"
            );
            report
                .missing
                .push(format!("a second QEMU version for comparison ({reason})"));
        }
    }
    Ok(())
}

/// Prints and records what was found or done.
fn record_outcome(report: &mut Report, outcome: qemu::Outcome) {
    if outcome.installed {
        println!("installed: {}", outcome.detail);
        report.installed.push(outcome.item);
    } else {
        println!("found: {}", outcome.detail);
        report.present.push(outcome.item);
    }
}

/// The host decoder of the firmware's defmt log (crate and binary): the HIL tests
/// and `decoy hil` pipe QEMU's semihosting output through it.
pub const DEFMT_PRINT: &str = "defmt-print";

/// Time limit of a `cargo install` of a tool (defmt-print: about 2 to 4 minutes cold).
const INSTALL_TIMEOUT: Duration = Duration::from_secs(1800);

/// The unused-dependency checker the test stage runs: binary and crate.
pub const CARGO_MACHETE: (&str, &str) = ("cargo-machete", "cargo-machete@0.9.2");

/// Makes sure `defmt-print` runs, installing it with `cargo install defmt-print
/// --locked` when missing (and saying so).
fn defmt_print(report: &mut Report) -> Result<()> {
    cargo_tool(report, DEFMT_PRINT, DEFMT_PRINT, "about 3 minutes")
}

/// Makes sure `cargo-machete` runs (the unused-dependency stage of `test`).
fn cargo_machete(report: &mut Report) -> Result<()> {
    let (binary, krate) = CARGO_MACHETE;
    cargo_tool(report, binary, krate, "about 2 minutes")
}

/// Makes sure `binary --version` runs, installing `krate` with `cargo install
/// --locked` when it does not (and saying so).
fn cargo_tool(report: &mut Report, binary: &str, krate: &str, duration: &str) -> Result<()> {
    if let Some(v) = version(binary, &["--version"]) {
        println!("found: {v}");
        report.present.push(format!("{binary} (cargo install)"));
        return Ok(());
    }
    println!("missing: {binary}; installing it with `cargo install {krate} --locked` ({duration})");
    process::run_with_timeout(
        Command::new("cargo").args(["install", krate, "--locked"]),
        INSTALL_TIMEOUT,
    )
    .map_err(|e| format!("cannot install {binary}: {e}"))?;
    let now = version(binary, &["--version"]).ok_or_else(|| {
        format!("{binary} was installed but does not run (is ~/.cargo/bin on PATH?)")
    })?;
    println!("installed: {now}");
    report.installed.push(format!("{now} (cargo install)"));
    Ok(())
}

/// The gungraun benchmark runner: crate, version (must equal the `gungraun` library
/// version in `crates/benches/Cargo.toml`) and binary.
pub const GUNGRAUN_RUNNER: (&str, &str) = ("gungraun-runner", "0.20.0");

/// Time limit of `cargo install gungraun-runner` (about 6 minutes cold).
const GUNGRAUN_INSTALL_TIMEOUT: Duration = Duration::from_secs(1800);

/// Makes sure `gungraun-runner --version` reports [`GUNGRAUN_RUNNER`]'s version,
/// installing that version with `cargo install --locked` otherwise (and saying so).
pub fn gungraun_runner() -> Result<()> {
    let (krate, wanted) = GUNGRAUN_RUNNER;
    let found = version(krate, &["--version"]);
    let matches = found
        .as_deref()
        .is_some_and(|v| v.split_whitespace().nth(1) == Some(wanted));
    if matches {
        println!("found: {krate} {wanted}");
        return Ok(());
    }
    match &found {
        Some(other) => {
            println!("found `{other}`, need {krate} {wanted}; installing {krate}@{wanted}")
        }
        None => println!("missing: {krate}; installing {krate}@{wanted} (about 6 minutes)"),
    }
    process::run_with_timeout(
        Command::new("cargo").args(["install", &format!("{krate}@{wanted}"), "--locked"]),
        GUNGRAUN_INSTALL_TIMEOUT,
    )?;
    let now = version(krate, &["--version"]).ok_or_else(|| {
        format!("{krate} was installed but does not run (is ~/.cargo/bin on PATH?)")
    })?;
    println!("installed: {now}");
    Ok(())
}
