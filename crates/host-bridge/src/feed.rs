//! `decoy feed`: a scenario (the flight profiles of `decoy simulate` and `decoy
//! hil`) flown through a running bridge at the 10 ms control period, lockstep or
//! free-running, written as `decoy hil` writes its runs (`timeseries.csv`,
//! `summary.json`, plots) beside the host's replay of the same frames.
//!
//! The output directory follows `decoy simulate`'s rule: the options are checked
//! first, then the files an earlier run left there are removed
//! ([`decoy_sim::clear_output_dir`]) before the bridge is contacted, and every
//! file is written whole. SIGINT or SIGTERM stops the flight at the next frame:
//! the frames flown are written, `summary.json`'s `stopped` names the signal and
//! the result is [`FeedError::Interrupted`]; a second signal ends the process at
//! once.

use std::collections::HashMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use bridge_types::{Answer, Status, command, field_text, kind};
use decoy_config::SystemConfig;
use decoy_hil::flight;
use decoy_hil::hil_run::{paired_rows, sample, write_timeseries};
use decoy_link::{AircraftStateFrame, Command, DeviceMessage, HostMessage, RejectReason, Rejected};
use decoy_sim::atomic::write_atomically;
use decoy_sim::format::format_number;
use decoy_sim::{
    RunOptions, Sample, Scenario, ScenarioKind, Summary, clear_output_dir, format_time, summarize,
    write_comparison_plots, write_management_plot,
};
use serde::Serialize;

use crate::BridgeError;
use crate::backend::{BackendOptions, Precision, host_backend};
use crate::bridge::Percentiles;
use crate::client::BridgeClient;
use crate::convert;

/// How the states go to the bridge.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FeedMode {
    /// Request-response: each state waits for its answer.
    Lockstep,
    /// Publish-subscribe: states are published at their pace, answers collected
    /// from the outputs service.
    Free,
}

impl FeedMode {
    /// `lockstep` or `free`.
    pub fn name(self) -> &'static str {
        match self {
            FeedMode::Lockstep => "lockstep",
            FeedMode::Free => "free",
        }
    }
}

/// What `decoy feed` runs.
#[derive(Clone, Debug)]
pub struct FeedOptions {
    /// The bridge instance.
    pub instance: String,
    /// Lockstep or free-running.
    pub mode: FeedMode,
    /// Pace the frames at real time (10 ms apart) instead of flat out.
    pub realtime: bool,
    /// Simulated time, s (default: the scenario's).
    pub t_end: Option<f64>,
    /// Flight-path rotation rate of a pull-up or turn, rad/s.
    pub rate: Option<f64>,
    /// Output directory (default `out/feed-<scenario>`).
    pub out_dir: Option<PathBuf>,
    /// Draw the plots.
    pub plots: bool,
    /// Deadline of each answer.
    pub timeout: Duration,
}

/// The longest deadline of an answer `--timeout` accepts, s (a day: a longer
/// one is no deadline but a hang).
pub const MAX_TIMEOUT_S: f64 = 86_400.0;

/// `--timeout S` as the deadline of each answer: a number of seconds above 0
/// (at least a nanosecond) and at most [`MAX_TIMEOUT_S`], else a
/// [`BridgeError::Usage`] naming the value.
pub fn answer_timeout(seconds: f64) -> Result<Duration, BridgeError> {
    let usable = seconds.is_finite() && seconds > 0.0 && seconds <= MAX_TIMEOUT_S;
    match Duration::try_from_secs_f64(seconds) {
        Ok(d) if usable && !d.is_zero() => Ok(d),
        _ => Err(BridgeError::Usage(format!(
            "--timeout must be a number of seconds above 0 and at most {} (a day), got {}",
            format_number(MAX_TIMEOUT_S),
            format_number(seconds)
        ))),
    }
}

impl Default for FeedOptions {
    fn default() -> Self {
        FeedOptions {
            instance: "default".to_owned(),
            mode: FeedMode::Lockstep,
            realtime: false,
            t_end: None,
            rate: None,
            out_dir: None,
            plots: true,
            timeout: crate::client::ANSWER_TIMEOUT,
        }
    }
}

