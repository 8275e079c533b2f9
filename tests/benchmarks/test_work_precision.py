"""The work-precision benchmark (hertzmap bench --quick) runs and writes its CSV, PNG and
same-run ratios."""
from __future__ import annotations

import csv

from benchmarks.work_precision import run_bench


def test_bench_quick_writes_csv_png_and_ratios(tmp_path):
    r = run_bench(tmp_path, quick=True, log=lambda *a: None)
    rows = list(csv.DictReader(open(r["csv"])))
    methods = {row["method"] for row in rows}
    assert methods == {"hertzmap", "paper-cd", "paper-cd-tuned", "scipy-DOP853", "scipy-Radau"}
    assert r["png"].stat().st_size > 1000
    hm = [row for row in rows if row["method"] == "hertzmap"]
    assert all(row["status"] == "converged" for row in hm)
    # tighter tolerance, smaller error (by > 10x over 1e-5 -> 1e-11) on every case
    for case in {row["case"] for row in hm}:
        e = [float(row["err_x0"]) for row in hm if row["case"] == case]
        assert e[-1] < 0.1 * e[0]
    assert r["summary"]["scipy-DOP853"][0] > 1
