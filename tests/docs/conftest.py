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


def pytest_terminal_summary(terminalreporter):
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
