"""A client of a running ``decoy bridge``: the same operations as the Rust client,
over shared memory (iceoryx2, on the bridge's host) or across hosts (Zenoh).

Services of bridge instance ``NAME`` (docs/bridge.md): ``decoy/NAME/lockstep``
(request-response, :class:`~decoy_bridge.wire.AircraftState` →
:class:`~decoy_bridge.wire.Answer`), ``decoy/NAME/state`` (publish-subscribe of
states, free-running), ``decoy/NAME/outputs`` (publish-subscribe of every answer),
``decoy/NAME/status`` (publish-subscribe of :class:`~decoy_bridge.wire.Status`),
``decoy/NAME/commands`` (request-response, :class:`~decoy_bridge.wire.Command` →
:class:`~decoy_bridge.wire.CommandReply`), and the events ``to-bridge`` (the client
notifies after sending) and ``from-bridge`` (the bridge notifies after answering).

**Readiness.** The bridge creates ``status`` last, after every other service
and port, then its publisher: a ``status`` service with a publisher means that
everything is served (docs/bridge.md, "Readiness"). :class:`Bridge` waits for
that mark (up to ``connect_timeout_s``) before it opens the rest, as the Rust
client does, so a command sent at once is never lost to a bridge still starting.

Every wait blocks in an iceoryx2 WaitSet on the ``from-bridge`` listener with a
timeout: no spinning. Errors are exceptions of :mod:`decoy_bridge.errors`.

**Across hosts: Zenoh.** ``decoy bridge --instance NAME --zenoh-listen
tcp/HOST:PORT [--zenoh-users FILE]`` serves the same services over Zenoh
(crates/host-bridge/src/remote.rs; docs/bridge.md, "Across hosts"), and
``Bridge(NAME, zenoh="tcp/HOST:PORT", credentials=FILE)`` talks to it with the same
methods, semantics and exceptions:

==========================  ===================================  ==========================
key expression              Zenoh                                payload
==========================  ===================================  ==========================
``decoy/NAME/lockstep``     queryable, one reply per query       AircraftState → Answer
``decoy/NAME/commands``     queryable, one reply per query       Command → CommandReply
``decoy/NAME/state``        the client puts, the bridge takes    AircraftState
``decoy/NAME/outputs``      the bridge publishes                 every Answer
``decoy/NAME/status``       the bridge publishes                 Status
``decoy/NAME/alive``        liveliness token                     the readiness mark
==========================  ===================================  ==========================

Every payload is the wire structure's bytes exactly as in shared memory
(``bytes(structure)``), with its tag as the attachment: the type name and size,
UTF-8, ``decoy.bridge.v4.AircraftState/104`` (:func:`wire_tag`). Both sides check
it: a reply or sample of another tag or size is a :class:`VersionMismatch`, and the
bridge answers a query of another tag by an error reply (which this client raises
as :class:`VersionMismatch` too). The client's session is a Zenoh *client* that
connects to the given endpoints only: no listening, no multicast or gossip
scouting, no admin space (:func:`make_zenoh_config`). The readiness mark is the
bridge's liveliness token ``decoy/NAME/alive``, declared once everything is
served; :class:`Bridge` waits for it (up to ``connect_timeout_s``) as it waits
for the ``status`` publisher over shared memory. A query unanswered within its
time limit is a :class:`BridgeTimeout`; a query nothing serves (the bridge went
away, the link is down) is a :class:`NoBridge`. Waits block (in Zenoh's reply
channel, or on a condition the subscriptions' callbacks notify): no spinning.

Units and frames of the states and outputs: SI, flat-earth NED world frame
(altitude = -z), body FRD, quaternion Hamilton scalar first body→NED; the output's
decoy position is in the aircraft's flight-path frame (x along its velocity,
y horizontal right, z down) relative to the aircraft reference point.
"""

from __future__ import annotations

import collections
import ctypes
import json
import os
import re
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import iceoryx2 as iox

from . import wire
from .errors import BridgeError, BridgeTimeout, NoBridge, Rejected, VersionMismatch

DEFAULT_TIMEOUT_S = 2.0
"""How long an operation waits for the bridge by default, s."""
CONNECT_TIMEOUT_S = 2.0
"""How long :class:`Bridge` waits for a starting bridge to be ready by default, s
(the Rust client's ``CONNECT_TIMEOUT``)."""
READY_POLL_S = 0.005
"""How often :class:`Bridge` looks for the readiness mark while a bridge starts, s
(the services may not exist yet: there is no event to wait on)."""


PREFIX_ENV = "DECOY_IOX_PREFIX"
"""Environment variable: the iceoryx2 file prefix (as the bridge reads it)."""
ROOT_ENV = "DECOY_IOX_ROOT"
"""Environment variable: the iceoryx2 root directory (default ``/tmp/iceoryx2/``)."""


def make_config(prefix: str | None = None, root: str | None = None) -> Any:
    """The iceoryx2 configuration the bridge uses: iceoryx2's defaults with the file
    ``prefix`` and ``root`` directory given, else from ``$DECOY_IOX_PREFIX`` and
    ``$DECOY_IOX_ROOT`` (docs/bridge.md §5). A bridge and its clients must agree;
    different prefixes never see each other."""
    cfg = iox.config.default()
    prefix = prefix or os.environ.get(PREFIX_ENV)
    root = root or os.environ.get(ROOT_ENV)
    if prefix:
        cfg.global_cfg.prefix = iox.FileName.new(prefix)
    if root:
        cfg.global_cfg.root_path = iox.Path.new(root if root.endswith("/") else root + "/")
    return cfg


