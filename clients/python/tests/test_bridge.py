"""The client against a real `decoy bridge` (host backend, f32, embedded model):
lockstep, rejections, free-running, commands, timeouts, the JSBSim F-16."""

from __future__ import annotations

import csv
import ctypes
import json
import math
import os
import signal
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

import numpy as np
import pytest

from decoy_bridge import Bridge, BridgeTimeout, NoBridge, Rejected, VersionMismatch, make_state, wire
from decoy_bridge import f16 as F
from decoy_bridge import flight
from decoy_bridge import frames as fr

from conftest import REPO, sweep_iceoryx, unique_prefix

SPEED = 243.0  # m/s, about Mach 0.8 at 9 km


def level(t: float, seq_speed: float = SPEED):
    return make_state(t, [seq_speed * t, 0.0, -9000.0], [seq_speed, 0.0, 0.0])


def raw(out) -> bytes:
    return bytes(memoryview(out).cast("B"))


def test_no_bridge_is_a_clear_error():
    prefix = unique_prefix()
    root = Path(tempfile.mkdtemp(prefix="dxpy", dir="/tmp"))
    try:
        with pytest.raises(NoBridge, match="no bridge"):
            Bridge("nobody-here", prefix=prefix, root=str(root))
    finally:
        sweep_iceoryx(prefix, root)


def test_a_client_waits_for_the_readiness_mark_not_for_the_first_services():
    """Services that exist before the bridge serves them all (a bridge part-way
    through its start: every service, the lockstep server, but no status
    publisher yet) are not a bridge: the client waits for the readiness mark and
    says there is no bridge, instead of connecting and losing its first command
    (issue 27: a command sent before the commands server existed)."""
    import time

    import iceoryx2 as iox

    from decoy_bridge.client import make_config

    prefix = unique_prefix()
    root = Path(tempfile.mkdtemp(prefix="dxpy", dir="/tmp"))
    try:
        node = iox.NodeBuilder.new().config(make_config(prefix, str(root))).create(iox.ServiceType.Ipc)

        def name(service: str):
            return iox.ServiceName.new(f"decoy/half/{service}")

        lockstep = node.service_builder(name("lockstep")).request_response(wire.AircraftState, wire.Answer).create()
        server = lockstep.server_builder().create()
        made = [
            node.service_builder(name("commands")).request_response(wire.Command, wire.CommandReply).create(),
            node.service_builder(name("state")).publish_subscribe(wire.AircraftState).create(),
            node.service_builder(name("outputs")).publish_subscribe(wire.Answer).create(),
            node.service_builder(name("status")).publish_subscribe(wire.Status).create(),
            node.service_builder(name("to-bridge")).event().create(),
            node.service_builder(name("from-bridge")).event().create(),
        ]
        t0 = time.monotonic()
        with pytest.raises(NoBridge, match="no bridge .* is ready"):
            Bridge("half", prefix=prefix, root=str(root), connect_timeout_s=0.3)
        assert time.monotonic() - t0 < 5.0
        del server, made, lockstep, node
    finally:
        sweep_iceoryx(prefix, root)


def test_a_command_sent_at_once_while_the_bridge_starts_is_never_lost(bridge_factory):
    """Startups raced: the client connects as early as it can (no pause between
    attempts) while the bridge starts and pings at once; never lost."""
    import time

    for round_ in range(8):
        b = bridge_factory()
        deadline = time.monotonic() + 60.0
        while True:
            try:
                c = Bridge(b.instance, prefix=b.prefix, root=str(b.root), timeout_s=5.0, connect_timeout_s=0.01)
                break
            except NoBridge:
                if b.proc.poll() is not None or time.monotonic() > deadline:
                    raise
        with c:
            reply = c.ping(nonce=round_)
            assert reply.nonce == round_
        b.stop()


