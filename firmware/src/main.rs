//! Firmware for the towed-decoy model on a Cortex-M4F (QEMU `mps2-an386`).
//!
//! Builds the reference system's reduced model in f32 (16 graded segments, capacity
//! 64), trims it in level flight at 9 km, Mach 0.6, and runs the acceleration case of
//! [`scenario`] for 3 s of control steps. It prints over semihosting, with fixed
//! formatting so that two runs are byte-identical:
//!
//! ```text
//! trim instr=<n>
//! t=<s> T0=<connection tension, N> TN=<tow tension, N> pitch=<decoy pitch, deg> instr=<n>
//! ...                                      (every `REPORT_EVERY` control steps)
//! memory solver_bytes=<n> stack_used=<n> stack_size=<n>
//! done steps=<n> max_instr=<n> mean_instr=<n>
//! ```
//!
//! `instr` is the instructions executed by that one control step (its RK4 steps
//! and the flight-path samples they take), counted under QEMU `-icount`. The exit
//! code is 0 on success; an error, panic or HardFault prints a line and exits 1.
#![no_std]
#![no_main]

mod board;
mod reference;
mod scenario;

use core::fmt;

// Links cortex-m's `critical-section` implementation (used by semihosting).
use cortex_m as _;
use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use solver_core::{
    AeroTableError, AtmosphereError, ConfigError, FlightPath, Model, SolveError, Solver, TrimError,
    trim,
};
use static_cell::StaticCell;

use board::Board;
use scenario::{Acceleration, CONTROL_STEPS, REPORT_EVERY, SEGMENT_CAPACITY, SUBSTEPS, substep_s};

/// The embedded solver: f32, room for [`SEGMENT_CAPACITY`] segments.
type EmbeddedSolver = Solver<f32, SEGMENT_CAPACITY>;

/// The solver lives in static memory (`.bss`), not on the stack.
static SOLVER: StaticCell<EmbeddedSolver> = StaticCell::new();

#[entry]
fn main() -> ! {
    board::paint_stack();
    let Some(board) = Board::take() else {
        hprintln!("error: core peripherals already taken");
        board::exit_failure()
    };
    match run(&board) {
        Ok(summary) => {
            hprintln!(
                "memory solver_bytes={} stack_used={} stack_size={}",
                core::mem::size_of::<EmbeddedSolver>(),
                board::stack_high_water(),
                board::stack_size()
            );
            hprintln!(
                "done steps={} max_instr={} mean_instr={}",
                summary.steps,
                summary.max_instructions,
                summary.mean_instructions()
            );
            board::exit_success()
        }
        Err(e) => {
            hprintln!("error: {}", e);
            board::exit_failure()
        }
    }
}

/// Instruction counts over the control steps.
struct Summary {
    steps: u32,
    max_instructions: u32,
    total_instructions: u64,
}

impl Summary {
    fn record(&mut self, instructions: u32) {
        self.steps += 1;
        self.max_instructions = self.max_instructions.max(instructions);
        self.total_instructions += u64::from(instructions);
    }

    /// Mean per step, rounded down (0 before any step).
    fn mean_instructions(&self) -> u64 {
        self.total_instructions
            .checked_div(u64::from(self.steps))
            .unwrap_or(0)
    }
}

/// Builds, trims and runs the model, printing a line every [`REPORT_EVERY`] steps.
fn run(board: &Board) -> Result<Summary, AppError> {
    let counter = &board.instructions;
    let params = reference::model_params(reference::embedded_layout())?;
    let model = Model::<f32, SEGMENT_CAPACITY>::new(params)?;
    let path = Acceleration::new(&params.environment.atmosphere)?;

    let start = counter.now();
    let trimmed = trim(&model, &FlightPath::<f32>::state_at(&path, 0.0))?;
    hprintln!("trim instr={}", counter.since(start));

    let solver = SOLVER.init(Solver::new(model, trimmed)?);
    let mut summary = Summary {
        steps: 0,
        max_instructions: 0,
        total_instructions: 0,
    };
    for step in 1..=CONTROL_STEPS {
        let start = counter.now();
        for _ in 0..SUBSTEPS {
            solver.step(&path, substep_s())?;
        }
        let instructions = counter.since(start);
        summary.record(instructions);

        if step % REPORT_EVERY == 0 {
            let out = solver.outputs(&path)?;
            let pitch = out.decoy().map_or(f32::NAN, |d| d.euler.1.to_degrees());
            hprintln!(
                "t={:.4} T0={:.4} TN={:.4} pitch={:.4} instr={}",
                out.time(),
                out.connection_tension(),
                out.tow_tension(),
                pitch,
                instructions
            );
        }
    }
    Ok(summary)
}

/// What can stop the run, by stage.
#[derive(Debug)]
enum AppError {
    /// The aerodynamic table of the reference system is unusable.
    AeroTable(AeroTableError),
    /// The model parameters are invalid.
    Config(ConfigError),
    /// The scenario's altitude is outside the atmosphere.
    Atmosphere(AtmosphereError),
    /// No trim was found.
    Trim(TrimError),
    /// A step or an output evaluation failed.
    Solve(SolveError),
}

impl fmt::Display for AppError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AppError::AeroTable(e) => write!(f, "aerodynamic table: {e}"),
            AppError::Config(e) => write!(f, "model: {e}"),
            AppError::Atmosphere(e) => write!(f, "scenario: {e}"),
            AppError::Trim(e) => write!(f, "trim: {e}"),
            AppError::Solve(e) => write!(f, "solver: {e}"),
        }
    }
}

impl From<AeroTableError> for AppError {
    fn from(e: AeroTableError) -> Self {
        AppError::AeroTable(e)
    }
}
impl From<ConfigError> for AppError {
    fn from(e: ConfigError) -> Self {
        AppError::Config(e)
    }
}
impl From<AtmosphereError> for AppError {
    fn from(e: AtmosphereError) -> Self {
        AppError::Atmosphere(e)
    }
}
impl From<TrimError> for AppError {
    fn from(e: TrimError) -> Self {
        AppError::Trim(e)
    }
}
impl From<SolveError> for AppError {
    fn from(e: SolveError) -> Self {
        AppError::Solve(e)
    }
}
