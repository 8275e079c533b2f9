"""The measured sweeps a fit starts from, as a lab exports them, read and validated.

A measurement is one or two stepped-sine sweeps of the rig's excitation frequency, up and
down, each step's reading the amplitudes (peak values, N) of the force transmitted through the
contact at the excitation frequency (H1), at twice it (H2) and, optionally, at half of it
(H1/2, the order-2 subharmonic; paper Figs. 12-13). As a CSV file (``#`` comment lines
anywhere; a header line naming the columns; comma-, semicolon- or tab-separated)::

    # rig of paper section 4, sigma about 0.3
    frequency_hz,direction,H1_N,H2_N,H1_2_N
    200.0,up,86.1,12.3,0.02
    ...

or as an xarray Dataset (netCDF or zarr) with the same variables along one dimension. The rows
of a direction are in the order measured: an up sweep's frequencies increase row after row, a
down sweep's decrease (the rows of the two may be interleaved or one after the other).

Every error (:class:`FitInputError`) names the file, the row (1-based among the data rows, and
the file's line for a CSV) and the column, and what is allowed; nothing is computed or written
after one.
"""
from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np

__all__ = ["CHANNELS", "COLUMNS", "DIRECTIONS", "FitInputError", "Measurement",
           "MIN_STEPS", "measurement_from_columns", "measurement_from_dataset",
           "read_measurement"]

#: the harmonics of the transmitted force a fit compares, in the forward model's order
#: (study.solve.sweep.force_components): at omega, 2 omega and omega / 2
CHANNELS = ("H1", "H2", "H1_2")
#: the sweep directions (as study.solve.sweep.DIRECTIONS), their codes 0 and 1
DIRECTIONS = ("up", "down")
#: the fewest steps a measured direction may have
MIN_STEPS = 3

#: the columns of a measurement, declared once: name -> (long_name, units, required, channel);
#: channel: the index in CHANNELS of an amplitude, or of the harmonic a phase belongs to
COLUMNS: dict[str, tuple[str, str, bool, int | None]] = {
    "frequency_hz": ("excitation frequency", "Hz", True, None),
    "direction": ("sweep direction", "1", True, None),
    "H1_N": ("transmitted force harmonic H1 (at the excitation frequency), measured", "N",
             True, 0),
    "H2_N": ("transmitted force harmonic H2 (at twice the excitation frequency), measured",
             "N", True, 1),
    "H1_2_N": ("transmitted force subharmonic H1/2 (at half the excitation frequency), "
               "measured", "N", False, 2),
    "H1_phase_deg": ("phase of H1, measured (carried, not fitted)", "degree", False, 0),
    "H2_phase_deg": ("phase of H2, measured (carried, not fitted)", "degree", False, 1),
    "H1_2_phase_deg": ("phase of H1/2, measured (carried, not fitted)", "degree", False, 2),
}
_AMPLITUDES = ("H1_N", "H2_N", "H1_2_N")
_PHASES = ("H1_phase_deg", "H2_phase_deg", "H1_2_phase_deg")


class FitInputError(ValueError):
    """A fit's input is invalid (a measurement, a rig table, an option). The message names
    the source, the row and column (a measurement) or the field (a rig table), and what is
    allowed. The command line exits with code 2 on it, having written nothing."""

    def __init__(self, message: str, *, source: str | None = None, row: int | None = None,
                 line: int | None = None, column: str | None = None, field: str | None = None):
        self.source, self.row, self.line, self.column, self.field = (source, row, line, column,
                                                                     field)
        where = []
        if row is not None:
            where.append(f"row {row}" + (f" (line {line})" if line is not None else ""))
        elif line is not None:
            where.append(f"line {line}")
        if column is not None:
            where.append(f"column {column}")
        if field is not None:
            where.append(field)
        head = ", ".join(where)
        text = f"{head}: {message}" if head else message
        super().__init__(f"{source}: {text}" if source else text)


@dataclass(frozen=True)
class Measurement:
    """Measured stepped-sine sweeps (module docstring), validated.

    frequency: (n,) Hz; direction: (n,) 0 up, 1 down; amplitude: (n, 3) N, the peak values of
    the transmitted force's harmonics CHANNELS (H1, H2, H1/2; NaN where not measured: a
    missing H1_2_N column, an empty or NaN cell of it); phase: (n, 3) degrees (NaN where not given;
    carried into the fit's result, not fitted). row: (n,) the 1-based data row; line: (n,) the
    CSV line (0 for a Dataset). source: the file or "<dataset>". The rows are kept in the
    order given.
    """

    frequency: np.ndarray
    direction: np.ndarray
    amplitude: np.ndarray
    phase: np.ndarray
    row: np.ndarray
    line: np.ndarray
    source: str

    @property
    def size(self) -> int:
        return int(self.frequency.size)

    @property
    def directions(self) -> tuple[str, ...]:
        """The directions measured, in DIRECTIONS order."""
        return tuple(d for i, d in enumerate(DIRECTIONS) if np.any(self.direction == i))

    @property
    def channels(self) -> tuple[str, ...]:
        """The harmonics measured (at least at one row)."""
        return tuple(c for k, c in enumerate(CHANNELS) if np.any(np.isfinite(self.amplitude[:, k])))

    def where(self, i: int, column: str) -> dict[str, Any]:
        """The keywords of a FitInputError about row index ``i`` and ``column``."""
        return {"source": self.source, "row": int(self.row[i]),
                "line": int(self.line[i]) or None, "column": column}


