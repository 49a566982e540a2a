//! The Python environment of the bridge's Python client and the JSBSim F-16
//! example: `.venv/` at the repository root, made by `cargo xtask setup` and used
//! by the `python client (pytest)` test stage.
//!
//! What goes in: `clients/python/requirements.txt` (pinned: `iceoryx2` of the Rust
//! crate's version, `jsbsim`, `numpy`, `matplotlib`, `pytest`) and the client
//! package itself, editable (`pip install -e clients/python`). A stamp file in the
//! environment records the requirements it was made from, so a second setup only
//! checks that the packages import (about a second) and a changed requirements file
//! reinstalls.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use crate::process::{self, Result};

/// The environment's directory, relative to the root.
pub const VENV: &str = ".venv";
/// The client package, relative to the root.
pub const CLIENT: &str = "clients/python";
/// Its pinned requirements, relative to the root.
const REQUIREMENTS: &str = "clients/python/requirements.txt";
/// The record of what the environment was made from, relative to the environment.
const STAMP: &str = "decoy-setup.stamp";
/// Modules that must import for the environment to count as present.
const IMPORTS: &str = "import iceoryx2, jsbsim, numpy, matplotlib, pytest, decoy_bridge";
/// Time limit of one `pip install` (about 30 s with a warm cache, a few minutes cold).
const PIP_TIMEOUT: Duration = Duration::from_secs(900);

/// The environment's interpreter.
pub fn python(root: &Path) -> PathBuf {
    root.join(VENV).join("bin").join("python")
}

/// What [`ensure`] did.
pub enum Outcome {
    /// The environment was there and complete; the pinned packages.
    Present(String),
    /// It was made or completed now; the pinned packages.
    Installed(String),
}

/// Makes `.venv/` hold the pinned requirements and the client package, saying what
/// it found or installed.
pub fn ensure(root: &Path) -> Result<Outcome> {
    let requirements = fs::read_to_string(root.join(REQUIREMENTS))
        .map_err(|e| format!("cannot read {REQUIREMENTS}: {e}"))?;
    let pinned = pinned(&requirements);
    let venv = root.join(VENV);
    let python = python(root);
    let stamp = venv.join(STAMP);
    let stamp_matches = fs::read_to_string(&stamp).is_ok_and(|s| s == requirements);
    if stamp_matches && imports(root) {
        println!("found: Python environment {VENV}/ ({pinned}, client package `decoy_bridge`)");
        return Ok(Outcome::Present(pinned));
    }

    if !python.is_file() {
        let python3 = process::which("python3").ok_or(
            "python3 not found: install Python 3.10 or newer (Debian: apt-get install python3 python3-venv)",
        )?;
        println!("missing: Python environment {VENV}/; creating it with python3 -m venv");
        process::run(
            Command::new(python3)
                .args(["-m", "venv", VENV])
                .current_dir(root),
        )
        .map_err(|e| format!("{e} (on Debian the venv module is the package python3-venv)"))?;
    } else {
        println!("found: {VENV}/ but not the pinned packages; installing them");
    }
    process::run_with_timeout(
        Command::new(&python)
            .args([
                "-m",
                "pip",
                "install",
                "--quiet",
                "--disable-pip-version-check",
            ])
            .args(["-r", REQUIREMENTS, "-e", CLIENT])
            .current_dir(root),
        PIP_TIMEOUT,
    )
    .map_err(|e| format!("cannot install the Python packages (PyPI reachable?): {e}"))?;
    if !imports(root) {
        return Err(format!(
            "the Python environment was installed but `{IMPORTS}` fails in {VENV}/"
        ));
    }
    fs::write(&stamp, &requirements)
        .map_err(|e| format!("cannot write {}: {e}", stamp.display()))?;
    println!(
        "installed: Python environment {VENV}/ ({pinned}, client package `decoy_bridge` editable)"
    );
    Ok(Outcome::Installed(pinned))
}

/// Whether every module of [`IMPORTS`] imports in the environment.
fn imports(root: &Path) -> bool {
    let python = python(root);
    python.is_file()
        && process::succeeds(
            Command::new(&python)
                .args(["-c", IMPORTS])
                .current_dir(root),
        )
}

/// `name==version` lines of a requirements file, joined for the summary.
fn pinned(requirements: &str) -> String {
    requirements
        .lines()
        .map(|l| l.split('#').next().unwrap_or("").trim())
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join(", ")
}

/// The `python client (pytest)` test stage: the client's tests with the
/// environment's interpreter, against the `decoy` binary of this tree
/// (`target/debug/decoy`, built by the host tests stage; built here if missing).
/// pytest's exit 5 (no tests collected) is a failure with its own message.
pub fn test_stage(root: &Path) -> Result<()> {
    process::run(
        Command::new("cargo")
            .args(["build", "-p", "decoy-cli", "--bin", "decoy"])
            .current_dir(root),
    )?;
    let decoy = root.join("target").join("debug").join("decoy");
    let mut cmd = Command::new(python(root));
    cmd.args(["-m", "pytest", "-q", &format!("{CLIENT}/tests")])
        .env("DECOY_BIN", &decoy)
        .current_dir(root);
    println!("$ {}", process::display(&cmd));
    let status = cmd.status().map_err(|e| {
        format!(
            "cannot run {} (run `cargo xtask setup`): {e}",
            python(root).display()
        )
    })?;
    match status.code() {
        Some(0) => Ok(()),
        Some(5) => Err(format!(
            "pytest collected no tests in {CLIENT}/tests (exit 5): the Python tests are missing"
        )),
        _ => Err(format!("pytest failed ({status})")),
    }
}
