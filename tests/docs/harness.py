"""Runs what the docs ask a reader to run, the way a reader would, on small stores.

Two folders stand in for a clone of the repository:

* the **small** workspace, where commands are executed: ``scenes/`` holds every scene with its
  grid cut down to a few points of the original grid (:data:`SMALL`: the same grid values, so a
  number read off a store is the one the full scene gives wherever the cut keeps what it depends
  on), ``results/`` starts empty, and ``.venv``, ``benchmarks/``, ``scripts/``, ``tests/`` point
  at the repository's. ``hertzmap run scenes/X.toml`` there makes a small ``results/X.zarr``.
* the **real** workspace (``scenes/`` is the repository's), where the commands marked ``long``
  or ``cluster`` are dry-run and every ``hertzmap run`` of a scene is dry-run too (the real study
  file is valid and plans).

:func:`check_command`, :func:`check_python`, :func:`check_toml` run one command or block and
raise :class:`DocError` naming the file and line when the reader would meet an error, an
output that differs from the sample, or a number that differs from the text.
"""
from __future__ import annotations

import ast
import contextlib
import io
import math
import os
import re
import shlex
import subprocess
import sys
import tomllib
import warnings
from dataclasses import dataclass
from pathlib import Path

from tests.docs.markdown import Block, Command, Marker

REPO = Path(__file__).resolve().parents[2]

#: every page whose commands and snippets are under test
DOC_FILES = (["README.md", "VALIDATION.md", "BENCHMARKS.md", "RELIABILITY.md"]
             + sorted(f"docs/{p.name}" for p in (REPO / "docs").glob("*.md")))

#: the scenes cut down for the small workspace: axis -> slice of the scene's own grid values
#: (or a list of indices), and the outputs kept. What each cut keeps, and for which doc:
SMALL: dict[str, dict] = {
    # the flip minimum near (2.0, 0.36) (VALIDATION row 4), sigma = 0.5 (dataset.md)
    "default": {"omega": slice(112, 129), "sigma": slice(20, 37)},
    # the README runs it as a speed example: a corner of stable 1T orbits in contact
    "fine_map": {"omega": slice(0, 5), "sigma": slice(0, 5)},
    "fig03": {"omega": slice(30, 50), "sigma": slice(5, 15), "outputs": ["orbits", "measures"]},
    # the whole line: the 2T branch is followed from omega = 2 down to its fold at 0.472 (rows 7-9)
    "fig06": {},
    # around the flip minimum (2.0, 0.18), without the traced curves: row 3's grid minimum
    # (a parabola through the lowest three crossings: the same grid values, the same number)
    "fig07": {"omega": slice(50, 70), "sigma": slice(0, 20), "outputs": ["orbits", "measures"]},
    "fig08": {"omega": slice(100, 420, 4)},
    # the sigma lines of row 10 (0.16, 0.17) and of the join (0.36, 0.37); traced curves kept
    "fig09": {"sigma": [6, 7, 26, 27]},
    # the located points of the worked query of dataset.md (sigma = 0.42), no traced curves
    "fig09_bifurcations": {"omega": slice(10, 31), "sigma": slice(0, 3),
                           "outputs": ["orbits", "measures", "bifurcations"]},
    "fig10": {"omega": slice(440, 481)},
    "fig12": {"omega": slice(80, 121)},
    # the whole line: the stable 2T with contact loss from the grid's start (row 14)
    "fig13": {},
    "fig14": {},
    "fig15": {},
    # two zeta values (0.005, 0.01) near omega = 2 with the thresholds stage: the worked query
    # "sigma* for each zeta" of dataset.md (sigma* needs no grid point; sigma** is NaN: the
    # isola's lowest point is off this grid)
    "damping": {"omega": slice(31, 33), "sigma": slice(2, 4), "zeta": [1, 3],
                "outputs": ["orbits", "measures", "thresholds"]},
    # a chaotic point (0.5, 2.5) and its neighbours: the census query of dataset.md
    "vibro_impact": {"omega": slice(7, 9), "sigma": slice(48, 50)},
    # the whole line (167 omega values, about 10 s): the down sweep must start above the 1T
    # flip to follow the 2T response down to its fold at 0.4721, the up sweep cross the flip at
    # 1.9776 (the jumps of dataset.md's worked query and of VALIDATION.md)
    "sweeps": {},
}

