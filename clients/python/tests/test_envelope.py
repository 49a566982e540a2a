"""The manoeuvre envelope map from Python (``decoy.envelope``) and on a real
local Ray cluster: a head and a second node process (``ray start``), started
here and stopped here (only the processes this module started: their process
groups). The map is the same bits locally (on 1 or 2 threads), from the
command line (``decoy envelope --json``), on Ray from Python
(``decoy.envelope(ray=)``) and on Ray from the command line (``--ray``); a map
resumes on Ray from the cells its directory holds; a cell's error on a Ray
worker is the command line's typed error."""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

import decoy
from conftest import decoy_binary
from test_solver import assert_same

#: A small grid on the embedded-size model (seconds per map, not minutes).
GRID = dict(altitudes=[3000.0, 12000.0], machs=[0.6, 0.8], segments=12, grading=1.26, tolerance=0.02)
GRID_FLAGS = [
    "--altitudes", "3000,12000", "--machs", "0.6,0.8", "--segments", "12",
    "--grading", "1.26", "--tolerance", "0.02",
]
#: Time allowed for the cluster to come up (about 13 s on the 2-core machine).
CLUSTER_STARTUP_S = 120.0
RAY_BIN = Path(sys.executable).with_name("ray")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def alive_nodes(address: str) -> int:
    """Alive nodes of the cluster, asked by a separate interpreter (so that this
    one does not stay connected)."""
    probe = (
        "import ray; ray.init(address=%r, logging_level='ERROR', log_to_driver=False); "
        "print(sum(1 for n in ray.nodes() if n['Alive']))" % address
    )
    try:
        done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120)
    except subprocess.TimeoutExpired:
        return 0
    return int(done.stdout.strip()) if done.returncode == 0 and done.stdout.strip().isdigit() else 0


@pytest.fixture(scope="module")
def ray_cluster() -> Iterator[str]:
    """A head and a second node, one CPU each, on loopback; killed after (their
    process groups: `ray stop` would stop every Ray of the machine)."""
    port = free_port()
    address = f"127.0.0.1:{port}"
    # Short: Ray's Unix sockets live under it (107 bytes at most).
    temp = tempfile.mkdtemp(prefix="rayt", dir="/tmp")
    env = dict(os.environ, RAY_USAGE_STATS_ENABLED="0")
    common = ["--num-cpus=1", "--object-store-memory=100000000", f"--temp-dir={temp}", "--block"]
    logs = Path(temp) / "start-logs"
    logs.mkdir()
    procs: list[subprocess.Popen] = []

    def start(name: str, *args: str) -> None:
        with open(logs / f"{name}.out", "w") as log:
            procs.append(
                subprocess.Popen(
                    [str(RAY_BIN), "start", *args, *common],
                    env=env,
                    stdout=log,
                    stderr=subprocess.STDOUT,
                    start_new_session=True,
                )
            )

    try:
        start("head", "--head", f"--port={port}", "--node-ip-address=127.0.0.1",
              "--include-dashboard=false", "--disable-usage-stats")
        start("node", f"--address={address}", "--node-ip-address=127.0.0.1")
        deadline = time.monotonic() + CLUSTER_STARTUP_S
        while alive_nodes(address) < 2:
            for p in procs:
                if p.poll() is not None:
                    pytest.fail(f"ray start exited ({p.returncode}): " + "".join(
                        f.read_text()[-2000:] for f in logs.iterdir()))
            if time.monotonic() > deadline:
                pytest.fail(f"the Ray cluster at {address} did not have 2 nodes within {CLUSTER_STARTUP_S} s")
            time.sleep(1.0)
        yield address
    finally:
        # Each `ray start --block` leads its own session: its process group is
        # the node (GCS, raylet, workers); killing the groups stops this cluster
        # and nothing else.
        for p in procs:
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        for p in procs:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                pass
        shutil.rmtree(temp, ignore_errors=True)


def read_outputs(directory: Path) -> dict[str, str]:
    return {name: (directory / name).read_text() for name in ("envelope.json", "envelope.csv", "summary.txt", "inputs.json")}


def test_the_python_map_is_the_command_lines(tmp_path: Path) -> None:
    """decoy.envelope() is `decoy envelope --json` bit for bit, on 1 and on 2
    threads, and writes the same files."""
    one = decoy.envelope("pull-up", **GRID, workers=1)
    two = decoy.envelope("pull-up", **GRID, workers=2, out=tmp_path / "py")
    assert_same(one, two)
    done = subprocess.run(
        [decoy_binary(), "envelope", "--manoeuvre", "pull-up", *GRID_FLAGS, "--out", str(tmp_path / "cli"), "--json"],
        capture_output=True, text=True, timeout=600,
    )
    assert done.returncode == 0, done.stderr
    assert_same(json.loads(done.stdout), one)
    assert read_outputs(tmp_path / "py") == read_outputs(tmp_path / "cli")
    assert (tmp_path / "py" / "limit.png").is_file()
    limits = {(c["altitude_m"], c["mach"]): c["limit"] for c in one["cells"]}
    assert len(limits) == 4 and all(0.0 < v <= 0.35 for v in limits.values()), limits


