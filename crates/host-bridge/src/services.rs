//! The services of one bridge instance, opened with the same settings by the
//! bridge and by every client (docs/bridge.md lists them), the readiness mark,
//! and the iceoryx2 configuration: the default one, with the file prefix and
//! root directory taken from the environment so that tests and side-by-side
//! runs stay apart.
//!
//! **Readiness.** The bridge creates the `status` service last, after every
//! other service and every port of its own, then its publisher and its first
//! status: a `status` service with a publisher is the mark that the bridge
//! serves everything ([`wait_until_ready`]). A client that waits for it before
//! it opens the rest can send at once; one that opens services half created
//! could send a command before the commands server exists, and lose it.

use std::time::{Duration, Instant};

use bridge_types::{
    AircraftState, Answer, Command, CommandReply, SERVICE_ROOT, Status, service, service_name,
    valid_instance,
};
use iceoryx2::prelude::*;
use iceoryx2::service::builder::publish_subscribe::PublishSubscribeOpenError;
use iceoryx2::service::port_factory::{event, publish_subscribe, request_response};

use crate::BridgeError;

/// The IPC service type of every port.
pub type Ipc = ipc::Service;

/// Environment variable: the iceoryx2 file prefix (`config.global.prefix`);
/// bridges and clients with different prefixes never see each other.
pub const PREFIX_ENV: &str = "DECOY_IOX_PREFIX";
/// Environment variable: the iceoryx2 root directory (default `/tmp/iceoryx2/`).
pub const ROOT_ENV: &str = "DECOY_IOX_ROOT";

/// Samples of history on the outputs service (late joiners get the last ones).
pub const OUTPUTS_HISTORY: usize = 16;
/// The largest buffer a subscriber of the outputs service may ask for.
pub const OUTPUTS_BUFFER: usize = 1024;
/// Buffer of the bridge's subscriber on the free-running state service.
pub const STATE_BUFFER: usize = 1024;
/// Clients of the lockstep and commands services.
pub const MAX_CLIENTS: usize = 16;
/// Requests a client may have in flight on a request-response service; each
/// client's response buffer holds as many, so with overflow disabled no answer
/// is ever overwritten and the bridge never blocks on a slow client.
pub const MAX_ACTIVE_REQUESTS: usize = 4;
/// Publishers of the free-running state service.
pub const MAX_STATE_PUBLISHERS: usize = 8;
/// Subscribers of the outputs and status services.
pub const MAX_SUBSCRIBERS: usize = 16;
/// Nodes on a service (the bridge and its clients).
pub const MAX_NODES: usize = 40;
/// Largest event id (bridge_types::event).
pub const EVENT_ID_MAX: usize = 31;
/// How often a client looks for the readiness mark while a bridge starts (the
/// services may not exist yet, so there is no event to wait on).
pub const READY_POLL: Duration = Duration::from_millis(5);

/// The iceoryx2 configuration: iceoryx2's defaults (no config file is read, so
/// nothing on the machine changes the services' limits), with `prefix` and
/// `root` if given, else from [`PREFIX_ENV`] and [`ROOT_ENV`].
pub fn iox_config(prefix: Option<&str>, root: Option<&str>) -> Result<Config, BridgeError> {
    let mut config = Config::default();
    let env_prefix = std::env::var(PREFIX_ENV).ok();
    let env_root = std::env::var(ROOT_ENV).ok();
    if let Some(p) = prefix.or(env_prefix.as_deref()) {
        config.global.prefix = FileName::new(p.as_bytes())
            .map_err(|e| BridgeError::Usage(format!("bad iceoryx2 prefix {p:?}: {e:?}")))?;
    }
    if let Some(r) = root.or(env_root.as_deref()) {
        let mut dir = r.to_owned();
        if !dir.ends_with('/') {
            dir.push('/');
        }
        let path = Path::new(dir.as_bytes())
            .map_err(|e| BridgeError::Usage(format!("bad iceoryx2 root {r:?}: {e:?}")))?;
        config.global.set_root_path(&path);
    }
    Ok(config)
}

/// Quiets iceoryx2's own log (its warnings go to stderr; the bridge reports
/// failures itself). `RUST_LOG`-style control: `IOX2_LOG_LEVEL`.
pub fn quiet_iceoryx_log() {
    set_log_level_from_env_or(LogLevel::Error);
}

