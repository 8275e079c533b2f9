"""The doc harness can fail: pages with a broken snippet, a wrong number, an option hertzmap
does not have, an output that changed... each make it raise, naming the line; a correct page
passes. (A harness that passes everything would prove nothing about the docs.)"""
from __future__ import annotations

from pathlib import Path

import pytest

from tests.docs import markdown as md
from tests.docs.harness import (DocError, Workspace, check_command, check_python, check_toml,
                                compare_sample, shape)


@pytest.fixture(scope="module")
def spaces(tmp_path_factory):
    small = Workspace(tmp_path_factory.mktemp("h-small"), small=True)
    yield small, Workspace(tmp_path_factory.mktemp("h-real"), small=False)
    small.close()


def _page(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "page.md"
    p.write_text(text)
    return p


def _run_page(page: Path, spaces) -> list[str]:
    small, real = spaces
    done = []
    text = page.read_text()
    for b in md.blocks(page):
        if b.kind == "python":
            done.append(check_python(b, small, text))
        elif b.kind == "toml":
            done.append(check_toml(b, small, real))
    for c in md.all_commands(page):
        done.append(check_command(c, small, real))
    return done


GOOD = """# A page

    hertzmap run scenes/default.toml --dry-run
    hertzmap plot --paper fig02

<!-- doc-test: cluster -->

    hertzmap run scenes/default.toml --cluster slurm --cluster-option queue=q

<!-- doc-test: prints 0.5 -->
```python
print(0.5)
```

The half above is 0.5.
"""

BROKEN = {
    "a snippet that raises": "```python\nimport xarray as xr\nxr.open_zarr('nowhere.zarr')\n```\n",
    "a snippet that does not parse": "```python\nprint(1\n```\n",
    "a warning (here, a Dask PerformanceWarning or any other)":
        "```python\nimport warnings\nwarnings.warn('slow', RuntimeWarning)\n```\n",
    "a number the output does not have":
        "The value is 0.25.\n\n<!-- doc-test: prints 0.25 -->\n```python\nprint(0.26)\n```\n",
    "a number the text does not have":
        "The value is 0.3.\n\n<!-- doc-test: prints 0.25 -->\n```python\nprint(0.5 / 2)\n```\n",
    "an option hertzmap does not have":
        "    hertzmap run scenes/default.toml --dry-run --fast\n",
    "a command hertzmap does not have": "    hertzmap draw results/default.zarr\n",
    "a study that does not exist": "    hertzmap run scenes/nosuch.toml --dry-run\n",
    "a command that fails": "    hertzmap status results/nosuch.zarr\n",
    "a long command with a bad option":
        "<!-- doc-test: long -->\n\n    hertzmap run scenes/fine_map.toml --wrokers 2\n",
    "a script that does not exist": "    .venv/bin/python benchmarks/nosuch.py\n",
    "a module without a __main__": "    .venv/bin/python -m hertzmap.study.solve.discovery --sigma 0.2\n",
    "a script option it does not take": "    .venv/bin/python benchmarks/paper_checks.py --fast\n",
    "a test file that moved": "    .venv/bin/python -m pytest tests/test_kernels.py\n",
    "an extra that does not exist": "    pip install 'hertzmap[gpu]'\n",
    "an invalid study file": "```toml\n[grid]\nomega = 0\nsigma = 0.1\nzeta = 0.01\n```\n",
    "a synopsis that leaves an option out":
        "<!-- doc-test: usage -->\n\n    hertzmap status STORE [--json]\n",
    "an output sample that changed":
        "<!-- doc-test: output -->\n```\n$ hertzmap run scenes/default.toml --dry-run\n"
        "study        default (hash 731f3b440965)\ntasks        77 (chunk 161 omega; about 2s each)\n```\n",
}


def test_a_correct_page_passes(tmp_path, spaces):
    done = _run_page(_page(tmp_path, GOOD), spaces)
    assert done == ["ran", "ran", "ran", "parsed"]


@pytest.mark.parametrize("what", list(BROKEN))
def test_a_broken_page_fails(what, tmp_path, spaces):
    with pytest.raises(DocError, match=r"page\.md:\d+"):
        _run_page(_page(tmp_path, BROKEN[what]), spaces)


def test_an_unknown_marker_word_is_an_error():
    assert [m.word for m in md.parse_marker("prints 0.25; long", 3)] == ["prints", "long"]
    with pytest.raises(ValueError, match="'prnts'"):
        md.parse_marker("prnts 0.25", 3)


def test_sample_comparison_sets_numbers_free_but_not_words():
    class Here:
        @staticmethod
        def where():
            return "here"
    got = "done: 20 tasks, 12397 points in 6.38 s wall on 2 workers\nstore: results/x.zarr\n"
    compare_sample(Here, ["done: 4 tasks, 289 points in 1.2 s wall on 2 workers"], got)
    compare_sample(Here, ["store: ..."], got)
    with pytest.raises(DocError):
        compare_sample(Here, ["done: 4 tasks, 289 points in 1.2 s wall on 2 busy workers"], got)
    assert shape("hash 731f3b440965, 2026-11-22T04:10:37Z") == shape("hash 0a1b2c3d4e5f, 2026-01-02T00:00:00Z")


def test_blocks_and_commands_are_found(tmp_path):
    page = _page(tmp_path, """Text with `hertzmap status results/default.zarr` inline.

- a list item

  ```python
  x = 1
  ```

      hertzmap run scenes/default.toml \\
          --workers 2 && hertzmap plot results/default.zarr

| a | `python -c "print(1)"` |
""")
    kinds = [b.kind for b in md.blocks(page)]
    assert kinds == ["python", "shell"]
    cmds = [c.text for c in md.all_commands(page)]
    assert cmds == ["hertzmap run scenes/default.toml --workers 2",
                    "hertzmap plot results/default.zarr",
                    "hertzmap status results/default.zarr", 'python -c "print(1)"']
