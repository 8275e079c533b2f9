"""A/B of two kernel versions in one process: the working tree's kernels/ against a git revision,
timed, or checked bit for bit.

    .venv/bin/python benchmarks/ab_kernels.py 40b705d          (timing: about 2 minutes, two compiles)
    .venv/bin/python benchmarks/ab_kernels.py 40b705d --identical      (bits: about 40 s)
    .venv/bin/python benchmarks/ab_kernels.py --save-block FILE.npz
    .venv/bin/python benchmarks/ab_kernels.py --compare A.npz B.npz

The revision's kernels/ is extracted into a temporary package ``kernels_ab`` (imports renamed)
and loaded beside the working tree's.

**Timing** (the default): both versions solve the cases of benchmarks/bench_kernels.py from the
same guess, 64 identical solves per call, 5 calls per run, 16 rounds in ABBA order through
benchmarks/abba.py (on this VM, whichever version runs second in a round was 2-4 % faster with
identical code). Printed per case: the fastest run of each, their ratio (> 1: the working tree
is faster) and the median and spread of the ratios round by round; then the step evaluations
of one period map from the orbit (accepted, rejected, partial steps of event location) for
each version. Code layout alone moves a build by up to ~4 %: smaller differences are not
findings. Run it against HEAD with a clean tree to see the noise floor.

**Bits** (``--identical``; for changes meant not to move a single bit: inlining, code layout,
before any timing): both versions solve the six cases from three perturbed guesses each
(seeded) at rtol 1e-6, 1e-8 and 1e-10: start point, min/max q, flight fraction, steps and
multipliers must be equal to the last bit. ``--save-block``: solve a 1,200-point grid block
(400 omega x sigma 0.3, 0.6, 0.9, zeta 0.01, 1T and 2T seeds) with this tree's
``study.block.solve_block`` and save every variable; run it in a worktree of the other commit
too (PYTHONPATH and NUMBA_CACHE_DIR as in benchmarks/archive/block_time.py), then ``--compare``
the two files.
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
from math import pi
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.abba import abba  # noqa: E402
from benchmarks.bench_kernels import CASES  # noqa: E402

# the rtol bench_kernels picks for each case (start-point error <= 1e-8)
RTOL = {"1T in contact": 3e-8, "1T primary resonance": 2e-8, "1T long flights (60%)": 5e-8,
        "2T contact loss": 2e-9, "2T in contact": 1e-8, "1T impacts n=1": 2e-8}
EXPONENT = {"1T impacts n=1": 1.0}
ROUNDS, CALLS, BATCH = 16, 5, 64


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


def compare_timing(rev: str) -> int:
    with tempfile.TemporaryDirectory() as tmp:
        os.environ.setdefault("NUMBA_CACHE_DIR", str(Path(tmp) / "numba"))
        pkg_a = extract(rev, Path(tmp))
        from hertzmap.kernels import shoot
        from hertzmap.kernels.shooting import N_FIELDS, shoot_batch_into as new_into
        old_into = importlib.import_module(f"{pkg_a}.shooting").shoot_batch_into
        print(f"A = kernels/ of {rev}, B = the working tree; ratio A/B > 1: B is faster")
        for name, omega, sigma, zeta, m, guess in CASES:
            n, rtol = EXPONENT.get(name, 1.5), RTOL[name]
            ref = shoot(omega, sigma, zeta, period=m, guess=guess, exponent=n, rtol=1e-13)
            full = lambda v: np.full(BATCH, v, dtype=np.float64)  # noqa: E731
            head = (full(omega), full(sigma), full(zeta), np.full(BATCH, m, dtype=np.int64),
                    full(ref.x0[0] + 1e-2), full(ref.x0[1] + 1e-2), n, 0, rtol, rtol, 40)
            tail = (200_000, False, np.empty((BATCH, N_FIELDS)))
            # kernels before the stall_ratio argument take one argument fewer
            args = {fn: head + ((1.0,) if "stall_ratio" in inspect.signature(
                fn.py_func).parameters else ()) + tail for fn in (old_into, new_into)}

            def variant(fn):
                def run(_k):
                    for _ in range(CALLS):
                        fn(*args[fn])
                return run
            res = abba({"A": variant(old_into), "B": variant(new_into)}, ROUNDS, warm_up=True)
            t_a, t_b = (np.array(res.of(v)) / CALLS / BATCH * 1e6 for v in "AB")
            ratios = res.ratios("A", "B")
            counts = [step_counts(p, ref.x0, omega, sigma, zeta, m, n, rtol)
                      for p in (pkg_a, "kernels")]
            print(f"{name:24s} A {t_a.min():6.1f} us  B {t_b.min():6.1f} us  ratio "
                  f"{t_a.min() / t_b.min():.2f} (round by round: median {np.median(ratios):.2f}, "
                  f"spread {min(ratios):.2f}-{max(ratios):.2f});  "
                  f"steps per map (accepted, rejected, partial; -1: not counted) "
                  f"A {counts[0]}  B {counts[1]}")
        lo, hi = res.loads()
        print(f"load average {lo:.1f}-{hi:.1f} over the last case's rounds")
    return 0


def compare_solves(rev: str) -> int:
    a = importlib.import_module(extract(rev, Path(tempfile.mkdtemp())))
    import hertzmap.kernels as b

    rng = np.random.default_rng(1)
    n = differ = 0
    for name, w, s, z, m, rough in CASES:
        exponent = 1.0 if "n=1" in name else 1.5
        for rtol in (1e-6, 1e-8, 1e-10):
            for _ in range(3):
                guess = (rough[0] + 0.05 * rng.standard_normal(),
                         rough[1] + 0.05 * rng.standard_normal())
                fields = []
                for mod in (a, b):
                    o = mod.shoot(w, s, z, m, guess=guess, rtol=rtol, exponent=exponent)
                    fields.append(np.array([*o.x0, o.min_q, o.max_q, o.flight_fraction, o.steps,
                                            *np.real(o.multipliers), *np.imag(o.multipliers)],
                                           float))
                n += 1
                if not np.array_equal(fields[0], fields[1], equal_nan=True):
                    differ += 1
                    print(f"differs: {name}, rtol {rtol:g}, guess {guess}: {fields[0] - fields[1]}")
    print(f"{n} solves, {differ} differ")
    return 1 if differ else 0


def save_block(path: str) -> None:
    from hertzmap.study.solve.block import solve_block

    out = solve_block(np.linspace(0.5, 2.5, 400), np.array([0.3, 0.6, 0.9]), np.array([0.01]))
    np.savez(path, **{k: np.asarray(v) for k, v in out.items()})
    print(f"wrote {path}")


def compare_blocks(p: str, q: str) -> int:
    a, b = np.load(p), np.load(q)
    differ = [k for k in a.files if not np.array_equal(a[k], b[k], equal_nan=True)]
    print(f"{len(a.files)} variables, {a[a.files[0]].size} values in the first; differing: {differ}")
    return 1 if differ else 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("rev", nargs="?", help="git revision whose kernels/ is the baseline (A)")
    ap.add_argument("--identical", action="store_true",
                    help="check the two versions' solves bit for bit instead of timing them")
    ap.add_argument("--save-block", metavar="FILE")
    ap.add_argument("--compare", nargs=2, metavar=("A", "B"))
    a = ap.parse_args(argv)
    if a.save_block:
        save_block(a.save_block)
        return 0
    if a.compare:
        return compare_blocks(*a.compare)
    if not a.rev:
        ap.error("give REV, --save-block FILE or --compare A B")
    return compare_solves(a.rev) if a.identical else compare_timing(a.rev)


if __name__ == "__main__":
    sys.exit(main())
