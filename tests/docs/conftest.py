"""The doc tests' workspaces (made once per session) and their tally."""
from __future__ import annotations

import pytest

from tests.docs.harness import Workspace

#: what the doc tests did, per page: (page, 'ran' or 'parsed') -> count (printed at the end)
TALLY: dict[tuple[str, str], int] = {}


@pytest.fixture(scope="session")
def small_ws(tmp_path_factory) -> Workspace:
    """Commands run here: the scenes cut down, results/ empty to start with."""
    ws = Workspace(tmp_path_factory.mktemp("docs-small"), small=True)
    yield ws
    ws.close()


@pytest.fixture(scope="session")
def real_ws(tmp_path_factory) -> Workspace:
    """Dry runs of the real study files."""
    return Workspace(tmp_path_factory.mktemp("docs-real"), small=False)


def record_tally(config) -> None:
    """In an xdist worker: hand this process's TALLY to the controller (which prints it)."""
    output = getattr(config, "workeroutput", None)
    if output is not None and TALLY:
        output["doc_tally"] = [[page, kind, n] for (page, kind), n in TALLY.items()]


def merge_tally(workeroutput) -> None:
    """In the xdist controller: add a worker's TALLY to this process's."""
    for page, kind, n in (workeroutput or {}).get("doc_tally", []):
        TALLY[(page, kind)] = TALLY.get((page, kind), 0) + n


def write_tally(terminalreporter) -> None:
    """The tally's lines at the end of the run (tests/conftest.py calls it: the controller of
    an xdist run never loads this conftest, whose tests run in its workers)."""
    if not TALLY:
        return
    pages = sorted({p for p, _ in TALLY})
    ran = sum(n for (_, k), n in TALLY.items() if k == "ran")
    parsed = sum(n for (_, k), n in TALLY.items() if k == "parsed")
    terminalreporter.write_line(f"doc tests: {ran} commands and snippets run, {parsed} parsed "
                                f"(or dry-run) only:")
    for p in pages:
        terminalreporter.write_line(f"  {p}: {TALLY.get((p, 'ran'), 0)} run, "
                                    f"{TALLY.get((p, 'parsed'), 0)} parsed")
