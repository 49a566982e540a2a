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
//!   counts ([`FirmwareRow`], measured by the binary through `hil-tests`), for the
//!   Cortex-M4 (f32) and, once measured, the Cortex-M7 (f64);
//! - the machine ([`Machine`]) and an optional external reference (Pinocchio);
//!
//! and renders them with [`render`] (Markdown) and [`scaling_plot`] (the log-log
//! figure). The analysis ([`per_segment`], [`flatness`], [`breakdown`], the targets)
//! is here so that it can be tested without running anything.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::fs;
use std::path::Path;

use decoy_plots::{Aspect, Plot, Series};

pub use crate::names::{
    BREAKDOWN_CASES, INSTRUCTION_DENSE_STEP_SIZES, INSTRUCTION_STEP_SIZES, System, TENSION_METHODS,
    TENSION_SIZES, Variant, WALL_DENSE_STEP_SIZES, WALL_STEP_SIZES, instr_step_key, wall_step_key,
};
use crate::names::{
    instr_breakdown_key, instr_graded_key, instr_tension_key, wall_breakdown_key, wall_graded_key,
    wall_tension_key,
};

/// The command that generates the report (quoted in it).
pub const COMMAND: &str = "cargo xtask bench-report";
/// The criterion command the report runs (quoted in it).
pub const CRITERION_COMMAND: &str =
    "cargo bench -p benches --bench rk4_step -- --warm-up-time 1 --measurement-time 3";
/// The gungraun command the report runs (quoted in it).
pub const GUNGRAUN_COMMAND: &str =
    "cargo bench -p benches --bench instructions -- --save-summary=json";

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
    /// One RK4 step on the Cortex-M4F, f32, 16 graded segments
    /// (`firmware/examples/step_cost.rs`), or why it was not measured.
    pub step_cost: Result<hil_tests::step_cost::StepCost, String>,
    /// The same on the Cortex-M7, f64.
    pub step_cost_m7: Result<hil_tests::step_cost::StepCost, String>,
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
            firmware_m7: Vec::new(),
            step_cost: Err("not run".into()),
            step_cost_m7: Err("not run".into()),
            pinocchio: Err("not run".into()),
        }
    }
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

/// The wall-clock (ns) and instruction costs of one RK4-step series, by N.
pub fn step_costs(inputs: &Inputs, system: System, variant: Variant) -> (Costs, Costs) {
    let wall = variant
        .wall_sizes()
        .iter()
        .filter_map(|&n| {
            inputs
                .wall
                .get(&wall_step_key(system, variant, n))
                .map(|&t| (n, t))
        })
        .collect();
    let instr = variant
        .instruction_sizes()
        .iter()
        .filter_map(|&n| {
            inputs
                .instructions
                .get(&instr_step_key(system, variant, n))
                .map(|&c| (n, c as f64))
        })
        .collect();
    (wall, instr)
}

/// One evaluation split into its parts, in one unit (ns or instructions).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Breakdown {
    /// The whole evaluation (`evaluate`).
    pub evaluate: f64,
    /// Kinematics, velocity terms and load assembly: `prepare` − the aerodynamics.
    pub kinematics_assembly: f64,
    /// Cable drag of every segment.
    pub cable_drag: f64,
    /// Decoy aerodynamics.
    pub decoy_aero: f64,
    /// The tension solve: joint rows assembled in the forward sweep, back sweep.
    pub sweeps: f64,
    /// Pass 3.
    pub accelerations: f64,
}

impl Breakdown {
    /// The sum of the parts (differs from [`Breakdown::evaluate`] by call overhead,
    /// inlining across the passes, and noise).
    pub fn sum(&self) -> f64 {
        self.kinematics_assembly
            + self.cable_drag
            + self.decoy_aero
            + self.sweeps
            + self.accelerations
    }
}

