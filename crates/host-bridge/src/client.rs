//! A client of a running bridge: lockstep requests with a deadline, free-running
//! samples, commands, and the outputs and status it publishes. `decoy feed`, the
//! tests, the benchmark and the smallest-client example use it.

use std::time::{Duration, Instant};

use bridge_types::{
    AircraftState, Answer, Command, CommandReply, Header, Status, command, event, kind,
};
use iceoryx2::pending_response::PendingResponse;
use iceoryx2::port::client::Client as IoxClient;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;

use crate::BridgeError;
use crate::remote::{ZenohClient, ZenohOptions};
use crate::services::{Ipc, Services, node, wait_until_ready};

/// Default deadline of one answer.
pub const ANSWER_TIMEOUT: Duration = Duration::from_secs(5);
/// How long [`BridgeClient::connect`] waits for the bridge to be ready (a
/// starting bridge takes milliseconds from its first service to its readiness
/// mark; this leaves room for a loaded machine).
pub const CONNECT_TIMEOUT: Duration = Duration::from_secs(2);

/// A connection to bridge `instance`: over shared memory
/// ([`BridgeClient::connect`]) or across hosts over Zenoh
/// ([`BridgeClient::connect_zenoh`], crate::remote), with the same operations
/// and the same answers.
pub struct BridgeClient {
    transport: Transport,
    instance: String,
    timeout: Duration,
    command_seq: u32,
    free_seq: u32,
}

enum Transport {
    Shm(Box<ShmPorts>),
    Zenoh(Box<ZenohClient>),
}

/// The iceoryx2 ports of a shared-memory client.
struct ShmPorts {
    lockstep: IoxClient<Ipc, AircraftState, (), Answer, ()>,
    commands: IoxClient<Ipc, Command, (), CommandReply, ()>,
    state: Publisher<Ipc, AircraftState, ()>,
    outputs: Subscriber<Ipc, Answer, ()>,
    status: Subscriber<Ipc, Status, ()>,
    to_bridge: Notifier<Ipc>,
    from_bridge: Listener<Ipc>,
    _status_service: crate::services::StatusService,
    _services: Services,
    _node: Node<Ipc>,
}

fn ipc(what: &str, e: impl std::fmt::Debug) -> BridgeError {
    BridgeError::Ipc(format!("{what}: {e:?}"))
}

impl BridgeClient {
    /// Connects to bridge `instance` as node `node_name` once it is ready
    /// (waiting up to [`CONNECT_TIMEOUT`] for its readiness mark, so that a
    /// bridge still starting is waited for and everything it serves exists
    /// when this returns); [`BridgeError::NoBridge`] when no bridge is ready
    /// in that time.
    pub fn connect(instance: &str, node_name: &str, config: &Config) -> Result<Self, BridgeError> {
        Self::connect_within(instance, node_name, config, CONNECT_TIMEOUT)
    }

    /// [`BridgeClient::connect`], waiting up to `timeout` for the bridge to be
    /// ready.
    pub fn connect_within(
        instance: &str,
        node_name: &str,
        config: &Config,
        timeout: Duration,
    ) -> Result<Self, BridgeError> {
        let node = node(node_name, config)?;
        // The readiness mark first (crate::services): every other service and
        // the bridge's every port exist once it does.
        let status_service = wait_until_ready(&node, instance, timeout)?;
        let services = Services::open(&node, instance)?;
        let lockstep = services
            .lockstep
            .client_builder()
            .create()
            .map_err(|e| ipc("the lockstep client", e))?;
        let commands = services
            .commands
            .client_builder()
            .create()
            .map_err(|e| ipc("the commands client", e))?;
        let state = services
            .state
            .publisher_builder()
            .create()
            .map_err(|e| ipc("the state publisher", e))?;
        let outputs = services
            .outputs
            .subscriber_builder()
            .buffer_size(crate::services::OUTPUTS_BUFFER)
            .create()
            .map_err(|e| ipc("the outputs subscriber", e))?;
        let status = status_service
            .subscriber_builder()
            .create()
            .map_err(|e| ipc("the status subscriber", e))?;
        let to_bridge = services
            .to_bridge
            .notifier_builder()
            .create()
            .map_err(|e| ipc("the event notifier", e))?;
        let from_bridge = services
            .from_bridge
            .listener_builder()
            .create()
            .map_err(|e| ipc("the event listener", e))?;
        Ok(BridgeClient {
            transport: Transport::Shm(Box::new(ShmPorts {
                lockstep,
                commands,
                state,
                outputs,
                status,
                to_bridge,
                from_bridge,
                _status_service: status_service,
                _services: services,
                _node: node,
            })),
            instance: instance.to_owned(),
            timeout: ANSWER_TIMEOUT,
            command_seq: 0,
            free_seq: 0,
        })
    }