#: what replaces a scene name in text (the figures' own folder is the repository's)
STORE_RE = re.compile(r"results/([A-Za-z0-9_.-]+?)\.zarr")
STUDY_RE = re.compile(r"scenes/([A-Za-z0-9_.-]+?)\.toml")
PLACEHOLDER = re.compile(r"\b(STUDY|STORE|PATH|ADDRESS|KEY|VALUE|PID|JOBID|TESTS|REV|N|S|FIG|NAME|DIR|"
                         r"NN|OLD)\b|<[^>]*>|\.\.\.|\[[^\]=]*\]|figNN|\bx\.zarr|study\.toml|"
                         r"tiny\.toml|big\.toml")


class DocError(AssertionError):
    """What a reader following the docs would meet."""


@dataclass
class Result:
    argv: str
    returncode: int
    stdout: str
    stderr: str

    @property
    def output(self) -> str:
        return self.stdout + self.stderr


# -- study files -----------------------------------------------------------------------------

def small_study(path: Path) -> str:
    """The study file ``path`` with its grid cut to :data:`SMALL` (its name kept)."""
    from hertzmap.study.spec import load_study, study_toml

    cut = SMALL[path.stem]
    doc = tomllib.loads(path.read_text())
    study = load_study(path)
    for axis in ("omega", "sigma", "zeta"):
        if axis in cut:
            values = study.axis(axis)
            pick = cut[axis]
            chosen = values[pick] if isinstance(pick, slice) else values[list(pick)]
            doc["grid"][axis] = [float(v) for v in chosen]
    if "outputs" in cut:
        doc.setdefault("products", {})["outputs"] = cut["outputs"]
    doc.setdefault("study", {})["name"] = study.name
    return ("# a cut-down copy for the doc tests (tests/docs/harness.py SMALL)\n"
            + study_toml(doc))


# -- the workspaces --------------------------------------------------------------------------

