//! The bridge across hosts over Zenoh (docs/bridge.md, "Across hosts").
//!
//! `decoy bridge --zenoh-listen ENDPOINT` serves the instance's services over
//! Zenoh as well as over shared memory, through a gateway
//! (`crate::gateway::ZenohGateway`: two threads that are clients of the
//! bridge's own shared-memory services, so a remote client's frames go
//! through the same engine, in the same order, with the same bits as a local
//! client's) and a Zenoh session that carries them. This module holds what
//! both ends share (the key expressions, the tags, the configuration rules)
//! and a client's end, [`ZenohClient`]:
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
//! `decoy.bridge.v4.Answer/272`) as the attachment; both sides check it and a
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
use std::time::{Duration, Instant};

use bridge_types::{
    AircraftState, Answer, Command, CommandReply, SERVICE_ROOT, Status, Wire, service,
};
use zenoh::handlers::{FifoChannelHandler, RingChannel, RingChannelHandler};
use zenoh::query::{ConsolidationMode, QueryTarget, Reply};
use zenoh::sample::Sample;
use zenoh::{Session, Wait};

use crate::BridgeError;

/// The liveliness token of a serving gateway: `decoy/NAME/alive`.
pub const ALIVE: &str = "alive";
/// How long a remote client waits for the bridge's session and readiness mark.
pub const REMOTE_CONNECT_TIMEOUT: Duration = Duration::from_secs(5);
/// How long a client waits before it sends again a query Zenoh ended
/// without a reply.
pub const RESEND_PAUSE: Duration = Duration::from_millis(2);
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

/// A Zenoh error's text without the source location Zenoh appends
/// (` at /root/.cargo/registry/.../file.rs:62.`): the user's words only.
pub(crate) fn zenoh_text(e: impl std::fmt::Display) -> String {
    let text = e.to_string();
    match text.find(" at /") {
        Some(i) if text[i..].contains(".rs:") => text[..i].trim_end_matches('.').to_owned(),
        _ => text,
    }
}

pub(crate) fn zenoh_error(what: &str, e: impl std::fmt::Display) -> BridgeError {
    BridgeError::Ipc(format!("Zenoh: {what}: {}", zenoh_text(e)))
}

/// Checks the form of an endpoint given on the command line:
/// `<protocol>/<host>:<port>` with a port of 1 to 65535 (Zenoh's own message
/// for a bad one is long, and a bad port shows only when the session opens).
fn check_endpoint(option: &str, endpoint: &str) -> Result<(), BridgeError> {
    let bad = |why: &str| {
        BridgeError::Usage(format!(
            "{option} {endpoint:?}: {why}; an endpoint is <protocol>/<host>:<port>, e.g. tcp/127.0.0.1:7447 or tls/10.0.0.1:7447"
        ))
    };
    let address = endpoint.split(['#', '?']).next().unwrap_or("");
    let Some((protocol, locator)) = address.split_once('/') else {
        return Err(bad("no protocol"));
    };
    if protocol.is_empty() || locator.is_empty() {
        return Err(bad("no protocol or no address"));
    }
    if matches!(protocol, "tcp" | "tls" | "udp" | "quic" | "ws") {
        let Some((host, port)) = locator.rsplit_once(':') else {
            return Err(bad("no port"));
        };
        if host.is_empty() {
            return Err(bad("no host"));
        }
        match port.parse::<u16>() {
            Ok(p) if p > 0 => {}
            _ => return Err(bad("the port must be 1 to 65535")),
        }
    }
    Ok(())
}

