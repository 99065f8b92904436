"""Tick counts of the twin node: the window, the totals and the start-up phase."""

from __future__ import annotations

import pytest

from ballscrew_twin.ros.tick_counts import ON_TIME_NS, TickBook, TickWindow


def test_window_counts_late_ticks_and_step_times() -> None:
    w = TickWindow()
    assert w.mean_step_time == 0.0
    w.add(1e-4, ON_TIME_NS)  # on time: within, not beyond
    w.add(3e-4, ON_TIME_NS + 1)
    assert (w.ticks, w.late) == (2, 1)
    assert w.mean_step_time == pytest.approx(2e-4) and w.step_time_max == 3e-4
    assert w.latencies_ns == [ON_TIME_NS, ON_TIME_NS + 1]


def test_skipped_ticks_at_start_up_are_apart() -> None:
    book = TickBook(grace_ns=10**12)
    review = TickWindow()
    assert book.starting_up
    assert book.book_skipped(40, review)
    assert book.totals.startup_skipped == 40 and book.totals.skipped == 0
    assert book.window.skipped == review.skipped == 0


def test_the_first_tick_on_time_ends_start_up() -> None:
    book = TickBook(grace_ns=10**12)
    review = TickWindow()
    book.latency_log = []
    book.book_published(1e-5, 5 * ON_TIME_NS, review)  # late: still starting
    assert book.starting_up and book.totals.late == 1
    book.book_published(1e-5, 1000, review)
    assert not book.starting_up
    assert not book.book_skipped(3, review)
    assert book.totals.skipped == book.window.skipped == review.skipped == 3
    assert book.totals.published == 2 and review.ticks == 2
    assert book.latency_log == [5 * ON_TIME_NS, 1000]


def test_start_up_ends_after_the_grace_time() -> None:
    book = TickBook(grace_ns=0)
    assert not book.starting_up


def test_close_window_starts_a_new_one() -> None:
    book = TickBook(grace_ns=0)
    book.book_published(1e-5, 0, TickWindow())
    w = book.close_window()
    assert w.ticks == 1 and book.window.ticks == 0 and book.totals.published == 1
