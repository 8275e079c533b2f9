"""How the kernels are compiled: ``kernel``, numba's njit with one fixed signature compiled (or
loaded from the disk cache) on first use, never at import.

Why. numba compiles a function decorated with a signature when the module is imported; without
one, it compiles a new specialisation for every new combination of argument types, and a
constant argument in a caller (``integrate(..., True, False, ...)``, ``mode = MODE_T``) is a
*literal* type: each constant seen made another copy of the integrator (four of
``integrate`` and two of ``_locate_crossing`` for one orbit and a study, each compiled in full).
A ``kernel`` has exactly one specialisation, its signature: callers' literal arguments convert
to it; and nothing compiles before something calls it, so ``import kernels`` (which every
process of a study does, the client included) compiles nothing, and a process that only
shoots never compiles the attractor code.
"""
from __future__ import annotations

from numba import njit


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
      so it is typed again at every call site, but it is no library of its own. For thin
      wrappers, which would otherwise cost a full compile of everything below them.
    """
    def wrap(fn):
        dispatcher = njit(cache=cache, nogil=True, forceinline=inline == "llvm",
                          inline="always" if inline == "ir" else "never")(fn)
        if signature is not None:
            _fix_signature(dispatcher, signature)
        return dispatcher
    return wrap


def _fix_signature(dispatcher, signature) -> None:
    """Compile ``signature`` when the dispatcher is first typed (by a jitted caller) or called
    (from Python), then disable compilation: every later call resolves to that one overload."""
    typed_call = dispatcher.get_call_template

    def compile_once():
        if dispatcher._can_compile:
            dispatcher.compile(signature)
            dispatcher.disable_compile()

    def get_call_template(args, kws):
        compile_once()
        return typed_call(args, kws)

    def _compile_for_args(*args, **kws):
        # the C dispatcher found no overload and calls what this returns with the same
        # arguments: the dispatcher itself, now holding the signature (an argument that does
        # not convert to it gets numba's TypeError: compilation is disabled)
        compile_once()
        return dispatcher

    dispatcher.get_call_template = get_call_template
    dispatcher._compile_for_args = _compile_for_args
    dispatcher.fixed_signature = signature
