"""The cache stamp of a kernel covers every kernel file it is built from.

The contact kernel is split over several files of ``kernels/``; a kernel calling it (the steady
Newton kernel, the dynamic step) stamps its cache with the contact kernel's module, so the stamp
must follow that module's own imports from its package, transitively.
"""

from __future__ import annotations

from pathlib import Path

from ballscrew_twin.kernels import (
    cache_stamp,
    contact_law,
    contact_layout,
    contacts,
    scalar_laws,
    vector3,
)


def test_the_contact_kernel_stamp_covers_the_files_it_is_built_from() -> None:
    sources = cache_stamp.dependency_sources((contacts,))
    expected = {Path(str(m.__file__)) for m in (contacts, contact_law, contact_layout)}
    expected |= {Path(str(m.__file__)) for m in (scalar_laws, vector3)}
    assert expected <= set(sources)
    assert len(sources) == len(set(sources))  # each file once
    assert sources[0] == Path(str(contacts.__file__))
    # files outside kernels/ (params, physics) are not kernel code: not stamped
    assert all(path.parent == sources[0].parent for path in sources)


def test_the_stamp_changes_with_a_dependency_and_the_constants() -> None:
    base = cache_stamp.dependency_stamp((contacts,), (1, 2))
    assert cache_stamp.dependency_stamp((contacts,), (1, 2)) == base
    assert cache_stamp.dependency_stamp((contacts,), (1, 3)) != base
    # a module alone stamps fewer files than the one importing it
    assert cache_stamp.dependency_stamp((scalar_laws,), (1, 2)) != base
