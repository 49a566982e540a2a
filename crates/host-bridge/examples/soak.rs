//! The bridge's soak (`cargo xtask soak`, also a stage of `cargo xtask
//! bench-report`; writes docs/soak.md and docs/soak.json): the real bridge, the
//! `decoy bridge` binary as a child process (so that its RSS is the bridge's
//! alone), in an iceoryx2 setup of its own, serving side by side for
//! `--duration` (default 10 minutes):
//!
//! - a lockstep client at 100 Hz (a simulation's 10 ms frames), every round
//!   trip timed;
//! - a free-running flood: a publisher of valid states flat out (notifying the
//!   bridge after each, as `decoy feed --mode free` and the Python client do),
//!   faster than the bridge can process them;
//! - a command (a ping) every 100 ms, every round trip timed;
//!
//! while the bridge's RSS (`/proc/<pid>/status` VmRSS) is sampled every second.
//! At the end SIGTERM, the flood still running: the time to the bridge's exit
//! and its JSON summary (counters, service time) are reported too.
//!
//! All the states are one level flight at 9 km whose time is the wall clock's,
//! scaled by [`TIME_SCALE`] and strictly increasing across the clients: the
//! flood's overwritten samples leave small gaps (no time jump); a state older
//! than one the controller already accepted (a flood sample still waiting when
//! a lockstep state was served, or a lockstep state served after a flood
//! sample published after it) is rejected (time not increasing), which is
//! counted, not an error. (Giving the lockstep states a 3 ms lead was tried:
//! fewer lockstep rejections, 25 % against 37 % in 30 s, but a lockstep median
//! of 1.1 to 1.7 ms against 0.2 ms, not understood; not kept.)
//!
//! ```text
//! cargo build --release -p decoy-cli --bin decoy
//! cargo run --release -p host-bridge --example soak -- [--duration 10m]
//!     [--decoy target/release/decoy] [--md docs/soak.md] [--json docs/soak.json]
//! ```

use std::io::{BufRead, BufReader, Write as _};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use bridge_local::Isolated;
use bridge_types::{AircraftState, Command as BridgeCommand, Header, command, kind, result};
use host_bridge::client::BridgeClient;
use host_bridge::services::quiet_iceoryx_log;
use host_bridge::timing::LatencyHistogram;
use host_bridge::timing::Percentiles;
use serde_json::{Value, json};

const INSTANCE: &str = "soak";
/// Speed of the level flight, m/s.
const SPEED: f64 = 243.0;
/// Simulated seconds per wall-clock second: a stall of the bridge of up to 2 s
/// leaves a gap below the controller's 0.1 s time-jump limit.
const TIME_SCALE: f64 = 0.05;
/// The lockstep client's frame period.
const LOCKSTEP_PERIOD: Duration = Duration::from_millis(10);

/// The command client's period.
const COMMAND_PERIOD: Duration = Duration::from_millis(100);
/// Deadline of one answer (a lost answer is counted, the soak goes on).
const ANSWER_TIMEOUT: Duration = Duration::from_secs(5);
/// The RSS is sampled this often.
const RSS_PERIOD: Duration = Duration::from_secs(1);
/// The RSS "after warm-up" is the sample at this fraction of the run (at least
/// [`WARM_UP_MIN`] in): the growth from there is the soak's figure.
const WARM_UP_FRACTION: f64 = 0.1;
const WARM_UP_MIN: Duration = Duration::from_secs(5);

fn main() {
    quiet_iceoryx_log();
    let args = match Args::parse() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("soak: {e}\n\n{USAGE}");
            std::process::exit(2);
        }
    };
    if let Err(e) = run(&args) {
        eprintln!("soak: {e}");
        std::process::exit(1);
    }
}

const USAGE: &str = "usage: soak [--duration 10m|30s|600] [--decoy PATH] [--md PATH] [--json PATH]";

