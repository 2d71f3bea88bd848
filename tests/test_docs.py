"""The documentation: numpydoc docstrings of the public API and a -W build."""

import inspect
import re
import subprocess
import sys
from pathlib import Path

import pytest

import ctrl_lpv
import ctrl_lpv.plotting
import ctrl_lpv.twomass

docscrape = pytest.importorskip("numpydoc.docscrape")

DOCS = Path(__file__).resolve().parents[1] / "docs"
MODULES = (ctrl_lpv, ctrl_lpv.twomass, ctrl_lpv.plotting)
PUBLIC = [
    (f"{module.__name__}.{name}", getattr(module, name))
    for module in MODULES
    for name in module.__all__
]
CALLABLES = [(n, obj) for n, obj in PUBLIC if callable(obj)]


def takes_arguments(obj) -> bool:
    try:
        signature = inspect.signature(obj)
    except (TypeError, ValueError):
        return True
    return any(name not in ("self", "cls") for name in signature.parameters)


@pytest.mark.parametrize("name, obj", CALLABLES, ids=[n for n, _ in CALLABLES])
def test_public_docstring_has_numpydoc_sections(name, obj):
    if inspect.isclass(obj):
        doc = docscrape.ClassDoc(obj, config={"show_class_members": False})
        # Dataclasses and exceptions document their fields as attributes.
        documented = doc["Parameters"] or doc["Attributes"]
        if takes_arguments(obj):
            assert documented, f"{name}: no Parameters or Attributes section"
    else:
        doc = docscrape.FunctionDoc(obj)
        if takes_arguments(obj):
            assert doc["Parameters"], f"{name}: no Parameters section"
        assert doc["Returns"] or doc["Yields"], f"{name}: no Returns section"
    summary = " ".join(doc["Summary"])
    assert summary and len(summary) < 80, f"{name}: summary line {summary!r}"


@pytest.fixture(scope="module")
def html(tmp_path_factory):
    pytest.importorskip("sphinx")
    out = tmp_path_factory.mktemp("html")
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "sphinx",
            "-W",
            "--keep-going",
            "-q",
            "-b",
            "html",
            str(DOCS),
            str(out),
        ],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stderr[-5000:]
    return out


def test_docs_build_with_warnings_as_errors(html):
    for page in ("index", "tutorial", "cli", "errata", "numerics", "api"):
        assert (html / f"{page}.html").is_file()
    tutorial = (html / "tutorial.html").read_text()
    for figure in ("published", "designs", "alpha_step", "backstepping"):
        assert f"{figure}.png" in tutorial
        assert list(html.rglob(f"{figure}.png")), f"{figure}.png not in the build"


GALLERY = sorted(p.stem for p in (DOCS.parent / "examples").glob("plot_*.py"))


def test_objectives_and_discrete_pages_in_the_build(html):
    index = (html / "index.html").read_text()
    for page in ("objectives", "discrete"):
        assert (html / f"{page}.html").is_file()
        assert f'href="{page}.html"' in index, f"{page} not in the toctree"
    # The citations of the objectives page resolve (no unknown-target marks).
    text = (html / "objectives.html").read_text()
    for label in ("SGC97", "GAC96", "dOBG99", "ATB01", "OP07", "DB01"):
        assert label in text


@pytest.mark.parametrize("example", GALLERY)
def test_gallery_example_ran_with_a_figure(html, example):
    """Each example runs at build time: its page shows output and a figure."""
    page = html / "generated" / "gallery" / f"{example}.html"
    assert page.is_file(), f"no gallery page for {example}"
    text = page.read_text()
    figures = list(html.rglob(f"sphx_glr_{example}_*.png"))
    figures = [f for f in figures if "thumb" not in f.name]
    assert figures, f"{example}: no figure in the build"
    assert any(f.name in text for f in figures)
    assert "sphx-glr-script-out" in text, f"{example}: no captured output"


_REMOTE = re.compile(
    r"""<(?:script|link|img|iframe)\b[^>]*\b(?:src|href)\s*=\s*["']"""
    r"""((?:[a-z][a-z0-9+.-]*:)?//[^"']*)""",
    re.IGNORECASE,
)
_SCRIPT = re.compile(r"""<script\b[^>]*\bsrc\s*=\s*["']([^"']*)""", re.IGNORECASE)


