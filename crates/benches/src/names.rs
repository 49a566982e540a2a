//! The benchmark ids, defined once for the benchmarks and the report.
//!
//! The criterion benchmarks (`benches/rk4_step.rs`) register their groups and
//! functions with these constants; the gungraun benchmarks (`benches/instructions.rs`)
//! are named by Rust identifiers in attribute macros, which cannot take constants, so
//! a test here reads that file and checks that it defines exactly
//! [`expected_instruction_keys`]. The criterion sizes are const-generic literals in
//! macro calls; a test checks them against [`WALL_STEP_SIZES`],
//! [`WALL_DENSE_STEP_SIZES`] and [`TENSION_SIZES`]. The report reads its cells with the key functions
//! below, and `bench-report` fails when a result it expects is missing or a result it
//! does not know appears ([`crate::report::check_complete`]): a renamed benchmark is
//! an error, not a table cell reading "n/a".
//!
//! Criterion keys are `group/function/value` (criterion's `full_id`), gungraun keys
//! `group/function/id`.

use crate::passes::Pass;

/// Criterion group: one RK4 step of the compound pendulum.
pub const PENDULUM_RK4_STEP: &str = "pendulum_rk4_step";
/// Criterion group: one RK4 step of the reference towed system.
pub const TOWED_RK4_STEP: &str = "towed_rk4_step";
/// Criterion group: one tension solve (derivative evaluation) of the pendulum.
pub const TENSION_SOLVE: &str = "tension_solve";
/// Criterion group: the passes of one evaluation of the towed system.
pub const EVAL_BREAKDOWN: &str = "eval_breakdown";
/// Gungraun group of the RK4 steps.
pub const STEPS: &str = "steps";
/// Gungraun group of the tension solves.
pub const TENSION: &str = "tension";
/// Gungraun group of the passes of one evaluation.
pub const BREAKDOWN: &str = "breakdown";

/// The towed model with 16 graded segments (both harnesses).
pub const GRADED16: &str = "graded16";
/// Prefix of the towed scaling series' sizes (`uniform{N}`, both harnesses).
pub const UNIFORM: &str = "uniform";
/// Tension-solve methods, as named in both harnesses.
pub const TENSION_METHODS: [&str; 3] = ["two_sweep", "shooting", "dense"];
/// The towed configurations of the evaluation breakdown (both harnesses).
pub const BREAKDOWN_CASES: [&str; 4] = [
    "f64_graded16",
    "f32_graded16",
    "f64_uniform300",
    "f32_uniform300",
];
/// The precisions of the graded towed step, as named in both harnesses.
pub const GRADED_PRECISIONS: [&str; 2] = ["f32", "f64"];

/// Sizes of the criterion RK4-step series with O(N) derivatives (two-sweep f64 and
/// f32, shooting), pendulum and towed.
pub const WALL_STEP_SIZES: [u32; 6] = [16, 64, 300, 1024, 2048, 4096];
/// Sizes of the criterion RK4-step series with the dense derivatives.
pub const WALL_DENSE_STEP_SIZES: [u32; 3] = [16, 64, 300];
/// Sizes of the gungraun RK4-step series with O(N) derivatives.
pub const INSTRUCTION_STEP_SIZES: [u32; 5] = [8, 64, 300, 1024, 4096];
/// Sizes of the gungraun RK4-step series with the dense derivatives.
pub const INSTRUCTION_DENSE_STEP_SIZES: [u32; 3] = [8, 64, 300];
/// Sizes of the tension-solve benchmarks (both harnesses).
pub const TENSION_SIZES: [u32; 3] = [16, 64, 300];

/// The system an RK4-step series runs on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum System {
    /// The compound pendulum on a fixed anchor (`pendulum_rk4_step`, `steps/pendulum_*`).
    Pendulum,
    /// The trimmed reference towed system, uniform segments (`towed_rk4_step/*/uniform{N}`).
    Towed,
}