class Workspace:
    """A folder standing in for a clone; commands run with it as the working directory."""

    def __init__(self, root: Path, small: bool):
        self.root = root
        self.small = small
        self._cluster = None
        self.cache: dict[str, Result] = {}
        self.namespaces: dict[str, dict] = {}
        root.mkdir(parents=True, exist_ok=True)
        for name in ("benchmarks", "scripts", "tests", "docs"):
            _link(root / name, REPO / name)
        _link(root / ".venv", Path(sys.prefix))
        if small:
            (root / "scenes").mkdir(exist_ok=True)
            for p in sorted((REPO / "scenes").glob("*.toml")):
                if p.stem not in SMALL:
                    raise DocError(f"scenes/{p.name} has no cut-down grid in "
                                   f"tests/docs/harness.py SMALL")
                (root / "scenes" / p.name).write_text(small_study(p))
        else:
            (root / "scenes").mkdir(exist_ok=True)
            for p in sorted((REPO / "scenes").glob("*.toml")):
                _link(root / "scenes" / p.name, p)

    # the scenes a command or snippet needs, made first with the docs' own two commands
    def ensure(self, text: str) -> None:
        if not self.small:
            return
        names = {m for m in STORE_RE.findall(text)} | {m for m in STUDY_RE.findall(text)}
        for name in sorted(names):
            if name in SMALL and not (self.root / "results" / f"{name}.zarr").exists():
                self.make_scene(name)

    def make_scene(self, name: str) -> None:
        for cmd in (f"hertzmap run scenes/{name}.toml --workers 2",
                    f"hertzmap plot results/{name}.zarr"):
            r = self.run(cmd)
            if r.returncode != 0:
                raise DocError(f"making the small {name} scene: `{cmd}` exited "
                               f"{r.returncode}:\n{r.output[-3000:]}")

    def run(self, text: str, *, timeout: float = 600) -> Result:
        """Run one command line in this workspace (once: the result is kept)."""
        if text in self.cache:
            return self.cache[text]
        words = shlex.split(text, comments=True)
        if words and words[0] in ("hertzmap", ".venv/bin/hertzmap") and not _shell_syntax(text):
            r = self._hertzmap_in_process(words[1:], text)
        else:
            env = dict(os.environ)
            env["PATH"] = f"{self.root / '.venv' / 'bin'}:{env.get('PATH', '')}"
            env["MPLBACKEND"] = "Agg"
            env.pop("PYTHONPATH", None)
            p = subprocess.run(["bash", "-c", text], cwd=self.root, env=env, text=True,
                               capture_output=True, timeout=timeout)
            r = Result(text, p.returncode, p.stdout, p.stderr)
        self.cache[text] = r
        return r

    def shared_cluster(self):
        """One embedded cluster (2 single-threaded worker processes, hertzmap's Dask config) for
        every `hertzmap run` of the session: the runs are those of the docs, word for word; only
        the cluster each would start and stop (seconds each) is started once."""
        if self._cluster is None:
            import logging

            import dask
            from distributed import LocalCluster

            from hertzmap.scheduler.cluster.clusters import CLUSTER_CONFIG
            with dask.config.set(CLUSTER_CONFIG):
                self._cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                             dashboard_address="127.0.0.1:0",
                                             silence_logs=logging.CRITICAL)
        return self._cluster

    def close(self) -> None:
        if self._cluster is not None:
            from hertzmap.scheduler.cluster.clusters import close_quietly
            close_quietly(None, self._cluster)
            self._cluster = None

    def _hertzmap_in_process(self, argv: list[str], text: str) -> Result:
        import hertzmap.scheduler.run as run_module
        from hertzmap.scheduler.doors.cli import main

        own = run_module.make_client

        def make_client(spec, report=None):
            if spec.kind != "local":
                return own(spec, report=report)
            from distributed import Client
            return Client(self.shared_cluster()), None

        out, err = io.StringIO(), io.StringIO()
        old = Path.cwd()
        os.chdir(self.root)
        run_module.make_client = make_client
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                try:
                    rc = main(argv)
                except SystemExit as exc:        # argparse
                    rc = exc.code if isinstance(exc.code, int) else 1
        finally:
            run_module.make_client = own
            os.chdir(old)
        return Result(text, rc, out.getvalue(), err.getvalue())


def _link(path: Path, target: Path) -> None:
    if not path.exists() and not path.is_symlink():
        path.symlink_to(target)


def _shell_syntax(text: str) -> bool:
    return any(c in text for c in "|;&<>$`") or bool(re.match(r"^\s*[A-Z_]+=", text))


# -- commands --------------------------------------------------------------------------------

def has_placeholder(text: str) -> bool:
    """A word the reader replaces (STUDY.toml, <scene>, [--workers N], ...); the code of a
    ``python -c`` is not looked at."""
    try:
        words = shlex.split(text, comments=True)
    except ValueError:
        return bool(PLACEHOLDER.search(text))
    if "-c" in words:
        words = words[:words.index("-c")]
    return any(PLACEHOLDER.search(w) for w in words if not w.startswith("hertzmap["))


