//! `decoy`: the towed-decoy solver on the command line.
//!
//! - `decoy simulate`: the main job. Flies a scenario (steady flight, the paper's
//!   acceleration, pull-up and turn, or a recorded flight) and writes the time
//!   series, cable snapshots, a summary and plots (`decoy-sim`, `docs/outputs.md`).
//! - `decoy pendulum`: the compound multi-pendulum validation case (docs/design.md §7.1),
//!   integrated with the O(N) tension recurrence or the dense mass-matrix reference,
//!   sampled at chosen times.
//! - `decoy trim`: the steady level-flight equilibrium of the configured towed
//!   system (docs/design.md §5): decoy pitch and position, cable tension profile.
//! - `decoy sweep speed|altitude|tow-point|cg`: the paper's steady-flight and
//!   decoy-station studies (Figs. 15-24), tables and plots.
//! - `decoy study discretisation`: the segment-count study (Figs. 13-14) and the
//!   choice of the embedded model.
//! - `decoy report`: regenerates `docs/paper-reproduction.md` and its figures.
//! - `decoy hil`: flies a scenario on the decoy controller firmware under QEMU,
//!   frame by frame over the decoy link, beside the host's solution
//!   (`decoy_stream::hil`).
//! - `decoy bridge`, `decoy bridge-layout`, `decoy feed`: the host bridge over
//!   iceoryx2 (`host_bridge`, docs/bridge.md; `decoy feed` is
//!   `decoy_stream::feed`).
//!
//! Human-readable output by default, `--json` for machines. Errors are one line
//! `error: ...` on stderr; the exit code is 2 for usage and configuration errors,
//! 1 when the solver fails, and 130 or 143 when SIGINT or SIGTERM stopped
//! `decoy simulate`, `decoy hil` or `decoy feed` (which then write what they
//! flew; a second signal ends them at once: `decoy_stream::signals`).

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

mod board_arg;
mod bridge_cmd;
mod envelope_cmd;
mod failure;
mod progress;
mod scenario_arg;
mod stream_args;
mod studies;

use clap::{Args, Parser, Subcommand, ValueEnum};
use decoy_config::SystemConfig;
use decoy_hil::qemu::Board;
use decoy_sim::pendulum::{
    PendulumError, PendulumMethod, PendulumReport, PendulumRequest, run_pendulum,
};
use decoy_sim::trim::{LevelTrim, TrimRequest, level_trim};
use decoy_sim::{InitialState, RunOptions, RunOutput, Scenario, describe_layout};
use decoy_stream::fly::Mode;
use decoy_stream::hil::{HilOptions, HilRun, run_hil};
use decoy_stream::signals::Interrupts;
use failure::{Failure, summary_json, to_json, usage};
use progress::Progress;
use scenario_arg::ScenarioArg;
use solver_core::pendulum::{GRAVITY, ROD_LENGTH, ROD_MASS};
use stream_args::StreamArgs;

/// Stack of the worker thread (the fixed-capacity solver types are large values).
const WORKER_STACK_BYTES: usize = 64 << 20;

