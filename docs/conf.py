"""Sphinx configuration of the pgcomm documentation.

Build (what ``.ci/run`` runs; warnings are errors)::

    pip install -e ".[docs]"
    sphinx-build -W --keep-going -b html docs docs/_build/html

The API reference is generated from the docstrings (autosummary walks the package, so a new
module appears without editing this file); the gallery runs ``examples/*.py`` on the twin.
"""

from __future__ import annotations

import inspect
import os
from pathlib import Path

# the examples and autodoc import the library like the command line does (pgcomm.cli): one BLAS thread
# next to XLA's pool, JAX on the CPU; the library itself sets nothing process-wide
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("JAX_PLATFORMS", "cpu")

import pgcomm  # noqa: E402

DOCS = Path(__file__).resolve().parent

project = "pgcomm"
author = "pgcomm authors"
copyright = "pgcomm authors"
release = version = pgcomm.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build"]
templates_path = ["_templates"]
html_theme = "alabaster"
html_theme_options = {"description": "Physics-guided commutation for linear and rotary motors", "fixed_sidebar": True}
html_static_path: list[str] = []

# Markdown pages (the user guide, readable on GitHub too): headings down to ### are link targets (page.md#section)
myst_heading_anchors = 3

# API reference: Google-style docstrings ("Args:", "Returns:", "Attributes:"); attributes as fields of their
# class, so a dataclass's "Attributes:" section and its fields are not described twice
napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_use_ivar = True
autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_member_order = "bysource"
autodoc_preserve_defaults = True
autodoc_typehints = "signature"

# The gallery: every examples/*.py runs on the twin during the build (a failing example fails the build)
sphinx_gallery_conf = {
    "examples_dirs": str(DOCS.parent / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r".*\.py$",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "show_memory": False,
}


def _front_door_table() -> str:
    """The names of ``pgcomm.__all__`` with where they live and their docstring's first line, as an RST table.

    Generated at every build from the package itself, so the table and the front door cannot disagree.
    """
    lines = [".. list-table::", "   :header-rows: 1", "   :widths: 25 45 60", "",
             "   * - name", "     - defined as", "     - what it is"]
    for name in pgcomm.__all__:
        if name.startswith("__"):
            continue
        obj = getattr(pgcomm, name)
        if inspect.isclass(obj) or inspect.isfunction(obj):
            target = f"{obj.__module__}.{obj.__qualname__}"
            doc = inspect.getdoc(obj) or ""
        else:  # a module-level constant: documented under its class's module
            target = f"{type(obj).__module__}.{name}"
            doc = f"an instance of :class:`{type(obj).__module__}.{type(obj).__qualname__}`"
        summary = doc.strip().split("\n\n")[0].replace("\n", " ")
        lines += [f"   * - ``{name}``", f"     - :py:obj:`{target}`", f"     - {summary}"]
    return "\n".join(lines) + "\n"


def _write_generated(app) -> None:
    out = DOCS / "_generated"
    out.mkdir(exist_ok=True)
    path = out / "front_door.rst"
    text = _front_door_table()
    if not path.exists() or path.read_text() != text:  # unchanged files keep Sphinx's incremental build
        path.write_text(text)


def setup(app):
    app.connect("builder-inited", _write_generated)
