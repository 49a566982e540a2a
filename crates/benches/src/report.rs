//! The benchmark report (`docs/benchmarks.md`) from the results of one run.
//!
//! `cargo xtask bench-report` runs the benchmarks and then the `bench-report`
//! binary, which gathers:
//!
//! - criterion's medians (wall clock) from `target/criterion/**/new/`
//!   ([`read_criterion`]);
//! - gungraun's instruction counts from `target/gungraun/**/summary.json`
//!   ([`read_gungraun`]);
//! - the firmware's instruction counts under QEMU `-icount` for several segment
//!   counts ([`FirmwareRow`], measured by the binary through `hil-tests`);
//! - the machine ([`Machine`]) and an optional external reference (Pinocchio);
//!
//! and renders them with [`render`] (Markdown) and [`scaling_plot`] (the log-log
//! figure). The analysis ([`per_segment`], [`flatness`], the targets) is here so that
//! it can be tested without running anything.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::fs;
use std::path::Path;

use decoy_plots::{Aspect, Plot, Series};

/// The command that generates the report (quoted in it).
pub const COMMAND: &str = "cargo xtask bench-report";
/// The criterion command the report runs (quoted in it).
pub const CRITERION_COMMAND: &str =
    "cargo bench -p benches --bench rk4_step -- --warm-up-time 1 --measurement-time 3";
/// The gungraun command the report runs (quoted in it).
pub const GUNGRAUN_COMMAND: &str =
    "cargo bench -p benches --bench instructions -- --save-summary=json";

/// Pendulum sizes of the criterion RK4-step benchmarks (f64).
pub const WALL_STEP_SIZES: [u32; 6] = [16, 64, 300, 1024, 2048, 4096];
/// Pendulum sizes of the criterion RK4-step benchmarks (f32).
pub const WALL_STEP_SIZES_F32: [u32; 3] = [16, 64, 300];
/// Pendulum sizes of the gungraun RK4-step benchmarks (f64).
pub const INSTRUCTION_STEP_SIZES: [u32; 5] = [8, 64, 300, 1024, 4096];
/// Sizes of the tension-solve benchmarks (both harnesses).
pub const TENSION_SIZES: [u32; 3] = [16, 64, 300];
/// Tension-solve methods, as named in both harnesses.
pub const TENSION_METHODS: [&str; 3] = ["two_sweep", "shooting", "dense"];
/// Segment counts of the firmware runs.
pub const FIRMWARE_SEGMENTS: [usize; 4] = [8, 16, 32, 64];

/// Size the per-segment costs are normalised to.
pub const REFERENCE_N: u32 = 64;
/// Allowed deviation of the per-segment cost from its value at [`REFERENCE_N`].
pub const FLATNESS_TOLERANCE: f64 = 0.20;
/// Required speed-up of the O(N) tension solve over the dense one at N = 300.
pub const DENSE_SPEEDUP_TARGET: f64 = 100.0;
/// Target for one 300-rod RK4 step (f64), µs.
pub const STEP_300_TARGET_US: f64 = 60.0;
/// Goal for one 300-rod RK4 step (f64), µs.
pub const STEP_300_GOAL_US: f64 = 40.0;
/// Target for one firmware RK4 step (16 graded segments, f32, Cortex-M4), instructions.
pub const FIRMWARE_STEP_TARGET: u64 = 40_000;
/// RK4 steps per firmware control step (the firmware reports per control step).
pub const FIRMWARE_SUBSTEPS: u64 = 2;

/// Criterion medians, ns, keyed `group/function/value` (criterion's `full_id`, e.g.
/// `pendulum_rk4_step/f64/300`).
pub type WallClock = BTreeMap<String, f64>;
/// Instruction counts keyed `group/function/id` (e.g. `steps/pendulum_f64/n300`).
pub type Instructions = BTreeMap<String, u64>;

