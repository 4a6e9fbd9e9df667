"""Sphinx configuration of the vfrs documentation site (docs/ is the source folder).

Build (warnings are errors, cross-references checked, no network):

    python -m sphinx -W --keep-going -n -b html docs docs/_build/html

or ``scripts/build_docs.sh`` (the same, plus the offline link check). ``-D plot_gallery=0``
skips running the gallery scripts. The built site (docs/_build), the gallery pages
sphinx-gallery writes (docs/auto_gallery) and the generated reference text
(docs/reference/_generated) are build outputs, never committed.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))
os.environ.setdefault("MPLBACKEND", "Agg")

project = "vfrs"
author = "the vfrs authors"
copyright = "the vfrs authors"
try:
    from vfrs._version import __version__ as release
except Exception:  # pragma: no cover - the package is not importable
    release = "unknown"
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx_gallery.gen_gallery",
    "sphinxarg.ext",
    "vfrs_docs",  # docs/_ext/vfrs_docs.py: the scene reference and the verification list, from the code
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = [
    "_build",
    "Thumbs.db",
    ".DS_Store",
    "reference/_generated",  # included by reference/scene.md, not pages of their own
    "gallery/README.rst",
    "auto_gallery/*.ipynb",
    "auto_gallery/*.py",
    "auto_gallery/*.zip",
    "auto_gallery/*.md5",
    "auto_gallery/*.json",
]

# ---- MyST (the pages are Markdown) ----------------------------------------------------
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
# Anchors for headings down to ####, so `page.md#a-heading` links resolve (and are checked).
myst_heading_anchors = 4

# ---- cross-references: -n (nitpicky) checks every one ---------------------------------
nitpicky = True
nitpick_ignore_regex = [
    # vfrs's internal modules that the API reference does not document (the docstrings name
    # them for readers of the source), the front's re-exports (vfrs.Scene is vfrs.scene.Scene)
    # and names the docstrings give unqualified within their module
    (r"py:.*", r"vfrs\.(dynamics|enforcement|contact|checkpoint|roles|flow|acoustics|history|output|"
               r"studies\.(validation|accuracy|derived|extra|sweep\.\w+|converge\.\w+)|"
               r"assembly|linalg|finite_strain|scene\.(plausibility|sizes|selectors|keypath|"
               r"overrides|contact_keys|toml_writer)|params\.table|meshes\.(base|m5_family))(\..*)?"),
    (r"py:.*", r"vfrs\.figures(\..*)?"),  # what the effects' figures are drawn with
    (r"py:.*", r"vfrs\.[A-Z][A-Za-z]*"),
    (r"py:.*", r"[A-Za-z_][A-Za-z0-9_]*"),
    # types of other packages (no intersphinx: the build is offline)
    (r"py:.*", r"(np|numpy|scipy|sp|meshio|dask|distributed|pyarrow|matplotlib|pathlib|collections|typing|os|"
               r"argparse|dataclasses|concurrent|types|io|enum)(\..*)?"),
    (r"py:.*", r"(Path|PathLike|Any|Callable|Iterable|Iterator|Sequence|Mapping|MutableMapping|Optional|"
               r"ClassVar|ndarray|NDArray|ArrayLike|Figure|Axes|Client|DataFrame|datetime|SparseMatrix|"
               r"csr_matrix|csc_matrix|coo_matrix|spmatrix|sparray|TextIO|IO|Self|Literal)"),
]

# ---- API reference --------------------------------------------------------------------
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": False}
autodoc_member_order = "bysource"
autodoc_typehints = "none"  # the signatures say the names; types are in the docstrings' prose
autosummary_generate = False

# ---- gallery --------------------------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": ["gallery"],
    "gallery_dirs": ["auto_gallery"],
    "filename_pattern": r"/plot_",
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "abort_on_example_error": True,
    "show_memory": False,
    "min_reported_time": 1,
}

# ---- theme ----------------------------------------------------------------------------
# pydata-sphinx-theme: the theme of NumPy, SciPy, scikit-learn, PyVista and matplotlib, whose
# sites this project's users already read (docs/about.md says why).
html_theme = "pydata_sphinx_theme"
html_title = f"vfrs {release}"
html_theme_options = {
    "navigation_depth": 3,
    "show_toc_level": 2,
    "navbar_align": "left",
    # resolve each page's section navigation and drop the left sidebar where it is empty (most
    # pages: the navbar holds the sections), so the article gets the width (tables at 1280 px)
    "sidebar_includehidden": False,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version", "theme-version"],
}
html_sidebars = {"**": ["sidebar-nav-bs"]}
html_static_path = ["_static"]
html_css_files = ["vfrs.css"]  # docs/_static/vfrs.css: tables and lists that fit the article
html_last_updated_fmt = None
