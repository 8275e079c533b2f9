"""Every command and snippet of the docs, run as a reader would (tests/docs/harness.py).

One test per Python block, TOML block, and command line (in a shell block or a code span of the
text). Commands run in a small workspace whose scenes are cut down (harness.SMALL); blocks
marked ``long``, ``cluster`` or ``server`` (``<!-- doc-test: long -->``) are parsed and, for
``hertzmap run``, dry-run on the real study. Python blocks of a page run in order in one
namespace, warnings as errors.
"""
from __future__ import annotations

import pytest

from tests.docs import markdown as md
from tests.docs.conftest import TALLY
from tests.docs.harness import (DOC_FILES, REPO, check_command, check_python, check_toml)


def _items():
    """Blocks and commands of each page, in the page's order (a file saved, then run)."""
    items = []
    for name in DOC_FILES:
        path = REPO / name
        page = [(b.line, b) for b in md.blocks(path) if b.kind in ("python", "toml")]
        page += [(c.line, c) for c in md.all_commands(path)]
        for _, it in sorted(page, key=lambda t: t[0]):
            label = it.kind if isinstance(it, md.Block) else it.text[:60]
            items.append(pytest.param(it, id=f"{it.where()} {label}"))
    return items


ITEMS = _items()


def _page_blocks(path):
    return [b for b in md.blocks(path) if b.kind == "python"]


@pytest.mark.parametrize("item", ITEMS)
def test_doc(item, small_ws, real_ws):
    if isinstance(item, md.Block) and item.kind == "toml":
        done = check_toml(item, small_ws, real_ws)
    elif isinstance(item, md.Block):
        text = item.path.read_text()
        if "fresh" not in item.words:       # the page's earlier blocks first, as a reader would
            ns = small_ws.namespaces.setdefault(str(item.path), {"__name__": "__doc__"})
            ran = ns.setdefault("__doc_blocks__", set())
            for b in _page_blocks(item.path):
                if b.line >= item.line:
                    break
                if b.line not in ran and "fresh" not in b.words:
                    check_python(b, small_ws, text)
                    ran.add(b.line)
            ran.add(item.line)
        done = check_python(item, small_ws, text)
    else:
        done = check_command(item, small_ws, real_ws)
    key = (item.path.relative_to(REPO).as_posix(), done)
    TALLY[key] = TALLY.get(key, 0) + 1
