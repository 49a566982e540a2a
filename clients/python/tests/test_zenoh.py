"""The client across hosts over Zenoh (``Bridge(..., zenoh=ENDPOINT)``) against a
real ``decoy bridge --zenoh-listen``: the same answers, byte for byte, as over
shared memory; commands, status, free-running; the wire tags checked on both
sides; NoBridge and BridgeTimeout; two hosts in two network namespaces with
user/password authentication; the JSBSim example over Zenoh."""

from __future__ import annotations

import contextlib
import csv
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import zenoh

from decoy_bridge import Bridge, BridgeTimeout, NoBridge, Rejected, VersionMismatch, make_state, wire
from decoy_bridge import client as client_module
from decoy_bridge import f16 as F
from decoy_bridge import flight
from decoy_bridge.client import make_zenoh_config, read_credentials, wire_tag

from conftest import REPO, RunningBridge

HERE = Path(__file__).resolve().parent
SPEED = 243.0  # m/s, about Mach 0.8 at 9 km


def level(t: float):
    return make_state(t, [SPEED * t, 0.0, -9000.0], [SPEED, 0.0, 0.0])


def free_port() -> int:
    """A TCP port of loopback free now (the bridge binds it a moment later)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def normalised(answer) -> bytes:
    """An answer's bytes with header.seq zeroed: the bridge numbers its answers
    across all its clients (the shared-memory flight's and the Zenoh flight's
    differ by the frames between them); every other byte is the flight's."""
    copy = type(answer).from_buffer_copy(answer)
    copy.header.seq = 0
    return bytes(copy)


@pytest.fixture(scope="module")
def frames() -> list[bytes]:
    """JSBSim's F-16 pulling up at 0.2 rad/s from t = 2 s, 4 s: 401 states."""
    fdm = F.F16(9000.0, 0.8)
    man = F.make_manoeuvre("pull-up", fdm, 0.2)
    return [bytes(flight.to_wire(s)) for s in fdm.fly(man, 4.0)]


def fly(c: Bridge, frames: list[bytes]) -> list[bytes]:
    """A lockstep flight after a reset to trim: each answer, normalised."""
    c.reset_to_trim()
    return [normalised(c.request_answer(wire.AircraftState.from_buffer_copy(b))) for b in frames]


def zenoh_bridge(bridge_factory, *args: str) -> tuple[RunningBridge, str]:
    """A bridge listening on loopback over Zenoh too, once it serves."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    b = bridge_factory("--zenoh-listen", endpoint, *args)
    b.client().close()  # serving over shared memory (the gateway starts right after)
    return b, endpoint


def remote(b: RunningBridge, endpoint: str, **kw) -> Bridge:
    kw.setdefault("timeout_s", 5.0)
    kw.setdefault("connect_timeout_s", 10.0)
    return Bridge(b.instance, zenoh=endpoint, **kw)


# --- loopback ---------------------------------------------------------------------------


def test_lockstep_over_zenoh_is_byte_for_byte_the_shared_memory_flight(bridge_factory, frames):
    """The F-16 pull-up flown over shared memory, then over Zenoh (each after a
    reset to trim, each client numbering from 0): the same answers, every byte but
    the bridge's own answer numbering; the bridge counted the remote frames."""
    b, endpoint = zenoh_bridge(bridge_factory)
    with b.client() as c:
        local = fly(c, frames)
        before = c.get_status().counters
    with remote(b, endpoint) as z:
        assert z.transport == "zenoh"
        answers = fly(z, frames)
        assert z.last_seq == len(frames) - 1
    assert len(answers) == len(local) == 401
    kinds = [wire.Answer.from_buffer_copy(a).header.kind for a in answers]
    assert kinds.count(wire.LAYOUT.codes["kind"]["output"]) > 390
    assert answers == local
    with b.client() as c:
        after = c.get_status().counters
    assert after.lockstep_requests - before.lockstep_requests == len(frames)
    assert after.lost == before.lost
    assert b.stop()["zenoh"]["lockstep"] == len(frames)