def check_command(cmd: Command, small: Workspace, real: Workspace) -> str:
    """Check one command as its markers say; returns what was done ('ran', 'parsed')."""
    words = cmd.words
    text = cmd.text.strip()
    argv = shlex.split(text, comments=True)
    while argv and re.match(r"^[A-Z_][A-Z0-9_]*=", argv[0]):
        argv = argv[1:]
    if not argv:
        raise DocError(f"{cmd.where()}: empty command {text!r}")
    prog = argv[0]
    parse_only = bool(words & {"cluster", "long", "server", "edits"}) or has_placeholder(text)
    if prog in ("hertzmap", ".venv/bin/hertzmap"):
        sub = _check_hertzmap_args(cmd, argv[1:])
        if sub is None:                          # a mention: `hertzmap run`
            return "parsed"
        if sub == "run" and len(argv) > 2 and argv[2] in SMALL:
            # a shipped scene by its name: in the workspaces, the scene's copy there
            argv = [*argv[:2], f"scenes/{argv[2]}.toml", *argv[3:]]
            text = shlex.join(argv)
        if sub == "run" and not has_placeholder(text):
            study = next((a for a in argv[2:] if a.endswith(".toml")), None)
            if study and (real.root / study).exists():
                dry = real.run(_dry_run_of(text))
                if dry.returncode != 0:
                    raise DocError(f"{cmd.where()}: `{text}` with --dry-run on the real study "
                                   f"exits {dry.returncode}:\n{dry.output[-2000:]}")
        if parse_only or sub in ("explore", "bench"):
            return "parsed"
        if sub == "run" and "--dry-run" in argv:
            r = real.run(text)
        else:
            small.ensure(text)
            r = small.run(text)
        _expect_ok(cmd, r)
        _check_output(cmd, r)
        return "ran"
    if prog == "bash":
        script = next((a for a in argv[1:] if not a.startswith("-")), None)
        if script is None or not (REPO / script).is_file():
            raise DocError(f"{cmd.where()}: `{text}`: no script {script!r} in the repository")
        p = subprocess.run(["bash", "-n", str(REPO / script)], capture_output=True, text=True)
        if p.returncode:
            raise DocError(f"{cmd.where()}: {script}: bash -n: {p.stderr}")
        _check_paths(cmd, [a for a in argv[2:] if "/" in a])   # a script's words: paths only
        return "parsed"
    if prog == "pip" or prog.endswith("/pip"):
        _check_pip(cmd, argv)
        return "parsed"
    if prog in ("python", "python3", ".venv/bin/python"):
        _check_python_command(cmd, argv, parse_only=parse_only)
        if parse_only or _is_pytest(argv):
            return "parsed"
        if _is_benchmark(argv) and not words & {"prints", "run"}:
            return "parsed"             # a measurement: minutes of CPU, its numbers not stable
        small.ensure(text)
        r = small.run(text)            # `python`: the venv's (first on PATH, as activated)
        _expect_ok(cmd, r)
        _check_output(cmd, r)
        return "ran"
    if prog == "pytest":
        _check_paths(cmd, argv[1:])
        return "parsed"
    if prog == "export":
        for a in argv[1:] if not has_placeholder(text) else []:
            if not re.match(r"^[A-Z_][A-Z0-9_]*=\S+$", a):
                raise DocError(f"{cmd.where()}: `{text}`: not NAME=value")
        return "parsed"
    if prog == "dask":
        if len(argv) < 2 or argv[1] not in ("scheduler", "worker"):
            raise DocError(f"{cmd.where()}: `{text}`: dask has no command {argv[1:2]}")
        if not (Path(sys.prefix) / "bin" / "dask").exists():
            raise DocError(f"{cmd.where()}: `{text}`: no dask command in the environment")
        return "parsed"
    # a program of the reader's cluster (ssh, squeue, scontrol ...): its words only
    return "parsed"


def _dry_run_of(text: str) -> str:
    words = shlex.split(text, comments=True)
    if "--dry-run" not in words:
        words.append("--dry-run")
    return shlex.join(words)


