//! `decoy hil`: a scenario flown by the firmware under QEMU, frame by frame over
//! the link, beside the host's replay of the same frames, written as `decoy
//! simulate` writes its runs (`timeseries.csv`, `summary.json`, plots; see
//! `docs/outputs.md`).
//!
//! The output directory follows `decoy simulate`'s rule: once the options and
//! the firmware are checked, the files an earlier run left there are removed
//! ([`decoy_sim::clear_output_dir`]) before the firmware is built and booted, and
//! every file is written whole. A stop request ([`run_hil_until`]: the command
//! line's SIGINT or SIGTERM) ends the flight at the next frame; the frames flown
//! are written and the result is [`HilError::Interrupted`].

use std::fmt;
use std::fs;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use decoy_config::SystemConfig;
use decoy_link::{AircraftStateFrame, DeviceMessage, HostMessage, OutputFrame};
use decoy_schema::Quantity;
use decoy_schema::columns::HIL_TIMESERIES;
use decoy_sim::atomic::write_atomically;
use decoy_sim::{
    Cell, FIRMWARE_LOG, RunOptions, Sample, Scenario, ScenarioKind, SimError, Summary,
    clear_output_dir, csv_row, format_time, summarize, write_comparison_plots,
};
use serde::Serialize;

use crate::firmware::{self, BuildError};
use crate::flight::{self, HostSetupError, InstructionStats};
use crate::link::{LinkError, Session};
use crate::qemu::Board;
use crate::reference::{Reference, ReferenceError};

/// Time limit of a firmware build.
pub const BUILD_TIMEOUT: Duration = Duration::from_secs(900);

/// The RK4 step the controller takes at most (`decoy_link`'s stepping rule).
pub const MAX_STEP_S: f64 = decoy_controller::MAX_STEP_S;

/// What `decoy hil` runs.
#[derive(Clone, Debug, PartialEq)]
pub struct HilOptions {
    /// The board (and firmware build).
    pub board: Board,
    /// Cable segments; `None`: the configuration's `solver.segments_embedded`
    /// (another count builds a firmware variant).
    pub segments: Option<usize>,
    /// Simulated time, s (default: the scenario's).
    pub t_end: Option<f64>,
    /// Flight-path rotation rate of a pull-up or turn, rad/s.
    pub rate: Option<f64>,
    /// Output directory (default `out/hil-<scenario>`).
    pub out_dir: Option<PathBuf>,
    /// Draw the plots.
    pub plots: bool,
    /// A firmware ELF to boot instead of building one (`--firmware`).
    pub firmware: Option<PathBuf>,
}

impl Default for HilOptions {
    fn default() -> Self {
        HilOptions {
            board: Board::default(),
            segments: None,
            t_end: None,
            rate: None,
            out_dir: None,
            plots: true,
            firmware: None,
        }
    }
}

