"""Speed-up over the paper's scheme on the orbits a real map holds, not on hand-picked cases.

    .venv/bin/python benchmarks/speedup_sample.py [STORE] [--size 120] [--seed 0]

STORE defaults to results/default.zarr (``bash scripts/run-default.sh`` makes it). A random
sample of its converged orbits (every period, every solution slot, equal weight: the mix of the
map) is re-solved by both methods with the protocol of benchmarks/bench_kernels.py: a reference
at rtol 1e-13 from the stored start point, every method starting Newton from reference +
(1e-2, 1e-2); the paper's scheme at N = 10000 steps per period with its fair Newton tolerance
(study.benchmark.paper_scheme_xtol); hertzmap at the loosest rtol whose start-point error is
<= min(paper's error, 1e-8). Each time is the fastest of 7 rounds (hertzmap: a batch of 16
identical solves through the numba entry point the grid solver uses).

Printed: the speed-up distribution (min, 10th percentile, median, share below 30x) over the sample and per
class of orbit (period x contact loss), with each class's share of the whole store, and over
the sample against the paper's scheme tuned (kernels.central_difference.cd_shoot_tuned); sampled
orbits that either method does not bring back to the reference are counted, not timed. About
a minute for 120 orbits.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench_kernels import RTOLS, per_call  # noqa: E402  (same directory)

from hertzmap.kernels import shoot  # noqa: E402
from hertzmap.kernels.central_difference import cd_shoot, cd_shoot_tuned  # noqa: E402
from hertzmap.kernels.shooting import N_FIELDS, shoot_batch_into  # noqa: E402
from benchmarks.work_precision import paper_scheme_xtol  # noqa: E402

N_PAPER = 10_000
BATCH = 16


def sample_orbits(store: Path, size: int, seed: int):
    """(omega, sigma, zeta, period, q0, v0, loses_contact) of ``size`` converged orbits drawn
    uniformly from the store, and the class counts of the whole store."""
    import xarray as xr

    ds = xr.open_zarr(store)
    exponent = float(ds.attrs.get("exponent", 1.5))
    if ds.attrs.get("model", "hertz") != "hertz":
        raise SystemExit(f"{store}: the paper's scheme baseline needs model = hertz")
    ok = (ds.status == 0).values
    idx = np.argwhere(ok)
    cols = {v: ds[v].values[ok] for v in ("period", "q0", "v0", "loses_contact")}
    dims = ds.status.dims
    coords = {d: ds[d].values for d in ("omega", "sigma", "zeta")}
    classes = {}
    for p, lc in zip(cols["period"], cols["loses_contact"]):
        key = (int(p), bool(lc))
        classes[key] = classes.get(key, 0) + 1
    rng = np.random.default_rng(seed)
    pick = rng.choice(len(idx), size=min(size, len(idx)), replace=False)
    rows = []
    for k in pick:
        at = dict(zip(dims, idx[k]))
        rows.append((float(coords["omega"][at["omega"]]), float(coords["sigma"][at["sigma"]]),
                     float(coords["zeta"][at["zeta"]]), int(cols["period"][k]),
                     float(cols["q0"][k]), float(cols["v0"][k]), bool(cols["loses_contact"][k])))
    return rows, classes, exponent, int(ok.sum())


def time_orbit(w, s, z, m, x0, n_exp):
    """(speed-up, hertzmap s, paper s, rtol, reason, tuned paper s) for one orbit; reason is
    None when timed. The tuned paper's scheme (cd_shoot_tuned) runs the same iterates."""
    ref = shoot(w, s, z, m, guess=x0, rtol=1e-13, exponent=n_exp)
    if not ref.converged or np.abs(ref.x0 - np.asarray(x0)).max() > 1e-6 * (1 + np.abs(x0).max()):
        return None, None, None, None, "reference not found at rtol 1e-13", None
    guess = ref.x0 + 1e-2
    xtol, _ = paper_scheme_xtol(w, s, z, m, guess, n_exp, ref.x0, N_PAPER)
    out = np.zeros(9)
    cd_shoot(w, s, z, m, guess[0], guess[1], n_exp, 0, N_PAPER, 40, xtol, out)
    err_cd = float(np.abs(out[1:3] - ref.x0).max())
    if out[0] != 0 or err_cd > 1e-4:
        return None, None, None, None, "the paper's scheme leaves the orbit from the guess", None
    target = min(err_cd, 1e-8)
    rtol = None
    for r in RTOLS:
        o = shoot(w, s, z, m, guess=guess, rtol=r, exponent=n_exp)
        if o.converged and float(np.abs(o.x0 - ref.x0).max()) <= target:
            rtol = r
            break
    if rtol is None:
        return None, None, None, None, "hertzmap leaves the orbit from the guess", None
    t_cd = per_call(lambda: cd_shoot(w, s, z, m, guess[0], guess[1], n_exp, 0, N_PAPER, 40,
                                     xtol, out), 0.05)
    t_tuned = per_call(lambda: cd_shoot_tuned(w, s, z, m, guess[0], guess[1], n_exp, 0, N_PAPER,
                                              40, xtol, out), 0.05)
    args = [np.full(BATCH, v) for v in (w, s, z)] + [np.full(BATCH, m, np.int64)] + \
        [np.full(BATCH, guess[0]), np.full(BATCH, guess[1])]
    res = np.empty((BATCH, N_FIELDS))
    t_hm = per_call(lambda: shoot_batch_into(*args, n_exp, 0, rtol, rtol, 40, 1.0, 200_000, False,
                                             res), 0.05) / BATCH
    return t_cd / t_hm, t_hm, t_cd, rtol, None, t_tuned


