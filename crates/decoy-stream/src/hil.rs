//! `decoy hil`: a scenario flown by the firmware under QEMU, frame by frame over
//! its UART ([`decoy_hil::link::Session`], `crate::uart`), beside the host's
//! replay of the same frames, written as `decoy simulate` writes its runs
//! (`timeseries.csv`, `summary.json`, `firmware.log`, plots; see
//! `docs/outputs.md`) by the pipeline of `crate::run`.
//!
//! Before the output directory is cleared the segment count and the firmware
//! are checked (an ELF given with `--firmware` must be one; else the firmware's
//! source must be found); after it, the firmware is built (or the ELF given
//! checked against the board), booted, and its Hello checked.

use std::fmt;
use std::path::{Path, PathBuf};

use decoy_config::SystemConfig;
use decoy_hil::firmware::{self, BuildError, MemoryUsage, StackMarks};
use decoy_hil::flight::{self, HostSetupError};
use decoy_hil::link::{LinkError, Session};
use decoy_hil::qemu::Board;
use decoy_hil::reference::{Reference, ReferenceError};
use decoy_link::{DeviceMessage, HostMessage, OutputFrame};
use decoy_sim::atomic::write_atomically;
use decoy_sim::{FIRMWARE_LOG, Scenario, Summary};
use serde::Serialize;

use crate::files::instructions_plot;
use crate::firmware::{build_firmware, check_segments};
use crate::run::{
    self, Device, DeviceError, Flight, Model, PlotTitles, Replays, Row, StreamError, StreamOptions,
};

/// What `decoy hil` runs.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HilOptions {
    /// The board (and firmware build).
    pub board: Board,
    /// Cable segments; `None`: the configuration's `solver.segments_embedded`
    /// (another count builds a firmware variant).
    pub segments: Option<usize>,
    /// A firmware ELF to boot instead of building one (`--firmware`).
    pub firmware: Option<PathBuf>,
    /// What every streamed run takes (the default output directory is
    /// `out/hil-<scenario>`; the UART is flown in lockstep only).
    pub stream: StreamOptions,
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

/// Why the firmware failed.
#[derive(Debug)]
pub enum FirmwareError {
    /// The firmware could not be built (or the ELF given is none).
    Build(BuildError),
    /// The host's f64 reference could not be built.
    Host(HostSetupError),
    /// The host reference in the firmware's precision failed.
    Reference(ReferenceError),
    /// QEMU or the link failed.
    Link(LinkError),
}

