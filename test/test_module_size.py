"""Issue 17's size rule: no module of the package over 800 lines (a module with one purpose
stays readable in one sitting; a longer one is split along its parts)."""

from __future__ import annotations

from pathlib import Path

import ballscrew_twin

MAX_LINES = 800


def test_no_module_is_over_800_lines() -> None:
    package = Path(ballscrew_twin.__file__).resolve().parent
    sizes = {
        str(path.relative_to(package)): len(path.read_text(encoding="utf-8").splitlines())
        for path in package.rglob("*.py")
    }
    assert len(sizes) > 100  # the package, not an empty folder
    too_long = {name: n for name, n in sizes.items() if n > MAX_LINES}
    assert not too_long, f"modules over {MAX_LINES} lines: {too_long}"