/// `decoy hil`'s `summary.json`: `decoy simulate`'s summary of the firmware's run
/// plus the keys of the run in the loop.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct HilSummary {
    /// The firmware run's summary, as `decoy simulate` defines it.
    #[serde(flatten)]
    pub run: Summary,
    /// `m4` or `m7`.
    pub board: String,
    /// The firmware's floating-point precision, bits.
    pub precision_bits: u8,
    /// Most instructions one 10 ms control step took (SysTick under `-icount`).
    pub instructions_per_step_max: u32,
    /// Mean instructions per 10 ms control step.
    pub instructions_per_step_mean: f64,
    /// Most instructions one frame's decoy management took (monitors and the
    /// look-ahead's slice, after the Output's solution;
    /// `OutputFrame::management_instructions`).
    pub management_instructions_max: u32,
    /// Look-ahead predictions that completed during the run.
    pub predictions_completed: usize,
    /// Horizon of the last completed prediction, s (0: none completed).
    pub prediction_horizon_s: f64,
    /// State frames sent to the firmware (the `ResetToTrim` command before them is
    /// not counted: like with like with `frames_answered`).
    pub frames_sent: usize,
    /// Of those, answered by an Output frame.
    pub frames_answered: usize,
    /// Of those, answered by the initialisation's Status (the frames of the
    /// trim before the one that completes it; docs/protocol.md §4).
    pub frames_initialising: usize,
    /// Frames of the initialisation (those and the Output completing the trim)
    /// and the most instructions one of them took.
    pub trim_frames: usize,
    /// See [`HilSummary::trim_frames`].
    pub trim_instructions_max: u32,
    /// Largest difference of either tension from the host's f64 solution, N.
    #[serde(rename = "max_tension_diff_vs_host_N")]
    pub max_tension_diff_vs_host_n: f64,
    /// Largest difference of either tension from the host reference in the
    /// firmware's own precision (the firmware's controller in this process; f32 on
    /// the M4), N: 0 when they agree bit for bit.
    #[serde(rename = "max_tension_diff_vs_host_same_precision_N")]
    pub max_tension_diff_vs_host_same_precision_n: f64,
    /// Of the output frames, those equal to the host's same-precision ones in every
    /// field but `instructions`.
    pub frames_identical_to_host_same_precision: usize,
    /// Static RAM of the ELF (`.data` + `.bss`), bytes.
    pub ram_bytes: u64,
    /// Flash of the ELF (`.text` + `.data`), bytes.
    pub flash_bytes: u64,
    /// The stack's peak from reset until the controller was built (stack
    /// painting, from the firmware's log), bytes; None if the log has no report.
    pub stack_boot_bytes: Option<u64>,
    /// The stack's peak in the link loop, at its last report in the log (the trim
    /// and every 100th output), bytes; None without one.
    pub stack_link_bytes: Option<u64>,
    /// Static RAM plus the larger stack peak: the most RAM in use at any moment,
    /// bytes; None without the stack reports.
    pub ram_peak_bytes: Option<u64>,
    /// The board's RAM budget ([`decoy_boards::BoardSpec::ram_budget`]), bytes.
    pub ram_budget_bytes: u64,
    /// Round trips per second over the link (wall clock).
    pub link_frames_per_s: f64,
    /// The ELF that ran.
    pub elf: String,
    /// Where it came from: "built from DIR" (the firmware source `decoy hil`
    /// found and built) or "given with --firmware".
    pub firmware_source: String,
}

/// A finished `decoy hil` run.
#[derive(Clone, Debug)]
pub struct HilRun {
    /// `summary.json`'s contents.
    pub summary: HilSummary,
    /// The output directory.
    pub out_dir: PathBuf,
    /// Every file written.
    pub files: Vec<PathBuf>,
    /// The decoded firmware log.
    pub log: String,
}

/// Why `decoy hil` failed.
#[derive(Debug)]
pub enum HilError {
    /// The scenario or an option is unusable (exit code 2).
    Usage(String),
    /// The scenario could not be planned.
    Scenario(SimError),
    /// The firmware could not be built.
    Build(BuildError),
    /// The host reference could not be built.
    Host(HostSetupError),
    /// The host reference in the firmware's precision failed.
    Reference(ReferenceError),
    /// QEMU or the link failed.
    Link(LinkError),
    /// The firmware rejected a frame of the scenario (the outputs up to then are
    /// written).
    Stopped {
        /// Time of the last accepted frame, s.
        t_s: f64,
        /// The rejection.
        reason: String,
        /// Where the outputs are.
        out_dir: PathBuf,
    },
    /// A stop request (SIGINT, SIGTERM) ended the flight at a frame: the
    /// outputs up to then are written, `summary.json`'s `stopped.reason` names it.
    Interrupted {
        /// Time of the last answered frame, s.
        t_s: f64,
        /// What asked to stop (`SIGINT`).
        signal: &'static str,
        /// Where the outputs are.
        out_dir: PathBuf,
    },
    /// Writing an output failed.
    Output(String),
}

impl HilError {
    /// Whether the input must change (exit code 2) rather than the run failing (1).
    pub fn is_usage(&self) -> bool {
        match self {
            HilError::Usage(_) => true,
            HilError::Build(BuildError::NotElf(_) | BuildError::NoSource(_)) => true,
            HilError::Scenario(e) => e.is_usage(),
            _ => false,
        }
    }
}

