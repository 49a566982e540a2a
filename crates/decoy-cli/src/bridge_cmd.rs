//! `decoy bridge`, `decoy bridge-layout` and `decoy feed`: the host bridge
//! (crate `host-bridge`, docs/bridge.md); the CLI parses and prints.

use std::fmt::Write as _;
use std::path::PathBuf;

use clap::{Args, ValueEnum};
use decoy_config::SystemConfig;
use decoy_hil::qemu::Board;
use decoy_sim::Scenario;
use host_bridge::affinity::{Cpus, current_list, pin_process, shown};
use host_bridge::backend::{
    BackendKind, BackendOptions, Precision, describe_backend, make_backend,
};
use host_bridge::bridge::{BridgeOptions, run_bridge};
use host_bridge::feed::{FeedError, FeedMode, FeedOptions, FeedRun, answer_timeout, run_feed};
use host_bridge::services::{check_instance, iox_config, quiet_iceoryx_log};

use crate::progress::Progress;
use crate::scenario_arg::ScenarioArg;
use crate::{Failure, usage};

/// The instance when none is named.
pub const DEFAULT_INSTANCE: &str = "default";

#[derive(Args, Debug)]
pub struct BridgeArgs {
    /// The instance's name (its services are decoy/NAME/...; 1 to 32 of A-Z a-z 0-9 _ -).
    #[arg(long, value_name = "NAME", default_value = DEFAULT_INSTANCE)]
    instance: String,
    /// host: the controller in this process; qemu: the firmware under QEMU over its UART.
    #[arg(long, value_enum, default_value_t = BackendArg::Host)]
    backend: BackendArg,
    /// The qemu backend's board (firmware/boards.toml).
    #[arg(long, value_name = "NAME", value_parser = crate::board_arg::BoardParser, default_value_t = Board::default())]
    board: Board,
    /// The host backend's precision (f32 with libm: the firmware's bits).
    #[arg(long, value_enum)]
    precision: Option<PrecisionArg>,
    /// Cable segments (default: the configuration's solver.segments_embedded; host: up to 512).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    segments: Option<usize>,
    /// Length ratio of neighbouring segments, short at the decoy (default: solver.grading_ratio_embedded; 1 = uniform).
    #[arg(long, value_name = "R", allow_negative_numbers = true)]
    grading: Option<f64>,
    /// Run on these CPUs only (Linux list format: 0, 0,2, 0-3; QEMU too). A lockstep client on the same core is fastest (docs/bridge.md, "Cores").
    #[arg(long, value_name = "LIST")]
    cpu: Option<String>,
}

