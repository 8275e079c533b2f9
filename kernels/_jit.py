"""How the kernels are compiled: ``kernel``, numba's njit with one fixed signature compiled (or
loaded from the disk cache) on first use, never at import, and compiled by one process at a
time for all the processes that share the cache.

Why one signature, on first use. numba compiles a function decorated with a signature when
its module is imported; without one, it compiles a new specialisation for every new combination
of argument types, and a constant argument in a caller (``integrate(..., True, False, ...)``,
``mode = MODE_T``) is a *literal* type: each constant seen made another copy of the integrator
(four of ``integrate`` and two of ``_locate_crossing`` for one orbit and a study, each compiled
in full). A ``kernel`` has exactly one specialisation, its signature: callers' literal arguments
convert to it; and nothing compiles before something calls it, so ``import kernels`` (which
every process of a study does, the client included) compiles nothing, and a process that only
shoots never compiles the attractor code.

Why a lock. The workers of a study start together and, with an empty cache, each compiled
every kernel itself, at the same time (the same minute of CPU, once per worker). A kernel is
now compiled under an exclusive lock on a file next to its cache entry: a second process that
needs it waits, then loads the first one's machine code from the disk cache. Processes that
walk the kernels in different orders (``compile_kernels``) share the work instead of repeating
it. The lock is released when its holder ends, however it ends (``flock``); where it cannot be
taken (no ``fcntl``, a read-only cache) kernels compile as before.

Why helper processes. A kernel called from Python with nothing of it in the disk cache (a new
clone, venv, version or node) compiles its whole tree: about 20 s of one core for the first
orbit, most of it in the leaves (the generated DOP853 steps) that do not depend on each other.
That first call starts HELPERS background processes (at most one fewer than the cores) that
compile the leaves, then the integrator's small kernels, from the other end of each list,
under the same locks, while this process compiles the same lists from their start (before its
own tree: typing it in call order made this process wait on the helper's lock of a kernel
whose callees the helper then compiled alone) and loads what they have finished. The first
helper then compiles the integrator while this process types its own kernel (typing needs
only the integrator's signature: ``_fix_signature``); they exit when that is done.
``HERTZMAP_COMPILE_HELPERS=0`` turns them off.

What is numba's own and what is not. No class of numba's is patched: an earlier version linked
the large kernels by symbol (replacing ``CPUCodeLibrary.finalize`` and
``FunctionIdentity.from_function``) and memoised numba's scalar typing (replacing
``types.Function.get_call_type``) for a quicker cold compile, which made every numba release a
new risk for every numba user in the process. What stays, the fixed signature compiled on
first use, sets methods on the kernels' own dispatcher objects and reads three of their private
members (``_can_compile``, ``_compile_for_args``, ``_compiler.fold_argument_types``); it is on
only for the numba versions in CHECKED_NUMBA, which tests/kernels/test_jit.py pins (the lock
file installs one of them). On any other version ``kernel`` is numba's plain lazy ``njit``: the same arithmetic, without the lock and the
helpers, and possibly more than one specialisation of a kernel.
"""
from __future__ import annotations

import os
import subprocess
import sys
import time
from contextlib import contextmanager

import numba
from numba import njit
from numba.core import sigutils, typing

try:
    import fcntl
except ImportError:     # not on POSIX: no lock, each process compiles what it needs
    fcntl = None

#: the numba versions the lazy fixed signature (``_fix_signature``) was checked on: the whole
#: test suite passed with each (uv.lock pins one). On any other, kernels are plain njit.
CHECKED_NUMBA = ("0.68.1",)
LAZY_SIGNATURES = numba.__version__ in CHECKED_NUMBA

#: every kernel with a fixed signature, in definition order (modules are imported callees
#: first, so a kernel's callees mostly come before it)
KERNELS: list = []
#: a process waits this long for another's compile before compiling the kernel itself
LOCK_TIMEOUT = 900.0
#: environment variable: how many helper processes a cold first call may start (default: one
#: fewer than the cores, at most 3; 0 = none)
HELPERS_ENV = "HERTZMAP_COMPILE_HELPERS"


def kernel(signature=None, *, inline: str | None = None, cache: bool = True):
    """``numba.njit(cache=True, nogil=True)`` with ``signature`` compiled on first use.

    Calls from Python and from other jitted functions with other argument types convert to the
    signature (as with an eager signature) or fail with numba's TypeError; no other
    specialisation is ever compiled. Without ``signature``: plain lazy njit (one
    specialisation per argument types).

    Every compiled function is a library of machine code that holds a copy of everything it
    calls, optimised and compiled again with it: a chain of thin wrappers over the integrator
    compiles the integrator once per link. ``inline`` chooses how a function joins its callers:

    * ``"llvm"`` (numba's ``forceinline``): typed and lowered once, then LLVM inlines it into
      each caller, as if written there. For large bodies in hot loops (the DOP853 step).
    * ``"ir"`` (numba's ``inline='always'``): its IR is copied into each caller before typing,
      so it is typed again at every call site (with the caller's argument types: the signature
      documents them), but it is no library of its own. For thin wrappers, which would
      otherwise cost a full compile of everything below them.
    """
    def wrap(fn):
        options = dict(cache=cache, nogil=True, forceinline=inline == "llvm",
                       inline="always" if inline == "ir" else "never")
        if not LAZY_SIGNATURES:
            return _plain(fn, signature, inline, options)
        dispatcher = njit(**options)(fn)
        if signature is not None:
            _fix_signature(dispatcher, signature, locked=cache, deferred=inline != "ir")
            if inline != "ir":
                KERNELS.append(dispatcher)
        return dispatcher
    return wrap


