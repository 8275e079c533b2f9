"""Fixtures of the sweep tests (tests/study/solve/test_sweep.py, test_swept_sine.py): the
stepped sweeps of paper Fig. 6 both files read, made once per test process."""
from __future__ import annotations

import numpy as np
import pytest

from hertzmap.kernels import shoot
from hertzmap.study.solve.sweep import stepped_sweep

Z, S = 0.01, 0.5
#: paper Fig. 6 (sigma 0.5, zeta 0.01): the fold where the 2T branch born at the 1T flip ends
#: towards low omega (the "downward jump"), by this repo's continuation (VALIDATION.md)
FOLD_FIG6 = 0.4720910
#: how far a located jump may be from an independent value beyond its own bracket: the
#: oracle's root (xtol 1e-10, rtol 1e-11) and the kernels' shooting (rtol 1e-10) agree to ~1e-9
MARGIN = 1e-7


@pytest.fixture(scope="session")
def down_from_2t():
    """Down in omega from the stable 2T orbit at omega 0.50 (class III: contact loss)."""
    start = shoot(0.50, S, Z, 2, guess=(-26.4, 8.55))
    assert start.converged and start.minimal_period == 2 and start.stable
    return stepped_sweep("omega", np.round(np.arange(0.44, 0.5001, 0.01), 10),
                         {"sigma": S, "zeta": Z}, "down", start.x0)


@pytest.fixture(scope="session")
def up_from_1t():
    """Up in omega from the stable 1T orbit at omega 1.905, across the 1T flip near 1.978."""
    start = shoot(1.905, S, Z, 1, guess=(0.0, 0.0))
    assert start.converged and start.stable
    return stepped_sweep("omega", np.round(np.arange(1.905, 1.9951, 0.01), 10),
                         {"sigma": S, "zeta": Z}, "up", start.x0)