/// How the derivatives of an RK4-step series are computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    /// The two-sweep recurrence in f64 (`Solver::step`).
    F64,
    /// The two-sweep recurrence in f32 (`Solver::step`).
    F32,
    /// The shooting form (f64), which diverges with N.
    Shooting,
    /// The dense Kane reference (f64), O(N³).
    Dense,
}

impl Variant {
    /// Every variant, in table order.
    pub const ALL: [Variant; 4] = [
        Variant::F64,
        Variant::F32,
        Variant::Shooting,
        Variant::Dense,
    ];

    /// The variant's part of the benchmark names.
    pub fn name(self) -> &'static str {
        match self {
            Variant::F64 => "f64",
            Variant::F32 => "f32",
            Variant::Shooting => "shooting",
            Variant::Dense => "dense",
        }
    }

    /// A short label for tables and the figure.
    pub fn label(self) -> &'static str {
        match self {
            Variant::F64 => "two-sweep f64",
            Variant::F32 => "two-sweep f32",
            Variant::Shooting => "shooting f64",
            Variant::Dense => "dense f64",
        }
    }

    /// The sizes of the variant's criterion series.
    pub fn wall_sizes(self) -> &'static [u32] {
        match self {
            Variant::Dense => &WALL_DENSE_STEP_SIZES,
            _ => &WALL_STEP_SIZES,
        }
    }

    /// The sizes of the variant's gungraun series.
    pub fn instruction_sizes(self) -> &'static [u32] {
        match self {
            Variant::Dense => &INSTRUCTION_DENSE_STEP_SIZES,
            _ => &INSTRUCTION_STEP_SIZES,
        }
    }
}

impl System {
    /// Both systems, in table order.
    pub const ALL: [System; 2] = [System::Pendulum, System::Towed];

    /// A short label for tables and the figure.
    pub fn label(self) -> &'static str {
        match self {
            System::Pendulum => "pendulum",
            System::Towed => "towed system",
        }
    }

    /// The criterion group of the system's RK4 steps.
    pub fn wall_group(self) -> &'static str {
        match self {
            System::Pendulum => PENDULUM_RK4_STEP,
            System::Towed => TOWED_RK4_STEP,
        }
    }

    /// The criterion value of size `n` (`{N}` for the pendulum, `uniform{N}` for the
    /// towed system).
    pub fn wall_size(self, n: u32) -> String {
        match self {
            System::Pendulum => n.to_string(),
            System::Towed => format!("{UNIFORM}{n}"),
        }
    }
}

/// Criterion key of one RK4 step of a series.
pub fn wall_step_key(system: System, variant: Variant, n: u32) -> String {
    format!(
        "{}/{}/{}",
        system.wall_group(),
        variant.name(),
        system.wall_size(n)
    )
}

/// Gungraun key of one RK4 step of a series.
pub fn instr_step_key(system: System, variant: Variant, n: u32) -> String {
    match system {
        System::Pendulum => format!("{STEPS}/pendulum_{}/n{n}", variant.name()),
        System::Towed => format!("{STEPS}/towed_{}/{UNIFORM}{n}", variant.name()),
    }
}

/// Criterion key of one RK4 step of the graded towed model (`precision`: `f32`, `f64`).
pub fn wall_graded_key(precision: &str) -> String {
    format!("{TOWED_RK4_STEP}/{precision}/{GRADED16}")
}

/// Gungraun key of one RK4 step of the graded towed model.
pub fn instr_graded_key(precision: &str) -> String {
    format!("{STEPS}/towed_{precision}/{GRADED16}")
}

/// Criterion key of one tension solve.
pub fn wall_tension_key(method: &str, n: u32) -> String {
    format!("{TENSION_SOLVE}/{method}/{n}")
}

/// Gungraun key of one tension solve.
pub fn instr_tension_key(method: &str, n: u32) -> String {
    format!("{TENSION}/{method}/n{n}")
}

/// Criterion key of one pass of the evaluation breakdown.
pub fn wall_breakdown_key(case: &str, pass: &str) -> String {
    format!("{EVAL_BREAKDOWN}/{case}/{pass}")
}