#[derive(Parser, Debug)]
#[command(
    name = "decoy",
    version,
    about = "Towed-decoy cable dynamics: flight simulations, pendulum validation runs and steady-flight trim"
)]
struct Cli {
    /// System configuration TOML (default: the built-in reference system).
    #[arg(long, global = true, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Print machine-readable JSON instead of the human-readable report.
    #[arg(long, global = true)]
    json: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Fly a scenario and write timeseries.csv, cable.csv, summary.json and plots.
    Simulate(SimulateArgs),
    /// Compound multi-pendulum (N rods of 0.1 m and 0.5 kg hinged at a fixed point,
    /// released at rest from -60 deg), sampled at the given times.
    Pendulum(PendulumArgs),
    /// Steady level-flight trim of the configured towed system.
    Trim(TrimArgs),
    /// Sweep a flight condition or a decoy station (the paper's Figs. 15-24):
    /// a table (CSV, printed, or JSON) and plots.
    Sweep(studies::SweepArgs),
    /// The manoeuvre envelope map: for each altitude x Mach, the largest pull-up
    /// or turn rate that violates no requirement, and what limits it.
    Envelope(envelope_cmd::EnvelopeArgs),
    /// Write the envelope map the onboard controller carries
    /// (config/reference-system.limits.toml) from `decoy envelope`'s maps of
    /// this configuration.
    LimitsTable(envelope_cmd::LimitsTableArgs),
    /// A study: `discretisation` (the paper's Figs. 13-14) and the embedded
    /// model's choice.
    Study(studies::StudyArgs),
    /// Regenerate the paper reproduction report (docs/paper-reproduction.md and
    /// its figures).
    Report(studies::ReportArgs),
    /// Fly a scenario on the controller firmware under QEMU (hardware in the loop,
    /// 10 ms frames over the UART) beside the host's solution: timeseries.csv,
    /// summary.json, firmware.log and plots.
    Hil(HilArgs),
    /// Serve the decoy controller (in process, or the firmware under QEMU) to
    /// avionics simulations over iceoryx2 shared memory until Ctrl-C
    /// (docs/bridge.md); prints its counters at exit.
    Bridge(bridge_cmd::BridgeArgs),
    /// Print the bridge's wire types (size, alignment, every field's offset and
    /// type), its services and codes: the reference of a mirror in another language.
    BridgeLayout,
    /// Fly a scenario through a running bridge (lockstep or free-running) and
    /// write timeseries.csv, summary.json and plots as `decoy hil` does.
    Feed(bridge_cmd::FeedArgs),
}

#[derive(Args, Debug)]
struct HilArgs {
    #[command(flatten)]
    stream: StreamArgs,
    /// The board (firmware/boards.toml).
    #[arg(long, value_name = "NAME", value_parser = board_arg::BoardParser, default_value_t = Board::default())]
    board: Board,
    /// Cable segments (default: the configuration's solver.segments_embedded; another count builds a firmware variant).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    segments: Option<usize>,
    /// Boot this firmware ELF instead of building one (default: build the firmware
    /// of the checkout this `decoy` was built from, or of $DECOY_SOURCE_DIR).
    #[arg(long, value_name = "ELF")]
    firmware: Option<PathBuf>,
}

#[derive(Args, Debug)]
struct PendulumArgs {
    /// Number of rods.
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    segments: usize,
    /// End of the simulated interval, s.
    #[arg(long, value_name = "T", allow_negative_numbers = true)]
    t_end: f64,
    /// RK4 time step, s.
    #[arg(long, value_name = "DT", allow_negative_numbers = true)]
    dt: f64,
    /// Sample times, s, comma separated; each a whole number of time steps, at most --t-end.
    #[arg(long, value_name = "t1,t2,...", value_delimiter = ',', num_args = 1.., required = true, allow_negative_numbers = true)]
    times: Vec<f64>,
    /// Which dynamics to integrate.
    #[arg(long, value_enum, default_value_t = Method::Recurrence)]
    solver: Method,
}

#[derive(Args, Debug)]
struct TrimArgs {
    /// Aircraft altitude, m (0 to 20000).
    #[arg(long, value_name = "H", allow_negative_numbers = true)]
    altitude: f64,
    /// Aircraft Mach number (above 0, at most 2).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    mach: f64,
    /// Number of cable segments (default: the configuration's solver.segments_host).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    segments: Option<usize>,
    /// Grade the segments geometrically by this length ratio, short at the decoy (1 = uniform).
    #[arg(long, value_name = "R", allow_negative_numbers = true)]
    grading: Option<f64>,
}

