"""A client on "another host": test_zenoh.py runs this script in a network
namespace of its own (``ip netns exec NAME python zenoh_remote.py ...``) against a
bridge in another namespace, reachable only over Zenoh.

    zenoh_remote.py INSTANCE ENDPOINT FRAMES [--credentials FILE] [--connect-timeout S]

``FRAMES``: the aircraft states to fly in lockstep, ``bytes(AircraftState)`` one
after the other (empty: only connect). Prints one JSON object: ``{"ok": true,
"transport", "answers": [hex of each Answer with header.seq zeroed], "elapsed_s"}``,
or ``{"ok": false, "error": exception class, "message", "elapsed_s"}``.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import sys
import time
from pathlib import Path

from decoy_bridge import Bridge, BridgeError, wire


def normalised(answer: ctypes.Structure) -> bytes:
    """The answer's bytes with its header's ``seq`` zeroed (the bridge numbers its
    answers across all clients; everything else is the flight's)."""
    copy = type(answer).from_buffer_copy(answer)
    copy.header.seq = 0
    return bytes(copy)


def read_frames(path: Path) -> list[bytes]:
    data = path.read_bytes()
    size = ctypes.sizeof(wire.AircraftState)
    if len(data) % size:
        raise SystemExit(f"{path}: {len(data)} bytes is not a whole number of {size}-byte states")
    return [data[i : i + size] for i in range(0, len(data), size)]


def main() -> int:
    p = argparse.ArgumentParser()
    p.add_argument("instance")
    p.add_argument("endpoint")
    p.add_argument("frames", type=Path)
    p.add_argument("--credentials", type=Path, default=None)
    p.add_argument("--connect-timeout", type=float, default=5.0)
    a = p.parse_args()
    frames = read_frames(a.frames)
    t0 = time.monotonic()
    try:
        with Bridge(a.instance, zenoh=a.endpoint, credentials=a.credentials, timeout_s=5.0,
                    connect_timeout_s=a.connect_timeout) as c:
            answers = []
            if frames:
                c.reset_to_trim()
                for b in frames:
                    answers.append(normalised(c.request_answer(wire.AircraftState.from_buffer_copy(b))).hex())
            result = {"ok": True, "transport": c.transport, "answers": answers}
    except BridgeError as e:
        result = {"ok": False, "error": type(e).__name__, "message": str(e)}
    result["elapsed_s"] = time.monotonic() - t0
    json.dump(result, sys.stdout)
    return 0


if __name__ == "__main__":
    sys.exit(main())
