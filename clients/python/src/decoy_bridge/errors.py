"""The exceptions of the bridge client: one class per way a request can fail."""

from __future__ import annotations


class BridgeError(Exception):
    """Base class of every error of the bridge client."""


class NoBridge(BridgeError):
    """No bridge serves the instance: its services do not exist (never started, or
    stopped cleanly), or exist with no server (the bridge died). Start one with
    ``decoy bridge --instance NAME``."""


class BridgeTimeout(BridgeError):
    """The bridge did not answer within the time limit (it is busy, stopped, or was
    killed while the client waited)."""


class VersionMismatch(BridgeError):
    """The bridge speaks another protocol version: its wire types (type names,
    sizes) or a sample's header version differ from this package's."""


class Rejected(BridgeError):
    """The bridge rejected a state or a command. The controller's state is as if
    it had never been sent; the next valid state is answered normally.

    Attributes:
        reason: the reason's name (``non_finite``, ``out_of_range``,
            ``bad_quaternion``, ``time_not_increasing``, ``time_jump``, ...).
        code: its numeric code (docs/bridge.md).
        count: the bridge's counter of that reason, this rejection included.
        request_seq: the rejected request's sequence number.
    """

    def __init__(self, reason: str, code: int, count: int, request_seq: int, message: str):
        super().__init__(message)
        self.reason = reason
        self.code = code
        self.count = count
        self.request_seq = request_seq
