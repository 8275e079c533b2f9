"""The records hertzmap computes, each declared once: its fields, with name, dtype, units,
long_name, description and the study output that stores them.

Everything else derives from these declarations: the kernels' result-row layout and column
indices (kernels.shooting.FIELDS, ``I_*``), the Python view ``kernels.Orbit``, the solver's
solution dicts (study.solve.point), the stored variables and their attrs (study.schema), the
explore page's orbit table (study.explore_data), and the check that docs/dataset.md has a row
for every stored variable (tests/study/test_schema.py).

Adding a per-orbit measure: one ``Field`` in :data:`ORBIT` (in the place the stored variables
should list it), the line of ``kernels.shooting.shoot_into`` that writes its column, and its
row in docs/dataset.md.

Pure data (no numba, no numpy arrays): the kernels read the indices as compile-time
constants.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from hertzmap.kernels import status as _status

#: Amplitudes of the contact force kept per orbit: k omega / period, k = 1..N_HARMONICS.
N_HARMONICS = 4
#: The longest period (in forcing periods) any record carries.
MAX_PERIOD = 16

#: flag values/meanings of a period: 0 empty, m an orbit of period m T
PERIOD_FLAGS = ((0, "empty"),) + tuple((m, f"period_{m}T") for m in range(1, MAX_PERIOD + 1))
#: flag values/meanings of a solver status (kernels.status)
STATUS_FLAGS = tuple(sorted(_status.NAMES.items()))


@dataclass(frozen=True)
class Field:
    """One quantity of a record.

    ``columns``: the kernel row's columns that hold it, in order (default: one column named
    like the field; empty: not computed by the kernel but by the solve layer, e.g. the stored
    period of a 2T solve that landed on the 1T orbit). A field of several columns is a vector
    over the trailing dim ``dim`` = (name, length); ``dtype`` complex128 pairs its columns as
    (real, imaginary). ``output``: the study output that stores it (study.spec), None for a
    field kept in the kernel row only (diagnostics of the kernels, the monodromy). ``dtype``,
    ``fill`` (the value of an empty slot), ``units``, ``long_name``, ``description`` and
    ``flags`` ((value, meaning) pairs) are what the store says of it. ``quantity`` says how a
    rig's units scale it (displacement, velocity, force, fraction; None: a pure number)."""

    name: str
    long_name: str
    units: str
    description: str
    output: str | None = None
    dtype: str = "float64"
    fill: Any = math.nan
    columns: tuple[str, ...] | None = None
    dim: tuple[str, int] | None = None
    flags: tuple[tuple[int, str], ...] | None = None
    quantity: str | None = None

    @property
    def kernel_columns(self) -> tuple[str, ...]:
        return (self.name,) if self.columns is None else self.columns


@dataclass(frozen=True)
class Record:
    """A record: its fields in order (the stored variables follow this order, the kernel row
    the order of their columns)."""

    name: str
    fields: tuple[Field, ...]

    def __post_init__(self):
        seen: set[str] = set()
        for f in self.fields:
            for c in f.kernel_columns:
                if c in seen:     # two fields on one column: the row would hold it twice
                    raise ValueError(f"{self.name}: kernel column {c!r} declared twice")
                seen.add(c)
        names = [f.name for f in self.fields]
        if len(set(names)) != len(names):
            raise ValueError(f"{self.name}: a field name declared twice")

    @property
    def columns(self) -> tuple[str, ...]:
        """The kernel result row's layout."""
        return tuple(c for f in self.fields for c in f.kernel_columns)

    @property
    def index(self) -> dict[str, int]:
        """Column name -> index in the kernel row."""
        return {c: i for i, c in enumerate(self.columns)}

    def field(self, name: str) -> Field:
        for f in self.fields:
            if f.name == name:
                return f
        raise KeyError(f"{self.name} has no field {name!r}")

    def stored(self, output: str | None = None) -> tuple[Field, ...]:
        """The fields a study stores (those of ``output`` only, when given)."""
        return tuple(f for f in self.fields
                     if f.output is not None and (output is None or f.output == output))


