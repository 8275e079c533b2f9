"""How long ``hertzmap fit`` takes, and where the time goes (issue 49: two sweeps of about 200
steps fitted with their intervals on 2 cores, warm, in at most 2 minutes).

    PYTHONPATH=. .venv/bin/python benchmarks/identify_fit_time.py --workers 2
    PYTHONPATH=. .venv/bin/python benchmarks/identify_fit_time.py --resolution   # the step

The measurement is the worked example (docs/examples/paper_rig_sweeps.csv: 200 steps up and
200 down over 200 .. 600 Hz of the paper's rig). Warm: the embedded LocalCluster is started
and each worker has computed a forward model (the kernels compiled or loaded from numba's
cache) before the clock starts; the fit then runs as ``hertzmap fit`` runs it
(scheduler.stages.fit_tasks.run_fit on that client). Prints the wall time, each stage's wall time,
its tasks' wall and CPU seconds and count, the client's CPU, the machine's load before and
after, and inside one forward model (a pair of sweeps at the estimate) the shares of the
kernels' Newton shots, the transients, the histories' harmonics and the Python around them.

``--resolution``: the forward model's interpolation error at the worked example's 400
frequencies against a model 5 times finer (steps of 0.0005 in omega), for steps of 0.0025
(the fit's), 0.005 and 0.01, with each one's cost: what chose the step.
"""
from __future__ import annotations

import argparse
import datetime
import os
import sys
import time

import numpy as np

EXAMPLE = "docs/examples/paper_rig_sweeps.csv"
RIG = "docs/examples/paper_rig.toml"


def resolution() -> None:
    from hertzmap.study.identify.forward_model import forward_model, omega_grid
    from hertzmap.study.identify.measurement import read_measurement

    f = np.unique(read_measurement(EXAMPLE).frequency)
    cases = [(270.6, 0.33, 0.0055), (271.0, 0.2, 0.005)]
    print("forward model step against 0.0005 (max |error| / H1 per harmonic H1, H2, H1/2 at "
          "the worked example's frequencies; CPU s a pair of sweeps):")
    for f0, sigma, zeta in cases:
        w = f / f0
        lo, hi = 0.98 * w.min(), 1.02 * w.max()
        ref = forward_model(sigma, zeta, omega_grid(lo, hi, 0.0005), exponent=1.5)
        for step in (0.0025, 0.005, 0.01):
            c = time.process_time()
            fm = forward_model(sigma, zeta, omega_grid(lo, hi, step), exponent=1.5)
            cpu = time.process_time() - c
            worst = np.zeros(3)
            for d in ("up", "down"):
                a = ref.at(w, d)[0]
                b = fm.at(w, d)[0]
                worst = np.maximum(worst, (np.abs(a - b) / a[:, :1]).max(axis=0))
            print(f"  sigma {sigma}, zeta {zeta}: step {step}: {worst[0]:.1e}, {worst[1]:.1e}, "
                  f"{worst[2]:.1e}; {cpu:.2f} s CPU ({fm.steps} steps)")


