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

Why some kernels are linked by symbol. numba links a copy of every callee's optimised code into
each caller's module and optimises and compiles it again there: every entry point held the whole
integrator (about 21,000 LLVM instructions) and spent 1.5-2 s of LLVM on it again, about a
third of a study's cold compile. A kernel declared ``link="symbol"`` (the integrator, its large
steps, shooting) is compiled once: the kernels that call it keep numba's declaration of it
and the JIT resolves the call against its loaded machine code. So that this holds in every
process: its symbol name is the same in every process (numba numbers functions by a
per-process counter, here replaced for these kernels by a hash of their name), and a kernel
loaded from the disk cache first loads every symbol-linked kernel it may call (its globals,
through the kernels it links whole); one being compiled gets them as it is lowered. Code numba
compiles for anything else (a plain ``njit`` function calling a kernel) links all of them
whole, as numba does, so it can be cached and loaded alone. ``HERTZMAP_SYMBOL_LINK=0`` turns
it off (another cache folder).

Why a typing memo. Most of a cold compile is numba's own Python, not LLVM: typing the generated
DOP853 steps (thousands of scalar ``+ - * /`` on float64) asked numba's function templates the
same question at every operation (about 11 templates each, the numpy ufunc loop search among
them): a fifth of the CPU of a first orbit. ``memo_scalar_typing`` keeps the answer numba gave
for a function type and scalar argument types (float, integer, boolean; no literals, no
keywords) and gives it again: the same signature object, so typing, lowering and the machine
code are those numba would make without it. ``HERTZMAP_TYPING_MEMO=0`` turns it off.
"""
from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import time
import types as pytypes
from contextlib import contextmanager

import numba
from numba import njit
from numba.core import bytecode, codegen, sigutils, typing
from numba.core.dispatcher import Dispatcher

try:
    import fcntl
except ImportError:     # not on POSIX: no lock, each process compiles what it needs
    fcntl = None

#: every kernel with a fixed signature, in definition order (modules are imported callees
#: first, so a kernel's callees mostly come before it)
KERNELS: list = []
#: a process waits this long for another's compile before compiling the kernel itself
LOCK_TIMEOUT = 900.0
#: environment variable: how many helper processes a cold first call may start (default: one
#: fewer than the cores, at most 3; 0 = none)
HELPERS_ENV = "HERTZMAP_COMPILE_HELPERS"


#: environment variable: 0 turns the scalar typing memo off (benchmarks/cold_start.py compares)
TYPING_MEMO_ENV = "HERTZMAP_TYPING_MEMO"


def memo_scalar_typing() -> bool:
    """Memoise numba's ``types.Function.get_call_type`` for scalar argument types (see the
    module's docstring). Idempotent; returns whether the memo is on."""
    from numba.core import types
    from numba.core.types import functions

    if os.environ.get(TYPING_MEMO_ENV, "1") == "0":
        return False
    if getattr(functions.Function.get_call_type, "_hertzmap_memo", False):
        return True
    original = functions.Function.get_call_type
    scalar = (types.Float, types.Integer, types.Boolean)
    memo: dict = {}

    def get_call_type(self, context, args, kws):
        if kws or not all(isinstance(a, scalar) and not isinstance(a, types.Literal)
                          for a in args):
            return original(self, context, args, kws)
        key = (self, type(context), tuple(args))
        sig = memo.get(key)
        if sig is None:
            sig = original(self, context, args, kws)
            if sig is not None:     # failures are not kept: numba reports them each time
                memo[key] = sig
        return sig

    get_call_type._hertzmap_memo = True
    functions.Function.get_call_type = get_call_type
    return True


TYPING_MEMO = memo_scalar_typing()


#: environment variable: 0 links every kernel whole into its callers, as numba does
SYMBOL_LINK_ENV = "HERTZMAP_SYMBOL_LINK"
SYMBOL_LINK = os.environ.get(SYMBOL_LINK_ENV, "1") != "0"
#: the Python functions of symbol-linked kernels -> the number numba names them by
_STABLE_IDS: dict = {}
#: mangled name -> code library of every symbol-linked kernel this process has loaded
_SYMBOL_LIBRARIES: dict = {}
#: the kernels compile_once is compiling (innermost last): their own libraries link by symbol
_compiling: list = []


