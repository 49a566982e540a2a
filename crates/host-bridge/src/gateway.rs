//! The bridge's end of the bridge across hosts (crate::remote, docs/bridge.md
//! §7): a [`ZenohGateway`], two threads that are clients of the bridge's own
//! shared-memory services and a Zenoh session. The requests thread answers
//! every lockstep and command query and forwards every free-running sample,
//! in arrival order, through one client; the outputs thread publishes every
//! answer and status the bridge publishes.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::Duration;

use bridge_types::{AircraftState, Answer, Command, Status, Wire, service};
use iceoryx2::config::Config as IoxConfig;
use zenoh::query::Query;
use zenoh::sample::Sample;
use zenoh::{Session, Wait};

use crate::BridgeError;
use crate::client::BridgeClient;
use crate::remote::{
    ALIVE, ERROR_PREFIX, Role, ZenohOptions, decode, key, open_session, query_id, zenoh_error,
};

/// How often the gateway's threads look at the stop flag while idle.
const IDLE: Duration = Duration::from_millis(100);

/// What the gateway counted (printed in the bridge's summary).
#[derive(Debug, Default)]
pub struct GatewayCounters {
    /// Lockstep queries answered.
    pub lockstep: AtomicU64,
    /// Command queries answered.
    pub commands: AtomicU64,
    /// Free-running samples forwarded.
    pub states: AtomicU64,
    /// Queries and samples refused: wrong tag or size (answered by an error).
    pub refused: AtomicU64,
    /// Answers and statuses published.
    pub published: AtomicU64,
    /// Requests sent again by their client and answered from the record
    /// (the controller did not see them twice).
    pub repeated: AtomicU64,
    /// Replies, forwarded samples and publications that failed (each
    /// reported on stderr; the gateway serves on).
    pub failed: AtomicU64,
}

impl GatewayCounters {
    /// Counts and reports one failure; the gateway serves on (one lost
    /// reply must not end the service of every other client).
    fn failure(&self, instance: &str, e: &BridgeError) {
        self.failed.fetch_add(1, Ordering::Relaxed);
        eprintln!("bridge {instance}: {e}");
    }
}

/// What came in over Zenoh, in arrival order.
enum Incoming {
    Lockstep(Query),
    Command(Query),
    State(Sample),
}

/// The bridge's Zenoh side: running from [`ZenohGateway::start`] until
/// [`ZenohGateway::stop`].
pub struct ZenohGateway {
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<Result<(), BridgeError>>>,
    counters: Arc<GatewayCounters>,
    // Dropped last: the token, then the session.
    _token: zenoh::liveliness::LivelinessToken,
    session: Session,
    endpoints: String,
}

