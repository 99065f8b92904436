"""The runs a compared monitor of ``bench detection`` judges otherwise than the default, run by
run (issue 13: a setting becomes the default only if it makes no run wrong that the default
gets right, which the headline counts cannot show when one run is made right and another
wrong)."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from ballscrew_twin.benchmarks.detection import Run
from ballscrew_twin.benchmarks.detection_changes import changed_runs, changes_report, outcome


def _run(seed: int, true_class: str, alarm: float, named: str) -> Run:
    return Run(
        unit=7,
        seed=seed,
        true_class=true_class,
        severity=0.3 if true_class else 0.0,
        growth="step" if true_class else "",
        onset=20.0 if true_class else math.nan,
        duration=60.0,
        alarm=alarm,
        detector="cusum",
        fault_class=named,
        confidence=0.95,
        reason="",
        gated=0.0,
        compared=60.0,
        scores=(1.0,),
    )


def test_each_outcome_of_a_run() -> None:
    assert outcome(_run(1, "", math.nan, "")) == "quiet"
    assert outcome(_run(1, "", 30.0, "jam_onset")) == "false alarm"
    assert outcome(_run(1, "jam_onset", math.nan, "")) == "missed"
    assert outcome(_run(1, "jam_onset", 10.0, "jam_onset")) == "early"
    assert outcome(_run(1, "jam_onset", 21.0, "jam_onset")) == "right"
    assert outcome(_run(1, "jam_onset", 21.0, "")) == "unclassified"
    assert outcome(_run(1, "jam_onset", 21.0, "preload_loss")) == "wrong"


def test_a_swap_that_leaves_the_counts_alone_is_listed_both_ways() -> None:
    """One jam made right and another made wrong: the confusion counts are the same, the
    report names both runs and a new false alarm."""
    default = [
        _run(1, "jam_onset", 21.0, "preload_loss"),
        _run(2, "jam_onset", 22.0, "jam_onset"),
        _run(3, "", math.nan, ""),
        _run(4, "preload_loss", 21.5, "preload_loss"),
    ]
    compared = [
        replace(default[0], fault_class="jam_onset"),
        replace(default[1], fault_class="preload_loss"),
        replace(default[2], alarm=40.0, fault_class="jam_onset"),
        default[3],
    ]
    assert [a.seed for a, _ in changed_runs(default, compared)] == [1, 2, 3]
    text = changes_report(default, compared)
    assert "made right 1, made wrong 1, new false alarms 1 (gone 0;" in text
    assert "| 7 | jam_onset | 0.3 | +1.00 | +1.00 | preload_loss (0.95) | jam_onset (0.95) " in text
    assert "| wrong -> right |" in text and "| right -> wrong |" in text
    assert "| quiet -> false alarm |" in text and "at 40.0" in text


def test_an_alarm_before_the_onset_counts_as_a_false_alarm_both_ways() -> None:
    """A fault run whose alarm moves before the onset is a new false alarm, and one that moves
    after it a false alarm gone; a healthy recording's alarm that goes is one too."""
    default = [
        _run(1, "jam_onset", 21.0, "jam_onset"),
        _run(2, "preload_loss", 10.0, "preload_loss"),
        _run(3, "", 40.0, "jam_onset"),
    ]
    compared = [
        replace(default[0], alarm=12.0),
        replace(default[1], alarm=21.0),
        replace(default[2], alarm=math.nan, fault_class=""),
    ]
    text = changes_report(default, compared)
    assert "made right 1, made wrong 1, new false alarms 1 (gone 2;" in text
    assert "| right -> early |" in text and "| early -> right |" in text
    assert "| false alarm -> quiet |" in text


def test_the_same_judgement_is_reported_as_none() -> None:
    runs = [_run(1, "jam_onset", 21.0, "jam_onset"), _run(2, "", math.nan, "")]
    assert changed_runs(runs, list(runs)) == []
    assert "none" in changes_report(runs, list(runs))


def test_a_later_alarm_with_the_same_class_is_a_change() -> None:
    default = [_run(1, "jam_onset", 21.0, "jam_onset")]
    later = [replace(default[0], alarm=23.0)]
    assert "| right -> right |" in changes_report(default, later)


@pytest.mark.parametrize("other_seed, count", [(9, 1), (1, 2)])
def test_runs_of_other_recordings_are_refused(other_seed: int, count: int) -> None:
    default = [_run(1, "jam_onset", 21.0, "jam_onset")]
    other = [_run(other_seed, "jam_onset", 21.0, "jam_onset")] * count
    with pytest.raises(ValueError):
        changed_runs(default, other)
