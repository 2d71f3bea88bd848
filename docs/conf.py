"""Sphinx configuration of the ctrl_lpv documentation.

Build (warnings are errors)::

    PYTHONPATH=src python -m sphinx -W --keep-going -b html docs docs/_build/html

Autosummary writes one stub page per public name into ``docs/generated/``
(regenerated on every build; see `_clean_generated`).
"""

from __future__ import annotations

import re
import shutil
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
SRC = DOCS.parent / "src"
# Build from a checkout without installing the package.
sys.path.insert(0, str(SRC))

import ctrl_lpv  # noqa: E402
import ctrl_lpv.twomass  # noqa: E402

# -- Project -----------------------------------------------------------------
project = "ctrl_lpv"
author = "ctrl_lpv developers"
copyright = "ctrl_lpv developers"
release = ctrl_lpv.__version__
version = ".".join(release.split(".")[:2])

# -- General -----------------------------------------------------------------
extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    # MathJax 3 bundled in the wheel and copied to _static/mathjax: maths
    # renders offline, with no CDN (the package sets mathjax_path).
    "sphinx-mathjax-offline",
    "numpydoc",
    # The gallery: examples/plot_*.py run at build time, with their output
    # and figures (generated/gallery, rebuilt on every build).
    "sphinx_gallery.gen_gallery",
]
# No sphinx.ext.intersphinx: the docs must build and read without network
# access (tests/test_docs.py checks that no page loads a remote script).

templates_path = ["_templates"]
exclude_patterns = ["_build", "scripts", "Thumbs.db", ".DS_Store"]
source_suffix = {".rst": "restructuredtext"}
root_doc = "index"

# Single backticks are Python cross-references, as in python-control and in
# this package's docstrings. Unresolved targets (python-control, numpy,
# cvxpy names) render as plain literals: nitpicky stays off.
default_role = "py:obj"
nitpicky = False

# -- autodoc / autosummary ---------------------------------------------------
autosummary_generate = True
autosummary_generate_overwrite = True
autosummary_imported_members = False
autodoc_default_options = {
    "members": True,
    "show-inheritance": True,
}
autodoc_member_order = "bysource"
# Type hints stay in the signature; numpydoc renders the documented types.
autodoc_typehints = "signature"

# -- numpydoc ----------------------------------------------------------------
# Members are documented by autodoc (:members:); numpydoc's own member tables
# would document them a second time (duplicate object warnings) or link to
# pages that do not exist.
numpydoc_show_class_members = False
numpydoc_show_inherited_class_members = False
numpydoc_class_members_toctree = False
numpydoc_attributes_as_param_list = True
numpydoc_xref_param_type = False

# -- sphinx-gallery ------------------------------------------------------------
# The examples live in ``examples/`` at the repository root (runnable as
# scripts); their pages, figures and downloads are written to
# ``generated/gallery``, which `_clean_generated` removes before every build,
# so every build runs every example (a failing example fails the build).
sphinx_gallery_conf = {
    "examples_dirs": ["../examples"],
    "gallery_dirs": ["generated/gallery"],
    "filename_pattern": r"/plot_",
    "within_subsection_order": "FileNameSortKey",
    "backreferences_dir": None,
    "doc_module": (),
    "download_all_examples": False,
    "write_computation_times": False,
    "show_memory": False,
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "reset_modules": ("matplotlib",),
    "plot_gallery": "True",
}

# -- HTML --------------------------------------------------------------------
html_theme = "alabaster"
html_static_path: list[str] = []
html_theme_options = {
    "description": "Polytopic LPV systems and certified LMI gain scheduling",
    "fixed_sidebar": True,
}


# -- Build hooks ---------------------------------------------------------------
def _clean_generated(app):
    """Remove stale autosummary stubs before they are regenerated.

    A name removed from ``__all__`` would otherwise leave an orphan page in
    ``docs/generated/``, which fails a ``-W`` build ("document isn't included
    in any toctree").
    """
    shutil.rmtree(Path(app.srcdir) / "generated", ignore_errors=True)


_AUTOSUMMARY_ITEM = re.compile(r"^ {3}~?([A-Za-z_][\w.]*)\s*$")


def _documented_names(rst: Path) -> set[str]:
    """Fully qualified names listed in the autosummary tables of `rst`."""
    names: set[str] = set()
    module = ""
    in_table = False
    for line in rst.read_text(encoding="utf-8").splitlines():
        stripped = line.strip()
        if stripped.startswith(".. currentmodule::"):
            module = stripped.split("::", 1)[1].strip()
            in_table = False
        elif stripped.startswith(".. autosummary::"):
            in_table = True
        elif in_table and line and not line.startswith(" "):
            in_table = False
        elif in_table:
            match = _AUTOSUMMARY_ITEM.match(line)
            if match and not stripped.startswith(":"):
                name = match.group(1)
                names.add(name if name.startswith("ctrl_lpv") else f"{module}.{name}")
    return names


