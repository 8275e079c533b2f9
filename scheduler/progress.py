"""Progress of a run's stage on the terminal: tasks done, points (or tasks) per second, time
left."""
from __future__ import annotations

import math
import time
from typing import TextIO

from hertzmap.scheduler.report import fmt_time


def rewrites_in_place(stream: TextIO) -> bool:
    """Whether ``stream`` shows a line rewritten after a carriage return in place: a terminal,
    or a Jupyter cell's output (the kernel's stream, which notebooks render with ``\r`` as a
    terminal does; its ``isatty()`` says False)."""
    if hasattr(stream, "isatty") and stream.isatty():
        return True
    return type(stream).__module__.startswith("ipykernel.")


class Progress:
    """One line per update: rewritten in place on a terminal or in a notebook's cell (every
    0.5 s at most), appended every 10 s otherwise (logs of batch jobs; none for a stage
    shorter than that). ``label``: the stage (``grid``, ``atlas round 2``, ...); ``unit``: what
    the rate counts (``points``: the tasks' sizes; ``tasks``)."""

    def __init__(self, stream: TextIO, label: str, total_tasks: int, total_points: int,
                 done_tasks: int, unit: str = "points"):
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
        self.t0 = time.perf_counter()
        # a log gets its first line after 10 s (a short stage adds none)
        self.last = 0.0 if self.tty else self.t0
        self.written = False

    def update(self, points: int, force: bool = False) -> None:
        self.done_tasks += 1
        self.points += points if self.unit == "points" else 1
        now = time.perf_counter()
        if not force and now - self.last < (0.5 if self.tty else 10.0):
            return
        self.last = now
        elapsed = now - self.t0
        rate = self.points / elapsed if elapsed > 0 else 0.0
        eta = (self.total_points - self.points) / rate if rate > 0 else math.inf
        line = (f"hertzmap: {self.label}: {self.done_tasks}/{self.total_tasks} tasks  "
                f"{rate:,.{0 if self.unit == 'points' else 1}f} {self.unit}/s  "
                f"ETA {fmt_time(eta)}")
        if self.tty:
            self.stream.write("\r" + line.ljust(72))
        else:
            self.stream.write(line + "\n")
        self.written = True
        self.stream.flush()

    def close(self) -> None:
        if self.tty and self.written and self.keeps_lines:
            self.stream.write("\n")
            self.stream.flush()