struct Args {
    duration: Duration,
    decoy: PathBuf,
    md: PathBuf,
    json: PathBuf,
}

/// The workspace root (this crate is crates/host-bridge).
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap_or_else(|_| PathBuf::from("."))
}

fn parse_duration(s: &str) -> Result<Duration, String> {
    let (number, unit) = match s.find(|c: char| !(c.is_ascii_digit() || c == '.')) {
        Some(i) => s.split_at(i),
        None => (s, "s"),
    };
    let n: f64 = number
        .parse()
        .map_err(|_| format!("bad duration {s:?} (e.g. 30s, 10m, 1h, 600)"))?;
    let seconds = match unit {
        "s" => n,
        "m" | "min" => n * 60.0,
        "h" => n * 3600.0,
        _ => return Err(format!("bad duration unit in {s:?} (s, m or h)")),
    };
    if !(seconds.is_finite() && seconds >= 5.0) {
        return Err(format!("duration {s:?}: at least 5 s"));
    }
    Ok(Duration::from_secs_f64(seconds))
}

impl Args {
    fn parse() -> Result<Args, String> {
        let root = root();
        let mut a = Args {
            duration: Duration::from_secs(600),
            decoy: root.join("target/release/decoy"),
            md: root.join("docs/soak.md"),
            json: root.join("docs/soak.json"),
        };
        let mut it = std::env::args().skip(1);
        while let Some(flag) = it.next() {
            let mut value = || it.next().ok_or(format!("{flag} needs a value"));
            match flag.as_str() {
                "--duration" => a.duration = parse_duration(&value()?)?,
                "--decoy" => a.decoy = PathBuf::from(value()?),
                "--md" => a.md = PathBuf::from(value()?),
                "--json" => a.json = PathBuf::from(value()?),
                "-h" | "--help" => {
                    println!("{USAGE}");
                    std::process::exit(0);
                }
                // `cargo bench`/`cargo test` style flags are not ours.
                other => return Err(format!("unknown argument {other:?}")),
            }
        }
        Ok(a)
    }
}

/// One clock for every client: wall-clock time since the start scaled by
/// [`TIME_SCALE`], strictly increasing from call to call (in ns of wall clock).
struct Timeline {
    start: Instant,
    last_ns: AtomicU64,
}

impl Timeline {
    fn now_s(&self) -> f64 {
        let now = self.start.elapsed().as_nanos() as u64;
        let prev = self
            .last_ns
            .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |last| {
                Some(now.max(last + 1))
            })
            .unwrap_or(0);
        let ns = now.max(prev + 1);
        1e-9 * ns as f64 * TIME_SCALE
    }
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

/// What the lockstep client saw.
#[derive(Default)]
struct Lockstep {
    round_trips: LatencyHistogram,
    outputs: u64,
    initialising: u64,
    rejected: u64,
    /// No answer within [`ANSWER_TIMEOUT`], or an error.
    failed: u64,
    /// Frames that started later than their slot (the client fell behind).
    late: u64,
}

/// What the command client saw.
#[derive(Default)]
struct Commands {
    round_trips: LatencyHistogram,
    ok: u64,
    /// No reply in time, a wrong nonce, or an error.
    failed: u64,
}

/// A client thread: `body` with its own client until `stop`.
fn client_thread<T: Send + 'static>(
    name: &str,
    iso_config: &iceoryx2::config::Config,
    body: impl FnOnce(BridgeClient) -> T + Send + 'static,
) -> JoinHandle<Result<T, String>> {
    let (config, node) = (iso_config.clone(), format!("{INSTANCE}-{name}"));
    std::thread::Builder::new()
        .name(node.clone())
        .spawn(move || {
            let mut c =
                BridgeClient::connect_within(INSTANCE, &node, &config, Duration::from_secs(60))
                    .map_err(|e| format!("{node}: {e}"))?;
            c.set_timeout(ANSWER_TIMEOUT);
            Ok(body(c))
        })
        .expect("a client thread")
}

