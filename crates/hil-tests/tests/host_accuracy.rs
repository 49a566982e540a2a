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
//!   snatch load that alone moves the peak: the 300-segment model's own peak on
//!   the frames is below its peak on the analytic path (the baselines have
//!   both).
//!
//! What is asserted:
//!
//! - **the budget** ([`budgets::PEAK_TENSION`], issue 14's 2 %): against the
//!   same frames on every shipped manoeuvre, the snatch loads included; against
//!   the analytic path on every one but the recorded flight, where the
//!   300-segment model itself, fed the 100 Hz frames, is more than 2 % below its
//!   analytic run, so that no controller fed 100 Hz frames can meet it there;
//!   and the embedded model itself (f64, the reference's converged steps, the
//!   same frames; [`the_embedded_model_converged_is_within_two_percent`]), so
//!   that the controller's steps of at most 2.5 ms are what add to the model's
//!   own error (firmware/README.md, "The worst frame and the accuracy", has the
//!   study of models and steps);
//! - **the baselines** (`crates/hil-tests/baselines.toml`, `[host_accuracy]`, a
//!   line per manoeuvre): each error's size at most its baseline (the runs are
//!   deterministic: the file keeps them to 1e-6), the recorded flight against
//!   its analytic path included. With `DECOY_BLESS=1` (`cargo xtask bless`)
//!   they are written instead, with the peaks themselves.
//!
//! Each scenario is its own test (they run in parallel); each takes a few
//! seconds to about 20 s.

mod common;

use common::baselines::{self, Margin, Ratchet};
use decoy_config::SystemConfig;
use decoy_hil::{budgets, flight};
use decoy_link::DeviceMessage;
use decoy_sim::{TraceOptions, trace};
use solver_core::SegmentLayout;
use toml::{Table, Value};

/// The accuracy target on the peak connection tension.
const TARGET: f64 = budgets::PEAK_TENSION.limit;
/// The section of the baselines.
const SECTION: &str = "host_accuracy";
/// How far an error's size may be above its baseline: the file keeps it to
/// 1e-6.
const ERROR_MARGIN: Margin = Margin::Absolute(1e-6);

/// RK4 step of the same-frames references, s (converged; see the module's text).
const REFERENCE_STEP_S: f64 = 0.000125;

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

/// Checks the errors `errors` (name, relative error) of manoeuvre `key`
/// against their baselines, or with `DECOY_BLESS` writes them and `values`
/// (peaks, not compared) into its line.
fn baselines_of(key: &str, errors: &[(&str, f64)], values: &[(&str, f64)]) {
    if baselines::blessing() {
        baselines::record(&[SECTION], |t| {
            let shipped = baselines::shipped_keys();
            t.retain(|k, _| shipped.iter().any(|s| s == k) || k == baselines::MEASURED);
            let line = t
                .entry(key.to_owned())
                .or_insert_with(|| Value::Table(Table::new()))
                .as_table_mut()
                .unwrap_or_else(|| panic!("{SECTION}.{key} is not a table"));
            for (name, x) in errors {
                line.insert((*name).to_owned(), baselines::rounded(*x, 6));
            }
            for (name, x) in values {
                line.insert((*name).to_owned(), baselines::rounded(*x, 2));
            }
        });
        return;
    }
    let mut ratchet = Ratchet::inline(&[SECTION], key, key);
    for (name, x) in errors {
        ratchet.at_most(name, *x, ERROR_MARGIN);
    }
    ratchet.finish();
}

/// Checks `name` against both references, the analytic path within
/// `limit_analytic` if any, then against the baselines; returns the errors
/// (same frames, analytic).
fn check(
    name: &str,
    rate: Option<f64>,
    t_end: f64,
    limit_frames: f64,
    limit_analytic: Option<f64>,
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
    if let Some(limit) = limit_analytic {
        assert!(
            analytic.abs() <= limit,
            "{name} {rate:?}: the peak connection tension is {:+.2} % off the 300-segment f64 \
             solution on the analytic path, over {:.1} %",
            analytic * 100.0,
            limit * 100.0
        );
    }
    baselines_of(
        &baselines::manoeuvre_key(name, rate),
        &[("same_frames", frames), ("analytic", analytic)],
        &[
            ("controller_n", p.controller),
            ("same_frames_n", p.same_frames),
            ("analytic_n", p.analytic),
        ],
    );
    (frames, analytic)
}

/// Checks `name` at `rate` for `t_end` s: within [`TARGET`] of the same frames
/// and of the analytic path.
fn within_target(name: &str, rate: Option<f64>, t_end: f64) {
    check(name, rate, t_end, TARGET, Some(TARGET));
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
        baselines_of(
            &baselines::manoeuvre_key(name, rate),
            &[("embedded_converged", error)],
            &[],
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
    within_target("steady", None, 10.0);
}

#[test]
fn acceleration_is_within_two_percent_of_the_host() {
    within_target("acceleration", None, 12.0);
}

#[test]
fn turn_010_is_within_two_percent_of_the_host() {
    within_target("turn", Some(0.10), 10.0);
}

#[test]
fn turn_020_is_within_two_percent_of_the_host() {
    within_target("turn", Some(0.20), 10.0);
}

#[test]
fn pull_up_005_is_within_two_percent_of_the_host() {
    within_target("pull-up", Some(0.05), 10.0);
}

#[test]
fn pull_up_010_is_within_two_percent_of_the_host() {
    within_target("pull-up", Some(0.10), 10.0);
}

#[test]
fn pull_up_020_is_within_two_percent_of_the_host() {
    within_target("pull-up", Some(0.20), 10.0);
}

/// Within [`TARGET`] of the same frames; against the analytic path held to
/// its baseline only (see the module's text).
#[test]
fn recorded_is_within_two_percent_of_the_host_on_its_frames() {
    check("recorded", None, 10.0, TARGET, None);
}
