//! The bridge: one controller (a [`Backend`]) served to any number of clients
//! over the services of [`crate::services`], woken by a WaitSet (no busy loop).

use std::collections::HashMap;
use std::io::{IsTerminal, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use bridge_types::{
    AircraftState, Answer, Command, CommandReply, Counters, Header, Status, ascii_field, event,
    health, kind, reason, result,
};
use decoy_link::{DeviceMessage, HostMessage, StatusFlags};
use iceoryx2::identifiers::UniquePublisherId;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::server::Server;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::waitset::WaitSetRunResult;
use serde::Serialize;

use crate::BridgeError;
use crate::backend::{Backend, ModelInfo};
use crate::convert;
use crate::services::{Ipc, Services, StatusService, create_status_service, node};
use crate::timing::{LatencyHistogram, Percentiles};

/// A run with no valid state for this long is reported degraded (the
/// controller's own link-silence time, on the bridge's clock).
pub const SILENCE: Duration = Duration::from_millis(decoy_controller::SILENCE_MS as u64);
/// The WaitSet's tick: silence supervision, status publication, the status line.
pub const TICK: Duration = Duration::from_millis(100);
/// Status published at least this often.
pub const STATUS_PERIOD: Duration = Duration::from_secs(1);
/// Free-running samples the bridge processes at most between two looks at
/// everything else (commands, lockstep requests, the stop request, SIGINT and
/// SIGTERM, the tick's work): a command or a lockstep request waits for at most
/// one batch however fast the free-running publishers are (docs/bridge.md,
/// "Serving order and free-running floods").
pub const FREE_BATCH: usize = 8;

/// Service time of the answers (receive to send, in the bridge), kept for the
/// status line and the summary in fixed histograms (crate::timing): the
/// bridge's memory does not grow with the answers it sends.
#[derive(Clone, Debug, Default)]
struct Timing {
    /// Every answer since the start (the summary).
    all: LatencyHistogram,
    /// The answers since the last status line.
    window: LatencyHistogram,
}

impl Timing {
    /// Counts one answer's service time.
    fn record(&mut self, took: Duration) {
        self.all.record(took);
        self.window.record(took);
    }

    /// Heap bytes held (the histograms' counts: fixed).
    #[cfg(test)]
    fn heap_bytes(&self) -> usize {
        self.all.heap_bytes() + self.window.heap_bytes()
    }
}

/// What `decoy bridge` prints when it ends.
#[derive(Clone, Debug, Serialize)]
pub struct BridgeSummary {
    /// The instance.
    pub instance: String,
    /// `host` or `qemu`.
    pub backend: String,
    /// The board (`host` or the firmware's).
    pub board: String,
    /// 32 or 64.
    pub precision_bits: u8,
    /// Segments of the model.
    pub segments: u16,
    /// Grading ratio.
    pub grading_ratio: f64,
    /// The CPUs the bridge's thread could run on (Linux's list format, `0-1`;
    /// `--cpu` sets them; empty where unknown).
    pub cpus: String,
    /// Why it ended: `SIGINT`, `SIGTERM`, or `stop request` (a bridge on a
    /// thread).
    pub ended_by: String,
    /// Seconds it ran.
    pub uptime_s: f64,
    /// Every counter.
    pub counters: Counters,
    /// States rejected, all reasons.
    pub rejected: u64,
    /// Service time of the answers in the bridge (receive to send), us: from
    /// a fixed histogram (crate::timing), percentiles within 0.1 %, the
    /// maximum exact.
    pub service_time_us: Percentiles,
    /// Health at the end.
    pub health: String,
    /// The Zenoh gateway's work, when the bridge served across hosts too
    /// (crate::remote).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub zenoh: Option<crate::gateway::GatewaySummary>,
}

impl BridgeSummary {
    /// The human-readable form.
    pub fn text(&self) -> String {
        let c = &self.counters;
        let mut s = format!(
            "bridge {} ({}, f{}, {} segments graded {}, CPUs {}) ended by {} after {:.1} s\n",
            self.instance,
            crate::backend::describe_backend(&self.backend, &self.board),
            self.precision_bits,
            self.segments,
            self.grading_ratio,
            cpu_affinity::shown(&self.cpus),
            self.ended_by,
            self.uptime_s
        );
        s += &format!(
            "  states: {} lockstep, {} free-running; {} answered, {} rejected; {} commands\n",
            c.lockstep_requests, c.free_samples, c.accepted, self.rejected, c.commands
        );
        let reasons: Vec<String> = [
            ("non_finite", c.non_finite),
            ("out_of_range", c.out_of_range),
            ("bad_quaternion", c.bad_quaternion),
            ("time_not_increasing", c.time_not_increasing),
            ("time_jump", c.time_jump),
            ("not_trimmed", c.not_trimmed),
            ("solver_failure", c.solver_failure),
            ("wrong_mode", c.wrong_mode),
            ("wrong_version", c.wrong_version),
            ("wrong_type", c.wrong_type),
            ("backend_failure", c.backend_failure),
        ]
        .iter()
        .filter(|(_, n)| *n > 0)
        .map(|(k, n)| format!("{k} {n}"))
        .collect();
        if !reasons.is_empty() {
            s += &format!("  rejections: {}\n", reasons.join(", "));
        }
        s += &format!(
            "  free-running: {} overruns, {} lost; {} silences; health {}\n",
            c.overruns, c.lost, c.silences, self.health
        );
        let t = &self.service_time_us;
        s += &format!(
            "  service time (us): p50 {:.1}, p99 {:.1}, p99.9 {:.1}, max {:.1}\n",
            t.p50, t.p99, t.p999, t.max
        );
        if let Some(z) = &self.zenoh {
            s += &z.text();
        }
        s
    }
}

/// A running bridge's options.
#[derive(Clone, Debug)]
pub struct BridgeOptions {
    /// The instance's name.
    pub instance: String,
    /// The iceoryx2 configuration.
    pub config: Config,
    /// Draw the status line (on a terminal).
    pub status_line: bool,
    /// Set to stop the bridge (noticed within a tick) as SIGINT would; for a
    /// bridge run on a thread (tests, benchmarks).
    pub stop: Option<Arc<AtomicBool>>,
}

/// The ports of a bridge.
struct Ports {
    lockstep: Server<Ipc, AircraftState, (), Answer, ()>,
    commands: Server<Ipc, Command, (), CommandReply, ()>,
    state: Subscriber<Ipc, AircraftState, ()>,
    outputs: Publisher<Ipc, Answer, ()>,
    status: Publisher<Ipc, Status, ()>,
    to_bridge: Listener<Ipc>,
    from_bridge: Notifier<Ipc>,
    // The services and the node outlive the ports (fields drop in order).
    _status_service: StatusService,
    _services: Services,
    node: Node<Ipc>,
}

/// The bridge's state apart from its ports.
struct Engine {
    instance: String,
    backend: Box<dyn Backend + Send>,
    info: ModelInfo,
    counters: Counters,
    started: Instant,
    last_input: Option<Instant>,
    /// A run is active (the controller has trimmed and not been reset since).
    trimmed: bool,
    health: u8,
    controller_flags: u16,
    last_time_s: f64,
    answer_seq: u32,
    status_seq: u32,
    reply_seq: u32,
    /// Next expected `header.seq` of each free-running publisher.
    free_next: HashMap<UniquePublisherId, u32>,
    timing: Timing,
    last_status: Instant,
    last_line: Instant,
    /// When the tick's work last ran ([`Ports::tick`]).
    last_tick: Instant,
}

impl Engine {
    fn new(instance: &str, backend: Box<dyn Backend + Send>) -> Self {
        let info = backend.info().clone();
        let now = Instant::now();
        Engine {
            instance: instance.to_owned(),
            backend,
            info,
            counters: Counters::default(),
            started: now,
            last_input: None,
            trimmed: false,
            health: health::WAITING,
            controller_flags: 0,
            last_time_s: 0.0,
            answer_seq: 0,
            status_seq: 0,
            reply_seq: 0,
            free_next: HashMap::new(),
            timing: Timing::default(),
            last_status: now,
            last_line: now,
            last_tick: now,
        }
    }

    fn reject(&mut self, request_seq: u32, code: u16) -> Answer {
        let count = self.counters.count_rejection(code);
        self.answer_seq = self.answer_seq.wrapping_add(1);
        convert::rejected_answer(self.answer_seq, request_seq, code, count)
    }

    /// The answer to one state (validated by the header here, then by the controller).
    fn on_state(&mut self, state: &AircraftState) -> Answer {
        let started = Instant::now();
        let seq = state.header.seq;
        if let Some(code) = convert::check_header(&state.header, kind::AIRCRAFT_STATE) {
            return self.reject(seq, code);
        }
        let message = HostMessage::State(convert::to_link_frame(state));
        let answer = match self.backend.handle(message) {
            Ok(DeviceMessage::Output(out)) => {
                self.counters.accepted += 1;
                self.trimmed = out.flags & StatusFlags::TRIMMED != 0;
                self.controller_flags = out.flags & !convert::LINK_SUPERVISION_FLAGS;
                self.last_time_s = out.time_s;
                self.last_input = Some(Instant::now());
                self.health = match self.health {
                    health::DEGRADED | health::RECOVERED => health::RECOVERED,
                    _ => health::RUNNING,
                };
                self.answer_seq = self.answer_seq.wrapping_add(1);
                convert::output_answer(self.answer_seq, convert::output_from_link(&out))
            }
            Ok(DeviceMessage::Rejected(r)) => self.reject(seq, convert::reason_code(r.reason)),
            // The controller is initialising (computing its trim): the state is
            // accepted and answered so.
            Ok(DeviceMessage::Status(status)) if status.flags & StatusFlags::INITIALISING != 0 => {
                self.trimmed = false;
                self.controller_flags = status.flags & !convert::LINK_SUPERVISION_FLAGS;
                self.last_time_s = status.time_s;
                self.last_input = Some(Instant::now());
                self.answer_seq = self.answer_seq.wrapping_add(1);
                convert::initialising_answer(self.answer_seq, seq, &status)
            }
            Ok(other) => {
                eprintln!(
                    "bridge {}: unexpected answer to a state: {other:?}",
                    self.instance
                );
                self.reject(seq, reason::BACKEND_FAILURE)
            }
            Err(e) => {
                eprintln!("bridge {}: {e}", self.instance);
                self.reject(seq, reason::BACKEND_FAILURE)
            }
        };
        let took = started.elapsed();
        self.timing.record(took);
        answer
    }

    fn on_command(&mut self, c: &Command) -> CommandReply {
        self.counters.commands += 1;
        let mut reply_reason = 0;
        let mut ok = true;
        match convert::check_header(&c.header, kind::COMMAND)
            .map(Err)
            .unwrap_or_else(|| convert::to_link_command(c))
        {
            Err(code) => {
                self.counters.count_rejection(code);
                reply_reason = code;
                ok = false;
            }
            Ok(command) => match self.backend.handle(HostMessage::Command(command)) {
                Ok(DeviceMessage::Status(s)) => {
                    self.controller_flags = s.flags & !convert::LINK_SUPERVISION_FLAGS;
                    self.trimmed = s.flags & StatusFlags::TRIMMED != 0;
                    if !self.trimmed {
                        self.health = health::WAITING;
                    }
                }
                Ok(DeviceMessage::Pong { .. }) => {}
                Ok(DeviceMessage::Rejected(r)) => {
                    let code = convert::reason_code(r.reason);
                    self.counters.count_rejection(code);
                    reply_reason = code;
                    ok = false;
                }
                Ok(other) => {
                    eprintln!(
                        "bridge {}: unexpected answer to a command: {other:?}",
                        self.instance
                    );
                    self.counters.count_rejection(reason::BACKEND_FAILURE);
                    reply_reason = reason::BACKEND_FAILURE;
                    ok = false;
                }
                Err(e) => {
                    eprintln!("bridge {}: {e}", self.instance);
                    self.counters.count_rejection(reason::BACKEND_FAILURE);
                    reply_reason = reason::BACKEND_FAILURE;
                    ok = false;
                }
            },
        }
        self.reply_seq = self.reply_seq.wrapping_add(1);
        CommandReply {
            header: Header::new(kind::COMMAND_REPLY, self.reply_seq),
            request_seq: c.header.seq,
            command: c.command,
            result: if ok { result::OK } else { result::REJECTED },
            reason: reply_reason,
            reserved: 0,
            nonce: c.nonce,
            status: self.status(),
        }
    }

    fn status(&mut self) -> Status {
        self.status_seq = self.status_seq.wrapping_add(1);
        Status {
            header: Header::new(kind::STATUS, self.status_seq),
            time_s: self.last_time_s,
            uptime_s: self.started.elapsed().as_secs_f64(),
            input_age_s: self.last_input.map_or(-1.0, |t| t.elapsed().as_secs_f64()),
            counters: self.counters,
            grading_ratio: self.info.grading_ratio,
            segments: self.info.segments,
            capacity: self.info.capacity,
            precision_bits: self.info.precision_bits,
            backend: self.info.backend,
            health: self.health,
            reserved0: 0,
            controller_flags: self.controller_flags,
            link_protocol_version: self.info.link_protocol_version,
            reserved1: 0,
            board: ascii_field(&self.info.board),
            instance: ascii_field(&self.instance),
        }
    }

    /// Silence supervision; true when the health changed.
    fn supervise(&mut self) -> bool {
        if self.trimmed
            && matches!(self.health, health::RUNNING | health::RECOVERED)
            && self.last_input.is_some_and(|t| t.elapsed() >= SILENCE)
        {
            self.health = health::DEGRADED;
            self.counters.silences += 1;
            return true;
        }
        false
    }

    fn status_line(&mut self) {
        let elapsed = self.last_line.elapsed().as_secs_f64();
        if elapsed < 0.5 {
            return;
        }
        let rate = self.timing.window.len() as f64 / elapsed;
        let p = self.timing.window.percentiles();
        let c = &self.counters;
        let line = format!(
            "\r{} [{} f{} {}seg] {:>7.0} states/s  service p50 {:>6.1} us max {:>7.1} us  ok {}  rejected {}  overruns {}  lost {}  {}   ",
            self.instance,
            self.info.board,
            self.info.precision_bits,
            self.info.segments,
            rate,
            p.p50,
            p.max,
            c.accepted,
            c.rejected(),
            c.overruns,
            c.lost,
            health::name(self.health)
        );
        let mut err = std::io::stderr();
        let _ = err.write_all(line.as_bytes());
        let _ = err.flush();
        self.timing.window.clear();
        self.last_line = Instant::now();
    }

    fn summary(&self, ended_by: &str, cpus: String) -> BridgeSummary {
        BridgeSummary {
            instance: self.instance.clone(),
            backend: bridge_types::backend::name(self.info.backend).to_owned(),
            board: self.info.board.clone(),
            precision_bits: self.info.precision_bits,
            segments: self.info.segments,
            grading_ratio: self.info.grading_ratio,
            cpus,
            ended_by: ended_by.to_owned(),
            uptime_s: self.started.elapsed().as_secs_f64(),
            counters: self.counters,
            rejected: self.counters.rejected(),
            service_time_us: self.timing.all.percentiles(),
            health: health::name(self.health).to_owned(),
            zenoh: None,
        }
    }
}

impl Ports {
    fn open(options: &BridgeOptions) -> Result<Self, BridgeError> {
        let node = node(&options.instance, &options.config)?;
        let services = Services::open_or_create(&node, &options.instance)?;
        let ipc = |what: &str, e: String| BridgeError::Ipc(format!("{what}: {e}"));
        let lockstep = services.lockstep.server_builder().create().map_err(|e| {
            BridgeError::Ipc(format!(
                "cannot serve decoy/{}/lockstep ({e:?}): is another bridge with this instance name running?",
                options.instance
            ))
        })?;
        let commands = services
            .commands
            .server_builder()
            .create()
            .map_err(|e| ipc("the commands server", format!("{e:?}")))?;
        let state = services
            .state
            .subscriber_builder()
            .buffer_size(crate::services::STATE_BUFFER)
            .create()
            .map_err(|e| ipc("the state subscriber", format!("{e:?}")))?;
        let outputs = services
            .outputs
            .publisher_builder()
            .create()
            .map_err(|e| ipc("the outputs publisher", format!("{e:?}")))?;
        let to_bridge = services
            .to_bridge
            .listener_builder()
            .create()
            .map_err(|e| ipc("the event listener", format!("{e:?}")))?;
        let from_bridge = services
            .from_bridge
            .notifier_builder()
            .create()
            .map_err(|e| ipc("the event notifier", format!("{e:?}")))?;
        // Last, the readiness mark: the status service and its publisher, once
        // every other service and port exists (crate::services).
        let status_service = create_status_service(&node, &options.instance)?;
        let status = status_service
            .publisher_builder()
            .create()
            .map_err(|e| ipc("the status publisher", format!("{e:?}")))?;
        Ok(Ports {
            lockstep,
            commands,
            state,
            outputs,
            status,
            to_bridge,
            from_bridge,
            _status_service: status_service,
            _services: services,
            node,
        })
    }

    fn notify(&self, id: usize) {
        let _ = self
            .from_bridge
            .notify_with_custom_event_id(EventId::new(id));
    }

    fn publish(&self, answer: &Answer) {
        if let Ok(sample) = self.outputs.loan_uninit() {
            let _ = sample.write_payload(*answer).send();
        }
    }

    fn publish_status(&self, engine: &mut Engine) {
        let status = engine.status();
        if let Ok(sample) = self.status.loan_uninit() {
            let _ = sample.write_payload(status).send();
        }
        engine.last_status = Instant::now();
        self.notify(event::STATUS);
    }

    /// The tick's work: silence supervision, the status (on a change of health
    /// and every [`STATUS_PERIOD`]), the status line.
    fn tick(&self, engine: &mut Engine, status_line: bool) {
        engine.last_tick = Instant::now();
        let changed = engine.supervise();
        if changed || engine.last_status.elapsed() >= STATUS_PERIOD {
            self.publish_status(engine);
        }
        if status_line {
            engine.status_line();
        }
    }

    /// Everything waiting, in rounds until the free-running queue is empty:
    /// each round serves the waiting commands, then the waiting lockstep
    /// requests (at most [`REQUESTS_PER_ROUND`] of each: every client's
    /// requests in flight), then at most [`FREE_BATCH`] free-running samples,
    /// then looks at `halt` (the stop request, SIGINT, SIGTERM) and does the
    /// tick's work when it is due (`tick_due`, or a [`TICK`] since the last).
    /// So however fast free-running samples arrive, a command or a lockstep
    /// request waits for at most one batch of them, and a stop or a signal is
    /// noticed within one round. `Some` when the bridge is to end.
    fn serve(
        &self,
        engine: &mut Engine,
        halt: &Halt<'_>,
        mut tick_due: bool,
        status_line: bool,
    ) -> Result<Option<Ending>, BridgeError> {
        loop {
            self.serve_commands(engine)?;
            self.serve_lockstep(engine)?;
            let drained = self.serve_free(engine)?;
            if let Some(ending) = halt.requested() {
                return Ok(Some(ending));
            }
            if tick_due || engine.last_tick.elapsed() >= TICK {
                self.tick(engine, status_line);
                tick_due = false;
            }
            if drained {
                return Ok(None);
            }
        }
    }

    /// The waiting commands (at most [`REQUESTS_PER_ROUND`]), each answered
    /// and followed by the status.
    fn serve_commands(&self, engine: &mut Engine) -> Result<(), BridgeError> {
        for _ in 0..REQUESTS_PER_ROUND {
            let Some(active) = self
                .commands
                .receive()
                .map_err(|e| BridgeError::Ipc(format!("{e:?}")))?
            else {
                break;
            };
            let reply = engine.on_command(active.payload());
            if let Ok(r) = active.loan_uninit() {
                let _ = r.write_payload(reply).send();
            }
            self.notify(event::COMMAND_REPLY);
            self.publish_status(engine);
        }
        Ok(())
    }

    /// The waiting lockstep requests (at most [`REQUESTS_PER_ROUND`]), each
    /// answered, copied on `outputs`, then followed by the frame's look-ahead
    /// slice.
    fn serve_lockstep(&self, engine: &mut Engine) -> Result<(), BridgeError> {
        for _ in 0..REQUESTS_PER_ROUND {
            let Some(active) = self
                .lockstep
                .receive()
                .map_err(|e| BridgeError::Ipc(format!("{e:?}")))?
            else {
                break;
            };
            engine.counters.lockstep_requests += 1;
            let answer = engine.on_state(active.payload());
            if let Ok(r) = active.loan_uninit() {
                let _ = r.write_payload(answer).send();
            }
            // The copy on `outputs` goes out before the one notification, which
            // announces both: one event per lockstep frame (a listener is woken
            // by any id, so `OUTPUT` would only wake the client a second time).
            self.publish(&answer);
            self.notify(event::ANSWER);
            // The frame's look-ahead slice, once its answer is out.
            engine.backend.background();
        }
        Ok(())
    }

    /// At most [`FREE_BATCH`] free-running samples, in order, each answered on
    /// `outputs` (one `OUTPUT` notification for the batch); true when no
    /// sample is left waiting. Counts `lost` (gaps in a publisher's numbers)
    /// and `overruns` (a sample processed when a later one was waiting).
    fn serve_free(&self, engine: &mut Engine) -> Result<bool, BridgeError> {
        let mut answered = 0;
        let mut drained = false;
        while answered < FREE_BATCH {
            let Some(sample) = self
                .state
                .receive()
                .map_err(|e| BridgeError::Ipc(format!("{e:?}")))?
            else {
                drained = true;
                break;
            };
            answered += 1;
            engine.counters.free_samples += 1;
            let publisher = sample.header().publisher_id();
            let seq = sample.payload().header.seq;
            if let Some(next) = engine.free_next.get(&publisher) {
                let gap = seq.wrapping_sub(*next);
                // A gap is lost samples; a number at or below the expected one
                // (a restarted publisher) starts counting afresh.
                if gap > 0 && gap < u32::MAX / 2 {
                    engine.counters.lost += u64::from(gap);
                }
            }
            engine.free_next.insert(publisher, seq.wrapping_add(1));
            let later_waiting = self.state.has_samples().unwrap_or(false);
            if later_waiting {
                engine.counters.overruns += 1;
            }
            let answer = engine.on_state(sample.payload());
            drop(sample);
            self.publish(&answer);
            engine.backend.background();
            if !later_waiting {
                drained = true;
                break;
            }
        }
        if answered > 0 {
            self.notify(event::OUTPUT);
        }
        Ok(drained)
    }
}

/// Requests of each request-response service served at most in one round of
/// [`Ports::serve`]: every request the clients can have in flight.
pub const REQUESTS_PER_ROUND: usize =
    crate::services::MAX_CLIENTS * crate::services::MAX_ACTIVE_REQUESTS;

/// Why a bridge ends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ending {
    /// SIGINT or SIGTERM.
    Signal,
    /// [`BridgeOptions::stop`].
    StopRequest,
}

