"""The study file: parse and validate a TOML study into a frozen :class:`Study`.

A study file describes *what* to compute (the grid, the model, the solver accuracy, the
periods searched, the outputs stored), never *where* (that is the command line's job).
See docs/study-file.md for the reference of every table and key.

Every validation problem raises :class:`StudyError` (a ``ValueError``) whose message names
the offending field (``grid.omega``, ``solver.rtol``...) and the allowed range.
Nothing here touches the disk except :func:`load_study`, which only reads the file.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from hertzmap.kernels.model import (DEFAULT_EXPONENT, DEFAULT_LAW, DEFAULT_RTOL, LAW_OF_CODE, LAWS,
                                    MODELS, Model)
from hertzmap.study import spec_fields as F
from hertzmap.study.spec_fields import MAX_GRID_POINTS, StudyError

__all__ = [
    "StudyError",
    "Study",
    "load_study",
    "parse_study",
    "OUTPUTS",
    "DEFAULT_OUTPUTS",
    "MAX_GRID_POINTS",
    "SPEC_VERSION",
    "SWEEP_AXES",
    "DEFAULT_SWEEP",
    "SWEEP_RATE_RANGE",
    "SWEEP_MAX_CYCLES",
]

SPEC_VERSION = 2


AXES = ("omega", "sigma", "zeta")

#: What a run can store, the study file's ``[products] outputs`` (not the products derived from
#: the results afterwards, study.products); the variables of each: study.schema.OUTPUT_VARIABLES.
#: "curves" (traced fold, flip and grazing curves, products/traced_curves, written by the run)
#: stores the sign changes of the test functions along each line (``crossing_*``, its seeds)
#: and implies "measures" (the stored orbits' min q and max q match neighbouring grid points).
#: "thresholds" (sigma*(zeta), sigma**(zeta) and the isola's join continued over the grid's zeta
#: range, products/thresholds, written by the run) needs two or more zeta values and implies
#: "curves" (sigma** starts from the traced isola).
#: "sweeps" (stepped-sine sweeps up and down each line of the grid along the [sweep] axis, the
#: grid's values as the steps, with their jumps, products/sweeps, written by the run) needs two or
#: more values on that axis and implies "measures" (the stored branches drawn behind the sweeps).
OUTPUTS = ("orbits", "measures", "force_harmonics", "diagnostics", "bifurcations",
           "attractors", "curves", "thresholds", "sweeps")
#: "orbits" is always stored (period, q0, v0, status, multipliers, stable).
CORE_OUTPUT = "orbits"
DEFAULT_OUTPUTS = ("orbits", "measures")

#: the contact laws a study file may name (kernels.model.LAWS)
MODEL_KINDS = tuple(law.name for law in LAWS)
EXPONENT_RANGE = (0.0, 3.0)           # exclusive, inclusive
RTOL_RANGE = (1e-13, 1e-4)            # inclusive
PERIODS_ALLOWED = tuple(range(1, 17))     # any m in 1..16 (periods in forcing periods)
#: Where the attractor census runs transients: at the points where shooting found no stable
#: orbit, at every point (basins everywhere), or nowhere.
ATTRACTOR_MODES = ("where-none-stable", "always", "never")
#: which unstable orbits the atlas continues into the grid neighbours (study.solve.atlas):
#: those of the periods the study searches (the unstable orbits of other periods, which the
#: census meets inside chaotic sets, are stored where they were met), or all of them
CONTINUE_UNSTABLE = ("searched-periods", "all")
INITIAL_STATES_RANGE = (1, 64)
TRANSIENT_PERIODS_RANGE = (10, 100_000)
RECORD_PERIODS_RANGE = (32, 10_000)
DEFAULT_INITIAL_STATES = 16
DEFAULT_TRANSIENT_PERIODS = 500
DEFAULT_RECORD_PERIODS = 128
MAX_TRANSIENT_PERIODS_RANGE = (10, 1_000_000)
DEFAULT_MAX_TRANSIENT_PERIODS = 20_000
POINT_STEPS_RANGE = (10_000, 10_000_000_000)
DEFAULT_POINT_STEPS = 2_000_000
#: search.lyapunov_error: the largest Lyapunov exponent's target standard error (per unit tau)
LYAPUNOV_ERROR_RANGE = (1e-6, 1.0)
CONTACTS = ("double", "single")
#: [sweep] (the "sweeps" output, study.solve.sweep.stepped_sweep): the axis stepped (the two
#: others fixed at each line of the grid), the width each jump is bracketed to, and each step's
#: budget of forcing periods (transient, then record window)
SWEEP_AXES = ("omega", "sigma")
SWEEP_JUMP_TOL_RANGE = (1e-10, 1e-1)
SWEEP_SETTLE_PERIODS_RANGE = (10, 1_000_000)
SWEEP_RECORD_PERIODS_RANGE = (32, 10_000)
#: the defaults: near a flip the followed orbit's multiplier is ~ -1 + c d at a distance d, and
#: a step 2.4e-3 past the flip at sigma 0.5, zeta 0.01 (omega 1.98) needs ~2000 periods to
#: leave the 1T orbit for the 2T one (1000 do not: the step is then recorded unsettled)
DEFAULT_SWEEP = {"axis": "omega", "jump_tol": 1e-6, "settle_periods": 4000,
                 "record_periods": 200}
#: [sweep] rates: the swept-sine runs beside the stepped sweeps (study.solve.swept_sine.swept_sine),
#: each rate the swept parameter's change per unit dimensionless time tau (d omega / d tau for
#: axis omega, d sigma / d tau for sigma), up and down each line; none by default (the key is
#: then left out of the canonical form: a study without it hashes as before). rates_hz_per_s
#: gives them on the [rig] instead (axis omega: d f / d t = rate 2 pi f0^2).
SWEEP_RATE_RANGE = (1e-9, 1e-2)
#: the most forcing cycles one swept-sine run may take (about 10 us each near omega 2, up to
#: 80 us at omega 0.5 with impacts: 1e7 cycles are 2 to 15 minutes)
SWEEP_MAX_CYCLES = 10_000_000
SWEEP_MAX_RATES = 16

_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,63}$")


_RIG_KEYS = {
    # key: (description of allowed range, check)
    "E": ("Young's modulus in Pa, > 0", lambda x: x > 0),
    "nu": ("Poisson's ratio, -1 < nu < 0.5", lambda x: -1.0 < x < 0.5),
    "R": ("sphere radius in m, > 0", lambda x: x > 0),
    "m": ("moving mass in kg, > 0", lambda x: x > 0),
    "N": ("static preload in N, > 0", lambda x: x > 0),
}


@dataclass(frozen=True)
class Study:
    """A validated study. Immutable; ``hash`` identifies it (sha256 of :meth:`canonical_json`).

    Axis values are stored in the order given (a decreasing omega axis is a downward sweep).
    ``source_text`` is the original TOML text (kept for the store's attrs, not part of the hash).
    """

    name: str
    description: str
    omega: tuple[float, ...]
    sigma: tuple[float, ...]
    zeta: tuple[float, ...]
    model: str = DEFAULT_LAW
    exponent: float | None = DEFAULT_EXPONENT
    rtol: float = DEFAULT_RTOL
    periods: tuple[int, ...] = (1, 2)
    discover: bool = False
    transients: int = 16
    attractors: str = "always"
    continue_unstable: str = "searched-periods"
    initial_states: int = DEFAULT_INITIAL_STATES
    transient_periods: int = DEFAULT_TRANSIENT_PERIODS
    record_periods: int = DEFAULT_RECORD_PERIODS
    max_transient_periods: int = DEFAULT_MAX_TRANSIENT_PERIODS
    point_steps: int = DEFAULT_POINT_STEPS
    lyapunov_error: float | None = None
    outputs: tuple[str, ...] = DEFAULT_OUTPUTS
    rig: tuple[tuple[str, Any], ...] | None = None
    #: the [sweep] table, fully defaulted, as sorted (key, value) pairs (None: no "sweeps"
    #: output)
    sweep: tuple[tuple[str, Any], ...] | None = None
    source_text: str = field(default="", compare=False, repr=False)

    # -- derived ---------------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int, int]:
        """Grid shape (len(omega), len(sigma), len(zeta))."""
        return (len(self.omega), len(self.sigma), len(self.zeta))

    @property
    def size(self) -> int:
        """Number of grid points."""
        return len(self.omega) * len(self.sigma) * len(self.zeta)

    def axis(self, name: str) -> np.ndarray:
        """Coordinate values of one axis as a float64 array."""
        if name not in AXES:
            raise KeyError(name)
        return np.asarray(getattr(self, name), dtype=np.float64)

    @property
    def rig_dict(self) -> dict[str, Any] | None:
        return None if self.rig is None else dict(self.rig)

    @property
    def sweep_dict(self) -> dict[str, Any] | None:
        """The [sweep] settings (axis, jump_tol, settle_periods, record_periods), defaults
        filled in, and ``rates`` (a tuple, per unit tau, fastest first) when it has swept-sine
        rates; None for a study without the "sweeps" output."""
        return None if self.sweep is None else dict(self.sweep)

    @property
    def sweep_rates(self) -> tuple[float, ...]:
        """The [sweep] rates of the swept-sine runs (per unit tau, fastest first); () without
        any (or without the "sweeps" output)."""
        return tuple((self.sweep_dict or {}).get("rates", ()))

    def sweep_lines(self) -> list[dict[str, float]]:
        """The lines the "sweeps" output sweeps: the fixed parameters of each (the two axes
        other than [sweep] axis), every combination of the grid's values, in the grid's
        order (the first of the two axes varying slowest)."""
        if self.sweep is None:
            return []
        axis = self.sweep_dict["axis"]
        a, b = [ax for ax in AXES if ax != axis]
        return [{a: float(x), b: float(y)} for x in getattr(self, a) for y in getattr(self, b)]

    @property
    def model_value(self) -> Model:
        """The study's contact law, exponent (the default where the law has none) and rtol."""
        return Model(self.model, DEFAULT_EXPONENT if self.exponent is None else self.exponent,
                     self.rtol)

    def solver_kwargs(self) -> dict[str, Any]:
        """Keyword arguments for ``study.block.solve_block`` (everything but the coordinates)."""
        model = self.model_value
        kw = {
            "periods": tuple(self.periods),
            "exponent": model.exponent,
            "model": model.law,
            "rtol": model.rtol,
        }
        if "force_harmonics" not in self.outputs:
            kw["harmonics"] = False  # not stored: skip their quadrature (a quarter of the time)
        if "bifurcations" in self.outputs:
            kw["locate"] = True     # only then: other studies call the solver as before
        if "curves" in self.outputs:
            kw["crossings"] = True  # the curves' seeds along each line (no kernel call)
        if self.discover:
            kw["discover"] = True   # transients + continuation per line (study.solve.discovery)
            kw["transients"] = int(self.transients)
        kw["attractors"] = self.attractors
        if self.attractors != "never":
            kw["initial_states"] = int(self.initial_states)
            kw["transient_periods"] = int(self.transient_periods)
            kw["record_periods"] = int(self.record_periods)
            kw["max_transient_periods"] = int(self.max_transient_periods)
            kw["point_steps"] = int(self.point_steps)
            if self.lyapunov_error is not None:
                kw["lyapunov_error"] = float(self.lyapunov_error)
        return kw

    def to_dict(self) -> dict[str, Any]:
        """The canonical, fully defaulted content of the study (JSON-compatible)."""
        return {
            "spec_version": SPEC_VERSION,
            "study": {"name": self.name, "description": self.description},
            "grid": {ax: [float(x) for x in getattr(self, ax)] for ax in AXES},
            "model": {"kind": self.model, "exponent": self.exponent},
            "solver": {"rtol": self.rtol},
            "search": self._search_dict(),
            # the study file's table and key ([products] outputs): the hash reads them
            "products": {"outputs": list(self.outputs)},
            "rig": self.rig_dict,
        } | ({"sweep": self.sweep_dict} if self.sweep is not None else {})

    def _search_dict(self) -> dict[str, Any]:
        """The [search] table with the keys that apply (a key a study file may not give in this
        configuration is left out, so that the dict reads back as a valid study file)."""
        out: dict[str, Any] = {"periods": list(self.periods), "attractors": self.attractors,
                               "continue_unstable": self.continue_unstable}
        if self.discover:
            out.update(discover=True, transients=int(self.transients))
        if self.attractors != "never":
            out.update(initial_states=int(self.initial_states),
                       transient_periods=int(self.transient_periods),
                       record_periods=int(self.record_periods),
                       max_transient_periods=int(self.max_transient_periods),
                       point_steps=int(self.point_steps))
            if self.lyapunov_error is not None:
                out["lyapunov_error"] = float(self.lyapunov_error)
        return out

    def canonical_json(self) -> str:
        """Canonical JSON: sorted keys, no whitespace, floats in shortest round-trip form.

        Two study files that mean the same computation (same values, whatever the
        formatting, comments, key order or axis notation) have the same canonical JSON.
        """
        return json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"), allow_nan=False)

    @property
    def hash(self) -> str:
        """sha256 (hex) of :meth:`canonical_json`."""
        return hashlib.sha256(self.canonical_json().encode("utf-8")).hexdigest()


# ----------------------------------------------------------------------------------------
# the parser


def parse_study(text: str, *, default_name: str | None = None) -> Study:
    """Parse and validate the TOML text of a study file.

    ``default_name`` is used when the file has no ``[study] name`` (load_study passes the
    file's stem). Raises :class:`StudyError` on any problem.
    """
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise StudyError("toml", f"not valid TOML: {exc}") from None
    return _validated(doc, default_name, text)


def study_from_dict(doc: dict, *, default_name: str | None = None) -> Study:
    """Validate a study given as the dict its study file parses to (``{"grid": {"omega":
    [...], ...}, "search": {...}}``: the tables of docs/study-file.md as dicts). Its
    ``source_text`` (kept in the store's attrs) is the TOML text of ``doc``
    (:func:`study_toml`). Raises :class:`StudyError` on any problem."""
    if not isinstance(doc, dict):
        raise StudyError("study", f"a study is a dict of tables (grid, search, ...), got "
                         f"{type(doc).__name__}")
    text = study_toml(doc)
    return _validated(tomllib.loads(text), default_name, text)


def _toml_value(v: Any, where: str) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float, np.integer, np.floating)):
        x = v.item() if isinstance(v, np.generic) else v
        if isinstance(x, float) and not math.isfinite(x):
            return "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf")
        return repr(x)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple, np.ndarray)):
        return "[" + ", ".join(_toml_value(x, where) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(x, f'{where}.{k}')}"
                                for k, x in v.items()) + " }"
    raise StudyError(where, f"a value of type {type(v).__name__} has no TOML form; give numbers, "
                     "strings, booleans, lists or tables")