def test_commands_status_free_running_and_tags_over_zenoh(bridge_factory, monkeypatch):
    b, endpoint = zenoh_bridge(bridge_factory)
    with remote(b, endpoint) as z:
        # Commands and the published status.
        assert z.ping(nonce=4242).nonce == 4242
        st = z.get_status()
        assert wire.to_dict(st)["instance"] == b.instance
        assert st.header.protocol_version == wire.PROTOCOL_VERSION
        assert wire.LAYOUT.code_name("backend", st.backend) == "host"
        with pytest.raises(Rejected):
            z.select_profile("turn", rate_radps=1.5)  # above 1 rad/s
        assert wire.to_dict(z.status(timeout_s=3.0))["instance"] == b.instance

        # Free-running: every state answered on outputs, in order.
        z.subscribe_outputs()
        z.reset_to_trim()
        before = z.get_status().counters
        for k in range(200):
            assert z.publish(level(k * 0.01)) == k
        answers = z.outputs(at_least=200, timeout_s=10.0)[-200:]
        assert [a.output.request_seq for a in answers] == list(range(200))
        assert all(a.header.kind == wire.LAYOUT.codes["kind"]["output"] for a in answers)
        after = z.get_status().counters
        assert after.free_samples - before.free_samples == 200
        assert after.lost == before.lost
        with pytest.raises(BridgeTimeout, match="0 of 1 outputs"):
            z.outputs(timeout_s=0.2)

        # A query of another protocol version: the bridge answers by an error
        # reply naming the tag it expects ...
        session = zenoh.open(make_zenoh_config(endpoint))
        try:
            replies = list(session.get(f"decoy/{b.instance}/lockstep", payload=bytes(level(0.0)),
                                       attachment="decoy.bridge.v2.AircraftState/104", timeout=5.0))
        finally:
            session.close()
        assert len(replies) == 1 and replies[0].ok is None
        text = replies[0].err.payload.to_bytes().decode()
        assert "expected decoy.bridge.v4.AircraftState/104" in text, text
        # ... which the client raises as VersionMismatch.
        real = wire_tag
        monkeypatch.setattr(client_module, "wire_tag",
                            lambda cls: real(cls).replace(".v4.", ".v2.") if cls is wire.AircraftState else real(cls))
        with pytest.raises(VersionMismatch, match="expected decoy.bridge.v4.AircraftState/104"):
            z.request(level(0.0))
        monkeypatch.undo()
        assert z.ping(nonce=7).nonce == 7
    assert b.stop()["zenoh"]["refused"] == 2


def test_a_reply_of_another_tag_is_a_version_mismatch(bridge_factory):
    """The client checks the replies' tags too: a "bridge" (a Zenoh session serving
    another instance through the real bridge's session) answering with another
    version's Answer."""
    b, endpoint = zenoh_bridge(bridge_factory)
    fake = f"{b.instance}fake"
    session = zenoh.open(make_zenoh_config(endpoint))
    try:
        token = session.liveliness().declare_token(f"decoy/{fake}/alive")
        queryable = session.declare_queryable(
            f"decoy/{fake}/lockstep",
            lambda q: q.reply(q.key_expr, bytes(wire.Answer()), attachment="decoy.bridge.v2.Answer/240"),
        )
        with Bridge(fake, zenoh=endpoint, connect_timeout_s=10.0) as z:
            with pytest.raises(VersionMismatch, match="decoy.bridge.v2.Answer/240, expected decoy.bridge.v4.Answer"):
                z.request(level(0.0))
        queryable.undeclare()
        token.undeclare()
    finally:
        session.close()


def test_no_bridge_over_zenoh_within_the_connect_timeout(bridge_factory):
    # Nothing listens.
    t0 = time.monotonic()
    with pytest.raises(NoBridge, match="no bridge reachable over Zenoh"):
        Bridge("nobody", zenoh=f"tcp/127.0.0.1:{free_port()}", connect_timeout_s=0.5)
    assert time.monotonic() - t0 < 2.0
    # A bridge listens, but serves another instance: no readiness token.
    b, endpoint = zenoh_bridge(bridge_factory)
    remote(b, endpoint).close()
    t0 = time.monotonic()
    with pytest.raises(NoBridge, match=r"no bridge `nobody` is ready over Zenoh .*no decoy/nobody/alive token"):
        Bridge("nobody", zenoh=endpoint, connect_timeout_s=0.5)
    assert time.monotonic() - t0 < 2.0
    # Bad arguments are errors of the caller.
    with pytest.raises(ValueError, match="needs zenoh=ENDPOINT"):
        Bridge("nobody", credentials=("pilot", "secret"))
    with pytest.raises(ValueError, match="instance"):
        Bridge("no/body", zenoh=endpoint)