# ---- reading ----------------------------------------------------------------------------------

def read_measurement(path: str | Path) -> Measurement:
    """A measurement from a file: a CSV (``.csv``, ``.txt``, ``.tsv``), a netCDF file (``.nc``)
    or a zarr store (a folder, or ``.zarr``) holding an xarray Dataset. Raises
    :class:`FitInputError`."""
    p = Path(path)
    if not p.exists():
        raise FitInputError("no such file or folder", source=str(p))
    if p.is_dir() or p.suffix == ".zarr":
        import xarray as xr
        try:
            ds = xr.open_zarr(str(p))
        except Exception as exc:        # noqa: BLE001 (any reader failure is a bad input)
            raise FitInputError(f"cannot read as a zarr store of an xarray Dataset "
                                f"({type(exc).__name__}: {exc})", source=str(p)) from None
        return measurement_from_dataset(ds, source=str(p))
    if p.suffix == ".nc":
        import xarray as xr
        try:
            ds = xr.load_dataset(str(p))
        except Exception as exc:        # noqa: BLE001
            raise FitInputError(f"cannot read as a netCDF file of an xarray Dataset "
                                f"({type(exc).__name__}: {exc})", source=str(p)) from None
        return measurement_from_dataset(ds, source=str(p))
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise FitInputError(f"cannot read: {exc.strerror or exc}", source=str(p)) from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise FitInputError("not UTF-8 text (a CSV file is expected; .nc or a zarr folder "
                            "for a Dataset)", source=str(p)) from None
    return _from_csv_text(text, str(p))


def _from_csv_text(text: str, source: str) -> Measurement:
    lines = [(k + 1, s) for k, s in enumerate(io.StringIO(text).read().splitlines())
             if s.strip() and not s.lstrip().startswith("#")]
    if not lines:
        raise FitInputError("no header line and no data: a CSV with the columns "
                            f"{_columns_text()} is expected", source=source)
    header_line, header = lines[0]
    delimiter = _delimiter(header)
    names = [h.strip() for h in next(csv.reader([header], delimiter=delimiter))]
    _check_header(names, source, header_line)
    body = lines[1:]
    if not body:
        raise FitInputError("a header and no data rows", source=source, line=header_line)
    columns: dict[str, list[str]] = {name: [] for name in names}
    numbers, rows = [], []
    for r, (k, s) in enumerate(body, 1):
        cells = next(csv.reader([s], delimiter=delimiter))
        if len(cells) != len(names):
            raise FitInputError(f"{len(cells)} fields where the header has {len(names)} "
                                f"({', '.join(names)})", source=source, row=r, line=k)
        for name, cell in zip(names, cells):
            columns[name].append(cell.strip())
        numbers.append(k)
        rows.append(r)
    return measurement_from_columns(columns, source=source, rows=rows, lines=numbers)


def _delimiter(header: str) -> str:
    """The delimiter that splits the header into the most known column names."""
    best, count = ",", -1
    for d in (",", ";", "\t"):
        n = sum(h.strip() in COLUMNS for h in header.split(d))
        if n > count:
            best, count = d, n
    return best


def _columns_text() -> str:
    required = [c for c, (_, _, req, _) in COLUMNS.items() if req]
    optional = [c for c, (_, _, req, _) in COLUMNS.items() if not req]
    return f"{', '.join(required)} (required) and {', '.join(optional)} (optional)"


def _check_header(names: list[str], source: str, line: int | None) -> None:
    seen = set()
    for name in names:
        if name in seen:
            raise FitInputError("appears twice", source=source, line=line, column=name)
        seen.add(name)
        if name not in COLUMNS:
            raise FitInputError(f"unknown column; the columns are {_columns_text()}",
                                source=source, line=line, column=repr(name))
    for name, (_, _, required, _) in COLUMNS.items():
        if required and name not in seen:
            raise FitInputError(f"missing; the columns are {_columns_text()}", source=source,
                                line=line, column=name)


