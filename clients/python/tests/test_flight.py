"""What a run writes, the pure parts: the largest magnitude the F-16 example's
``comparison.json`` reports (issue 27, item 9)."""

import pytest

from decoy_bridge import flight


def test_largest_magnitude_is_never_negative():
    # A decoy drifting 3.8 mm to the right: the largest absolute offset is
    # +0.0038 m (``max(values, key=abs)`` gave -0.0038).
    assert flight.largest_magnitude([0.001, -0.0038, 0.002]) == 0.0038
    assert flight.largest_magnitude(iter([-1.5, 1.0])) == 1.5
    assert flight.largest_magnitude([-0.0]) == 0.0
    assert flight.largest_magnitude([]) is None


def _state(t: float) -> "flight.AircraftState":
    import numpy as np

    return flight.AircraftState(
        time_s=t,
        position_ned_m=np.array([10.0, 20.0, -9000.0]),
        velocity_ned_mps=np.array([3.0, 4.0, 0.0]),
        acceleration_ned_mps2=np.array([0.5, 0.0, -0.25]),
        attitude_wxyz=np.array([1.0, 0.0, 0.0, 0.0]),
        body_rate_radps=np.array([0.0, 0.1, 0.0]),
        body_angular_acceleration_radps2=np.array([0.0, 0.0, 0.0]),
        extra={"mach": 0.8, "load_factor": 1.5},
    )


def test_rows_follow_the_column_schema_of_the_layout():
    """The client's files take their columns from the layout description
    (``decoy bridge-layout --json``): every row has a value for every column, in
    its order, and the per-requirement columns come from the requirement list."""
    import math

    from decoy_bridge import wire

    o = wire.Output()
    o.time_s = 1.25
    o.request_seq = 7
    o.connection_tension_n = 900.5
    o.posture.margin = math.radians(5.0)
    o.exhaust.level = 3
    o.exhaust.margin = -0.5
    o.advisories = 8
    rec = flight.Record(state=_state(1.25), seq=7, latency_us=42.0, output=o)
    row = flight.output_row(rec)
    assert tuple(row) == flight.OUTPUT_COLUMNS
    assert flight.OUTPUT_COLUMNS[:2] == ("t_s", "seq")
    assert row["tension_connection_N"] == 900.5
    assert row["aircraft_speed_mps"] == 5.0
    assert row["aircraft_load_factor"] == 1.5
    assert row["posture_margin_deg"] == pytest.approx(5.0)
    assert (row["exhaust_level"], row["exhaust_margin_m"], row["advisories"]) == (3, -0.5, 8)
    assert [r.name for r in wire.REQUIREMENTS] == list(flight.REQUIREMENTS)
    for r in wire.REQUIREMENTS:
        assert f"{r.name}_level" in row and f"{r.name}_margin_{r.file_unit}" in row
    summary = flight.management_summary([row])
    assert summary["exhaust"]["first_violation_s"] == 1.25
    assert summary["exhaust"]["first_advisory_s"] == 1.25
    assert summary["posture"]["first_violation_s"] is None

    traj = flight.trajectory_row(_state(0.5))
    assert len(traj) == len(flight.TRAJECTORY_COLUMNS)
    at = dict(zip(flight.TRAJECTORY_COLUMNS, traj))
    assert (at["t_s"], at["north_m"], at["vn_mps"], at["ad_mps2"], at["q_radps"]) == (
        "0.500000000",
        "10.000000",
        "3.000000",
        "-0.250000",
        "0.100000",
    )
    assert (at["mach"], at["load_factor"], at["throttle"]) == ("0.800000", "1.500000", "nan")


def test_written_files_have_the_schema_header(tmp_path):
    """``write_outputs`` and ``write_trajectory`` write the layout's headers and
    rows of the same length."""
    import csv

    from decoy_bridge import wire

    o = wire.Output()
    o.time_s = 0.01
    run = flight.Run(records=[flight.Record(state=_state(0.01), seq=1, latency_us=10.0, output=o)])
    flight.write_outputs(tmp_path / "timeseries.csv", run)
    flight.write_trajectory(tmp_path / "trajectory.csv", [_state(0.01)])
    for name, columns in (("timeseries.csv", flight.OUTPUTS), ("trajectory.csv", flight.TRAJECTORY)):
        rows = list(csv.reader((tmp_path / name).open()))
        assert tuple(rows[0]) == columns.names
        assert all(len(r) == len(columns.columns) for r in rows[1:])
    assert wire.LAYOUT.csv_files["client_timeseries"] is flight.OUTPUTS
