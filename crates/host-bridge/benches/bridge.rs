//! The bridge's benchmark (`cargo bench -p host-bridge --bench bridge`; the
//! numbers go to docs/benchmarks.md, section "Host bridge"). In one run, each
//! server a separate process (this binary re-run with `--serve`) in an iceoryx2
//! setup of its own, the client here, every round trip timed:
//!
//! 1. iceoryx2's own request-response with an empty handler (the same payload
//!    types and the same event wake-up as the bridge, the answer a zero `Answer`);
//! 2. the bridge's lockstep round trip, host backend, the configuration's embedded
//!    model (12 segments graded 1.26 for the reference system) in f32;
//! 3. the same, 300 uniform segments f64;
//! 4. the same, qemu backend (the M4 firmware under QEMU);
//!
//! p50/p99/p99.9/max, frames per second flat out, the solver's own time per frame
//! (the host controller in this process on the same frames), samples lost, and
//! the server process's CPU at 100 Hz (a real-time paced client, 10 s).
//!
//! Then 1 and 2 again with the client and the server on one core
//! (`BRIDGE_BENCH_CPU`, default 0; what `decoy bridge --cpu` and `decoy feed
//! --cpu` do): each hand-off a context switch instead of the wake-up of an idle
//! core (docs/bridge.md, "Cores").
//! `BRIDGE_BENCH_FRAMES` scales the flat-out runs (default 20,000).

use std::process::{Child, Command};
use std::time::{Duration, Instant};

use bridge_local::Isolated;
use bridge_types::{AircraftState, Answer, event};
use cpu_affinity::{Cpus, pin_process};
use decoy_config::SystemConfig;
use decoy_hil::flight::scenario_frames;
use decoy_link::AircraftStateFrame;
use decoy_stream::qemu_backend::{QemuOptions, qemu_backend};
use host_bridge::backend::{Backend, BackendOptions, Precision, host_backend};
use host_bridge::bridge::{BridgeOptions, run_bridge};
use host_bridge::client::BridgeClient;
use host_bridge::convert::from_link_frame;
use host_bridge::services::{
    Ipc, Services, create_status_service, iox_config, node, quiet_iceoryx_log,
};
use host_bridge::timing::Percentiles;
use iceoryx2::prelude::*;
use solver_core::profiles::LevelTurn;

const INSTANCE: &str = "bench";