def _check_hertzmap_args(cmd: Command, args: list[str]) -> str | None:
    """argparse accepts the command (options checked by name when it has placeholders)."""
    from hertzmap.scheduler.doors.cli import SUBCOMMANDS, build_parser

    if not args:
        raise DocError(f"{cmd.where()}: `{cmd.text}`: no subcommand")
    sub = args[0]
    if sub not in SUBCOMMANDS:
        raise DocError(f"{cmd.where()}: `{cmd.text}`: hertzmap has no command {sub!r} "
                       f"(it has {', '.join(SUBCOMMANDS)})")
    if cmd.inline and sub not in ("bench",) and all(a.startswith("-") for a in args[1:]):
        mention = True                           # `hertzmap run --overwrite`: a mention
    else:
        mention = False
    parser = build_parser()
    sp = _subparser(parser, sub)
    known = {o for a in sp._actions for o in a.option_strings if a.help != "==SUPPRESS=="}
    opts = [a.split("=")[0] for a in args[1:] if a.startswith("--")]
    bad = [o for o in opts if o not in known]
    if bad:
        raise DocError(f"{cmd.where()}: `{cmd.text}`: hertzmap {sub} has no option "
                       f"{', '.join(bad)}")
    if mention:
        return None
    if "usage" in cmd.words:
        text = cmd.context or cmd.text
        missing = sorted(o for o in known - {"-h", "--help"} if o not in text)
        if missing:
            raise DocError(f"{cmd.where()}: the synopsis of hertzmap {sub} leaves out "
                           f"{', '.join(missing)}")
    if has_placeholder(cmd.text):
        return sub
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            parser.parse_args(args)
    except SystemExit as exc:
        if exc.code:
            raise DocError(f"{cmd.where()}: `{cmd.text}`: {err.getvalue().strip()}") from None
    return sub


def _subparser(parser, name):
    for a in parser._actions:
        if getattr(a, "choices", None) and name in a.choices:
            return a.choices[name]
    raise KeyError(name)


def _is_benchmark(argv: list[str]) -> bool:
    """``python benchmarks/X.py ...``: scripts that measure (minutes each, times that vary),
    parsed unless a ``prints`` or ``run`` marker asks for a run."""
    return len(argv) > 1 and argv[1].startswith("benchmarks/")


def _is_pytest(argv: list[str]) -> bool:
    return "-m" in argv and argv[argv.index("-m") + 1:argv.index("-m") + 2] == ["pytest"]


def _check_python_command(cmd: Command, argv: list[str], *, parse_only: bool) -> None:
    """python -c CODE (compiles), python -m MODULE (importable, and runnable as a script),
    python FILE (exists, compiles); pytest paths exist."""
    rest = argv[1:]
    if rest[:1] == ["-c"]:
        try:
            ast.parse(rest[1])
        except SyntaxError as exc:
            raise DocError(f"{cmd.where()}: python -c: {exc}") from None
        return
    if rest[:1] == ["-m"]:
        mod = rest[1]
        if mod == "pytest":
            _check_paths(cmd, rest[2:])
            return
        import importlib.util
        spec = importlib.util.find_spec(mod)
        if spec is None:
            raise DocError(f"{cmd.where()}: `{cmd.text}`: no module {mod}")
        src = Path(spec.origin).read_text() if spec.origin else ""
        if "__main__" not in src and not spec.submodule_search_locations:
            raise DocError(f"{cmd.where()}: `{cmd.text}`: {mod} does nothing as a script "
                           f"(no __main__)")
        return
    script = rest[0] if rest else None
    if not script or not (REPO / script).is_file():
        raise DocError(f"{cmd.where()}: `{cmd.text}`: no file {script!r}")
    try:
        compile((REPO / script).read_text(), script, "exec")
    except SyntaxError as exc:
        raise DocError(f"{cmd.where()}: {script}: {exc}") from None
    src = (REPO / script).read_text()
    flags = [a.split("=")[0] for a in rest[1:] if a.startswith("--")]
    missing = [f for f in flags if f"\"{f}\"" not in src and f"'{f}'" not in src]
    if missing:
        raise DocError(f"{cmd.where()}: `{cmd.text}`: {script} takes no option "
                       f"{', '.join(missing)}")