fn rss_kib(pid: u32) -> Option<u64> {
    let text = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let line = text.lines().find(|l| l.starts_with("VmRSS:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

fn loadavg() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_default()
}

fn command_output(program: &str, args: &[&str]) -> String {
    Command::new(program)
        .args(args)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
        .unwrap_or_default()
}

/// Starts `decoy bridge` in `iso` and waits for its ready line; its stderr is
/// drained on a thread (kept for an error message).
/// The bridge's stderr lines (the first 200).
type Lines = Arc<Mutex<Vec<String>>>;

fn start_bridge(decoy: &Path, iso: &Isolated) -> Result<(Child, Lines), String> {
    let mut child = Command::new(decoy)
        .args(["bridge", "--instance", INSTANCE, "--json"])
        .envs(iso.env())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| {
            format!(
                "cannot start {} ({e}): build it with `cargo build --release -p decoy-cli --bin decoy`, or pass --decoy",
                decoy.display()
            )
        })?;
    let stderr = child.stderr.take().ok_or("no stderr")?;
    let lines = Arc::new(Mutex::new(Vec::new()));
    let (tx, rx) = std::sync::mpsc::channel();
    let kept = lines.clone();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if line.contains(" ready (") {
                let _ = tx.send(());
            }
            if let Ok(mut k) = kept.lock()
                && k.len() < 200
            {
                k.push(line);
            }
        }
    });
    if rx.recv_timeout(Duration::from_secs(120)).is_err() {
        let _ = child.kill();
        let _ = child.wait();
        return Err(format!(
            "the bridge did not get ready: {:?}",
            lines.lock().map(|l| l.clone()).unwrap_or_default()
        ));
    }
    Ok((child, lines))
}

fn percentiles_json(p: &Percentiles) -> Value {
    json!({"p50": p.p50, "p99": p.p99, "p999": p.p999, "max": p.max})
}