/// Reads every `new/benchmark.json` + `new/estimates.json` pair under `dir`
/// (criterion's output directory) into median times.
pub fn read_criterion(dir: &Path) -> Result<WallClock, String> {
    let mut out = WallClock::new();
    let mut pending = vec![dir.to_path_buf()];
    while let Some(current) = pending.pop() {
        let entries = fs::read_dir(&current)
            .map_err(|e| format!("cannot read {}: {e}", current.display()))?;
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                pending.push(path);
                continue;
            }
            let in_new = path
                .parent()
                .and_then(Path::file_name)
                .is_some_and(|name| name == "new");
            if !in_new || path.file_name().is_none_or(|n| n != "benchmark.json") {
                continue;
            }
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
    }
    Ok(out)
}

/// Reads every `summary.json` under `dir` (gungraun's output directory) into
/// instruction counts (callgrind's `Ir`, total over the run's parts).
pub fn read_gungraun(dir: &Path) -> Result<Instructions, String> {
    let mut out = Instructions::new();
    let mut pending = vec![dir.to_path_buf()];
    while let Some(current) = pending.pop() {
        let entries = fs::read_dir(&current)
            .map_err(|e| format!("cannot read {}: {e}", current.display()))?;
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                pending.push(path);
            } else if path.file_name().is_some_and(|n| n == "summary.json") {
                let (key, count) = parse_gungraun_summary(&json_file(&path)?)
                    .map_err(|e| format!("{}: {e}", path.display()))?;
                out.insert(key, count);
            }
        }
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

fn json_file(path: &Path) -> Result<serde_json::Value, String> {
    let text =
        fs::read_to_string(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))
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
    /// Instructions per control step (max, mean), or why there are none.
    pub outcome: Result<(u64, u64), String>,
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
    /// Firmware runs, by segment count.
    pub firmware: Vec<FirmwareRow>,
    /// The Pinocchio reference: its result line, or why there is none.
    pub pinocchio: Result<String, String>,
}

impl Default for Inputs {
    /// No results at all; the Pinocchio reference "not run".
    fn default() -> Self {
        Inputs {
            machine: Machine::default(),
            wall: WallClock::new(),
            instructions: Instructions::new(),
            firmware: Vec::new(),
            pinocchio: Err("not run".into()),
        }
    }
}

/// Criterion key of one pendulum RK4 step.
fn wall_step(precision: &str, n: u32) -> String {
    format!("pendulum_rk4_step/{precision}/{n}")
}

/// Criterion key of one tension solve.
fn wall_tension(method: &str, n: u32) -> String {
    format!("tension_solve/{method}/{n}")
}

/// Gungraun key of one pendulum RK4 step (f64).
fn instr_step(n: u32) -> String {
    format!("steps/pendulum_f64/n{n}")
}

/// Gungraun key of one tension solve.
fn instr_tension(method: &str, n: u32) -> String {
    format!("tension/{method}/n{n}")
}

/// Cost per segment (`cost(N) / N`) normalised to its value at [`REFERENCE_N`], for
/// the sizes present in `costs` (sizes without a cost are left out). `None` if there
/// is no cost at [`REFERENCE_N`].
pub fn per_segment(costs: &[(u32, f64)]) -> Option<Vec<(u32, f64)>> {
    let reference = costs
        .iter()
        .find(|(n, _)| *n == REFERENCE_N)
        .map(|(n, c)| c / f64::from(*n))?;
    Some(
        costs
            .iter()
            .map(|(n, c)| (*n, c / f64::from(*n) / reference))
            .collect(),
    )
}

/// Largest size of the flatness criterion.
pub const FLATNESS_MAX_N: u32 = 4096;

/// Whether every normalised per-segment cost for N in [`REFERENCE_N`]..=
/// [`FLATNESS_MAX_N`] is within ±[`FLATNESS_TOLERANCE`], and the worst deviation;
/// `None` unless both ends of the range were measured.
pub fn flatness(normalised: &[(u32, f64)]) -> Option<(bool, f64)> {
    let has = |size: u32| normalised.iter().any(|(n, _)| *n == size);
    if !(has(REFERENCE_N) && has(FLATNESS_MAX_N)) {
        return None;
    }
    let deviations: Vec<f64> = normalised
        .iter()
        .filter(|(n, _)| (REFERENCE_N..=FLATNESS_MAX_N).contains(n))
        .map(|(_, r)| r - 1.0)
        .collect();
    let worst = deviations
        .iter()
        .copied()
        .fold(0.0f64, |w, d| if d.abs() > w.abs() { d } else { w });
    Some((worst.abs() <= FLATNESS_TOLERANCE, worst))
}