fn main() {
    quiet_iceoryx_log();
    let args: Vec<String> = std::env::args().collect();
    if let Some(i) = args.iter().position(|a| a == "--serve") {
        if let Some(j) = args.iter().position(|a| a == "--cpu") {
            pin_process(&Cpus::parse(&args[j + 1]).unwrap()).unwrap();
        }
        serve(&args[i + 1]);
        return;
    }
    if args.iter().any(|a| a == "--list") {
        return;
    }
    let frames: usize = std::env::var("BRIDGE_BENCH_FRAMES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(20_000);
    println!(
        "| run | frames | p50 us | p99 us | p99.9 us | max us | frames/s | solver p50 us | lost | server CPU at 100 Hz |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let embedded = SystemConfig::builtin()
        .map(|c| (c.solver.segments_embedded, c.solver.grading_ratio_embedded))
        .unwrap_or_else(|e| panic!("the built-in configuration: {e}"));
    let label = format!("{} graded {}", embedded.0, embedded.1);
    let cpu: usize = std::env::var("BRIDGE_BENCH_CPU")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0);
    run(
        "iceoryx2 request-response, empty handler",
        "bare",
        frames,
        None,
        None,
    );
    run(
        &format!("bridge lockstep, host f32, {label}"),
        "host-f32-embedded",
        frames,
        Some((Precision::F32, embedded.0, embedded.1)),
        None,
    );
    run(
        "bridge lockstep, host f64, 300 uniform",
        "host-f64-300",
        frames / 10,
        Some((Precision::F64, 300, 1.0)),
        None,
    );
    run(
        &format!("bridge lockstep, qemu M4 f32, {label}"),
        "qemu",
        frames / 40,
        None,
        None,
    );
    run(
        &format!("iceoryx2 request-response, empty handler, both on CPU {cpu}"),
        "bare",
        frames,
        None,
        Some(cpu),
    );
    run(
        &format!("bridge lockstep, host f32, {label}, both on CPU {cpu}"),
        "host-f32-embedded",
        frames,
        Some((Precision::F32, embedded.0, embedded.1)),
        Some(cpu),
    );
}

/// A turning flight long enough for any frame count (10 ms frames).
fn flight(n: usize) -> Vec<AircraftStateFrame> {
    let turn = LevelTurn {
        altitude: 9000.0,
        speed: 240.0,
        start: 0.0,
        rate: 0.05,
        gravity: 9.80665,
    };
    scenario_frames(&turn, n as u32)
}

fn spawn(kind: &str, iso: &Isolated, cpu: Option<usize>) -> Child {
    let exe = std::env::current_exe().unwrap();
    let mut command = Command::new(exe);
    command.args(["--serve", kind]);
    if let Some(c) = cpu {
        command.args(["--cpu", &c.to_string()]);
    }
    command.envs(iso.env()).spawn().unwrap()
}

fn cpu_ticks(pid: u32) -> u64 {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<&str> = after.split_whitespace().collect();
    f.get(11).and_then(|v| v.parse::<u64>().ok()).unwrap_or(0)
        + f.get(12).and_then(|v| v.parse::<u64>().ok()).unwrap_or(0)
}

fn connect(iso: &Isolated) -> BridgeClient {
    let deadline = Instant::now() + Duration::from_secs(900);
    loop {
        match BridgeClient::connect(
            INSTANCE,
            &format!("bench-client-{}", std::process::id()),
            &iso.config,
        ) {
            Ok(c) => return c,
            Err(e) if Instant::now() < deadline => {
                let _ = e;
                std::thread::sleep(Duration::from_millis(100));
            }
            Err(e) => panic!("{e}"),
        }
    }
}

fn run(
    label: &str,
    kind: &str,
    n: usize,
    solver: Option<(Precision, usize, f64)>,
    cpu: Option<usize>,
) {
    // The client (this process) on `cpu` for the run, as the server.
    let unpinned = Cpus::of_this_thread().unwrap();
    if let Some(c) = cpu {
        pin_process(&Cpus::parse(&c.to_string()).unwrap()).unwrap();
    }
    let iso = Isolated::new().unwrap();
    let mut server = spawn(kind, &iso, cpu);
    let mut client = connect(&iso);
    client.set_timeout(Duration::from_secs(30));
    let frames = flight(n + 1000);
    if kind != "bare" {
        client
            .simple_command(bridge_types::command::RESET_TO_TRIM)
            .unwrap();
        // The trim frame (about 1 ms of solver work) is not a control step.
        client.step(&from_link_frame(&frames[0])).unwrap();
    }
    let mut rtt = Vec::with_capacity(n);
    let mut lost = 0usize;
    let started = Instant::now();
    for f in &frames[1..=n] {
        let t0 = Instant::now();
        let a = client.step(&from_link_frame(f)).unwrap();
        rtt.push(t0.elapsed().as_secs_f64() * 1e6);
        if kind != "bare" && a.header.kind != bridge_types::kind::OUTPUT {
            lost += 1;
        }
    }
    let fps = n as f64 / started.elapsed().as_secs_f64();
    // 100 Hz paced: the server's CPU over 10 s (1,000 frames).
    let ticks_per_s = 100.0; // USER_HZ on Linux
    let c0 = cpu_ticks(server.id());
    let t0 = Instant::now();
    for (i, f) in frames[n + 1..n + 1000].iter().enumerate() {
        let due = t0 + Duration::from_millis(10 * i as u64);
        if let Some(wait) = due.checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        }
        client.step(&from_link_frame(f)).unwrap();
    }
    let cpu_share = (cpu_ticks(server.id()) - c0) as f64 / ticks_per_s / t0.elapsed().as_secs_f64();
    drop(client);
    let _ = Command::new("kill")
        .args(["-INT", &server.id().to_string()])
        .status();
    let _ = server.wait();
    let solver_p50 = solver.map(|(p, seg, g)| solver_time(p, seg, g, &frames[..=n.min(5000)]));
    let p = Percentiles::of(&mut rtt);
    println!(
        "| {label} | {n} | {:.1} | {:.1} | {:.1} | {:.1} | {:.0} | {} | {lost} | {:.1} % |",
        p.p50,
        p.p99,
        p.p999,
        p.max,
        fps,
        solver_p50.map_or("-".to_owned(), |s| format!("{s:.1}")),
        cpu_share * 100.0
    );
    pin_process(&unpinned).unwrap();
}

