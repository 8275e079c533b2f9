"""study.solve.swept_sine: swept sines of paper Eq. 7 at finite rates and where they leave the
branches a stepped sweep jumps from, against independent oracles (benchmarks/oracle.py: scipy
solve_ivp, no code shared with kernels/) and the stepped sweep's own jumps."""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks import oracle
from hertzmap.kernels import shoot, status
from hertzmap.study.solve.sweep import force_components
from hertzmap.study.solve.swept_sine import (SWEPT_WINDOW, jump_measure, swept_crossing,
                                             swept_jump, swept_sine)
from tests.study.solve.conftest import S, Z


def test_a_swept_sine_jumps_later_the_faster_it_sweeps_and_tends_to_the_stepped_jump(
        down_from_2t):
    """Swept down in omega at a finite rate from the stable 2T orbit at omega 0.48 (the stepped
    sweep's step there), the forcing's phase run on continuously: the response leaves the 2T
    branch after the stepped sweep's fold (0.4720908), the later the faster the sweep, the
    delay shrinking like rate^(2/3) (the slow passage through a fold: 4.0e-3, 8.5e-4, 1.9e-4
    at rates 1e-5, 1e-6, 1e-7, about 8.6 rate^(2/3), read where its subharmonic H1/2 falls
    through half the 2T orbit's: a 2T -> 1T jump; its amplitude falls through half-way a few
    cycles sooner, 3.7e-3 at 1e-5) towards the stepped jump as the rate falls. 1e-7 per unit
    tau is 0.046 Hz/s on the paper's rig."""
    (jump,) = down_from_2t.jumps
    step = next(s for s in down_from_2t.steps if s.value == pytest.approx(0.48))
    assert step.period == 2 and step.stable
    delays = []
    for rate in (1e-5, 1e-6, 1e-7):
        sw = swept_sine("omega", 0.48, 0.462, rate, {"sigma": S, "zeta": Z}, step.orbit.x0)
        assert sw.status == status.CONVERGED and sw.direction == "down"
        assert np.all(np.diff(sw.values) < 0) and sw.values[-1] > 0.462 - rate * 14
        # the forcing cycles' lengths: each cycle's omega moved by rate T
        np.testing.assert_allclose(-np.diff(sw.values), rate * 2 * np.pi / sw.values[:-1],
                                   rtol=1e-9)
        value, delay = swept_jump(sw, jump)
        assert value < jump.value and delay == pytest.approx(jump.value - value)
        delays.append(delay)
        # before the jump it is on the 2T branch: its ptp over two cycles near the orbit's
        on = sw.values > jump.value + 5e-3
        assert np.allclose(sw.ptp(2)[on][1:], 81.0, rtol=0.05)
    assert delays[0] > delays[1] > delays[2] > 0.0, delays
    for faster, slower in zip(delays, delays[1:]):
        assert 0.1 < slower / faster < 0.4, delays        # 10^(-2/3) = 0.215
    assert delays[2] < 5e-4, delays


def _oracle_cycle(x0, omega):
    """One forcing cycle of paper Eq. 7 from x0 at tau = 0 by the scipy oracle (solve_ivp,
    restarted at every contact switch: benchmarks/oracle.py piecewise), with the integrals of
    F exp(-i k omega t / 2), k = 1, 2, 4, carried along and q sampled finely on each piece:
    (end state, the three integrals, min q, max q)."""
    ks = (1, 2, 4)
    T = 2 * np.pi / omega

    def rhs(t, y):
        f = oracle.force(y[0])
        out = [y[1], 1.0 + S * np.cos(omega * t) - 2.0 * Z * y[1] - f]
        for k in ks:
            out += [f * np.cos(k * omega * t / 2), -f * np.sin(k * omega * t / 2)]
        return out

    qs = []

    def on_piece(sol):
        qs.append(sol.sol(np.linspace(sol.t[0], sol.t[-1], 4001))[0])

    y, _ = oracle.piecewise(rhs, [x0[0], x0[1]] + [0.0] * 6, 0.0, T, rtol=1e-12, atol=1e-12,
                            dense_output=True, on_piece=on_piece)
    q = np.concatenate(qs)
    return y[:2], y[2::2] + 1j * y[3::2], float(q.min()), float(q.max())