/// What ends a bridge, looked at between the rounds of [`Ports::serve`].
struct Halt<'a> {
    stop: Option<&'a AtomicBool>,
    signals: &'a Signals,
    node: &'a Node<Ipc>,
}

impl Halt<'_> {
    /// The stop request, SIGINT or SIGTERM, if one came.
    fn requested(&self) -> Option<Ending> {
        if self.stop.is_some_and(|s| s.load(Ordering::Relaxed)) {
            return Some(Ending::StopRequest);
        }
        if self.signals.received() {
            return Some(Ending::Signal);
        }
        // Without both flags (registration failed) iceoryx2's own record,
        // which this call consumes: the bridge ends at once on it.
        if !self.signals.complete() && self.node.wait(Duration::ZERO).is_err() {
            return Some(Ending::Signal);
        }
        None
    }
}

/// Runs a bridge until SIGINT or SIGTERM (or [`BridgeOptions::stop`]) and
/// returns its summary. Every service and port exists from `ready` on (called
/// once, with the status now): the `status` service, created last, is the
/// clients' readiness mark (crate::services).
pub fn run_bridge(
    options: &BridgeOptions,
    backend: Box<dyn Backend + Send>,
    ready: impl FnOnce(&Status),
) -> Result<BridgeSummary, BridgeError> {
    let ports = Ports::open(options)?;
    // After the node (iceoryx2's handler is in place): signal-hook chains it, so
    // both run; iceoryx2's ends the wait, these flags say which signal it was.
    let signals = Signals::register();
    let mut engine = Engine::new(&options.instance, backend);
    let waitset = WaitSetBuilder::new()
        .create::<Ipc>()
        .map_err(|e| BridgeError::Ipc(format!("cannot create the WaitSet: {e:?}")))?;
    let wake = waitset
        .attach_notification(&ports.to_bridge)
        .map_err(|e| BridgeError::Ipc(format!("cannot attach the listener: {e:?}")))?;
    let tick = waitset
        .attach_interval(TICK)
        .map_err(|e| BridgeError::Ipc(format!("cannot attach the tick: {e:?}")))?;
    ports.publish_status(&mut engine);
    ready(&engine.status());
    let status_line = options.status_line && std::io::stderr().is_terminal();
    let halt = Halt {
        stop: options.stop.as_deref(),
        signals: &signals,
        node: &ports.node,
    };
    let mut failure = None;
    let mut ending = None;
    let outcome = loop {
        let outcome = waitset.wait_and_process(|id| {
            if id.has_event_from(&wake) {
                // Consume the notifications, or the WaitSet keeps waking.
                let _ = ports.to_bridge.try_wait(|_| {});
            }
            match ports.serve(&mut engine, &halt, id.has_event_from(&tick), status_line) {
                Ok(None) => CallbackProgression::Continue,
                Ok(Some(e)) => {
                    ending = Some(e);
                    CallbackProgression::Stop
                }
                Err(e) => {
                    failure = Some(e);
                    CallbackProgression::Stop
                }
            }
        });
        match outcome {
            // Any signal interrupts the wait, SIGCONT after a SIGSTOP included; only
            // SIGINT and SIGTERM (which the node records) end the bridge.
            Ok(WaitSetRunResult::Interrupt)
                if failure.is_none()
                    && ending.is_none()
                    && !signals.received()
                    && ports.node.wait(Duration::ZERO).is_ok() => {}
            outcome => break outcome,
        }
    };
    if status_line {
        eprintln!();
    }
    if let Some(e) = failure {
        return Err(e);
    }
    let ended_by = match (ending, outcome) {
        (Some(Ending::Signal), _) => signals.which(),
        (Some(Ending::StopRequest), _) => "stop request",
        // iceoryx2 reports SIGINT and SIGTERM alike once its handler consumed
        // the signal; the flags chained before it tell them apart.
        (None, Ok(WaitSetRunResult::Interrupt | WaitSetRunResult::TerminationRequest)) => {
            signals.which()
        }
        (None, Ok(_)) => "stop request",
        (None, Err(e)) => return Err(BridgeError::Ipc(format!("the WaitSet failed: {e:?}"))),
    };
    let summary = engine.summary(ended_by, cpu_affinity::current_list());
    drop(tick);
    drop(wake);
    drop(waitset);
    drop(ports);
    Ok(summary)
}

