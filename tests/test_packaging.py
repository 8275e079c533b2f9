"""What a user who installs hertzmap the ordinary way gets: a wheel built from this checkout holds
one top-level name, hertzmap, with every package folder of the repo (explore included) and the
scenes as package data, and nothing else (no benchmarks, no tests); installed in a new venv,
it runs a small study, lists the scenes and explains explore from a folder outside the repo.
And the lock: uv.lock was written for this pyproject.toml's dependencies.

The wheel is built by uv (the version scripts/uv.sh names) and installed with the lock's
versions (uv export), so the venv is the one a user of this checkout gets."""
from __future__ import annotations

import os
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest
from packaging.requirements import Requirement

from tests.helpers import REPO

PACKAGE = "hertzmap"
#: the repo's folders the wheel maps under hertzmap: folder -> installed name below hertzmap
#: ("" for the package's own folder; pyproject.toml's package-dir, read from there)
FOLDERS = {folder: name.removeprefix(PACKAGE).removeprefix(".") for name, folder in
           tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
           ["package-dir"].items()}

SMALL_STUDY = """
[study]
name = "small"
[grid]
omega = {start = 1.5, stop = 2.1, num = 4}
sigma = [0.3, 0.5]
zeta = [0.01]
[search]
periods = [1, 2]
attractors = "never"        # fewer kernels to compile cold in the new venv
[products]
outputs = ["orbits", "measures"]
"""


def _uv() -> str:
    return subprocess.run(["bash", str(REPO / "scripts" / "uv.sh")], capture_output=True,
                          text=True, check=True).stdout.strip()


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("wheel")
    r = subprocess.run([_uv(), "build", "--wheel", "--out-dir", str(out), str(REPO)],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    (found,) = out.glob("*.whl")
    return found


def test_the_wheel_holds_one_name_every_package_and_the_scenes(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split("/")[0] for n in names if not n.split("/")[0].endswith(".dist-info")}
    assert tops == {PACKAGE}, tops
    expected = set()
    for folder, installed in FOLDERS.items():
        for module in (REPO / folder).rglob("*.py"):
            # a module installs under the most specific folder that maps it
            owner = max((f for f in FOLDERS if module.is_relative_to(REPO / f)), key=len)
            if owner != folder:
                continue
            rel = module.relative_to(REPO / folder)
            expected.add("/".join((PACKAGE, *filter(None, installed.split(".")), *rel.parts)))
    scenes = {f"{PACKAGE}/scenes/{p.name}" for p in (REPO / "scenes").glob("*.toml")}
    assert len(scenes) >= 10
    missing = (expected | scenes) - set(names)
    assert not missing, sorted(missing)
    assert f"{PACKAGE}/scheduler/doors/explore/page.py" in names
    assert f"{PACKAGE}/__init__.py" in names          # import hertzmap: the front door
    assert not any("package_root" in n for n in names)
    assert not any("/benchmarks/" in n or "/tests/" in n for n in names)


@pytest.mark.slow
def test_the_installed_wheel_runs_a_study_from_outside_the_repo(wheel, tmp_path):
    uv = _uv()
    venv = tmp_path / "venv"
    constraints = tmp_path / "constraints.txt"
    env = dict(os.environ, UV_PYTHON_DOWNLOADS="never")
    env.pop("PYTHONPATH", None)
    run = dict(capture_output=True, text=True, timeout=600, env=env)
    r = subprocess.run([uv, "export", "--locked", "--no-emit-project", "--no-hashes",
                        "--project", str(REPO), "-o", str(constraints)], **run)
    assert r.returncode == 0, r.stderr[-3000:]
    r = subprocess.run([uv, "venv", "--python", sys.executable, str(venv)], **run)
    assert r.returncode == 0, r.stderr[-3000:]
    r = subprocess.run([uv, "pip", "install", "--python", str(venv / "bin" / "python"),
                        str(wheel), "-c", str(constraints)], **run)
    assert r.returncode == 0, r.stderr[-3000:]
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "small.toml").write_text(SMALL_STUDY)
    hertzmap = str(venv / "bin" / "hertzmap")
    run["cwd"] = elsewhere

    r = subprocess.run([hertzmap, "scenes"], **run)
    assert r.returncode == 0, r.stderr
    assert {line.split()[0] for line in r.stdout.splitlines()} >= {"default", "vibro_impact"}
    r = subprocess.run([hertzmap, "explore", "--help"], **run)
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    assert "usage: hertzmap explore" in r.stdout
    r = subprocess.run([hertzmap, "run", "default", "--dry-run"], **run)
    assert r.returncode == 0, r.stderr
    r = subprocess.run([hertzmap, "run", "small.toml", "--workers", "1", "--error-sample", "0"],
                       **run)
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stdout + r.stderr
    check = ("import xarray as xr, hertzmap.kernels as k; "
             "ds = xr.open_zarr('results/small.zarr'); "
             "assert k.__file__.startswith(%r), k.__file__; "
             "print(int((ds.period > 0).sum()))" % str(venv))
    r = subprocess.run([str(venv / "bin" / "python"), "-c", check], **run)
    assert r.returncode == 0, r.stderr
    assert int(r.stdout) >= 8          # at least the 1T orbit at each of the 8 points
    # the library's front door, installed: the same store as a DataTree
    check = ("import hertzmap; t = hertzmap.open('results/small.zarr'); "
             "assert hertzmap.__file__.startswith(%r), hertzmap.__file__; "
             "print(int((t['period'] > 0).sum()))" % str(venv))
    r = subprocess.run([str(venv / "bin" / "python"), "-c", check], **run)
    assert r.returncode == 0, r.stderr
    assert int(r.stdout) >= 8


def _requirements(items) -> dict[str, str]:
    out = {}
    for item in items:
        req = Requirement(item)
        marker = str(req.marker) if req.marker else ""
        out[f"{req.name}{sorted(req.extras)}{marker}"] = str(req.specifier)
    return out


def test_the_lock_was_written_for_this_pyproject():
    """uv.lock records the dependencies it was resolved for: they must be pyproject.toml's (the
    CI step `bash scripts/lock.sh --check` also resolves them again)."""
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    lock = tomllib.loads((REPO / "uv.lock").read_text())
    (me,) = [p for p in lock["package"] if p["name"] == PACKAGE]
    wanted = _requirements(project["dependencies"])
    for extra, items in project["optional-dependencies"].items():
        wanted.update(_requirements(f"{i}; extra == '{extra}'" for i in items))
    locked = {}
    for d in me["metadata"]["requires-dist"]:
        extras = f"[{','.join(d['extras'])}]" if d.get("extras") else ""
        item = f"{d['name']}{extras}{d.get('specifier', '')}"
        locked.update(_requirements([item + (f"; {d['marker']}" if d.get("marker") else "")]))
    assert locked == wanted
    assert sorted(me["metadata"]["provides-extras"]) == sorted(project["optional-dependencies"])
