"""What the stages after the grid share (the atlas, scheduler.atlas_tasks; the traced curves,
scheduler.curve_tasks): the study, its locked store and the lock's owner, where to print, the
run's interrupt guard and command, and the solver's options the stage's tasks integrate with."""
from __future__ import annotations

from typing import TextIO

from hertzmap.kernels.model import contact_loss_level
from hertzmap.scheduler.store import Store
from hertzmap.study.spec import Study


class Stage:
    """A stage of one run of a study into its (locked) store, after its grid."""

    def __init__(self, study: Study, store: Store, out: TextIO, err: TextIO, interrupt,
                 command: str = "hertzmap run", owner: dict | None = None):
        self.study = study
        #: the store's lock record of this run's client (scheduler.store.Lock.owner): workers
        #: write into the store only while it holds it
        self.owner = owner
        self.store = store
        self.out = out
        self.err = err
        self.interrupt = interrupt
        self.command = command
        kw = study.solver_kwargs()
        #: the integration options of the stage's tasks (exponent, model, rtol)
        self.options = {"exponent": kw["exponent"], "model": kw["model"], "rtol": kw["rtol"]}
        #: the contact-loss level (the grazing test)
        self.level = contact_loss_level(kw["model"], kw["exponent"])
