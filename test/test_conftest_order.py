"""The order test/conftest.py gives the modules under pytest-xdist: every module it names
exists, once, so a renamed or removed module is not silently dropped from the list."""

from pathlib import Path

from conftest import SLOWEST_FIRST

ROOT = Path(__file__).resolve().parents[1]


def test_every_module_named_slowest_first_exists_once() -> None:
    assert len(set(SLOWEST_FIRST)) == len(SLOWEST_FIRST)
    missing = [path for path in SLOWEST_FIRST if not (ROOT / path).is_file()]
    assert missing == []
    assert all(path.startswith("test/") and path.endswith(".py") for path in SLOWEST_FIRST)
