"""``hertzmap explore`` in a real browser: headless Chromium (Debian's chromium and
chromium-driver) driven by selenium loads the page of a small store made here with
``hertzmap run``, clicks a grid point that has a stable 2T orbit with contact loss, reads the
orbit table from the DOM and compares it with the store and with an independent
``kernels.simulate``; then box-zooms, refines the window (6 x 6) and waits for the new store
and the page showing it. A sweep through the clicked point: the button, "computing...", the
sweep's panels, their data read from the page's Bokeh document and compared with an independent
``study.solve.sweep.stepped_sweep`` (along omega, computed by the page; along sigma, the
store's products/sweeps, shown as such). Bad input: not a store, a port in use, a store still
being written; a sweep refused or failing says so.

Screenshots go to pytest's tmp_path, or to the folder $HERTZMAP_SCREENSHOTS names
(scripts/make-figures.sh: docs/figures/explore/, the gallery's; the tests never write there
themselves). Without chromium, chromedriver, selenium or bokeh the browser
tests skip, naming what is missing.
"""
from __future__ import annotations

import importlib.util
import json
import math
import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

from tests.helpers import free_port, hertzmap_cmd, subprocess_env

CHROMIUM = os.environ.get("HERTZMAP_CHROMIUM", "/usr/bin/chromium")
CHROMEDRIVER = os.environ.get("HERTZMAP_CHROMEDRIVER", "/usr/bin/chromedriver")
HAVE_BOKEH = importlib.util.find_spec("bokeh") is not None


def _browser_missing() -> str:
    missing = []
    if not (os.path.isfile(CHROMIUM) or shutil.which(CHROMIUM)):
        missing.append(f"chromium ({CHROMIUM}; apt-get install chromium)")
    if not (os.path.isfile(CHROMEDRIVER) or shutil.which(CHROMEDRIVER)):
        missing.append(f"chromedriver ({CHROMEDRIVER}; apt-get install chromium-driver)")
    if importlib.util.find_spec("selenium") is None:
        missing.append("selenium (pip install selenium)")
    if not HAVE_BOKEH:
        missing.append("bokeh (a dependency of hertzmap: bash scripts/install.sh)")
    return ", ".join(missing)


MISSING = _browser_missing()
needs_browser = pytest.mark.skipif(bool(MISSING), reason=f"browser test not run: missing {MISSING}")
needs_bokeh = pytest.mark.skipif(not HAVE_BOKEH, reason="needs bokeh (a dependency of hertzmap: bash scripts/install.sh)")

# A small map around the flip near omega = 2 (paper Fig. 6-9), in the paper's rig units:
# 11 x 16 = 176 points, a few seconds; with stepped sweeps along sigma (the sweeps output: 11
# lines x up, down x 16 steps, about a second), so that the page's sweep along sigma is the
# store's and the one along omega is computed.
STUDY = """
[study]
name = "explore_e2e"
description = "hertzmap explore end-to-end test map"

[grid]
omega = { start = 1.8, stop = 2.0, num = 11 }
sigma = { start = 0.3, stop = 0.6, num = 16 }
zeta = 0.01

[search]
periods = [1, 2]

[products]
outputs = ["orbits", "measures", "force_harmonics", "sweeps"]

[sweep]
axis = "sigma"

[rig]
E = 2.1e11
nu = 0.29
R = 0.0127
m = 7.1
N = 69.7
contact = "double"
"""
#: The clicked point: a stable 2T orbit with contact loss (class III), the README's example.
OMEGA, SIGMA, ZETA = 1.9, 0.5, 0.01

# the page's units, from the rig's formulas (paper Eq. 2-5, 28; double contact)
_K = 2.1e11 * math.sqrt(0.0127) / (3 * math.sqrt(2) * (1 - 0.29**2))
_ZS = (69.7 / _K) ** (2 / 3)
F0 = math.sqrt(1.5 * _K * math.sqrt(_ZS) / 7.1) / (2 * math.pi)     # Hz per unit omega
PRELOAD = 69.7                                                     # N per unit sigma
UM = _ZS / 1.5 * 1e6                                               # um per unit q

DEEP = """
function deep(root, sel, out) {
  root.querySelectorAll(sel).forEach(e => out.push(e));
  root.querySelectorAll('*').forEach(e => { if (e.shadowRoot) deep(e.shadowRoot, sel, out); });
  return out;
}
"""