/// `1234567` as `1,234,567`.
pub fn thousands(value: u64) -> String {
    let digits = value.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// A duration in ns, in a readable unit.
pub fn duration(ns: f64) -> String {
    if ns >= 1e6 {
        format!("{:.2} ms", ns / 1e6)
    } else if ns >= 1e3 {
        format!("{:.2} µs", ns / 1e3)
    } else {
        format!("{ns:.0} ns")
    }
}

fn pass(ok: bool) -> &'static str {
    if ok { "**pass**" } else { "**FAIL**" }
}

const MISSING: &str = "n/a (missing from this run)";

/// Costs by segment count: `(N, cost)`.
pub type Costs = Vec<(u32, f64)>;

/// The wall-clock and instruction costs of the pendulum RK4 step (f64), by N.
fn step_costs(inputs: &Inputs) -> (Costs, Costs) {
    let wall = WALL_STEP_SIZES
        .iter()
        .filter_map(|&n| inputs.wall.get(&wall_step("f64", n)).map(|&t| (n, t)))
        .collect();
    let instr = INSTRUCTION_STEP_SIZES
        .iter()
        .filter_map(|&n| {
            inputs
                .instructions
                .get(&instr_step(n))
                .map(|&c| (n, c as f64))
        })
        .collect();
    (wall, instr)
}

/// The report, Markdown.
pub fn render(inputs: &Inputs) -> String {
    let mut s = String::new();
    // `write!` to a String cannot fail.
    let _ = render_into(&mut s, inputs);
    s
}

