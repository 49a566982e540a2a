#!/usr/bin/env python3
"""JSBSim's F-16 flying the paper's manoeuvres through a running ``decoy bridge``.

    .venv/bin/python clients/python/examples/jsbsim_f16.py --instance demo \\
        --manoeuvre pull-up --rate 0.1 --out out/f16-pull-up

Trims the F-16 (default 9 km, Mach 0.8; the acceleration starts at Mach 0.6), flies
the manoeuvre in JSBSim and streams the aircraft state at 100 Hz in lockstep to
bridge ``--instance`` (after a reset to trim: the first state trims the decoy).
Then flies the built-in profile of the same manoeuvre (same altitude, Mach, rate,
start and duration: a scenario file written to ``DIR/builtin/scenario.toml``)
through the same bridge with ``decoy feed``, and writes to ``DIR``:

* ``trajectory.csv``: the F-16's state as sent (NED position, velocity, derived
  acceleration, quaternion, body rates and angular accelerations) and flight-test
  quantities (Mach, altitude, load factor, Euler angles, controls);
* ``timeseries.csv``: the decoy's outputs, ``decoy feed``'s columns, one row per
  answered frame, with each frame's round trip from Python;
* ``summary.json``: ``decoy feed``'s keys for the F-16 run;
* ``comparison.json``: the F-16 run beside ``decoy feed``'s built-in profile (peak
  tension, smallest clearances, largest lateral offset, latency, wall time);
* ``tensions.png``, ``decoy-position.png``, ``clearances.png``, ``load-factor.png``:
  the F-16 run and the built-in profile side by side (unless ``--no-plots``);
* ``builtin/``: ``decoy feed``'s own output (unless ``--no-compare``).

Across hosts, over Zenoh (the bridge runs with ``--zenoh-listen ENDPOINT``, and
``--zenoh-users FILE`` beyond loopback):

    .venv/bin/python clients/python/examples/jsbsim_f16.py --instance demo \\
        --manoeuvre pull-up --zenoh-connect tcp/10.0.0.1:7447 \\
        --zenoh-credentials pilot.cred --out out/f16-pull-up

flies the same frames with the same answers (the summary says ``"transport":
"zenoh"``), and ``decoy feed`` flies the built-in profile over Zenoh too.

Exit 0 when every frame was answered by an output, 1 when frames were rejected or
the run stopped (the files are written either way), 2 for bad arguments or no bridge.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

from decoy_bridge import Bridge, BridgeError, NoBridge
from decoy_bridge import f16 as F
from decoy_bridge import flight
from decoy_bridge.affinity import parse_cpu_list, pin


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--instance", required=True, help="bridge instance (decoy bridge --instance NAME)")
    p.add_argument("--manoeuvre", required=True, choices=F.MANOEUVRES)
    p.add_argument("--rate", type=float, help="pull-up / turn rate, rad/s (paper: pull-up 0.05, 0.10, 0.20; turn 0.10, 0.20)")
    p.add_argument("--altitude", type=float, help="initial altitude, m (default 9000)")
    p.add_argument("--mach", type=float, help="initial Mach number (default 0.8; acceleration 0.6)")
    p.add_argument("--t-end", type=float, help="simulated time, s (default: the built-in scenario's)")
    p.add_argument("--out", required=True, type=Path, help="output directory")
    p.add_argument("--prefix", default=None,
                   help="iceoryx2 file prefix of the bridge (default $DECOY_IOX_PREFIX, else iceoryx2's)")
    p.add_argument("--zenoh-connect", action="append", default=None, metavar="ENDPOINT",
                   help="fly through a bridge across hosts over Zenoh: connect to ENDPOINT (the bridge's "
                   "--zenoh-listen, tcp/10.0.0.1:7447; repeatable)")
    p.add_argument("--zenoh-config", type=Path, default=None, metavar="FILE",
                   help="a Zenoh configuration file (JSON5: TLS, certificates, ...), read first")
    p.add_argument("--zenoh-credentials", type=Path, default=None, metavar="FILE",
                   help="this client's credentials for a bridge that authenticates (one line `user:password`)")
    p.add_argument("--timeout", type=float, default=5.0, help="time limit of each answer, s")
    p.add_argument("--decoy", default=None, help="the decoy binary for the built-in comparison (default: $DECOY_BIN, "
                   "target/release/decoy, target/debug/decoy, then PATH)")
    p.add_argument("--no-compare", action="store_true", help="do not fly the built-in profile with decoy feed")
    p.add_argument("--cpu", default=None, metavar="LIST",
                   help="run on these CPUs only (0, 0,2, 0-3), as decoy bridge --cpu; the built-in comparison too "
                   "(docs/bridge.md, \"Cores\")")
    p.add_argument("--no-plots", action="store_true")
    p.add_argument("--json", action="store_true", help="print summary.json on stdout")
    a = p.parse_args(argv)
    alt, mach = F.DEFAULT_CONDITION[a.manoeuvre]
    a.altitude = alt if a.altitude is None else a.altitude
    a.mach = mach if a.mach is None else a.mach
    a.t_end = F.DEFAULT_T_END[a.manoeuvre] if a.t_end is None else a.t_end
    if not (0.0 <= a.altitude <= 15000.0):
        p.error(f"--altitude {a.altitude}: 0 to 15000 m")
    if not (0.2 <= a.mach <= 1.2):
        p.error(f"--mach {a.mach}: 0.2 to 1.2")
    if not (0.01 <= a.t_end <= 600.0):
        p.error(f"--t-end {a.t_end}: 0.01 to 600 s")
    if a.rate is not None and a.manoeuvre not in F.DEFAULT_RATE:
        p.error(f"--rate does not apply to the {a.manoeuvre} manoeuvre")
    if a.rate is None and a.manoeuvre in F.DEFAULT_RATE:
        a.rate = F.DEFAULT_RATE[a.manoeuvre]
    if a.rate is not None and not (0.0 < abs(a.rate) <= 1.0):
        p.error(f"--rate {a.rate}: 0 < |rate| <= 1 rad/s")
    a.zenoh = a.zenoh_connect is not None or a.zenoh_config is not None or a.zenoh_credentials is not None
    if a.zenoh and a.zenoh_connect is None and a.zenoh_config is None:
        p.error("--zenoh-credentials needs --zenoh-connect ENDPOINT (or --zenoh-config)")
    if a.cpu is not None:
        try:
            a.cpus = parse_cpu_list(a.cpu)
        except ValueError as e:
            p.error(str(e))
    return a


def find_decoy(given: str | None) -> str | None:
    """The decoy binary: ``--decoy``, ``$DECOY_BIN``, the repository's target/, or PATH."""
    if given:
        return given
    if os.environ.get("DECOY_BIN"):
        return os.environ["DECOY_BIN"]
    root = Path(__file__).resolve().parents[3]
    for build in ("release", "debug"):
        candidate = root / "target" / build / "decoy"
        if candidate.is_file():
            return str(candidate)
    return shutil.which("decoy")


