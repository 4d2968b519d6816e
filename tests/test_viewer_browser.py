"""The viewer in a real browser (headless Chromium, software WebGL): the offline page of the triple pendulum
and the live server's page are drawn, animate, switch modes when a mode is clicked, and request nothing
outside 127.0.0.1. Skipped when Chromium is missing, except under CI (``CI=true``), where that fails."""

import base64
import io
import json
import os
import re
import shutil
import subprocess
import tempfile
import time
import urllib.parse
import urllib.request
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT

import vibdyn as vd

MODELS = Path(__file__).resolve().parents[1] / "models"
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
         "--disable-background-networking", "--no-first-run", "--disable-component-update", "--disable-sync",
         "--disable-quic", "--window-size=900,700", "--hide-scrollbars"]
PANEL = (0, 0, 400, 270)  # x0, y0, x1, y1: where the panel of modes may be (left, top)


def _chromium():
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail("Chromium is missing under CI: .ci/run installs it (apt-get install chromium)")
        pytest.skip("Chromium is not installed (apt-get install chromium)")
    return exe


@pytest.fixture(scope="module")
def chromium():
    return _chromium()


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    path = tmp_path_factory.mktemp("page") / "triple.html"
    vd.export_html(vd.load_scene(MODELS / "triple_pendulum.toml"), path)
    return path


def _image(png):
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def colours(img):
    return len(np.unique(img.reshape(-1, 3) @ np.array([1, 256, 65536])))


def changed(a, b, tol=24):
    """Mask of pixels that differ (largest channel difference above tol), the panel left out."""
    m = np.abs(a - b).max(axis=2) > tol
    x0, y0, x1, y1 = PANEL
    m[y0:y1, x0:x1] = False
    return m


def screenshot(chromium, url, budget=1500):
    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "shot.png"
        subprocess.run([chromium, *FLAGS, f"--user-data-dir={d}/profile", f"--screenshot={out}",
                        f"--virtual-time-budget={budget}", url], capture_output=True, timeout=120, check=True)
        return _image(out.read_bytes())


def _site_check():
    """docs/check_site.py, whose DevTools client (Browser) these tests drive too."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("check_site", ROOT / "docs" / "check_site.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class Browser(_site_check().Browser):
    """The docs check's headless Chromium, at the viewer's window size, recording the page's requests, with
    screenshots and real mouse clicks."""

    def __init__(self, chromium):
        super().__init__(chromium, FLAGS)
        self.call("Network.enable")
        self.call("Emulation.setDeviceMetricsOverride", width=900, height=700, deviceScaleFactor=1, mobile=False)

    def shot(self):
        return _image(base64.b64decode(self.call("Page.captureScreenshot", format="png")["data"]))

    def click(self, selector):
        """A real mouse click (pressed and released) at the middle of the element."""
        r = self.js(f"(() => {{ const b = document.querySelector({json.dumps(selector)}).getBoundingClientRect();"
                    " return [b.x + b.width / 2, b.y + b.height / 2]; })()")
        for kind in ("mousePressed", "mouseReleased"):
            self.call("Input.dispatchMouseEvent", type=kind, x=r[0], y=r[1], button="left", clickCount=1)


@pytest.fixture
def browser(chromium):
    b = Browser(chromium)
    yield b
    b.close()


def _outside_local(urls):
    bad = []
    for u in urls:
        p = urllib.parse.urlparse(u)
        if p.scheme in ("http", "https", "ws", "wss") and p.hostname not in ("127.0.0.1", "localhost"):
            bad.append(u)
    return bad


def test_offline_page_is_drawn_and_animates(chromium, page):
    """Two frames of mode 1 (t = 0.25 s and 0.75 s of its 2 s loop: opposite swings) are drawn scenes with
    many colours, and differ where the pendulum is (the middle of the view), not in the panel."""
    a = screenshot(chromium, f"{page.as_uri()}#mode=1&t=0.25")
    b = screenshot(chromium, f"{page.as_uri()}#mode=1&t=0.75")
    assert a.shape == (700, 900, 3)
    ca, cb = colours(a), colours(b)
    print(f"offline page screenshots 900×700: {ca} and {cb} distinct colours")
    assert min(ca, cb) > 500  # shaded bodies, grid, background gradient: not a blank page
    m = changed(a, b)
    assert m.sum() > 300
    ys, xs = np.nonzero(m)
    assert 0.3 * 900 < xs.min() and xs.max() < 0.7 * 900  # the pendulum hangs in the middle of the view


def test_offline_page_mode_control_and_no_request_outside(browser, page):
    """Clicking mode 3 in the list switches the animation: paused at the same time it is the picture of
    mode 3 (as the page shows it for #mode=3) and not that of mode 1. Nothing is requested from any host."""
    browser.goto(f"{page.as_uri()}#mode=1&t=0.2", "typeof viewer === 'object' && viewer.animator.actions.length > 0")
    time.sleep(0.5)
    one = browser.shot()
    browser.click(".vd-row[data-index='2']")
    assert browser.js("document.querySelectorAll('.vd-row')[2].classList.contains('vd-on')")
    assert browser.js("viewer.animator.playing")
    browser.js("viewer.animator.seek(0.2); viewer.animator.pause(); true")
    time.sleep(0.5)
    clicked = browser.shot()
    browser.js("location.hash = 'mode=3&t=0.2'; true")
    time.sleep(0.5)
    three = browser.shot()
    assert changed(clicked, one).sum() > 300
    assert changed(clicked, three).sum() < 0.02 * changed(one, three).sum() + 20
    assert not _outside_local(browser.requests)
    text = page.read_text(encoding="utf-8")
    # every URL with a literal host in the page; ws://${location.host} is meshcat's (unused) live connection
    urls = [u for u in re.findall(r"(?:https?|wss?)://[A-Za-z0-9][A-Za-z0-9.:\-]*", text)
            if not u.startswith("http://www.w3.org")]  # XML namespace names, never fetched
    assert not _outside_local(urls)


def test_live_page_draws_switches_modes_and_stays_local(browser):
    viewer = vd.view(vd.load_scene(MODELS / "triple_pendulum.toml"))
    try:
        assert viewer.url.startswith("http://127.0.0.1:") and viewer.meshcat_url.startswith("http://127.0.0.1:")
        browser.goto(viewer.url + "#mode=1", "document.querySelector('.vd-row.vd-on') !== null")
        deadline = time.monotonic() + 30
        while colours(a := browser.shot()) < 500 and time.monotonic() < deadline:
            time.sleep(0.3)
        time.sleep(0.6)
        b = browser.shot()
        print(f"live page screenshots 900×700: {colours(a)} and {colours(b)} distinct colours")
        assert min(colours(a), colours(b)) > 500
        assert changed(a, b).sum() > 100  # it animates
        browser.click("#vd-play")  # pause: mode 1 on its first frame
        browser.wait("document.getElementById('vd-play').textContent === 'play'", 20)
        time.sleep(1.0)
        one = browser.shot()
        browser.click(".vd-row[data-index='2']")
        browser.wait("document.querySelectorAll('.vd-row')[2].classList.contains('vd-on')", 20)
        assert viewer.state()["current"] == 2
        browser.click("#vd-play")
        browser.wait("document.getElementById('vd-play').textContent === 'play'", 20)
        time.sleep(1.0)
        three = browser.shot()
        assert changed(one, three).sum() > 300  # another mode shape
        assert not _outside_local(browser.requests)
        assert all(urllib.parse.urlparse(u).scheme in ("http", "ws", "data", "blob", "about")
                   for u in browser.requests)
    finally:
        viewer.close()
    assert not viewer.running
