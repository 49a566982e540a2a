"""JSBSim's F-16 as the avionics simulation: trim, the paper's manoeuvres, and the
aircraft state the decoy solver takes, at 100 Hz.

How each quantity of :class:`AircraftState` is obtained (units and frames as in
:mod:`decoy_bridge.frames`):

* ``position_ned_m``: JSBSim's geodetic position (``position/lat-geod-rad``,
  ``position/long-gc-rad``, ``position/h-sl-meters``) in the flat-earth NED frame
  about the start point (:class:`~decoy_bridge.frames.FlatEarth`); ``down = -h``.
* ``velocity_ned_mps``: ``velocities/v-north-fps``, ``v-east-fps``, ``v-down-fps``
  (velocity relative to the earth in the local-level frame), × 0.3048.
* ``attitude_wxyz``: from the local-to-body matrix ``get_propagate().get_Tl2b()``
  (NED→body): its transpose is body→NED, turned into a quaternion by Shepperd's
  method (:func:`~decoy_bridge.frames.quat_from_dcm`), scalar first, ``w >= 0``.
* ``body_rate_radps``: ``velocities/p-rad_sec``, ``q-rad_sec``, ``r-rad_sec``
  (body FRD, relative to the earth).
* ``acceleration_ned_mps2`` and ``body_angular_acceleration_radps2``: JSBSim has no
  NED acceleration property. Both are central differences of the sampled NED
  velocity and body rates over the neighbouring frames, ``(v[k+1] - v[k-1]) / 2h``
  with ``h`` = 10 ms (the first frame: the forward difference, the last: the
  backward one), so they are the slopes of exactly the samples the solver
  interpolates between (its path between frames is cubic Hermite on positions and
  velocities with the acceleration linear). The stream therefore runs one frame
  behind the flight model. A test checks the NED acceleration against JSBSim's own
  body-axis derivatives (``accelerations/udot-ft_sec2``… plus ω × v, rotated to NED).

JSBSim runs at 200 Hz (``dt`` = 5 ms, two steps per 10 ms frame); the manoeuvre's
loops act on every step. Trim: ``ic/lat-geod-deg`` and ``ic/long-gc-deg`` are set
before ``ic/h-sl-ft`` and ``ic/mach`` (the other order changes the Mach number),
then ``run_ic()``, the engine running, ``simulation/do_simple_trim = 1``.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from . import wire
from .frames import FT, FlatEarth, central_difference, quat_from_dcm

G0 = 9.80665
"""Standard gravity, m/s²."""

FRAME_DT = 0.01
"""The solver's control period: one aircraft state every 10 ms."""
JSBSIM_DT = 0.005
"""JSBSim's integration step, s (two per frame)."""

MANOEUVRES = ("steady", "pull-up", "turn", "acceleration")
"""The manoeuvres :func:`make_manoeuvre` knows."""


class TrimError(RuntimeError):
    """JSBSim's trim did not converge for the requested flight condition."""


@dataclass
class AircraftState:
    """One 10 ms frame of the aircraft state, in the solver's frames (SI).

    Attributes:
        time_s: simulation time since the trimmed start, s.
        position_ned_m: reference point, flat-earth NED about the start point, m (down = -altitude).
        velocity_ned_mps: velocity over the ground, NED, m/s.
        acceleration_ned_mps2: acceleration, NED, m/s² (central difference of the velocity).
        attitude_wxyz: Hamilton quaternion, scalar first, body (FRD) → NED.
        body_rate_radps: body rates p, q, r (FRD), rad/s.
        body_angular_acceleration_radps2: their rates of change, rad/s² (central difference).
        extra: flight-test quantities for the trajectory CSV (Mach, altitude, load
            factor, Euler angles, flight-path angle, controls), see :data:`EXTRA_COLUMNS`.
    """

    time_s: float
    position_ned_m: np.ndarray
    velocity_ned_mps: np.ndarray
    acceleration_ned_mps2: np.ndarray
    attitude_wxyz: np.ndarray
    body_rate_radps: np.ndarray
    body_angular_acceleration_radps2: np.ndarray
    extra: dict[str, float] = field(default_factory=dict)


