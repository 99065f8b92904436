"""Stamp of what a numba kernel's cached machine code depends on outside its own file.

numba's cache notices a change of the kernel's own file only: a kernel that calls the contact
kernel, or freezes solver constants defined elsewhere, keeps stale machine code when those
change. Each such module freezes :func:`dependency_stamp` into a compiled function and compares
it at first use (recompiling once when it differs).

The stamp covers the given modules and, transitively, every module of their own package that
they import (``from .x import ...``, ``from . import x``): the contact kernel is built from
several files of ``kernels/``, and a change in any of them reaches its callers' caches.
"""

from __future__ import annotations

import ast
import hashlib
import importlib
from pathlib import Path
from types import ModuleType


def _package_imports(module: ModuleType) -> list[ModuleType]:
    """The modules of ``module``'s own package that its source imports (relative, one level)."""
    package = module.__package__
    tree = ast.parse(Path(str(module.__file__)).read_text())
    names: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level == 1:
            if node.module is not None:
                names.append(node.module)
            else:
                names.extend(alias.name for alias in node.names)
    return [importlib.import_module(f".{name}", package) for name in names]


def dependency_sources(modules: tuple[ModuleType, ...]) -> list[Path]:
    """Source files of ``modules`` and of the modules of their packages they import,
    transitively, each once, in a fixed order (depth first, in import order)."""
    seen: dict[str, Path] = {}

    def visit(module: ModuleType) -> None:
        if module.__name__ in seen:
            return
        seen[module.__name__] = Path(str(module.__file__))
        for imported in _package_imports(module):
            visit(imported)

    for module in modules:
        visit(module)
    return list(seen.values())


def dependency_stamp(modules: tuple[ModuleType, ...], constants: object) -> int:
    """63-bit hash of the source files of ``modules`` (with those they import from their
    package, :func:`dependency_sources`) and of ``repr(constants)``."""
    digest = hashlib.sha256()
    for path in dependency_sources(modules):
        digest.update(path.read_bytes())
    digest.update(repr(constants).encode())
    return int.from_bytes(digest.digest()[:7], "little")
