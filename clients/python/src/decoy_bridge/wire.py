"""The bridge's wire types as ``ctypes`` structures, generated from one description.

The Rust crate ``bridge-types`` describes every wire type from the compiler's own
layout (``size_of``, ``align_of``, ``offset_of!``): type name, iceoryx2 type name,
size, alignment and each field's name, offset, size, element type and count.
``decoy bridge-layout --json`` prints that description; a copy of it ships with
this package (``wire_layout.json``, rewritten by
``decoy bridge-layout --json > clients/python/src/decoy_bridge/wire_layout.json``)
and the classes below are built from it at import. :func:`build_types` refuses a
description that the ctypes layout does not reproduce byte for byte, and the
package's tests compare the shipped copy with the ``decoy`` binary of the tree.

iceoryx2 itself only checks a payload's type name, size and alignment when a port
opens, so a reordered field would pass it silently: the field-by-field check here
is what guards against that.

Every structure has a static ``type_name()`` returning the Rust type's iceoryx2
name (``decoy.bridge.v4.AircraftState``), which the iceoryx2 Python package uses
when it opens a service.

The same description lists the decoy management's requirements in wire order
(:data:`REQUIREMENTS`: the ``Output`` fields holding their reports, their
advisory bits, units) and the columns of every CSV file the tools write
(:attr:`Layout.csv_files`, ``decoy_schema::columns``), from which
:mod:`decoy_bridge.flight` takes its files' columns.
"""

from __future__ import annotations

import ctypes
import json
import math
from dataclasses import dataclass
from importlib import resources
from typing import Any

SCALARS: dict[str, Any] = {
    "u8": ctypes.c_uint8,
    "u16": ctypes.c_uint16,
    "u32": ctypes.c_uint32,
    "u64": ctypes.c_uint64,
    "i8": ctypes.c_int8,
    "i16": ctypes.c_int16,
    "i32": ctypes.c_int32,
    "i64": ctypes.c_int64,
    "f32": ctypes.c_float,
    "f64": ctypes.c_double,
}
"""Element types of the description and their ctypes."""


class LayoutError(ValueError):
    """The layout description is malformed or not reproducible with ctypes."""


@dataclass(frozen=True)
class Requirement:
    """One requirement of the decoy management (``decoy_schema::Requirement``).

    Attributes:
        name: its name: the :class:`Output` field holding its report, the prefix
            of its columns (``"posture"``).
        bit: its bit in ``Output.advisories``.
        unit: the unit of its margin on the wire (``"rad"``).
        file_unit: the unit of its margin in the files (``"deg"``).
        title: a title.
        margin: what its margin is.
    """

    name: str
    bit: int
    unit: str
    file_unit: str
    title: str
    margin: str

    def to_file_unit(self, margin: float) -> float:
        """``margin`` (in :attr:`unit`) in :attr:`file_unit`: radians to degrees."""
        if self.unit == "rad" and self.file_unit == "deg":
            return math.degrees(margin)
        return margin


@dataclass(frozen=True)
class Column:
    """One column of a CSV file (``decoy_schema::columns``).

    Attributes:
        name: its name in the header (``"posture_margin_deg"``).
        unit: its unit (``""`` for a count or a code).
        quantity: what it holds (``"margin"``, ``"tension_connection"``, ...).
        requirement: the requirement of a per-requirement quantity, else ``None``.
        index: the component of a vector quantity, else ``None``.
        description: what it means.
    """

    name: str
    unit: str
    quantity: str
    requirement: str | None
    index: int | None
    description: str


@dataclass(frozen=True)
class CsvFile:
    """A CSV file the tools write: ``id`` (``"client_timeseries"``), its ``file``
    name, what writes it and its :class:`Column` s in file order."""

    id: str
    file: str
    written_by: str
    columns: tuple[Column, ...]

    @property
    def names(self) -> tuple[str, ...]:
        """The column names, in file order (the header)."""
        return tuple(c.name for c in self.columns)


@dataclass(frozen=True)
class Layout:
    """A parsed layout description.

    Attributes:
        protocol_version: the bridge protocol version (in every header and type name).
        types: the ctypes structure of each wire type, by Rust name (``"Answer"``).
        services: each service's last name part → ``(pattern, payload type name,
            response type name)``.
        event_ids: event id by name (``"REQUEST"`` → 1).
        codes: per field (``"reason"``, ``"command"``, ...) the name → value map.
        requirements: the decoy management's requirements, in wire order (the
            order of ``Output``'s reports and of the advisory bits).
        csv_files: the columns of every CSV file the tools write, by id.
        raw: the description as parsed from JSON.
    """

    protocol_version: int
    types: dict[str, type[ctypes.Structure]]
    services: dict[str, tuple[str, str | None, str | None]]
    event_ids: dict[str, int]
    codes: dict[str, dict[str, int]]
    requirements: tuple[Requirement, ...]
    csv_files: dict[str, CsvFile]
    raw: dict[str, Any]

    def code_name(self, field: str, value: int) -> str:
        """The name of ``value`` of the code ``field`` (``"?<value>"`` if unknown)."""
        for name, v in self.codes.get(field, {}).items():
            if v == value:
                return name
        return f"?{value}"


