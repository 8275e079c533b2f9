"""study.identify.measurement: a lab's measured sweeps read from a CSV or an xarray Dataset, and
every bad input refused with its row, line and column named."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
import xarray as xr

from hertzmap.study.identify.measurement import (CHANNELS, FitInputError, measurement_from_columns,
                                                 measurement_from_dataset, read_measurement)

GOOD = """\
# a comment before the header
frequency_hz,direction,H1_N,H2_N,H1_2_N,H1_phase_deg
500.0,up,8.5,0.13,0.02,-12.5
510.0,up,8.1,0.12,,-14.0
# a comment between rows
520.0,up,7.9,0.11,0.03,-15.5
520.0,down,7.8,0.10,40.0,
510.0,down,9.0,0.2,60.0,
500.0,down,10.1,0.3,70.0,
"""


def write(tmp_path, text, name="m.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_a_csv_is_read_in_its_order_with_its_rows_lines_and_empty_optional_cells(tmp_path):
    m = read_measurement(write(tmp_path, GOOD))
    assert m.size == 6 and m.directions == ("up", "down") and m.channels == CHANNELS
    assert np.array_equal(m.frequency, [500, 510, 520, 520, 510, 500])
    assert np.array_equal(m.direction, [0, 0, 0, 1, 1, 1])
    assert np.array_equal(m.row, [1, 2, 3, 4, 5, 6])
    assert np.array_equal(m.line, [3, 4, 6, 7, 8, 9])          # comment lines counted
    assert m.amplitude[0].tolist() == [8.5, 0.13, 0.02]
    assert np.isnan(m.amplitude[1, 2]) and m.amplitude[3, 2] == 40.0   # empty: not measured
    assert m.phase[0, 0] == -12.5 and np.isnan(m.phase[3, 0]) and np.all(np.isnan(m.phase[:, 1:]))


def test_semicolons_tabs_a_bom_and_upper_case_directions_are_read(tmp_path):
    text = GOOD.replace(",", ";").replace("up", "Up").replace("down", " DOWN ")
    m = read_measurement(write(tmp_path, "\ufeff" + text))
    assert m.size == 6 and np.array_equal(m.direction, [0, 0, 0, 1, 1, 1])
    m = read_measurement(write(tmp_path, GOOD.replace(",", "\t"), "m.tsv"))
    assert m.amplitude[5, 2] == 70.0


def test_a_dataset_with_the_same_variables_reads_the_same(tmp_path):
    m = read_measurement(write(tmp_path, GOOD))
    ds = xr.Dataset({"frequency_hz": ("step", m.frequency),
                     "direction": ("step", np.array(["up"] * 3 + ["down"] * 3)),
                     "H1_N": ("step", m.amplitude[:, 0]), "H2_N": ("step", m.amplitude[:, 1]),
                     "H1_2_N": ("step", m.amplitude[:, 2])})
    d = measurement_from_dataset(ds)
    assert np.array_equal(d.frequency, m.frequency) and np.array_equal(d.direction, m.direction)
    assert np.array_equal(d.amplitude, m.amplitude, equal_nan=True)
    ds.to_netcdf(tmp_path / "m.nc", engine="scipy")
    assert np.array_equal(read_measurement(tmp_path / "m.nc").amplitude, m.amplitude,
                          equal_nan=True)
    with warnings.catch_warnings():     # zarr's own, on writing a string variable
        warnings.simplefilter("ignore")
        ds.to_zarr(tmp_path / "m.zarr")
    z = read_measurement(tmp_path / "m.zarr")
    assert np.array_equal(z.amplitude, m.amplitude, equal_nan=True) and z.directions == (
        "up", "down")
    bad = ds.assign(H2_N=("other", m.amplitude[:, 1]))
    with pytest.raises(FitInputError, match="one and the same dimension"):
        measurement_from_dataset(bad)
    with pytest.raises(FitInputError, match="row 2, column H1_N: -1.0 N is negative"):
        measurement_from_dataset(ds.assign(H1_N=("step", [1.0, -1.0, 1, 1, 1, 1])))


@pytest.mark.parametrize("edit, row, line, column, message", [
    # a missing column, named in the header's line
    (lambda t: t.replace(",H2_N", "").replace(",0.13", "").replace(",0.12", "")
     .replace(",0.11", "").replace(",0.10", "").replace(",0.2,", ",").replace(",0.3,", ","),
     None, 2, "H2_N", "missing; the columns are"),
    (lambda t: t.replace("H1_2_N", "H1_2N"), None, 2, "'H1_2N'", "unknown column"),
    (lambda t: t.replace("510.0,up,8.1", "510.0,up,abc"), 2, 4, "H1_N", "'abc' is not a number"),
    (lambda t: t.replace("510.0,up,8.1", "510.0,up,"), 2, 4, "H1_N", "empty"),
    (lambda t: t.replace("520.0,down", "520.0,sideways"), 4, 7, "direction",
     "'sideways' is not a direction; give up or down"),
    (lambda t: t.replace("520.0,up", "505.0,up"), 3, 6, "frequency_hz",
     "505.0 Hz does not increase from 510.0 Hz at row 2"),
    (lambda t: t.replace("500.0,down", "515.0,down"), 6, 9, "frequency_hz",
     "does not decrease from 510.0 Hz at row 5"),
    (lambda t: t.replace("0.2,60.0", "-0.2,60.0"), 5, 8, "H2_N", "-0.2 N is negative"),
    (lambda t: t.replace("0.03,-15.5", "inf,-15.5"), 3, 6, "H1_2_N", "inf is not a finite"),
    (lambda t: t.replace("500.0,up", "-500.0,up"), 1, 3, "frequency_hz", "must be > 0"),
    (lambda t: t.replace("510.0,up,8.1,0.12,,-14.0", "510.0,up,8.1"), 2, 4, None,
     "3 fields where the header has 6"),
])
def test_each_bad_input_names_its_row_line_and_column(tmp_path, edit, row, line, column,
                                                      message):
    p = write(tmp_path, edit(GOOD))
    with pytest.raises(FitInputError) as exc:
        read_measurement(p)
    e = exc.value
    assert (e.row, e.line, e.column) == (row, line, column)
    assert message in str(e) and str(e).startswith(str(p))
    where = (f"row {row} (line {line})" if row is not None else f"line {line}")
    assert where in str(e)


def test_a_sweep_needs_three_steps_and_files_must_exist(tmp_path):
    with pytest.raises(FitInputError, match="the down sweep has 1 row; a sweep needs at least 3"):
        measurement_from_columns({"frequency_hz": [1.0, 2, 3, 4], "direction": ["up"] * 3 +
                                  ["down"], "H1_N": [1.0] * 4, "H2_N": [1.0] * 4})
    with pytest.raises(FitInputError, match="no such file"):
        read_measurement(tmp_path / "nope.csv")
    with pytest.raises(FitInputError, match="no data rows"):
        read_measurement(write(tmp_path, "frequency_hz,direction,H1_N,H2_N\n# none\n"))
