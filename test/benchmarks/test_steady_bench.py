"""``bench steady`` prints both solvers side by side and, on request, their agreement."""

from __future__ import annotations

import argparse

import pytest

from ballscrew_twin.benchmarks import steady


def test_both_solvers_are_printed_with_their_agreement(capsys: pytest.CaptureFixture[str]) -> None:
    args = argparse.Namespace(config=None, repeat=1, agreement=3)
    assert steady.run(args) == 0
    text = capsys.readouterr().out
    for mode in ("symmetric", "full"):
        assert f"{mode:<9} previous   solver: cold" in text
        assert f"{mode:<9} structured solver: cold" in text
    assert "cold: 3 points, 3 solved by both, 3 equal to 1e-9" in text
    assert "warm path: 3 points" in text
