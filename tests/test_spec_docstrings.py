"""Docstrings that say how to pass a spec (issue 19): checked against the code."""

import inspect

from numpydoc import docscrape

import ctrl_lpv as lpv
from ctrl_lpv.synthesis.spec import Spec


def _objectives():
    """The public spec classes `synthesize` takes as an objective: those
    with a channel (`Spec.channel`)."""
    out, todo = [], [Spec]
    while todo:
        cls = todo.pop()
        todo += cls.__subclasses__()
        if cls.channel and cls.__name__ in lpv.__all__:
            out.append(cls.__name__)
    return out


def test_synthesize_objective_lists_every_accepted_objective():
    doc = docscrape.FunctionDoc(lpv.synthesize)
    objective = next(p for p in doc["Parameters"] if p.name == "objective")
    accepted = _objectives()
    assert "Peak" in accepted
    for name in accepted:
        assert f"`{name}`" in objective.type, (name, objective.type)


def test_region_docstrings_name_the_arguments_that_take_regions():
    """Every public function with a `regions` parameter, and `synthesize`."""
    takes_regions = sorted(
        name
        for name in lpv.__all__
        if callable(getattr(lpv, name))
        and not inspect.isclass(getattr(lpv, name))
        and "regions" in inspect.signature(getattr(lpv, name)).parameters
    )
    assert len(takes_regions) >= 5  # the four paper functions and H2
    assert "constraints" in inspect.signature(lpv.synthesize).parameters
    returns = " ".join(docscrape.FunctionDoc(lpv.halfplane)["Returns"][0].desc)
    assert "``constraints=[...]`` to `synthesize`" in returns
    assert "``regions=``" in returns
    for name in takes_regions:
        assert f"`{name}`" in returns, name
