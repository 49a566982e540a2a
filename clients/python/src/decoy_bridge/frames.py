"""Frame and attitude conversions between a flight model and the decoy solver.

The solver's conventions (README "Frames, units and signs", docs/outputs.md):

* SI units throughout.
* World frame: flat-earth NED (x north, y east, z down) about a fixed start point;
  altitude is ``-z`` (geometric, above sea level), so ``z`` is *not* relative to
  the start point's altitude: the solver's atmosphere (ISA 1976) reads it.
* Body frame: FRD (x forward, y right, z down).
* Attitude: Hamilton quaternion, scalar first ``(w, x, y, z)``, rotating body (FRD)
  vectors into NED: ``v_ned = q ⊗ v_body ⊗ q*``.  Equivalently the rotation matrix
  ``C_b2n`` whose columns are the body axes written in NED.
* Body rates and angular accelerations: rad/s and rad/s², in the body frame.

Every function here is pure (numpy in, numpy out) and independent of JSBSim; the
JSBSim-specific reading of properties lives in :mod:`decoy_bridge.f16`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

FT = 0.3048
"""One foot in metres (JSBSim's unit of length)."""

WGS84_A = 6_378_137.0
"""WGS-84 equatorial radius, m."""
WGS84_F = 1.0 / 298.257223563
"""WGS-84 flattening."""
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)
"""WGS-84 first eccentricity squared."""

Vec = NDArray[np.float64]


def meridian_radius(lat_rad: float) -> float:
    """Radius of curvature of the WGS-84 meridian at geodetic latitude ``lat_rad`` (rad), m."""
    s = math.sin(lat_rad)
    return WGS84_A * (1.0 - WGS84_E2) / (1.0 - WGS84_E2 * s * s) ** 1.5


def prime_vertical_radius(lat_rad: float) -> float:
    """Radius of curvature of the WGS-84 prime vertical at ``lat_rad`` (rad), m."""
    s = math.sin(lat_rad)
    return WGS84_A / math.sqrt(1.0 - WGS84_E2 * s * s)


@dataclass(frozen=True)
class FlatEarth:
    """A flat-earth NED frame tangent to the ellipsoid at a start point.

    ``north`` and ``east`` are arc lengths at the start point's altitude
    (``(lat - lat0) (M0 + h0)`` and ``(lon - lon0) (N0 + h0) cos lat0`` with the
    WGS-84 radii of curvature at the start), ``down = -h`` (geometric altitude
    above sea level, m, so that the solver's atmosphere sees the true altitude).

    Consistency with a flight model's local-level velocity (north, east, down):
    ``d(north)/dt = v_north (M0 + h0) / (M + h)``; the relative difference is
    below ``|h - h0| / R + 1e-3 |lat - lat0|`` (1e-4 for 600 m of climb), so
    positions and velocities fed together satisfy the solver's Hermite path within
    a few cm/s. The frame does not turn with the earth's curvature (about 0.16
    mrad per km flown): attitudes and velocities are taken as the flight model
    gives them in its local-level frame, which over a 20 s run differs from the
    start point's by under a milliradian.

    Attributes:
        lat0_rad: geodetic latitude of the start point, rad.
        lon0_rad: longitude of the start point, rad.
        h0_m: altitude of the start point above sea level, m.
    """

    lat0_rad: float
    lon0_rad: float
    h0_m: float

    def ned(self, lat_rad: float, lon_rad: float, h_m: float) -> Vec:
        """The NED position, m, of geodetic ``(lat_rad, lon_rad)`` (rad) at altitude ``h_m`` (m)."""
        dlon = (lon_rad - self.lon0_rad + math.pi) % (2.0 * math.pi) - math.pi
        north = (lat_rad - self.lat0_rad) * (meridian_radius(self.lat0_rad) + self.h0_m)
        east = (
            dlon
            * (prime_vertical_radius(self.lat0_rad) + self.h0_m)
            * math.cos(self.lat0_rad)
        )
        return np.array([north, east, -h_m])

    def geodetic(self, ned: ArrayLike) -> tuple[float, float, float]:
        """Inverse of :meth:`ned`: ``(lat_rad, lon_rad, h_m)`` of an NED position (m)."""
        n, e, d = np.asarray(ned, dtype=float)
        lat = self.lat0_rad + n / (meridian_radius(self.lat0_rad) + self.h0_m)
        lon = self.lon0_rad + e / (
            (prime_vertical_radius(self.lat0_rad) + self.h0_m) * math.cos(self.lat0_rad)
        )
        return lat, lon, -float(d)


def quat_normalize(q: ArrayLike) -> Vec:
    """``q / |q|`` with the scalar part made non-negative (the same rotation)."""
    q = np.asarray(q, dtype=float)
    n = np.linalg.norm(q)
    if not np.isfinite(n) or n == 0.0:
        raise ValueError(f"cannot normalise quaternion {q}")
    q = q / n
    return -q if q[0] < 0.0 else q


