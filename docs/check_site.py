"""Open the built documentation in headless Chromium and fail on what a reader would meet broken.

    python docs/check_site.py build/html            # after: python -m sphinx -W -b html docs build/html
    python docs/check_site.py build/html --no-gallery   # a site built with VIBDYN_DOCS_GALLERY=0

The site is served on 127.0.0.1 and every page is opened in the browser. Checked:

- every internal link, image, iframe, stylesheet and script of every page resolves (HTTP 200), and every
  ``#anchor`` of an internal link exists on its target page;
- every image on every page has loaded (``naturalWidth > 0``), and every gallery page shows at least one;
- no gallery page shows the same figure twice (two of its pictures with the same bytes) nor an object's default
  repr in its outputs (``<matplotlib.legend.Legend object at 0x…>``): :func:`gallery_problems`, read from the
  files, without the browser;
- the site's own search (``search.html?q=...``, Sphinx's JavaScript) answers four newcomer's questions with
  the right page among its first three results (:data:`SEARCHES`).

Exit status 1 with the list of problems, 0 with a one-line summary."""

from __future__ import annotations

import argparse
import asyncio
import functools
import http.server
import json
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.parse
import urllib.request
from pathlib import Path

# (a newcomer's question typed as it is into the search box, the page that answers it)
SEARCHES = [
    ("how to name an FRF input", "guide/responses.html"),
    ("how to give a start to a looped mechanism", "guide/loops.html"),
    ("what ω_d means in a table", "guide/glossary.html"),
    ("how to hold a robot with servo stiffness", "guide/robots.html"),
]
TOP = 3  # the answer must be among the first TOP results
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--enable-unsafe-swiftshader", "--window-size=1100,800"]
SKIP_DIRS = ("_static/", "_sources/", "_images/", "_downloads/", "auto_examples/viewers/")

COLLECT = """(() => ({
  links: [...document.querySelectorAll('a[href]')].map(a => a.href),
  resources: [...document.querySelectorAll('img[src], iframe[src], script[src]')].map(e => e.src)
             .concat([...document.querySelectorAll('link[rel=stylesheet][href]')].map(e => e.href)),
  images: [...document.images].map(i => [i.src, i.complete, i.naturalWidth]),
  ids: [...document.querySelectorAll('[id]')].map(e => e.id),
}))()"""


def chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


class Server:
    """The built site on 127.0.0.1 (a thread of this process)."""

    def __init__(self, root: Path):
        class Quiet(http.server.SimpleHTTPRequestHandler):
            def log_message(self, *args):
                pass

        class Httpd(http.server.ThreadingHTTPServer):
            def handle_error(self, request, client_address):
                if not isinstance(sys.exc_info()[1], ConnectionError):  # the browser left a page mid-transfer
                    super().handle_error(request, client_address)

        handler = functools.partial(Quiet, directory=str(root))
        self.httpd = Httpd(("127.0.0.1", 0), handler)
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}/"
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)
        self.thread.start()

    def close(self):
        self.httpd.shutdown()
        self.httpd.server_close()


