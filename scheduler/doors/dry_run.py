"""``hertzmap run --dry-run``: the plan of a study and what it would cost, without writing."""
from __future__ import annotations

from pathlib import Path

from hertzmap.scheduler.stages.atlas_tasks import NEEDS as ATLAS_NEEDS
from hertzmap.scheduler.stages.atlas_tasks import TILE_BLOCKS, atlas_chunks
from hertzmap.scheduler.stages.plan import Plan, choose_chunks, make_plan
from hertzmap.scheduler.doors.report import fmt_bytes, fmt_time
from hertzmap.scheduler.resources import check_resources
from hertzmap.scheduler.store import Store, StoreError, read_attrs
from hertzmap.study.schema import bytes_per_point, stored_variables
from hertzmap.study.solve.curve_seeds import swept_planes
from hertzmap.study.spec import AXES, Study


def plan_for(study: Study, store_path: Path, task_seconds: float) -> tuple[Plan, str]:
    """The plan, reusing the chunk shape of an existing store of the same study.
    Reads only. Returns (plan, note about the store)."""
    attrs = read_attrs(store_path) if store_path.exists() else None
    if attrs is not None and attrs.get("hertzmap_study_hash") == study.hash:
        plan = make_plan(study, tuple(attrs["hertzmap_chunk_shape"]))
        try:
            done = int(Store(store_path).done_mask().sum())
        except (StoreError, KeyError):
            done = 0
        return plan, f"exists (same study): resume, {done}/{len(plan.tasks)} tasks done"
    plan = make_plan(study, choose_chunks(study, task_seconds))
    if attrs is not None:
        return plan, "exists (another study or not hertzmap): refused unless --overwrite"
    if store_path.exists():
        return plan, "path exists and is not a zarr store: refused"
    return plan, "new"


def describe(study: Study, store_path: Path, task_seconds: float, cluster) -> str:
    """The --dry-run report. Raises RunError when the study cannot fit (disk, memory)."""
    plan, note = plan_for(study, store_path, task_seconds)
    check_resources(study, plan, store_path, new_store=not note.startswith("exists (same"))
    n_o, n_s, n_z = study.shape
    size = study.size * bytes_per_point(study)
    est = plan.estimated_seconds()
    stored = stored_variables(study)
    workers = cluster.workers if cluster.kind == "local" else None
    per_worker = f", about {fmt_time(est / (workers or 1))} on {workers} workers" if workers else ""
    lines = [
        f"study        {study.name} (hash {study.hash[:12]})",
        f"grid         {n_o} omega x {n_s} sigma x {n_z} zeta = {study.size} points, "
        f"periods {list(study.periods)}, every orbit found stored",
        f"model        {study.model}" + (f" exponent {study.exponent}" if study.exponent else "")
        + f", rtol {study.rtol:g}",
        f"outputs      {', '.join(study.outputs)} -> {', '.join(stored)}",
        f"tasks        {len(plan.tasks)} (chunk {plan.chunks[0]} omega x {plan.chunks[1]} sigma x "
        f"{plan.chunks[2]} zeta; about {fmt_time(est / max(1, len(plan.tasks)))} each)",
        f"compute      about {fmt_time(est)} of one core{per_worker} (estimate)",
        *([atlas_line(study, plan)] if all(n in stored for n in ATLAS_NEEDS) else []),
        *([curves_line(study)] if "curves" in study.outputs else []),
        f"store        {store_path} ({note}); about {fmt_bytes(size)} uncompressed",
        f"runs on      {cluster.describe()}",
    ]
    return "\n".join(lines)


def atlas_line(study: Study, plan: Plan) -> str:
    """The dry run's line on the atlas (scheduler.stages.atlas_tasks): its tiles per round. Its time
    is not estimated (it depends on the orbits the grid finds); BENCHMARKS.md measures it."""
    tiles = len(make_plan(study, atlas_chunks(plan.chunks)).tasks)
    which = ("every orbit" if study.continue_unstable == "all" else
             "the stable orbits and those of the periods searched")
    return (f"atlas        after the grid, {which} continued into their grid neighbours in "
            f"rounds of at most {tiles} tile(s) ({TILE_BLOCKS} tasks' blocks along sigma "
            "each); not in the estimate (10-60 % of the grid's compute on the shipped scenes)")


def curves_line(study: Study) -> str:
    """The dry run's line on the curve stage: the planes its curves are traced in, each at
    every value of the third parameter (a grid sweeping three parameters traces in three:
    the damping scene's 41 x 31 x 12 grid gave 15268 seeds, 4836 of them in (omega, sigma)).
    Its time is not estimated (it depends on the curves the grid crosses)."""
    axes = {n: study.axis(n) for n in AXES}
    planes = swept_planes(axes)
    parts = [f"({a}, {b}) at {len(axes[c])} {c}"
             for a, b in planes for c in AXES if c not in (a, b)]
    return (f"curves       traced after the grid in {len(planes)} plane(s): " + ", ".join(parts)
            + "; not in the estimate")
