//! Issue 27, reliability: a free-running flood does not starve the other
//! services or the stop request, and a client that connects while a bridge
//! starts never loses what it sends. Each test in an iceoryx2 setup of its own,
//! the bridge on a thread of this process (host backend).
//!
//! The bounds are correctness bounds, not speed figures (those are the
//! benchmarks' and the soak's, docs/soak.md): an answer or a stop comes while
//! the flood still runs, within seconds on a loaded 2-core machine.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use bridge_local::{BRIDGE_STACK_BYTES, Isolated, LocalBridge};
use bridge_types::{AircraftState, Command, Header, command, event, kind, reason, result};
use decoy_config::SystemConfig;
use host_bridge::BridgeError;
use host_bridge::backend::{BackendOptions, Precision, host_backend};
use host_bridge::bridge::{BridgeOptions, run_bridge};
use host_bridge::client::BridgeClient;
use host_bridge::services::{Services, node, quiet_iceoryx_log};
use iceoryx2::prelude::*;

/// Speed of the flood's level flight, m/s.
const SPEED: f64 = 243.0;
/// Simulated seconds per wall-clock second of the flood's states: a sample's
/// time is the wall clock's (scaled, strictly increasing), so the samples the
/// bridge never sees (overwritten in its buffer) leave gaps far below the
/// controller's 0.1 s limit however long the bridge is held up (10 s of wall
/// clock for 0.1 s): every sample it processes is valid, with or without the
/// bounded serving loop.
const FLOOD_TIME_SCALE: f64 = 0.01;
/// The flood wakes the bridge once per this many samples.
const FLOOD_NOTIFY_EVERY: u64 = 1024;
/// The longest a flood runs (it stops by itself): far longer than any bound
/// below, so that "before the flood ended" is told apart from "after it".
const FLOOD_LIMIT: Duration = Duration::from_secs(20);
/// A command's or a lockstep request's round trip during a flood is at most
/// this: a correctness bound (answered at all while the flood goes on), far
/// above what the bridge guarantees (one batch of free-running samples, a few
/// milliseconds with the flood's 300-segment model) and far below the flood's
/// length. Before the bounded serving loop a ping waited seconds.
const ROUND_TRIP_BOUND: Duration = Duration::from_secs(2);
/// A stop request during a flood is honoured within this (the same kind of bound).
const STOP_BOUND: Duration = Duration::from_secs(5);

/// One test at a time: each measures time with a bridge (and a flood) that
/// keep a core busy; side by side on a 2-core machine they would measure each
/// other.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

fn one_at_a_time() -> MutexGuard<'static, ()> {
    ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner())
}

/// Steady level flight at 9 km, due north, at time `t`.
fn level(t: f64, seq: u32) -> AircraftState {
    AircraftState {
        header: Header::new(kind::AIRCRAFT_STATE, seq),
        time_s: t,
        position_ned_m: [SPEED * t, 0.0, -9000.0],
        velocity_ned_mps: [SPEED as f32, 0.0, 0.0],
        attitude_wxyz: [1.0, 0.0, 0.0, 0.0],
        ..Default::default()
    }
}