def study_toml(doc: dict) -> str:
    """The TOML text of a study given as a dict of tables (each a dict of keys)."""
    out = []
    for table, body in doc.items():
        if not isinstance(body, dict):
            raise StudyError(str(table), f"must be a table (a dict of keys), got "
                             f"{type(body).__name__}")
        out.append(f"[{table}]")
        out += [f"{k} = {_toml_value(v, f'{table}.{k}')}" for k, v in body.items()]
        out.append("")
    return "\n".join(out)


def _validated(doc: dict, default_name: str | None, text: str) -> Study:
    """The Study of a parsed study file ``doc`` (``text``: its TOML text)."""
    F.refuse_unknown(doc, "", ("study", "grid", "model", "solver", "search", "products", "rig",
                              "sweep"))

    # [study]
    st = F.table(doc, "study")
    F.refuse_unknown(st, "study", ("name", "description"))
    name = st.get("name", default_name)
    if name is None:
        raise StudyError("study.name", "missing; give [study] name = \"...\"")
    if not isinstance(name, str) or not _NAME_RE.match(name):
        raise StudyError("study.name", "must be 1-64 characters from letters, digits, '.', '_', '-' "
                         f"(starting with a letter or digit), got {F.shown(name)}")
    description = st.get("description", "")
    if not isinstance(description, str):
        raise StudyError("study.description", f"expected a string, got {F.shown(description)}")

    # [grid]
    grid = F.table(doc, "grid", required=True)
    F.refuse_unknown(grid, "grid", AXES)
    for ax in AXES:
        if ax not in grid:
            raise StudyError(f"grid.{ax}", "missing; give a number, a list or {start, stop, num}")
    # the size is checked before any axis is expanded: a huge grid is refused at once,
    # without allocating its axes
    lengths = {ax: F.axis_length(grid[ax]) for ax in AXES}
    if all(n is not None for n in lengths.values()):
        size = math.prod(lengths.values())
        if size > MAX_GRID_POINTS:
            raise StudyError("grid", f"{size} points (omega x sigma x zeta = "
                             f"{' x '.join(str(lengths[a]) for a in AXES)}) exceeds the limit of "
                             f"{MAX_GRID_POINTS}; split the study")
    axes = {}
    for ax in AXES:
        axes[ax] = F.parse_axis(grid[ax], ax)
    size = math.prod(len(v) for v in axes.values())
    if size > MAX_GRID_POINTS:
        raise StudyError("grid", f"{size} points (omega x sigma x zeta = "
                         f"{' x '.join(str(len(axes[a])) for a in AXES)}) exceeds the limit of "
                         f"{MAX_GRID_POINTS}; split the study")

    # [model]
    mt = F.table(doc, "model")
    F.refuse_unknown(mt, "model", ("kind", "exponent"))
    kind = mt.get("kind", DEFAULT_LAW)
    if kind not in MODEL_KINDS:
        raise StudyError("model.kind", f"must be one of {', '.join(map(repr, MODEL_KINDS))}, "
                         f"got {F.shown(kind)}")
    if LAW_OF_CODE[MODELS[kind]].has_exponent:
        lo, hi = EXPONENT_RANGE
        exponent = F.number(mt.get("exponent", DEFAULT_EXPONENT), "model.exponent", f"{lo} < exponent <= {hi}")
        if not lo < exponent <= hi:
            raise StudyError("model.exponent", f"must satisfy {lo:g} < exponent <= {hi:g}, "
                             f"got {F.shown(exponent)}")
    else:
        if "exponent" in mt:
            raise StudyError("model.exponent", "only allowed with kind = "
                             + " or ".join(f'"{law.name}"' for law in LAWS if law.has_exponent)
                             + f" (the {kind} model has no exponent)")
        exponent = None

    # [solver]
    so = F.table(doc, "solver")
    if "max_solutions" in so:
        raise StudyError("solver.max_solutions", "no longer a setting: every orbit found at a "
                         "point is stored (store format 2); delete this key")
    F.refuse_unknown(so, "solver", ("rtol",))
    lo, hi = RTOL_RANGE
    rtol = F.number(so.get("rtol", DEFAULT_RTOL), "solver.rtol", f"{lo:g} <= rtol <= {hi:g}")
    if not lo <= rtol <= hi:
        raise StudyError("solver.rtol", f"must satisfy {lo:g} <= rtol <= {hi:g}, got {F.shown(rtol)}")

    # [search]
    se = F.table(doc, "search")
    F.refuse_unknown(se, "search", ("periods", "discover", "transients", "attractors",
                                   "continue_unstable",
                                   "initial_states", "transient_periods", "record_periods",
                                   "max_transient_periods", "point_steps", "lyapunov_error"))
    discover = se.get("discover", False)
    if not isinstance(discover, bool):
        raise StudyError("search.discover", f"expected true or false, got {F.shown(discover)}")
    transients = se.get("transients", 16)
    if isinstance(transients, bool) or not isinstance(transients, int) or not 1 <= transients <= 256:
        raise StudyError("search.transients", f"expected an integer 1..256 (initial states of the "
                         f"transients per line), got {F.shown(transients)}")
    if "transients" in se and not discover:
        raise StudyError("search.transients", "only meaningful with search.discover = true")
    periods = se.get("periods", [1, 2])
    if not isinstance(periods, list) or not periods:
        raise StudyError("search.periods", "expected a non-empty list of periods, integers "
                         f"1..{PERIODS_ALLOWED[-1]} (e.g. [1, 2, 4]), got {F.shown(periods)}")
    for p in periods:
        if not isinstance(p, int) or isinstance(p, bool) or p not in PERIODS_ALLOWED:
            raise StudyError("search.periods", f"each period must be an integer "
                             f"1..{PERIODS_ALLOWED[-1]} (in forcing periods), got {F.shown(p)}")
    if len(set(periods)) != len(periods):
        raise StudyError("search.periods", f"duplicated period in {F.shown(periods)}")
    periods_t = tuple(sorted(int(p) for p in periods))
    # the attractor census at every point (every point's basins sampled: what attracts there is
    # known by construction); a 1T-only scene (a flip curve, say) pays nothing for it by default
    attractors = se.get("attractors", "always" if max(periods_t) >= 2 else "never")
    if attractors not in ATTRACTOR_MODES:
        raise StudyError("search.attractors", f"must be one of "
                         f"{', '.join(map(repr, ATTRACTOR_MODES))}, got {F.shown(attractors)}")
    continue_unstable = se.get("continue_unstable", CONTINUE_UNSTABLE[0])
    if continue_unstable not in CONTINUE_UNSTABLE:
        raise StudyError("search.continue_unstable", f"must be one of "
                         f"{', '.join(map(repr, CONTINUE_UNSTABLE))}, got {F.shown(continue_unstable)}")
    census = {}
    for key, (lo, hi), default, what in (
            ("initial_states", INITIAL_STATES_RANGE, DEFAULT_INITIAL_STATES,
             "initial states of the transients per grid point"),
            ("transient_periods", TRANSIENT_PERIODS_RANGE, DEFAULT_TRANSIENT_PERIODS,
             "forcing periods a transient may run before it counts as unsettled"),
            ("record_periods", RECORD_PERIODS_RANGE, DEFAULT_RECORD_PERIODS,
             "forcing periods of the window the exponent and measures are taken over"),
            ("max_transient_periods", MAX_TRANSIENT_PERIODS_RANGE, DEFAULT_MAX_TRANSIENT_PERIODS,
             "forcing periods the transients of a point that did not settle may run in all, "
             "in longer passes, before it is called unsettled"),
            ("point_steps", POINT_STEPS_RANGE, DEFAULT_POINT_STEPS,
             "integration steps the longer passes of one point may take, summed over its "
             "transients")):
        value = se.get(key, default)
        if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
            raise StudyError(f"search.{key}", f"expected an integer {lo}..{hi} ({what}), "
                             f"got {F.shown(value)}")
        if key in se and attractors == "never":
            raise StudyError(f"search.{key}", 'only meaningful with search.attractors other '
                             'than "never"')
        census[key] = value
    if census.get("max_transient_periods", DEFAULT_MAX_TRANSIENT_PERIODS) < census.get(
            "transient_periods", DEFAULT_TRANSIENT_PERIODS):
        raise StudyError("search.max_transient_periods", "must be at least "
                         "search.transient_periods")
    if "lyapunov_error" in se:
        lo, hi = LYAPUNOV_ERROR_RANGE
        value = se["lyapunov_error"]
        if not F.is_number(value) or not lo <= value <= hi:
            raise StudyError("search.lyapunov_error", f"expected a number {lo:g}..{hi:g} (the "
                             "largest Lyapunov exponent's standard error to reach, per unit "
                             f"dimensionless time), got {F.shown(value)}")
        if attractors == "never":
            raise StudyError("search.lyapunov_error", 'only meaningful with search.attractors '
                             'other than "never"')
        census["lyapunov_error"] = float(value)

    # [products]
    pr = F.table(doc, "products")
    F.refuse_unknown(pr, "products", ("outputs",))
    outputs = pr.get("outputs", list(DEFAULT_OUTPUTS))
    if not isinstance(outputs, list):
        raise StudyError("products.outputs", f"expected a list of names from {list(OUTPUTS)}, "
                         f"got {F.shown(outputs)}")
    for o in outputs:
        if o not in OUTPUTS:
            raise StudyError("products.outputs", f"unknown output {F.shown(o)}; allowed: {', '.join(OUTPUTS)}")
    if len(set(outputs)) != len(outputs):
        raise StudyError("products.outputs", f"duplicated output in {F.shown(outputs)}")
    if "attractors" in outputs and attractors == "never":
        raise StudyError("products.outputs", '"attractors" needs search.attractors other than '
                         '"never"')
    # -- the thresholds in zeta: continued over the grid's zeta range, sigma** from the
    #    traced isola
    if "thresholds" in outputs:
        if len(axes["zeta"]) < 2:
            raise StudyError("products.outputs", "\"thresholds\" continues sigma* and sigma** "
                             f"in zeta over the grid's zeta range; grid.zeta has "
                             f"{len(axes['zeta'])} value (give it two or more, or drop "
                             "\"thresholds\")")
        if "curves" not in outputs:
            outputs = list(outputs) + ["curves"]
    # -- traced curves: seeded by the grid's sign changes, in planes of two swept
    #    axes
    if "curves" in outputs:
        swept = [ax for ax in AXES if len(axes[ax]) >= 2]
        if len(swept) < 2:
            raise StudyError("products.outputs", "\"curves\" traces curves in a plane of two "
                             "swept parameters; this grid sweeps "
                             f"{' and '.join(swept) if swept else 'no axis'} only (give two of "
                             "grid.omega, grid.sigma, grid.zeta two or more values, or drop "
                             "\"curves\")")
        outputs = list(outputs) + ["measures"]
    if "sweeps" in outputs:
        outputs = list(outputs) + ["measures"]
    # the census's results are stored whenever it runs
    outputs = tuple(p for p in OUTPUTS if p in outputs or p == CORE_OUTPUT
                    or (p == "attractors" and attractors != "never"))

    # [rig]
    rig = None
    if "rig" in doc:
        rt = F.table(doc, "rig")
        F.refuse_unknown(rt, "rig", (*_RIG_KEYS, "contact"))
        values: dict[str, Any] = {}
        for key, (desc, check) in _RIG_KEYS.items():
            if key not in rt:
                raise StudyError(f"rig.{key}", f"missing ({desc})")
            x = F.number(rt[key], f"rig.{key}", desc)
            if not check(x):
                raise StudyError(f"rig.{key}", f"out of range: {desc}, got {F.shown(x)}")
            values[key] = x
        contact = rt.get("contact", "double")
        if contact not in CONTACTS:
            raise StudyError("rig.contact", f"must be one of {', '.join(map(repr, CONTACTS))}, "
                             f"got {F.shown(contact)}")
        values["contact"] = contact
        rig = tuple(sorted(values.items()))

    # [sweep] (after [rig]: its rates may be given in the rig's units)
    sweep = _parse_sweep(doc, outputs, axes, rig)

    return Study(
        name=name,
        description=description,
        omega=axes["omega"],
        sigma=axes["sigma"],
        zeta=axes["zeta"],
        model=kind,
        exponent=exponent,
        rtol=rtol,
        periods=periods_t,
        discover=discover,
        transients=transients,
        attractors=attractors,
        continue_unstable=continue_unstable,
        **census,
        outputs=outputs,
        rig=rig,
        sweep=sweep,
        source_text=text,
    )


