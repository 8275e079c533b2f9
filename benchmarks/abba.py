"""Same-run A/B: two variants of one measurement (Python callables or commands) run in ABBA
rounds on this machine, in this run, and compared pair by pair.

    .venv/bin/python benchmarks/abba.py [--rounds 4] [--warm-up] "COMMAND A" "COMMAND B"
        [--figure "NAME=REGEX"]                  (prints each run, then B / A pair by pair)

Round k runs the variants in their order when k is even and in reverse when it is odd (A B,
B A, A B, ...: with more variants, A B C, C B A, ...), so that a drift of the machine's speed
falls on every variant alike and each A run has its B run beside it. A round's ratio is the two
variants' figures in that round (an A run against its neighbouring B run); the report gives every
ratio, their median (the figure to quote) and their spread (min-max), and the machine's load
average over the rounds: on a shared machine walls move with it, same-run ratios much less.
Ratios of totals or of each variant's best run are left to the caller (``Result.of``).

Every run is timed: ``wall`` (time.perf_counter) and ``cpu`` (this process's CPU and that of the
child processes that ended during the run: a command's, its workers' once reaped). A callable
is called with the round's index and may return a dict: its numbers are figures of the run too
(census CPU, grid wall read off a summary, bytes on disk; one named ``wall`` or ``cpu`` takes
the place of the harness's own), the whole return is ``Run.value``.
A command (``Command``: argv, or a function of the round's index giving argv) returns its
output, and the figures ``parse`` reads off it.

The A/B scripts of benchmarks/ time through this module (ab_kernels.py, census_ab.py,
search_ab.py, cold_start.py clone, run_cost.py curves / store / task-size / scale); each keeps
its own logic (what a variant runs, what is compared besides time).
"""
from __future__ import annotations

import argparse
import os
import re
import resource
import shlex
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence


def load_average() -> str:
    """The 1, 5 and 15 minute load averages, as "1.46 1.50 1.40": every timed benchmark
    prints them (on a shared machine the walls move with them, same-run ratios less)."""
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def load_line() -> str:
    """"load average 1.46 1.50 1.40", as the benchmarks print it before and after a run."""
    return "load average " + load_average()


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


class RunFailed(RuntimeError):
    pass


@dataclass
class Command:
    """A variant that runs a command: ``argv`` (a list, a string split like a shell's, or a
    function of the round's index giving either), in ``cwd`` with ``env``; ``parse`` reads
    figures off its output (stdout and stderr). Returns {"output": text, **figures}."""
    argv: Sequence[str] | str | Callable[[int], Sequence[str] | str]
    env: Mapping[str, str] | None = None
    cwd: str | Path | None = None
    parse: Callable[[str], Mapping[str, Any]] | None = None

    def __call__(self, k: int) -> dict[str, Any]:
        argv = self.argv(k) if callable(self.argv) else self.argv
        argv = shlex.split(argv) if isinstance(argv, str) else list(argv)
        p = subprocess.run(argv, capture_output=True, text=True, cwd=self.cwd,
                           env=None if self.env is None else dict(self.env))
        text = p.stdout + p.stderr
        if p.returncode != 0:
            raise RunFailed(f"{shlex.join(argv)} exited {p.returncode}:\n{text[-3000:]}")
        out: dict[str, Any] = {"output": text}
        if self.parse is not None:
            out.update(self.parse(text))
        return out


def figure_parser(patterns: Mapping[str, str]) -> Callable[[str], dict[str, float]]:
    """A ``parse`` for Command: name -> regex whose first group is a number."""
    def parse(text: str) -> dict[str, float]:
        got = {}
        for name, pattern in patterns.items():
            m = re.search(pattern, text, re.M)
            if m:
                got[name] = float(m.group(1))
        return got
    return parse


@dataclass
class Run:
    name: str
    round: int
    wall: float
    cpu: float
    load: float                       # 1-minute load average when the run started
    figures: dict[str, float] = field(default_factory=dict)
    value: Any = None

    def __getitem__(self, key: str) -> float:
        if key in self.figures:
            return self.figures[key]
        if key in ("wall", "cpu"):
            return getattr(self, key)
        raise KeyError(f"run {self.name} of round {self.round} has no figure {key!r} "
                       f"(it has wall, cpu{''.join(', ' + k for k in self.figures)})")


