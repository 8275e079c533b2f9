"""docs/architecture.md's "Where to add" recipes are true: a per-orbit measure added the way the
recipe says (a field in kernels/records.py, the line of kernels/shooting.py that writes it, a
row in docs/dataset.md), in a copy of the packages, reaches the Orbit view, the solver's
solutions, a store written by ``hertzmap run``, the explore page's orbit table and the docs
check; without its docs row, the docs check fails."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap

from tests.helpers import REPO

TOY = "toy_half_ptp"

TOY_FIELD = f'''    Field("{TOY}", "half the peak-to-peak displacement", "1",
          "(max_q - min_q) / 2, a measure added by the recipe test", output="measures",
          quantity="displacement"),
'''
TOY_LINE = f'''    res[F_TOY] = 0.5 * (stats[S_MAX_Q] - stats[S_MIN_Q])
'''
TOY_DOC_ROW = f"| `{TOY}` | float64 | measures | half the peak-to-peak displacement |\n"

CHECK = textwrap.dedent(f'''
    import sys
    from pathlib import Path

    import numpy as np
    import xarray as xr

    copy = Path(sys.argv[1])
    import hertzmap.kernels as K
    assert Path(K.__file__).is_relative_to(copy), K.__file__
    o = K.shoot(2.0, 0.3, 0.01, 1)
    assert o.converged and o.{TOY} == 0.5 * o.ptp, (o.{TOY}, o.ptp)

    from hertzmap.study.solve.point import shoot_seeds
    sol = shoot_seeds(2.0, 0.3, 0.01, 1, [(0.0, 0.0)], {{}})[0]
    assert sol["{TOY}"] == 0.5 * sol["ptp"]

    import subprocess
    study = copy / "toy.toml"
    study.write_text("""[study]
    name = "toy"
    [grid]
    omega = [1.9, 2.0, 2.1]
    sigma = 0.3
    zeta = 0.01
    [search]
    periods = [1]
    attractors = "never"
    [products]
    outputs = ["orbits", "measures"]
    """.replace("\\n    ", "\\n"))
    store = copy / "toy.zarr"
    subprocess.run([sys.executable, "-m", "hertzmap.scheduler.doors.cli", "run", str(study),
                    "--store", str(store), "--workers", "1", "--error-sample", "0"],
                   check=True, capture_output=True)
    ds = xr.open_zarr(store)
    ok = (ds.status == 0).values
    assert ok.sum() >= 3
    assert ds["{TOY}"].attrs["long_name"] == "half the peak-to-peak displacement"
    np.testing.assert_array_equal(ds["{TOY}"].values[ok], 0.5 * ds["ptp"].values[ok])

    from hertzmap.study import explore_data as E
    from hertzmap.scheduler.doors.explore.table import orbit_table
    orbits = E.point_orbits(ds, 2.0, 0.3, 0.01)
    rows = [(0, orbits, {{"q": np.zeros(3)}}, 0.0, 1, "#000", "stable")]
    html = orbit_table(rows, E.units_of(ds))
    assert "data-field='{TOY}'" in html and "half the peak-to-peak displacement" in html

    import tests.study.test_schema as docs_check
    docs_check.REPO = copy
    docs_check.test_docs_list_every_stored_variable_and_nothing_else()
    print("recipe holds")
''')

DOCS_ONLY = textwrap.dedent('''
    import sys
    from pathlib import Path
    import tests.study.test_schema as docs_check
    docs_check.REPO = Path(sys.argv[1])
    try:
        docs_check.test_docs_list_every_stored_variable_and_nothing_else()
    except AssertionError:
        print("docs check failed")
    else:
        print("docs check passed")
''')


def _copy_with_toy(root):
    """The packages under root/hertzmap (a regular package there, found before the installed
    one), with the recipe's three edits, and docs/dataset.md without the toy's row."""
    pkg = root / "hertzmap"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    ignore = shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc")
    for src, dst in (("kernels", "kernels"), ("study", "study"), ("scheduler", "scheduler")):
        shutil.copytree(REPO / src, pkg / dst, ignore=ignore)
    records = pkg / "kernels" / "records.py"
    text = records.read_text()
    anchor = '    Field("force_harmonics", "contact force harmonic amplitudes"'
    assert anchor in text
    records.write_text(text.replace(anchor, TOY_FIELD + anchor))
    shooting = pkg / "kernels" / "shooting.py"
    text = shooting.read_text()
    anchor = "    res[I_PEAKF] = rhs_force(stats[S_MAX_Q], n, model)\n"
    assert anchor in text
    text = text.replace(anchor, anchor + TOY_LINE)
    # the column index beside the others (a compile-time constant of the kernel)
    anchor = "I_M11, I_M12, I_M21, I_M22 = "
    text = text.replace(anchor, f'F_TOY = F["{TOY}"]\n' + anchor)
    shooting.write_text(text)
    (root / "docs").mkdir()
    shutil.copy(REPO / "docs" / "dataset.md", root / "docs" / "dataset.md")


def _run(script, root, tmp_path):
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(root), str(REPO)])
    env["XDG_CACHE_HOME"] = str(tmp_path / "cache")      # the copy's kernels compile anew
    return subprocess.run([sys.executable, "-c", script, str(root)], env=env, cwd=root,
                          capture_output=True, text=True, timeout=1200)


def test_a_per_orbit_measure_added_by_the_recipe_reaches_everything(tmp_path):
    root = tmp_path / "copy"
    root.mkdir()
    _copy_with_toy(root)
    before = _run(DOCS_ONLY, root, tmp_path)
    assert before.stdout.strip() == "docs check failed", before.stdout + before.stderr
    doc = root / "docs" / "dataset.md"
    anchor = "| `peak_force` |"
    text = doc.read_text()
    assert anchor in text
    doc.write_text(text.replace(anchor, TOY_DOC_ROW + anchor))
    r = _run(CHECK, root, tmp_path)
    assert r.returncode == 0 and r.stdout.strip().endswith("recipe holds"), r.stdout + r.stderr
