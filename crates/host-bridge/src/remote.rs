//! The bridge across hosts over Zenoh (docs/bridge.md, "Across hosts").
//!
//! `decoy bridge --zenoh-listen ENDPOINT` serves the instance's services over
//! Zenoh as well as over shared memory, through a [`ZenohGateway`]: two
//! threads that are clients of the bridge's own shared-memory services (so a
//! remote client's frames go through the same engine, in the same order, with
//! the same bits as a local client's) and a Zenoh session that carries them:
//!
//! | key expression | Zenoh | payload |
//! |---|---|---|
//! | `decoy/NAME/lockstep` | queryable, one reply per query | AircraftState -> Answer |
//! | `decoy/NAME/commands` | queryable, one reply per query | Command -> CommandReply |
//! | `decoy/NAME/state` | the bridge subscribes | AircraftState (free-running) |
//! | `decoy/NAME/outputs` | the bridge publishes | every Answer |
//! | `decoy/NAME/status` | the bridge publishes | Status |
//! | `decoy/NAME/alive` | liveliness token | the readiness mark |
//!
//! Every payload is the wire type's bytes exactly as in shared memory
//! ([`Wire`]), with the type's tag (type name and size,
//! `decoy.bridge.v3.Answer/392`) as the attachment; both sides check it and a
//! mismatch is a typed error ([`BridgeError::Protocol`]), as iceoryx2 refuses
//! a port of another type. A query the bridge cannot answer gets one error
//! reply saying why.
//!
//! **Security.** Multicast and gossip scouting are off and nothing listens
//! unless an endpoint is given; an endpoint beyond loopback is refused unless
//! the bridge authenticates its peers (`--zenoh-users FILE`, Zenoh's
//! user/password authentication: only the named users connect) or the user
//! says `--zenoh-unauthenticated`. TLS (and client certificates) come from a
//! Zenoh configuration file (`--zenoh-config`).
//!
//! **Readiness.** The gateway declares `decoy/NAME/alive` once its queryables,
//! subscriber, publishers and its two shared-memory clients exist; a remote
//! client waits for that token before its first request, as a local client
//! waits for the status publisher (crate::services).

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use bridge_types::{
    AircraftState, Answer, Command, CommandReply, SERVICE_ROOT, Status, Wire, service,
};
use iceoryx2::config::Config as IoxConfig;
use zenoh::handlers::{FifoChannelHandler, RingChannel, RingChannelHandler};
use zenoh::query::{Query, QueryTarget, Reply};
use zenoh::sample::Sample;
use zenoh::{Session, Wait};

use crate::BridgeError;
use crate::client::BridgeClient;

/// The liveliness token of a serving gateway: `decoy/NAME/alive`.
pub const ALIVE: &str = "alive";
/// How long a remote client waits for the bridge's session and readiness mark.
pub const REMOTE_CONNECT_TIMEOUT: Duration = Duration::from_secs(5);
/// How often the gateway's threads look at the stop flag while idle.
const IDLE: Duration = Duration::from_millis(100);
/// Answers a remote client keeps from the `outputs` publication until it
/// takes them (the oldest go first: bounded memory).
pub const REMOTE_OUTPUTS_BUFFER: usize = crate::services::OUTPUTS_BUFFER;

/// The key expression of `service` of `instance`: `decoy/NAME/SERVICE`.
pub fn key(instance: &str, service: &str) -> String {
    format!("{SERVICE_ROOT}/{instance}/{service}")
}

/// How one end of the Zenoh transport is configured.
#[derive(Clone, Debug, Default)]
pub struct ZenohOptions {
    /// Endpoints to listen on (`tcp/127.0.0.1:7447`, `tls/10.0.0.1:7447`).
    pub listen: Vec<String>,
    /// Endpoints to connect to.
    pub connect: Vec<String>,
    /// A Zenoh configuration file (JSON5) read first: TLS, certificates,
    /// anything Zenoh configures; the options above and the scouting settings
    /// are applied over it.
    pub config_file: Option<PathBuf>,
    /// The bridge: the users allowed to connect (Zenoh's user/password
    /// dictionary, a `user:password` per line); peers without these
    /// credentials are refused at the handshake.
    pub users_file: Option<PathBuf>,
    /// A client: the file holding its `user:password` (one line).
    pub credentials_file: Option<PathBuf>,
    /// The bridge: listen beyond loopback without authentication.
    pub unauthenticated: bool,
}

