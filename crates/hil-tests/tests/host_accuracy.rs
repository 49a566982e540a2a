//! The embedded controller against the host's converged solution (issue 14): the
//! f32 controller with the embedded model (16 segments graded 1.3, the firmware's
//! bits: `tests/hil_link.rs` shows the M4 and the STM32F405 answer bit for bit as
//! this host controller) flies every shipped manoeuvre frame by frame at 10 ms
//! with its stepping rule (docs/protocol.md §5), and its peak connection tension
//! (at the frame times, where it answers) is compared with two host solutions of
//! 300 uniform segments in f64, sampled at the same frame times:
//!
//! - **the same frames** ([`flight::frame_reference`]): the host model integrated
//!   along the very frames the controller receives (the same `FramePath`
//!   between them), with fixed RK4 steps of 0.125 ms (converged: 0.0625 ms moves
//!   the 0.20 rad/s snatch peak by 0.06 %). This isolates the embedded model and
//!   its integration from the input;
//! - **the analytic flight path** (`decoy simulate`'s run of the scenario, at its
//!   own RK4 step: 1 ms; 0.5 ms for the recorded flight, 0.25 ms for the
//!   pull-ups). A controller sees the aircraft only every 10 ms, and through a
//!   snatch load that alone moves the peak: the 300-segment model's 0.20 rad/s
//!   peak is 841.3 N on the frames against 853.2 N on the analytic path
//!   (-1.4 %), the recorded flight's 497.0 N against 513.5 N (-3.2 %).
//!
//! What holds and what does not (measured 2026-12-02):
//!
//! - **The embedded model is accurate enough**: 16 graded 1.3 in f64 along the
//!   same frames with the reference's converged steps is within the 2 %
//!   of the 300-segment solution on all eight manoeuvres (worst: -1.85 %, the
//!   0.20 rad/s pull-up), asserted by [`the_embedded_model_converged_is_within_two_percent`].
//! - **Its integration at the frame budget is not**: with the stepping rule's RK4
//!   steps at the wave-speed stability limit (0.8 l/c on the 0.46 m segment at
//!   the decoy) the snatch peaks overshoot (against the same frames) by 5.30 %,
//!   17.78 %, 5.93 % (pull-ups 0.05 / 0.10 / 0.20) and 9.60 % (recorded flight).
//!   Steps of at most 0.5 ms (20 a frame, about 620,000 instructions on the M4)
//!   bring all four within 2 % (+0.08, +0.57, -1.42, +0.82 %); 1 ms steps leave
//!   the 0.20 rad/s pull-up at +2.75 %. Steady flight, the acceleration and the
//!   turns are within 0.1 % at the shipped rule.
//! - **Models and steps that would meet it** (`examples/step_study.rs` in
//!   decoy-hil, firmware/README.md): 12 segments graded 1.22 to 1.26 with steps
//!   of at most 2.5 ms are within 2 % on all eight in f64 (12 graded 1.25 on the
//!   M4: 117,680 instructions in every frame, the f32 controller +2.06 % on the
//!   0.20 rad/s pull-up); 16 graded 1.15 at a fixed 2 ms step within 0.61 %
//!   (about 172,000 a frame). Within 100,000 either needs a cheaper evaluation.
//! - Against the analytic path no controller fed 100 Hz frames can meet 2 % on
//!   the recorded flight: the 300-segment model itself, fed the frames, is 3.2 %
//!   below it.
//!
//! The manoeuvres within the target are asserted on it ([`WITHIN_TARGET`]); the
//! others are held to the error measured today ([`KNOWN_GAPS`], both
//! comparisons) so that a change making them worse fails, and the gap is
//! printed.
//!
//! Each scenario is its own test (they run in parallel); each takes a few
//! seconds to about 20 s.

use decoy_config::SystemConfig;
use decoy_hil::flight;
use decoy_link::DeviceMessage;
use decoy_sim::{TraceOptions, trace};
use solver_core::SegmentLayout;

/// The accuracy target on the peak connection tension.
const TARGET: f64 = 0.02;

/// RK4 step of the same-frames references, s (converged; see the module's text).
const REFERENCE_STEP_S: f64 = 0.000125;