def _check_api_coverage(app):
    """Warn (an error under -W) about public names missing from api.rst."""
    from sphinx.util import logging

    logger = logging.getLogger("ctrl_lpv.docs")
    listed = _documented_names(Path(app.srcdir) / "api.rst")
    public = {f"ctrl_lpv.{n}" for n in ctrl_lpv.__all__}
    public |= {f"ctrl_lpv.twomass.{n}" for n in ctrl_lpv.twomass.__all__}
    for name in sorted(public - listed):
        logger.warning(
            "%s is in __all__ but not in an autosummary table of api.rst",
            name,
            location="api",
        )


def _reexported_data_doc(app, what, name, obj, options, lines):
    """Doc comments (``#:``) of constants re-exported by a package.

    autodoc reads ``#:`` comments only in the module a name is documented
    under. ``ctrl_lpv.twomass.PAPER_GAIN`` is defined, with its comment, in
    ``ctrl_lpv.twomass.model``; without this hook autodoc falls back to the
    docstring of the value's type (`numpy.ndarray`, whose docstring is not
    valid in this project and breaks the build). The comment is looked up in
    the submodules of the package that define the same object.
    """
    if what != "data" or not name.startswith("ctrl_lpv."):
        return
    import importlib
    import pkgutil

    from sphinx.pycode import ModuleAnalyzer

    modname, _, attr = name.rpartition(".")
    try:
        package = importlib.import_module(modname)
        if ("", attr) in ModuleAnalyzer.for_module(modname).find_attr_docs():
            return  # documented where it is listed: autodoc found it
    except Exception:  # noqa: BLE001 (not a module with source: nothing to do)
        return
    for info in pkgutil.iter_modules(getattr(package, "__path__", [])):
        if info.name.startswith("_"):  # private, and __main__ runs the CLI
            continue
        submodule = importlib.import_module(f"{modname}.{info.name}")
        if getattr(submodule, attr, None) is not obj:
            continue
        try:
            docs = ModuleAnalyzer.for_module(submodule.__name__).find_attr_docs()
        except Exception:  # noqa: BLE001 (no source: keep the fallback)
            continue
        comment = docs.get(("", attr))
        if comment:
            lines[:] = list(comment)
            return


_SECTION = re.compile(r"^# \[([\w-]+)\]\s*$", re.MULTILINE)


def _run_tutorial(app):
    """Run ``scripts/tutorial.py`` section by section into ``generated/``.

    The sections (``# [name]`` comments) run in one namespace, as the script
    does; each section's printed output goes to
    ``generated/tutorial/<name>.txt`` and its figures to the same folder, so
    that ``tutorial.rst`` shows code, output and figures of this very build.
    """
    import contextlib
    import io

    import matplotlib

    matplotlib.use("Agg")
    source_path = Path(app.srcdir) / "scripts" / "tutorial.py"
    source = source_path.read_text(encoding="utf-8")
    out = Path(app.srcdir) / "generated" / "tutorial"
    out.mkdir(parents=True, exist_ok=True)
    parts = _SECTION.split(source)  # [preamble, name1, code1, name2, code2, ...]
    namespace = {"__name__": "__tutorial__", "__file__": str(source_path)}
    argv = sys.argv
    sys.argv = [str(source_path), str(out)]
    try:
        exec(compile(parts[0], str(source_path), "exec"), namespace)
        for name, code in zip(parts[1::2], parts[2::2]):
            buffer = io.StringIO()
            with contextlib.redirect_stdout(buffer):
                exec(compile(code, f"{source_path}:[{name}]", "exec"), namespace)
            (out / f"{name}.txt").write_text(buffer.getvalue(), encoding="utf-8")
    finally:
        sys.argv = argv


def _write_cli_help(app):
    """``ctrl-lpv --help`` of every command, for ``cli.rst``."""
    import contextlib
    import io
    import os

    from ctrl_lpv.cli import build_parser

    out = Path(app.srcdir) / "generated" / "cli"
    out.mkdir(parents=True, exist_ok=True)
    os.environ["COLUMNS"] = "80"  # argparse wraps help at the terminal width
    for command in ("", "reproduce", "design", "simulate"):
        buffer = io.StringIO()
        argv = [command, "--help"] if command else ["--help"]
        with contextlib.redirect_stdout(buffer), contextlib.suppress(SystemExit):
            build_parser().parse_args(argv)
        (out / f"{command or 'main'}.txt").write_text(buffer.getvalue())


def setup(app):
    # Before autosummary's own builder-inited handler (priority 500).
    app.connect("builder-inited", _clean_generated, priority=100)
    app.connect("builder-inited", _run_tutorial, priority=200)
    app.connect("builder-inited", _write_cli_help, priority=200)
    app.connect("builder-inited", _check_api_coverage)
    app.connect("autodoc-process-docstring", _reexported_data_doc)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
