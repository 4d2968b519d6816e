"""The documentation's code runs and says what it shows: every ```python block of the pages under docs/ runs
as written, each page top to bottom as one session, in a temporary directory with no models/ folder (bundled
models load by name, as installed); each page with code asserts something; the API reference covers every public
name of vibdyn."""

import re

import pytest
from conftest import ROOT

import vibdyn

DOCS = ROOT / "docs"
BLOCK = re.compile(r"^```python[^\n]*\n(.*?)^```", re.S | re.M)
PAGES = sorted(p for p in DOCS.rglob("*.md") if BLOCK.search(p.read_text(encoding="utf-8"))
               and not p.relative_to(DOCS).parts[0].startswith(("_", "auto_examples", "generated")))


def test_the_guide_has_code():
    names = {p.relative_to(DOCS).as_posix() for p in PAGES}
    for page in ("getting-started.md", "guide/scenes.md", "guide/equilibria.md", "guide/modes.md",
                 "guide/responses.md", "guide/loops.md", "guide/simulation.md", "guide/campbell-sweeps.md",
                 "guide/viewer.md", "guide/robots.md"):
        assert page in names, f"docs/{page} lost its Python code"


@pytest.mark.parametrize("page", PAGES, ids=[p.relative_to(DOCS).as_posix() for p in PAGES])
def test_page_code_runs(page, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # no models/ folder here: the pages load the bundled models by name, as installed
    import matplotlib
    import matplotlib.pyplot as plt

    matplotlib.use("Agg")
    text = page.read_text(encoding="utf-8")
    blocks = [(text[:m.start(1)].count("\n") + 1, m.group(1)) for m in BLOCK.finditer(text)]
    assert any("assert " in src for _, src in blocks), f"{page.name}: its code shows numbers but checks none"
    namespace = {"__name__": "__docs__"}
    try:
        for line, source in blocks:
            code = compile("\n" * (line - 1) + source, str(page), "exec")  # tracebacks give the page's lines
            try:
                exec(code, namespace)
            except Exception as exc:  # noqa: BLE001 - say which block failed, keep the cause
                raise AssertionError(f"{page.relative_to(ROOT)} block at line {line} raised "
                                     f"{type(exc).__name__}: {exc}") from exc
    finally:
        plt.close("all")


def test_api_reference_lists_every_public_name():
    """docs/api.md's groups name only public names; the build appends those they leave out (new names)."""
    import sys

    sys.path.insert(0, str(DOCS / "_ext"))
    try:
        from vibdyn_gallery import api_addition
    finally:
        sys.path.remove(str(DOCS / "_ext"))
    text = (DOCS / "api.md").read_text(encoding="utf-8")
    grouped = set(re.findall(r"^\s*vibdyn\.(\w+)\s*$", text, re.M))
    unknown = grouped - set(vibdyn.__all__)
    assert not unknown, f"docs/api.md lists names vibdyn does not export: {unknown}"
    built = set(re.findall(r"^\s*vibdyn\.(\w+)\s*$", text + api_addition(text), re.M))
    assert built == set(vibdyn.__all__)
    assert len(grouped) >= 60  # the groups hold most names
