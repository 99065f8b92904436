"""Contact states built a slice per tick equal the message built at once."""

from __future__ import annotations

from ballscrew_twin_msgs.msg import ContactStateArray

from ballscrew_twin.ros.twin_node import PendingContacts


def _rows(count: int) -> list[tuple[float | int | bool, ...]]:
    return [
        (k % 25, k // 100, k % 4, k % 3 != 0, *(float(k + j) for j in range(11)))
        for k in range(count)
    ]


def test_slices_complete_on_the_last_advance_and_equal_the_whole() -> None:
    rows = _rows(200)
    pending = PendingContacts(ContactStateArray(fidelity="f"), rows, slices=9)
    done = [pending.advance() for _ in range(9)]
    assert done == [False] * 8 + [True]
    whole = PendingContacts(ContactStateArray(fidelity="f"), rows, slices=1).finish()
    assert pending.msg.contacts == whole.contacts
    assert [c.sphere_index for c in whole.contacts] == [r[0] for r in rows]
    assert [c.slip_speed for c in whole.contacts] == [r[-1] for r in rows]


def test_finish_builds_what_is_left_once() -> None:
    rows = _rows(7)
    pending = PendingContacts(ContactStateArray(), rows, slices=3)
    pending.advance()
    assert len(pending.finish().contacts) == 7
    assert len(pending.finish().contacts) == 7
