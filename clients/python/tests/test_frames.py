"""Conversions of decoy_bridge.frames: quaternions, Euler angles, flat earth."""

import math

import numpy as np
import pytest

from decoy_bridge import frames as fr


def rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def random_quats(n: int, seed: int = 1) -> np.ndarray:
    q = np.random.default_rng(seed).normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1)[:, None]


def same_rotation(a: np.ndarray, b: np.ndarray, tol: float = 1e-12) -> bool:
    return min(np.abs(a - b).max(), np.abs(a + b).max()) < tol


def test_quaternion_dcm_round_trip():
    for q in random_quats(500):
        c = fr.dcm_from_quat(q)
        assert np.allclose(c @ c.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(c) == pytest.approx(1.0, abs=1e-12)
        back = fr.quat_from_dcm(c)
        assert back[0] >= 0.0
        assert same_rotation(back, q)


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_half_turns_take_every_branch(axis):
    # 180 deg rotations have w = 0: Shepperd's x, y and z branches.
    c = [rot_x, rot_y, rot_z][axis](math.pi)
    q = fr.quat_from_dcm(c)
    expected = np.zeros(4)
    expected[axis + 1] = 1.0
    assert same_rotation(q, expected)
    assert np.allclose(fr.dcm_from_quat(q), c, atol=1e-12)


def test_euler_matches_the_zyx_product_and_round_trips():
    rng = np.random.default_rng(7)
    for _ in range(200):
        roll, yaw = rng.uniform(-math.pi, math.pi, 2)
        pitch = rng.uniform(-1.5, 1.5)
        q = fr.quat_from_euler(roll, pitch, yaw)
        # body -> NED = Rz(yaw) Ry(pitch) Rx(roll)
        assert np.allclose(fr.dcm_from_quat(q), rot_z(yaw) @ rot_y(pitch) @ rot_x(roll), atol=1e-12)
        r2, p2, y2 = fr.euler_from_quat(q)
        assert (r2, p2, y2) == pytest.approx((roll, pitch, yaw), abs=1e-9)


def test_nose_up_pitch_points_the_nose_up():
    q = fr.quat_from_euler(0.0, math.radians(30), 0.0)
    nose = fr.rotate(q, [1.0, 0.0, 0.0])
    assert nose[2] < 0.0  # NED: up is -z
    assert nose[0] == pytest.approx(math.cos(math.radians(30)))


def test_hamilton_product_composes_like_the_matrices():
    qs = random_quats(50, seed=3)
    for a, b in zip(qs[:25], qs[25:]):
        ab = fr.quat_multiply(a, b)
        assert np.allclose(fr.dcm_from_quat(ab), fr.dcm_from_quat(a) @ fr.dcm_from_quat(b), atol=1e-12)


def test_degenerate_quaternion_is_an_error():
    with pytest.raises(ValueError):
        fr.quat_normalize([0.0, 0.0, 0.0, 0.0])
    with pytest.raises(ValueError):
        fr.quat_normalize([math.nan, 0.0, 0.0, 1.0])


def test_flat_earth_lengths_and_round_trip():
    frame = fr.FlatEarth(math.radians(45.0), math.radians(7.0), 0.0)
    # One arc minute of latitude at 45 deg is 1852.2 m on WGS-84.
    n = frame.ned(math.radians(45.0 + 1 / 60), math.radians(7.0), 9000.0)
    assert n[0] == pytest.approx(1852.2, abs=0.5)
    assert n[2] == -9000.0
    # One arc minute of longitude at 45 deg: 1314.2 m.
    e = frame.ned(math.radians(45.0), math.radians(7.0 + 1 / 60), 0.0)
    assert e[1] == pytest.approx(1314.2, abs=0.5)
    p = np.array([1234.5, -678.9, -9100.0])
    lat, lon, h = frame.geodetic(p)
    assert np.allclose(frame.ned(lat, lon, h), p, atol=1e-6)


def test_flat_earth_wraps_longitude():
    frame = fr.FlatEarth(0.0, math.radians(179.999), 0.0)
    e = frame.ned(0.0, math.radians(-179.999), 0.0)
    assert e[1] == pytest.approx(2 * 0.001 * math.pi / 180 * fr.WGS84_A, rel=1e-6)


def test_flight_path_frame_is_right_handed_with_y_horizontal():
    for v in ([240.0, 0.0, 0.0], [100.0, 100.0, -50.0], [0.0, -30.0, 10.0]):
        m = fr.flight_path_frame(v)
        assert np.allclose(m @ m.T, np.eye(3), atol=1e-12)
        assert np.allclose(np.cross(m[0], m[1]), m[2])
        assert m[1][2] == 0.0
        assert np.allclose(m[0], np.array(v) / np.linalg.norm(v))
    level = fr.flight_path_frame([240.0, 0.0, 0.0])
    assert np.allclose(level, np.eye(3))


def test_central_difference_is_exact_for_quadratics():
    h = 0.01
    f = lambda t: np.array([3 * t * t + 2 * t, -t * t, 5.0])  # noqa: E731
    assert np.allclose(fr.central_difference(f(0.5 - h), f(0.5 + h), h), [5.0, -1.0, 0.0])
    with pytest.raises(ValueError):
        fr.central_difference(f(0), f(1), 0.0)