/// The scenarios within [`TARGET`] against both references: (name, rate,
/// simulated seconds).
const WITHIN_TARGET: [(&str, Option<f64>, f64); 4] = [
    ("steady", None, 10.0),
    ("acceleration", None, 12.0),
    ("turn", Some(0.10), 10.0),
    ("turn", Some(0.20), 10.0),
];

/// The scenarios that miss [`TARGET`]: (name, rate, simulated seconds, limit
/// against the same frames, limit against the analytic path), each limit the
/// relative error measured plus a guard of 0.5 point. Deterministic runs: these
/// are exact numbers, not a noise band.
///
/// Measured against the same frames: +5.30 %, +17.78 %, +5.93 %, +9.60 %;
/// against the analytic path: +4.72 %, +16.39 %, +4.45 %, +6.09 % (they were
/// +4.51 %, +16.09 %, +4.89 %, +6.46 % before the solver's arithmetic was
/// reordered for the M4: through a snatch load integrated at the stability
/// limit, last-bit differences move the peaks by tenths of a point).
const KNOWN_GAPS: [(&str, Option<f64>, f64, f64, f64); 4] = [
    ("pull-up", Some(0.05), 10.0, 0.058, 0.052),
    ("pull-up", Some(0.10), 10.0, 0.183, 0.169),
    ("pull-up", Some(0.20), 10.0, 0.065, 0.050),
    ("recorded", None, 10.0, 0.101, 0.066),
];

/// Peak connection tensions (N) at the frame times of one manoeuvre.
struct Peaks {
    /// The f32 controller with its stepping rule (the firmware's bits).
    controller: f64,
    /// 300 uniform segments f64 along the same frames.
    same_frames: f64,
    /// 300 uniform segments f64 along the analytic flight path.
    analytic: f64,
}

/// The configuration, the plan and the frames of `name` at `rate` for `t_end` s.
fn setup(
    name: &str,
    rate: Option<f64>,
    t_end: f64,
) -> (
    SystemConfig,
    decoy_sim::RunPlan,
    Vec<decoy_link::AircraftStateFrame>,
) {
    let config = SystemConfig::builtin().unwrap_or_else(|e| panic!("{e}"));
    let (plan, frames) =
        flight::builtin_frames(&config, name, rate, t_end).unwrap_or_else(|e| panic!("{e}"));
    (config, plan, frames)
}

/// The largest of `values`.
fn peak(values: impl IntoIterator<Item = f64>) -> f64 {
    values.into_iter().fold(0.0, f64::max)
}

