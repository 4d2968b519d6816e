"""Every ```python block of README.md runs as written, top to bottom, as one session (later blocks may use
names from earlier ones), in a temporary directory where the repository's models/ are reachable; the README
stays a first visit's page (at most 12 000 characters) whose links and picture exist. The material that moved
out of it is in docs/, whose code tests/test_docs.py runs."""

import fnmatch
import os
import re

from conftest import ROOT

README = ROOT / "README.md"
BLOCK = re.compile(r"^```python[^\n]*\n(.*?)^```", re.S | re.M)


def blocks():
    """(line number, source) of every ```python block of README.md."""
    text = README.read_text(encoding="utf-8")
    return [(text[:m.start(1)].count("\n") + 1, m.group(1)) for m in BLOCK.finditer(text)]


def test_readme_has_python_blocks():
    assert len(blocks()) >= 1  # the first example
    assert all("assert " in source for _, source in blocks())  # each checks what it shows


def test_readme_is_short_and_its_links_exist():
    text = README.read_text(encoding="utf-8")
    assert len(text) <= 12_000, f"README.md has {len(text)} characters: move the details into docs/"
    targets = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text)
    local = [t for t in targets if not re.match(r"\w+://", t)]
    assert "docs/_static/readme-modes.png" in local and "docs/getting-started.md" in local
    missing = [t for t in local if not (ROOT / t).exists()]
    assert not missing, f"README.md links to missing files: {missing}"


def test_readme_blocks_run_top_to_bottom(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    os.symlink(ROOT / "models", tmp_path / "models")
    import matplotlib  # a test dependency: the tour draws plots, off screen

    import matplotlib.pyplot as plt

    matplotlib.use("Agg")
    namespace = {"__name__": "__readme__"}
    try:
        for line, source in blocks():
            code = compile("\n" * (line - 1) + source, str(README), "exec")  # tracebacks give README lines
            try:
                exec(code, namespace)
            except Exception as exc:  # noqa: BLE001 - say which block failed, keep the cause
                raise AssertionError(f"README.md block at line {line} raised {type(exc).__name__}: {exc}") from exc
    finally:
        plt.close("all")
    # what the tour wrote is covered by .gitignore (simple glob lines there), so it never lands in a commit
    ignored = [line.strip() for line in (ROOT / ".gitignore").read_text().splitlines()
               if line.strip() and not line.startswith(("#", "!"))]
    written = [p.name for p in tmp_path.iterdir() if p.name != "models"]
    assert written, "the tour writes files (a01.csv, bode.png, ...): were they moved?"
    uncovered = [name for name in written if not any(fnmatch.fnmatch(name, g.rstrip("/")) for g in ignored)]
    assert not uncovered, f"README examples write files .gitignore does not cover: {uncovered}"