def _plain(fn, signature, inline, options):
    """numba's own lazy njit, for the numba versions the fixed signature was not checked on:
    one specialisation per argument types (a caller's literal arguments may compile more than
    one), ``compile_fixed`` compiles the signature (the workers' warm-up)."""
    dispatcher = njit(**options)(fn)
    if signature is not None and inline != "ir":
        dispatcher.fixed_signature = signature
        dispatcher.compile_fixed = lambda: dispatcher.compile(signature)
        KERNELS.append(dispatcher)
    return dispatcher


def _fix_signature(dispatcher, signature, locked: bool, deferred: bool) -> None:
    """Compile ``signature`` when the dispatcher is first called (from Python) or, with
    ``deferred``, when a jitted caller is lowered (else when it is typed), then disable
    compilation: every later call resolves to that one overload.

    Why deferred. Typing a call needs only the callee's signature, which is fixed; its machine
    code is needed when the caller is lowered and linked. So a caller is typed while another
    process compiles its callee (a first orbit types shoot_into while the helper compiles the
    integrator), and waits for it only then."""
    typed_call = dispatcher.get_call_template
    overload = dispatcher.get_overload
    fixed = []

    def compile_once():
        if dispatcher._can_compile:
            with (_compile_lock(dispatcher) if locked else _no_lock()):
                # after another process's compile this loads its entry from the disk cache
                dispatcher.compile(signature)
            dispatcher.disable_compile()

    def get_call_template(args, kws):
        if not deferred or not dispatcher._can_compile:
            compile_once()
            return typed_call(args, kws)
        # numba's Dispatcher.get_call_template, with the fixed signature in place of the
        # compiled overloads'
        pysig, args = dispatcher._compiler.fold_argument_types(args, kws)
        if not fixed:
            arg_types, return_type = sigutils.normalize_signature(signature)
            fixed.append(typing.signature(return_type, *arg_types))
        name = dispatcher.py_func.__name__
        template = typing.make_concrete_template(f"CallTemplate({name})", key=name,
                                                 signatures=fixed)
        return template, pysig, args, {}

    def get_overload(sig):
        compile_once()
        return overload(sig)

    def _compile_for_args(*args, **kws):
        # the C dispatcher found no overload and calls what this returns with the same
        # arguments: the dispatcher itself, now holding the signature (an argument that does
        # not convert to it gets numba's TypeError: compilation is disabled)
        if dispatcher._can_compile and start_helpers(dispatcher):
            # this process's share of what the helpers compile, from the other end, before the
            # entry's own tree
            compile_shared(0, 1, backward=False)
        compile_once()
        return dispatcher

    dispatcher.get_call_template = get_call_template
    dispatcher.get_overload = get_overload
    dispatcher._compile_for_args = _compile_for_args
    dispatcher.fixed_signature = signature
    dispatcher.compile_fixed = compile_once


def _cache_index(dispatcher) -> str | None:
    """The path of the kernel's numba cache index; None for a kernel without a disk cache."""
    cache_file = getattr(getattr(dispatcher, "_cache", None), "_cache_file", None)
    return None if cache_file is None else cache_file._index_path


def in_disk_cache(dispatcher) -> bool:
    """Has some process written this kernel into the disk cache (so that compiling it will
    load it)? Without a cache: False."""
    index = _cache_index(dispatcher)
    return index is not None and os.path.exists(index)


def compiled(dispatcher) -> bool:
    """Has this process compiled or loaded the kernel yet?"""
    return bool(dispatcher.signatures)


def compile_kernels(dispatchers) -> int:
    """Compile (or load from the disk cache) each kernel in the given order; returns how many
    were compiled or loaded now. Processes that share a cache and call this with different
    orders split the compile work between them (each kernel is compiled once, under its lock)."""
    done = 0
    for d in dispatchers:
        if not compiled(d):
            d.compile_fixed()
            done += 1
    return done


def kernel_name(dispatcher) -> str:
    return f"{dispatcher.py_func.__module__}.{dispatcher.py_func.__qualname__}"


_held: set[str] = set()


@contextmanager
def _no_lock():
    yield