def test_a_swept_sine_cycle_by_cycle_against_the_scipy_oracle():
    """Each cycle of a swept sine (from the 2T orbit at omega 0.5, with impacts, swept down
    at 1e-3 per unit tau) is one forcing cycle at that cycle's omega from the last one's end
    state, the phase starting at 0: the scipy oracle integrating the same cycles gives the
    same states, contact-force integrals and extrema of q; the H1, H2, H1/2 read over two
    cycles are 2 |integral| over the two cycles' length with the second cycle's phase
    continued."""
    orbit = shoot(0.50, S, Z, 2, guess=(-26.4, 8.55))
    sw = swept_sine("omega", 0.5, 0.4, 1e-3, {"sigma": S, "zeta": Z}, orbit.x0)
    T = 2 * np.pi / sw.values
    np.testing.assert_allclose(np.diff(sw.tau), T[:-1], rtol=1e-14)
    for j in range(6):
        end, a, lo, hi = _oracle_cycle(sw.start[j], float(sw.values[j]))
        scale = 1.0 + np.abs(sw.start[j + 1]).max()
        assert np.abs(end - sw.start[j + 1]).max() < 1e-5 * scale, (j, end, sw.start[j + 1])
        np.testing.assert_allclose(sw.harmonics[j], a, atol=1e-6 * np.abs(a).max())
        assert abs(sw.min_q[j] - lo) < 1e-6 * scale and abs(sw.max_q[j] - hi) < 1e-6 * scale
        if j:
            _, b, _, _ = _oracle_cycle(sw.start[j - 1], float(sw.values[j - 1]))
            span = T[j - 1] + T[j]
            h1, h2, h12 = (x[j] for x in sw.force_components(2))
            assert h1 == pytest.approx(2 * abs(b[1] + a[1]) / span, rel=1e-6)
            assert h2 == pytest.approx(2 * abs(b[2] + a[2]) / span, rel=1e-6)
            assert h12 == pytest.approx(2 * abs(b[0] - a[0]) / span, rel=1e-6)
    # swept slowly, the first two cycles are the 2T orbit: its stored harmonics, amplitude
    slow = swept_sine("omega", 0.5, 0.5 - 3e-6, 1e-7, {"sigma": S, "zeta": Z}, orbit.x0)
    got = [float(x[1]) for x in slow.force_components(SWEPT_WINDOW)]
    want = [float(x) for x in force_components(orbit.force_harmonics, orbit.period)]
    np.testing.assert_allclose(got, want, rtol=1e-5)
    assert slow.ptp(2)[1] == pytest.approx(orbit.ptp, rel=1e-6)
    # one cycle's window has no subharmonic; where each value of omega was first reached
    assert np.isnan(sw.force_components(1)[2]).all() and np.isnan(sw.force_components(2)[0][0])
    np.testing.assert_array_equal(sw.cycle_at([0.5, sw.values[3], sw.values[3] + 1e-9, 0.3,
                                               0.6]), [0, 3, 3, -1, -1])


def test_the_measure_and_window_a_swept_jump_is_read_on():
    """1T <-> 2T jumps are read on the subharmonic H1/2, others on the amplitude; a crossing
    counts only after the response was on the first level's side inside the window, and a
    jump between two nearly equal levels (a 2T response ending on the 1T orbit) is not read."""
    assert jump_measure(1, 2) == jump_measure(2, 1) == jump_measure(2, 3) == "H1_2"
    assert jump_measure(1, 1) == jump_measure(2, 4) == jump_measure(1, 3) == "ptp"
    orbit = shoot(0.50, S, Z, 2, guess=(-26.4, 8.55))
    sw = swept_sine("omega", 0.5, 0.44, 1e-4, {"sigma": S, "zeta": Z}, orbit.x0)
    ptp = sw.ptp(2)
    # the 2T response's own amplitude grows as omega falls: a level above it at the start is
    # crossed upwards later, not at the first cycle
    level = float(np.nanmax(ptp[:4])) + 1.0
    where, delay = swept_crossing(sw, 0.5, 0.0, 2 * level, measure="ptp", period=2)
    k = int(np.flatnonzero(ptp > level)[0])
    assert where == sw.values[k] and delay == pytest.approx(0.5 - sw.values[k])
    # only inside the window: from 0.49 on, before 0.47
    where, _ = swept_crossing(sw, 0.5, 0.0, 2 * level, measure="ptp", period=2, start=0.49,
                              stop=0.47)
    assert np.isnan(where) or 0.47 < where <= 0.49
    assert np.isnan(swept_crossing(sw, 0.5, 10.0, 10.5)[0])          # nothing jumps
    assert np.isnan(swept_crossing(sw, 0.5, 1.0, 0.0, measure="H1_2", scale=100.0)[0])
    with pytest.raises(ValueError, match="measure"):
        swept_crossing(sw, 0.5, 0.0, 1.0, measure="rms")


@pytest.mark.parametrize("kwargs, message", [
    (dict(axis="zeta"), "axis"),
    (dict(rate=0.0), "rate"),
    (dict(rate=-1e-5), "rate"),
    (dict(stop=0.5), "start and stop"),
    (dict(rate=1e-12), "max_cycles"),
    (dict(fixed={"sigma": S}), "fixed"),
])
def test_bad_swept_sine_arguments_raise(kwargs, message):
    args = dict(axis="omega", start=0.5, stop=0.6, rate=1e-5, fixed={"sigma": S, "zeta": Z})
    args.update(kwargs)
    if args["axis"] == "zeta":
        args["fixed"] = {"omega": 0.5, "sigma": S}
    with pytest.raises(ValueError, match=message):
        swept_sine(**args)
