"""The gallery's pictures and viewer pages, and a check that the API reference lists every public name.

Convention with ``examples/plot_*.py``: an example draws with matplotlib (pyplot figures, or the Figures vibdyn
returns, e.g. ``fig = modes.plot()``), may save PNG files, and saves its offline viewer page as
``viewer_<topic>.html`` in its working directory (sphinx-gallery runs it in ``examples/``). This scraper puts
each new figure or PNG on the page and embeds each new viewer page in an iframe (the page itself is copied to
``auto_examples/viewers/`` of the built site)."""

import re
import shutil
from pathlib import Path

DOCS = Path(__file__).resolve().parents[1]
VIEWER_ROOT = DOCS / "_gallery_viewers"  # html_extra_path: copied to the site's root
VIEWERS = VIEWER_ROOT / "auto_examples" / "viewers"
VIEWERS.mkdir(parents=True, exist_ok=True)

_before: dict[Path, int] = {}  # output file -> mtime (ns) when the current example started


def _outputs(folder: Path) -> dict[Path, int]:
    files = [*folder.glob("*.png"), *folder.glob("viewer_*.html")]
    return {p: p.stat().st_mtime_ns for p in files}


def snapshot_outputs(gallery_conf, fname):
    """sphinx-gallery's reset hook, run before each example: note the files already in the examples folder."""
    _before.clear()
    for src in _example_dirs(gallery_conf):
        _before.update(_outputs(src))


def _example_dirs(gallery_conf):
    dirs = gallery_conf["examples_dirs"]
    dirs = [dirs] if isinstance(dirs, str) else dirs
    return [(Path(gallery_conf["src_dir"]) / d).resolve() for d in dirs]


class VibdynScraper:
    """An image scraper for sphinx-gallery: Figures held by the example's names that pyplot does not manage,
    PNG files and ``viewer_*.html`` pages the example wrote since it started (or since the previous block)."""

    def __init__(self):
        self._figures: dict[str, list] = {}

    def __repr__(self):  # a stable repr: sphinx-gallery hashes its configuration
        return "VibdynScraper()"

    def __call__(self, block, block_vars, gallery_conf):
        from matplotlib.figure import Figure
        from sphinx_gallery.scrapers import figure_rst

        src = Path(block_vars["src_file"])
        seen = self._figures.setdefault(str(src), [])
        images = []
        for value in list(block_vars["example_globals"].values()):
            # a pyplot figure (it has a number, kept after pyplot closes it) is the matplotlib scraper's: taken
            # here too once pyplot had closed it, it was shown twice (the four-bar's potential energy)
            if (isinstance(value, Figure) and value.canvas.manager is None and getattr(value, "number", None) is None
                    and not any(value is f for f in seen)):
                seen.append(value)
                path = next(block_vars["image_path_iterator"])
                value.savefig(path, dpi=100)
                images.append(path)
        rst = ""
        for path, stamp in sorted(_outputs(src.parent).items()):
            if _before.get(path) == stamp:
                continue
            _before[path] = stamp
            if path.suffix == ".png":
                target = next(block_vars["image_path_iterator"])
                shutil.copyfile(path, target)
                images.append(target)
            else:
                shutil.copyfile(path, VIEWERS / path.name)
                rst += _iframe(path.name)
        return figure_rst(images, gallery_conf["src_dir"]) + rst


scraper = VibdynScraper()


def _iframe(name: str) -> str:
    return (
        "\n.. raw:: html\n\n"
        f'    <iframe class="vibdyn-viewer" src="viewers/{name}" title="offline viewer: {name}" '
        'loading="lazy"></iframe>\n'
        f'    <p class="vibdyn-viewer-link"><a href="viewers/{name}">The viewer page alone</a> '
        "(self-contained: pick a mode, play, pause).</p>\n\n"
    )


def api_addition(text: str) -> str:
    """What docs/api.md gets appended when built: an autosummary of the public names of ``vibdyn.__all__`` its
    groups leave out (a name added to the package is in the reference at once; give it a group when you can)."""
    import vibdyn

    listed = set(re.findall(r"^\s*vibdyn\.(\w+)\s*$", text, re.M))
    missing = [n for n in vibdyn.__all__ if n not in listed]
    if not missing:
        return ""
    return "\n".join(["", "## More public names", "", "Names not yet given a group above.", "", "```{eval-rst}",
                      ".. autosummary::", "   :toctree: generated", "   :nosignatures:", "",
                      *[f"   vibdyn.{n}" for n in missing], "```", ""])


def complete_api(app, docname, source):
    if docname == "api":
        source[0] += api_addition(source[0])


def api_stubs(app):
    """The stub pages of the names :func:`api_addition` appends (autosummary scans only files on disk)."""
    from sphinx.ext.autosummary.generate import generate_autosummary_docs

    more = api_addition((Path(app.srcdir) / "api.md").read_text(encoding="utf-8"))
    if more:
        rst = re.sub(r"(?s)^.*```\{eval-rst\}\n(.*)```\n$", r"\1", more)
        path = Path(app.srcdir) / "_api_more.rst"  # excluded from the documents (conf.py), ignored by git
        path.write_text(rst, encoding="utf-8")
        generate_autosummary_docs([str(path)], suffix=".rst", base_path=app.srcdir, app=app)