fn render_into(s: &mut String, inputs: &Inputs) -> std::fmt::Result {
    let m = &inputs.machine;
    writeln!(s, "# Benchmarks")?;
    writeln!(s)?;
    writeln!(
        s,
        "Generated by `{COMMAND}`; do not edit by hand, rerun it. It runs the criterion \
         wall-clock benchmarks (`{CRITERION_COMMAND}`), the gungraun instruction counts \
         (`{GUNGRAUN_COMMAND}`), the firmware under QEMU `-icount` with 8, 16, 32 and 64 \
         segments, and the optional Pinocchio reference, then writes this file and \
         `docs/figures/bench-scaling.png`/`.svg`."
    )?;
    writeln!(s)?;
    writeln!(s, "## Machine")?;
    writeln!(s)?;
    writeln!(s, "| | |")?;
    writeln!(s, "|---|---|")?;
    writeln!(s, "| CPU | {} |", m.cpu)?;
    writeln!(s, "| logical CPUs | {} |", m.cores)?;
    writeln!(s, "| OS | {} |", m.os)?;
    writeln!(s, "| rustc | {} |", m.rustc)?;
    writeln!(s, "| valgrind | {} |", m.valgrind)?;
    writeln!(s, "| QEMU | {} |", m.qemu)?;
    writeln!(s)?;
    writeln!(
        s,
        "Wall-clock times: numbers from one run on the machine above (criterion medians); \
         they vary from run to run. Instruction counts are exact and repeat for the same \
         build: x86-64 instructions under valgrind's callgrind (gungraun 0.20), Cortex-M4 \
         instructions under QEMU `-icount`."
    )?;
    writeln!(s)?;

    render_targets(s, inputs)?;
    render_wall(s, inputs)?;
    render_instructions(s, inputs)?;
    render_ratios(s, inputs)?;
    render_firmware(s, inputs)?;

    writeln!(s, "## Scaling")?;
    writeln!(s)?;
    writeln!(
        s,
        "![log-log scaling of the cost per step](figures/bench-scaling.png)"
    )?;
    writeln!(s)?;
    writeln!(
        s,
        "log10 of the wall-clock time per call (µs) against log10 N, criterion medians: \
         one RK4 step of the pendulum (f64 and f32, O(N) two-sweep solve) and one tension \
         solve by each method. A slope of 1 is O(N); the dense solve's slope approaches 3. \
         Also `docs/figures/bench-scaling.svg`."
    )?;
    writeln!(s)?;

    writeln!(s, "## External reference: Pinocchio ABA")?;
    writeln!(s)?;
    match &inputs.pinocchio {
        Ok(line) => writeln!(
            s,
            "`crates/benches/pinocchio/aba_300.py` (optional, not run in CI; `pip install \
             pin`): the same chain of 0.1 m, 0.5 kg rods on spherical joints, one RK4 step \
             = 4 calls of Pinocchio's ABA. Pinocchio's `Data` grows as nv^3 in memory, so \
             the 300-rod spherical chain does not fit: the script times 25 to 100 rods and \
             extrapolates (ABA is O(N)), and times 300 revolute joints directly as a planar \
             lower bound. Measured in this run: {line} For comparison, this solver's \
             300-rod RK4 step (f64) is in the wall-clock table above."
        )?,
        Err(why) => writeln!(
            s,
            "`crates/benches/pinocchio/aba_300.py` (optional, not run in CI; `pip install \
             pin`) times Pinocchio's ABA on the same 300-rod chain. Not measured in this \
             run: {why}."
        )?,
    }
    writeln!(s)?;

    writeln!(s, "## How the numbers are taken")?;
    writeln!(s)?;
    writeln!(
        s,
        "- Pendulum: the compound pendulum with N rods (capacity N) hinged to a fixed \
         anchor, all rods at -60 degrees, dt = 1e-4 s; towed: the reference system, 16 \
         segments graded 1.3, trimmed at 9 km, Mach 0.8, dt = 1e-3 s (`crates/benches/src/lib.rs`)."
    )?;
    writeln!(
        s,
        "- Criterion (`crates/benches/benches/rk4_step.rs`): the solver steps \
         continuously and its initial state is restored, untimed, every 1000 steps."
    )?;
    writeln!(
        s,
        "- Gungraun (`crates/benches/benches/instructions.rs`): exactly one call counted; \
         building, trimming and boxing the solver happen in gungraun's setup, outside the \
         count. The dense solve allocates its matrix inside the count."
    )?;
    writeln!(
        s,
        "- Tension solve: one derivative evaluation of the pendulum in its initial state \
         (the O(N) forms through `Solver::derivative`, the dense reference through \
         `evaluate_dense`)."
    )?;
    writeln!(
        s,
        "- Firmware: `hil_tests::firmware::build_with_segments` builds the unchanged \
         firmware against a copy of `config/` whose `segments_embedded` is 8, 16, 32 or \
         64 (`target/firmware-variants/`), and runs the acceleration case (300 control \
         steps of 10 ms = 2 RK4 steps of 5 ms, f32, capacity 64) on QEMU's Cortex-M4F \
         with `-icount shift=0`."
    )?;
    writeln!(
        s,
        "- Zero allocations per step and per output evaluation are a test, not a \
         benchmark: `crates/benches/tests/no_alloc.rs` (run by `cargo test`)."
    )?;
    Ok(())
}

