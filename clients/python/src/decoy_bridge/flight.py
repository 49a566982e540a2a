"""Flying a stream of aircraft states through a bridge in lockstep, and what a run
writes: the aircraft's trajectory, the decoy's outputs and a summary with the keys
of ``decoy feed``'s ``summary.json`` (docs/outputs.md, docs/bridge.md).
"""

from __future__ import annotations

import csv
import json
import math
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import wire
from .affinity import current_cpus
from .client import Bridge, make_state
from .errors import Rejected
from .f16 import AircraftState

TRAJECTORY = wire.LAYOUT.csv_files["client_trajectory"]
"""``trajectory.csv``'s columns, from the layout description (``decoy_schema::columns``,
docs/outputs.md): the state sent (as the solver takes it), then the flight
simulation's own quantities (:data:`decoy_bridge.f16.EXTRA_COLUMNS`)."""
TRAJECTORY_COLUMNS = TRAJECTORY.names
"""The names of :data:`TRAJECTORY`'s columns (the header)."""

OUTPUTS = wire.LAYOUT.csv_files["client_timeseries"]
"""``timeseries.csv``'s columns, from the layout description: ``decoy feed``'s
(docs/outputs.md: position in the flight-path frame from the aircraft reference
point, ``lateral`` positive to the left, angles relative to the flight-path
frame), then the flight simulation's load factor and the round trip of each frame
from Python, µs, then the decoy management (docs/management.md): each
requirement's level (0 normal, 1 caution, 2 warning, 3 violated) and margin, and
the advisory bits."""
OUTPUT_COLUMNS = OUTPUTS.names
"""The names of :data:`OUTPUTS`' columns (the header)."""

REQUIREMENTS = tuple(r.name for r in wire.REQUIREMENTS)
"""The decoy-management requirements, in the wire order."""
MARGIN_UNITS = tuple(r.file_unit for r in wire.REQUIREMENTS)
"""Units of their margins in the files (the wire's posture margin is in rad)."""


@dataclass
class Record:
    """One frame of a run: the state sent and the answer."""

    state: AircraftState
    seq: int
    latency_us: float
    output: Any | None = None
    rejection: Rejected | None = None
    # Answered while the controller initialised (``output`` is then the
    # initialising answer's, with no solution: not a row of the time series).
    initialising: bool = False


@dataclass
class Run:
    """A finished lockstep run."""

    records: list[Record] = field(default_factory=list)
    wall_s: float = 0.0
    stopped: dict[str, Any] | None = None


def to_wire(s: AircraftState) -> Any:
    """The wire :class:`~decoy_bridge.wire.AircraftState` of a frame."""
    return make_state(
        s.time_s,
        s.position_ned_m,
        s.velocity_ned_mps,
        s.acceleration_ned_mps2,
        s.attitude_wxyz,
        s.body_rate_radps,
        s.body_angular_acceleration_radps2,
    )


def fly_lockstep(bridge: Bridge, states: Iterable[AircraftState], progress: Any = None) -> Run:
    """Resets the bridge's controller to trim, then sends every state and waits for
    its answer (the first state trims). As ``decoy feed``, the run stops at the
    first rejected state (recorded, with ``stopped``: the controller stays at the
    last accepted state, so every later frame would be a time jump) or at any other
    error; what was flown up to then is kept."""
    run = Run()
    bridge.reset_to_trim()
    start = time.perf_counter()
    try:
        for s in states:
            msg = to_wire(s)
            t0 = time.perf_counter_ns()
            answer = bridge.request_answer(msg)
            latency = (time.perf_counter_ns() - t0) / 1e3
            rec = Record(s, bridge.last_seq, latency)
            try:
                from .client import check_answer, is_initialising

                rec.output = check_answer(answer)
                rec.initialising = is_initialising(rec.output)
            except Rejected as r:
                rec.rejection = r
            run.records.append(rec)
            if rec.rejection is not None:
                last = next((x.state.time_s for x in reversed(run.records) if x.output is not None), 0.0)
                run.stopped = {"t_s": last, "reason": f"state {rec.seq} at t = {s.time_s:.2f} s rejected: "
                                                     f"{rec.rejection.reason}"}
                break
            if progress is not None:
                progress(s.time_s)
    except Exception as e:  # stop, keep what was flown
        run.stopped = {"t_s": run.records[-1].state.time_s if run.records else 0.0, "reason": str(e)}
    run.wall_s = time.perf_counter() - start
    return run