/// The breakdown from the cost of each pass (`cost(pass name)`), `None` if any is missing.
pub fn breakdown(cost: &dyn Fn(&str) -> Option<f64>) -> Option<Breakdown> {
    let prepare = cost("prepare")?;
    let cable_drag = cost("cable_drag")?;
    let decoy_aero = cost("decoy_aero")?;
    Some(Breakdown {
        evaluate: cost("evaluate")?,
        kinematics_assembly: prepare - cable_drag - decoy_aero,
        cable_drag,
        decoy_aero,
        sweeps: cost("solve_tensions")?,
        accelerations: cost("accelerations")?,
    })
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
         build: x86-64 instructions under valgrind's callgrind (gungraun 0.20), Cortex-M \
         instructions under QEMU `-icount`."
    )?;
    writeln!(s)?;

    render_targets(s, inputs)?;
    render_steps(s, inputs)?;
    render_ratios(s, inputs)?;
    render_breakdown(s, inputs)?;
    render_other(s, inputs)?;
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
        "log10 of the wall-clock time per call (µs) against log10 N, criterion medians. \
         Top: the pendulum, one RK4 step with each kind of derivative (two-sweep f64 and \
         f32, shooting, dense) and one tension solve by each method. Bottom: the towed \
         system with N uniform segments, one RK4 step with each kind of derivative. A \
         slope of 1 is O(N); the dense solve's slope approaches 3. Also \
         `docs/figures/bench-scaling.svg`."
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
             300-rod RK4 step (f64) is in the RK4-step table above."
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
         anchor, all rods at -60 degrees, dt = 1e-4 s. Towed: the reference system \
         trimmed at 9 km, Mach 0.8, either 16 segments graded 1.3 with dt = 1e-3 s, or \
         (the scaling series) N segments of equal length with dt = 1e-5 s, small enough \
         that 1000 steps from the trim stay finite at every N in both precisions; the \
         cost of a step does not depend on dt (`crates/benches/src/lib.rs`)."
    )?;
    writeln!(
        s,
        "- Two-sweep RK4 steps are `Solver::step`. Shooting and dense RK4 steps use the \
         same RK4 scheme written in the benches crate (`crates/benches/src/stepper.rs`, \
         bit-identical to `Solver::step` with the two-sweep derivatives, checked by a \
         test), with `dynamics::solve_tensions_shooting` or `dense::evaluate_dense` for \
         the derivatives. The shooting form diverges numerically with N (round-off grows \
         about 3.7x per segment): beyond a few tens of segments its results are garbage \
         or not finite and the step fails, but its cost is still measurable: the \
         stepper runs all four stages whatever the numbers, so a failed step does the \
         same work as a successful one (`Solver::step` would stop at the first failed \
         stage). The dense derivatives allocate their matrices on every call and are \
         measured up to N = 300 only."
    )?;
    writeln!(
        s,
        "- Criterion (`crates/benches/benches/rk4_step.rs`): the solver steps \
         continuously and its initial state is restored, untimed, every 1000 steps, or \
         more often where fewer consecutive steps stay finite from the initial state \
         (counted in setup and printed by the benchmark as a note; the f32 cases with \
         thousands of segments: the f32 towed system with 4096 uniform segments does not \
         stay finite beyond its first step from the f32 trim, even with dt = 1e-6 s). The \
         work of a step does not depend on that."
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
        "- Breakdown (`crates/benches/src/passes.rs`): each public pass of \
         `solver_core::dynamics` timed alone on a workspace filled by one evaluation of \
         the trimmed state; the aerodynamics by calling `cable_drag` (with the local \
         density) for every segment and `decoy_aero` once, on the inputs `prepare` \
         computes."
    )?;
    writeln!(
        s,
        "- Firmware: `hil_tests::firmware::build_with_segments` builds the unchanged \
         firmware against a copy of `config/` whose `segments_embedded` is 8, 16, 32 or \
         64 (graded as configured, or less where that would make the shortest segment \
         shorter than the configured model's, so that the rows compare the cost of an \
         RK4 step, not the number of steps; `target/firmware-variants/`; for the M7, f64, `-C target-cpu=cortex-m7`), \
         boots it on QEMU's Cortex-M4F or Cortex-M7 with `-icount shift=0` and flies 3 s \
         of the acceleration case over the decoy link (capacity 64)."
    )?;
    writeln!(
        s,
        "- Zero allocations per step and per output evaluation are a test, not a \
         benchmark: `crates/benches/tests/no_alloc.rs` (run by `cargo test`)."
    )?;
    Ok(())
}

/// The flatness verdict of one series' costs: `Some((ok, worst))` or `None`.
fn series_flatness(costs: &Costs) -> Option<(bool, f64)> {
    per_segment(costs).and_then(|n| flatness(&n))
}

