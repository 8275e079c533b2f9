"""kernels.records: every record's kernel columns and field names are unique (a column declared
by two fields would be written at one index and read at another), and the kernels' row layouts
and indices are the records'."""
from __future__ import annotations

import pytest

from hertzmap.kernels import attractors, shooting
from hertzmap.kernels.continuation import VERTEX_FIELDS
from hertzmap.kernels.records import ATTRACTOR, ORBIT, VERTEX, Field, Record


@pytest.mark.parametrize("record", [ORBIT, ATTRACTOR, VERTEX], ids=lambda r: r.name)
def test_columns_and_names_are_unique(record):
    assert len(set(record.columns)) == len(record.columns)
    assert len({f.name for f in record.fields}) == len(record.fields)


def test_a_column_declared_twice_is_refused():
    with pytest.raises(ValueError, match="declared twice"):
        Record("x", (Field("a", "a", "1", "a"), Field("b", "b", "1", "b", columns=("a",))))


def test_the_kernels_rows_are_the_records():
    assert shooting.FIELDS == ORBIT.columns and attractors.ATTRACTOR_FIELDS == ATTRACTOR.columns
    assert VERTEX_FIELDS == VERTEX.columns
    for name, i in ORBIT.index.items():
        assert shooting.F[name] == i
    assert attractors.A_RUN == ATTRACTOR.index["periods_run"]
    assert shooting.I_PEAKF == ORBIT.index["peak_force"]
