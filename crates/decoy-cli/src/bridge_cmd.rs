//! `decoy bridge`, `decoy bridge-layout` and `decoy feed`: the host bridge
//! (crate `host-bridge`, docs/bridge.md; its qemu backend and `decoy feed` are
//! `decoy_stream::qemu_backend` and `decoy_stream::feed`); the CLI parses and
//! prints.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use clap::{Args, ValueEnum};
use cpu_affinity::{Cpus, current_list, pin_process, shown};
use decoy_config::SystemConfig;
use decoy_hil::qemu::Board;
use decoy_sim::Scenario;
use decoy_stream::feed::{FeedOptions, FeedRun, answer_timeout, run_feed};
use decoy_stream::fly::Mode;
use decoy_stream::qemu_backend::{QemuOptions, qemu_backend};
use host_bridge::backend::{BackendOptions, Precision, describe_backend, host_backend};
use host_bridge::bridge::{BridgeOptions, run_bridge};
use host_bridge::gateway::ZenohGateway;
use host_bridge::remote::ZenohOptions;
use host_bridge::services::{check_instance, iox_config, quiet_iceoryx_log};

use crate::failure::{Failure, summary_json, usage};
use crate::progress::Progress;
use crate::stream_args::StreamArgs;

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
    #[command(flatten)]
    zenoh: BridgeZenohArgs,
}

/// `decoy bridge`'s Zenoh options (docs/bridge.md, "Across hosts").
#[derive(Args, Debug)]
struct BridgeZenohArgs {
    /// Serve across hosts over Zenoh as well, listening on ENDPOINT (tcp/127.0.0.1:7447; repeatable). Beyond loopback needs --zenoh-users or --zenoh-unauthenticated.
    #[arg(long, value_name = "ENDPOINT")]
    zenoh_listen: Vec<String>,
    /// Serve over Zenoh by connecting to ENDPOINT (a Zenoh router; repeatable). Beyond loopback needs authentication or --zenoh-unauthenticated, as --zenoh-listen.
    #[arg(long, value_name = "ENDPOINT")]
    zenoh_connect: Vec<String>,
    /// A Zenoh configuration file (JSON5: TLS, certificates, ...), read first.
    #[arg(long, value_name = "FILE")]
    zenoh_config: Option<PathBuf>,
    /// Only these users connect over Zenoh (a `user:password` per line; Zenoh's user/password authentication).
    #[arg(long, value_name = "FILE")]
    zenoh_users: Option<PathBuf>,
    /// Allow an endpoint beyond loopback (listened on or connected to) without authentication.
    #[arg(long)]
    zenoh_unauthenticated: bool,
}

impl BridgeZenohArgs {
    /// The Zenoh options, if any Zenoh option was given.
    fn options(&self) -> Option<ZenohOptions> {
        let any = !self.zenoh_listen.is_empty()
            || !self.zenoh_connect.is_empty()
            || self.zenoh_config.is_some()
            || self.zenoh_users.is_some()
            || self.zenoh_unauthenticated;
        any.then(|| ZenohOptions {
            listen: self.zenoh_listen.clone(),
            connect: self.zenoh_connect.clone(),
            config_file: self.zenoh_config.clone(),
            users_file: self.zenoh_users.clone(),
            credentials_file: None,
            unauthenticated: self.zenoh_unauthenticated,
        })
    }
}

/// `decoy feed`'s Zenoh options.
#[derive(Args, Debug)]
struct FeedZenohArgs {
    /// Feed a bridge across hosts over Zenoh: connect to ENDPOINT (the bridge's --zenoh-listen; repeatable).
    #[arg(long, value_name = "ENDPOINT")]
    zenoh_connect: Vec<String>,
    /// A Zenoh configuration file (JSON5: TLS, certificates, ...), read first.
    #[arg(long, value_name = "FILE")]
    zenoh_config: Option<PathBuf>,
    /// This client's credentials for a bridge that authenticates (one line `user:password`).
    #[arg(long, value_name = "FILE")]
    zenoh_credentials: Option<PathBuf>,
}

impl FeedZenohArgs {
    fn options(&self) -> Option<ZenohOptions> {
        let any = !self.zenoh_connect.is_empty()
            || self.zenoh_config.is_some()
            || self.zenoh_credentials.is_some();
        any.then(|| ZenohOptions {
            listen: Vec::new(),
            connect: self.zenoh_connect.clone(),
            config_file: self.zenoh_config.clone(),
            users_file: None,
            credentials_file: self.zenoh_credentials.clone(),
            unauthenticated: false,
        })
    }
}