impl fmt::Display for FirmwareError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FirmwareError::Build(e) => write!(f, "{e}"),
            FirmwareError::Host(e) => write!(f, "{e}"),
            FirmwareError::Reference(e) => write!(f, "{e}"),
            FirmwareError::Link(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for FirmwareError {}

impl From<LinkError> for FirmwareError {
    fn from(e: LinkError) -> Self {
        FirmwareError::Link(e)
    }
}

impl DeviceError for FirmwareError {
    const WHO: &'static str = "the firmware";

    fn is_usage(&self) -> bool {
        matches!(
            self,
            FirmwareError::Build(BuildError::NotElf(_) | BuildError::NoSource(_))
        )
    }
}

/// Why `decoy hil` failed.
pub type HilError = StreamError<FirmwareError>;

/// Where a run's firmware comes from.
enum Origin {
    /// An ELF given with `--firmware`.
    Given(PathBuf),
    /// Built from the firmware source in this directory.
    Source(PathBuf),
}

/// The firmware under QEMU on a board, as a [`Device`] of the pipeline.
struct Firmware {
    /// The configuration with the run's segment count as its embedded one.
    config: SystemConfig,
    board: Board,
    segments: usize,
    /// The configuration's own embedded segment count (another builds a variant).
    configured: usize,
    /// `--firmware`.
    given: Option<PathBuf>,
    origin: Option<Origin>,
    /// The ELF that runs and where it came from.
    elf: PathBuf,
    source: String,
    memory: Option<MemoryUsage>,
    /// Set once the session is closed: the firmware's decoded log and the
    /// stack's marks in it.
    log: String,
    marks: Option<StackMarks>,
}

impl Firmware {
    /// The firmware given, checked to be an ELF, or the source found.
    fn origin(&self) -> Result<Origin, HilError> {
        Ok(match &self.given {
            Some(path) => {
                firmware::check_elf(path).map_err(FirmwareError::Build)?;
                Origin::Given(path.clone())
            }
            None => Origin::Source(firmware::locate_source().map_err(FirmwareError::Build)?),
        })
    }
}

impl Device for Firmware {
    type Transport = Session;
    type Error = FirmwareError;
    type Summary = HilSummary;
    const OUT_PREFIX: &'static str = "hil";
    const SERIES: &'static str = "firmware";

    fn config(&self) -> &SystemConfig {
        &self.config
    }

    fn planned_layout(&self) -> Result<(usize, f64), HilError> {
        check_segments(self.segments).map_err(StreamError::Usage)?;
        Ok((self.segments, self.config.solver.grading_ratio_embedded))
    }

    fn check(&mut self) -> Result<(), HilError> {
        self.origin = Some(self.origin()?);
        Ok(())
    }

    fn open(&mut self) -> Result<(Session, Model), HilError> {
        let board = self.board;
        let origin = match self.origin.take() {
            Some(origin) => origin,
            None => self.origin()?,
        };
        let (elf, source) = match origin {
            Origin::Given(elf) => {
                // An ELF that names its board (`firmware/build.rs`) must name this
                // one; one that names none is checked by its Hello below.
                let named = Board::of_elf(&elf).map_err(|e| StreamError::Usage(e.to_string()))?;
                if let Some(named) = named.filter(|&b| b != board) {
                    return Err(StreamError::Usage(format!(
                        "the firmware {} is built for the board {} ({named} in firmware/boards.toml), \
                         not {} (--board {})",
                        elf.display(),
                        named.hello(),
                        board.hello(),
                        board.name()
                    )));
                }
                (elf, "given with --firmware".to_owned())
            }
            Origin::Source(dir) => {
                let elf = build_firmware(board, self.segments, self.configured)
                    .map_err(FirmwareError::Build)?;
                (elf, format!("built from {}", dir.display()))
            }
        };
        self.memory = Some(firmware::memory_usage(&elf).map_err(StreamError::Output)?);
        let session = Session::start(&elf, board).map_err(FirmwareError::Link)?;
        let hello = session.hello;
        let expected = board.info().name;
        if hello.board != expected {
            return Err(StreamError::Usage(format!(
                "the firmware {} is built for the board {}, not {expected} (--board {})",
                elf.display(),
                hello.board,
                board.name()
            )));
        }
        if usize::from(hello.segments) != self.segments {
            return Err(StreamError::Usage(format!(
                "the firmware {} runs {} segments, not {}: pass --segments {}",
                elf.display(),
                hello.segments,
                self.segments,
                hello.segments
            )));
        }
        self.elf = elf;
        self.source = source;
        let model = Model {
            segments: self.segments,
            grading: self.config.solver.grading_ratio_embedded,
            precision_bits: hello.precision_bits,
        };
        Ok((session, model))
    }

    fn close(&mut self, session: Session) {
        let log = session.finish();
        self.marks = firmware::stack_marks(&log.log).ok();
        self.log = log.log;
    }

    fn replay(&self, model: &Model, messages: &[HostMessage]) -> Result<Replays, HilError> {
        let host64 = {
            let mut c = flight::accuracy_controller(&self.config).map_err(FirmwareError::Host)?;
            flight::replay(&mut c, messages)
        };
        // The firmware's precision with the target's maths: bit for bit.
        let same = Reference::for_config(&self.config, model.precision_bits)
            .and_then(|mut r| r.replay(messages))
            .map_err(FirmwareError::Reference)?;
        Ok(Replays { host64, same })
    }

    fn plot_titles(&self, name: &str) -> PlotTitles {
        let title = format!("{name} (HIL, {})", self.board);
        PlotTitles {
            comparison: title.clone(),
            management: title,
        }
    }

    fn summary(&self, flight: Flight<'_, DeviceMessage>) -> HilSummary {
        let stats = flight::instruction_stats(flight.answered);
        let memory = self.memory.unwrap_or_default();
        let marks = self.marks;
        let sent = flight.flown.sent.len();
        HilSummary {
            board: self.board.name().to_owned(),
            precision_bits: flight.model.precision_bits,
            instructions_per_step_max: stats.max,
            instructions_per_step_mean: stats.mean,
            management_instructions_max: flight
                .outputs
                .iter()
                .map(|o| o.management_instructions)
                .max()
                .unwrap_or(0),
            predictions_completed: predictions_completed(flight.outputs),
            prediction_horizon_s: flight
                .outputs
                .last()
                .map_or(0.0, |o| f64::from(o.management.prediction_horizon_s)),
            // Like with like: the State frames sent and the Outputs answering them (the
            // ResetToTrim command before them is neither).
            frames_sent: sent,
            frames_answered: flight.frames_answered(),
            frames_initialising: stats.trim_frames.saturating_sub(1),
            trim_frames: stats.trim_frames,
            trim_instructions_max: stats.trim_max,
            max_tension_diff_vs_host_n: flight.vs_host.max_tension_diff_n,
            max_tension_diff_vs_host_same_precision_n: flight.vs_same.max_tension_diff_n,
            frames_identical_to_host_same_precision: flight.vs_same.identical,
            ram_bytes: memory.ram(),
            flash_bytes: memory.flash(),
            stack_boot_bytes: marks.map(|m| m.boot),
            stack_link_bytes: marks.and_then(|m| m.link),
            ram_peak_bytes: marks.map(|m| memory.ram() + m.peak()),
            ram_budget_bytes: self.board.ram_budget(),
            link_frames_per_s: sent as f64 / flight.flown.wall.as_secs_f64().max(1e-9),
            elf: self.elf.display().to_string(),
            firmware_source: self.source.clone(),
            run: flight.run,
        }
    }

    fn write_files(&self, dir: &Path) -> Result<Vec<PathBuf>, String> {
        let path = dir.join(FIRMWARE_LOG);
        write_atomically(&path, self.log.as_bytes())
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        Ok(vec![path])
    }

    fn write_plots(&self, name: &str, rows: &[Row], dir: &Path) -> Result<Vec<PathBuf>, String> {
        instructions_plot(name, self.board, rows, dir)
    }
}

/// How many look-ahead predictions completed: the number of distinct
/// `prediction_from_s` the Outputs reported.
fn predictions_completed(outputs: &[OutputFrame]) -> usize {
    let mut count = 0;
    let mut last = -1.0;
    for o in outputs {
        let from = o.management.prediction_from_s;
        if from >= 0.0 && from != last {
            count += 1;
            last = from;
        }
    }
    count
}

/// Flies `scenario` on the firmware in QEMU (`options.board`) and on the host, and
/// writes `timeseries.csv`, `summary.json`, `firmware.log` and (with
/// `options.plots`) the plots. `progress` gets the fraction of frames done;
/// SIGINT or SIGTERM stops the flight at the next frame
/// ([`StreamError::Interrupted`]).
pub fn run_hil(
    config: &SystemConfig,
    scenario: &Scenario,
    options: &HilOptions,
    progress: impl FnMut(f64),
) -> Result<HilRun, HilError> {
    let configured = config.solver.segments_embedded;
    let segments = options.segments.unwrap_or(configured);
    let mut config = config.clone();
    config.solver.segments_embedded = segments;
    let mut device = Firmware {
        config,
        board: options.board,
        segments,
        configured,
        given: options.firmware.clone(),
        origin: None,
        elf: PathBuf::new(),
        source: String::new(),
        memory: None,
        log: String::new(),
        marks: None,
    };
    let run = run::run(scenario, &options.stream, &mut device, progress)?;
    Ok(HilRun {
        summary: run.summary,
        out_dir: run.out_dir,
        files: run.files,
        log: device.log,
    })
}
