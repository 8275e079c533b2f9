"""Shared branches of the continuation tests: the 1T branch at zeta 0.01, sigma 0.5 from omega
2.2 down (its two flips) and the 2T branch switched onto at its upper flip (down to its fold,
through contact loss, back to the 1T orbit at the lower flip)."""
from __future__ import annotations

import pytest

from hertzmap.kernels import continuation as cont
from hertzmap.study.solve.seeds import linear_response_seed

Z, S = 0.01, 0.5


@pytest.fixture(scope="package")
def branch_1t():
    return cont.continue_orbit(Z, linear_response_seed(2.2, S, Z), omega=2.2, sigma=S, period=1,
                               direction=-1, p_min=1.9, p_max=2.3, dp_max=0.01)


@pytest.fixture(scope="package")
def branch_2t(branch_1t):
    flip = max((p for p in branch_1t.special if p.kind == "flip"), key=lambda p: p.omega)
    x, w, _, tan = cont.switch_at_flip(Z, flip)
    return cont.continue_orbit(Z, x, omega=w, sigma=S, period=2, tangent=tan, p_min=0.3,
                               p_max=2.5)
