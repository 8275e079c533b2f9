"""The doc tests' workspaces (made once per session) and their tally."""
from __future__ import annotations

import pytest

from tests.docs.harness import Workspace

#: what the doc tests did: 'ran' or 'parsed' -> count (printed at the end of the run)
TALLY: dict[str, int] = {}


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
    if TALLY:
        terminalreporter.write_line(
            "doc tests: " + ", ".join(f"{n} {k}" for k, n in sorted(TALLY.items()))
            + " (commands and snippets of README.md, VALIDATION.md, BENCHMARKS.md, "
              "RELIABILITY.md, docs/*.md)")
