"""What a run does unless told otherwise: the defaults the command line states in its help and
the run uses, declared once (importing this costs nothing, so ``hertzmap --help`` stays quick)."""

#: Target duration of one task (seconds, as estimated by scheduler.plan.seconds_per_point).
#: Dask costs a few ms per task, but the client also writes every finished chunk, one file per
#: variable (~36), and on a small machine shares the cores with the workers: the default study
#: in 77 tasks of one sigma line (~0.3 s each) cost the client 8.6-9.8 s of CPU against
#: 5.6-6.2 s in 26 tasks of three, and its grid 1.09-1.14x the wall (benchmarks/task_size.py).
DEFAULT_TASK_SECONDS = 2.0
#: Wall-clock budget of one task (s): see solve_block's time_budget.
DEFAULT_TASK_TIMEOUT = 600.0
#: Converged orbits re-solved at a tighter tolerance for the run's error estimate.
ERROR_SAMPLE = 8
