//! The pipeline every streamed run follows, once: the options checked and the
//! scenario planned, the output directory cleared, the device opened, the
//! signals installed, the scenario's frames flown through the device's
//! [`Transport`], the same frames replayed on the host controller, then the
//! files written as `decoy simulate` writes its runs (`timeseries.csv`,
//! `summary.json`, the plots; `docs/outputs.md`). A [`Device`] supplies what
//! differs: how it is opened, the host replay of its model, its summary and
//! its own files.
//!
//! Order: the options, the scenario and what the device checks come first (a
//! usage error leaves the output directory as it was); then the files an
//! earlier run left there are removed ([`clear_output_dir`]) before the device
//! is built, booted or contacted, so a run that fails from there on leaves no
//! earlier summary to be taken for its own; every file is written whole.
//! SIGINT or SIGTERM stops the flight at the next frame: the frames flown are
//! written, `summary.json`'s `stopped` names the signal and the result is
//! [`StreamError::Interrupted`]; a second signal ends the process at once
//! (`crate::signals`).

use std::fmt;
use std::fs;
use std::path::{Path, PathBuf};

use decoy_config::SystemConfig;
use decoy_hil::flight::{self, Agreement, InstructionStats};
use decoy_link::{Command, DeviceMessage, HostMessage, OutputFrame};
use decoy_sim::atomic::write_atomically;
use decoy_sim::{
    RunOptions, Sample, Scenario, ScenarioKind, SimError, Summary, clear_output_dir, format_time,
    summarize, write_comparison_plots, write_management_plot,
};
use serde::Serialize;

use crate::files::{paired_rows, sample, write_timeseries};
use crate::fly::{self, Flown, Mode, Stop};
use crate::signals::Interrupts;
use crate::transport::{FrameAnswer, Transport};

/// The RK4 step the controller takes at most (the stepping rule,
/// docs/protocol.md §5): the step a streamed run's scenario is planned with.
pub const MAX_STEP_S: f64 = decoy_controller::MAX_STEP_S;

/// What every streamed run takes.
#[derive(Clone, Debug, PartialEq)]
pub struct StreamOptions {
    /// Simulated time, s (default: the scenario's).
    pub t_end: Option<f64>,
    /// Flight-path rotation rate of a pull-up or turn, rad/s.
    pub rate: Option<f64>,
    /// Output directory (default `out/<prefix>-<scenario>`, the prefix the
    /// device's [`Device::OUT_PREFIX`]).
    pub out_dir: Option<PathBuf>,
    /// Draw the plots.
    pub plots: bool,
    /// Lockstep or free-running.
    pub mode: Mode,
    /// Pace the frames at real time (10 ms apart) instead of flat out.
    pub realtime: bool,
}

impl Default for StreamOptions {
    fn default() -> Self {
        StreamOptions {
            t_end: None,
            rate: None,
            out_dir: None,
            plots: true,
            mode: Mode::Lockstep,
            realtime: false,
        }
    }
}

/// The model the device's controller runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Model {
    /// Cable segments.
    pub segments: usize,
    /// Length ratio of neighbouring segments (1: uniform).
    pub grading: f64,
    /// Bits of the controller's floats: 32 or 64.
    pub precision_bits: u8,
}

/// The titles of a run's plots, after the scenario's name.
#[derive(Clone, Debug, PartialEq)]
pub struct PlotTitles {
    /// The device's outputs beside the host's (`(HIL, m4)`).
    pub comparison: String,
    /// The decoy management's plot.
    pub management: String,
}

/// A device's failure: what it says and whether the input must change.
pub trait DeviceError: fmt::Display {
    /// The device in words, as a stop's message names it (`the firmware`).
    const WHO: &'static str;
    /// Whether the input must change (exit code 2) rather than the run failing.
    fn is_usage(&self) -> bool;
}

/// The far end of a streamed run: what is checked before its output
/// directory is cleared, how it is opened, the host's replay of its model,
/// its summary and its own files.
pub trait Device {
    /// What carries the frames.
    type Transport: Transport<Error: fmt::Display>;
    /// Why the device failed.
    type Error: DeviceError + From<<Self::Transport as Transport>::Error>;
    /// Its `summary.json`.
    type Summary: Serialize;
    /// The default output directory is `out/<OUT_PREFIX>-<scenario>`.
    const OUT_PREFIX: &'static str;
    /// Its outputs' label in the plots (`firmware`).
    const SERIES: &'static str;

    /// The configuration the run is planned and replayed with.
    fn config(&self) -> &SystemConfig;

