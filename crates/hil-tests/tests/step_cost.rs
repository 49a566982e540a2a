//! The cost of one RK4 step on the target, exact under QEMU `-icount`: the
//! firmware's `examples/step_cost.rs` steps the embedded model (the reference
//! system's 12 segments graded 1.26, capacity 64) along the flight path of 10 ms
//! State frames, and logs each step's instructions ([`decoy_hil::step_cost`]).
//!
//! Asserted on every f32 board of `firmware/boards.toml`, the Cortex-M4F of
//! `mps2-an386` and the STM32F405 (`netduinoplus2`, whose 168 MHz SysTick reads
//! 125 instructions per 21 ticks): an RK4 step that evaluates all four stages
//! takes at most [`RK4_STEP_TARGET`] instructions (the benchmark issue's target),
//! at most issue 14's [`ISSUE_14_STEP_TARGET`] and at most [`RK4_STEP_GUARD`]
//! (just above the measurement); a
//! frame's first step, whose first stage is the previous frame's output evaluation
//! reused, is cheaper by most of an evaluation; and in the steady turn every frame
//! costs the same to within a few ticks. The f64 boards' (the M7's) counts are
//! printed.

mod common;

use common::{boards_in, on_each};
use decoy_hil::qemu::{Board, Precision};
use decoy_hil::step_cost::{StepCost, measure};

/// The benchmark issue's target for one RK4 step, M4 f32.
const RK4_STEP_TARGET: u32 = 40_000;
/// Issue 14's target for one RK4-equivalent step (f32, M4): met by the embedded
/// model (measured 22,400; it was 38,640 with 16 graded segments before issue 14,
/// 31,200 after its first step work, firmware/README.md).
const ISSUE_14_STEP_TARGET: u32 = 25_000;
/// A guard just above the measurement of a step evaluating all four stages, so that
/// a regression fails: measured 22,400 on the M4 and 22,422 on the STM32F405 (its
/// finer clock); lower it as the solver gets faster.
const RK4_STEP_GUARD: u32 = 22_500;

#[test]
fn an_rk4_step_on_every_f32_board_is_within_the_target() {
    on_each(&boards_in(Precision::F32), check_f32_step_cost);
}

/// The f32 step-cost checks on `board`.
fn check_f32_step_cost(board: Board) {
    let frames = measure(board).unwrap_or_else(|e| panic!("{e}"));
    let cost = StepCost::of(&frames);
    println!(
        "{board} f32, the embedded model: RK4 step with four stages max {} (min {}), first step of \
         a frame (first stage reused) max {}, output evaluation max {}, flight path of a frame \
         max {} instructions",
        cost.four_stages, cost.four_stages_min, cost.first_stage_reused, cost.outputs, cost.path
    );
    let verdict = if cost.four_stages <= ISSUE_14_STEP_TARGET {
        "met"
    } else {
        "NOT met"
    };
    println!("{board}: issue 14's target of {ISSUE_14_STEP_TARGET} per RK4 step: {verdict}");
    assert!(
        cost.four_stages <= RK4_STEP_TARGET,
        "an RK4 step took {} instructions, over {RK4_STEP_TARGET}: {frames:#?}",
        cost.four_stages
    );
    assert!(
        cost.four_stages <= ISSUE_14_STEP_TARGET,
        "an RK4 step took {} instructions, over issue 14's {ISSUE_14_STEP_TARGET}: {frames:#?}",
        cost.four_stages
    );
    assert!(
        cost.four_stages <= RK4_STEP_GUARD,
        "an RK4 step took {} instructions, over the guard of {RK4_STEP_GUARD}: {frames:#?}",
        cost.four_stages
    );
    assert!(
        cost.first_stage_reused + cost.outputs / 2 < cost.four_stages,
        "the first step does not reuse the output evaluation: {cost:?}"
    );
    // The turn's steps take data-dependent branches (table intervals, the
    // renormalisation's window): measured 22,320 to 22,400 on the M4, two
    // 40-instruction ticks, and 22,339 to 22,422 on the STM32F405 (its finer clock).
    assert!(
        cost.four_stages - cost.four_stages_min <= 440,
        "the steady turn's steps differ by more than 440 instructions: {frames:#?}"
    );
}

#[test]
fn the_f64_boards_step_cost_is_measured() {
    on_each(&boards_in(Precision::F64), check_f64_step_cost);
}

/// The f64 step cost on `board`, printed; a frame's first step must reuse the
/// output evaluation.
fn check_f64_step_cost(board: Board) {
    let frames = measure(board).unwrap_or_else(|e| panic!("{e}"));
    let cost = StepCost::of(&frames);
    println!(
        "{board} f64, the embedded model: RK4 step with four stages max {}, first step of a frame \
         (first stage reused) max {}, output evaluation max {} instructions",
        cost.four_stages, cost.first_stage_reused, cost.outputs
    );
    assert!(cost.first_stage_reused < cost.four_stages, "{cost:?}");
}
