"""The checks of a study file's fields, each refusal a :class:`StudyError` naming the field and
what is allowed (study.spec validates a whole study with them): a number, an integer in a
range, a table, unknown keys, and an axis of the grid (a value, a list or a
``{start, stop, num}`` table, its values distinct and within the axis' range).
"""
from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

__all__ = ["StudyError", "MAX_GRID_POINTS", "AXIS_RULES", "shown", "is_number", "number",
           "integer", "table", "refuse_unknown", "check_axis_value", "parse_axis",
           "axis_length"]

#: Largest grid (omega x sigma x zeta points) a single study may ask for.
MAX_GRID_POINTS = 20_000_000

AXIS_RULES = {
    # axis: (lower bound, bound is strict, description)
    "omega": (0.0, True, "> 0"),
    "sigma": (0.0, False, ">= 0"),
    "zeta": (0.0, False, ">= 0"),
}


class StudyError(ValueError):
    """A study file is invalid. The message names the field and what is allowed."""

    def __init__(self, field_name: str, message: str):
        self.field = field_name
        super().__init__(f"{field_name}: {message}" if field_name else message)


def shown(value: Any, limit: int = 80) -> str:
    """repr of a value for an error message, shortened (a study file may hold huge values)."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 5] + " ...>"


def is_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def number(value: Any, field_name: str, allowed: str) -> float:
    if not is_number(value):
        raise StudyError(field_name, f"expected a number ({allowed}), got {shown(value)}")
    try:
        x = float(value) + 0.0          # + 0.0: -0.0 is stored (and hashed) as 0.0
    except OverflowError:               # an integer beyond the float range
        raise StudyError(field_name, f"must be a finite number ({allowed}), got {shown(value)}") from None
    if not math.isfinite(x):
        raise StudyError(field_name, f"must be a finite number ({allowed}), got {shown(value)}")
    return x


def integer(value: Any, field_name: str, lo: int, hi: int) -> int:
    if not isinstance(value, int) or isinstance(value, bool):
        raise StudyError(field_name, f"expected an integer in {lo}..{hi}, got {shown(value)}")
    if not lo <= value <= hi:
        raise StudyError(field_name, f"must be in {lo}..{hi}, got {value}")
    return int(value)


def table(doc: Mapping[str, Any], key: str, required: bool = False) -> dict[str, Any]:
    if key not in doc:
        if required:
            raise StudyError(key, f"missing required table [{key}]")
        return {}
    value = doc[key]
    if not isinstance(value, dict):
        raise StudyError(key, f"expected a table [{key}], got {type(value).__name__}")
    return value


def refuse_unknown(table: Mapping[str, Any], prefix: str, allowed: tuple[str, ...]) -> None:
    for key in table:
        if key not in allowed:
            where = f"{prefix}.{key}" if prefix else key
            raise StudyError(where, f"unknown key; allowed keys: {', '.join(allowed)}")


def check_axis_value(x: float, field_name: str, axis: str) -> None:
    lower, strict, desc = AXIS_RULES[axis]
    if (x <= lower) if strict else (x < lower):
        raise StudyError(field_name, f"{axis} must be {desc} (finite), got {shown(x)}")


def parse_axis(value: Any, axis: str) -> tuple[float, ...]:
    fname = f"grid.{axis}"
    _, _, desc = AXIS_RULES[axis]
    allowed = f"{desc}, finite"
    if is_number(value):
        values = [number(value, fname, allowed)]
        check_axis_value(values[0], fname, axis)
    elif isinstance(value, list):
        if not value:
            raise StudyError(fname, "empty list; give at least one value")
        values = [number(v, f"{fname}[{i}]", allowed) for i, v in enumerate(value)]
        for i, x in enumerate(values):
            check_axis_value(x, f"{fname}[{i}]", axis)
    elif isinstance(value, dict):
        refuse_unknown(value, fname, ("start", "stop", "num"))
        for key in ("start", "stop", "num"):
            if key not in value:
                raise StudyError(f"{fname}.{key}", "missing; a range needs start, stop and num")
        start = number(value["start"], f"{fname}.start", allowed)
        stop = number(value["stop"], f"{fname}.stop", allowed)
        check_axis_value(start, f"{fname}.start", axis)
        check_axis_value(stop, f"{fname}.stop", axis)
        num = value["num"]
        if not isinstance(num, int) or isinstance(num, bool) or num < 1:
            raise StudyError(f"{fname}.num", f"expected an integer >= 1, got {shown(num)}")
        if num > MAX_GRID_POINTS:
            raise StudyError(f"{fname}.num", f"must be <= {MAX_GRID_POINTS}, got {num}")
        if num == 1 and start != stop:
            raise StudyError(f"{fname}.num", "num = 1 with start != stop is ambiguous; "
                             "use a one-element list instead")
        values = [float(x) for x in np.linspace(start, stop, num)]
        # np.linspace may leave the last value off by an ulp: pin the end points exactly.
        values[0] = start
        values[-1] = stop
    else:
        raise StudyError(fname, "expected a number, a list of numbers or a table "
                         f"{{start, stop, num}}, got {type(value).__name__}")
    seen: dict[float, int] = {}
    for i, x in enumerate(values):
        if x in seen:
            raise StudyError(fname, f"duplicated value {shown(x)} (positions {seen[x]} and {i}); "
                             "axis values must be distinct")
        seen[x] = i
    return tuple(values)


def axis_length(value: Any) -> int | None:
    """Number of values an axis asks for, when that is clear before validation (else None)."""
    if is_number(value):
        return 1
    if isinstance(value, list):
        return len(value) or None
    if isinstance(value, dict):
        num = value.get("num")
        if isinstance(num, int) and not isinstance(num, bool) and num >= 1:
            return num
    return None
