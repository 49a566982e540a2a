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
    ALIVE, ERROR_PREFIX, PROTOCOL_PREFIX, Role, ZenohOptions, connect_endpoints, decode, key,
    listen_endpoints, open_session, query_id, zenoh_error,
};

/// How often the gateway's threads look at the stop flag while idle.
const IDLE: Duration = Duration::from_millis(100);
/// Queries and samples waiting for the requests thread at most.
pub const REQUEST_QUEUE: usize = 1024;
/// How long the gateway's threads may take to connect to the bridge.
const READY_TIMEOUT: Duration = Duration::from_secs(10);

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
        // Bounded: a client flooding queries fills it and its further
        // queries end without a reply (each dropped, counted `failed`);
        // a callback never blocks Zenoh's threads.
        let (tx, rx) = mpsc::sync_channel::<Incoming>(REQUEST_QUEUE);
        let enqueue = {
            let counters = Arc::clone(&counters);
            move |tx: &mpsc::SyncSender<Incoming>, item: Incoming| {
                if tx.try_send(item).is_err() {
                    counters.failed.fetch_add(1, Ordering::Relaxed);
                }
            }
        };
        let (lockstep_tx, lockstep_enqueue) = (tx.clone(), enqueue.clone());
        let lockstep = session
            .declare_queryable(key(instance, service::LOCKSTEP))
            .callback(move |q| lockstep_enqueue(&lockstep_tx, Incoming::Lockstep(q)))
            .wait()
            .map_err(|e| zenoh_error("the lockstep queryable", e))?;
        let (commands_tx, commands_enqueue) = (tx.clone(), enqueue.clone());
        let commands = session
            .declare_queryable(key(instance, service::COMMANDS))
            .callback(move |q| commands_enqueue(&commands_tx, Incoming::Command(q)))
            .wait()
            .map_err(|e| zenoh_error("the commands queryable", e))?;
        let state = session
            .declare_subscriber(key(instance, service::STATE))
            .callback(move |s| enqueue(&tx, Incoming::State(s)))
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
        // From here on, a failure stops and joins the threads started.
        let abandon = |threads: Vec<JoinHandle<Result<(), BridgeError>>>, e: BridgeError| {
            stop.store(true, Ordering::Relaxed);
            for t in threads {
                let _ = t.join();
            }
            e
        };
        {
            let (instance, iox, stop, counters, ready) = (
                instance.to_owned(),
                iox.clone(),
                Arc::clone(&stop),
                Arc::clone(&counters),
                ready_tx,
            );
            let spawned = std::thread::Builder::new()
                .name("zenoh-outputs".to_owned())
                .spawn(move || {
                    forward_outputs(&instance, &iox, &outputs, &status, &stop, &counters, &ready)
                });
            match spawned {
                Ok(t) => threads.push(t),
                Err(e) => {
                    return Err(abandon(
                        threads,
                        BridgeError::Ipc(format!("cannot start a thread: {e}")),
                    ));
                }
            }
        }
        let mut gateway_failed = None;
        for _ in 0..2 {
            match ready_rx.recv_timeout(READY_TIMEOUT) {
                Ok(Ok(())) => {}
                Ok(Err(e)) => gateway_failed = Some(e),
                Err(_) => {
                    gateway_failed = Some(BridgeError::Ipc(format!(
                        "the Zenoh gateway's threads did not connect to the bridge within {READY_TIMEOUT:?}"
                    )));
                    break;
                }
            }
        }
        if let Some(e) = gateway_failed {
            return Err(abandon(threads, e));
        }
        let token = match session
            .liveliness()
            .declare_token(key(instance, ALIVE))
            .wait()
        {
            Ok(t) => t,
            Err(e) => return Err(abandon(threads, zenoh_error("the readiness token", e))),
        };
        // What it serves on: the endpoints of the final configuration.
        let effective = crate::remote::effective_config(options)?;
        let mut endpoints: Vec<String> = listen_endpoints(&effective)
            .iter()
            .map(|e| format!("listen {e}"))
            .collect();
        endpoints.extend(
            connect_endpoints(&effective)
                .iter()
                .map(|e| format!("connect {e}")),
        );
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

    /// Withdraws the readiness token (remote clients see no bridge from
    /// then on), stops the threads, and closes the session on a thread of
    /// its own (Zenoh's goodbye to a peer whose link is cut waits 10 s); the
    /// first thread's failure, if any.
    pub fn stop(self) -> Result<GatewaySummary, BridgeError> {
        drop(self._token);
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
        let session = self.session;
        let _ = std::thread::Builder::new()
            .name("zenoh-close".to_owned())
            .spawn(move || {
                let _ = session.close().wait();
            });
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

/// One error reply: [`ERROR_PREFIX`], then `protocol: ` for a payload of
/// another type or size (the client's `BridgeError::Protocol`), then the
/// message.
fn reply_error(query: &Query, e: &BridgeError) {
    let kind = if matches!(e, BridgeError::Protocol(_)) {
        PROTOCOL_PREFIX
    } else {
        ""
    };
    let _ = query.reply_err(format!("{ERROR_PREFIX}{kind}{e}")).wait();
}

/// Requests answered lately, with their answers, per service: how many (16
/// for each of the clients a bridge serves).
pub const ANSWERED_RECORD: usize = 16 * crate::services::MAX_CLIENTS;

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

/// One query of a request-response service: its request decoded and checked
/// (else one error reply, counted `refused`); a query id among the record's
/// answered from it (counted `repeated`); else `serve` (the bridge, over
/// shared memory) answers it, counted in `served` and recorded; a reply
/// Zenoh cannot send counted `failed`.
fn answer_query<Req: Wire, Resp: Wire + Copy>(
    q: &Query,
    what: &str,
    record: &mut Record<Resp>,
    served: &AtomicU64,
    counters: &GatewayCounters,
    instance: &str,
    serve: impl FnOnce(Req) -> Result<Resp, BridgeError>,
) {
    let request = match decode::<Req>(q.payload(), q.attachment(), what) {
        Ok(r) => r,
        Err(e) => {
            counters.refused.fetch_add(1, Ordering::Relaxed);
            return reply_error(q, &e);
        }
    };
    let id = query_id(q.attachment());
    let answer = match record.find(id.as_deref()) {
        Some(answer) => {
            counters.repeated.fetch_add(1, Ordering::Relaxed);
            answer
        }
        None => match serve(request) {
            Ok(answer) => {
                served.fetch_add(1, Ordering::Relaxed);
                record.record(id, answer);
                answer
            }
            Err(e) => return reply_error(q, &e),
        },
    };
    if let Err(e) = reply(q, &answer) {
        counters.failure(instance, &e);
    }
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
            Incoming::Lockstep(q) => answer_query(
                &q,
                "a lockstep query",
                &mut answered.lockstep,
                &counters.lockstep,
                counters,
                instance,
                |state: AircraftState| client.step(&state),
            ),
            Incoming::Command(q) => answer_query(
                &q,
                "a command query",
                &mut answered.commands,
                &counters.commands,
                counters,
                instance,
                |command: Command| client.command_as_sent(command),
            ),
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
    let _ = client.take_outputs();
    while !stop.load(Ordering::Relaxed) {
        // A failure of the shared-memory side is counted and reported, and
        // the thread serves on after a pause (it never ends unseen while the
        // queries are still answered).
        let answers = client.wait_event(IDLE).and_then(|()| client.take_outputs());
        let answers = match answers {
            Ok(a) => a,
            Err(e) => {
                counters.failure(instance, &e);
                std::thread::sleep(IDLE);
                continue;
            }
        };
        for answer in answers {
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
        match client.latest_status() {
            Ok(Some(s)) => {
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
            Ok(None) => {}
            Err(e) => counters.failure(instance, &e),
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
