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
            if isinstance(value, Figure) and value.canvas.manager is None and not any(value is f for f in seen):
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


def _iframe(name: str) -> str:
    return (
        "\n.. raw:: html\n\n"
        f'    <iframe class="vibdyn-viewer" src="viewers/{name}" title="offline viewer: {name}" '
        'loading="lazy"></iframe>\n'
        f'    <p class="vibdyn-viewer-link"><a href="viewers/{name}">The viewer page alone</a> '
        "(self-contained: pick a mode, play, pause).</p>\n\n"
    )


def check_api_reference(app):
    """Warn (an error under -W) when docs/api.md leaves out a name of ``vibdyn.__all__``."""
    import re

    import vibdyn
    from sphinx.util import logging

    text = (Path(app.srcdir) / "api.md").read_text(encoding="utf-8")
    listed = set(re.findall(r"^\s*vibdyn\.(\w+)\s*$", text, re.M))
    missing = sorted(set(vibdyn.__all__) - listed)
    if missing:
        logging.getLogger(__name__).warning("api.md leaves out public names of vibdyn.__all__: %s",
                                            ", ".join(missing))


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


def _public_objects():
    import vibdyn

    return [getattr(vibdyn, n) for n in vibdyn.__all__ if not isinstance(getattr(vibdyn, n), (str, type(vibdyn)))]


def skip_public_in_modules(app, what, name, obj, skip, options):
    """A public name has its own page: a module page (vd.response, vd.identify, ...) leaves it out."""
    if what == "module" and any(obj is o for o in _public_objects()):
        return True
    return None


def setup(app):
    app.connect("builder-inited", check_api_reference)
    app.connect("autodoc-process-docstring", plain_bars)
    app.connect("autodoc-skip-member", skip_public_in_modules)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