#[derive(Args, Debug)]
struct SimulateArgs {
    /// A shipped scenario or the path of a scenario TOML file.
    #[arg(long, value_name = "NAME|FILE", value_parser = ScenarioArg)]
    scenario: String,
    /// Number of cable segments (default: the scenario's, else the configuration's solver.segments_host).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    segments: Option<usize>,
    /// Grade the segments geometrically by this length ratio, short at the decoy (1 = uniform).
    #[arg(long, value_name = "R", allow_negative_numbers = true)]
    grading: Option<f64>,
    /// A fixed RK4 time step, s (default: the scenario's `dt_s`, else the adaptive step rule of docs/outputs.md, "Time steps").
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    dt: Option<f64>,
    /// Simulated time, s.
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    t_end: Option<f64>,
    /// Initial altitude, m (0 to 20000).
    #[arg(long, value_name = "H", allow_negative_numbers = true)]
    altitude: Option<f64>,
    /// Initial Mach number (above 0, at most 2).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    mach: Option<f64>,
    /// Flight-path rotation rate of a pull-up or turn, rad/s (the paper's: 0.05, 0.10, 0.20).
    #[arg(long, value_name = "W", allow_negative_numbers = true)]
    rate: Option<f64>,
    /// Time over which a pull-up or turn builds its rate (and a pull-up removes
    /// it), s: a flyable entry at a finite angular acceleration (about 0.5 s for
    /// a fighter). Default: the scenario's `onset_s`, else 0, the paper's step.
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    onset: Option<f64>,
    /// Initial state: the trim of the flight condition at t = 0, or a straight cable.
    #[arg(long, value_enum, default_value_t = Initial::Trim)]
    initial: Initial,
    /// Output directory (default: out/NAME, NAME the scenario's name).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Do not draw the plots (CSV and JSON only).
    #[arg(long)]
    no_plots: bool,
}

/// How `decoy simulate` starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Initial {
    /// The steady equilibrium of the flight condition at t = 0.
    Trim,
    /// Every segment trailing straight behind the connection point, the decoy along the flight direction.
    Straight,
}

/// The dynamics `decoy pendulum` integrates.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Method {
    /// The O(N) two-sweep tension recurrence (the solver).
    Recurrence,
    /// The dense mass-matrix (Kane) reference, O(N^3) per evaluation.
    Dense,
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) {
                e.exit();
            }
            // clap's report spans several lines (message, tips, usage): keep the message's paragraph.
            let rendered = e.render().to_string();
            let paragraph = rendered
                .trim_start()
                .split("\n\n")
                .next()
                .unwrap_or_default();
            let words: Vec<&str> = paragraph.split_whitespace().collect();
            let message = words.join(" ");
            let message = message.strip_prefix("error:").unwrap_or(&message).trim();
            eprintln!("error: {message} (see `decoy --help`)");
            return ExitCode::from(2);
        }
    };
    let worker = std::thread::Builder::new()
        .name("decoy".into())
        .stack_size(WORKER_STACK_BYTES)
        .spawn(move || run(&cli));
    let result = match worker {
        Ok(handle) => handle.join().unwrap_or_else(|_| {
            Err(Failure::Solver(
                "internal error: the solver panicked".into(),
            ))
        }),
        Err(e) => Err(Failure::Solver(format!(
            "cannot start the worker thread: {e}"
        ))),
    };
    match result {
        Ok(text) => {
            let mut out = std::io::stdout().lock();
            // A closed pipe (e.g. `| head`) is not an error of the command.
            let _ = out.write_all(text.as_bytes()).and_then(|()| out.flush());
            ExitCode::SUCCESS
        }
        Err(failure) => {
            eprintln!("error: {}", failure.message().replace('\n', " "));
            ExitCode::from(failure.exit_code())
        }
    }
}

