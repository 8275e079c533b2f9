"""What a computed orbit is, defined once: its class (paper Fig. 6, extended) and when two
computed orbits are the same orbit.

Both rules are used by the solver (to keep each orbit once at a grid point), by the products (to
classify and count the stored slots) and by the tests; nothing else defines them.

Classes
-------
Codes 1-5 are paper Fig. 6's classes I-V; 6-8 extend them to the 1T orbits the paper does not
label (the primary resonance with contact loss, and the unstable 1T orbits between folds or past a
flip); 9-10 are the orbits of longer periods m >= 3 (4T from a 2T flip, 3T, 6T ... found by the
attractor census). Code 0 is an empty slot, a failed solve or a point not computed.

Identity
--------
Two orbits are the same when they have the same period and the same invariants: min q, max q
(within ``SAME_ORBIT_TOL (1 + ptp)``) and the trace of the monodromy (within
``SAME_ORBIT_TOL (1 + |tr M|)``). The invariants do not change under the T-shift of a 2T orbit
(its two start points at tau = 0 and tau = T are one orbit), and the trace separates a 1T orbit
from the 2T solve that landed on it (whose monodromy is M^2). The tolerance is four orders above
the solver's accuracy (rtol 1e-10 gives start points within ~1e-9) and far below the distance
between distinct coexisting orbits on the paper's maps.

Continuity
----------
Two orbits at neighbouring grid points lie on one branch when they have the same period, their
invariants (min q, max q) differ by at most ``CONTINUITY_SHARE (1 + ptp)`` and their fold
functions (1 - mu1)(1 - mu2) do not have opposite signs (a branch changes that sign only at a
fold, where it turns back): :func:`match_neighbours` pairs them one to one, closest first. The
line search (study.solve.line) finds its branch ends with it, the traced curves' seeds
(study.solve.curve_seeds) the sign changes of the test functions between neighbouring grid points.
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = [
    "ORBIT_CLASSES",
    "CLASS_NAMES",
    "CLASS_LABELS",
    "SAME_ORBIT_TOL",
    "class_code",
    "class_codes",
    "same_orbit",
    "first_of_duplicates",
    "CONTINUITY_SHARE",
    "FOLD_SIGN_FLOOR",
    "fold_function",
    "continuity_distance",
    "match_neighbours",
]

#: (code, flag name, description) of every orbit class.
ORBIT_CLASSES: tuple[tuple[int, str, str], ...] = (
    (0, "none", "empty slot, failed solve or not computed"),
    (1, "I_1T_stable", "I: 1T stable, in contact"),
    (2, "II_2T_stable_contact", "II: 2T stable without loss of contact"),
    (3, "III_2T_stable_contact_loss", "III: 2T stable with loss of contact"),
    (4, "IV_2T_unstable_contact", "IV: 2T unstable without loss of contact"),
    (5, "V_2T_unstable_contact_loss", "V: 2T unstable with loss of contact"),
    (6, "1T_stable_contact_loss", "1T stable with loss of contact (primary resonance impacts)"),
    (7, "1T_unstable_contact", "1T unstable, in contact"),
    (8, "1T_unstable_contact_loss", "1T unstable with loss of contact"),
    (9, "mT_stable", "stable, period m >= 3 (m T, T = 2 pi / omega)"),
    (10, "mT_unstable", "unstable, period m >= 3"),
)
#: Code -> description.
CLASS_NAMES = {code: desc for code, _, desc in ORBIT_CLASSES}
#: Code -> short label (legends of figures).
CLASS_LABELS = {1: "I: 1T stable", 2: "II: 2T stable, contact", 3: "III: 2T stable, contact loss",
                4: "IV: 2T unstable, contact", 5: "V: 2T unstable, contact loss",
                6: "1T stable, contact loss", 7: "1T unstable", 8: "1T unstable, contact loss",
                9: "period m >= 3, stable", 10: "period m >= 3, unstable"}

#: Relative tolerance of the identity rule (see the module docstring).
SAME_ORBIT_TOL = 1e-6


def class_codes(ok, period, stable, loses_contact) -> np.ndarray:
    """Class code of each orbit from its flags (arrays broadcast; int8). ``ok``: the slot holds a
    converged orbit (else class 0)."""
    ok = np.asarray(ok, bool)
    period = np.asarray(period)
    p1 = ok & (period == 1)
    p2 = ok & (period == 2)
    s = np.asarray(stable, bool)
    lc = np.asarray(loses_contact, bool)
    code = np.zeros(np.broadcast(ok, period, s, lc).shape, np.int8)
    code[p1 & s & ~lc] = 1
    code[p2 & s & ~lc] = 2
    code[p2 & s & lc] = 3
    code[p2 & ~s & ~lc] = 4
    code[p2 & ~s & lc] = 5
    code[p1 & s & lc] = 6
    code[p1 & ~s & ~lc] = 7
    code[p1 & ~s & lc] = 8
    longer = ok & (period >= 3)
    code[longer & s] = 9
    code[longer & ~s] = 10
    return code


def class_code(orbit) -> int:
    """Class code of one converged orbit: a solution mapping (study.solve) or a kernels.Orbit."""
    get = orbit.get if _is_mapping(orbit) else lambda k: getattr(orbit, k)
    return int(class_codes(True, get("period"), bool(get("stable")),
                           bool(get("loses_contact"))))


def _is_mapping(x) -> bool:
    # the solver's orbits are dicts: the exact type test first (the ABC's check is ~10x slower
    # and same_orbit runs ~30,000 times per 20 lines of the default study)
    return type(x) is dict or isinstance(x, Mapping)


def _trace(orbit: Any) -> float:
    if _is_mapping(orbit):
        if "trace_m" in orbit:
            return float(orbit["trace_m"])
        return float(np.sum(orbit["multipliers"]).real)
    return float(np.sum(orbit.multipliers).real)


def same_orbit(a, b) -> bool:
    """The identity rule on two converged orbits (mappings with period, min_q, max_q, ptp and
    trace or multipliers, or kernels.Orbit objects)."""
    get_a = a.get if _is_mapping(a) else lambda k: getattr(a, k)
    get_b = b.get if _is_mapping(b) else lambda k: getattr(b, k)
    if get_a("period") != get_b("period"):
        return False
    tol = SAME_ORBIT_TOL * (1.0 + abs(get_a("ptp")))
    ta, tb = _trace(a), _trace(b)
    return (abs(get_a("min_q") - get_b("min_q")) <= tol
            and abs(get_a("max_q") - get_b("max_q")) <= tol
            and abs(ta - tb) <= SAME_ORBIT_TOL * (1.0 + abs(ta)))


def first_of_duplicates(ok, period, min_q, max_q, trace) -> np.ndarray:
    """The identity rule over stored slots: bool array (like ``ok``, slots on the last axis),
    True for each converged slot that is not the same orbit as a converged slot before it.
    ``trace``: tr M of each slot (the sum of its two multipliers)."""
    ok = np.asarray(ok, bool)
    per = np.asarray(period)
    lo = np.asarray(min_q, float)
    hi = np.asarray(max_q, float)
    tr = np.asarray(trace, float)
    keep = ok.copy()
    n = ok.shape[-1]
    with np.errstate(invalid="ignore"):
        for j in range(1, n):
            for i in range(j):
                tol = SAME_ORBIT_TOL * (1.0 + np.abs(hi[..., i] - lo[..., i]))
                same = (keep[..., i] & ok[..., j] & (per[..., i] == per[..., j])
                        & (np.abs(lo[..., i] - lo[..., j]) <= tol)
                        & (np.abs(hi[..., i] - hi[..., j]) <= tol)
                        & (np.abs(tr[..., i] - tr[..., j])
                           <= SAME_ORBIT_TOL * (1.0 + np.abs(tr[..., i]))))
                keep[..., j] &= ~same
    return keep


#: Two orbits at neighbouring grid points are one branch when their invariants (min q, max q)
#: differ by less than this share of (1 + ptp); beyond it the branch is taken as ended there.
#: A false end costs one turn attempt that finds nothing new; a missed end loses a branch: the
#: share is on the generous side of the jumps seen at folds (primary resonance: the upper and
#: lower branches differ by 2-5 in max q at ptp 3-8).
CONTINUITY_SHARE = 0.2
#: Fold functions below this are taken as zero (a fold at the grid point itself) when matching.
FOLD_SIGN_FLOOR = 1e-6


def fold_function(orbit) -> float:
    """(1 - mu1)(1 - mu2) = 1 - tr M + det M of an orbit (a mapping with ``multipliers``): zero
    at a fold, positive on its stable side."""
    mu = orbit["multipliers"]
    return float(((1.0 - mu[0]) * (1.0 - mu[1])).real)


def flip_function(orbit) -> float:
    """(1 + mu1)(1 + mu2) = 1 + tr M + det M of an orbit: zero at a flip (a multiplier -1),
    negative past it."""
    mu = orbit["multipliers"]
    return float(((1.0 + mu[0]) * (1.0 + mu[1])).real)


def continuity_distance(a, b) -> float:
    """Distance of two orbits' invariants (min q, max q): unchanged by the T-shift of an orbit
    of period > 1, unlike their start points."""
    return abs(a["min_q"] - b["min_q"]) + abs(a["max_q"] - b["max_q"])


def match_neighbours(A, B) -> list[tuple[int, int]]:
    """The continuity rule (module docstring) between the orbits ``A`` and ``B`` (mappings with
    period, min_q, max_q, ptp, multipliers) at two neighbouring grid points: (index in A, index
    in B) of the pairs on one branch, one to one, closest pairs first."""
    # (continuity_distance written out: the atlas calls this tens of thousands of times a
    # round, with a few orbits a side, and the calls cost more than the arithmetic)
    pairs = []
    for ia, x in enumerate(A):
        period, lo, hi = x["period"], x["min_q"], x["max_q"]
        for ib, y in enumerate(B):
            if y["period"] == period:
                pairs.append((abs(lo - y["min_q"]) + abs(hi - y["max_q"]), ia, ib))
    if not pairs:
        return []
    pairs.sort()
    # the fold functions of the orbits a pair needs, each computed once
    fold_a: dict[int, float] = {}
    fold_b: dict[int, float] = {}
    used_a, used_b = set(), set()
    out = []
    for d, ia, ib in pairs:
        if ia in used_a or ib in used_b:
            continue
        # along a branch the fold function (1 - mu1)(1 - mu2) changes sign only at a fold,
        # where the branch turns back: neighbours with opposite signs are two branches,
        # however close their invariants
        ga = fold_a.get(ia)
        if ga is None:
            ga = fold_a[ia] = fold_function(A[ia])
        gb = fold_b.get(ib)
        if gb is None:
            gb = fold_b[ib] = fold_function(B[ib])
        if ga * gb < 0.0 and min(abs(ga), abs(gb)) > FOLD_SIGN_FLOOR:
            continue
        if d <= CONTINUITY_SHARE * (1.0 + max(A[ia]["ptp"], B[ib]["ptp"])):
            used_a.add(ia)
            used_b.add(ib)
            out.append((ia, ib))
    return out