def _parse_sweep(doc: Mapping[str, Any], outputs, axes: dict[str, tuple[float, ...]],
                 rig: tuple[tuple[str, Any], ...] | None = None
                 ) -> tuple[tuple[str, Any], ...] | None:
    """The [sweep] table (the "sweeps" output's settings), defaults filled in, as sorted pairs;
    None without the "sweeps" output (a [sweep] table is then refused). ``rig``: the study's
    validated [rig] (for rates_hz_per_s)."""
    if "sweeps" not in outputs:
        if "sweep" in doc:
            raise StudyError("sweep", 'the [sweep] table is only meaningful with "sweeps" in '
                             "products.outputs")
        return None
    sw = F.table(doc, "sweep")
    F.refuse_unknown(sw, "sweep", (*DEFAULT_SWEEP, "rates", "rates_hz_per_s"))
    axis = sw.get("axis", DEFAULT_SWEEP["axis"])
    if axis not in SWEEP_AXES:
        raise StudyError("sweep.axis", f"must be one of {', '.join(map(repr, SWEEP_AXES))} (the "
                         f"parameter stepped), got {F.shown(axis)}")
    if len(axes[axis]) < 2:
        raise StudyError("products.outputs", f"\"sweeps\" steps along grid.{axis} (sweep.axis), "
                         f"which has {len(axes[axis])} value; give it two or more values (the "
                         "steps), or drop \"sweeps\"")
    lo, hi = SWEEP_JUMP_TOL_RANGE
    allowed = f"{lo:g} <= jump_tol <= {hi:g} (the width in the swept parameter each jump is " \
              "bracketed to)"
    jump_tol = F.number(sw.get("jump_tol", DEFAULT_SWEEP["jump_tol"]), "sweep.jump_tol", allowed)
    if not lo <= jump_tol <= hi:
        raise StudyError("sweep.jump_tol", f"must satisfy {allowed}, got {F.shown(jump_tol)}")
    out: dict[str, Any] = {"axis": axis, "jump_tol": jump_tol}
    for key, (lo, hi), what in (
            ("settle_periods", SWEEP_SETTLE_PERIODS_RANGE,
             "forcing periods a step's transient may run to settle"),
            ("record_periods", SWEEP_RECORD_PERIODS_RANGE,
             "forcing periods of the window a step that does not settle is measured over")):
        value = sw.get(key, DEFAULT_SWEEP[key])
        if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
            raise StudyError(f"sweep.{key}", f"expected an integer {lo}..{hi} ({what}), got "
                             f"{F.shown(value)}")
        out[key] = int(value)
    rates = _parse_rates(sw, axis, axes, rig)
    if rates:
        out["rates"] = rates
    return tuple(sorted(out.items()))


