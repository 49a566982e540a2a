"""Fixtures: the decoy binary of this tree and bridges started and stopped by the
tests, each isolated by its own iceoryx2 prefix and root directory, whose files
are removed afterwards."""

from __future__ import annotations

import gc
import itertools
import json
import os
import shutil
import signal
import subprocess
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from decoy_bridge import Bridge, NoBridge

REPO = Path(__file__).resolve().parents[3]
_counter = itertools.count()


def decoy_binary() -> str:
    """``$DECOY_BIN`` (the test stage sets it), else the tree's target/debug or target/release."""
    given = os.environ.get("DECOY_BIN")
    if given:
        return given
    for build in ("debug", "release"):
        candidate = REPO / "target" / build / "decoy"
        if candidate.is_file():
            return str(candidate)
    pytest.fail("no decoy binary: build it (cargo build -p decoy-cli) or set DECOY_BIN")


@pytest.fixture(scope="session")
def decoy() -> str:
    return decoy_binary()


def unique_prefix() -> str:
    return f"pyt{os.getpid()}x{next(_counter)}_"


def sweep_iceoryx(prefix: str, root: Path | None) -> None:
    """Removes the files iceoryx2 made for ``prefix``: /dev/shm/<prefix>* and the root directory."""
    shm = Path("/dev/shm")
    if shm.is_dir():
        for f in shm.glob(f"{prefix}*"):
            try:
                f.unlink()
            except OSError:
                pass
    if root is not None:
        shutil.rmtree(root, ignore_errors=True)


class RunningBridge:
    """A ``decoy bridge`` process with its own prefix and root (``launcher``: a
    command that runs it, ``ip netns exec NAME``: it must exec the bridge, whose
    process id is then the launcher's)."""

    def __init__(self, decoy: str, tmp: Path, *args: str, launcher: tuple[str, ...] = ()):
        self.instance = f"py{os.getpid()}n{next(_counter)}"
        self.prefix = unique_prefix()
        # Short: the event services' sockets live under the root and a Unix socket
        # path holds at most 107 bytes (pytest's tmp_path is too long).
        self.root = Path(tempfile.mkdtemp(prefix="dxpy", dir="/tmp"))
        self.env = dict(os.environ, DECOY_IOX_PREFIX=self.prefix, DECOY_IOX_ROOT=str(self.root))
        self.proc = subprocess.Popen(
            [*launcher, decoy, "bridge", "--instance", self.instance, "--json", *args],
            env=self.env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        self.final: dict | None = None

    def client(self, timeout_s: float = 5.0, startup_s: float = 60.0) -> Bridge:
        """A client, once the bridge serves (it may still be starting)."""
        deadline = time.monotonic() + startup_s
        while True:
            try:
                return Bridge(self.instance, prefix=self.prefix, root=str(self.root), timeout_s=timeout_s)
            except NoBridge:
                if self.proc.poll() is not None:
                    raise RuntimeError(f"decoy bridge exited with {self.proc.returncode}: {self.proc.stderr.read()}")
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.05)  # startup only: the bridge's services do not exist yet

    def stop(self) -> dict | None:
        """SIGINT, then the bridge's JSON summary."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                out, err = self.proc.communicate(timeout=20)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                out, err = self.proc.communicate()
            self.final = json.loads(out) if out.strip().startswith("{") else None
            self.stderr = err
        return self.final


@pytest.fixture
def bridge_factory(decoy: str, tmp_path: Path) -> Iterator:
    """Starts bridges (``bridge_factory(*args, launcher=())``); stops them and sweeps their files."""
    started: list[RunningBridge] = []

    def start(*args: str, launcher: tuple[str, ...] = ()) -> RunningBridge:
        b = RunningBridge(decoy, tmp_path / f"b{len(started)}", *args, launcher=launcher)
        started.append(b)
        return b

    yield start
    gc.collect()  # the clients' nodes go first (they remove their own files)
    for b in started:
        b.stop()
        sweep_iceoryx(b.prefix, b.root)


@pytest.fixture
def bridge(bridge_factory) -> RunningBridge:
    """One bridge: host backend, f32, the embedded model (12 segments graded 1.26)."""
    return bridge_factory()