EXTRA_COLUMNS = tuple(
    c.name for c in wire.LAYOUT.csv_files["client_trajectory"].columns if c.quantity == "flight_test"
)
"""Keys of :attr:`AircraftState.extra`, the trajectory's flight-test columns of the
layout description (docs/outputs.md): Mach number, altitude (m), true airspeed
(m/s), load factor ``accelerations/Nz`` (g, 1 in level flight), JSBSim's Euler
angles (deg), flight-path angle (deg, positive climbing), angle of attack (deg),
and the normalised commands the loops set."""


class Manoeuvre(Protocol):
    """A manoeuvre: sets JSBSim's control inputs before each JSBSim step."""

    name: str

    def control(self, fdm: "F16", t: float) -> None:
        """Sets the controls for the step starting at simulation time ``t`` (s)."""


class F16:
    """JSBSim's F-16, trimmed in level flight at ``altitude_m`` and ``mach``.

    Args:
        altitude_m: altitude above sea level, m.
        mach: Mach number.
        lat_deg, lon_deg: start point (geodetic), deg.

    Raises:
        ImportError: the ``jsbsim`` package is missing (``cargo xtask setup``).
        TrimError: the trim did not converge.
    """

    def __init__(self, altitude_m: float = 9000.0, mach: float = 0.8, lat_deg: float = 0.0, lon_deg: float = 0.0):
        import jsbsim  # imported here: the client itself does not need it

        jsbsim.FGJSBBase().debug_lvl = 0
        fdm = jsbsim.FGFDMExec(None)
        fdm.set_debug_level(0)
        if not fdm.load_model("f16"):
            raise RuntimeError("JSBSim could not load its f16 model")
        fdm.set_dt(JSBSIM_DT)
        # Order matters (docs/toolchain.md §7): position before altitude and Mach.
        fdm["ic/lat-geod-deg"] = lat_deg
        fdm["ic/long-gc-deg"] = lon_deg
        fdm["ic/h-sl-ft"] = altitude_m / FT
        fdm["ic/mach"] = mach
        fdm["ic/psi-true-deg"] = 0.0
        if not fdm.run_ic():
            raise TrimError("JSBSim's run_ic failed")
        fdm["propulsion/set-running"] = -1
        try:
            fdm["simulation/do_simple_trim"] = 1
        except Exception as e:  # JSBSim raises TrimFailureError (a RuntimeError subclass)
            raise TrimError(f"the F-16 does not trim at {altitude_m:.0f} m, Mach {mach:.3f}: {e}") from e
        if abs(fdm["velocities/mach"] - mach) > 1e-3:
            raise TrimError(f"trimmed at Mach {fdm['velocities/mach']:.4f}, asked {mach:.4f}")
        self.fdm = fdm
        self.altitude_m = altitude_m
        self.mach = mach
        self.t0 = fdm.get_sim_time()
        self.frame = FlatEarth(fdm["position/lat-geod-rad"], fdm["position/long-gc-rad"], fdm["position/h-sl-meters"])
        self.trim_throttle = fdm["fcs/throttle-cmd-norm"]
        self.trim_alpha_deg = fdm["aero/alpha-deg"]

    # --- readings -------------------------------------------------------------------

    @property
    def time_s(self) -> float:
        """Simulation time since the trim, s."""
        return self.fdm.get_sim_time() - self.t0

    def velocity_ned(self) -> np.ndarray:
        """Velocity over the ground, NED, m/s."""
        f = self.fdm
        return np.array([f["velocities/v-north-fps"], f["velocities/v-east-fps"], f["velocities/v-down-fps"]]) * FT

    def body_rates(self) -> np.ndarray:
        """Body rates p, q, r, rad/s."""
        f = self.fdm
        return np.array([f["velocities/p-rad_sec"], f["velocities/q-rad_sec"], f["velocities/r-rad_sec"]])

    def c_b2n(self) -> np.ndarray:
        """Body→NED rotation matrix (transpose of JSBSim's ``Tl2b``)."""
        with warnings.catch_warnings():  # JSBSim's binding builds a numpy.matrix
            warnings.simplefilter("ignore", PendingDeprecationWarning)
            tl2b = self.fdm.get_propagate().get_Tl2b()
        return np.asarray(tl2b, dtype=float).reshape(3, 3).T.copy()

    def body_acceleration_ned(self) -> np.ndarray:
        """NED acceleration from JSBSim's body-axis derivatives, m/s² (a cross-check only).

        ``C_b2n (d(uvw)/dt + ω × uvw)``: the inertial derivative of the velocity seen
        in the rotating body frame, without the earth's rotation and curvature terms
        (about 1e-2 m/s² at 250 m/s).
        """
        f = self.fdm
        uvw = np.array([f["velocities/u-fps"], f["velocities/v-fps"], f["velocities/w-fps"]]) * FT
        uvw_dot = np.array([f["accelerations/udot-ft_sec2"], f["accelerations/vdot-ft_sec2"], f["accelerations/wdot-ft_sec2"]]) * FT
        return self.c_b2n() @ (uvw_dot + np.cross(self.body_rates(), uvw))

    def raw_sample(self) -> AircraftState:
        """The current state without the derived accelerations (zeros there)."""
        f = self.fdm
        v = self.velocity_ned()
        speed = float(np.linalg.norm(v))
        extra = {
            "mach": f["velocities/mach"],
            "altitude_m": f["position/h-sl-meters"],
            "airspeed_mps": f["velocities/vt-fps"] * FT,
            "load_factor": f["accelerations/Nz"],
            "roll_deg": math.degrees(f["attitude/phi-rad"]),
            "pitch_deg": math.degrees(f["attitude/theta-rad"]),
            "heading_deg": math.degrees(f["attitude/psi-rad"]),
            "flight_path_deg": math.degrees(math.asin(max(-1.0, min(1.0, -v[2] / speed)))) if speed > 0 else 0.0,
            "alpha_deg": f["aero/alpha-deg"],
            "throttle": f["fcs/throttle-cmd-norm"],
            "elevator_cmd": f["fcs/elevator-cmd-norm"],
            "aileron_cmd": f["fcs/aileron-cmd-norm"],
        }
        return AircraftState(
            time_s=round(self.time_s, 9),
            position_ned_m=self.frame.ned(f["position/lat-geod-rad"], f["position/long-gc-rad"], f["position/h-sl-meters"]),
            velocity_ned_mps=v,
            acceleration_ned_mps2=np.zeros(3),
            attitude_wxyz=quat_from_dcm(self.c_b2n()),
            body_rate_radps=self.body_rates(),
            body_angular_acceleration_radps2=np.zeros(3),
            extra=extra,
        )

    # --- flying ----------------------------------------------------------------------

    def step(self, manoeuvre: Manoeuvre) -> None:
        """One JSBSim step (5 ms) with the manoeuvre's controls."""
        manoeuvre.control(self, self.time_s)
        if not self.fdm.run():
            raise RuntimeError("JSBSim stopped")

    def fly(self, manoeuvre: Manoeuvre, t_end: float) -> Iterator[AircraftState]:
        """The frames from t = 0 (the trim) to ``t_end`` (s), every 10 ms, with the
        derived accelerations (see the module docs); one frame behind the model."""
        steps_per_frame = round(FRAME_DT / JSBSIM_DT)
        frames = int(round(t_end / FRAME_DT))
        prev: AircraftState | None = None
        cur = self.raw_sample()
        for _ in range(frames):
            for _ in range(steps_per_frame):
                self.step(manoeuvre)
            nxt = self.raw_sample()
            _differentiate(cur, prev, nxt)
            yield cur
            prev, cur = cur, nxt
        _differentiate(cur, prev, None)
        yield cur


