"""``bench contacts`` times the numpy reference, the compiled drop-in and the raw kernel."""

from __future__ import annotations

import argparse

import pytest

from ballscrew_twin.benchmarks import contact_laws


def test_every_implementation_is_timed_for_both_sphere_counts(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert contact_laws.run(argparse.Namespace(repeat=3)) == 0
    lines = capsys.readouterr().out.splitlines()
    for count in ("B=2 ", "B=50"):
        timed = [line for line in lines if line.strip().startswith(count.strip())]
        names = ("reference evaluate_contacts", "evaluate_contacts_compiled", "contacts_kernel")
        assert all(any(name in line for line in timed) for name in names)
        assert all(line.endswith(" us") for line in timed)
