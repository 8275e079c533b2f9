"""What the docs name exists: files and test ids, modules and functions, links and their anchors,
images (shipped in docs/figures/, tracked, remade by scripts/make-figures.sh), every scene in
docs/index.md, the Dask config of running.md. Nothing to run: these read the repository."""
from __future__ import annotations

import importlib
import re
import subprocess
from pathlib import Path

import pytest

from tests.docs import markdown as md
from tests.docs.harness import DOC_FILES, REPO

PAGES = [REPO / p for p in DOC_FILES]

_PATH = re.compile(r"(?<![\w./-])((?:kernels|study|scheduler|benchmarks|tests|scripts|studies|docs)"
                   r"/[\w./-]*[\w/])(::[\w\[\]-]+)?")
#: example names the prose uses for the reader's own files
_EXAMPLES = {"scenes/x.toml", "scenes/big.toml", "scenes/fig", "scenes/figNN.toml",
             "docs/figures/explore/<name>"}
_DOTTED = re.compile(r"\b(kernels|study|scheduler|benchmarks)((?:\.[A-Za-z_]\w*)+)")
_SPAN = re.compile(r"`([^`\n]+)`")
_LINK = re.compile(r"(!?)\[[^\]]*\]\(([^)\s]+)\)")


def _prose_lines(path: Path):
    """(line number, text) of a page's lines outside fenced blocks."""
    fence = None
    for k, ln in enumerate(path.read_text().splitlines(), 1):
        m = re.match(r"^\s*(`{3,}|~{3,})", ln)
        if m:
            fence = None if fence == m.group(1) else (fence or m.group(1))
            continue
        if fence is None:
            yield k, ln


def _saved_by_the_reader() -> set[str]:
    """Files a page asks the reader to save (``<!-- doc-test: file PATH -->``)."""
    return {m.args[0] for p in PAGES for b in md.blocks(p) for m in b.markers
            if m.word == "file" and m.args}


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_paths_and_test_ids_exist(page):
    bad = []
    saved = _saved_by_the_reader()
    for k, ln in enumerate(page.read_text().splitlines(), 1):
        for m in _PATH.finditer(ln):
            path, node = m.group(1).rstrip("."), m.group(2)
            if (path in _EXAMPLES or path in saved or re.search(r"NN|NAME", path)
                    or path.startswith("results/")):
                continue
            if not (REPO / path).exists():
                bad.append(f"{page.name}:{k}: {path} does not exist")
            elif node:
                name = node[2:].split("[")[0]
                if not re.search(rf"^(async )?def {re.escape(name)}\(", (REPO / path).read_text(),
                                 re.M):
                    bad.append(f"{page.name}:{k}: no {name} in {path}")
    assert not bad, "\n".join(bad)


def _test_names() -> set[str]:
    return {m for p in (REPO / "tests").rglob("test_*.py")
            for m in re.findall(r"^(?:async )?def (test_\w+)\(", p.read_text(), re.M)}


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_tests_named_exist(page):
    """A test named in the text (`test_...`) is a test of tests/."""
    names = _test_names()
    bad = [f"{page.name}:{k}: no test {name} in tests/"
           for k, ln in _prose_lines(page) for span in _SPAN.findall(ln)
           for name in re.findall(r"(?<![\w/])(test_\w+)(?![\w.])", span)
           if name not in names and not span.endswith(".py")]
    assert not bad, "\n".join(bad)


def _resolve(dotted: str) -> bool:
    parts = dotted.split(".")
    for n in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:n]))
        except ImportError:
            continue
        for attr in parts[n:]:
            if not hasattr(obj, attr):
                try:
                    obj = importlib.import_module(f"{obj.__name__}.{attr}")
                    continue
                except (ImportError, AttributeError):
                    return False
            obj = getattr(obj, attr)
        return True
    return False


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_modules_and_functions_named_in_code_exist(page):
    bad = []
    for k, ln in _prose_lines(page):
        for span in _SPAN.findall(ln):
            for m in _DOTTED.finditer(span):
                dotted = (m.group(1) + m.group(2)).rstrip(".")
                if re.search(r"\.(md|toml|py|png|zarr|csv|sh)$", dotted):
                    continue
                if not _resolve(dotted):
                    bad.append(f"{page.name}:{k}: `{dotted}` is not importable")
    assert not bad, "\n".join(bad)


def _slug(heading: str) -> str:
    s = heading.strip().lower()
    s = re.sub(r"[^\w\- ]", "", s)
    return s.replace(" ", "-")


def _anchors(path: Path) -> set[str]:
    return {_slug(ln.lstrip("#")) for k, ln in _prose_lines(path) if ln.startswith("#")}