def test_lockstep_session_answers_every_frame_and_types_rejections(bridge):
    """300 frames of level flight with bad frames interleaved: every frame is answered,
    each bad one by its typed rejection and counter, nothing lost, and the valid
    frames' outputs are byte for byte those of an undisturbed run."""
    with bridge.client() as c:
        c.subscribe_outputs()
        c.reset_to_trim()
        before = c.get_status().counters
        bad = {
            50: ("non_finite", lambda s: s.velocity_ned_mps.__setitem__(1, math.nan)),
            90: ("bad_quaternion", lambda s: s.attitude_wxyz.__setitem__(0, 0.5)),
            130: ("time_not_increasing", lambda s: setattr(s, "time_s", s.time_s - 0.02)),
            170: ("time_jump", lambda s: setattr(s, "time_s", s.time_s + 0.5)),
            210: ("out_of_range", lambda s: s.position_ned_m.__setitem__(2, -30000.0)),
        }
        outputs, rejections, sent = [], [], 0
        for k in range(300):
            t = k * 0.01
            if k in bad:
                s = level(t)
                bad[k][1](s)
                sent += 1
                with pytest.raises(Rejected) as e:
                    c.request(s)
                assert e.value.reason.lower().replace("_", "") == bad[k][0].replace("_", ""), e.value
                assert e.value.request_seq == c.last_seq
                assert e.value.count == 1
                rejections.append(e.value)
            s = level(t)
            sent += 1
            out = c.request(s)
            assert out.request_seq == c.last_seq
            assert out.time_s == pytest.approx(t)
            outputs.append(raw(out))
        # A wrong protocol version: typed, not a crash.
        s = level(3.0)
        s.header.protocol_version = 99
        s.header.kind = 1
        sent += 1
        answer = c.request_answer(s, keep_header=True)
        assert answer.header.kind == wire.LAYOUT.codes["kind"]["rejected"]
        assert wire.LAYOUT.code_name("reason", answer.rejection.reason).lower().replace("_", "") == "wrongversion"
        after = c.get_status().counters
        assert after.accepted - before.accepted == 300
        assert after.lockstep_requests - before.lockstep_requests == sent
        for name in ("non_finite", "bad_quaternion", "time_not_increasing", "time_jump", "out_of_range", "wrong_version"):
            assert getattr(after, name) - getattr(before, name) == 1, name
        assert after.lost == before.lost
        # Every answer was also published on `outputs`, numbered without a gap.
        published = c.outputs(at_least=sent, timeout_s=5.0)
        published = published[-sent:]
        seqs = [a.header.seq for a in published]
        assert seqs == list(range(seqs[0], seqs[0] + sent))
        # Undisturbed run: the same valid frames after a reset give the same bytes.
        c.reset_to_trim()
        again = [raw(c.request(level(k * 0.01))) for k in range(300)]

    def strip_seq(b: bytes) -> bytes:  # request_seq (offset 8) differs between the runs
        return b[:8] + b[12:]

    assert [strip_seq(b) for b in again] == [strip_seq(b) for b in outputs]
    tension = [wire.Output.from_buffer_copy(b).connection_tension_n for b in outputs]
    assert all(math.isfinite(x) and x > 0 for x in tension)


def test_free_running_publish_is_answered_on_outputs(bridge):
    with bridge.client() as c:
        c.subscribe_outputs()
        c.reset_to_trim()
        before = c.get_status().counters
        for k in range(200):
            c.publish(level(k * 0.01))
        answers = c.outputs(at_least=200, timeout_s=10.0)[-200:]
        assert [a.output.request_seq for a in answers] == list(range(200))
        assert all(a.header.kind == wire.LAYOUT.codes["kind"]["output"] for a in answers)
        after = c.status(timeout_s=3.0).counters
        assert after.free_samples - before.free_samples == 200
        assert after.lost == before.lost