impl fmt::Display for HilError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            HilError::Usage(m) | HilError::Output(m) => f.write_str(m),
            HilError::Scenario(e) => write!(f, "{e}"),
            HilError::Build(e) => write!(f, "{e}"),
            HilError::Host(e) => write!(f, "{e}"),
            HilError::Reference(e) => write!(f, "{e}"),
            HilError::Link(e) => write!(f, "{e}"),
            HilError::Stopped {
                t_s,
                reason,
                out_dir,
            } => write!(
                f,
                "the firmware stopped accepting the scenario after t = {} s: {reason}; the outputs up to then are in {}",
                format_time(*t_s),
                out_dir.display()
            ),
            HilError::Interrupted {
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

impl std::error::Error for HilError {}

/// Builds the firmware `decoy hil` needs: the configured one, or a variant with
/// `segments` segments; returns its ELF.
pub fn build_firmware(
    board: Board,
    segments: usize,
    configured: usize,
) -> Result<PathBuf, HilError> {
    check_segments(segments)?;
    let elf = if segments == configured {
        firmware::build_board(board, BUILD_TIMEOUT)
    } else {
        firmware::build_board_with_segments(board, segments, BUILD_TIMEOUT)
    };
    elf.map_err(HilError::Build)
}

/// `--segments` must fit the firmware's solver.
fn check_segments(segments: usize) -> Result<(), HilError> {
    if (1..=firmware::MAX_SEGMENTS).contains(&segments) {
        Ok(())
    } else {
        Err(HilError::Usage(format!(
            "--segments must be between 1 and {} (the firmware's capacity), got {segments}",
            firmware::MAX_SEGMENTS
        )))
    }
}

/// Flies `scenario` on the firmware in QEMU (`options.board`) and on the host, and
/// writes `timeseries.csv`, `summary.json` and (with `options.plots`) the plots.
/// `progress` gets the fraction of frames done.
pub fn run_hil(
    config: &SystemConfig,
    scenario: &Scenario,
    options: &HilOptions,
    progress: impl FnMut(f64),
) -> Result<HilRun, HilError> {
    run_hil_until(config, scenario, options, progress, || None)
}

/// [`run_hil`], stopping at the next frame when `stop` (asked before every
/// frame) returns `Some(signal)`: the command line passes the name of the
/// signal it received. The frames flown are written as a rejection's are, with
/// `interrupted by SIGNAL` as `summary.json`'s `stopped.reason`, and the result is
/// [`HilError::Interrupted`]. A link that fails once a stop was requested (QEMU
/// got the terminal's SIGINT too) counts as the same stop.
pub fn run_hil_until(
    config: &SystemConfig,
    scenario: &Scenario,
    options: &HilOptions,
    progress: impl FnMut(f64),
    stop: impl Fn() -> Option<&'static str>,
) -> Result<HilRun, HilError> {
    let configured = config.solver.segments_embedded;
    let segments = options.segments.unwrap_or(configured);
    check_segments(segments)?;
    if scenario.kind == ScenarioKind::Recorded && options.rate.is_some() {
        return Err(HilError::Usage(
            "--rate does not apply to a recorded flight".to_owned(),
        ));
    }
    let mut config = config.clone();
    config.solver.segments_embedded = segments;
    let plan = scenario
        .plan(
            &config,
            &RunOptions {
                segments: Some(segments),
                grading: Some(config.solver.grading_ratio_embedded),
                dt: Some(MAX_STEP_S),
                t_end: options.t_end,
                rate: options.rate,
                plots: false,
                ..RunOptions::default()
            },
        )
        .map_err(HilError::Scenario)?;
    let frame_count = flight::checked_frame_count(plan.t_end, options.t_end.is_some())
        .map_err(HilError::Usage)?;
    let out_dir = options
        .out_dir
        .clone()
        .unwrap_or_else(|| Path::new("out").join(format!("hil-{}", plan.name)));
    // The firmware given is checked (a usage error leaves the directory as it
    // was) before the directory is cleared, and that before the build.
    let origin = match &options.firmware {
        Some(path) => {
            firmware::check_elf(path).map_err(HilError::Build)?;
            FirmwareOrigin::Given(path.clone())
        }
        None => FirmwareOrigin::Source(firmware::locate_source().map_err(HilError::Build)?),
    };
    clear_output_dir(&out_dir).map_err(|e| HilError::Output(e.to_string()))?;
    let (elf, firmware_source) = match origin {
        FirmwareOrigin::Given(elf) => {
            // An ELF that names its board (`firmware/build.rs`) must name this one;
            // one that names none is checked by its Hello below.
            let named = Board::of_elf(&elf).map_err(|e| HilError::Usage(e.to_string()))?;
            if let Some(named) = named.filter(|&b| b != options.board) {
                return Err(HilError::Usage(format!(
                    "the firmware {} is built for the board {} ({named} in firmware/boards.toml), \
                     not {} (--board {})",
                    elf.display(),
                    named.hello(),
                    options.board.hello(),
                    options.board.name()
                )));
            }
            (elf, "given with --firmware".to_owned())
        }
        FirmwareOrigin::Source(dir) => {
            let elf = build_firmware(options.board, segments, configured)?;
            (elf, format!("built from {}", dir.display()))
        }
    };
    let memory = firmware::memory_usage(&elf).map_err(HilError::Output)?;

    let wall = Instant::now();
    let frames = flight::scenario_frames(&plan.profile, frame_count);
    let messages = flight::scenario_messages(&frames);
    let mut session = Session::start(&elf, options.board).map_err(HilError::Link)?;
    let hello = session.hello;
    let expected = options.board.info().name;
    if hello.board != expected {
        return Err(HilError::Usage(format!(
            "the firmware {} is built for the board {}, not {expected} (--board {})",
            elf.display(),
            hello.board,
            options.board.name()
        )));
    }
    if usize::from(hello.segments) != segments {
        return Err(HilError::Usage(format!(
            "the firmware {} runs {} segments, not {segments}: pass --segments {}",
            elf.display(),
            hello.segments,
            hello.segments
        )));
    }
    let flown = fly_until_rejected(&mut session, &messages, progress, &stop);
    let log = session.finish();
    let marks = firmware::stack_marks(&log.log).ok();
    let (exchanges, stop, fps) = match flown {
        Ok(run) => run,
        Err(e) => return Err(HilError::Link(e)),
    };
    let sent: Vec<HostMessage> = exchanges.iter().map(|(m, _)| *m).collect();
    let answers: Vec<DeviceMessage> = exchanges.into_iter().map(|(_, a)| a).collect();

    let host64 = {
        let mut c = flight::accuracy_controller(&config).map_err(HilError::Host)?;
        flight::replay(&mut c, &sent)
    };
    // The firmware's precision with the target's maths: bit for bit.
    let same_precision = Reference::for_config(&config, hello.precision_bits)
        .and_then(|mut r| r.replay(&sent))
        .map_err(HilError::Reference)?;
    let (vs64, _) = flight::compare(&answers, &host64);
    let (vs_same, _) = flight::compare(&answers, &same_precision);
    let stats: InstructionStats = flight::instruction_stats(&answers);

    fs::create_dir_all(&out_dir)
        .map_err(|e| HilError::Output(format!("cannot create {}: {e}", out_dir.display())))?;
    let rows = paired_rows(&frames, &answers, &host64);
    let firmware_samples: Vec<Sample> = rows
        .iter()
        .map(|(frame, fw, _)| sample(fw, frame, plan.lateral_sign))
        .collect();
    let host_samples: Vec<Sample> = rows
        .iter()
        .map(|(frame, _, host)| sample(host, frame, plan.lateral_sign))
        .collect();
    let timeseries = out_dir.join("timeseries.csv");
    write_timeseries(&timeseries, &rows, &firmware_samples, &host_samples)?;

    let run = summarize(
        &plan.name,
        segments,
        MAX_STEP_S,
        plan.t_end,
        plan.profile.manoeuvre_start(),
        &firmware_samples,
        wall.elapsed().as_secs_f64(),
        stop.as_ref().map(|s| s.reason.clone()),
    );
    let summary = HilSummary {
        run,
        board: options.board.name().to_owned(),
        precision_bits: hello.precision_bits,
        instructions_per_step_max: stats.max,
        instructions_per_step_mean: stats.mean,
        management_instructions_max: flight::outputs(&answers)
            .iter()
            .map(|o| o.management_instructions)
            .max()
            .unwrap_or(0),
        predictions_completed: predictions_completed(&answers),
        prediction_horizon_s: flight::outputs(&answers)
            .last()
            .map_or(0.0, |o| f64::from(o.management.prediction_horizon_s)),
        // Like with like: the State frames sent and the Outputs answering them (the
        // ResetToTrim command before them is neither).
        frames_sent: sent
            .iter()
            .filter(|m| matches!(m, HostMessage::State(_)))
            .count(),
        frames_answered: answers
            .iter()
            .filter(|a| matches!(a, DeviceMessage::Output(_)))
            .count(),
        frames_initialising: stats.trim_frames.saturating_sub(1),
        trim_frames: stats.trim_frames,
        trim_instructions_max: stats.trim_max,
        max_tension_diff_vs_host_n: vs64.max_tension_diff_n,
        max_tension_diff_vs_host_same_precision_n: vs_same.max_tension_diff_n,
        frames_identical_to_host_same_precision: vs_same.identical,
        ram_bytes: memory.ram(),
        flash_bytes: memory.flash(),
        stack_boot_bytes: marks.map(|m| m.boot),
        stack_link_bytes: marks.and_then(|m| m.link),
        ram_peak_bytes: marks.map(|m| memory.ram() + m.peak()),
        ram_budget_bytes: options.board.ram_budget(),
        link_frames_per_s: fps,
        elf: elf.display().to_string(),
        firmware_source,
    };
    let summary_path = out_dir.join("summary.json");
    let mut json = serde_json::to_string_pretty(&summary)
        .map_err(|e| HilError::Output(format!("cannot write the summary: {e}")))?;
    json.push('\n');
    write_atomically(&summary_path, json.as_bytes())
        .map_err(|e| HilError::Output(format!("cannot write {}: {e}", summary_path.display())))?;
    let log_path = out_dir.join(FIRMWARE_LOG);
    write_atomically(&log_path, log.log.as_bytes())
        .map_err(|e| HilError::Output(format!("cannot write {}: {e}", log_path.display())))?;
    let mut files = vec![timeseries, summary_path, log_path];
    if options.plots {
        let plotted = write_comparison_plots(
            &format!("{} (HIL, {})", plan.name, options.board),
            &[
                ("firmware", &firmware_samples[..]),
                ("host f64", &host_samples[..]),
            ],
            &out_dir,
        )
        .map_err(|e| HilError::Output(e.to_string()))?;
        files.extend(plotted);
        files.extend(instructions_plot(
            &plan.name,
            options.board,
            &rows,
            &out_dir,
        )?);
        files.extend(
            decoy_sim::write_management_plot(
                &format!("{} (HIL, {})", plan.name, options.board),
                &firmware_samples,
                &out_dir,
            )
            .map_err(|e| HilError::Output(e.to_string()))?,
        );
    }
    if let Some(FlightStop {
        t_s,
        reason,
        requested,
    }) = stop
    {
        return Err(match requested {
            Some(signal) => HilError::Interrupted {
                t_s,
                signal,
                out_dir,
            },
            None => HilError::Stopped {
                t_s,
                reason,
                out_dir,
            },
        });
    }
    Ok(HilRun {
        summary,
        out_dir,
        files,
        log: log.log,
    })
}

/// Where a run's firmware comes from.
enum FirmwareOrigin {
    /// An ELF given with `--firmware`.
    Given(PathBuf),
    /// Built from the firmware source in this directory.
    Source(PathBuf),
}

/// Why a flight ended early.
struct FlightStop {
    /// Time of the last accepted frame, s.
    t_s: f64,
    /// Why, in words (`summary.json`'s `stopped.reason`).
    reason: String,
    /// The stop request that ended it (a signal's name), if one did rather than
    /// a rejection.
    requested: Option<&'static str>,
}

/// The exchanges up to and including the first rejected frame (or up to a stop
/// request), why the flight ended early, and the round trips per second.
type Flight = (Vec<(HostMessage, DeviceMessage)>, Option<FlightStop>, f64);

fn fly_until_rejected(
    session: &mut Session,
    messages: &[HostMessage],
    mut progress: impl FnMut(f64),
    stop: &dyn Fn() -> Option<&'static str>,
) -> Result<Flight, LinkError> {
    let started = Instant::now();
    let mut exchanges = Vec::with_capacity(messages.len());
    let mut last_time = 0.0;
    let every = (messages.len() / 500).max(1);
    let fps = |n: usize| n as f64 / started.elapsed().as_secs_f64().max(1e-9);
    let requested = |signal: &'static str, last_time: f64| FlightStop {
        t_s: last_time,
        reason: format!("interrupted by {signal}"),
        requested: Some(signal),
    };
    for (i, message) in messages.iter().enumerate() {
        if let Some(signal) = stop() {
            let n = exchanges.len();
            return Ok((exchanges, Some(requested(signal, last_time)), fps(n)));
        }
        let answer = match session.link.request(message) {
            Ok(answer) => answer,
            // QEMU, in the terminal's process group, got the SIGINT as well.
            Err(e) => match stop() {
                Some(signal) => {
                    let n = exchanges.len();
                    return Ok((exchanges, Some(requested(signal, last_time)), fps(n)));
                }
                None => return Err(e),
            },
        };
        let rejected = match (&answer, message) {
            (DeviceMessage::Rejected(r), HostMessage::State(frame)) => Some(format!(
                "frame {} (t = {} s) rejected: {:?} ({} so far)",
                frame.seq,
                format_time(frame.time_s),
                r.reason,
                r.count
            )),
            (DeviceMessage::Output(o), _) => {
                last_time = o.time_s;
                None
            }
            _ => None,
        };
        exchanges.push((*message, answer));
        if let Some(reason) = rejected {
            let n = exchanges.len();
            let stop = FlightStop {
                t_s: last_time,
                reason,
                requested: None,
            };
            return Ok((exchanges, Some(stop), fps(n)));
        }
        if i % every == 0 {
            progress(i as f64 / messages.len() as f64);
        }
    }
    progress(1.0);
    let n = exchanges.len();
    Ok((exchanges, None, fps(n)))
}