    /// The segments and grading the scenario is checked with before the
    /// device is open (a usage error when they cannot be).
    fn planned_layout(&self) -> Result<(usize, f64), StreamError<Self::Error>>;

    /// What must hold before the output directory is cleared (by default
    /// nothing).
    fn check(&mut self) -> Result<(), StreamError<Self::Error>> {
        Ok(())
    }

    /// Opens the device (after the output directory is cleared): its
    /// transport and the model its controller runs.
    fn open(&mut self) -> Result<(Self::Transport, Model), StreamError<Self::Error>>;

    /// Closes the transport after the flight (by default drops it).
    fn close(&mut self, transport: Self::Transport) {
        drop(transport);
    }

    /// The host's replays of `messages` (what the device's controller took):
    /// the f64 accuracy reference, which completes its trim in the first
    /// frame, and the device's controller in its own precision, one answer per
    /// message each.
    fn replay(
        &self,
        model: &Model,
        messages: &[HostMessage],
    ) -> Result<Replays, StreamError<Self::Error>>;

    /// The plots' titles for scenario `name`.
    fn plot_titles(&self, name: &str) -> PlotTitles;

    /// `summary.json`.
    fn summary(&self, flight: Flight<'_, <Self::Transport as Transport>::Answer>) -> Self::Summary;

    /// The device's own files, written after `summary.json` into `dir`
    /// (`firmware.log`; by default none).
    fn write_files(&self, dir: &Path) -> Result<Vec<PathBuf>, String> {
        let _ = dir;
        Ok(Vec::new())
    }

    /// The device's own plots of scenario `name`, drawn after the comparison
    /// plots into `dir` (by default none).
    fn write_plots(&self, name: &str, rows: &[Row], dir: &Path) -> Result<Vec<PathBuf>, String> {
        let _ = (name, rows, dir);
        Ok(Vec::new())
    }
}

/// The host's two replays of what a device's controller took, one answer per
/// message each ([`Device::replay`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Replays {
    /// The f64 accuracy reference, which completes its trim in the first frame.
    pub host64: Vec<DeviceMessage>,
    /// The device's controller in its own precision.
    pub same: Vec<DeviceMessage>,
}

/// One frame of `timeseries.csv`: the frame, the device's output and the f64
/// replay's.
pub type Row = (decoy_link::AircraftStateFrame, OutputFrame, OutputFrame);

/// What a flight gives its device's summary.
pub struct Flight<'a, A> {
    /// `decoy simulate`'s summary of the device's outputs.
    pub run: Summary,
    /// The model flown.
    pub model: &'a Model,
    /// The frames and their answers.
    pub flown: &'a Flown<A>,
    /// The answers that came, in order.
    pub answered: &'a [A],
    /// The Outputs among them.
    pub outputs: &'a [OutputFrame],
    /// The control steps' instructions (the Outputs that integrated).
    pub steps: InstructionStats,
    /// Against the host's f64 replay.
    pub vs_host: Agreement,
    /// Against the host's replay in the device's precision.
    pub vs_same: Agreement,
}

impl<A: FrameAnswer> Flight<'_, A> {
    /// Frames answered by an Output.
    pub fn frames_answered(&self) -> usize {
        self.outputs.len()
    }

    /// Frames the initialisation took.
    pub fn frames_initialising(&self) -> usize {
        self.answered.iter().filter(|a| a.is_initialising()).count()
    }
}

/// A finished streamed run.
#[derive(Clone, Debug)]
pub struct StreamRun<S> {
    /// `summary.json`'s contents.
    pub summary: S,
    /// The output directory.
    pub out_dir: PathBuf,
    /// Every file written.
    pub files: Vec<PathBuf>,
}

/// Why a streamed run failed; `E` is the device's own failure.
#[derive(Debug)]
pub enum StreamError<E> {
    /// The scenario or an option is unusable (exit code 2).
    Usage(String),
    /// The scenario could not be planned.
    Scenario(SimError),
    /// The device failed.
    Device(E),
    /// The controller rejected a frame of the scenario (lockstep): the outputs
    /// up to then are written.
    Stopped {
        /// Time of the last frame it took, s.
        t_s: f64,
        /// The rejection.
        reason: String,
        /// Where the outputs are.
        out_dir: PathBuf,
    },
    /// SIGINT or SIGTERM stopped the flight at a frame: the outputs up to then
    /// are written, `summary.json`'s `stopped.reason` is `interrupted by
    /// SIGINT` (or SIGTERM).
    Interrupted {
        /// Time of the last answered frame, s.
        t_s: f64,
        /// `SIGINT` or `SIGTERM`.
        signal: &'static str,
        /// Where the outputs are.
        out_dir: PathBuf,
    },
    /// The transport failed after frames were answered (lockstep: no answer
    /// within the deadline, a link cut): the outputs up to the last answered
    /// frame are written, `summary.json`'s `stopped.reason` starts `link lost`.
    LinkLost {
        /// Time of the last answered frame, s.
        t_s: f64,
        /// The transport's error, in words.
        reason: String,
        /// Where the outputs are.
        out_dir: PathBuf,
    },
    /// Writing an output failed.
    Output(String),
}

