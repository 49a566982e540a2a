"""The solver's package ``decoy`` (crates/decoy-py) against the ``decoy`` command
line of the same tree: the same numbers bit for bit (summary, time series,
cable snapshots, trim), the same errors with the same messages, the GIL
released while the solver runs, Ctrl-C as KeyboardInterrupt."""

from __future__ import annotations

import json
import math
import os
import signal
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import decoy
from conftest import REPO, decoy_binary


@pytest.fixture(scope="module")
def cli() -> str:
    return decoy_binary()


def run_cli(cli: str, *args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([cli, *args], capture_output=True, text=True, timeout=600, cwd=cwd)


def cli_json(cli: str, *args: str) -> dict:
    done = run_cli(cli, *args, "--json")
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def cli_error(cli: str, *args: str, cwd: Path | None = None) -> str:
    """The message of a failing command (its stderr without ``error: ``)."""
    done = run_cli(cli, *args, cwd=cwd)
    assert done.returncode != 0, done.stdout
    line = done.stderr.strip()
    assert line.startswith("error: "), line
    return line[len("error: ") :]


def bits(x: float) -> bytes:
    return struct.pack("<d", x)


def assert_same(a, b, path: str = "") -> None:
    """Equal values, floats bit for bit (NaN and the sign of zero included)."""
    if isinstance(a, float) or isinstance(b, float):
        assert isinstance(a, float) and isinstance(b, float), f"{path}: {a!r} vs {b!r}"
        assert bits(a) == bits(b), f"{path}: {a!r} vs {b!r}"
    elif isinstance(a, dict):
        assert isinstance(b, dict) and list(a) == list(b), f"{path}: keys {list(a)} vs {list(b)}"
        for k in a:
            assert_same(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), f"{path}: {a!r} vs {b!r}"
        for i, (x, y) in enumerate(zip(a, b)):
            assert_same(x, y, f"{path}[{i}]")
    else:
        assert a == b and type(a) is type(b), f"{path}: {a!r} vs {b!r}"


def without_wall(summary: dict) -> dict:
    return {k: v for k, v in summary.items() if k != "wall_s"}


def format_time(t: float) -> str:
    """decoy_sim::format_time: nine decimals, trailing zeros dropped."""
    s = f"{t:.9f}".rstrip("0").rstrip(".")
    return "0" if s == "-0" else s


def format_cell(value: float, written: str) -> str:
    """A value as the CSV file writes its column's kind: six decimals (no
    negative zero), or a whole number for counts and codes."""
    if "." not in written:
        assert float(value).is_integer(), value
        return str(int(value))
    s = f"{value:.6f}"
    return "0.000000" if s == "-0.000000" else s


def assert_columns_are_the_file(columns: dict, csv: Path) -> None:
    """The arrays hold, row for row, the values the file writes (its cells are
    the arrays' values formatted as the writer formats them)."""
    header, *rows = csv.read_text().splitlines()
    assert list(columns) == header.split(",")
    cells = [row.split(",") for row in rows]
    for k, (name, values) in enumerate(columns.items()):
        assert isinstance(values, np.ndarray) and values.dtype == np.float64 and values.ndim == 1
        assert len(values) == len(cells), name
        for row, value in zip(cells, values.tolist()):
            written = row[k]
            expected = format_time(value) if name == "t_s" else format_cell(value, written)
            assert expected == written, f"{csv.name} {name}: {value!r} is written {written}"


CASES = [
    ("steady", {"segments": 8, "t_end": 1.5}),
    ("acceleration", {"segments": 10, "grading": 1.3, "t_end": 3.0, "dt": 0.002}),
    ("pull-up", {"segments": 12, "t_end": 3.0, "rate": 0.2}),
    ("pull-up", {"segments": 12, "t_end": 3.0, "rate": 0.2, "onset": 0.5}),
    ("turn", {"segments": 8, "t_end": 2.0, "rate": -0.1, "initial": "straight"}),
    ("recorded", {"segments": 6, "t_end": 1.5}),
]


def flags(kwargs: dict) -> list[str]:
    out = []
    for key, value in kwargs.items():
        out += [f"--{key.replace('_', '-')}", str(value)]
    return out


@pytest.mark.parametrize(("scenario", "kwargs"), CASES, ids=[c[0] for c in CASES])
def test_a_simulation_is_the_command_lines_bit_for_bit(cli, tmp_path, scenario, kwargs):
    cli_dir = tmp_path / "cli"
    printed = cli_json(cli, "simulate", "--scenario", scenario, *flags(kwargs), "--out", str(cli_dir), "--no-plots")
    sim = decoy.simulate(scenario, **kwargs)
    assert isinstance(sim, decoy.Simulation) and sim.files == []
    # The summary: what the command line prints and writes, but for the wall time.
    assert_same(without_wall(sim.summary), without_wall(printed))
    assert_same(without_wall(sim.summary), without_wall(json.loads((cli_dir / "summary.json").read_text())))
    assert "stopped" not in sim.summary
    # The time series and the cable snapshots: the files' values at full precision.
    assert_columns_are_the_file(sim.timeseries, cli_dir / "timeseries.csv")
    assert_columns_are_the_file(sim.cable, cli_dir / "cable.csv")
    joints = sim.summary["segments"] + 1
    per_snapshot = sim.cable["joint"].reshape(-1, joints)
    assert (per_snapshot == np.arange(joints)).all()
    assert sim.cable["t_s"][0] == 0.0 and sim.cable["t_s"][-1] == sim.timeseries["t_s"][-1]

    # `out=` writes the command line's files, byte for byte.
    py_dir = tmp_path / "py"
    written = decoy.simulate(scenario, **kwargs, out=py_dir, plots=False)
    assert written.files == [str(py_dir / f) for f in ("timeseries.csv", "cable.csv", "summary.json")]
    for name in ("timeseries.csv", "cable.csv"):
        assert (py_dir / name).read_bytes() == (cli_dir / name).read_bytes(), name
    assert_same(without_wall(json.loads((py_dir / "summary.json").read_text())), without_wall(printed))
    assert_same(without_wall(written.summary), without_wall(sim.summary))


def test_plots_are_the_command_lines_files(cli, tmp_path):
    args = {"segments": 6, "t_end": 1.0}
    run = run_cli(cli, "simulate", "--scenario", "turn", *flags(args), "--out", str(tmp_path / "cli"), "--json")
    assert run.returncode == 0, run.stderr
    sim = decoy.simulate("turn", **args, out=tmp_path / "py")
    assert sorted(Path(f).name for f in sim.files) == sorted(p.name for p in (tmp_path / "cli").iterdir())
    assert all(Path(f).is_file() for f in sim.files)


def test_the_scenario_as_a_path_a_dict_or_overridden_is_the_same_run():
    base = decoy.simulate("pull-up", segments=6, t_end=2.5, rate=0.2)
    as_path = decoy.simulate(REPO / "scenarios" / "pull-up.toml", segments=6, t_end=2.5, rate=0.2)
    assert_same(without_wall(as_path.summary), without_wall(base.summary))
    spec = decoy.builtin_scenario("pull-up")
    assert spec["kind"] == "pull-up" and spec["rate_radps"] == 0.1
    spec.update(rate_radps=0.2, t_end_s=2.5, segments=6, description=None)
    as_dict = decoy.simulate(spec)
    assert_same(without_wall(as_dict.summary), without_wall(base.summary))
    for name in base.timeseries:
        assert np.array_equal(as_dict.timeseries[name], base.timeseries[name]), name


def test_trim_is_the_command_lines(cli):
    for args in ({}, {"segments": 20}, {"segments": 12, "grading": 1.26}):
        printed = cli_json(cli, "trim", "--altitude", "9000", "--mach", "0.8", *flags(args))
        assert_same(decoy.trim(9000, 0.8, **args), printed)
    assert len(decoy.trim(3000.0, 0.6, segments=7)["tension_profile_N"]) == 8


def test_the_configuration_as_a_path_or_a_dict(cli, tmp_path):
    reference = REPO / "config" / "reference-system.toml"
    base = decoy.trim(9000, 0.7, segments=16)
    assert_same(decoy.trim(9000, 0.7, segments=16, config=reference), base)
    assert_same(decoy.trim(9000, 0.7, segments=16, config=str(reference)), base)
    # The built-in system as a dict: the same system.
    assert_same(decoy.trim(9000, 0.7, segments=16, config=decoy.builtin_config()), base)
    # An overlay as a dict is the overlay file the command line reads.
    overlay = tmp_path / "heavy.toml"
    overlay.write_text(f'base = "{reference}"\n[decoy]\nmass = 5.5\n')
    printed = cli_json(cli, "--config", str(overlay), "trim", "--altitude", "9000", "--mach", "0.7", "--segments", "16")
    heavy = decoy.trim(9000, 0.7, segments=16, config={"base": "reference-system.toml", "decoy": {"mass": 5.5}})
    assert_same(heavy, printed)
    assert heavy["tension_tow_N"] != base["tension_tow_N"]
    # A simulation with it too.
    sim = decoy.simulate("steady", segments=6, t_end=0.5, config={"base": str(reference), "decoy": {"mass": 5.5}})
    run = cli_json(cli, "--config", str(overlay), "simulate", "--scenario", "steady", "--segments", "6", "--t-end", "0.5", "--out", str(tmp_path / "o"), "--no-plots")
    assert_same(without_wall(sim.summary), without_wall(run))


# ---------------------------------------------------------------- bad inputs


def test_a_nan_rate_is_the_command_lines_error(cli):
    with pytest.raises(decoy.InputError) as e:
        decoy.simulate("pull-up", rate=float("nan"))
    assert str(e.value) == cli_error(cli, "simulate", "--scenario", "pull-up", "--rate", "NaN")
    assert str(e.value) == "command line: --rate must be a rate between -1 and 1 rad/s, got NaN"
    with pytest.raises(decoy.InputError) as e:
        decoy.simulate("steady", rate=0.1)
    assert str(e.value) == cli_error(cli, "simulate", "--scenario", "steady", "--rate", "0.1")
    for flag, value in (("segments", 0), ("t_end", -1.0), ("mach", 2.5), ("altitude", 30000.0), ("grading", 0.5), ("dt", 0.0), ("onset", -1.0), ("onset", 0.5)):
        with pytest.raises(decoy.InputError) as e:
            decoy.simulate("steady", **{flag: value})
        assert str(e.value) == cli_error(cli, "simulate", "--scenario", "steady", f"--{flag.replace('_', '-')}", str(value)), flag
    with pytest.raises(decoy.InputError) as e:
        decoy.trim(9000, float("inf"))
    assert str(e.value) == cli_error(cli, "trim", "--altitude", "9000", "--mach", "inf")
    with pytest.raises(decoy.InputError, match=r"^command line: --segments must be between 1 and 512, got -3$"):
        decoy.simulate("steady", segments=-3)
    with pytest.raises(decoy.InputError, match="--initial"):
        decoy.simulate("steady", initial="sideways")


def test_an_unknown_scenario_is_the_command_lines_error(cli, tmp_path):
    with pytest.raises(decoy.ScenarioError) as e:
        decoy.simulate("loop")
    assert str(e.value) == cli_error(cli, "simulate", "--scenario", "loop")
    assert str(e.value).startswith("unknown scenario `loop`: the shipped scenarios are steady, acceleration")
    with pytest.raises(decoy.ScenarioError):
        decoy.builtin_scenario("loop")
    missing = tmp_path / "missing.toml"
    with pytest.raises(decoy.ScenarioError) as e:
        decoy.simulate(str(missing))
    assert str(e.value) == cli_error(cli, "simulate", "--scenario", str(missing))


def test_a_broken_toml_is_the_command_lines_error(cli, tmp_path):
    broken = tmp_path / "broken.toml"
    broken.write_text('name = "broken"\nkind = "steady"\nmach = 0.8 0.9\n')
    with pytest.raises(decoy.ScenarioError) as e:
        decoy.simulate(broken)
    assert str(e.value) == cli_error(cli, "simulate", "--scenario", str(broken))
    assert str(e.value).startswith(f"{broken}, line 3: ")
    # The same for a configuration file.
    with pytest.raises(decoy.ConfigError) as e:
        decoy.trim(9000, 0.8, config=broken)
    assert str(e.value) == cli_error(cli, "--config", str(broken), "trim", "--altitude", "9000", "--mach", "0.8")
    with pytest.raises(decoy.ConfigError) as e:
        decoy.trim(9000, 0.8, config=tmp_path / "none.toml")
    assert str(e.value) == cli_error(cli, "--config", str(tmp_path / "none.toml"), "trim", "--altitude", "9000", "--mach", "0.8")


def test_a_negative_mass_in_a_config_dict_is_the_command_lines_error(cli, tmp_path):
    config = decoy.builtin_config()
    config["decoy"]["mass"] = -1.0
    with pytest.raises(decoy.ConfigError) as e:
        decoy.simulate("steady", config=config)
    assert str(e.value) == "config dict: decoy.mass must be positive, got -1"
    # The command line's message for a file with that value, but for its name.
    reference = REPO / "config" / "reference-system.toml"
    overlay = tmp_path / "light.toml"
    overlay.write_text(f'base = "{reference}"\n[decoy]\nmass = -1.0\n')
    message = cli_error(cli, "--config", str(overlay), "simulate", "--scenario", "steady")
    assert message == f"{overlay}: decoy.mass must be positive, got -1"
    with pytest.raises(decoy.ConfigError) as e:
        decoy.trim(9000, 0.8, config={"base": "reference-system.toml", "decoy": {"mass": -1.0}})
    assert str(e.value) == message.replace(str(overlay), "config dict")


def test_wrong_types_are_exceptions(cli, tmp_path):
    # Arguments of the wrong Python type: Python's TypeError.
    for call in (
        lambda: decoy.simulate("pull-up", rate="fast"),
        lambda: decoy.simulate(42),
        lambda: decoy.simulate("steady", config=3.5),
        lambda: decoy.simulate("steady", segments=2.5),
        lambda: decoy.trim("high", 0.8),
        lambda: decoy.simulate({"name": "x", 7: "key"}),
        lambda: decoy.simulate({"name": "x", "tags": [1, None]}),
        lambda: decoy.simulate({"name": "x", "kind": object()}),
    ):
        with pytest.raises(TypeError):
            call()
    # A value of the wrong type in a dict: the file's error for that value.
    spec = {"name": "typed", "kind": "steady", "altitude_m": 9000.0, "mach": "fast", "t_end_s": 1.0}
    with pytest.raises(decoy.ScenarioError) as e:
        decoy.simulate(spec)
    as_file = tmp_path / "typed.toml"
    as_file.write_text("".join(f"{k} = {json.dumps(v)}\n" for k, v in spec.items()))
    message = cli_error(cli, "simulate", "--scenario", str(as_file))
    assert message.startswith(f"{as_file}, line 4: ")
    assert str(e.value) == message.replace(str(as_file), "scenario")
    with pytest.raises(decoy.ConfigError, match=r'^config dict, line 3: invalid type: string "heavy", expected f64 \(in \[decoy\]\)$'):
        decoy.trim(9000, 0.8, config={"base": "reference-system.toml", "decoy": {"mass": "heavy"}})
    # An unknown key.
    with pytest.raises(decoy.ScenarioError, match="unknown field `colour`"):
        decoy.simulate({**decoy.builtin_scenario("steady"), "colour": "red"})


def test_a_diverging_run_raises_stopped_with_the_run_up_to_then(cli, tmp_path):
    args = {"segments": 12, "dt": 0.5, "t_end": 10.0}
    message = cli_error(cli, "simulate", "--scenario", "steady", *flags(args), "--out", str(tmp_path / "cli"), "--no-plots")
    with pytest.raises(decoy.Stopped) as e:
        decoy.simulate("steady", **args)
    assert isinstance(e.value, decoy.SolverError) and isinstance(e.value, decoy.DecoyError)
    # The command line's message, without the directory a run in memory does not have.
    assert message.endswith(f"; the outputs up to then are in {tmp_path / 'cli'}")
    assert str(e.value) == message.split("; the outputs up to then are in ")[0]
    result = e.value.result
    assert result.summary["stopped"]["t_s"] == e.value.t_s < 10.0
    assert "diverged" in result.summary["stopped"]["reason"]
    assert result.timeseries["t_s"][-1] == e.value.t_s
    printed = json.loads((tmp_path / "cli" / "summary.json").read_text())
    assert_same(without_wall(result.summary), without_wall(printed))
    # With `out=`: the message names the directory, as the command line's.
    with pytest.raises(decoy.Stopped) as e:
        decoy.simulate("steady", **args, out=tmp_path / "py", plots=False)
    assert str(e.value) == message.replace(str(tmp_path / "cli"), str(tmp_path / "py"))
    assert (tmp_path / "py" / "timeseries.csv").read_bytes() == (tmp_path / "cli" / "timeseries.csv").read_bytes()


def test_no_trim_is_a_solver_error(cli):
    with pytest.raises(decoy.SolverError) as e:
        decoy.trim(20000, 0.05)
    assert not isinstance(e.value, decoy.Stopped)
    assert str(e.value) == cli_error(cli, "trim", "--altitude", "20000", "--mach", "0.05")


def test_an_unwritable_output_is_an_output_error(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    with pytest.raises(decoy.OutputError, match="cannot create the directory"):
        decoy.simulate("steady", segments=4, t_end=0.1, out=blocker / "out")


# ---------------------------------------------------------------- threads and signals


def test_python_runs_while_a_thread_is_inside_simulate():
    """The solver runs without the GIL: this thread's Python code makes
    progress all through the other thread's call (with the GIL held, it would
    stand still for the whole call)."""
    done = threading.Event()
    call: dict = {}

    def run():
        call["start"] = time.monotonic()
        # Fixed 0.25 ms steps: long enough to see in any build (the adaptive
        # rule flies these 2.5 s in a few hundredths of a second in release).
        call["sim"] = decoy.simulate("pull-up", t_end=2.5, segments=200, dt=0.00025)
        call["end"] = time.monotonic()
        done.set()

    worker = threading.Thread(target=run)
    stamps = []
    worker.start()
    while not done.is_set():
        stamps.append(time.monotonic())
        sum(range(2000))
    worker.join()
    start, end = call["start"], call["end"]
    assert end - start > 0.3, "the call must be long enough to see"
    inside = [start] + [t for t in stamps if start < t < end] + [end]
    largest_gap = max(b - a for a, b in zip(inside, inside[1:]))
    assert largest_gap < 0.5 * (end - start), (largest_gap, end - start)
    assert "stopped" not in call["sim"].summary


def test_two_threads_give_the_same_numbers():
    results = [None, None]

    def run(k):
        results[k] = decoy.simulate("turn", segments=10, t_end=1.0)

    threads = [threading.Thread(target=run, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert_same(without_wall(results[0].summary), without_wall(results[1].summary))
    for name, values in results[0].timeseries.items():
        assert np.array_equal(values, results[1].timeseries[name], equal_nan=True), name


def test_ctrl_c_stops_a_run_with_keyboard_interrupt():
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signals are handled on the main thread")
    # Python's own handler, which raises KeyboardInterrupt: a library may have
    # put its own in its place (iceoryx2's nodes do, in the bridge's tests).
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT))
    start = time.monotonic()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            # About 20 s of work: stopped within a step of the signal.
            decoy.simulate("pull-up", t_end=20.0)
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    assert time.monotonic() - start < 8.0
    # The package still works afterwards.
    assert math.isfinite(decoy.trim(9000, 0.8, segments=8)["tension_connection_N"])


def test_the_speed_sweep_example_draws_its_plot(tmp_path):
    png = tmp_path / "speed-sweep.png"
    example = REPO / "clients" / "python" / "examples" / "speed_sweep.py"
    done = subprocess.run([sys.executable, str(example), str(png)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
