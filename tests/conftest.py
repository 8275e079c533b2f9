"""Fixtures shared by the tests (helpers that are plain functions live in tests/helpers.py)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from tests import parallel
from tests.docs import conftest as docs
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
    """An in-process Dask client (one thread): the placeholder solver runs in milliseconds. Its
    dashboard on a free loopback port (not 8787: another test process may have a cluster up)."""
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address="127.0.0.1:0") as cluster, Client(cluster) as c:
        yield c


@pytest.fixture()
def hand():
    """tests.helpers.hand_built_results, fresh for each test."""
    return hand_built_results()


# -- the suite over processes (pytest-xdist, scripts/test.sh): tests/parallel.py ------------------

@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """--dist loadgroup: a test file is a group unless marked otherwise (tests/parallel.py)."""
    if config.getoption("dist") == "loadgroup":
        return parallel.make_scheduler(config, log)
    return None


def pytest_collection_modifyitems(config, items):
    """In an xdist worker: the longest files first (tests/parallel.py SECONDS); every worker
    sorts the same collection the same way."""
    if os.environ.get("PYTEST_XDIST_WORKER"):
        items.sort(key=lambda item: parallel.rank(item.nodeid))


def pytest_sessionfinish(session):
    docs.record_tally(session.config)


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node, error):
    docs.merge_tally(getattr(node, "workeroutput", None))


def pytest_terminal_summary(terminalreporter):
    docs.write_tally(terminalreporter)