def largest_magnitude(values: Iterable[float]) -> float | None:
    """The largest absolute value of ``values`` (never negative), ``None`` when empty.

    ``max(values, key=abs)`` would keep the sign of that value: a decoy drifting
    3.8 mm to the right would report a "largest absolute" offset of -0.0038 m.
    """
    magnitudes = [abs(v) for v in values]
    return max(magnitudes) if magnitudes else None


def percentiles(values: list[float]) -> dict[str, float]:
    """``{"p50", "p99", "p999", "max"}`` by nearest rank (as ``decoy feed``), zeros when empty."""
    if not values:
        return {"p50": 0.0, "p99": 0.0, "p999": 0.0, "max": 0.0}
    v = sorted(values)

    def rank(p: float) -> float:
        return v[min(len(v) - 1, max(0, math.ceil(p * len(v)) - 1))]

    return {"p50": rank(0.5), "p99": rank(0.99), "p999": rank(0.999), "max": v[-1]}


def output_row(rec: Record) -> dict[str, Any]:
    """One ``timeseries.csv`` row of an answered frame: each column of
    :data:`OUTPUTS` by name."""
    o = rec.output
    x, y, z = (float(v) for v in o.decoy_position_fp_m)
    roll, pitch, yaw = (math.degrees(float(v)) for v in o.decoy_euler_rel_rad)
    values: dict[str, Any] = {
        "time": o.time_s,
        "seq": o.request_seq,
        "tension_connection": float(o.connection_tension_n),
        "tension_tow": float(o.tow_tension_n),
        "decoy_cg_behind": -x,
        "decoy_cg_lateral": -y,
        "decoy_cg_below": z,
        "decoy_roll": roll,
        "decoy_pitch": pitch,
        "decoy_yaw": yaw,
        "decoy_aoa": math.degrees(float(o.angle_of_attack_rad)),
        "cable_exhaust_clearance": float(o.cable_clearance_exhaust_m),
        "decoy_aircraft_clearance": float(o.decoy_clearance_aircraft_m),
        "aircraft_speed": float(np.linalg.norm(rec.state.velocity_ned_mps)),
        "aircraft_altitude": float(-rec.state.position_ned_m[2]),
        "aircraft_load_factor": rec.state.extra.get("load_factor", math.nan),
        "flags": o.flags,
        "rk4_steps": o.steps,
        "instructions": o.instructions,
        "latency": rec.latency_us,
        "advisories": int(o.advisories),
    }
    return {c.name: _requirement_value(o, c) if c.requirement else values[c.quantity] for c in OUTPUTS.columns}


def _requirement_value(o: Any, column: wire.Column) -> Any:
    """A per-requirement column's value of an Output: its report's level, its
    margin in the file unit, or its time to violation (-1 for none)."""
    requirement = next(r for r in wire.REQUIREMENTS if r.name == column.requirement)
    report = getattr(o, requirement.name)
    if column.quantity == "level":
        return int(report.level)
    if column.quantity == "margin":
        return requirement.to_file_unit(float(report.margin))
    if column.quantity == "violation_in":
        return float(report.time_to_violation_s)
    raise KeyError(f"{column.name}: no value for the quantity {column.quantity!r}")


def management_columns(o: Any) -> dict[str, Any]:
    """The management columns of an Output (those of :data:`OUTPUTS` holding a
    requirement's value, and the advisory bits)."""
    cols = {c.name: _requirement_value(o, c) for c in OUTPUTS.columns if c.requirement}
    cols["advisories"] = int(o.advisories)
    return cols