fn render_targets(s: &mut String, inputs: &Inputs) -> std::fmt::Result {
    writeln!(s, "## Targets")?;
    writeln!(s)?;
    writeln!(s, "| target | measured | result |")?;
    writeln!(s, "|---|---|---|")?;

    let (wall, instr) = step_costs(inputs);
    match per_segment(&wall).and_then(|n| flatness(&n)) {
        Some((ok, worst)) => writeln!(
            s,
            "| O(N): wall-clock cost per segment of an RK4 step (f64) within ±20 % of N = 64, \
             for N = 64..4096 | worst {:+.1} % | {} |",
            worst * 100.0,
            pass(ok)
        )?,
        None => writeln!(
            s,
            "| O(N) flatness, wall clock, N = 64..4096 | {MISSING} | - |"
        )?,
    }
    if let Some((ok, worst)) = per_segment(&instr).and_then(|n| flatness(&n)) {
        writeln!(
            s,
            "| O(N), instruction count (same criterion, for reference) | worst {:+.1} % | {} |",
            worst * 100.0,
            pass(ok)
        )?;
    }

    let speedup = |get: &dyn Fn(&str) -> Option<f64>| Some(get("dense")? / get("two_sweep")?);
    let wall_speedup = speedup(&|m| inputs.wall.get(&wall_tension(m, 300)).copied());
    let instr_speedup = speedup(&|m| {
        inputs
            .instructions
            .get(&instr_tension(m, 300))
            .map(|&c| c as f64)
    });
    match wall_speedup {
        Some(x) => writeln!(
            s,
            "| tension solve ≥ 100x faster than dense at N = 300 (wall clock) | {x:.0}x{} | {} |",
            instr_speedup
                .map(|i| format!(" ({i:.0}x in instructions)"))
                .unwrap_or_default(),
            pass(x >= DENSE_SPEEDUP_TARGET)
        )?,
        None => writeln!(s, "| tension solve vs dense at N = 300 | {MISSING} | - |")?,
    }

    match inputs.wall.get(&wall_step("f64", 300)) {
        Some(&ns) => {
            let us = ns / 1e3;
            let goal = if us <= STEP_300_GOAL_US {
                "goal of 40 µs met"
            } else {
                "goal of 40 µs not met"
            };
            writeln!(
                s,
                "| 300-rod RK4 step (f64) ≤ 60 µs (goal 40 µs) | {us:.1} µs ({goal}) | {} |",
                pass(us <= STEP_300_TARGET_US)
            )?
        }
        None => writeln!(s, "| 300-rod RK4 step ≤ 60 µs | {MISSING} | - |")?,
    }

    let sixteen = inputs.firmware.iter().find(|r| r.segments == 16);
    match sixteen.map(|r| &r.outcome) {
        Some(Ok((max, mean))) => writeln!(
            s,
            "| firmware, 16 graded segments, f32, Cortex-M4: ≤ 40,000 instructions per RK4 \
             step | {} max, {} mean (the firmware reports per 10 ms control step = 2 RK4 \
             steps: {} max, {} mean, divided by 2) | {} |",
            thousands(max / FIRMWARE_SUBSTEPS),
            thousands(mean / FIRMWARE_SUBSTEPS),
            thousands(*max),
            thousands(*mean),
            pass(max / FIRMWARE_SUBSTEPS <= FIRMWARE_STEP_TARGET)
        )?,
        Some(Err(why)) => writeln!(
            s,
            "| firmware, 16 graded segments ≤ 40,000 instructions per RK4 step | not \
             measured: {} | - |",
            one_line(why)
        )?,
        None => writeln!(
            s,
            "| firmware, 16 graded segments ≤ 40,000 instructions per RK4 step | not run | - |"
        )?,
    }
    writeln!(s)?;
    Ok(())
}

fn render_wall(s: &mut String, inputs: &Inputs) -> std::fmt::Result {
    writeln!(s, "## Wall clock (criterion medians)")?;
    writeln!(s)?;
    writeln!(s, "| benchmark | median | per segment |")?;
    writeln!(s, "|---|---:|---:|")?;
    let mut row = |key: String, n: Option<u32>| -> std::fmt::Result {
        match inputs.wall.get(&key) {
            Some(&ns) => writeln!(
                s,
                "| `{key}` | {} | {} |",
                duration(ns),
                n.map(|n| duration(ns / f64::from(n)))
                    .unwrap_or_else(|| "-".into())
            ),
            None => writeln!(s, "| `{key}` | {MISSING} | - |"),
        }
    };
    for n in WALL_STEP_SIZES {
        row(wall_step("f64", n), Some(n))?;
    }
    for n in WALL_STEP_SIZES_F32 {
        row(wall_step("f32", n), Some(n))?;
    }
    row("towed_rk4_step/f32/graded16".into(), Some(16))?;
    row("towed_rk4_step/f64/graded16".into(), Some(16))?;
    row("towed_rk4_step/f64/uniform300".into(), Some(300))?;
    for method in TENSION_METHODS {
        for n in TENSION_SIZES {
            row(wall_tension(method, n), Some(n))?;
        }
    }
    writeln!(s)?;
    Ok(())
}

