//! The bridge across hosts (`cargo bench -p host-bridge --bench zenoh`, as
//! root; the numbers go to docs/benchmarks.md, section "Bridge across hosts").
//! Two hosts on one machine (bridge_local::netns: two network namespaces
//! joined by a veth pair); every server runs in namespace `a` and every
//! remote client in `b`, each this binary re-run there; each round trip
//! (state sent to answer received) is timed in the client. In one run:
//!
//! 1. a bare Zenoh query with an empty handler (a queryable answering every
//!    query with a zero `Answer`, tagged as the bridge's), across the namespaces;
//! 2. the bridge's lockstep over Zenoh, host backend, the configuration's
//!    embedded model in f32, across the namespaces;
//! 3. the same bridge over shared memory, its client on the bridge's host;
//! 4. 2 paced at 100 Hz (a frame every 10 ms for 20 s): every answer within
//!    its period?
//!
//! `ZENOH_BENCH_FRAMES` scales the flat-out runs (default 5,000).

use std::io::{BufRead, BufReader, Write};
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use bridge_local::Isolated;
use bridge_local::netns::Hosts;
use bridge_types::{Answer, SERVICE_ROOT, Wire, service};
use decoy_config::SystemConfig;
use decoy_hil::flight::scenario_frames;
use decoy_link::AircraftStateFrame;
use host_bridge::backend::{BackendOptions, host_backend};
use host_bridge::bridge::{BridgeOptions, run_bridge};
use host_bridge::client::BridgeClient;
use host_bridge::convert::from_link_frame;
use host_bridge::gateway::ZenohGateway;
use host_bridge::remote::{ALIVE, ZenohOptions};
use host_bridge::services::{iox_config, quiet_iceoryx_log};
use host_bridge::timing::Percentiles;
use serde::{Deserialize, Serialize};
use solver_core::profiles::LevelTurn;
use zenoh::Wait;

const INSTANCE: &str = "zbench";
const PORT: u16 = 7447;
const PERIOD: Duration = Duration::from_millis(10);

/// What a client measured (one JSON line on its stdout).
#[derive(Debug, Serialize, Deserialize)]
struct Measured {
    frames: usize,
    p50: f64,
    p99: f64,
    p999: f64,
    max: f64,
    frames_per_s: f64,
    /// Answers that took longer than the 10 ms period.
    over_period: usize,
    /// Frames not answered by an output (bridge runs).
    not_output: usize,
    /// Queries sent again after Zenoh ended them without a reply.
    resent: u64,
}