def _stable_id(fn) -> int:
    name = f"{fn.__module__}.{fn.__qualname__}".encode()
    return int(hashlib.sha256(name).hexdigest()[:12], 16)


def _function_identity(cls, pyfunc):
    """numba's FunctionIdentity.from_function, with a symbol-linked kernel's number taken from
    its name: its machine code's symbol is then the same in every process."""
    identity = _original_function_identity(cls, pyfunc)
    uid = _STABLE_IDS.get(pyfunc)
    if uid is not None:
        identity.unique_id = uid
        identity.unique_name = f"{identity.func_qualname}${uid}"
    return identity


def _declares(module, name: str) -> bool:
    try:
        return module.get_function(name).is_declaration
    except NameError:
        return False


def _finalize(self):
    """numba's CPUCodeLibrary.finalize, except that the library of a kernel being compiled does
    not link in the symbol-linked kernels it calls (they stay declarations, resolved by the JIT
    against their loaded code), and any other library links in whole what the linked code calls
    by symbol, so that it can be cached and loaded alone."""
    codegen.require_global_compiler_lock()
    self._codegen._check_llvm_bugs()
    self._raise_if_finalized()
    own = bool(_compiling) and self.name == _compiling[-1].py_func.__qualname__
    linked = set()

    def link(library, whole=True):
        self._reload_init.update(library._reload_init)
        linked.add(library)
        if whole:
            self._final_module.link_in(library._get_module_for_linking(), preserve=True)

    for library in dict.fromkeys(self._linking_libraries):
        link(library, whole=not (own and getattr(library, "_hertzmap_by_symbol", False)))
    while not own:
        missing = [lib for name, lib in _SYMBOL_LIBRARIES.items()
                   if lib not in linked and _declares(self._final_module, name)]
        if not missing:
            break
        for library in missing:
            link(library)
    self._optimize_final_module()
    self._final_module.verify()
    self._finalize_final_module()


if SYMBOL_LINK:
    _original_function_identity = bytecode.FunctionIdentity.from_function.__func__
    bytecode.FunctionIdentity.from_function = classmethod(_function_identity)
    codegen.CPUCodeLibrary.finalize = _finalize


def _called_dispatchers(fn) -> list:
    """The numba dispatchers among the global names ``fn`` (and its nested code) uses."""
    names, stack = set(), [fn.__code__]
    while stack:
        code = stack.pop()
        names.update(code.co_names)
        stack.extend(c for c in code.co_consts if isinstance(c, pytypes.CodeType))
    found = (fn.__globals__.get(n) for n in sorted(names))
    return [d for d in found if isinstance(d, Dispatcher)]


def symbol_callees(dispatcher) -> list:
    """The symbol-linked kernels the machine code of ``dispatcher`` may call by symbol: those
    its function calls, and those called by the kernels it links whole (the walk stops at a
    symbol-linked kernel: loading it loads its own)."""
    found = getattr(dispatcher, "_symbol_callees", None)
    if found is None:
        found, seen, todo = [], {dispatcher}, [dispatcher]
        while todo:
            for callee in _called_dispatchers(todo.pop().py_func):
                if callee in seen:
                    continue
                seen.add(callee)
                if getattr(callee, "link_by_symbol", False):
                    found.append(callee)
                else:
                    todo.append(callee)
        dispatcher._symbol_callees = found
    return found