fn render_targets(s: &mut String, inputs: &Inputs) -> std::fmt::Result {
    writeln!(s, "## Targets")?;
    writeln!(s)?;
    writeln!(s, "| target | measured | result |")?;
    writeln!(s, "|---|---|---|")?;

    for system in System::ALL {
        let (wall, instr) = step_costs(inputs, system, Variant::F64);
        let instr_flat = series_flatness(&instr).map(|(ok, _)| ok);
        match series_flatness(&wall) {
            Some((ok, worst)) => writeln!(
                s,
                "| O(N), {}: wall-clock cost per segment of an RK4 step (f64) within ±20 % of \
                 N = 64, for N = 64..4096 | worst {:+.1} %{} | {} |",
                system.label(),
                worst * 100.0,
                if !ok && instr_flat == Some(true) {
                    " (the instruction counts are flat: probably a loaded machine, rerun)"
                } else {
                    ""
                },
                pass(ok)
            )?,
            None => writeln!(
                s,
                "| O(N) flatness, {}, wall clock, N = 64..4096 | {MISSING} | - |",
                system.label()
            )?,
        }
        if let Some((ok, worst)) = series_flatness(&instr) {
            writeln!(
                s,
                "| O(N), {}, instruction count (same criterion, for reference) | worst {:+.1} % | {} |",
                system.label(),
                worst * 100.0,
                pass(ok)
            )?;
        }
    }

    let speedup = |get: &dyn Fn(&str) -> Option<f64>| Some(get("dense")? / get("two_sweep")?);
    let wall_speedup = speedup(&|m| inputs.wall.get(&wall_tension_key(m, 300)).copied());
    let instr_speedup = speedup(&|m| {
        inputs
            .instructions
            .get(&instr_tension_key(m, 300))
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
    for system in System::ALL {
        let wall = |v: Variant| inputs.wall.get(&wall_step_key(system, v, 300)).copied();
        let instr = |v: Variant| {
            inputs
                .instructions
                .get(&instr_step_key(system, v, 300))
                .map(|&c| c as f64)
        };
        match (wall(Variant::Dense), wall(Variant::F64)) {
            (Some(dense), Some(fast)) if fast > 0.0 => {
                let x = dense / fast;
                let i = match (instr(Variant::Dense), instr(Variant::F64)) {
                    (Some(d), Some(f)) if f > 0.0 => format!(" ({:.0}x in instructions)", d / f),
                    _ => String::new(),
                };
                writeln!(
                    s,
                    "| RK4 step, {}, ≥ 100x faster than with the dense derivatives at N = 300 \
                     (wall clock) | {x:.0}x{i} | {} |",
                    system.label(),
                    pass(x >= DENSE_SPEEDUP_TARGET)
                )?
            }
            _ => writeln!(
                s,
                "| RK4 step, {}, vs dense at N = 300 | {MISSING} | - |",
                system.label()
            )?,
        }
    }

    match inputs
        .wall
        .get(&wall_step_key(System::Pendulum, Variant::F64, 300))
    {
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
    let in_frames = match sixteen.map(|r| &r.outcome) {
        Some(Ok(c)) => format!(
            "in the link's 10 ms frames {} max, {} mean per RK4 step (`step_instructions / \
             steps` of the frames with the fewest steps, whose first stage reuses the previous \
             frame's output evaluation; a whole control step is {} max, {} mean)",
            thousands(c.rk4_step_max),
            thousands(c.rk4_step_mean),
            thousands(c.frame_max),
            thousands(c.frame_mean)
        ),
        Some(Err(why)) => format!("over the link: not measured: {}", one_line(why)),
        None => "over the link: not run".to_owned(),
    };
    match &inputs.step_cost {
        Ok(c) => writeln!(
            s,
            "| firmware, 16 graded segments, f32, Cortex-M4: ≤ 40,000 instructions per RK4 \
             step | {} max for an RK4 step evaluating all four stages (`firmware/examples/\
             step_cost.rs`; {} when its first stage reuses the output evaluation); {in_frames} \
             | {} |",
            thousands(u64::from(c.four_stages)),
            thousands(u64::from(c.first_stage_reused)),
            pass(u64::from(c.four_stages) <= FIRMWARE_STEP_TARGET)
        )?,
        Err(why) => writeln!(
            s,
            "| firmware, 16 graded segments ≤ 40,000 instructions per RK4 step | RK4 step not \
             measured: {}; {in_frames} | - |",
            one_line(why)
        )?,
    }
    writeln!(s)?;
    Ok(())
}

/// Every size of `sizes` lists, sorted, without repeats.
fn union_sizes<'a>(sizes: impl IntoIterator<Item = &'a [u32]>) -> Vec<u32> {
    let mut all: Vec<u32> = sizes.into_iter().flatten().copied().collect();
    all.sort_unstable();
    all.dedup();
    all
}

/// The RK4-step tables: one row per N, one column per system and variant.
fn render_steps(s: &mut String, inputs: &Inputs) -> std::fmt::Result {
    writeln!(s, "## RK4 step against segment count")?;
    writeln!(s)?;
    writeln!(
        s,
        "One RK4 step (four derivative evaluations) of the pendulum and of the towed \
         system with N uniform segments, with each kind of derivative: the two-sweep \
         recurrence (`Solver::step`) in f64 and f32, the shooting form (diverges with N, \
         see below; the cost is still measured) and the dense reference (O(N³), up to \
         N = 300). `-`: not measured at that size."
    )?;
    writeln!(s)?;
    let header = || {
        let mut h = String::from("| N |");
        for system in System::ALL {
            for variant in Variant::ALL {
                let _ = write!(h, " {}, {} |", system.label(), variant.label());
            }
        }
        h
    };
    let rule = format!(
        "|---:|{}",
        "---:|".repeat(System::ALL.len() * Variant::ALL.len())
    );

    writeln!(s, "### Wall clock (criterion medians)")?;
    writeln!(s)?;
    // One row per size, one cell per system and variant ("-": not measured).
    let table = |s: &mut String,
                 sizes: Vec<u32>,
                 cell: &dyn Fn(System, Variant, u32) -> Option<String>|
     -> std::fmt::Result {
        writeln!(s, "{}", header())?;
        writeln!(s, "{rule}")?;
        for n in sizes {
            let mut row = format!("| {n} |");
            for system in System::ALL {
                for variant in Variant::ALL {
                    let cell = cell(system, variant, n).unwrap_or_else(|| "-".into());
                    let _ = write!(row, " {cell} |");
                }
            }
            writeln!(s, "{row}")?;
        }
        writeln!(s)
    };
    table(
        s,
        union_sizes([&WALL_STEP_SIZES[..], &WALL_DENSE_STEP_SIZES[..]]),
        &|system, variant, n| {
            inputs
                .wall
                .get(&wall_step_key(system, variant, n))
                .map(|&ns| duration(ns))
        },
    )?;

    writeln!(
        s,
        "### Instruction counts (gungraun, x86-64 under callgrind)"
    )?;
    writeln!(s)?;
    table(
        s,
        union_sizes([
            &INSTRUCTION_STEP_SIZES[..],
            &INSTRUCTION_DENSE_STEP_SIZES[..],
        ]),
        &|system, variant, n| {
            inputs
                .instructions
                .get(&instr_step_key(system, variant, n))
                .map(|&c| thousands(c))
        },
    )
}

/// `a / b` as `12.3x`, or `-`.
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
        _ => "-".into(),
    }
}

