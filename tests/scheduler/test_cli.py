"""The command line: exit codes (2 and nothing written on bad input), dry runs, status, plot."""
from __future__ import annotations

from pathlib import Path
import json
import os
import subprocess

import pytest
import zarr

from scheduler.cli import main
from scheduler.store import store_status
from study.spec import MAX_GRID_POINTS
from tests.helpers import (hertzmap_cmd, placeholder_run, placeholder_study, subprocess_env, write_results)


def test_cli_plot(hand, tmp_path):
    from scheduler.cli import main

    store = write_results(hand, tmp_path / "c.zarr")
    out = tmp_path / "figs"
    assert main(["plot", str(store), "--out", str(out), "--which", "map"]) == 0
    assert (out / "t_map.png").is_file()
    assert main(["plot", "--paper", "fig04", "--out", str(out)]) == 0
    assert (out / "paper_fig04.png").is_file()
    assert main(["plot", "--out", str(out)]) == 2
    assert main(["plot", str(tmp_path / "nope.zarr")]) == 2
    assert main(["plot", "--paper", "fig99"]) == 2


MINIMAL = """
[grid]
omega = {start = 0.5, stop = 2.5, num = 5}
sigma = [0.1, 0.2]
zeta = 0.01
"""


def with_grid(omega="[1.0]", sigma="[0.1]", zeta="[0.01]", extra="") -> str:
    return f"[grid]\nomega = {omega}\nsigma = {sigma}\nzeta = {zeta}\n{extra}"


# -- validation errors name the field and the allowed range ------------------------------------

BAD = [
    # (text, field in the message, words of the allowed range)
    (with_grid(omega="[0.0]"), "grid.omega[0]", "> 0"),
    (with_grid(omega="[-1.0, 1.0]"), "grid.omega[0]", "> 0"),
    (with_grid(sigma="[-0.1]"), "grid.sigma[0]", ">= 0"),
    (with_grid(zeta="-0.5"), "grid.zeta", ">= 0"),
    (with_grid(omega="[nan]"), "grid.omega[0]", "finite"),
    (with_grid(omega="[inf]"), "grid.omega[0]", "finite"),
    (with_grid(sigma='["a"]'), "grid.sigma[0]", "number"),
    (with_grid(omega="[]"), "grid.omega", "at least one"),
    (with_grid(omega="[1.0, 2.0, 1.0]"), "grid.omega", "duplicated"),
    (with_grid(sigma="{start = 0.1, stop = 0.1, num = 3}"), "grid.sigma", "duplicated"),
    (with_grid(omega="{start = 0.5, stop = 2.0, num = 0}"), "grid.omega.num", ">= 1"),
    (with_grid(omega="{start = 0.5, stop = 2.0, num = 2.5}"), "grid.omega.num", "integer"),
    (with_grid(omega="{start = 0.5, stop = 2.0, num = 1}"), "grid.omega.num", "ambiguous"),
    (with_grid(omega="{start = 0.5, num = 3}"), "grid.omega.stop", "missing"),
    (with_grid(omega="{start = 0.0, stop = 2.0, num = 3}"), "grid.omega.start", "> 0"),
    (with_grid(omega="{start = 0.5, stop = 2.0, num = 3, step = 1}"), "grid.omega.step", "unknown key"),
    (with_grid(omega='"1.0"'), "grid.omega", "expected a number"),
    ("[grid]\nomega = [1.0]\nsigma = [0.1]\n", "grid.zeta", "missing"),
    ("[grid]\nomega = [1.0]\nsigma = [0.1]\nzeta = [0.1]\ntheta = [1.0]\n", "grid.theta", "unknown key"),
    ("[study]\nname = 'x'\n", "grid", "missing required table"),
    (with_grid(omega="{start = 0.1, stop = 10.0, num = 5000}",
               sigma="{start = 0.1, stop = 1.0, num = 5000}"), "grid", str(MAX_GRID_POINTS)),
    (with_grid(extra='[model]\nkind = "linear"\n'), "model.kind", "'hertz', 'taylor'"),
    (with_grid(extra="[model]\nexponent = 0.0\n"), "model.exponent", "0 < exponent <= 3"),
    (with_grid(extra="[model]\nexponent = 3.5\n"), "model.exponent", "0 < exponent <= 3"),
    (with_grid(extra='[model]\nkind = "taylor"\nexponent = 1.5\n'), "model.exponent", "only allowed"),
    (with_grid(extra="[solver]\nrtol = 1e-3\n"), "solver.rtol", "1e-13 <= rtol <= 0.0001"),
    (with_grid(extra="[solver]\nrtol = 1e-15\n"), "solver.rtol", "1e-13 <= rtol <= 0.0001"),
    (with_grid(extra="[solver]\nmax_solutions = 0\n"), "solver.max_solutions", "1..16"),
    (with_grid(extra="[solver]\nmax_solutions = 17\n"), "solver.max_solutions", "1..16"),
    (with_grid(extra="[solver]\nmax_solutions = true\n"), "solver.max_solutions", "1..16"),
    (with_grid(extra="[solver]\natol = 1e-9\n"), "solver.atol", "unknown key"),
    (with_grid(extra="[search]\nperiods = [3]\n"), "search.periods", "[1, 2]"),
    (with_grid(extra="[search]\nperiods = []\n"), "search.periods", "non-empty"),
    (with_grid(extra="[search]\nperiods = [1, 1]\n"), "search.periods", "duplicated"),
    (with_grid(extra='[products]\noutputs = ["orbits", "movies"]\n'), "products.outputs", "measures"),
    (with_grid(extra='[products]\noutputs = "orbits"\n'), "products.outputs", "list"),
    (with_grid(extra='[study]\nname = "a b"\n'), "study.name", "letters, digits"),
    (with_grid(extra='[study]\nowner = "me"\n'), "study.owner", "unknown key"),
    (with_grid(extra="[rig]\nE = 2e11\nnu = 0.3\nR = 0.01\nm = 1.0\n"), "rig.N", "missing"),
    (with_grid(extra="[rig]\nE = -2e11\nnu = 0.3\nR = 0.01\nm = 1.0\nN = 10\n"), "rig.E", "> 0"),
    (with_grid(extra="[rig]\nE = 2e11\nnu = 0.6\nR = 0.01\nm = 1.0\nN = 10\n"), "rig.nu", "0.5"),
    (with_grid(extra='[rig]\nE = 2e11\nnu = 0.3\nR = 0.01\nm = 1.0\nN = 10\ncontact = "triple"\n'),
     "rig.contact", "'double', 'single'"),
    (with_grid(extra="[cluster]\nworkers = 4\n"), "cluster", "unknown key"),
    ("[grid\nomega = 1", "toml", "not valid TOML"),
]