fn main() {
    quiet_iceoryx_log();
    let args: Vec<String> = std::env::args().collect();
    let arg = |name: &str| {
        args.iter()
            .position(|a| a == name)
            .map(|i| args[i + 1].clone())
    };
    if let Some(endpoint) = arg("--serve-echo") {
        serve_echo(&endpoint);
        return;
    }
    if let Some(endpoint) = arg("--serve-bridge") {
        serve_bridge(&endpoint);
        return;
    }
    if let Some(endpoint) = arg("--client") {
        let n: usize = arg("--frames").unwrap().parse().unwrap();
        let paced = args.iter().any(|a| a == "--paced");
        let bridge = args.iter().any(|a| a == "--bridge");
        let mut client = BridgeClient::connect_zenoh(
            INSTANCE,
            &ZenohOptions {
                connect: vec![endpoint],
                ..ZenohOptions::default()
            },
        )
        .unwrap();
        let m = measure(&mut client, n, paced, bridge);
        println!("{}", serde_json::to_string(&m).unwrap());
        return;
    }
    if args.iter().any(|a| a == "--list") {
        return;
    }
    let n: usize = std::env::var("ZENOH_BENCH_FRAMES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(5_000);
    let hosts = Hosts::new().unwrap_or_else(|e| panic!("{e}"));
    let endpoint = hosts.endpoint(PORT);
    let embedded = SystemConfig::builtin()
        .map(|c| (c.solver.segments_embedded, c.solver.grading_ratio_embedded))
        .unwrap();
    let label = format!("{} graded {}", embedded.0, embedded.1);
    println!(
        "| run | frames | p50 us | p99 us | p99.9 us | max us | frames/s | over 10 ms | not answered by an output | queries sent again |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let row = |name: &str, m: &Measured| {
        println!(
            "| {name} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {:.0} | {} | {} | {} |",
            m.frames,
            m.p50,
            m.p99,
            m.p999,
            m.max,
            m.frames_per_s,
            m.over_period,
            m.not_output,
            m.resent
        );
    };

    let iso = Isolated::new().unwrap();
    let echo = Server::start(&hosts, &iso, "--serve-echo", &endpoint);
    let bare = remote_client(&hosts, &endpoint, n, false, false);
    row("bare Zenoh query, empty handler, across namespaces", &bare);
    drop(echo);

    let bridge = Server::start(&hosts, &iso, "--serve-bridge", &endpoint);
    let zenoh = remote_client(&hosts, &endpoint, n, false, true);
    row(
        &format!("bridge lockstep over Zenoh, host f32, {label}, across namespaces"),
        &zenoh,
    );
    let mut local = BridgeClient::connect(
        INSTANCE,
        &format!("zbench-{}", std::process::id()),
        &iso.config,
    )
    .unwrap();
    let shm = measure(&mut local, n, false, true);
    drop(local);
    row(
        &format!("bridge lockstep over shared memory, host f32, {label}, one host"),
        &shm,
    );
    let paced = remote_client(&hosts, &endpoint, 2000, true, true);
    row(
        &format!("bridge lockstep over Zenoh, host f32, {label}, across namespaces, paced 100 Hz"),
        &paced,
    );
    drop(bridge);

    let config = SystemConfig::builtin().unwrap();
    let solver = bridge_local::controller_time_p50(
        &config,
        &BackendOptions::default(),
        &flight(n.min(5000) + 1),
    )
    .unwrap();
    println!();
    println!("controller's own time per frame (p50, in this process): {solver:.1} us");
    let bound = 2.0 * bare.p50 + solver;
    println!(
        "target: bridge over Zenoh p50 {:.1} us <= 2 x bare {:.1} + controller {solver:.1} = {bound:.1} us: {}",
        zenoh.p50,
        bare.p50,
        if zenoh.p50 <= bound { "met" } else { "NOT met" }
    );
    println!(
        "target: paced 100 Hz, every answer within its 10 ms period: {} ({} of {} over; p99.9 {:.1} us, max {:.1} us)",
        if paced.over_period == 0 && paced.not_output == 0 {
            "met"
        } else {
            "NOT met"
        },
        paced.over_period,
        paced.frames,
        paced.p999,
        paced.max
    );
}

/// A level turn at 9 km, 240 m/s, 0.05 rad/s, long enough for `n` frames.
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

/// `n` lockstep round trips through `client` after a reset and the trim frame
/// (a bridge), flat out or paced at 100 Hz.
fn measure(client: &mut BridgeClient, n: usize, paced: bool, bridge: bool) -> Measured {
    client.set_timeout(Duration::from_secs(30));
    let frames = flight(n + 1);
    if bridge {
        client
            .simple_command(bridge_types::command::RESET_TO_TRIM)
            .unwrap();
        // The trim frame is not a control step.
        client.step(&from_link_frame(&frames[0])).unwrap();
    }
    let mut rtt = Vec::with_capacity(n);
    let mut not_output = 0;
    let started = Instant::now();
    for (i, f) in frames[1..=n].iter().enumerate() {
        if paced {
            let due = started + PERIOD * i as u32;
            if let Some(wait) = due.checked_duration_since(Instant::now()) {
                std::thread::sleep(wait);
            }
        }
        let t0 = Instant::now();
        let a = client.step(&from_link_frame(f)).unwrap();
        rtt.push(t0.elapsed().as_secs_f64() * 1e6);
        if bridge && a.header.kind != bridge_types::kind::OUTPUT {
            not_output += 1;
        }
    }
    let wall = started.elapsed().as_secs_f64();
    let over_period = rtt
        .iter()
        .filter(|&&us| us > PERIOD.as_secs_f64() * 1e6)
        .count();
    let p = Percentiles::of(&mut rtt);
    Measured {
        frames: n,
        p50: p.p50,
        p99: p.p99,
        p999: p.p999,
        max: p.max,
        frames_per_s: n as f64 / wall,
        over_period,
        not_output,
        resent: client.queries_resent(),
    }
}

/// A client in namespace `b`.
fn remote_client(hosts: &Hosts, endpoint: &str, n: usize, paced: bool, bridge: bool) -> Measured {
    let exe = std::env::current_exe().unwrap();
    let mut c = Hosts::exec(&hosts.b, &exe);
    c.args(["--client", endpoint, "--frames", &n.to_string()]);
    if paced {
        c.arg("--paced");
    }
    if bridge {
        c.arg("--bridge");
    }
    let out = c.output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    serde_json::from_str(text.lines().last().unwrap_or("")).unwrap()
}

/// A server in namespace `a`, ready when its first line (`READY`) came;
/// SIGINT and waited for on drop.
struct Server(Child);

impl Server {
    fn start(hosts: &Hosts, iso: &Isolated, mode: &str, endpoint: &str) -> Server {
        let exe = std::env::current_exe().unwrap();
        let mut child = Hosts::exec(&hosts.a, &exe)
            .args([mode, endpoint])
            .envs(iso.env())
            .stdout(Stdio::piped())
            .spawn()
            .unwrap();
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        assert_eq!(line.trim(), "READY", "{mode}");
        Server(child)
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = Command::new("kill")
            .args(["-INT", &self.0.id().to_string()])
            .status();
        let _ = self.0.wait();
    }
}

fn ready() {
    let mut out = std::io::stdout();
    let _ = writeln!(out, "READY");
    let _ = out.flush();
}

/// Zenoh alone: a queryable on the bridge's lockstep key answering every
/// query with a zero `Answer` (tagged), and the readiness token.
fn serve_echo(endpoint: &str) {
    let mut c = zenoh::Config::default();
    for (k, v) in [
        ("mode", "\"peer\"".to_owned()),
        ("scouting/multicast/enabled", "false".to_owned()),
        ("listen/endpoints", format!("[\"{endpoint}\"]")),
    ] {
        c.insert_json5(k, &v).unwrap();
    }
    let session = zenoh::open(c).wait().unwrap();
    let zero = Answer::default().as_wire_bytes().to_vec();
    let _queryable = session
        .declare_queryable(format!("{SERVICE_ROOT}/{INSTANCE}/{}", service::LOCKSTEP))
        .callback(move |q| {
            let _ = q
                .reply(q.key_expr().clone(), zero.clone())
                .attachment(Answer::tag())
                .wait();
        })
        .wait()
        .unwrap();
    let _token = session
        .liveliness()
        .declare_token(format!("{SERVICE_ROOT}/{INSTANCE}/{ALIVE}"))
        .wait()
        .unwrap();
    ready();
    let stop = Arc::new(AtomicBool::new(false));
    signal_hook::flag::register(signal_hook::consts::SIGINT, Arc::clone(&stop)).unwrap();
    while !stop.load(std::sync::atomic::Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// `decoy bridge --zenoh-listen ENDPOINT` in this process: the host backend
/// with the configuration's embedded model, its Zenoh gateway, until SIGINT.
fn serve_bridge(endpoint: &str) {
    let iox = iox_config(None, None).unwrap();
    let options = BridgeOptions {
        instance: INSTANCE.to_owned(),
        config: iox.clone(),
        status_line: false,
        stop: None,
    };
    let zenoh = ZenohOptions {
        listen: vec![endpoint.to_owned()],
        unauthenticated: true,
        ..ZenohOptions::default()
    };
    std::thread::Builder::new()
        .stack_size(bridge_local::BRIDGE_STACK_BYTES)
        .spawn(move || {
            let system = SystemConfig::builtin().unwrap();
            let backend = host_backend(&system, &BackendOptions::default()).unwrap();
            let mut gateway = None;
            run_bridge(&options, backend, |_| {
                gateway = Some(ZenohGateway::start(INSTANCE, &iox, &zenoh).unwrap());
                ready();
            })
            .unwrap();
            gateway.unwrap().stop().unwrap();
        })
        .unwrap()
        .join()
        .unwrap();
}