def _kind(name: str) -> int:
    return wire.LAYOUT.codes["kind"][name]


# --- Zenoh ---------------------------------------------------------------------------------

ZENOH_READY_POLL_S = 0.02
"""How often :class:`Bridge` asks for the readiness token while a bridge starts
(over Zenoh), s."""
ZENOH_RESEND_PAUSE_S = 0.002
"""How long the client waits before it sends again a query Zenoh ended without a
reply, s (the Rust client's ``RESEND_PAUSE``)."""
ZENOH_OUTPUTS_BUFFER = 1024
"""Answers a client over Zenoh keeps from the ``outputs`` publication until
:meth:`Bridge.outputs` takes them (the oldest go first), as the Rust client's
``REMOTE_OUTPUTS_BUFFER`` and the shared-memory subscriber's buffer."""
ZENOH_STATUS_BUFFER = 4
"""Statuses a client over Zenoh keeps until :meth:`Bridge.status` takes them."""
_INSTANCE = re.compile(r"[A-Za-z0-9_-]{1,32}")


def wire_tag(cls: type) -> str:
    """The tag of wire type ``cls`` carried beside every payload over Zenoh: its
    type name and size, ``decoy.bridge.v4.AircraftState/104`` (the Rust
    ``Wire::tag``)."""
    return f"{cls.type_name()}/{ctypes.sizeof(cls)}"  # type: ignore[attr-defined]


def read_credentials(credentials: str | os.PathLike[str] | tuple[str, str]) -> tuple[str, str]:
    """``(user, password)`` of a client over Zenoh: given as a pair, or a file whose
    first line is ``user:password`` (as ``decoy feed --zenoh-credentials``).

    Raises:
        ValueError: an unreadable file, or no ``user:password`` in it.
    """
    if isinstance(credentials, tuple):
        if len(credentials) != 2 or not all(isinstance(x, str) and x for x in credentials):
            raise ValueError("credentials: a (user, password) pair of non-empty strings")
        return credentials[0], credentials[1]
    path = Path(credentials)
    try:
        text = path.read_text()
    except OSError as e:
        raise ValueError(f"cannot read the Zenoh credentials {path}: {e}") from e
    lines = text.splitlines()
    user, sep, password = (lines[0].strip() if lines else "").partition(":")
    if not (sep and user and password):
        raise ValueError(f"the Zenoh credentials {path} must hold one line `user:password`")
    return user, password


def make_zenoh_config(
    endpoints: str | Sequence[str] | None = None,
    config_file: str | os.PathLike[str] | None = None,
    credentials: str | os.PathLike[str] | tuple[str, str] | None = None,
    connect_timeout_s: float = CONNECT_TIMEOUT_S,
) -> Any:
    """The Zenoh configuration of a client of the bridge (the Rust client's):
    ``config_file`` (JSON5: TLS, certificates, ...) read first, then mode
    ``client``, no listening, multicast and gossip scouting and the admin space
    off, ``connect/endpoints`` = ``endpoints``, ``connect/timeout_ms`` =
    ``connect_timeout_s``, and the user/password of ``credentials``
    (:func:`read_credentials`).

    Raises:
        ValueError: no endpoint and no configuration file, an unreadable file,
            a value Zenoh refuses.
    """
    import zenoh

    given = [endpoints] if isinstance(endpoints, str) else list(endpoints or [])
    if not given and config_file is None:
        raise ValueError("a client over Zenoh needs zenoh=ENDPOINT (the bridge's --zenoh-listen) or zenoh_config=FILE")
    if config_file is not None:
        try:
            config = zenoh.Config.from_file(str(config_file))
        except Exception as e:  # zenoh.ZError, or the file is missing
            raise ValueError(f"cannot read the Zenoh configuration {config_file}: {e}") from e
    else:
        config = zenoh.Config()

    def insert(key: str, value: Any) -> None:
        try:
            config.insert_json5(key, json.dumps(value))
        except Exception as e:
            raise ValueError(f"Zenoh configuration {key} = {json.dumps(value)}: {e}") from e

    insert("scouting/multicast/enabled", False)
    insert("scouting/gossip/enabled", False)
    insert("adminspace/enabled", False)
    insert("mode", "client")
    insert("listen/endpoints", [])
    # Keep trying while a bridge starts, then fail (NoBridge).
    insert("connect/timeout_ms", max(1, round(connect_timeout_s * 1000.0)))
    if given:
        insert("connect/endpoints", given)
    if credentials is not None:
        user, password = read_credentials(credentials)
        insert("transport/auth/usrpwd/user", user)
        insert("transport/auth/usrpwd/password", password)
    return config


def _decode(cls: type, payload: bytes, attachment: Any, what: str, instance: str) -> Any:
    """A payload of wire type ``cls`` with its tag and size checked."""
    # The tag, then (on a query) a space and the query's id.
    text = "" if attachment is None else attachment.to_bytes().decode("utf-8", "replace")
    tag = text.split(" ")[0]
    expected = wire_tag(cls)
    if tag != expected:
        raise VersionMismatch(
            f"bridge `{instance}`: {what} is {tag or 'untagged'}, expected {expected} "
            f"(another protocol version or layout; this client speaks v{wire.PROTOCOL_VERSION})"
        )
    if len(payload) != ctypes.sizeof(cls):
        raise VersionMismatch(f"bridge `{instance}`: {what} has {len(payload)} bytes, {expected} has {ctypes.sizeof(cls)}")
    return cls.from_buffer_copy(payload)