def kernel(signature=None, *, inline: str | None = None, cache: bool = True, link: str = "ir"):
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

    ``link="symbol"`` (with a signature, not inlined): the kernels that call it call its one
    compiled copy instead of holding their own (see the module's docstring). For large kernels
    called from several others; a small one in a hot loop stays ``"ir"``, where LLVM may
    inline it.
    """
    if link not in ("ir", "symbol"):
        raise ValueError(f"link must be 'ir' or 'symbol', not {link!r}")

    def wrap(fn):
        by_symbol = link == "symbol" and signature is not None and inline is None
        if by_symbol and SYMBOL_LINK:
            _STABLE_IDS[fn] = _stable_id(fn)
        dispatcher = njit(cache=cache, nogil=True, forceinline=inline == "llvm",
                          inline="always" if inline == "ir" else "never")(fn)
        dispatcher.link_by_symbol = by_symbol and SYMBOL_LINK
        if signature is not None:
            _fix_signature(dispatcher, signature, locked=cache, deferred=inline != "ir")
            if inline != "ir":
                KERNELS.append(dispatcher)
        return dispatcher
    return wrap


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
                if in_disk_cache(dispatcher):
                    # loading: what its machine code calls by symbol must be in this process
                    # first (compiling, its lowering loads them)
                    for callee in symbol_callees(dispatcher):
                        callee.compile_fixed()
                _compiling.append(dispatcher)
                try:
                    # after another process's compile this loads its entry from the disk cache
                    dispatcher.compile(signature)
                finally:
                    _compiling.pop()
            dispatcher.disable_compile()
            if dispatcher.link_by_symbol:
                cres = dispatcher.overloads[dispatcher.signatures[0]]
                cres.library._hertzmap_by_symbol = True
                _SYMBOL_LIBRARIES[cres.fndesc.mangled_name] = cres.library

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
            compile_shared(dispatcher.py_func.__module__.split(".")[0], 0, 1, backward=False)
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
    return not dispatcher._can_compile


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
    return dispatcher.py_func.__module__.rsplit(".", 1)[-1]


def leaf_kernels() -> list:
    """The leaf kernels (LEAF_MODULES) of the kernels package defined so far (``import
    kernels`` defines them all), in definition order: the first of its shared stages."""
    return shared_stages("kernels")[0]


def shared_stages(package: str) -> list[list]:
    """What every integrating entry point compiles below ``integrate``, in two stages of
    independent kernels, each in definition order: the leaves (LEAF_MODULES: the DOP853 steps
    are most of it), then the integrator's own small kernels (which call the leaves)."""
    mine = [d for d in KERNELS if d.py_func.__module__.split(".")[0] == package]
    return [[d for d in mine if _module_tail(d) in LEAF_MODULES],
            [d for d in mine if _module_tail(d) == INTEGRATOR_MODULE
             and d.py_func.__name__ != "integrate"]]


def compile_shared(package: str, index: int, count: int, backward: bool) -> int:
    """Compile shared_stages stage by stage, each from its start (``backward``: from its end),
    rotated to the index-th of count shares: processes that take different ends and shares
    split each stage between them and meet inside it, the heavy leaves included, before the
    next stage (whose kernels call them). Returns how many were compiled or loaded."""
    done = 0
    for stage in shared_stages(package):
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
    package = entry.py_func.__module__.split(".")[0]
    # a helper compiles the shared stages (everything ``integrate`` calls)
    if all(compiled(d) for stage in shared_stages(package) for d in stage):
        return 0
    root = os.path.dirname(os.path.dirname(sys.modules[package].__file__))
    env = dict(os.environ, **{HELPERS_ENV: "0"})
    code = (f"import sys; sys.path.insert(0, {root!r}); "
            f"from {package}._jit import run_helper; run_helper({package!r}, {{i}}, {n})")
    _helpers_started = True
    for i in range(n):
        _helpers.append(subprocess.Popen(
            [sys.executable, "-c", code.format(i=i)], env=env, stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True))
    return n


def run_helper(package: str, index: int, count: int) -> None:
    """A helper process's work: compile_shared backwards, from its share of each stage."""
    import importlib
    importlib.import_module(package)      # sets the cache folder
    integrator = importlib.import_module(package + "." + INTEGRATOR_MODULE)
    compile_shared(package, index, count, backward=True)
    # then the integrator itself, while the first call types its own kernel (which needs only
    # the integrator's signature until it is lowered)
    if index == 0:
        compile_kernels([integrator.integrate])
