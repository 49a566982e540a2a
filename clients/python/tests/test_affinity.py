"""decoy_bridge.affinity: the list format as the bridge's, pinning refused cleanly."""

import os

import pytest

from decoy_bridge import affinity as af


def test_the_list_format_parses_and_prints_as_the_bridge_does():
    assert af.parse_cpu_list("3,0-1, 6 ,1") == {0, 1, 3, 6}
    assert af.format_cpu_list({0, 1, 3, 6}) == "0-1,3,6"
    assert af.format_cpu_list({2}) == "2"


@pytest.mark.parametrize("text,says", [("", "empty item"), ("0,,1", "empty item"), ("x", "not a CPU number"),
                                       ("3-1", "runs backwards"), ("4096", "0 to 1023")])
def test_bad_lists_say_what_is_wrong(text, says):
    with pytest.raises(ValueError, match=says):
        af.parse_cpu_list(text)


def test_an_unavailable_cpu_is_refused_and_nothing_changes():
    before = os.sched_getaffinity(0)
    absent = next(c for c in range(1024) if c not in before)
    with pytest.raises(ValueError, match="not available"):
        af.pin({min(before), absent})
    with pytest.raises(ValueError, match="none of these CPUs"):
        af.pin({absent})
    assert os.sched_getaffinity(0) == before
    assert af.current_cpus() == af.format_cpu_list(before)