fn render_instructions(s: &mut String, inputs: &Inputs) -> std::fmt::Result {
    writeln!(
        s,
        "## Instruction counts (gungraun, x86-64 under callgrind)"
    )?;
    writeln!(s)?;
    writeln!(s, "| benchmark | instructions | per segment |")?;
    writeln!(s, "|---|---:|---:|")?;
    let mut row = |key: String, n: u32| -> std::fmt::Result {
        match inputs.instructions.get(&key) {
            Some(&c) => writeln!(
                s,
                "| `{key}` | {} | {} |",
                thousands(c),
                thousands(c / u64::from(n))
            ),
            None => writeln!(s, "| `{key}` | {MISSING} | - |"),
        }
    };
    for n in INSTRUCTION_STEP_SIZES {
        row(instr_step(n), n)?;
    }
    row("steps/towed_f32/graded16".into(), 16)?;
    row("steps/towed_f64/graded16".into(), 16)?;
    for method in TENSION_METHODS {
        for n in TENSION_SIZES {
            row(instr_tension(method, n), n)?;
        }
    }
    writeln!(s)?;
    Ok(())
}

/// `a / b` as `12.3x`, or `n/a`.
fn ratio(a: Option<f64>, b: Option<f64>) -> String {
    match (a, b) {
        (Some(a), Some(b)) if b > 0.0 => {
            let r = a / b;
            if r >= 10.0 {
                format!("{r:.0}x")
            } else {
                format!("{r:.2}x")
            }
        }
        _ => "n/a".into(),
    }
}

fn render_ratios(s: &mut String, inputs: &Inputs) -> std::fmt::Result {
    let wall = |k: String| inputs.wall.get(&k).copied();
    let instr = |k: String| inputs.instructions.get(&k).map(|&c| c as f64);
    writeln!(s, "## Ratios")?;
    writeln!(s)?;
    writeln!(
        s,
        "### Tension solve: dense and shooting against the recurrence"
    )?;
    writeln!(s)?;
    writeln!(
        s,
        "Cost of one derivative evaluation relative to the O(N) two-sweep recurrence \
         (larger = the recurrence is that many times faster)."
    )?;
    writeln!(s)?;
    writeln!(
        s,
        "| N | dense / two-sweep (wall) | dense / two-sweep (instr.) | shooting / two-sweep (wall) | shooting / two-sweep (instr.) |"
    )?;
    writeln!(s, "|---:|---:|---:|---:|---:|")?;
    for n in TENSION_SIZES {
        writeln!(
            s,
            "| {n} | {} | {} | {} | {} |",
            ratio(
                wall(wall_tension("dense", n)),
                wall(wall_tension("two_sweep", n))
            ),
            ratio(
                instr(instr_tension("dense", n)),
                instr(instr_tension("two_sweep", n))
            ),
            ratio(
                wall(wall_tension("shooting", n)),
                wall(wall_tension("two_sweep", n))
            ),
            ratio(
                instr(instr_tension("shooting", n)),
                instr(instr_tension("two_sweep", n))
            ),
        )?;
    }
    writeln!(s)?;
    writeln!(s, "### f32 against f64")?;
    writeln!(s)?;
    writeln!(s, "| case | f64 / f32 (wall) | f64 / f32 (instr.) |")?;
    writeln!(s, "|---|---:|---:|")?;
    writeln!(
        s,
        "| towed, 16 graded segments | {} | {} |",
        ratio(
            wall("towed_rk4_step/f64/graded16".into()),
            wall("towed_rk4_step/f32/graded16".into())
        ),
        ratio(
            instr("steps/towed_f64/graded16".into()),
            instr("steps/towed_f32/graded16".into())
        )
    )?;
    for n in WALL_STEP_SIZES_F32 {
        writeln!(
            s,
            "| pendulum, N = {n} | {} | - |",
            ratio(wall(wall_step("f64", n)), wall(wall_step("f32", n)))
        )?;
    }
    writeln!(s)?;
    writeln!(s, "### Cost per segment across N (RK4 step, pendulum, f64)")?;
    writeln!(s)?;
    writeln!(
        s,
        "Cost per segment divided by its value at N = {REFERENCE_N}; O(N) means flat. \
         Target: within ±20 % from N = 64 to 4096."
    )?;
    writeln!(s)?;
    let (wall_costs, instr_costs) = step_costs(inputs);
    let wall_norm = per_segment(&wall_costs).unwrap_or_default();
    let instr_norm = per_segment(&instr_costs).unwrap_or_default();
    let mut sizes: Vec<u32> = wall_norm
        .iter()
        .chain(&instr_norm)
        .map(|(n, _)| *n)
        .collect();
    sizes.sort_unstable();
    sizes.dedup();
    writeln!(s, "| N | wall clock | instructions |")?;
    writeln!(s, "|---:|---:|---:|")?;
    let find = |v: &[(u32, f64)], n: u32| {
        v.iter()
            .find(|(m, _)| *m == n)
            .map(|(_, r)| format!("{r:.2}"))
            .unwrap_or_else(|| "-".into())
    };
    for n in sizes {
        writeln!(
            s,
            "| {n} | {} | {} |",
            find(&wall_norm, n),
            find(&instr_norm, n)
        )?;
    }
    writeln!(s)?;
    let verdict = |v: &[(u32, f64)]| match flatness(v) {
        Some((true, worst)) => format!("flat within ±20 % (worst {:+.1} %)", worst * 100.0),
        Some((false, worst)) => format!("NOT flat within ±20 % (worst {:+.1} %)", worst * 100.0),
        None => "no verdict (N = 64 or 4096 missing)".into(),
    };
    writeln!(
        s,
        "From N = 64 to 4096: wall clock {}; instructions {}.",
        verdict(&wall_norm),
        verdict(&instr_norm)
    )?;
    writeln!(s)?;
    Ok(())
}