fn run(args: &Args) -> Result<(), String> {
    let iso = Isolated::new().map_err(|e| e.to_string())?;
    let started_utc = command_output("date", &["-u", "+%Y-%m-%d %H:%M UTC"]);
    let load_start = loadavg();
    eprintln!(
        "soak: {} for {:?} (lockstep 100 Hz, a free-running flood, a ping every 100 ms)",
        args.decoy.display(),
        args.duration
    );
    let (mut child, stderr_lines) = start_bridge(&args.decoy, &iso)?;
    let pid = child.id();
    let t0 = Instant::now();
    let mut rss: Vec<(f64, u64)> = Vec::new();
    if let Some(k) = rss_kib(pid) {
        rss.push((0.0, k));
    }

    let timeline = Arc::new(Timeline {
        start: Instant::now(),
        last_ns: AtomicU64::new(0),
    });
    // The lockstep and command clients stop before the SIGTERM (a request in
    // flight at the exit would count as unanswered), the flood after it.
    let stop = Arc::new(AtomicBool::new(false));
    let stop_flood = Arc::new(AtomicBool::new(false));
    let flood_published = Arc::new(AtomicU64::new(0));

    // The run's start, as a simulation's: the controller reset, then the
    // first lockstep frames (the trim) before the flood.
    let (tl, st) = (timeline.clone(), stop.clone());
    let (trimmed_tx, trimmed_rx) = std::sync::mpsc::channel::<()>();
    let lockstep = client_thread("lockstep", &iso.config, move |mut c| {
        let mut l = Lockstep::default();
        if c.simple_command(command::RESET_TO_TRIM)
            .map(|r| r.result != result::OK)
            .unwrap_or(true)
        {
            l.failed += 1;
        }
        let mut seq = 0u32;
        let mut next = Instant::now();
        let mut told = false;
        while !st.load(Ordering::Relaxed) {
            let now = Instant::now();
            if now < next {
                std::thread::sleep(next - now);
            } else if now > next + LOCKSTEP_PERIOD {
                l.late += 1;
                next = now;
            }
            next += LOCKSTEP_PERIOD;
            let state = level(tl.now_s(), seq);
            seq = seq.wrapping_add(1);
            let sent = Instant::now();
            match c.step(&state) {
                Ok(a) => {
                    l.round_trips.record(sent.elapsed());
                    match a.header.kind {
                        k if k == kind::OUTPUT => l.outputs += 1,
                        k if k == kind::REJECTED => l.rejected += 1,
                        _ => l.initialising += 1,
                    }
                    if !told && a.header.kind == kind::OUTPUT {
                        told = true;
                        let _ = trimmed_tx.send(());
                    }
                }
                Err(_) => l.failed += 1,
            }
        }
        l
    });
    if trimmed_rx.recv_timeout(Duration::from_secs(60)).is_err() {
        stop.store(true, Ordering::Relaxed);
        stop_flood.store(true, Ordering::Relaxed);
        let _ = child.kill();
        let _ = child.wait();
        let why = match lockstep.join() {
            Ok(Err(e)) => e,
            _ => "no output within 60 s".to_owned(),
        };
        return Err(format!("the lockstep client did not start: {why}"));
    }

    let (tl, st, count) = (
        timeline.clone(),
        stop_flood.clone(),
        flood_published.clone(),
    );
    let flood = client_thread("flood", &iso.config, move |mut c| {
        let mut failed = 0u64;
        while !st.load(Ordering::Relaxed) {
            let seq = c.next_free_seq();
            if c.publish(&level(tl.now_s(), seq)).is_err() {
                failed += 1;
                std::thread::sleep(Duration::from_millis(1));
            }
            count.fetch_add(1, Ordering::Relaxed);
        }
        failed
    });

    let st = stop.clone();
    let commands = client_thread("commands", &iso.config, move |mut c| {
        let mut k = Commands::default();
        let mut nonce = 0u32;
        let mut next = Instant::now();
        while !st.load(Ordering::Relaxed) {
            let now = Instant::now();
            if now < next {
                std::thread::sleep(next - now);
            }
            next = next.max(now) + COMMAND_PERIOD;
            nonce = nonce.wrapping_add(1);
            let sent = Instant::now();
            match c.command(BridgeCommand {
                command: command::PING,
                nonce,
                ..Default::default()
            }) {
                Ok(r) if r.result == result::OK && r.nonce == nonce => {
                    k.round_trips.record(sent.elapsed());
                    k.ok += 1;
                }
                _ => k.failed += 1,
            }
        }
        k
    });

    // The RSS every second, a progress line every 10 s.
    let end = t0 + args.duration;
    let mut next_sample = t0 + RSS_PERIOD;
    let mut next_line = t0 + Duration::from_secs(10);
    while Instant::now() < end {
        if let Ok(Some(status)) = child.try_wait() {
            stop.store(true, Ordering::Relaxed);
            stop_flood.store(true, Ordering::Relaxed);
            return Err(format!(
                "the bridge exited during the soak ({status}): {:?}",
                stderr_lines.lock().map(|l| l.clone()).unwrap_or_default()
            ));
        }
        let now = Instant::now();
        if now >= next_sample {
            if let Some(k) = rss_kib(pid) {
                rss.push((t0.elapsed().as_secs_f64(), k));
            }
            next_sample += RSS_PERIOD;
        }
        if now >= next_line {
            eprintln!(
                "soak: {:>5.0} s, RSS {} KiB, flood {} published",
                t0.elapsed().as_secs_f64(),
                rss.last().map(|r| r.1).unwrap_or(0),
                flood_published.load(Ordering::Relaxed)
            );
            next_line += Duration::from_secs(10);
        }
        std::thread::sleep(
            next_sample
                .min(end)
                .saturating_duration_since(Instant::now()),
        );
    }

    // The lockstep and command clients end (their last requests answered),
    // then SIGTERM with the flood still running.
    stop.store(true, Ordering::Relaxed);
    let lockstep = lockstep
        .join()
        .map_err(|_| "the lockstep thread panicked")??;
    let commands = commands
        .join()
        .map_err(|_| "the command thread panicked")??;
    let term = Instant::now();
    let killed = Command::new("kill")
        .args(["-TERM", &pid.to_string()])
        .status()
        .map(|s| s.success())
        .unwrap_or(false);
    let deadline = term + Duration::from_secs(30);
    let exited = loop {
        match child.try_wait() {
            Ok(Some(_)) => break true,
            _ if Instant::now() > deadline => break false,
            _ => std::thread::sleep(Duration::from_millis(1)),
        }
    };
    let sigterm_ms = term.elapsed().as_secs_f64() * 1e3;
    stop_flood.store(true, Ordering::Relaxed);
    if !exited {
        let _ = child.kill();
    }
    let output = child.wait_with_output().map_err(|e| e.to_string())?;
    let summary: Value = serde_json::from_slice(&output.stdout).unwrap_or(Value::Null);
    let flood_failed = flood.join().map_err(|_| "the flood thread panicked")??;
    if !(killed && exited) {
        return Err(format!(
            "SIGTERM did not end the bridge within 30 s (kill: {killed}); summary {summary}"
        ));
    }

    let figures = Figures {
        args,
        started_utc,
        load_start,
        load_end: loadavg(),
        rss,
        lockstep,
        commands,
        flood_published: flood_published.load(Ordering::Relaxed),
        flood_failed,
        sigterm_ms,
        summary,
    };
    let json = figures.json();
    let text = serde_json::to_string_pretty(&json).map_err(|e| e.to_string())? + "\n";
    write(&args.json, &text)?;
    write(&args.md, &figures.markdown(&json))?;
    eprintln!(
        "soak: wrote {} and {}",
        args.md.display(),
        args.json.display()
    );
    let _ = std::io::stdout().write_all(figures.markdown(&json).as_bytes());
    Ok(())
}