    /// Connects to bridge `instance` across hosts over Zenoh (crate::remote)
    /// once its readiness token is seen, waiting up to
    /// [`crate::remote::REMOTE_CONNECT_TIMEOUT`]; [`BridgeError::NoBridge`]
    /// when no bridge answers in that time, [`BridgeError::Usage`] for bad
    /// options.
    pub fn connect_zenoh(instance: &str, options: &ZenohOptions) -> Result<Self, BridgeError> {
        let client =
            ZenohClient::connect(instance, options, crate::remote::REMOTE_CONNECT_TIMEOUT)?;
        Ok(BridgeClient {
            transport: Transport::Zenoh(Box::new(client)),
            instance: instance.to_owned(),
            timeout: ANSWER_TIMEOUT,
            command_seq: 0,
            free_seq: 0,
        })
    }

    /// `shm` or `zenoh`.
    pub fn transport_name(&self) -> &'static str {
        match self.transport {
            Transport::Shm(_) => "shm",
            Transport::Zenoh(_) => "zenoh",
        }
    }

    /// Queries sent again after Zenoh ended them without a reply (0 over
    /// shared memory; crate::remote): each answered once by the bridge.
    pub fn queries_resent(&self) -> u64 {
        match &self.transport {
            Transport::Shm(_) => 0,
            Transport::Zenoh(z) => z.resent(),
        }
    }

    /// Sets the deadline of each answer.
    pub fn set_timeout(&mut self, timeout: Duration) {
        self.timeout = timeout;
    }

    /// One lockstep exchange: `state` in, its answer out (an output or a rejection).
    pub fn step(&mut self, state: &AircraftState) -> Result<Answer, BridgeError> {
        match &mut self.transport {
            Transport::Shm(p) => {
                let pending = p
                    .lockstep
                    .loan_uninit()
                    .map_err(|e| ipc("loaning a request", e))?
                    .write_payload(*state)
                    .send()
                    .map_err(|e| ipc("sending a request", e))?;
                let _ = p
                    .to_bridge
                    .notify_with_custom_event_id(EventId::new(event::REQUEST));
                p.await_response(&self.instance, self.timeout, &pending, "answer")
            }
            Transport::Zenoh(z) => z.step(state, self.timeout),
        }
    }

    /// One command (numbered by this client); its reply.
    pub fn command(&mut self, mut c: Command) -> Result<CommandReply, BridgeError> {
        self.command_seq = self.command_seq.wrapping_add(1);
        c.header = Header::new(kind::COMMAND, self.command_seq);
        self.command_as_sent(c)
    }

    /// One command exactly as given (its header too: the Zenoh gateway passes
    /// a remote client's commands on so); its reply.
    pub fn command_as_sent(&mut self, c: Command) -> Result<CommandReply, BridgeError> {
        match &mut self.transport {
            Transport::Shm(p) => {
                let pending = p
                    .commands
                    .loan_uninit()
                    .map_err(|e| ipc("loaning a command", e))?
                    .write_payload(c)
                    .send()
                    .map_err(|e| ipc("sending a command", e))?;
                let _ = p
                    .to_bridge
                    .notify_with_custom_event_id(EventId::new(event::COMMAND));
                p.await_response(&self.instance, self.timeout, &pending, "command reply")
            }
            Transport::Zenoh(z) => z.command(&c, self.timeout),
        }
    }

    /// `command` with only its code set.
    pub fn simple_command(&mut self, code: u16) -> Result<CommandReply, BridgeError> {
        self.command(Command {
            command: code,
            ..Default::default()
        })
    }

    /// The bridge's status now (a GetStatus command).
    pub fn get_status(&mut self) -> Result<Status, BridgeError> {
        Ok(self.simple_command(command::GET_STATUS)?.status)
    }

    /// Publishes `state` on the free-running service (its `header.seq` as
    /// given; see [`BridgeClient::next_free_seq`]) and wakes the bridge.
    pub fn publish(&mut self, state: &AircraftState) -> Result<(), BridgeError> {
        self.publish_quietly(state)?;
        self.wake_for_states();
        Ok(())
    }

    /// [`BridgeClient::publish`] without waking the bridge: a publisher of
    /// many samples can wake it once per batch ([`BridgeClient::wake_for_states`]);
    /// the bridge's 100 ms tick serves the samples anyway. (Over Zenoh the
    /// gateway wakes the bridge for every sample.)
    pub fn publish_quietly(&mut self, state: &AircraftState) -> Result<(), BridgeError> {
        match &mut self.transport {
            Transport::Shm(p) => {
                p.state
                    .loan_uninit()
                    .map_err(|e| ipc("loaning a sample", e))?
                    .write_payload(*state)
                    .send()
                    .map_err(|e| ipc("publishing a state", e))?;
                Ok(())
            }
            Transport::Zenoh(z) => z.publish(state),
        }
    }

    /// Wakes the bridge for the free-running samples published (`STATE`).
    pub fn wake_for_states(&self) {
        if let Transport::Shm(p) = &self.transport {
            let _ = p
                .to_bridge
                .notify_with_custom_event_id(EventId::new(event::STATE));
        }
    }

    /// The next sequence number of this client's free-running samples (from 0).
    pub fn next_free_seq(&mut self) -> u32 {
        let s = self.free_seq;
        self.free_seq = self.free_seq.wrapping_add(1);
        s
    }

    /// Every answer received on the outputs service so far.
    pub fn take_outputs(&mut self) -> Result<Vec<Answer>, BridgeError> {
        match &mut self.transport {
            Transport::Shm(p) => {
                let mut out = Vec::new();
                while let Some(sample) = p
                    .outputs
                    .receive()
                    .map_err(|e| ipc("receiving outputs", e))?
                {
                    out.push(*sample.payload());
                }
                Ok(out)
            }
            Transport::Zenoh(z) => z.take_outputs(),
        }
    }

    /// The newest status published, if any arrived.
    pub fn latest_status(&mut self) -> Result<Option<Status>, BridgeError> {
        match &mut self.transport {
            Transport::Shm(p) => {
                let mut last = None;
                while let Some(sample) =
                    p.status.receive().map_err(|e| ipc("receiving status", e))?
                {
                    last = Some(*sample.payload());
                }
                Ok(last)
            }
            Transport::Zenoh(z) => z.latest_status(),
        }
    }

    /// Blocks until the bridge notifies something (over Zenoh: publishes an
    /// answer) or `timeout` passes.
    pub fn wait_event(&mut self, timeout: Duration) -> Result<(), BridgeError> {
        match &mut self.transport {
            Transport::Shm(p) => {
                p.from_bridge
                    .timed_wait(|_| {}, timeout)
                    .map_err(|e| ipc("waiting for the bridge", e))?;
                Ok(())
            }
            Transport::Zenoh(z) => z.wait_event(timeout),
        }
    }
}

