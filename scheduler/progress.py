"""Progress of a run on the terminal: tasks done, points per second, time left."""
from __future__ import annotations

import math
import time
from typing import TextIO

from hertzmap.scheduler.report import fmt_time


class Progress:
    """One line per update: rewritten in place on a terminal (every 0.5 s at most), appended
    every 10 s otherwise (logs of batch jobs)."""

    def __init__(self, stream: TextIO, total_tasks: int, total_points: int, done_tasks: int):
        self.stream = stream
        self.tty = hasattr(stream, "isatty") and stream.isatty()
        self.total_tasks = total_tasks
        self.total_points = total_points
        self.done_tasks = done_tasks
        self.points = 0
        self.t0 = time.perf_counter()
        self.last = 0.0

    def update(self, points: int, force: bool = False) -> None:
        self.done_tasks += 1
        self.points += points
        now = time.perf_counter()
        if not force and now - self.last < (0.5 if self.tty else 10.0):
            return
        self.last = now
        elapsed = now - self.t0
        rate = self.points / elapsed if elapsed > 0 else 0.0
        eta = (self.total_points - self.points) / rate if rate > 0 else math.inf
        line = (f"hertzmap: {self.done_tasks}/{self.total_tasks} tasks  {rate:,.0f} points/s  "
                f"ETA {fmt_time(eta)}")
        if self.tty:
            self.stream.write("\r" + line.ljust(72))
        else:
            self.stream.write(line + "\n")
        self.stream.flush()

    def close(self) -> None:
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()
