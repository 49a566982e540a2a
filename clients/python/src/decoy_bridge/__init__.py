"""Python client of the towed-decoy solver's host bridge (``decoy bridge``).

* :class:`Bridge`: lockstep requests, free-running publishing, outputs and status
  subscriptions, commands; blocking waits with timeouts in an iceoryx2 WaitSet.
  Across hosts the same over Zenoh (``Bridge(NAME, zenoh="tcp/HOST:PORT",
  credentials=FILE)`` to ``decoy bridge --zenoh-listen``): every payload the
  wire structure's bytes, tagged with its type name and size (:func:`wire_tag`).
* :mod:`decoy_bridge.wire`: the wire types as ctypes structures, generated from
  the Rust crate's layout description (``decoy bridge-layout --json``).
* :mod:`decoy_bridge.errors`: :class:`NoBridge`, :class:`BridgeTimeout`,
  :class:`VersionMismatch`, :class:`Rejected` (all :class:`BridgeError`).
* :mod:`decoy_bridge.frames`, :mod:`decoy_bridge.f16`: JSBSim's F-16 as the
  avionics simulation (frames, attitude, derived accelerations).

Units SI; world frame flat-earth NED (altitude = -z); body FRD; quaternions
Hamilton, scalar first, body→NED.
"""

from .client import Bridge, check_answer, is_initialising, make_config, make_state, make_zenoh_config, wire_tag
from .errors import BridgeError, BridgeTimeout, NoBridge, Rejected, VersionMismatch
from .wire import PROTOCOL_VERSION

__all__ = [
    "Bridge",
    "BridgeError",
    "BridgeTimeout",
    "NoBridge",
    "PROTOCOL_VERSION",
    "Rejected",
    "VersionMismatch",
    "check_answer",
    "is_initialising",
    "make_config",
    "make_state",
    "make_zenoh_config",
    "wire_tag",
]
