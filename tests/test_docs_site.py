"""The documentation site in headless Chromium (docs/check_site.py): built with Sphinx (-W: warnings are errors)
without running the gallery, every internal link resolves and the site's own search answers the four newcomer's
questions with the right page; and the check itself fails on a broken link, a missing anchor, an image that does
not load and a gallery page without its figure. Skipped without Sphinx (the docs extra) or Chromium, except
under CI (``CI=true``), where a missing Chromium fails. The full build with the gallery is checked by .ci/run.

``VIBDYN_DOCS_SITE=build/html`` checks that site instead of building one."""

import os
import re
import shutil
import subprocess
import sys

import pytest
from conftest import ROOT

sys.path.insert(0, str(ROOT / "docs"))
import check_site

sys.path.remove(str(ROOT / "docs"))


@pytest.fixture(scope="module")
def exe():
    exe = check_site.chromium()
    if exe is None:
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail("Chromium is missing under CI: .ci/run installs it (apt-get install chromium)")
        pytest.skip("Chromium is not installed (apt-get install chromium)")
    return exe


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    given = os.environ.get("VIBDYN_DOCS_SITE")
    if given:
        return ROOT / given
    pytest.importorskip("sphinx", reason="the docs extra: pip install -e '.[docs]'")
    pytest.importorskip("sphinx_gallery", reason="the docs extra: pip install -e '.[docs]'")
    out = tmp_path_factory.mktemp("site") / "html"
    doctrees = out.parent / "doctrees"
    env = {**os.environ, "VIBDYN_DOCS_GALLERY": "0", "OPENBLAS_NUM_THREADS": "1"}
    r = subprocess.run([sys.executable, "-m", "sphinx", "-W", "-q", "-b", "html", "-d", str(doctrees),
                        str(ROOT / "docs"), str(out)], capture_output=True, text=True, env=env, timeout=900)
    assert r.returncode == 0, f"the docs build failed:\n{r.stdout[-3000:]}\n{r.stderr[-6000:]}"
    return out


def test_links_resolve_and_search_answers(site, exe):
    gallery = bool(os.environ.get("VIBDYN_DOCS_SITE"))
    problems, summary = check_site.check(site, gallery=gallery, exe=exe)
    assert not problems, "\n".join(problems)
    print(summary)
    assert summary["pages"] >= 30 and summary["links"] >= 500
    for query, page in check_site.SEARCHES:
        assert page in summary["search"][query][:check_site.TOP], (query, summary["search"][query])


def test_the_check_fails_on_what_is_broken(site, exe, tmp_path):
    broken = tmp_path / "html"
    shutil.copytree(site, broken)
    page = broken / "guide" / "modes.html"
    text = page.read_text(encoding="utf-8")
    text = text.replace("</article>", '<a href="glossary.html#no-such-anchor">x</a><a href="nowhere.html">y</a>'
                                      '<img src="../_static/missing.png" alt="gone"></article>', 1)
    page.write_text(text, encoding="utf-8")
    example = broken / "auto_examples" / "plot_first_model.html"
    example.write_text(re.sub(r"<img [^>]*sphx_glr[^>]*>", "", example.read_text(encoding="utf-8")),
                       encoding="utf-8")
    (broken / "guide" / "robots.html").unlink()  # the guide's table of contents links it
    wrong = [(check_site.SEARCHES[3][0], "guide/loops.html")]  # an answer the search does not give first
    problems, _ = check_site.check(broken, exe=exe, only=["guide/modes.html", "auto_examples/plot_first_model.html",
                                                          "guide/index.html"], searches=wrong)
    text = "\n".join(problems)
    assert "broken link guide/nowhere.html" in text
    assert "missing anchor guide/glossary.html#no-such-anchor" in text
    assert "image" in text and "missing.png did not load" in text
    assert "auto_examples/plot_first_model.html: a gallery page without its figure" in text
    assert "broken link guide/robots.html" in text
    assert "search 'how to hold a robot with servo stiffness': guide/loops.html not among" in text