/// The frames answered by an output on both sides, with both outputs, matched by
/// `seq` (also `decoy feed`'s rows).
pub fn paired_rows(
    frames: &[AircraftStateFrame],
    firmware: &[DeviceMessage],
    host: &[DeviceMessage],
) -> Vec<(AircraftStateFrame, OutputFrame, OutputFrame)> {
    let host_outputs = flight::outputs(host);
    flight::outputs(firmware)
        .into_iter()
        .filter_map(|fw| {
            let frame = frames.iter().find(|f| f.seq == fw.seq)?;
            let host = host_outputs.iter().find(|h| h.seq == fw.seq)?;
            Some((*frame, fw, *host))
        })
        .collect()
}

/// The file stem of the instruction-count plot (named in decoy-sim, with every
/// other output file, for [`decoy_sim::clear_output_dir`]).
pub use decoy_sim::INSTRUCTIONS_PLOT;

/// Draws the instructions of every control step against time (the trim frame
/// left out), with the board's frame budget ([`crate::budgets::frame`]) for
/// comparison.
fn instructions_plot(
    name: &str,
    board: Board,
    rows: &[(AircraftStateFrame, OutputFrame, OutputFrame)],
    dir: &Path,
) -> Result<Vec<PathBuf>, HilError> {
    let steps: Vec<&OutputFrame> = rows
        .iter()
        .map(|(_, o, _)| o)
        .filter(|o| o.steps > 0)
        .collect();
    let t: Vec<f64> = steps.iter().map(|o| o.time_s).collect();
    let mut series = vec![decoy_plots::Series {
        label: format!("firmware ({board})"),
        x: t.clone(),
        y: steps.iter().map(|o| f64::from(o.instructions)).collect(),
    }];
    if let (Some(first), Some(last)) = (t.first(), t.last()) {
        let budget = crate::budgets::frame(board);
        series.push(decoy_plots::Series {
            label: format!("budget {} ({})", budget.limit, budget.source),
            x: vec![*first, *last],
            y: vec![f64::from(budget.limit); 2],
        });
    }
    let plot = decoy_plots::Plot {
        title: format!("{name} (HIL, {board}): instructions per 10 ms control step"),
        x_label: "t [s]".to_owned(),
        y_label: "instructions".to_owned(),
        series,
        aspect: decoy_plots::Aspect::Free,
        invert_y: false,
    };
    decoy_plots::write_plot(&plot, &dir.join(INSTRUCTIONS_PLOT))
        .map(Vec::from)
        .map_err(|e| HilError::Output(format!("the {INSTRUCTIONS_PLOT} plot: {e}")))
}