def _differentiate(cur: AircraftState, prev: AircraftState | None, nxt: AircraftState | None) -> None:
    """Fills ``cur``'s accelerations from its neighbours (central, or one-sided at an end)."""
    if prev is not None and nxt is not None:
        cur.acceleration_ned_mps2 = central_difference(prev.velocity_ned_mps, nxt.velocity_ned_mps, FRAME_DT)
        cur.body_angular_acceleration_radps2 = central_difference(prev.body_rate_radps, nxt.body_rate_radps, FRAME_DT)
    elif nxt is not None:
        cur.acceleration_ned_mps2 = (nxt.velocity_ned_mps - cur.velocity_ned_mps) / FRAME_DT
        cur.body_angular_acceleration_radps2 = (nxt.body_rate_radps - cur.body_rate_radps) / FRAME_DT
    elif prev is not None:
        cur.acceleration_ned_mps2 = (cur.velocity_ned_mps - prev.velocity_ned_mps) / FRAME_DT
        cur.body_angular_acceleration_radps2 = (cur.body_rate_radps - prev.body_rate_radps) / FRAME_DT


# --- the manoeuvres' loops ---------------------------------------------------------------


def speed_of_sound(fdm: F16) -> float:
    """Speed of sound at the aircraft, m/s."""
    return fdm.fdm["atmosphere/a-fps"] * FT


