"""A/B of two kernel versions in one process: the working tree's kernels/ against a git revision.

    .venv/bin/python benchmarks/ab_kernels.py 40b705d          (about 2 minutes, two compiles)

The revision's kernels/ is extracted into a temporary package ``kernels_ab`` (imports renamed)
and both versions solve the cases of benchmarks/bench_kernels.py from the same guess, 64
identical solves per call, 16 rounds in ABBA order (on this VM, whichever version runs second
in a round was 2-4 % faster with identical code). Printed per case: the fastest round of each,
their ratio (> 1: the working tree is faster) and the median of the paired per-round ratios;
then the step evaluations of one period map from the orbit (accepted, rejected, partial steps
of event location) for each version. Code layout alone moves a build by up to ~4 %: smaller
differences are not findings. Run it against HEAD with a clean tree to see the noise floor.
"""
from __future__ import annotations

import argparse
import importlib
import inspect
import os
import re
import subprocess
import sys
import tempfile
import time
from math import pi
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench_kernels import CASES  # noqa: E402  (same directory)

# the rtol bench_kernels picks for each case (start-point error <= 1e-8)
RTOL = {"1T in contact": 3e-8, "1T primary resonance": 2e-8, "1T long flights (60%)": 5e-8,
        "2T contact loss": 2e-9, "2T in contact": 1e-8, "1T impacts n=1": 2e-8}
EXPONENT = {"1T impacts n=1": 1.0}


def extract(rev: str, into: Path) -> str:
    """kernels/ of ``rev`` as the package ``kernels_ab`` under ``into``; returns its name."""
    pkg = into / "kernels_ab"
    pkg.mkdir()
    # every file of the tree, subpackages (kernels/continuation/) included
    files = subprocess.run(["git", "-C", str(ROOT), "ls-tree", "-r", "--name-only",
                            f"{rev}:kernels"],
                           capture_output=True, text=True, check=True).stdout.split()
    for name in files:
        if not name.endswith(".py"):
            continue
        src = subprocess.run(["git", "-C", str(ROOT), "show", f"{rev}:kernels/{name}"],
                             capture_output=True, text=True, check=True).stdout
        # the installed name (hertzmap.kernels) and the repo-relative one of older revisions
        src = re.sub(r"\bfrom (hertzmap\.)?kernels\b", "from kernels_ab", src)
        src = re.sub(r"\bimport (hertzmap\.)?kernels\b", "import kernels_ab", src)
        (pkg / name).parent.mkdir(parents=True, exist_ok=True)
        (pkg / name).write_text(src)
    sys.path.insert(0, str(into))
    return "kernels_ab"


def step_counts(pkg: str, x0, omega, sigma, zeta, m, n, rtol) -> tuple[int, int, int]:
    """(accepted, rejected, partial) steps of one period map from x0, with the step sizes a
    Newton run would carry over from the previous map."""
    integ = importlib.import_module(f"{pkg}.integrate")
    P = m * 2 * pi / omega
    stats = np.zeros(integ.N_STATS)
    partial = getattr(integ, "S_PARTIAL", None)
    h = min(0.1, P / 16)
    for _ in range(2):
        keep = stats[integ.S_H_RECONTACT]
        h = stats[integ.S_H_FIRST] if stats[integ.S_H_FIRST] > 0 else h
        stats[:] = 0.0
        stats[integ.S_H_RECONTACT] = keep
        y = np.array([x0[0], x0[1], 1.0, 0.0, 0.0, 1.0])
        integ.integrate(y, 0.0, P, omega, sigma, zeta, n, 0, rtol, rtol, h, 200_000, True, False,
                        False, P, np.zeros((2, integ.N_HARMONICS + 1)), np.empty(0),
                        np.empty((3, 0)), stats, np.empty(6), np.empty(6), np.empty(6),
                        np.empty((16, 2)), np.empty((7, 2)))
    return (int(stats[integ.S_ACCEPTED]), int(stats[integ.S_REJECTED]),
            int(stats[partial]) if partial is not None else -1)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rev", help="git revision whose kernels/ is the baseline (A)")
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        os.environ.setdefault("NUMBA_CACHE_DIR", str(Path(tmp) / "numba"))
        pkg_a = extract(a.rev, Path(tmp))
        from hertzmap.kernels import shoot
        from hertzmap.kernels.shooting import N_FIELDS, shoot_batch_into as new_into
        old_into = importlib.import_module(f"{pkg_a}.shooting").shoot_batch_into
        print(f"A = kernels/ of {a.rev}, B = the working tree; ratio A/B > 1: B is faster")
        for name, omega, sigma, zeta, m, guess in CASES:
            n, rtol = EXPONENT.get(name, 1.5), RTOL[name]
            ref = shoot(omega, sigma, zeta, period=m, guess=guess, exponent=n, rtol=1e-13)
            k = 64
            full = lambda v: np.full(k, v, dtype=np.float64)  # noqa: E731
            head = (full(omega), full(sigma), full(zeta), np.full(k, m, dtype=np.int64),
                    full(ref.x0[0] + 1e-2), full(ref.x0[1] + 1e-2), n, 0, rtol, rtol, 40)
            tail = (200_000, False, np.empty((k, N_FIELDS)))
            # kernels before the stall_ratio argument take one argument fewer
            args = {fn: head + ((1.0,) if "stall_ratio" in inspect.signature(
                fn.py_func).parameters else ()) + tail for fn in (old_into, new_into)}
            old_into(*args[old_into])
            new_into(*args[new_into])
            t_a, t_b = [], []
            for r in range(16):
                pair = ((old_into, t_a), (new_into, t_b))
                for fn, out in (pair if r % 2 == 0 else pair[::-1]):
                    t0 = time.perf_counter()
                    for _ in range(5):
                        fn(*args[fn])
                    out.append((time.perf_counter() - t0) / 5 / k * 1e6)
            t_a, t_b = np.array(t_a), np.array(t_b)
            counts = [step_counts(p, ref.x0, omega, sigma, zeta, m, n, rtol)
                      for p in (pkg_a, "kernels")]
            print(f"{name:24s} A {t_a.min():6.1f} us  B {t_b.min():6.1f} us  ratio "
                  f"{t_a.min() / t_b.min():.2f} (paired median {np.median(t_a / t_b):.2f});  "
                  f"steps per map (accepted, rejected, partial; -1: not counted) "
                  f"A {counts[0]}  B {counts[1]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