impl ZenohGateway {
    /// Starts serving bridge `instance` (running, ready, in the iceoryx2 setup
    /// `iox`) over Zenoh; returns once the readiness token is declared.
    pub fn start(
        instance: &str,
        iox: &IoxConfig,
        options: &ZenohOptions,
    ) -> Result<Self, BridgeError> {
        crate::services::check_instance(instance)?;
        let session = open_session(options, Role::Bridge)?;
        let stop = Arc::new(AtomicBool::new(false));
        let counters = Arc::new(GatewayCounters::default());
        let (tx, rx) = mpsc::channel::<Incoming>();
        let lockstep_tx = tx.clone();
        let lockstep = session
            .declare_queryable(key(instance, service::LOCKSTEP))
            .callback(move |q| {
                let _ = lockstep_tx.send(Incoming::Lockstep(q));
            })
            .wait()
            .map_err(|e| zenoh_error("the lockstep queryable", e))?;
        let commands_tx = tx.clone();
        let commands = session
            .declare_queryable(key(instance, service::COMMANDS))
            .callback(move |q| {
                let _ = commands_tx.send(Incoming::Command(q));
            })
            .wait()
            .map_err(|e| zenoh_error("the commands queryable", e))?;
        let state = session
            .declare_subscriber(key(instance, service::STATE))
            .callback(move |s| {
                let _ = tx.send(Incoming::State(s));
            })
            .wait()
            .map_err(|e| zenoh_error("the state subscriber", e))?;
        let outputs = session
            .declare_publisher(key(instance, service::OUTPUTS))
            .wait()
            .map_err(|e| zenoh_error("the outputs publisher", e))?;
        let status = session
            .declare_publisher(key(instance, service::STATUS))
            .wait()
            .map_err(|e| zenoh_error("the status publisher", e))?;

        let (ready_tx, ready_rx) = mpsc::channel::<Result<(), BridgeError>>();
        let mut threads = Vec::new();
        {
            let (instance, iox, stop, counters, ready) = (
                instance.to_owned(),
                iox.clone(),
                Arc::clone(&stop),
                Arc::clone(&counters),
                ready_tx.clone(),
            );
            threads.push(
                std::thread::Builder::new()
                    .name("zenoh-requests".to_owned())
                    .spawn(move || {
                        // The queryables and the subscriber live as long as
                        // the thread that answers them.
                        let _ports = (lockstep, commands, state);
                        serve_requests(&instance, &iox, &rx, &stop, &counters, &ready)
                    })
                    .map_err(|e| BridgeError::Ipc(format!("cannot start a thread: {e}")))?,
            );
        }
        {
            let (instance, iox, stop, counters, ready) = (
                instance.to_owned(),
                iox.clone(),
                Arc::clone(&stop),
                Arc::clone(&counters),
                ready_tx,
            );
            threads.push(
                std::thread::Builder::new()
                    .name("zenoh-outputs".to_owned())
                    .spawn(move || {
                        forward_outputs(
                            &instance, &iox, &outputs, &status, &stop, &counters, &ready,
                        )
                    })
                    .map_err(|e| BridgeError::Ipc(format!("cannot start a thread: {e}")))?,
            );
        }
        let mut gateway_failed = None;
        for _ in 0..2 {
            match ready_rx.recv() {
                Ok(Ok(())) => {}
                Ok(Err(e)) => gateway_failed = Some(e),
                Err(_) => {
                    gateway_failed = Some(BridgeError::Ipc(
                        "the Zenoh gateway's thread ended while starting".to_owned(),
                    ))
                }
            }
        }
        if let Some(e) = gateway_failed {
            stop.store(true, Ordering::Relaxed);
            for t in threads {
                let _ = t.join();
            }
            return Err(e);
        }
        let token = session
            .liveliness()
            .declare_token(key(instance, ALIVE))
            .wait()
            .map_err(|e| zenoh_error("the readiness token", e))?;
        let mut endpoints: Vec<String> = options
            .listen
            .iter()
            .map(|e| format!("listen {e}"))
            .collect();
        endpoints.extend(options.connect.iter().map(|e| format!("connect {e}")));
        if let Some(f) = &options.config_file {
            endpoints.push(format!("config {}", f.display()));
        }
        if options.users_file.is_some() {
            endpoints.push("user/password authentication".to_owned());
        }
        Ok(ZenohGateway {
            stop,
            threads,
            counters,
            _token: token,
            session,
            endpoints: endpoints.join(", "),
        })
    }

    /// What the gateway serves on, for the bridge's messages.
    pub fn describe(&self) -> &str {
        &self.endpoints
    }

    /// The counters so far.
    pub fn counters(&self) -> &GatewayCounters {
        &self.counters
    }

    /// Stops the threads, closes the session; the first thread's failure, if any.
    pub fn stop(self) -> Result<GatewaySummary, BridgeError> {
        self.stop.store(true, Ordering::Relaxed);
        let mut failure = None;
        for t in self.threads {
            match t.join() {
                Ok(Ok(())) => {}
                Ok(Err(e)) => failure = failure.or(Some(e)),
                Err(_) => {
                    failure = failure.or(Some(BridgeError::Ipc(
                        "a Zenoh gateway thread panicked".to_owned(),
                    )))
                }
            }
        }
        drop(self._token);
        let _ = self.session.close().wait();
        if let Some(e) = failure {
            return Err(e);
        }
        let c = &self.counters;
        Ok(GatewaySummary {
            endpoints: self.endpoints,
            lockstep: c.lockstep.load(Ordering::Relaxed),
            commands: c.commands.load(Ordering::Relaxed),
            states: c.states.load(Ordering::Relaxed),
            refused: c.refused.load(Ordering::Relaxed),
            published: c.published.load(Ordering::Relaxed),
            repeated: c.repeated.load(Ordering::Relaxed),
            failed: c.failed.load(Ordering::Relaxed),
        })
    }
}

/// What a gateway did, at its end.
#[derive(Clone, Debug, serde::Serialize)]
pub struct GatewaySummary {
    /// Where it served.
    pub endpoints: String,
    /// Lockstep queries answered.
    pub lockstep: u64,
    /// Command queries answered.
    pub commands: u64,
    /// Free-running samples forwarded.
    pub states: u64,
    /// Queries and samples refused (wrong type tag or size).
    pub refused: u64,
    /// Answers and statuses published.
    pub published: u64,
    /// Requests sent again by their client and answered from the record.
    pub repeated: u64,
    /// Replies, forwarded samples and publications that failed.
    pub failed: u64,
}

