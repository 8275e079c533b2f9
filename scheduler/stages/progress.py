"""Progress of a run's stage on the terminal: tasks done, points (or tasks) per second, time
left.

The time left is the compute still ahead (WorkEstimate: each task not done yet costs what the
done tasks nearest it on the grid cost per point) over the compute done per second of wall so
far. A grid's costs vary by region (the census's longer passes where nothing settles, the
multistable corner of a map: per line 2.1 s at low sigma against 4.4 s near sigma = 1 on the
default scene), so a rate of points per second from the first tasks says little of the last
ones; with the tasks shipped spread over the grid (scheduler.stages.plan.spread_order), the done
tasks sample every region from the start.
"""
from __future__ import annotations

import math
import time
from typing import Hashable, Mapping, TextIO

import numpy as np

from hertzmap.scheduler.doors.report import fmt_time


def rewrites_in_place(stream: TextIO) -> bool:
    """Whether ``stream`` shows a line rewritten after a carriage return in place: a terminal,
    or a Jupyter cell's output (the kernel's stream, which notebooks render with ``\r`` as a
    terminal does; its ``isatty()`` says False)."""
    if hasattr(stream, "isatty") and stream.isatty():
        return True
    return type(stream).__module__.startswith("ipykernel.")


class WorkEstimate:
    """The compute (seconds) still ahead of a stage's tasks. Each task has a place (its block's
    index on the grid) and a size (points); a task not done yet costs its size times the
    cost per point of the done tasks nearest it (inverse-distance weights over the NEAREST
    nearest, places scaled by the grid's block counts), or ``prior`` seconds per point while
    none is done. Evaluated at most on SAMPLE of the tasks left (scaled up): the progress
    line of a study of 10^5 tasks stays cheap."""

    NEAREST = 4
    SAMPLE = 2000

    def __init__(self, places: Mapping[Hashable, tuple], sizes: Mapping[Hashable, int],
                 prior: float):
        self.keys = list(places)
        self.index = {k: i for i, k in enumerate(self.keys)}
        xy = np.array([places[k] for k in self.keys], float).reshape(len(self.keys), -1)
        span = np.ptp(xy, axis=0) if len(xy) else np.zeros(0)
        self.xy = xy / np.where(span > 0, span, 1.0)
        self.size = np.array([sizes[k] for k in self.keys], float)
        self.prior = float(prior)
        self.per_point = np.full(len(self.keys), np.nan)

    def done(self, key: Hashable, seconds: float) -> None:
        i = self.index.get(key)
        if i is not None:
            self.per_point[i] = float(seconds) / max(self.size[i], 1.0)

    def remaining(self) -> float:
        """Compute seconds of the tasks not done yet (one core)."""
        left = np.flatnonzero(np.isnan(self.per_point))
        if not left.size:
            return 0.0
        known = np.flatnonzero(~np.isnan(self.per_point))
        if not known.size:
            return float(self.size[left].sum() * self.prior)
        scale = 1.0
        if left.size > self.SAMPLE:
            scale = left.size / self.SAMPLE
            left = left[np.linspace(0, left.size - 1, self.SAMPLE).astype(int)]
        d = np.sqrt(((self.xy[left, None, :] - self.xy[None, known, :]) ** 2).sum(axis=2)) \
            if known.size * left.size <= 4_000_000 else None
        if d is None:       # too many pairs: the done tasks' mean cost per point
            return float(scale * self.size[left].sum() * np.mean(self.per_point[known]))
        k = min(self.NEAREST, known.size)
        near = np.argpartition(d, k - 1, axis=1)[:, :k]
        dn = np.take_along_axis(d, near, axis=1)
        w = 1.0 / np.maximum(dn, 1e-9)
        cost = (w * self.per_point[known][near]).sum(axis=1) / w.sum(axis=1)
        return float(scale * (self.size[left] * cost).sum())


class Progress:
    """One line per update: rewritten in place on a terminal or in a notebook's cell (every
    0.5 s at most), appended every 10 s otherwise (logs of batch jobs; none for a stage
    shorter than that). ``label``: the stage (``grid``, ``atlas round 2``, ...); ``unit``: what
    the rate counts (``points``: the tasks' sizes; ``tasks``)."""

    def __init__(self, stream: TextIO, label: str, total_tasks: int, total_points: int,
                 done_tasks: int, unit: str = "points", work: WorkEstimate | None = None):
        self.stream = stream
        self.tty = rewrites_in_place(stream)
        # a terminal keeps each stage's last line; a notebook's cell keeps one line, which
        # each stage rewrites in turn
        self.keeps_lines = hasattr(stream, "isatty") and stream.isatty()
        self.label = label
        self.unit = unit
        self.total_tasks = total_tasks
        self.total_points = total_points if unit == "points" else total_tasks - done_tasks
        self.done_tasks = done_tasks
        self.points = 0
        #: the compute still ahead (scheduler.stages.progress.WorkEstimate), with the compute done
        #: and when the last task came back: the time left
        self.work = work
        self.compute = 0.0
        self.t0 = time.perf_counter()
        self.t_last = self.t0
        # a log gets its first line after 10 s (a short stage adds none)
        self.last = 0.0 if self.tty else self.t0
        self.written = False

    def update(self, points: int, force: bool = False, key: Hashable = None,
               seconds: float = 0.0) -> None:
        """A task of ``points`` came back (``key`` and its compute ``seconds``: the work
        estimate's)."""
        self.done_tasks += 1
        self.points += points if self.unit == "points" else 1
        now = time.perf_counter()
        self.compute += float(seconds)
        self.t_last = now
        if self.work is not None and key is not None:
            self.work.done(key, seconds)
        if not force and now - self.last < (0.5 if self.tty else 10.0):
            return
        self.last = now
        elapsed = now - self.t0
        rate = self.points / elapsed if elapsed > 0 else 0.0
        eta = self.eta(now)
        line = (f"hertzmap: {self.label}: {self.done_tasks}/{self.total_tasks} tasks  "
                f"{rate:,.{0 if self.unit == 'points' else 1}f} {self.unit}/s  "
                f"ETA {fmt_time(eta)}")
        if self.tty:
            self.stream.write("\r" + line.ljust(72))
        else:
            self.stream.write(line + "\n")
        self.written = True
        self.stream.flush()

    def eta(self, now: float) -> float:
        """Seconds left: the work estimate's compute ahead, less what the tasks in flight did
        since the last one came back, over the compute done per second of wall; without an
        estimate, the points left at the points' rate so far."""
        elapsed = now - self.t0
        if elapsed <= 0.0:
            return math.inf
        if self.work is None or self.compute <= 0.0:
            rate = self.points / elapsed
            return (self.total_points - self.points) / rate if rate > 0 else math.inf
        throughput = self.compute / elapsed          # compute seconds per second of wall
        ahead = self.work.remaining() - throughput * (now - self.t_last)
        return max(0.0, ahead) / throughput

    def close(self) -> None:
        if self.tty and self.written and self.keeps_lines:
            self.stream.write("\n")
            self.stream.flush()
