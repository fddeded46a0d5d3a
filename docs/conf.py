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
    "myst_nb",  # MyST Markdown (myst_parser) and notebooks: docs/tutorial.ipynb, shown with its stored outputs
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",  # a [source] link beside every documented object
    "sphinx.ext.intersphinx",
    "jamflow_cli",
]

root_doc = "index"  # myst_nb registers .md and .ipynb; Sphinx adds .rst
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "**/.ipynb_checkpoints", "tutorial-output"]
# The tutorial's outputs (numbers and figures of every code cell) are stored in docs/tutorial.ipynb and
# shown as stored: the build does not run it. tests/test_tutorial.py runs it again and fails when what
# it prints differs from what is stored; `python tests/test_tutorial.py` stores the outputs anew.
nb_execution_mode = "off"

myst_enable_extensions = ["colon_fence", "deflist", "dollarmath"]
myst_heading_anchors = 3

autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": False}
autodoc_member_order = "bysource"
autodoc_typehints = "signature"  # type hints in the signatures, with names and defaults
autodoc_typehints_format = "short"  # numpy.ndarray shown as ndarray (linked when its inventory is there)
python_maximum_signature_line_length = 100  # a longer signature shows one parameter per line
autodoc_preserve_defaults = True
napoleon_google_docstring = True
napoleon_numpy_docstring = True

# Links to the documentation of the libraries jamflow's API takes and returns. The inventories
# (objects.inv) are fetched over the network at build time; a build without a route to a site
# (CI reaches package registries only) would fail under -W ("failed to reach any of the
# inventories"), so each site is probed first (3 s, in parallel) and only those that answer are
# mapped: names of the others show as plain text. JAMFLOW_DOCS_OFFLINE=1 skips the probe.
INTERSPHINX = {
    "python": "https://docs.python.org/3/",
    "numpy": "https://numpy.org/doc/stable/",
    "scipy": "https://docs.scipy.org/doc/scipy/",
    "h5py": "https://docs.h5py.org/en/stable/",
    "freud": "https://freud.readthedocs.io/en/latest/",
    "gsd": "https://gsd.readthedocs.io/en/stable/",
    "MDAnalysis": "https://docs.mdanalysis.org/stable/",
    "lammps": "https://docs.lammps.org/",
}


def _reachable_inventories(sites: dict[str, str], timeout: float = 3.0) -> dict[str, str]:
    """The sites whose objects.inv answers within ``timeout`` seconds."""
    if os.environ.get("JAMFLOW_DOCS_OFFLINE") == "1":
        return {}
    import urllib.request
    from concurrent.futures import ThreadPoolExecutor

    def answers(url: str) -> bool:
        try:
            with urllib.request.urlopen(urllib.request.Request(url + "objects.inv", method="HEAD"), timeout=timeout) as r:
                return r.status == 200
        except Exception:
            return False

    with ThreadPoolExecutor(len(sites)) as pool:
        ok = dict(zip(sites, pool.map(answers, sites.values())))
    missing = [name for name, good in ok.items() if not good]
    if missing:
        print(f"jamflow docs: no route to the inventories of {', '.join(missing)}: their names are not linked",
              file=sys.stderr, flush=True)
    return {name: url for name, url in sites.items() if ok[name]}


intersphinx_mapping = {name: (url, None) for name, url in _reachable_inventories(INTERSPHINX).items()}
intersphinx_timeout = 10

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
# when some are missing, make them here, before any page is read (the chapter figures they belong
# to, in 2 processes: about 100 s of CPU the first time, nothing once they exist), so that
# `sphinx-build docs docs/_build/html` on a fresh clone needs no other step.
GALLERY_IMAGE = re.compile(r"gallery/images/[A-Za-z0-9_.-]+\.png")
GALLERY_FIGURE = re.compile(r"fig-(\d+)-(\d+)[a-z]?\.png$")  # fig-2-21b.png: chapter Figure 2.21


def _make_gallery(app):
    import subprocess

    from sphinx.errors import ConfigError

    wanted = sorted(set(GALLERY_IMAGE.findall((HERE / "gallery.md").read_text())))
    missing = [name for name in wanted if not (HERE / name).is_file()]
    if not missing:
        return
    figures = sorted({".".join(GALLERY_FIGURE.search(name).groups()) for name in missing})
    print(f"jamflow docs: making the gallery's {len(missing)} pictures (~2 min, once)", file=sys.stderr, flush=True)
    path = os.pathsep.join(filter(None, [str(HERE.parent), os.environ.get("PYTHONPATH")]))  # this checkout's jamflow
    done = subprocess.run([sys.executable, str(HERE / "gallery" / "make_gallery.py"), "--only", *figures],
                          cwd=HERE.parent, env={**os.environ, "PYTHONPATH": path}, stdout=subprocess.DEVNULL)
    still = [name for name in wanted if not (HERE / name).is_file()]
    if done.returncode or still:
        message = (f"docs/gallery/make_gallery.py --only {' '.join(figures)} exited with {done.returncode} and left "
                   f"{len(still)} of the gallery's {len(wanted)} pictures missing ({', '.join(still) or 'none'}); "
                   "its error is above")
        print(f"\njamflow docs: {message}\n", file=sys.stderr)  # first, above Sphinx's error report
        raise ConfigError(message)


# napoleon reads the text before the first colon of an attribute's or property's description as its
# type ("Type: ..."), once per style it parses (numpy, then google). jamflow's types are the
# annotations, and its descriptions (the ``#:`` comments) use colons in prose ("None: not checked"):
# one leading ": " per style gives napoleon an empty type each time, so the whole text stays the
# description. Connected before napoleon (priority 400 < 500).
def _keep_attribute_text(app, what, name, obj, options, lines):
    if what in ("attribute", "data", "property") and lines and lines[0].strip():
        passes = int(bool(app.config.napoleon_numpy_docstring)) + int(bool(app.config.napoleon_google_docstring))
        lines[0] = ": " * passes + lines[0]


def setup(app):
    app.connect("autodoc-process-docstring", _keep_attribute_text, priority=400)
    app.connect("autodoc-process-docstring", _plain_text_docstring)
    app.connect("builder-inited", _make_gallery)
