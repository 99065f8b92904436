"""``/diagnostics`` of the twin node: plain check results turned into a DiagnosticArray.

The node fills :class:`Check` records (one per concern: model, real time, each input,
validity); :func:`to_message` converts them. ``diagnostic_updater`` is not available from PyPI,
so the array is built directly (levels OK/WARN/ERROR/STALE as in ``diagnostic_msgs``).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

OK = 0
WARN = 1
ERROR = 2
STALE = 3
LEVEL_NAMES = ("OK", "WARN", "ERROR", "STALE")


@dataclass(frozen=True)
class Check:
    """Result of one diagnostic check.

    Attributes:
        name: what was checked, e.g. ``"real time"`` (prefixed with the node name on the wire).
        level: :data:`OK`, :data:`WARN`, :data:`ERROR` or :data:`STALE`.
        message: one-line summary.
        values: key/value details (values already formatted, with units).
    """

    name: str
    level: int
    message: str
    values: tuple[tuple[str, str], ...] = field(default_factory=tuple)


def to_message(
    checks: Iterable[Check], *, node_name: str, hardware_id: str, stamp: Time
) -> DiagnosticArray:
    """A ``diagnostic_msgs/DiagnosticArray`` with one status per check."""
    array = DiagnosticArray()
    array.header.stamp = stamp
    for check in checks:
        array.status.append(
            DiagnosticStatus(
                level=bytes([check.level]),
                name=f"{node_name}: {check.name}",
                message=check.message,
                hardware_id=hardware_id,
                values=[KeyValue(key=k, value=v) for k, v in check.values],
            )
        )
    return array


def level_of(status: DiagnosticStatus) -> int:
    """Level of a received status as an int (the field is a one-byte ``bytes``)."""
    level = status.level
    return level[0] if isinstance(level, bytes | bytearray) else int(level)