def describe(w, s, z, m, x0, n_exp, rtol):
    """(flight fraction, Newton iterations, steps of the solve) of hertzmap's timed solve."""
    ref = shoot(w, s, z, m, guess=x0, rtol=1e-13, exponent=n_exp)
    o = shoot(w, s, z, m, guess=ref.x0 + 1e-2, rtol=rtol, exponent=n_exp)
    return o.flight_fraction, o.newton_iterations, o.steps


def summary(label, ratios, share=None):
    r = np.asarray(ratios)
    if r.size == 0:
        return f"{label:28s} {'':>9s}      0 timed"
    head = f"{label:28s} {share:8.1%} " if share is not None else f"{label:28s} {'':>9s}"
    return (head + f"{r.size:6d} timed   min {r.min():6.0f}x   p10 {np.percentile(r, 10):6.0f}x"
            f"   median {np.median(r):6.0f}x   max {r.max():6.0f}x   below 30x {np.mean(r < 30):4.0%}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("store", nargs="?", default=str(ROOT / "results" / "default.zarr"))
    ap.add_argument("--size", type=int, default=120)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--worst", type=int, default=5, help="print the K slowest-ratio orbits")
    a = ap.parse_args(argv)
    store = Path(a.store)
    if not store.exists():
        raise SystemExit(f"{store} not found: run `bash scripts/run-default.sh` first "
                         "(or pass the path of another study's store)")
    rows, classes, n_exp, n_total = sample_orbits(store, a.size, a.seed)
    print(f"{store}: {n_total} converged orbits, exponent {n_exp}; sample of {len(rows)} "
          f"(seed {a.seed})")
    t0 = time.perf_counter()
    by_class, skipped, all_ratios, t_hm_all, timed, tuned = {}, {}, [], [], [], []
    for w, s, z, m, q0, v0, lc in rows:
        ratio, t_hm, t_cd, rtol, why, t_tuned = time_orbit(w, s, z, m, (q0, v0), n_exp)
        if why is not None:
            skipped[why] = skipped.get(why, 0) + 1
            continue
        by_class.setdefault((m, lc), []).append(ratio)
        all_ratios.append(ratio)
        tuned.append(t_tuned / t_hm)
        t_hm_all.append(t_hm)
        timed.append((ratio, w, s, z, m, (q0, v0), t_hm, t_cd, rtol))
    print(f"({time.perf_counter() - t0:.0f} s)")
    print(f"{'class':28s} {'of store':>8s}")
    for key in sorted(classes):
        m, lc = key
        label = f"{m}T, {'loses contact' if lc else 'in contact'}"
        print(summary(label, by_class.get(key, []), classes[key] / n_total))
    print(summary("all sampled orbits", all_ratios))
    print(summary("  against the tuned scheme", tuned))
    print(f"hertzmap time per orbit: median {np.median(t_hm_all) * 1e6:.1f} us")
    if a.worst > 0 and timed:
        print(f"the {a.worst} lowest speed-ups:")
        print(f"  {'x paper':>7s} {'omega':>7s} {'sigma':>7s} {'T':>2s} {'flight':>6s} "
              f"{'us':>6s} {'paper ms':>8s} {'rtol':>6s} {'Newton':>6s} {'steps':>5s}")
        for ratio, w, s, z, m, x0, t_hm, t_cd, rtol in sorted(timed)[:a.worst]:
            flight, it, steps = describe(w, s, z, m, x0, n_exp, rtol)
            print(f"  {ratio:7.1f} {w:7.4f} {s:7.4f} {m:2d} {flight:6.2f} {t_hm * 1e6:6.1f} "
                  f"{t_cd * 1e3:8.2f} {rtol:6.0e} {it:6d} {steps:5d}")
    for why, k in skipped.items():
        print(f"not timed: {k} orbits ({why})")


if __name__ == "__main__":
    main()