fn zenoh_error(what: &str, e: impl std::fmt::Display) -> BridgeError {
    BridgeError::Ipc(format!("Zenoh: {what}: {e}"))
}

fn insert(config: &mut zenoh::Config, key: &str, value: &str) -> Result<(), BridgeError> {
    config
        .insert_json5(key, value)
        .map_err(|e| BridgeError::Usage(format!("Zenoh configuration {key} = {value}: {e}")))
}

fn json_list(items: &[String]) -> String {
    serde_json::to_string(items).unwrap_or_else(|_| "[]".to_owned())
}

/// Whether `endpoint` (`proto/host:port[#...]`) is on loopback only.
pub fn is_loopback(endpoint: &str) -> bool {
    let address = endpoint.split('#').next().unwrap_or(endpoint);
    let Some((_, locator)) = address.split_once('/') else {
        return false;
    };
    let host = match locator.rsplit_once(':') {
        Some((h, _)) => h,
        None => locator,
    };
    let host = host.trim_start_matches('[').trim_end_matches(']');
    if host == "localhost" {
        return true;
    }
    host.parse::<std::net::IpAddr>()
        .is_ok_and(|ip| ip.is_loopback())
}

/// `user:password` of a credentials file's first line.
fn read_credentials(path: &PathBuf) -> Result<(String, String), BridgeError> {
    let text = std::fs::read_to_string(path).map_err(|e| {
        BridgeError::Usage(format!(
            "cannot read the Zenoh credentials {}: {e}",
            path.display()
        ))
    })?;
    let line = text.lines().next().unwrap_or("").trim();
    match line.split_once(':') {
        Some((user, password)) if !user.is_empty() && !password.is_empty() => {
            Ok((user.to_owned(), password.to_owned()))
        }
        _ => Err(BridgeError::Usage(format!(
            "the Zenoh credentials {} must hold one line `user:password`",
            path.display()
        ))),
    }
}

fn check_users_file(path: &PathBuf) -> Result<(), BridgeError> {
    let text = std::fs::read_to_string(path).map_err(|e| {
        BridgeError::Usage(format!(
            "cannot read the Zenoh users {}: {e}",
            path.display()
        ))
    })?;
    let mut users = 0;
    for (n, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        match line.split_once(':') {
            Some((u, p)) if !u.is_empty() && !p.is_empty() => users += 1,
            _ => {
                return Err(BridgeError::Usage(format!(
                    "{} line {}: expected `user:password`",
                    path.display(),
                    n + 1
                )));
            }
        }
    }
    if users == 0 {
        return Err(BridgeError::Usage(format!(
            "the Zenoh users {} name nobody: no peer could connect",
            path.display()
        )));
    }
    Ok(())
}

/// Which end a configuration is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    /// The bridge: a peer that listens (and may connect).
    Bridge,
    /// A client: connects, never listens.
    Client,
}