def _kernel_counts(*names_and_docs) -> tuple[Field, ...]:
    """Integer fields of a kernel row that no study stores."""
    return tuple(Field(n, long_name, "1", description, dtype="int64", fill=0)
                 for n, long_name, description in names_and_docs)


#: A periodic orbit of period m T (paper section 3.2): kernels.shooting.shoot_into's row.
ORBIT = Record("orbit", (
    Field("period", "period of the orbit", "1",
          "period of the periodic response in forcing periods T = 2 pi / omega (1: 1T orbit, "
          "2: 2T orbit, ..., 16; 0: empty slot)",
          output="orbits", dtype="int8", fill=0, columns=(), flags=PERIOD_FLAGS),
    Field("status", "solver status", "1",
          "outcome of the solve for this slot (kernels/status.py); only status 0 (converged) "
          "slots hold a periodic orbit",
          output="orbits", dtype="int8", fill=_status.EMPTY, flags=STATUS_FLAGS),
    Field("q0", "displacement at tau = 0", "1",
          "dimensionless displacement q = 3 (z - z_s) / (2 z_s) of the orbit at tau = 0 (start "
          "point of the periodic orbit); contact is lost at q = -exponent", output="orbits",
          quantity="displacement"),
    Field("v0", "velocity at tau = 0", "1",
          "dimensionless velocity dq/dtau of the orbit at tau = 0", output="orbits",
          quantity="velocity"),
    Field("multipliers", "Floquet multipliers", "1",
          "the two eigenvalues of the monodromy matrix over the orbit's period (their product "
          "is exp(-2 zeta P) for an orbit of period P = period * T)",
          output="orbits", dtype="complex128", fill=complex(math.nan, 0.0),
          columns=("multiplier1_re", "multiplier1_im", "multiplier2_re", "multiplier2_im"),
          dim=("multiplier", 2)),
    Field("stable", "orbit is stable", "1",
          "True when both Floquet multipliers lie inside the unit circle",
          output="orbits", dtype="bool", fill=False),
    Field("liouville_residual", "Liouville residual of the monodromy", "1",
          "|det M - exp(-2 zeta P)| / max(exp(-2 zeta P), |m11 m22| + |m12 m21|): how far the "
          "product of the Floquet multipliers is from Liouville's exact value for an orbit of "
          "period P, relative to what a 2x2 determinant resolves; a certificate of the "
          "monodromy independent of the solve (integration error ~ rtol)", output="orbits"),
    Field("atlas_round", "how the orbit was found", "1",
          "0: by the grid's search at this point; r >= 1: continued into this point from a "
          "grid neighbour by round r of the atlas (study.solve.atlas); -1: empty slot",
          output="orbits", dtype="int8", fill=-1, columns=()),
    Field("min_q", "minimum displacement over the orbit", "1",
          "minimum of q over one period of the orbit", output="measures",
          quantity="displacement"),
    Field("max_q", "maximum displacement over the orbit", "1",
          "maximum of q over one period of the orbit", output="measures",
          quantity="displacement"),
    Field("ptp", "peak-to-peak displacement", "1", "max_q - min_q", output="measures",
          quantity="displacement"),
    Field("loses_contact", "orbit loses contact", "1",
          "True when q reaches the loss-of-contact threshold q = -exponent during the orbit",
          output="measures", dtype="bool", fill=False),
    Field("flight_fraction", "fraction of the period in flight", "1",
          "fraction of the orbit's period spent out of contact (0..1)", output="measures",
          quantity="fraction"),
    Field("max_impact_velocity", "largest impact velocity", "1",
          "largest |dq/dtau| at recontact (q = -exponent) over one period of the orbit",
          output="measures", quantity="velocity"),
    Field("peak_force", "peak contact force over the orbit", "1",
          "largest contact force F/N over one period of the orbit (F of max_q: the contact "
          "laws are increasing)", output="measures", quantity="force"),
    Field("force_harmonics", "contact force harmonic amplitudes", "1",
          "amplitude of the contact force F(q) (in units of the static preload) at the "
          f"frequencies k omega / period, k = 1..{N_HARMONICS}",
          output="force_harmonics", columns=tuple(f"force_h{k}" for k in range(1, N_HARMONICS + 1)),
          dim=("harmonic", N_HARMONICS)),
    Field("rms_force", "rms contact force over the orbit", "1",
          "root mean square of the contact force F/N over one period of the orbit (8-point "
          "Gauss-Legendre on every integration step, the quadrature of force_harmonics)",
          output="force_harmonics", quantity="force"),
    Field("mean_force", "mean contact force over the orbit", "1",
          "mean of F/N over one period: 1 (the static load) for a periodic orbit, a check of "
          "the force quadrature"),
    Field("newton_iterations", "Newton iterations", "1",
          "number of Newton (shooting) iterations used for this slot",
          output="diagnostics", dtype="int16", fill=0),
    Field("residual", "final shooting residual", "1",
          "|Phi_P(x0) - x0| at the returned start point", output="diagnostics"),
    Field("trace_m", "trace of the monodromy", "1", "tr M"),
    Field("det_m", "determinant of the monodromy", "1", "det M"),
    *_kernel_counts(
        ("minimal_period", "minimal period", "smallest j dividing the period with "
         "Phi_{jT}(x0) = x0 (1 for a 2T solve that landed on the 1T orbit; 0: not converged)"),
        ("steps", "integration steps", "accepted steps of the last period map"),
        ("rejected", "rejected steps", "rejected steps of the last period map"),
        ("events", "contact events", "losses of contact and recontacts over the period"),
    ),
    Field("monodromy", "monodromy matrix", "1", "M = dPhi/dx over the orbit's period, row by row",
          columns=("m11", "m12", "m21", "m22"), dim=("monodromy_entry", 4)),
))