impl GatewaySummary {
    /// One line for the bridge's summary.
    pub fn text(&self) -> String {
        format!(
            "  zenoh ({}): {} lockstep, {} commands, {} free-running states, {} refused, {} answered again; {} publications; {} failed\n",
            self.endpoints,
            self.lockstep,
            self.commands,
            self.states,
            self.refused,
            self.repeated,
            self.published,
            self.failed
        )
    }
}

fn connect_local(instance: &str, iox: &IoxConfig, role: &str) -> Result<BridgeClient, BridgeError> {
    let node = format!("zenoh-{role}-{instance}-{}", std::process::id());
    let mut client = BridgeClient::connect(instance, &node, iox)?;
    // The bridge's own clients wait as long as a remote client would.
    client.set_timeout(crate::client::ANSWER_TIMEOUT);
    Ok(client)
}

fn reply<T: Wire>(query: &Query, value: &T) -> Result<(), BridgeError> {
    query
        .reply(query.key_expr().clone(), value.as_wire_bytes().to_vec())
        .attachment(T::tag())
        .wait()
        .map_err(|e| zenoh_error("replying", e))
}

fn reply_error(query: &Query, e: &BridgeError) {
    let _ = query.reply_err(format!("{ERROR_PREFIX}{e}")).wait();
}

/// Requests answered lately, with their answers, per service: how many.
pub const ANSWERED_RECORD: usize = 16;

/// The ids of the last [`ANSWERED_RECORD`] queries of a service and their
/// answers. A query with one of these ids is its client sending again a query
/// Zenoh ended without its reply (crate::remote): it gets the recorded
/// answer, and the controller does not see the frame a second time (exactly
/// once). A query without an id is always served.
struct Record<A> {
    entries: std::collections::VecDeque<(String, A)>,
}

impl<A> Default for Record<A> {
    fn default() -> Self {
        Record {
            entries: std::collections::VecDeque::with_capacity(ANSWERED_RECORD),
        }
    }
}

impl<A: Copy> Record<A> {
    fn find(&self, id: Option<&str>) -> Option<A> {
        let id = id?;
        self.entries
            .iter()
            .rev()
            .find(|(r, _)| r == id)
            .map(|(_, a)| *a)
    }

    fn record(&mut self, id: Option<String>, answer: A) {
        let Some(id) = id else {
            return;
        };
        if self.entries.len() == ANSWERED_RECORD {
            self.entries.pop_front();
        }
        self.entries.push_back((id, answer));
    }
}

/// The records of the two request-response services.
#[derive(Default)]
struct Answered {
    lockstep: Record<Answer>,
    commands: Record<bridge_types::CommandReply>,
}

