"""The towed-decoy solver in Python: the ``decoy`` command line's trim and
simulations called directly, with its numbers bit for bit (see the package's
docstring, the repository's README, "The solver in Python", and
docs/outputs.md for the columns)."""

import os
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Final, Literal, TypeAlias

import numpy as np
import numpy.typing as npt

__version__: Final[str]

#: The shipped scenarios' names: ``steady``, ``acceleration``, ``pull-up``,
#: ``turn``, ``recorded``.
SCENARIOS: Final[tuple[str, ...]]

#: The system: None (the built-in reference system), the path of a system TOML
#: file (as ``decoy --config``), or a dict of that file's tables (an overlay
#: too: ``{"base": "reference-system.toml", "decoy": {"mass": 5.0}}``).
Config: TypeAlias = str | os.PathLike[str] | Mapping[str, Any] | None

#: A scenario: a shipped name or the path of a scenario TOML file (as
#: ``decoy simulate --scenario``), or a dict of that file's keys.
ScenarioLike: TypeAlias = str | os.PathLike[str] | Mapping[str, Any]

#: Column name to a 1-D float64 array of the column's rows.
Columns: TypeAlias = dict[str, npt.NDArray[np.float64]]

class DecoyError(Exception):
    """Every error of the decoy package; the message is the decoy command
    line's for the same input (without its ``error: ``)."""

class ConfigError(DecoyError):
    """The system configuration (a path or a dict) cannot be read, parsed or
    validated, or does not suit the run: ``config dict: decoy.mass must be
    positive, got -1``."""

class ScenarioError(DecoyError):
    """The scenario is unknown, or its file, dict or recorded flight cannot be
    read or parsed: ``unknown scenario `x`: the shipped scenarios are ...``."""

class InputError(DecoyError):
    """A value of the scenario or an argument is missing, out of range or does
    not apply to the scenario's kind. An argument is named by the command
    line's flag: ``command line: --rate must be a rate between -1 and 1 rad/s,
    got NaN``."""

class SolverError(DecoyError):
    """The solver could not produce a result: no trim for the flight condition,
    an initial state that cannot be evaluated."""

class Stopped(SolverError):
    """The integration stopped part way: the state diverged (a time step too
    long for the discretisation) or the flight left the atmosphere."""

    #: The run up to its last good state (its summary has ``stopped``).
    result: Simulation
    #: Time of the last good state, s.
    t_s: float

class OutputError(DecoyError):
    """An output file or plot (``out=``) could not be written."""

class Simulation:
    """A run of ``simulate``: what ``decoy simulate`` writes to summary.json,
    timeseries.csv and cable.csv (docs/outputs.md), in memory."""

    @property
    def summary(self) -> dict[str, Any]:
        """summary.json's content: scenario, segments, dt, t_end,
        max_tension_connection_N, t_at_max_tension_s,
        pitch_oscillation_amplitude_deg, settling_time_s, final,
        min_cable_clearance_to_exhaust_m, min_decoy_clearance_to_aircraft_m,
        wall_s, management, and stopped when the run ended early."""

    @property
    def timeseries(self) -> Columns:
        """timeseries.csv's columns (t_s, tension_connection_N, ...; the names
        of docs/outputs.md, in its order): a row every 10 ms of simulated time,
        the initial and final states included, at full precision (the file
        rounds to 6 decimals). Levels and advisories are whole numbers; a
        ``*_violation_in_s`` is -1 where none is predicted."""

    @property
    def cable(self) -> Columns:
        """cable.csv's columns (t_s, joint, along_m, behind_m, lateral_m,
        below_m, tension_N): every snapshot (every 1 s, and the initial and
        final states) as its joints 0 (connection point) to N (towing point),
        one after the other; ``cable["tension_N"].reshape(-1, N + 1)`` has a
        row per snapshot."""

    @property
    def files(self) -> list[str]:
        """The files written with ``out=``, in order; empty otherwise."""