def _check_paths(cmd: Command, args: list[str]) -> None:
    """Test files and node ids named on a command line exist."""
    for a in args:
        if a.startswith("-") or has_placeholder(a):
            continue
        path, _, name = a.partition("::")
        if not (REPO / path).exists():
            raise DocError(f"{cmd.where()}: `{cmd.text}`: no {path}")
        if name and not re.search(rf"^def {re.escape(name.split('[')[0])}\(",
                                  (REPO / path).read_text(), re.M):
            raise DocError(f"{cmd.where()}: `{cmd.text}`: no test {name} in {path}")


def _check_pip(cmd: Command, argv: list[str]) -> None:
    """pip install 'hertzmap[extra]': the extra exists; ``pip install .``: the checkout is a
    project; a plain package is one the docs can promise (importable in the test environment,
    which installs every extra)."""
    import importlib.util
    pyproject = tomllib.loads((REPO / "pyproject.toml").read_text())
    extras = pyproject["project"]["optional-dependencies"]
    for a in argv[2:]:
        if a.startswith("-"):
            continue
        m = re.fullmatch(r"hertzmap\[([\w,-]+)\]", a)
        if a == "." or a.startswith(("./", "/")):
            if not (REPO / a / "pyproject.toml").is_file():
                raise DocError(f"{cmd.where()}: `{cmd.text}`: {a} is not a project to install")
        elif m:
            bad = [e for e in m.group(1).split(",") if e not in extras]
            if bad:
                raise DocError(f"{cmd.where()}: `{cmd.text}`: no extra {bad} in pyproject.toml")
        elif importlib.util.find_spec(a.replace("-", "_")) is None:
            raise DocError(f"{cmd.where()}: `{cmd.text}`: {a} is not installed with the extras")


def _expect_ok(where, r: Result) -> None:
    if r.returncode != 0:
        raise DocError(f"{where.where()}: `{r.argv}` exits {r.returncode}:\n{r.output[-3000:]}")
    if "Traceback" in r.stderr:
        raise DocError(f"{where.where()}: `{r.argv}` printed a traceback:\n{r.stderr[-3000:]}")


def _check_output(cmd: Command, r: Result) -> None:
    mk = cmd.marker("output")
    if cmd.output and mk:
        compare_sample(cmd, cmd.output, r.output, numbers="shape" not in mk.args)
    mk = cmd.marker("prints")
    if mk:
        check_numbers(cmd, mk, r.stdout, cmd.context)


# -- samples and numbers ---------------------------------------------------------------------

