"""Shared pytest configuration."""

from __future__ import annotations

import pytest


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "slow: heavy stress variants (run in benchmarks)")


@pytest.fixture(autouse=True)
def _private_archive(
    tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Commands that archive by default write to a temporary archive, never to $HOME."""
    monkeypatch.setenv("BOWLREC_ARCHIVE", str(tmp_path_factory.mktemp("archive") / "a"))
