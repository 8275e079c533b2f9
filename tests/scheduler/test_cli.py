"""The command line: exit codes (2 and nothing written on bad input), dry runs, status, plot."""
from __future__ import annotations

from pathlib import Path
import json
import os
import subprocess

import pytest
import zarr

from hertzmap.scheduler.cli import main
from hertzmap.scheduler.store import store_status
from tests.helpers import (hertzmap_cmd, placeholder_run, placeholder_study, subprocess_env, write_results)


def test_cli_plot(hand, tmp_path):
    from hertzmap.scheduler.cli import main

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
