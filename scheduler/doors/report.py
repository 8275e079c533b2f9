"""What a run prints: sizes and durations in words, and the summary at the end of a run."""
from __future__ import annotations

import math
from typing import Any, TextIO


def fmt_bytes(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if n < 1000 or unit == "TB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000
    return f"{n} B"  # pragma: no cover


def fmt_time(s: float) -> str:
    if not math.isfinite(s):
        return "?"
    s = int(round(s))
    h, rem = divmod(s, 3600)
    m, sec = divmod(rem, 60)
    return f"{h}h{m:02d}m{sec:02d}s" if h else (f"{m}m{sec:02d}s" if m else f"{sec}s")


def busy_workers(workers: int, tasks_run: int) -> int:
    """The workers that had a task: with fewer tasks than workers the others idled, which is
    not Dask's overhead."""
    return min(workers, max(1, tasks_run))


def overhead(compute: float, wall: float, workers: int, tasks_run: int) -> float:
    """Dask's share of the busy workers' time: 1 - task compute / (busy workers x wall)."""
    return 1.0 - compute / (busy_workers(workers, tasks_run) * wall) if wall > 0 else math.nan


def overhead_line(s: dict[str, Any]) -> str:
    """Where the workers' time went (``s["overhead"]``: :func:`overhead`); with fewer tasks than
    workers the line says how many idled."""
    busy = busy_workers(s["workers"], s["tasks_run"])
    head = (f"dask overhead: {100 * s['overhead']:.1f} % (task compute {s['compute']:.2f} s over "
            f"{busy} busy worker{'s' if busy > 1 else ''} x {s['wall']:.2f} s wall; "
            f"{1000 * s['per_task']:.0f} ms per task)")
    if busy < s["workers"]:
        head += (f"; {s['tasks_run']} task{'s' if s['tasks_run'] > 1 else ''} for "
                 f"{s['workers']} workers, so {s['workers'] - busy} stayed idle")
    return head


#: the census's attractor kinds counted by the run summary (kernels.records.ATTRACTOR_KINDS)
KIND_COUNTS = ("periodic", "non_periodic", "unsettled", "failed")
#: what a finished block adds to the run summary (block_counts), summed (or, for the
#: certificates, the worst kept; for the slots, the most) by the client (add_counts)
SUMMED_COUNTS = ("conv", "stable", "fail", "cut", "with", "attractors") + KIND_COUNTS
WORST_COUNTS = ("liouville", "lyapunov_sum")


def block_counts(arrays: dict) -> dict[str, Any]:
    """What the run summary needs of one block, counted on the worker that solved it: the
    converged (and stable), failed and time-limited slots, the points with an orbit, the
    census's attractors by kind, the most orbits and attractors a point holds (``slots``:
    scheduler.store.slots_used), the worst certificates (worst_certificates)."""
    import numpy as np

    from hertzmap.kernels.records import ATTRACTOR_KINDS
    from hertzmap.kernels.status import TIME_LIMIT
    from hertzmap.scheduler.store import slots_used

    st = arrays["status"]
    counts: dict[str, Any] = {"conv": int((st == 0).sum()),
                              "fail": int(((st > 0) & (st != TIME_LIMIT)).sum()),
                              "cut": int((st == TIME_LIMIT).sum()),
                              "with": int((st == 0).any(axis=-1).sum()),
                              "attractors": 0, "slots": slots_used(arrays),
                              "liouville": math.nan, "lyapunov_sum": math.nan}
    counts["stable"] = int(((st == 0) & np.asarray(arrays["stable"])).sum()) \
        if "stable" in arrays else 0
    kinds = np.asarray(arrays.get("attractor_kind", np.zeros(0, np.int8)))
    for k in KIND_COUNTS:
        counts[k] = int((kinds == ATTRACTOR_KINDS[k]).sum())
    worst_certificates(counts, arrays)
    return counts


def add_counts(tally: dict[str, Any], counts: dict[str, Any]) -> None:
    """Add a block's counts (block_counts) to the run's ``tally``."""
    for k in SUMMED_COUNTS:
        tally[k] += counts[k]
    for k in WORST_COUNTS:
        if math.isfinite(counts[k]):
            tally[k] = counts[k] if not math.isfinite(tally[k]) else max(tally[k], counts[k])
    for dim, n in counts.get("slots", {}).items():
        tally.setdefault("slots", {})
        tally["slots"][dim] = max(tally["slots"].get(dim, 0), n)


def worst_certificates(tally: dict[str, Any], arrays: dict) -> None:
    """Keep in ``tally`` the worst of each orbit certificate of a finished block: the Liouville
    residual over its converged orbits, the Lyapunov sum error over its census attractors."""
    import numpy as np

    if "liouville_residual" in arrays:
        r = arrays["liouville_residual"][arrays["status"] == 0]
        r = r[np.isfinite(r)]
        if r.size:
            tally["liouville"] = float(np.nanmax([tally["liouville"], r.max()]))
    if "lyapunov_sum_error" in arrays:
        e = arrays["lyapunov_sum_error"][arrays["attractor_kind"] > 0]
        e = e[np.isfinite(e)]
        tally["attractors"] += int(e.size)
        if e.size:
            tally["lyapunov_sum"] = float(np.nanmax([tally["lyapunov_sum"], e.max()]))


def certificates_line(s: dict[str, Any]) -> str | None:
    """The worst certificate of this run's orbits and attractors (docs/dataset.md)."""
    parts = []
    if math.isfinite(s.get("liouville_worst", math.nan)):
        parts.append(f"Liouville residual <= {s['liouville_worst']:.1e} over the {s['orbits']} "
                     f"orbits (relative, |det M - exp(-2 zeta P)|)")
    if math.isfinite(s.get("lyapunov_sum_worst", math.nan)):
        parts.append(f"|lambda1 + lambda2 + 2 zeta| <= {s['lyapunov_sum_worst']:.1e} over the "
                     f"{s['attractors']} census attractors")
    return "certificates: " + "; ".join(parts) if parts else None


def print_summary(s: dict[str, Any], out: TextIO) -> None:
    lines = [
        f"done: {s['tasks_run']} tasks, {s['points']} points in {s['wall']:.2f} s wall "
        f"{s.get('where') or 'on %d workers' % s['workers']} ({s['points_per_second']:,.0f} "
        f"points/s; setup {s['setup']:.1f} s)",
        f"orbits: {s['orbits']} converged ({s['orbits_per_second']:,.0f} orbits/s; "
        f"{s.get('stable', 0)} stable, {s['orbits'] - s.get('stable', 0)} unstable, every one "
        f"stored), {s['failed_slots']} failed slots, converged fraction "
        f"{s['converged_fraction']:.4f}, {s['points_with_orbit']} points with at least one orbit"
        + (f", at most {s['slots']['solution']} at a point" if s.get("slots") else ""),
        overhead_line(s),
    ]
    certificates = certificates_line(s)
    if certificates:
        lines.append(certificates)
    kinds = s.get("attractor_kinds") or {}
    if any(kinds.values()):
        lines.append("attractors (census): " + ", ".join(
            f"{kinds.get(k, 0)} {k.replace('_', '-')}" for k in KIND_COUNTS)
            + (f"; at most {s['slots']['attractor']} at a point" if s.get("slots", {}).get(
                "attractor") else "") + ", every one stored")
    if s.get("time_limited"):
        lines.append(f"time limit: {s['time_limited']} grid points not solved within "
                     f"--task-timeout (status time_limit); rerun with --overwrite and a larger "
                     f"--task-timeout to compute them")
    e = s.get("error") or {}
    if e.get("failed"):
        lines.append(f"error estimate: failed ({e['failed']})")
    elif e.get("n"):
        lines.append(f"error estimate: max |d(q0, v0)| = {e['max_deviation']:.2e} over "
                     f"{e['matched']}/{e['n']} sampled orbits re-solved at rtol {e['rtol_ref']:g}"
                     f" (wall {s['wall']:.2f} s; in the store's attrs: hertzmap_error_estimate)"
                     + (" (reference rtol not tighter than the run's)" if e.get("ref_equals_run") else ""))
    lines.append(f"store: {s['store']} ({s['tasks_done_before'] + s['tasks_run']}/{s['tasks_total']} tasks done)")
    if s["failed"]:
        lines.append(f"FAILED tasks: {len(s['failed'])} (rerun the same command to retry them)")
        for key, msg in s["failed"][:5]:
            lines.append(f"  {key}: {msg}")
    out.write("\n".join(lines) + "\n")
    out.flush()