# -- the CLI: exit code 2, message on stderr, nothing on disk -----------------------------------

def _tree(path: Path) -> set[str]:
    return {str(p.relative_to(path)) for p in path.rglob("*")}


def test_cli_invalid_study_exits_2_and_writes_nothing(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    p = tmp_path / "bad.toml"
    p.write_text(with_grid(omega="[0.0, 1.0]"))
    before = _tree(tmp_path)
    assert main(["run", str(p)]) == 2
    err = capsys.readouterr().err
    assert "grid.omega[0]" in err and "> 0" in err
    assert _tree(tmp_path) == before           # no results/, no store, no lock


def test_cli_dry_run_writes_nothing(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    p = tmp_path / "ok.toml"
    p.write_text(MINIMAL)
    before = _tree(tmp_path)
    assert main(["run", str(p), "--dry-run", "--workers", "3"]) == 0
    out = capsys.readouterr().out
    assert "10 points" in out and "tasks" in out and "results/ok.zarr" in out
    assert "3 single-threaded worker processes" in out
    assert _tree(tmp_path) == before


def test_cli_subprocess_exit_code_2(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text(with_grid(extra="[solver]\nrtol = 1.0\n"))
    r = subprocess.run(hertzmap_cmd("run", str(p)), cwd=tmp_path, env=subprocess_env(),
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2
    assert "solver.rtol" in r.stderr and "1e-13 <= rtol <= 0.0001" in r.stderr
    assert sorted(os.listdir(tmp_path)) == ["bad.toml"]


def test_cli_bad_options_exit_2(tmp_path, capsys):
    p = tmp_path / "ok.toml"
    p.write_text(MINIMAL)
    assert main(["run", str(p), "--workers", "0", "--store", str(tmp_path / "s.zarr")]) == 2
    assert main(["run", str(p), "--cluster-option", "queue=x", "--store", str(tmp_path / "s.zarr")]) == 2
    with pytest.raises(SystemExit) as info:
        main(["run", str(p), "--cluster", "nope"])
    assert info.value.code == 2
    assert not (tmp_path / "s.zarr").exists()


def test_status_command(tmp_path, client, capsys):
    path = tmp_path / "e.zarr"
    placeholder_run(path, client)
    info = store_status(path)
    assert info["tasks_done"] == info["tasks_total"] > 1
    assert info["hertzmap_study_name"] == "store-test"
    assert info["hertzmap_study_hash"] == placeholder_study().hash
    assert info["versions"]["zarr"] == zarr.__version__
    assert main(["status", str(path)]) == 0
    out = capsys.readouterr().out
    assert "store-test" in out and f"{info['tasks_total']}/{info['tasks_total']} done" in out
    assert placeholder_study().hash in out and "xarray" in out
    assert main(["status", str(path), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["tasks_done"] == info["tasks_total"]
    assert main(["status", str(tmp_path / "nope.zarr")]) == 2