def _parse_rates(sw: Mapping[str, Any], axis: str, axes: dict[str, tuple[float, ...]],
                 rig: tuple[tuple[str, Any], ...] | None) -> tuple[float, ...]:
    """[sweep] rates (per unit tau) or rates_hz_per_s (on the [rig], axis omega), checked and
    converted to per unit tau, fastest first; () when neither is given."""
    if "rates" in sw and "rates_hz_per_s" in sw:
        raise StudyError("sweep.rates_hz_per_s", "give the swept-sine rates once: rates "
                         "(dimensionless, per unit tau) or rates_hz_per_s (on the [rig]), not "
                         "both")
    key = "rates_hz_per_s" if "rates_hz_per_s" in sw else "rates"
    field_name = f"sweep.{key}"
    given = sw.get(key, [])
    lo, hi = SWEEP_RATE_RANGE
    if key == "rates":
        scale, unit = 1.0, ""
        what = (f"each {lo:g} <= rate <= {hi:g}, the change of {axis} per unit dimensionless "
                "time tau")
    else:
        if axis != "omega":
            raise StudyError(field_name, 'a rate in Hz/s is a frequency\'s: only with axis = '
                             '"omega"; give rates (d sigma per unit tau) for axis "sigma"')
        if rig is None:
            raise StudyError(field_name, "needs a [rig] (its f0 converts Hz/s into omega per "
                             "unit tau); without one give rates (per unit tau)")
        from hertzmap.study.analytic.rig import Rig

        r = dict(rig)
        f0 = Rig.hertz(r["E"], r["nu"], r["R"], r["m"], r["N"], contact=r["contact"]).f0
        scale, unit = 1.0 / (2.0 * math.pi * f0 * f0), " Hz/s"
        what = (f"each {lo / scale:.4g} <= rate <= {hi / scale:.4g} Hz/s (a rate of 1 in "
                f"omega per unit tau is 2 pi f0^2 = {1 / scale:.6g} Hz/s, the rig's f0 = "
                f"{f0:.6g} Hz)")
    if not isinstance(given, list):
        raise StudyError(field_name, f"expected a list of numbers ({what}), got {F.shown(given)}")
    if len(given) > SWEEP_MAX_RATES:
        raise StudyError(field_name, f"at most {SWEEP_MAX_RATES} rates, got {len(given)}")
    rates = []
    for x in given:
        x = F.number(x, field_name, what)
        rate = x * scale
        if not (x > 0.0 and lo * (1 - 1e-12) <= rate <= hi * (1 + 1e-12)):
            raise StudyError(field_name, f"{what}; got {F.shown(x)}{unit}")
        rates.append(rate)
    if len(set(rates)) != len(rates):
        raise StudyError(field_name, f"duplicated rate in {F.shown(given)}")
    # the run's length: the forcing cycles of the slowest run along the line (T = 2 pi / omega)
    values = axes[axis]
    span = max(values) - min(values)
    for x, rate in zip(given, rates):
        if axis == "omega":
            cycles = (max(values) ** 2 - min(values) ** 2) / (4.0 * math.pi * rate)
        else:
            cycles = span * max(axes["omega"]) / (2.0 * math.pi * rate)
        if cycles > SWEEP_MAX_CYCLES:
            raise StudyError(field_name, f"the rate {F.shown(x)}{unit} would sweep grid.{axis} "
                             f"{min(values):g} .. {max(values):g} in {cycles:.3g} forcing "
                             f"cycles, more than the limit of {SWEEP_MAX_CYCLES:,} a swept run; "
                             f"give a rate at least {x * cycles / SWEEP_MAX_CYCLES:.3g}{unit}")
    return tuple(sorted(rates, reverse=True))


def load_study(path: str | Path) -> Study:
    """Read and validate a study file. The study name defaults to the file's stem."""
    p = Path(path)
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise StudyError("file", f"cannot read study file {str(p)!r}: {exc.strerror or exc}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise StudyError("file", f"{str(p)!r} is not UTF-8 text") from None
    return parse_study(text, default_name=p.stem)