@contextmanager
def _compile_lock(dispatcher):
    """An exclusive flock on ``<cache dir>/locks/<kernel>.compiling`` while the kernel
    compiles; the wait is bounded (LOCK_TIMEOUT) and any failure to lock means compiling
    without it. (The numba cache's own lock: the store's locks are scheduler.store's.)"""
    name = kernel_name(dispatcher)
    if fcntl is None or name in _held:
        yield
        return
    fd = None
    try:
        folder = os.path.join(numba.config.CACHE_DIR or ".", "locks")
        os.makedirs(folder, exist_ok=True)
        fd = os.open(os.path.join(folder, name + ".compiling"), os.O_RDWR | os.O_CREAT, 0o666)
        deadline = time.monotonic() + LOCK_TIMEOUT
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                if time.monotonic() > deadline:
                    raise TimeoutError(name) from None
                time.sleep(0.02)
    except (OSError, TimeoutError):
        if fd is not None:
            os.close(fd)
        yield
        return
    _held.add(name)
    try:
        yield
    finally:
        _held.discard(name)
        os.close(fd)        # releases the lock


#: modules whose kernels call no other module's kernels but the model's: the leaves of every
#: compiled entry point (the DOP853 steps are most of a cold compile)
LEAF_MODULES = ("model", "flight", "_dop853")
#: the integrator's module: its kernels other than ``integrate`` are independent of each other
INTEGRATOR_MODULE = "integrate"


def _module_tail(dispatcher) -> str:
    """The kernels module (or subpackage: ``continuation`` for kernels.continuation.core) that
    defines the kernel."""
    package = __name__.rpartition(".")[0]
    return dispatcher.py_func.__module__.removeprefix(package + ".").split(".")[0]


def leaf_kernels() -> list:
    """The leaf kernels (LEAF_MODULES) defined so far (``import hertzmap.kernels`` defines
    them all), in definition order: the first of the shared stages."""
    return shared_stages()[0]


def shared_stages() -> list[list]:
    """What every integrating entry point compiles below ``integrate``, in two stages of
    independent kernels, each in definition order: the leaves (LEAF_MODULES: the DOP853 steps
    are most of it), then the integrator's own small kernels (which call the leaves)."""
    return [[d for d in KERNELS if _module_tail(d) in LEAF_MODULES],
            [d for d in KERNELS if _module_tail(d) == INTEGRATOR_MODULE
             and d.py_func.__name__ != "integrate"]]


def compile_shared(index: int, count: int, backward: bool) -> int:
    """Compile shared_stages stage by stage, each from its start (``backward``: from its end),
    rotated to the index-th of count shares: processes that take different ends and shares
    split each stage between them and meet inside it, the heavy leaves included, before the
    next stage (whose kernels call them). Returns how many were compiled or loaded."""
    done = 0
    for stage in shared_stages():
        todo = stage[::-1] if backward else stage
        start = index * len(todo) // count
        done += compile_kernels(todo[start:] + todo[:start])
    return done


#: modules whose kernels call the integrator: a cold first call of one of theirs is worth the
#: helpers (a kernel of another module, e.g. the baseline's, compiles alone)
INTEGRATOR_USERS = (INTEGRATOR_MODULE, "shooting", "continuation", "attractors")


_helpers_started = False
_helpers: list[subprocess.Popen] = []     # kept, so that they are reaped, not warned about


def helper_count() -> int:
    value = os.environ.get(HELPERS_ENV)
    if value is not None:
        try:
            return max(0, int(value))
        except ValueError:
            return 0
    return max(0, min(3, (os.cpu_count() or 1) - 1))


def start_helpers(entry) -> int:
    """Before ``entry`` (a kernel of INTEGRATOR_USERS called from Python) compiles with
    nothing in the disk cache: start helper processes that compile compile_shared() from the
    other end (helper i of n starts at its own share of each stage, backwards). Returns how
    many were started (0 when the entry is cached or integrates nothing, the helpers already
    ran in this process, or HELPERS_ENV says 0)."""
    global _helpers_started
    n = helper_count()
    if n == 0 or _helpers_started or fcntl is None:
        return 0
    if _module_tail(entry) not in INTEGRATOR_USERS:
        return 0
    index = _cache_index(entry)
    if index is None or os.path.exists(index):
        return 0        # no cache, or in it (nothing to share)
    # a helper compiles the shared stages (everything ``integrate`` calls)
    if all(compiled(d) for stage in shared_stages() for d in stage):
        return 0
    env = dict(os.environ, **{HELPERS_ENV: "0"})
    code = f"from {__name__} import run_helper; run_helper({{i}}, {n})"
    _helpers_started = True
    for i in range(n):
        _helpers.append(subprocess.Popen(
            [sys.executable, "-c", code.format(i=i)], env=env, stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True))
    return n


def run_helper(index: int, count: int) -> None:
    """A helper process's work: compile_shared backwards, from its share of each stage."""
    import importlib
    package = __name__.rpartition(".")[0]
    importlib.import_module(package)      # sets the cache folder
    integrator = importlib.import_module(package + "." + INTEGRATOR_MODULE)
    compile_shared(index, count, backward=True)
    # then the integrator itself, while the first call types its own kernel (which needs only
    # the integrator's signature until it is lowered)
    if index == 0:
        compile_kernels([integrator.integrate])
