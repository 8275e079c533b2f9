"""study.solve.sweep: stepped-sine sweeps of paper Eq. 7 and their jumps, against independent
oracles: the scipy oracle's own bifurcation points and orbits (benchmarks/oracle.py: scipy
solve_ivp, root and brentq, no code shared with kernels/) and the fold of paper Fig. 6
recomputed by continuation (VALIDATION.md row 8, docs/discovery.md: omega 0.4720910)."""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks import oracle
from hertzmap.kernels import shoot, status
from hertzmap.study.solve.sweep import jump_kind, stepped_sweep
from tests.study.solve.conftest import FOLD_FIG6, MARGIN, S, Z



def test_down_sweep_stays_on_2t_and_jumps_to_1t_at_the_fold(down_from_2t):
    sw = down_from_2t
    assert np.all(np.diff(sw.values) < 0)          # swept down
    (jump,) = sw.jumps
    # the steps above the fold stay on the 2T branch they started on, those below are on 1T
    for step in sw.steps:
        assert step.orbit is not None and step.stable
        assert step.period == (2 if step.value > FOLD_FIG6 else 1), step.value
        assert step.branch == (0 if step.value > FOLD_FIG6 else 1)
    assert jump.located and jump.kind == "fold"
    assert (jump.from_period, jump.to_period) == (2, 1)
    assert jump.to_step is sw.steps[jump.step_index] and jump.to_step.settled
    # bracketed to the default jump_tol, the attracting end on the high side (swept down)
    assert 0.0 < jump.accuracy <= 1e-6 and jump.after < jump.before
    assert abs(jump.value - FOLD_FIG6) <= jump.accuracy + 1e-5, jump.value
    # the oracle's own fold: Phi_2T(x) = x and 1 - tr M + det M = 0 solved for (q, v, omega)
    # by scipy (hybr), from 1e-2 in x and 1e-4 in omega off the followed orbit
    x_o, w_o, (fixed_res, fold_res) = oracle.fold_point(
        jump.from_orbit.x0 + 1e-2, jump.before + 1e-4, S, Z, 2, rtol=1e-11)
    assert fixed_res < 1e-8 * (1.0 + np.abs(x_o).max()) and fold_res < 1e-8
    assert abs(jump.value - w_o) <= jump.accuracy + MARGIN, (jump.value, w_o)
    # the followed orbit's multiplier -> +1: ~ 1 - c sqrt(distance to the fold)
    assert np.min(np.abs(jump.multipliers - 1.0)) == pytest.approx(jump.margin)
    assert jump.margin < 1e-2
    # the bisection probes started on the branch: those on its side settled back on it
    log = jump.probe_log
    assert log.shape == (jump.probes, 3) and jump.probes >= 10
    assert np.all(log[log[:, 2] == 1, 0] >= jump.before)


def test_up_sweep_jumps_from_1t_to_2t_at_the_flip(up_from_1t):
    sw = up_from_1t
    assert np.all(np.diff(sw.values) > 0)
    (jump,) = sw.jumps
    assert jump.located and jump.kind == "flip"
    assert (jump.from_period, jump.to_period) == (1, 2)
    landed = jump.to_step
    assert landed.settled and landed.stable and landed.period == 2 and landed.ptp > 1.0
    for step in sw.steps[:jump.step_index]:
        assert step.period == 1 and step.stable and step.branch == 0
    for step in sw.steps[jump.step_index:]:
        assert step.period == 2 and step.settled and step.branch == 1
    assert 0.0 < jump.accuracy <= 1e-6 and jump.before < jump.after
    # the oracle's flip: brentq on its own 1 + tr M + det M along omega, each 1T orbit by scipy
    # root on its period map, M from its variational equations
    w_o, _ = oracle.flip_omega((1.965, 1.985), S, Z, sw.steps[0].orbit.x0, rtol=1e-11,
                               xtol=1e-10)
    assert abs(jump.value - w_o) <= jump.accuracy + MARGIN, (jump.value, w_o)
    # docs/discovery.md: the lower 1T flip at sigma 0.5 is at omega 1.97757924
    assert abs(jump.value - 1.97757924) <= jump.accuracy + 1e-7
    assert abs(jump.multipliers.real.min() + 1.0) == pytest.approx(jump.margin)
    assert jump.margin < 1e-5


