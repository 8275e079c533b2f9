"""study.solve.seeds: where the census's transients start. The fixed box, and where a point's
known orbits leave it, a box covering them (their q extent with a margin, q' grown like the
square root of the extent), half of the states there; both boxes evenly covered."""
from __future__ import annotations

import numpy as np

from hertzmap.study.solve.seeds import REACH_MARGIN, TRANSIENT_BOX, initial_states, reach_box


def _inside(states, box):
    (q0, q1), (v0, v1) = box
    s = np.asarray(states)
    return (s[:, 0] >= q0) & (s[:, 0] <= q1) & (s[:, 1] >= v0) & (s[:, 1] <= v1)


def test_orbits_inside_the_box_leave_it_as_it_is():
    assert reach_box([]) is None
    assert reach_box([{"min_q": -5.5, "max_q": 2.4}]) is None
    assert initial_states(16, None) == initial_states(16)


def test_a_long_flight_grows_the_box_to_cover_it():
    """An orbit from q = -119 to 11.5 (the stable 5T orbit at (0.95, 1.8), zeta 0.01): the
    reach box holds it with a margin of REACH_MARGIN of its extent on each side."""
    box = reach_box([{"min_q": -5.5, "max_q": 2.4}, {"min_q": -119.0, "max_q": 11.5}])
    (lo, hi), (vlo, vhi) = box
    extent = 11.5 + 119.0
    assert np.isclose(lo, -119.0 - REACH_MARGIN * extent)
    assert np.isclose(hi, 11.5 + REACH_MARGIN * extent)
    (q0, q1), (v0, v1) = TRANSIENT_BOX
    grow = np.sqrt((hi - lo) / (q1 - q0))
    assert np.isclose(vlo, v0 * grow) and np.isclose(vhi, v1 * grow)


def test_half_the_states_in_each_box_each_evenly_spread():
    box = ((-150.0, 30.0), (-20.0, 20.0))
    states = initial_states(65, box)
    assert states[0] == (0.0, 0.0)
    odd, even = np.array(states[1::2]), np.array(states[2::2])
    assert len(odd) == len(even) == 32
    assert _inside(odd, TRANSIENT_BOX).all()
    assert _inside(even, box).all() and (~_inside(even, TRANSIENT_BOX)).sum() >= 24
    # the odd ones are the first 32 Halton points of the fixed box, as without a reach box
    assert np.array_equal(odd[:8], np.array(initial_states(9)[1:]))
    # each box's points cover its four quadrants (a low-discrepancy sequence of its own)
    for pts, ((q0, q1), (v0, v1)) in ((odd, TRANSIENT_BOX), (even, box)):
        qm, vm = (q0 + q1) / 2, (v0 + v1) / 2
        quads = {(bool(q > qm), bool(v > vm)) for q, v in pts}
        assert len(quads) == 4