fn config(options: &ZenohOptions, role: Role) -> Result<zenoh::Config, BridgeError> {
    let mut c = match &options.config_file {
        Some(path) => zenoh::Config::from_file(path).map_err(|e| {
            BridgeError::Usage(format!(
                "cannot read the Zenoh configuration {}: {e}",
                path.display()
            ))
        })?,
        None => zenoh::Config::default(),
    };
    insert(&mut c, "scouting/multicast/enabled", "false")?;
    insert(&mut c, "scouting/gossip/enabled", "false")?;
    insert(&mut c, "adminspace/enabled", "false")?;
    match role {
        Role::Bridge => {
            let from_file = options.config_file.is_some();
            if options.listen.is_empty() && options.connect.is_empty() && !from_file {
                return Err(BridgeError::Usage(
                    "the bridge over Zenoh needs --zenoh-listen, --zenoh-connect or --zenoh-config"
                        .to_owned(),
                ));
            }
            let open: Vec<&String> = options.listen.iter().filter(|e| !is_loopback(e)).collect();
            if !open.is_empty() && options.users_file.is_none() && !options.unauthenticated {
                return Err(BridgeError::Usage(format!(
                    "--zenoh-listen {} is beyond loopback: give --zenoh-users FILE (only those users connect) or say --zenoh-unauthenticated",
                    open[0]
                )));
            }
            insert(&mut c, "mode", "\"peer\"")?;
            if !options.listen.is_empty() || !from_file {
                insert(&mut c, "listen/endpoints", &json_list(&options.listen))?;
            }
        }
        Role::Client => {
            if options.connect.is_empty() && options.config_file.is_none() {
                return Err(BridgeError::Usage(
                    "a client over Zenoh needs --zenoh-connect ENDPOINT".to_owned(),
                ));
            }
            insert(&mut c, "mode", "\"client\"")?;
            insert(&mut c, "listen/endpoints", "[]")?;
            // Keep trying while a bridge starts, then fail with a typed error.
            insert(
                &mut c,
                "connect/timeout_ms",
                &REMOTE_CONNECT_TIMEOUT.as_millis().to_string(),
            )?;
        }
    }
    if !options.connect.is_empty() {
        insert(&mut c, "connect/endpoints", &json_list(&options.connect))?;
    }
    if let Some(users) = &options.users_file {
        check_users_file(users)?;
        let path = users.display().to_string();
        insert(
            &mut c,
            "transport/auth/usrpwd/dictionary_file",
            &serde_json::to_string(&path).unwrap_or_default(),
        )?;
    }
    if let Some(file) = &options.credentials_file {
        let (user, password) = read_credentials(file)?;
        insert(
            &mut c,
            "transport/auth/usrpwd/user",
            &serde_json::to_string(&user).unwrap_or_default(),
        )?;
        insert(
            &mut c,
            "transport/auth/usrpwd/password",
            &serde_json::to_string(&password).unwrap_or_default(),
        )?;
    }
    Ok(c)
}

/// Checks a bridge's Zenoh options as [`ZenohGateway::start`] will (files
/// read, endpoints beyond loopback) without opening a session, so that bad
/// options are a usage error before the bridge starts.
pub fn check_bridge_options(options: &ZenohOptions) -> Result<(), BridgeError> {
    config(options, Role::Bridge).map(|_| ())
}

/// Checks a client's Zenoh options as [`BridgeClient::connect_zenoh`] will.
pub fn check_client_options(options: &ZenohOptions) -> Result<(), BridgeError> {
    config(options, Role::Client).map(|_| ())
}

fn open_session(options: &ZenohOptions, role: Role) -> Result<Session, BridgeError> {
    let c = config(options, role)?;
    zenoh::open(c).wait().map_err(|e| match role {
        Role::Bridge => BridgeError::Ipc(format!(
            "Zenoh: cannot open the bridge's session (listen {}, connect {}): {e}",
            json_list(&options.listen),
            json_list(&options.connect)
        )),
        Role::Client => BridgeError::NoBridge(format!(
            "Zenoh: no bridge reachable at {} within {:?}: {e}",
            json_list(&options.connect),
            REMOTE_CONNECT_TIMEOUT
        )),
    })
}

/// The tag carried beside a payload, as text.
fn tag_of(attachment: Option<&zenoh::bytes::ZBytes>) -> String {
    attachment
        .map(|a| String::from_utf8_lossy(&a.to_bytes()).into_owned())
        .unwrap_or_default()
}

/// A payload of type `T` with its tag checked.
fn decode<T: Wire>(
    payload: Option<&zenoh::bytes::ZBytes>,
    attachment: Option<&zenoh::bytes::ZBytes>,
    what: &str,
) -> Result<T, BridgeError> {
    let tag = tag_of(attachment);
    let expected = T::tag();
    if tag != expected {
        return Err(BridgeError::Protocol(format!(
            "{what}: the payload is {}, expected {expected} (another protocol version or layout)",
            if tag.is_empty() { "untagged" } else { &tag }
        )));
    }
    let bytes = payload.map(|p| p.to_bytes()).unwrap_or_default();
    T::from_wire_bytes(&bytes).ok_or_else(|| {
        BridgeError::Protocol(format!(
            "{what}: {} bytes, {expected} has {}",
            bytes.len(),
            std::mem::size_of::<T>()
        ))
    })
}

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
}