#[derive(Args, Debug)]
pub struct FeedArgs {
    /// The bridge instance to feed.
    #[arg(long, value_name = "NAME", default_value = DEFAULT_INSTANCE)]
    instance: String,
    #[command(flatten)]
    stream: StreamArgs,
    /// lockstep: each state waits for its answer; free: publish and collect the outputs.
    #[arg(long, value_enum, default_value_t = ModeArg::Lockstep)]
    mode: ModeArg,
    /// Send a frame every 10 ms of wall-clock time (default: flat out).
    #[arg(long)]
    realtime: bool,
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
    #[command(flatten)]
    zenoh: FeedZenohArgs,
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

fn affinity_failure(e: cpu_affinity::AffinityError) -> Failure {
    if e.is_usage() {
        Failure::Usage(e.to_string())
    } else {
        Failure::Solver(e.to_string())
    }
}

/// `--cpu`: this process (and what it starts) on those CPUs only.
fn pin(cpu: Option<&str>) -> Result<(), Failure> {
    if let Some(text) = cpu {
        let cpus = Cpus::parse(text).map_err(affinity_failure)?;
        pin_process(&cpus).map_err(affinity_failure)?;
    }
    Ok(())
}

pub fn bridge_command(
    config: Option<SystemConfig>,
    args: &BridgeArgs,
    json: bool,
) -> Result<String, Failure> {
    check_instance(&args.instance).map_err(bridge_failure)?;
    let qemu = args.backend == BackendArg::Qemu;
    if qemu && config.is_some() {
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
    let precision = args.precision.map(|p| match p {
        PrecisionArg::F32 => Precision::F32,
        PrecisionArg::F64 => Precision::F64,
    });
    let backend = if qemu {
        eprintln!("decoy bridge: building and booting the firmware under QEMU ...");
        let options = QemuOptions {
            board: args.board,
            precision,
            segments: args.segments,
            grading: args.grading,
        };
        qemu_backend(&config, &options)
    } else {
        let options = BackendOptions {
            precision,
            segments: args.segments,
            grading: args.grading,
            trim_at_once: false,
        };
        host_backend(&config, &options)
    }
    .map_err(bridge_failure)?;
    // A map of another configuration is not used: the Outputs say every limit
    // is unknown; say why once.
    if let Err(stale) = config.check_limits() {
        eprintln!("warning: {stale}; the controller reports every manoeuvre limit as unknown (-1)");
    }
    let info = backend.info().clone();
    let zenoh = args.zenoh.options();
    if let Some(z) = &zenoh {
        // Bad Zenoh options are refused before the backend runs a frame.
        host_bridge::remote::check_bridge_options(z).map_err(bridge_failure)?;
    }
    // Set when the Zenoh gateway cannot start: the bridge stops at its next tick.
    let stop = Arc::new(AtomicBool::new(false));
    let bridge = BridgeOptions {
        instance: args.instance.clone(),
        config: iox.clone(),
        status_line: !json,
        stop: Some(Arc::clone(&stop)),
    };
    let mut gateway: Option<Result<ZenohGateway, host_bridge::BridgeError>> = None;
    let result = run_bridge(&bridge, backend, |_| {
        let across = match &zenoh {
            Some(z) => match ZenohGateway::start(&args.instance, &iox, z) {
                Ok(g) => {
                    let text = format!("; over Zenoh too ({})", g.describe());
                    gateway = Some(Ok(g));
                    text
                }
                Err(e) => {
                    gateway = Some(Err(e));
                    stop.store(true, Ordering::Relaxed);
                    return;
                }
            },
            None => String::new(),
        };
        eprintln!(
            "decoy bridge: instance {} ready ({}, f{}, {} segments graded {}, CPUs {}): services decoy/{}/*{across}; Ctrl-C to stop",
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
    });
    let zenoh_summary = match gateway {
        Some(Ok(g)) => Some(g.stop().map_err(bridge_failure)?),
        Some(Err(e)) => return Err(bridge_failure(e)),
        None => None,
    };
    let mut summary = result.map_err(bridge_failure)?;
    summary.zenoh = zenoh_summary;
    if json {
        summary_json(&summary)
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
    let scenario = Scenario::load(&args.stream.scenario)?;
    pin(args.cpu.as_deref())?;
    quiet_iceoryx_log();
    let iox = iox_config(None, None).map_err(bridge_failure)?;
    let mode = match args.mode {
        ModeArg::Lockstep => Mode::Lockstep,
        ModeArg::Free => Mode::Free,
    };
    let zenoh = args.zenoh.options();
    if let Some(z) = &zenoh {
        host_bridge::remote::check_client_options(z).map_err(bridge_failure)?;
    }
    let options = FeedOptions {
        instance: args.instance.clone(),
        timeout,
        zenoh,
        stream: args.stream.options(mode, args.realtime),
    };
    // SIGINT and SIGTERM stop the flight at the next frame: the pipeline's
    // handlers (`decoy_stream::signals`), chained after the client node's
    // iceoryx2 handler (which would replace ones installed before it).
    let mut bar = Progress::new("feeding the bridge", json);
    let result = run_feed(config, &scenario, &options, &iox, |f| bar.update(f));
    bar.finish();
    let run = result?;
    if json {
        return summary_json(&run.summary);
    }
    Ok(feed_text(&run))
}

fn feed_text(run: &FeedRun) -> String {
    let f = &run.summary;
    let r = &f.run;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Feed `{}` through bridge {}{} ({}, f{}, {} segments), {}{}",
        r.scenario,
        f.instance,
        if f.transport == "zenoh" {
            " over Zenoh"
        } else {
            ""
        },
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
