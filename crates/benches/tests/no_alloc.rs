//! Zero heap allocations per step: `Solver::step` and `Solver::outputs` must not
//! touch the allocator (the pendulum, and the towed model with its aerodynamics and
//! decoy, graded and uniform, f32 and f64), so the same code runs on a target without one and its
//! timing has no allocator noise.
//!
//! A counting global allocator wraps [`System`] and counts, per thread, every
//! `alloc`, `alloc_zeroed` and `realloc`. The test harness runs each test on its own
//! thread, so a thread-local counter sees exactly the allocations of the code under
//! test, whatever else runs in parallel. [`a_vec_in_the_counted_region_counts_one`]
//! checks that the counter does see allocations, so the zero results mean something.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::hint::black_box;

use benches::{
    GRADED_COUNT, PENDULUM_DT, TOWED_DT, TOWED_SCALING_DT, cruise_path, fixed_anchor,
    graded_layout, pendulum_solver, towed_solver, towed_uniform_solver,
};
use solver_core::{FlightPath, Real, Solver};

/// Steps (and output evaluations) per case.
const CALLS: usize = 1000;

thread_local! {
    /// Allocations made by this thread so far. Const-initialised `Cell` without a
    /// destructor: reading it never allocates and never fails.
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

/// [`System`], counting allocations per thread.
struct CountingAllocator;

fn count_one() {
    // `try_with`: during thread teardown the slot may be gone; nothing to count then.
    let _ = ALLOCATIONS.try_with(|count| count.set(count.get() + 1));
}

// The one unsafe item of the benches crate: `GlobalAlloc` is an unsafe trait. The
// crate denies `unsafe_code` instead of forbidding it (Cargo.toml says why) so that
// this impl can allow it locally. Every method forwards to `System` with the
// caller's arguments unchanged, so `System`'s guarantees carry over.
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count_one();
        // SAFETY: forwarded unchanged; the caller upholds `GlobalAlloc::alloc`'s contract.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count_one();
        // SAFETY: as `alloc`.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count_one();
        // SAFETY: `ptr` came from this allocator, that is from `System`; forwarded unchanged.
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from this allocator, that is from `System`; forwarded unchanged.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

/// Allocations this thread made while running `f`, and `f`'s result.
fn allocations_in<R>(f: impl FnOnce() -> R) -> (u64, R) {
    let before = ALLOCATIONS.with(Cell::get);
    let result = f();
    let after = ALLOCATIONS.with(Cell::get);
    (after - before, result)
}

/// Allocations made by [`CALLS`] RK4 steps of `solver` along `path`.
fn allocations_per_steps<T: Real, const N: usize, P: FlightPath<T>>(
    solver: &mut Solver<T, N>,
    path: &P,
    dt: f64,
) -> u64 {
    let (count, ()) = allocations_in(|| {
        for _ in 0..CALLS {
            solver
                .step(black_box(path), black_box(dt))
                .expect("RK4 step");
        }
    });
    black_box(solver.state());
    count
}

/// Allocations made by [`CALLS`] output evaluations (and reading them).
fn allocations_per_outputs<T: Real, const N: usize, P: FlightPath<T>>(
    solver: &mut Solver<T, N>,
    path: &P,
) -> u64 {
    let (count, ()) = allocations_in(|| {
        for _ in 0..CALLS {
            let out = solver.outputs(black_box(path)).expect("outputs");
            black_box((
                out.time(),
                out.connection_tension(),
                out.tow_tension(),
                out.decoy(),
            ));
        }
    });
    count
}

#[test]
fn a_vec_in_the_counted_region_counts_one() {
    let (count, v) = allocations_in(|| black_box(Vec::<u64>::with_capacity(16)));
    assert_eq!(count, 1, "the counting allocator missed an allocation");
    drop(v);
    let (count, ()) = allocations_in(|| ());
    assert_eq!(count, 0);
}

#[test]
fn pendulum_300_f64_steps_do_not_allocate() {
    let mut solver = pendulum_solver::<f64, 300>(300);
    let anchor = fixed_anchor::<f64>();
    let count = allocations_per_steps(&mut *solver, &anchor, PENDULUM_DT);
    assert_eq!(
        count, 0,
        "{CALLS} pendulum steps (N = 300, f64) allocated {count} times"
    );
    let count = allocations_per_outputs(&mut *solver, &anchor);
    assert_eq!(
        count, 0,
        "{CALLS} pendulum output evaluations allocated {count} times"
    );
}

#[test]
fn towed_graded16_f32_steps_do_not_allocate() {
    let mut solver = towed_solver::<f32, GRADED_COUNT>(graded_layout());
    let path = cruise_path::<f32>();
    let count = allocations_per_steps(&mut *solver, &path, TOWED_DT);
    assert_eq!(
        count, 0,
        "{CALLS} towed steps (graded 16, f32) allocated {count} times"
    );
    let count = allocations_per_outputs(&mut *solver, &path);
    assert_eq!(
        count, 0,
        "{CALLS} towed output evaluations (f32) allocated {count} times"
    );
}

#[test]
fn towed_graded16_f64_steps_do_not_allocate() {
    let mut solver = towed_solver::<f64, GRADED_COUNT>(graded_layout());
    let path = cruise_path::<f64>();
    let count = allocations_per_steps(&mut *solver, &path, TOWED_DT);
    assert_eq!(
        count, 0,
        "{CALLS} towed steps (graded 16, f64) allocated {count} times"
    );
    let count = allocations_per_outputs(&mut *solver, &path);
    assert_eq!(
        count, 0,
        "{CALLS} towed output evaluations (f64) allocated {count} times"
    );
}

#[test]
fn towed_uniform300_steps_do_not_allocate() {
    let mut solver = towed_uniform_solver::<f64, 300>(300);
    let path = cruise_path::<f64>();
    let count = allocations_per_steps(&mut *solver, &path, TOWED_SCALING_DT);
    assert_eq!(
        count, 0,
        "{CALLS} towed steps (uniform 300, f64) allocated {count} times"
    );
    let count = allocations_per_outputs(&mut *solver, &path);
    assert_eq!(
        count, 0,
        "{CALLS} towed output evaluations (uniform 300, f64) allocated {count} times"
    );
    let mut solver = towed_uniform_solver::<f32, 300>(300);
    let path = cruise_path::<f32>();
    let count = allocations_per_steps(&mut *solver, &path, TOWED_SCALING_DT);
    assert_eq!(
        count, 0,
        "{CALLS} towed steps (uniform 300, f32) allocated {count} times"
    );
    let count = allocations_per_outputs(&mut *solver, &path);
    assert_eq!(
        count, 0,
        "{CALLS} towed output evaluations (uniform 300, f32) allocated {count} times"
    );
}
