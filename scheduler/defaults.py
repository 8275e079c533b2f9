"""What a run does unless told otherwise: the defaults the command line states in its help and
the run uses, declared once (importing this costs nothing, so ``hertzmap --help`` stays quick)."""

#: Target duration of one task (seconds, as estimated by scheduler.stages.plan.seconds_per_point).
#: Each task costs its worker a block write (one file per variable, ~36: 32 ms for 4000
#: points), the scheduler 6.5-10.5 ms and the client 7-8 ms of CPU (the flag, the counts:
#: benchmarks/run_cost.py scale); when the client still wrote every block, the default study
#: in 77 tasks of one sigma line (~0.3 s each) cost its grid 1.09-1.14x the wall of 26 tasks of
#: three (benchmarks/run_cost.py task-size). Larger tasks for very large clusters: docs/running.md,
#: "Scale on paper".
DEFAULT_TASK_SECONDS = 2.0
#: Wall-clock budget of one task (s): see solve_block's time_budget.
DEFAULT_TASK_TIMEOUT = 600.0
#: Converged orbits re-solved at a tighter tolerance for the run's error estimate.
ERROR_SAMPLE = 8