class _Loops:
    """The small closed loops the manoeuvres share.

    * Load factor (elevator): the F-16's fly-by-wire treats ``fcs/elevator-cmd-norm``
      roughly as a g command (about -0.2 per g, negative nose up); the loop feeds that
      forward and integrates the error of ``accelerations/Nz``.
    * Mach (throttle): proportional-integral from the trim throttle, 0..1 (1 = full
      afterburner).
    * Bank (aileron): proportional on the bank error, damped by the roll rate.
    """

    # Elevator command against the steady load factor it gave at 9 km, Mach 0.8
    # (measured: step inputs, about 1 s time constant); a feed-forward only, the
    # proportional-integral term on the load factor error does the rest.
    FF_ELEV = (-1.0, -0.8, -0.4, -0.2, -0.1, 0.0, 0.1, 0.2, 0.4)
    FF_DN = (3.6, 3.35, 2.05, 1.25, 0.7, 0.0, -0.7, -1.25, -2.05)
    KP_N = -0.25
    KI_N = -0.5
    KP_MACH = 8.0
    KI_MACH = 2.0
    KP_BANK = 1.2
    KD_BANK = 0.25

    def __init__(self, fdm: F16):
        self.n_int = 0.0
        self.mach_int = 0.0
        self.throttle0 = fdm.trim_throttle
        self.elev0 = fdm.fdm["fcs/elevator-cmd-norm"]

    def load_factor(self, fdm: F16, n_cmd: float) -> None:
        f = fdm.fdm
        err = n_cmd - f["accelerations/Nz"]
        # The table in increasing load factor (decreasing elevator).
        ff = float(np.interp(n_cmd - 1.0, self.FF_DN[::-1], self.FF_ELEV[::-1]))
        raw = self.elev0 + ff + self.KP_N * err + self.n_int
        if -1.0 < raw < 1.0 or (raw >= 1.0) == (err > 0):  # no wind-up into a stop
            self.n_int = min(1.0, max(-1.0, self.n_int + self.KI_N * err * JSBSIM_DT))
        f["fcs/elevator-cmd-norm"] = min(1.0, max(-1.0, raw))

    def mach(self, fdm: F16, mach_cmd: float) -> None:
        f = fdm.fdm
        err = mach_cmd - f["velocities/mach"]
        unclamped = self.throttle0 + self.KP_MACH * err + self.mach_int + self.KI_MACH * err * JSBSIM_DT
        if 0.0 < unclamped < 1.0:  # no wind-up while saturated
            self.mach_int += self.KI_MACH * err * JSBSIM_DT
        f["fcs/throttle-cmd-norm"] = min(1.0, max(0.0, self.throttle0 + self.KP_MACH * err + self.mach_int))

    def bank(self, fdm: F16, bank_cmd: float) -> None:
        f = fdm.fdm
        err = bank_cmd - f["attitude/phi-rad"]
        f["fcs/aileron-cmd-norm"] = min(1.0, max(-1.0, self.KP_BANK * err - self.KD_BANK * f["velocities/p-rad_sec"]))


def _climb_rate_and_gamma(fdm: F16) -> tuple[float, float, float]:
    v = fdm.velocity_ned()
    speed = float(np.linalg.norm(v))
    return -v[2], math.asin(max(-1.0, min(1.0, -v[2] / speed))), speed


class Steady:
    """Steady level flight: the trimmed controls, untouched (no loop)."""

    name = "steady"

    def control(self, fdm: F16, t: float) -> None:
        """Leaves the trimmed controls."""