def _shots(tmp_path: Path) -> Path:
    """Where the gallery's screenshots go: $HERTZMAP_SCREENSHOTS (scripts/make-figures.sh sets
    it to docs/figures/explore), else the test's tmp_path."""
    named = os.environ.get("HERTZMAP_SCREENSHOTS")
    d = Path(named).resolve() if named else tmp_path / "screenshots"
    d.mkdir(parents=True, exist_ok=True)
    return d


def _screenshot(driver, path: Path) -> None:
    """The page as a PNG, without the focus ring of the last click; into the gallery with 256
    colours when they are kept (a quarter of the bytes, no visible change: the page is flat
    colours and text)."""
    driver.execute_script("""
        let e = document.activeElement;
        while (e && e.shadowRoot && e.shadowRoot.activeElement) e = e.shadowRoot.activeElement;
        if (e && e.blur) e.blur();""")
    png = driver.get_screenshot_as_png()
    if os.environ.get("HERTZMAP_SCREENSHOTS"):
        import io
        from PIL import Image
        img = Image.open(io.BytesIO(png)).convert("RGB").quantize(256)
        img.save(path, optimize=True)
    else:
        path.write_bytes(png)


@pytest.fixture(scope="module")
def map_store(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("explore")
    study = d / "explore_e2e.toml"
    study.write_text(STUDY)
    store = d / "explore_e2e.zarr"
    r = subprocess.run(hertzmap_cmd("run", str(study), "--store", str(store), "--workers", "1"),
                       env=subprocess_env(), capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    return store


class Served:
    """``hertzmap explore STORE --port P`` as a subprocess in its own session."""

    def __init__(self, store: Path, *extra: str):
        self.port = free_port()
        self.proc = subprocess.Popen(
            hertzmap_cmd("explore", str(store), "--port", str(self.port), *extra),
            env=subprocess_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            start_new_session=True)
        t0 = time.monotonic()
        while True:
            if self.proc.poll() is not None:
                raise AssertionError("hertzmap explore exited: " + self.proc.stderr.read())
            with socket.socket() as s:
                if s.connect_ex(("127.0.0.1", self.port)) == 0:
                    break
            if time.monotonic() - t0 > 60:
                self.stop()
                raise AssertionError("hertzmap explore did not open its port within 60 s")
            time.sleep(0.1)
        self.url = f"http://localhost:{self.port}/"

    def stop(self) -> tuple[int, str, str]:
        """SIGTERM (what a service manager or Ctrl-C sends): it must stop cleanly, exit 0."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        try:
            out, err = self.proc.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(self.proc.pid, signal.SIGKILL)
            out, err = self.proc.communicate()
        return self.proc.returncode, out, err


@pytest.fixture(scope="module")
def browser():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    profile = tempfile.mkdtemp(prefix="hertzmap-chromium-")
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic",
              "--no-first-run", "--disable-background-networking", "--disable-component-update",
              "--disable-sync", "--hide-scrollbars", "--window-size=1640,1300",
              f"--user-data-dir={profile}"):
        opts.add_argument(a)
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)
    driver.set_script_timeout(30)
    yield driver
    driver.quit()
    shutil.rmtree(profile, ignore_errors=True)


def _wait(pred, timeout: float, what: str):
    t0 = time.monotonic()
    while True:
        v = pred()
        if v:
            return v
        if time.monotonic() - t0 > timeout:
            raise AssertionError(f"timed out after {timeout} s waiting for {what}")
        time.sleep(0.1)


def _open(driver, url: str) -> None:
    driver.get(url)
    _wait(lambda: driver.execute_script(
        "return !!(window.Bokeh && Bokeh.documents && Bokeh.documents.length && "
        "Bokeh.documents[0].get_model_by_name('map') && "
        "Bokeh.index.find_one(Bokeh.documents[0].get_model_by_name('map')))"), 30, "the page")
    _wait(lambda: _text(driver, "#tasks_done"), 30, "the header")


def _text(driver, selector: str) -> str | None:
    return driver.execute_script(DEEP + "const e = deep(document, arguments[0], []);"
                                 "return e.length ? e[0].textContent : null;", selector)


def _map_px(driver, x: float, y: float) -> tuple[int, int]:
    """Viewport pixel of the map's data point (x, y) (page units), from BokehJS's own scales."""
    px = driver.execute_script("""
        const v = Bokeh.index.find_one(Bokeh.documents[0].get_model_by_name('map'));
        const r = v.canvas_view.el.getBoundingClientRect();
        return [r.left + v.frame.x_scale.compute(arguments[0]),
                r.top + v.frame.y_scale.compute(arguments[1])];""", x, y)
    return int(round(px[0])), int(round(px[1]))


def _pointer(driver):
    from selenium.webdriver.common.actions.action_builder import ActionBuilder
    ab = ActionBuilder(driver)
    return ab, ab.pointer_action


def _table(driver) -> dict[tuple[int, str], str]:
    cells = driver.execute_script(DEEP + "return deep(document, 'td[data-field]', [])"
                                  ".map(e => [e.dataset.orbit, e.dataset.field, e.textContent]);")
    return {(int(k), f): t for k, f, t in cells}


def _nearest(values, x):
    values = np.asarray(values)
    return float(values[np.argmin(np.abs(values - x))])


@needs_browser
def test_click_gives_the_orbits_and_a_refine_recomputes_the_window(map_store, browser, tmp_path):
    from selenium.webdriver.common.keys import Keys

    from hertzmap.kernels import simulate
    from hertzmap.scheduler.store import Store
    from hertzmap.study import products as P
    from hertzmap.study.spec import load_study

    shots = _shots(tmp_path)
    ds = P.open_store(map_store)
    w, s = _nearest(ds["omega"].values, OMEGA), _nearest(ds["sigma"].values, SIGMA)
    server = Served(map_store, "--workers", "1")
    try:
        _open(browser, server.url)
        n_tasks = int(Store(map_store).done_mask().size)
        assert _text(browser, "#tasks_done") == f"{n_tasks}/{n_tasks}"

        # -- click the point: its orbits --------------------------------------------------
        ab, pa = _pointer(browser)
        pa.move_to_location(*_map_px(browser, w * F0, s * PRELOAD))
        pa.click()
        ab.perform()
        table = _wait(lambda: _table(browser), 30, "the orbit table")
        # the store's distinct orbits at the point, and its stable 2T with contact loss
        pt = ds.sel(omega=[w], sigma=[s], zeta=[ZETA], method="nearest")
        valid = P.valid_orbits(pt).values[0, 0, 0]
        cls = P.orbit_classes(pt).values[0, 0, 0]
        slots = np.flatnonzero(valid)
        assert {k for k, _ in table} == set(range(slots.size))
        k3 = [k for k in range(slots.size) if table[(k, "class")].startswith("III")]
        assert len(k3) == 1, table
        k = k3[0]
        slot = int(slots[k])
        assert cls[slot] == 3
        one = pt.isel(omega=0, sigma=0, zeta=0, solution=slot)
        assert table[(k, "period")] == "2" and table[(k, "stable")] == "yes"
        assert table[(k, "loses_contact")] == "yes"
        # the table's numbers (7 significant digits, um and mm/s) are the store's
        for field, scale in (("min_q", UM), ("max_q", UM), ("ptp", UM), ("q0", UM),
                             ("flight_fraction", 100.0)):
            assert float(table[(k, field)]) == pytest.approx(float(one[field]) * scale,
                                                             rel=2e-6), field
        # ... and an independent integration from the stored start point over the 2T period
        T2 = 2 * 2 * np.pi / w
        t = np.linspace(0.0, T2, 40001)
        sim = simulate(w, s, ZETA, (float(one["q0"]), float(one["v0"])), t_end=T2, t_eval=t,
                       rtol=1e-12)
        assert sim["status"] == 0
        assert abs(sim["q"][-1] - sim["q"][0]) < 1e-7       # the stored start point closes
        # min q: the store's (event-located) and the page's own integration, to 1e-5 in q
        assert float(table[(k, "min_q")]) / UM == pytest.approx(sim["q"].min(), abs=1e-5)
        assert float(table[(k, "min_q_sim")]) / UM == pytest.approx(sim["q"].min(), abs=1e-5)
        assert sim["q"].min() < -1.5                         # it does lose contact
        time.sleep(0.5)    # let the last panels paint
        ab, pa = _pointer(browser)
        pa.move_to_location(5, 5)                             # the hover away from the map
        ab.perform()
        time.sleep(0.3)
        _screenshot(browser, shots / "explore_orbit.png")

        # -- box-zoom a window around the point, refine it on 6 x 6 -----------------------
        a = _map_px(browser, (w - 0.035) * F0, (s + 0.055) * PRELOAD)
        b = _map_px(browser, (w + 0.035) * F0, (s - 0.055) * PRELOAD)
        ab, pa = _pointer(browser)
        pa.move_to_location(*a)
        pa.pointer_down()
        pa.move_to_location((a[0] + b[0]) // 2, (a[1] + b[1]) // 2)
        pa.move_to_location(*b)
        pa.pointer_up()
        ab.perform()
        _wait(lambda: "omega 1.86" in (_text(browser, "#refine_plan") or ""), 10,
              "the zoomed window")
        inputs = browser.execute_script(DEEP + "return deep(document, 'input', [])")
        for inp in inputs[:2]:                               # omega points, sigma points
            inp.send_keys(Keys.END, Keys.BACKSPACE * 8, "6", Keys.ENTER)
        _wait(lambda: ": 36 points" in (_text(browser, "#refine_plan") or ""), 10,
              "6 x 6 points")
        button = browser.execute_script(DEEP + "return deep(document, 'button', [])"
                                        ".filter(e => e.textContent.includes('Refine'))[0]")
        t0 = time.monotonic()
        button.click()
        progress = set()             # what the page said while the refine ran

        def refined():
            tasks = _text(browser, "#refine_tasks")
            if tasks:
                progress.add(tasks)
            return _text(browser, "#refined_store")
        shown = _wait(refined, 120, "the refined store")
        refine_seconds = time.monotonic() - t0
        new = map_store.parent / shown
        assert new.name.startswith("explore_e2e.refine-") and new.suffix == ".zarr"
        assert Store(new).done_mask().all()                  # complete, flags all set
        study = load_study(new.with_suffix(".toml"))         # the study file written beside it
        assert study.shape == (6, 6, 1) and study.zeta == (ZETA,)
        assert study.omega[0] == pytest.approx(w - 0.035, abs=0.004)
        assert study.omega[-1] == pytest.approx(w + 0.035, abs=0.004)
        assert study.sigma[0] == pytest.approx(s - 0.055, abs=0.004)
        assert study.sigma[-1] == pytest.approx(s + 0.055, abs=0.004)
        total = Store(new).done_mask().size
        # progress was on the page (done/total tasks of the new store) before the new map
        assert progress and all(p.endswith(f"/{total}") for p in progress), progress
        refined = P.open_store(new)
        assert refined.attrs["hertzmap_study_hash"] == study.hash
        assert int((refined["status"] == 0).any("solution").sum()) == 36
        # the page shows it: its header names the refined store and its 6 x 6 grid
        _wait(lambda: "6 omega x 6 sigma" in browser.execute_script(
            DEEP + "return deep(document, 'div', []).map(e => e.textContent).join(' ')"),
            10, "the refined map")
        time.sleep(0.5)
        _screenshot(browser, shots / "explore_refined.png")
        print(f"refine of 36 points: {refine_seconds:.1f} s from the click; screenshots in {shots}")
    finally:
        rc, out, err = server.stop()
    assert rc == 0, err
    assert "Traceback" not in err, err


READ_SWEEP = """
const doc = Bokeh.documents[0];
const out = {};
for (const name of ['sweep_up', 'sweep_down', 'sweep_jumps']) {
  const d = doc.get_model_by_name(name).data;
  const keys = d instanceof Map ? [...d.keys()] : Object.keys(d);
  out[name] = {};
  for (const k of keys) {
    const col = d instanceof Map ? d.get(k) : d[k];
    out[name][k] = Array.from(col).map(
      x => (typeof x === 'number' && !Number.isFinite(x)) ? null : x);
  }
}
const fig = doc.get_model_by_name('sweep_H1');
out.drawn = !!Bokeh.index.find_one(fig);
return out;
"""


def _columns(data: dict) -> dict[str, np.ndarray]:
    """A data source read by READ_SWEEP: numbers as float arrays (null: NaN)."""
    return {k: (np.array([np.nan if x is None else x for x in v], float)
                if all(x is None or isinstance(x, (int, float)) for x in v) else v)
            for k, v in data.items()}


def _independent_sweeps(axis, values, fixed):
    """study.solve.sweep.stepped_sweep up and down, called here with the study's settings
    (its [sweep] table, model and rtol; from rest): {direction: (values in increasing order,
    H1, H2, ptp, period in that order, the Sweep)}."""
    from hertzmap.study.solve.sweep import force_components
    from hertzmap.study.solve.sweep import stepped_sweep
    from hertzmap.study.spec import parse_study

    study = parse_study(STUDY)
    sw = study.sweep_dict
    out = {}
    for d in ("up", "down"):
        r = stepped_sweep(axis, values, fixed, d, x0=(0.0, 0.0), exponent=1.5, model="hertz",
                          rtol=study.rtol, jump_tol=sw["jump_tol"],
                          settle_periods=sw["settle_periods"],
                          record_periods=sw["record_periods"])
        a = r.arrays()
        h1, h2, _ = force_components(a["force_harmonics"], a["period"])
        o = np.argsort(a["value"])
        out[d] = (a["value"][o], h1[o], h2[o], a["ptp"][o], a["period"][o], r)
    return out


def _check_sweep(got: dict, want: dict, scale: float) -> None:
    """The page's sweep columns (READ_SWEEP) against the independent sweeps: the steps, H1 and
    H2 (N), the amplitude (um), the jumps (location in Hz or N, kind)."""
    jumps = _columns(got["sweep_jumps"])
    n_jumps = 0
    for d, (values, h1, h2, ptp, period, ref) in want.items():
        c = _columns(got[f"sweep_{d}"])
        rows = np.isfinite(c["value"])             # the path's breaks at its jumps dropped
        assert int((~rows).sum()) == sum(1 for j in ref.jumps if j.step_index > 0), d
        np.testing.assert_array_equal(c["value"][rows], values)
        np.testing.assert_allclose(c["x"][rows], values * scale, rtol=1e-12)
        np.testing.assert_allclose(c["H1"][rows] / PRELOAD, h1, rtol=1e-9, equal_nan=True)
        np.testing.assert_allclose(c["H2"][rows] / PRELOAD, h2, rtol=1e-9, equal_nan=True)
        np.testing.assert_allclose(c["ptp"][rows] / UM, ptp, rtol=1e-9, equal_nan=True)
        np.testing.assert_array_equal(c["period"][rows], period)
        mine = [k for k, dd in enumerate(jumps["direction"]) if dd == d]
        assert len(mine) == len(ref.jumps), (d, jumps)
        for k, j in zip(mine, ref.jumps):
            assert jumps["kind"][k] == j.kind
            assert jumps["x"][k] / scale == pytest.approx(j.value, rel=1e-12)
        n_jumps += len(mine)
    assert len(jumps["x"]) == n_jumps


def _sweep_button(driver):
    """The page's "Sweep through this point" button once it is enabled (by a click on the map,
    or the last sweep done)."""
    return _wait(lambda: driver.execute_script(
        DEEP + "return deep(document, 'button', [])"
        ".filter(e => e.textContent.includes('Sweep through this point') && !e.disabled)[0]"),
        10, "the sweep button enabled")


@needs_browser
def test_a_sweep_through_the_clicked_point(map_store, browser, tmp_path):
    """Click (1.9, 0.5), press "Sweep through this point": the page says "computing...", then
    draws the sweeps up and down omega (the store's 11 omega values, computed in the server)
    that an independent stepped_sweep gives; along sigma it shows the store's products/sweeps
    (not recomputed), the same numbers."""
    from hertzmap.scheduler.store import read_product
    from hertzmap.study import products as P

    ds = P.open_store(map_store)
    w, s = _nearest(ds["omega"].values, OMEGA), _nearest(ds["sigma"].values, SIGMA)
    server = Served(map_store)
    try:
        _open(browser, server.url)
        ab, pa = _pointer(browser)
        pa.move_to_location(*_map_px(browser, w * F0, s * PRELOAD))
        pa.click()
        ab.perform()
        _wait(lambda: _table(browser), 30, "the orbit table")
        button = _sweep_button(browser)

        # -- along omega (the default): computed in the server ----------------------------
        t0 = time.monotonic()
        button.click()
        states = set()

        def state(want):
            st = _text(browser, "#sweep_state")
            states.add(st)
            return st == want
        _wait(lambda: state("done"), 60, "the sweep along omega")
        page_seconds = time.monotonic() - t0
        assert "computing..." in states, states          # the page said so while it ran
        def drawn():
            g = browser.execute_script(READ_SWEEP)
            return g if g["drawn"] and g["sweep_up"]["x"] else None
        got = _wait(drawn, 10, "the sweep's panels")
        want = _independent_sweeps("omega", np.sort(ds["omega"].values),
                                   {"sigma": s, "zeta": ZETA})
        _check_sweep(got, want, F0)
        # the up sweep leaves the 1T response at its flip near omega 1.97758 for the 2T one
        up = want["up"][5]
        assert [j.kind for j in up.jumps] == ["flip"]
        assert abs(up.jumps[0].value - 1.97758) < 1e-5
        status = browser.execute_script(
            DEEP + "return deep(document, 'div', []).map(e => e.textContent).join(' ')")
        assert "computed here" in status and "11 steps, the store's grid values of omega" \
            in status, status
        assert "up: flip at omega = 1.97758" in status, status
        time.sleep(0.5)
        browser.execute_script("window.scrollTo(0, document.body.scrollHeight)")
        time.sleep(0.3)
        _screenshot(browser, tmp_path / "explore_sweep.png")      # not a gallery image

        # -- along sigma: the store's products/sweeps, shown as such ----------------------
        browser.execute_script(
            "Bokeh.documents[0].get_model_by_name('sweep_axis').value = 'sigma'")
        time.sleep(0.3)                                   # the choice reaches the server
        _sweep_button(browser).click()                   # (redrawn since: found again)
        _wait(lambda: state("from the store"), 30, "the stored sweep along sigma")
        got = browser.execute_script(READ_SWEEP)
        sigmas = np.sort(ds["sigma"].values)
        want = _independent_sweeps("sigma", sigmas, {"omega": w, "zeta": ZETA})
        _check_sweep(got, want, PRELOAD)
        product = read_product(map_store, "sweeps")
        i = int(np.flatnonzero(np.isclose(product["line_omega"].values, w))[0])
        up = _columns(got["sweep_up"])
        np.testing.assert_allclose(up["H1"][np.isfinite(up["value"])] / PRELOAD,
                                   product["H1"].values[i, 0], rtol=1e-12, equal_nan=True)
        page = browser.execute_script(
            DEEP + "return deep(document, 'div', []).map(e => e.textContent).join(' ')")
        assert "products/sweeps" in page and "not recomputed" in page
        said = status[status.index("Stepped-sine sweeps"):].split("\u25b2")[0]
        print(f"sweep along omega (11 steps up and down) on the page: {page_seconds:.1f} s "
              f"from the click; the page: {said}")
    finally:
        rc, _, err = server.stop()
    assert rc == 0, err
    assert "Traceback" not in err, err


READ_BASINS = """
const doc = Bokeh.documents[0];
const src = doc.get_model_by_name('basin_image');
const img = src.data.image[0];
return {flat: Array.from(img), shape: img.shape ? Array.from(img.shape) : null};
"""


@needs_browser
def test_a_basin_map_of_the_clicked_point(map_store, browser, tmp_path):
    """Click (1.9, 0.5), choose 100 states per side, press "Basin map of this point": the page
    says "computing...", draws the tiles as they return, then the map: the same partition of
    the 100 x 100 states as an independent study.solve.dense_basins map (the same store orbits,
    in this process), the census's shares at the point beside the map's, the map written into
    the store as its product group."""
    from hertzmap.scheduler.stages.basin_tasks import check_request, store_orbits
    from hertzmap.scheduler.store import read_product
    from hertzmap.study import explore_data as E
    from hertzmap.study import products as P
    from hertzmap.study.products.basin_map import basin_map_name
    from hertzmap.study.solve.dense_basins import cell_basin_map

    ds = P.open_store(map_store)
    w, s = _nearest(ds["omega"].values, OMEGA), _nearest(ds["sigma"].values, SIGMA)
    server = Served(map_store, "--workers", "1")
    try:
        _open(browser, server.url)
        ab, pa = _pointer(browser)
        pa.move_to_location(*_map_px(browser, w * F0, s * PRELOAD))
        pa.click()
        ab.perform()
        _wait(lambda: _table(browser), 30, "the orbit table")
        browser.execute_script(
            "Bokeh.documents[0].get_model_by_name('basin_side').value = '100'")
        time.sleep(0.3)
        button = _wait(lambda: (browser.execute_script(
            DEEP + "return deep(document, 'button', []).filter("
            "e => e.textContent.includes('Basin map of this point') && !e.disabled)") or [None])[0], 10,
            "the basin button")
        button.click()
        states = set()

        def state(want):
            st = _text(browser, "#basin_state")
            states.add(st)
            return st == want
        _wait(lambda: state("done"), 240, "the basin map")
        assert "computing..." in states, states
        got = browser.execute_script(READ_BASINS)
        page = np.array(got["flat"], int).reshape(100, 100)
        req = check_request(map_store, w, s, ZETA, "100x100", None, None)
        ref = cell_basin_map(w, s, ZETA, req.q_range, req.v_range, (100, 100),
                             options=req.options, orbits=store_orbits(req),
                             transient_periods=req.transient_periods,
                             record_periods=req.record_periods)
        # the same partition (the page keeps the tiles' colours: a renumbering)
        pairs = set(zip(page.ravel().tolist(), ref.labels.ravel().tolist()))
        assert len(pairs) == len(set(page.ravel())) == len(set(ref.labels.ravel())), pairs
        # beside it: the census's shares and the map's, as the store and the map have them
        census = E.stored_attractors(ds, w, s, ZETA)
        assert census, "the test store has the census at the point"
        cells = browser.execute_script(
            DEEP + "return deep(document, '#basin_table tr[data-attractor]', [])"
            ".map(e => [e.children[1].textContent, e.querySelector('.map').textContent,"
            " e.querySelector('.census').textContent]);")
        stored = read_product(map_store, basin_map_name(w, s, ZETA))
        for name, share_map, share_census in cells:
            if share_map:
                a = next(i for i in range(stored.sizes["basin_attractor"])
                         if f"{int(stored.attractor_period[i])}T" == name)
                assert float(share_map.rstrip(" %")) == pytest.approx(
                    100 * float(ref.attractors[a]["count"]) / 1e4, abs=0.051)
            if share_census:
                assert any(abs(float(share_census.rstrip(" %")) - 100 * c["basin"]) < 0.051
                           for c in census)
        assert (stored["basin_label"].values == ref.labels).all()
        assert _text(browser, "#basin_measures")
        time.sleep(0.5)
        browser.execute_script("window.scrollTo(0, document.body.scrollHeight)")
        time.sleep(0.3)
        _screenshot(browser, _shots(tmp_path) / "explore_basins.png")
    finally:
        rc, _, err = server.stop()
    assert rc == 0, err
    assert "Traceback" not in err, err


@needs_bokeh
def test_a_refused_or_failed_sweep_says_so_and_the_server_goes_on(tmp_path, monkeypatch):
    """No browser: the page's document with its callbacks run here. A line study has one
    sigma: a sweep along sigma is refused, nothing computed; a sweep whose computation raises
    shows "failed" and the message, no traceback; the next one is drawn."""
    from bokeh.document import Document

    from hertzmap.scheduler.cluster.clusters import ClusterSpec
    from hertzmap.scheduler.doors.explore.page import Page
    from hertzmap.scheduler.doors.explore.state import ExploreState
    from hertzmap.study import explore_sweeps as E
    from tests.helpers import blank_results, write_results

    ds = blank_results("[grid]\nomega = [1.96, 1.98, 2.0]\nsigma = 0.5\nzeta = 0.01\n", "line")
    store = write_results(ds, tmp_path / "line.zarr")
    page = Page(Document(), ExploreState(store, ClusterSpec()))
    assert page.sweep_button.disabled                   # no point clicked yet
    page.show_point(1.98, 0.5)
    assert not page.sweep_button.disabled
    page.sweep_axis.value = "sigma"
    page.on_sweep()
    assert "refused" in page.sweep_div.text and "one sigma value" in page.sweep_div.text
    assert page.sweep_job is None

    def broken(*args, **kwargs):
        raise RuntimeError("the integrator gave up")
    monkeypatch.setattr(E, "line_sweep", broken)
    page.sweep_axis.value = "omega"
    page.on_sweep()
    _wait(lambda: page.sweep_job.state != "running", 10, "the sweep's thread")
    page.poll()
    assert "failed" in page.sweep_div.text
    assert "RuntimeError: the integrator gave up" in page.sweep_div.text
    assert "Traceback" not in page.sweep_div.text and not page.sweep_button.disabled
    monkeypatch.undo()
    page.on_sweep()
    assert "computing..." in page.sweep_div.text and page.sweep_button.disabled
    _wait(lambda: page.sweep_job.state != "running", 60, "the sweep's thread")
    page.poll()
    assert "done" in page.sweep_div.text, page.sweep_div.text
    np.testing.assert_array_equal(page.sweep_srcs["down"].data["value"], [1.96, 1.98, 2.0])
    assert list(page.sweep_line_src.data["y"]) == [0.5, 0.5]      # the swept line on the map


@needs_browser
def test_a_store_being_written_shows_done_over_total_and_follows(map_store, browser, tmp_path):
    from hertzmap.scheduler.store import Store, lock_path

    store = tmp_path / "being_written.zarr"
    shutil.copytree(map_store, store)
    s = Store(store)
    n = s.done_mask().size
    assert n >= 2, "the test store needs at least two tasks"
    undone = [idx for idx in np.ndindex(*s.done_mask().shape)][n // 2:]
    for idx in undone:
        s.unmark(idx)
    # a lock held by a live process: a run is writing this store
    lock_path(store).write_text(json.dumps({"host": socket.gethostname(), "pid": os.getpid()}))
    server = Served(store)
    try:
        _open(browser, server.url)
        assert _text(browser, "#tasks_done") == f"{n - len(undone)}/{n}"
        page = browser.execute_script(DEEP + "return deep(document, 'div', [])"
                                      ".map(e => e.textContent).join(' ')")
        assert "being written" in page
        for idx in undone:                                   # the run finishes its blocks
            s.mark_done(idx)
        lock_path(store).unlink()
        _wait(lambda: _text(browser, "#tasks_done") == f"{n}/{n}", 15, "the page to follow")
        _wait(lambda: "complete" in browser.execute_script(
            DEEP + "return deep(document, 'div', []).map(e => e.textContent).join(' ')"),
            10, "complete")
        _screenshot(browser, tmp_path / "explore_followed.png")     # not a gallery image
    finally:
        rc, _, err = server.stop()
    assert rc == 0 and "Traceback" not in err, err


def _listing(path: Path) -> list[str]:
    return sorted(str(p.relative_to(path)) for p in path.rglob("*"))


def test_not_a_store_exits_2_and_changes_nothing(tmp_path):
    plain = tmp_path / "plain"
    plain.mkdir()
    (plain / "notes.txt").write_text("not a store")
    foreign = tmp_path / "foreign.zarr"
    foreign.mkdir()
    (foreign / "zarr.json").write_text(json.dumps({"zarr_format": 3, "node_type": "group",
                                                   "attributes": {}}))
    before = _listing(tmp_path)
    for path, says in ((tmp_path / "missing.zarr", "no such store"),
                       (plain, "not a zarr store"),
                       (foreign, "not written by hertzmap")):
        r = subprocess.run(hertzmap_cmd("explore", str(path), "--port", str(free_port())),
                           env=subprocess_env(), capture_output=True, text=True, timeout=120)
        assert r.returncode == 2, r.stderr
        assert says in r.stderr and str(path) in r.stderr and "Traceback" not in r.stderr
    assert _listing(tmp_path) == before


@needs_bokeh
def test_a_port_in_use_exits_2(map_store):
    before = _listing(map_store.parent)
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        port = taken.getsockname()[1]
        r = subprocess.run(hertzmap_cmd("explore", str(map_store), "--port", str(port)),
                           env=subprocess_env(), capture_output=True, text=True, timeout=120)
    assert r.returncode == 2, r.stdout + r.stderr
    assert f"port {port} is in use" in r.stderr and "Traceback" not in r.stderr
    assert _listing(map_store.parent) == before
