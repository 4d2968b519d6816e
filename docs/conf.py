"""Sphinx configuration of vibdyn's documentation: MyST pages, the API reference by autosummary, the gallery by
sphinx-gallery (every ``examples/plot_*.py`` runs during the build). Build: ``python -m sphinx -W -b html docs
build/html`` from the repository root."""

import os
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", "warning")  # the Dask example's pages without its INFO log
sys.path.insert(0, str(DOCS / "_ext"))

from vibdyn_gallery import VIEWER_ROOT  # noqa: E402

import vibdyn  # noqa: E402

project = "vibdyn"
author = "the vibdyn authors"
copyright = "the vibdyn authors, BSD-3-Clause"  # noqa: A001 - Sphinx's name
release = version = vibdyn.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx_gallery.gen_gallery",
    "vibdyn_gallery",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "auto_examples/*.ipynb", "auto_examples/*.py", "auto_examples/*.zip",
                    "auto_examples/*.md5", "auto_examples/*.json", "check_site.py", "_api_more.rst"]
root_doc = "index"

myst_enable_extensions = ["colon_fence", "dollarmath", "deflist"]
myst_heading_anchors = 3

templates_path = ["_templates"]
autosummary_generate = True
autodoc_default_options = {"undoc-members": False}
autodoc_typehints = "description"
autodoc_member_order = "bysource"
autoclass_content = "both"

html_theme = "furo"
html_title = f"vibdyn {release}"
html_static_path = ["_static"]
html_css_files = ["vibdyn.css"]
html_extra_path = [str(VIEWER_ROOT)]  # the gallery's offline viewer pages, at auto_examples/viewers/
html_show_sourcelink = False

# VIBDYN_DOCS_GALLERY=0 builds the pages without running the examples (the search test: a quick build)
_run_gallery = os.environ.get("VIBDYN_DOCS_GALLERY", "1") != "0"
sphinx_gallery_conf = {
    "examples_dirs": "../examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": os.environ.get("VIBDYN_DOCS_EXAMPLES", r"/plot_"),  # a regex: run only some (drafting)
    "plot_gallery": _run_gallery,
    "image_scrapers": ("matplotlib", "vibdyn_gallery.scraper"),  # names, not objects: the config pickles
    "reset_modules": ("matplotlib", "vibdyn_gallery.snapshot_outputs"),
    "download_all_examples": False,
    "remove_config_comments": True,
    "abort_on_example_error": True,
    "only_warn_on_example_error": False,
    "min_reported_time": 1,
    # no block's last value shown: an example prints what it means to show (a Legend, a Figure or a path left
    # as a block's last expression printed <matplotlib.legend.Legend object at 0x…> on the four-bar's page)
    "capture_repr": (),
}