/// Flags set by SIGINT and SIGTERM, registered for the bridge's run (and
/// unregistered after it: bridges on threads come and go in one process).
struct Signals {
    interrupt: Arc<AtomicBool>,
    terminate: Arc<AtomicBool>,
    ids: Vec<signal_hook::SigId>,
}

impl Signals {
    fn register() -> Self {
        let interrupt = Arc::new(AtomicBool::new(false));
        let terminate = Arc::new(AtomicBool::new(false));
        let ids = [
            (signal_hook::consts::SIGINT, &interrupt),
            (signal_hook::consts::SIGTERM, &terminate),
        ]
        .into_iter()
        // A signal that cannot be registered is reported as "SIGINT/SIGTERM".
        .filter_map(|(signal, flag)| signal_hook::flag::register(signal, Arc::clone(flag)).ok())
        .collect();
        Signals {
            interrupt,
            terminate,
            ids,
        }
    }

    /// Whether SIGINT or SIGTERM came.
    fn received(&self) -> bool {
        self.interrupt.load(Ordering::Relaxed) || self.terminate.load(Ordering::Relaxed)
    }

    /// Whether both flags are registered (else [`Signals::received`] may miss one).
    fn complete(&self) -> bool {
        self.ids.len() == 2
    }

    /// The signal that ended the run (SIGTERM if both came).
    fn which(&self) -> &'static str {
        match (
            self.interrupt.load(Ordering::Relaxed),
            self.terminate.load(Ordering::Relaxed),
        ) {
            (_, true) => "SIGTERM",
            (true, false) => "SIGINT",
            (false, false) => "SIGINT/SIGTERM",
        }
    }
}