def test_a_stopped_bridge_is_a_timeout_over_zenoh(bridge_factory):
    """SIGSTOP the bridge between two frames: the next request and command fail
    with BridgeTimeout at their time limit, never hang; after SIGCONT the bridge
    answers again."""
    b, endpoint = zenoh_bridge(bridge_factory)
    with remote(b, endpoint, timeout_s=0.5) as z:
        z.reset_to_trim()
        z.request(level(0.0))
        os.kill(b.proc.pid, signal.SIGSTOP)
        try:
            t0 = time.monotonic()
            with pytest.raises(BridgeTimeout, match="did not answer lockstep request 1 within 0.500 s"):
                z.request(level(0.01))
            assert 0.45 < time.monotonic() - t0 < 2.0
            t0 = time.monotonic()
            with pytest.raises(BridgeTimeout, match="did not answer command ping"):
                z.ping(nonce=1, timeout_s=0.3)
            assert time.monotonic() - t0 < 2.0
        finally:
            os.kill(b.proc.pid, signal.SIGCONT)
        assert z.ping(nonce=2, timeout_s=5.0).nonce == 2


def test_credentials_files_are_read_as_the_rust_client_reads_them(tmp_path):
    good = tmp_path / "good"
    good.write_text("pilot:se:cret\nignored\n")
    assert read_credentials(good) == ("pilot", "se:cret")
    assert read_credentials(("pilot", "secret")) == ("pilot", "secret")
    for text in ("nopassword\n", ":secret\n", "pilot:\n", ""):
        bad = tmp_path / "bad"
        bad.write_text(text)
        with pytest.raises(ValueError, match="user:password"):
            read_credentials(bad)
    with pytest.raises(ValueError, match="cannot read"):
        read_credentials(tmp_path / "missing")


# --- two hosts on one machine --------------------------------------------------------------


def run(*cmd: str, **kw) -> subprocess.CompletedProcess:
    done = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if done.returncode != 0:
        raise AssertionError(f"`{' '.join(cmd)}` failed ({done.returncode}): {done.stderr.strip()}")
    return done


@contextlib.contextmanager
def two_hosts() -> Iterator[tuple[str, str, str, str]]:
    """Two network namespaces joined by a veth pair: (A, B, A's address, B's
    address), names and a /24 of 10.230.0.0/16 to 10.239.255.0/24 from this
    process's id; the namespaces (and with them the pair) deleted afterwards."""
    if os.geteuid() != 0:
        pytest.fail("the two-host test makes network namespaces: run it as root (CI does)")
    if shutil.which("ip") is None:
        pytest.fail("the two-host test needs `ip` (iproute2) for network namespaces")
    pid = os.getpid()
    a, b = f"dzpA{pid}", f"dzpB{pid}"
    va, vb = f"dzva{pid}"[:15], f"dzvb{pid}"[:15]
    net = f"10.23{pid % 10}.{(pid // 10) % 256}"
    addr_a, addr_b = f"{net}.1", f"{net}.2"
    made: list[str] = []
    try:
        for ns in (a, b):
            try:
                run("ip", "netns", "add", ns)
            except AssertionError as e:
                pytest.fail(f"`ip netns` is unavailable here: {e}")
            made.append(ns)
        run("ip", "link", "add", va, "type", "veth", "peer", "name", vb)
        run("ip", "link", "set", va, "netns", a)
        run("ip", "link", "set", vb, "netns", b)
        for ns, dev, addr in ((a, va, addr_a), (b, vb, addr_b)):
            run("ip", "-n", ns, "addr", "add", f"{addr}/24", "dev", dev)
            run("ip", "-n", ns, "link", "set", dev, "up")
            run("ip", "-n", ns, "link", "set", "lo", "up")
        yield a, b, addr_a, addr_b
    finally:
        for ns in made:
            subprocess.run(["ip", "netns", "del", ns], capture_output=True)
        # The pair goes with its namespaces; one left in the root namespace (a
        # failure between its creation and its move) goes here.
        subprocess.run(["ip", "link", "del", va], capture_output=True)


