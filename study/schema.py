"""The stored schema of a study, defined once: variables, dims, dtypes, fill values, units, flags,
attrs, and the dataset a store starts from (no Dask, no I/O).

One xarray Dataset per study, dims ``omega``, ``sigma``, ``zeta``, ``solution`` (a point's
orbits) and ``attractor`` (its census's attractors) (plus ``multiplier``, ``harmonic``,
``strobe`` for the vector-valued variables) and a completion array ``task_done`` over the chunk
grid (dims ``omega_chunk``, ``sigma_chunk``, ``zeta_chunk``).

No cap on what a point holds: ``solution`` and ``attractor`` are sized by the data (SLOT_DIMS:
their length in a store is the most any point holds, chunked by SLOT_CHUNK, grown by the
scheduler as blocks need more), so every orbit the search finds and every attractor the census
finds is stored at its point.

Everything that writes or reads a store takes its variables from :data:`VARIABLES`: the block
solver allocates its arrays with :func:`empty_arrays`, the scheduler turns :func:`template` into
the store (``scheduler.store``) and region-writes each block, products read them back.
Every variable and coordinate carries ``long_name``, ``units`` and ``description``; code
variables carry ``flag_values``/``flag_meanings``. See docs/dataset.md for the reference.
"""

from __future__ import annotations

import datetime as _dt
import importlib.metadata
import json
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import xarray as xr

from hertzmap.kernels.records import (ATTRACTOR, ATTRACTOR_KINDS, ORBIT, PERIOD_FLAGS,  # noqa: F401
                                      STROBE_POINTS)
from hertzmap.study.spec import Study, StudyError, parse_study

__all__ = [
    "VarSpec",
    "VARIABLES",
    "ORBIT_VARIABLES",
    "LINE_VARIABLES",
    "BIFURCATION_VARIABLES",
    "CROSSING_VARIABLES",
    "CROSSING_SLOTS",
    "BIFURCATION_SLOTS",
    "BIFURCATION_KINDS",
    "empty_arrays",
    "study_from_attrs",
    "OUTPUT_VARIABLES",
    "GRID_DIMS",
    "PRODUCT_GROUP",
    "STORE_FORMAT",
    "FORMAT_ADVICE",
    "SLOT_DIMS",
    "SLOT_CHUNK",
    "slot_counts",
    "chunked_length",
    "array_slots",
    "pad_slots",
    "check_format",
    "StoreFormatError",
    "stored_variables",
    "template",
    "block_dataset",
    "check_block",
    "chunk_counts",
    "chunk_slices",
    "bytes_per_point",
    "software_versions",
    "history_line",
    "code_fingerprint",
    "parse_attrs",
]

#: Version of the store layout written by this module (an attr of every store). 2: the
#: ``solution`` and ``attractor`` dims sized by the data (every orbit and attractor a point has;
#: format 1 kept at most solver.max_solutions orbits and 4 attractors a point, and said how
#: many it dropped in ``orbits_dropped``).
#: 3: every array of the main group sharded (zarr's sharding codec: a shard of whole blocks,
#: written once by the client; scheduler.store.layout), format 2's values unchanged.
STORE_FORMAT = 3
#: What a reader of another format is told to do (study.products.results.check_format).
FORMAT_ADVICE = {1: "format 1 (hertzmap before 2026-11-28) kept at most solver.max_solutions "
                    "orbits and 4 attractors per point and may have dropped some: rerun the "
                    "study with `hertzmap run STUDY --overwrite` (delete solver.max_solutions "
                    "from its file) to store them all",
                 2: "format 2 (hertzmap before 2026-12-08) stored one file per chunk (not "
                    "sharded): rewrite it in place, without recomputing, with "
                    "`hertzmap upgrade STORE`"}

