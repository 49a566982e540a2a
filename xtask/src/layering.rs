//! The layering the architecture promises (ARCHITECTURE.md, invariants), checked
//! on the real dependency graph with `cargo tree`, and on the sources:
//!
//! - `decoy-link` (the protocol) depends on nothing of the solver;
//! - `bridge-types` (the host bridge's wire types) depends on nothing of the
//!   solver, the protocol or the controller;
//! - both may depend on `decoy-schema`, the shared vocabulary (the manoeuvres,
//!   ...), which depends on serde only: were it to reach the solver, the two
//!   checks above would fail through it;
//! - `host-bridge` (the bridge's server and client) reaches nothing of the
//!   scenarios, the firmware's build, QEMU, the streamed runs or the plotting,
//!   so that a Rust client of a bridge compiles none of it;
//! - `decoy-sim` (one run of a scenario) reaches neither the studies
//!   (`decoy-studies`), the streamed runs (`decoy-stream`) nor the firmware in
//!   the loop (`decoy-hil`), and `decoy-hil` neither the streamed runs nor the
//!   bridge;
//! - no crate depends on `hil-tests` (tests only; the library is `decoy-hil`) or
//!   on `bridge-local` (a bridge on a thread for tests, benchmarks and examples)
//!   but as a dev-dependency;
//! - no `#[path]` includes anywhere in the sources;
//! - no file cycles: in every crate of the workspace and the firmware, the
//!   files' dependencies through `crate::`, `super::` and `self::` paths form no
//!   ring ([`crate::modules`]).

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

/// The packages checked for file cycles beside every one under `crates/`.
const PACKAGES: &[&str] = &["xtask", "firmware"];

/// Crates that must not reach others (normal dependencies): the crate, and
/// what it must not reach, with why.
const NOT_REACHED: &[(&str, &[&str], &str)] = &[
    (
        "host-bridge",
        &[
            "decoy-sim",
            "decoy-hil",
            "decoy-stream",
            "decoy-studies",
            "decoy-plots",
            "plotters",
            "bridge-local",
        ],
        "the bridge's server and client",
    ),
    (
        "decoy-sim",
        &["decoy-studies", "decoy-stream", "decoy-hil", "host-bridge"],
        "one run of a scenario",
    ),
    (
        "decoy-hil",
        &["decoy-stream", "decoy-studies", "host-bridge"],
        "the firmware in the loop",
    ),
];

/// Crates that only tests, benchmarks and examples use (nothing depends on them
/// but as a dev-dependency).
const DEV_ONLY: &[&str] = &["hil-tests", "bridge-local"];

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

    for (krate, forbidden, role) in NOT_REACHED {
        let tree = cargo_tree(root, &["-p", krate, "-e", "normal"])?;
        for name in *forbidden {
            if tree
                .lines()
                .any(|l| l.split_whitespace().next() == Some(name))
            {
                violations.push(format!("{krate} ({role}) depends on {name}"));
            }
        }
    }

    for krate in DEV_ONLY {
        let dependents = cargo_tree(root, &["-i", krate, "-e", "normal,build", "--workspace"])?;
        for line in dependents.lines().skip(1).filter(|l| !l.trim().is_empty()) {
            violations.push(format!(
                "{} depends on {krate}, which only tests, benchmarks and examples may use",
                line.trim()
            ));
        }
    }

    for dir in SOURCES {
        path_includes(&root.join(dir), &mut violations)?;
    }

    let mut crates = 0;
    for package in packages(root)? {
        for crate_root in crate::modules::crate_roots(&package) {
            crates += 1;
            let graph = crate::modules::Graph::of_crate(&crate_root)?;
            for cycle in graph.cycles() {
                let files: Vec<String> = cycle
                    .iter()
                    .map(|p| p.strip_prefix(root).unwrap_or(p).display().to_string())
                    .collect();
                violations.push(format!("a file cycle: {}", files.join(" <-> ")));
            }
        }
    }

    if violations.is_empty() {
        println!(
            "layering: decoy-link and bridge-types free of the solver, host-bridge free of the runs and the firmware, decoy-sim of the studies, hil-tests and bridge-local dev-only, no #[path], no file cycle in {crates} crates"
        );
        Ok(())
    } else {
        Err(format!("layering violated:\n  {}", violations.join("\n  ")))
    }
}

/// The package directories whose crates are checked for file cycles.
fn packages(root: &Path) -> Result<Vec<std::path::PathBuf>> {
    let mut found = Vec::new();
    let crates = root.join("crates");
    let entries =
        fs::read_dir(&crates).map_err(|e| format!("cannot list {}: {e}", crates.display()))?;
    for entry in entries {
        let path = entry.map_err(|e| e.to_string())?.path();
        if path.join("src").is_dir() {
            found.push(path);
        }
    }
    found.sort();
    found.extend(PACKAGES.iter().map(|p| root.join(p)));
    Ok(found)
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
