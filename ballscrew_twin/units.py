"""Units at the edges: the rpm and degrees Celsius of command lines, catalogues and ROS
messages, converted to the SI the code uses inside (rad/s, K), the nanoseconds of ROS
times, and the frame their headers name.

One definition of each, imported wherever a conversion is made.
"""

from __future__ import annotations

import math
from decimal import Decimal
from typing import Any

#: rad/s per rpm: a speed in rpm times RPM is in rad/s.
RPM = 2.0 * math.pi / 60.0
#: The kelvin temperature of 0 degrees Celsius [K].
CELSIUS_ZERO = 273.15
#: Nanoseconds per second: ROS times and stamps are integer nanoseconds.
NS_PER_S = 1_000_000_000
#: ``header.frame_id`` of every message and bag the project writes (the simulation writer,
#: the bench-data generator, the twin and health nodes): the screw's frame, z along its axis.
SCREW_FRAME_ID = "screw"


def stamp_to_ns(stamp: Any) -> int:
    """A builtin_interfaces/Time (``sec``, ``nanosec``) as integer nanoseconds [ns]."""
    return int(stamp.sec) * NS_PER_S + int(stamp.nanosec)


def stamp_to_seconds(stamp: Any) -> float:
    """A builtin_interfaces/Time (``sec``, ``nanosec``) as float seconds [s] (the health
    monitor's time; a double keeps 1e-7 s over a Unix epoch's 1.7e9 s)."""
    return float(stamp.sec) + 1e-9 * float(stamp.nanosec)


def seconds_to_stamp(seconds: float) -> tuple[int, int]:
    """Float seconds [s] as the (``sec``, ``nanosec``) of a builtin_interfaces/Time, nanosec
    rounded and kept below one second."""
    sec = math.floor(seconds)
    return int(sec), min(round((seconds - sec) * 1e9), NS_PER_S - 1)


def ns_to_stamp(ns: int) -> tuple[int, int]:
    """Integer nanoseconds [ns] as the (``sec``, ``nanosec``) of a builtin_interfaces/Time."""
    return divmod(ns, NS_PER_S)


def celsius_to_kelvin(celsius: float) -> float:
    """A temperature in degrees Celsius in kelvin [K], the float nearest the exact decimal sum.

    ``celsius + 273.15`` rounds twice (273.15 has no exact binary value): -40 C gives
    233.14999999999998 K, below a bound written as 233.15 K. Adding the shortest decimal
    forms exactly and rounding once gives 233.15 K, the same float as the literal.
    """
    if not math.isfinite(celsius):
        return celsius + CELSIUS_ZERO
    return float(Decimal(repr(float(celsius))) + Decimal(repr(CELSIUS_ZERO)))