fn no_answer(instance: &str, timeout: Duration, what: &str) -> BridgeError {
    BridgeError::NoAnswer(format!(
        "no {what} from bridge {instance:?} within {timeout:?}: is `decoy bridge --instance {instance}` running?"
    ))
}

impl ShmPorts {
    /// Waits (blocked on the from-bridge event, no spinning) for the response
    /// to `pending` until the deadline.
    fn await_response<Req, Resp>(
        &self,
        instance: &str,
        timeout: Duration,
        pending: &PendingResponse<Ipc, Req, (), Resp, ()>,
        what: &str,
    ) -> Result<Resp, BridgeError>
    where
        Req: std::fmt::Debug + ZeroCopySend,
        Resp: std::fmt::Debug + ZeroCopySend + Copy,
    {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(response) = pending
                .receive()
                .map_err(|e| ipc("receiving an answer", e))?
            {
                return Ok(*response.payload());
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(no_answer(instance, timeout, what));
            }
            if pending.number_of_server_connections() == 0 {
                return Err(BridgeError::NoAnswer(format!(
                    "bridge {:?} is not serving (no server took the request)",
                    instance
                )));
            }
            if !pending.is_connected() {
                // Answered and released between the two calls, or dropped.
                if let Some(response) = pending
                    .receive()
                    .map_err(|e| ipc("receiving an answer", e))?
                {
                    return Ok(*response.payload());
                }
                return Err(BridgeError::NoAnswer(format!(
                    "bridge {:?} released the request without an answer (it is shutting down or died)",
                    instance
                )));
            }
            self.from_bridge
                .timed_wait(|_| {}, left.min(Duration::from_millis(100)))
                .map_err(|e| ipc("waiting for the bridge", e))?;
        }
    }
}
