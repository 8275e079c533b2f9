"""study.schema: the template of a store (variables, dims, dtypes, fill values, attrs), the block
arrays, the study read back from a store's attrs."""
from __future__ import annotations

import json
import re

import numpy as np
import pytest

from hertzmap.kernels import status
from hertzmap.study import products as P
from hertzmap.study.orbit_rules import ORBIT_CLASSES
from hertzmap.study.schema import (BIFURCATION_KINDS, BIFURCATION_SLOTS, OUTPUT_VARIABLES,
                                   STORE_FORMAT, VARIABLES, StoreFormatError, bytes_per_point,
                                   check_block, check_format, empty_arrays, pad_slots,
                                   slot_counts, stored_variables, study_from_attrs, template)
from hertzmap.study.spec import StudyError, parse_study
from tests.helpers import ALL_OUTPUTS_STUDY, REPO, STORE_TEST_STUDY, placeholder_study


def test_template_schema_and_attrs():
    s = placeholder_study()
    ds = template(s, (17, 1, 1), history="h")
    names = stored_variables(s)
    # the census's variables come with every study whose search.attractors is not "never"
    assert s.attractors == "always"
    assert set(names) == set(OUTPUT_VARIABLES["orbits"] + OUTPUT_VARIABLES["measures"]
                             + OUTPUT_VARIABLES["force_harmonics"]
                             + OUTPUT_VARIABLES["attractors"])
    assert "residual" not in ds and "newton_iterations" not in ds
    assert set(ds.data_vars) == set(names) | {"task_done"}
    assert ds.sizes["omega"] == 17 and ds.sizes["solution"] == 4
    assert ds.multipliers.dims[-1] == "multiplier" and ds.sizes["multiplier"] == 2
    assert list(ds.harmonic.values) == [1, 2, 3, 4]
    assert ds.task_done.shape == (1, 5, 2)
    assert ds.strobe_q.dims == ("omega", "sigma", "zeta", "attractor", "strobe")
    for name in list(ds.data_vars) + list(ds.coords):
        assert ds[name].attrs.get("long_name"), name
        assert "units" in ds[name].attrs, name
    assert ds.attrs["hertzmap_study_hash"] == s.hash
    assert ds.attrs["hertzmap_study_toml"] == STORE_TEST_STUDY
    assert json.loads(ds.attrs["hertzmap_study_json"]) == s.to_dict()
    versions = json.loads(ds.attrs["hertzmap_versions"])
    assert {"numpy", "numba", "scipy", "dask", "zarr", "xarray", "hertzmap"} <= set(versions)
    assert ds.attrs["history"] == "h"
    # empty values: NaN floats, False bools, period 0, status -1; no memory used
    assert np.isnan(ds.q0.values).all() and not ds.stable.values.any()
    assert (ds.status.values == -1).all() and (ds.period.values == 0).all()
    assert ds.q0.variable._data.base is not None or ds.q0.values.strides[0] == 0
    # the slot dims start one chunk long (SLOT_CHUNK = 4: the store grows them as blocks
    # need), the attractor slots' chunk too
    assert ds.sizes["attractor"] == 4
    assert ds.q0.encoding["chunks"][-1] == 4 and ds.strobe_q.encoding["chunks"][-2:] == (4, 32)
    # estimated at one chunk of each: 4 slots x (10 float64 with the Liouville residual and
    # the peak and rms force, 2 complex128, 5 bool/int8 with the atlas round, 4 harmonics), the
    # orbit count (int16), and the census: count (int16), the basin entropies (2 float64), 3
    # int8 x 4 attractors (the unsettled reason among them) and their orbit slots (int16 x 4),
    # 11 float64 x 4 (the Lyapunov sum error, the exponent's periods and the periods run among
    # them), 2 x 4 x 32 strobe points
    assert bytes_per_point(s) == (4 * (10 * 8 + 2 * 16 + 5 * 1 + 4 * 8) + 2
                                  + 2 + 2 * 8 + 3 * 4 + 2 * 4 + 11 * 4 * 8 + 2 * 4 * 32 * 8)


# -- the schema, a store, the products and docs/dataset.md say the same -------------------------

def _doc_table(path, heading: str) -> list[list[str]]:
    """Rows (cells, stripped) of the first markdown table after ``heading`` in a doc file."""
    lines = (REPO / path).read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.strip().lstrip("#").strip() == heading)
    rows, in_table = [], False
    for line in lines[start + 1:]:
        if line.startswith("|"):
            in_table = True
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if not set("".join(cells)) <= set("-: "):
                rows.append(cells)
        elif in_table:
            break
    return rows[1:]                      # without the header row


def _names(cell: str) -> list[str]:
    return re.findall(r"`([^`]+)`", cell)


