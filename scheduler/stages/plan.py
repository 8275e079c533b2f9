"""Plan the tasks of a study: one task = one zarr chunk of the grid.

A chunk is (an omega block, a few sigma values, a few zeta values) x all solution slots.
The omega axis is kept whole when it fits (neighbours along omega seed each other in the
block solver). The chunk shape depends on the study only (never on the number of workers),
so a store can be resumed by any cluster; once a store exists its chunk shape is read back
from it.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from hertzmap.scheduler.defaults import DEFAULT_TASK_SECONDS
from hertzmap.study.schema import chunk_counts, chunk_slices
from hertzmap.study.solve.line import PROBE_POINTS
from hertzmap.study.spec import Study

#: Estimated seconds of solver work per grid point, per period searched (a 1T search, a 2T
#: search). Calibrated on the block solver (see docs/running.md); used only to size tasks
#: and for --dry-run estimates.
SECONDS_PER_POINT = {1: 1.4e-4, 2: 6.4e-4}  # study.solve.block, default window (zeta 0.01, 5 sigma
#: lines): 0.134 ms per point for 1T, 0.772 ms for 1T + 2T on 2 cores (benchmarks/run_cost.py grid)
#: extra per point with [search] discover = true (transients + continuation, ~1.5 s per
#: 161-point line, docs/discovery.md)
SECONDS_PER_POINT_DISCOVER = 1e-2
#: Longest omega block in one chunk.
MAX_OMEGA_CHUNK = 4096
#: Try to have at least this many tasks (better balance, finer progress and resume).
MIN_TASKS = 16


@dataclass(frozen=True)
class Block:
    """One block of the grid: one zarr chunk of the store, the grid stage's one task."""
    index: tuple[int, int, int]             # chunk index (omega_chunk, sigma_chunk, zeta_chunk)
    slices: tuple[slice, slice, slice]      # grid slices of the chunk

    @property
    def shape(self) -> tuple[int, int, int]:
        return tuple(s.stop - s.start for s in self.slices)

    @property
    def size(self) -> int:
        return math.prod(self.shape)


@dataclass(frozen=True)
class Plan:
    study: Study
    chunks: tuple[int, int, int]
    tasks: tuple[Block, ...]

    @property
    def counts(self) -> tuple[int, int, int]:
        return chunk_counts(self.study.shape, self.chunks)

    def estimated_seconds(self) -> float:
        """Estimated total solver time (one core)."""
        return self.study.size * seconds_per_point(self.study)


#: Solver seconds per initial state of the attractor census at a point whose transients do not
#: settle (the full budget of 500 + 128 periods; measured 60-80 ms for 16 states at zeta 0.01,
#: sigma 2-3); settling ones take a tenth of it.
SECONDS_PER_CENSUS_STATE = 4.5e-3
#: Share of grid points assumed to need the census for want of a stable orbit when
#: search.attractors is "where-none-stable" (not known before the run: a planning guess, for
#: task sizes and the dry run's estimate only). Measured: none of the default study's or the
#: fine map's points; 35 % of the vibro-impact scene's (whose tasks run longer than planned).
CENSUS_SHARE = 0.01
#: Solver seconds per initial state at the census's probe points (study.solve.line
#: PROBE_POINTS per line, run whatever shooting found): transients that settle on the point's
#: orbits and the tracing along the line of what they find. benchmarks/run_cost.py grid on the
#: default study (no point there without a stable orbit: the census phase is all probes):
#: 1.56-1.75 s for 80 probe points of 16 states, 1.2-1.4 ms per state.
SECONDS_PER_PROBE_STATE = 1.25e-3
#: Solver seconds per initial state where the census runs at every point (search.attractors
#: = "always"): transients recognised in the certified neighbourhoods of the point's stable
#: orbits, the certificates and the tracing of what the census finds. The default scene:
#: 141 s of task compute for 12,397 points of 16 states, 0.71 ms per state.
SECONDS_PER_ALWAYS_STATE = 0.7e-3


