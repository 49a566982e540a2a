//! The firmware's `examples/step_cost.rs`: the cost of one RK4 step of the
//! embedded model on the target, exact under QEMU `-icount` (see the example's
//! documentation for what it steps and logs).

use std::time::Duration;

use crate::defmt;
use crate::firmware;
use crate::qemu::{Board, Qemu};

/// The example's name (`firmware/examples/step_cost.rs`).
pub const EXAMPLE: &str = "step_cost";
/// Frames the example measures.
pub const FRAMES: usize = 20;

/// One measured frame, instructions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepCostFrame {
    /// Building the frame's flight path.
    pub path: u32,
    /// The frame's first RK4 step (its first stage reused from the previous
    /// frame's output evaluation).
    pub first: u32,
    /// The frame's second RK4 step (all four stages evaluated).
    pub second: u32,
    /// The output evaluation at the frame.
    pub outputs: u32,
}

/// Maxima over the measured frames, instructions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StepCost {
    /// An RK4 step evaluating all four stages.
    pub four_stages: u32,
    /// A frame's first RK4 step, its first stage reused.
    pub first_stage_reused: u32,
    /// The output evaluation.
    pub outputs: u32,
    /// The flight path of a frame.
    pub path: u32,
    /// The fewest instructions of a four-stage step (steady flight: within a few
    /// 40-instruction ticks of the most).
    pub four_stages_min: u32,
}

impl StepCost {
    /// The maxima (and the four-stage minimum) of `frames`; zero for none.
    pub fn of(frames: &[StepCostFrame]) -> Self {
        let max = |f: fn(&StepCostFrame) -> u32| frames.iter().map(f).max().unwrap_or(0);
        StepCost {
            four_stages: max(|f| f.second),
            first_stage_reused: max(|f| f.first),
            outputs: max(|f| f.outputs),
            path: max(|f| f.path),
            four_stages_min: frames.iter().map(|f| f.second).min().unwrap_or(0),
        }
    }
}

/// Builds the example for `board`, runs it under QEMU and returns the frames it
/// logged; the error says what failed (build, run, decoding, or the log).
pub fn measure(board: Board) -> Result<Vec<StepCostFrame>, String> {
    defmt::require().map_err(|e| e.to_string())?;
    let elf = firmware::build_example(board, EXAMPLE, firmware::BUILD_TIMEOUT)
        .map_err(|e| e.to_string())?;
    let run = Qemu::new()
        .board(board)
        .timeout(Duration::from_secs(120))
        .run(&elf)
        .map_err(|e| e.to_string())?;
    if !run.status.success() {
        return Err(format!(
            "the {EXAMPLE} example failed on {}:\n{}",
            board.name(),
            defmt::describe(&elf, &run.stdout)
        ));
    }
    let log = defmt::decode(&elf, &run.stdout).map_err(|e| e.to_string())?;
    let frames = parse(&log)?;
    if frames.len() != FRAMES {
        return Err(format!(
            "the {EXAMPLE} example logged {} frames, not {FRAMES}:\n{log}",
            frames.len()
        ));
    }
    Ok(frames)
}

/// The `frame=... path=... first=... second=... outputs=...` lines of a decoded log.
pub fn parse(log: &str) -> Result<Vec<StepCostFrame>, String> {
    let field = |line: &str, key: &str| -> Result<u32, String> {
        line.split_whitespace()
            .find_map(|word| word.strip_prefix(key)?.strip_prefix('='))
            .and_then(|value| value.parse().ok())
            .ok_or_else(|| format!("no {key}=<count> in the log line `{line}`"))
    };
    log.lines()
        .filter(|line| line.split_whitespace().any(|w| w.starts_with("frame=")))
        .map(|line| {
            Ok(StepCostFrame {
                path: field(line, "path")?,
                first: field(line, "first")?,
                second: field(line, "second")?,
                outputs: field(line, "outputs")?,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_frame_lines_and_names_a_missing_field() {
        let log = "INFO  decoy\nINFO  frame=1 path=800 first=30720 second=38400 outputs=8600\n\
                   INFO  frame=2 path=840 first=30760 second=38440 outputs=8600\n\
                   INFO  rk4 step max: four stages=38440 first stage reused=30760\n";
        let frames = parse(log).unwrap();
        assert_eq!(frames.len(), 2);
        let cost = StepCost::of(&frames);
        assert_eq!(cost.four_stages, 38_440);
        assert_eq!(cost.four_stages_min, 38_400);
        assert_eq!(cost.first_stage_reused, 30_760);
        assert_eq!(cost.path, 840);
        let broken = parse("INFO  frame=3 path=800 first=1 outputs=2");
        assert!(broken.unwrap_err().contains("no second="));
    }
}