class Browser:
    """Headless Chromium driven through the DevTools protocol (tornado's websocket client)."""

    def __init__(self, exe: str, flags=FLAGS):
        from tornado.websocket import websocket_connect

        self.dir = tempfile.mkdtemp()
        self.requests: list[str] = []  # every URL the page asked for (with Network.enable)
        self.proc = subprocess.Popen([exe, *flags, f"--user-data-dir={self.dir}/profile", "--remote-debugging-port=0",
                                      "about:blank"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        deadline, port = time.monotonic() + 60, None
        while port is None:
            line = self.proc.stderr.readline().decode(errors="replace")
            m = re.search(r"DevTools listening on ws://127\.0\.0\.1:(\d+)/", line)
            if m:
                port = int(m.group(1))
            elif (not line and self.proc.poll() is not None) or time.monotonic() > deadline:
                self.close()
                raise RuntimeError("Chromium did not start its DevTools server")
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=30) as r:
            target = next(t for t in json.load(r) if t["type"] == "page")
        self.loop = asyncio.new_event_loop()

        async def connect():
            return await websocket_connect(target["webSocketDebuggerUrl"], max_message_size=1 << 28)

        try:
            self.ws = self.loop.run_until_complete(connect())
        except BaseException:
            self.close()
            raise
        self.id = 0
        try:
            self.call("Page.enable")
        except BaseException:
            self.close()
            raise

    def call(self, method, **params):
        self.id += 1
        message = json.dumps({"id": self.id, "method": method, "params": params})

        async def send():
            await self.ws.write_message(message)

        async def receive():
            return await asyncio.wait_for(self.ws.read_message(), 60)

        self.loop.run_until_complete(send())
        while True:
            msg = json.loads(self.loop.run_until_complete(receive()))
            if msg.get("method") == "Network.requestWillBeSent":
                self.requests.append(msg["params"]["request"]["url"])
            if msg.get("id") == self.id:
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return msg.get("result", {})

    def js(self, expression):
        r = self.call("Runtime.evaluate", expression=expression, awaitPromise=True, returnByValue=True)
        if "exceptionDetails" in r:
            raise RuntimeError(f"{expression}: {r['exceptionDetails']}")
        return r["result"].get("value")

    def goto(self, url, ready="true", timeout=60):
        self.call("Page.navigate", url=url)
        self.wait(ready, timeout, url)

    def wait(self, condition, timeout=60, what=""):
        """Until the page is loaded and the JavaScript ``condition`` holds (TimeoutError after ``timeout`` s)."""
        deadline = time.monotonic() + timeout
        while True:
            try:
                if self.js(f"document.readyState === 'complete' && ({condition})"):
                    return
            except RuntimeError:
                pass
            if time.monotonic() > deadline:
                raise TimeoutError(f"{what}: {condition}" if what else condition)
            time.sleep(0.05)

    def close(self):
        try:
            if hasattr(self, "ws"):
                self.ws.close()
                self.loop.close()
        finally:
            self.proc.kill()
            self.proc.wait()
            shutil.rmtree(self.dir, ignore_errors=True)


def _status(url: str, cache: dict) -> int:
    if url not in cache:
        try:
            with urllib.request.urlopen(url, timeout=30) as r:
                cache[url] = r.status
        except urllib.error.HTTPError as e:
            cache[url] = e.code
    return cache[url]


def search(browser: Browser, base: str, query: str) -> list[str]:
    """The result pages (paths relative to the site) Sphinx's search page lists for ``query``, best first."""
    browser.goto(f"{base}search.html?q={urllib.parse.quote(query)}",
                 ready="(document.querySelector('#search-results .search-summary') || {}).innerText > ''")
    # Sphinx creates the summary first and fills its text once the last result is listed
    hrefs = browser.js("[...document.querySelectorAll('#search-results ul.search > li')]"
                       ".map(li => li.querySelector('a').href)")
    return [urllib.parse.urlparse(h).path.lstrip("/") for h in hrefs]


#: an object's default repr, as an output shows it: what a block's last expression leaves when nothing prints it
OBJECT_REPR = re.compile(r"&lt;[\w.]+ object at 0x[0-9a-fA-F]+&gt;")


def gallery_problems(root: str | Path, pages: list[str]) -> list[str]:
    """Problems of the gallery pages ``pages`` (paths under ``root``) read from their HTML: a picture shown twice
    (two images with the same bytes) and an object's default repr in the outputs."""
    import hashlib

    root, problems = Path(root), []
    for page in pages:
        html = (root / page).read_text(encoding="utf-8", errors="replace")
        for m in sorted(set(OBJECT_REPR.findall(html))):
            problems.append(f"{page}: an object's repr in its output: {m.replace('&lt;', '<').replace('&gt;', '>')}")
        seen: dict[str, str] = {}
        for src in re.findall(r'<img [^>]*src="([^"]*sphx_glr[^"]*)"', html):
            path = (root / page).parent / urllib.parse.unquote(src)
            if not path.is_file():
                continue  # (a missing image is reported by the browser's check)
            digest = hashlib.sha256(path.read_bytes()).hexdigest()
            if digest in seen and seen[digest] != src:
                problems.append(f"{page}: the same figure shown twice ({seen[digest]} and {src})")
            seen.setdefault(digest, src)
    return problems


def check(root: str | Path, gallery: bool = True, searches=SEARCHES, exe: str | None = None,
          only: list[str] | None = None) -> tuple[list, dict]:
    """Problems found on the site built at ``root`` (an empty list when none) and a summary of what was
    checked (pages, links, images, gallery pages, the search results). ``only``: visit these pages alone."""
    root = Path(root)
    if not (root / "index.html").is_file():
        return [f"{root}: no index.html (build the site first)"], {}
    exe = exe or chromium()
    if exe is None:
        return ["Chromium is not installed (apt-get install chromium)"], {}
    pages = sorted(p.relative_to(root).as_posix() for p in root.rglob("*.html")
                   if not p.relative_to(root).as_posix().startswith(SKIP_DIRS))
    if only is not None:
        pages = [p for p in pages if p in only]
    problems, status, ids, targets = [], {}, {}, []
    n_images = 0
    gallery_pages = [p for p in pages if re.fullmatch(r"auto_examples/plot_\w+\.html", p)]
    server, browser = Server(root), Browser(exe)
    try:
        for page in pages:
            browser.goto(server.url + page, ready="[...document.images].every(i => i.complete)")
            got = browser.js(COLLECT)
            ids[page] = set(got["ids"])
            for url in got["links"] + got["resources"]:
                if url.startswith(server.url):
                    targets.append((page, url))
            for src, complete, width in got["images"]:
                n_images += 1
                if not (complete and width > 0):
                    problems.append(f"{page}: image {src} did not load")
            shown = any(w > 0 and "sphx_glr" in src for src, _, w in got["images"])
            if gallery and page in gallery_pages and not shown:
                problems.append(f"{page}: a gallery page without its figure")
        if gallery and not gallery_pages and only is None:
            problems.append("no gallery page (auto_examples/plot_*.html) in the site")
        if gallery:
            problems += gallery_problems(root, gallery_pages)
        for page, url in targets:
            parts = urllib.parse.urlparse(url)
            path = parts.path.lstrip("/") or "index.html"
            if _status(server.url + path, status) != 200:
                problems.append(f"{page}: broken link {path}")
            elif parts.fragment and path.endswith(".html") and not path.startswith(SKIP_DIRS):
                if path not in ids:
                    text = (root / path).read_text(encoding="utf-8", errors="replace")
                    ids[path] = set(re.findall(r'id="([^"]+)"', text))
                if urllib.parse.unquote(parts.fragment) not in ids[path]:
                    problems.append(f"{page}: link to a missing anchor {path}#{parts.fragment}")
        found = {}
        for query, want in searches:
            results = search(browser, server.url, query)
            found[query] = results[:TOP]
            if want not in results[:TOP]:
                problems.append(f"search {query!r}: {want} not among the first {TOP} results {results[:TOP]}")
    finally:
        browser.close()
        server.close()
    summary = {"pages": len(pages), "links": len(targets), "images": n_images, "gallery_pages": len(gallery_pages),
               "search": found}
    return problems, summary


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("root", nargs="?", default="build/html", help="the built site (default build/html)")
    ap.add_argument("--no-gallery", action="store_true", help="a site built without running the gallery")
    args = ap.parse_args(argv)
    t = time.perf_counter()
    problems, summary = check(args.root, gallery=not args.no_gallery)
    for p in problems:
        print(p)
    if summary:
        print(f"site check: {summary['pages']} pages, {summary['links']} internal links and resources, "
              f"{summary['images']} images, {summary['gallery_pages']} gallery pages; search: "
              + "; ".join(f"{q!r} -> {r[0] if r else 'nothing'}" for q, r in summary["search"].items())
              + f"; {time.perf_counter() - t:.1f} s")
    print(f"site check: {'FAILED, ' + str(len(problems)) + ' problems' if problems else 'ok'}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