/// One output as a `decoy simulate` sample (flight-path frame, degrees; angles
/// relative to the flight-path frame; the closest point's position along the
/// cable is not reported by the controller: NaN).
pub fn sample(out: &OutputFrame, frame: &AircraftStateFrame, lateral_sign: f64) -> Sample {
    let p = out.decoy_position_fp_m.map(f64::from);
    let e = out.decoy_euler_rel_rad.map(|a| f64::from(a).to_degrees());
    let v = frame.velocity_ned_mps.map(f64::from);
    Sample {
        t: out.time_s,
        tension_connection: f64::from(out.connection_tension_n),
        tension_tow: f64::from(out.tow_tension_n),
        // `0.0 - x`, not `-x`: no negative zero in the files.
        cg: [0.0 - p[0], (0.0 - p[1]) * lateral_sign + 0.0, p[2]],
        euler_deg: e,
        aoa_deg: f64::from(out.angle_of_attack_rad).to_degrees(),
        exhaust_clearance: f64::from(out.cable_clearance_exhaust_m),
        exhaust_along: f64::NAN,
        decoy_clearance: f64::from(out.decoy_clearance_aircraft_m),
        speed: (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt(),
        altitude: -frame.position_ned_m[2],
        management: decoy_sim::ManagementSample::of_report(&out.management),
    }
}

/// How many look-ahead predictions completed: the number of distinct
/// `prediction_from_s` the Outputs reported.
fn predictions_completed(answers: &[DeviceMessage]) -> usize {
    let mut count = 0;
    let mut last = -1.0;
    for o in &flight::outputs(answers) {
        let from = o.management.prediction_from_s;
        if from >= 0.0 && from != last {
            count += 1;
            last = from;
        }
    }
    count
}

/// The cell of the column holding `quantity` in `decoy hil`'s `timeseries.csv`
/// (`decoy_schema::columns::HIL_TIMESERIES`) for the frame whose controller's
/// Output is `controller`, measured as `sample`, beside the host's `host`
/// (`None`: not a column of the file).
pub fn timeseries_cell(
    controller: &OutputFrame,
    sample: &Sample,
    host: &Sample,
    quantity: Quantity,
) -> Option<Cell> {
    Some(match quantity {
        Quantity::Seq => Cell::Count(u64::from(controller.seq)),
        Quantity::Flags => Cell::Count(u64::from(controller.flags)),
        Quantity::Rk4Steps => Cell::Count(u64::from(controller.steps)),
        Quantity::Instructions => Cell::Count(u64::from(controller.instructions)),
        Quantity::HostTensionConnection => Cell::Value(host.tension_connection),
        Quantity::HostTensionTow => Cell::Value(host.tension_tow),
        Quantity::HostDecoyPitch => Cell::Value(host.euler_deg[1]),
        Quantity::HostDecoyAoa => Cell::Value(host.aoa_deg),
        Quantity::TensionConnectionDiff => {
            Cell::Value(sample.tension_connection - host.tension_connection)
        }
        Quantity::TensionTowDiff => Cell::Value(sample.tension_tow - host.tension_tow),
        Quantity::PredictionSteps => Cell::Count(u64::from(controller.prediction_steps)),
        Quantity::ManagementInstructions => {
            Cell::Count(u64::from(controller.management_instructions))
        }
        // The closest point along the cable is not in the controller's Output.
        Quantity::CableExhaustClosestAlong => return None,
        other => return sample.cell(other),
    })
}

/// Writes `decoy hil`'s `timeseries.csv` (`decoy_schema::columns::HIL_TIMESERIES`):
/// the controller's outputs (`firmware`), the host's (`host`) and their
/// differences, one row per element of `rows` (also `decoy feed`'s file).
pub fn write_timeseries(
    path: &Path,
    rows: &[(AircraftStateFrame, OutputFrame, OutputFrame)],
    firmware: &[Sample],
    host: &[Sample],
) -> Result<(), HilError> {
    let mut text = String::with_capacity(rows.len() * 256);
    text.push_str(&HIL_TIMESERIES.header().to_string());
    text.push('\n');
    for (((_, fw, _), s), h) in rows.iter().zip(firmware).zip(host) {
        text.push_str(&csv_row(&HIL_TIMESERIES, |q| timeseries_cell(fw, s, h, q)));
    }
    write_atomically(path, text.as_bytes())
        .map_err(|e| HilError::Output(format!("cannot write {}: {e}", path.display())))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A row has a cell for every column of the schema, in its order: the
    /// controller's values where the file has them, the host's beside them.
    #[test]
    fn rows_have_every_column_of_the_schema() {
        let mut fw = OutputFrame {
            seq: 17,
            time_s: 1.5,
            connection_tension_n: 0.0,
            tow_tension_n: 0.0,
            decoy_position_fp_m: [0.0; 3],
            decoy_euler_rel_rad: [0.0; 3],
            angle_of_attack_rad: 0.0,
            cable_clearance_exhaust_m: 0.0,
            decoy_clearance_aircraft_m: 0.0,
            flags: 3,
            instructions: 88_000,
            step_instructions: 80_000,
            steps: 4,
            management_instructions: 250_000,
            prediction_steps: 5,
            management: decoy_link::Management::default(),
        };
        fw.management.advisories = 8;
        let mut s = Sample {
            t: 1.5,
            tension_connection: 900.25,
            tension_tow: 40.5,
            ..Sample::default()
        };
        s.management.margins.exhaust = -0.5;
        s.management.levels.exhaust = 3;
        s.management.advisories = 8;
        s.management.violation_in.exhaust = 0.25;
        let h = Sample {
            tension_connection: 900.0,
            tension_tow: 40.0,
            ..Sample::default()
        };
        assert!(
            decoy_sim::missing_cells(&HIL_TIMESERIES, |q| timeseries_cell(&fw, &s, &h, q))
                .is_empty()
        );
        let row = csv_row(&HIL_TIMESERIES, |q| timeseries_cell(&fw, &s, &h, q));
        let cells: Vec<&str> = row.trim_end().split(',').collect();
        assert_eq!(cells.len(), HIL_TIMESERIES.columns.len());
        let at = |name: &str| {
            let k = HIL_TIMESERIES.names().position(|n| n == name).unwrap();
            cells[k]
        };
        assert_eq!(
            [
                at("t_s"),
                at("seq"),
                at("tension_connection_N"),
                at("flags"),
                at("instructions"),
                at("host_tension_connection_N"),
                at("tension_connection_diff_N"),
                at("tension_tow_diff_N"),
                at("management_instructions"),
                at("exhaust_level"),
                at("exhaust_margin_m"),
                at("advisories"),
                at("exhaust_violation_in_s"),
                at("posture_violation_in_s"),
            ],
            [
                "1.5",
                "17",
                "900.250000",
                "3",
                "88000",
                "900.000000",
                "0.250000",
                "0.500000",
                "250000",
                "3",
                "-0.500000",
                "8",
                "0.250000",
                "-1.000000",
            ]
        );
    }
}
