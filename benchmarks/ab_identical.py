"""Are two kernel versions bit-identical? For changes meant not to move a single bit (inlining,
code layout), before any timing.

    .venv/bin/python benchmarks/ab_identical.py REV              (about 40 s, two compiles)
    .venv/bin/python benchmarks/ab_identical.py --save-block FILE.npz
    .venv/bin/python benchmarks/ab_identical.py --compare A.npz B.npz

REV: the revision's kernels/ is loaded beside the working tree's (as in
benchmarks/ab_kernels.py), and both solve the six cases of benchmarks/bench_kernels.py from
three perturbed guesses each (seeded) at rtol 1e-6, 1e-8 and 1e-10: start point, min/max q,
flight fraction, steps and multipliers must be equal to the last bit. ``--save-block``: solve
a 1,200-point grid block (400 omega x sigma 0.3, 0.6, 0.9, zeta 0.01, 1T and 2T seeds) with
this tree's ``study.block.solve_block`` and save every variable; run it in a worktree of the
other commit too (PYTHONPATH and NUMBA_CACHE_DIR as in benchmarks/archive/block_time.py), then
``--compare`` the two files.
"""
from __future__ import annotations

import argparse
import importlib
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))


def compare_solves(rev: str) -> int:
    from ab_kernels import extract
    from bench_kernels import CASES

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
    ap.add_argument("rev", nargs="?")
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
    return compare_solves(a.rev)


if __name__ == "__main__":
    sys.exit(main())