class Bridge:
    """A connection to bridge instance ``instance``: over shared memory (iceoryx2, on
    the bridge's host), or across hosts over Zenoh when ``zenoh``, ``zenoh_config``
    or ``credentials`` is given (the bridge runs with ``--zenoh-listen``). The
    methods, their semantics and their exceptions are the same over both.

    Args:
        instance: the bridge's instance name (``decoy bridge --instance NAME``).
        prefix: the iceoryx2 file prefix the bridge runs with (default
            ``$DECOY_IOX_PREFIX``, else iceoryx2's). Shared memory only.
        root: the iceoryx2 root directory (default ``$DECOY_IOX_ROOT``, else
            ``/tmp/iceoryx2/``). Shared memory only.
        timeout_s: default time limit of every wait, s.
        node_name: this client's iceoryx2 node name (default ``decoy-py-<pid>``).
            Shared memory only.
        connect_timeout_s: how long to wait for the bridge to be ready (its
            ``status`` service with its publisher, created after everything
            else; over Zenoh: the bridge's session reached and its liveliness
            token ``decoy/NAME/alive`` seen), s.
        zenoh: Zenoh: the endpoint (``tcp/10.0.0.1:7447``, ``tls/host:7447``) or
            endpoints to connect to, the bridge's ``--zenoh-listen``.
        zenoh_config: Zenoh: a configuration file (JSON5: TLS, certificates,
            ...) read first; the settings of :func:`make_zenoh_config` are
            applied over it.
        credentials: Zenoh: this client's user and password for a bridge that
            authenticates (``--zenoh-users``): a file holding one line
            ``user:password``, or a ``(user, password)`` pair.

    Raises:
        NoBridge: no bridge is ready within ``connect_timeout_s`` (its services do
            not exist, or the readiness mark is missing: a bridge still starting,
            or one that died; over Zenoh also: nothing reachable at the
            endpoints, or the bridge refused this client's credentials).
        VersionMismatch: the bridge speaks another protocol version (its type names
            differ from this package's).
        ValueError: bad Zenoh arguments (no endpoint, an unreadable file, an
            instance name the bridge would refuse).
    """

    def __init__(
        self,
        instance: str,
        *,
        prefix: str | None = None,
        root: str | None = None,
        timeout_s: float = DEFAULT_TIMEOUT_S,
        node_name: str | None = None,
        connect_timeout_s: float = CONNECT_TIMEOUT_S,
        zenoh: str | Sequence[str] | None = None,
        zenoh_config: str | os.PathLike[str] | None = None,
        credentials: str | os.PathLike[str] | tuple[str, str] | None = None,
    ):
        self.instance = instance
        self.timeout_s = timeout_s
        self.layout = wire.LAYOUT
        # Each service's samples are numbered 0, 1, 2, ... (+1 each, wrapping).
        self._seq = -1
        self._cmd_seq = -1
        self._state_seq = -1
        self._transport: _Shm | _Zenoh | None = None
        if zenoh is not None or zenoh_config is not None or credentials is not None:
            self._transport_name = "zenoh"
            self._transport = _Zenoh(instance, zenoh, zenoh_config, credentials, connect_timeout_s)
        else:
            self._transport_name = "shm"
            self._transport = _Shm(instance, prefix, root, node_name, connect_timeout_s)

    @property
    def transport(self) -> str:
        """``"shm"`` (iceoryx2 shared memory) or ``"zenoh"`` (across hosts), as
        ``decoy feed``'s summary says."""
        return self._transport_name

    @property
    def queries_resent(self) -> int:
        """Queries sent again after Zenoh ended them without a reply (0 over shared
        memory); the bridge answers each once (docs/bridge.md §7, exactly once)."""
        return int(getattr(self._transport, "resent", 0))

    def _limit(self, timeout_s: float | None) -> float:
        return self.timeout_s if timeout_s is None else timeout_s

    def _ports(self) -> _Shm | _Zenoh:
        if self._transport is None:
            raise BridgeError(f"the client of bridge `{self.instance}` is closed")
        return self._transport

    # --- lockstep ------------------------------------------------------------------------

    def request(self, state: Any, timeout_s: float | None = None) -> Any:
        """Lockstep: sends one aircraft state and waits for its answer.

        ``state`` is a :class:`~decoy_bridge.wire.AircraftState` (its header is
        filled here: protocol version, kind, the next sequence number) or a mapping
        accepted by :func:`make_state`.

        Returns:
            the :class:`~decoy_bridge.wire.Output`; while the controller
            initialises (its trim, over the first state or a few), an output with
            the ``INITIALISING`` flag and no solution (:func:`is_initialising`).

        Raises:
            Rejected: the bridge rejected the state (``reason``, ``count``); the
                controller's state is as if it had never been sent.
            BridgeTimeout: no answer within ``timeout_s`` (default: the client's).
            VersionMismatch: the answer's protocol version differs.
        """
        answer = self.request_answer(state, timeout_s)
        return check_answer(answer)

    def request_answer(self, state: Any, timeout_s: float | None = None, *, keep_header: bool = False) -> Any:
        """Like :meth:`request` but returns the raw :class:`~decoy_bridge.wire.Answer`
        (output or rejection) without raising on a rejection.

        ``keep_header=True`` sends ``state``'s header as it is (protocol version and
        kind; the sequence number is still the client's): for testing the bridge's
        header checks."""
        msg = state if isinstance(state, wire.AircraftState) else make_state(**state)
        self._seq = (self._seq + 1) & 0xFFFFFFFF
        if not keep_header:
            msg.header.protocol_version = wire.PROTOCOL_VERSION
            msg.header.kind = _kind("aircraft_state")
        msg.header.seq = self._seq
        answer = self._ports().lockstep(msg, f"lockstep request {self._seq}", self._limit(timeout_s))
        if answer.header.protocol_version != wire.PROTOCOL_VERSION:
            raise VersionMismatch(
                f"answer of protocol v{answer.header.protocol_version}, this client speaks v{wire.PROTOCOL_VERSION}"
            )
        return answer

    @property
    def last_seq(self) -> int:
        """The sequence number of the last lockstep request sent (-1 before any)."""
        return self._seq

    # --- free-running ---------------------------------------------------------------------

    def publish(self, state: Any) -> int:
        """Free-running: publishes one aircraft state without waiting; returns its
        sequence number. The bridge processes samples in order and counts (status
        ``lost``, ``overruns``) what it could not process in time."""
        ports = self._ports()
        msg = state if isinstance(state, wire.AircraftState) else make_state(**state)
        self._state_seq = (self._state_seq + 1) & 0xFFFFFFFF
        msg.header.protocol_version = wire.PROTOCOL_VERSION
        msg.header.kind = _kind("aircraft_state")
        msg.header.seq = self._state_seq
        ports.publish(msg)
        return self._state_seq

    # --- listening -----------------------------------------------------------------------

    def subscribe_outputs(self) -> None:
        """Starts receiving every answer the bridge publishes; see :meth:`outputs`.
        Over shared memory with the service's small history for late joiners; over
        Zenoh the answers published from now on (this returns once the bridge
        knows of the subscription)."""
        self._ports().subscribe_outputs(self.timeout_s)

    def outputs(self, timeout_s: float | None = None, at_least: int = 1) -> list[Any]:
        """The answers published since the last call (:class:`~decoy_bridge.wire.Answer`,
        in order), waiting up to ``timeout_s`` for ``at_least`` of them.

        Raises:
            BridgeTimeout: fewer than ``at_least`` arrived in time.
        """
        ports = self._ports()
        ports.subscribe_outputs(self.timeout_s)
        return ports.outputs(at_least, self._limit(timeout_s))

    def status(self, timeout_s: float | None = None) -> Any:
        """The bridge's latest published :class:`~decoy_bridge.wire.Status`
        (waiting up to ``timeout_s`` for one)."""
        return self._ports().statuses(self._limit(timeout_s))[-1]

    # --- commands ------------------------------------------------------------------------

    def command(self, name: str, *, profile: str | None = None, rate_radps: float = 0.0, nonce: int = 0,
                timeout_s: float | None = None) -> Any:
        """Sends command ``name`` (``reset_to_trim``, ``select_profile``,
        ``get_status``, ``ping``) and returns the :class:`~decoy_bridge.wire.CommandReply`.

        Raises:
            Rejected: the bridge rejected the command.
            BridgeTimeout: no reply in time.
        """
        codes = self.layout.codes
        if name not in codes["command"]:
            raise ValueError(f"unknown command {name!r}; one of {', '.join(codes['command'])}")
        cmd = wire.Command()
        self._cmd_seq = (self._cmd_seq + 1) & 0xFFFFFFFF
        cmd.header.protocol_version = wire.PROTOCOL_VERSION
        cmd.header.kind = _kind("command")
        cmd.header.seq = self._cmd_seq
        cmd.command = codes["command"][name]
        if profile is not None:
            key = profile.replace("-", "_")
            if key not in codes["profile"]:
                raise ValueError(f"unknown profile {profile!r}; one of {', '.join(codes['profile'])}")
            cmd.profile = codes["profile"][key]
        cmd.rate_milli_radps = round(rate_radps * 1000.0)
        cmd.nonce = nonce
        reply = self._ports().command(cmd, f"command {name}", self._limit(timeout_s))
        if reply.header.protocol_version != wire.PROTOCOL_VERSION:
            raise VersionMismatch(f"reply of protocol v{reply.header.protocol_version}")
        if reply.result != codes["result"]["ok"]:
            reason = self.layout.code_name("reason", reply.reason)
            raise Rejected(reason, reply.reason, 0, reply.request_seq, f"command {name} rejected: {reason}")
        return reply

    def reset_to_trim(self, timeout_s: float | None = None) -> Any:
        """Command: the controller back to its waiting state; the next state trims."""
        return self.command("reset_to_trim", timeout_s=timeout_s)

    def ping(self, nonce: int = 0, timeout_s: float | None = None) -> Any:
        """Command: a round trip; the reply echoes ``nonce``."""
        return self.command("ping", nonce=nonce, timeout_s=timeout_s)

    def get_status(self, timeout_s: float | None = None) -> Any:
        """Command: the bridge's :class:`~decoy_bridge.wire.Status` now."""
        return self.command("get_status", timeout_s=timeout_s).status

    def select_profile(self, profile: str, rate_radps: float = 0.0, timeout_s: float | None = None) -> Any:
        """Command: select a built-in profile by name: ``streamed``, or a manoeuvre
        (the ``profile`` codes of the layout: ``steady``, ``pull-up`` or ``pull_up``,
        ...); the rate in rad/s for the manoeuvres that have one (pull-up, turn)."""
        return self.command("select_profile", profile=profile, rate_radps=rate_radps, timeout_s=timeout_s)

    # --- closing -------------------------------------------------------------------------

    def close(self) -> None:
        """Releases every port, the services and the node (removing the node's files;
        over Zenoh: the subscriptions, the publisher and the session); also on
        ``with`` exit. The client cannot be used afterwards."""
        transport, self._transport = self._transport, None
        if transport is not None:
            transport.close()

    def __enter__(self) -> "Bridge":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class _Shm:
    """The shared-memory transport of :class:`Bridge`: the instance's iceoryx2
    services, ports, events and WaitSet."""

    def __init__(self, instance: str, prefix: str | None, root: str | None, node_name: str | None,
                 connect_timeout_s: float):
        self.instance = instance
        self._node = (
            iox.NodeBuilder.new()
            .name(iox.NodeName.new(node_name or f"decoy-py-{os.getpid()}"))
            .config(make_config(prefix, root))
            .create(iox.ServiceType.Ipc)
        )
        # The readiness mark first: every other service and port exists once it does.
        self._status_svc = self._wait_until_ready(connect_timeout_s)
        self._lockstep_svc = self._open_rr("lockstep", wire.AircraftState, wire.Answer)
        self._commands_svc = self._open_rr("commands", wire.Command, wire.CommandReply)
        self._state_svc = self._open_ps("state", wire.AircraftState)
        self._outputs_svc = self._open_ps("outputs", wire.Answer)
        self._to_bridge = self._open_event("to-bridge")
        self._from_bridge = self._open_event("from-bridge")

        self._lockstep = self._lockstep_svc.client_builder().create()
        self._commands = self._commands_svc.client_builder().create()
        self._publisher: Any = None
        self._outputs_sub: Any = None
        self._status_sub: Any = None
        self._notifier = self._to_bridge.notifier_builder().create()
        self._listener = self._from_bridge.listener_builder().create()
        self._waitset = iox.WaitSetBuilder.new().create(iox.ServiceType.Ipc)
        self._guard = self._waitset.attach_notification(self._listener)
        self._ev = {k: iox.EventId.new(v) for k, v in wire.LAYOUT.event_ids.items()}
        if self._lockstep_svc.dynamic_config.number_of_servers == 0:
            raise NoBridge(f"bridge `{instance}` is not running (its services exist but nothing serves them)")

    # --- opening ------------------------------------------------------------------------

    def _name(self, service: str) -> Any:
        return iox.ServiceName.new(f"decoy/{self.instance}/{service}")

    def _open(self, service: str, builder: Any) -> Any:
        try:
            return builder.open()
        except Exception as e:  # iceoryx2 raises one exception type per builder
            text = f"{type(e).__name__}: {e}"
            if "DoesNotExist" in text:
                raise NoBridge(f"no bridge `{self.instance}` (service decoy/{self.instance}/{service} does not exist)") from e
            if "Incompatible" in text:
                raise VersionMismatch(
                    f"decoy/{self.instance}/{service}: the bridge's types differ from this client's "
                    f"(protocol v{wire.PROTOCOL_VERSION}); {text}"
                ) from e
            raise BridgeError(f"cannot open decoy/{self.instance}/{service}: {text}") from e

    def _wait_until_ready(self, timeout_s: float) -> Any:
        """The ``status`` service once it has its publisher (the bridge's readiness
        mark), looking every :data:`READY_POLL_S`; NoBridge after ``timeout_s``."""
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                svc = self._open_ps("status", wire.Status)
            except NoBridge as e:
                why = str(e)
            except BridgeError as e:
                # A service being created or removed: a bridge starting or stopping.
                if not any(s in str(e) for s in ("HangsInCreation", "IsMarkedForDestruction", "CorruptedState")):
                    raise
                why = str(e)
            else:
                if svc.dynamic_config.number_of_publishers > 0:
                    return svc
                why = "its status service has no publisher: the bridge is starting, or died"
                del svc
            if time.monotonic() >= deadline:
                raise NoBridge(
                    f"no bridge `{self.instance}` is ready ({why}; waited {timeout_s:.3f} s); "
                    f"start one with `decoy bridge --instance {self.instance}`"
                )
            time.sleep(READY_POLL_S)

    def _open_rr(self, service: str, req: type, resp: type) -> Any:
        return self._open(service, self._node.service_builder(self._name(service)).request_response(req, resp))

    def _open_ps(self, service: str, payload: type) -> Any:
        return self._open(service, self._node.service_builder(self._name(service)).publish_subscribe(payload))

    def _open_event(self, service: str) -> Any:
        return self._open(service, self._node.service_builder(self._name(service)).event())

    # --- waiting -------------------------------------------------------------------------

    def _wait(self, deadline: float) -> None:
        """Blocks until the bridge notifies or ``deadline`` (time.monotonic) passes."""
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            return
        _, result = self._waitset.wait_and_process_with_timeout(iox.Duration.from_secs_f64(remaining))
        if result in (iox.WaitSetRunResult.Interrupt, iox.WaitSetRunResult.TerminationRequest):
            raise KeyboardInterrupt
        # Consume the notifications, or the WaitSet wakes at once next time.
        self._listener.try_wait()

    def _notify(self, event: str) -> None:
        self._notifier.notify_with_custom_event_id(self._ev[event])

    def _receive_response(self, pending: Any, what: str, timeout_s: float) -> Any:
        deadline = time.monotonic() + timeout_s
        while True:
            response = pending.receive()
            if response is not None:
                value = type(response.payload().contents).from_buffer_copy(response.payload().contents)
                response.delete()
                return value
            if time.monotonic() >= deadline:
                if self._lockstep_svc.dynamic_config.number_of_servers == 0:
                    raise NoBridge(f"bridge `{self.instance}` went away while waiting for {what}")
                raise BridgeTimeout(f"bridge `{self.instance}` did not answer {what} within {timeout_s:.3f} s")
            self._wait(deadline)

    # --- the operations of Bridge ------------------------------------------------------

    def lockstep(self, msg: Any, what: str, timeout_s: float) -> Any:
        pending = self._lockstep.loan_uninit().write_payload(msg).send()
        self._notify("REQUEST")
        answer = self._receive_response(pending, what, timeout_s)
        pending.delete()
        return answer

    def command(self, cmd: Any, what: str, timeout_s: float) -> Any:
        pending = self._commands.loan_uninit().write_payload(cmd).send()
        self._notify("COMMAND")
        reply = self._receive_response(pending, what, timeout_s)
        pending.delete()
        return reply

    def publish(self, msg: Any) -> None:
        if self._publisher is None:
            self._publisher = self._state_svc.publisher_builder().create()
        self._publisher.loan_uninit().write_payload(msg).send()
        self._notify("STATE")

    def subscribe_outputs(self, timeout_s: float) -> None:
        if self._outputs_sub is None:
            self._outputs_sub = self._outputs_svc.subscriber_builder().create()

    def outputs(self, at_least: int, timeout_s: float) -> list[Any]:
        return self._drain(self._outputs_sub, at_least, timeout_s, "outputs")

    def statuses(self, timeout_s: float) -> list[Any]:
        if self._status_sub is None:
            self._status_sub = self._status_svc.subscriber_builder().create()
        return self._drain(self._status_sub, 1, timeout_s, "a status")

    def _drain(self, sub: Any, at_least: int, timeout_s: float, what: str) -> list[Any]:
        deadline = time.monotonic() + timeout_s
        got: list[Any] = []
        while True:
            while True:
                sample = sub.receive()
                if sample is None:
                    break
                c = sample.payload().contents
                got.append(type(c).from_buffer_copy(c))
                sample.delete()
            if len(got) >= at_least:
                return got
            if time.monotonic() >= deadline:
                raise BridgeTimeout(f"bridge `{self.instance}`: {len(got)} of {at_least} {what} within the time limit")
            self._wait(deadline)

    def close(self) -> None:
        for attr in ("_guard", "_waitset", "_listener", "_notifier", "_publisher", "_outputs_sub", "_status_sub",
                     "_lockstep", "_commands"):
            port = getattr(self, attr, None)
            if port is not None and hasattr(port, "delete"):
                try:
                    port.delete()
                except Exception:
                    pass
            setattr(self, attr, None)
        for attr in ("_lockstep_svc", "_commands_svc", "_state_svc", "_outputs_svc", "_status_svc", "_to_bridge",
                     "_from_bridge", "_node"):
            setattr(self, attr, None)