fn insert(config: &mut zenoh::Config, key: &str, value: &str) -> Result<(), BridgeError> {
    config.insert_json5(key, value).map_err(|e| {
        BridgeError::Usage(format!(
            "Zenoh configuration {key} = {value}: {}",
            zenoh_text(e)
        ))
    })
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
pub(crate) enum Role {
    /// The bridge: a peer that listens (and may connect).
    Bridge,
    /// A client: connects, never listens.
    Client,
}

fn config(options: &ZenohOptions, role: Role) -> Result<zenoh::Config, BridgeError> {
    let mut c = match &options.config_file {
        Some(path) => zenoh::Config::from_file(path).map_err(|e| {
            BridgeError::Usage(format!(
                "cannot read the Zenoh configuration {}: {}",
                path.display(),
                zenoh_text(e)
            ))
        })?,
        None => zenoh::Config::default(),
    };
    for e in &options.listen {
        check_endpoint("--zenoh-listen", e)?;
    }
    for e in &options.connect {
        check_endpoint("--zenoh-connect", e)?;
    }
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
            insert(&mut c, "mode", "\"peer\"")?;
            // Zenoh's default for a peer is every interface on a random port
            // (`tcp/[::]:0`): the bridge listens on what it is given, the
            // endpoints of --zenoh-listen or those a configuration file names,
            // and on nothing else.
            let file_names_its_own =
                from_file && listen_endpoints(&c) != listen_endpoints(&zenoh::Config::default());
            if !options.listen.is_empty() || !file_names_its_own {
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
    if role == Role::Bridge {
        check_listeners(&c, options)?;
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

/// The endpoints configuration `c` listens on (its `listen/endpoints`: a
/// list, or a list per mode, of which the peer's).
pub(crate) fn listen_endpoints(c: &zenoh::Config) -> Vec<String> {
    endpoints(c, "listen/endpoints")
}

/// The endpoints configuration `c` connects to.
pub(crate) fn connect_endpoints(c: &zenoh::Config) -> Vec<String> {
    endpoints(c, "connect/endpoints")
}

fn endpoints(c: &zenoh::Config, key: &str) -> Vec<String> {
    let value: serde_json::Value = c
        .get_json(key)
        .ok()
        .and_then(|j| serde_json::from_str(&j).ok())
        .unwrap_or_default();
    let list = match &value {
        serde_json::Value::Object(per_mode) => per_mode.get("peer").cloned().unwrap_or_default(),
        other => other.clone(),
    };
    list.as_array()
        .map(|a| {
            a.iter()
                .filter_map(|e| e.as_str().map(str::to_owned))
                .collect()
        })
        .unwrap_or_default()
}

/// Whether configuration `c` says `key` is set (not null, not false).
fn is_set(c: &zenoh::Config, key: &str) -> bool {
    c.get_json(key).is_ok_and(|j| {
        let v: serde_json::Value = serde_json::from_str(&j).unwrap_or_default();
        !(v.is_null() || v == serde_json::Value::Bool(false))
    })
}

/// The bridge's rule: an endpoint beyond loopback, listened on or connected
/// to (a router's peers reach the bridge as well as the router's own), only
/// with its peers authenticated (a user/password dictionary, or TLS with
/// client certificates on a `tls/` endpoint) or with
/// `--zenoh-unauthenticated`.
fn check_listeners(c: &zenoh::Config, options: &ZenohOptions) -> Result<(), BridgeError> {
    if options.unauthenticated {
        return Ok(());
    }
    let users = is_set(c, "transport/auth/usrpwd/dictionary_file");
    let mtls = is_set(c, "transport/link/tls/enable_mtls");
    for endpoint in listen_endpoints(c).into_iter().chain(connect_endpoints(c)) {
        if is_loopback(&endpoint) || users || (mtls && endpoint.starts_with("tls/")) {
            continue;
        }
        return Err(BridgeError::Usage(format!(
            "the Zenoh endpoint {endpoint} is beyond loopback: authenticate the peers (--zenoh-users FILE, or TLS with client certificates in --zenoh-config: enable_mtls on a tls/ endpoint) or say --zenoh-unauthenticated"
        )));
    }
    Ok(())
}

/// The configuration a bridge with `options` runs with.
pub(crate) fn effective_config(options: &ZenohOptions) -> Result<zenoh::Config, BridgeError> {
    config(options, Role::Bridge)
}

/// Checks a bridge's Zenoh options as `gateway::ZenohGateway::start` will (files
/// read, endpoints beyond loopback) without opening a session, so that bad
/// options are a usage error before the bridge starts.
pub fn check_bridge_options(options: &ZenohOptions) -> Result<(), BridgeError> {
    config(options, Role::Bridge).map(|_| ())
}

/// Checks a client's Zenoh options as `BridgeClient::connect_zenoh` will.
pub fn check_client_options(options: &ZenohOptions) -> Result<(), BridgeError> {
    config(options, Role::Client).map(|_| ())
}

pub(crate) fn open_session(options: &ZenohOptions, role: Role) -> Result<Session, BridgeError> {
    let c = config(options, role)?;
    zenoh::open(c).wait().map_err(|e| match role {
        Role::Bridge => BridgeError::Ipc(format!(
            "Zenoh: cannot open the bridge's session (listen {}, connect {}): {}",
            json_list(&options.listen),
            json_list(&options.connect),
            zenoh_text(e)
        )),
        Role::Client => BridgeError::NoBridge(format!(
            "Zenoh: no bridge reachable at {} within {:?}: {}",
            json_list(&options.connect),
            REMOTE_CONNECT_TIMEOUT,
            zenoh_text(e)
        )),
    })
}

/// The start of every error reply the gateway sends (Zenoh's own, such as a
/// query's timeout, do not have it).
pub const ERROR_PREFIX: &str = "decoy bridge: ";
/// After [`ERROR_PREFIX`], the mark of an error reply to a payload of another
/// type or size.
pub const PROTOCOL_PREFIX: &str = "protocol: ";

/// The tag carried beside a payload, as text.
/// The attachment is the tag, then, on a query, a space and the query's id
/// (`<session id>:<number>`: the client's Zenoh session id and its count of
/// queries), the same when the client sends the query again.
fn tag_of(attachment: Option<&zenoh::bytes::ZBytes>) -> String {
    let text = attachment
        .map(|a| String::from_utf8_lossy(&a.to_bytes()).into_owned())
        .unwrap_or_default();
    text.split(' ').next().unwrap_or("").to_owned()
}

/// The id of a query (its attachment's second word), if it carries one.
pub(crate) fn query_id(attachment: Option<&zenoh::bytes::ZBytes>) -> Option<String> {
    let text = String::from_utf8_lossy(&attachment?.to_bytes()).into_owned();
    text.split(' ')
        .nth(1)
        .filter(|id| !id.is_empty())
        .map(str::to_owned)
}

/// A payload of type `T` with its tag checked.
pub(crate) fn decode<T: Wire>(
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

/// A client's end of the Zenoh transport (inside `client::BridgeClient`).
pub(crate) struct ZenohClient {
    /// Present until dropped ([`ZenohClient`]'s `Drop`).
    ports: Option<ClientPorts>,
    lockstep_key: String,
    commands_key: String,
    /// Queries sent again after Zenoh ended them without a reply.
    resent: std::cell::Cell<u64>,
    /// Queries sent (each numbered in its id).
    queries: std::cell::Cell<u64>,
    /// This client's Zenoh session id (the first part of its queries' ids).
    session_id: String,
    /// An answer received while waiting ([`ZenohClient::wait_event`]), not yet taken.
    stash: Vec<Answer>,
    instance: String,
}

/// A client's Zenoh session and what it declared (fields drop in order: the
/// declarations, then the session).
struct ClientPorts {
    state: zenoh::pubsub::Publisher<'static>,
    outputs: zenoh::pubsub::Subscriber<RingChannelHandler<Sample>>,
    status: zenoh::pubsub::Subscriber<RingChannelHandler<Sample>>,
    session: Session,
}

impl ZenohClient {
    fn ports(&self) -> &ClientPorts {
        self.ports
            .as_ref()
            .expect("a client's ports exist until it is dropped")
    }

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
        let session_id = session.zid().to_string();
        let client = ZenohClient {
            session_id,
            lockstep_key: key(instance, service::LOCKSTEP),
            commands_key: key(instance, service::COMMANDS),
            ports: Some(ClientPorts {
                state,
                outputs,
                status,
                session,
            }),
            stash: Vec::new(),
            resent: std::cell::Cell::new(0),
            queries: std::cell::Cell::new(0),
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
                .ports()
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
        let deadline = Instant::now() + timeout;
        let no_answer = |why: &str| {
            BridgeError::NoAnswer(format!(
                "no {what} from bridge {:?} over Zenoh within {timeout:?}{why}: is the link up and `decoy bridge --instance {} --zenoh-listen ...` running?",
                self.instance, self.instance
            ))
        };
        let mut resent = 0u32;
        let number = self.queries.get();
        self.queries.set(number + 1);
        let attachment = format!("{} {}:{number}", Q::tag(), self.session_id);
        let reply = loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let replies: FifoChannelHandler<Reply> = self
                .ports()
                .session
                .get(key)
                .payload(request.as_wire_bytes().to_vec())
                .attachment(attachment.clone())
                .target(QueryTarget::BestMatching)
                // The one reply as soon as it comes (the default holds it
                // until the query is finalised).
                .consolidation(ConsolidationMode::None)
                .timeout(left.max(Duration::from_millis(1)))
                .wait()
                .map_err(|e| zenoh_error("sending a query", e))?;
            // The one reply; the channel closes when the query is finalised.
            match replies.recv_deadline(deadline + Duration::from_millis(50)) {
                Ok(Some(reply)) => break reply,
                Ok(None) => return Err(no_answer("")),
                // Finalised with no reply, before the deadline: Zenoh routed
                // the query to no queryable (its routes are rebuilt while a
                // peer's session goes away, Zenoh issues 2516 and 2767) or
                // lost the reply. Sent again, the same bytes: the gateway
                // answers a request it already answered from its record
                // (crate::gateway, "exactly once"), so the controller never
                // sees a frame twice.
                Err(_) if Instant::now() + RESEND_PAUSE < deadline => {
                    resent += 1;
                    std::thread::sleep(RESEND_PAUSE);
                }
                Err(_) => {
                    return Err(no_answer(&format!(
                        " (every query ended without a reply; sent {} times)",
                        resent + 1
                    )));
                }
            }
        };
        if resent > 0 {
            self.resent.set(self.resent.get() + u64::from(resent));
        }
        match reply.result() {
            Ok(sample) => decode::<R>(Some(sample.payload()), sample.attachment(), what),
            Err(e) => {
                let text = String::from_utf8_lossy(&e.payload().to_bytes()).into_owned();
                match text.strip_prefix(ERROR_PREFIX) {
                    Some(m) if m.starts_with(PROTOCOL_PREFIX) => {
                        let m = &m[PROTOCOL_PREFIX.len()..];
                        Err(BridgeError::Protocol(format!(
                            "bridge {:?} refused the {what}'s request: {m}",
                            self.instance
                        )))
                    }
                    Some(m) => Err(BridgeError::NoAnswer(format!(
                        "bridge {:?} could not answer: {m}",
                        self.instance
                    ))),
                    // Zenoh's own (the query's timeout): no answer in time.
                    None => Err(no_answer(&format!(" (Zenoh: {text})"))),
                }
            }
        }
    }

    /// Queries this client sent again after Zenoh ended them without a reply.
    pub(crate) fn resent(&self) -> u64 {
        self.resent.get()
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
        self.ports()
            .state
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

    /// Every answer published so far; a sample of another type or size is a
    /// [`BridgeError::Protocol`], the answers before it kept for the next call.
    pub(crate) fn take_outputs(&mut self) -> Result<Vec<Answer>, BridgeError> {
        loop {
            let next = self
                .ports()
                .outputs
                .try_recv()
                .map_err(|e| zenoh_error("receiving outputs", e))?;
            let Some(sample) = next else {
                return Ok(std::mem::take(&mut self.stash));
            };
            let answer = Self::answer_of(&sample)?;
            self.keep(answer);
        }
    }

    /// Keeps `answer` until taken, the oldest going first beyond
    /// [`REMOTE_OUTPUTS_BUFFER`].
    fn keep(&mut self, answer: Answer) {
        if self.stash.len() == REMOTE_OUTPUTS_BUFFER {
            self.stash.remove(0);
        }
        self.stash.push(answer);
    }

    pub(crate) fn latest_status(&mut self) -> Result<Option<Status>, BridgeError> {
        let mut last = None;
        while let Some(s) = self
            .ports()
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
            .ports()
            .outputs
            .recv_timeout(timeout)
            .map_err(|e| zenoh_error("waiting for outputs", e))?
        {
            let a = Self::answer_of(&s)?;
            self.keep(a);
        }
        Ok(())
    }
}

impl Drop for ZenohClient {
    /// Undeclares and closes on a thread of its own: Zenoh's close says
    /// goodbye to the peer and waits up to 10 s for it when the link is cut
    /// (and an undeclaration meanwhile waits for the close), which a client
    /// that has lost its bridge must not spend; a process that ends meanwhile
    /// ends the session with it.
    fn drop(&mut self) {
        if let Some(ports) = self.ports.take() {
            let _ = std::thread::Builder::new()
                .name("zenoh-close".to_owned())
                .spawn(move || drop(ports));
        }
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

    /// TLS with client certificates authenticates a `tls/` endpoint; plain
    /// TLS does not; an endpoint a configuration file lists is held to the
    /// rule as one given on the command line.
    #[test]
    fn tls_with_client_certificates_counts_as_authentication() {
        let dir = std::env::temp_dir().join(format!("decoy-zenoh-tls-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mtls = dir.join("mtls.json5");
        std::fs::write(
            &mtls,
            "{ transport: { link: { tls: { enable_mtls: true } } } }",
        )
        .unwrap();
        let plain = dir.join("plain.json5");
        std::fs::write(
            &plain,
            "{ transport: { link: { tls: { enable_mtls: false } } } }",
        )
        .unwrap();
        let listed = dir.join("listed.json5");
        std::fs::write(
            &listed,
            "{ listen: { endpoints: [\"tcp/10.9.9.9:7447\"] } }",
        )
        .unwrap();
        let with = |file: &PathBuf, listen: &[&str]| ZenohOptions {
            listen: listen.iter().map(|e| (*e).to_owned()).collect(),
            config_file: Some(file.clone()),
            ..Default::default()
        };
        assert!(config(&with(&mtls, &["tls/10.1.2.3:7447"]), Role::Bridge).is_ok());
        let e = config(&with(&mtls, &["tcp/10.1.2.3:7447"]), Role::Bridge).unwrap_err();
        assert!(e.is_usage(), "{e}");
        assert!(config(&with(&plain, &["tls/10.1.2.3:7447"]), Role::Bridge).is_err());
        let e = config(&with(&listed, &[]), Role::Bridge).unwrap_err();
        assert!(e.to_string().contains("tcp/10.9.9.9:7447"), "{e}");
        assert!(config(&with(&listed, &["tcp/127.0.0.1:7447"]), Role::Bridge).is_ok());
        // A file that names no endpoint: the bridge listens on nothing (not
        // on Zenoh's default, every interface), whatever else it says.
        let quiet = ZenohOptions {
            connect: vec!["tcp/127.0.0.1:7447".to_owned()],
            ..with(&mtls, &[])
        };
        let c = config(&quiet, Role::Bridge).unwrap();
        assert_eq!(listen_endpoints(&c), Vec::<String>::new());
        // Connecting beyond loopback is held to the rule too.
        let out = ZenohOptions {
            connect: vec!["tcp/10.1.2.3:7447".to_owned()],
            ..Default::default()
        };
        let e = config(&out, Role::Bridge).unwrap_err();
        assert!(e.to_string().contains("tcp/10.1.2.3:7447"), "{e}");
        let consent = ZenohOptions {
            unauthenticated: true,
            ..out
        };
        assert!(config(&consent, Role::Bridge).is_ok());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn endpoints_are_checked_before_zenoh_sees_them() {
        for good in [
            "tcp/127.0.0.1:7447",
            "tls/[::1]:1",
            "tcp/example.org:65535",
            "unixsock-stream//tmp/x",
        ] {
            assert!(check_endpoint("--zenoh-listen", good).is_ok(), "{good}");
        }
        for bad in [
            "nonsense",
            "tcp/127.0.0.1",
            "tcp/127.0.0.1:99999",
            "tcp/127.0.0.1:0",
            "tcp/:7447",
            "/x",
        ] {
            let e = check_endpoint("--zenoh-listen", bad).unwrap_err();
            assert!(
                e.is_usage() && e.to_string().contains("<protocol>/<host>:<port>"),
                "{bad}: {e}"
            );
        }
        assert_eq!(
            zenoh_text("invalid port value at /root/.cargo/registry/src/x/lib.rs:62."),
            "invalid port value"
        );
        assert_eq!(zenoh_text("plain"), "plain");
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