/// A node named `name`.
pub fn node(name: &str, config: &Config) -> Result<Node<Ipc>, BridgeError> {
    let node_name = NodeName::new(name)
        .map_err(|e| BridgeError::Usage(format!("bad node name {name:?}: {e:?}")))?;
    let node = NodeBuilder::new()
        .name(&node_name)
        .config(config)
        .create::<Ipc>()
        .map_err(|e| BridgeError::Ipc(format!("cannot create the node {name}: {e:?}")))?;
    // Installs the SIGINT/SIGTERM handler now (iceoryx2's pitfall: before the
    // first wait a signal would end the process abruptly).
    let _ = node.wait(Duration::ZERO);
    Ok(node)
}

/// Checks an instance name (it becomes part of the service and node names).
pub fn check_instance(instance: &str) -> Result<(), BridgeError> {
    if valid_instance(instance) {
        Ok(())
    } else {
        Err(BridgeError::Usage(format!(
            "--instance must be 1 to 32 of A-Z a-z 0-9 _ -, got {instance:?}"
        )))
    }
}

/// The port factories of one instance's services but `status`, the readiness
/// mark ([`StatusService`]).
pub struct Services {
    /// `lockstep`: AircraftState -> Answer.
    pub lockstep: request_response::PortFactory<Ipc, AircraftState, (), Answer, ()>,
    /// `state`: free-running AircraftState samples.
    pub state: publish_subscribe::PortFactory<Ipc, AircraftState, ()>,
    /// `outputs`: every Answer.
    pub outputs: publish_subscribe::PortFactory<Ipc, Answer, ()>,
    /// `commands`: Command -> CommandReply.
    pub commands: request_response::PortFactory<Ipc, Command, (), CommandReply, ()>,
    /// `to-bridge` event.
    pub to_bridge: event::PortFactory<Ipc>,
    /// `from-bridge` event.
    pub from_bridge: event::PortFactory<Ipc>,
}

/// Why `service` of `instance` could not be created (the bridge) or opened (a
/// client: [`BridgeError::NoBridge`]).
fn failure(instance: &str, create: bool, service: &str, e: String) -> BridgeError {
    if create {
        BridgeError::Ipc(format!(
            "cannot create {SERVICE_ROOT}/{instance}/{service}: {e}"
        ))
    } else {
        BridgeError::NoBridge(format!(
            "no bridge named {instance:?} is running (service {SERVICE_ROOT}/{instance}/{service}: {e}); start one with `decoy bridge --instance {instance}`"
        ))
    }
}

fn name(instance: &str, service: &str) -> Result<ServiceName, BridgeError> {
    let full = service_name(instance, service);
    ServiceName::new(&full)
        .map_err(|e| BridgeError::Usage(format!("bad service name {full}: {e:?}")))
}

impl Services {
    /// Creates (or opens, after a crash) the services of `instance` but
    /// `status`: the bridge's side, which creates [`StatusService`] after its
    /// ports.
    pub fn open_or_create(node: &Node<Ipc>, instance: &str) -> Result<Self, BridgeError> {
        Self::build(node, instance, true)
    }

    /// Opens the services of a running bridge `instance`: a client's side,
    /// after [`wait_until_ready`]. [`BridgeError::NoBridge`] when they do not
    /// exist.
    pub fn open(node: &Node<Ipc>, instance: &str) -> Result<Self, BridgeError> {
        Self::build(node, instance, false)
    }

