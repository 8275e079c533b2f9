"""The worked example of ``hertzmap fit`` (docs/identify.md), made by the scipy oracle alone
(benchmarks/oracle_sweep.py: no code of kernels/ or study/): the paper's rig of section 4
swept up and down over 200 .. 600 Hz (paper Figs. 12-13 span 244 .. 569 Hz), 200 steps a
direction, at known parameters near the paper's: f0 = 270.6 Hz (its measured value; Hertz
theory gives 271.0 Hz), sigma = 0.33 (the lab's "about 30 %"), zeta = 0.0055 (its 0.5 %),
read with the fit's noise model (a = 3 % multiplicative, b = 0.05 N floor), seed 2026.

    PYTHONPATH=. .venv/bin/python benchmarks/make_fit_example.py     # about 2 min on one core

writes docs/examples/paper_rig_sweeps.csv (the measurement, the truth in its comment lines)
and docs/examples/paper_rig.toml (the rig table: what the lab knows, not the truth).
"""
from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np

from benchmarks.oracle_sweep import measured_sweeps

#: the truth of the worked example, and how it is measured
TRUTH = {"f0": 270.6, "sigma": 0.33, "zeta": 0.0055}
NOISE = {"a": 0.03, "b": 0.05}
N = 69.7
SEED = 2026
FREQUENCIES = np.linspace(200.0, 600.0, 200)

RIG_TABLE = """\
# The rig of paper section 4 as its lab knows it (hertzmap fit --rig, docs/identify.md):
# a 25.4 mm steel ball preloaded between two flats by the 7.1 kg cylinder's weight.
[rig]
N = 69.7              # static preload, N
m = 7.1               # moving mass, kg
E = 2.1e11            # Young's modulus, Pa
nu = 0.29
R = 0.0127            # ball radius, m
contact = "double"    # Hertz theory's f0: 271.0 Hz (paper Eq. 28-29); searched within +-10 %

[excitation]
force_N = 20.9        # the shaker's set point, "sigma of about 30 %" of the 69.7 N preload
tolerance = 0.5       # known roughly: sigma searched within 0.15 .. 0.45
"""


def write_csv(path: Path, rows: list[dict], header: list[str]) -> None:
    with open(path, "w", newline="") as fh:
        for line in header:
            fh.write(f"# {line}\n")
        w = csv.writer(fh)
        w.writerow(["frequency_hz", "direction", "H1_N", "H2_N", "H1_2_N"])
        for r in rows:
            w.writerow([f"{r['frequency_hz']:.4f}", r["direction"], f"{r['H1_N']:.6g}",
                        f"{r['H2_N']:.6g}", f"{r['H1_2_N']:.6g}"])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=Path("docs/examples"))
    args = p.parse_args()
    t0 = time.perf_counter()
    rows, clean = measured_sweeps(FREQUENCIES, N=N, seed=SEED, **TRUTH, **NOISE)
    args.out.mkdir(parents=True, exist_ok=True)
    header = ["hertzmap fit's worked example (docs/identify.md), made by "
              "benchmarks/make_fit_example.py with the scipy oracle (benchmarks/oracle_sweep.py)",
              f"truth: f0 = {TRUTH['f0']} Hz, sigma = {TRUTH['sigma']}, zeta = {TRUTH['zeta']}, "
              f"n = 3/2, N = {N} N; noise: |m + sd e|, sd = sqrt((a m)^2 + b^2), "
              f"a = {NOISE['a']}, b = {NOISE['b']} N, numpy default_rng({SEED})",
              "quasi-static stepped sweeps up then down, 200 steps each over 200 .. 600 Hz; "
              "amplitudes are peak values of the transmitted force's harmonics, N"]
    write_csv(args.out / "paper_rig_sweeps.csv", rows, header)
    (args.out / "paper_rig.toml").write_text(RIG_TABLE)
    periods = [c["period"] for c in clean]
    print(f"{len(rows)} steps in {time.perf_counter() - t0:.0f} s; periods of the responses: "
          f"{dict(zip(*np.unique(periods, return_counts=True)))}")
    print(f"{args.out / 'paper_rig_sweeps.csv'}\n{args.out / 'paper_rig.toml'}")


if __name__ == "__main__":
    main()
