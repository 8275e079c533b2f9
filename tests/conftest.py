"""Fixtures shared by the tests (helpers that are plain functions live in tests/helpers.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.helpers import hand_built_results


@pytest.fixture
def study_file(tmp_path):
    """Write a study file; returns a function (text, name) -> path."""
    def write(text: str, name: str = "t") -> Path:
        p = tmp_path / f"{name}.toml"
        p.write_text(text)
        return p
    return write


@pytest.fixture(scope="module")
def client():
    """An in-process Dask client (one thread): the placeholder solver runs in milliseconds."""
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=None) as cluster, Client(cluster) as c:
        yield c


@pytest.fixture()
def hand():
    """tests.helpers.hand_built_results, fresh for each test."""
    return hand_built_results()