def builtin_scenario(a: argparse.Namespace, man: F.Manoeuvre) -> str:
    """The scenario file of the built-in profile that the F-16 flies."""
    name = f"f16-{a.manoeuvre}"
    lines = [f'name = "{name}-builtin"', f'description = "Built-in profile of the F-16 run {a.out.name}"',
             f'altitude_m = {a.altitude:.1f}', f't_end_s = {a.t_end}']
    if a.manoeuvre == "steady":
        lines += ['kind = "steady"', f"mach = {a.mach}"]
    elif a.manoeuvre == "pull-up":
        assert isinstance(man, F.PullUp)
        lines += ['kind = "pull-up"', f"mach = {a.mach}", f"rate_radps = {a.rate}", f"start_s = {man.start}",
                  f"duration_s = {man.duration}"]
    elif a.manoeuvre == "turn":
        assert isinstance(man, F.Turn)
        lines += ['kind = "turn"', f"mach = {a.mach}", f"rate_radps = {a.rate}", f"start_s = {man.start}"]
    else:
        assert isinstance(man, F.Acceleration)
        lines += ['kind = "acceleration"', f"mach = {a.mach}", f"final_mach = {man.m1}",
                  f"accel_start_s = {man.start}", f"acceleration_mps2 = {man.accel}"]
    return "\n".join(lines) + "\n"