#: Stroboscopic points (q, q' at tau = 0 mod T) a census keeps per attractor: the last ones of
#: its window.
STROBE_POINTS = 32
#: Codes of a census attractor's kind (0: empty slot).
ATTRACTOR_KINDS = {"periodic": 1, "non_periodic": 2, "unsettled": 3, "failed": 4}
ATTRACTOR_FLAGS = ((0, "empty"),) + tuple((c, k) for k, c in ATTRACTOR_KINDS.items())


def _window(name, column, long_name, description, quantity=None):
    """A measure over the attractor's window, stored under ``name``, from kernel column
    ``column``."""
    return Field(name, long_name, "1", description, output="attractors", columns=(column,),
                 quantity=quantity)


def _kernel_only(*names_and_docs) -> tuple[Field, ...]:
    return tuple(Field(n, n.replace("_", " "), "1", d) for n, d in names_and_docs)


#: Where a transient goes (kernels.attractors.attractor_batch_into's row) and what the census
#: stores of it per attractor slot (dims omega, sigma, zeta, attractor): fields without kernel
#: columns are the census's own (study.solve.census); the stored names of the window measures
#: carry the record's prefix (the orbit record has fields of the same kernel names).
ATTRACTOR = Record("attractor", (
    Field("attractor_kind", "kind of attractor", "1",
          "1 periodic (a stable orbit, stored in the slot attractor_solution), 2 non_periodic "
          "(no period <= 16 within the budget and a positive largest Lyapunov exponent beyond "
          "three standard errors: chaotic; beside a stable orbit of the point only once a "
          "longer pass ended with none of its transients escaping to that orbit, or after "
          "search.max_transient_periods), 3 unsettled (the transients did not settle and the "
          "response is not shown chaotic: a longer period, a long transient, or a point with "
          "a stable orbit that the longer passes did not tell apart; unsettled_reason says "
          "why), 4 failed (integration failure); 0 empty slot", output="attractors", dtype="int8", fill=0, columns=(),
          flags=ATTRACTOR_FLAGS),
    Field("attractor_period", "period of a periodic attractor", "1",
          "m of a periodic attractor (its orbit has period m T), 0 otherwise",
          output="attractors", dtype="int8", fill=0, columns=(), flags=PERIOD_FLAGS),
    Field("attractor_solution", "solution slot of a periodic attractor", "1",
          "index along the solution dim of the stored orbit a periodic attractor is; -1: not "
          "periodic (a periodic attractor's orbit is always stored)",
          output="attractors", dtype="int16", fill=-1, columns=()),
    Field("basin_fraction", "basin fraction", "1",
          "fraction of the study's initial states whose transient ends on this attractor "
          "(a measure of the basin over the box of initial states)",
          output="attractors", columns=()),
    Field("unsettled_reason", "why an attractor is unsettled", "1",
          "an unsettled attractor's transients, continued in longer passes (each 4 times the "
          "last) from where they stopped: 1 period_limit (they ran search.max_transient_periods "
          "periods in all without settling, and are not shown chaotic), 2 work_budget "
          "(search.point_steps ran out first); 0 otherwise",
          output="attractors", dtype="int8", fill=0, columns=(),
          flags=((0, "none"), (1, "period_limit"), (2, "work_budget"))),
    Field("attractor_periods_run", "forcing periods the transient ran", "1",
          "periods the attractor's representative transient was integrated from its initial "
          "state, the longer passes included (an unsettled or non-periodic attractor), or "
          "until it settled (a periodic one)", output="attractors", columns=("periods_run",)),
    Field("lyapunov_exponent", "largest Lyapunov exponent", "1",
          "per unit dimensionless time tau: Benettin's method with the variational equations "
          "(exact across contact loss) over the record window (non-periodic and unsettled "
          "attractors), or log|mu_max| / (m T) from the orbit's multipliers (periodic)",
          output="attractors", columns=("lyapunov",)),
    Field("lyapunov_error", "uncertainty of the Lyapunov exponent", "1",
          "one standard error of the exponent over 8 blocks of the record window (NaN for a "
          "periodic attractor, whose exponent is exact to the solver's accuracy)",
          output="attractors"),
    Field("lyapunov_periods", "forcing periods of the Lyapunov exponent's average", "1",
          "periods Benettin's average ran over (non-periodic and unsettled attractors: the "
          "record window, or with search.lyapunov_error the windows it took to reach that "
          "standard error, up to search.max_transient_periods); 0 for a periodic attractor "
          "(its exponent from the orbit's multipliers)",
          output="attractors", columns=("lyapunov_periods",)),
    Field("lyapunov_sum_error", "error of the Lyapunov exponents' sum", "1",
          "|lambda1 + lambda2 + 2 zeta| per unit tau: the sum of both exponents is -2 zeta "
          "exactly (Liouville's formula), here taken over the same window as the exponent "
          "(mean log|det M_k| / T, Benettin) or from the orbit's multipliers (periodic); a "
          "certificate of the variational integration behind the exponent",
          output="attractors"),
    _window("attractor_flight_fraction", "flight_fraction", "flight fraction on the attractor",
            "fraction of the time out of contact over the attractor's window", "fraction"),
    _window("attractor_max_impact_velocity", "max_impact_velocity",
            "largest impact velocity on the attractor",
            "largest |dq/dtau| at recontact over the attractor's window", "velocity"),
    _window("attractor_min_q", "min_q", "minimum displacement on the attractor",
            "minimum of q over the attractor's window", "displacement"),
    Field("max_q", "maximum displacement on the attractor", "1",
          "maximum of q over the attractor's window"),
    _window("attractor_peak_force", "peak_force", "peak contact force on the attractor",
            "largest contact force F/N over the attractor's window (F of its largest q)",
            "force"),
    _window("attractor_rms_force", "rms_force", "rms contact force on the attractor",
            "root mean square of the contact force F/N over the attractor's window", "force"),
    Field("strobe_q", "stroboscopic displacement on the attractor", "1",
          "q at tau = 0 mod T of the last periods of the attractor's window (the points of a "
          "brute-force bifurcation diagram); NaN beyond those recorded",
          output="attractors", columns=(), dim=("strobe", STROBE_POINTS),
          quantity="displacement"),
    Field("strobe_v", "stroboscopic velocity on the attractor", "1",
          "dq/dtau at tau = 0 mod T of the same points as strobe_q",
          output="attractors", columns=(), dim=("strobe", STROBE_POINTS), quantity="velocity"),
    *_kernel_only(
        ("status", "kernels.status code"),
        ("period", "m of the detected cycle (0: none)"),
        ("settled_at", "period index of the confirmed detection (NaN: none)"),
        ("cycle_residual", "max |x_j - x_{j-m}| / (1 + |x_K|) over the detected cycle"),
        ("q_end", "last stroboscopic displacement (tau = 0 mod T)"),
        ("v_end", "last stroboscopic velocity"),
        ("lyapunov_halves", "|estimate of the first half - of the second half| (Benettin)"),
        ("liouville_error", "max_k |det M_k - exp(-2 zeta T)| / scale over the window"),
        ("window_periods", "periods the measures are over"),
        ("mean_force", "<F> / N over the window (sampled)"),
        ("force_quadrature_error", "|sampled <F> - exact <F>| (Eq. 7 over the window)"),
        ("steps", "accepted integrator steps of the transient and the record"),
        ("rejected", "rejected steps"),
        ("events", "contact events"),
        ("refinements", "shooting attempts"),
        ("orbit_period", "period m of the orbit row (the last shooting attempt; 0: none)"),
        ("strobe_count", "stroboscopic points written to the strobe array"),
        ("recognised_as", "label of the known attractor the transient was recognised on "
                          "(status recognised; NaN otherwise)"),
    ),
))


