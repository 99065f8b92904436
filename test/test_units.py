"""ROS time conversions of units.py against exact integer arithmetic."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from ballscrew_twin.units import (
    NS_PER_S,
    ns_to_stamp,
    seconds_to_stamp,
    stamp_to_ns,
    stamp_to_seconds,
)


@pytest.mark.parametrize("ns", [0, 1, 999_999_999, 1_700_000_000_123_456_789, 42 * NS_PER_S])
def test_nanoseconds_and_stamps_round_trip_exactly(ns: int) -> None:
    sec, nanosec = ns_to_stamp(ns)
    assert 0 <= nanosec < NS_PER_S
    assert stamp_to_ns(SimpleNamespace(sec=sec, nanosec=nanosec)) == ns


@pytest.mark.parametrize("ns", [0, 250_000_000, 1_700_000_000_123_456_789, 12_999_999_999])
def test_float_seconds_keep_a_stamp_to_the_resolution_of_a_double(ns: int) -> None:
    sec, nanosec = ns_to_stamp(ns)
    seconds = stamp_to_seconds(SimpleNamespace(sec=sec, nanosec=nanosec))
    # a double near 1.7e9 s resolves 2.4e-7 s: back to a stamp within that of the exact one
    back_sec, back_nanosec = seconds_to_stamp(seconds)
    assert abs((back_sec * NS_PER_S + back_nanosec) - ns) <= 250


def test_a_time_just_under_a_whole_second_keeps_nanosec_below_one_second() -> None:
    sec, nanosec = seconds_to_stamp(4.9999999999)
    assert (sec, nanosec) == (4, NS_PER_S - 1)
    assert seconds_to_stamp(-0.25) == (-1, 750_000_000)
