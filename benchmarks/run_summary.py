"""The figures a ``hertzmap run`` prints, read back by the benchmarks that time whole runs
(run_cost.py, curve_cost.py, scale_cost.py, cold_start.py)."""
from __future__ import annotations

import re

#: field -> pattern of the summary line that prints it (its first group: seconds)
PATTERNS = {
    "setup": r"setup ([\d.]+) s",
    "wall": r"points in ([\d.]+) s wall",
    "compute": r"task compute ([\d.]+) s",
    "curves": r"curves: .*?([\d.]+) s wall \([\d.]+ s loading",
}


def run_summary(text: str) -> dict[str, float | None]:
    """The figures of a ``hertzmap run`` summary (scheduler.doors.report and scheduler.stages.curve_tasks
    print it), read back by the benchmarks that time whole runs: setup, grid wall, task compute
    and the curve stage, in seconds; a field its text does not print is None (``curves``
    when the run traced none)."""
    found = {}
    for name, pattern in PATTERNS.items():
        m = re.search(pattern, text)
        found[name] = float(m.group(1)) if m else None
    return found