fn run(cli: &Cli) -> Result<String, Failure> {
    // An explicitly named configuration is loaded (and so checked) whatever the
    // command; the map's own commands never fail on its envelope map on
    // board, which they make (a stale map must not stop them): `decoy
    // limits-table` does not read it, `decoy envelope` uses it only when it
    // was made for the configuration (the controller flown beside its runs
    // then advises with it, as the firmware's does).
    let config = match &cli.config {
        Some(path) if matches!(cli.command, Command::Envelope(_)) => {
            Some(SystemConfig::from_file_for_mapping(path)?)
        }
        Some(path) if matches!(cli.command, Command::LimitsTable(_)) => {
            Some(SystemConfig::from_file_unmapped(path)?)
        }
        Some(path) => Some(SystemConfig::from_file(path)?),
        None => None,
    };
    match &cli.command {
        Command::Simulate(args) => {
            let config = match config {
                Some(c) => c,
                None => SystemConfig::builtin()?,
            };
            simulate_command(&config, args, cli.json)
        }
        Command::Pendulum(args) => pendulum(args, cli.json),
        Command::Trim(args) => {
            let config = match config {
                Some(c) => c,
                None => SystemConfig::builtin()?,
            };
            trim_command(&config, args, cli.json)
        }
        Command::Sweep(args) => {
            let config = match config {
                Some(c) => c,
                None => SystemConfig::builtin()?,
            };
            studies::sweep_command(&config, args, cli.json)
        }
        Command::Envelope(args) => {
            let config = match config {
                Some(c) => c,
                None => SystemConfig::builtin_for_mapping()?,
            };
            envelope_cmd::envelope_command(&config, args, cli.json)
        }
        Command::LimitsTable(args) => {
            let config = match config {
                Some(c) => c,
                None => SystemConfig::builtin_unmapped()?,
            };
            envelope_cmd::limits_table_command(&config, args, cli.json, cli.config.is_some())
        }
        Command::Study(args) => {
            let config = match config {
                Some(c) => c,
                None => SystemConfig::builtin()?,
            };
            studies::study_command(&config, args, cli.json)
        }
        Command::Hil(args) => {
            if cli.config.is_some() {
                return Err(usage(
                    "--config does not apply to `decoy hil`: the firmware is built from config/reference-system.toml",
                ));
            }
            hil_command(&SystemConfig::builtin()?, args, cli.json)
        }
        Command::Bridge(args) => bridge_cmd::bridge_command(config, args, cli.json),
        Command::BridgeLayout => bridge_cmd::layout_command(cli.json),
        Command::Feed(args) => {
            let config = match config {
                Some(c) => c,
                None => SystemConfig::builtin()?,
            };
            bridge_cmd::feed_command(&config, args, cli.json)
        }
        Command::Report(args) => {
            let config = match config {
                Some(c) => c,
                None => SystemConfig::builtin()?,
            };
            studies::report_command(&config, args, cli.config.as_deref(), cli.json)
        }
    }
}

// ---------------------------------------------------------------- simulate

fn simulate_command(
    config: &SystemConfig,
    args: &SimulateArgs,
    json: bool,
) -> Result<String, Failure> {
    let scenario = Scenario::load(&args.scenario)?;
    let options = RunOptions {
        segments: args.segments,
        grading: args.grading,
        dt: args.dt,
        t_end: args.t_end,
        altitude: args.altitude,
        mach: args.mach,
        rate: args.rate,
        onset: args.onset,
        initial: match args.initial {
            Initial::Trim => InitialState::Trim,
            Initial::Straight => InitialState::Straight,
        },
        out_dir: args.out.clone(),
        plots: !args.no_plots,
    };
    // SIGINT and SIGTERM stop the run at a step boundary (`decoy_stream::signals`).
    let interrupts = Interrupts::install()
        .map_err(|e| Failure::Solver(format!("cannot install the SIGINT/SIGTERM handlers: {e}")))?;
    let mut bar = Progress::new("simulating", json);
    let result = decoy_sim::simulate_until(
        config,
        &scenario,
        &options,
        |f| bar.update(f),
        || interrupts.received(),
    );
    bar.finish();
    let run = result?;
    if let Some(signal) = interrupts.received() {
        // After the last step: the run and its files are complete.
        return Err(Failure::interrupted(
            signal,
            format!(
                "interrupted by {signal} after the last step; the outputs in {} are complete",
                run.out_dir.display()
            ),
        ));
    }
    if json {
        return summary_json(&run.summary);
    }
    Ok(simulate_text(config, &scenario, &run, args))
}