/// The requests thread: every lockstep query, command query and free-running
/// sample, in arrival order, through one shared-memory client of the bridge.
fn serve_requests(
    instance: &str,
    iox: &IoxConfig,
    rx: &mpsc::Receiver<Incoming>,
    stop: &AtomicBool,
    counters: &GatewayCounters,
    ready: &mpsc::Sender<Result<(), BridgeError>>,
) -> Result<(), BridgeError> {
    let mut client = match connect_local(instance, iox, "req") {
        Ok(c) => {
            let _ = ready.send(Ok(()));
            c
        }
        Err(e) => {
            let _ = ready.send(Err(e));
            return Ok(());
        }
    };
    let mut answered = Answered::default();
    while !stop.load(Ordering::Relaxed) {
        let incoming = match rx.recv_timeout(IDLE) {
            Ok(i) => i,
            Err(mpsc::RecvTimeoutError::Timeout) => continue,
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
        };
        match incoming {
            Incoming::Lockstep(q) => {
                match decode::<AircraftState>(q.payload(), q.attachment(), "a lockstep query") {
                    Ok(state) => {
                        let id = query_id(q.attachment());
                        if let Some(answer) = answered.lockstep.find(id.as_deref()) {
                            counters.repeated.fetch_add(1, Ordering::Relaxed);
                            if let Err(e) = reply(&q, &answer) {
                                counters.failure(instance, &e);
                            }
                            continue;
                        }
                        match client.step(&state) {
                            Ok(answer) => {
                                counters.lockstep.fetch_add(1, Ordering::Relaxed);
                                answered.lockstep.record(id, answer);
                                if let Err(e) = reply(&q, &answer) {
                                    counters.failure(instance, &e);
                                }
                            }
                            Err(e) => reply_error(&q, &e),
                        }
                    }
                    Err(e) => {
                        counters.refused.fetch_add(1, Ordering::Relaxed);
                        reply_error(&q, &e);
                    }
                }
            }
            Incoming::Command(q) => {
                match decode::<Command>(q.payload(), q.attachment(), "a command query") {
                    Ok(command) => {
                        let id = query_id(q.attachment());
                        if let Some(r) = answered.commands.find(id.as_deref()) {
                            counters.repeated.fetch_add(1, Ordering::Relaxed);
                            if let Err(e) = reply(&q, &r) {
                                counters.failure(instance, &e);
                            }
                            continue;
                        }
                        match client.command_as_sent(command) {
                            Ok(r) => {
                                counters.commands.fetch_add(1, Ordering::Relaxed);
                                answered.commands.record(id, r);
                                if let Err(e) = reply(&q, &r) {
                                    counters.failure(instance, &e);
                                }
                            }
                            Err(e) => reply_error(&q, &e),
                        }
                    }
                    Err(e) => {
                        counters.refused.fetch_add(1, Ordering::Relaxed);
                        reply_error(&q, &e);
                    }
                }
            }
            Incoming::State(s) => {
                match decode::<AircraftState>(Some(s.payload()), s.attachment(), "a state sample") {
                    Ok(state) => {
                        counters.states.fetch_add(1, Ordering::Relaxed);
                        if let Err(e) = client.publish(&state) {
                            counters.failure(instance, &e);
                        }
                    }
                    // A sample has no reply: counted, and the bridge's summary shows it.
                    Err(_) => {
                        counters.refused.fetch_add(1, Ordering::Relaxed);
                    }
                }
            }
        }
    }
    Ok(())
}

/// The outputs thread: every answer and status the bridge publishes, published
/// again over Zenoh.
fn forward_outputs(
    instance: &str,
    iox: &IoxConfig,
    outputs: &zenoh::pubsub::Publisher<'_>,
    status: &zenoh::pubsub::Publisher<'_>,
    stop: &AtomicBool,
    counters: &GatewayCounters,
    ready: &mpsc::Sender<Result<(), BridgeError>>,
) -> Result<(), BridgeError> {
    let mut client = match connect_local(instance, iox, "out") {
        Ok(c) => {
            let _ = ready.send(Ok(()));
            c
        }
        Err(e) => {
            let _ = ready.send(Err(e));
            return Ok(());
        }
    };
    // Answers from before this client existed (the service's history) are
    // not forwarded: a remote subscriber sees answers from its own start on.
    let _ = client.take_outputs()?;
    while !stop.load(Ordering::Relaxed) {
        client.wait_event(IDLE)?;
        for answer in client.take_outputs()? {
            match outputs
                .put(answer.as_wire_bytes().to_vec())
                .attachment(Answer::tag())
                .wait()
            {
                Ok(()) => counters.published.fetch_add(1, Ordering::Relaxed),
                Err(e) => {
                    counters.failure(instance, &zenoh_error("publishing an answer", e));
                    0
                }
            };
        }
        if let Some(s) = client.latest_status()? {
            match status
                .put(s.as_wire_bytes().to_vec())
                .attachment(Status::tag())
                .wait()
            {
                Ok(()) => counters.published.fetch_add(1, Ordering::Relaxed),
                Err(e) => {
                    counters.failure(instance, &zenoh_error("publishing a status", e));
                    0
                }
            };
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The record answers the ids it holds, the newest [`ANSWERED_RECORD`],
    /// and never a query without an id.
    #[test]
    fn the_record_holds_the_last_ids() {
        let mut r = Record::<u32>::default();
        r.record(None, 1);
        assert_eq!(r.find(None), None);
        for n in 0..(ANSWERED_RECORD as u32 + 4) {
            r.record(Some(format!("s:{n}")), n);
        }
        assert_eq!(r.find(Some("s:3")), None, "evicted");
        assert_eq!(r.find(Some("s:4")), Some(4));
        let last = ANSWERED_RECORD as u32 + 3;
        assert_eq!(r.find(Some(&format!("s:{last}"))), Some(last));
        assert_eq!(r.find(Some("t:4")), None);
    }
}
