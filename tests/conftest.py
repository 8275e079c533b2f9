"""Shared fixtures and helpers.

``placeholder_solve_block`` is a stand-in with the exact contract of
``study.block.solve_block`` (shapes, dtypes, empty-slot values) but no physics: it lets the
scheduler and store be tested without the real solver. Workers import it as
``conftest:placeholder_solve_block`` (tests/ is put on their path). Never used by the CLI
unless asked for with the hidden ``--solver`` option.
"""

from __future__ import annotations

import importlib.util
import os
import socket
import sys
import time
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parent.parent
TESTS = Path(__file__).resolve().parent

HAVE_BLOCK = importlib.util.find_spec("study.block") is not None
needs_block = pytest.mark.skipif(not HAVE_BLOCK, reason="study/block.py (the real solver) not there yet")

PLACEHOLDER = "conftest:placeholder_solve_block"


def placeholder_solve_block(omega, sigma, zeta, *, periods=(1, 2), exponent=1.5, model="hertz",
                            rtol=1e-10, max_solutions=4, harmonics=True):
    """Deterministic fake with the solve_block contract (delay: $HERTZMAP_PLACEHOLDER_DELAY s/point)."""
    omega = np.asarray(omega, dtype=np.float64)
    sigma = np.asarray(sigma, dtype=np.float64)
    zeta = np.asarray(zeta, dtype=np.float64)
    shape = (len(omega), len(sigma), len(zeta), max_solutions)
    delay = float(os.environ.get("HERTZMAP_PLACEHOLDER_DELAY", "0"))
    if delay:
        time.sleep(delay * len(omega) * len(sigma) * len(zeta))
    w, s, z = np.meshgrid(omega, sigma, zeta, indexing="ij")
    out = {
        "period": np.zeros(shape, np.int8),
        "q0": np.full(shape, np.nan), "v0": np.full(shape, np.nan),
        "multipliers": np.full(shape + (2,), complex(np.nan, np.nan)),
        "stable": np.zeros(shape, bool),
        "min_q": np.full(shape, np.nan), "max_q": np.full(shape, np.nan),
        "ptp": np.full(shape, np.nan),
        "loses_contact": np.zeros(shape, bool),
        "flight_fraction": np.full(shape, np.nan),
        "max_impact_velocity": np.full(shape, np.nan),
        "force_harmonics": np.full(shape + (4,), np.nan),
        "newton_iterations": np.zeros(shape, np.int16),
        "residual": np.full(shape, np.nan),
        "status": np.full(shape, -1, np.int8),
    }
    amp = s / np.sqrt((1 - w**2) ** 2 + (2 * z * w) ** 2)
    slots = []
    if 1 in periods:
        slots.append((1, np.ones_like(w, bool)))
    if 2 in periods:
        slots.append((2, (w > 1.8) & (w < 2.2) & (s > 0.2)))
    for slot, (p, mask) in enumerate(slots[:max_solutions]):
        a = amp * p
        sl = (slice(None),) * 3 + (slot,)
        out["period"][sl] = np.where(mask, p, 0)
        out["status"][sl] = np.where(mask, np.where(a > 50, 1, 0), -1)
        out["q0"][sl] = np.where(mask, a, np.nan)
        out["v0"][sl] = np.where(mask, -a * w / p, np.nan)
        out["stable"][sl] = mask & (a < 2)
        out["min_q"][sl] = np.where(mask, -a, np.nan)
        out["max_q"][sl] = np.where(mask, a, np.nan)
        out["ptp"][sl] = np.where(mask, 2 * a, np.nan)
        out["loses_contact"][sl] = mask & (a > exponent)
        out["flight_fraction"][sl] = np.where(mask, np.clip((a - exponent) / (a + 1), 0, 1), np.nan)
        out["max_impact_velocity"][sl] = np.where(mask, a * w, np.nan)
        out["multipliers"][sl] = np.where(mask[..., None], np.exp(-z * p * np.pi / w)[..., None]
                                          * np.array([1, 1j]), complex(np.nan, np.nan))
        if harmonics:   # as solve_block: NaN unless asked for
            out["force_harmonics"][sl] = np.where(mask[..., None], a[..., None] / np.arange(1, 5),
                                                  np.nan)
        out["newton_iterations"][sl] = np.where(mask, 3, 0)
        out["residual"][sl] = np.where(mask, 1e-12, np.nan)
    return out


def failing_solve_block(omega, sigma, zeta, **kwargs):
    """The placeholder, but raising for blocks with a sigma above 0.85 (a task failing for good)."""
    if np.max(sigma) > 0.85:
        raise FloatingPointError(f"placeholder failure at sigma = {np.max(sigma)}")
    return placeholder_solve_block(omega, sigma, zeta, **kwargs)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def subprocess_env(**extra) -> dict[str, str]:
    """Environment for CLI / dask subprocesses: repo and tests/ importable."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), str(TESTS), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    env.update({k: str(v) for k, v in extra.items()})
    return env


def hertzmap_cmd(*args: str) -> list[str]:
    return [sys.executable, "-m", "scheduler.cli", *args]


@pytest.fixture
def study_file(tmp_path):
    """Write a study file; returns a function (text, name) -> path."""
    def write(text: str, name: str = "t") -> Path:
        p = tmp_path / f"{name}.toml"
        p.write_text(text)
        return p
    return write


def done_count(store) -> int:
    """Tasks marked done in a store (0 while it does not exist or cannot be read yet)."""
    from scheduler.store import Store
    try:
        return int(Store(store).done_mask().sum())
    except Exception:
        return 0


def wait_until(pred, timeout: float, what: str) -> None:
    t0 = time.monotonic()
    while not pred():
        if time.monotonic() - t0 > timeout:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.02)


def kill_client_mid_study(cmd, env, store, tasks: int) -> int:
    """Start `hertzmap run` (cmd) in its own process group, SIGKILL the whole group (client,
    scheduler, workers) once ``tasks`` tasks are done, and return how many were done."""
    import signal
    import subprocess
    p = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                         start_new_session=True)
    try:
        wait_until(lambda: done_count(store) >= tasks or p.poll() is not None, 90,
                   f"{tasks} tasks")
        os.killpg(p.pid, signal.SIGKILL)
        p.wait(timeout=30)
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
    return done_count(store)