GRID_DIMS = ("omega", "sigma", "zeta", "solution")
#: Products (study.products) are stored in the study's store as zarr groups PRODUCT_GROUP/<name>.
PRODUCT_GROUP = "products"
#: Dims of the per-block variables (located bifurcation points): one entry per omega chunk of
#: the store and (sigma, zeta) line, so that each task writes exactly its own chunk.
BLOCK_DIMS = ("omega_block", "sigma", "zeta")
#: Located bifurcation points kept per omega line of a block; more are dropped
#: (``bifurcation_count`` says how many were found).
BIFURCATION_SLOTS = 16
#: Sign changes of the test functions recorded per omega line of a block (the traced curves'
#: seeds); more are dropped (``crossing_count`` says how many were found).
CROSSING_SLOTS = 32
#: Codes of ``bifurcation_kind`` and ``crossing_kind`` (0: empty slot).
BIFURCATION_KINDS = {"fold": 1, "flip": 2, "grazing": 3}
BIFURCATION_FLAGS = ((0, "empty"),) + tuple((c, k) for k, c in BIFURCATION_KINDS.items())
CHUNK_DIMS = ("omega_chunk", "sigma_chunk", "zeta_chunk")
#: Dims of the per-point variables (the attractor census, the orbit count).
POINT_DIMS = ("omega", "sigma", "zeta")
#: The dims sized by the data: a point's orbits and its census's attractors, each filled from
#: index 0 in its order (study.solve.point_state). A store's length along each is the most any
#: of its points holds; its chunks along them are SLOT_CHUNK long, so a block that holds more
#: writes more chunks (only there: a missing chunk reads as empty) and the store grows by
#: whole chunks (scheduler.store), never by rewriting one.
SLOT_DIMS = ("solution", "attractor")
SLOT_CHUNK = 4


#: Leading dims of a variable by its layout: one value per orbit (slot), per census attractor,
#: per grid point, or per (omega block, sigma, zeta) line.
LAYOUTS = {"slot": GRID_DIMS, "attractor": POINT_DIMS + ("attractor",), "point": POINT_DIMS,
           "line": BLOCK_DIMS}
#: The slot dim of each layout that has one.
LAYOUT_SLOT_DIM = {"slot": "solution", "attractor": "attractor"}


def slot_counts(solution: int = SLOT_CHUNK, attractor: int = SLOT_CHUNK) -> dict[str, int]:
    """The lengths of the SLOT_DIMS of a block or store (at least 1 each)."""
    return {"solution": max(1, int(solution)), "attractor": max(1, int(attractor))}