/// Gungraun key of one pass of the evaluation breakdown.
pub fn instr_breakdown_key(case: &str, pass: &str) -> String {
    format!("{BREAKDOWN}/{case}/{pass}")
}

/// Every criterion result the report reads.
pub fn expected_wall_keys() -> Vec<String> {
    let mut keys = Vec::new();
    for system in System::ALL {
        for variant in Variant::ALL {
            for &n in variant.wall_sizes() {
                keys.push(wall_step_key(system, variant, n));
            }
        }
    }
    keys.extend(GRADED_PRECISIONS.map(wall_graded_key));
    for method in TENSION_METHODS {
        keys.extend(TENSION_SIZES.map(|n| wall_tension_key(method, n)));
    }
    for case in BREAKDOWN_CASES {
        keys.extend(Pass::ALL.map(|pass| wall_breakdown_key(case, pass.name())));
    }
    keys
}

/// Every gungraun result the report reads.
pub fn expected_instruction_keys() -> Vec<String> {
    let mut keys = Vec::new();
    for system in System::ALL {
        for variant in Variant::ALL {
            for &n in variant.instruction_sizes() {
                keys.push(instr_step_key(system, variant, n));
            }
        }
    }
    keys.extend(GRADED_PRECISIONS.map(instr_graded_key));
    for method in TENSION_METHODS {
        keys.extend(TENSION_SIZES.map(|n| instr_tension_key(method, n)));
    }
    for case in BREAKDOWN_CASES {
        keys.extend(Pass::ALL.map(|pass| instr_breakdown_key(case, pass.name())));
    }
    keys
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeSet;

    #[test]
    fn keys_match_the_benchmark_names() {
        assert_eq!(
            wall_step_key(System::Pendulum, Variant::F32, 4096),
            "pendulum_rk4_step/f32/4096"
        );
        assert_eq!(
            wall_step_key(System::Towed, Variant::Dense, 300),
            "towed_rk4_step/dense/uniform300"
        );
        assert_eq!(
            instr_step_key(System::Pendulum, Variant::Shooting, 64),
            "steps/pendulum_shooting/n64"
        );
        assert_eq!(
            instr_step_key(System::Towed, Variant::F64, 8),
            "steps/towed_f64/uniform8"
        );
        assert_eq!(wall_graded_key("f32"), "towed_rk4_step/f32/graded16");
        assert_eq!(instr_tension_key("dense", 300), "tension/dense/n300");
        assert_eq!(
            wall_breakdown_key("f64_graded16", "prepare"),
            "eval_breakdown/f64_graded16/prepare"
        );
    }

    #[test]
    fn expected_keys_are_distinct() {
        let wall = expected_wall_keys();
        let instr = expected_instruction_keys();
        assert_eq!(wall.iter().collect::<BTreeSet<_>>().len(), wall.len());
        assert_eq!(instr.iter().collect::<BTreeSet<_>>().len(), instr.len());
        // 2 systems x (3 x 6 + 3) steps, 2 graded, 9 tension solves, 24 passes.
        assert_eq!(wall.len(), 2 * 21 + 2 + 9 + 24);
        // 2 systems x (3 x 5 + 3) steps, 2 graded, 9 tension solves, 24 passes.
        assert_eq!(instr.len(), 2 * 18 + 2 + 9 + 24);
    }

    /// The `group/function/id` keys that gungraun source text defines: every
    /// `#[bench::ID(` attribute belongs to the next `fn FUNCTION(`, and every function
    /// to the `library_benchmark_group!` whose `benchmarks = [...]` lists it.
    fn gungraun_keys(source: &str) -> BTreeSet<String> {
        let mut ids_of = Vec::new();
        let mut pending = Vec::new();
        for line in source.lines().map(str::trim) {
            if let Some(rest) = line.strip_prefix("#[bench::") {
                let id: String = rest.chars().take_while(|c| *c != '(').collect();
                pending.push(id);
            } else if let Some(rest) = line.strip_prefix("fn ") {
                let function: String = rest.chars().take_while(|c| *c != '(').collect();
                if !pending.is_empty() {
                    ids_of.push((function, std::mem::take(&mut pending)));
                }
            }
        }
        let mut keys = BTreeSet::new();
        let mut rest = source;
        while let Some(start) = rest.find("library_benchmark_group!(") {
            let body = &rest[start..];
            let end = body.find(");").expect("a closed group");
            let group_text = &body[..end];
            let group = group_text
                .split("name =")
                .nth(1)
                .and_then(|s| s.split(',').next())
                .expect("a group name")
                .trim();
            let list = group_text
                .split("benchmarks =")
                .nth(1)
                .expect("a benchmark list");
            let list = list.trim().trim_start_matches('[');
            let list = list.split(']').next().expect("a closed list");
            for function in list.split(',').map(str::trim).filter(|f| !f.is_empty()) {
                let ids = ids_of
                    .iter()
                    .find(|(f, _)| f == function)
                    .map(|(_, ids)| ids.clone())
                    .unwrap_or_default();
                for id in ids {
                    keys.insert(format!("{group}/{function}/{id}"));
                }
            }
            rest = &body[end..];
        }
        keys
    }

    #[test]
    fn the_gungraun_benchmarks_define_exactly_the_expected_keys() {
        let defined = gungraun_keys(include_str!("../benches/instructions.rs"));
        let expected: BTreeSet<String> = expected_instruction_keys().into_iter().collect();
        let missing: Vec<_> = expected.difference(&defined).collect();
        let unknown: Vec<_> = defined.difference(&expected).collect();
        assert!(
            missing.is_empty() && unknown.is_empty(),
            "benches/instructions.rs does not define {missing:?}; it defines unknown {unknown:?}"
        );
    }

    #[test]
    fn a_renamed_gungraun_benchmark_is_noticed() {
        let source = include_str!("../benches/instructions.rs");
        let renamed = source.replace("fn towed_dense(", "fn towed_kane(");
        let defined = gungraun_keys(&renamed);
        assert!(!defined.contains(&instr_step_key(System::Towed, Variant::Dense, 64)));
        let renamed_id = source.replacen(
            "#[bench::n300(setup = pendulum_case",
            "#[bench::m300(setup = pendulum_case",
            1,
        );
        let defined = gungraun_keys(&renamed_id);
        assert!(!defined.contains(&instr_step_key(System::Pendulum, Variant::F64, 300)));
        assert!(defined.contains("steps/pendulum_f64/m300"));
    }

    /// The literal sizes after `marker` up to `end` on every line of `source` that
    /// holds `marker` (skipping the macro's own pattern, which has no digits).
    fn literal_sizes(source: &str, marker: &str, end: char) -> Vec<Vec<u32>> {
        source
            .lines()
            .filter_map(|line| line.split_once(marker).map(|(_, rest)| rest))
            .map(|rest| {
                rest.split(end)
                    .next()
                    .unwrap_or_default()
                    .split(',')
                    .filter_map(|n| n.trim().parse().ok())
                    .collect::<Vec<u32>>()
            })
            .filter(|sizes| !sizes.is_empty())
            .collect()
    }

    #[test]
    fn the_criterion_benchmarks_register_the_expected_sizes() {
        let source = include_str!("../benches/rk4_step.rs");
        // The pendulum and the towed scaling series.
        assert_eq!(
            literal_sizes(source, "o_n:", ';'),
            vec![WALL_STEP_SIZES.to_vec(); 2]
        );
        assert_eq!(
            literal_sizes(source, "dense:", ')'),
            vec![WALL_DENSE_STEP_SIZES.to_vec(); 2]
        );
        assert_eq!(
            literal_sizes(source, "tension_solve!(group,", ')'),
            vec![TENSION_SIZES.to_vec()]
        );
        // A changed size is noticed.
        let changed = source.replace(
            "o_n: 16, 64, 300, 1024, 2048, 4096",
            "o_n: 16, 64, 300, 1024, 4096",
        );
        assert_ne!(
            literal_sizes(&changed, "o_n:", ';'),
            vec![WALL_STEP_SIZES.to_vec(); 2]
        );
    }
}