/// `decoy feed`'s `summary.json`: `decoy simulate`'s summary of the bridge's run
/// plus the keys of `decoy hil` that apply and the feed's own.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FeedSummary {
    /// The run's summary, as `decoy simulate` defines it.
    #[serde(flatten)]
    pub run: Summary,
    /// The bridge instance.
    pub instance: String,
    /// The bridge's backend: `host` or `qemu`.
    pub backend: String,
    /// `host` or the firmware's board.
    pub board: String,
    /// The controller's precision, bits.
    pub precision_bits: u8,
    /// The model's grading ratio (1: uniform).
    pub grading_ratio: f64,
    /// `lockstep` or `free`.
    pub mode: String,
    /// Paced at real time.
    pub realtime: bool,
    /// The CPUs the client could run on (Linux's list format; `--cpu` sets
    /// them; empty where unknown).
    pub client_cpus: String,
    /// State frames sent (the reset command before them not counted).
    pub frames_sent: usize,
    /// Of those, answered by an output.
    pub frames_answered: usize,
    /// Of those, answered while the controller initialised (the trim's frames:
    /// an `initialising` answer each, docs/bridge.md).
    pub frames_initialising: usize,
    /// Of those, answered by a rejection.
    pub frames_rejected: usize,
    /// Of those, never answered (free-running samples the bridge lost).
    pub frames_lost: usize,
    /// Round trip (state sent to its answer received), us.
    pub latency_us: Percentiles,
    /// Frames per second of wall-clock time.
    pub frames_per_s: f64,
    /// Most instructions one 10 ms control step took (qemu backend; 0 from the host).
    pub instructions_per_step_max: u32,
    /// Mean instructions per control step.
    pub instructions_per_step_mean: f64,
    /// Largest difference of either tension from the host's f64 replay of the
    /// same frames with the bridge's model, N.
    #[serde(rename = "max_tension_diff_vs_host_N")]
    pub max_tension_diff_vs_host_n: f64,
    /// Largest difference from the host replay in the bridge's own precision, N:
    /// 0 when they agree bit for bit.
    #[serde(rename = "max_tension_diff_vs_host_same_precision_N")]
    pub max_tension_diff_vs_host_same_precision_n: f64,
    /// Outputs equal to the same-precision replay's in every field but the
    /// instruction counts.
    pub frames_identical_to_host_same_precision: usize,
}

/// A finished feed.
#[derive(Clone, Debug)]
pub struct FeedRun {
    /// `summary.json`'s contents.
    pub summary: FeedSummary,
    /// The output directory.
    pub out_dir: PathBuf,
    /// Every file written.
    pub files: Vec<PathBuf>,
    /// Every answer of the bridge to the states, in the order of the states.
    pub answers: Vec<Answer>,
    /// The same-precision host replay's answers to the same messages.
    pub host_same_precision: Vec<DeviceMessage>,
}

/// Why `decoy feed` failed.
#[derive(Debug)]
pub enum FeedError {
    /// The bridge, iceoryx2 or an option.
    Bridge(BridgeError),
    /// The scenario.
    Scenario(decoy_sim::SimError),
    /// A lockstep state was rejected: the outputs up to then are written.
    Stopped {
        /// Time of the last accepted state, s.
        t_s: f64,
        /// The rejection.
        reason: String,
        /// Where the outputs are.
        out_dir: PathBuf,
    },
    /// SIGINT or SIGTERM stopped the flight at a frame: the outputs up to then
    /// are written, `summary.json`'s `stopped.reason` is `interrupted by SIGINT` (or SIGTERM).
    Interrupted {
        /// Time of the last answered state, s.
        t_s: f64,
        /// `SIGINT` or `SIGTERM`.
        signal: &'static str,
        /// Where the outputs are.
        out_dir: PathBuf,
    },
}

impl FeedError {
    /// Whether the input must change (exit code 2).
    pub fn is_usage(&self) -> bool {
        match self {
            FeedError::Bridge(e) => e.is_usage(),
            FeedError::Scenario(e) => e.is_usage(),
            FeedError::Stopped { .. } | FeedError::Interrupted { .. } => false,
        }
    }
}

impl std::fmt::Display for FeedError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FeedError::Bridge(e) => write!(f, "{e}"),
            FeedError::Scenario(e) => write!(f, "{e}"),
            FeedError::Stopped {
                t_s,
                reason,
                out_dir,
            } => write!(
                f,
                "the bridge stopped accepting the scenario after t = {} s: {reason}; the outputs up to then are in {}",
                format_time(*t_s),
                out_dir.display()
            ),
            FeedError::Interrupted {
                t_s,
                signal,
                out_dir,
            } => write!(
                f,
                "interrupted by {signal} after t = {} s; the outputs up to then are in {}",
                format_time(*t_s),
                out_dir.display()
            ),
        }
    }
}

