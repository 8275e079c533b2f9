"""``hertzmap fit`` (scheduler.stages.fit_tasks, study.identify): a synthetic measurement made by the
scipy oracle (benchmarks/oracle_sweep.py: no code of kernels/ or study/) at known parameters,
with a stated seed and noise, fitted through the command line: the truth within the 95 %
intervals, every point on the oracle's branch; and every kind of bad input refused with exit
code 2, its row and column (or field) named, nothing written."""
from __future__ import annotations

import csv

import numpy as np
import pytest
import xarray as xr

from benchmarks.oracle_sweep import measured_sweeps
from hertzmap.scheduler.doors.cli import main

#: the truth: the paper's Fig. 12 conditions near the order-2 subharmonic resonance, where the
#: up sweep flips 1T -> 2T (omega 1.9856) and falls back at the 2T fold (2.0124), the down
#: sweep flips 1T -> 2T at 2.0124 (the hysteresis); 21 steps a direction over 505 .. 565 Hz
TRUTH = {"f0": 271.0, "sigma": 0.3, "zeta": 0.005}
NOISE = {"a": 0.03, "b": 0.05}
SEED = 1
N = 69.7
RIG = """\
[rig]
N = 69.7
f0 = 271.0
f0_tolerance = 0.03
[excitation]
sigma = 0.3
tolerance = 0.2
[damping]
bounds = [0.002, 0.02]
"""


def write_csv(path, rows, header="frequency_hz,direction,H1_N,H2_N,H1_2_N"):
    with open(path, "w", newline="") as fh:
        fh.write("# made by tests/scheduler/stages/test_fit_tasks.py\n" + header + "\n")
        w = csv.writer(fh)
        for r in rows:
            w.writerow(r)
    return path


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    """(csv, rig, clean): the oracle's measurement (seed 1, a = 3 %, b = 0.05 N)."""
    folder = tmp_path_factory.mktemp("fit")
    rows, clean = measured_sweeps(np.linspace(505.0, 565.0, 21), N=N, seed=SEED, **TRUTH,
                                  **NOISE)
    path = write_csv(folder / "flip.csv", [[r["frequency_hz"], r["direction"], r["H1_N"],
                                            r["H2_N"], r["H1_2_N"]] for r in rows])
    rig = folder / "rig.toml"
    rig.write_text(RIG)
    return path, rig, clean


def test_the_fit_recovers_the_oracles_parameters_within_their_intervals(measured, tmp_path,
                                                                        capsys):
    path, rig, clean = measured
    out = tmp_path / "out"
    assert main(["fit", str(path), "--rig", str(rig), "--out", str(out), "--in-process"]) == 0
    printed = capsys.readouterr().out
    assert "95 % interval" in printed and "not identified" not in printed
    ds = xr.load_dataset(out / "flip_fit.nc")
    assert (out / "flip_fit.png").stat().st_size > 10_000
    for name in ds.variables:
        if name not in ds.dims:
            assert {"long_name", "units"} <= set(ds[name].attrs), name
    for i, name in enumerate(ds["parameter"].values):
        lo, hi = float(ds["lower"][i]), float(ds["upper"][i])
        assert bool(ds["identified"][i]) and lo < float(ds["estimate"][i]) < hi, name
        assert lo <= TRUTH[name] <= hi, (name, lo, hi)
    # every measured step on the branch the oracle's sweep was on there (1T or 2T)
    assert np.array_equal(ds["model_period"].values, [c["period"] for c in clean])
    # the noise model recovered within a factor 1.5 (186 readings)
    assert 0.02 < float(ds["noise_multiplicative"]) < 0.045
    assert 0.033 < float(ds["noise_floor"]) < 0.075
    # the model's jumps beside the measured ones: the up sweep's flip and fold, the down
    # sweep's flip, each inside the measured bracket of its direction
    model = ds["model_jump_hz"].values
    located = np.isin(ds["model_jump_kind"].values, (1, 2))
    ok = np.isfinite(model) & np.isfinite(ds["measured_jump_before_hz"].values) & located
    assert ok.sum() == 3 == located.sum()
    lo = np.minimum(ds["measured_jump_before_hz"].values, ds["measured_jump_after_hz"].values)
    hi = np.maximum(ds["measured_jump_before_hz"].values, ds["measured_jump_after_hz"].values)
    assert np.all((lo[ok] <= model[ok]) & (model[ok] <= hi[ok]))


