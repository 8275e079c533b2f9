"""Where Newton starts: the seeds of the grid solver (paper section 3.2).

* the linear 1T response (paper Eq. 7 linearised about the static point);
* the multiple-scales 2T response (paper Eq. 19-23, study.analytic.multiple_scales), both
  branches;
* the flip eigenvector of a 1T orbit with a multiplier below -1 (the 2T branch leaves the 1T
  orbit along it, x0 +- d e);
* continuation from the neighbouring grid point (a secant predictor along the branch).

Each seed is a (q, q') pair at tau = 0, dimensionless.
"""
from __future__ import annotations

import warnings

import numpy as np

from hertzmap.kernels import status as st

#: Initial states of transients are spread over this box of (q, q'), which holds the orbits of
#: the paper's maps at moderate sigma (a state outside it decays into it within a few periods).
TRANSIENT_BOX = ((-6.0, 4.0), (-5.0, 5.0))


def _halton(i, base):
    """The i-th element of the van der Corput sequence in ``base`` (a Halton coordinate)."""
    f, r = 1.0, 0.0
    while i > 0:
        f /= base
        r += f * (i % base)
        i //= base
    return r


def initial_states(count: int, reach=None) -> list[tuple[float, float]]:
    """The static point and count - 1 Halton points (bases 2, 3) in TRANSIENT_BOX; with
    ``reach`` (a box ((q_lo, q_hi), (v_lo, v_hi)) larger than TRANSIENT_BOX: reach_box), the
    Halton points alternate between TRANSIENT_BOX and ``reach``, each box's points its own
    Halton sequence (so both are evenly covered)."""
    out = [(0.0, 0.0)]
    n = {0: 0, 1: 0}
    for i in range(1, count):
        box = TRANSIENT_BOX if reach is None or i % 2 else reach
        k = 0 if box is TRANSIENT_BOX else 1
        n[k] += 1
        (q0, q1), (v0, v1) = box
        out.append((q0 + (q1 - q0) * _halton(n[k], 2), v0 + (v1 - v0) * _halton(n[k], 3)))
    return out[:max(count, 0)]


#: the share of an orbit's q extent added on each side of the reach box
REACH_MARGIN = 0.1


def reach_box(orbits) -> tuple | None:
    """Where the motion of a point can go, from the largest of its known orbits (mappings
    with min_q, max_q; converged ones): TRANSIENT_BOX grown in q to cover them (with a
    REACH_MARGIN share of their extent on each side), and in q' like the square root of the
    q extent's growth (in a flight the speed grows like the square root of its height: the
    force is bounded). None when the orbits fit in TRANSIENT_BOX (the box is the reach)."""
    (q0, q1), (v0, v1) = TRANSIENT_BOX
    lo = min((float(o["min_q"]) for o in orbits), default=q0)
    hi = max((float(o["max_q"]) for o in orbits), default=q1)
    if lo >= q0 and hi <= q1:
        return None
    pad = REACH_MARGIN * (hi - lo)
    lo, hi = min(q0, lo - pad), max(q1, hi + pad)
    grow = np.sqrt((hi - lo) / (q1 - q0))
    return (lo, hi), (v0 * grow, v1 * grow)


#: Distances d along the flip eigenvector at which 2T seeds are placed (both signs).
FLIP_SEED_OFFSETS = (0.05, 0.3)


def linear_response_seed(omega, sigma, zeta):
    """(q, q') at tau = 0 of the linearised 1T response: q = Re[X e^{i omega tau}],
    X = sigma / (1 - omega^2 + 2 i zeta omega)."""
    den = 1.0 - omega**2 + 2j * zeta * omega
    if den == 0:            # undamped exact resonance: no linear response; start at rest
        return 0.0, 0.0
    X = sigma / den
    return X.real, (1j * omega * X).real


MMS_WINDOW = None


def mms_seeds(omega, sigma, zeta):
    """Multiple-scales 2T seeds (both branches of Eq. 23, where real) at every omega of a line:
    a list, per omega, of (q0, v0) pairs. Evaluated once per line (the functions broadcast)."""
    # Far from omega = 2 the multiple-scales response is no theory, but it is a cheap seed that
    # lands on unstable halves of 2T branches the sweeps miss (measured on sigma 0.2/0.5/0.8
    # lines: restricting it to |omega - 2| < 0.3 lost 17 unstable orbits of 1330).
    from hertzmap.study.analytic.multiple_scales import mms_2t_seed

    omega = np.atleast_1d(np.asarray(omega, float))
    seeds = [[] for _ in range(omega.size)]
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        for branch in ("upper", "lower"):
            q, v = mms_2t_seed(omega, sigma, zeta, branch)
            q = np.broadcast_to(np.asarray(q, float), omega.shape)
            v = np.broadcast_to(np.asarray(v, float), omega.shape)
            for i in range(omega.size):
                if MMS_WINDOW is not None and abs(omega[i] - 2.0) > MMS_WINDOW:
                    continue
                if np.isfinite(q[i]) and np.isfinite(v[i]):
                    seeds[i].append((float(q[i]), float(v[i])))
    return seeds


def flip_seeds(sol):
    """Seeds of twice the orbit's period along the eigenvector of a multiplier below -1 (past a
    flip: 2T seeds from a 1T orbit, 4T seeds from a 2T orbit, ...)."""
    if sol["status"] != st.CONVERGED:
        return []
    M = sol["monodromy"]
    # np.linalg.eig is most of this function's cost and gives no seed unless a multiplier is
    # below -0.95: skip it where the kernel's multipliers (roots of mu^2 - tr M mu + det M,
    # the same M) are both above -0.9. For |M_ij| < 1e4 the two computations differ by less
    # than ~sqrt(eps) |M| ~ 1e-4 (the eigenvalue perturbation bound of a 2x2 matrix), well
    # inside the 0.05 margin: the seeds are exactly those eig gives.
    mu = sol["multipliers"]
    if mu[0].real > -0.9 and mu[1].real > -0.9 and np.abs(M).max() < 1e4:
        return []
    w, V = np.linalg.eig(M)
    seeds = []
    for k in range(2):
        if abs(w[k].imag) < 1e-12 and w[k].real < -0.95:
            e = np.real(V[:, k])
            e /= np.linalg.norm(e)
            for d in FLIP_SEED_OFFSETS:
                seeds.append(tuple(sol["x0"] + d * e))
                seeds.append(tuple(sol["x0"] - d * e))
    return seeds


def continuation_seed(sol, omega):
    """Seed at omega from a solution of the neighbouring point: a secant predictor along the
    branch when the solution itself came from continuation, else its start point."""
    # Python floats: the same IEEE operations as on 2-element arrays, at a fraction of the cost
    q, v = sol["x0"].tolist()
    if "x0_prev" in sol and sol["omega"] != sol["omega_prev"]:
        step = (omega - sol["omega"]) / (sol["omega"] - sol["omega_prev"])
        q_prev, v_prev = sol["x0_prev"].tolist()
        dq, dv = q - q_prev, v - v_prev
        if (0.0 < step <= 2.0 and abs(dq) < 0.5 * (1.0 + abs(q))
                and abs(dv) < 0.5 * (1.0 + abs(v))):
            return q + step * dq, v + step * dv
    return q, v
