"""What a run writes, the pure parts: the largest magnitude the F-16 example's
``comparison.json`` reports (issue 27, item 9)."""

from decoy_bridge import flight


def test_largest_magnitude_is_never_negative():
    # A decoy drifting 3.8 mm to the right: the largest absolute offset is
    # +0.0038 m (``max(values, key=abs)`` gave -0.0038).
    assert flight.largest_magnitude([0.001, -0.0038, 0.002]) == 0.0038
    assert flight.largest_magnitude(iter([-1.5, 1.0])) == 1.5
    assert flight.largest_magnitude([-0.0]) == 0.0
    assert flight.largest_magnitude([]) is None
