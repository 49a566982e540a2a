//! The layering the architecture promises (ARCHITECTURE.md, invariants), checked
//! on the real dependency graph with `cargo tree`, and on the sources:
//!
//! - `decoy-link` (the protocol) depends on nothing of the solver;
//! - `bridge-types` (the host bridge's wire types) depends on nothing of the
//!   solver, the protocol or the controller;
//! - both may depend on `decoy-schema`, the shared vocabulary (the manoeuvres,
//!   ...), which depends on serde only: were it to reach the solver, the two
//!   checks above would fail through it;
//! - no crate depends on `hil-tests` (tests only; the library is `decoy-hil`);
//! - no `#[path]` includes anywhere in the sources.

use std::fs;
use std::path::Path;
use std::process::Command;

use crate::process::Result;

/// Crates the protocol must not reach.
const NOT_IN_THE_PROTOCOL: &[&str] = &["solver-core", "nalgebra", "decoy-controller", "libm"];

/// Crates the bridge's wire types must not reach (any language mirrors them).
const NOT_IN_THE_WIRE_TYPES: &[&str] = &[
    "solver-core",
    "nalgebra",
    "libm",
    "decoy-link",
    "decoy-controller",
    "decoy-config",
    "decoy-sim",
    "decoy-hil",
    "host-bridge",
];

/// Source folders searched for `#[path]`.
const SOURCES: &[&str] = &["crates", "firmware/src", "firmware/examples", "xtask/src"];

/// Runs every check; the error lists every violation.
pub fn check(root: &Path) -> Result<()> {
    let mut violations = Vec::new();

    let protocol = cargo_tree(root, &["-p", "decoy-link", "-e", "normal"])?;
    for name in NOT_IN_THE_PROTOCOL {
        if protocol
            .lines()
            .any(|l| l.split_whitespace().next() == Some(name))
        {
            violations.push(format!("decoy-link (the protocol) depends on {name}"));
        }
    }

    let wire = cargo_tree(root, &["-p", "bridge-types", "-e", "normal"])?;
    for name in NOT_IN_THE_WIRE_TYPES {
        if wire
            .lines()
            .any(|l| l.split_whitespace().next() == Some(name))
        {
            violations.push(format!("bridge-types (the wire types) depends on {name}"));
        }
    }

    let dependents = cargo_tree(
        root,
        &["-i", "hil-tests", "-e", "normal,build", "--workspace"],
    )?;
    for line in dependents.lines().skip(1).filter(|l| !l.trim().is_empty()) {
        violations.push(format!(
            "{} depends on the test crate hil-tests",
            line.trim()
        ));
    }

    for dir in SOURCES {
        path_includes(&root.join(dir), &mut violations)?;
    }

    if violations.is_empty() {
        println!(
            "layering: decoy-link and bridge-types free of the solver, nothing depends on hil-tests, no #[path]"
        );
        Ok(())
    } else {
        Err(format!("layering violated:\n  {}", violations.join("\n  ")))
    }
}

/// `cargo tree --prefix none` with `args`, in `root`'s workspace.
fn cargo_tree(root: &Path, args: &[&str]) -> Result<String> {
    let out = Command::new("cargo")
        .arg("tree")
        .args(args)
        .args(["--prefix", "none"])
        .current_dir(root)
        .output()
        .map_err(|e| format!("cannot run cargo tree: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "cargo tree {} failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// Every `.rs` file under `dir` (but `target/`) with a `#[path` attribute.
fn path_includes(dir: &Path, violations: &mut Vec<String>) -> Result<()> {
    let entries = match fs::read_dir(dir) {
        Ok(entries) => entries,
        Err(_) => return Ok(()),
    };
    for entry in entries {
        let path = entry.map_err(|e| e.to_string())?.path();
        if path.is_dir() {
            if path.file_name().is_some_and(|n| n != "target") {
                path_includes(&path, violations)?;
            }
        } else if path.extension().is_some_and(|e| e == "rs") {
            let text = fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
            if text.lines().any(|l| l.trim_start().starts_with("#[path")) {
                violations.push(format!("{} includes a file by #[path]", path.display()));
            }
        }
    }
    Ok(())
}