def quat_from_dcm(c_b2n: ArrayLike) -> Vec:
    """Quaternion ``(w, x, y, z)`` (Hamilton, body→NED) of the rotation matrix ``c_b2n``.

    ``c_b2n`` maps body (FRD) components to NED components (its columns are the
    body axes in NED). JSBSim's ``get_Tl2b()`` is the transpose (NED→body).
    Shepperd's method: the largest of the four squared components is taken from
    the trace so that no branch divides by a small number; the result has
    ``w >= 0`` and unit norm.
    """
    m = np.asarray(c_b2n, dtype=float)
    if m.shape != (3, 3):
        raise ValueError(f"expected a 3x3 matrix, got shape {m.shape}")
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    candidates = (tr, m[0, 0], m[1, 1], m[2, 2])
    k = int(np.argmax(candidates))
    if k == 0:
        w = 0.5 * math.sqrt(max(0.0, 1.0 + tr))
        q = [w, (m[2, 1] - m[1, 2]) / (4 * w), (m[0, 2] - m[2, 0]) / (4 * w), (m[1, 0] - m[0, 1]) / (4 * w)]
    elif k == 1:
        x = 0.5 * math.sqrt(max(0.0, 1.0 + m[0, 0] - m[1, 1] - m[2, 2]))
        q = [(m[2, 1] - m[1, 2]) / (4 * x), x, (m[0, 1] + m[1, 0]) / (4 * x), (m[0, 2] + m[2, 0]) / (4 * x)]
    elif k == 2:
        y = 0.5 * math.sqrt(max(0.0, 1.0 - m[0, 0] + m[1, 1] - m[2, 2]))
        q = [(m[0, 2] - m[2, 0]) / (4 * y), (m[0, 1] + m[1, 0]) / (4 * y), y, (m[1, 2] + m[2, 1]) / (4 * y)]
    else:
        z = 0.5 * math.sqrt(max(0.0, 1.0 - m[0, 0] - m[1, 1] + m[2, 2]))
        q = [(m[1, 0] - m[0, 1]) / (4 * z), (m[0, 2] + m[2, 0]) / (4 * z), (m[1, 2] + m[2, 1]) / (4 * z), z]
    return quat_normalize(q)


def dcm_from_quat(q: ArrayLike) -> Vec:
    """Rotation matrix body→NED of the unit quaternion ``q = (w, x, y, z)`` (normalised first)."""
    w, x, y, z = quat_normalize(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def quat_from_euler(roll_rad: float, pitch_rad: float, yaw_rad: float) -> Vec:
    """Body→NED quaternion of ZYX Euler angles (yaw ψ, then pitch θ, then roll φ), rad."""
    cr, sr = math.cos(roll_rad / 2), math.sin(roll_rad / 2)
    cp, sp = math.cos(pitch_rad / 2), math.sin(pitch_rad / 2)
    cy, sy = math.cos(yaw_rad / 2), math.sin(yaw_rad / 2)
    return quat_normalize(
        [
            cr * cp * cy + sr * sp * sy,
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
        ]
    )


def euler_from_quat(q: ArrayLike) -> tuple[float, float, float]:
    """ZYX Euler angles ``(roll, pitch, yaw)``, rad, of a body→NED quaternion (pitch in [-π/2, π/2])."""
    c = dcm_from_quat(q)
    pitch = -math.asin(max(-1.0, min(1.0, c[2, 0])))
    roll = math.atan2(c[2, 1], c[2, 2])
    yaw = math.atan2(c[1, 0], c[0, 0])
    return roll, pitch, yaw


def quat_multiply(a: ArrayLike, b: ArrayLike) -> Vec:
    """Hamilton product ``a ⊗ b`` of quaternions ``(w, x, y, z)`` (not normalised)."""
    aw, ax, ay, az = np.asarray(a, dtype=float)
    bw, bx, by, bz = np.asarray(b, dtype=float)
    return np.array(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ]
    )


def rotate(q: ArrayLike, v_body: ArrayLike) -> Vec:
    """The NED components of body vector ``v_body`` under body→NED quaternion ``q``."""
    return dcm_from_quat(q) @ np.asarray(v_body, dtype=float)


def central_difference(prev: ArrayLike, nxt: ArrayLike, h: float) -> Vec:
    """Derivative at the middle sample of three spaced ``h`` apart: ``(nxt - prev) / (2 h)``.

    Second-order accurate; this is how the NED acceleration and the body angular
    acceleration are derived from the flight model's velocities and body rates
    (see :mod:`decoy_bridge.f16`), so that they are the slopes of the very samples
    the solver interpolates between frames.
    """
    if h <= 0.0:
        raise ValueError(f"step must be positive, got {h}")
    return (np.asarray(nxt, dtype=float) - np.asarray(prev, dtype=float)) / (2.0 * h)


def flight_path_frame(velocity_ned: ArrayLike) -> Vec:
    """Rows: the flight-path frame's axes in NED (docs/outputs.md "Frames and signs").

    x along the velocity, y horizontal to its right, z = x × y (down, perpendicular
    to the flight path in its vertical plane). Used to express the decoy's position
    relative to the aircraft as ``behind = -x``, ``lateral = -y`` (left),
    ``below = z``.
    """
    v = np.asarray(velocity_ned, dtype=float)
    speed = np.linalg.norm(v)
    if speed == 0.0:
        raise ValueError("the flight-path frame needs a non-zero velocity")
    x = v / speed
    y = np.array([-x[1], x[0], 0.0])
    ny = np.linalg.norm(y)
    y = np.array([0.0, 1.0, 0.0]) if ny < 1e-12 else y / ny
    z = np.cross(x, y)
    return np.vstack([x, y, z])