def _column(quantity: str, requirement: str) -> str:
    """The name of :data:`OUTPUTS`' column of ``requirement``'s ``quantity``."""
    return next(c.name for c in OUTPUTS.columns if c.quantity == quantity and c.requirement == requirement)


def management_summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """``summary.json``'s ``"management"``, as ``decoy feed`` computes it: per
    requirement the worst margin, the first violation and the first advisory (s)
    and the advisory's lead (null where none)."""
    out: dict[str, Any] = {}
    for requirement in wire.REQUIREMENTS:
        name = requirement.name
        margin, level = _column("margin", name), _column("level", name)
        margins = [r[margin] for r in rows if math.isfinite(r[margin])]
        violation = next((round(r["t_s"], 9) for r in rows if r[level] == 3), None)
        advisory = next((round(r["t_s"], 9) for r in rows if r["advisories"] & requirement.bit), None)
        out[name] = {
            "worst_margin": min(margins) if margins else None,
            "first_violation_s": violation,
            "first_advisory_s": advisory,
            "advisory_lead_s": round(violation - advisory, 9)
            if violation is not None and advisory is not None
            else None,
        }
    return out


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.6f}" if math.isfinite(v) else str(v)
    return str(v)


def trajectory_row(s: AircraftState) -> list[str]:
    """One ``trajectory.csv`` row: each column of :data:`TRAJECTORY` (times with 9
    decimals; a flight-test quantity the state lacks is NaN)."""
    vectors = {
        "position_ned": s.position_ned_m,
        "velocity_ned": s.velocity_ned_mps,
        "acceleration_ned": s.acceleration_ned_mps2,
        "attitude": s.attitude_wxyz,
        "body_rate": s.body_rate_radps,
        "body_angular_acceleration": s.body_angular_acceleration_radps2,
    }
    row = []
    for c in TRAJECTORY.columns:
        if c.quantity == "time":
            row.append(f"{s.time_s:.9f}")
        elif c.quantity == "flight_test":
            row.append(_fmt(float(s.extra.get(c.name, math.nan))))
        elif c.index is not None:
            row.append(_fmt(float(vectors[c.quantity][c.index])))
        else:
            raise KeyError(f"trajectory.csv: no value for the column {c.name!r}")
    return row


def write_trajectory(path: Path, states: Iterable[AircraftState]) -> None:
    """``trajectory.csv``: one row per frame (:data:`TRAJECTORY_COLUMNS`), times with 9 decimals."""
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(TRAJECTORY_COLUMNS)
        for s in states:
            w.writerow(trajectory_row(s))


def write_outputs(path: Path, run: Run) -> list[dict[str, Any]]:
    """``timeseries.csv``: one row per answered frame (:data:`OUTPUT_COLUMNS`); returns the rows."""
    rows = [output_row(r) for r in run.records if r.output is not None and not r.initialising]
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(OUTPUT_COLUMNS)
        for r in rows:
            w.writerow([f"{r[c.name]:.9f}" if c.quantity == "time" else _fmt(r[c.name]) for c in OUTPUTS.columns])
    return rows