def _vertex(name, long_name, description, stored=True):
    return Field(name, long_name, "1", description, output="curves" if stored else None)


#: A vertex of a traced fold, flip or grazing curve (kernels.continuation.trace_curve): the
#: kernel's record (VERTEX_FIELDS) and, where ``output`` is set, a variable of dim ``vertex`` of
#: the stored traced curves (study.products.traced_curves).
VERTEX = Record("vertex", (
    _vertex("omega", "excitation frequency", "omega of the vertex (paper Eq. 8)"),
    _vertex("sigma", "excitation amplitude",
            "sigma of the vertex (force amplitude / static preload)"),
    _vertex("zeta", "damping ratio", "zeta of the vertex"),
    _vertex("q0", "displacement at tau = 0",
            "start point q(0) of the periodic orbit at the vertex"),
    _vertex("v0", "velocity at tau = 0", "start point dq/dtau(0) of the periodic orbit"),
    Field("monodromy", "monodromy matrix", "1", "M over the orbit's period, row by row",
          columns=("m11", "m12", "m21", "m22"), dim=("monodromy_entry", 4)),
    _vertex("min_q", "minimum displacement over the orbit",
            "min q over one period (-n on a grazing curve; below -n the orbit loses contact)"),
    _vertex("max_q", "maximum displacement over the orbit",
            "max q over one period (with min q: the invariants a grid cell's orbits are "
            "matched to the curve by)"),
    _vertex("fold", "fold test function", "1 - tr M + det M of the orbit at the vertex"),
    _vertex("flip", "flip test function", "1 + tr M + det M of the orbit at the vertex"),
    _vertex("grazing", "grazing test function", "min q + n (Hertz) or min q - q_c (Taylor, Eq. 12)"),
    _vertex("asym", "distance of the orbit from its T-shift",
            "|Phi_T(x0) - x0| of a 2T orbit: 0 on the 1T orbit", stored=False),
    _vertex("step", "continuation step",
            "distance from the previous vertex of the curve in (q0, v0, a, b), (a, b) the "
            "curve's parameters (0 at a curve's first vertex)"),
    _vertex("residual", "residual of the extended system",
            "max |(Phi(x) - x, g)| at the vertex, g the curve's test function (~1e-12: the "
            "vertex solves the curve's equations to the integrator's accuracy)"),
    _vertex("iterations", "corrector iterations", "chord iterations of the vertex",
            stored=False),
    _vertex("arclength", "arclength", "cumulated step from the curve's first vertex"),
    _vertex("flag", "vertex flags", "why the vertex is there (bit mask; the product's "
            "flag_masks, kernels.continuation.VERTEX_FLAGS)", stored=False),
))