class PullUp:
    """The paper's pull-up: level until ``start`` s, the flight path rotating up at
    ``rate`` rad/s for ``duration`` s, then the climb held; Mach held on throttle.

    Elevator loop: the flight-path angle follows ``γ_ref(t)`` through the load
    factor ``n = (V (γ̇_ref + K (γ_ref - γ)) + g cos γ) / g``, K = 0.5 /s. The
    reference's rate is the paper's step (``rate`` from ``start`` for ``duration``)
    through a first-order lag of ``TAU`` s, and ``γ_ref`` its integral: the same
    final climb angle (``rate × duration``), but a load factor the fly-by-wire (about
    1 s to respond) can follow without overshooting into a push-over at the end,
    which would slacken the cable and snatch it.
    """

    name = "pull-up"
    K_GAMMA = 0.5
    TAU = 1.0

    def __init__(self, fdm: F16, rate: float, start: float = 2.0, duration: float = 5.0):
        self.rate, self.start, self.duration = rate, start, duration
        self.loops = _Loops(fdm)
        self.mach_cmd = fdm.mach

    def gamma_ref(self, t: float) -> tuple[float, float]:
        """Reference flight-path angle (rad) and its rate (rad/s) at ``t``: the step
        of the rate through the lag, in closed form."""
        w, tau = self.rate, self.TAU

        def ramp(x: float) -> tuple[float, float]:  # response to a rate step at x = 0
            if x <= 0.0:
                return 0.0, 0.0
            e = math.exp(-x / tau)
            return w * (x - tau * (1.0 - e)), w * (1.0 - e)

        g1, r1 = ramp(t - self.start)
        g2, r2 = ramp(t - self.start - self.duration)
        return g1 - g2, r1 - r2

    def control(self, fdm: F16, t: float) -> None:
        """Elevator for the flight-path angle, throttle for Mach."""
        _, gamma, speed = _climb_rate_and_gamma(fdm)
        g_ref, rate_ref = self.gamma_ref(t)
        gamma_dot = rate_ref + self.K_GAMMA * (g_ref - gamma)
        self.loops.load_factor(fdm, (speed * gamma_dot + G0 * math.cos(gamma)) / G0)
        self.loops.mach(fdm, self.mach_cmd)


class _LevelFlight:
    """Altitude on the elevator (with the 1/cos(bank) term), Mach on the throttle."""

    K_H = 0.4  # 1/s: climb rate commanded per metre of altitude error
    K_HDOT = 1.0  # 1/s: vertical acceleration per m/s of climb-rate error

    def __init__(self, fdm: F16):
        self.loops = _Loops(fdm)
        self.h_cmd = fdm.fdm["position/h-sl-meters"]

    def hold_altitude(self, fdm: F16) -> None:
        f = fdm.fdm
        climb, _, _ = _climb_rate_and_gamma(fdm)
        a_up = self.K_HDOT * (self.K_H * (self.h_cmd - f["position/h-sl-meters"]) - climb)
        bank = f["attitude/phi-rad"]
        self.loops.load_factor(fdm, (1.0 + a_up / G0) / max(0.2, math.cos(bank)))


class Turn(_LevelFlight):
    """Coordinated level turn at ``rate`` rad/s (positive right) from t = ``start``:
    bank ``atan(V ω / g)`` on the aileron, altitude on the elevator, Mach on the throttle.

    The bank's turn rate is corrected by the integral of the track-rate error once
    the bank has settled, and not while the elevator is at its stop. The bank is
    limited to ``acos(1 / MAX_LOAD_FACTOR)`` (75.5 deg): the F-16 at 9 km, Mach 0.8
    pulls about 4.2 g with the elevator at its stop, so a level turn of 0.20 rad/s
    (5 g) is out of reach and it flies about 0.16 rad/s instead, keeping its
    altitude."""

    name = "turn"

    K_RATE = 1.0  # 1/s: integral correction of the commanded turn rate
    MAX_LOAD_FACTOR = 4.0  # g: about what the elevator's stop gives at 9 km, Mach 0.8

    def __init__(self, fdm: F16, rate: float, start: float = 0.0):
        super().__init__(fdm)
        self.rate, self.start = rate, start
        self.mach_cmd = fdm.mach
        self.rate_int = 0.0
        self.last_bank = 0.0
        self.track: float | None = None

    def control(self, fdm: F16, t: float) -> None:
        """Bank (from the turn rate asked plus an integral of the track-rate error),
        altitude and Mach loops."""
        v = fdm.velocity_ned()
        speed = float(np.linalg.norm(v))
        track = math.atan2(v[1], v[0])
        if self.track is not None and t >= self.start:
            track_rate = ((track - self.track + math.pi) % (2 * math.pi) - math.pi) / JSBSIM_DT
            settled = abs(fdm.fdm["attitude/phi-rad"] - self.last_bank) < math.radians(3.0)
            # Not while rolling in (that winds up into an overshoot), nor while the
            # elevator is at its stop (no load factor left to turn harder with).
            if settled and abs(fdm.fdm["fcs/elevator-cmd-norm"]) < 0.95:
                self.rate_int += self.K_RATE * (self.rate - track_rate) * JSBSIM_DT
            self.rate_int = max(-abs(self.rate), min(abs(self.rate), self.rate_int))
        self.track = track
        w = self.rate + self.rate_int
        bank = math.atan(speed * w / G0) if t >= self.start else 0.0
        # A level turn at bank φ needs 1/cos φ g: no more than the aircraft has.
        limit = math.acos(1.0 / self.MAX_LOAD_FACTOR)
        bank = max(-limit, min(limit, bank))
        self.last_bank = bank
        self.loops.bank(fdm, bank)
        self.hold_altitude(fdm)
        self.loops.mach(fdm, self.mach_cmd)