def test_docs_list_every_stored_variable_and_nothing_else():
    documented = {n for row in _doc_table("docs/dataset.md", "Variables") for n in _names(row[0])}
    assert documented == set(VARIABLES) | {"task_done"}


def test_a_store_holds_exactly_the_variables_of_its_outputs():
    s = parse_study(ALL_OUTPUTS_STUDY, default_name="all")
    ds = template(s, (17, 1, 1), history="h")
    assert set(ds.data_vars) == set(VARIABLES) | {"task_done"}
    for name, v in VARIABLES.items():
        assert ds[name].dtype == np.dtype(v.dtype) and ds[name].dims == v.dims, name
        assert ds[name].attrs["long_name"] == v.long_name and ds[name].attrs["units"] == v.units


def test_docs_status_codes_are_the_kernels_codes():
    rows = _doc_table("docs/dataset.md", "Status codes (`status`, from `kernels/status.py`)")
    documented = {int(row[0]): _names(row[1])[0] for row in rows}
    assert documented == status.NAMES
    ds = template(placeholder_study(), (17, 1, 1), history="h")
    assert dict(zip(ds.status.attrs["flag_values"].tolist(),
                    ds.status.attrs["flag_meanings"].split())) == status.NAMES


def test_docs_orbit_classes_are_the_classes_products_use(hand):
    rows = _doc_table("docs/products.md", "Orbit classes (`orbit_class`)")
    documented = {int(row[0]): _names(row[1])[0] for row in rows}
    assert documented == {code: name for code, name, _ in ORBIT_CLASSES}
    cls = P.orbit_classes(P.open_store(hand))
    assert dict(zip(cls.attrs["flag_values"].tolist(), cls.attrs["flag_meanings"].split())) \
        == documented


def test_bifurcation_kinds_in_store_products_and_docs(hand):
    flags = VARIABLES["bifurcation_kind"].attrs()
    assert dict(zip(flags["flag_values"].tolist(), flags["flag_meanings"].split())) \
        == {0: "empty", **{c: k for k, c in BIFURCATION_KINDS.items()}}
    assert P.LOCATED_KINDS == {c: k for k, c in BIFURCATION_KINDS.items()}
    assert VARIABLES["bifurcation_omega"].extra == (("bifurcation", BIFURCATION_SLOTS),)


def test_empty_arrays_are_the_fill_values():
    a = empty_arrays((3, 2, 1), slot_counts(solution=8, attractor=4))
    assert set(a) == set(VARIABLES)
    for name, v in VARIABLES.items():
        lead = {"line": (1, 2, 1), "slot": (3, 2, 1, 8), "point": (3, 2, 1),
                "attractor": (3, 2, 1, 4)}[v.layout]
        assert a[name].shape == lead + v.trailing
        assert a[name].dtype == np.dtype(v.dtype)
        np.testing.assert_array_equal(a[name], np.full_like(a[name], v.fill))


def test_a_block_of_uneven_slot_lengths_is_refused_and_padding_fills():
    """check_block: every variable of a slot dim the same length; pad_slots fills a block up
    to the store's length with the fill values, its own entries unchanged."""
    names = ("period", "status", "q0", "attractor_kind", "basin_fraction")
    a = empty_arrays((2, 1, 1), slot_counts(solution=4, attractor=4), names)
    check_block(a, names, (2, 1, 1))
    bad = dict(a, q0=np.full((2, 1, 1, 8), np.nan))
    with pytest.raises(ValueError, match="q0"):
        check_block(bad, names, (2, 1, 1))
    a["period"][0, 0, 0, :2] = (1, 2)
    padded = pad_slots(a, slot_counts(solution=12, attractor=4))
    assert padded["period"].shape == (2, 1, 1, 12) and padded["period"][0, 0, 0].tolist() == [
        1, 2] + [0] * 10
    assert padded["attractor_kind"] is a["attractor_kind"]


def test_a_store_of_another_format_is_refused_with_what_to_do():
    with pytest.raises(StoreFormatError, match="format 1.*--overwrite"):
        check_format({"hertzmap_store_format": 1}, "old.zarr")
    with pytest.raises(StoreFormatError, match="format 7"):
        check_format({"hertzmap_store_format": 7})
    check_format({"hertzmap_store_format": STORE_FORMAT})


def test_study_read_back_from_the_attrs():
    s = placeholder_study()
    ds = template(s, (17, 1, 1), history="h")
    assert study_from_attrs(ds.attrs) == s and study_from_attrs(ds.attrs).hash == s.hash
    edited = dict(ds.attrs, hertzmap_study_toml=STORE_TEST_STUDY.replace("num = 17", "num = 18"))
    with pytest.raises(StudyError, match="does not match its hash"):
        study_from_attrs(edited)
    with pytest.raises(StudyError, match="hold no study"):
        study_from_attrs({})