def _receiver(queue: collections.deque, ready: threading.Condition, cls: type, what: str, instance: str) -> Any:
    """A subscription's callback (run on Zenoh's thread): each sample decoded (or
    its VersionMismatch, raised when taken) into ``queue``, waking the waiters.
    It holds no reference to the client, which Python may then collect."""

    def on_sample(sample: Any) -> None:
        try:
            value: Any = _decode(cls, sample.payload.to_bytes(), sample.attachment, what, instance)
        except VersionMismatch as e:
            value = e
        with ready:
            queue.append(value)
            ready.notify_all()

    return on_sample


class _Zenoh:
    """The Zenoh transport of :class:`Bridge` (the Rust client's ``ZenohClient``):
    a client session connected to the bridge's endpoints, queries for the lockstep
    and the commands, a publisher of free-running states, subscriptions of the
    outputs and the status."""

    def __init__(self, instance: str, endpoints: str | Sequence[str] | None, config_file: Any, credentials: Any,
                 connect_timeout_s: float):
        import zenoh

        if not isinstance(instance, str) or not _INSTANCE.fullmatch(instance):
            raise ValueError(f"instance must be 1 to 32 of A-Z a-z 0-9 _ -, got {instance!r}")
        self.instance = instance
        self._zenoh = zenoh
        self._where = ", ".join([endpoints] if isinstance(endpoints, str) else list(endpoints or [])) or str(config_file)
        self._session: Any = None
        self._publisher: Any = None
        self._outputs_sub: Any = None
        self._status_sub: Any = None
        self._ready = threading.Condition()
        self._queries = 0
        self.resent_now = 0
        self.resent = 0
        """Queries sent again after Zenoh ended them without a reply."""
        self._outputs: collections.deque = collections.deque(maxlen=ZENOH_OUTPUTS_BUFFER)
        self._statuses: collections.deque = collections.deque(maxlen=ZENOH_STATUS_BUFFER)
        config = make_zenoh_config(endpoints, config_file, credentials, connect_timeout_s)
        deadline = time.monotonic() + connect_timeout_s
        try:
            self._session = zenoh.open(config)
        except zenoh.ZError as e:
            raise NoBridge(
                f"no bridge reachable over Zenoh at {self._where} within {connect_timeout_s:.3f} s ({e}): is "
                f"`decoy bridge --instance {instance} --zenoh-listen ...` running there, and are this client's "
                f"credentials the bridge's?"
            ) from e
        self._session_id = str(self._session.zid())
        try:
            # Subscribed before the readiness token is seen: the bridge knows of
            # the subscription by then (same link, in order).
            self._status_sub = self._session.declare_subscriber(
                self._key("status"), _receiver(self._statuses, self._ready, wire.Status, "a status sample", instance)
            )
            self._wait_until_ready(deadline, connect_timeout_s)
        except BaseException:
            self.close()
            raise

    def _key(self, service: str) -> str:
        return f"decoy/{self.instance}/{service}"

    def _alive(self, timeout_s: float) -> bool:
        """Whether the bridge's readiness token ``decoy/NAME/alive`` answers within
        ``timeout_s`` (a round trip through the bridge's session)."""
        try:
            replies = self._session.liveliness().get(self._key("alive"), timeout=timeout_s)
            return any(reply.ok is not None for reply in replies)
        except self._zenoh.ZError as e:
            raise BridgeError(f"Zenoh: asking for the readiness token of bridge `{self.instance}`: {e}") from e

    def _wait_until_ready(self, deadline: float, timeout_s: float) -> None:
        while True:
            if self._alive(min(max(deadline - time.monotonic(), 0.001), 0.5)):
                return
            if time.monotonic() >= deadline:
                raise NoBridge(
                    f"no bridge `{self.instance}` is ready over Zenoh at {self._where} (no {self._key('alive')} "
                    f"token within {timeout_s:.3f} s); start one with "
                    f"`decoy bridge --instance {self.instance} --zenoh-listen ENDPOINT`"
                )
            time.sleep(ZENOH_READY_POLL_S)  # startup only: the token does not exist yet

    def _query(self, service: str, msg: Any, reply_cls: type, what: str, timeout_s: float) -> Any:
        """One query: ``msg`` to ``decoy/NAME/service``, its one reply within ``timeout_s``.

        The attachment carries the tag and the query's id (``<session id>:<n>``). A
        query Zenoh ends without a reply before the time limit (it routed it to no
        queryable while its routes were rebuilt, or lost the reply) is sent again
        with the same id after :data:`ZENOH_RESEND_PAUSE_S`; the bridge answers an id
        it already answered from its record, so the controller sees each state once
        (the Rust client's rule, docs/bridge.md §7)."""
        zenoh = self._zenoh
        deadline = time.monotonic() + timeout_s
        self._queries += 1
        attachment = f"{wire_tag(type(msg))} {self._session_id}:{self._queries}"
        self.resent_now = 0
        while True:
            left = max(deadline - time.monotonic(), 0.001)
            try:
                replies = self._session.get(
                    self._key(service),
                    payload=bytes(msg),
                    attachment=attachment,
                    target=zenoh.QueryTarget.BEST_MATCHING,
                    # The one reply as soon as it comes.
                    consolidation=zenoh.ConsolidationMode.NONE,
                    timeout=left,
                )
            except zenoh.ZError as e:
                raise BridgeError(f"Zenoh: sending {what} to bridge `{self.instance}`: {e}") from e
            try:
                reply = replies.recv()
                break
            except zenoh.ZError:  # the query ended without a reply
                if time.monotonic() + ZENOH_RESEND_PAUSE_S < deadline:
                    self.resent += 1
                    self.resent_now += 1
                    time.sleep(ZENOH_RESEND_PAUSE_S)
                    continue
                # Within the deadline, as the Rust client's NoAnswer.
                raise BridgeTimeout(
                    f"bridge `{self.instance}` did not answer {what} within {timeout_s:.3f} s (over Zenoh at "
                    f"{self._where}; every query ended without a reply, sent {self.resent_now + 1} times)"
                ) from None
        sample = reply.ok
        if sample is None:
            text = reply.err.payload.to_bytes().decode("utf-8", "replace")
            if text.startswith("decoy bridge: protocol: ") or "expected decoy.bridge" in text:
                raise VersionMismatch(f"bridge `{self.instance}` refused {what}: {text}")
            # Zenoh's own error reply when the query's time limit passes with the
            # queryable matched but silent (a stopped bridge, a slow link).
            if text == "Timeout" or time.monotonic() >= deadline - 0.001:
                raise BridgeTimeout(
                    f"bridge `{self.instance}` did not answer {what} within {timeout_s:.3f} s (over Zenoh at {self._where})"
                )
            # The bridge's own error replies: its shared-memory client failed.
            if "not serving" in text or "released the request" in text:
                raise NoBridge(f"bridge `{self.instance}` went away while waiting for {what}: {text}")
            if "within" in text:
                raise BridgeTimeout(f"bridge `{self.instance}` did not answer {what}: {text}")
            raise BridgeError(f"bridge `{self.instance}` could not answer {what}: {text}")
        return _decode(reply_cls, sample.payload.to_bytes(), sample.attachment, f"the reply to {what}", self.instance)

    # --- the operations of Bridge ------------------------------------------------------

    def lockstep(self, msg: Any, what: str, timeout_s: float) -> Any:
        return self._query("lockstep", msg, wire.Answer, what, timeout_s)

    def command(self, cmd: Any, what: str, timeout_s: float) -> Any:
        return self._query("commands", cmd, wire.CommandReply, what, timeout_s)

    def publish(self, msg: Any) -> None:
        if self._publisher is None:
            self._publisher = self._session.declare_publisher(self._key("state"))
        try:
            self._publisher.put(bytes(msg), attachment=wire_tag(wire.AircraftState))
        except self._zenoh.ZError as e:
            raise BridgeError(f"Zenoh: publishing a state to bridge `{self.instance}`: {e}") from e

    def subscribe_outputs(self, timeout_s: float) -> None:
        if self._outputs_sub is None:
            self._outputs_sub = self._session.declare_subscriber(
                self._key("outputs"),
                _receiver(self._outputs, self._ready, wire.Answer, "an outputs sample", self.instance),
            )
            # A round trip through the bridge's session: it knows of the
            # subscription before the next request is answered.
            if not self._alive(timeout_s):
                raise NoBridge(f"bridge `{self.instance}` went away (no {self._key('alive')} token over Zenoh)")

    def outputs(self, at_least: int, timeout_s: float) -> list[Any]:
        return self._drain(self._outputs, at_least, timeout_s, "outputs")

    def statuses(self, timeout_s: float) -> list[Any]:
        return self._drain(self._statuses, 1, timeout_s, "a status")

    def _drain(self, queue: collections.deque, at_least: int, timeout_s: float, what: str) -> list[Any]:
        deadline = time.monotonic() + timeout_s
        got: list[Any] = []
        with self._ready:
            while True:
                while queue:
                    value = queue.popleft()
                    if isinstance(value, BaseException):
                        raise value
                    got.append(value)
                if len(got) >= at_least:
                    return got
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise BridgeTimeout(f"bridge `{self.instance}`: {len(got)} of {at_least} {what} within the time limit")
                self._ready.wait(remaining)

    def close(self) -> None:
        for attr in ("_outputs_sub", "_status_sub", "_publisher"):
            entity = getattr(self, attr, None)
            if entity is not None:
                try:
                    entity.undeclare()
                except Exception:
                    pass
            setattr(self, attr, None)
        session, self._session = self._session, None
        if session is not None:
            # Zenoh's goodbye to a bridge whose link is cut waits up to 10 s. Not
            # on a thread of its own (as the Rust client does): a daemon thread
            # still inside Zenoh when the interpreter ends aborts the process.
            try:
                session.close()
            except Exception:
                pass