class Acceleration(_LevelFlight):
    """Level acceleration from the trim Mach to ``final_mach``: from ``start`` s the
    Mach command ramps at ``accel`` m/s² (the built-in profile's 10 m/s²) and the
    throttle loop follows it as far as the engine allows (full afterburner gives the
    F-16 about 5 m/s² at 9 km); altitude held on the elevator."""

    name = "acceleration"

    def __init__(self, fdm: F16, final_mach: float = 0.8, start: float = 2.0, accel: float = 10.0):
        super().__init__(fdm)
        self.m0, self.m1, self.start, self.accel = fdm.mach, final_mach, start, accel
        self.a = speed_of_sound(fdm)

    def mach_cmd(self, t: float) -> float:
        """The Mach command at ``t``."""
        if t < self.start:
            return self.m0
        m = self.m0 + math.copysign(self.accel * (t - self.start) / self.a, self.m1 - self.m0)
        return min(m, self.m1) if self.m1 >= self.m0 else max(m, self.m1)

    def control(self, fdm: F16, t: float) -> None:
        """Altitude and Mach loops, wings level."""
        self.loops.bank(fdm, 0.0)
        self.hold_altitude(fdm)
        self.loops.mach(fdm, self.mach_cmd(t))


DEFAULT_CONDITION = {
    "steady": (9000.0, 0.8),
    "pull-up": (9000.0, 0.8),
    "turn": (9000.0, 0.8),
    "acceleration": (9000.0, 0.6),
}
"""Initial altitude (m) and Mach of each manoeuvre, those of the built-in scenario
of the same name (``scenarios/*.toml``) so that the two can be compared."""

DEFAULT_RATE = {"pull-up": 0.10, "turn": 0.20}
"""Default rates, rad/s, as the built-in scenarios."""

DEFAULT_T_END = {"steady": 10.0, "pull-up": 20.0, "turn": 20.0, "acceleration": 25.0}
"""Default simulated time, s, as the built-in scenarios."""


def make_manoeuvre(name: str, fdm: F16, rate: float | None = None) -> Manoeuvre:
    """The manoeuvre ``name`` (one of :data:`MANOEUVRES`) for the trimmed ``fdm``.

    ``rate`` (rad/s) applies to the pull-up and the turn (defaults
    :data:`DEFAULT_RATE`); giving it for another manoeuvre is an error.
    """
    if name not in MANOEUVRES:
        raise ValueError(f"unknown manoeuvre {name!r}; one of {', '.join(MANOEUVRES)}")
    if rate is not None and name not in DEFAULT_RATE:
        raise ValueError(f"--rate does not apply to the {name} manoeuvre")
    w = DEFAULT_RATE.get(name, 0.0) if rate is None else rate
    if name in DEFAULT_RATE and not (0.0 < abs(w) <= 1.0):
        raise ValueError(f"rate must be in (0, 1] rad/s in magnitude, got {w}")
    if name == "steady":
        return Steady()
    if name == "pull-up":
        return PullUp(fdm, w)
    if name == "turn":
        return Turn(fdm, w)
    return Acceleration(fdm)
