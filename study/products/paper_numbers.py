"""Numbers the paper states, derived from products (VALIDATION.md): the lowest point of the flip
curve (sigma*) and where a branch ends along a line (the downward jump of Fig. 6)."""
from __future__ import annotations

from typing import Iterable

import numpy as np
import xarray as xr

def flip_minimum(lcm: xr.Dataset, zeta: float) -> tuple[float, float]:
    """(omega, sigma) of the lowest point of the numerical flip curve at ``zeta`` (sigma*).

    On each omega line of the grid, the lowest sigma where ``flip_indicator_1T`` changes sign
    (+ to -) is interpolated linearly; a parabola through the lowest such crossing and its two
    neighbours gives the minimum (accurate when the omega step is below about zeta)."""
    m = lcm.sel(zeta=zeta, method="nearest")
    f = m["flip_indicator_1T"].transpose("omega", "sigma").values
    om, sg = m["omega"].values, m["sigma"].values
    cross = np.full(om.size, np.nan)
    for i in range(om.size):
        with np.errstate(invalid="ignore"):
            k = np.flatnonzero((f[i, :-1] > 0) & (f[i, 1:] <= 0))
        if k.size:
            j = k[0]
            cross[i] = sg[j] + (sg[j + 1] - sg[j]) * f[i, j] / (f[i, j] - f[i, j + 1])
    if not np.isfinite(cross).any():
        return (np.nan, np.nan)
    i = int(np.nanargmin(cross))
    if 0 < i < om.size - 1 and np.isfinite(cross[i - 1:i + 2]).all():
        a, b, c = np.polyfit(om[i - 1:i + 2], cross[i - 1:i + 2], 2)
        if a > 0:
            w = -b / (2 * a)
            return float(w), float(c - b * b / (4 * a))
    return float(om[i]), float(cross[i])


def branch_end(fr: xr.Dataset, classes: Iterable[int] = (2, 3), side: str = "low"
               ) -> float:
    """Lowest (``side="low"``) or highest omega of a line where an orbit of the given classes
    exists (default: stable 2T), e.g. the downward jump of paper Fig. 6 (accurate to one step)."""
    c = fr["orbit_class"].values
    has = np.isin(c, list(classes)).any(axis=tuple(range(1, c.ndim)))
    om = fr["omega"].values[has]
    if om.size == 0:
        return float("nan")
    return float(om.min() if side == "low" else om.max())

