//! The solver's capacity: the const generic `N` of `Model<f64, N>` chosen from a
//! run's segment count, in one place ([`with_capacity!`]).
//!
//! A capacity of [`SMALL_CAPACITY`] serves up to 32 segments and gives the same
//! numbers as [`MAX_SEGMENTS`] (tested in `run.rs`) with less to copy per step.

/// Capacity of the solver's segment arrays: the largest segment count a run may use.
pub const MAX_SEGMENTS: usize = 512;

/// Capacity of the model for small segment counts (up to this many segments).
pub const SMALL_CAPACITY: usize = 32;

/// Evaluates `$body` with the const `$n` set to the capacity for `$segments`
/// segments: [`SMALL_CAPACITY`] for up to 32, else [`MAX_SEGMENTS`].
///
/// `with_capacity!(layout.count(), N => run_with::<N>(..))` monomorphises `$body`
/// for both capacities and runs the one the count needs.
macro_rules! with_capacity {
    ($segments:expr, $n:ident => $body:expr) => {
        if $segments <= $crate::capacity::SMALL_CAPACITY {
            const $n: usize = $crate::capacity::SMALL_CAPACITY;
            $body
        } else {
            const $n: usize = $crate::capacity::MAX_SEGMENTS;
            $body
        }
    };
}
pub(crate) use with_capacity;
