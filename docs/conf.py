"""Sphinx configuration of the fsmctl documentation site.

Build (from the repository root; warnings are errors, as in CI)::

    pip install -e '.[docs]'
    sphinx-build -W --keep-going -b html -d docs/_build/doctrees docs docs/_build/html

(``-d``: Sphinx's pickled doctrees, ~10 MB, stay out of the published ``docs/_build/html``.)

Generated at build time (gitignored, see ``docs/.gitignore``): the API pages of every module in
``fsmctl._PUBLIC_MODULES`` and their autosummary stubs (``docs/api/modules/``, ``docs/api/generated/``), and
the gallery's copies of ``notebooks/*.py`` (``docs/gallery/generated/``), executed by myst-nb in fast mode
(``FSMCTL_FAST=1``, as ``tests/test_notebooks.py`` runs them).  ``FSMCTL_DOCS_EXECUTE=off`` skips the
execution while writing pages (never in CI).

Intersphinx (links to Python, NumPy, SciPy, xarray, Matplotlib, python-control): ``FSMCTL_DOCS_INTERSPHINX``
``auto`` (default) maps each project whose inventory answers within a few seconds and leaves the others out (a
machine without internet, as CI's, builds without those links rather than failing under ``-W``); ``on`` maps all
(a failed download is then a warning, an error under ``-W``: use it for a published build); ``off`` maps none.

The landing page's figure and verdict table and the gallery's thumbnails are committed files written by
``docs/make_landing.py`` from a full ``fsmctl reproduce`` and an executed build (see that script).
"""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS / "_ext"))
sys.path.insert(0, str(DOCS.parent))  # fsmctl and derive/ from this checkout (also when not installed)

import fsmctl_docs  # noqa: E402

import fsmctl  # noqa: E402

# ----------------------------------------------------------------------------- project

project = "fsmctl"
author = "fsmctl developers"
copyright = "fsmctl developers"
release = fsmctl.__version__
version = fsmctl.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.intersphinx",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_nb",
    "sphinxarg.ext",
    "sphinx_copybutton",
    "sphinx_design",
    "fsmctl_docs",
]

root_doc = "index"
exclude_patterns = [
    "_build",
    "_ext",
    "_includes",
    "make_landing.py",
    "_templates",
    "conf.py",
    "examples/*.py",
    "**/.ipynb_checkpoints",
    "Thumbs.db",
    ".DS_Store",
]
templates_path = ["_templates"]
smartquotes = False  # "--from" must stay two hyphens: every command line on the site is copied and run
default_role = "py:obj"  # `fsmctl.simulate` in a docstring links to its page (or to intersphinx)

# ----------------------------------------------------------------------------- generated pages (one source each)

API_PROBLEMS = fsmctl_docs.write_api_pages(stubs=fsmctl_docs.API_STUBS_DIR)  # a page per fsmctl._PUBLIC_MODULES
GALLERY = fsmctl_docs.copy_notebooks()  # notebooks/*.py -> gallery/generated/

# ----------------------------------------------------------------------------- API reference

autosummary_generate = True
autosummary_imported_members = True
autodoc_typehints = "none"  # numpydoc's Parameters sections carry the types
autodoc_member_order = "bysource"
autodoc_default_options = {"exclude-members": "__init__, model_config, model_fields, model_computed_fields"}
add_module_names = False

numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_attributes_as_param_list = False
# the checks of tests/test_api_docs.py: functions and classes here, class members in fsmctl_docs.check_members
numpydoc_validation_checks = set(fsmctl_docs.FUNCTION_CHECKS)
numpydoc_validation_exclude = {
    fsmctl_docs.MEMBER_PATTERN,  # members: METHOD_CHECKS (fsmctl_docs.check_members)
    *("^" + re.escape(m) + "$" for m in fsmctl_docs.public_modules()),  # module docstrings
    r"^fsmctl\.cli\.main$",
}

# ----------------------------------------------------------------------------- MyST and the gallery

myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3
myst_dmath_double_inline = True
nb_render_markdown_format = "myst"  # display(Markdown(...)) outputs: $$ math and pipe tables, as in the pages
nb_custom_formats = {".py": ["jupytext.reads", {"fmt": "py:percent"}]}
nb_execution_mode = os.environ.get("FSMCTL_DOCS_EXECUTE", "force")
nb_execution_timeout = 900
nb_execution_in_temp = True  # a notebook's files (06: ./my_laws/) go to a temporary folder
nb_execution_raise_on_error = True
nb_execution_show_tb = True
nb_merge_streams = True
os.environ["FSMCTL_FAST"] = "1"  # the kernels inherit it: small grids, short horizons (tests/test_notebooks.py)
# the kernels have no ipywidgets: tqdm.auto's "IProgress not found" warning (with this machine's paths) is not content
os.environ["PYTHONWARNINGS"] = ",".join(filter(None, [os.environ.get("PYTHONWARNINGS"), "ignore:IProgress not found"]))
os.environ.pop("MPLBACKEND", None)  # the notebooks' `%matplotlib inline` shows every figure as an image

# ----------------------------------------------------------------------------- intersphinx

INTERSPHINX = {
    "python": "https://docs.python.org/3",
    "numpy": "https://numpy.org/doc/stable",
    "scipy": "https://docs.scipy.org/doc/scipy",
    "xarray": "https://docs.xarray.dev/en/stable",
    "matplotlib": "https://matplotlib.org/stable",
    "control": "https://python-control.readthedocs.io/en/latest",
}
intersphinx_mapping = fsmctl_docs.intersphinx_mapping(INTERSPHINX, os.environ.get("FSMCTL_DOCS_INTERSPHINX", "auto"))
intersphinx_timeout = 10

# ----------------------------------------------------------------------------- HTML

html_theme = "pydata_sphinx_theme"
html_title = f"fsmctl {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
    "header_links_before_dropdown": 6,  # the tutorial, findings, guide, gallery, API and commands in the top bar
}
html_static_path = ["_static"]
html_css_files = ["fsmctl.css"]  # wide tables and long code lines scroll inside the page (docs/_ext/check_html.py)
copybutton_prompt_text = r">>> |\.\.\. |\$ "
copybutton_prompt_is_regexp = True


def _report_api_problems(app):
    from sphinx.util import logging

    for problem in API_PROBLEMS:
        logging.getLogger("fsmctl_docs").warning(problem)


def setup(app):
    app.connect("builder-inited", _report_api_problems)