impl Drop for Signals {
    fn drop(&mut self) {
        for id in self.ids.drain(..) {
            signal_hook::low_level::unregister(id);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 27: the bridge's service-time record (every answer's, for the
    /// summary and the status line) holds the same memory after a million
    /// answers as before the first (it kept every sample, 8 B an answer, before),
    /// and its summary percentiles stay within the histogram's 0.1 %.
    #[test]
    fn service_time_memory_does_not_grow_with_the_answers() {
        let mut t = Timing::default();
        let empty = t.heap_bytes();
        for i in 0..1_000_000u64 {
            t.record(Duration::from_nanos(20_000 + (i % 1000) * 97));
        }
        assert_eq!(t.heap_bytes(), empty, "grew with the answers");
        assert!(empty < 1 << 20, "{empty} bytes");
        let p = t.all.percentiles();
        // Uniform over 20 us + k * 97 ns, k = 0..999: nearest rank p50 at
        // k = 499, max at k = 999.
        let p50 = (20_000.0 + 499.0 * 97.0) / 1e3;
        assert!(p.p50 >= p50 && p.p50 <= p50 * 1.001, "{p:?}");
        assert_eq!(p.max, (20_000.0 + 999.0 * 97.0) / 1e3);
        assert_eq!(t.window.len(), 1_000_000);
    }
}