impl<E: DeviceError> StreamError<E> {
    /// Whether the input must change (exit code 2) rather than the run failing (1).
    pub fn is_usage(&self) -> bool {
        match self {
            StreamError::Usage(_) => true,
            StreamError::Scenario(e) => e.is_usage(),
            StreamError::Device(e) => e.is_usage(),
            _ => false,
        }
    }
}

impl<E: DeviceError> fmt::Display for StreamError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StreamError::Usage(m) | StreamError::Output(m) => f.write_str(m),
            StreamError::Scenario(e) => write!(f, "{e}"),
            StreamError::Device(e) => write!(f, "{e}"),
            StreamError::Stopped {
                t_s,
                reason,
                out_dir,
            } => write!(
                f,
                "{} stopped accepting the scenario after t = {} s: {reason}; the outputs up to then are in {}",
                E::WHO,
                format_time(*t_s),
                out_dir.display()
            ),
            StreamError::LinkLost {
                t_s,
                reason,
                out_dir,
            } => write!(
                f,
                "{} stopped answering after t = {} s: {reason}; the outputs up to then are in {}",
                E::WHO,
                format_time(*t_s),
                out_dir.display()
            ),
            StreamError::Interrupted {
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

impl<E: DeviceError + fmt::Debug> std::error::Error for StreamError<E> {}

impl<E> From<E> for StreamError<E> {
    fn from(e: E) -> Self {
        StreamError::Device(e)
    }
}

/// The run options of the plan: the layout, the controller's step, the
/// run's time and rate.
fn plan_options(options: &StreamOptions, segments: usize, grading: f64) -> RunOptions {
    RunOptions {
        segments: Some(segments),
        grading: Some(grading),
        dt: Some(MAX_STEP_S),
        t_end: options.t_end,
        rate: options.rate,
        plots: false,
        ..RunOptions::default()
    }
}

/// Writes `value` as pretty JSON to `path`, whole.
fn write_json(path: &Path, value: &impl Serialize) -> Result<(), String> {
    let mut json = serde_json::to_string_pretty(value)
        .map_err(|e| format!("cannot write the summary: {e}"))?;
    json.push('\n');
    write_atomically(path, json.as_bytes())
        .map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// Flies `scenario` through `device` and writes the outputs (see the module
/// docs); `progress` gets the fraction of frames done.
pub fn run<D: Device>(
    scenario: &Scenario,
    options: &StreamOptions,
    device: &mut D,
    progress: impl FnMut(f64),
) -> Result<StreamRun<D::Summary>, StreamError<D::Error>> {
    let (segments, grading) = device.planned_layout()?;
    if scenario.kind == ScenarioKind::Recorded && options.rate.is_some() {
        return Err(StreamError::Usage(
            "--rate does not apply to a recorded flight".to_owned(),
        ));
    }
    let mut plan = scenario
        .plan(device.config(), &plan_options(options, segments, grading))
        .map_err(StreamError::Scenario)?;
    let frame_count = flight::checked_frame_count(plan.t_end, options.t_end.is_some())
        .map_err(StreamError::Usage)?;
    let out_dir = options
        .out_dir
        .clone()
        .unwrap_or_else(|| Path::new("out").join(format!("{}-{}", D::OUT_PREFIX, plan.name)));
    device.check()?;
    clear_output_dir(&out_dir).map_err(|e| StreamError::Output(e.to_string()))?;

    let (mut transport, model) = device.open()?;
    // After the transport, whose own handler (a bridge client's iceoryx2 node)
    // they chain.
    let signals = Interrupts::install().map_err(|e| {
        StreamError::Output(format!("cannot install the SIGINT/SIGTERM handlers: {e}"))
    })?;
    if (model.segments, model.grading) != (segments, grading) {
        plan = scenario
            .plan(
                device.config(),
                &plan_options(options, model.segments, model.grading),
            )
            .map_err(StreamError::Scenario)?;
    }
    let frames = flight::scenario_frames(&plan.profile, frame_count);
    transport.reset().map_err(D::Error::from)?;
    let flown = match options.mode {
        Mode::Lockstep => fly::lockstep(
            &mut transport,
            &frames,
            options.realtime,
            progress,
            &signals,
        ),
        Mode::Free => match transport.free_running() {
            Some(free) => fly::free_running(free, &frames, options.realtime, progress, &signals),
            None => {
                return Err(StreamError::Usage(format!(
                    "{} is flown in lockstep only, not free-running",
                    D::Error::WHO
                )));
            }
        },
    }
    .map_err(D::Error::from)?;
    device.close(transport);

    // What the device's controller took: the reset, then the frames it answered.
    let seen: Vec<HostMessage> = std::iter::once(HostMessage::Command(Command::ResetToTrim))
        .chain(flown.seen().into_iter().map(HostMessage::State))
        .collect();
    let Replays { host64, same } = device.replay(&model, &seen)?;
    let answered = flown.answered();
    let outputs: Vec<OutputFrame> = answered.iter().filter_map(|a| a.output()).collect();
    let output_messages: Vec<DeviceMessage> =
        outputs.iter().copied().map(DeviceMessage::Output).collect();
    let agreement = |host: &[DeviceMessage]| {
        // Frame by frame: each Output beside the host's answer to the same frame.
        let (device_side, host_side): (Vec<DeviceMessage>, Vec<DeviceMessage>) = answered
            .iter()
            .zip(host.iter().skip(1))
            .filter_map(|(a, h)| a.output().map(|o| (DeviceMessage::Output(o), *h)))
            .unzip();
        flight::compare(&device_side, &host_side).0
    };
    let (vs_host, vs_same) = (agreement(&host64), agreement(&same));
    let steps = flight::instruction_stats(&output_messages);

    fs::create_dir_all(&out_dir)
        .map_err(|e| StreamError::Output(format!("cannot create {}: {e}", out_dir.display())))?;
    let rows = paired_rows(&flown.sent, &output_messages, &host64);
    let device_samples: Vec<Sample> = rows
        .iter()
        .map(|(frame, out, _)| sample(out, frame, plan.lateral_sign))
        .collect();
    let host_samples: Vec<Sample> = rows
        .iter()
        .map(|(frame, _, host)| sample(host, frame, plan.lateral_sign))
        .collect();
    let timeseries = out_dir.join("timeseries.csv");
    write_timeseries(&timeseries, &rows, &device_samples, &host_samples)
        .map_err(StreamError::Output)?;
    let summary = summarize(
        &plan.name,
        model.segments,
        MAX_STEP_S,
        plan.t_end,
        plan.profile.manoeuvre_start(),
        &device_samples,
        flown.wall.as_secs_f64(),
        flown.stop.as_ref().map(Stop::reason),
    );
    let stopped_at = summary.stopped.as_ref().map_or(0.0, |s| s.t_s);
    let summary = device.summary(Flight {
        run: summary,
        model: &model,
        flown: &flown,
        answered: &answered,
        outputs: &outputs,
        steps,
        vs_host,
        vs_same,
    });
    let summary_path = out_dir.join("summary.json");
    write_json(&summary_path, &summary).map_err(StreamError::Output)?;
    let mut files = vec![timeseries, summary_path];
    files.extend(device.write_files(&out_dir).map_err(StreamError::Output)?);
    if options.plots {
        let titles = device.plot_titles(&plan.name);
        files.extend(
            write_comparison_plots(
                &titles.comparison,
                &[
                    (D::SERIES, &device_samples[..]),
                    ("host f64", &host_samples[..]),
                ],
                &out_dir,
            )
            .map_err(|e| StreamError::Output(e.to_string()))?,
        );
        files.extend(
            device
                .write_plots(&plan.name, &rows, &out_dir)
                .map_err(StreamError::Output)?,
        );
        files.extend(
            write_management_plot(
                &titles.management,
                &device_samples,
                device.config(),
                &out_dir,
            )
            .map_err(|e| StreamError::Output(e.to_string()))?,
        );
    }
    match flown.stop {
        Some(Stop::Rejected { t_s, reason }) => Err(StreamError::Stopped {
            t_s,
            reason,
            out_dir,
        }),
        Some(Stop::Lost { t_s, reason }) => Err(StreamError::LinkLost {
            t_s,
            reason,
            out_dir,
        }),
        Some(Stop::Signal(signal)) => Err(StreamError::Interrupted {
            t_s: stopped_at,
            signal,
            out_dir,
        }),
        None => Ok(StreamRun {
            summary,
            out_dir,
            files,
        }),
    }
}
