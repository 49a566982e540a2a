//! The Python environment: `.venv/` at the repository root, made by `cargo
//! xtask setup` and used by the `python client (pytest)` test stage.
//!
//! What goes in: `clients/python/requirements.txt` (pinned: `iceoryx2` of the Rust
//! crate's version, `jsbsim`, `numpy`, `matplotlib`, `pytest`, `maturin`, and
//! `ray` with its dependencies), the
//! bridge's client package (`pip install -e clients/python`), and the solver's
//! package `decoy` (`crates/decoy-py`): a wheel that maturin builds into the
//! workspace's `target/` with the host tests' profile, installed with pip.
//!
//! Two stamp files in the environment record what it was made from: the
//! requirements (a changed requirements file reinstalls them) and the solver's
//! sources (every workspace file of the extension's build, from cargo's
//! dependency list of it, with the manifests and the package's Python files,
//! by a hash of their contents: a changed source rebuilds and reinstalls the
//! wheel, in which cargo rebuilds only what changed). A second setup only
//! hashes those files and checks that the packages import (about a second).

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
const IMPORTS: &str =
    "import iceoryx2, zenoh, jsbsim, numpy, matplotlib, pytest, maturin, ray, decoy_bridge";
/// Time limit of one `pip install` (about 30 s with a warm cache, a few minutes cold).
const PIP_TIMEOUT: Duration = Duration::from_secs(900);
/// The solver's package (the crate `decoy-py`), relative to the root.
pub const SOLVER: &str = "crates/decoy-py";
/// Its Python files (the package beside the extension module), relative to the root.
const SOLVER_PYTHON: &str = "crates/decoy-py/python/decoy";
/// What must import for the solver's package to count as installed.
const SOLVER_IMPORT: &str = "import decoy; decoy.trim";
/// The record of the sources the installed solver was built from, relative to
/// the environment.
const SOLVER_STAMP: &str = "decoy-solver.stamp";
/// The cargo profile of the wheel: the host tests' (`dev`: opt-level 2, line
/// tables), so that the wheel and `cargo test --workspace` share every artifact
/// (a release build of the tree would cost minutes and gigabytes more). Rust's
/// f64 arithmetic is IEEE's at every optimisation level (no contraction into
/// fused multiply-adds), so the numbers are those of the release binary; the
/// bit-identity test (`clients/python/tests/test_solver.py`) compares them with
/// the command line's.
const SOLVER_PROFILE: &str = "dev";
/// Where the wheel is built, relative to the root (in the workspace's target
/// directory, beside the artifacts it shares).
const WHEELS: &str = "target/wheels";
/// Cargo's dependency list of the extension module (the profile's directory,
/// the library's name `_native`), relative to the root.
const SOLVER_DEP_INFO: &str = "target/debug/lib_native.d";
/// Files of the solver's build that cargo's list does not name, relative to
/// the root (the Python files are added from their directory).
const SOLVER_MANIFESTS: &[&str] = &[
    "Cargo.toml",
    "Cargo.lock",
    ".cargo/config.toml",
    "crates/decoy-py/pyproject.toml",
    "crates/decoy-py/pyo3-config.txt",
];
/// Time limit of the wheel's build (a few minutes from nothing on 2 cores).
const BUILD_TIMEOUT: Duration = Duration::from_secs(3600);

/// The environment's interpreter.
pub fn python(root: &Path) -> PathBuf {
    root.join(VENV).join("bin").join("python")
}

/// What [`ensure`] did.
pub enum Outcome {
    /// The environment was there and complete; what it holds.
    Present(String),
    /// It was made or completed now; what it holds and what was installed.
    Installed(String),
}

/// Makes `.venv/` hold the pinned requirements, the client package and the
/// solver's package built from the current sources, saying what it found or
/// installed.
pub fn ensure(root: &Path) -> Result<Outcome> {
    let requirements = fs::read_to_string(root.join(REQUIREMENTS))
        .map_err(|e| format!("cannot read {REQUIREMENTS}: {e}"))?;
    let pinned = pinned(&requirements);
    let mut installed = Vec::new();
    if !packages(root, &requirements)? {
        installed.push("the pinned packages, decoy_bridge editable");
    }
    if solver_current(root) {
        println!("found: the solver's package `decoy` in {VENV}/, built from the current sources");
    } else {
        install_solver(root)?;
        installed.push("the solver's package decoy");
    }
    let holds = format!("{pinned}, client package `decoy_bridge`, solver package `decoy`");
    Ok(if installed.is_empty() {
        Outcome::Present(holds)
    } else {
        Outcome::Installed(format!("{holds}; installed: {}", installed.join(", ")))
    })
}