fn simulate_text(
    config: &SystemConfig,
    scenario: &Scenario,
    run: &RunOutput,
    args: &SimulateArgs,
) -> String {
    let r = &run.summary;
    let f = &r.final_values;
    let allowable = config.cable.allowable_tension;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Simulation `{}` ({}, {})",
        r.scenario,
        scenario.origin.describe(),
        config.source
    );
    // The scenario's description states its flight condition and duration: it
    // is shown only when no flag changed them.
    let overridden = args.altitude.is_some()
        || args.mach.is_some()
        || args.rate.is_some()
        || args.t_end.is_some();
    if !scenario.description.is_empty() && !overridden {
        let _ = writeln!(s, "  {}", scenario.description);
    }
    let _ = writeln!(
        s,
        "  initial flight condition: {}",
        run.plan.describe_initial_condition(config)
    );
    let initial = match args.initial {
        Initial::Trim => "trim",
        Initial::Straight => "straight cable",
    };
    let steps = match (&r.steps, r.dt) {
        (Some(st), Some(dt)) => format!("{} RK4 steps of {dt} s (fixed)", st.count),
        (Some(st), None) => format!(
            "{} RK4 steps of {:.3} to {:.3} ms (adaptive)",
            st.count,
            st.min_s * 1000.0,
            st.max_s * 1000.0
        ),
        (None, dt) => format!("RK4 dt = {} s", dt.unwrap_or(f64::NAN)),
    };
    let _ = writeln!(
        s,
        "  {}, {steps}, {} s simulated, initial state: {initial}",
        describe_layout(&run.plan.layout),
        r.t_end
    );
    let _ = writeln!(s, "Connection-point tension");
    let _ = writeln!(
        s,
        "  maximum                       {:>10.3} N at t = {} s ({:.1} % of the {allowable} N allowable)",
        r.max_tension_connection_n,
        r.t_at_max_tension_s,
        100.0 * r.max_tension_connection_n / allowable
    );
    let _ = writeln!(
        s,
        "  final                         {:>10.3} N",
        f.tension_connection_n
    );
    let settling = match r.settling_time_s {
        Some(t) => format!("from t = {t} s"),
        None => "not settled by the end of the run".to_owned(),
    };
    let _ = writeln!(s, "  within 2 % of its final value {settling}");
    let _ = writeln!(
        s,
        "Towing-point tension, final     {:>10.3} N",
        f.tension_tow_n
    );
    let _ = writeln!(s, "Decoy");
    let _ = writeln!(
        s,
        "  pitch oscillation amplitude   {:>10.3} deg (half peak-to-peak from the manoeuvre start)",
        r.pitch_oscillation_amplitude_deg
    );
    let _ = writeln!(
        s,
        "  final pitch                   {:>10.3} deg",
        f.decoy_pitch_deg
    );
    let _ = writeln!(
        s,
        "  final CG behind the aircraft  {:>10.3} m",
        f.decoy_cg_behind_m
    );
    let _ = writeln!(
        s,
        "  final CG below the flight path{:>10.3} m",
        f.decoy_cg_below_m
    );
    let _ = writeln!(
        s,
        "  final CG lateral              {:>10.3} m (positive toward the outside of the turn / left)",
        f.decoy_cg_lateral_m
    );
    let _ = writeln!(s, "Clearances (smallest over the run)");
    let inside = if r.min_cable_clearance_to_exhaust_m < 0.0 {
        " (inside the plume)"
    } else {
        ""
    };
    let _ = writeln!(
        s,
        "  cable to the exhaust plume    {:>10.3} m{inside}",
        r.min_cable_clearance_to_exhaust_m
    );
    let _ = writeln!(
        s,
        "  decoy CG to the aircraft      {:>10.3} m",
        r.min_decoy_clearance_to_aircraft_m
    );
    write_management(&mut s, &r.management);
    let speed = if r.wall_s > 0.0 {
        format!(" ({:.0}x real time)", r.t_end / r.wall_s)
    } else {
        String::new()
    };
    let _ = writeln!(s, "Wall time {:.3} s{speed}", r.wall_s);
    let _ = writeln!(s, "Files written to {}:", run.out_dir.display());
    for file in &run.files {
        let name = file.file_name().map_or_else(
            || file.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        let _ = writeln!(s, "  {name}");
    }
    s
}