impl std::error::Error for FeedError {}

impl From<BridgeError> for FeedError {
    fn from(e: BridgeError) -> Self {
        FeedError::Bridge(e)
    }
}

/// How long a free-running feed waits for the last answers after its last state.
pub const FREE_DRAIN: Duration = Duration::from_secs(2);

/// The answers of a flight, one per state sent (None: never answered), and the
/// round trip of each answered one.
struct Flown {
    sent: Vec<AircraftStateFrame>,
    answers: Vec<Option<Answer>>,
    latency_us: Vec<f64>,
    wall: Duration,
    /// A rejection (lockstep): the time of the last accepted state and why.
    stop: Option<(f64, String)>,
    /// The signal that stopped the flight, if one did.
    interrupted: Option<&'static str>,
}

/// SIGINT and SIGTERM during a feed, registered after the client's node (whose
/// iceoryx2 handler records a signal but consumes it, and would replace handlers
/// installed before it; signal-hook chains it) and unregistered when dropped.
/// The first signal of either kind is recorded for the flight to stop at the next
/// frame; a second ends the process at once with the signal's default action.
struct FeedSignals {
    /// The number of the first signal received (0: none yet).
    received: Arc<AtomicUsize>,
    ids: Vec<signal_hook::SigId>,
}

impl FeedSignals {
    const SIGNALS: [(i32, &'static str); 2] = [
        (signal_hook::consts::SIGINT, "SIGINT"),
        (signal_hook::consts::SIGTERM, "SIGTERM"),
    ];

    fn register() -> Result<Self, BridgeError> {
        let received = Arc::new(AtomicUsize::new(0));
        let armed = Arc::new(AtomicBool::new(false));
        let mut signals = FeedSignals {
            received: Arc::clone(&received),
            ids: Vec::new(),
        };
        for (signal, _) in Self::SIGNALS {
            // In this order: the default action only once `armed` is set, so on
            // the second signal; the first one's number kept.
            let ids = [
                signal_hook::flag::register_conditional_default(signal, Arc::clone(&armed)),
                signal_hook::flag::register_usize(signal, Arc::clone(&received), signal as usize),
                signal_hook::flag::register(signal, Arc::clone(&armed)),
            ];
            for id in ids {
                signals.ids.push(id.map_err(|e| {
                    BridgeError::Output(format!("cannot install the SIGINT/SIGTERM handlers: {e}"))
                })?);
            }
        }
        Ok(signals)
    }

    /// The name of the signal received, if one came: one load.
    fn received(&self) -> Option<&'static str> {
        let number = self.received.load(Ordering::Relaxed);
        Self::SIGNALS
            .iter()
            .find(|(signal, _)| *signal as usize == number)
            .map(|(_, name)| *name)
    }
}

impl Drop for FeedSignals {
    fn drop(&mut self) {
        for id in self.ids.drain(..) {
            signal_hook::low_level::unregister(id);
        }
    }
}

fn pace(started: Instant, frame: &AircraftStateFrame) {
    let due = started + Duration::from_secs_f64(frame.time_s.max(0.0));
    let now = Instant::now();
    if due > now {
        std::thread::sleep(due - now);
    }
}

fn describe_rejection(frame: &AircraftStateFrame, a: &Answer) -> String {
    format!(
        "frame {} (t = {} s) rejected: {} ({} so far)",
        frame.seq,
        format_time(frame.time_s),
        bridge_types::reason::name(a.rejection.reason),
        a.rejection.count
    )
}