/// `path` relative to the workspace root where it is under it.
fn shown(path: &Path) -> String {
    let path = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
    path.strip_prefix(root())
        .unwrap_or(&path)
        .display()
        .to_string()
}

fn write(path: &Path, text: &str) -> Result<(), String> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    std::fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

struct Figures<'a> {
    args: &'a Args,
    started_utc: String,
    load_start: String,
    load_end: String,
    rss: Vec<(f64, u64)>,
    lockstep: Lockstep,
    commands: Commands,
    flood_published: u64,
    flood_failed: u64,
    sigterm_ms: f64,
    summary: Value,
}

impl Figures<'_> {
    fn json(&self) -> Value {
        let duration = self.args.duration.as_secs_f64();
        let warm_at = (duration * WARM_UP_FRACTION).max(WARM_UP_MIN.as_secs_f64());
        let first = self.rss.first().map(|r| r.1).unwrap_or(0);
        let warm = self
            .rss
            .iter()
            .find(|r| r.0 >= warm_at)
            .map(|r| r.1)
            .unwrap_or(first);
        let last = self.rss.last().map(|r| r.1).unwrap_or(0);
        let max = self.rss.iter().map(|r| r.1).max().unwrap_or(0);
        let s = &self.summary;
        json!({
            "generator": "cargo xtask soak (crates/host-bridge/examples/soak.rs)",
            "started": self.started_utc,
            "duration_s": duration,
            "machine": {
                "cores": std::thread::available_parallelism().map(|n| n.get()).unwrap_or(0),
                "loadavg_start": self.load_start,
                "loadavg_end": self.load_end,
            },
            "bridge": {
                "binary": shown(&self.args.decoy),
                "backend": s["backend"], "precision_bits": s["precision_bits"],
                "segments": s["segments"], "grading_ratio": s["grading_ratio"],
                "uptime_s": s["uptime_s"], "ended_by": s["ended_by"],
                "sigterm_to_exit_ms": self.sigterm_ms,
                "counters": s["counters"], "rejected": s["rejected"],
                "service_time_us": s["service_time_us"],
            },
            "rss_kib": {
                "start": first, "after_warm_up": warm, "warm_up_at_s": warm_at,
                "max": max, "end": last,
                "growth": last as i64 - first as i64,
                "growth_after_warm_up": last as i64 - warm as i64,
                "samples": self.rss.iter().map(|r| json!([(r.0 * 10.0).round() / 10.0, r.1])).collect::<Vec<_>>(),
            },
            "lockstep": {
                "rate_hz": 1.0 / LOCKSTEP_PERIOD.as_secs_f64(),
                "frames": self.lockstep.round_trips.len(),
                "outputs": self.lockstep.outputs,
                "initialising": self.lockstep.initialising,
                "rejected": self.lockstep.rejected,
                "failed": self.lockstep.failed,
                "late": self.lockstep.late,
                "round_trip_us": percentiles_json(&self.lockstep.round_trips.percentiles()),
            },
            "commands": {
                "period_ms": COMMAND_PERIOD.as_secs_f64() * 1e3,
                "answered": self.commands.ok,
                "failed": self.commands.failed,
                "round_trip_us": percentiles_json(&self.commands.round_trips.percentiles()),
            },
            "flood": {
                "published": self.flood_published,
                "publish_errors": self.flood_failed,
            },
        })
    }

    fn markdown(&self, j: &Value) -> String {
        let num = |v: &Value| match v {
            Value::Number(n) => {
                let f = n.as_f64().unwrap_or(0.0);
                if n.is_f64() {
                    format!("{f:.1}")
                } else {
                    group(f as i64)
                }
            }
            Value::String(s) => s.clone(),
            Value::Null => "-".to_owned(),
            other => other.to_string(),
        };
        let b = &j["bridge"];
        let c = &b["counters"];
        let r = &j["rss_kib"];
        let l = &j["lockstep"];
        let k = &j["commands"];
        let minutes = j["duration_s"].as_f64().unwrap_or(0.0) / 60.0;
        let mut md = String::new();
        md.push_str("# Bridge soak\n\n");
        md.push_str(
            "Generated by `cargo xtask soak` (`crates/host-bridge/examples/soak.rs`, also a stage of \
             `cargo xtask bench-report`); do not edit by hand, rerun it. The figures are also in \
             `docs/soak.json` (with the RSS every second).\n\n",
        );
        md.push_str(&format!(
            "The real bridge (`{} bridge --json`, a child process, host backend, {} segments, \
             {}-bit; its own iceoryx2 setup) served for {:.1} min from {}, side by side: a lockstep \
             client at 100 Hz, a free-running flood (valid states flat out, each followed by its \
             wake-up), and a ping every 100 ms; the bridge's RSS (`/proc/<pid>/status` VmRSS) \
             sampled every second; then SIGTERM with the flood still running. {} cores, load \
             average {} at the start, {} at the end. The bounds behind these figures are in \
             docs/bridge.md, \"Serving order and free-running floods\" and \"Memory\".\n\n",
            num(&b["binary"]),
            num(&b["segments"]),
            num(&b["precision_bits"]),
            minutes,
            num(&j["started"]),
            num(&j["machine"]["cores"]),
            num(&j["machine"]["loadavg_start"]),
            num(&j["machine"]["loadavg_end"]),
        ));
        md.push_str("## Memory (RSS of the bridge, KiB)\n\n");
        md.push_str("| start | after warm-up | max | end | growth | growth after warm-up |\n");
        md.push_str("|---:|---:|---:|---:|---:|---:|\n");
        md.push_str(&format!(
            "| {} | {} (at {} s) | {} | {} | {} | {} |\n\n",
            num(&r["start"]),
            num(&r["after_warm_up"]),
            num(&r["warm_up_at_s"]),
            num(&r["max"]),
            num(&r["end"]),
            num(&r["growth"]),
            num(&r["growth_after_warm_up"]),
        ));
        md.push_str("## Round trips, us\n\n");
        md.push_str("| | count | p50 | p99 | p99.9 | max | not answered |\n");
        md.push_str("|---|---:|---:|---:|---:|---:|---:|\n");
        md.push_str(&format!(
            "| lockstep (100 Hz) | {} | {} | {} | {} | {} | {} |\n",
            num(&l["frames"]),
            num(&l["round_trip_us"]["p50"]),
            num(&l["round_trip_us"]["p99"]),
            num(&l["round_trip_us"]["p999"]),
            num(&l["round_trip_us"]["max"]),
            num(&l["failed"]),
        ));
        md.push_str(&format!(
            "| command (ping, every 100 ms) | {} | {} | {} | - | {} | {} |\n",
            num(&k["answered"]),
            num(&k["round_trip_us"]["p50"]),
            num(&k["round_trip_us"]["p99"]),
            num(&k["round_trip_us"]["max"]),
            num(&k["failed"]),
        ));
        md.push_str(&format!(
            "| bridge service time (receive to send, every answer) | - | {} | {} | {} | {} | - |\n\n",
            num(&b["service_time_us"]["p50"]),
            num(&b["service_time_us"]["p99"]),
            num(&b["service_time_us"]["p999"]),
            num(&b["service_time_us"]["max"]),
        ));
        md.push_str(&format!(
            "Lockstep answers: {} outputs, {} rejected (a flood state with a later time reached \
             the controller first: time not increasing), {} while initialising; {} frames started \
             late (the client fell behind its 10 ms slots). The two streams share one \
             controller and one timeline (the wall clock's): a lockstep request is served before the \
             flood's samples already waiting, so those, older than it, are rejected (time not \
             increasing) until the flood's times pass it; most of the flood's rejections are \
             these, and they are cheap, which is why the service time's median is small.\n\n",
            num(&l["outputs"]),
            num(&l["rejected"]),
            num(&l["initialising"]),
            num(&l["late"]),
        ));
        md.push_str("## Frames\n\n");
        md.push_str(
            "| flood published | free-running processed | lost (overwritten unseen) | overruns | lockstep requests | accepted | rejected | commands |\n",
        );
        md.push_str("|---:|---:|---:|---:|---:|---:|---:|---:|\n");
        md.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} |\n\n",
            num(&j["flood"]["published"]),
            num(&c["free_samples"]),
            num(&c["lost"]),
            num(&c["overruns"]),
            num(&c["lockstep_requests"]),
            num(&c["accepted"]),
            num(&b["rejected"]),
            num(&c["commands"]),
        ));
        md.push_str(&format!(
            "Rejections by reason: time not increasing {}, time jump {}, solver failure {}, other {}.\n\n",
            num(&c["time_not_increasing"]),
            num(&c["time_jump"]),
            num(&c["solver_failure"]),
            group(
                b["rejected"].as_i64().unwrap_or(0)
                    - c["time_not_increasing"].as_i64().unwrap_or(0)
                    - c["time_jump"].as_i64().unwrap_or(0)
                    - c["solver_failure"].as_i64().unwrap_or(0)
            ),
        ));
        md.push_str(&format!(
            "SIGTERM during the flood: the bridge exited {:.1} ms later (ended by {}, uptime {} s).\n",
            b["sigterm_to_exit_ms"].as_f64().unwrap_or(0.0),
            num(&b["ended_by"]),
            num(&b["uptime_s"]),
        ));
        md
    }
}

/// `1234567` as `1,234,567`.
fn group(n: i64) -> String {
    let digits = n.unsigned_abs().to_string();
    let mut out = String::new();
    for (i, ch) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(ch);
    }
    if n < 0 { format!("-{out}") } else { out }
}
