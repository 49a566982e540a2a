#!/usr/bin/env python3
"""External reference, optional and not run in CI: Pinocchio's ABA on the
benchmarks' 300-rod compound pendulum.

The chain matches `reference_pendulum` in solver-core: rods of 0.1 m and 0.5 kg,
hinged end to end by spherical joints to a fixed anchor, gravity 9.81 m/s^2,
every rod at -60 degrees from the downward vertical, at rest. Each rod is a solid
cylinder 1 cm in diameter (the solver's rods have no inertia about their own axis;
a spherical joint needs some, or the articulated inertia is singular). One RK4
step evaluates the dynamics 4 times, so its cost is taken as 4 ABA calls.

Memory: pinocchio's `Data` (pin 4.1) grows as nv^3 (about 1.8 GB for 100
spherical joints, nv = 300), so a 300-joint spherical chain (nv = 900) needs tens
of GB. The script therefore times spherical chains of 25, 50 and 100 rods, fits
ABA time = a + b N (ABA is O(N)) and extrapolates to 300 rods, and times directly
a 300-rod chain of revolute joints about y (nv = 300; the same motion, since the
pendulum starts at rest in the x-z plane, but 1 instead of 3 degrees of freedom
per joint, so a lower bound on the spherical cost).

Usage: pip install pin; python3 aba_300.py [REPEATS]
Prints one line with the medians (what `cargo xtask bench-report` quotes).
"""

import statistics
import sys
import time

import numpy as np
import pinocchio as pin

ROD_LENGTH = 0.1
ROD_MASS = 0.5
ROD_RADIUS = 0.005
GRAVITY = 9.81
INITIAL_ANGLE = -np.pi / 3
DT = 1e-4


def chain(rods, joint=pin.JointModelSpherical):
    """The pendulum: rod i hangs along -z of its joint frame, COM at mid-length."""
    model = pin.Model()
    model.gravity.linear = np.array([0.0, 0.0, -GRAVITY])
    rod = pin.Inertia.FromCylinder(ROD_MASS, ROD_RADIUS, ROD_LENGTH)
    rod = pin.SE3(np.eye(3), np.array([0.0, 0.0, -ROD_LENGTH / 2])).act(rod)
    parent = 0
    for i in range(rods):
        placement = pin.SE3(
            np.eye(3), np.array([0.0, 0.0, 0.0 if i == 0 else -ROD_LENGTH])
        )
        parent = model.addJoint(parent, joint(), placement, f"joint{i}")
        model.appendBodyToJoint(parent, rod, pin.SE3.Identity())
    return model


def initial_configuration(model):
    """First joint tilted by INITIAL_ANGLE about y, the others straight: every rod
    at the same angle from the vertical."""
    q = pin.neutral(model)
    if model.nq == model.nv:  # revolute joints about y
        q[0] = INITIAL_ANGLE
    else:
        quat = pin.Quaternion(pin.utils.rotate("y", INITIAL_ANGLE))
        q[0:4] = quat.coeffs()  # x, y, z, w
    return q


def median_seconds(fn, repeats, inner):
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(inner):
            fn()
        samples.append((time.perf_counter() - start) / inner)
    return statistics.median(samples)


def time_chain(rods, repeats, joint=pin.JointModelSpherical):
    """Median seconds of one ABA call and of one Python RK4 step."""
    model = chain(rods, joint)
    data = model.createData()
    q = initial_configuration(model)
    v = np.zeros(model.nv)
    tau = np.zeros(model.nv)

    def aba():
        pin.aba(model, data, q, v, tau)

    def rk4_step():
        k1v, k1a = v, pin.aba(model, data, q, v, tau).copy()
        q2 = pin.integrate(model, q, 0.5 * DT * k1v)
        v2 = v + 0.5 * DT * k1a
        k2a = pin.aba(model, data, q2, v2, tau).copy()
        q3 = pin.integrate(model, q, 0.5 * DT * v2)
        v3 = v + 0.5 * DT * k2a
        k3a = pin.aba(model, data, q3, v3, tau).copy()
        q4 = pin.integrate(model, q, DT * v3)
        v4 = v + DT * k3a
        k4a = pin.aba(model, data, q4, v4, tau).copy()
        dq = DT / 6.0 * (k1v + 2.0 * v2 + 2.0 * v3 + v4)
        dv = DT / 6.0 * (k1a + 2.0 * k2a + 2.0 * k3a + k4a)
        return pin.integrate(model, q, dq), v + dv

    for _ in range(50):  # warm-up
        aba()
        rk4_step()
    return median_seconds(aba, repeats, 100), median_seconds(rk4_step, repeats, 25)


def main():
    repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 30
    sizes = [25, 50, 100]
    times = [time_chain(n, repeats)[0] for n in sizes]
    slope, intercept = np.polyfit(sizes, times, 1)
    spherical_300 = intercept + slope * 300
    revolute_aba, revolute_step = time_chain(300, repeats, pin.JointModelRY)
    print(
        f"Pinocchio {pin.__version__} ABA (medians of {repeats} batches): spherical "
        f"joints, {', '.join(f'{n} rods {t * 1e6:.1f} µs' for n, t in zip(sizes, times))} "
        f"per call, extrapolated linearly to 300 rods {spherical_300 * 1e6:.0f} µs per "
        f"call = {4 * spherical_300 * 1e6:.0f} µs per RK4 step (4 calls); measured "
        f"directly, 300 revolute joints (planar lower bound) {revolute_aba * 1e6:.1f} µs "
        f"per call = {4 * revolute_aba * 1e6:.1f} µs per RK4 step "
        f"({revolute_step * 1e6:.1f} µs for a whole RK4 step in Python with pin.integrate)."
    )


if __name__ == "__main__":
    main()
