"""A progress bar on stderr for the commands, driven by the ``on_progress(done, total)``
callbacks of the work below the command layer (which draws no bar itself)."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from tqdm import tqdm


@contextmanager
def progress_bar(
    desc: str, unit: str, *, enabled: bool = True
) -> Iterator[Callable[[int, int], None]]:
    """A bar named ``desc`` counting ``unit``; yields the callback that moves it to ``done`` of
    ``total`` (the total may be learnt on the first call). Closed on leaving, also on an error."""
    with tqdm(desc=desc, unit=unit, file=sys.stderr, disable=not enabled) as bar:

        def advance(done: int, total: int) -> None:
            bar.total = total
            bar.update(done - bar.n)

        yield advance