def chunked_length(count: int) -> int:
    """The slots a block allocates for ``count`` entries: whole chunks of SLOT_CHUNK, at least
    one chunk (an empty point still has its slot 0 to say so)."""
    return max(1, -(-int(count) // SLOT_CHUNK)) * SLOT_CHUNK


@dataclass(frozen=True)
class VarSpec:
    name: str
    dtype: str
    fill: Any                  # value of an empty slot (and the zarr fill_value)
    long_name: str
    units: str
    description: str
    extra: tuple[tuple[str, int], ...] = ()     # trailing dims (name, length)
    flags: tuple[tuple[int, str], ...] | None = None
    layout: str = "slot"       # a key of LAYOUTS

    @property
    def per_block(self) -> bool:
        return self.layout == "line"

    @property
    def dims(self) -> tuple[str, ...]:
        return LAYOUTS[self.layout] + tuple(d for d, _ in self.extra)

    @property
    def trailing(self) -> tuple[int, ...]:
        return tuple(n for _, n in self.extra)

    @property
    def slot_dim(self) -> str | None:
        """The dim of SLOT_DIMS this variable has (None: a per-point or per-line variable)."""
        return LAYOUT_SLOT_DIM.get(self.layout)

    def block_shape(self, shape: tuple[int, int, int],
                    slots: Mapping[str, int] | None = None) -> tuple[int, ...]:
        """Shape of the variable in one block of ``shape`` = (omega, sigma, zeta) points (a
        line variable: one omega block), with ``slots`` (slot_counts) along the SLOT_DIMS."""
        slots = slot_counts() if slots is None else slots
        lead = {"line": (1,) + tuple(shape[1:]), "point": tuple(shape)}.get(self.layout)
        if lead is None:
            lead = tuple(shape) + (int(slots[self.slot_dim]),)
        return lead + self.trailing

    def attrs(self) -> dict[str, Any]:
        a: dict[str, Any] = {"long_name": self.long_name, "units": self.units,
                             "description": self.description}
        if self.flags:
            a["flag_values"] = np.array([v for v, _ in self.flags], dtype=self.dtype)
            a["flag_meanings"] = " ".join(m for _, m in self.flags)
        return a


VARIABLES: dict[str, VarSpec] = {v.name: v for v in [
    # -- the orbits (kernels.records.ORBIT) -------------------------------------------------
    *(VarSpec(f.name, f.dtype, f.fill, f.long_name, f.units, f.description,
              extra=(f.dim,) if f.dim else (), flags=f.flags) for f in ORBIT.stored()),
    # -- bifurcations (per omega block and (sigma, zeta) line) ---------------------------------
    VarSpec("bifurcation_omega", "float64", math.nan, "omega of a located bifurcation point", "1",
            "excitation frequency of a fold, flip or grazing point located on a branch along the "
            "omega line (sigma, zeta), within the omega range of the block; refined to a zero of "
            "the test function (|g| ~ 1e-14) by kernels.continuation; ordered by omega; NaN: "
            "empty slot", extra=(("bifurcation", BIFURCATION_SLOTS),), layout="line"),
    VarSpec("bifurcation_kind", "int8", 0, "kind of the located bifurcation point", "1",
            "1 fold (a multiplier +1: zero of 1 - tr M + det M), 2 flip (a multiplier -1: zero "
            "of 1 + tr M + det M), 3 grazing (onset of contact loss: zero of min q + n), "
            "0 empty slot", extra=(("bifurcation", BIFURCATION_SLOTS),),
            flags=BIFURCATION_FLAGS, layout="line"),
    VarSpec("bifurcation_period", "int8", 0, "period of the orbit at the point", "1",
            "period of the branch the point lies on, in forcing periods (1: 1T, 2: 2T; 0 empty)",
            extra=(("bifurcation", BIFURCATION_SLOTS),),
            flags=PERIOD_FLAGS, layout="line"),
    VarSpec("bifurcation_q0", "float64", math.nan, "displacement at tau = 0 at the point", "1",
            "start point q(0) of the periodic orbit at the located point",
            extra=(("bifurcation", BIFURCATION_SLOTS),), layout="line"),
    VarSpec("bifurcation_v0", "float64", math.nan, "velocity at tau = 0 at the point", "1",
            "start point dq/dtau(0) of the periodic orbit at the located point",
            extra=(("bifurcation", BIFURCATION_SLOTS),), layout="line"),
    VarSpec("bifurcation_count", "int16", -1, "number of located bifurcation points", "1",
            "points located along the line in the block's omega range; more than the "
            f"{BIFURCATION_SLOTS} slots means the extra ones (highest omega) were dropped; "
            "-1: not located (block not computed, or its time budget ran out)", layout="line"),
    # -- crossings (per omega block and (sigma, zeta) line): the traced curves' seeds ----------
    VarSpec("crossing_omega", "float64", math.nan, "omega of a test function's sign change", "1",
            "estimated omega where a fold, flip or grazing curve crosses the omega line (sigma, "
            "zeta) between two neighbouring grid points of the block: the test function "
            "interpolated linearly between the two matched orbits (flip, grazing), the midpoint "
            "where a branch ends in a fold; the seed of a traced curve (study.solve.curve_seeds); "
            "ordered by omega; NaN: empty slot", extra=(("crossing", CROSSING_SLOTS),),
            layout="line"),
    VarSpec("crossing_kind", "int8", 0, "kind of the test function's sign change", "1",
            "1 fold (a branch ends: both halves of a fold, or a census orbit with a multiplier "
            "near +1), 2 flip (1 + tr M + det M changes sign), 3 grazing (min q + n changes "
            "sign), 0 empty slot", extra=(("crossing", CROSSING_SLOTS),),
            flags=BIFURCATION_FLAGS, layout="line"),
    VarSpec("crossing_period", "int8", 0, "period of the orbits at the sign change", "1",
            "in forcing periods", extra=(("crossing", CROSSING_SLOTS),), flags=PERIOD_FLAGS,
            layout="line"),
    VarSpec("crossing_q0", "float64", math.nan, "displacement at tau = 0 of the nearer orbit", "1",
            "start point q(0) of the orbit at the grid point nearer the crossing (for a fold of "
            "1T orbits: the mean of its two halves)", extra=(("crossing", CROSSING_SLOTS),),
            layout="line"),
    VarSpec("crossing_v0", "float64", math.nan, "velocity at tau = 0 of the nearer orbit", "1",
            "start point dq/dtau(0), as crossing_q0", extra=(("crossing", CROSSING_SLOTS),),
            layout="line"),
    VarSpec("crossing_min_q", "float64", math.nan, "minimum displacement at the crossing", "1",
            "min q of the orbits interpolated to the crossing (a fold: the mean of its halves)",
            extra=(("crossing", CROSSING_SLOTS),), layout="line"),
    VarSpec("crossing_max_q", "float64", math.nan, "maximum displacement at the crossing", "1",
            "max q, as crossing_min_q", extra=(("crossing", CROSSING_SLOTS),), layout="line"),
    VarSpec("crossing_spread", "float64", math.nan, "spread of the invariants at the crossing",
            "1", "|d min q| + |d max q| between the two orbits the crossing lies between (a "
            "fold: its two halves): how well crossing_min_q and crossing_max_q are known",
            extra=(("crossing", CROSSING_SLOTS),), layout="line"),
    VarSpec("crossing_count", "int16", -1, "number of test function sign changes", "1",
            "sign changes found along the line in the block's omega range; more than the "
            f"{CROSSING_SLOTS} slots means the extra ones (highest omega) were dropped; -1: not "
            "recorded (block not computed, or its time budget ran out)", layout="line"),
    # -- the orbit count (always stored) --------------------------------------------------------
    VarSpec("orbits_found", "int16", -1, "distinct periodic orbits found at the point", "1",
            "distinct converged orbits (all periods searched, stable or not) the solver found at "
            "the point, every one stored in its solution slots; -1: point not computed",
            layout="point"),
    # -- the attractor census (per point and attractor slot) ---------------------------------------
    VarSpec("attractor_count", "int16", -1, "attractors found by the census", "1",
            "distinct long-time responses reached by the transients from the study's initial "
            "states (search.initial_states); -1: the census did not run at this point "
            "(search.attractors = where-none-stable and a stable orbit was found, or not "
            "computed)", layout="point"),
    VarSpec("basin_entropy", "float64", math.nan, "basin entropy of the census's states",
            "nats", "S_b (Daza et al., Sci. Rep. 6, 31416, 2016): the box of initial states "
            "(the census's Halton points in study.solve.seeds.TRANSIENT_BOX: all of "
            "search.initial_states, or half where a reach box takes the others) cut into "
            "cells of about 4 states, each cell's Gibbs entropy -sum_i p_i log p_i over the "
            "share p_i of its states ending on attractor i (every attractor the census tells "
            "apart, unsettled and failed included), averaged over the cells holding 2 states or "
            "more; 0: one attractor; at most log(attractor_count). Coarse: from 16 states (the "
            "default) it tells a point with mixed basins from one without, not a basin's "
            "geometry (hertzmap basins maps that); NaN: the census did not run",
            layout="point"),
    VarSpec("boundary_basin_entropy", "float64", math.nan,
            "boundary basin entropy of the census's states", "nats",
            "S_bb: the mean of the same cells' entropies over the cells that hold more than one "
            "attractor (0 where none does); S_bb > log 2 is a sufficient condition for a "
            "fractal basin boundary (Daza et al. 2016), as coarse as basin_entropy; NaN: the "
            "census did not run", layout="point"),
    *(VarSpec(f.name, f.dtype, f.fill, f.long_name, f.units, f.description,
              extra=(f.dim,) if f.dim else (), flags=f.flags, layout="attractor")
      for f in ATTRACTOR.stored()),
]}

#: Per-slot variables of an orbit (dims GRID_DIMS + extra), in schema order.
ORBIT_VARIABLES: tuple[str, ...] = tuple(n for n, v in VARIABLES.items() if v.layout == "slot")
#: Per-line variables (dims BLOCK_DIMS + extra): the located bifurcation points and the
#: crossings.
LINE_VARIABLES: tuple[str, ...] = tuple(n for n, v in VARIABLES.items() if v.layout == "line")
#: The located bifurcation points (``locate=True``).
BIFURCATION_VARIABLES: tuple[str, ...] = tuple(n for n in LINE_VARIABLES
                                               if n.startswith("bifurcation_"))
#: The crossings (``crossings=True``): the traced curves' seeds along each line.
CROSSING_VARIABLES: tuple[str, ...] = tuple(n for n in LINE_VARIABLES
                                            if n.startswith("crossing_"))
#: Per-point variables of the attractor census (dims POINT_DIMS + extra).
ATTRACTOR_VARIABLES: tuple[str, ...] = tuple(
    n for n, v in VARIABLES.items() if v.layout == "attractor"
    or (v.layout == "point" and not n.startswith("orbits_")))


def empty_arrays(shape: tuple[int, int, int], slots: Mapping[str, int] | None = None,
                 names: tuple[str, ...] | None = None) -> dict[str, np.ndarray]:
    """The arrays of one block (``shape`` = (len(omega), len(sigma), len(zeta))) with every slot
    empty: each variable at its fill value and dtype, ``slots`` (slot_counts; default one
    chunk each) along the SLOT_DIMS. Per-line variables get leading dims (1, len(sigma),
    len(zeta)). ``names``: a subset (default: every variable)."""
    out = {}
    for name in (tuple(VARIABLES) if names is None else names):
        v = VARIABLES[name]
        out[name] = np.full(v.block_shape(shape, slots), v.fill, dtype=v.dtype)
    return out


def array_slots(arrays: Mapping[str, np.ndarray]) -> dict[str, int]:
    """The lengths of the SLOT_DIMS of a block's (or a region's) arrays (slot_counts: a dim no
    array has gets its default)."""
    found = {}
    for name, a in arrays.items():
        v = VARIABLES.get(name)
        if v is not None and v.slot_dim is not None:
            found.setdefault(v.slot_dim, np.shape(a)[3])
    return slot_counts(**found)


OUTPUT_VARIABLES: dict[str, tuple[str, ...]] = {
    "orbits": tuple(f.name for f in ORBIT.stored("orbits")) + ("orbits_found",),
    "measures": tuple(f.name for f in ORBIT.stored("measures")),
    "force_harmonics": tuple(f.name for f in ORBIT.stored("force_harmonics")),
    "diagnostics": tuple(f.name for f in ORBIT.stored("diagnostics")),
    "bifurcations": BIFURCATION_VARIABLES,
    "attractors": ATTRACTOR_VARIABLES,
    # traced curves: a products group written by the run (study.products.traced_curves),
    # seeded by the crossings along the lines and the stored orbits' measures
    "curves": CROSSING_VARIABLES,
    # the thresholds in zeta: a products group written by the run (products/thresholds)
    "thresholds": (),
    # stepped-sine sweeps along the lines: a products group written by the run
    # (products/sweeps, study.products.stepped_sweeps)
    "sweeps": (),
}

_COORD_ATTRS = {
    "omega": {"long_name": "excitation frequency", "units": "1",
              "description": "forcing frequency divided by the linearised natural frequency "
                             "of the preloaded contact (dimensionless time tau = Omega t)"},
    "sigma": {"long_name": "excitation amplitude", "units": "1",
              "description": "amplitude of the harmonic force divided by the static preload"},
    "zeta": {"long_name": "damping ratio", "units": "1",
             "description": "viscous damping ratio (q'' + 2 zeta q' + F(q) = 1 + sigma cos(omega tau))"},
    "solution": {"long_name": "solution slot", "units": "1",
                 "description": "index of a coexisting periodic solution at a grid point: every "
                                "orbit found there, in the order (period, ptp) (slot 0: the 1T "
                                "orbit of smallest ptp, or why its solve failed); filled from "
                                "0, empty slots have status -1; as long as the most orbits any "
                                "point holds"},
    "multiplier": {"long_name": "Floquet multiplier index", "units": "1",
                   "description": "index of the multiplier (order as returned by the block solver)"},
    "harmonic": {"long_name": "harmonic order", "units": "1",
                 "description": "k: the component at frequency k omega / period"},
    "attractor": {"long_name": "attractor slot", "units": "1",
                  "description": "index of a distinct long-time response found by the attractor "
                                 "census at a grid point: every one it found, largest basin "
                                 "first; empty slots have attractor_kind 0; as long as the most "
                                 "attractors any point has"},
    "strobe": {"long_name": "stroboscopic point index", "units": "1",
               "description": "k-th of the last stroboscopic points (tau = 0 mod T) of an "
                              "attractor's window, in time order"},
    "bifurcation": {"long_name": "bifurcation point slot", "units": "1",
                    "description": "index of a located bifurcation point along the line "
                                   "(ordered by omega); empty slots have bifurcation_kind 0"},
    "crossing": {"long_name": "crossing slot", "units": "1",
                 "description": "index of a test function's sign change along the line "
                                "(ordered by omega); empty slots have crossing_kind 0"},
}

_TASK_DONE_ATTRS = {
    "long_name": "task completed",
    "units": "1",
    "description": "True once the block of chunk (omega_chunk, sigma_chunk, zeta_chunk) is "
                   "written; a block without this flag is not computed, whatever the chunk files say",
}


def stored_variables(study: Study) -> tuple[str, ...]:
    """Names of the data variables stored for this study (its outputs), in schema order."""
    wanted = {n for p in study.outputs for n in OUTPUT_VARIABLES[p]}
    return tuple(n for n in VARIABLES if n in wanted)


def bytes_per_point(study: Study) -> int:
    """Uncompressed bytes stored per grid point, at one chunk (SLOT_CHUNK) of orbits and of
    attractors per point (a point that holds more stores more)."""
    total = 0.0
    for name in stored_variables(study):
        v = VARIABLES[name]
        # a per-block variable: one line per (sigma, zeta), spread over the line's omega points;
        # the slot dims at one chunk (the common case: more where points hold more)
        n = {"point": 1.0, "line": 1.0 / len(study.omega)}.get(v.layout, SLOT_CHUNK) \
            * math.prod(v.trailing)
        total += n * np.dtype(v.dtype).itemsize
    return int(math.ceil(total))


def chunk_counts(shape: tuple[int, ...], chunks: tuple[int, ...]) -> tuple[int, ...]:
    """Number of chunks along each grid axis."""
    return tuple(-(-n // c) for n, c in zip(shape, chunks))


def chunk_slices(shape: tuple[int, ...], chunks: tuple[int, ...],
                 index: tuple[int, ...]) -> tuple[slice, ...]:
    """Grid slices (omega, sigma, zeta) covered by the chunk at ``index``."""
    return tuple(slice(i * c, min((i + 1) * c, n)) for n, c, i in zip(shape, chunks, index))


def _hertzmap_version() -> str:
    try:
        return importlib.metadata.version("hertzmap")
    except importlib.metadata.PackageNotFoundError:
        pyproject = Path(__file__).resolve().parent.parent / "pyproject.toml"
        try:
            return tomllib.loads(pyproject.read_text())["project"]["version"] + "+src"
        except (OSError, KeyError, tomllib.TOMLDecodeError):
            return "unknown"


def software_versions() -> dict[str, str]:
    """Versions of hertzmap and its numerical stack (read from metadata: imports nothing)."""
    out = {"hertzmap": _hertzmap_version()}
    for pkg in ("numpy", "numba", "scipy", "dask", "distributed", "zarr", "xarray"):
        try:
            out[pkg] = importlib.metadata.version(pkg)
        except importlib.metadata.PackageNotFoundError:
            out[pkg] = "not installed"
    return out


def code_fingerprint() -> str:
    """sha256 of the solver's source (kernels/*.py and study/*.py): a store resumed with other
    code may hold blocks computed by two versions of the solver."""
    import hashlib

    root = Path(__file__).resolve().parent.parent
    h = hashlib.sha256()
    for pkg in ("kernels", "study"):
        for f in sorted((root / pkg).rglob("*.py")):
            h.update(str(f.relative_to(root)).encode())
            h.update(f.read_bytes())
    return h.hexdigest()


def history_line(action: str) -> str:
    """One line of the ``history`` attr: UTC timestamp, hertzmap version, action."""
    now = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    return f"{now} hertzmap {_hertzmap_version()}: {action}"


def template(study: Study, chunks: tuple[int, int, int], *, history: str) -> xr.Dataset:
    """The empty dataset of a study, backed by zero-copy numpy broadcasts (no memory).

    ``chunks`` is the (omega, sigma, zeta) chunk shape of the store; each variable's
    ``encoding`` carries its zarr chunks, fill value and compressor. The scheduler chunks
    this with Dask and writes it with ``to_zarr(compute=False)``: only metadata, the
    coordinates and the (all False) ``task_done`` array are written.
    """
    if len(chunks) != 3 or any(int(c) < 1 for c in chunks):
        raise ValueError(f"chunks must be three integers >= 1, got {chunks!r}")
    chunks = tuple(min(int(c), n) for c, n in zip(chunks, study.shape))
    coords = {
        "omega": ("omega", study.axis("omega"), _COORD_ATTRS["omega"]),
        "sigma": ("sigma", study.axis("sigma"), _COORD_ATTRS["sigma"]),
        "zeta": ("zeta", study.axis("zeta"), _COORD_ATTRS["zeta"]),
    }
    data_vars: dict[str, xr.Variable] = {}
    encoding: dict[str, dict[str, Any]] = {}
    counts = chunk_counts(study.shape, chunks)
    for name in stored_variables(study):
        v = VARIABLES[name]
        if v.layout == "line":
            shape = (counts[0],) + study.shape[1:]
            vchunks = (1,) + chunks[1:]
        else:
            shape, vchunks = tuple(study.shape), tuple(chunks)
        if v.slot_dim is not None:
            # one chunk to start with: the scheduler grows the dim as blocks need more
            shape += (SLOT_CHUNK,)
            vchunks += (SLOT_CHUNK,)
            if v.slot_dim not in coords:
                coords[v.slot_dim] = (v.slot_dim, np.arange(SLOT_CHUNK, dtype=np.int16),
                                      _COORD_ATTRS[v.slot_dim])
        for dim, n in v.extra:
            shape += (n,)
            vchunks += (n,)
            if dim not in coords:
                start = 1 if dim == "harmonic" else 0
                coords[dim] = (dim, np.arange(start, start + n, dtype=np.int16), _COORD_ATTRS[dim])
        fill = np.array(v.fill, dtype=v.dtype)
        data_vars[name] = xr.Variable(v.dims, np.broadcast_to(fill, shape), v.attrs())
        encoding[name] = {"chunks": vchunks, "fill_value": fill.item()}
    data_vars["task_done"] = xr.Variable(CHUNK_DIMS, np.zeros(counts, dtype=bool), {
        **_TASK_DONE_ATTRS, "chunk_shape": list(chunks)})
    encoding["task_done"] = {"chunks": (1, 1, 1), "fill_value": False}

    versions = software_versions()
    attrs = {
        "title": f"hertzmap study {study.name}",
        "description": study.description,
        "hertzmap_store_format": STORE_FORMAT,
        "hertzmap_study_name": study.name,
        "hertzmap_study_hash": study.hash,
        "hertzmap_study_toml": study.source_text,
        "hertzmap_study_json": study.canonical_json(),
        "hertzmap_chunk_shape": list(chunks),
        "hertzmap_versions": json.dumps(versions, sort_keys=True),
        "hertzmap_code_hash": code_fingerprint(),
        "model": study.model,
        "exponent": study.exponent if study.exponent is not None else "none",
        "rtol": study.rtol,
        "history": history,
    }
    ds = xr.Dataset(data_vars, coords={k: xr.Variable(*c) for k, c in coords.items()}, attrs=attrs)
    for name, enc in encoding.items():
        ds[name].encoding.update(enc)
    for name in coords:
        ds[name].encoding.update({"chunks": (SLOT_CHUNK if name in SLOT_DIMS else len(ds[name]),)})
    return ds


def check_block(arrays: Mapping[str, np.ndarray], names: tuple[str, ...],
                shape: tuple[int, int, int]) -> None:
    """Check a ``solve_block`` result against the contract (every variable of ``names``, its
    dtype, its shape, one length along each of the SLOT_DIMS); raise ValueError naming the
    problem."""
    missing = [n for n in names if n not in arrays]
    if missing:
        raise ValueError(f"solve_block result lacks variable {missing[0]!r}")
    slots = array_slots({n: arrays[n] for n in names})
    for name in names:
        v = VARIABLES[name]
        a = np.asarray(arrays[name])
        want = v.block_shape(shape, slots)
        if a.shape != want:
            raise ValueError(f"solve_block variable {name!r} has shape {a.shape}, expected {want}")
        if not np.can_cast(a.dtype, np.dtype(v.dtype), casting="same_kind"):
            raise ValueError(f"solve_block variable {name!r} has dtype {a.dtype}, expected {v.dtype}")


def pad_slots(arrays: Mapping[str, np.ndarray], slots: Mapping[str, int]) -> dict[str, np.ndarray]:
    """The arrays with each slot dim filled up to ``slots`` (its entries beyond the array's
    at the variable's fill value): whole SLOT_CHUNK chunks, or a store's length."""
    out = {}
    for name, a in arrays.items():
        v = VARIABLES.get(name)
        a = np.asarray(a)
        if v is None or v.slot_dim is None or a.shape[3] >= slots[v.slot_dim]:
            out[name] = a
            continue
        full = np.full(a.shape[:3] + (int(slots[v.slot_dim]),) + a.shape[4:], v.fill, a.dtype)
        full[:, :, :, :a.shape[3]] = a
        out[name] = full
    return out


def block_dataset(arrays: Mapping[str, np.ndarray], names: tuple[str, ...]) -> xr.Dataset:
    """A dataset holding one solved block, without coordinates (for a region write)."""
    data_vars = {}
    for name in names:
        v = VARIABLES[name]
        data_vars[name] = xr.Variable(v.dims, np.asarray(arrays[name]).astype(v.dtype, copy=False))
    return xr.Dataset(data_vars)


def study_from_attrs(attrs: Mapping[str, Any]) -> Study:
    """The study a store holds, parsed back from its attrs (the TOML text it was created from)
    and checked against the recorded hash. Raises StudyError when the attrs hold no study or
    one that does not match its hash (edited attrs, or written by another version)."""
    text = attrs.get("hertzmap_study_toml")
    if not text:
        raise StudyError("store", "the store's attrs hold no study (not written by hertzmap run)")
    study = parse_study(text, default_name=attrs.get("hertzmap_study_name") or "study")
    recorded = attrs.get("hertzmap_study_hash")
    if recorded is not None and study.hash != recorded:
        raise StudyError("store", "the recorded study does not match its hash "
                         "(attrs edited or written by another version)")
    return study


def parse_attrs(attrs: Mapping[str, Any]) -> dict[str, Any]:
    """The hertzmap attrs of a store, decoded (versions as a dict)."""
    out = {k: attrs.get(k) for k in ("hertzmap_store_format", "hertzmap_study_name",
                                     "hertzmap_study_hash", "hertzmap_chunk_shape",
                                     "hertzmap_code_hash", "history")}
    try:
        out["versions"] = json.loads(attrs.get("hertzmap_versions", "{}"))
    except (TypeError, ValueError):
        out["versions"] = {}
    return out


class StoreFormatError(ValueError):
    """A store written in another layout than this version reads (check_format)."""


def check_format(attrs: Mapping[str, Any], where: str = "the store") -> None:
    """Raise StoreFormatError, naming the store's format and what to do, unless ``attrs`` (a
    store's root attrs) say it is in STORE_FORMAT: a store of another layout is refused, never
    misread."""
    found = attrs.get("hertzmap_store_format")
    if found == STORE_FORMAT:
        return
    advice = FORMAT_ADVICE.get(found, "written by another version of hertzmap: rerun its study "
                                      "with `hertzmap run STUDY --overwrite`")
    raise StoreFormatError(f"{where} is in store format {found}, this hertzmap reads format "
                           f"{STORE_FORMAT}: {advice}")
