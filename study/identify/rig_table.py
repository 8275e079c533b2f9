"""The rig table of a fit (``hertzmap fit MEASURED --rig RIG.toml``): what the lab knows about
its rig and its excitation, validated field by field (docs/identify.md, "The rig table").

Paper Eq. 1-8 (study.analytic.rig): omega = f / f0, sigma = excitation force amplitude / N, and
the transmitted force's harmonics in N are N times the model's dimensionless ones, so the
preload N is the one number a fit cannot do without. The tables and keys::

    [rig]
    N = 69.7              # static preload, N (required)
    f0 = 270.6            # measured linearised natural frequency, Hz; or, from Hertz theory
    m = 7.1               #   (paper Eq. 28-29): the moving mass, kg,
    E = 2.1e11            #   Young's modulus, Pa,
    nu = 0.29             #   Poisson's ratio,
    R = 0.0127            #   the ball's radius, m,
    contact = "double"    #   "double" (a ball between two flats) or "single"
    f0_tolerance = 0.1    # f0 is searched within nominal x (1 -/+ this); or f0_bounds = [lo, hi]

    [excitation]
    force_N = 20.9        # the set point: force amplitude (peak), N; or sigma = 0.3
    tolerance = 0.5       # how roughly it is known: sigma within nominal x (1 -/+ this);
                          # or sigma_bounds = [lo, hi]
    [damping]             # optional
    zeta = 0.005          # a nominal damping ratio (a small-amplitude test), if known
    bounds = [0.001, 0.05]
    [model]               # optional
    # exponent            # the contact exponent n (default kernels.model's: 3/2, Hertz)
    fit_exponent = false  # true: n is fitted too, within exponent_bounds
    exponent_bounds = [1.0, 2.0]

Every error is a :class:`~hertzmap.study.identify.measurement.FitInputError` naming the table
and key (``excitation.tolerance``) and the allowed range.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from hertzmap.kernels.model import DEFAULT_EXPONENT
from hertzmap.study.analytic.rig import Rig
from hertzmap.study.identify.measurement import FitInputError

__all__ = ["RigTable", "rig_table", "read_rig_table", "TABLES", "F0_TOLERANCE",
           "SIGMA_TOLERANCE", "ZETA_BOUNDS", "SIGMA_MAX", "ZETA_LIMITS", "EXPONENT_LIMITS",
           "EXPONENT_BOUNDS", "table_attrs"]

#: the tables of a rig table and their keys
TABLES = {
    "rig": ("N", "f0", "m", "E", "nu", "R", "contact", "f0_tolerance", "f0_bounds"),
    "excitation": ("force_N", "sigma", "tolerance", "sigma_bounds"),
    "damping": ("zeta", "bounds"),
    "model": ("exponent", "fit_exponent", "exponent_bounds"),
}
#: default relative half-width of the f0 search around its nominal value, and its limits
F0_TOLERANCE, F0_TOLERANCE_LIMITS = 0.1, (1e-3, 0.5)
#: default relative half-width of the sigma search around the set point, and its limits
SIGMA_TOLERANCE, SIGMA_TOLERANCE_LIMITS = 0.5, (0.01, 0.9)
#: the largest sigma a fit searches (the vibro_impact scene's range)
SIGMA_MAX = 4.0
#: the damping ratios a fit may search, and the default search bounds
ZETA_LIMITS, ZETA_BOUNDS = (1e-4, 0.3), (1e-3, 0.05)
#: the contact exponents a fit may use (as the study file's model.exponent), and the default
#: bounds of a fitted one
EXPONENT_LIMITS, EXPONENT_BOUNDS = (0.0, 3.0), (1.0, 2.0)


@dataclass(frozen=True)
class RigTable:
    """A validated rig table (module docstring).

    N: the static preload, N. f0: the nominal linearised natural frequency, Hz, and
    f0_source: "measured" (the table's f0) or "hertz" (from m, E, nu, R, contact: paper Eq.
    28-29); f0_hertz: Hertz theory's f0 when m, E, nu, R are given (else NaN). f0_bounds,
    sigma_bounds, zeta_bounds, exponent_bounds: the search bounds. sigma: the set point's
    sigma (force_N / N); zeta: a nominal damping ratio (NaN: not given). exponent: the contact
    exponent n (the nominal value when fit_exponent). text: the TOML text; source: its file.
    """

    N: float
    f0: float
    f0_source: str
    f0_hertz: float
    f0_bounds: tuple[float, float]
    sigma: float
    sigma_bounds: tuple[float, float]
    zeta: float
    zeta_bounds: tuple[float, float]
    exponent: float
    fit_exponent: bool
    exponent_bounds: tuple[float, float]
    text: str = field(default="", repr=False)
    source: str = "<rig table>"


def read_rig_table(path: str | Path) -> RigTable:
    """The rig table of a TOML file. Raises FitInputError."""
    p = Path(path)
    try:
        text = p.read_bytes().decode("utf-8")
    except OSError as exc:
        raise FitInputError(f"cannot read the rig table: {exc.strerror or exc}",
                            source=str(p)) from None
    except UnicodeDecodeError:
        raise FitInputError("the rig table is not UTF-8 text", source=str(p)) from None
    return rig_table(text, source=str(p))


def rig_table(table: str | Path | Mapping | RigTable, *, source: str | None = None) -> RigTable:
    """A validated :class:`RigTable` from TOML text (a string with a newline or a ``=``), a
    path, a dict of tables, or a RigTable (returned as it is). Raises FitInputError."""
    if isinstance(table, RigTable):
        return table
    if isinstance(table, Path) or (isinstance(table, str) and "\n" not in table
                                   and "=" not in table):
        return read_rig_table(table)
    if isinstance(table, str):
        src = source or "<rig table>"
        try:
            doc = tomllib.loads(table)
        except tomllib.TOMLDecodeError as exc:
            raise FitInputError(f"not valid TOML: {exc}", source=src) from None
        return _validated(doc, table, src)
    if isinstance(table, Mapping):
        return _validated(dict(table), "", source or "<rig table>")
    raise FitInputError(f"give a rig table as a TOML file's path, its text or a dict of "
                        f"tables, got {type(table).__name__}", source=source)


def _validated(doc: dict, text: str, source: str) -> RigTable:
    def fail(name: str, message: str) -> FitInputError:
        return FitInputError(message, source=source, field=name)

    for name, body in doc.items():
        if name not in TABLES:
            raise fail(name, f"unknown table; the tables are {', '.join(TABLES)}")
        if not isinstance(body, dict):
            raise fail(name, f"must be a table [{name}], got a {type(body).__name__}")
        for key in body:
            if key not in TABLES[name]:
                raise fail(f"{name}.{key}", f"unknown key; [{name}] takes "
                           f"{', '.join(TABLES[name])}")
    rig = doc.get("rig")
    if rig is None:
        raise fail("rig", "missing; give [rig] N = the static preload in N (and f0, or m, E, "
                   "nu, R)")
    exc = doc.get("excitation")
    if exc is None:
        raise fail("excitation", "missing; give [excitation] force_N = the excitation force "
                   "amplitude in N, or sigma = force / N")
    damping = doc.get("damping", {})
    model = doc.get("model", {})

    def number(table: dict, tname: str, key: str, lo: float, hi: float, *, open_lo=True,
               open_hi=False, unit: str = "") -> float | None:
        if key not in table:
            return None
        v = table[key]
        name = f"{tname}.{key}"
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise fail(name, f"expected a number, got {v!r}")
        v = float(v)
        ok = (math.isfinite(v) and (v > lo if open_lo else v >= lo)
              and (v < hi if open_hi else v <= hi))
        if not ok:
            rng = (f"{lo:g} {'<' if open_lo else '<='} {key} "
                   f"{'<' if open_hi else '<='} {hi:g}" if math.isfinite(hi)
                   else f"{key} {'>' if open_lo else '>='} {lo:g}")
            raise fail(name, f"{v!r}{unit} is out of range; give {rng}")
        return v

    def bounds(table: dict, tname: str, key: str, lo: float, hi: float,
               unit: str = "") -> tuple[float, float] | None:
        if key not in table:
            return None
        v = table[key]
        name = f"{tname}.{key}"
        if (not isinstance(v, list) or len(v) != 2
                or any(isinstance(x, bool) or not isinstance(x, (int, float)) for x in v)):
            raise fail(name, f"expected two numbers [low, high], got {v!r}")
        a, b = float(v[0]), float(v[1])
        if not (math.isfinite(a) and math.isfinite(b) and lo < a < b <= hi):
            raise fail(name, f"[{a!r}, {b!r}]{unit}: give {lo:g} < low < high <= {hi:g}")
        return a, b

    inf = math.inf
    N = number(rig, "rig", "N", 0.0, inf, unit=" N")
    if N is None:
        raise fail("rig.N", "missing; give the static preload in N (> 0): the harmonics in N "
                   "are N times the model's")
    f0 = number(rig, "rig", "f0", 0.0, inf, unit=" Hz")
    hertz_keys = ("m", "E", "nu", "R")
    given = [k for k in hertz_keys if k in rig]
    f0_hertz = math.nan
    if given or "contact" in rig:
        missing = [k for k in hertz_keys if k not in rig]
        if missing:
            raise fail(f"rig.{missing[0]}", "missing; Hertz theory's f0 (paper Eq. 28-29) "
                       f"needs all of m, E, nu, R (given: {', '.join(given) or 'none'}; or "
                       "give only a measured f0)")
        m = number(rig, "rig", "m", 0.0, inf, unit=" kg")
        E = number(rig, "rig", "E", 0.0, inf, unit=" Pa")
        nu = number(rig, "rig", "nu", -1.0, 0.5, open_hi=True)
        R = number(rig, "rig", "R", 0.0, inf, unit=" m")
        contact = rig.get("contact", "double")
        if contact not in ("double", "single"):
            raise fail("rig.contact", f"{contact!r}: give \"double\" (a ball between two "
                       "flats, paper Eq. 28) or \"single\"")
        f0_hertz = Rig.hertz(E, nu, R, m, N, contact=contact).f0
    if f0 is None and not math.isfinite(f0_hertz):
        raise fail("rig.f0", "missing; give the measured f0 in Hz, or m, E, nu, R (and "
                   "contact) for Hertz theory's")
    nominal = f0 if f0 is not None else f0_hertz
    if "f0_tolerance" in rig and "f0_bounds" in rig:
        raise fail("rig.f0_bounds", "give f0_tolerance or f0_bounds, not both")
    f0_bounds = bounds(rig, "rig", "f0_bounds", 0.0, inf, unit=" Hz")
    if f0_bounds is None:
        tol = number(rig, "rig", "f0_tolerance", *F0_TOLERANCE_LIMITS, open_lo=False)
        tol = F0_TOLERANCE if tol is None else tol
        f0_bounds = (nominal * (1.0 - tol), nominal * (1.0 + tol))
    elif not f0_bounds[0] <= nominal <= f0_bounds[1]:
        raise fail("rig.f0_bounds", f"[{f0_bounds[0]:g}, {f0_bounds[1]:g}] Hz does not hold "
                   f"the nominal f0 {nominal:.6g} Hz ({'measured' if f0 is not None else 'Hertz'})")

    force = number(exc, "excitation", "force_N", 0.0, inf, unit=" N")
    sigma = number(exc, "excitation", "sigma", 0.0, SIGMA_MAX)
    if (force is None) == (sigma is None):
        raise fail("excitation", "give exactly one of force_N (the set point's force "
                   "amplitude, N) and sigma (force / N)")
    if force is not None:
        sigma = force / N
        if not sigma <= SIGMA_MAX:
            raise fail("excitation.force_N", f"{force!r} N is sigma = {sigma:.4g} with N = "
                       f"{N:g} N; a fit searches sigma <= {SIGMA_MAX:g}")
    if "tolerance" in exc and "sigma_bounds" in exc:
        raise fail("excitation.sigma_bounds", "give tolerance or sigma_bounds, not both")
    sigma_bounds = bounds(exc, "excitation", "sigma_bounds", 0.0, SIGMA_MAX)
    if sigma_bounds is None:
        tol = number(exc, "excitation", "tolerance", *SIGMA_TOLERANCE_LIMITS, open_lo=False)
        tol = SIGMA_TOLERANCE if tol is None else tol
        sigma_bounds = (sigma * (1.0 - tol), min(sigma * (1.0 + tol), SIGMA_MAX))
    elif not sigma_bounds[0] <= sigma <= sigma_bounds[1]:
        raise fail("excitation.sigma_bounds", f"[{sigma_bounds[0]:g}, {sigma_bounds[1]:g}] "
                   f"does not hold the set point's sigma {sigma:.4g}")

    zeta = number(damping, "damping", "zeta", ZETA_LIMITS[0], ZETA_LIMITS[1], open_lo=False)
    zeta_bounds = bounds(damping, "damping", "bounds", ZETA_LIMITS[0] * (1 - 1e-12),
                         ZETA_LIMITS[1]) or ZETA_BOUNDS
    if zeta is not None and not zeta_bounds[0] <= zeta <= zeta_bounds[1]:
        raise fail("damping.zeta", f"{zeta!r} lies outside damping.bounds [{zeta_bounds[0]:g}, "
                   f"{zeta_bounds[1]:g}]")

    exponent = number(model, "model", "exponent", *EXPONENT_LIMITS)
    exponent = DEFAULT_EXPONENT if exponent is None else exponent
    fit_exponent = model.get("fit_exponent", False)
    if not isinstance(fit_exponent, bool):
        raise fail("model.fit_exponent", f"expected true or false, got {fit_exponent!r}")
    exponent_bounds = bounds(model, "model", "exponent_bounds", *EXPONENT_LIMITS)
    if exponent_bounds is not None and not fit_exponent:
        raise fail("model.exponent_bounds", "only with fit_exponent = true")
    exponent_bounds = exponent_bounds or EXPONENT_BOUNDS
    if fit_exponent and not exponent_bounds[0] <= exponent <= exponent_bounds[1]:
        raise fail("model.exponent", f"{exponent!r} lies outside model.exponent_bounds "
                   f"[{exponent_bounds[0]:g}, {exponent_bounds[1]:g}]")
    return RigTable(N=N, f0=nominal, f0_source="measured" if f0 is not None else "hertz",
                    f0_hertz=f0_hertz, f0_bounds=f0_bounds, sigma=sigma,
                    sigma_bounds=sigma_bounds, zeta=math.nan if zeta is None else zeta,
                    zeta_bounds=zeta_bounds, exponent=exponent, fit_exponent=fit_exponent,
                    exponent_bounds=exponent_bounds, text=text, source=source)


def table_attrs(rig: RigTable) -> dict[str, Any]:
    """The rig table as the fit's Dataset attrs (numbers and strings)."""
    return {"rig_N": rig.N, "rig_f0_nominal": rig.f0, "rig_f0_source": rig.f0_source,
            "rig_f0_hertz": rig.f0_hertz, "rig_sigma_set_point": rig.sigma,
            "rig_zeta_nominal": rig.zeta, "rig_exponent": rig.exponent,
            "rig_fit_exponent": int(rig.fit_exponent), "rig_table": rig.text,
            "rig_table_source": rig.source}