def test_commands_and_status(bridge):
    with bridge.client() as c:
        assert c.ping(nonce=4242).nonce == 4242
        st = c.get_status()
        d = wire.to_dict(st)
        assert d["instance"] == bridge.instance
        assert wire.LAYOUT.code_name("backend", st.backend) == "host"
        assert st.precision_bits == 32
        # the bridge's host backend runs the embedded model of the reference system
        with open(REPO / "config/reference-system.toml", "rb") as f:
            embedded = tomllib.load(f)["solver"]["segments_embedded"]
        assert st.segments == embedded
        assert st.header.protocol_version == wire.PROTOCOL_VERSION
        with pytest.raises(Rejected):
            c.select_profile("turn", rate_radps=1.5)  # above 1 rad/s
        with pytest.raises(ValueError):
            c.command("fly-to-the-moon")
        pub = c.status(timeout_s=3.0)
        assert wire.to_dict(pub)["instance"] == bridge.instance


def test_a_killed_bridge_is_a_clear_error_not_a_hang(bridge):
    """SIGKILL the bridge between two frames: the next request fails within its
    time limit with BridgeTimeout (the dead node still owns the server port until
    someone cleans it up) or NoBridge, never hangs."""
    import time

    with bridge.client(timeout_s=0.5) as c:
        c.reset_to_trim()
        c.request(level(0.0))
        bridge.proc.kill()
        bridge.proc.wait()
        t0 = time.monotonic()
        with pytest.raises((BridgeTimeout, NoBridge), match="did not answer|went away"):
            c.request(level(0.01), timeout_s=0.5)
        assert time.monotonic() - t0 < 3.0


def test_version_mismatch_is_named(bridge, tmp_path):
    """A client whose types carry another protocol version cannot open the services."""
    client = bridge.client()
    client.close()
    desc = json.loads(json.dumps(wire.LAYOUT.raw))
    for t in desc["types"]:
        t["type_name"] = t["type_name"].replace(f".v{wire.LAYOUT.protocol_version}.", ".v99.")
        assert ".v99." in t["type_name"], t["type_name"]
    other = wire.build_types(desc)
    import iceoryx2 as iox

    from decoy_bridge.client import _Shm, make_config

    node = iox.NodeBuilder.new().config(make_config(bridge.prefix, str(bridge.root))).create(iox.ServiceType.Ipc)
    c = _Shm.__new__(_Shm)  # the shared-memory transport behind Bridge
    c.instance = bridge.instance
    c._node = node
    with pytest.raises(VersionMismatch, match="differ"):
        c._open_rr("lockstep", other.types["AircraftState"], other.types["Answer"])
    del c, node


def f16_through_bridge(c: Bridge, manoeuvre: str, t_end: float, rate=None, altitude=9000.0, mach=None):
    fdm = F.F16(altitude, mach if mach is not None else F.DEFAULT_CONDITION[manoeuvre][1])
    man = F.make_manoeuvre(manoeuvre, fdm, rate)
    run = flight.fly_lockstep(c, fdm.fly(man, t_end))
    return run


def test_jsbsim_pull_up_through_the_bridge(bridge):
    """A short F-16 pull-up (0.2 rad/s from t = 2 s): every frame answered, tensions
    finite, the connection tension rising well above its trim value."""
    with bridge.client() as c:
        run = f16_through_bridge(c, "pull-up", 4.0, rate=0.2)
    assert run.stopped is None
    assert len(run.records) == 401
    assert all(r.output is not None for r in run.records)
    t = np.array([r.output.time_s for r in run.records])
    tc = np.array([r.output.connection_tension_n for r in run.records])
    tt = np.array([r.output.tow_tension_n for r in run.records])
    assert np.isfinite(tc).all() and np.isfinite(tt).all()
    trim = tc[0]
    assert abs(tc[t < 2.0] - trim).max() < 0.01 * trim  # steady before the pull-up
    assert tc[t > 3.0].max() > 1.3 * trim