#[derive(Args, Debug)]
pub struct FeedArgs {
    /// The bridge instance to feed.
    #[arg(long, value_name = "NAME", default_value = DEFAULT_INSTANCE)]
    instance: String,
    /// A shipped scenario or the path of a scenario TOML file.
    #[arg(long, value_name = "NAME|FILE", value_parser = ScenarioArg)]
    scenario: String,
    /// Flight-path rotation rate of a pull-up or turn, rad/s.
    #[arg(long, value_name = "W", allow_negative_numbers = true)]
    rate: Option<f64>,
    /// lockstep: each state waits for its answer; free: publish and collect the outputs.
    #[arg(long, value_enum, default_value_t = ModeArg::Lockstep)]
    mode: ModeArg,
    /// Send a frame every 10 ms of wall-clock time (default: flat out).
    #[arg(long)]
    realtime: bool,
    /// Simulated time, s (default: the scenario's).
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    t_end: Option<f64>,
    /// Output directory (default: out/feed-NAME).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Do not draw the plots.
    #[arg(long)]
    no_plots: bool,
    /// Deadline of each answer, s.
    #[arg(
        long,
        value_name = "S",
        default_value_t = 5.0,
        allow_negative_numbers = true
    )]
    timeout: f64,
    /// Run on these CPUs only (Linux list format: 0, 0,2, 0-3). Lockstep is fastest on the bridge's core (docs/bridge.md, "Cores").
    #[arg(long, value_name = "LIST")]
    cpu: Option<String>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum BackendArg {
    /// The controller in this process.
    Host,
    /// The firmware under QEMU.
    Qemu,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum PrecisionArg {
    /// f32.
    F32,
    /// f64.
    F64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum ModeArg {
    /// Request-response.
    Lockstep,
    /// Publish-subscribe.
    Free,
}

fn bridge_failure(e: host_bridge::BridgeError) -> Failure {
    if e.is_usage() {
        Failure::Usage(e.to_string())
    } else {
        Failure::Solver(e.to_string())
    }
}

/// `--cpu`: this process (and what it starts) on those CPUs only.
fn pin(cpu: Option<&str>) -> Result<(), Failure> {
    if let Some(text) = cpu {
        let cpus = Cpus::parse(text).map_err(bridge_failure)?;
        pin_process(&cpus).map_err(bridge_failure)?;
    }
    Ok(())
}

pub fn bridge_command(
    config: Option<SystemConfig>,
    args: &BridgeArgs,
    json: bool,
) -> Result<String, Failure> {
    check_instance(&args.instance).map_err(bridge_failure)?;
    let kind = match args.backend {
        BackendArg::Host => BackendKind::Host,
        BackendArg::Qemu => BackendKind::Qemu,
    };
    if kind == BackendKind::Qemu && config.is_some() {
        return Err(usage(
            "--config does not apply to the qemu backend: the firmware is built from config/reference-system.toml",
        ));
    }
    let config = match config {
        Some(c) => c,
        None => SystemConfig::builtin()?,
    };
    pin(args.cpu.as_deref())?;
    quiet_iceoryx_log();
    let iox = iox_config(None, None).map_err(bridge_failure)?;
    let options = BackendOptions {
        kind,
        board: args.board,
        precision: args.precision.map(|p| match p {
            PrecisionArg::F32 => Precision::F32,
            PrecisionArg::F64 => Precision::F64,
        }),
        segments: args.segments,
        grading: args.grading,
        trim_at_once: false,
    };
    if kind == BackendKind::Qemu {
        eprintln!("decoy bridge: building and booting the firmware under QEMU ...");
    }
    let backend = make_backend(&config, &options).map_err(bridge_failure)?;
    let info = backend.info().clone();
    let bridge = BridgeOptions {
        instance: args.instance.clone(),
        config: iox,
        status_line: !json,
        stop: None,
    };
    let summary = run_bridge(&bridge, backend, |_| {
        eprintln!(
            "decoy bridge: instance {} ready ({}, f{}, {} segments graded {}, CPUs {}): services decoy/{}/*; Ctrl-C to stop",
            args.instance,
            if info.backend == bridge_types::backend::QEMU {
                format!("qemu, firmware on {}", info.board)
            } else {
                "host".to_owned()
            },
            info.precision_bits,
            info.segments,
            info.grading_ratio,
            shown(&current_list()),
            args.instance
        );
    })
    .map_err(bridge_failure)?;
    if json {
        let mut text = serde_json::to_string_pretty(&summary)
            .map_err(|e| Failure::Solver(format!("cannot print the summary: {e}")))?;
        text.push('\n');
        Ok(text)
    } else {
        Ok(summary.text())
    }
}

pub fn layout_command(json: bool) -> Result<String, Failure> {
    let d = bridge_types::layouts();
    if json {
        let mut text = serde_json::to_string_pretty(&d)
            .map_err(|e| Failure::Solver(format!("cannot print the layout: {e}")))?;
        text.push('\n');
        return Ok(text);
    }
    let mut s = format!(
        "Bridge wire types, protocol version {}\n",
        d.protocol_version
    );
    for t in &d.types {
        let _ = writeln!(
            s,
            "\n{} ({}): size {}, align {}",
            t.name, t.type_name, t.size, t.align
        );
        for f in &t.fields {
            let ty = if f.count == 1 {
                f.ty.to_owned()
            } else {
                format!("[{}; {}]", f.ty, f.count)
            };
            let _ = writeln!(
                s,
                "  {:>4}  {:<34} {:<10} {:>4} B",
                f.offset, f.name, ty, f.size
            );
        }
    }
    let _ = writeln!(s, "\nServices (decoy/<instance>/<name>):");
    for sv in &d.services {
        let _ = writeln!(
            s,
            "  {:<12} {:<18} {} {}",
            sv.name,
            sv.pattern,
            sv.payload.unwrap_or(""),
            sv.response.map(|r| format!("-> {r}")).unwrap_or_default()
        );
    }
    Ok(s)
}

pub fn feed_command(config: &SystemConfig, args: &FeedArgs, json: bool) -> Result<String, Failure> {
    check_instance(&args.instance).map_err(bridge_failure)?;
    let timeout = answer_timeout(args.timeout).map_err(bridge_failure)?;
    let scenario = Scenario::load(&args.scenario)?;
    pin(args.cpu.as_deref())?;
    quiet_iceoryx_log();
    let iox = iox_config(None, None).map_err(bridge_failure)?;
    let options = FeedOptions {
        instance: args.instance.clone(),
        mode: match args.mode {
            ModeArg::Lockstep => FeedMode::Lockstep,
            ModeArg::Free => FeedMode::Free,
        },
        realtime: args.realtime,
        t_end: args.t_end,
        rate: args.rate,
        out_dir: args.out.clone(),
        plots: !args.no_plots,
        timeout,
    };
    // SIGINT and SIGTERM stop the flight at the next frame: host-bridge's
    // handlers, chained after the client node's iceoryx2 handler (which would
    // replace ones installed before it).
    let mut bar = Progress::new("feeding the bridge", json);
    let result = run_feed(config, &scenario, &options, &iox, |f| bar.update(f));
    bar.finish();
    let run = result.map_err(|e| match &e {
        FeedError::Interrupted { signal, .. } => Failure::interrupted(signal, e.to_string()),
        _ if e.is_usage() => Failure::Usage(e.to_string()),
        _ => Failure::Solver(e.to_string()),
    })?;
    if json {
        let mut text = serde_json::to_string_pretty(&run.summary)
            .map_err(|e| Failure::Solver(format!("cannot print the summary: {e}")))?;
        text.push('\n');
        return Ok(text);
    }
    Ok(feed_text(&run))
}

fn feed_text(run: &FeedRun) -> String {
    let f = &run.summary;
    let r = &f.run;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Feed `{}` through bridge {} ({}, f{}, {} segments), {}{}",
        r.scenario,
        f.instance,
        describe_backend(&f.backend, &f.board),
        f.precision_bits,
        r.segments,
        f.mode,
        if f.realtime {
            ", real time"
        } else {
            ", flat out"
        }
    );
    let _ = writeln!(
        s,
        "  {} frames sent, {} answered, {} initialising, {} rejected, {} lost; {:.0} frames/s (client on CPUs {})",
        f.frames_sent,
        f.frames_answered,
        f.frames_initialising,
        f.frames_rejected,
        f.frames_lost,
        f.frames_per_s,
        shown(&f.client_cpus)
    );
    let l = &f.latency_us;
    let _ = writeln!(
        s,
        "  round trip (us): p50 {:.1}, p99 {:.1}, p99.9 {:.1}, max {:.1}",
        l.p50, l.p99, l.p999, l.max
    );
    let _ = writeln!(
        s,
        "  connection tension max {:.3} N at t = {} s; vs the host's f64 replay: {:.3e} N; same precision: {:.3e} N ({} of {} outputs identical)",
        r.max_tension_connection_n,
        r.t_at_max_tension_s,
        f.max_tension_diff_vs_host_n,
        f.max_tension_diff_vs_host_same_precision_n,
        f.frames_identical_to_host_same_precision,
        f.frames_answered
    );
    let _ = writeln!(
        s,
        "Wrote {} files to {}",
        run.files.len(),
        run.out_dir.display()
    );
    s
}