fn peaks(name: &str, rate: Option<f64>, t_end: f64) -> Peaks {
    let (config, plan, frames) = setup(name, rate, t_end);
    assert_eq!(plan.layout.count(), config.solver.segments_host);
    let host = trace(
        &config,
        &plan,
        &TraceOptions {
            sample_interval_s: flight::CONTROL_PERIOD_S,
            ..TraceOptions::default()
        },
        |_| {},
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(
        host.stopped.is_none(),
        "{name}: the host run stopped: {:?}",
        host.stopped
    );
    let same_frames = flight::frame_reference(
        &config,
        &frames,
        SegmentLayout::Uniform {
            count: config.solver.segments_host,
        },
        REFERENCE_STEP_S,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(same_frames.len(), frames.len());

    let mut controller = flight::host_controller::<f32>(&config).unwrap_or_else(|e| panic!("{e}"));
    let answers = flight::replay(&mut controller, &flight::scenario_messages(&frames));
    let outputs = flight::outputs(&answers);
    let rejected = answers
        .iter()
        .filter(|a| matches!(a, DeviceMessage::Rejected(_)))
        .count();
    assert_eq!(rejected, 0, "{name}: the controller rejected frames");
    assert_eq!(outputs.len(), frames.len(), "{name}: one output per frame");

    // The analytic run's samples at the frame times (the controller answers only there).
    let analytic = peak(outputs.iter().map(|out| {
        host.samples
            .iter()
            .find(|s| (s.t - out.time_s).abs() < 1e-6)
            .unwrap_or_else(|| panic!("{name}: no host sample at t = {}", out.time_s))
            .tension_connection
    }));
    Peaks {
        controller: peak(outputs.iter().map(|o| f64::from(o.connection_tension_n))),
        same_frames: peak(same_frames),
        analytic,
    }
}

/// Checks `name` against both references with the limits given; returns the
/// errors (same frames, analytic).
fn check(
    name: &str,
    rate: Option<f64>,
    t_end: f64,
    limit_frames: f64,
    limit_analytic: f64,
) -> (f64, f64) {
    let p = peaks(name, rate, t_end);
    let frames = p.controller / p.same_frames - 1.0;
    let analytic = p.controller / p.analytic - 1.0;
    println!(
        "{name} {rate:?} ({t_end} s): peak connection tension {:.2} N; 300 segments f64 on the \
         same frames {:.2} N: {:+.2} %; on the analytic path {:.2} N: {:+.2} % (target {:.0} %)",
        p.controller,
        p.same_frames,
        frames * 100.0,
        p.analytic,
        analytic * 100.0,
        TARGET * 100.0
    );
    assert!(
        frames.abs() <= limit_frames,
        "{name} {rate:?}: the peak connection tension is {:+.2} % off the 300-segment f64 \
         solution on the same frames, over {:.1} %",
        frames * 100.0,
        limit_frames * 100.0
    );
    assert!(
        analytic.abs() <= limit_analytic,
        "{name} {rate:?}: the peak connection tension is {:+.2} % off the 300-segment f64 \
         solution on the analytic path, over {:.1} %",
        analytic * 100.0,
        limit_analytic * 100.0
    );
    (frames, analytic)
}

fn within_target(i: usize) {
    let (name, rate, t_end) = WITHIN_TARGET[i];
    check(name, rate, t_end, TARGET, TARGET);
}

fn known_gap(i: usize) {
    let (name, rate, t_end, limit_frames, limit_analytic) = KNOWN_GAPS[i];
    let (frames, analytic) = check(name, rate, t_end, limit_frames, limit_analytic);
    println!(
        "{name} {rate:?}: issue 14's target of {:.0} % is not met ({:+.2} % on the same frames, \
         {:+.2} % on the analytic path)",
        TARGET * 100.0,
        frames * 100.0,
        analytic * 100.0
    );
}

/// The embedded model (16 graded 1.3, f64) integrated with the reference's
/// converged steps along the same frames is within [`TARGET`] of the
/// 300-segment solution on every shipped manoeuvre: the model is accurate
/// enough, its integration at the frame budget is what misses.
#[test]
fn the_embedded_model_converged_is_within_two_percent() {
    let mut worst: (f64, &str, Option<f64>) = (0.0, "", None);
    for (name, rate, t_end) in flight::SHIPPED_MANOEUVRES {
        let (config, _, frames) = setup(name, rate, t_end);
        let reference = |layout| {
            peak(
                flight::frame_reference(&config, &frames, layout, REFERENCE_STEP_S)
                    .unwrap_or_else(|e| panic!("{e}")),
            )
        };
        let host = reference(SegmentLayout::Uniform {
            count: config.solver.segments_host,
        });
        let embedded = reference(config.embedded_layout());
        let error = embedded / host - 1.0;
        println!(
            "{name} {rate:?}: embedded model converged {embedded:.2} N, 300 segments {host:.2} N: \
             {:+.2} %",
            error * 100.0
        );
        if error.abs() > worst.0.abs() {
            worst = (error, name, rate);
        }
        assert!(
            error.abs() <= TARGET,
            "{name} {rate:?}: the embedded model, converged, is {:+.2} % off the 300-segment \
             solution on the same frames",
            error * 100.0
        );
    }
    println!(
        "worst: {} {:?}, {:+.2} %",
        worst.1,
        worst.2,
        worst.0 * 100.0
    );
}

#[test]
fn steady_is_within_two_percent_of_the_host() {
    within_target(0);
}

#[test]
fn acceleration_is_within_two_percent_of_the_host() {
    within_target(1);
}

#[test]
fn turn_010_is_within_two_percent_of_the_host() {
    within_target(2);
}

#[test]
fn turn_020_is_within_two_percent_of_the_host() {
    within_target(3);
}

#[test]
fn pull_up_005_is_held_to_its_measured_error() {
    known_gap(0);
}

#[test]
fn pull_up_010_is_held_to_its_measured_error() {
    known_gap(1);
}

#[test]
fn pull_up_020_is_held_to_its_measured_error() {
    known_gap(2);
}

#[test]
fn recorded_is_held_to_its_measured_error() {
    known_gap(3);
}