def is_initialising(output: Any) -> bool:
    """True for the output answering a state while the bridge's controller
    initialises (it is computing the trim its run starts from; the answer's kind
    is ``initialising`` and the output's ``INITIALISING`` flag is set): its
    ``time_s``, ``flags`` and ``instructions`` are set, its solution is zero.
    The first state after the trim completes is answered by a real output."""
    return bool(int(output.flags) & wire.LAYOUT.codes["flag"]["initialising"])


def check_answer(answer: Any) -> Any:
    """The :class:`~decoy_bridge.wire.Output` of an answer (while the controller
    initialises, an output with the ``INITIALISING`` flag: see
    :func:`is_initialising`), or :class:`Rejected`."""
    if answer.header.kind in (_kind("output"), _kind("initialising")):
        return answer.output
    if answer.header.kind == _kind("rejected"):
        r = answer.rejection
        reason = wire.LAYOUT.code_name("reason", r.reason)
        if reason.lower().replace("_", "") == "wrongversion":
            raise VersionMismatch(f"state {r.request_seq}: the bridge rejected this client's protocol version "
                                  f"v{wire.PROTOCOL_VERSION}")
        raise Rejected(reason, r.reason, r.count, r.request_seq, f"state {r.request_seq} rejected: {reason} (#{r.count})")
    raise BridgeError(f"answer of unexpected kind {answer.header.kind}")


