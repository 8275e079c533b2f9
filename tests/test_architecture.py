"""The house: imports go scheduler -> study -> kernels and never back, no import cycle, the study
layer and the products import neither Dask nor the scheduler, argparse only in the command
line, zarr writes and locks only in scheduler.store, every concept defined once.

The import graph is read from the source (every ``import``, at module level or inside a
function), so a lazy import that runs backwards is caught as well.
"""
from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.helpers import REPO, subprocess_env

PACKAGES = ("kernels", "study", "scheduler", "benchmarks")
#: a package may import only packages of a lower rank (and itself)
RANK = {"kernels": 0, "study": 1, "scheduler": 2, "benchmarks": 3}


def _modules() -> dict[str, Path]:
    out = {}
    for pkg in PACKAGES:
        for path in sorted((REPO / pkg).rglob("*.py")):
            rel = path.relative_to(REPO).with_suffix("")
            name = ".".join(rel.parts)
            out[name.removesuffix(".__init__")] = path
    return out


MODULES = _modules()
#: the one top-level name the packages install under (pyproject.toml's package-dir)
INSTALLED = "hertzmap"


def _in_repo(module: str) -> str:
    """The repo-relative name of an installed module (``hertzmap.kernels.model`` is the
    repo's ``kernels/model.py``); other names unchanged."""
    return module.removeprefix(INSTALLED + ".")


