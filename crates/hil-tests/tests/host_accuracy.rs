//! The embedded controller against the host's converged solution (issue 14): the
//! f32 controller with the embedded model (12 segments graded 1.26, the firmware's
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
//! What holds (measured 2026-12-02, embedded model 12 graded 1.26, RK4 steps of at
//! most 2.5 ms, `cargo test -p hil-tests --test host_accuracy -- --nocapture`):
//!
//! - **Against the same frames every shipped manoeuvre is within the issue's
//!   2 %**, the snatch loads included: steady -0.03 %, acceleration -0.01 %,
//!   pull-ups +0.47 / +0.59 / +0.50 % (0.05 / 0.10 / 0.20 rad/s), turns +0.27 /
//!   +0.11 %, recorded flight -0.19 %. Before issue 14's model change (16 graded
//!   1.3, steps at the wave-speed stability limit on its 0.46 m segment) the
//!   snatches were +5.30, +17.78, +5.93 and +9.60 % off.
//! - **The embedded model itself** (f64, the reference's converged steps, the
//!   same frames) is within 2 % on all eight (worst -1.76 %, the 0.20 rad/s
//!   pull-up), asserted by [`the_embedded_model_converged_is_within_two_percent`]:
//!   the step of at most 2.5 ms adds at most about two points to the model's
//!   own error, never as much as to leave the band (firmware/README.md, "The
//!   worst frame and the accuracy", has the study of models and steps).
//! - **Against the analytic path** all are within 2 % but the recorded flight,
//!   -3.39 %: the 300-segment model itself, fed the 100 Hz frames, is 3.2 %
//!   below its analytic run, so no controller fed 100 Hz frames can meet 2 %
//!   there. It is held to its measurement plus a guard of 0.5 point
//!   ([`RECORDED_ANALYTIC_LIMIT`]), so that a change making it worse fails.
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

/// The recorded flight against its analytic path: measured -3.39 % (the
/// 300-segment model on the frames is -3.2 % off it), plus a guard of 0.5 point.
/// Deterministic runs: an exact number, not a noise band.
const RECORDED_ANALYTIC_LIMIT: f64 = 0.039;

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

/// Checks `name` at `rate` for `t_end` s: within [`TARGET`] of the same frames,
/// within `limit_analytic` of the analytic path.
fn within_target(name: &str, rate: Option<f64>, t_end: f64, limit_analytic: f64) {
    check(name, rate, t_end, TARGET, limit_analytic);
}

/// The embedded model (f64) integrated with the reference's converged steps
/// along the same frames is within [`TARGET`] of the 300-segment solution on
/// every shipped manoeuvre: the model is accurate enough on its own, apart from
/// the controller's integration.
#[test]
fn the_embedded_model_converged_is_within_two_percent() {
    let mut worst: (f64, &str, Option<f64>) = (0.0, "", None);
    for (kind, rate, t_end) in flight::SHIPPED_MANOEUVRES {
        let name = kind.name();
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
    within_target("steady", None, 10.0, TARGET);
}

#[test]
fn acceleration_is_within_two_percent_of_the_host() {
    within_target("acceleration", None, 12.0, TARGET);
}

#[test]
fn turn_010_is_within_two_percent_of_the_host() {
    within_target("turn", Some(0.10), 10.0, TARGET);
}

#[test]
fn turn_020_is_within_two_percent_of_the_host() {
    within_target("turn", Some(0.20), 10.0, TARGET);
}

#[test]
fn pull_up_005_is_within_two_percent_of_the_host() {
    within_target("pull-up", Some(0.05), 10.0, TARGET);
}

#[test]
fn pull_up_010_is_within_two_percent_of_the_host() {
    within_target("pull-up", Some(0.10), 10.0, TARGET);
}

#[test]
fn pull_up_020_is_within_two_percent_of_the_host() {
    within_target("pull-up", Some(0.20), 10.0, TARGET);
}

/// Within [`TARGET`] of the same frames; against the analytic path held to
/// [`RECORDED_ANALYTIC_LIMIT`] (see the module's text).
#[test]
fn recorded_is_within_two_percent_of_the_host_on_its_frames() {
    within_target("recorded", None, 10.0, RECORDED_ANALYTIC_LIMIT);
}