/// Makes `.venv/` hold the pinned requirements and the client package; true
/// when they were there already.
fn packages(root: &Path, requirements: &str) -> Result<bool> {
    let pinned = pinned(requirements);
    let venv = root.join(VENV);
    let python = python(root);
    let stamp = venv.join(STAMP);
    let stamp_matches = fs::read_to_string(&stamp).is_ok_and(|s| s == requirements);
    if stamp_matches && imports(root) {
        println!("found: Python environment {VENV}/ ({pinned}, client package `decoy_bridge`)");
        return Ok(true);
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
    fs::write(&stamp, requirements)
        .map_err(|e| format!("cannot write {}: {e}", stamp.display()))?;
    println!(
        "installed: Python environment {VENV}/ ({pinned}, client package `decoy_bridge` editable)"
    );
    Ok(false)
}

/// Whether the installed solver package was built from the sources as they
/// are: its stamp's hash is that of the files it lists, and it imports.
fn solver_current(root: &Path) -> bool {
    let Ok(stamp) = fs::read_to_string(root.join(VENV).join(SOLVER_STAMP)) else {
        return false;
    };
    let mut lines = stamp.lines();
    let recorded = lines.next().unwrap_or_default();
    let files: Vec<String> = lines.map(str::to_owned).collect();
    recorded == fingerprint(root, &files) && imports_solver(root)
}

/// Builds the solver's wheel (maturin, the [`SOLVER_PROFILE`] profile, into
/// [`WHEELS`]), installs it, and stamps the sources it was built from.
fn install_solver(root: &Path) -> Result<()> {
    println!(
        "building: the solver's package `decoy` ({SOLVER}, profile {SOLVER_PROFILE}; a few minutes the first time)"
    );
    let wheels = root.join(WHEELS);
    // Only this build's wheel in the directory: the one to install.
    for old in decoy_wheels(&wheels) {
        fs::remove_file(&old).map_err(|e| format!("cannot remove {}: {e}", old.display()))?;
    }
    let python = python(root);
    process::run_with_timeout(
        Command::new(&python)
            .args(["-m", "maturin", "build", "--profile", SOLVER_PROFILE])
            .args(["--manifest-path", &format!("{SOLVER}/Cargo.toml")])
            .args(["--out", WHEELS])
            .arg("--interpreter")
            .arg(&python)
            // Installed here only: the platform's own tag, no manylinux audit.
            .args(["--compatibility", "linux"])
            .current_dir(root),
        BUILD_TIMEOUT,
    )
    .map_err(|e| format!("cannot build the solver's package: {e}"))?;
    let wheel = match decoy_wheels(&wheels).as_slice() {
        [one] => one.clone(),
        other => {
            return Err(format!(
                "expected one decoy wheel in {WHEELS}/ after the build, found {}",
                other.len()
            ));
        }
    };
    process::run_with_timeout(
        Command::new(&python)
            .args([
                "-m",
                "pip",
                "install",
                "--quiet",
                "--disable-pip-version-check",
            ])
            .args(["--no-deps", "--force-reinstall"])
            .arg(&wheel)
            .current_dir(root),
        PIP_TIMEOUT,
    )
    .map_err(|e| format!("cannot install {}: {e}", wheel.display()))?;
    if !imports_solver(root) {
        return Err(format!(
            "the solver's package was installed but `{SOLVER_IMPORT}` fails in {VENV}/"
        ));
    }
    let files = solver_sources(root)?;
    let stamp = root.join(VENV).join(SOLVER_STAMP);
    let mut text = fingerprint(root, &files);
    for file in &files {
        text.push('\n');
        text.push_str(file);
    }
    text.push('\n');
    fs::write(&stamp, text).map_err(|e| format!("cannot write {}: {e}", stamp.display()))?;
    let size = fs::metadata(&wheel).map_or(0, |m| m.len());
    println!(
        "installed: the solver's package `decoy` ({}, {:.1} MB)",
        wheel.display(),
        size as f64 / 1e6
    );
    Ok(())
}

/// The decoy wheels in `dir`.
fn decoy_wheels(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = fs::read_dir(dir) else {
        return Vec::new();
    };
    entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("decoy-") && n.ends_with(".whl"))
        })
        .collect()
}