/// A publisher of valid free-running states as fast as it can, until `stop`
/// or [`FLOOD_LIMIT`]; its thread keeps its ports (and so its samples still
/// waiting in the bridge's buffer) until `release`.
struct Flood {
    stop: Arc<AtomicBool>,
    release: Arc<AtomicBool>,
    published: Arc<AtomicU64>,
    done: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Flood {
    fn start(iso: &Isolated, instance: &str) -> Flood {
        let stop = Arc::new(AtomicBool::new(false));
        let release = Arc::new(AtomicBool::new(false));
        let published = Arc::new(AtomicU64::new(0));
        let done = Arc::new(AtomicBool::new(false));
        let (flag, count) = (stop.clone(), published.clone());
        let (released, finished) = (release.clone(), done.clone());
        let (config, instance) = (iso.config.clone(), instance.to_owned());
        // Ports are not `Send`: the flood's own, on its thread. A client for
        // the status, a publisher of its own for the flood: it wakes the bridge
        // once per FLOOD_NOTIFY_EVERY samples, not after each (the bridge's
        // tick serves it anyway), so it never waits for the bridge to consume
        // its wake-ups: however long the bridge keeps serving, the flood goes on.
        let thread = std::thread::spawn(move || {
            let mut c =
                BridgeClient::connect(&instance, &format!("{instance}-flood"), &config).unwrap();
            let node = node(&format!("{instance}-floodpub"), &config).unwrap();
            let services = Services::open(&node, &instance).unwrap();
            let publisher = services.state.publisher_builder().create().unwrap();
            let notifier = services.to_bridge.notifier_builder().create().unwrap();
            let wake = || {
                let _ = notifier.notify_with_custom_event_id(EventId::new(event::STATE));
            };
            let publish = |state: AircraftState| {
                publisher
                    .loan_uninit()
                    .unwrap()
                    .write_payload(state)
                    .send()
                    .unwrap();
            };
            // The first sample, seen by the bridge before the flood: a publisher's
            // samples are counted lost from the first one the bridge sees.
            let before = c.get_status().unwrap().counters.free_samples;
            publish(level(1e-3, 0));
            wake();
            while c.get_status().unwrap().counters.free_samples == before {
                std::thread::sleep(Duration::from_millis(1));
            }
            count.store(1, Ordering::Relaxed);
            let started = Instant::now();
            let (mut n, mut last_ns) = (1u64, 0u64);
            while !flag.load(Ordering::Relaxed) && started.elapsed() < FLOOD_LIMIT {
                // Strictly later than the first sample, and than the one before.
                let ns = (started.elapsed().as_nanos() as u64).max(last_ns + 1);
                last_ns = ns;
                let t = 1e-3 + 1e-9 * ns as f64 * FLOOD_TIME_SCALE;
                publish(level(t, n as u32));
                if n % FLOOD_NOTIFY_EVERY == 0 {
                    wake();
                }
                n += 1;
                count.store(n, Ordering::Relaxed);
            }
            finished.store(true, Ordering::Release);
            while !released.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(5));
            }
        });
        Flood {
            stop,
            release,
            published,
            done,
            thread: Some(thread),
        }
    }

    /// Waits until the flood has published `n` samples.
    fn wait_for(&self, n: u64) {
        let deadline = Instant::now() + Duration::from_secs(10);
        while self.published.load(Ordering::Relaxed) < n {
            assert!(Instant::now() < deadline, "the flood does not publish");
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    /// Whether the flood still publishes (it has not reached [`FLOOD_LIMIT`]).
    fn running(&self) -> bool {
        !self.done.load(Ordering::Acquire)
    }

    /// Stops publishing (the client stays); how many were published.
    fn stop(&self) -> u64 {
        self.stop.store(true, Ordering::Relaxed);
        while !self.done.load(Ordering::Acquire) {
            std::thread::sleep(Duration::from_millis(1));
        }
        self.published.load(Ordering::Relaxed)
    }
}

impl Drop for Flood {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        self.release.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The flood tests' backend: 300 uniform segments in f64, so that each
/// free-running sample costs the bridge far more than its publisher (hundreds
/// of microseconds against a few): its 1,024-sample buffer never empties while
/// the flood runs, even when the publisher's thread is descheduled for a while
/// on a loaded machine. Trimmed at once (the first frame answers an output).
fn heavy() -> BackendOptions {
    BackendOptions {
        precision: Some(Precision::F64),
        segments: Some(300),
        grading: Some(1.0),
        trim_at_once: true,
    }
}

fn start(iso: &Isolated, instance: &str) -> LocalBridge {
    quiet_iceoryx_log();
    LocalBridge::start(
        instance,
        &SystemConfig::builtin().unwrap(),
        &heavy(),
        &iso.config,
    )
    .unwrap()
}

/// A flood of valid free-running states, published faster than the bridge
/// can process them: commands, status and a lockstep request are still
/// answered within [`ROUND_TRIP_BOUND`] while the flood goes on (the bridge
/// looks at them after every batch of free-running samples), the status is
/// still published, and the flood is counted as before (every sample
/// processed or lost, the overruns).
#[test]
fn commands_status_and_lockstep_are_answered_during_a_flood() {
    let _one = one_at_a_time();
    let iso = Isolated::new().unwrap();
    let bridge = start(&iso, "flood");
    let mut c = BridgeClient::connect("flood", "flood-client", &iso.config).unwrap();
    c.set_timeout(Duration::from_secs(20));
    assert_eq!(
        c.simple_command(command::RESET_TO_TRIM).unwrap().result,
        result::OK
    );
    // The trim frame, then the flood from just after it.
    assert_eq!(c.step(&level(0.0, 0)).unwrap().header.kind, kind::OUTPUT);
    let flood = Flood::start(&iso, "flood");
    flood.wait_for(20_000);
    let before = c.get_status().unwrap();
    let mut worst = Duration::ZERO;
    let mut timed = |what: &str, f: &mut dyn FnMut(&mut BridgeClient)| {
        let t0 = Instant::now();
        f(&mut c);
        let took = t0.elapsed();
        assert!(
            took < ROUND_TRIP_BOUND,
            "{what} took {took:?} during the flood"
        );
        assert!(
            flood.running(),
            "{what}: answered only once the flood ended"
        );
        worst = worst.max(took);
    };
    for nonce in 0..20u32 {
        timed("a ping", &mut |c| {
            let r = c
                .command(Command {
                    command: command::PING,
                    nonce,
                    ..Default::default()
                })
                .unwrap();
            assert_eq!((r.result, r.nonce), (result::OK, nonce));
        });
        timed("GetStatus", &mut |c| {
            c.get_status().unwrap();
        });
        // A state behind the flood's: answered by its rejection, which leaves
        // the controller (and so the flood's validity) untouched.
        timed("a lockstep request", &mut |c| {
            let a = c.step(&level(0.0, 1 + nonce)).unwrap();
            assert_eq!(a.header.kind, kind::REJECTED);
            assert_eq!(a.rejection.reason, reason::TIME_NOT_INCREASING);
        });
        std::thread::sleep(Duration::from_millis(20));
    }
    // The status keeps coming (at least every second) while the flood runs.
    c.latest_status().unwrap();
    let deadline = Instant::now() + Duration::from_millis(2500);
    let published = loop {
        if let Some(s) = c.latest_status().unwrap() {
            break s;
        }
        assert!(
            Instant::now() < deadline,
            "no status published during the flood"
        );
        c.wait_event(Duration::from_millis(50)).unwrap();
    };
    assert!(published.counters.free_samples > before.counters.free_samples);
    let during = c.get_status().unwrap();
    let published_samples = flood.stop();
    // The flood outpaced the bridge: samples overwritten unseen, and overruns.
    assert!(during.counters.free_samples > before.counters.free_samples);
    assert!(during.counters.overruns > 0, "{:?}", during.counters);
    // Every sample published was processed or counted lost (once the bridge
    // has caught up with the last ones).
    let deadline = Instant::now() + Duration::from_secs(20);
    let after = loop {
        let s = c.get_status().unwrap();
        if s.counters.free_samples + s.counters.lost == published_samples
            || Instant::now() > deadline
        {
            break s;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let k = after.counters;
    assert_eq!(k.free_samples + k.lost, published_samples, "{k:?}");
    assert!(k.lost > 0, "the flood did outpace the bridge: {k:?}");
    // Valid states: the free-running ones all accepted; only the 20 lockstep
    // requests behind them rejected.
    assert_eq!(k.time_not_increasing, 20, "{k:?}");
    assert_eq!(k.rejected(), 20, "{k:?}");
    assert_eq!(k.accepted, 1 + k.free_samples, "{k:?}");
    eprintln!(
        "flood: {published_samples} published, {} processed, {} lost, {} overruns; worst round trip {worst:?}",
        k.free_samples, k.lost, k.overruns
    );
    drop(c);
    assert_eq!(bridge.stop().unwrap().ended_by, "stop request");
}

/// A stop request during a flood ends the bridge within [`STOP_BOUND`] while
/// the flood goes on (looked at between batches), not when the flood ends.
/// (SIGTERM and SIGINT are looked at in the same place, `Halt::requested` in
/// crates/host-bridge/src/bridge.rs, after each round; the soak, docs/soak.md,
/// sends a real SIGTERM to `decoy bridge` during a flood and reports how long it
/// took.)
#[test]
fn a_stop_request_during_a_flood_ends_the_bridge_at_once() {
    let _one = one_at_a_time();
    let iso = Isolated::new().unwrap();
    let bridge = start(&iso, "floodstop");
    let mut c = BridgeClient::connect("floodstop", "floodstop-client", &iso.config).unwrap();
    c.simple_command(command::RESET_TO_TRIM).unwrap();
    c.step(&level(0.0, 0)).unwrap();
    drop(c);
    let flood = Flood::start(&iso, "floodstop");
    flood.wait_for(20_000);
    std::thread::sleep(Duration::from_millis(300));
    let t0 = Instant::now();
    let summary = bridge.stop().unwrap();
    let took = t0.elapsed();
    let during = flood.running();
    let published = flood.stop();
    assert!(
        during,
        "the stop was honoured only once the flood ended ({took:?})"
    );
    assert!(took < STOP_BOUND, "the stop took {took:?}");
    assert_eq!(summary.ended_by, "stop request");
    assert!(summary.counters.free_samples > 0);
    assert!(published > summary.counters.free_samples);
}

/// A bridge on a thread, started without waiting for it to be ready.
fn spawn_bridge(
    iso: &Isolated,
    instance: &str,
    stop: &Arc<AtomicBool>,
) -> JoinHandle<Result<String, BridgeError>> {
    let options = BridgeOptions {
        instance: instance.to_owned(),
        config: iso.config.clone(),
        status_line: false,
        stop: Some(stop.clone()),
    };
    std::thread::Builder::new()
        .stack_size(BRIDGE_STACK_BYTES)
        .spawn(move || {
            let backend = host_backend(
                &SystemConfig::builtin().unwrap(),
                &BackendOptions::default(),
            )?;
            run_bridge(&options, backend, |_| {}).map(|s| s.ended_by)
        })
        .unwrap()
}

/// Startups raced: a client connects as soon as it can while the bridge
/// starts, and sends a command at once; 30 times, never lost.
#[test]
fn a_command_sent_at_once_while_the_bridge_starts_is_never_lost() {
    let _one = one_at_a_time();
    quiet_iceoryx_log();
    let iso = Isolated::new().unwrap();
    for round in 0..30u32 {
        let instance = format!("race{round}");
        let stop = Arc::new(AtomicBool::new(false));
        let bridge = spawn_bridge(&iso, &instance, &stop);
        let deadline = Instant::now() + Duration::from_secs(60);
        let mut c = loop {
            match BridgeClient::connect(&instance, &format!("{instance}-client"), &iso.config) {
                Ok(c) => break c,
                // Nothing of the bridge exists yet: at once again.
                Err(BridgeError::NoBridge(_)) if Instant::now() < deadline => {}
                Err(e) => panic!("round {round}: {e}"),
            }
        };
        c.set_timeout(Duration::from_secs(5));
        let r = c
            .command(Command {
                command: command::PING,
                nonce: round,
                ..Default::default()
            })
            .unwrap_or_else(|e| panic!("round {round}: the command was lost: {e}"));
        assert_eq!((r.result, r.nonce), (result::OK, round));
        drop(c);
        stop.store(true, Ordering::Relaxed);
        assert_eq!(bridge.join().unwrap().unwrap(), "stop request");
    }
}

/// Services that exist before anything serves them (a bridge part-way
/// through its start) are not a bridge: a client does not connect to them,
/// it waits for the readiness mark and says there is no bridge.
#[test]
fn a_client_does_not_connect_to_a_bridge_still_starting() {
    let _one = one_at_a_time();
    quiet_iceoryx_log();
    let iso = Isolated::new().unwrap();
    let node = node("half", &iso.config).unwrap();
    let services = Services::open_or_create(&node, "half").unwrap();
    let _lockstep = services.lockstep.server_builder().create().unwrap();
    let started = Instant::now();
    let e = BridgeClient::connect("half", "half-client", &iso.config)
        .err()
        .expect("connected to a bridge that serves no commands yet");
    assert!(matches!(e, BridgeError::NoBridge(_)), "{e}");
    assert!(started.elapsed() < Duration::from_secs(5));
}