def summarize(
    run: Run,
    rows: list[dict[str, Any]],
    *,
    scenario: str,
    t_end: float,
    manoeuvre_start: float,
    status: Any,
    instance: str,
    transport: str = "shm",
) -> dict[str, Any]:
    """``summary.json``: the keys of ``decoy feed``'s summary (docs/outputs.md and
    docs/bridge.md), computed the same way from the answered frames (10 ms rows).

    The two host-replay keys (``max_tension_diff_vs_host_N``,
    ``max_tension_diff_vs_host_same_precision_N``,
    ``frames_identical_to_host_same_precision``) need the Rust host controller and
    are ``null`` here. ``transport`` is :attr:`Bridge.transport <decoy_bridge.client.Bridge.transport>`
    (``shm`` or ``zenoh``), as ``decoy feed``'s.
    """
    sent = len(run.records)
    answered = len(rows)
    rejected = sum(1 for r in run.records if r.rejection is not None)
    initialising = sum(1 for r in run.records if r.initialising)
    lat = [r.latency_us for r in run.records]
    out: dict[str, Any] = {"scenario": scenario}
    segments = int(status.segments) if status is not None else None
    out["segments"] = segments
    out["dt"] = 0.005
    out["t_end"] = round(t_end, 9)
    if rows:
        t = np.array([r["t_s"] for r in rows])
        tc = np.array([r["tension_connection_N"] for r in rows])
        k = int(np.argmax(tc))
        pitch = np.array([r["decoy_pitch_deg"] for r in rows])
        after = pitch[t >= manoeuvre_start - 1e-9]
        final = tc[-1]
        outside = np.nonzero(np.abs(tc - final) > 0.02 * abs(final))[0]
        # As decoy_sim's settling_time: from the row after the last one outside the
        # 2 % band around the final tension; shown only when held for 1 s.
        settle = float(t[outside[-1] + 1]) if len(outside) else float(t[0])
        last = rows[-1]
        out.update(
            {
                "max_tension_connection_N": float(tc[k]),
                "t_at_max_tension_s": round(float(t[k]), 9),
                "pitch_oscillation_amplitude_deg": float(0.5 * (after.max() - after.min())) if after.size else None,
                "settling_time_s": round(settle, 9) if run.stopped is None and t[-1] - settle >= 1.0 - 1e-9 else None,
                "final": {
                    "tension_connection_N": last["tension_connection_N"],
                    "tension_tow_N": last["tension_tow_N"],
                    "decoy_pitch_deg": last["decoy_pitch_deg"],
                    "decoy_cg_behind_m": last["decoy_cg_behind_m"],
                    "decoy_cg_below_m": last["decoy_cg_below_m"],
                    "decoy_cg_lateral_m": last["decoy_cg_lateral_m"],
                },
                "min_cable_clearance_to_exhaust_m": float(min(r["cable_exhaust_clearance_m"] for r in rows)),
                "min_decoy_clearance_to_aircraft_m": float(min(r["decoy_aircraft_clearance_m"] for r in rows)),
                "management": management_summary(rows),
            }
        )
    else:
        out.update(
            {
                "max_tension_connection_N": None,
                "t_at_max_tension_s": None,
                "pitch_oscillation_amplitude_deg": None,
                "settling_time_s": None,
                "final": None,
                "min_cable_clearance_to_exhaust_m": None,
                "min_decoy_clearance_to_aircraft_m": None,
                "management": management_summary([]),
            }
        )
    out["wall_s"] = run.wall_s
    if run.stopped is not None:
        out["stopped"] = run.stopped
    layout = wire.LAYOUT
    out.update(
        {
            "instance": instance,
            "backend": layout.code_name("backend", status.backend) if status is not None else None,
            "board": wire.to_dict(status)["board"] if status is not None else None,
            "precision_bits": int(status.precision_bits) if status is not None else None,
            "grading_ratio": float(status.grading_ratio) if status is not None else None,
            "mode": "lockstep",
            "transport": transport,
            "realtime": False,
            "client_cpus": current_cpus(),
            "frames_sent": sent,
            "frames_answered": answered,
            "frames_initialising": initialising,
            "frames_rejected": rejected,
            "frames_lost": sent - answered - initialising - rejected,
            "latency_us": percentiles(lat),
            "frames_per_s": sent / run.wall_s if run.wall_s > 0 else 0.0,
            "instructions_per_step_max": max((r["instructions"] for r in rows[1:]), default=0),
            "instructions_per_step_mean": float(np.mean([r["instructions"] for r in rows[1:]])) if len(rows) > 1 else 0.0,
            "max_tension_diff_vs_host_N": None,
            "max_tension_diff_vs_host_same_precision_N": None,
            "frames_identical_to_host_same_precision": None,
        }
    )
    return out


def write_json(path: Path, value: Any) -> None:
    """``value`` as indented JSON (non-finite numbers as ``null``)."""

    def clean(v: Any) -> Any:
        if isinstance(v, float) and not math.isfinite(v):
            return None
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        if isinstance(v, np.generic):
            return clean(v.item())
        return v

    path.write_text(json.dumps(clean(value), indent=2) + "\n")
