"""Status codes returned by every kernel call (stored as int8 in the dataset).

A kernel never raises and never hangs: whatever happens, it returns one of these codes.
"""

CONVERGED = 0          # Newton converged: |dx| <= xtol and the orbit passes the period test
NOT_CONVERGED = 1      # Newton iteration limit reached without convergence
DIVERGED = 2           # state left the admissible box (|q| or |v| > 1e6) or Newton residual blew up
STEP_LIMIT = 3         # integrator step-count limit (max_steps per period) reached
STEP_SIZE = 4          # integrator step size fell below its floor (h < 1e-14 * period)
SINGULAR = 5           # I - M singular (multiplier +1 to machine precision): no Newton step
TIME_LIMIT = 6         # not solved: the task's time budget ran out first (grid studies only)
UNSETTLED = 7          # attractor: no repeating stroboscopic cycle (m <= 16) within the budget
UNCONFIRMED = 8        # attractor: the points repeat, but shooting confirmed no stable orbit
RECOGNISED = 9         # attractor: the transient stayed by a known attractor's points (the census's)
EMPTY = -1             # no solution in this slot (used by the store, never returned by a solve)

NAMES = {
    CONVERGED: "converged",
    NOT_CONVERGED: "not_converged",
    DIVERGED: "diverged",
    STEP_LIMIT: "step_limit",
    STEP_SIZE: "step_size",
    SINGULAR: "singular",
    TIME_LIMIT: "time_limit",
    UNSETTLED: "unsettled",
    UNCONFIRMED: "unconfirmed",
    RECOGNISED: "recognised",
    EMPTY: "empty",
}
