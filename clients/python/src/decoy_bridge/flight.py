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
from .f16 import EXTRA_COLUMNS, AircraftState

TRAJECTORY_COLUMNS = (
    "t_s",
    "north_m",
    "east_m",
    "down_m",
    "vn_mps",
    "ve_mps",
    "vd_mps",
    "an_mps2",
    "ae_mps2",
    "ad_mps2",
    "qw",
    "qx",
    "qy",
    "qz",
    "p_radps",
    "q_radps",
    "r_radps",
    "pdot_radps2",
    "qdot_radps2",
    "rdot_radps2",
) + EXTRA_COLUMNS
"""Columns of ``trajectory.csv``: the state sent (as the solver takes it), then the
flight-test quantities of :data:`decoy_bridge.f16.EXTRA_COLUMNS`."""

OUTPUT_COLUMNS = (
    "t_s",
    "seq",
    "tension_connection_N",
    "tension_tow_N",
    "decoy_cg_behind_m",
    "decoy_cg_lateral_m",
    "decoy_cg_below_m",
    "decoy_roll_deg",
    "decoy_pitch_deg",
    "decoy_yaw_deg",
    "decoy_aoa_deg",
    "cable_exhaust_clearance_m",
    "decoy_aircraft_clearance_m",
    "aircraft_speed_mps",
    "aircraft_altitude_m",
    "aircraft_load_factor",
    "flags",
    "rk4_steps",
    "instructions",
    "latency_us",
    "posture_level",
    "posture_margin_deg",
    "collision_level",
    "collision_margin_m",
    "tension_level",
    "tension_margin_N",
    "exhaust_level",
    "exhaust_margin_m",
    "advisories",
)
"""Columns of ``timeseries.csv``: ``decoy feed``'s (docs/outputs.md: position in the
flight-path frame from the aircraft reference point, ``lateral`` positive to the
left, angles relative to the flight-path frame), then the F-16's load factor and
the round trip of each frame from Python, µs, then the decoy management
(docs/management.md): each requirement's level (0 normal, 1 caution, 2 warning,
3 violated) and margin, and the advisory bits (posture 1, collision 2, tension 4,
exhaust 8)."""

REQUIREMENTS = ("posture", "collision", "tension", "exhaust")
"""The paper's four decoy-management requirements, in the wire order."""
MARGIN_UNITS = ("deg", "m", "N", "m")
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
    """One ``timeseries.csv`` row of an answered frame."""
    o = rec.output
    x, y, z = (float(v) for v in o.decoy_position_fp_m)
    roll, pitch, yaw = (math.degrees(float(v)) for v in o.decoy_euler_rel_rad)
    return {
        "t_s": o.time_s,
        "seq": o.request_seq,
        "tension_connection_N": float(o.connection_tension_n),
        "tension_tow_N": float(o.tow_tension_n),
        "decoy_cg_behind_m": -x,
        "decoy_cg_lateral_m": -y,
        "decoy_cg_below_m": z,
        "decoy_roll_deg": roll,
        "decoy_pitch_deg": pitch,
        "decoy_yaw_deg": yaw,
        "decoy_aoa_deg": math.degrees(float(o.angle_of_attack_rad)),
        "cable_exhaust_clearance_m": float(o.cable_clearance_exhaust_m),
        "decoy_aircraft_clearance_m": float(o.decoy_clearance_aircraft_m),
        "aircraft_speed_mps": float(np.linalg.norm(rec.state.velocity_ned_mps)),
        "aircraft_altitude_m": float(-rec.state.position_ned_m[2]),
        "aircraft_load_factor": rec.state.extra.get("load_factor", math.nan),
        "flags": o.flags,
        "rk4_steps": o.steps,
        "instructions": o.instructions,
        "latency_us": rec.latency_us,
        **management_columns(o),
    }


def management_columns(o: Any) -> dict[str, Any]:
    """The management columns of an Output (:data:`OUTPUT_COLUMNS`)."""
    cols: dict[str, Any] = {}
    for name, unit in zip(REQUIREMENTS, MARGIN_UNITS):
        r = getattr(o, name)
        margin = float(r.margin)
        cols[f"{name}_level"] = int(r.level)
        cols[f"{name}_margin_{unit}"] = math.degrees(margin) if name == "posture" else margin
    cols["advisories"] = int(o.advisories)
    return cols


def management_summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """``summary.json``'s ``"management"``, as ``decoy feed`` computes it: per
    requirement the worst margin, the first violation and the first advisory (s)
    and the advisory's lead (null where none)."""
    out: dict[str, Any] = {}
    for k, (name, unit) in enumerate(zip(REQUIREMENTS, MARGIN_UNITS)):
        margins = [r[f"{name}_margin_{unit}"] for r in rows if math.isfinite(r[f"{name}_margin_{unit}"])]
        violation = next((round(r["t_s"], 9) for r in rows if r[f"{name}_level"] == 3), None)
        advisory = next((round(r["t_s"], 9) for r in rows if r["advisories"] & (1 << k)), None)
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


def write_trajectory(path: Path, states: Iterable[AircraftState]) -> None:
    """``trajectory.csv``: one row per frame (:data:`TRAJECTORY_COLUMNS`), times with 9 decimals."""
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(TRAJECTORY_COLUMNS)
        for s in states:
            row = [f"{s.time_s:.9f}"]
            for arr in (s.position_ned_m, s.velocity_ned_mps, s.acceleration_ned_mps2, s.attitude_wxyz,
                        s.body_rate_radps, s.body_angular_acceleration_radps2):
                row.extend(_fmt(float(v)) for v in arr)
            row.extend(_fmt(float(s.extra.get(k, math.nan))) for k in EXTRA_COLUMNS)
            w.writerow(row)


def write_outputs(path: Path, run: Run) -> list[dict[str, Any]]:
    """``timeseries.csv``: one row per answered frame (:data:`OUTPUT_COLUMNS`); returns the rows."""
    rows = [output_row(r) for r in run.records if r.output is not None and not r.initialising]
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(OUTPUT_COLUMNS)
        for r in rows:
            w.writerow([f"{r['t_s']:.9f}"] + [_fmt(r[k]) for k in OUTPUT_COLUMNS[1:]])
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
) -> dict[str, Any]:
    """``summary.json``: the keys of ``decoy feed``'s summary (docs/outputs.md and
    docs/bridge.md), computed the same way from the answered frames (10 ms rows).

    The two host-replay keys (``max_tension_diff_vs_host_N``,
    ``max_tension_diff_vs_host_same_precision_N``,
    ``frames_identical_to_host_same_precision``) need the Rust host controller and
    are ``null`` here.
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