    fn build(node: &Node<Ipc>, instance: &str, create: bool) -> Result<Self, BridgeError> {
        check_instance(instance)?;
        let failed = |what: &str, e: String| failure(instance, create, what, e);
        macro_rules! finish {
            ($builder:expr, $what:expr) => {
                if create {
                    $builder
                        .open_or_create()
                        .map_err(|e| failed($what, format!("{e:?}")))?
                } else {
                    $builder
                        .open()
                        .map_err(|e| failed($what, format!("{e:?}")))?
                }
            };
        }
        let lockstep = finish!(
            node.service_builder(&name(instance, service::LOCKSTEP)?)
                .request_response::<AircraftState, Answer>()
                .enable_safe_overflow_for_requests(false)
                .enable_safe_overflow_for_responses(false)
                .max_active_requests_per_client(MAX_ACTIVE_REQUESTS)
                .max_response_buffer_size(MAX_ACTIVE_REQUESTS)
                .max_clients(MAX_CLIENTS)
                .max_servers(1)
                .max_nodes(MAX_NODES),
            service::LOCKSTEP
        );
        let commands = finish!(
            node.service_builder(&name(instance, service::COMMANDS)?)
                .request_response::<Command, CommandReply>()
                .enable_safe_overflow_for_requests(false)
                .enable_safe_overflow_for_responses(false)
                .max_active_requests_per_client(MAX_ACTIVE_REQUESTS)
                .max_response_buffer_size(MAX_ACTIVE_REQUESTS)
                .max_clients(MAX_CLIENTS)
                .max_servers(1)
                .max_nodes(MAX_NODES),
            service::COMMANDS
        );
        let state = finish!(
            node.service_builder(&name(instance, service::STATE)?)
                .publish_subscribe::<AircraftState>()
                .subscriber_max_buffer_size(STATE_BUFFER)
                .history_size(0)
                .max_publishers(MAX_STATE_PUBLISHERS)
                .max_subscribers(2)
                .max_nodes(MAX_NODES),
            service::STATE
        );
        let outputs = finish!(
            node.service_builder(&name(instance, service::OUTPUTS)?)
                .publish_subscribe::<Answer>()
                .subscriber_max_buffer_size(OUTPUTS_BUFFER)
                .history_size(OUTPUTS_HISTORY)
                .max_publishers(1)
                .max_subscribers(MAX_SUBSCRIBERS)
                .max_nodes(MAX_NODES),
            service::OUTPUTS
        );
        let to_bridge = finish!(
            node.service_builder(&name(instance, service::TO_BRIDGE)?)
                .event()
                .event_id_max_value(EVENT_ID_MAX)
                .max_notifiers(MAX_NODES)
                .max_listeners(2)
                .max_nodes(MAX_NODES),
            service::TO_BRIDGE
        );
        let from_bridge = finish!(
            node.service_builder(&name(instance, service::FROM_BRIDGE)?)
                .event()
                .event_id_max_value(EVENT_ID_MAX)
                .max_notifiers(2)
                .max_listeners(MAX_NODES)
                .max_nodes(MAX_NODES),
            service::FROM_BRIDGE
        );
        Ok(Services {
            lockstep,
            state,
            outputs,
            commands,
            to_bridge,
            from_bridge,
        })
    }
}

/// The `status` service (Status, history 1), the readiness mark: the bridge
/// creates it after every other service and port.
pub type StatusService = publish_subscribe::PortFactory<Ipc, Status, ()>;

fn status_builder(
    node: &Node<Ipc>,
    instance: &str,
) -> Result<iceoryx2::service::builder::publish_subscribe::Builder<Status, (), Ipc>, BridgeError> {
    check_instance(instance)?;
    Ok(node
        .service_builder(&name(instance, service::STATUS)?)
        .publish_subscribe::<Status>()
        .subscriber_max_buffer_size(4)
        .history_size(1)
        .max_publishers(1)
        .max_subscribers(MAX_SUBSCRIBERS)
        .max_nodes(MAX_NODES))
}

/// Creates (or opens, after a crash) the `status` service of `instance`: the
/// bridge's side, once every other service and port of it exists.
pub fn create_status_service(
    node: &Node<Ipc>,
    instance: &str,
) -> Result<StatusService, BridgeError> {
    status_builder(node, instance)?
        .open_or_create()
        .map_err(|e| failure(instance, true, service::STATUS, format!("{e:?}")))
}

/// Whether the bridge behind `status` is ready: its status publisher exists
/// (and with it every other port of the bridge).
pub fn is_ready(status: &StatusService) -> bool {
    status.dynamic_config().number_of_publishers() > 0
}

/// Waits until bridge `instance` is ready (its `status` service exists with its
/// publisher: the readiness mark), looking every [`READY_POLL`], and returns
/// the service; [`BridgeError::NoBridge`] when it is not ready within
/// `timeout`. A client calls it before it opens the other services.
pub fn wait_until_ready(
    node: &Node<Ipc>,
    instance: &str,
    timeout: Duration,
) -> Result<StatusService, BridgeError> {
    let deadline = Instant::now() + timeout;
    loop {
        let why = match status_builder(node, instance)?.open() {
            Ok(status) if is_ready(&status) => return Ok(status),
            Ok(_) => {
                "its status service has no publisher: the bridge is starting, or died".to_owned()
            }
            // Not there (yet), or a stopped bridge's going away: the bridge
            // may be starting.
            Err(
                e @ (PublishSubscribeOpenError::DoesNotExist
                | PublishSubscribeOpenError::HangsInCreation
                | PublishSubscribeOpenError::IsMarkedForDestruction
                | PublishSubscribeOpenError::ServiceInCorruptedState),
            ) => format!(
                "service {SERVICE_ROOT}/{instance}/{}: {e:?}",
                service::STATUS
            ),
            // Another protocol version, or settings that differ: final.
            Err(e) => return Err(failure(instance, false, service::STATUS, format!("{e:?}"))),
        };
        if Instant::now() >= deadline {
            return Err(BridgeError::NoBridge(format!(
                "no bridge named {instance:?} is running ({why}; waited {timeout:?}); start one with `decoy bridge --instance {instance}`"
            )));
        }
        std::thread::sleep(READY_POLL);
    }
}