def trim(
    altitude: float,
    mach: float,
    *,
    segments: int | None = None,
    grading: float | None = None,
    config: Config = None,
) -> dict[str, Any]:
    """The steady level-flight trim of the towed system, as ``decoy trim --json``.

    altitude: aircraft altitude, m (0 to 20000). mach: Mach number (above 0, at
    most 2). segments: cable segments (default: the configuration's
    solver.segments_host). grading: segment length ratio, short at the decoy
    (1 = uniform). config: the system.

    Returns decoy_pitch_deg, tension_connection_N, tension_tow_N,
    decoy_cg_behind_m, decoy_cg_below_m (from the aircraft reference point),
    decoy_cg_behind_connection_m, decoy_cg_below_connection_m (from the
    connection point) and tension_profile_N (joints 0 to N).

    Raises InputError, ConfigError or SolverError (no trim) with the command
    line's message.
    """

def simulate(
    scenario: ScenarioLike,
    *,
    rate: float | None = None,
    onset: float | None = None,
    altitude: float | None = None,
    mach: float | None = None,
    t_end: float | None = None,
    segments: int | None = None,
    grading: float | None = None,
    dt: float | None = None,
    initial: Literal["trim", "straight"] = "trim",
    config: Config = None,
    out: str | os.PathLike[str] | None = None,
    plots: bool = True,
) -> Simulation:
    """Flies a scenario as ``decoy simulate`` does and returns the run.

    scenario: a shipped name (SCENARIOS), the path of a scenario TOML file, or
    a dict of its keys (``builtin_scenario(name)`` gives one to edit; a None
    value leaves its key out).

    The keywords override the scenario as the command line's flags do: rate
    (``--rate``, rad/s, pull-up and turn), onset (``--onset``, s: the pull-up's
    or turn's rate built over it at a finite angular acceleration; 0: the
    paper's step), altitude (``--altitude``, m), mach
    (``--mach``), t_end (``--t-end``, s), segments (``--segments``), grading
    (``--grading``), dt (``--dt``, s: a fixed RK4 step; None: the scenario's
    step rule), initial (``--initial``: the trim of the flight condition at
    t = 0, or a straight cable). config: the system.

    out: a directory to write what ``decoy simulate --out`` writes
    (timeseries.csv, cable.csv, summary.json and, with plots, the plots);
    None writes nothing.

    The solver runs with the GIL released. Raises ScenarioError, InputError,
    ConfigError, SolverError or OutputError with the command line's message;
    Stopped when the integration stopped part way (``e.result`` the run up to
    its last good state); KeyboardInterrupt at Ctrl-C.
    """

def envelope(
    manoeuvre: Literal["pull-up", "turn", "acceleration"],
    *,
    altitudes: Sequence[float] | None = None,
    machs: Sequence[float] | None = None,
    segments: int | None = None,
    grading: float | None = None,
    onset: float | None = None,
    tolerance: float | None = None,
    mach_gain: float | None = None,
    workers: int | None = None,
    ray: str | None = None,
    out: str | os.PathLike[str] | None = None,
    config: Config = None,
    progress: Callable[[int, int], None] | bool | None = None,
) -> dict[str, Any]:
    """The manoeuvre envelope map, as ``decoy envelope --json`` prints it
    (docs/envelope.md): for each cell of altitude x Mach, the largest pull-up
    or turn rate (rad/s) or along-path acceleration (m/s^2) clear of every
    requirement, what limits it, and the steady-flight margins.

    altitudes (m), machs: the grid (default: the configuration's declared
    envelope). segments, grading: the model (default 300 uniform segments).
    onset: s (default 0.5; pull-up and turn). tolerance: of the bisection
    (default 0.005 rad/s, or 0.05 m/s^2). mach_gain: the acceleration's gain in
    Mach (default 0.1). workers: threads of a local map (default: all cores).
    ray: a Ray cluster's address: every cell a Ray task of this package, the
    same bits as a local map (not with workers). out: the map's directory
    (resumed when it holds a map of the same inputs; None: no files). config:
    the system. progress: callable(done, total), True (a bar on stderr) or
    False (None: a bar at a terminal).

    Raises InputError, ConfigError, SolverError or OutputError with the
    command line's message.
    """

def builtin_config() -> dict[str, Any]:
    """The built-in reference system (config/reference-system.toml) as a dict
    of its tables, to edit and pass as ``config=``; its aero_table,
    ``decoy-aero.csv``, is the built-in table (unless the working directory
    has a file of that name)."""

def builtin_scenario(name: str) -> dict[str, Any]:
    """A shipped scenario (SCENARIOS) as a dict of its keys, to edit and pass to
    ``simulate``. An unknown name raises ScenarioError."""