fn fly_lockstep(
    client: &mut BridgeClient,
    frames: &[AircraftStateFrame],
    realtime: bool,
    mut progress: impl FnMut(f64),
    signals: &FeedSignals,
) -> Result<Flown, BridgeError> {
    let started = Instant::now();
    let mut flown = Flown {
        sent: Vec::new(),
        answers: Vec::new(),
        latency_us: Vec::new(),
        wall: Duration::ZERO,
        stop: None,
        interrupted: None,
    };
    let mut last_time = 0.0;
    let every = (frames.len() / 500).max(1);
    for (i, frame) in frames.iter().enumerate() {
        // A signal stops the flight between two frames.
        if let Some(signal) = signals.received() {
            flown.interrupted = Some(signal);
            break;
        }
        if realtime {
            pace(started, frame);
        }
        let state = convert::from_link_frame(frame);
        let t0 = Instant::now();
        let answer = client.step(&state)?;
        flown.latency_us.push(t0.elapsed().as_secs_f64() * 1e6);
        flown.sent.push(*frame);
        flown.answers.push(Some(answer));
        if answer.header.kind == kind::REJECTED {
            flown.stop = Some((last_time, describe_rejection(frame, &answer)));
            break;
        }
        last_time = answer.output.time_s;
        if i % every == 0 {
            progress(i as f64 / frames.len() as f64);
        }
    }
    progress(1.0);
    flown.wall = started.elapsed();
    Ok(flown)
}

fn fly_free(
    client: &mut BridgeClient,
    frames: &[AircraftStateFrame],
    realtime: bool,
    mut progress: impl FnMut(f64),
    signals: &FeedSignals,
) -> Result<Flown, BridgeError> {
    // The outputs service's history (earlier runs' answers) is not this run's.
    client.take_outputs()?;
    let started = Instant::now();
    let mut sent_at: HashMap<u32, Instant> = HashMap::new();
    let mut got: HashMap<u32, (Answer, Instant)> = HashMap::new();
    let collect = |client: &mut BridgeClient,
                   got: &mut HashMap<u32, (Answer, Instant)>,
                   sent_at: &HashMap<u32, Instant>|
     -> Result<(), BridgeError> {
        let now = Instant::now();
        for a in client.take_outputs()? {
            let seq = if a.header.kind == kind::OUTPUT {
                a.output.request_seq
            } else {
                a.rejection.request_seq
            };
            if sent_at.contains_key(&seq) {
                got.entry(seq).or_insert((a, now));
            }
        }
        Ok(())
    };
    let every = (frames.len() / 500).max(1);
    let mut interrupted = None;
    let mut published = 0;
    for (i, frame) in frames.iter().enumerate() {
        // A signal stops the publishing between two frames (the answers to
        // those sent are still collected).
        if let Some(signal) = signals.received() {
            interrupted = Some(signal);
            break;
        }
        if realtime {
            pace(started, frame);
        }
        published = i + 1;
        let state = convert::from_link_frame(frame);
        sent_at.insert(frame.seq, Instant::now());
        client.publish(&state)?;
        collect(client, &mut got, &sent_at)?;
        if i % every == 0 {
            progress(i as f64 / frames.len() as f64);
        }
    }
    let frames = &frames[..published];
    let drain_until = Instant::now() + FREE_DRAIN;
    while got.len() < frames.len() && Instant::now() < drain_until {
        client.wait_event(Duration::from_millis(20))?;
        collect(client, &mut got, &sent_at)?;
    }
    progress(1.0);
    let wall = started.elapsed();
    let mut latency_us = Vec::new();
    let answers = frames
        .iter()
        .map(|f| {
            got.get(&f.seq).map(|(a, at)| {
                latency_us.push(at.duration_since(sent_at[&f.seq]).as_secs_f64() * 1e6);
                *a
            })
        })
        .collect();
    Ok(Flown {
        sent: frames.to_vec(),
        answers,
        latency_us,
        wall,
        stop: None,
        interrupted,
    })
}

/// The decoy link's form of an answer (for the comparison with the host replay).
fn device_message(a: &Answer) -> DeviceMessage {
    if a.header.kind == kind::OUTPUT {
        DeviceMessage::Output(convert::output_to_link(&a.output))
    } else {
        DeviceMessage::Rejected(Rejected {
            seq: Some(a.rejection.request_seq),
            reason: RejectReason::WrongMode,
            count: a.rejection.count as u32,
        })
    }
}

/// The host's replay of `messages` with the bridge's model in `precision`.
fn replay(
    config: &SystemConfig,
    status: &Status,
    precision: Precision,
    trim_at_once: bool,
    messages: &[HostMessage],
) -> Result<Vec<DeviceMessage>, BridgeError> {
    let mut backend = host_backend(
        config,
        &BackendOptions {
            precision: Some(precision),
            segments: Some(usize::from(status.segments)),
            grading: Some(status.grading_ratio),
            trim_at_once,
            ..BackendOptions::default()
        },
    )?;
    messages.iter().map(|m| backend.handle(*m)).collect()
}

