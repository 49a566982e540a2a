"""The ctypes mirror against the Rust wire types (`decoy bridge-layout --json`)."""

from __future__ import annotations

import ctypes
import json
import subprocess
from importlib import resources

import pytest

from decoy_bridge import wire


@pytest.fixture(scope="module")
def rust_layout(decoy: str) -> dict:
    out = subprocess.run([decoy, "bridge-layout", "--json"], capture_output=True, text=True, check=True)
    return json.loads(out.stdout)


def test_shipped_description_is_the_rust_one(rust_layout):
    """The package's wire_layout.json is what the Rust crate of this tree describes
    (rewrite it with `decoy bridge-layout --json > clients/python/src/decoy_bridge/wire_layout.json`)."""
    shipped = json.loads(resources.files("decoy_bridge").joinpath("wire_layout.json").read_text())
    assert shipped == rust_layout


def test_every_mirror_matches_the_rust_layout(rust_layout):
    """Type names, sizes, alignments and every field's name, order, offset and size,
    checked against the live description (not the shipped copy)."""
    names = [t["name"] for t in rust_layout["types"]]
    assert set(names) == set(wire.LAYOUT.types)
    for desc in rust_layout["types"]:
        cls = wire.LAYOUT.types[desc["name"]]
        wire.check_structure(cls, desc)
        assert cls.type_name() == desc["type_name"]
        assert desc["type_name"].endswith(f".v{rust_layout['protocol_version']}.{desc['name']}")
        # The element types too: a u32 where the Rust side has an f32 keeps every offset.
        for f in desc["fields"]:
            ty = dict(cls._fields_)[f["name"]]
            elem = getattr(ty, "_type_", ty) if f["count"] != 1 else ty
            if f["type"] in wire.SCALARS:
                assert elem is wire.SCALARS[f["type"]], f"{desc['name']}.{f['name']}"
            else:
                assert elem is wire.LAYOUT.types[f["type"]]
    assert wire.PROTOCOL_VERSION == rust_layout["protocol_version"]
    # The codes the client uses exist.
    for field in ("kind", "reason", "command", "profile", "result", "backend", "health"):
        assert wire.LAYOUT.codes.get(field), field
    assert set(wire.LAYOUT.event_ids) >= {"REQUEST", "STATE", "COMMAND", "ANSWER", "OUTPUT", "STATUS", "COMMAND_REPLY"}


def test_a_reordered_field_is_caught():
    """iceoryx2 would accept this (same name, size, alignment); the check does not."""
    desc = next(t for t in wire.LAYOUT.raw["types"] if t["name"] == "Output")
    fields = list(wire.Output._fields_)
    i = [n for n, _ in fields].index("connection_tension_n")
    fields[i], fields[i + 1] = fields[i + 1], fields[i]
    swapped = type("Output", (ctypes.Structure,), {"_fields_": fields, "type_name": staticmethod(wire.Output.type_name)})
    assert ctypes.sizeof(swapped) == ctypes.sizeof(wire.Output)
    with pytest.raises(wire.LayoutError, match="fields"):
        wire.check_structure(swapped, desc)


def test_a_description_ctypes_cannot_reproduce_is_refused():
    raw = json.loads(json.dumps(wire.LAYOUT.raw))
    header = next(t for t in raw["types"] if t["name"] == "Header")
    header["fields"][2]["offset"] = 6  # seq at 6: not what repr(C) gives
    with pytest.raises(wire.LayoutError, match="seq"):
        wire.build_types(raw)
    raw["types"][0]["fields"][0]["type"] = "c_char_p"
    with pytest.raises(wire.LayoutError, match="unknown element type"):
        wire.build_types(raw)


def test_to_dict_reads_text_fields():
    s = wire.Status()
    s.instance[: len(b"f16")] = list(b"f16")
    d = wire.to_dict(s)
    assert d["instance"] == "f16"
    assert d["counters"]["accepted"] == 0
