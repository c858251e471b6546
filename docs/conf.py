"""Sphinx configuration of adaptid's documentation site.

Build (from the repository root, after ``pip install -e ".[docs]"``)::

    python -m sphinx -W --keep-going -b html docs docs/_build/html

The markdown pages of ``docs/`` are read through MyST; the API reference is
generated from the public names only: ``adaptid.__all__`` and the ``__all__``
of each public subpackage (:data:`PUBLIC_MODULES`). Each object is documented
once, under the first public path that exports it (``adaptid.RLS``, not again
as ``adaptid.estimators.RLS``); a later page lists it with a link. The pages
under ``docs/api/`` are written here at every build (they are not committed),
so a name added to or removed from an ``__all__`` changes the reference with
no second list to keep in step.
"""

from __future__ import annotations

import importlib
import inspect
import posixpath
import re
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))  # the checkout, not an installed copy

import adaptid  # noqa: E402

project = "adaptid"
author = "adaptid developers"
copyright = "adaptid developers"
release = version = adaptid.__version__

extensions = [
    "myst_parser",
    "numpydoc",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.extlinks",
    "sphinx.ext.mathjax",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
templates_path = ["_templates"]
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store"]

html_theme = "furo"
html_title = f"adaptid {release}"

# --- API reference -----------------------------------------------------------
autosummary_generate = True
autodoc_default_options = {"member-order": "groupwise"}
autodoc_typehints = "none"  # numpydoc's Parameters section says the types and shapes
numpydoc_show_class_members = False  # the class template lists members itself
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_attributes_as_param_list = True
nitpicky = False  # references to names outside the site (numpy.ndarray) stay plain text

# The docstrings cite papers as :doi:`10.1017/...` (rendered as a link).
extlinks = {"doi": ("https://doi.org/%s", "doi:%s")}

# --- MyST --------------------------------------------------------------------
# No MyST extensions: the pages write their formulas in Unicode and use plain
# CommonMark (+ tables); dollarmath would turn a "$" pair of a future page into math.
myst_heading_anchors = 3  # the pages link to their own sections (#lms-and-nlms)

suppress_warnings = []  # none: every warning is a fault to fix

#: Files outside ``docs/`` that are pages of this site (each included by the
#: page named here), so that links to them from any page land on that page.
INCLUDED_FILES = {"BENCHMARKS.md": "benchmarks.md", "CONTRIBUTING.md": "contributing.md"}
_LINK = re.compile(r"(\]\()([^)\s#:]+)(#[^)\s]*)?(\))")

# --- the API pages -----------------------------------------------------------
#: The public modules, in the order of the layers (docs/architecture.md).
PUBLIC_MODULES = (
    "adaptid", "adaptid.estimators", "adaptid.forgetting", "adaptid.constrained",
    "adaptid.continuous", "adaptid.models", "adaptid.diagnostics",
    "adaptid.datasets", "adaptid.io", "adaptid.plot", "adaptid.codegen",
    "adaptid.sklearn", "adaptid.fleet",
)
API = HERE / "api"
_PUBLIC_OBJECTS = []  # every object the reference documents (filled by write_api_pages)


def _page(modname, seen):
    """The reST of one module's page; ``seen`` maps each object documented so far
    (constants by their path) to its documented path."""
    mod = importlib.import_module(modname)
    own, elsewhere = [], []
    for name in mod.__all__:
        obj = getattr(mod, name)
        documented_by_identity = inspect.isclass(obj) or callable(obj)
        key = id(obj) if documented_by_identity else (modname, name)
        if key in seen:
            elsewhere.append((name, seen[key]))
        else:
            seen[key] = f"{modname}.{name}"
            own.append(name)
            _PUBLIC_OBJECTS.append(obj)
    title = f"``{modname}``"
    lines = [title, "=" * len(title), "", f".. automodule:: {modname}",
             "   :no-members:", "", f".. currentmodule:: {modname}", ""]
    if own:
        lines += [".. autosummary::", "   :toctree: generated/", "", *[f"   {n}" for n in own], ""]
    if elsewhere:
        lines += ["Also exported here (documented under the path shown):", "",
                  ".. autosummary::", "", *[f"   {full}" for _, full in elsewhere], ""]
    return "\n".join(lines)


def write_api_pages():
    """Write ``docs/api/index.rst`` and one page per public module."""
    API.mkdir(exist_ok=True)
    seen = {}
    pages = []
    for modname in PUBLIC_MODULES:
        text = _page(modname, seen)
        path = API / f"{modname}.rst"
        if not path.exists() or path.read_text() != text:
            path.write_text(text)
        pages.append(modname)
    index = "\n".join(["API reference", "=============", "",
                       "The public names of adaptid, module by module (each module's "
                       "``__all__``).", "", ".. toctree::", "   :maxdepth: 1", "",
                       *[f"   {p}" for p in pages], ""])
    path = API / "index.rst"
    if not path.exists() or path.read_text() != index:
        path.write_text(index)


def _relink(text, base, page_dir=None):
    """Rewrite the relative links of a markdown file at ``base`` for this site.

    The pages keep the links that work on GitHub (``../BENCHMARKS.md``,
    ``docs/guide.md`` from the root, ``../src/adaptid/io.py``); here a link to
    a page goes to that page, and a link to any other file of the repository
    becomes a download of that file (MyST's ``path:``), which fails the
    build if the file does not exist. ``base`` is the folder the links are
    written from, ``page_dir`` the folder of the page they are rendered in
    (MyST resolves from there; another folder for an included file).
    """
    page_dir = base if page_dir is None else page_dir

    def one(m):
        target = posixpath.normpath(posixpath.join(base, m.group(2)))
        if target in INCLUDED_FILES:
            path = posixpath.relpath("docs/" + INCLUDED_FILES[target], page_dir)
        elif target.startswith("docs/") and target.endswith(".md"):
            path = posixpath.relpath(target, page_dir)
        else:
            path = "path:" + posixpath.relpath(target, page_dir)
        return m.group(1) + path + (m.group(3) or "") + m.group(4)
    return _LINK.sub(one, text)


def _relink_page(app, docname, source):
    if not docname.startswith("api/"):
        source[0] = _relink(source[0], posixpath.dirname("docs/" + docname))


def _relink_included(app, relative_path, parent_docname, content):
    """The same for a file brought in by ``{include}`` (path relative to docs/)."""
    target = posixpath.normpath(posixpath.join("docs", Path(relative_path).as_posix()))
    content[0] = _relink(content[0], posixpath.dirname(target),
                         posixpath.dirname("docs/" + parent_docname))


def _defined_outside_adaptid(obj):
    obj = getattr(obj, "fget", obj)  # a property: the module of its getter
    module = getattr(obj, "__module__", None)
    return isinstance(module, str) and not module.startswith("adaptid")


def _skip_foreign_members(app, what, name, obj, skip, options):
    """Leave out members inherited from other libraries (scikit-learn's mixins).

    Their docstrings cross-reference labels of those libraries' own sites,
    which this site does not have; they are documented there.
    """
    if what == "class" and _defined_outside_adaptid(obj):
        return True
    return None


def _no_type_docstring(app, what, name, obj, options, lines):
    """A constant (``METHODS``, ``__version__``) has no docstring of its own:
    show none rather than its type's (``tuple``'s "Built-in immutable sequence")."""
    if what in ("data", "attribute") and type(obj).__module__ == "builtins":
        own = type(obj).__doc__
        if isinstance(own, str) and " ".join(lines).split() == own.split():
            lines[:] = []


def _public_bases(app, name, obj, options, bases):
    """Show only bases a reader can look up: public adaptid classes or outside ones."""
    public = {id(o) for o in _PUBLIC_OBJECTS}
    bases[:] = [b for b in bases
                if not getattr(b, "__module__", "").startswith("adaptid") or id(b) in public]


def setup(app):
    app.connect("autodoc-process-docstring", _no_type_docstring, priority=400)  # before numpydoc
    app.connect("autodoc-process-bases", _public_bases)
    app.connect("source-read", _relink_page)
    app.connect("include-read", _relink_included)
    app.connect("autodoc-skip-member", _skip_foreign_members)


write_api_pages()