/// The controller's own time per frame in this process (median), us.
fn solver_time(
    precision: Precision,
    segments: usize,
    grading: f64,
    frames: &[AircraftStateFrame],
) -> f64 {
    let options = BackendOptions {
        precision: Some(precision),
        segments: Some(segments),
        grading: Some(grading),
        ..BackendOptions::default()
    };
    bridge_local::controller_time_p50(&SystemConfig::builtin().unwrap(), &options, frames).unwrap()
}

/// How a server builds its backend once its thread runs.
type MakeBackend = Box<dyn FnOnce(&SystemConfig) -> Box<dyn Backend + Send> + Send>;

/// The server side, in its own process.
fn serve(kind: &str) {
    let config = iox_config(None, None).unwrap();
    if kind == "bare" {
        bare_server(&config);
        return;
    }
    let system = SystemConfig::builtin().unwrap();
    let host = |options: BackendOptions| {
        move |system: &SystemConfig| -> Box<dyn Backend + Send> {
            host_backend(system, &options).unwrap()
        }
    };
    let make: MakeBackend = match kind {
        "host-f32-embedded" => Box::new(host(BackendOptions::default())),
        "host-f64-300" => Box::new(host(BackendOptions {
            precision: Some(Precision::F64),
            segments: Some(300),
            grading: Some(1.0),
            ..BackendOptions::default()
        })),
        "qemu" => {
            Box::new(|system: &SystemConfig| qemu_backend(system, &QemuOptions::default()).unwrap())
        }
        other => panic!("unknown server {other}"),
    };
    let bridge = BridgeOptions {
        instance: INSTANCE.to_owned(),
        config,
        status_line: false,
        stop: None,
    };
    std::thread::Builder::new()
        .stack_size(64 << 20)
        .spawn(move || {
            let backend = make(&system);
            run_bridge(&bridge, backend, |_| {}).unwrap();
        })
        .unwrap()
        .join()
        .unwrap();
}

/// iceoryx2 alone: the bridge's services, a WaitSet on the same event, and an
/// empty handler answering every request with a zero `Answer`.
fn bare_server(config: &Config) {
    let node = node(INSTANCE, config).unwrap();
    let services = Services::open_or_create(&node, INSTANCE).unwrap();
    let lockstep = services.lockstep.server_builder().create().unwrap();
    let commands = services.commands.server_builder().create().unwrap();
    let listener = services.to_bridge.listener_builder().create().unwrap();
    let notifier = services.from_bridge.notifier_builder().create().unwrap();
    // The readiness mark, last (host_bridge::services), as the bridge's.
    let status_service = create_status_service(&node, INSTANCE).unwrap();
    let status = status_service.publisher_builder().create().unwrap();
    let _ = status.send_copy(bridge_types::Status::default());
    let waitset = WaitSetBuilder::new().create::<Ipc>().unwrap();
    let guard = waitset.attach_notification(&listener).unwrap();
    let _ = waitset.wait_and_process(|id| {
        if id.has_event_from(&guard) {
            let _ = listener.try_wait(|_| {});
        }
        while let Ok(Some(active)) = commands.receive() {
            let _ = active.send_copy(bridge_types::CommandReply::default());
            let _ = notifier.notify_with_custom_event_id(EventId::new(event::COMMAND_REPLY));
        }
        while let Ok(Some(active)) = lockstep.receive() {
            let _: &AircraftState = active.payload();
            let _ = active.send_copy(Answer::default());
            let _ = notifier.notify_with_custom_event_id(EventId::new(event::ANSWER));
        }
        CallbackProgression::Continue
    });
}