def ideal_load_factor(a: argparse.Namespace, man: F.Manoeuvre, t: list[float], speed: list[float]) -> list[float]:
    """The built-in profile's load factor (its acceleration minus gravity, normal to
    the flight path, in g): pull-up cos γ + V ω / g while rotating, turn
    sqrt(1 + (V ω / g)²), level flight 1."""
    out = []
    for ti, v in zip(t, speed):
        if isinstance(man, F.PullUp):
            gamma, rate = man.gamma_ref(ti)
            out.append(math.cos(gamma) + v * rate / F.G0)
        elif isinstance(man, F.Turn):
            w = a.rate if ti >= man.start else 0.0
            out.append(math.hypot(1.0, v * w / F.G0))
        else:
            out.append(1.0)
    return out


def run_feed(decoy: str, a: argparse.Namespace, scenario: Path, out_dir: Path) -> dict | None:
    """``decoy feed`` of the built-in profile through the same bridge; its summary."""
    cmd = [decoy, "feed", "--instance", a.instance, "--scenario", str(scenario), "--out", str(out_dir), "--no-plots",
           "--json"]
    if a.cpu is not None:
        cmd += ["--cpu", a.cpu]
    for endpoint in a.zenoh_connect or []:
        cmd += ["--zenoh-connect", endpoint]
    if a.zenoh_config is not None:
        cmd += ["--zenoh-config", str(a.zenoh_config)]
    if a.zenoh_credentials is not None:
        cmd += ["--zenoh-credentials", str(a.zenoh_credentials)]
    env = dict(os.environ)
    if a.prefix:
        env["DECOY_IOX_PREFIX"] = a.prefix
    print(f"$ {' '.join(cmd)}", file=sys.stderr)
    done = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if done.returncode != 0:
        print(f"warning: decoy feed failed ({done.returncode}): {done.stderr.strip()}", file=sys.stderr)
        return None
    return json.loads(done.stdout)


def read_csv(path: Path) -> dict[str, list[float]]:
    import csv

    with path.open() as f:
        rows = list(csv.DictReader(f))
    if not rows:
        return {}
    out: dict[str, list[float]] = {}
    for k in rows[0]:
        try:
            out[k] = [float(r[k]) for r in rows]
        except ValueError:
            pass
    return out


