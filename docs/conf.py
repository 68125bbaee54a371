"""Sphinx configuration of the stickslip documentation site.

Build (inside ./dev, which has Sphinx, MyST, sphinx-gallery and the RTD theme):

    ./dev python3 -m sphinx -W --keep-going -b html docs docs/_build/html

The pages are MyST Markdown. ``_ext/stickslip_reference.py`` writes the command and
scene-key references from the code when the build starts; sphinx-gallery runs the literate
demos of ``demos/`` and renders them with their figures into ``docs/demos/``.
``STICKSLIP_DOCS_DEMOS=0`` skips running the demos (their pages then show the code only);
``STICKSLIP_DOCS_RERUN=1`` runs every demo, also those unchanged since the last build.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
REPO = DOCS.parent
# stickslip itself is imported from its install (./dev's editable one, or `pip install .`)
sys.path.insert(0, str(DOCS / "_ext"))

project = "stickslip"
author = "the stickslip developers"
copyright = "the stickslip developers"  # noqa: A001 (Sphinx's name)
from stickslip.solver import __version__ as release  # noqa: E402

version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx_gallery.gen_gallery",
    "stickslip_reference",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "demos/*.md5", "demos/*.py", "demos/*.ipynb", "demos/*.zip",
                    "demos/*.json", "**/*.jsonl"]

myst_heading_anchors = 3
smartquotes = False  # keep "--set" and quotes as typed (commands and TOML)
myst_enable_extensions = ["colon_fence"]
suppress_warnings = ["myst.header"]  # pages that start below level 1 (kept from the notes)

autodoc_member_order = "bysource"
autodoc_typehints = "signature"
napoleon_google_docstring = True
napoleon_numpy_docstring = False

html_theme = "sphinx_rtd_theme"
html_title = f"stickslip {release}"
html_static_path = ["_static"]
html_css_files = ["stickslip.css"]
html_theme_options = {"navigation_depth": 3, "collapse_navigation": False}

sphinx_gallery_conf = {
    "examples_dirs": str(REPO / "demos"),
    "gallery_dirs": str(DOCS / "demos"),
    "filename_pattern": r"/demo_",
    "plot_gallery": os.environ.get("STICKSLIP_DOCS_DEMOS", "1") != "0",
    # CI runs every demo on every build (not only the changed ones): they test the API
    "run_stale_examples": os.environ.get("STICKSLIP_DOCS_RERUN", "0") == "1",
    "abort_on_example_error": True,
    "only_warn_on_example_error": False,
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "show_memory": False,
    "min_reported_time": 1e9,
}