def test_sigma_sweep_locates_the_flip_on_the_sigma_axis():
    """Up in sigma at omega 1.98: the 1T orbit flips; the oracle's flip_point on the line."""
    sw = stepped_sweep("sigma", np.round(np.arange(0.30, 0.5001, 0.05), 10),
                       {"omega": 1.98, "zeta": Z}, "up")
    assert sw.steps[0].period == 1 and sw.steps[0].settled
    jump = sw.jumps[0]
    assert jump.located and jump.kind == "flip" and jump.from_period == 1
    assert jump.accuracy <= 1e-6
    s_o, _ = oracle.flip_point(jump.from_orbit.x0, (0.40, 0.50), fixed="omega", free="sigma",
                               params={"omega": 1.98, "sigma": 0.45, "zeta": Z}, rtol=1e-11,
                               xtol=1e-10)
    assert abs(jump.value - s_o) <= jump.accuracy + MARGIN, (jump.value, s_o)


def test_a_sweep_without_jumps_stays_on_the_1t_orbit():
    values = np.round(np.arange(0.50, 0.8001, 0.02), 10)
    sw = stepped_sweep("omega", values, {"sigma": 0.1, "zeta": Z}, "up")
    assert sw.jumps == () and sw.probes == 0
    a = sw.arrays()
    assert np.array_equal(a["value"], values)
    assert np.all(a["period"] == 1) and np.all(a["settled"]) and np.all(a["stable"])
    assert np.all(a["status"] == status.CONVERGED) and np.all(a["branch"] == 0)
    assert np.all(a["class_code"] == 1) and not np.any(a["loses_contact"])
    assert a["force_harmonics"].shape == (values.size, 4)
    assert np.all(np.isfinite(a["force_harmonics"]))
    # each step starts where the last ended
    for prev, step in zip(sw.steps, sw.steps[1:]):
        assert np.array_equal(step.start, prev.end)
    # one step against the oracle's own 1T orbit (scipy root on its period map, from 1e-2 off)
    step = sw.steps[8]
    assert step.value == pytest.approx(0.66)
    x_o, M_o, _ = oracle.shoot(step.orbit.x0 + 1e-2, step.omega, 0.1, Z, 1, rtol=1e-12)
    assert np.max(np.abs(step.orbit.x0 - x_o)) < 1e-8, (step.orbit.x0, x_o)
    mu_o = np.sort_complex(np.linalg.eigvals(M_o))
    assert np.max(np.abs(np.sort_complex(step.multipliers) - mu_o)) < 1e-7
    assert abs(step.min_q - oracle.min_q(x_o, step.omega, 0.1, Z)) < 1e-8


def test_jump_kind_from_multipliers():
    assert jump_kind([0.999, 0.5], 0.02) == ("fold", pytest.approx(1e-3))
    assert jump_kind([-0.9999, -0.3], 0.02) == ("flip", pytest.approx(1e-4))
    kind, margin = jump_kind([0.6 + 0.79j, 0.6 - 0.79j], 0.02)   # a complex pair: neither
    assert kind == "loss" and margin == pytest.approx(abs(0.6 + 0.79j - 1.0))
    assert jump_kind([0.9, 0.5], 0.02)[0] == "loss"


@pytest.mark.parametrize("kwargs, message", [
    (dict(axis="q"), "axis"),
    (dict(direction="sideways"), "direction"),
    (dict(fixed={"sigma": 0.1}), "fixed"),
    (dict(values=[0.5, 0.5]), "repeat"),
    (dict(jump_tol=0.0), "jump_tol"),
    (dict(x0=(np.nan, 0.0)), "x0"),
])
def test_bad_arguments_raise(kwargs, message):
    args = dict(axis="omega", values=[0.5, 0.6], fixed={"sigma": 0.1, "zeta": Z},
                direction="up")
    args.update(kwargs)
    with pytest.raises(ValueError, match=message):
        stepped_sweep(**args)


@pytest.mark.parametrize("start, stop, guess, fold", [(0.44, 0.48, (0.0, 0.0), 0.466517),
                                                      (0.74, 0.77, (1.3, 0.05), 0.753526)])