def _tracked() -> set[str]:
    out = subprocess.run(["git", "ls-files", "-co", "--exclude-standard"], cwd=REPO,
                         capture_output=True, text=True, check=True).stdout
    return set(out.split())


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_links_and_images_resolve(page):
    tracked = _tracked()
    bad = []
    for k, ln in _prose_lines(page):
        for image, target in _LINK.findall(ln):
            if re.match(r"^[a-z]+://", target) or target.startswith("mailto:"):
                continue
            file, _, anchor = target.partition("#")
            dest = (page.parent / file).resolve() if file else page
            rel = dest.relative_to(REPO).as_posix() if dest.is_relative_to(REPO) else str(dest)
            if not dest.exists():
                bad.append(f"{page.name}:{k}: {target}: no such file")
            elif anchor and dest.suffix == ".md" and anchor not in _anchors(dest):
                bad.append(f"{page.name}:{k}: {target}: no heading #{anchor}")
            if image and not (rel.startswith("docs/figures/") and rel in tracked):
                bad.append(f"{page.name}:{k}: the image {target} is not a tracked file of "
                           f"docs/figures/ (results/ is the user's output)")
    assert not bad, "\n".join(bad)


def test_shipped_figures_are_shown_and_remade_by_the_script():
    """Each figure in docs/figures/ is shown by a page and remade by scripts/make-figures.sh
    (its scene and figure in the script's table, or the paper / explore / bench steps)."""
    script = (REPO / "scripts" / "make-figures.sh").read_text()
    table = dict(re.findall(r"\[(\w+)\]=\"([\w ]+)\"", script))
    # a scene in the table but not in ORDER (bash's tables have no order) would not be remade
    order = re.search(r'^ORDER="([\w ]+)"', script, re.M).group(1).split()
    assert sorted(order) == sorted(table), (order, sorted(table))
    shown = "\n".join(p.read_text() for p in PAGES)
    bad = []
    for png in sorted((REPO / "docs" / "figures").rglob("*.png")):
        rel = png.relative_to(REPO / "docs" / "figures").as_posix()
        if rel not in shown:
            bad.append(f"docs/figures/{rel} is shown by no page")
        if rel.startswith("explore/") or rel == "bench.png":
            continue
        m = re.fullmatch(r"paper_(fig\d\d)\.png", rel)
        basin = re.fullmatch(r"(\w+)_basin_map_omega([\d.]+)_sigma([\d.]+)_zeta[\d.]+\.png", rel)
        fit = re.fullmatch(r"(\w+)_fit\.png", rel)
        if fit:                                 # hertzmap fit docs/examples/NAME.csv --out OUT
            ok = re.search(rf"fit docs/examples/{fit.group(1)}\.csv [^;]*--out", script)
        elif basin:                             # hertzmap basins STORE --omega W --sigma S
            scene, w, s = basin.groups()
            ok = re.search(rf'basins "\$STORES/{scene}\.zarr" --omega {re.escape(w)} '
                           rf'--sigma {re.escape(s)}', script)
        elif m:
            ok = re.search(rf"--paper [\w ]*{m.group(1)}", script)
        else:
            # <scene>_<figure>[_sigma...].png; scene and figure names may hold underscores
            # (vibro_impact_strobe_sigma2.5, damping_zeta_maps)
            stem = re.sub(r"_sigma[\d.]+$", "", rel.removesuffix(".png"))
            ok = any(stem == f"{scene}_{fig}" for scene, figs in table.items()
                     for fig in figs.split())
        if not ok:
            bad.append(f"docs/figures/{rel}: scripts/make-figures.sh does not remake it")
    assert not bad, "\n".join(bad)


def test_nothing_tracked_in_results():
    """results/ is the user's output (git-ignored): only its README is in git."""
    out = subprocess.run(["git", "ls-files", "results"], cwd=REPO, capture_output=True,
                         text=True, check=True).stdout.split()
    assert out == ["results/README.md"], out
    probe = ["results/x.zarr/zarr.json", "results/default_map.png",
             "results/explore/explore_orbit.png", "results/make-figures/fig06.zarr/zarr.json"]
    ignored = subprocess.run(["git", "check-ignore", *probe], cwd=REPO, capture_output=True,
                             text=True).stdout.split()
    assert ignored == probe


def test_every_scene_is_in_the_index_with_its_time():
    """docs/index.md lists every study file of scenes/ in its scene table, with a time."""
    text = (REPO / "docs" / "index.md").read_text()
    rows = {m.group(1): m.group(0) for m in re.finditer(r"^\| \[?`?(\w+)`?\]?[^|]*\|.*$", text,
                                                         re.M)}
    bad = []
    for p in sorted((REPO / "scenes").glob("*.toml")):
        row = rows.get(p.stem)
        if row is None:
            bad.append(f"scenes/{p.name} is not in docs/index.md's scene table")
        elif not re.search(r"\d+(\.\d+)?(-\d+(\.\d+)?)? (s|min)\b", row):
            bad.append(f"docs/index.md: the row of {p.stem} gives no time")
    assert not bad, "\n".join(bad)


def test_running_md_gives_the_dask_config_hertzmap_gives_its_workers():
    """The export lines of running.md are those of scheduler.cluster.clusters.CLUSTER_CONFIG."""
    from hertzmap.scheduler.cluster.clusters import CLUSTER_CONFIG, config_env_lines

    page = REPO / "docs" / "running.md"
    exports = [c.text for c in md.all_commands(page)
               if c.text.startswith("export DASK_") and not c.inline]
    assert sorted(exports) == sorted(config_env_lines(CLUSTER_CONFIG))
