"""The hypothesis profile chosen by test/conftest.py: reproducible and stateless under CI."""

import os

import pytest
from hypothesis import settings


@pytest.mark.skipif(os.environ.get("CI", "").lower() != "true", reason="CI=true not set")
def test_ci_runs_are_derandomized_without_a_database() -> None:
    assert settings.default.derandomize
    assert settings.default.database is None


@pytest.mark.skipif(os.environ.get("CI", "").lower() == "true", reason="CI=true set")
def test_local_runs_explore_and_remember() -> None:
    assert not settings.default.derandomize
    assert settings.default.database is not None