def test_up_sweep_leaves_the_1t_branch_at_its_fold_onto_the_other_1t_branch(start, stop, guess,
                                                                            fold):
    """Up in omega at sigma 0.5 over the 2:1 superharmonic and the primary resonance's bends
    (the sweeps scene's up sweep): the 1T branch the sweep follows ends at a fold where a larger
    1T orbit with contact loss coexists. Newton from the branch's last orbit past the fold lands
    on that orbit, which the transient reaches too: the round trip (shooting back must give the
    orbit it started from) keeps the sweep from calling it the same branch. At omega 0.7535 the
    followed orbit has grazed (min q < -n) and its multipliers are a complex pair 0.92 +- 0.04i
    at 6e-7 before the fold: the branch gone at the bracket's far end names it a fold. The
    oracle's fold (period 1, scipy hybr) within the bracket."""
    first = shoot(start, S, Z, 1, guess=guess)          # the 1T orbit in contact
    assert first.converged and first.stable and not first.loses_contact
    values = np.round(np.arange(start, stop + 1e-9, 0.01), 10)
    sw = stepped_sweep("omega", values, {"sigma": S, "zeta": Z}, "up", first.x0,
                       settle_periods=4000)
    (jump,) = sw.jumps
    assert jump.located and jump.kind == "fold" and (jump.from_period, jump.to_period) == (1, 1)
    assert 0.0 < jump.accuracy <= 1e-6 and abs(jump.value - fold) < 1e-5, jump.value
    before, after = sw.steps[jump.step_index - 1], jump.to_step
    assert after.loses_contact and after.ptp > 1.5 * before.ptp     # onto the larger orbit
    x_o, w_o, (fixed_res, fold_res) = oracle.fold_point(
        jump.from_orbit.x0 + 1e-3, jump.before - 1e-5, S, Z, 1, rtol=1e-11)
    assert fixed_res < 1e-8 * (1.0 + np.abs(x_o).max()) and fold_res < 1e-8
    assert abs(jump.value - w_o) <= jump.accuracy + MARGIN, (jump.value, w_o)


def test_the_quasi_static_sweep_follows_by_shooting_and_locates_the_same_jumps():
    """follow_first (the fit's forward model, study.identify): the steps on a branch are its
    orbits continued by shooting (no transient), the jumps the branch's ends located by
    shooting alone; the same steps and jumps as the default sweep's transients, and its flip
    at the oracle's own (brentq on 1 + tr M + det M, scipy root on its period map)."""
    values = np.round(np.arange(1.90, 2.0001, 0.01), 10)
    fixed = {"sigma": S, "zeta": Z}
    # 4000 periods: the step 2.4e-3 past the flip needs ~2000 to reach the 2T response
    quasi = stepped_sweep("omega", values, fixed, "up", settle_periods=4000, follow_first=True)
    rig = stepped_sweep("omega", values, fixed, "up", settle_periods=4000)
    assert quasi.settings["follow_first"] and not rig.settings["follow_first"]
    (jump,), (rig_jump,) = quasi.jumps, rig.jumps
    assert jump.kind == rig_jump.kind == "flip" and (jump.from_period, jump.to_period) == (1, 2)
    # bisected by shooting alone: every probe a shot (status converged or not), no transient
    assert jump.probes >= 10 and set(jump.probe_log[:, 1]) <= {status.CONVERGED,
                                                               status.NOT_CONVERGED}
    assert abs(jump.value - rig_jump.value) <= jump.accuracy + rig_jump.accuracy
    w_o, _ = oracle.flip_omega((1.965, 1.985), S, Z, quasi.steps[0].orbit.x0, rtol=1e-11,
                               xtol=1e-10)
    assert abs(jump.value - w_o) <= jump.accuracy + MARGIN, (jump.value, w_o)
    # the steps on the 1T branch ran no transient; each is the default sweep's orbit
    on_branch = quasi.steps[1:jump.step_index]
    assert on_branch and all(s.periods_run == 0 and s.attractor is None and s.settled
                             for s in on_branch)
    a, b = quasi.arrays(), rig.arrays()
    assert np.array_equal(a["period"], b["period"]) and np.array_equal(a["branch"], b["branch"])
    assert np.allclose(a["force_harmonics"], b["force_harmonics"], rtol=1e-6, atol=1e-9)
    assert a["periods_run"][1:jump.step_index].sum() == 0 < b["periods_run"][1:jump.step_index].min()
