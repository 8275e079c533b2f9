"""docs/notebook.ipynb, the worked notebook, executed top to bottom in a fresh kernel of this
venv (nbclient, in a folder of its own): a cell that raises fails the test. Then what it left:
the store it ran opens as a DataTree with the groups the notebook made, its progress went to
the cell as one line rewritten in place (carriage returns, no line per update or per stage),
and no cell printed a traceback."""
from __future__ import annotations

import shutil
import time

import pytest
import xarray as xr

from tests.helpers import REPO

nbformat = pytest.importorskip("nbformat", reason="the test extras install nbformat")
nbclient = pytest.importorskip("nbclient", reason="the test extras install nbclient")

NOTEBOOK = REPO / "docs" / "notebook.ipynb"


def _text(cell) -> str:
    out = []
    for o in cell.get("outputs", []):
        if o["output_type"] == "stream":
            out.append(o["text"])
        elif o["output_type"] in ("execute_result", "display_data"):
            out.append(o["data"].get("text/plain", ""))
        elif o["output_type"] == "error":
            out.append("\n".join(o["traceback"]))
    return "".join(out)


@pytest.mark.slow
def test_the_worked_notebook_runs_top_to_bottom(tmp_path):
    work = tmp_path / "nb"
    work.mkdir()
    shutil.copy(NOTEBOOK, work / NOTEBOOK.name)
    nb = nbformat.read(work / NOTEBOOK.name, as_version=4)
    t0 = time.perf_counter()
    nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                            resources={"metadata": {"path": str(work)}}).execute()
    seconds = time.perf_counter() - t0
    print(f"notebook executed in {seconds:.1f} s")
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert all(c.execution_count is not None for c in code)
    texts = [_text(c) for c in code]
    assert not any("Traceback" in t for t in texts), texts
    run_cell = next(t for c, t in zip(code, texts) if "hertzmap.run(study" in c.source)
    # the run's progress: rewritten in place (carriage returns), the summary a few lines
    stderr = "".join(o["text"] for c in code if "hertzmap.run(study" in c.source
                     for o in c.outputs if o.get("name") == "stderr")
    assert stderr.count("\n") == 0 and stderr.count("\r") >= 1, stderr
    assert "orbits:" in run_cell and "DataTree" in run_cell
    refused = next(t for c, t in zip(code, texts) if "StudyError" in c.source)
    assert refused.startswith("grid.zeta: ") and ">= 0" in refused, refused
    tree = xr.open_datatree(work / "results" / "notebook.zarr", engine="zarr")
    groups = {node.path for node in tree.subtree}
    assert "/products/loss_of_contact_map" in groups
    assert any(g.startswith("/products/basin_map") for g in groups), groups
    assert (work / "results" / "notebook_map.png").is_file()
    assert not (work / "results" / "bad.zarr").exists()     # refused: nothing written