/// The run options of the feed's plan: the bridge's layout (`segments`,
/// `grading`), the controller's step, the feed's time and rate.
fn plan_options(options: &FeedOptions, segments: usize, grading: f64) -> RunOptions {
    RunOptions {
        segments: Some(segments),
        grading: Some(grading),
        dt: Some(decoy_controller::MAX_STEP_S),
        t_end: options.t_end,
        rate: options.rate,
        plots: false,
        ..RunOptions::default()
    }
}

/// Flies `scenario` through bridge `options.instance` and writes the outputs.
///
/// Order: the options and the scenario are checked (usage errors leave the
/// output directory as it was), the output directory is cleared of an earlier
/// run's files ([`clear_output_dir`]), then the bridge is contacted: a feed that
/// fails from there on leaves no earlier summary to be taken for its own.
pub fn run_feed(
    config: &SystemConfig,
    scenario: &Scenario,
    options: &FeedOptions,
    iox: &iceoryx2::config::Config,
    progress: impl FnMut(f64),
) -> Result<FeedRun, FeedError> {
    if scenario.kind == ScenarioKind::Recorded && options.rate.is_some() {
        return Err(
            BridgeError::Usage("--rate does not apply to a recorded flight".to_owned()).into(),
        );
    }
    // Everything but the layout (which the bridge decides) checked before
    // anything is touched: one uniform segment stands for it here.
    let checked = scenario
        .plan(config, &plan_options(options, 1, 1.0))
        .map_err(FeedError::Scenario)?;
    let frame_count = flight::checked_frame_count(checked.t_end, options.t_end.is_some())
        .map_err(BridgeError::Usage)?;
    let out_dir = options
        .out_dir
        .clone()
        .unwrap_or_else(|| Path::new("out").join(format!("feed-{}", checked.name)));
    clear_output_dir(&out_dir).map_err(|e| BridgeError::Output(e.to_string()))?;

    let node_name = format!("feed-{}-{}", options.instance, std::process::id());
    let mut client = BridgeClient::connect(&options.instance, &node_name, iox)?;
    // After the client's node, whose iceoryx2 handler they chain.
    let signals = FeedSignals::register()?;
    client.set_timeout(options.timeout);
    let status = client.get_status()?;
    let segments = usize::from(status.segments);
    let plan = scenario
        .plan(
            config,
            &plan_options(options, segments, status.grading_ratio),
        )
        .map_err(FeedError::Scenario)?;
    let frames = flight::scenario_frames(&plan.profile, frame_count);
    let reset = client.simple_command(command::RESET_TO_TRIM)?;
    if reset.result != bridge_types::result::OK {
        return Err(BridgeError::Backend(format!(
            "the bridge refused the reset: {}",
            bridge_types::reason::name(reset.reason)
        ))
        .into());
    }
    let flown = match options.mode {
        FeedMode::Lockstep => {
            fly_lockstep(&mut client, &frames, options.realtime, progress, &signals)?
        }
        FeedMode::Free => fly_free(&mut client, &frames, options.realtime, progress, &signals)?,
    };
    drop(client);

    // What the bridge's controller saw: the reset, then the states it answered.
    let seen: Vec<HostMessage> = std::iter::once(HostMessage::Command(Command::ResetToTrim))
        .chain(
            flown
                .sent
                .iter()
                .zip(&flown.answers)
                .filter(|(_, a)| a.is_some())
                .map(|(f, _)| HostMessage::State(*f)),
        )
        .collect();
    let precision = if status.precision_bits == 64 {
        Precision::F64
    } else {
        Precision::F32
    };
    // The f64 accuracy reference trims in the first frame (as the f32
    // controller does); the same-precision replay is the bridge's controller.
    let host64 = replay(config, &status, Precision::F64, true, &seen)?;
    let same = replay(config, &status, precision, false, &seen)?;
    let answers: Vec<Answer> = flown.answers.iter().flatten().copied().collect();
    let bridge_messages: Vec<DeviceMessage> = answers.iter().map(device_message).collect();
    let only_outputs = |v: &[DeviceMessage]| -> Vec<DeviceMessage> {
        v.iter()
            .filter(|m| matches!(m, DeviceMessage::Output(_)))
            .copied()
            .collect()
    };
    let (vs64, _) = flight::compare(&only_outputs(&bridge_messages), &only_outputs(&host64));
    let (vs_same, _) = flight::compare(&only_outputs(&bridge_messages), &only_outputs(&same));
    let stats = flight::instruction_stats(&bridge_messages);

    fs::create_dir_all(&out_dir)
        .map_err(|e| BridgeError::Output(format!("cannot create {}: {e}", out_dir.display())))?;
    let rows = paired_rows(&flown.sent, &bridge_messages, &host64);
    let bridge_samples: Vec<Sample> = rows
        .iter()
        .map(|(frame, out, _)| sample(out, frame, plan.lateral_sign))
        .collect();
    let host_samples: Vec<Sample> = rows
        .iter()
        .map(|(frame, _, host)| sample(host, frame, plan.lateral_sign))
        .collect();
    let timeseries = out_dir.join("timeseries.csv");
    write_timeseries(&timeseries, &rows, &bridge_samples, &host_samples)
        .map_err(|e| BridgeError::Output(e.to_string()))?;
    let run = summarize(
        &plan.name,
        segments,
        decoy_controller::MAX_STEP_S,
        plan.t_end,
        plan.profile.manoeuvre_start(),
        &bridge_samples,
        flown.wall.as_secs_f64(),
        flown
            .stop
            .as_ref()
            .map(|(_, r)| r.clone())
            .or(flown.interrupted.map(|s| format!("interrupted by {s}"))),
    );
    let answered = answers
        .iter()
        .filter(|a| a.header.kind == kind::OUTPUT)
        .count();
    let initialising = answers
        .iter()
        .filter(|a| a.header.kind == kind::INITIALISING)
        .count();
    let rejected = answers.len() - answered - initialising;
    let mut latency = flown.latency_us.clone();
    let summary = FeedSummary {
        run,
        instance: options.instance.clone(),
        backend: bridge_types::backend::name(status.backend).to_owned(),
        board: field_text(&status.board),
        precision_bits: status.precision_bits,
        grading_ratio: status.grading_ratio,
        mode: options.mode.name().to_owned(),
        realtime: options.realtime,
        client_cpus: crate::affinity::current_list(),
        frames_sent: flown.sent.len(),
        frames_answered: answered,
        frames_initialising: initialising,
        frames_rejected: rejected,
        frames_lost: flown.sent.len() - answers.len(),
        latency_us: Percentiles::of(&mut latency),
        frames_per_s: flown.sent.len() as f64 / flown.wall.as_secs_f64().max(1e-9),
        instructions_per_step_max: stats.max,
        instructions_per_step_mean: stats.mean,
        max_tension_diff_vs_host_n: vs64.max_tension_diff_n,
        max_tension_diff_vs_host_same_precision_n: vs_same.max_tension_diff_n,
        frames_identical_to_host_same_precision: vs_same.identical,
    };
    let summary_path = out_dir.join("summary.json");
    let mut json = serde_json::to_string_pretty(&summary)
        .map_err(|e| BridgeError::Output(format!("cannot write the summary: {e}")))?;
    json.push('\n');
    write_atomically(&summary_path, json.as_bytes()).map_err(|e| {
        BridgeError::Output(format!("cannot write {}: {e}", summary_path.display()))
    })?;
    let mut files = vec![timeseries, summary_path];
    if options.plots {
        let plotted = write_comparison_plots(
            &format!(
                "{} (bridge {}, {})",
                plan.name,
                options.instance,
                bridge_types::backend::name(status.backend)
            ),
            &[
                ("bridge", &bridge_samples[..]),
                ("host f64", &host_samples[..]),
            ],
            &out_dir,
        )
        .map_err(|e| BridgeError::Output(e.to_string()))?;
        files.extend(plotted);
        files.extend(
            write_management_plot(
                &format!("{} (bridge {})", plan.name, options.instance),
                &bridge_samples,
                &out_dir,
            )
            .map_err(|e| BridgeError::Output(e.to_string()))?,
        );
    }
    if let Some((t_s, reason)) = flown.stop {
        return Err(FeedError::Stopped {
            t_s,
            reason,
            out_dir,
        });
    }
    if let Some(signal) = flown.interrupted {
        return Err(FeedError::Interrupted {
            t_s: summary.run.stopped.as_ref().map_or(0.0, |s| s.t_s),
            signal,
            out_dir,
        });
    }
    Ok(FeedRun {
        summary,
        out_dir,
        files,
        answers,
        host_same_precision: same[1..].to_vec(),
    })
}
