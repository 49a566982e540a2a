"""A speed sweep with the solver's package ``decoy``: the steady connection-point
tension at 9 km from Mach 0.5 to 0.9 (the trim of the host model, 300 segments)
and the peak tension of the shipped 0.10 rad/s pull-up flown at each speed (the
embedded model, the configuration's), two runs at a time on two threads (the
solver releases the GIL). Plots both to speed-sweep.png, or to the path given.

    .venv/bin/python clients/python/examples/speed_sweep.py out/speed-sweep.png
"""

import sys
from concurrent.futures import ThreadPoolExecutor

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import decoy

machs = np.linspace(0.5, 0.9, 9)
steady = [decoy.trim(9000, m)["tension_connection_N"] for m in machs]
embedded = decoy.builtin_config()["solver"]
model = {"segments": embedded["segments_embedded"], "grading": embedded["grading_ratio_embedded"]}
with ThreadPoolExecutor(2) as pool:
    runs = list(pool.map(lambda m: decoy.simulate("pull-up", mach=m, t_end=10.0, **model), machs))
fig, ax = plt.subplots(figsize=(6, 4))
ax.plot(machs, steady, "o-", label="steady level flight (trim, 300 segments)")
ax.plot(machs, [r.summary["max_tension_connection_N"] for r in runs], "s-", label="pull-up at 0.10 rad/s, peak")
ax.set(xlabel="Mach number", ylabel="connection-point tension [N]", title="Speed sweep at 9 km")
ax.grid(True, alpha=0.3)
ax.legend()
fig.savefig(sys.argv[1] if len(sys.argv) > 1 else "speed-sweep.png", dpi=120, bbox_inches="tight")
