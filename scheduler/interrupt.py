"""Ctrl-C during a run: never between a block's write and its ``task_done`` flag."""
from __future__ import annotations

import contextlib
import signal
import threading


class DeferInterrupt:
    """SIGINT (Ctrl-C) raises KeyboardInterrupt at once, except inside :meth:`critical`
    (a block write and its flag, a history line), where it is deferred to the section's end.
    Only in the main thread (signal handlers cannot be set elsewhere)."""

    def __init__(self):
        self.pending = False
        self.inside = False
        self.old = None

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            self.old = signal.signal(signal.SIGINT, self._handler)
        return self

    def __exit__(self, *exc):
        if self.old is not None:
            signal.signal(signal.SIGINT, self.old)
            self.old = None

    def _handler(self, signum, frame):
        if self.inside:
            self.pending = True
        else:
            raise KeyboardInterrupt

    @contextlib.contextmanager
    def critical(self):
        self.inside = True
        try:
            yield
        finally:
            self.inside = False
        if self.pending:
            self.pending = False
            raise KeyboardInterrupt
