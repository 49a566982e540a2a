//! The benchmark report (`docs/benchmarks.md`) from the results of one run.
//!
//! `cargo xtask bench-report` runs the benchmarks and then the `bench-report`
//! binary, which gathers:
//!
//! - criterion's medians (wall clock) from `target/criterion/**/new/`
//!   ([`read_criterion`]);
//! - gungraun's instruction counts from `target/gungraun/**/summary.json`
//!   ([`read_gungraun`]), both checked against the benchmark names the report
//!   expects ([`check_complete`], [`crate::names`]);
//! - the firmware's instruction counts under QEMU `-icount` for several segment
//!   counts ([`FirmwareRow`], measured by the binary through `hil-tests`), for the
//!   Cortex-M4 (f32) and, once measured, the Cortex-M7 (f64);
//! - the machine ([`Machine`]) and an optional external reference (Pinocchio);
//!
//! and renders them with [`render`] (Markdown) and [`scaling_plot`] (the log-log
//! figure). The analysis ([`per_segment`], [`flatness`], [`breakdown`], the targets)
//! is here so that it can be tested without running anything.
//!
//! The parts, along the report's seams:
//!
//! - `data` — the results of one run: reading criterion's and gungraun's JSON
//!   results, checking them against the expected names, and [`Inputs`], everything
//!   the report shows;
//! - `claims` — the targets and their verdicts: per-segment costs, flatness, the
//!   evaluation breakdown, the table of targets;
//! - `envelope` — the operating envelope's sweep under QEMU: its section, its
//!   target rows and its figure;
//! - `figures` — the log-log scaling figure;
//! - `render` — the Markdown document and its number formats.

mod claims;
mod data;
mod envelope;
mod figures;
mod render;

pub use claims::*;
pub use data::*;
pub use envelope::*;
pub use figures::*;
pub use render::*;

/// The heading of the host bridge's section of `docs/benchmarks.md`, which
/// `cargo bench -p host-bridge --bench bridge` measures and a person writes: the
/// report keeps it (from this heading to the end) when it rewrites the document.
pub const KEPT_SECTION: &str = "## Host bridge";

/// The part of an existing `docs/benchmarks.md` the report keeps ([`KEPT_SECTION`]
/// to the end), empty if there is none.
pub fn kept_section(existing: &str) -> &str {
    existing
        .find(&format!("\n{KEPT_SECTION}"))
        .map_or("", |i| &existing[i + 1..])
}

/// The rendered report followed by the kept section of `existing`.
pub fn with_kept_section(rendered: &str, existing: &str) -> String {
    match kept_section(existing) {
        "" => rendered.to_owned(),
        kept => format!("{}\n\n{}", rendered.trim_end_matches('\n'), kept),
    }
}

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

/// Segment counts of the firmware runs besides the configuration's embedded
/// model's ([`firmware_segments`]).
pub const FIRMWARE_SEGMENTS: [usize; 4] = [8, 16, 32, 64];

/// Segment counts of the firmware runs: [`FIRMWARE_SEGMENTS`] and `embedded`, the
/// configuration's embedded model's count, in increasing order.
pub fn firmware_segments(embedded: usize) -> Vec<usize> {
    let mut sizes = FIRMWARE_SEGMENTS.to_vec();
    if !sizes.contains(&embedded) {
        sizes.push(embedded);
        sizes.sort_unstable();
    }
    sizes
}

/// `sizes` in words: "8, 12, 16, 32 and 64".
pub(crate) fn listed(sizes: &[usize]) -> String {
    match sizes.split_last() {
        None => String::new(),
        Some((last, [])) => last.to_string(),
        Some((last, rest)) => format!(
            "{} and {last}",
            rest.iter()
                .map(usize::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
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
        // Another size's row, then the embedded model's: the targets read the latter.
        inputs.firmware.push(FirmwareRow {
            segments: 64,
            grading: 1.0,
            outcome: Ok(FirmwareCounts {
                frame_max: 300_000,
                frame_mean: 290_000,
                rk4_steps: (4, 4),
                rk4_step_max: 75_000,
                rk4_step_mean: 72_000,
            }),
        });
        inputs.firmware.push(FirmwareRow {
            segments: inputs.embedded.0,
            grading: inputs.embedded.1,
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
        assert!(!md.contains("75,000 max, 72,000 mean per RK4 step"), "{md}");
        let (n, ratio) = inputs.embedded;
        assert!(
            md.contains(&format!(
                "| firmware, the embedded model ({n} segments graded {ratio})"
            )),
            "{md}"
        );
        // Without the RK4 step measurement the target has no verdict.
        let row = |md: &str| {
            md.lines()
                .find(|l| l.starts_with("| firmware, the embedded model"))
                .map(str::to_owned)
                .unwrap_or_default()
        };
        assert!(row(&md).ends_with("| - |"), "{}", row(&md));
        let mut cost = decoy_hil::step_cost::StepCost {
            four_stages: 31_200,
            first_stage_reused: 24_920,
            outputs: 7_960,
            path: 1_640,
            four_stages_min: 30_800,
        };
        inputs.step_cost = Ok(cost);
        let md = render(&inputs);
        assert!(row(&md).contains("31,200 max for an RK4 step evaluating all four stages"));
        assert!(
            row(&md).contains("45,000 max, 40,000 mean per RK4 step"),
            "{}",
            row(&md)
        );
        assert!(row(&md).ends_with("| **pass** |"), "{}", row(&md));
        assert!(md.contains("the output evaluation 7,960, the frame's flight path 1,640."));
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

    /// The headings and table header rows of a Markdown document, in order.
    fn structure(markdown: &str) -> Vec<&str> {
        let lines: Vec<&str> = markdown.lines().collect();
        let is_rule = |line: &str| {
            line.starts_with('|') && line.chars().all(|c| matches!(c, '|' | '-' | ':' | ' '))
        };
        (0..lines.len())
            .filter(|&i| {
                lines[i].starts_with('#')
                    || (lines[i].starts_with('|') && lines.get(i + 1).is_some_and(|l| is_rule(l)))
            })
            .map(|i| lines[i])
            .collect()
    }

    #[test]
    fn complete_results_render_the_sections_and_tables_of_the_document() {
        let (wall, instructions) = complete_results();
        let md = render(&Inputs {
            wall,
            instructions,
            ..Inputs::default()
        });
        let document = include_str!("../../../../docs/benchmarks.md");
        let md = with_kept_section(&md, document);
        assert_eq!(structure(&md), structure(document));
        // The check can fail: a renamed section is noticed.
        let renamed = md.replace("## Machine", "## Host");
        assert_ne!(structure(&renamed), structure(document));
    }
}
