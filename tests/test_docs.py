"""The documentation: numpydoc docstrings of the public API and a -W build."""

import inspect
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
