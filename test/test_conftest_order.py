"""The order test/conftest.py gives the modules under pytest-xdist: every module it names
exists, once, so a renamed or removed module is not silently dropped from the list."""

from pathlib import Path

from conftest import SLOWEST_FIRST, WHILE_THE_STEADY_SOLVER_COMPILES, module_order

ROOT = Path(__file__).resolve().parents[1]


def test_every_module_named_slowest_first_exists_once() -> None:
    assert len(set(SLOWEST_FIRST)) == len(SLOWEST_FIRST)
    missing = [path for path in SLOWEST_FIRST if not (ROOT / path).is_file()]
    assert missing == []
    assert all(path.startswith("test/") and path.endswith(".py") for path in SLOWEST_FIRST)


def test_the_modules_run_while_the_steady_solver_compiles_exist_once_apart_from_the_slowest() -> (
    None
):
    order = module_order()
    assert len(set(order)) == len(order)  # none named twice, none also among the slowest
    assert [path for path in WHILE_THE_STEADY_SOLVER_COMPILES if not (ROOT / path).is_file()] == []
    assert order[0] == SLOWEST_FIRST[0] and order[-len(SLOWEST_FIRST) + 1 :] == SLOWEST_FIRST[1:]
