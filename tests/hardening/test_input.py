"""Hardening, bad input: property-based malformed study files and CLI arguments.

Every generated case must end with exit code 2, a message on stderr naming the field (or the
option), and no store created or changed. Most cases go through the CLI's ``main`` in-process
(fast); a handful through a real ``hertzmap`` subprocess. Hypothesis is derandomized so CI
sees the same cases on every run; case counts are in RELIABILITY.md."""
from __future__ import annotations

from pathlib import Path
import contextlib
import io
import math
import os
import re
import subprocess
import tempfile

from hypothesis import HealthCheck, given, settings, strategies as hs
import pytest

from hertzmap.scheduler.doors.cli import main
from hertzmap.study.spec import MAX_GRID_POINTS, OUTPUTS
from tests.helpers import PLACEHOLDER, hertzmap_cmd, subprocess_env


SETTINGS = dict(deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much,
                                       HealthCheck.data_too_large])

# -- a tiny TOML writer (enough for study files) -----------------------------------------------

_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(k: str) -> str:
    return k if _BARE.match(k) else '"' + k.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _val(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return '"' + "".join(
            "\\\\" if c == "\\" else '\\"' if c == '"' else
            f"\\u{ord(c):04x}" if ord(c) < 0x20 or ord(c) == 0x7F or 0xD800 <= ord(c) < 0xE000
            else c for c in v) + '"'
    if isinstance(v, list):
        return "[" + ", ".join(_val(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(k)} = {_val(x)}" for k, x in v.items()) + "}"
    raise TypeError(type(v))


def to_toml(doc: dict) -> str:
    lines = []
    for k, v in doc.items():
        if not isinstance(v, dict):
            lines.append(f"{_key(k)} = {_val(v)}")
    for k, v in doc.items():
        if isinstance(v, dict):
            lines.append(f"[{_key(k)}]")
            lines.extend(f"{_key(kk)} = {_val(vv)}" for kk, vv in v.items())
    return "\n".join(lines) + "\n"


def base() -> dict:
    """A valid study using every table (the mutations break one thing in it)."""
    return {
        "study": {"name": "h", "description": "hardening"},
        "grid": {"omega": {"start": 0.5, "stop": 2.5, "num": 5}, "sigma": [0.1, 0.2],
                 "zeta": 0.01},
        "model": {"kind": "hertz", "exponent": 1.5},
        "solver": {"rtol": 1e-10},
        "search": {"periods": [1, 2]},
        "products": {"outputs": ["orbits", "measures"]},
        "rig": {"E": 2.1e11, "nu": 0.3, "R": 0.0127, "m": 1.2, "N": 50.0, "contact": "double"},
    }


# -- mutations: each returns (doc, accepted fields) ----------------------------------------------

NONFINITE = hs.sampled_from([math.nan, math.inf, -math.inf])
NOT_A_NUMBER = hs.one_of(hs.text(max_size=8), hs.booleans(), hs.just([]), hs.just(["1"]),
                         hs.just({"a": 1}), hs.lists(hs.integers(), min_size=1, max_size=3))
NOT_A_STRING = hs.one_of(hs.integers(), hs.floats(allow_nan=False), hs.booleans(),
                         hs.just(["x"]), hs.just({"a": "b"}))
AXES = ["omega", "sigma", "zeta"]
NUMERIC_LEAVES = [("model", "exponent"), ("solver", "rtol"), ("rig", "E"), ("rig", "nu"),
                  ("rig", "R"), ("rig", "m"), ("rig", "N")]
ALLOWED = {"": ["study", "grid", "model", "solver", "search", "products", "rig"],
           "study": ["name", "description"], "grid": AXES, "model": ["kind", "exponent"],
           "solver": ["rtol"], "search": ["periods"], "products": ["outputs"],
           "rig": ["E", "nu", "R", "m", "N", "contact"]}


@hs.composite
def axis_bad(draw):
    """A grid axis made invalid: wrong type, non-finite, out of range, empty, duplicated."""
    doc = base()
    ax = draw(hs.sampled_from(AXES))
    f = f"grid.{ax}"
    lo_bad = hs.floats(max_value=0.0, allow_nan=False, allow_infinity=False) if ax == "omega" \
        else hs.floats(max_value=-1e-300, allow_nan=False, allow_infinity=False)
    good = hs.floats(0.01, 5.0)
    kind = draw(hs.sampled_from(["scalar_type", "scalar_nonfinite", "scalar_range", "list_item",
                                 "empty", "dup", "range_key", "range_num", "range_missing",
                                 "range_unknown"]))
    if kind == "scalar_type":
        doc["grid"][ax] = draw(hs.one_of(hs.text(max_size=5), hs.booleans()))
    elif kind == "scalar_nonfinite":
        doc["grid"][ax] = draw(NONFINITE)
    elif kind == "scalar_range":
        doc["grid"][ax] = draw(lo_bad)
    elif kind == "list_item":
        values = draw(hs.lists(good, min_size=1, max_size=6, unique=True))
        i = draw(hs.integers(0, len(values)))
        bad = draw(hs.one_of(NONFINITE, lo_bad, NOT_A_NUMBER))
        values.insert(i, bad)
        doc["grid"][ax] = values
        f = f"grid.{ax}[{i}]"
    elif kind == "empty":
        doc["grid"][ax] = []
    elif kind == "dup":
        values = draw(hs.lists(good, min_size=1, max_size=6, unique=True))
        j = draw(hs.integers(0, len(values) - 1))
        values.insert(draw(hs.integers(0, len(values))), values[j])
        doc["grid"][ax] = values
    elif kind == "range_key":
        key = draw(hs.sampled_from(["start", "stop"]))
        r = {"start": 0.5, "stop": 2.0, "num": 4}
        r[key] = draw(hs.one_of(NONFINITE, lo_bad, NOT_A_NUMBER))
        doc["grid"][ax] = r
        f = f"grid.{ax}.{key}"
    elif kind == "range_num":
        num = draw(hs.one_of(hs.integers(max_value=0), hs.floats(allow_nan=False, allow_infinity=False),
                             hs.booleans(), hs.text(max_size=3), hs.just(1)))
        doc["grid"][ax] = {"start": 0.5, "stop": 2.0, "num": num}
        f = f"grid.{ax}.num"
    elif kind == "range_missing":
        key = draw(hs.sampled_from(["start", "stop", "num"]))
        r = {"start": 0.5, "stop": 2.0, "num": 4}
        del r[key]
        doc["grid"][ax] = r
        f = f"grid.{ax}.{key}"
    else:
        key = draw(hs.sampled_from(["step", "end", "n", "count", "Start"]))
        doc["grid"][ax] = {"start": 0.5, "stop": 2.0, "num": 4, key: 1}
        f = f"grid.{ax}.{key}"
    return doc, {f}


@hs.composite
def huge_grid(draw):
    doc = base()
    nums = [draw(hs.integers(1, 10**6)) for _ in AXES]
    if math.prod(nums) <= MAX_GRID_POINTS:
        nums[draw(hs.integers(0, 2))] = draw(hs.integers(MAX_GRID_POINTS + 1, 10**12))
    for ax, n in zip(AXES, nums):
        doc["grid"][ax] = [0.5] if n == 1 else {"start": 0.5, "stop": 2.0, "num": n}
    # either the product is refused, or the single axis beyond the limit
    return doc, {"grid"} | {f"grid.{ax}.num" for ax in AXES}


@hs.composite
def leaf_bad(draw):
    """A scalar setting made invalid: wrong type, non-finite or out of range."""
    doc = base()
    which = draw(hs.sampled_from(["numeric", "name", "description", "kind", "max_solutions",
                                  "periods", "outputs", "contact", "taylor_exponent"]))
    if which == "numeric":
        table, key = draw(hs.sampled_from(NUMERIC_LEAVES))
        ranges = {"exponent": hs.one_of(hs.floats(max_value=0.0), hs.floats(min_value=3.0001)),
                  "rtol": hs.one_of(hs.floats(max_value=9.9e-14), hs.floats(min_value=1.01e-4)),
                  "nu": hs.one_of(hs.floats(max_value=-1.0), hs.floats(min_value=0.5))}
        out_of_range = ranges.get(key, hs.floats(max_value=0.0))
        doc[table][key] = draw(hs.one_of(NONFINITE, NOT_A_NUMBER,
                                         out_of_range.filter(math.isfinite)))
        return doc, {f"{table}.{key}"}
    if which == "name":
        doc["study"]["name"] = draw(hs.one_of(
            NOT_A_STRING, hs.just(""), hs.text(min_size=65, max_size=80, alphabet="abc"),
            hs.text(min_size=1, max_size=10).filter(
                lambda s: not re.match(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,63}$", s))))
        return doc, {"study.name"}
    if which == "description":
        doc["study"]["description"] = draw(NOT_A_STRING)
        return doc, {"study.description"}
    if which == "kind":
        doc["model"]["kind"] = draw(hs.one_of(NOT_A_STRING, hs.text(max_size=8).filter(
            lambda s: s not in ("hertz", "taylor"))))
        return doc, {"model.kind"}
    if which == "max_solutions":
        # no longer a setting (every orbit found is stored): any value is refused by name
        doc["solver"]["max_solutions"] = draw(hs.one_of(hs.integers(), hs.booleans(),
                                                        NONFINITE, hs.text(max_size=3)))
        return doc, {"solver.max_solutions"}
    if which == "periods":
        doc["search"]["periods"] = draw(hs.one_of(
            hs.just([]), hs.just([1, 1]), hs.just([2, 2, 1]), hs.just([1.0]), hs.just(["1"]),
            hs.just(1), hs.just("1, 2"), hs.lists(hs.integers().filter(lambda p: p not in (1, 2)),
                                                  min_size=1, max_size=3),
            hs.just([True])))
        return doc, {"search.periods"}
    if which == "outputs":
        doc["products"]["outputs"] = draw(hs.one_of(
            hs.just("orbits"), hs.just(["orbits", "orbits"]), hs.just([1]),
            hs.lists(hs.text(max_size=6).filter(
                lambda s: s not in OUTPUTS),
                min_size=1, max_size=3)))
        return doc, {"products.outputs"}
    if which == "contact":
        doc["rig"]["contact"] = draw(hs.one_of(NOT_A_STRING, hs.sampled_from(
            ["triple", "Double", "", "double ", "mm", "SI"])))
        return doc, {"rig.contact"}
    doc["model"] = {"kind": "taylor", "exponent": draw(hs.floats(0.1, 3.0))}
    return doc, {"model.exponent"}


@hs.composite
def structure_bad(draw):
    """Unknown keys and tables (bad units, typos), missing required pieces, tables of the
    wrong type."""
    doc = base()
    which = draw(hs.sampled_from(["unknown", "missing_grid", "missing_axis", "missing_rig",
                                  "not_a_table"]))
    if which == "unknown":
        table = draw(hs.sampled_from(list(ALLOWED)))
        key = draw(hs.one_of(
            hs.sampled_from(["E_GPa", "units", "unit", "R_mm", "mass", "atol", "workers",
                             "cluster", "theta", "omega_hz", "Name", "period"]),
            hs.text(alphabet="abcdefghijklmnopqrstuvwxyz_", min_size=1, max_size=10)))
        if key in ALLOWED[table]:
            key = key + "_x"
        if table == "":
            doc[key] = {"x": 1} if draw(hs.booleans()) else 1
            return doc, {key}
        doc[table][key] = draw(hs.one_of(hs.integers(), hs.text(max_size=4), hs.floats(0, 1)))
        return doc, {f"{table}.{key}"}
    if which == "missing_grid":
        del doc["grid"]
        return doc, {"grid"}
    if which == "missing_axis":
        ax = draw(hs.sampled_from(AXES))
        del doc["grid"][ax]
        return doc, {f"grid.{ax}"}
    if which == "missing_rig":
        key = draw(hs.sampled_from(["E", "nu", "R", "m", "N"]))
        del doc["rig"][key]
        return doc, {f"rig.{key}"}
    table = draw(hs.sampled_from(["study", "grid", "model", "solver", "search", "products", "rig"]))
    doc[table] = draw(hs.one_of(hs.integers(), hs.text(max_size=4), hs.just([1, 2])))
    return doc, {table}


# -- running a case through the CLI's main --------------------------------------------------------

WORK = Path(tempfile.mkdtemp(prefix="hertzmap-hardening-"))


def _snapshot(root: Path) -> dict[str, tuple[int, int]]:
    return {str(p.relative_to(root)): (p.stat().st_size, p.stat().st_mtime_ns)
            for p in sorted(root.rglob("*"))}


def run_main(argv: list[str]) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            rc = main(argv)
        except SystemExit as exc:           # argparse usage errors
            rc = exc.code
    return rc, err.getvalue()


def check_refused(text: str | bytes, fields: set[str], store: Path | None = None) -> str:
    d = Path(tempfile.mkdtemp(dir=WORK))
    study = d / "case.toml"
    (study.write_bytes if isinstance(text, bytes) else study.write_text)(text)
    store = store or d / "out.zarr"
    before_dir = _snapshot(d)
    before_store = _snapshot(store) if store.exists() else None
    rc, err = run_main(["run", str(study), "--store", str(store), "--workers", "1"])
    assert rc == 2, (rc, err, text)
    m = re.search(r"hertzmap: error: .*?case\.toml: (\S+?): ", err)
    assert m, err
    assert m.group(1) in fields, (m.group(1), fields, err)
    assert len(err) < 2000, err                     # short, not a traceback
    assert "Traceback" not in err
    assert _snapshot(d) == before_dir               # nothing created (no store, no lock)
    if before_store is not None:
        assert _snapshot(store) == before_store     # nothing changed
        assert not Path(str(store) + ".lock").exists()
    return err


# -- an existing store is never changed by a bad study -------------------------------------------

@pytest.fixture(scope="module")
def existing_store():
    d = Path(tempfile.mkdtemp(dir=WORK))
    study = d / "h.toml"
    doc = base()
    study.write_text(to_toml(doc))
    store = d / "h.zarr"
    rc, err = run_main(["run", str(study), "--store", str(store), "--workers", "1",
                        "--solver", PLACEHOLDER, "--error-sample", "0", "--task-seconds", "0.01"])
    assert rc == 0, err
    return store


# -- bad command-line arguments -------------------------------------------------------------------

BAD_ARGS = [
    # (arguments after STUDY, text the message must contain)
    (["--workers", "0"], "--workers"),
    (["--workers", "-3"], "--workers"),
    (["--workers", "abc"], "--workers"),
    (["--workers", "2.5"], "--workers"),
    (["--workers", "100000000"], "--workers"),
    (["--task-seconds", "0"], "--task-seconds"),
    (["--task-seconds", "-1"], "--task-seconds"),
    (["--task-seconds", "nan"], "--task-seconds"),
    (["--task-seconds", "inf"], "--task-seconds"),
    (["--task-seconds", "x"], "--task-seconds"),
    (["--error-sample", "-1"], "--error-sample"),
    (["--error-sample", "1.5"], "--error-sample"),
    (["--cluster", "kubernetes"], "--cluster"),
    (["--cluster-option", "queue=normal"], "--cluster-option"),
    (["--cluster", "slurm", "--cluster-option", "no_equals_sign"], "--cluster-option"),
    (["--cluster", "slurm", "--cluster-option", "1bad=2"], "--cluster-option"),
    (["--scheduler", "tcp://h:1", "--cluster", "slurm"], "--cluster"),
    (["--scheduler", "tcp://a b:1"], "--scheduler"),
    (["--frobnicate"], "--frobnicate"),
    (["--workers"], "--workers"),
]


# -- too large for the disk or the memory: refused by the dry run, before anything is written -----

def _big_study(tmp_path) -> Path:
    p = tmp_path / "big.toml"
    p.write_text(to_toml({"grid": {"omega": {"start": 0.1, "stop": 5.0, "num": 20000},
                                   "sigma": {"start": 0.0, "stop": 1.0, "num": 1000}, "zeta": 0.01},
                          "products": {"outputs": ["orbits", "measures", "force_harmonics",
                                                   "diagnostics"]}}))
    return p


# -- a handful through a real subprocess -----------------------------------------------------------

SUBPROCESS_CASES = [
    ({"grid": {"omega": [0.0], "sigma": [0.1], "zeta": 0.01}}, [], "grid.omega[0]"),
    ({"grid": {"omega": [1.0, 1.0], "sigma": [0.1], "zeta": 0.01}}, [], "grid.omega"),
    ({"grid": {"omega": [1.0], "sigma": [math.nan], "zeta": 0.01}}, [], "grid.sigma[0]"),
    ({"grid": {"omega": [1.0], "sigma": [0.1], "zeta": 0.01}, "rig": {"E": 1.0, "nu": 0.3,
      "R": 0.01, "m": 1.0, "N": 1.0, "units": "mm"}}, [], "rig.units"),
    ({"grid": {"omega": [1.0], "sigma": [0.1], "zeta": 0.01}}, ["--workers", "0"], "--workers"),
    ({"grid": {"omega": [1.0], "sigma": [0.1], "zeta": 0.01}}, ["--task-seconds", "inf"],
     "--task-seconds"),
]


# 1000 + cases in all (counts in RELIABILITY.md)

@settings(max_examples=350, **SETTINGS)
@given(case=axis_bad())
def test_bad_grid_axes_are_refused(case):
    doc, fields = case
    check_refused(to_toml(doc), fields)


@settings(max_examples=60, **SETTINGS)
@given(case=huge_grid())
def test_huge_grids_are_refused_at_once(case):
    doc, fields = case
    check_refused(to_toml(doc), fields)


@settings(max_examples=350, **SETTINGS)
@given(case=leaf_bad())
def test_bad_settings_are_refused(case):
    doc, fields = case
    check_refused(to_toml(doc), fields)


@settings(max_examples=200, **SETTINGS)
@given(case=structure_bad())
def test_unknown_missing_and_mistyped_tables_are_refused(case):
    doc, fields = case
    check_refused(to_toml(doc), fields)


@settings(max_examples=60, **SETTINGS)
@given(cut=hs.integers(1, 400), junk=hs.sampled_from(["[", "=", "]]", "\"", "{", "= =", "\x00"]))
def test_broken_toml_and_bytes_are_refused(cut, junk):
    text = to_toml(base())
    broken = text[: cut % len(text)] + junk + "\n" + text[cut % len(text):]
    d = Path(tempfile.mkdtemp(dir=WORK))
    p = d / "case.toml"
    p.write_text(broken)
    rc, err = run_main(["run", str(p), "--store", str(d / "out.zarr")])
    assert rc == 2 and re.search(r"case\.toml: \S+: ", err), err
    assert sorted(os.listdir(d)) == ["case.toml"]
    # not UTF-8
    p.write_bytes(b"\xff\xfe" + text.encode("utf-16-le"))
    check_refused(p.read_bytes(), {"file"})


@settings(max_examples=80, **SETTINGS)
@given(case=hs.one_of(axis_bad(), leaf_bad(), structure_bad()))
def test_bad_study_never_touches_an_existing_store(existing_store, case):
    doc, fields = case
    check_refused(to_toml(doc), fields, store=existing_store)


@settings(max_examples=150, **SETTINGS)
@given(case=hs.sampled_from(BAD_ARGS), extra=hs.sampled_from(
    [[], ["--dry-run"], ["--overwrite"], ["--dry-run", "--overwrite"]]),
    order=hs.booleans())
def test_bad_arguments_are_refused(existing_store, case, extra, order):
    args, needle = case
    study = existing_store.parent / "h.toml"
    before = _snapshot(existing_store)
    argv = ["run", str(study), "--store", str(existing_store)]
    argv += (extra + args) if order else (args + extra)
    rc, err = run_main(argv)
    assert rc == 2, (argv, rc, err)
    assert needle in err, (argv, err)
    assert "Traceback" not in err
    assert _snapshot(existing_store) == before


def test_store_paths_that_are_not_stores_are_refused(tmp_path):
    study = tmp_path / "h.toml"
    study.write_text(to_toml(base()))
    f = tmp_path / "file.zarr"
    f.write_text("precious")
    d = tmp_path / "dir.zarr"
    d.mkdir()
    (d / "keep.txt").write_text("keep")
    for store in (f, d):
        for extra in ([], ["--overwrite"]):
            rc, err = run_main(["run", str(study), "--store", str(store), "--workers", "1", *extra])
            assert rc == 2 and "not a zarr store" in err, err
    assert f.read_text() == "precious" and (d / "keep.txt").read_text() == "keep"
    rc, err = run_main(["run", str(tmp_path / "missing.toml")])
    assert rc == 2 and "file: cannot read" in err
    rc, err = run_main(["run", str(tmp_path)])          # a directory, not a file
    assert rc == 2 and "file: cannot read" in err
    rc, err = run_main(["status", str(f)])
    assert rc == 2 and "not a hertzmap store" in err


def test_store_too_large_for_the_disk_is_refused(tmp_path, monkeypatch):
    import collections
    import hertzmap.scheduler.resources as run

    p = _big_study(tmp_path)
    Usage = collections.namedtuple("Usage", "total used free")
    monkeypatch.setattr(run.shutil, "disk_usage", lambda path: Usage(10**12, 10**12 - 10**9, 10**9))
    for extra in (["--dry-run"], []):
        rc, err = run_main(["run", str(p), "--store", str(tmp_path / "big.zarr"), *extra])
        assert rc == 2, err
        assert "grid: 20000 x 1000 x 1 points need a store of about" in err
        assert "free at" in err
    assert sorted(os.listdir(tmp_path)) == ["big.toml"]
    monkeypatch.setenv(run.SKIP_SPACE_ENV, "1")
    rc, err = run_main(["run", str(p), "--store", str(tmp_path / "big.zarr"), "--dry-run"])
    assert rc == 0, err
    assert sorted(os.listdir(tmp_path)) == ["big.toml"]


def test_study_too_large_for_the_memory_is_refused(tmp_path, monkeypatch):
    import hertzmap.scheduler.resources as run

    p = _big_study(tmp_path)
    # the memory check alone: the disk's (the test above) would refuse this store first where
    # tmp_path has less than its ~51 GB free (a tmpfs, a small disk)
    monkeypatch.setenv(run.SKIP_SPACE_ENV, "1")
    monkeypatch.setattr(run, "_available_memory", lambda: 10**6)
    rc, err = run_main(["run", str(p), "--store", str(tmp_path / "big.zarr"), "--dry-run"])
    assert rc == 2 and "grid:" in err and "of memory in the client" in err, err
    assert sorted(os.listdir(tmp_path)) == ["big.toml"]


def test_largest_allowed_grid_dry_run_is_quick_and_writes_nothing(tmp_path, monkeypatch):
    import hertzmap.scheduler.resources as run

    p = _big_study(tmp_path)
    # the whole dry run, wherever tmp_path is: its ~51 GB store is the disk check's case (above)
    monkeypatch.setenv(run.SKIP_SPACE_ENV, "1")
    rc, err = run_main(["run", str(p), "--store", str(tmp_path / "big.zarr"), "--dry-run"])
    assert rc in (0, 2), err                # 2 only with little memory
    assert sorted(os.listdir(tmp_path)) == ["big.toml"]


@pytest.mark.parametrize("doc,args,needle", SUBPROCESS_CASES,
                         ids=[c[2] for c in SUBPROCESS_CASES])
def test_subprocess_refusals(tmp_path, doc, args, needle):
    p = tmp_path / "case.toml"
    p.write_text(to_toml(doc))
    r = subprocess.run(hertzmap_cmd("run", str(p), *args), cwd=tmp_path, env=subprocess_env(),
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2, r.stderr
    assert needle in r.stderr and "Traceback" not in r.stderr
    assert sorted(os.listdir(tmp_path)) == ["case.toml"]


# -- the "curves" output needs two swept axes ------------------------------------------------------

@pytest.mark.parametrize("grid", [{"sigma": 0.1}, {"omega": 1.0, "sigma": [0.1]},
                                  {"omega": [1.0], "sigma": 0.2, "zeta": [0.01]}])
def test_curves_on_a_grid_with_one_swept_axis_are_refused(grid):
    doc = base()
    doc["grid"].update(grid)
    doc["products"]["outputs"] = ["orbits", "curves"]
    err = check_refused(to_toml(doc), {"products.outputs"})
    assert "two swept" in err