def test_docs_read_offline_with_maths_rendered_locally(html):
    """No page loads anything remote; maths uses the MathJax in the build."""
    pages = sorted(html.rglob("*.html"))
    remote = {
        str(page.relative_to(html)): _REMOTE.findall(page.read_text()) for page in pages
    }
    assert not {k: v for k, v in remote.items() if v}, "remote resources"
    math_pages = [p for p in pages if 'class="math' in p.read_text()]
    names = {p.name for p in math_pages}
    # Maths of index.rst and of the PolytopicStateSpace docstring.
    assert {"index.html", "ctrl_lpv.PolytopicStateSpace.html"} <= names
    for page in math_pages:
        scripts = _SCRIPT.findall(page.read_text())
        mathjax = [s for s in scripts if "mathjax" in s.lower()]
        assert mathjax, f"{page.name}: maths but no MathJax script"
        for src in mathjax:
            local = (page.parent / src.split("?")[0]).resolve()
            assert local.is_file(), f"{page.name}: {src} is not in the build"
            assert html.resolve() in local.parents
            assert "MathJax" in local.read_text(errors="replace")
            # MathJax's CommonHTML output loads its fonts beside the script.
            assert list(local.parent.glob("output/chtml/fonts/woff-v2/*.woff"))


SEE_ONLY = re.compile(r"^\s*see\b", re.IGNORECASE)


@pytest.mark.parametrize("name, obj", CALLABLES, ids=[n for n, _ in CALLABLES])
def test_public_summary_says_what_it_does(name, obj):
    """A summary line is a statement, not only a pointer ("See X")."""
    summary = (inspect.getdoc(obj) or "").split("\n\n", 1)[0]
    assert not SEE_ONLY.match(summary), f"{name}: summary {summary!r}"


# A description that is only a reference: "See `X`." or "As in `X`.".
POINTER = re.compile(
    r"^(see|as in)\s+`[^`]+`(\s*\([^)]*\))?(\s+for the \w+)?\.?$", re.IGNORECASE
)


def pointer_only_descriptions(obj) -> list[str]:
    """Parameters, Returns and Raises entries that only point elsewhere."""
    objects = [obj]
    if inspect.isclass(obj):  # and its public methods
        objects += [
            v for k, v in vars(obj).items() if not k.startswith("_") and callable(v)
        ]
    found = []
    for item in objects:
        doc = docscrape.FunctionDoc(item) if not inspect.isclass(item) else None
        if doc is None:
            doc = docscrape.ClassDoc(item, config={"show_class_members": False})
        else:
            summary = " ".join(doc["Summary"] + doc["Extended Summary"])
            if takes_arguments(item) and not doc["Parameters"] and "See" in summary:
                found.append(f"{item.__qualname__}: {summary}")
        for section in ("Parameters", "Returns", "Raises"):
            for entry in doc[section]:
                text = " ".join(entry.desc).strip()
                if POINTER.match(text):
                    found.append(f"{item.__qualname__} {entry.name or section}: {text}")
    return found


@pytest.mark.parametrize("name, obj", CALLABLES, ids=[n for n, _ in CALLABLES])
def test_public_descriptions_say_what_they_do(name, obj):
    """No parameter, return or exception is described only as "See X"."""
    assert pointer_only_descriptions(obj) == []


@pytest.mark.parametrize("name, obj", CALLABLES, ids=[n for n, _ in CALLABLES])
def test_every_public_callable_has_a_rendered_page(html, name, obj):
    page = html / "generated" / f"{name}.html"
    assert page.is_file(), f"no API page for {name}"
    text = page.read_text()
    if takes_arguments(obj):
        assert "Parameters" in text or "Attributes" in text
    if not inspect.isclass(obj):
        assert "Returns" in text


def test_readme_example_runs(capsys):
    readme = (DOCS.parent / "README.md").read_text()
    code = readme.split("```python\n", 1)[1].split("```", 1)[0]
    namespace: dict = {}
    exec(compile(code, "README.md", "exec"), namespace)
    design, ctrl = namespace["design"], namespace["ctrl"]
    assert design.certificate.verified and len(design.gains) == 2
    assert "k" in ctrl.input_labels and ctrl.output_labels == ["u"]
    assert "certified" in capsys.readouterr().out