fn render_ratios(s: &mut String, inputs: &Inputs) -> std::fmt::Result {
    let wall = |k: String| inputs.wall.get(&k).copied();
    let instr = |k: String| inputs.instructions.get(&k).map(|&c| c as f64);
    writeln!(s, "## Ratios")?;
    writeln!(s)?;

    writeln!(s, "### RK4 step: dense and shooting against the recurrence")?;
    writeln!(s)?;
    writeln!(
        s,
        "Cost of one RK4 step with the dense or the shooting derivatives divided by its \
         cost with the two-sweep recurrence (f64); larger = the recurrence is that many \
         times faster. The shooting form costs about as much as the recurrence but its \
         results are unusable beyond a few tens of segments (it diverges, ~3.7^N)."
    )?;
    writeln!(s)?;
    writeln!(
        s,
        "| system | N | dense / two-sweep (wall) | dense / two-sweep (instr.) | shooting / two-sweep (wall) | shooting / two-sweep (instr.) |"
    )?;
    writeln!(s, "|---|---:|---:|---:|---:|---:|")?;
    for system in System::ALL {
        let sizes = union_sizes([&WALL_STEP_SIZES[..], &INSTRUCTION_STEP_SIZES[..]]);
        for n in sizes {
            let w = |v| wall(wall_step_key(system, v, n));
            let i = |v| instr(instr_step_key(system, v, n));
            writeln!(
                s,
                "| {} | {n} | {} | {} | {} | {} |",
                system.label(),
                ratio(w(Variant::Dense), w(Variant::F64)),
                ratio(i(Variant::Dense), i(Variant::F64)),
                ratio(w(Variant::Shooting), w(Variant::F64)),
                ratio(i(Variant::Shooting), i(Variant::F64)),
            )?;
        }
    }
    writeln!(s)?;

    writeln!(
        s,
        "### Tension solve: dense and shooting against the recurrence"
    )?;
    writeln!(s)?;
    writeln!(
        s,
        "Cost of one derivative evaluation of the pendulum relative to the O(N) two-sweep \
         recurrence (larger = the recurrence is that many times faster)."
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
                wall(wall_tension_key("dense", n)),
                wall(wall_tension_key("two_sweep", n))
            ),
            ratio(
                instr(instr_tension_key("dense", n)),
                instr(instr_tension_key("two_sweep", n))
            ),
            ratio(
                wall(wall_tension_key("shooting", n)),
                wall(wall_tension_key("two_sweep", n))
            ),
            ratio(
                instr(instr_tension_key("shooting", n)),
                instr(instr_tension_key("two_sweep", n))
            ),
        )?;
    }
    writeln!(s)?;

    writeln!(s, "### f32 against f64")?;
    writeln!(s)?;
    writeln!(
        s,
        "Cost of one RK4 step in f64 divided by its cost in f32 (the two-sweep recurrence; \
         > 1: f32 is faster)."
    )?;
    writeln!(s)?;
    writeln!(s, "| case | f64 / f32 (wall) | f64 / f32 (instr.) |")?;
    writeln!(s, "|---|---:|---:|")?;
    writeln!(
        s,
        "| towed, 16 graded segments | {} | {} |",
        ratio(wall(wall_graded_key("f64")), wall(wall_graded_key("f32"))),
        ratio(
            instr(instr_graded_key("f64")),
            instr(instr_graded_key("f32"))
        )
    )?;
    for system in System::ALL {
        for n in union_sizes([&WALL_STEP_SIZES[..], &INSTRUCTION_STEP_SIZES[..]]) {
            writeln!(
                s,
                "| {}, N = {n} | {} | {} |",
                system.label(),
                ratio(
                    wall(wall_step_key(system, Variant::F64, n)),
                    wall(wall_step_key(system, Variant::F32, n))
                ),
                ratio(
                    instr(instr_step_key(system, Variant::F64, n)),
                    instr(instr_step_key(system, Variant::F32, n))
                ),
            )?;
        }
    }
    writeln!(s)?;

    writeln!(s, "### Cost per segment across N (RK4 step)")?;
    writeln!(s)?;
    writeln!(
        s,
        "Cost per segment divided by its value at N = {REFERENCE_N}; O(N) means flat. \
         Target: within ±20 % from N = 64 to 4096 (the targets table checks the f64 \
         recurrence; the other series are shown for comparison). The last row is the \
         cost per segment at N = {REFERENCE_N} itself."
    )?;
    writeln!(s)?;
    let o_n = [Variant::F64, Variant::F32, Variant::Shooting];
    let mut header = String::from("| N |");
    let mut normalised = Vec::new();
    for system in System::ALL {
        for variant in o_n {
            let (w, i) = step_costs(inputs, system, variant);
            let _ = write!(
                header,
                " {}, {} (wall) | {}, {} (instr.) |",
                system.label(),
                variant.label(),
                system.label(),
                variant.label()
            );
            normalised.push((
                system,
                variant,
                "wall",
                w.clone(),
                per_segment(&w).unwrap_or_default(),
            ));
            normalised.push((
                system,
                variant,
                "instructions",
                i.clone(),
                per_segment(&i).unwrap_or_default(),
            ));
        }
    }
    writeln!(s, "{header}")?;
    writeln!(s, "|---:|{}", "---:|".repeat(normalised.len()))?;
    let find = |v: &[(u32, f64)], n: u32| {
        v.iter()
            .find(|(m, _)| *m == n)
            .map(|(_, r)| format!("{r:.2}"))
            .unwrap_or_else(|| "-".into())
    };
    for n in union_sizes([&WALL_STEP_SIZES[..], &INSTRUCTION_STEP_SIZES[..]]) {
        let mut row = format!("| {n} |");
        for (.., norm) in &normalised {
            let _ = write!(row, " {} |", find(norm, n));
        }
        writeln!(s, "{row}")?;
    }
    let mut row = format!("| per segment at {REFERENCE_N} |");
    for (_, _, unit, costs, _) in &normalised {
        let cell = costs
            .iter()
            .find(|(n, _)| *n == REFERENCE_N)
            .map(|(n, c)| {
                let per = c / f64::from(*n);
                if *unit == "wall" {
                    duration(per)
                } else {
                    thousands(per.round() as u64)
                }
            })
            .unwrap_or_else(|| "-".into());
        let _ = write!(row, " {cell} |");
    }
    writeln!(s, "{row}")?;
    writeln!(s)?;
    let verdict = |v: &[(u32, f64)]| match flatness(v) {
        Some((true, worst)) => format!("flat within ±20 % (worst {:+.1} %)", worst * 100.0),
        Some((false, worst)) => format!("NOT flat within ±20 % (worst {:+.1} %)", worst * 100.0),
        None => "no verdict (N = 64 or 4096 missing)".into(),
    };
    writeln!(s, "From N = 64 to 4096:")?;
    writeln!(s)?;
    for (system, variant, unit, _, norm) in &normalised {
        writeln!(
            s,
            "- {}, {}, {unit}: {}.",
            system.label(),
            variant.label(),
            verdict(norm)
        )?;
    }
    writeln!(s)?;
    Ok(())
}

