"""Sphinx configuration of the control_ncs documentation site.

Build it from the repository root with::

    python -m sphinx -W --keep-going -b html docs docs/_build/html

The site follows python-control's own ``doc/``: numpydoc docstrings rendered
through autodoc/autosummary, one generated page per public name, grouped by
topic (``api.rst``). The theory and errata pages are MyST Markdown with
dollar math (MathJax); the teaching notebooks of ``notebooks/`` are rendered
by myst-nb, executed once per build (they are committed without outputs).
"""

from __future__ import annotations

import atexit
import os
import re
import shutil
import sys
import tempfile
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))

import control_ncs  # noqa: E402  (after the path above)

# The kernels that execute the notebooks log only errors: ipykernel 7 warns
# at every start that it runs over TCP without encryption (the build talks to
# a kernel on the same machine through the loopback interface). The profile
# lives in a temporary directory of this build; a caller's own IPYTHONDIR is
# kept.
if "IPYTHONDIR" not in os.environ:
    _profile = Path(tempfile.mkdtemp(prefix="control_ncs_docs_ipython_"))
    (_profile / "profile_default").mkdir()
    (_profile / "profile_default" / "ipython_kernel_config.py").write_text(
        "c = get_config()  # noqa: F821\nc.IPKernelApp.log_level = 'ERROR'\n",
        encoding="utf-8")
    os.environ["IPYTHONDIR"] = str(_profile)
    atexit.register(shutil.rmtree, _profile, ignore_errors=True)

project = "control_ncs"
author = "control_ncs developers"
copyright = "control_ncs developers"
release = control_ncs.__version__
version = ".".join(release.split(".")[:2])

needs_sphinx = "7.0"
extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "numpydoc",
    "sphinx.ext.mathjax",
    # MathJax shipped with the build (copied into _static/mathjax), not
    # fetched from a CDN: the site's formulas render on a machine without
    # internet, as engineering labs often are
    "sphinx-mathjax-offline",
    "myst_nb",
]

# -- API reference (python-control's choices) --------------------------------
autosummary_generate = True
autosummary_imported_members = True
autodoc_default_options = {
    "members": True,
    "exclude-members": "__init__, __weakref__, __repr__, __str__",
}
# type hints are shown in the signature; numpydoc's Parameters carry the prose
autodoc_typehints = "signature"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_attributes_as_param_list = False
templates_path = ["_templates"]
default_role = "py:obj"

# -- MyST: dollar math and section anchors ------------------------------------
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence"]
# GitHub's heading slugs: docs/theory.md#mean-square-stability works on
# GitHub, in the README and on the rendered site alike
myst_heading_anchors = 3

# -- notebooks -----------------------------------------------------------------
# Executed once per build: they are committed without outputs, and the test
# suite's nbmake run keeps none. Always ('force'), not from a cache: a cache
# is keyed on the cells' code only and would show the outputs of an older
# control_ncs after the package changed.
nb_execution_mode = "force"
nb_execution_timeout = 600
nb_execution_raise_on_error = True
nb_execution_show_tb = True
nb_merge_streams = True

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb",
                 ".ipynb": "myst-nb"}
master_doc = "index"
language = "en"
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store",
                    "**.ipynb_checkpoints"]

# -- HTML: the PyData theme ------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"control_ncs {version}"
html_static_path = ["_static"]
html_css_files = ["custom.css"]
html_theme_options = {
    "navbar_align": "left",
    "show_toc_level": 2,
    "navigation_with_keys": False,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
# pages without sub-pages need no left sidebar (it would stay empty)
html_sidebars = {page: [] for page in ("index", "theory", "errata",
                                       "benchmarks")}


def _copy_notebooks() -> None:
    """Copy ``notebooks/*.ipynb`` into ``docs/notebooks/`` (generated).

    Sphinx reads only its source folder; the notebooks stay where users
    open them. Their links to the docs (``../docs/theory.md#...``) are
    rewritten to the copy's place in the site (``../theory.md#...``).
    """
    target = DOCS / "notebooks"
    if target.exists():
        shutil.rmtree(target)
    target.mkdir()
    for source in sorted((ROOT / "notebooks").glob("*.ipynb")):
        text = source.read_text(encoding="utf-8")
        text = re.sub(r"\]\(\.\./docs/", "](../", text)
        (target / source.name).write_text(text, encoding="utf-8")


_copy_notebooks()
# the kernels inherit this process's environment: a non-interactive backend
# set for CI (MPLBACKEND=Agg) would make plt.show() draw nothing on the site
os.environ["MPLBACKEND"] = "module://matplotlib_inline.backend_inline"