/// The decoy-management block of a human summary: per requirement the worst
/// margin, the first violation, the first look-ahead advisory and its lead.
fn write_management(s: &mut String, m: &decoy_sim::ManagementSummary) {
    let _ = writeln!(
        s,
        "Decoy management (worst margin; first violation; first advisory; lead)"
    );
    for (requirement, r) in m.requirements.iter() {
        let (name, unit) = (requirement.name(), requirement.file_unit());
        let time = |t: Option<f64>| t.map_or_else(|| "none".to_owned(), |t| format!("t = {t} s"));
        let worst = r
            .worst_margin
            .map_or_else(|| "unknown".to_owned(), |w| format!("{w:>10.3} {unit}"));
        let lead = match (r.advisory_lead_s, r.first_violation_s, r.first_advisory_s) {
            (Some(l), _, _) if l >= 0.0 => format!("advised {l} s before"),
            (Some(l), _, _) => format!("advised {} s AFTER the violation", -l),
            (None, Some(_), None) => "NOT advised".to_owned(),
            (None, None, Some(_)) => "advisory, no violation".to_owned(),
            _ => "-".to_owned(),
        };
        let _ = writeln!(
            s,
            "  {name:<10} {worst:>14}; violated {}; advisory {}; {lead}",
            time(r.first_violation_s),
            time(r.first_advisory_s)
        );
    }
}

// ---------------------------------------------------------------- hil

fn hil_command(config: &SystemConfig, args: &HilArgs, json: bool) -> Result<String, Failure> {
    let scenario = Scenario::load(&args.stream.scenario)?;
    let options = HilOptions {
        board: args.board,
        segments: args.segments,
        firmware: args.firmware.clone(),
        stream: args.stream.options(Mode::Lockstep, false),
    };
    // SIGINT and SIGTERM stop the flight at the next frame (the pipeline's
    // handlers, `decoy_stream::signals`).
    let mut bar = Progress::new("flying on the firmware", json);
    let result = run_hil(config, &scenario, &options, |f| bar.update(f));
    bar.finish();
    let run = result?;
    if json {
        return summary_json(&run.summary);
    }
    Ok(hil_text(config, &run))
}