/// One row of the breakdown table: a part of a [`Breakdown`].
type Part = &'static dyn Fn(&Breakdown) -> f64;

/// A cell `value (share %)` of the breakdown table.
fn share_cell(value: f64, whole: f64, format: &dyn Fn(f64) -> String) -> String {
    format!("{} ({:.0} %)", format(value), 100.0 * value / whole)
}

fn render_breakdown(s: &mut String, inputs: &Inputs) -> std::fmt::Result {
    writeln!(
        s,
        "## One derivative evaluation: kinematics, aerodynamics, assembly, sweeps"
    )?;
    writeln!(s)?;
    writeln!(
        s,
        "The trimmed towed system (16 graded segments; 300 uniform segments), one \
         `dynamics::evaluate` split into its passes, each measured alone \
         (`eval_breakdown/{{case}}/{{pass}}`, `breakdown/{{case}}/{{pass}}`). Shares are in \
         % of one whole evaluation. The aerodynamics (cable drag of every segment with \
         its local density, and the decoy's airloads) run inside `prepare` and are \
         measured by calling the same functions on the same inputs; kinematics + assembly \
         = `prepare` − aerodynamics (forward kinematics, gravity, the velocity terms, the \
         decoy's joint block). The joint rows D_j, b_j of the tension system are \
         assembled inside the forward sweep (fused, not separable), so \"sweeps\" \
         includes that assembly. The parts do not add up exactly to the whole (call \
         overhead, inlining across passes, and for the wall clock noise): the last row \
         shows by how much. One RK4 step is four evaluations plus four flight-path \
         samples and the stage arithmetic."
    )?;
    writeln!(s)?;
    for (title, unit_is_wall) in [
        ("Wall clock (criterion medians)", true),
        ("Instruction counts (gungraun)", false),
    ] {
        writeln!(s, "### {title}")?;
        writeln!(s)?;
        let cases: Vec<(&str, Option<Breakdown>)> = BREAKDOWN_CASES
            .iter()
            .map(|case| {
                let cost = |pass: &str| -> Option<f64> {
                    if unit_is_wall {
                        inputs.wall.get(&wall_breakdown_key(case, pass)).copied()
                    } else {
                        inputs
                            .instructions
                            .get(&instr_breakdown_key(case, pass))
                            .map(|&c| c as f64)
                    }
                };
                (*case, breakdown(&cost))
            })
            .collect();
        let mut header = String::from("| part |");
        for (case, _) in &cases {
            let _ = write!(header, " `{case}` |");
        }
        writeln!(s, "{header}")?;
        writeln!(s, "|---|{}", "---:|".repeat(cases.len()))?;
        let format = |v: f64| {
            if unit_is_wall {
                duration(v)
            } else {
                thousands(v.max(0.0).round() as u64)
            }
        };
        let rows: [(&str, Part); 8] = [
            ("kinematics + assembly (prepare − aerodynamics)", &|b| {
                b.kinematics_assembly
            }),
            ("aerodynamics: cable drag, every segment", &|b| b.cable_drag),
            ("aerodynamics: decoy", &|b| b.decoy_aero),
            ("aerodynamics, total", &|b| b.cable_drag + b.decoy_aero),
            (
                "sweeps (solve_tensions: row assembly + forward sweep, back sweep)",
                &|b| b.sweeps,
            ),
            ("accelerations (pass 3)", &|b| b.accelerations),
            ("whole evaluation (evaluate)", &|b| b.evaluate),
            ("sum of the parts", &|b| b.sum()),
        ];
        for (label, part) in rows {
            let mut row = format!("| {label} |");
            for (_, b) in &cases {
                let cell = match b {
                    Some(b) => share_cell(part(b), b.evaluate, &format),
                    None => "-".into(),
                };
                let _ = write!(row, " {cell} |");
            }
            writeln!(s, "{row}")?;
        }
        writeln!(s)?;
    }
    Ok(())
}

