//! The targets and their verdicts: per-segment costs and their flatness, the
//! evaluation breakdown, the costs of a step series, and the table of targets.

use std::fmt::Write as _;

use super::*;

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
/// Target for one firmware RK4 step (the embedded model, f32, Cortex-M4), instructions.
pub const FIRMWARE_STEP_TARGET: u64 = 40_000;

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

pub(super) fn pass(ok: bool) -> &'static str {
    if ok { "**pass**" } else { "**FAIL**" }
}

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

/// The flatness verdict of one series' costs: `Some((ok, worst))` or `None`.
pub(super) fn series_flatness(costs: &Costs) -> Option<(bool, f64)> {
    per_segment(costs).and_then(|n| flatness(&n))
}

pub(super) fn render_targets(s: &mut String, inputs: &Inputs) -> std::fmt::Result {
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

    let embedded = inputs
        .firmware
        .iter()
        .find(|r| r.segments == inputs.embedded.0);
    let in_frames = match embedded.map(|r| &r.outcome) {
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
    let (n, ratio) = inputs.embedded;
    match &inputs.step_cost {
        Ok(c) => writeln!(
            s,
            "| firmware, the embedded model ({n} segments graded {ratio}), f32, Cortex-M4: \
             ≤ 40,000 instructions per RK4 \
             step | {} max for an RK4 step evaluating all four stages (`firmware/examples/\
             step_cost.rs`; {} when its first stage reuses the output evaluation); {in_frames} \
             | {} |",
            thousands(u64::from(c.four_stages)),
            thousands(u64::from(c.first_stage_reused)),
            pass(u64::from(c.four_stages) <= FIRMWARE_STEP_TARGET)
        )?,
        Err(why) => writeln!(
            s,
            "| firmware, the embedded model ({n} segments graded {ratio}) ≤ 40,000 instructions \
             per RK4 step | RK4 step not \
             measured: {}; {in_frames} | - |",
            one_line(why)
        )?,
    }
    render_envelope_targets(s, inputs)?;
    writeln!(s)?;
    Ok(())
}
