"""kernels._jit: importing compiles nothing, a first orbit compiles only the shooting path and
each kernel once, and processes sharing a cache wait for each other's compile instead of
repeating it. Each case runs in a new process with an empty numba cache."""
from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import pytest

from tests.helpers import REPO, subprocess_env

#: collects every numba compile of the child process: (module, function, signature count)
LISTEN = textwrap.dedent("""
    import json, sys
    from numba.core import event
    compiled = []
    class Listener(event.Listener):
        def on_start(self, ev):
            pass
        def on_end(self, ev):
            f = ev.data["dispatcher"].py_func
            compiled.append(f.__module__ + "." + f.__qualname__)
    event.register("numba:compile", Listener())
""")


def _run(code: str, cache, **env) -> dict:
    r = subprocess.run([sys.executable, "-c", LISTEN + textwrap.dedent(code)], cwd=REPO,
                       env=subprocess_env(NUMBA_CACHE_DIR=str(cache), **env),
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_importing_the_kernels_and_the_study_layer_compiles_nothing(tmp_path):
    out = _run("""
        import hertzmap.kernels.attractors, hertzmap.kernels.continuation
        import hertzmap.kernels.central_difference
        import hertzmap.study.schema, hertzmap.study.solve.block, hertzmap.study.products
        from hertzmap import kernels
        import os
        print(json.dumps({"compiled": compiled, "files": sorted(
            f for _, _, fs in os.walk(kernels.CACHE_DIR) for f in fs)}))
    """, tmp_path)
    assert out["compiled"] == []
    assert out["files"] == []


@pytest.mark.slow
def test_a_first_orbit_compiles_the_shooting_path_once(tmp_path):
    """No attractor, continuation or baseline kernel, and one specialisation of everything
    compiled (a literal argument used to make more: four copies of the integrator)."""
    out = _run("""
        from hertzmap import kernels
        from hertzmap.kernels._jit import KERNELS
        o = kernels.shoot(1.5, 0.2, 0.01, 1, guess=(-0.16, 0.006))
        mine = [k for k in compiled if k.startswith("hertzmap.kernels.")]
        print(json.dumps({"converged": bool(o.converged), "compiled": mine,
                          "signatures": {d.py_func.__qualname__: len(d.signatures)
                                         for d in KERNELS if d.signatures}}))
    """, tmp_path, HERTZMAP_COMPILE_HELPERS="0")
    assert out["converged"]
    modules = {k.rsplit(".", 1)[0] for k in out["compiled"]}
    assert modules <= {"hertzmap.kernels.model", "hertzmap.kernels.flight", "hertzmap.kernels._dop853",
                       "hertzmap.kernels.integrate", "hertzmap.kernels.shooting"}, modules
    assert "hertzmap.kernels.integrate.integrate" in out["compiled"]
    assert len(out["compiled"]) == len(set(out["compiled"])), "a kernel compiled twice"
    assert set(out["signatures"].values()) == {1}


def test_a_second_process_waits_for_the_compile_and_loads_it(tmp_path):
    """This process holds a kernel's compile lock while a second process asks for the same
    kernel; only then does it compile (into the shared cache) and let go. The second process
    must have waited: it loads the kernel from the cache instead of compiling it."""
    code = """
        import json, sys
        from hertzmap import kernels
        from hertzmap.kernels.model import cos_shifted
        print("asking", flush=True)
        cos_shifted.compile_fixed()
        print(json.dumps({"hits": sum(cos_shifted.stats.cache_hits.values()),
                          "misses": sum(cos_shifted.stats.cache_misses.values())}))
    """
    env = subprocess_env(NUMBA_CACHE_DIR=str(tmp_path), HERTZMAP_COMPILE_HELPERS="0")
    script = f"import os; os.environ['NUMBA_CACHE_DIR'] = {str(tmp_path)!r}\n"
    parent = subprocess.Popen(
        [sys.executable, "-c", script + textwrap.dedent(f"""
            import subprocess, sys, time
            from hertzmap import kernels
            from hertzmap.kernels._jit import _compile_lock
            from hertzmap.kernels.model import cos_shifted
            with _compile_lock(cos_shifted):
                child = subprocess.Popen([sys.executable, "-c", {textwrap.dedent(code)!r}],
                                         stdout=subprocess.PIPE, text=True)
                assert child.stdout.readline().strip() == "asking"
                time.sleep(1.0)     # the child would compile now if the lock did not hold it
                cos_shifted.compile(cos_shifted.fixed_signature)
            print(child.communicate()[0].strip().splitlines()[-1])
        """)], cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    out, err = parent.communicate(timeout=600)
    assert parent.returncode == 0, err[-3000:]
    child = json.loads(out.strip().splitlines()[-1])
    assert child == {"hits": 1, "misses": 0}


@pytest.mark.slow
def test_a_plain_njit_caller_of_a_kernel_is_cached_and_loads_alone(tmp_path):
    """A user's cached njit function that calls a kernel (the fixed signature's lazy compile
    included, and the kernels it calls in turn: flight_state -> _state, _phi12E -> _phi12)
    compiles once, and a new process loads it from numba's cache and runs it before any
    kernel is loaded. The flight it returns is scipy's (benchmarks.oracle.flow: the contact
    force is zero below q = -n)."""
    from benchmarks import oracle

    (tmp_path / "caller.py").write_text(textwrap.dedent("""
        from numba import njit
        from hertzmap.kernels.flight import flight_state

        @njit(cache=True)
        def fly(q0, v0, s):
            return flight_state(q0, v0, 0.3, s, 1.5, 0.2, 0.01)
    """))
    code = """
        import sys
        sys.path.insert(0, {folder!r})
        from caller import fly
        q, v, _, _ = fly(-3.0, 0.5, 0.4)
        print(json.dumps({{"q": q, "v": v,
                          "compiled": [k for k in compiled if k.startswith("hertzmap.kernels.")],
                          "caller": [k for k in compiled if k.startswith("caller.")]}}))
    """.format(folder=str(tmp_path))
    cache = tmp_path / "cache"
    first = _run(code, cache, HERTZMAP_COMPILE_HELPERS="0")
    again = _run(code, cache, HERTZMAP_COMPILE_HELPERS="0")
    assert first["caller"] == ["caller.fly"]
    assert "hertzmap.kernels.flight.flight_state" in first["compiled"]
    assert again["caller"] == [] and again["compiled"] == []
    assert (again["q"], again["v"]) == (first["q"], first["v"])
    q, v = oracle.flow((-3.0, 0.5), 0.3, 0.7, 1.5, 0.2, 0.01)
    assert q < -1.5 and abs(first["q"] - q) < 1e-10 and abs(first["v"] - v) < 1e-10


def test_the_installed_numba_is_one_the_lazy_signature_was_checked_on():
    """The lazy fixed signature reads private members of numba's dispatcher: it is on only for
    the versions in CHECKED_NUMBA, and the lock installs one of them. When the lock moves numba
    forward this fails: run the whole suite with the new version, then add it there."""
    import numba

    from hertzmap.kernels._jit import CHECKED_NUMBA, LAZY_SIGNATURES
    assert numba.__version__ in CHECKED_NUMBA
    assert LAZY_SIGNATURES


def test_on_another_numba_version_kernels_are_plain_njit_with_the_same_results(tmp_path):
    """With a numba version not in CHECKED_NUMBA, no dispatcher method is replaced and a kernel
    called from Python and from a jitted caller gives, to the bit, what the lazy signature
    gives."""
    code = """
        import numba
        if {fake!r}:
            numba.__version__ = "0.0.0"
        from numba import njit
        from hertzmap.kernels import _jit
        from hertzmap.kernels.model import cos_shifted
        @njit
        def caller(x):
            return cos_shifted(0.6, 0.8, 0.6435011087932844, x)
        print(json.dumps({{"lazy": _jit.LAZY_SIGNATURES,
                          "replaced": sorted(k for k in ("_compile_for_args", "get_call_template",
                                                         "get_overload") if k in vars(cos_shifted)),
                          "values": [cos_shifted(0.6, 0.8, 0.6435011087932844, t).hex()
                                     for t in (0.3, -0.9, 1.7)] + [caller(0.25).hex()]}}))
    """
    lazy = _run(code.format(fake=False), tmp_path / "lazy", HERTZMAP_COMPILE_HELPERS="0")
    plain = _run(code.format(fake=True), tmp_path / "plain", HERTZMAP_COMPILE_HELPERS="0")
    assert lazy["lazy"] and lazy["replaced"] == ["_compile_for_args", "get_call_template",
                                                 "get_overload"]
    assert not plain["lazy"] and plain["replaced"] == []
    assert plain["values"] == lazy["values"]