impl GatewaySummary {
    /// One line for the bridge's summary.
    pub fn text(&self) -> String {
        format!(
            "  zenoh ({}): {} lockstep, {} commands, {} free-running states, {} refused; {} publications\n",
            self.endpoints, self.lockstep, self.commands, self.states, self.refused, self.published
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
    let _ = query.reply_err(e.to_string()).wait();
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
    while !stop.load(Ordering::Relaxed) {
        let incoming = match rx.recv_timeout(IDLE) {
            Ok(i) => i,
            Err(mpsc::RecvTimeoutError::Timeout) => continue,
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
        };
        match incoming {
            Incoming::Lockstep(q) => {
                match decode::<AircraftState>(q.payload(), q.attachment(), "a lockstep query") {
                    Ok(state) => match client.step(&state) {
                        Ok(answer) => {
                            counters.lockstep.fetch_add(1, Ordering::Relaxed);
                            reply(&q, &answer)?;
                        }
                        Err(e) => reply_error(&q, &e),
                    },
                    Err(e) => {
                        counters.refused.fetch_add(1, Ordering::Relaxed);
                        reply_error(&q, &e);
                    }
                }
            }
            Incoming::Command(q) => {
                match decode::<Command>(q.payload(), q.attachment(), "a command query") {
                    Ok(command) => match client.command_as_sent(command) {
                        Ok(r) => {
                            counters.commands.fetch_add(1, Ordering::Relaxed);
                            reply(&q, &r)?;
                        }
                        Err(e) => reply_error(&q, &e),
                    },
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
                        client.publish(&state)?;
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
            outputs
                .put(answer.as_wire_bytes().to_vec())
                .attachment(Answer::tag())
                .wait()
                .map_err(|e| zenoh_error("publishing an answer", e))?;
            counters.published.fetch_add(1, Ordering::Relaxed);
        }
        if let Some(s) = client.latest_status()? {
            status
                .put(s.as_wire_bytes().to_vec())
                .attachment(Status::tag())
                .wait()
                .map_err(|e| zenoh_error("publishing a status", e))?;
            counters.published.fetch_add(1, Ordering::Relaxed);
        }
    }
    Ok(())
}

/// A client's end of the Zenoh transport (inside [`BridgeClient`]).
pub(crate) struct ZenohClient {
    session: Session,
    lockstep_key: String,
    commands_key: String,
    state: zenoh::pubsub::Publisher<'static>,
    outputs: zenoh::pubsub::Subscriber<RingChannelHandler<Sample>>,
    status: zenoh::pubsub::Subscriber<RingChannelHandler<Sample>>,
    /// An answer received while waiting ([`ZenohClient::wait_event`]), not yet taken.
    stash: Vec<Answer>,
    instance: String,
}

impl ZenohClient {
    /// Connects to bridge `instance` over Zenoh and waits (up to `timeout`)
    /// for its readiness token.
    pub(crate) fn connect(
        instance: &str,
        options: &ZenohOptions,
        timeout: Duration,
    ) -> Result<Self, BridgeError> {
        crate::services::check_instance(instance)?;
        let session = open_session(options, Role::Client)?;
        let outputs = session
            .declare_subscriber(key(instance, service::OUTPUTS))
            .with(RingChannel::new(REMOTE_OUTPUTS_BUFFER))
            .wait()
            .map_err(|e| zenoh_error("the outputs subscriber", e))?;
        let status = session
            .declare_subscriber(key(instance, service::STATUS))
            .with(RingChannel::new(4))
            .wait()
            .map_err(|e| zenoh_error("the status subscriber", e))?;
        let state = session
            .declare_publisher(key(instance, service::STATE))
            .wait()
            .map_err(|e| zenoh_error("the state publisher", e))?;
        let client = ZenohClient {
            lockstep_key: key(instance, service::LOCKSTEP),
            commands_key: key(instance, service::COMMANDS),
            session,
            state,
            outputs,
            status,
            stash: Vec::new(),
            instance: instance.to_owned(),
        };
        client.wait_until_ready(timeout, options)?;
        Ok(client)
    }

    fn wait_until_ready(
        &self,
        timeout: Duration,
        options: &ZenohOptions,
    ) -> Result<(), BridgeError> {
        let deadline = Instant::now() + timeout;
        let token = key(&self.instance, ALIVE);
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let replies = self
                .session
                .liveliness()
                .get(&token)
                .timeout(
                    left.max(Duration::from_millis(1))
                        .min(Duration::from_millis(500)),
                )
                .wait()
                .map_err(|e| zenoh_error("asking for the readiness token", e))?;
            if let Ok(reply) = replies.recv()
                && reply.result().is_ok()
            {
                return Ok(());
            }
            if Instant::now() >= deadline {
                return Err(BridgeError::NoBridge(format!(
                    "no bridge named {:?} answers over Zenoh at {} (no {token} token within {timeout:?}); start one with `decoy bridge --instance {} --zenoh-listen ENDPOINT`",
                    self.instance,
                    json_list(&options.connect),
                    self.instance
                )));
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// One query: `request` to `key`, its one reply of type `R` within `timeout`.
    fn query<Q: Wire, R: Wire>(
        &self,
        key: &str,
        request: &Q,
        timeout: Duration,
        what: &str,
    ) -> Result<R, BridgeError> {
        let replies: FifoChannelHandler<Reply> = self
            .session
            .get(key)
            .payload(request.as_wire_bytes().to_vec())
            .attachment(Q::tag())
            .target(QueryTarget::BestMatching)
            .timeout(timeout)
            .wait()
            .map_err(|e| zenoh_error("sending a query", e))?;
        let deadline = Instant::now() + timeout;
        // The one reply; the channel closes when the query is finalised.
        let first = replies
            .recv_deadline(deadline + Duration::from_millis(50))
            .map_err(|e| zenoh_error("receiving a reply", e))?;
        let Some(reply) = first else {
            return Err(BridgeError::NoAnswer(format!(
                "no {what} from bridge {:?} over Zenoh within {timeout:?}: is the link up and `decoy bridge --instance {} --zenoh-listen ...` running?",
                self.instance, self.instance
            )));
        };
        match reply.result() {
            Ok(sample) => decode::<R>(Some(sample.payload()), sample.attachment(), what),
            Err(e) => {
                let text = String::from_utf8_lossy(&e.payload().to_bytes()).into_owned();
                Err(if text.contains("expected decoy.bridge") {
                    BridgeError::Protocol(format!("bridge {:?}: {text}", self.instance))
                } else {
                    BridgeError::NoAnswer(format!(
                        "bridge {:?} could not answer: {text}",
                        self.instance
                    ))
                })
            }
        }
    }

    pub(crate) fn step(
        &self,
        state: &AircraftState,
        timeout: Duration,
    ) -> Result<Answer, BridgeError> {
        self.query(&self.lockstep_key, state, timeout, "answer")
    }

    pub(crate) fn command(
        &self,
        c: &Command,
        timeout: Duration,
    ) -> Result<CommandReply, BridgeError> {
        self.query(&self.commands_key, c, timeout, "command reply")
    }

    pub(crate) fn publish(&self, state: &AircraftState) -> Result<(), BridgeError> {
        self.state
            .put(state.as_wire_bytes().to_vec())
            .attachment(AircraftState::tag())
            .wait()
            .map_err(|e| zenoh_error("publishing a state", e))
    }

    fn answer_of(sample: &Sample) -> Result<Answer, BridgeError> {
        decode::<Answer>(
            Some(sample.payload()),
            sample.attachment(),
            "an outputs sample",
        )
    }

    pub(crate) fn take_outputs(&mut self) -> Result<Vec<Answer>, BridgeError> {
        let mut out = std::mem::take(&mut self.stash);
        while let Some(s) = self
            .outputs
            .try_recv()
            .map_err(|e| zenoh_error("receiving outputs", e))?
        {
            out.push(Self::answer_of(&s)?);
        }
        Ok(out)
    }

    pub(crate) fn latest_status(&mut self) -> Result<Option<Status>, BridgeError> {
        let mut last = None;
        while let Some(s) = self
            .status
            .try_recv()
            .map_err(|e| zenoh_error("receiving status", e))?
        {
            last = Some(decode::<Status>(
                Some(s.payload()),
                s.attachment(),
                "a status sample",
            )?);
        }
        Ok(last)
    }

    /// Blocks until an answer is published or `timeout` passes.
    pub(crate) fn wait_event(&mut self, timeout: Duration) -> Result<(), BridgeError> {
        if let Some(s) = self
            .outputs
            .recv_timeout(timeout)
            .map_err(|e| zenoh_error("waiting for outputs", e))?
        {
            let a = Self::answer_of(&s)?;
            self.stash.push(a);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loopback_endpoints() {
        for e in [
            "tcp/127.0.0.1:7447",
            "tcp/127.1.2.3:1",
            "tcp/[::1]:7447",
            "tls/localhost:7447",
            "tcp/127.0.0.1:7447#iface=lo",
        ] {
            assert!(is_loopback(e), "{e}");
        }
        for e in [
            "tcp/0.0.0.0:7447",
            "tcp/[::]:7447",
            "tcp/10.0.0.1:7447",
            "tcp/example.org:1",
            "nonsense",
        ] {
            assert!(!is_loopback(e), "{e}");
        }
    }

    #[test]
    fn beyond_loopback_needs_authentication_or_consent() {
        let open = ZenohOptions {
            listen: vec!["tcp/10.1.2.3:7447".to_owned()],
            ..Default::default()
        };
        let e = config(&open, Role::Bridge).unwrap_err();
        assert!(
            e.is_usage() && e.to_string().contains("--zenoh-users"),
            "{e}"
        );
        let consent = ZenohOptions {
            unauthenticated: true,
            ..open.clone()
        };
        assert!(config(&consent, Role::Bridge).is_ok());
        let none = ZenohOptions::default();
        assert!(config(&none, Role::Bridge).unwrap_err().is_usage());
        assert!(config(&none, Role::Client).unwrap_err().is_usage());
    }

    #[test]
    fn credentials_files_are_checked() {
        let dir = std::env::temp_dir().join(format!("decoy-zenoh-cred-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let bad = dir.join("bad");
        std::fs::write(&bad, "nopassword\n").unwrap();
        let e = read_credentials(&bad).unwrap_err();
        assert!(e.to_string().contains("user:password"), "{e}");
        let good = dir.join("good");
        std::fs::write(&good, "pilot:secret\n").unwrap();
        assert_eq!(
            read_credentials(&good).unwrap(),
            ("pilot".into(), "secret".into())
        );
        let empty = dir.join("empty");
        std::fs::write(&empty, "\n").unwrap();
        assert!(
            check_users_file(&empty)
                .unwrap_err()
                .to_string()
                .contains("nobody")
        );
        assert!(check_users_file(&good).is_ok());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_wrong_tag_is_a_protocol_error() {
        let state = AircraftState::default();
        let bytes = zenoh::bytes::ZBytes::from(state.as_wire_bytes().to_vec());
        let wrong = zenoh::bytes::ZBytes::from("decoy.bridge.v2.AircraftState/104".to_owned());
        let e = decode::<AircraftState>(Some(&bytes), Some(&wrong), "x").unwrap_err();
        assert!(matches!(e, BridgeError::Protocol(_)), "{e}");
        let right = zenoh::bytes::ZBytes::from(AircraftState::tag());
        assert_eq!(
            decode::<AircraftState>(Some(&bytes), Some(&right), "x").unwrap(),
            state
        );
        let short = zenoh::bytes::ZBytes::from(vec![0u8; 3]);
        assert!(matches!(
            decode::<AircraftState>(Some(&short), Some(&right), "x").unwrap_err(),
            BridgeError::Protocol(_)
        ));
    }
}
