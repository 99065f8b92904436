"""Stamp of what a numba kernel's cached machine code depends on outside its own file.

numba's cache notices a change of the kernel's own file only: a kernel that calls the contact
kernel, or freezes solver constants defined elsewhere, keeps stale machine code when those
change. Each such module freezes :func:`dependency_stamp` into a compiled function and compares
it at first use (recompiling once when it differs).
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from types import ModuleType


def dependency_stamp(modules: tuple[ModuleType, ...], constants: object) -> int:
    """63-bit hash of the source files of ``modules`` and of ``repr(constants)``."""
    digest = hashlib.sha256()
    for module in modules:
        digest.update(Path(str(module.__file__)).read_bytes())
    digest.update(repr(constants).encode())
    return int.from_bytes(digest.digest()[:7], "little")