def test_bad_maps_raise_the_command_lines_errors() -> None:
    for kwargs, kind, message in [
        (dict(manoeuvre="steady"), decoy.InputError, "--manoeuvre must be pull-up, turn or acceleration"),
        (dict(manoeuvre="pull-up", onset=float("nan")), decoy.InputError, "--onset must be a non-negative number"),
        (dict(manoeuvre="acceleration", machs=[0.95]), decoy.InputError, "below the envelope's upper Mach 0.95"),
        (dict(manoeuvre="turn", tolerance=-1.0), decoy.InputError, "tolerance must be positive"),
        (dict(manoeuvre="turn", workers=0), decoy.InputError, "--workers must be at least 1"),
        (dict(manoeuvre="turn", workers=1, ray="127.0.0.1:1"), decoy.InputError, "--workers applies to a local map"),
        (dict(manoeuvre="turn", config={"decoy": {"mass": -1.0}}), decoy.ConfigError, "decoy"),
    ]:
        kwargs = dict(kwargs)
        manoeuvre = kwargs.pop("manoeuvre")
        with pytest.raises(kind, match=None) as raised:
            decoy.envelope(manoeuvre, **kwargs)
        assert message in str(raised.value), raised.value


def test_the_map_on_ray_is_the_local_map(ray_cluster: str, tmp_path: Path) -> None:
    """Every cell a Ray task on the 2-node cluster: the same dict and files as
    the local map; a killed map resumes on Ray from the cells it has; the
    command line's --ray gives the same."""
    local = decoy.envelope("pull-up", **GRID, workers=2, out=tmp_path / "local")
    seen: list[tuple[int, int]] = []
    started = time.monotonic()
    on_ray = decoy.envelope("pull-up", **GRID, ray=ray_cluster, out=tmp_path / "ray",
                            progress=lambda done, total: seen.append((done, total)))
    elapsed = time.monotonic() - started
    assert_same(on_ray, local)
    assert read_outputs(tmp_path / "ray") == read_outputs(tmp_path / "local")
    assert seen == [(1, 4), (2, 4), (3, 4), (4, 4)], seen
    print(f"4 cells on the 2-node Ray cluster in {elapsed:.1f} s")
    # Without a directory: the same map.
    assert_same(decoy.envelope("pull-up", **GRID, ray=ray_cluster), local)

    # A cell removed (as a killed run leaves it): only that cell is a task.
    removed = sorted((tmp_path / "ray" / "cells").iterdir())[1]
    removed.unlink()
    seen.clear()
    again = decoy.envelope("pull-up", **GRID, ray=ray_cluster, out=tmp_path / "ray",
                           progress=lambda done, total: seen.append((done, total)))
    assert_same(again, local)
    assert seen == [(4, 4)], seen
    assert removed.is_file()

    # The command line on Ray: the same JSON and files.
    env = dict(os.environ, DECOY_PYTHON=sys.executable)
    done = subprocess.run(
        [decoy_binary(), "envelope", "--manoeuvre", "pull-up", *GRID_FLAGS, "--ray", ray_cluster,
         "--out", str(tmp_path / "cli-ray"), "--json"],
        capture_output=True, text=True, timeout=600, env=env,
    )
    assert done.returncode == 0, done.stderr
    assert_same(json.loads(done.stdout), local)
    assert read_outputs(tmp_path / "cli-ray") == read_outputs(tmp_path / "local")


def test_an_acceleration_map_on_ray(ray_cluster: str) -> None:
    """The acceleration map on Ray is the local one (limits in m/s^2)."""
    grid = dict(altitudes=[0.0, 9000.0], machs=[0.85], segments=12, grading=1.26, tolerance=0.5)
    local = decoy.envelope("acceleration", **grid, workers=1)
    assert local["limit_unit"] == "m/s^2" and local["mach_gain"] == 0.1
    assert_same(decoy.envelope("acceleration", **grid, ray=ray_cluster), local)


def test_a_cells_error_on_ray_is_typed(ray_cluster: str, tmp_path: Path) -> None:
    """A cell the solver refuses, mapped on a Ray worker: the command line's
    InputError naming the cell, from Python and from `decoy envelope --ray`."""
    with pytest.raises(decoy.InputError) as raised:
        decoy.envelope("pull-up", altitudes=[9000.0], machs=[2.5], segments=12, grading=1.26, ray=ray_cluster)
    assert "9000 m, Mach 2.5" in str(raised.value), raised.value
    env = dict(os.environ, DECOY_PYTHON=sys.executable)
    args = [decoy_binary(), "envelope", "--manoeuvre", "pull-up", "--altitudes", "9000", "--machs", "2.5",
            "--segments", "12", "--grading", "1.26"]
    local = subprocess.run([*args, "--out", str(tmp_path / "bad-local")], capture_output=True, text=True, timeout=600)
    done = subprocess.run([*args, "--ray", ray_cluster, "--out", str(tmp_path / "bad")],
                          capture_output=True, text=True, timeout=600, env=env)
    # The same one-line message and exit code as the local run's.
    assert local.returncode == 2, (local.stdout, local.stderr)
    assert (done.returncode, done.stderr) == (local.returncode, local.stderr), (done.stdout, done.stderr)
    assert "9000 m, Mach 2.5" in done.stderr and done.stderr.count("\n") == 1, done.stderr


def test_ray_without_python_says_what_to_install(tmp_path: Path) -> None:
    """`decoy envelope --ray` with no interpreter to run the cells: a one-line
    error naming it and what installs it, the map's directory kept for a rerun."""
    env = dict(os.environ, DECOY_PYTHON=str(tmp_path / "no-python"))
    done = subprocess.run(
        [decoy_binary(), "envelope", "--manoeuvre", "pull-up", *GRID_FLAGS, "--ray", "127.0.0.1:1",
         "--out", str(tmp_path / "map")],
        capture_output=True, text=True, timeout=600, env=env,
    )
    assert done.returncode == 1, (done.stdout, done.stderr)
    assert done.stderr.startswith("error: --ray: cannot run ") and "cargo xtask setup" in done.stderr, done.stderr
    assert done.stderr.count("\n") == 1, done.stderr
    assert (tmp_path / "map" / "inputs.json").is_file()