def test_decoy_steady_answer_equals_decoy_trim(bridge, decoy):
    """The F-16 trimmed at 9 km, Mach 0.8, flown steady through the bridge: the
    decoy's answer equals `decoy trim` of the bridge's model within 0.5 %."""
    with bridge.client() as c:
        st = c.get_status()
        run = f16_through_bridge(c, "steady", 2.0)
    assert all(r.output is not None for r in run.records)
    trim = json.loads(
        subprocess.run(
            [decoy, "trim", "--altitude", "9000", "--mach", "0.8", "--segments", str(st.segments), "--grading",
             repr(st.grading_ratio), "--json"],
            capture_output=True, text=True, check=True,
        ).stdout
    )
    # The connection point in the aircraft's body frame (FRD): `decoy trim` gives the
    # decoy from the reference point and from the connection point in level flight.
    conn_body = np.array([
        -(trim["decoy_cg_behind_m"] - trim["decoy_cg_behind_connection_m"]),
        0.0,
        trim["decoy_cg_below_m"] - trim["decoy_cg_below_connection_m"],
    ])
    for rec in (run.records[0], run.records[-1]):
        o = rec.output
        assert o.connection_tension_n == pytest.approx(trim["tension_connection_N"], rel=5e-3)
        assert o.tow_tension_n == pytest.approx(trim["tension_tow_N"], rel=5e-3)
        # `decoy trim` flies wings level at zero pitch; the F-16 flies at its trim
        # angle of attack (2.1 deg nose up), which lowers the connection point by
        # 4 m x sin(2.1 deg) = 0.15 m. From the connection point the two agree.
        fp = fr.flight_path_frame(rec.state.velocity_ned_mps)
        conn_fp = fp @ fr.rotate(rec.state.attitude_wxyz, conn_body)
        rel = np.array(o.decoy_position_fp_m[:]) - conn_fp
        assert -rel[0] == pytest.approx(trim["decoy_cg_behind_connection_m"], rel=5e-3)
        assert rel[2] == pytest.approx(trim["decoy_cg_below_connection_m"], rel=5e-3)
        assert abs(rel[1]) < 1e-3
        assert math.degrees(o.decoy_euler_rel_rad[1]) == pytest.approx(trim["decoy_pitch_deg"], abs=0.05)


def test_example_writes_feeds_keys_and_plots(bridge, decoy, tmp_path):
    """The documented example end to end (short pull-up), with the built-in profile
    flown by `decoy feed` through the same bridge: summary.json has feed's keys."""
    bridge.client().close()  # wait until it serves
    out = tmp_path / "f16"
    env = dict(os.environ, DECOY_IOX_PREFIX=bridge.prefix, DECOY_IOX_ROOT=str(bridge.root), DECOY_BIN=decoy)
    done = subprocess.run(
        [sys.executable, str(REPO / "clients/python/examples/jsbsim_f16.py"), "--instance", bridge.instance,
         "--manoeuvre", "pull-up", "--rate", "0.1", "--t-end", "3", "--out", str(out)],
        capture_output=True, text=True, env=env, timeout=600,
    )
    assert done.returncode == 0, done.stderr
    summary = json.loads((out / "summary.json").read_text())
    feed = json.loads((out / "builtin" / "summary.json").read_text())
    assert set(summary) == set(feed)
    assert summary["frames_sent"] == summary["frames_answered"] == 301
    assert summary["frames_lost"] == 0 and summary["frames_rejected"] == 0
    for name in ("trajectory.csv", "timeseries.csv", "comparison.json", "tensions.png", "decoy-position.png",
                 "clearances.png", "load-factor.png"):
        assert (out / name).is_file(), name
    assert "peak connection tension" in done.stdout
    # The largest absolute lateral offset of each side: |x| of the largest |x|.
    comparison = json.loads((out / "comparison.json").read_text())
    for side, csv_path in (("f16", out / "timeseries.csv"), ("builtin", out / "builtin" / "timeseries.csv")):
        with csv_path.open() as f:
            lateral = [abs(float(r["decoy_cg_lateral_m"])) for r in csv.DictReader(f)]
        assert comparison[side]["max_abs_decoy_cg_lateral_m"] == pytest.approx(max(lateral), abs=1e-6), side
        assert comparison[side]["max_abs_decoy_cg_lateral_m"] >= 0.0, side
