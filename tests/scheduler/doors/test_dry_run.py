"""scheduler.doors.dry_run: the dry run names the planes a study's curves are traced in (a grid that
sweeps omega, sigma and zeta traces in all three, each at every value of the third) and the
atlas's tiles, and says their time is not in its estimate."""
from __future__ import annotations

from hertzmap.scheduler.doors.dry_run import atlas_line, curves_line
from hertzmap.scheduler.stages.plan import make_plan
from hertzmap.study.spec import parse_study

CURVES = '\n[products]\noutputs = ["orbits", "measures", "curves"]\n'


def test_the_curves_line_names_every_plane_of_a_3d_grid():
    study = parse_study("[grid]\nomega = [1.9, 2.0, 2.1]\nsigma = [0.2, 0.3]\n"
                        "zeta = [0.005, 0.01, 0.02, 0.04]\n" + CURVES, default_name="t")
    assert curves_line(study) == (
        "curves       traced after the grid in 3 plane(s): (omega, sigma) at 4 zeta, "
        "(omega, zeta) at 2 sigma, (sigma, zeta) at 3 omega; not in the estimate")
    flat = parse_study("[grid]\nomega = [1.9, 2.0]\nsigma = [0.2, 0.3]\nzeta = 0.01\n" + CURVES,
                       default_name="t")
    assert "1 plane(s): (omega, sigma) at 1 zeta;" in curves_line(flat)


def test_the_atlas_line_counts_tiles_of_three_blocks_along_sigma():
    """10 sigma lines in blocks of 2: 5 task blocks along sigma, 2 atlas tiles (of 3 blocks and
    of the 2 left) at each of the 2 zeta values."""
    study = parse_study("[grid]\nomega = [1.9, 2.0]\nsigma = { start = 0.1, stop = 1.0, num = 10 }"
                        "\nzeta = [0.01, 0.02]\n" + CURVES, default_name="t")
    plan = make_plan(study, (2, 2, 1))
    assert len(plan.tasks) == 10
    assert " at most 4 tile(s) (3 tasks' blocks along sigma each); not in the estimate" \
        in atlas_line(study, plan)
