//! The results of one run: criterion's and gungraun's JSON results, their check
//! against the expected benchmark names, and everything else the report shows.

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};

/// Criterion medians, ns, keyed `group/function/value` (criterion's `full_id`, e.g.
/// `pendulum_rk4_step/f64/300`).
pub type WallClock = BTreeMap<String, f64>;
/// Instruction counts keyed `group/function/id` (e.g. `steps/pendulum_f64/n300`).
pub type Instructions = BTreeMap<String, u64>;

/// Every file under `dir` (recursively) for which `wanted` is true.
fn files_under(dir: &Path, wanted: impl Fn(&Path) -> bool) -> Result<Vec<PathBuf>, String> {
    let mut files = Vec::new();
    let mut pending = vec![dir.to_path_buf()];
    while let Some(current) = pending.pop() {
        let entries = fs::read_dir(&current)
            .map_err(|e| format!("cannot read {}: {e}", current.display()))?;
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                pending.push(path);
            } else if wanted(&path) {
                files.push(path);
            }
        }
    }
    Ok(files)
}

/// Reads every `new/benchmark.json` + `new/estimates.json` pair under `dir`
/// (criterion's output directory) into median times.
pub fn read_criterion(dir: &Path) -> Result<WallClock, String> {
    let mut out = WallClock::new();
    let benchmarks = files_under(dir, |path| {
        let in_new = path
            .parent()
            .and_then(Path::file_name)
            .is_some_and(|name| name == "new");
        in_new && path.file_name().is_some_and(|n| n == "benchmark.json")
    })?;
    for path in benchmarks {
        let id = json_file(&path)?;
        let id = id["full_id"]
            .as_str()
            .ok_or_else(|| format!("{}: no `full_id`", path.display()))?
            .to_owned();
        let estimates_path = path.with_file_name("estimates.json");
        let estimates = json_file(&estimates_path)?;
        let median = estimates["median"]["point_estimate"]
            .as_f64()
            .ok_or_else(|| format!("{}: no median", estimates_path.display()))?;
        out.insert(id, median);
    }
    Ok(out)
}

/// Reads every `summary.json` under `dir` (gungraun's output directory) into
/// instruction counts (callgrind's `Ir`, total over the run's parts).
pub fn read_gungraun(dir: &Path) -> Result<Instructions, String> {
    let mut out = Instructions::new();
    for path in files_under(dir, |path| {
        path.file_name().is_some_and(|n| n == "summary.json")
    })? {
        let (key, count) = parse_gungraun_summary(&json_file(&path)?)
            .map_err(|e| format!("{}: {e}", path.display()))?;
        out.insert(key, count);
    }
    Ok(out)
}

/// The key (`group/function/id`) and callgrind instruction count of one gungraun
/// `summary.json`.
pub fn parse_gungraun_summary(summary: &serde_json::Value) -> Result<(String, u64), String> {
    let field = |name: &str| {
        summary[name]
            .as_str()
            .ok_or_else(|| format!("no `{name}`"))
            .map(str::to_owned)
    };
    let key = format!(
        "{}/{}/{}",
        field("group")?,
        field("function_name")?,
        field("id")?
    );
    let profiles = summary["profiles"]
        .as_array()
        .ok_or("no `profiles` array")?;
    let callgrind = profiles
        .iter()
        .find(|p| p["tool"] == "Callgrind")
        .ok_or("no Callgrind profile")?;
    let count = callgrind["data"]["total"]["metrics"]["Ir"]["values"]["new"]
        .as_u64()
        .ok_or("no `Ir` count in the Callgrind profile")?;
    Ok((key, count))
}

pub(super) fn json_file(path: &Path) -> Result<serde_json::Value, String> {
    let text =
        fs::read_to_string(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))
}

/// The results the report expects and did not get, and the results it got and does
/// not know (a renamed benchmark shows up in both), for [`check_complete`].
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Incomplete {
    /// Expected keys (criterion, then gungraun) without a result.
    pub missing: Vec<String>,
    /// Result keys that no table reads.
    pub unknown: Vec<String>,
}

impl std::fmt::Display for Incomplete {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the benchmark results do not match the report's names \
             (crates/benches/src/names.rs): missing {:?}; unknown {:?} (an unknown result \
             can be a stale one of a renamed benchmark: remove target/criterion and \
             target/gungraun and rerun)",
            self.missing, self.unknown
        )
    }
}