def _bad_inputs(path, rig):
    """(label, csv text or None, rig text or None, row, column or field, message)."""
    text = path.read_text()
    lines = text.splitlines()
    header = lines[1]
    row3 = lines[4].split(",")

    def with_row3(cells):
        return "\n".join(lines[:4] + [",".join(cells)] + lines[5:]) + "\n"

    return [
        ("unknown column", text.replace(",H2_N", ",H3_N"), None, None, "'H3_N'",
         "unknown column"),
        ("missing column", "\n".join(lines[:1] + [header.replace(",H1_2_N", "")
                                                  .replace(",H2_N", "")]
                                     + [",".join(r.split(",")[:3]) for r in lines[2:]]) + "\n",
         None, None, "H2_N", "missing"),
        ("non-numeric", with_row3(row3[:2] + ["12x"] + row3[3:]), None, "row 3 (line 5)",
         "column H1_N", "'12x' is not a number"),
        ("unknown direction", with_row3(row3[:1] + ["upward"] + row3[2:]), None, "row 3",
         "column direction", "'upward' is not a direction"),
        ("not monotone", with_row3(["500.0"] + row3[1:]), None, "row 3", "column frequency_hz",
         "does not increase"),
        ("negative amplitude", with_row3(row3[:3] + ["-0.5"] + row3[4:]), None, "row 3",
         "column H2_N", "is negative"),
        ("rig table", None, RIG.replace("tolerance = 0.2", "tolerance = 2.0"), None,
         "excitation.tolerance", "give 0.01 <= tolerance <= 0.9"),
    ]


def test_every_bad_input_exits_2_names_its_row_and_column_and_writes_nothing(measured,
                                                                            tmp_path, capsys):
    path, rig, _ = measured
    for label, csv_text, rig_text, row, column, message in _bad_inputs(path, rig):
        bad_csv = tmp_path / "bad.csv"
        bad_csv.write_text(csv_text if csv_text is not None else path.read_text())
        bad_rig = tmp_path / "bad.toml"
        bad_rig.write_text(rig_text if rig_text is not None else RIG)
        out = tmp_path / f"out_{label.replace(' ', '_')}"
        code = main(["fit", str(bad_csv), "--rig", str(bad_rig), "--out", str(out),
                     "--in-process"])
        err = capsys.readouterr().err
        assert code == 2, (label, err)
        assert err.startswith("hertzmap: error: fit: "), (label, err)
        assert "Traceback" not in err
        for word in (row, column, message):
            if word is not None:
                assert word in err, (label, word, err)
        assert not out.exists(), label
    # the frequency the model cannot cover: named with the f0 bounds and the omega range
    bad_csv = tmp_path / "far.csv"
    lines = path.read_text().splitlines()
    cells = lines[-1].split(",")
    bad_csv.write_text("\n".join(lines[:-1] + [",".join(["50.0"] + cells[1:])]) + "\n")
    assert main(["fit", str(bad_csv), "--rig", str(rig), "--out", str(tmp_path / "o"),
                 "--in-process"]) == 2
    err = capsys.readouterr().err
    assert f"row 42 (line {len(lines)}), column frequency_hz: 50 Hz is omega = f / f0 = " in err
    assert "the model covers 0.25 <= omega <= 4" in err and not (tmp_path / "o").exists()


def test_the_dask_mapper_runs_a_batch_of_tasks_in_order_on_a_client(client, measured):
    from hertzmap.scheduler.stages.fit_tasks import DaskMapper, load_inputs

    path, rig, _ = measured
    _, _, problem = load_inputs(path, rig)
    specs = [{"kind": "forward", "problem": problem, "theta": (s, 0.005, 1.5)}
             for s in (0.25, 0.3)]
    out = DaskMapper(client, err=open("/dev/null", "w"))("forward models", specs)
    assert [r["model"].sigma for r in out] == [0.25, 0.3]
    assert all(r["seconds"] > 0 for r in out)