/// The first line of `text`, for a table cell.
fn one_line(text: &str) -> String {
    text.lines()
        .next()
        .unwrap_or("")
        .replace('|', "/")
        .trim()
        .to_owned()
}

fn render_firmware(s: &mut String, inputs: &Inputs) -> std::fmt::Result {
    writeln!(
        s,
        "## Firmware: Cortex-M4F (QEMU mps2-an386, `-icount`), f32, graded segments"
    )?;
    writeln!(s)?;
    writeln!(
        s,
        "The firmware reports instructions per 10 ms control step, which is 2 RK4 steps \
         of 5 ms (plus the flight-path samples they take); per RK4 step is that divided \
         by 2. Max and mean over the 300 control steps of the acceleration case."
    )?;
    writeln!(s)?;
    writeln!(
        s,
        "| segments | per control step, max | per control step, mean | per RK4 step, max | per RK4 step and segment |"
    )?;
    writeln!(s, "|---:|---:|---:|---:|---:|")?;
    if inputs.firmware.is_empty() {
        writeln!(s, "| - | not run | | | |")?;
    }
    for row in &inputs.firmware {
        match &row.outcome {
            Ok((max, mean)) => writeln!(
                s,
                "| {} | {} | {} | {} | {} |",
                row.segments,
                thousands(*max),
                thousands(*mean),
                thousands(max / FIRMWARE_SUBSTEPS),
                thousands(max / FIRMWARE_SUBSTEPS / row.segments as u64)
            )?,
            Err(why) => writeln!(
                s,
                "| {} | not measured: {} | | | |",
                row.segments,
                one_line(why)
            )?,
        }
    }
    writeln!(s)?;
    Ok(())
}