def _structure(desc: dict[str, Any], known: dict[str, type[ctypes.Structure]]) -> type[ctypes.Structure]:
    """One ctypes structure from its description, checked field by field."""
    name = desc["name"]
    fields: list[tuple[str, Any]] = []
    for f in desc["fields"]:
        ty = f["type"]
        if ty in SCALARS:
            base = SCALARS[ty]
        elif ty in known:
            base = known[ty]
        else:
            raise LayoutError(f"{name}.{f['name']}: unknown element type {ty!r} (nested types must come first)")
        count = int(f["count"])
        fields.append((f["name"], base * count if count != 1 else base))
    type_name = desc["type_name"]
    doc = f"Mirror of the Rust wire type ``{name}`` (iceoryx2 type name ``{type_name}``): " + ", ".join(
        f"``{f['name']}`` ({f['type']}{'' if f['count'] == 1 else ' x ' + str(f['count'])}, offset {f['offset']})"
        for f in desc["fields"]
    )
    cls = type(
        name,
        (ctypes.Structure,),
        {
            "_fields_": fields,
            "__doc__": doc,
            "type_name": staticmethod(lambda tn=type_name: tn),
        },
    )
    check_structure(cls, desc)
    return cls


def check_structure(cls: type[ctypes.Structure], desc: dict[str, Any]) -> None:
    """Raises :class:`LayoutError` unless ``cls`` has ``desc``'s type name, size,
    alignment and fields (names, order, offsets, sizes)."""
    name = desc["name"]
    problems = []
    if cls.type_name() != desc["type_name"]:  # type: ignore[attr-defined]
        problems.append(f"type name {cls.type_name()!r} != {desc['type_name']!r}")  # type: ignore[attr-defined]
    if ctypes.sizeof(cls) != desc["size"]:
        problems.append(f"size {ctypes.sizeof(cls)} != {desc['size']}")
    if ctypes.alignment(cls) != desc["align"]:
        problems.append(f"alignment {ctypes.alignment(cls)} != {desc['align']}")
    names = [f[0] for f in cls._fields_]
    if names != [f["name"] for f in desc["fields"]]:
        problems.append(f"fields {names} != {[f['name'] for f in desc['fields']]}")
    else:
        for f in desc["fields"]:
            attr = getattr(cls, f["name"])
            if attr.offset != f["offset"] or attr.size != f["size"]:
                problems.append(
                    f"field {f['name']}: offset {attr.offset}, size {attr.size} != offset {f['offset']}, size {f['size']}"
                )
    if problems:
        raise LayoutError(f"{name}: " + "; ".join(problems))


def build_types(description: dict[str, Any]) -> Layout:
    """The :class:`Layout` of a parsed description (``decoy bridge-layout --json``)."""
    try:
        known: dict[str, type[ctypes.Structure]] = {}
        for desc in description["types"]:
            known[desc["name"]] = _structure(desc, known)
        services = {s["name"]: (s["pattern"], s.get("payload"), s.get("response")) for s in description["services"]}
        event_ids = {str(n): int(v) for n, v in description["event_ids"]}
        codes: dict[str, dict[str, int]] = {}
        for field, n, v in description["codes"]:
            codes.setdefault(str(field), {})[str(n)] = int(v)
        requirements = tuple(Requirement(**r) for r in description["requirements"])
        csv_files = {
            f["id"]: CsvFile(f["id"], f["file"], f["written_by"], tuple(Column(**c) for c in f["columns"]))
            for f in description["csv_files"]
        }
        return Layout(
            int(description["protocol_version"]),
            known,
            services,
            event_ids,
            codes,
            requirements,
            csv_files,
            description,
        )
    except (KeyError, TypeError) as e:
        raise LayoutError(f"malformed layout description: {e!r}") from e


def load_shipped() -> Layout:
    """The layout shipped with the package (``wire_layout.json``)."""
    text = resources.files(__package__).joinpath("wire_layout.json").read_text(encoding="utf-8")
    return build_types(json.loads(text))


LAYOUT = load_shipped()
"""The wire types of the protocol version this package speaks."""
PROTOCOL_VERSION = LAYOUT.protocol_version
"""The bridge protocol version (:class:`Header` ``protocol_version``)."""

Header = LAYOUT.types["Header"]
AircraftState = LAYOUT.types["AircraftState"]
Output = LAYOUT.types["Output"]
Rejection = LAYOUT.types["Rejection"]
Answer = LAYOUT.types["Answer"]
Counters = LAYOUT.types["Counters"]
Status = LAYOUT.types["Status"]
Command = LAYOUT.types["Command"]
CommandReply = LAYOUT.types["CommandReply"]

REQUIREMENTS = LAYOUT.requirements
"""The decoy management's requirements, in wire order (:class:`Requirement`)."""


def to_dict(value: ctypes.Structure) -> dict[str, Any]:
    """A structure as plain Python values (arrays as lists, nested as dicts; u8
    arrays named like text, e.g. ``board``/``instance``, as strings)."""
    out: dict[str, Any] = {}
    for name, ty in value._fields_:
        v = getattr(value, name)
        if isinstance(v, ctypes.Structure):
            out[name] = to_dict(v)
        elif isinstance(v, ctypes.Array):
            if getattr(ty, "_type_", None) is ctypes.c_uint8 and not name.startswith("reserved"):
                out[name] = bytes(v).split(b"\0", 1)[0].decode("ascii", "replace")
            else:
                out[name] = list(v)
        else:
            out[name] = v
    return out
