"""JSBSim's F-16 as the avionics simulation: trim, the derived state, the manoeuvres."""

import math

import numpy as np
import pytest

from decoy_bridge import f16 as F
from decoy_bridge import frames as fr


def fly(name, t_end, rate=None, altitude=None, mach=None):
    alt, m = F.DEFAULT_CONDITION[name]
    fdm = F.F16(altitude if altitude is not None else alt, mach if mach is not None else m)
    return fdm, list(fdm.fly(F.make_manoeuvre(name, fdm, rate), t_end))


def test_trimmed_f16_in_steady_flight_has_near_zero_acceleration_and_rates():
    _, frames = fly("steady", 10.0)
    assert len(frames) == 1001
    assert [s.time_s for s in frames[:3]] == [0.0, 0.01, 0.02]
    for s in frames:
        assert np.linalg.norm(s.acceleration_ned_mps2) < 0.05  # m/s^2
        assert np.abs(s.body_rate_radps).max() < 1e-3  # rad/s
        assert np.abs(s.body_angular_acceleration_radps2).max() < 1e-2
        assert s.extra["mach"] == pytest.approx(0.8, abs=2e-3)
        assert -s.position_ned_m[2] == pytest.approx(9000.0, abs=2.0)
        assert abs(s.velocity_ned_mps[2]) < 0.2
        assert s.extra["load_factor"] == pytest.approx(1.0, abs=0.02)
    # Level, wings level, heading north: the nose is up by the trim angle of attack.
    roll, pitch, _ = fr.euler_from_quat(frames[0].attitude_wxyz)
    assert abs(roll) < 1e-3
    assert math.degrees(pitch) == pytest.approx(frames[0].extra["alpha_deg"], abs=0.05)
    assert frames[0].extra["alpha_deg"] == pytest.approx(2.1, abs=0.3)


def test_trim_at_another_condition():
    fdm = F.F16(6000.0, 0.7)
    assert fdm.fdm["velocities/mach"] == pytest.approx(0.7, abs=1e-3)
    assert fdm.fdm["position/h-sl-meters"] == pytest.approx(6000.0, abs=0.5)


def test_positions_follow_velocities_and_attitude_matches_jsbsim_euler():
    fdm, frames = fly("turn", 6.0, rate=0.1)
    for a, b in zip(frames, frames[1:]):
        # The solver's Hermite path: the chord over a frame equals the mean velocity
        # to second order; a few cm/s allow for the flat earth's scale.
        chord = (b.position_ned_m - a.position_ned_m) / F.FRAME_DT
        mean = 0.5 * (a.velocity_ned_mps + b.velocity_ned_mps)
        assert np.abs(chord - mean).max() < 0.05
        roll, pitch, yaw = fr.euler_from_quat(b.attitude_wxyz)
        assert roll == pytest.approx(math.radians(b.extra["roll_deg"]), abs=1e-6)
        assert pitch == pytest.approx(math.radians(b.extra["pitch_deg"]), abs=1e-6)
        dyaw = (yaw - math.radians(b.extra["heading_deg"]) + math.pi) % (2 * math.pi) - math.pi
        assert abs(dyaw) < 1e-6
    assert max(s.extra["roll_deg"] for s in frames) > 60.0


def test_derived_acceleration_matches_jsbsim_body_derivatives():
    """The central difference of the NED velocity against JSBSim's own u, v, w
    derivatives (plus omega x v, rotated to NED), through a pull-up's onset."""
    fdm = F.F16(9000.0, 0.8)
    man = F.make_manoeuvre("pull-up", fdm, 0.1)
    it = fdm.fly(man, 5.0)
    body = {}
    diffs = []
    for s in it:
        # fly() yields frame k after stepping to k+1: record JSBSim's value at each frame.
        body[round(fdm.time_s, 9)] = fdm.body_acceleration_ned()
        if s.time_s in body and s.time_s > 0:
            diffs.append(np.abs(s.acceleration_ned_mps2 - body[s.time_s]).max())
    assert len(diffs) > 400
    assert max(diffs) < 0.15, f"largest difference {max(diffs):.3f} m/s^2"


def test_pull_up_reaches_the_paper_climb_angle():
    _, frames = fly("pull-up", 12.0, rate=0.1)
    gamma = np.array([s.extra["flight_path_deg"] for s in frames])
    assert abs(gamma[150]) < 0.5  # level before t = 2 s
    assert gamma[-1] == pytest.approx(math.degrees(0.5), abs=1.0)  # 0.1 rad/s for 5 s
    n = np.array([s.extra["load_factor"] for s in frames])
    v = frames[400].velocity_ned_mps
    # During the rotation the load factor is about 1 + V w / g.
    assert n[300:650].mean() == pytest.approx(1 + np.linalg.norm(v) * 0.1 / F.G0, abs=0.35)


def test_turn_holds_rate_altitude_and_mach():
    _, frames = fly("turn", 15.0, rate=0.1)
    track = np.unwrap([math.atan2(s.velocity_ned_mps[1], s.velocity_ned_mps[0]) for s in frames])
    rate = (track[-1] - track[500]) / (frames[-1].time_s - frames[500].time_s)
    assert rate == pytest.approx(0.1, rel=0.03)
    assert max(abs(-s.position_ned_m[2] - 9000.0) for s in frames) < 15.0
    assert frames[-1].extra["mach"] == pytest.approx(0.8, abs=0.02)


def test_acceleration_goes_from_mach_06_to_08():
    _, frames = fly("acceleration", 25.0)
    mach = [s.extra["mach"] for s in frames]
    assert mach[0] == pytest.approx(0.6, abs=1e-3)
    assert mach[-1] == pytest.approx(0.8, abs=0.03)
    assert max(abs(-s.position_ned_m[2] - 9000.0) for s in frames) < 10.0


def test_bad_manoeuvre_arguments_are_errors():
    fdm = F.F16(9000.0, 0.8)
    with pytest.raises(ValueError, match="unknown manoeuvre"):
        F.make_manoeuvre("loop", fdm)
    with pytest.raises(ValueError, match="does not apply"):
        F.make_manoeuvre("steady", fdm, 0.1)
    with pytest.raises(ValueError, match="rate"):
        F.make_manoeuvre("turn", fdm, 0.0)
