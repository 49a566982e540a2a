"""The manoeuvre envelope map from Python: on this machine's cores, or as Ray tasks.

``decoy.envelope()`` is ``decoy envelope``: the same plan (the defaults of the
configuration's declared envelope), the same cells (each one the Rust
``decoy_studies::envelope::map_cell``, whichever process runs it), the same
files and the same ``--json`` dict. With ``ray=ADDRESS`` every cell the output
directory lacks is a Ray task calling this package in a worker of the cluster;
each result is stored atomically in the directory as it comes, and the map is
then made from the directory, as a resumed local run would: the same bits.

``python -m decoy._ray_cells ADDRESS DIR`` (``decoy envelope --ray`` runs it)
maps on Ray the cells DIR's ``inputs.json`` plans.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path
from typing import Callable, Optional, Sequence, Union

from decoy import _native

Progress = Callable[[int, int], None]


def _cell(plan: str, index: int) -> str:
    """One cell of the map (a Ray task's body): the cell's JSON."""
    from decoy import _native as native

    return native.envelope_cell(plan, index)


def _terminal_bar(done: int, total: int) -> None:
    """A one-line progress bar on stderr."""
    width = 30
    filled = width * done // max(total, 1)
    end = "\n" if done >= total else ""
    sys.stderr.write(f"\rmapping [{'=' * filled}{' ' * (width - filled)}] {done}/{total} cells{end}")
    sys.stderr.flush()


def _progress(progress: Union[None, bool, Progress]) -> Optional[Progress]:
    """The callback: the given one, a bar on stderr (True, or None at a
    terminal), or none."""
    if callable(progress):
        return progress
    if progress is True or (progress is None and sys.stderr.isatty()):
        return _terminal_bar
    return None


def map_on_ray(plan: str, address: str, directory: Union[str, os.PathLike], progress: Optional[Progress] = None) -> int:
    """Maps the cells ``directory`` lacks of ``plan`` (envelope_plan's text) as
    Ray tasks on the cluster at ``address`` (connecting, and disconnecting
    after, unless Ray is connected already), storing each in ``directory`` as it
    comes. Returns the number of cells mapped."""
    pending, total = _native.envelope_pending(plan, os.fspath(directory))
    if not pending:
        return 0
    try:
        import ray
    except ImportError as e:
        raise _native.InputError(
            f"ray={address!r}: the package ray is not importable ({e}); `cargo xtask setup` installs it into .venv/"
        ) from None
    connected_here = not ray.is_initialized()
    if connected_here:
        try:
            ray.init(address=address, logging_level="ERROR", log_to_driver=False)
        except Exception as e:  # Ray raises ConnectionError, ValueError, RuntimeError...
            raise _native.InputError(f"ray={address!r}: cannot connect to the Ray cluster: {e}") from None
    try:
        task = ray.remote(num_cpus=1)(_cell)
        refs = {task.remote(plan, i): i for i in pending}
        done = total - len(pending)
        while refs:
            ready, _ = ray.wait(list(refs), num_returns=1)
            for ref in ready:
                index = refs.pop(ref)
                try:
                    cell = ray.get(ref)
                except ray.exceptions.RayTaskError as e:
                    for other in refs:
                        ray.cancel(other)
                    # The task's own exception (a DecoyError with the command
                    # line's message), not Ray's wrapper of it.
                    cause = getattr(e, "cause", None)
                    if isinstance(cause, BaseException):
                        raise cause from None
                    raise
                _native.envelope_store(plan, os.fspath(directory), index, cell)
                done += 1
                if progress is not None:
                    progress(done, total)
        return len(pending)
    finally:
        if connected_here:
            ray.shutdown()


def envelope(
    manoeuvre: str,
    *,
    altitudes: Optional[Sequence[float]] = None,
    machs: Optional[Sequence[float]] = None,
    segments: Optional[int] = None,
    grading: Optional[float] = None,
    onset: Optional[float] = None,
    tolerance: Optional[float] = None,
    mach_gain: Optional[float] = None,
    workers: Optional[int] = None,
    ray: Optional[str] = None,
    out: Union[None, str, os.PathLike] = None,
    config=None,
    progress: Union[None, bool, Progress] = None,
) -> dict:
    """The manoeuvre envelope map, as ``decoy envelope --json`` prints it.

    manoeuvre: "pull-up", "turn" or "acceleration". altitudes (m), machs: the
    grid (default: the configuration's declared envelope, altitudes by 3000 m,
    Mach by 0.1 and its upper end; for the acceleration up to the upper end less
    the Mach gain); segments, grading: the model (default: 300 uniform
    segments); onset: the rate built over it, s (default 0.5; not for the
    acceleration); tolerance: of the bisection, rad/s (default 0.005) or m/s^2
    for the acceleration (default 0.05); mach_gain: the acceleration's gain in
    Mach from each cell (default 0.1). workers: threads for a local map
    (default: the machine's cores). ray: the address of a Ray cluster
    ("host:port", or "auto") to map the cells on as Ray tasks (then not
    workers). out: the directory of the map's files (envelope.json,
    envelope.csv, summary.txt, limit.png/.svg, inputs.json and cells/), resumed
    when it holds a map of the same inputs (None: nothing written). config: the
    system (None: the built-in reference system; a TOML path; a dict).
    progress: a callable(done, total) called after each cell, True for a bar
    on stderr, False for none (None: a bar when stderr is a terminal).

    Returns {"manoeuvre", "limit_unit", "cells": [{"altitude_m", "mach",
    "limit", "limiting_requirement", "margin", "cap", "inside_envelope",
    "steady_margins", ...}],
    ...}: docs/envelope.md. Raises InputError, ConfigError, SolverError with
    the command line's messages.
    """
    plan = _native.envelope_plan(
        manoeuvre,
        altitudes=None if altitudes is None else list(altitudes),
        machs=None if machs is None else list(machs),
        segments=segments,
        grading=grading,
        onset=onset,
        tolerance=tolerance,
        mach_gain=mach_gain,
        config=config,
    )
    report = _progress(progress)
    if ray is None:
        return _native.envelope_map(plan, workers=workers, out=None if out is None else os.fspath(out), progress=report)
    if workers is not None:
        raise _native.InputError(
            "command line: --workers applies to a local map: on Ray the cluster's CPUs run the cells (ray= and workers= together)"
        )
    with tempfile.TemporaryDirectory(prefix="decoy-envelope-") as scratch:
        directory = scratch if out is None else os.fspath(out)
        map_on_ray(plan, ray, directory, report)
        # Every cell is in the directory now: the map resumes them all.
        return _native.envelope_map(plan, workers=1, out=directory, outputs=out is not None)
