//! The instruction cost of one RK4 step of the embedded model, measured on the
//! target: the firmware's solver (the reference system's embedded model, 12
//! segments graded 1.26, capacity 64; f32 on the Cortex-M4F, f64 with the `f64`
//! feature (the M7 profile)) stepped along the flight path of State frames 10 ms
//! apart, as `decoy_controller::Controller` steps it (four RK4 steps of
//! `MAX_STEP_S` = 2.5 ms per frame, the outputs evaluated at the frame), one
//! `Solver::step` at a time, without the link, validation or clearances around it.
//!
//! Under QEMU with `-icount` SysTick counts executed instructions (in ticks of 40),
//! so every number is exact and the same in every run. For each of
//! [`FRAMES`] frames of a turning acceleration at 9 km it logs (defmt):
//!
//! ```text
//! frame=<k> path=<n> first=<n> second=<n> outputs=<n>
//! ```
//!
//! - `path`: building the frame's `FramePath`;
//! - `first`: the frame's first RK4 step, whose first stage reuses the previous
//!   frame's output evaluation (same state, same aircraft bits);
//! - `second`: the costliest of the frame's other three RK4 steps, which evaluate
//!   all four stages;
//! - `outputs`: the output evaluation at the frame.
//!
//! and at the end `rk4 step max: four stages=<n> first stage reused=<n>`, then exits
//! with status 0 (a solver error exits 1). Run it with
//! `cargo run --release --example step_cost` in `firmware/` (the runner boots it in
//! QEMU); `cargo test -p hil-tests --test step_cost` runs it and checks the target.
#![no_std]
#![no_main]

use cortex_m as _;
use cortex_m_rt::entry;
use decoy_controller::{FramePath, InstructionCounter};
use decoy_firmware::{SEGMENT_CAPACITY, Scalar, board, reference};
use decoy_link::AircraftStateFrame;
use solver_core::{AircraftState, FlightPath, Model, Solver, Vec3, trim};
use static_cell::StaticCell;

/// Frames measured.
const FRAMES: u32 = 20;
/// Frame period, s.
const FRAME_S: f64 = 0.01;
/// RK4 steps per frame: the controller's nominal four of `MAX_STEP_S`.
const STEPS_PER_FRAME: u32 = 4;

type EmbeddedSolver = Solver<Scalar, SEGMENT_CAPACITY>;
static SOLVER: StaticCell<EmbeddedSolver> = StaticCell::new();

/// A level turn at 0.05 rad/s with 2 m/s^2 along the track, at 9 km, from 182 m/s
/// (about Mach 0.6).
fn frame(k: u32) -> AircraftStateFrame {
    let t = FRAME_S * f64::from(k);
    let (v0, a, w) = (182.0, 2.0, 0.05);
    let s = v0 * t + 0.5 * a * t * t;
    let v = v0 + a * t;
    let psi = w * t;
    let (sp, cp) = (libm::sin(psi), libm::cos(psi));
    AircraftStateFrame {
        seq: k,
        time_s: t,
        position_ned_m: [s * cp, s * sp, -9000.0],
        velocity_ned_mps: [(v * cp) as f32, (v * sp) as f32, 0.0],
        acceleration_ned_mps2: [
            (a * cp - v * w * sp) as f32,
            (a * sp + v * w * cp) as f32,
            0.0,
        ],
        attitude_wxyz: [
            libm::cos(psi / 2.0) as f32,
            0.0,
            0.0,
            libm::sin(psi / 2.0) as f32,
        ],
        body_rate_radps: [0.0, 0.0, w as f32],
        body_angular_acceleration_radps2: [0.0; 3],
    }
}

#[entry]
fn main() -> ! {
    let Some(board) = board::Board::take() else {
        defmt::error!("core peripherals already taken");
        board::fail()
    };
    let clock = board.clock;
    let system = &reference::SYSTEM;
    let Ok(params) = system.model_params::<Scalar>(system.embedded_layout()) else {
        defmt::error!("the aerodynamic table is unusable");
        board::fail()
    };
    let Ok(model) = Model::<Scalar, SEGMENT_CAPACITY>::new(params) else {
        defmt::error!("the model parameters are invalid");
        board::fail()
    };
    let origin = [0.0; 3];
    let first = FramePath::<Scalar>::single(&frame(0), origin).state_at(0.0);
    let steady = AircraftState {
        acceleration: Vec3::zeros(),
        angular_rate: Vec3::zeros(),
        angular_acceleration: Vec3::zeros(),
        ..first
    };
    let Ok(state) = trim(&model, &steady) else {
        defmt::error!("no trim");
        board::fail()
    };
    let solver = SOLVER.init_with(|| match Solver::new(model, state) {
        Ok(solver) => solver,
        Err(_) => board::fail(),
    });
    // The outputs at the trimmed state, as the controller answers its first frame.
    if solver
        .outputs(&FramePath::<Scalar>::single(&frame(0), origin))
        .is_err()
    {
        board::fail()
    }
    let counter = &clock;
    let (mut four_stages, mut reused) = (0u32, 0u32);
    for k in 1..=FRAMES {
        let (previous, current) = (frame(k - 1), frame(k));
        let measure = |f: &mut dyn FnMut() -> bool| {
            clock.align();
            let start = counter.now();
            let ok = f();
            let spent = counter.elapsed(start);
            if !ok {
                defmt::error!("solver error at frame {=u32}", k);
                board::fail()
            }
            spent
        };
        let mut path = FramePath::<Scalar>::single(&current, origin);
        let path_cost = measure(&mut || {
            path = FramePath::new(&previous, &current, origin)
                .towing(solver.model().params().connection_point);
            true
        });
        let dt = FRAME_S / STEPS_PER_FRAME as f64;
        let first_step = measure(&mut || solver.step(&path, dt).is_ok());
        let mut second_step = 0;
        for _ in 1..STEPS_PER_FRAME {
            second_step = second_step.max(measure(&mut || solver.step(&path, dt).is_ok()));
        }
        solver.set_time(current.time_s);
        let outputs = measure(&mut || solver.outputs(&path).is_ok());
        defmt::info!(
            "frame={=u32} path={=u32} first={=u32} second={=u32} outputs={=u32}",
            k,
            path_cost,
            first_step,
            second_step,
            outputs
        );
        four_stages = four_stages.max(second_step);
        reused = reused.max(first_step);
    }
    defmt::info!(
        "rk4 step max: four stages={=u32} first stage reused={=u32}",
        four_stages,
        reused
    );
    exit_success()
}

/// Ends the run with status 0 (QEMU semihosting); on hardware, parks the core.
fn exit_success() -> ! {
    #[cfg(feature = "qemu")]
    cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_SUCCESS);
    loop {
        cortex_m::asm::wfi();
    }
}
