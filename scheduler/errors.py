"""The ways a command is refused before it writes anything (the command line exits with code 2).

Each message names what is wrong (the option, the store, the field) and what is allowed.
"""


class RefusedError(Exception):
    """A command cannot start as asked: nothing was created or changed."""


class ClusterError(RefusedError):
    """The cluster cannot be set up as asked (bad option, missing optional dependency,
    unreachable scheduler, a batch system that rejects the job)."""


class StoreError(RefusedError):
    """The store cannot be used (belongs to another study, is not a zarr store, is locked...)."""


class RunError(RefusedError):
    """The run cannot start (the solver is missing, the study does not fit on the disk or in
    memory)."""
