"""The command line: exit codes (2 and nothing written on bad input), dry runs, status, plot."""
from __future__ import annotations

from pathlib import Path
import json
import os
import subprocess

import pytest
import zarr

from hertzmap.scheduler.doors.cli import main
from hertzmap.scheduler.store import store_status
from tests.helpers import (hertzmap_cmd, placeholder_run, placeholder_study, subprocess_env, write_results)


def test_cli_plot(hand, tmp_path):
    from hertzmap.scheduler.doors.cli import main

    store = write_results(hand, tmp_path / "c.zarr")
    out = tmp_path / "figs"
    assert main(["plot", str(store), "--out", str(out), "--which", "map"]) == 0
    assert (out / "t_map.png").is_file()
    assert main(["plot", "--paper", "fig04", "--out", str(out)]) == 0
    assert (out / "paper_fig04.png").is_file()
    assert main(["plot", "--out", str(out)]) == 2
    assert main(["plot", str(tmp_path / "nope.zarr")]) == 2
    assert main(["plot", "--paper", "fig99"]) == 2


#: the products hertzmap plot computes on tests.helpers.EVERY_OUTPUT_STUDY given traced curves
#: (docs/products.md: all of them)
EVERY_PRODUCT = {"orbit_classes", "loss_of_contact_map", "bifurcation_curves",
                 "located_bifurcations", "mms_curves", "frequency_response", "mms_response",
                 "force_harmonics", "stroboscopic_diagram", "attractor_ids", "time_histories",
                 "isola_boundary"}


@pytest.fixture()
def every_output_store(tmp_path):
    """A small real store of every output, with the traced-curves group a run writes (made
    up)."""
    from hertzmap.scheduler.store import write_product
    from tests.helpers import EVERY_OUTPUT_STUDY, fake_traced_curves, solved_results

    store = solved_results(EVERY_OUTPUT_STUDY, tmp_path / "r.zarr")
    write_product(store, "traced_curves", fake_traced_curves())
    return store


def test_plot_writes_the_supported_products_and_draws_the_stored_groups(every_output_store,
                                                                         tmp_path, monkeypatch):
    from hertzmap.scheduler.stages import product_tasks
    from hertzmap.scheduler import store as S
    from hertzmap.study import plots

    store = every_output_store
    computed, drawn = {}, {}
    write_products, plot_results = S.write_products, plots.plot_results

    def write_and_mark(path, products):
        """Write, then mark each stored group: only a product read back carries the mark."""
        computed.update(products)
        groups = write_products(path, products)
        for name in products:
            S.write_product(path, name, S.read_product(path, name).assign_attrs(stored=name))
        return groups

    def record(ds, prods, *args, **kwargs):
        drawn.update(prods)
        return plot_results(ds, prods, *args, **kwargs)

    monkeypatch.setattr(product_tasks, "write_products", write_and_mark)
    monkeypatch.setattr(plots, "plot_results", record)
    out = tmp_path / "png"
    assert main(["plot", str(store), "--out", str(out)]) == 0
    assert set(computed) == EVERY_PRODUCT
    assert set(S.list_products(store)) == EVERY_PRODUCT | {"traced_curves"}
    assert set(drawn) == EVERY_PRODUCT | {"traced_curves"}
    assert all(drawn[name].attrs.get("stored") == name for name in EVERY_PRODUCT)
    for name in ("real_map.png", "real_bifurcation.png", "real_strobe_sigma0.3.png",
                 "real_histories.png"):
        assert (out / name).is_file(), name
    # the store, main group and every product group, opens as one DataTree: the products on
    # a grid of their own name its dims (the multiple-scales omega grid: mms_omega)
    import xarray as xr
    from hertzmap.study.products.mms import MMS_POINTS

    tree = xr.open_datatree(store, engine="zarr")
    assert set(tree.groups) == ({"/", "/products"}
                                | {f"/products/{n}" for n in EVERY_PRODUCT | {"traced_curves"}})
    mms = tree["products/mms_curves"].to_dataset(inherit=False)
    assert mms.sizes["mms_omega"] == MMS_POINTS and "omega" not in mms.dims


def test_plot_without_products_writes_nothing(every_output_store, tmp_path):
    from hertzmap.scheduler.store import list_products

    store = every_output_store
    files = {p: p.read_bytes() for p in sorted(store.rglob("*")) if p.is_file()}
    assert main(["plot", str(store), "--out", str(tmp_path / "png"), "--no-products"]) == 0
    assert {p: p.read_bytes() for p in sorted(store.rglob("*")) if p.is_file()} == files
    assert list_products(store) == ["traced_curves"]
    assert (tmp_path / "png" / "real_strobe_sigma0.3.png").is_file()


def test_plot_help_names_every_figure_and_says_what_it_draws(capsys):
    from hertzmap.study.plots import FIGURES

    with pytest.raises(SystemExit):
        main(["plot", "--help"])
    # (argparse wraps the help at hyphens: "vibro- impacts")
    text = " ".join(capsys.readouterr().out.split()).replace("- ", "-")
    assert all(f" {f.which} ({' '.join(f.help.split())})" in text for f in FIGURES)


def test_help_of_hertzmap_and_of_every_subcommand_prints_and_exits_0(capsys):
    """`hertzmap --help` lists every subcommand with its line (argparse formats those lines
    with %: the fit's "95 %" once made it raise), and each subcommand's --help prints."""
    from hertzmap.scheduler.doors.cli import SUBCOMMANDS

    with pytest.raises(SystemExit) as e:
        main(["--help"])
    assert e.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    for name, (_, _, line) in SUBCOMMANDS.items():
        assert name in text and " ".join(line.split()[:4]) in text
        with pytest.raises(SystemExit) as e:
            main([name, "--help"])
        assert e.value.code == 0, name
    assert "95 % profile-likelihood" in text


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
