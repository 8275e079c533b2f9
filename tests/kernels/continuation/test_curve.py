"""kernels.continuation.curve: traced fold, flip and grazing curves (trace_curve) and their
codimension-2 points and extrema, against the independent scipy oracle (benchmarks/oracle.py)
and the multiple-scales minimum of the flip curve."""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks import oracle as O
from hertzmap.kernels import continuation as cont
from hertzmap.study.analytic import multiple_scales as ms
from hertzmap.study.solve.seeds import linear_response_seed
from tests.kernels.continuation.conftest import S, Z

# Each check solves the curve's condition with benchmarks/oracle.py (scipy solve_ivp with the
# contact switches as events, scipy root/brentq/minimize_scalar, the monodromy from the
# variational equations) on a line through a vertex (one parameter held at the vertex's value)
# and compares the other parameter. The oracle shares no code with kernels/.


def _vertex(curve, i):
    V = curve.vertices
    return V["omega"][i], V["sigma"][i], V["zeta"][i], (V["q0"][i], V["v0"][i])


def _oracle_sigma(curve, i, point, half_width, m=1):
    """Vertex i's sigma and the oracle's (``point``: O.flip_point or O.grazing_point) at the
    vertex's omega, sigma free within ``half_width`` of it: (sigma, oracle's sigma, its x)."""
    w, s, z, x = _vertex(curve, i)
    so, xo = point(x, (s - half_width, s + half_width), fixed="omega", free="sigma",
                   params=dict(omega=w, sigma=s, zeta=z), m=m)
    return s, so, xo


@pytest.fixture(scope="module")
def flip_curve_0005():
    """The 1T flip curve at zeta 0.005 (paper Fig. 7) across omega 1.9..2.1, sigma 0.15..0.5."""
    z = 0.005
    b = cont.continue_orbit(z, linear_response_seed(2.1, 0.3, z), omega=2.1, sigma=0.3,
                            period=1, direction=-1, p_min=1.95, p_max=2.15, dp_max=0.01)
    f = [p for p in b.special if p.kind == "flip"][0]
    return cont.trace_curve(f.x0, f.omega, 0.3, z, kind="flip", period=1,
                            bounds={"omega": (1.9, 2.1), "sigma": (0.15, 0.5)})