/// Checks that the criterion and gungraun results hold exactly the keys the report
/// reads ([`crate::names::expected_wall_keys`],
/// [`crate::names::expected_instruction_keys`]). `bench-report` refuses to write
/// the document otherwise, so that no cell silently reads "n/a".
pub fn check_complete(wall: &WallClock, instructions: &Instructions) -> Result<(), Incomplete> {
    let mut incomplete = Incomplete::default();
    for (expected, present) in [
        (
            crate::names::expected_wall_keys(),
            wall.keys().collect::<Vec<_>>(),
        ),
        (
            crate::names::expected_instruction_keys(),
            instructions.keys().collect(),
        ),
    ] {
        incomplete.missing.extend(
            expected
                .iter()
                .filter(|key| !present.contains(key))
                .cloned(),
        );
        incomplete.unknown.extend(
            present
                .into_iter()
                .filter(|key| !expected.contains(key))
                .cloned(),
        );
    }
    if incomplete == Incomplete::default() {
        Ok(())
    } else {
        Err(incomplete)
    }
}

/// The machine the numbers come from.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Machine {
    /// CPU model (`/proc/cpuinfo`).
    pub cpu: String,
    /// Logical CPUs.
    pub cores: usize,
    /// Operating system (`/etc/os-release`).
    pub os: String,
    /// `rustc --version`.
    pub rustc: String,
    /// `valgrind --version`.
    pub valgrind: String,
    /// `qemu-system-arm --version`, first line.
    pub qemu: String,
}

/// The firmware measured with one segment count.
#[derive(Clone, Debug, PartialEq)]
pub struct FirmwareRow {
    /// Graded segments of the model.
    pub segments: usize,
    /// Their grading ratio (segment length ratio, short at the decoy).
    pub grading: f64,
    /// The counts, or why there are none.
    pub outcome: Result<FirmwareCounts, String>,
}

/// Instruction counts of one firmware run over the decoy link (10 ms frames).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FirmwareCounts {
    /// Whole control step (one frame: validation, RK4 steps, outputs), max.
    pub frame_max: u64,
    /// Whole control step, mean.
    pub frame_mean: u64,
    /// Fewest and most RK4 steps a frame took (docs/protocol.md §5).
    pub rk4_steps: (u16, u16),
    /// The solver's instructions per RK4 step (`step_instructions / steps`) over
    /// the frames with the fewest steps (none of them retried), max.
    pub rk4_step_max: u64,
    /// The same, mean.
    pub rk4_step_mean: u64,
}

/// Everything the report shows.
#[derive(Clone, Debug, PartialEq)]
pub struct Inputs {
    /// The machine.
    pub machine: Machine,
    /// Criterion medians.
    pub wall: WallClock,
    /// Gungraun instruction counts.
    pub instructions: Instructions,
    /// Firmware runs on the Cortex-M4F (QEMU mps2-an386), f32, by segment count.
    pub firmware: Vec<FirmwareRow>,
    /// Firmware runs on the Cortex-M7 (QEMU mps2-an500), f64, by segment count
    /// (empty: rendered as not measured).
    pub firmware_m7: Vec<FirmwareRow>,
    /// One RK4 step on the Cortex-M4F, f32, the embedded model
    /// (`firmware/examples/step_cost.rs`), or why it was not measured.
    pub step_cost: Result<decoy_hil::step_cost::StepCost, String>,
    /// The same on the Cortex-M7, f64.
    pub step_cost_m7: Result<decoy_hil::step_cost::StepCost, String>,
    /// The Pinocchio reference: its result line, or why there is none.
    pub pinocchio: Result<String, String>,
    /// The envelope sweep, per board (empty: not run).
    pub envelope: Vec<super::EnvelopeBoard>,
    /// The configuration's embedded model, `(solver.segments_embedded,
    /// solver.grading_ratio_embedded)`: the firmware row the targets read, and how
    /// the text names the model.
    pub embedded: (usize, f64),
}

impl Default for Inputs {
    /// No results at all; the Pinocchio reference "not run"; the built-in
    /// configuration's embedded model.
    fn default() -> Self {
        let solver = decoy_config::SystemConfig::builtin()
            .expect("the built-in configuration is valid")
            .solver;
        Inputs {
            embedded: (solver.segments_embedded, solver.grading_ratio_embedded),
            machine: Machine::default(),
            wall: WallClock::new(),
            instructions: Instructions::new(),
            firmware: Vec::new(),
            firmware_m7: Vec::new(),
            step_cost: Err("not run".into()),
            step_cost_m7: Err("not run".into()),
            pinocchio: Err("not run".into()),
            envelope: Vec::new(),
        }
    }
}
