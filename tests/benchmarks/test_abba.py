"""benchmarks/abba.py, the same-run A/B harness: the ABBA order of the rounds, the ratios taken
round by round (each A run against the B run beside it), their median and spread in the report,
the figures a variant returns, and commands (argv, output, figures read off it, failure).

    .venv/bin/python -m pytest tests/benchmarks/test_abba.py -q -n 0
"""
from __future__ import annotations

import sys

import pytest

from benchmarks.abba import Command, RunFailed, abba, figure_parser, main


def test_rounds_alternate_and_ratios_are_taken_round_by_round():
    order = []

    def variant(name, value):
        def run(k):
            order.append((k, name))
            return {"x": value[k]}
        return run

    res = abba({"A": variant("A", [1.0, 2.0, 4.0, 8.0]), "B": variant("B", [2.0, 2.0, 2.0, 2.0])},
               4)
    assert order == [(0, "A"), (0, "B"), (1, "B"), (1, "A"), (2, "A"), (2, "B"), (3, "B"),
                     (3, "A")]
    assert res.ratios("A", "B", "x") == [0.5, 1.0, 2.0, 4.0]
    assert res.of("B", "x") == [2.0] * 4
    line = res.report("A", "B", "x")
    assert "A / B (x), pair by pair: 0.50, 1.00, 2.00, 4.00; median 1.50, spread 0.50-4.00" in line
    assert "(4 pairs); load average" in line
    # every run is timed as well
    assert all(r.wall >= 0 and r.cpu >= 0 for r in res.runs)


def test_more_variants_run_in_a_palindrome_and_warm_up_is_untimed():
    order = []
    variants = {n: (lambda k, n=n: order.append((k, n))) for n in "ABC"}
    res = abba(variants, 2, warm_up=True)
    assert order == [(-1, "A"), (-1, "B"), (-1, "C"), (0, "A"), (0, "B"), (0, "C"), (1, "C"),
                     (1, "B"), (1, "A")]
    assert len(res.runs) == 6 and {r.round for r in res.runs} == {0, 1}


def test_a_round_without_a_denominator_has_no_ratio():
    values = {"A": [1.0, 3.0], "B": [0.0, 2.0]}
    res = abba({n: (lambda k, n=n: {"cpu census": values[n][k]}) for n in "AB"}, 2)
    assert res.ratios("A", "B", "cpu census") == [1.5]
    assert "none" in abba({n: (lambda k: {"y": 0.0}) for n in "AB"}, 1).report("A", "B", "y")


def test_a_command_gives_its_output_and_the_figures_read_off_it():
    cmd = Command([sys.executable, "-c", "print('grid 12.5 s wall')"],
                  parse=figure_parser({"grid": r"grid ([\d.]+) s"}))
    res = abba({"A": cmd, "B": cmd}, 2)
    assert res.of("A", "grid") == [12.5, 12.5]
    assert "grid 12.5 s wall" in res.run("B", 1).value["output"]
    assert res.run("A", 0).cpu > 0            # the child's CPU, once it ended
    with pytest.raises(RunFailed):
        Command([sys.executable, "-c", "raise SystemExit(3)"])(0)


def test_the_command_line_compares_two_commands(capsys):
    quick = f"{sys.executable} -c \"print('x 2')\""
    assert main(["--rounds", "2", "--figure", r"x=x (\d+)", quick, quick]) == 0
    out = capsys.readouterr().out
    assert "B / A (wall), pair by pair:" in out and "B / A (x), pair by pair: 1.00, 1.00" in out