/// The other benchmarks: the graded towed steps and the tension solves.
fn render_other(s: &mut String, inputs: &Inputs) -> std::fmt::Result {
    writeln!(s, "## Other benchmarks")?;
    writeln!(s)?;
    writeln!(
        s,
        "| benchmark | median (wall) | per segment | benchmark | instructions | per segment |"
    )?;
    writeln!(s, "|---|---:|---:|---|---:|---:|")?;
    let mut row = |wall_key: String, instr_key: String, n: u32| -> std::fmt::Result {
        let (w, wn) = match inputs.wall.get(&wall_key) {
            Some(&ns) => (duration(ns), duration(ns / f64::from(n))),
            None => (MISSING.into(), "-".into()),
        };
        let (i, i_n) = match inputs.instructions.get(&instr_key) {
            Some(&c) => (thousands(c), thousands(c / u64::from(n))),
            None => (MISSING.into(), "-".into()),
        };
        writeln!(
            s,
            "| `{wall_key}` | {w} | {wn} | `{instr_key}` | {i} | {i_n} |"
        )
    };
    for precision in ["f32", "f64"] {
        row(wall_graded_key(precision), instr_graded_key(precision), 16)?;
    }
    for method in TENSION_METHODS {
        for n in TENSION_SIZES {
            row(wall_tension_key(method, n), instr_tension_key(method, n), n)?;
        }
    }
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

/// One firmware table (rows by segment count); `empty` is shown when there are none.
fn render_firmware_table(s: &mut String, rows: &[FirmwareRow], empty: &str) -> std::fmt::Result {
    writeln!(
        s,
        "| segments, grading | control step, max | control step, mean | RK4 steps per control step | solver per RK4 step, max | mean | per RK4 step and segment |"
    )?;
    writeln!(s, "|---:|---:|---:|---:|---:|---:|---:|")?;
    if rows.is_empty() {
        writeln!(s, "| - | {empty} | | | | | |")?;
    }
    for row in rows {
        match &row.outcome {
            Ok(c) => writeln!(
                s,
                "| {}, {} | {} | {} | {} to {} | {} | {} | {} |",
                row.segments,
                row.grading,
                thousands(c.frame_max),
                thousands(c.frame_mean),
                c.rk4_steps.0,
                c.rk4_steps.1,
                thousands(c.rk4_step_max),
                thousands(c.rk4_step_mean),
                thousands(c.rk4_step_max / row.segments as u64)
            )?,
            Err(why) => writeln!(
                s,
                "| {}, {} | not measured: {} | | | | | |",
                row.segments,
                row.grading,
                one_line(why)
            )?,
        }
    }
    writeln!(s)?;
    Ok(())
}

fn render_firmware(s: &mut String, inputs: &Inputs) -> std::fmt::Result {
    writeln!(
        s,
        "## Firmware: Cortex-M4F (QEMU mps2-an386, `-icount`), f32, graded segments"
    )?;
    writeln!(s)?;
    writeln!(
        s,
        "The firmware answers every 10 ms aircraft-state frame of the acceleration case \
         (3 s, 300 frames, over the decoy link) with its instruction counts: the whole \
         control step (`instructions`: validation, RK4 steps, outputs and clearances) and \
         the solver's share (`step_instructions`: the RK4 steps along the flight path). A \
         frame takes at least 2 RK4 steps of 5 ms, more where the wave-speed limit asks \
         (more segments are shorter ones: docs/protocol.md §5); the solver per RK4 step \
         is `step_instructions / steps` over the frames with the fewest steps. The first \
         stage of a frame's first step is the previous frame's output evaluation, reused \
         (the same state and aircraft bits: `Solver::step`), so a frame of two steps \
         evaluates the dynamics seven times, not eight."
    )?;
    writeln!(s)?;
    render_firmware_table(s, &inputs.firmware, "not run")?;
    render_step_cost(s, &inputs.step_cost)?;
    writeln!(s, "## Firmware: Cortex-M7 (mps2-an500), f64")?;
    writeln!(s)?;
    writeln!(
        s,
        "The same measurement on QEMU's Cortex-M7 (`-M mps2-an500`, f64 in hardware, \
         FPv5-D16), same columns."
    )?;
    writeln!(s)?;
    render_firmware_table(s, &inputs.firmware_m7, "not measured")?;
    render_step_cost(s, &inputs.step_cost_m7)?;
    Ok(())
}

/// The paragraph on one RK4 step of `firmware/examples/step_cost.rs`.
fn render_step_cost(
    s: &mut String,
    cost: &Result<hil_tests::step_cost::StepCost, String>,
) -> std::fmt::Result {
    match cost {
        Ok(c) => writeln!(
            s,
            "One RK4 step of the 16 graded segments on its own (`firmware/examples/step_cost.rs`: \
             the solver stepped along the flight path of 10 ms frames of a turning \
             acceleration, as the controller steps it, without the link; 20 frames): {} \
             instructions at most for a step that evaluates all four stages, {} for a frame's \
             first step, whose first stage is the previous frame's output evaluation reused; \
             the output evaluation {}, the frame's flight path {}.",
            thousands(u64::from(c.four_stages)),
            thousands(u64::from(c.first_stage_reused)),
            thousands(u64::from(c.outputs)),
            thousands(u64::from(c.path)),
        )?,
        Err(why) => writeln!(
            s,
            "One RK4 step on its own (`firmware/examples/step_cost.rs`): not measured ({}).",
            one_line(why)
        )?,
    }
    writeln!(s)
}

/// Points `(log10 N, log10 µs)` of the wall-clock costs `(N, ns)`.
fn log_log(label: String, points: &[(u32, f64)]) -> Series {
    Series {
        label,
        x: points.iter().map(|(n, _)| f64::from(*n).log10()).collect(),
        y: points.iter().map(|(_, ns)| (ns / 1e3).log10()).collect(),
    }
}

/// The log-log scaling figure, two panels (pendulum, towed system): log10 of the
/// wall-clock µs per call against log10 N. Series with fewer than two points are
/// left out; so is a panel without any series.
pub fn scaling_plot(inputs: &Inputs) -> Vec<Plot> {
    let mut plots = Vec::new();
    for system in System::ALL {
        let mut series = Vec::new();
        for variant in Variant::ALL {
            let (wall, _) = step_costs(inputs, system, variant);
            if wall.len() >= 2 {
                series.push(log_log(format!("RK4 step, {}", variant.label()), &wall));
            }
        }
        if system == System::Pendulum {
            for (method, label) in [
                ("two_sweep", "tension solve, two-sweep O(N)"),
                ("shooting", "tension solve, shooting O(N)"),
                ("dense", "tension solve, dense O(N^3)"),
            ] {
                let points: Vec<(u32, f64)> = TENSION_SIZES
                    .iter()
                    .filter_map(|&n| {
                        inputs
                            .wall
                            .get(&wall_tension_key(method, n))
                            .map(|&t| (n, t))
                    })
                    .collect();
                if points.len() >= 2 {
                    series.push(log_log(label.into(), &points));
                }
            }
        }
        if series.is_empty() {
            continue;
        }
        let title = match system {
            System::Pendulum => "Pendulum: cost per call (log-log, wall clock)",
            System::Towed => {
                "Towed system, uniform segments: cost per RK4 step (log-log, wall clock)"
            }
        };
        plots.push(Plot {
            title: title.into(),
            x_label: "log10(N)".into(),
            y_label: "log10(time per call / µs)".into(),
            series,
            aspect: Aspect::Free,
            invert_y: false,
        });
    }
    plots
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
    fn breakdown_derives_kinematics_and_assembly() {
        let costs = [
            ("evaluate", 1000.0),
            ("prepare", 600.0),
            ("cable_drag", 300.0),
            ("decoy_aero", 100.0),
            ("solve_tensions", 350.0),
            ("accelerations", 60.0),
        ];
        let cost = |pass: &str| costs.iter().find(|(p, _)| *p == pass).map(|(_, c)| *c);
        let b = breakdown(&cost).unwrap();
        assert_eq!(b.kinematics_assembly, 200.0);
        assert_eq!(b.sum(), 1010.0);
        assert!(breakdown(&|_| None).is_none());
        let mut inputs = Inputs::default();
        for (pass, c) in costs {
            inputs
                .instructions
                .insert(instr_breakdown_key("f64_graded16", pass), c as u64);
        }
        let md = render(&inputs);
        assert!(
            md.contains("| kinematics + assembly (prepare − aerodynamics) | - | - | - | - |"),
            "{md}"
        );
        assert!(
            md.contains("| kinematics + assembly (prepare − aerodynamics) | 200 (20 %) | - |"),
            "{md}"
        );
        assert!(
            md.contains(
                "| sweeps (solve_tensions: row assembly + forward sweep, back sweep) | 350 (35 %) |"
            ),
            "{md}"
        );
    }

    #[test]
    fn report_names_its_command_and_targets() {
        let mut inputs = Inputs {
            pinocchio: Err("pinocchio is not installed".into()),
            ..Inputs::default()
        };
        for (n, ns) in [(64, 10_000.0), (300, 47_000.0), (4096, 700_000.0)] {
            inputs
                .wall
                .insert(wall_step_key(System::Pendulum, Variant::F64, n), ns);
            inputs
                .wall
                .insert(wall_step_key(System::Towed, Variant::F64, n), 1.5 * ns);
        }
        inputs.wall.insert(
            wall_step_key(System::Towed, Variant::Dense, 300),
            47_000.0 * 1.5 * 800.0,
        );
        inputs.wall.insert(wall_tension_key("dense", 300), 5e6);
        inputs.wall.insert(wall_tension_key("two_sweep", 300), 1e4);
        inputs.firmware.push(FirmwareRow {
            segments: 16,
            grading: 1.3,
            outcome: Ok(FirmwareCounts {
                frame_max: 90_000,
                frame_mean: 80_000,
                rk4_steps: (2, 2),
                rk4_step_max: 45_000,
                rk4_step_mean: 40_000,
            }),
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
        // Without the RK4 step measurement the target has no verdict.
        let row = |md: &str| {
            md.lines()
                .find(|l| l.starts_with("| firmware, 16 graded segments"))
                .map(str::to_owned)
                .unwrap_or_default()
        };
        assert!(row(&md).ends_with("| - |"), "{}", row(&md));
        let mut cost = hil_tests::step_cost::StepCost {
            four_stages: 38_640,
            first_stage_reused: 30_800,
            outputs: 8_640,
            path: 880,
            four_stages_min: 38_240,
        };
        inputs.step_cost = Ok(cost);
        let md = render(&inputs);
        assert!(row(&md).contains("38,640 max for an RK4 step evaluating all four stages"));
        assert!(
            row(&md).contains("45,000 max, 40,000 mean per RK4 step"),
            "{}",
            row(&md)
        );
        assert!(row(&md).ends_with("| **pass** |"), "{}", row(&md));
        assert!(md.contains("the output evaluation 8,640, the frame's flight path 880."));
        cost.four_stages = 40_040;
        inputs.step_cost = Ok(cost);
        assert!(row(&render(&inputs)).ends_with("| **FAIL** |"));
        assert!(md.contains("O(N), towed system: wall-clock"), "{md}");
        // A wall-clock failure with flat instruction counts points at the machine.
        let mut loaded = Inputs::default();
        for (n, ns, c) in [
            (64, 10_000.0, 1_000_000),
            (300, 47_000.0, 4_700_000),
            (4096, 1_000_000.0, 64_000_000),
        ] {
            let (wall, instr) = (
                wall_step_key(System::Pendulum, Variant::F64, n),
                instr_step_key(System::Pendulum, Variant::F64, n),
            );
            loaded.wall.insert(wall, ns);
            loaded.instructions.insert(instr, c);
        }
        let md_loaded = render(&loaded);
        assert!(
            md_loaded.contains(
                "+56.2 % (the instruction counts are flat: probably a loaded machine, rerun) | **FAIL**"
            ),
            "{md_loaded}"
        );
        assert!(
            md.contains("with the dense derivatives at N = 300 (wall clock) | 800x | **pass**"),
            "{md}"
        );
        // The Cortex-M7 table is an input; empty, it says so.
        assert!(
            md.contains("## Firmware: Cortex-M7 (mps2-an500), f64"),
            "{md}"
        );
        assert!(md.contains("| - | not measured | | | |"), "{md}");
        let plots = scaling_plot(&inputs);
        assert_eq!(plots.len(), 2);
        assert_eq!(plots[0].series.len(), 1);
        assert_eq!(plots[0].series[0].x.len(), 3);
        assert_eq!(plots[1].series.len(), 1);
    }

    #[test]
    fn measured_cortex_m7_rows_are_rendered() {
        let inputs = Inputs {
            firmware_m7: vec![FirmwareRow {
                segments: 16,
                grading: 1.3,
                outcome: Ok(FirmwareCounts {
                    frame_max: 20_000,
                    frame_mean: 18_000,
                    rk4_steps: (2, 3),
                    rk4_step_max: 9_000,
                    rk4_step_mean: 8_000,
                }),
            }],
            ..Inputs::default()
        };
        let md = render(&inputs);
        let m7 = &md[md.find("## Firmware: Cortex-M7").unwrap()..];
        assert!(
            m7.contains("| 16, 1.3 | 20,000 | 18,000 | 2 to 3 | 9,000 | 8,000 | 562 |"),
            "{md}"
        );
    }

    /// Every result the report reads, with made-up costs that grow with N.
    fn complete_results() -> (WallClock, Instructions) {
        let cost = |key: &str| 1000 + key.len() as u64;
        let wall = crate::names::expected_wall_keys()
            .into_iter()
            .map(|k| {
                let c = cost(&k) as f64;
                (k, c)
            })
            .collect();
        let instructions = crate::names::expected_instruction_keys()
            .into_iter()
            .map(|k| {
                let c = cost(&k);
                (k, c)
            })
            .collect();
        (wall, instructions)
    }

    #[test]
    fn complete_results_render_every_cell() {
        let (wall, instructions) = complete_results();
        assert_eq!(check_complete(&wall, &instructions), Ok(()));
        let inputs = Inputs {
            wall,
            instructions,
            ..Inputs::default()
        };
        let md = render(&inputs);
        assert!(!md.contains(MISSING), "{md}");
    }

    #[test]
    fn a_renamed_or_missing_benchmark_is_an_error() {
        let (mut wall, mut instructions) = complete_results();
        // A criterion benchmark renamed: its result arrives under a name no table reads.
        let key = wall_step_key(System::Towed, Variant::Dense, 300);
        let cost = wall.remove(&key).unwrap();
        wall.insert("towed_rk4_step/kane/uniform300".into(), cost);
        // A gungraun benchmark that did not run.
        let gone = instr_tension_key("shooting", 64);
        instructions.remove(&gone);
        let error = check_complete(&wall, &instructions).unwrap_err();
        assert_eq!(error.missing, vec![key.clone(), gone.clone()]);
        assert_eq!(
            error.unknown,
            vec!["towed_rk4_step/kane/uniform300".to_owned()]
        );
        let message = error.to_string();
        assert!(
            message.contains(&key) && message.contains(&gone),
            "{message}"
        );
        // Rendered anyway (as the tests above do with partial inputs), the cell says so.
        let md = render(&Inputs {
            wall,
            instructions,
            ..Inputs::default()
        });
        assert!(md.contains(MISSING), "{md}");
    }
}