def make_state(
    time_s: float,
    position_ned_m: Sequence[float],
    velocity_ned_mps: Sequence[float],
    acceleration_ned_mps2: Sequence[float] = (0.0, 0.0, 0.0),
    attitude_wxyz: Sequence[float] = (1.0, 0.0, 0.0, 0.0),
    body_rate_radps: Sequence[float] = (0.0, 0.0, 0.0),
    body_angular_acceleration_radps2: Sequence[float] = (0.0, 0.0, 0.0),
) -> Any:
    """An :class:`~decoy_bridge.wire.AircraftState` (header filled when sent).

    Args:
        time_s: simulation time, s (strictly increasing, at most 0.1 s steps).
        position_ned_m: reference point, flat-earth NED, m (altitude = -z).
        velocity_ned_mps: velocity over the ground, NED, m/s.
        acceleration_ned_mps2: NED, m/s².
        attitude_wxyz: Hamilton quaternion, scalar first, body (FRD) → NED.
        body_rate_radps: p, q, r (body FRD), rad/s.
        body_angular_acceleration_radps2: their derivatives, rad/s².
    """
    s = wire.AircraftState()
    s.time_s = float(time_s)
    for name, values in (
        ("position_ned_m", position_ned_m),
        ("velocity_ned_mps", velocity_ned_mps),
        ("acceleration_ned_mps2", acceleration_ned_mps2),
        ("attitude_wxyz", attitude_wxyz),
        ("body_rate_radps", body_rate_radps),
        ("body_angular_acceleration_radps2", body_angular_acceleration_radps2),
    ):
        arr = getattr(s, name)
        if len(values) != len(arr):
            raise ValueError(f"{name}: expected {len(arr)} values, got {len(values)}")
        for i, v in enumerate(values):
            arr[i] = float(v)
    return s


def output_dict(out: Any) -> dict[str, Any]:
    """An :class:`~decoy_bridge.wire.Output` as plain values (see :func:`wire.to_dict`)."""
    return wire.to_dict(out)


_ = ctypes  # ctypes structures come from wire