def plots(out: Path, f16_rows: list[dict], traj: list[F.AircraftState], builtin: dict[str, list[float]],
          ideal_n: list[float], title: str) -> list[str]:
    """The four comparison figures; returns their file names."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = [r["t_s"] for r in f16_rows]
    bt = builtin.get("t_s", [])
    written = []

    def save(fig, name):
        fig.suptitle(title)
        fig.tight_layout()
        fig.savefig(out / f"{name}.png", dpi=110)
        plt.close(fig)
        written.append(f"{name}.png")

    fig, ax = plt.subplots(1, 2, figsize=(12, 4.5), sharey=True)
    for axis, rows_t, src, label in ((ax[0], t, None, "JSBSim F-16"), (ax[1], bt, builtin, "built-in profile (decoy feed)")):
        get = (lambda k: [r[k] for r in f16_rows]) if src is None else (lambda k, s=src: s.get(k, []))
        axis.plot(rows_t, get("tension_connection_N"), label="connection (joint 0)")
        axis.plot(rows_t, get("tension_tow_N"), label="towing point (joint N)")
        axis.set_title(label)
        axis.set_xlabel("t [s]")
        axis.grid(alpha=0.3)
    ax[0].set_ylabel("tension [N]")
    ax[0].legend()
    save(fig, "tensions")

    fig, ax = plt.subplots(1, 3, figsize=(14, 4.2))
    for i, (key, label) in enumerate((("decoy_cg_behind_m", "behind [m]"), ("decoy_cg_lateral_m", "lateral, left + [m]"),
                                      ("decoy_cg_below_m", "below the flight path [m]"))):
        ax[i].plot(t, [r[key] for r in f16_rows], label="JSBSim F-16")
        if bt:
            ax[i].plot(bt, builtin.get(key, []), "--", label="built-in profile")
        ax[i].set_ylabel(label)
        ax[i].set_xlabel("t [s]")
        ax[i].grid(alpha=0.3)
    ax[0].legend()
    fig.text(0.5, 0.005, "decoy CG relative to the aircraft reference point, flight-path frame", ha="center", fontsize=8)
    save(fig, "decoy-position")

    fig, ax = plt.subplots(1, 2, figsize=(12, 4.5))
    for i, (key, label) in enumerate((("cable_exhaust_clearance_m", "cable to exhaust plume [m] (<0 inside)"),
                                      ("decoy_aircraft_clearance_m", "decoy to aircraft envelope [m]"))):
        ax[i].plot(t, [r[key] for r in f16_rows], label="JSBSim F-16")
        if bt:
            ax[i].plot(bt, builtin.get(key, []), "--", label="built-in profile")
        ax[i].set_ylabel(label)
        ax[i].set_xlabel("t [s]")
        ax[i].grid(alpha=0.3)
    ax[0].legend()
    save(fig, "clearances")

    fig, ax = plt.subplots(figsize=(8, 4.5))
    ax.plot([s.time_s for s in traj], [s.extra["load_factor"] for s in traj], label="JSBSim F-16 (accelerations/Nz)")
    ax.plot([s.time_s for s in traj], ideal_n, "--", label="built-in profile (ideal)")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("load factor [g]")
    ax.grid(alpha=0.3)
    ax.legend()
    save(fig, "load-factor")
    return written


def main(argv: list[str] | None = None) -> int:
    a = parse_args(argv)
    if a.cpu is not None:
        try:
            pin(a.cpus)
        except ValueError as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
    a.out.mkdir(parents=True, exist_ok=True)
    wall0 = time.perf_counter()
    try:
        if a.zenoh:
            bridge = Bridge(a.instance, timeout_s=a.timeout, zenoh=a.zenoh_connect, zenoh_config=a.zenoh_config,
                            credentials=a.zenoh_credentials)
        else:
            bridge = Bridge(a.instance, prefix=a.prefix, timeout_s=a.timeout)
    except NoBridge as e:
        # Over Zenoh the error says where it looked and how to start a bridge there.
        hint = "" if a.zenoh else f"; start one with `decoy bridge --instance {a.instance}`"
        print(f"error: {e}{hint}", file=sys.stderr)
        return 2
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    with bridge:
        try:
            fdm = F.F16(a.altitude, a.mach)
        except F.TrimError as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
        man = F.make_manoeuvre(a.manoeuvre, fdm, a.rate)
        what = f"{a.manoeuvre}" + (f" at {a.rate:.2f} rad/s" if a.rate else "") + \
            f", F-16 trimmed at {a.altitude:.0f} m, Mach {a.mach:.2f} (alpha {fdm.trim_alpha_deg:.2f} deg)"
        over = f" over Zenoh ({', '.join(a.zenoh_connect or [str(a.zenoh_config)])})" if a.zenoh else ""
        print(f"flying {what} for {a.t_end:g} s through bridge `{a.instance}`{over}", file=sys.stderr)
        traj: list[F.AircraftState] = []

        def states():
            for s in fdm.fly(man, a.t_end):
                traj.append(s)
                yield s

        ping_us = []
        for i in range(20):
            t0 = time.perf_counter_ns()
            bridge.ping(nonce=i)
            ping_us.append((time.perf_counter_ns() - t0) / 1e3)
        run = flight.fly_lockstep(bridge, states())
        status = bridge.get_status()

    flight.write_trajectory(a.out / "trajectory.csv", traj)
    rows = flight.write_outputs(a.out / "timeseries.csv", run)
    start = getattr(man, "start", 0.0)
    summary = flight.summarize(run, rows, scenario=f"f16-{a.manoeuvre}", t_end=a.t_end, manoeuvre_start=start,
                               status=status, instance=a.instance, transport=bridge.transport)
    flight.write_json(a.out / "summary.json", summary)

    builtin_summary = None
    builtin: dict[str, list[float]] = {}
    if not a.no_compare:
        decoy = find_decoy(a.decoy)
        if decoy is None:
            print("warning: no decoy binary found for the built-in comparison (--decoy, $DECOY_BIN)", file=sys.stderr)
        else:
            bdir = a.out / "builtin"
            bdir.mkdir(exist_ok=True)
            scenario = bdir / "scenario.toml"
            scenario.write_text(builtin_scenario(a, man))
            builtin_summary = run_feed(decoy, a, scenario, bdir)
            if builtin_summary is not None and (bdir / "timeseries.csv").is_file():
                builtin = read_csv(bdir / "timeseries.csv")

    comparison = {
        "manoeuvre": a.manoeuvre,
        "rate_radps": a.rate,
        "altitude_m": a.altitude,
        "mach": a.mach,
        "t_end_s": a.t_end,
        "f16": {
            "max_tension_connection_N": summary.get("max_tension_connection_N"),
            "min_cable_clearance_to_exhaust_m": summary.get("min_cable_clearance_to_exhaust_m"),
            "min_decoy_clearance_to_aircraft_m": summary.get("min_decoy_clearance_to_aircraft_m"),
            "max_abs_decoy_cg_lateral_m": flight.largest_magnitude(r["decoy_cg_lateral_m"] for r in rows),
            "max_load_factor": max(s.extra["load_factor"] for s in traj) if traj else None,
            "final_mach": traj[-1].extra["mach"] if traj else None,
            "final_flight_path_deg": traj[-1].extra["flight_path_deg"] if traj else None,
            "latency_us": summary["latency_us"],
            "ping_latency_us": flight.percentiles(ping_us),
            "wall_s": run.wall_s,
            "simulated_s": traj[-1].time_s if traj else 0.0,
            "frames_sent": summary["frames_sent"],
            "frames_answered": summary["frames_answered"],
            "frames_initialising": summary["frames_initialising"],
            "frames_rejected": summary["frames_rejected"],
        },
        "builtin": None if builtin_summary is None else {
            "max_tension_connection_N": builtin_summary.get("max_tension_connection_N"),
            "min_cable_clearance_to_exhaust_m": builtin_summary.get("min_cable_clearance_to_exhaust_m"),
            "min_decoy_clearance_to_aircraft_m": builtin_summary.get("min_decoy_clearance_to_aircraft_m"),
            "max_abs_decoy_cg_lateral_m": flight.largest_magnitude(builtin.get("decoy_cg_lateral_m", [])),
            "latency_us": builtin_summary.get("latency_us"),
            "wall_s": builtin_summary.get("wall_s"),
        },
        "total_wall_s": time.perf_counter() - wall0,
    }
    flight.write_json(a.out / "comparison.json", comparison)

    files = ["trajectory.csv", "timeseries.csv", "summary.json", "comparison.json"]
    if not a.no_plots and rows:
        ideal = ideal_load_factor(a, man, [s.time_s for s in traj], [float(sum(v * v for v in s.velocity_ned_mps) ** 0.5)
                                                                        for s in traj])
        files += plots(a.out, rows, traj, builtin, ideal, what)

    if a.json:
        print((a.out / "summary.json").read_text(), end="")
    else:
        f, b = comparison["f16"], comparison["builtin"] or {}

        def show(v, fmt="{:.1f}"):
            return "-" if v is None else fmt.format(v)

        print(f"F-16 {what}")
        print(f"  frames sent {f['frames_sent']}, answered {f['frames_answered']}, "
              f"initialising {f['frames_initialising']}, rejected {f['frames_rejected']}")
        print(f"  {'':34} {'F-16':>10} {'built-in':>10}")
        print(f"  {'peak connection tension [N]':34} {show(f['max_tension_connection_N']):>10} "
              f"{show(b.get('max_tension_connection_N')):>10}")
        print(f"  {'smallest plume clearance [m]':34} {show(f['min_cable_clearance_to_exhaust_m'], '{:.2f}'):>10} "
              f"{show(b.get('min_cable_clearance_to_exhaust_m'), '{:.2f}'):>10}")
        print(f"  {'largest decoy lateral offset [m]':34} {show(f['max_abs_decoy_cg_lateral_m'], '{:.2f}'):>10} "
              f"{show(b.get('max_abs_decoy_cg_lateral_m'), '{:.2f}'):>10}")
        lat = f["latency_us"]
        print(f"  latency from Python: p50 {lat['p50']:.0f} us, p99 {lat['p99']:.0f} us, max {lat['max']:.0f} us; "
              f"ping p50 {f['ping_latency_us']['p50']:.0f} us")
        print(f"  wall {f['wall_s']:.2f} s for {f['simulated_s']:.2f} s simulated "
              f"({f['simulated_s'] / max(f['wall_s'], 1e-9):.1f}x real time)")
        print(f"wrote to {a.out}: {', '.join(files)}")
    if run.stopped is not None:
        print(f"error: the run stopped at t = {run.stopped['t_s']:.2f} s: {run.stopped['reason']}", file=sys.stderr)
        return 1
    if summary["frames_rejected"]:
        print(f"error: {summary['frames_rejected']} frames were rejected (see timeseries.csv)", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except BridgeError as e:
        print(f"error: {e}", file=sys.stderr)
        sys.exit(1)
