//! The cost of one RK4 step on the target, exact under QEMU `-icount`: the
//! firmware's `examples/step_cost.rs` steps the embedded model (the reference
//! system's segments and grading) along the flight path of 10 ms State frames,
//! and logs each step's instructions ([`decoy_hil::step_cost`]).
//!
//! On every board of `firmware/boards.toml`: an RK4 step that evaluates all
//! four stages within the board's budget ([`budgets::rk4_step`]: issue 14's on
//! the f32 boards, the Cortex-M4F of `mps2-an386` and the STM32F405, whose
//! 168 MHz SysTick reads 125 instructions per 21 ticks; the f64 boards', the
//! M7's, has none); a frame's first step, whose first stage is the previous
//! frame's output evaluation reused, cheaper by most of an evaluation; then
//! every count against its baseline (`crates/hil-tests/baselines.toml`,
//! `[step_cost.BOARD]`, within the baselines' `COUNT_MARGIN`: `-icount`
//! repeats the counts exactly). The spread between the dearest and the
//! cheapest four-stage step of the steady turn (its data-dependent branches:
//! table intervals, the renormalisation's window) is a baseline too, within
//! the same margin of the step, so that a step whose cost starts to depend on
//! the state fails. With `DECOY_BLESS=1` the counts are written instead
//! (`cargo xtask bless`).

mod common;

use common::baselines::{self, Margin, Ratchet};
use common::{boards_in, on_each};
use decoy_hil::budgets;
use decoy_hil::qemu::{Board, Precision};
use decoy_hil::step_cost::{StepCost, measure};

/// The section of the baselines.
const SECTION: &str = "step_cost";

#[test]
fn an_rk4_step_on_every_f32_board_is_within_its_budget_and_baseline() {
    on_each(&boards_in(Precision::F32), check_step_cost);
}

/// The f64 boards apart, so that the harness runs them beside the f32 boards.
#[test]
fn an_rk4_step_on_every_f64_board_is_within_its_baseline() {
    on_each(&boards_in(Precision::F64), check_step_cost);
}

/// The step-cost checks on `board`.
fn check_step_cost(board: Board) {
    let frames = measure(board).unwrap_or_else(|e| panic!("{e}"));
    let cost = StepCost::of(&frames);
    let spread = cost.four_stages - cost.four_stages_min;
    println!(
        "{board} {}, the embedded model: RK4 step with four stages max {} (min {}), first step \
         of a frame (first stage reused) max {}, output evaluation max {}, flight path of a \
         frame max {} instructions",
        board.precision(),
        cost.four_stages,
        cost.four_stages_min,
        cost.first_stage_reused,
        cost.outputs,
        cost.path
    );
    if let Some(budget) = budgets::rk4_step(board) {
        budget
            .check(&board.to_string(), cost.four_stages)
            .unwrap_or_else(|e| panic!("{e}: {frames:#?}"));
    }
    assert!(
        cost.first_stage_reused + cost.outputs / 2 < cost.four_stages,
        "{board}: the first step does not reuse the output evaluation: {cost:?}"
    );
    let path = [SECTION, board.name()];
    if baselines::blessing() {
        baselines::record(&path, |t| {
            t.clear();
            for (name, n) in [
                ("four_stages", cost.four_stages),
                ("four_stages_min", cost.four_stages_min),
                ("spread", spread),
                ("first_stage_reused", cost.first_stage_reused),
                ("outputs", cost.outputs),
                ("path", cost.path),
            ] {
                t.insert(name.into(), baselines::int(n));
            }
        });
        return;
    }
    let mut ratchet = Ratchet::new(&path, board.to_string());
    ratchet.count("four_stages", cost.four_stages);
    // The spread is a difference of two counts: its margin is theirs.
    let spread_margin = ratchet.baseline("four_stages").map_or(Margin::Exact, |b| {
        Margin::Absolute(b * baselines::COUNT_MARGIN_FRACTION)
    });
    ratchet.at_most("spread", f64::from(spread), spread_margin);
    ratchet.count("first_stage_reused", cost.first_stage_reused);
    ratchet.count("outputs", cost.outputs);
    ratchet.count("path", cost.path);
    ratchet.finish();
}
