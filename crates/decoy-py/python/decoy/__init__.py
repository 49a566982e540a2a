"""The towed-decoy solver in Python.

The same solver as the ``decoy`` command line (crates/decoy-sim, built into the
extension module ``decoy._native``), called directly: no process, no files
unless asked, the numbers bit for bit the command line's.

- ``trim(altitude, mach, *, segments=None, grading=None, config=None)``: the
  steady level-flight trim, the dict ``decoy trim --json`` prints;
- ``simulate(scenario, *, rate=None, onset=None, altitude=None, mach=None,
  t_end=None, segments=None, grading=None, dt=None, initial="trim", config=None,
  out=None, plots=True)``: a flight as ``decoy simulate``, returned as a ``Simulation``
  (``summary``: summary.json's dict; ``timeseries``, ``cable``: the columns of
  timeseries.csv and cable.csv as float64 NumPy arrays; ``files``);
- ``envelope(manoeuvre, *, altitudes=None, machs=None, segments=None,
  grading=None, onset=None, tolerance=None, mach_gain=None, workers=None,
  ray=None, out=None, config=None, progress=None)``: the manoeuvre envelope map
  as ``decoy envelope --json``, on this machine's cores or as tasks on a Ray
  cluster (``ray="host:port"``);
- ``builtin_config()``, ``builtin_scenario(name)``, ``SCENARIOS``: the built-in
  system and the shipped scenarios as dicts, to edit and pass back;
- ``DecoyError`` and its kinds ``ConfigError``, ``ScenarioError``,
  ``InputError``, ``SolverError`` (``Stopped``), ``OutputError``: each with the
  command line's message for the same input.

The solver releases the GIL while it runs, so Python threads run beside it
(several simulations at once on several cores); Ctrl-C stops a run with
KeyboardInterrupt. Columns, units and frames: docs/outputs.md.
"""

from decoy._native import (
    SCENARIOS,
    ConfigError,
    DecoyError,
    InputError,
    OutputError,
    ScenarioError,
    Simulation,
    SolverError,
    Stopped,
    __version__,
    builtin_config,
    builtin_scenario,
    simulate,
    trim,
)
from decoy._envelope import envelope

__all__ = [
    "SCENARIOS",
    "ConfigError",
    "DecoyError",
    "InputError",
    "OutputError",
    "ScenarioError",
    "Simulation",
    "SolverError",
    "Stopped",
    "__version__",
    "builtin_config",
    "builtin_scenario",
    "envelope",
    "simulate",
    "trim",
]