/// The files the solver's package is built from, relative to the root where
/// they are inside it, sorted: the workspace files of cargo's dependency list
/// of the extension module (sources and the files they include), the
/// manifests of their crates, [`SOLVER_MANIFESTS`] and the package's Python
/// files.
fn solver_sources(root: &Path) -> Result<Vec<String>> {
    let dep_info = root.join(SOLVER_DEP_INFO);
    let text = fs::read_to_string(&dep_info).map_err(|e| {
        format!(
            "cannot read {} (cargo's dependency list of the build): {e}",
            dep_info.display()
        )
    })?;
    let relative = |path: &Path| -> String {
        path.strip_prefix(root)
            .unwrap_or(path)
            .to_string_lossy()
            .into_owned()
    };
    let mut files: Vec<String> = dep_info_paths(&text)
        .iter()
        .map(|p| relative(Path::new(p)))
        .collect();
    // The manifest of each crate whose files these are (`crates/NAME/...`).
    let crates: Vec<String> = files
        .iter()
        .filter_map(|f| {
            let mut parts = f.splitn(3, '/');
            match (parts.next(), parts.next(), parts.next()) {
                (Some(dir @ "crates"), Some(name), Some(_)) => {
                    Some(relative(&root.join(dir).join(name).join("Cargo.toml")))
                }
                _ => None,
            }
        })
        .collect();
    files.extend(crates);
    files.extend(SOLVER_MANIFESTS.iter().map(|f| (*f).to_owned()));
    let python = root.join(SOLVER_PYTHON);
    let entries =
        fs::read_dir(&python).map_err(|e| format!("cannot read {}: {e}", python.display()))?;
    for entry in entries {
        let path = entry
            .map_err(|e| format!("cannot read {}: {e}", python.display()))?
            .path();
        if path.is_file() {
            files.push(relative(&path));
        }
    }
    files.sort();
    files.dedup();
    Ok(files)
}

/// The prerequisites of a dep-info file's first rule (`target: dep dep ...`,
/// spaces in paths escaped with a backslash).
fn dep_info_paths(text: &str) -> Vec<String> {
    let rule = text.lines().next().unwrap_or_default();
    let Some((_, deps)) = rule.split_once(": ") else {
        return Vec::new();
    };
    let mut paths = Vec::new();
    let mut path = String::new();
    let mut chars = deps.chars();
    while let Some(c) = chars.next() {
        match c {
            '\\' => path.extend(chars.next()),
            ' ' => {
                if !path.is_empty() {
                    paths.push(std::mem::take(&mut path));
                }
            }
            c => path.push(c),
        }
    }
    if !path.is_empty() {
        paths.push(path);
    }
    paths
}

/// The hash (64-bit FNV-1a, hex) of `files`' names and contents (a missing
/// file hashes as such), relative to `root`.
fn fingerprint(root: &Path, files: &[String]) -> String {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    let mut add = |bytes: &[u8]| {
        for &b in bytes {
            hash ^= u64::from(b);
            hash = hash.wrapping_mul(0x0100_0000_01b3);
        }
    };
    for file in files {
        add(file.as_bytes());
        add(&[0]);
        match fs::read(root.join(file)) {
            Ok(contents) => {
                add(&(contents.len() as u64).to_le_bytes());
                add(&contents);
            }
            Err(_) => add(b"missing"),
        }
    }
    format!("{hash:016x}")
}

/// Whether the solver's package imports in the environment.
fn imports_solver(root: &Path) -> bool {
    let python = python(root);
    python.is_file()
        && process::succeeds(
            Command::new(&python)
                .args(["-c", SOLVER_IMPORT])
                .current_dir(root),
        )
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A dep-info rule's prerequisites, with an escaped space in a path.
    #[test]
    fn dep_info_lists_the_prerequisites() {
        let text = "/r/target/debug/lib_native.so: /r/crates/a/src/lib.rs /r/my\\ dir/x.toml /r/b.csv\n\n/r/crates/a/src/lib.rs:\n";
        assert_eq!(
            dep_info_paths(text),
            ["/r/crates/a/src/lib.rs", "/r/my dir/x.toml", "/r/b.csv"]
        );
        assert!(dep_info_paths("").is_empty());
    }

    /// The fingerprint changes with a file's contents, and with a file that
    /// goes missing, and not otherwise.
    #[test]
    fn the_fingerprint_follows_the_contents() {
        let dir = std::env::temp_dir().join(format!("xtask-fingerprint-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        fs::write(dir.join("a.rs"), "fn a() {}").unwrap();
        fs::write(dir.join("b.rs"), "fn b() {}").unwrap();
        let files = ["a.rs".to_owned(), "b.rs".to_owned()];
        let first = fingerprint(&dir, &files);
        assert_eq!(fingerprint(&dir, &files), first);
        fs::write(dir.join("b.rs"), "fn b() { }").unwrap();
        let changed = fingerprint(&dir, &files);
        assert_ne!(changed, first);
        fs::remove_file(dir.join("b.rs")).unwrap();
        assert_ne!(fingerprint(&dir, &files), changed);
        let _ = fs::remove_dir_all(&dir);
    }
}