fn hil_text(config: &SystemConfig, run: &HilRun) -> String {
    let h = &run.summary;
    let r = &h.run;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Hardware in the loop `{}` on the {} ({}-bit floats, {} segments), QEMU -icount",
        r.scenario, h.board, h.precision_bits, r.segments
    );
    let _ = writeln!(s, "  firmware {} ({})", h.elf, h.firmware_source);
    let _ = writeln!(
        s,
        "  {} frames sent, {} answered with an output, {} by the initialisation's Status, {:.0} round trips/s over the UART",
        h.frames_sent, h.frames_answered, h.frames_initialising, h.link_frames_per_s
    );
    let _ = writeln!(
        s,
        "Instructions per 10 ms control step  max {}, mean {:.0}; the trim over {} frame(s), at most {} in one",
        h.instructions_per_step_max,
        h.instructions_per_step_mean,
        h.trim_frames,
        h.trim_instructions_max
    );
    let _ = writeln!(
        s,
        "Connection-point tension             maximum {:.3} N at t = {} s ({:.1} % of the {} N allowable), final {:.3} N",
        r.max_tension_connection_n,
        r.t_at_max_tension_s,
        100.0 * r.max_tension_connection_n / config.cable.allowable_tension,
        config.cable.allowable_tension,
        r.final_values.tension_connection_n
    );
    let _ = writeln!(
        s,
        "Against the host                     max tension difference {:.4} N (f64), {:.4} N (same precision; {} of {} outputs identical)",
        h.max_tension_diff_vs_host_n,
        h.max_tension_diff_vs_host_same_precision_n,
        h.frames_identical_to_host_same_precision,
        h.frames_answered
    );
    let _ = writeln!(
        s,
        "Firmware                             flash {} B, static RAM {} B ({})",
        h.flash_bytes, h.ram_bytes, h.elf
    );
    let bytes = |b: Option<u64>| b.map_or_else(|| "not logged".to_owned(), |b| format!("{b} B"));
    let _ = writeln!(
        s,
        "Stack and RAM                        stack peak at boot {}, in the link loop {}; RAM peak {} of the board's {} B",
        bytes(h.stack_boot_bytes),
        bytes(h.stack_link_bytes),
        bytes(h.ram_peak_bytes),
        h.ram_budget_bytes
    );
    let _ = writeln!(
        s,
        "Decoy management                     max {} instructions per frame (monitors and look-ahead slice), {} predictions completed, horizon {} s",
        h.management_instructions_max, h.predictions_completed, h.prediction_horizon_s
    );
    write_management(&mut s, &r.management);
    let _ = writeln!(s, "Files written to {}:", run.out_dir.display());
    for file in &run.files {
        let name = file.file_name().map_or_else(
            || file.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        let _ = writeln!(s, "  {name}");
    }
    s
}

// ---------------------------------------------------------------- pendulum

fn pendulum(args: &PendulumArgs, json: bool) -> Result<String, Failure> {
    let request = PendulumRequest {
        segments: args.segments,
        t_end: args.t_end,
        dt: args.dt,
        times: args.times.clone(),
        method: match args.solver {
            Method::Recurrence => PendulumMethod::Recurrence,
            Method::Dense => PendulumMethod::Dense,
        },
    };
    let report = run_pendulum(&request).map_err(|e| match e {
        PendulumError::Usage(m) => Failure::Usage(m),
        PendulumError::Solver(m) => Failure::Solver(m),
    })?;
    if json {
        return Ok(to_json(&report));
    }
    Ok(pendulum_text(&report, args.solver))
}

fn pendulum_text(report: &PendulumReport, method: Method) -> String {
    let mut s = String::new();
    let method = match method {
        Method::Recurrence => "O(N) tension recurrence",
        Method::Dense => "dense mass-matrix reference",
    };
    let _ = writeln!(
        s,
        "Compound pendulum: {} rods of {ROD_LENGTH} m and {ROD_MASS} kg, g = {GRAVITY} m/s^2, {method}, RK4 dt = {} s",
        report.segments, report.dt
    );
    let _ = writeln!(
        s,
        "Frame: hinge at the origin, x horizontal, z up; released at rest, rods 60 deg toward -x."
    );
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "{:>12}  {:>13}  {:>13}  {:>19}  {:>17}",
        "t [s]", "tip x [m]", "tip z [m]", "support tension [N]", "energy [J]"
    );
    for p in &report.samples {
        let _ = writeln!(
            s,
            "{:>12}  {:>13.9}  {:>13.9}  {:>19.9}  {:>17.12}",
            p.t, p.tip[0], p.tip[1], p.support_tension_n, p.energy_j
        );
    }
    let earliest = report.samples.iter().min_by(|a, b| a.t.total_cmp(&b.t));
    if let (Some(first), true) = (earliest, report.samples.len() > 1) {
        let scale = first.energy_j.abs().max(f64::MIN_POSITIVE);
        let drift = report
            .samples
            .iter()
            .map(|p| (p.energy_j - first.energy_j).abs())
            .fold(0.0, f64::max)
            / scale;
        let _ = writeln!(
            s,
            "\nLargest energy change relative to t = {} s: {drift:.3e} (relative)",
            first.t
        );
    }
    s
}