def seconds_per_point(study: Study) -> float:
    """Estimated solver seconds per grid point for this study."""
    seconds = sum(SECONDS_PER_POINT.get(p, SECONDS_PER_POINT[2]) for p in study.periods)
    if getattr(study, "discover", False):
        seconds += SECONDS_PER_POINT_DISCOVER
    mode = getattr(study, "attractors", "never")
    if mode != "never":
        # the points held by a motion that does not settle (every state its whole budget)
        seconds += CENSUS_SHARE * study.initial_states * SECONDS_PER_CENSUS_STATE \
            * (study.transient_periods + study.record_periods) / 628
        if mode == "always":
            seconds += study.initial_states * SECONDS_PER_ALWAYS_STATE
        if mode == "where-none-stable":
            probes = min(PROBE_POINTS, study.shape[0])
            seconds += probes * study.initial_states * SECONDS_PER_PROBE_STATE / study.shape[0]
    return seconds


#: A study whose estimated solver time (Plan.estimated_seconds: the grid, by
#: seconds_per_point) is below this runs in-process (one worker thread in the client,
#: scheduler.cluster.clusters.INPROCESS) unless --workers, --cluster or --scheduler says where: a
#: process cluster costs 10-12 s more to start on this repository's 2-core machine (its workers
#: load the kernels; docs/running.md, "Small studies") and its second worker saves at most half
#: the solver time. The estimate comes out high on the shipped scenes (1.2-2.4x) but low where
#: the census runs at many points (the vibro-impact scene): at this threshold the worst case is
#: a few seconds slower than a process cluster, the usual case 10 s faster.
SMALL_STUDY_SECONDS = 4.0


def is_small_study(study: Study) -> bool:
    """True when the plan's estimate of the solver time is below SMALL_STUDY_SECONDS."""
    return study.size * seconds_per_point(study) < SMALL_STUDY_SECONDS


def choose_chunks(study: Study, task_seconds: float = DEFAULT_TASK_SECONDS) -> tuple[int, int, int]:
    """Chunk shape (omega, sigma, zeta) so that one chunk takes about ``task_seconds``."""
    n_o, n_s, n_z = study.shape
    target = max(1, int(round(task_seconds / seconds_per_point(study))))
    c_o = n_o if n_o <= MAX_OMEGA_CHUNK else math.ceil(n_o / math.ceil(n_o / MAX_OMEGA_CHUNK))
    c_s = min(n_s, max(1, round(target / c_o)))
    c_z = 1
    if c_s == n_s:
        c_z = min(n_z, max(1, round(target / (c_o * n_s))))
    # enough tasks for balance, if the grid allows it (never split the omega block for that)
    while math.prod(chunk_counts(study.shape, (c_o, c_s, c_z))) < MIN_TASKS and (c_s > 1 or c_z > 1):
        if c_z > 1:
            c_z = math.ceil(c_z / 2)
        else:
            c_s = math.ceil(c_s / 2)
    return (c_o, c_s, c_z)


def spread_order(blocks) -> list:
    """The blocks in the order a run ships them: the middle of the plan first, then the
    middles of its two halves, of their halves, and so on (a breadth-first bisection), so that
    the first to come back are spread over the whole grid and the progress line's estimate of
    the compute ahead (scheduler.stages.progress.WorkEstimate) knows every region's cost from the
    start: a grid's costs vary by region (the default scene's lines cost 2-4.4 s, those near
    sigma = 1 most). The results do not depend on the order (each block is solved on its
    own)."""
    blocks = list(blocks)
    order = []
    queue = deque([(0, len(blocks))])
    while queue:
        lo, hi = queue.popleft()
        if lo >= hi:
            continue
        mid = (lo + hi) // 2
        order.append(blocks[mid])
        queue.append((lo, mid))
        queue.append((mid + 1, hi))
    return order


def make_plan(study: Study, chunks: tuple[int, int, int]) -> Plan:
    chunks = tuple(min(int(c), n) for c, n in zip(chunks, study.shape))
    counts = chunk_counts(study.shape, chunks)
    tasks = tuple(
        Block(index=idx, slices=chunk_slices(study.shape, chunks, idx))
        for idx in np.ndindex(*counts)
    )
    return Plan(study=study, chunks=chunks, tasks=tasks)