_LITERAL = re.compile(r"(``.*?``|:\w+:`[^`]*`|`[^`]*`_?)")


def plain_bars(app, what, name, obj, options, lines):
    """vibdyn's docstrings write |x| for a norm or an absolute value, never an RST substitution: escape the
    bars outside literals and roles so that docutils leaves them as they are. A class attribute without a
    docstring of its own (``Ball.q_names``) shows none, not its value's type's (tuple's)."""
    import inspect

    if what == "attribute" and lines and "\n".join(lines).strip() == (inspect.getdoc(type(obj)) or "").strip():
        lines[:] = []
    for i, line in enumerate(lines):
        if "|" in line:
            parts = _LITERAL.split(line)
            lines[i] = "".join(p if k % 2 else p.replace("|", "\\|") for k, p in enumerate(parts))


_BARS = re.compile(r"(?<![\\\w|`])\|(?=\S)([^|`\n]+?)(?<=\S)\|(?![\w|`])")


def gallery_bars(app, docname, source):
    """The same for the gallery's text (an example's comments are RST): |λ| is an absolute value. Code, indented
    by four spaces in sphinx-gallery's pages, is left alone."""
    if docname.startswith("auto_examples/"):
        source[0] = "\n".join(line if line.startswith("    ") else _BARS.sub(r"\\|\1\\|", line)
                              for line in source[0].split("\n"))


def _public_objects():
    import vibdyn

    return [getattr(vibdyn, n) for n in vibdyn.__all__ if not isinstance(getattr(vibdyn, n), (str, type(vibdyn)))]


def skip_public_in_modules(app, what, name, obj, skip, options):
    """A public name has its own page: a module page (vd.response, vd.identify, ...) leaves it out."""
    if what == "module" and any(obj is o for o in _public_objects()):
        return True
    return None


def _models_dir(app) -> Path:
    return Path(app.srcdir).parent / "models"


def _cell(text: str) -> str:
    return " ".join(str(text).split()).replace("|", "\\|")


def reference_tables(app):
    """RST of two tables: every bundled scene with its source and reference values; and, for the scenes with
    reference frequencies about a static operating point, vibdyn's ω beside them, computed now."""
    import time

    import numpy as np
    import tomllib
    from sphinx.util import logging

    import vibdyn as vd

    log = logging.getLogger(__name__)
    files = sorted(_models_dir(app).glob("*.toml"))
    out = [".. list-table:: The bundled scenes (``models/``) and what each must reproduce", "   :header-rows: 1",
           "   :widths: 18 52 30", "", "   * - file", "     - source", "     - reference values"]
    rows = []
    for f in files:
        d = tomllib.loads(f.read_text(encoding="utf-8"))
        ref = d.get("reference", {})
        out += [f"   * - ``{f.name}``", f"     - {_cell(d.get('scene', {}).get('source', ''))}",
                f"     - {_cell(', '.join(k for k in ref if k != 'note')) or '—'}"]
        if "omega" not in ref:
            continue
        t = time.perf_counter()
        op = vd.load_scene(f).build().operating_point()
        if op.regime != "static":
            continue
        modes = op.linearize().modes()
        elapsed = time.perf_counter() - t
        want = np.sort(np.asarray(ref["omega"], float))
        got = np.sort(modes.omega)
        scale = np.where(want > 0, want, 1.0)
        diff = np.max(np.abs(got - want) / scale)
        est = float(np.max(modes.omega_relative_error))
        if diff > 10 * est + 1e-6:  # the references are printed to 7 significant digits or more
            log.warning("models/%s: vibdyn's ω %s differ from the reference %s by %.1e (estimate %.1e)",
                        f.name, got, want, diff, est)
        rows += [f"   * - ``{f.name}``", f"     - {', '.join(f'{w:.6f}' for w in want)}",
                 f"     - {', '.join(f'{w:.6f}' for w in got)}", f"     - {diff:.1e}", f"     - {est:.1e}",
                 f"     - {elapsed * 1e3:.0f} ms"]
    out += ["", ".. list-table:: Natural frequencies ω (rad/s) of the scenes at rest: reference and vibdyn, computed "
            "when this page was built (load, build, equilibrium, linearisation, modes)", "   :header-rows: 1", "",
            "   * - file", "     - reference ω (rad/s)", "     - vibdyn ω (rad/s)",
            "     - largest relative difference", "     - vibdyn's relative error estimate", "     - time", *rows, ""]
    return "\n".join(out)


def setup(app):
    from sphinx.util.docutils import SphinxDirective

    class ReferenceTables(SphinxDirective):
        """``.. vibdyn-reference-tables::`` (in MyST: a ``{vibdyn-reference-tables}`` fence); its tables are RST,
        parsed as RST whatever the page's language."""

        def run(self):
            from docutils.parsers.rst import Parser
            from docutils.utils import new_document

            doc = new_document(self.env.docname, self.state.document.settings)
            Parser().parse(reference_tables(self.env.app), doc)
            return list(doc.children)

    app.add_directive("vibdyn-reference-tables", ReferenceTables)
    app.connect("source-read", complete_api)
    app.connect("builder-inited", api_stubs)
    app.connect("autodoc-process-docstring", plain_bars)
    app.connect("source-read", gallery_bars)
    app.connect("autodoc-skip-member", skip_public_in_modules)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