// ---------------------------------------------------------------- trim

fn trim_command(config: &SystemConfig, args: &TrimArgs, json: bool) -> Result<String, Failure> {
    let request = TrimRequest {
        altitude: args.altitude,
        mach: args.mach,
        segments: args.segments,
        grading: args.grading,
    };
    let trim = level_trim(config, &request)?;
    if json {
        return Ok(to_json(&trim.report()));
    }
    Ok(trim_text(config, &trim))
}

fn trim_text(config: &SystemConfig, trim: &LevelTrim) -> String {
    let mut s = String::new();
    let r = trim.report();
    let point = &trim.point;
    let n = point.cable.len() - 1;
    let layout = describe_layout(&trim.layout);
    let allowable = config.cable.allowable_tension;
    let _ = writeln!(s, "Steady level-flight trim ({})", config.source);
    let _ = writeln!(
        s,
        "  altitude                      {:>10.1} m",
        point.altitude_m
    );
    let _ = writeln!(
        s,
        "  Mach                          {:>10.3}   ({:.2} m/s true airspeed)",
        point.mach, point.speed_mps
    );
    let _ = writeln!(
        s,
        "  cable                         {:>10.1} m in {layout}",
        config.cable.length
    );
    let _ = writeln!(s, "Decoy");
    let attitude = if r.decoy_pitch_deg >= 0.0 {
        "nose up"
    } else {
        "nose down"
    };
    let _ = writeln!(
        s,
        "  pitch                         {:>10.3} deg ({attitude})",
        r.decoy_pitch_deg
    );
    let _ = writeln!(
        s,
        "  CG behind connection point    {:>10.3} m",
        r.decoy_cg_behind_connection_m
    );
    let _ = writeln!(
        s,
        "  CG below connection point     {:>10.3} m",
        r.decoy_cg_below_connection_m
    );
    let _ = writeln!(s, "Cable tension");
    let _ = writeln!(
        s,
        "  at the connection point       {:>10.3} N   ({:.1} % of the {allowable} N allowable)",
        r.tension_connection_n,
        100.0 * r.tension_connection_n / allowable
    );
    let _ = writeln!(
        s,
        "  at the towing point           {:>10.3} N",
        r.tension_tow_n
    );
    let profile = &r.tension_profile_n;
    let (jmin, tmin) = extreme(profile, |a, b| a < b);
    let (jmax, tmax) = extreme(profile, |a, b| a > b);
    let _ = writeln!(
        s,
        "  minimum                       {:>10.3} N   (joint {jmin})",
        tmin
    );
    let _ = writeln!(
        s,
        "  maximum                       {:>10.3} N   (joint {jmax})",
        tmax
    );
    let _ = writeln!(
        s,
        "Tension profile (joint 0 = connection point, joint {n} = towing point)"
    );
    let _ = writeln!(
        s,
        "  {:>7}  {:>16}  {:>12}",
        "joint", "along cable [m]", "tension [N]"
    );
    let mut joints: Vec<usize> = (0..=4).map(|k| (k * n + 2) / 4).collect();
    joints.dedup();
    for j in joints {
        let along = point.cable[j].along_m;
        let _ = writeln!(s, "  {j:>7}  {along:>16.3}  {:>12.3}", profile[j]);
    }
    s
}

/// Index and value of the entry that wins `better` (the first one on ties).
fn extreme(values: &[f64], better: impl Fn(f64, f64) -> bool) -> (usize, f64) {
    values
        .iter()
        .copied()
        .enumerate()
        .fold((0, values[0]), |best, (j, v)| {
            if better(v, best.1) { (j, v) } else { best }
        })
}