def test_flip_curve_points_match_the_oracle(flip_curve_0005):
    c = flip_curve_0005
    V = c.vertices
    assert c.status == (cont.BOUNDARY, cont.BOUNDARY)
    assert np.all(np.abs(V["flip"]) < 1e-9) and np.all(V["residual"] < 1e-9)
    # both ends on the window's edge (sigma = 0.5), the lowest sigma a refined vertex
    assert np.allclose(V["sigma"][[0, -1]], 0.5, atol=1e-12)
    flags = V["flag"].astype(int)
    k = int(np.argmin(V["sigma"]))
    assert flags[k] & cont.VERTEX_EXTREMUM
    # the multiple-scales minimum (paper Eq. 25b, derived gamma) is an expansion of the Taylor
    # model, not of the Hertz law: the two minima differ by ~2.5e-5 here (docs/discovery.md),
    # inside the tolerance; the minimum sits near omega = 2 (paper Eq. 26-27)
    assert abs(V["sigma"][k] - float(ms.sigma_star(0.005, "min"))) < 1e-4
    assert abs(V["omega"][k] - 2.0) < 1e-3
    for i in (k, len(c) // 5):
        s, so, xo = _oracle_sigma(c, i, O.flip_point, 1e-3)
        assert abs(s - so) < 1e-8, (i, s, so)
        assert np.hypot(V["q0"][i] - xo[0], V["v0"][i] - xo[1]) < 1e-7


@pytest.fixture(scope="module")
def isola_fold_curve():
    """The 2T fold curve of the isola at zeta 0.01 (paper Fig. 8-9), from a fold located on
    the sigma = 0.2 line, across omega 1..2.2, sigma 0.1..0.5: orbits with long flights."""
    from hertzmap.study.solve.discovery import discover_line

    line = discover_line(np.linspace(1.0, 2.0, 21), 0.2, 0.01, transients=0)
    f = min((d for d in line.special if d["kind"] == "fold" and d["period"] == 2),
            key=lambda d: d["omega"])
    return cont.trace_curve((f["q0"], f["v0"]), f["omega"], 0.2, 0.01, kind="fold", period=2,
                            bounds={"omega": (1.0, 2.2), "sigma": (0.1, 0.5)})


def test_isola_fold_curve_sigma_star2_and_join(isola_fold_curve):
    c = isola_fold_curve
    V = c.vertices
    assert set(c.status) == {cont.BRANCH_POINT, cont.BOUNDARY}
    assert np.all(np.abs(V["fold"][V["flag"].astype(int) & cont.VERTEX_END == 0]) < 1e-9)
    assert np.nanmin(V["min_q"]) < -1.5                   # the isola's orbits lose contact
    # sigma**: the curve's lowest sigma, a refined extremum vertex; against the oracle's fold
    # at fixed omega (the extremum of sigma along the oracle's branch)
    k = int(np.argmin(V["sigma"]))
    assert V["flag"][k].astype(int) & cont.VERTEX_EXTREMUM
    w, s, z, x = _vertex(c, k)
    so, _ = O.fold_on_line(x, fixed="omega", free="sigma", params=dict(omega=w, sigma=s, zeta=z),
                         m=2)
    assert abs(s - so) < 1e-8, (s, so)
    assert 0.16 < s < 0.17 and 1.45 < w < 1.55               # paper: sigma** ~ 0.165 near 1.5
    # the end on the 1T orbit: where the isola joins the flip-born branch; the 1T orbit there
    # has a multiplier -1 (the oracle's own monodromy)
    join = [p for p in c.codim2 if p.kind == "fold_flip"]
    assert len(join) == 1 and join[0].accuracy < 1e-7
    p = join[0]
    _, M, _ = O.shoot(p.x0, p.omega, p.sigma, p.zeta, 1, rtol=1e-12)
    g = O.flip_function(M)
    assert abs(g) < 1e-6, g
    assert abs(p.sigma - 0.3596) < 1e-3 and abs(p.omega - 1.9996) < 1e-3
    # the grazing of the 2T orbit met on the way: the grazing function changes sign across it
    fg = [p for p in c.codim2 if p.kind == "fold_grazing"]
    assert len(fg) == 1 and fg[0].left * fg[0].right < 0 and abs(fg[0].value) < 1e-9


def test_isola_fold_vertex_with_contact_loss_matches_the_oracle(isola_fold_curve):
    c = isola_fold_curve
    V = c.vertices
    i = int(np.argmin(np.where(V["omega"] > 1.1, V["min_q"], np.inf)))   # deep in flight
    assert V["min_q"][i] < -5
    w, s, z, x = _vertex(c, i)
    so, _ = O.fold_on_line(x, fixed="omega", free="sigma", params=dict(omega=w, sigma=s, zeta=z),
                         m=2)
    assert abs(s - so) < 1e-8, (s, so)


def test_grazing_curve_of_2t_orbits_matches_the_oracle(branch_2t):
    g = [p for p in branch_2t.special if p.kind == "grazing"][0]
    c = cont.trace_curve(g.x0, g.omega, S, Z, kind="grazing", period=2,
                         bounds={"omega": (1.8, 2.0), "sigma": (0.25, 0.6)})
    V = c.vertices
    assert np.all(np.abs(V["min_q"] + 1.5) < 1e-9)
    # the grazing curve meets the 2T fold curve (the isola's) at its lower end
    assert any(p.kind == "fold_grazing" for p in c.codim2)
    s, so, _ = _oracle_sigma(c, len(c) // 3, O.grazing_point, 2e-3, m=2)
    assert abs(s - so) < 1e-8, (s, so)


def test_2t_to_4t_flip_curve_with_contact_loss_matches_the_oracle():
    """The flip of 2T orbits (a multiplier -1 of the 2T monodromy: the 4T orbit is born) near
    omega 0.52 at zeta 0.01, sigma 0.65, where the 2T orbits lose contact."""
    c = cont.trace_curve((2.19, 1.59), 0.519, 0.65, 0.01, kind="flip", period=2,
                         bounds={"omega": (0.5, 0.6), "sigma": (0.6, 0.9)})
    V = c.vertices
    assert len(c) > 10 and np.all(np.abs(V["flip"]) < 1e-9)
    assert np.all(V["min_q"] < -1.5)                    # every orbit on it loses contact
    s, so, _ = _oracle_sigma(c, len(c) // 2, O.flip_point, 2e-3, m=2)
    assert abs(s - so) < 1e-8, (s, so)


def test_cusp_of_the_primary_resonance_folds():
    """The two 1T folds of the primary resonance (softening, with contact loss) at zeta 0.01
    are one fold curve with a cusp near sigma 0.017: located where the curve's projection
    turns back; the 1T folds exist just above its sigma and not just below."""
    b = cont.continue_orbit(Z, linear_response_seed(0.6, 0.05, Z), omega=0.6, sigma=0.05,
                            period=1, direction=1, p_min=0.55, p_max=1.2, dp_max=0.01)
    f = [p for p in b.special if p.kind == "fold"][0]
    c = cont.trace_curve(f.x0, f.omega, 0.05, Z, kind="fold", period=1,
                         bounds={"omega": (0.55, 1.2), "sigma": (0.0, 0.2)})
    cusps = [p for p in c.codim2 if p.kind == "cusp"]
    assert len(cusps) == 1
    p = cusps[0]
    assert p.left > 0 > p.right                     # the projection's direction reverses
    assert 0.005 < p.sigma < 0.05
    V = c.vertices
    assert np.all(V["sigma"] >= p.sigma - 1e-12)    # the lowest point of the fold curve

    def folds_near(sigma):
        """1T folds within 0.02 of the cusp's omega on the line at sigma (one-parameter
        continuation from the linear response, steps of 1e-4 in omega)."""
        w0 = p.omega - 0.02
        r = cont.continue_orbit(Z, linear_response_seed(w0, sigma, Z), omega=w0, sigma=sigma,
                                period=1, direction=1, p_min=w0, p_max=p.omega + 0.02,
                                dp_max=1e-4, locate=("fold",))
        return sorted(q.omega for q in r.special if q.kind == "fold")
    above = folds_near(p.sigma + 2e-3)
    assert len(above) == 2
    # the traced curve crosses sigma_cusp + 2e-3 at the same two omegas
    crossing = np.nonzero(np.diff(np.sign(V["sigma"] - (p.sigma + 2e-3))))[0]
    w_curve = sorted(V["omega"][k] + (p.sigma + 2e-3 - V["sigma"][k]) / (V["sigma"][k + 1]
                     - V["sigma"][k]) * (V["omega"][k + 1] - V["omega"][k]) for k in crossing)
    np.testing.assert_allclose(above, w_curve, atol=1e-4)
    assert folds_near(p.sigma - 2e-3) == []


def test_curves_in_the_omega_zeta_and_sigma_zeta_planes():
    """The 1T flip curve in (omega, zeta) at sigma 0.5 and in (sigma, zeta) at a fixed omega,
    against the oracle's flip at a fixed omega (solving for zeta)."""
    b = cont.continue_orbit(Z, linear_response_seed(2.2, S, Z), omega=2.2, sigma=S, period=1,
                            direction=-1, p_min=1.9, p_max=2.3, dp_max=0.01)
    f = max((p for p in b.special if p.kind == "flip"), key=lambda p: p.omega)
    c = cont.trace_curve(f.x0, f.omega, S, Z, kind="flip", period=1, pair=("omega", "zeta"),
                         bounds={"omega": (1.9, 2.1), "zeta": (0.005, 0.02)})
    V = c.vertices
    assert np.all(V["sigma"] == S) and V["zeta"].max() > 0.012 and V["zeta"].min() < 0.006
    i = int(np.argmax(V["zeta"]))
    w, s, z, x = _vertex(c, i)
    if not (V["flag"][i].astype(int) & cont.VERTEX_EXTREMUM):
        i = len(c) // 3
        w, s, z, x = _vertex(c, i)
    zo, _ = O.flip_point(x, (z - 5e-4, z + 5e-4), fixed="omega", free="zeta",
                         params=dict(omega=w, sigma=s, zeta=z), xtol=1e-11)
    assert abs(z - zo) < 1e-9, (z, zo)
    c2 = cont.trace_curve(f.x0, f.omega, S, Z, kind="flip", period=1, pair=("sigma", "zeta"),
                          bounds={"sigma": (0.3, 0.8), "zeta": (0.005, 0.02)})
    assert len(c2) > 10 and np.all(c2.vertices["omega"] == f.omega)
    assert np.all(np.abs(c2.vertices["flip"]) < 1e-9)


def test_trace_failures_are_statuses():
    c = cont.trace_curve((50.0, 50.0), 1.0, 0.5, 0.01, kind="fold", period=2, max_points=5)
    assert c.status == (cont.START_FAIL, cont.START_FAIL) and len(c) == 0
    c = cont.trace_curve((0.0, 0.0), 2.0, 0.5, 0.01, kind="flip", period=1, max_points=4,
                         bounds={"omega": (1.9, 2.1), "sigma": (0.0, 5.0)})
    assert cont.MAX_POINTS in c.status and len(c) <= 9
    with pytest.raises(ValueError):
        cont.trace_curve((0.0, 0.0), 2.0, 0.5, 0.01, kind="fold", pair=("omega", "omega"))


# ---- the 3T -> 6T and 5T -> 10T flip curves of the default scene ----------------------------
#
# Orbits of period 3 and 5 with long flights (min q down to -40) at high sigma, zeta 0.01. The
# seeds are the attractor census's orbits of scenes/default.toml (grid point and start point
# as stored; the crossing's omega as the study's seed estimates it); the expected values are the
# oracle's own flip points: brentq on 1 + tr M + det M with sigma held at the vertex's value and
# omega free, each orbit by scipy root on the oracle's period map, M from the variational
# equations, DOP853 at rtol = atol = 1e-13. Measured (kernel at its default rtol 1e-10):
# 2.5e-11, 4.2e-11, 6.8e-11 in omega on the 3T curve, 9.5e-12, 1.5e-11, 5.6e-12 on the 5T
# curve (the kernel at rtol 1e-12: <= 4.1e-12; the oracle at rtol 1e-12 against 1e-13:
# <= 3.1e-11; docs/curves.md, Accuracy).

DEFAULT_WINDOW = {"omega": (0.5, 2.5), "sigma": (0.05, 1.0)}


def _transversal_vertex(curve, omega, sigma=None):
    """The vertex nearest (omega, sigma) (nearest omega when sigma is None) and the slope
    d sigma / d omega of the curve there: a line of constant sigma must cross the curve, not
    touch it."""
    V = curve.vertices
    d = (V["omega"] - omega) ** 2 + (0.0 if sigma is None else (V["sigma"] - sigma) ** 2)
    i = int(np.argmin(d))
    a, b = max(i - 1, 0), min(i + 1, len(curve) - 1)
    return i, (V["sigma"][b] - V["sigma"][a]) / (V["omega"][b] - V["omega"][a])


def _check_flip_vertices_against_the_oracle(curve, period, targets):
    for target in targets:
        i, slope = _transversal_vertex(curve, *target)
        assert abs(slope) > 0.2, (target, slope)
        w, s, z, x = _vertex(curve, i)
        # to 1e-11 in omega: a thousandth of what is checked
        wo, xo = O.flip_point(x, (w - 1e-5, w + 1e-5), fixed="sigma", free="omega",
                              params=dict(omega=w, sigma=s, zeta=z), m=period, rtol=1e-13,
                              xtol=1e-11)
        assert abs(w - wo) < 1e-8, (period, i, w, s, w - wo)
        assert np.hypot(*(np.array(x) - xo)) < 1e-6 * (1.0 + np.hypot(*xo)), (x, xo)


@pytest.mark.slow
def test_3t_flip_curve_of_the_default_scene_matches_the_oracle():
    """The 3T -> 6T flip curve (sigma > 0.64 from omega 0.5 to 1.22): from the census's 3T
    orbit at (1.1625, 0.7125) (multipliers -0.955, -0.757), across the default window; three
    vertices against the oracle: long flights (omega 0.52, min q -40), omega 0.65, 1.15."""
    c = cont.trace_curve((-3.86811476, -0.89227444), 1.15625, 0.7125, 0.01, kind="flip",
                         period=3, bounds=DEFAULT_WINDOW)
    V = c.vertices
    assert c.status == (cont.BOUNDARY, cont.BOUNDARY) and len(c) > 100
    assert np.all(np.abs(V["flip"]) < 1e-9) and np.all(V["residual"] < 1e-9)
    assert abs(V["omega"].min() - 0.5) < 1e-12 and V["omega"].max() > 1.2
    assert V["min_q"][_transversal_vertex(c, 0.52)[0]] < -35
    _check_flip_vertices_against_the_oracle(c, 3, [(0.52,), (0.65,), (1.15,)])


@pytest.mark.slow
def test_5t_flip_curve_of_the_default_scene_matches_the_oracle():
    """The 5T -> 10T flip curve near omega 0.5, sigma 0.77-0.84 (both ends on omega = 0.5):
    from the census's 5T orbit at (0.5, 0.7625) (multipliers -0.800, -0.356), the crossing
    at omega 0.50625; three vertices on its two arms against the oracle."""
    c = cont.trace_curve((-0.35446556, 4.67895854), 0.50625, 0.7625, 0.01, kind="flip",
                         period=5, bounds=DEFAULT_WINDOW)
    V = c.vertices
    assert c.status == (cont.BOUNDARY, cont.BOUNDARY) and len(c) > 20
    assert np.all(np.abs(V["flip"]) < 1e-9) and np.all(V["residual"] < 1e-9)
    assert np.allclose(V["omega"][[0, -1]], 0.5, atol=1e-12) and V["min_q"].max() < -35
    _check_flip_vertices_against_the_oracle(
        c, 5, [(0.5090, 0.8102), (0.5139, 0.7912), (0.5045, 0.7759)])