def _imports(path: Path) -> list[tuple[str, int]]:
    """(imported module, line) for every import in the file, resolved to a module of the repo
    where the name is one (``from pkg import module``), else the imported module itself."""
    tree = ast.parse(path.read_text())
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(_in_repo(a.name), node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            module = _in_repo(node.module)
            subs = [f"{module}.{a.name}" for a in node.names]
            found = [s for s in subs if s in MODULES]
            out += [(s, node.lineno) for s in found] or [(module, node.lineno)]
    return out


GRAPH = {m: {i for i, _ in _imports(p) if i in MODULES and i != m} for m, p in MODULES.items()}


def test_every_import_goes_down_the_layers():
    wrong = []
    for m, path in MODULES.items():
        for target, line in _imports(path):
            top = target.split(".")[0]
            if top in RANK and RANK[top] > RANK[m.split(".")[0]]:
                wrong.append(f"{path.relative_to(REPO)}:{line} imports {target}")
    assert not wrong, "imports that run back up the layers:\n" + "\n".join(wrong)


def test_no_import_cycle():
    index, low, stack, on, cycles = {}, {}, [], set(), []

    def visit(v):                        # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in GRAPH[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    sys.setrecursionlimit(10_000)
    for v in GRAPH:
        if v not in index:
            visit(v)
    # a package's __init__ re-exporting its modules is not a cycle of knowledge: leave out the
    # edges from a package to its own submodules
    real = [c for c in cycles
            if any(b in GRAPH[a] and not b.startswith(a + ".") for a in c for b in c)]
    assert not real, f"import cycles: {real}"


def test_kernels_are_pure_numerics():
    allowed = {"numpy", "numba", "scipy", "kernels"} | set(sys.stdlib_module_names)
    bad = [f"{path.relative_to(REPO)}:{line} imports {t}"
           for m, path in MODULES.items() if m.startswith("kernels")
           for t, line in _imports(path) if t.split(".")[0] not in allowed]
    assert not bad, bad


def test_kernel_modules_do_not_import_the_front_door():
    """kernels.api (re-exported by kernels/__init__.py) is the kernels' interface for the layers
    above; a kernel module takes what it needs from the module that defines it (shoot from
    kernels.periodic_orbit), so that importing one kernel module does not import them all."""
    bad = [f"{path.relative_to(REPO)}:{line} imports {t}"
           for m, path in MODULES.items() if m.startswith("kernels.") and m != "kernels.api"
           for t, line in _imports(path) if t in ("kernels", "kernels.api")]
    assert not bad, bad


def test_argparse_only_in_the_command_line():
    bad = [f"{p.relative_to(REPO)}:{line}" for m, p in MODULES.items()
           if m.split(".")[0] in ("kernels", "study", "scheduler") and m != "scheduler.doors.cli"
           for t, line in _imports(p) if t == "argparse"]
    assert not bad, bad


def test_zarr_writes_and_locks_only_in_the_store_module():
    bad = []
    for m, path in MODULES.items():
        if m.split(".")[0] not in ("kernels", "study", "scheduler") or m.startswith("scheduler.store"):
            continue
        text = path.read_text()
        for needle in (".to_zarr(", "zarr.open_group(", "zarr.open(", "O_EXCL", ".lock\""):
            if needle in text:
                bad.append(f"{path.relative_to(REPO)}: {needle}")
    assert not bad, bad


@pytest.mark.parametrize("modules", ["study.spec, study.schema, study.orbit_rules, study.solve.block",
                                     "study.products, study.plots, study.analytic.rig"])
def test_study_layer_imports_neither_dask_nor_the_scheduler(modules):
    installed = ", ".join(f"{INSTALLED}.{m}" for m in modules.split(", "))
    code = (f"import sys, {installed}; "
            "bad = [m for m in sys.modules if m.split('.')[0] in "
            "('dask', 'distributed', 'zarr') or m.startswith('hertzmap.scheduler')]; "
            "print(bad); sys.exit(1 if bad else 0)")
    r = subprocess.run([sys.executable, "-c", code], env=subprocess_env(), capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr


#: the concepts defined once: each name is assigned at module level in exactly this module
ONE_DEFINITION = {
    "N_HARMONICS": "kernels.records",
    "ORBIT": "kernels.records",
    "ATTRACTOR": "kernels.records",
    "PERIOD_FLAGS": "kernels.records",
    "MODELS": "kernels.model",
    "TAYLOR_CONTACT_LOSS": "kernels.model",
    "BRANCH_STATUS": "kernels.continuation.core",
    "BRANCH_DIFFERENCE": "kernels.continuation.core",
    "PATH_DIFFERENCE": "kernels.continuation.core",
    "PATH_STALL_DIFFERENCE": "kernels.continuation.core",
    "CURVE_DIFFERENCE": "kernels.continuation.core",
    "CORRECTOR_ITERATIONS": "kernels.continuation.path",
    "VARIABLES": "study.schema",
    "BIFURCATION_SLOTS": "study.schema",
    "BIFURCATION_KINDS": "study.schema",
    "PRODUCT_GROUP": "study.schema",
    "ORBIT_CLASSES": "study.orbit_rules",
    "SAME_ORBIT_TOL": "study.orbit_rules",
    "LOCK_SUFFIX": "scheduler.store.lock",
    "DEFAULT_LAW": "kernels.model",
    "DEFAULT_EXPONENT": "kernels.model",
    "DEFAULT_RTOL": "kernels.model",
}


def _assigned(path: Path) -> set[str]:
    names = set()
    for node in ast.parse(path.read_text()).body:
        targets = node.targets if isinstance(node, ast.Assign) else (
            [node.target] if isinstance(node, ast.AnnAssign) else [])
        for t in targets:
            for n in ast.walk(t):
                if isinstance(n, ast.Name):
                    names.add(n.id)
    return names


def test_every_concept_is_defined_once():
    where: dict[str, list[str]] = {name: [] for name in ONE_DEFINITION}
    for m, path in MODULES.items():
        for name in _assigned(path) & set(ONE_DEFINITION):
            where[name].append(m)
    assert where == {name: [m] for name, m in ONE_DEFINITION.items()}


def test_numbers_of_one_concept_are_not_written_twice():
    """The Taylor model's threshold (6 - 3 sqrt 6 = -1.34847...) is written once, in
    kernels.model; the paper's printed -1.348 only in study.analytic.paper (a published value,
    kept to compare with)."""
    for m, path in MODULES.items():
        text = path.read_text()
        if m != "kernels.model":
            assert "1.3484" not in text and "3.0 * sqrt(6" not in text, m
        if m != "study.analytic.paper":
            assert not re.search(r"1\.348(?!\d)", text), m


#: a default of the model restated (kernels.model's DEFAULT_LAW, DEFAULT_EXPONENT, DEFAULT_RTOL
#: and Model are the one declaration: a signature names them, a reader takes Model.of)
RESTATED_MODEL_DEFAULT = re.compile(
    r"""\bmodel\s*(?::\s*str\s*)?=\s*["']hertz["']|\bexponent\s*(?::\s*float\s*)?=\s*1\.5\b"""
    r"""|\brtol\s*(?::\s*float\s*)?=\s*1e-10\b"""
    r"""|get\(\s*["'](?:model|exponent|rtol)["']\s*,\s*(?:["']hertz["']|1\.5|1e-10)\s*\)""")


def test_the_model_defaults_are_declared_once():
    """The contact law, exponent and tolerance a solve takes by default are declared once
    (kernels.model); no other module of the packages restates them."""
    restated = []
    for m, path in MODULES.items():
        if m == "kernels.model" or m.split(".")[0] == "benchmarks":
            continue
        for k, line in enumerate(path.read_text().splitlines(), 1):
            if RESTATED_MODEL_DEFAULT.search(line) and not line.lstrip().startswith(("#", ">>>")):
                restated.append(f"{path.relative_to(REPO)}:{k}: {line.strip()}")
    assert not restated, "\n".join(restated)


def test_every_module_is_named_in_the_architecture_doc():
    """docs/architecture.md is the map of the house: each module of the three packages (and
    each subpackage) is named there, in backticks, by its file name."""
    doc = (REPO / "docs" / "architecture.md").read_text()
    unnamed = []
    for m, path in MODULES.items():
        if m.split(".")[0] not in ("kernels", "study", "scheduler"):
            continue
        name = f"`{path.parent.name}/`" if path.name == "__init__.py" else f"`{path.name}`"
        if path.name == "__init__.py" and "." not in m:
            continue                      # the package itself: its section's heading
        if name not in doc and not re.search(rf"`{re.escape(path.stem)}\.py`", doc):
            unnamed.append(str(path.relative_to(REPO)))
    assert not unnamed, f"modules docs/architecture.md does not name: {unnamed}"


def test_no_two_modules_share_a_file_name():
    """A module is found by its name: no two modules of kernels/, study/, scheduler/ have the
    same file name, nor names that differ by a plural's s (``curve.py`` beside ``curves.py``)."""
    seen: dict[str, list[str]] = {}
    for path in MODULES.values():
        if path.name == "__init__.py":
            continue
        seen.setdefault(path.stem.removesuffix("s"), []).append(str(path.relative_to(REPO)))
    twice = {k: v for k, v in seen.items() if len(v) > 1}
    assert not twice, f"modules sharing a name: {twice}"
