//! The wave-speed step limit, the stepping rule's input that the controller
//! and the look-ahead share (docs/protocol.md §5): no RK4 step is longer than
//! [`WAVE_STEP_FACTOR`] l_i / c_i on any segment i, where c_i is the transverse
//! wave speed at the segment's larger end tension.

use solver_core::{Real, Solver};

/// Safety factor of the wave-speed step limit: every RK4 step is at most
/// `WAVE_STEP_FACTOR` l_i / c_i for every segment i, c_i = sqrt(T_i / mu) the
/// transverse wave speed at its larger end tension: a thin rod pulled at both
/// ends swings at sqrt(12) c/l, and RK4 is stable to about 2.8 rad per step.
pub const WAVE_STEP_FACTOR: f64 = 0.8;

/// max_i c_i / l_i (1/s), c_i = sqrt(T_i / mu) at the larger end tension of
/// segment i, with the tensions of the solver's last evaluation: the stepping
/// rule's input, the controller's and the look-ahead's.
pub(crate) fn wave_rate_of<T: Real, const N: usize>(solver: &Solver<T, N>) -> T {
    let model = solver.model();
    let out = solver.last_outputs();
    // max_i T_i^2 / l_i^4 from the squared joint forces (two roots in all):
    // then max_i c_i / l_i = sqrt(sqrt(max) / mu).
    // (Compare-and-select rather than `max`, which is a libm call on the M4F.)
    let larger = |a: T, b: T| if b > a { b } else { a };
    let mut worst = T::zero();
    let mut upstream = out.joint_force(0).norm_squared();
    for (l, force) in model.lengths().iter().zip(out.downstream_joint_forces()) {
        let downstream = force.norm_squared();
        let l2 = *l * *l;
        worst = larger(worst, larger(upstream, downstream) / (l2 * l2));
        upstream = downstream;
    }
    (worst.square_root() / model.params().cable.linear_density).square_root()
}

/// The steps of `dt` the wave-speed limit asks for at the wave-speed rate `rate`
/// (max_i c_i / l_i, 1/s): ceil(dt rate / [`WAVE_STEP_FACTOR`]); 0 if not finite
/// (saturating at `max` + 1).
pub(crate) fn wave_steps<T: Real>(dt: f64, rate: T, max: u32) -> u32 {
    // In T (f64 is emulated on the M4F); an exact integer here is a tie of no
    // consequence either way.
    let steps = (T::lit(dt) * rate * T::lit(1.0 / WAVE_STEP_FACTOR)).ceil();
    if !steps.finite() {
        return 0;
    }
    if steps > T::from_count(u64::from(max)) {
        max + 1
    } else {
        steps.truncated_index() as u32
    }
}