def where_forward_time(sigma: float, zeta: float, problem) -> None:
    """The shares of one forward model's time: the kernels' Newton shots
    (kernels.shooting.shoot_into), its transients (kernels.attractors.attractor_batch_into),
    the integrations of history harmonics and the rest (the Python around them), timed by
    wrapping the kernels' entry points (a profiler's own cost would swamp the Python's)."""
    import hertzmap.kernels.api as api
    import hertzmap.kernels.periodic_orbit as po
    from hertzmap.kernels import attractors
    from hertzmap.study.identify.forward_model import forward_model

    spent = {"shots": 0.0, "transients": 0.0, "histories": 0.0}
    calls = {k: 0 for k in spent}

    def timed(name, fn):
        def run(*args, **kw):
            t = time.perf_counter()
            try:
                return fn(*args, **kw)
            finally:
                spent[name] += time.perf_counter() - t
                calls[name] += 1
        return run

    saved = (po.shoot_into, attractors.attractor_batch_into, api.integrate)
    po.shoot_into = timed("shots", saved[0])
    attractors.attractor_batch_into = timed("transients", saved[1])
    api.integrate = timed("histories", saved[2])
    try:
        forward_model(sigma, zeta, problem.omega, exponent=problem.exponent)  # warm
        for k in spent:
            spent[k], calls[k] = 0.0, 0
        t = time.perf_counter()
        fm = forward_model(sigma, zeta, problem.omega, exponent=problem.exponent)
        total = time.perf_counter() - t
    finally:
        po.shoot_into, attractors.attractor_batch_into, api.integrate = saved
    rest = total - sum(spent.values())
    print(f"one forward model at the estimate ({fm.steps} steps, both sweeps): {total:.2f} s: "
          f"Newton shots {spent['shots'] / total:.0%} ({calls['shots']} shots), transients "
          f"{spent['transients'] / total:.0%} ({calls['transients']}: from rest, after the "
          f"jumps), histories' harmonics {spent['histories'] / total:.0%} "
          f"({calls['histories']}), the Python around them {rest / total:.0%}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--resolution", action="store_true")
    args = p.parse_args()
    print(f"# {' '.join(['PYTHONPATH=. .venv/bin/python', *sys.argv])}")
    print(f"# {datetime.datetime.now():%Y-%m-%d %H:%M}, {os.cpu_count()} cores")
    if args.resolution:
        resolution()
        return

    from hertzmap.scheduler.cluster.clusters import ClusterSpec, close_quietly, make_client
    from hertzmap.scheduler.stages.fit_tasks import load_inputs, run_fit
    from hertzmap.study.identify.estimation import run_task

    _, _, problem = load_inputs(EXAMPLE, RIG)
    t = time.perf_counter()
    client, cluster = make_client(ClusterSpec(kind="local", workers=args.workers))
    started = time.perf_counter() - t
    try:
        warm = [client.submit(run_task, {"kind": "forward", "problem": problem,
                                         "theta": (0.3, 0.005 + 1e-4 * k, 1.5)}, pure=False)
                for k in range(args.workers)]
        client.gather(warm)
        load0 = os.getloadavg()[0]
        c0, t0 = time.process_time(), time.perf_counter()
        ds = run_fit(EXAMPLE, RIG, client=client, report=lambda s: None, figure=False)
        wall, client_cpu = time.perf_counter() - t0, time.process_time() - c0
        load1 = os.getloadavg()[0]
    finally:
        close_quietly(client, cluster)
    print(f"cluster start {started:.1f} s (not in the fit's time); load average "
          f"{load0:.1f} before, {load1:.1f} after")
    print(f"fit of {EXAMPLE} (400 steps, 1200 readings) on {args.workers} workers: "
          f"{wall:.1f} s wall, {ds.attrs['forward_models']} forward models, "
          f"{ds.attrs['restarts']} restarts; the client's CPU {client_cpu:.1f} s")
    cpu_total = 0.0
    for stage in ("global", "local", "profiles"):
        a = ds.attrs
        cpu = a[f"stage_{stage}_task_cpu_seconds"]
        cpu_total += cpu
        print(f"  {stage:8s}: {a[f'stage_{stage}_seconds']:6.1f} s wall, "
              f"{a[f'stage_{stage}_tasks']:3d} tasks, {a[f'stage_{stage}_task_seconds']:6.1f} s "
              f"of task wall, {cpu:6.1f} s of task CPU")
    print(f"  the tasks' CPU in all {cpu_total:.1f} s: on {args.workers} idle cores the "
          f"parallel stages (global, profiles) take their CPU / {args.workers}, the local "
          "stage its own (2-3 models an iteration)")
    for i, name in enumerate(ds["parameter"].values):
        print(f"  {name}: {float(ds['best'][i]):.6g} [{float(ds['lower'][i]):.6g}, "
              f"{float(ds['upper'][i]):.6g}]")
    best = {str(n): float(v) for n, v in zip(ds["parameter"].values, ds["best"].values)}
    where_forward_time(best["sigma"], best["zeta"], problem)


if __name__ == "__main__":
    main()
