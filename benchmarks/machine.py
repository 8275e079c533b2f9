"""What the benchmarks print about the machine they ran on."""
from __future__ import annotations

import os


def load_average() -> str:
    """The 1, 5 and 15 minute load averages, as "1.46 1.50 1.40": every timed benchmark
    prints them (on a shared machine the walls move with them, same-run ratios less)."""
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def load_line() -> str:
    """"load average 1.46 1.50 1.40", as the benchmarks print it before and after a run."""
    return "load average " + load_average()