@dataclass
class Result:
    names: list[str]
    runs: list[Run]
    load_before: str
    load_after: str = ""

    def rounds(self) -> int:
        return 1 + max((r.round for r in self.runs), default=-1)

    def run(self, name: str, k: int) -> Run:
        return next(r for r in self.runs if r.name == name and r.round == k)

    def of(self, name: str, key: str = "wall") -> list[float]:
        """The figure ``key`` of each run of ``name``, round by round."""
        return [r[key] for r in self.runs if r.name == name]

    def ratios(self, num: str, den: str, key: str = "wall") -> list[float]:
        """``num`` / ``den``, round by round (each run against its neighbour in the round);
        a round whose ``den`` is 0 (nothing measured: a line without census points) has none."""
        pairs = [(self.run(num, k)[key], self.run(den, k)[key]) for k in range(self.rounds())]
        return [x / y for x, y in pairs if y != 0]

    def loads(self) -> tuple[float, float]:
        values = [r.load for r in self.runs] + [os.getloadavg()[0]]
        return min(values), max(values)

    def report(self, num: str, den: str, key: str = "wall", label: str | None = None,
               digits: int = 2) -> str:
        """"LABEL, pair by pair: 1.16, 1.11, 1.08; median 1.11, spread 1.08-1.16 (3 pairs);
        load average 1.3-1.9" (LABEL: "num / den (key)")."""
        r = self.ratios(num, den, key)
        lo, hi = self.loads()
        f = f".{digits}f"
        head = f"{label or f'{num} / {den} ({key})'}, pair by pair: "
        if not r:
            return head + f"none (no round measured {den}); load average {lo:.1f}-{hi:.1f}"
        return (head + ", ".join(format(x, f) for x in r)
                + f"; median {statistics.median(r):{f}}, spread {min(r):{f}}-{max(r):{f}} "
                f"({len(r)} pair{'s' if len(r) != 1 else ''}); load average {lo:.1f}-{hi:.1f}")


def abba(variants: Mapping[str, Callable[[int], Any]], rounds: int, *, warm_up: bool = False,
         each: Callable[[Run], None] | None = None) -> Result:
    """Run ``variants`` (name -> callable of the round's index) in ``rounds`` ABBA rounds.
    ``warm_up``: each variant once first, untimed (compiles, caches), called with -1. ``each(run)`` is called
    after every run (to print it)."""
    names = list(variants)
    result = Result(names, [], load_average())
    if warm_up:
        for name in names:
            variants[name](-1)
    for k in range(rounds):
        for name in (names if k % 2 == 0 else names[::-1]):
            load = os.getloadavg()[0]
            cpu0, child0 = time.process_time(), _children_cpu()
            t0 = time.perf_counter()
            value = variants[name](k)
            wall = time.perf_counter() - t0
            cpu = time.process_time() - cpu0 + _children_cpu() - child0
            figures = ({key: float(v) for key, v in value.items()
                        if isinstance(v, (int, float)) and not isinstance(v, bool)}
                       if isinstance(value, Mapping) else {})
            run = Run(name, k, wall, cpu, load, figures, value)
            result.runs.append(run)
            if each is not None:
                each(run)
    result.load_after = load_average()
    return result


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("commands", nargs="+", metavar="COMMAND",
                    help="the variants, each one command (quoted); the first is A")
    ap.add_argument("--rounds", type=int, default=4, help="ABBA rounds (default 4)")
    ap.add_argument("--warm-up", action="store_true", help="run each command once first, untimed")
    ap.add_argument("--figure", action="append", default=[], metavar="NAME=REGEX",
                    help="a figure read off each run's output (the regex's first group)")
    a = ap.parse_args(argv)
    if len(a.commands) < 2:
        ap.error("give at least two commands")
    figures = dict(f.split("=", 1) for f in a.figure)
    names = [chr(ord("A") + i) for i in range(len(a.commands))]
    for name, cmd in zip(names, a.commands):
        print(f"{name}: {cmd}")
    variants = {n: Command(c, parse=figure_parser(figures)) for n, c in zip(names, a.commands)}

    def show(run: Run) -> None:
        extra = "".join(f", {k} {v:g}" for k, v in run.figures.items())
        print(f"  round {run.round + 1} {run.name}: wall {run.wall:.2f} s, CPU {run.cpu:.2f} s"
              f"{extra} (load {run.load:.2f})", flush=True)

    print(load_line(), flush=True)
    res = abba(variants, a.rounds, warm_up=a.warm_up, each=show)
    for name in names[1:]:
        for key in ("wall", "cpu", *figures):
            if all(key in ("wall", "cpu") or key in r.figures for r in res.runs
                   if r.name in (name, "A")):
                print(res.report(name, "A", key))
    print(load_line())
    return 0


if __name__ == "__main__":
    sys.exit(main())
