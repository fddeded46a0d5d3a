"""Sphinx configuration of the jamflow documentation site (build: sphinx-build -W -b html docs docs/_build/html)."""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # jamflow from this checkout, installed or not
sys.path.insert(0, str(HERE / "_ext"))
os.environ.setdefault("COLUMNS", "100")  # argparse help wraps at a fixed width in the CLI reference

import jamflow  # noqa: E402

project = "jamflow"
author = "the jamflow developers"
copyright = "the jamflow developers (MIT License)"
release = jamflow.__version__
version = release

extensions = [
    "myst_nb",  # MyST Markdown (myst_parser) and notebooks: docs/tutorial.ipynb, shown as stored (not executed)
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "jamflow_cli",
]

root_doc = "index"  # myst_nb registers .md and .ipynb; Sphinx adds .rst
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "**/.ipynb_checkpoints", "tutorial-output"]
nb_execution_mode = "off"  # the tutorial is executed by tests/test_tutorial.py, not by the site build

myst_enable_extensions = ["colon_fence", "deflist", "dollarmath"]
myst_heading_anchors = 3

autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": False}
autodoc_member_order = "bysource"
autodoc_typehints = "none"  # signatures show names and defaults; the docstrings say what they are
autodoc_preserve_defaults = True
napoleon_google_docstring = True
napoleon_numpy_docstring = True

html_theme = "furo"
html_title = f"jamflow {release}"


# jamflow's docstrings are plain text, read in a terminal: |x| is an absolute value or a norm,
# never a reST substitution, and "- " lists follow a paragraph line without a blank line. Make
# them valid reST here (outside literal blocks) so they render as written, without touching the
# code: escape the bars, and open and close each list with a blank line.
_BULLET = re.compile(r"^(\s*)(- |\d+\. )")


def _plain_text_docstring(app, what, name, obj, options, lines):
    out, literal_indent, list_indent = [], None, None
    for line in lines:
        indent = len(line) - len(line.lstrip())
        if literal_indent is not None and line.strip() and indent <= literal_indent:
            literal_indent = None
        if literal_indent is not None:
            out.append(line)
            continue
        line = line.replace("|", r"\|")
        bullet = _BULLET.match(line)
        if list_indent is not None and line.strip() and indent <= list_indent and not bullet:
            list_indent = None  # the list ended: close it
            if out and out[-1].strip():
                out.append("")
        if bullet and list_indent is not None and indent > list_indent:
            line = line[:indent] + "\\" + line[indent:]  # "- x" continuing an item, not a nested list
        elif bullet and list_indent is None:
            list_indent = indent
            if out and out[-1].strip():
                out.append("")
        out.append(line)
        if line.rstrip().endswith("::"):
            literal_indent = indent
    lines[:] = out


# The gallery's pictures (docs/gallery.md) are made by docs/gallery/make_gallery.py, not committed:
# stop the build with a message saying so when one is missing, before any page is read.
GALLERY_IMAGE = re.compile(r"gallery/images/[A-Za-z0-9_.-]+\.png")


def _check_gallery(app):
    from sphinx.errors import ConfigError

    wanted = sorted(set(GALLERY_IMAGE.findall((HERE / "gallery.md").read_text())))
    missing = [name for name in wanted if not (HERE / name).is_file()]
    if missing:
        message = (f"{len(missing)} of the gallery's {len(wanted)} pictures are missing ({', '.join(missing)}): make "
                   "them first with `python docs/gallery/make_gallery.py` (about a minute on 2 cores)")
        print(f"\njamflow docs: {message}\n", file=sys.stderr)  # first, above Sphinx's error report
        raise ConfigError(message)


def setup(app):
    app.connect("autodoc-process-docstring", _plain_text_docstring)
    app.connect("builder-inited", _check_gallery)