def measurement_from_dataset(ds, source: str = "<dataset>") -> Measurement:
    """A measurement from an xarray Dataset whose variables are the CSV's columns (COLUMNS),
    all along one dimension; ``direction`` as the strings "up" / "down". A row is the index
    along the dimension (1-based in the messages). Raises :class:`FitInputError`."""
    names = list(ds.data_vars) + [c for c in ds.coords if c in COLUMNS and c not in ds.data_vars]
    known = [n for n in names if n in COLUMNS]
    _check_header(known, source, None)
    dims = {ds[n].dims for n in known}
    if len(dims) != 1 or len(next(iter(dims))) != 1:
        raise FitInputError("the variables " + ", ".join(known) + " must all lie along one "
                            f"and the same dimension, got dims {sorted(map(str, dims))}",
                            source=source)
    columns: dict[str, list[Any]] = {}
    for n in known:
        values = np.asarray(ds[n].values)
        if values.dtype.kind in "SU" or values.dtype == object:
            columns[n] = [v.decode() if isinstance(v, bytes) else str(v) for v in values]
        else:
            columns[n] = list(values)
    size = len(columns["frequency_hz"])
    return measurement_from_columns(columns, source=source, rows=list(range(1, size + 1)),
                                    lines=[0] * size)


def measurement_from_columns(columns: Mapping[str, Any], *, source: str = "<columns>",
                             rows=None, lines=None) -> Measurement:
    """Validate columns (name -> a sequence of cells: strings as read from a CSV, or numbers)
    into a :class:`Measurement`. ``rows`` / ``lines``: each cell's row and file line for the
    messages (default 1, 2, ...). Raises :class:`FitInputError` at the first bad cell, in row
    order, then the sweeps' order and sizes."""
    names = list(columns)
    _check_header(names, source, None)
    size = len(columns["frequency_hz"])
    for name in names:
        if len(columns[name]) != size:
            raise FitInputError(f"{len(columns[name])} values where frequency_hz has {size}",
                                source=source, column=name)
    if size == 0:
        raise FitInputError("no data rows", source=source)
    rows = list(range(1, size + 1)) if rows is None else list(rows)
    lines = [0] * size if lines is None else list(lines)

    def err(i: int, column: str, message: str) -> FitInputError:
        return FitInputError(message, source=source, row=int(rows[i]),
                             line=int(lines[i]) or None, column=column)

    frequency = np.empty(size)
    direction = np.empty(size, np.int8)
    amplitude = np.full((size, len(CHANNELS)), np.nan)
    phase = np.full((size, len(CHANNELS)), np.nan)
    for i in range(size):
        for name in names:
            cell = columns[name][i]
            _, units, required, channel = COLUMNS[name]
            if name == "direction":
                text = str(cell).strip().lower()
                if text not in DIRECTIONS:
                    raise err(i, name, f"{str(cell)!r} is not a direction; give up or down")
                direction[i] = DIRECTIONS.index(text)
                continue
            value = _number(cell)
            if value is None:
                if required:
                    raise err(i, name, "empty; a number is required here" if _empty(cell)
                              else f"{str(cell)!r} is not a number")
                if not _empty(cell):
                    raise err(i, name, f"{str(cell)!r} is not a number (leave the cell "
                              "empty where not measured)")
                continue
            if math.isnan(value) and not required:
                continue                    # not measured at this row
            if not math.isfinite(value):
                raise err(i, name, f"{value!r} is not a finite number")
            if name == "frequency_hz":
                if value <= 0.0:
                    raise err(i, name, f"{value!r} Hz: a frequency must be > 0")
                frequency[i] = value
            elif name in _AMPLITUDES:
                if value < 0.0:
                    raise err(i, name, f"{value!r} N is negative: an amplitude is a peak "
                              "value >= 0")
                amplitude[i, channel] = value
            else:
                phase[i, channel] = value
    for d, name in enumerate(DIRECTIONS):
        idx = np.flatnonzero(direction == d)
        if idx.size and idx.size < MIN_STEPS:
            raise err(int(idx[0]), "direction", f"the {name} sweep has {idx.size} row"
                      f"{'s' if idx.size != 1 else ''}; a sweep needs at least {MIN_STEPS} "
                      "steps")
        sign = 1.0 if name == "up" else -1.0
        for a, b in zip(idx[:-1], idx[1:]):
            if not (frequency[b] - frequency[a]) * sign > 0.0:
                raise err(int(b), "frequency_hz", f"{float(frequency[b])!r} Hz does not "
                          f"{'increase' if name == 'up' else 'decrease'} from "
                          f"{float(frequency[a])!r} Hz at row {rows[a]}: the rows of "
                          f"{'an up' if name == 'up' else 'a down'} sweep are in the order "
                          f"measured, their frequencies "
                          f"{'increasing' if name == 'up' else 'decreasing'} strictly")
    return Measurement(frequency=frequency, direction=direction, amplitude=amplitude,
                       phase=phase, row=np.asarray(rows, int), line=np.asarray(lines, int),
                       source=source)


def _empty(cell: Any) -> bool:
    return cell is None or (isinstance(cell, str) and not cell.strip())


def _number(cell: Any) -> float | None:
    """The cell as a float; None when empty or not a number (a NaN float given as a number is
    returned as NaN: the caller says it is not finite)."""
    if _empty(cell):
        return None
    if isinstance(cell, (bool, np.bool_)):
        return None
    if isinstance(cell, (int, float, np.integer, np.floating)):
        return float(cell)
    try:
        return float(str(cell).strip())
    except ValueError:
        return None