_HASH = re.compile(r"\b(?=[0-9a-f]*\d)(?=[0-9a-f]*[a-f])[0-9a-f]{6,}\b")
_NUMBER = re.compile(r"[-+]?(?:\d[\d,]*\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def shape(line: str) -> str:
    s = _HASH.sub("#", line)
    s = _NUMBER.sub("#", s)
    s = re.sub(r"#(?:[.:,/-]?#)+", "#", s)
    s = re.sub(r"#[A-Za-z]?#?", "#", s)
    return " ".join(s.split())


def compare_sample(where, sample: list[str], actual: str, *, numbers: bool = False) -> None:
    """Every line of the sample matches a line of the actual output, in order ('...' in the
    sample matches anything). ``numbers``: the numbers too (a deterministic output, such as a
    dry run); else only the words (numbers and hashes set aside: a timed run's summary)."""
    norm = (lambda ln: " ".join(ln.split())) if numbers else shape
    got = [norm(ln) for ln in actual.splitlines() if ln.strip()]
    k = 0
    for line in sample:
        if not line.strip():
            continue
        pat = re.compile(".*".join(re.escape(part) for part in norm(line).split("...")))
        while k < len(got) and not pat.fullmatch(got[k]):
            k += 1
        if k == len(got):
            raise DocError(f"{where.where()}: the sample line\n    {line.strip()}\nis not in "
                           f"the output (in order):\n" + actual[-3000:])
        k += 1


def _tolerance(arg: str) -> tuple[float, float, str]:
    value, _, tol = arg.partition("@")
    v = float(value)
    if tol:
        return v, float(tol), value
    m = re.match(r"^[-+]?\d*\.?(\d*)(?:[eE]([-+]?\d+))?$", value)
    decimals = len(m.group(1)) if m else 0
    exp = int(m.group(2)) if m and m.group(2) else 0
    return v, 10.0 ** (exp - decimals), value


def check_numbers(where, mk: Marker, output: str, nearby: str) -> None:
    """The numbers of a ``prints`` marker are in the output (to their tolerance) and in the
    text next to the command."""
    printed = []
    for tok in _NUMBER.findall(output.replace(",", " ")):
        with contextlib.suppress(ValueError):
            printed.append(float(tok))
    nearby = re.sub(r"<!--.*?-->", "", nearby)
    for arg in mk.args:
        v, tol, written = _tolerance(arg)
        if written.lstrip("+") not in nearby:
            raise DocError(f"{where.where()}: the marker's {written} is not in the text next "
                           f"to it: keep the text and the marker in step")
        best = min((abs(p - v) for p in printed), default=math.inf)
        if best > tol:
            near = min(printed, key=lambda p: abs(p - v), default=None)
            raise DocError(f"{where.where()}: the docs say {written} (to {tol:g}); the "
                           f"command printed {near!r} as the nearest value:\n{output[-2000:]}")


# -- Python blocks and TOML ------------------------------------------------------------------

def check_python(block: Block, ws: Workspace, page_text: str) -> str:
    """Run a Python block in the small workspace, in the namespace of its page (blocks of a
    page run in order, as in one session), warnings as errors."""
    try:
        tree = ast.parse(block.text)
    except SyntaxError as exc:
        raise DocError(f"{block.where()}: {exc}") from None
    if block.words & {"long", "cluster", "server", "edits"}:
        return "parsed"
    ws.ensure(block.text)
    key = str(block.path)
    ns = {} if "fresh" in block.words else ws.namespaces.setdefault(key, {"__name__": "__doc__"})
    out = io.StringIO()
    old = Path.cwd()
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    os.chdir(ws.root)
    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(out):
            warnings.simplefilter("error")
            exec(compile(tree, f"{block.path.name}:{block.line}", "exec"), ns)
    except Exception as exc:
        import traceback
        tb = "".join(traceback.format_exception(exc)[-6:])
        raise DocError(f"{block.where()}: the snippet fails: {type(exc).__name__}: {exc}\n"
                       f"{tb}") from None
    finally:
        os.chdir(old)
        plt.close("all")
    mk = block.marker("prints")
    if mk:
        lines = page_text.splitlines()
        end = block.line + block.text.count("\n")
        nearby = "\n".join(lines[max(0, block.line - 25): end + 15])
        check_numbers(block, mk, out.getvalue(), nearby)
    return "ran"


def check_toml(block: Block, *workspaces: Workspace) -> str:
    """A TOML block parses; a study file (it has [grid]) validates as a study. With a marker
    ``file PATH`` the reader saves it there: so does the test, in each workspace."""
    try:
        doc = tomllib.loads(block.text)
    except tomllib.TOMLDecodeError as exc:
        raise DocError(f"{block.where()}: {exc}") from None
    if "grid" in doc:
        from hertzmap.study.spec import StudyError, parse_study
        try:
            parse_study(block.text, default_name="example")
        except StudyError as exc:
            raise DocError(f"{block.where()}: the study file is refused: {exc}") from None
    mk = block.marker("file")
    if mk:
        for ws in workspaces:
            dest = ws.root / mk.args[0]
            dest.parent.mkdir(parents=True, exist_ok=True)
            dest.write_text(block.text)
    return "ran"