/// The log-log scaling figure: log10 of the wall-clock µs per call against log10 N.
/// Series without data are left out.
pub fn scaling_plot(inputs: &Inputs) -> Plot {
    let mut series = Vec::new();
    let mut add = |label: &str, points: Vec<(u32, f64)>| {
        if points.len() >= 2 {
            series.push(Series {
                label: label.into(),
                x: points.iter().map(|(n, _)| f64::from(*n).log10()).collect(),
                y: points.iter().map(|(_, ns)| (ns / 1e3).log10()).collect(),
            });
        }
    };
    let wall = |key: String, n: u32| inputs.wall.get(&key).map(|&t| (n, t));
    add(
        "RK4 step, f64 (two-sweep)",
        WALL_STEP_SIZES
            .iter()
            .filter_map(|&n| wall(wall_step("f64", n), n))
            .collect(),
    );
    add(
        "RK4 step, f32 (two-sweep)",
        WALL_STEP_SIZES_F32
            .iter()
            .filter_map(|&n| wall(wall_step("f32", n), n))
            .collect(),
    );
    for (method, label) in [
        ("two_sweep", "tension solve, two-sweep O(N)"),
        ("shooting", "tension solve, shooting O(N)"),
        ("dense", "tension solve, dense O(N^3)"),
    ] {
        add(
            label,
            TENSION_SIZES
                .iter()
                .filter_map(|&n| wall(wall_tension(method, n), n))
                .collect(),
        );
    }
    Plot {
        title: "Cost per call against segment count (log-log, wall clock)".into(),
        x_label: "log10(N)".into(),
        y_label: "log10(time per call / µs)".into(),
        series,
        aspect: Aspect::Free,
        invert_y: false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn per_segment_and_flatness() {
        let costs = [(16, 40.0), (64, 128.0), (300, 630.0), (4096, 11_000.0)];
        let norm = per_segment(&costs).unwrap();
        assert_eq!(norm[1], (64, 1.0));
        assert!((norm[0].1 - 1.25).abs() < 1e-12);
        let (ok, worst) = flatness(&norm).unwrap();
        // 11000 / 4096 / 2 = 1.343: 34 % over, N = 16 ignored.
        assert!(!ok);
        assert!((worst - (11_000.0 / 4096.0 / 2.0 - 1.0)).abs() < 1e-12);
        // Without N = 4096 there is no verdict.
        assert!(flatness(&per_segment(&costs[..3]).unwrap()).is_none());
        let flat = [(64, 128.0), (300, 610.0), (4096, 8500.0)];
        assert_eq!(
            flatness(&per_segment(&flat).unwrap()).map(|f| f.0),
            Some(true)
        );
        assert!(per_segment(&[(16, 1.0)]).is_none());
    }

    #[test]
    fn gungraun_summary_is_parsed() {
        let summary = serde_json::json!({
            "group": "steps", "function_name": "pendulum_f64", "id": "n300",
            "profiles": [{"tool": "Callgrind", "data": {"total": {"metrics": {
                "Ir": {"values": {"new": 648972}}}}}}]
        });
        assert_eq!(
            parse_gungraun_summary(&summary).unwrap(),
            ("steps/pendulum_f64/n300".to_owned(), 648_972)
        );
        assert!(parse_gungraun_summary(&serde_json::json!({})).is_err());
    }

    #[test]
    fn numbers_are_formatted() {
        assert_eq!(thousands(0), "0");
        assert_eq!(thousands(999), "999");
        assert_eq!(thousands(1_234_567), "1,234,567");
        assert_eq!(duration(950.0), "950 ns");
        assert_eq!(duration(50_371.9), "50.37 µs");
        assert_eq!(duration(2.5e6), "2.50 ms");
    }

    #[test]
    fn report_names_its_command_and_targets() {
        let mut inputs = Inputs {
            pinocchio: Err("pinocchio is not installed".into()),
            ..Inputs::default()
        };
        for (n, ns) in [(64, 10_000.0), (300, 47_000.0), (4096, 700_000.0)] {
            inputs.wall.insert(wall_step("f64", n), ns);
        }
        inputs.wall.insert(wall_tension("dense", 300), 5e6);
        inputs.wall.insert(wall_tension("two_sweep", 300), 1e4);
        inputs.firmware.push(FirmwareRow {
            segments: 16,
            outcome: Ok((90_000, 80_000)),
        });
        let md = render(&inputs);
        assert!(md.contains("`cargo xtask bench-report`"), "{md}");
        assert!(md.contains("numbers from one run on the machine above"));
        assert!(md.contains("| 500x (") || md.contains("| 500x |"), "{md}");
        assert!(
            md.contains("47.0 µs (goal of 40 µs not met) | **pass**"),
            "{md}"
        );
        assert!(md.contains("45,000 max"), "{md}");
        let plot = scaling_plot(&inputs);
        assert_eq!(plot.series.len(), 1);
        assert_eq!(plot.series[0].x.len(), 3);
    }
}