def test_across_two_hosts_in_network_namespaces(bridge_factory, frames, tmp_path):
    """The bridge in namespace A listening on A's address with user/password
    authentication; a client in namespace B, reachable only over the veth pair,
    flies the F-16 pull-up over Zenoh with its credentials: the answers of the
    same flight over shared memory (from the root namespace: /dev/shm and the
    iceoryx2 root are shared). Without credentials, or with a wrong password,
    the client is refused (NoBridge) and the bridge never sees a frame."""
    users = tmp_path / "users"
    users.write_text("pilot:secret\ncopilot:other\n")
    pilot = tmp_path / "pilot"
    pilot.write_text("pilot:secret\n")
    wrong = tmp_path / "wrong"
    wrong.write_text("pilot:guess\n")
    frames_file = tmp_path / "frames.bin"
    frames_file.write_bytes(b"".join(frames))
    nothing = tmp_path / "none.bin"
    nothing.write_bytes(b"")

    with two_hosts() as (ns_a, ns_b, addr_a, _addr_b):
        endpoint = f"tcp/{addr_a}:7447"
        b = bridge_factory("--zenoh-listen", endpoint, "--zenoh-users", str(users),
                           launcher=("ip", "netns", "exec", ns_a))
        try:
            with b.client() as c:
                local = fly(c, frames)

                def from_b(*extra: str, frames_path: Path = frames_file) -> dict:
                    done = run("ip", "netns", "exec", ns_b, sys.executable, str(HERE / "zenoh_remote.py"), b.instance,
                               endpoint, str(frames_path), *extra, timeout=120)
                    return json.loads(done.stdout)

                flown = from_b("--credentials", str(pilot))
                assert flown["ok"], flown
                assert flown["transport"] == "zenoh"
                assert [bytes.fromhex(h) for h in flown["answers"]] == local

                before = c.get_status().counters
                for extra in ((), ("--credentials", str(wrong))):
                    refused = from_b(*extra, "--connect-timeout", "1.0")
                    assert not refused["ok"] and refused["error"] == "NoBridge", refused
                    assert refused["elapsed_s"] < 5.0, refused
                after = c.get_status().counters
                assert after.lockstep_requests == before.lockstep_requests
                assert after.accepted == before.accepted
        finally:
            final = b.stop()
        assert final is not None and final["zenoh"]["lockstep"] == len(frames), final
        assert "user/password" in final["zenoh"]["endpoints"]


# --- the JSBSim example -------------------------------------------------------------------


def test_example_over_zenoh_gives_the_shared_memory_numbers(bridge_factory, decoy, tmp_path):
    """jsbsim_f16.py (a 2 s pull-up, decoy feed's built-in profile beside it) over
    shared memory and over Zenoh through the same bridge: the same summaries but
    for the timings and the transport, the same time series but the latency."""
    b, endpoint = zenoh_bridge(bridge_factory)
    env = dict(os.environ, DECOY_IOX_PREFIX=b.prefix, DECOY_IOX_ROOT=str(b.root), DECOY_BIN=decoy)
    runs = {}
    for transport, extra in (("shm", []), ("zenoh", ["--zenoh-connect", endpoint])):
        out = tmp_path / transport
        done = subprocess.run(
            [sys.executable, str(REPO / "clients/python/examples/jsbsim_f16.py"), "--instance", b.instance,
             "--manoeuvre", "pull-up", "--rate", "0.2", "--t-end", "2", "--no-plots", "--out", str(out), *extra],
            capture_output=True, text=True, env=env, timeout=300,
        )
        assert done.returncode == 0, done.stderr
        runs[transport] = out
    timing = {"wall_s", "latency_us", "frames_per_s", "transport", "service_time_us"}

    def summary(path: Path) -> dict:
        return json.loads(path.read_text())

    for name in ("summary.json", "builtin/summary.json"):
        s, z = summary(runs["shm"] / name), summary(runs["zenoh"] / name)
        assert (s["transport"], z["transport"]) == ("shm", "zenoh"), name
        assert {k: v for k, v in s.items() if k not in timing} == {k: v for k, v in z.items() if k not in timing}, name
    f16 = summary(runs["shm"] / "summary.json")
    assert f16["frames_sent"] == f16["frames_answered"] == 201 and f16["frames_rejected"] == 0

    def series(path: Path) -> list[dict]:
        with path.open() as f:
            return [{k: v for k, v in row.items() if not k.startswith("latency")} for row in csv.DictReader(f)]

    for name in ("timeseries.csv", "builtin/timeseries.csv"):
        assert series(runs["shm"] / name) == series(runs["zenoh"] / name), name
