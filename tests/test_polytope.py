import numpy as np
import pytest

from ctrl_lpv import ParameterBox, Polytope, Simplex, box


def test_box_vertices_and_order():
    dom = ParameterBox({"a": (0.0, 1.0), "b": (-2.0, 2.0)})
    np.testing.assert_array_equal(
        dom.points, [[0.0, -2.0], [0.0, 2.0], [1.0, -2.0], [1.0, 2.0]]
    )
    assert dom.names == ("a", "b")
    assert dom.nvertices == 4


def test_box_weights_reproduce_affine_functions():
    dom = box(a=(0.0, 1.0), b=(-2.0, 2.0), c=(5.0, 6.0))
    rng = np.random.default_rng(1)
    coeffs = rng.normal(size=4)
    values_at_vertices = coeffs[0] + dom.points @ coeffs[1:]
    for _ in range(20):
        p = dom.lower + rng.random(3) * (dom.upper - dom.lower)
        delta = dom.weights(p)
        assert np.all(delta >= 0)
        assert delta.sum() == pytest.approx(1.0)
        np.testing.assert_allclose(delta @ dom.points, p)
        assert delta @ values_at_vertices == pytest.approx(coeffs[0] + p @ coeffs[1:])


def test_box_weights_at_vertices_are_unit_vectors():
    dom = box(p=(-0.95, 0.0))
    np.testing.assert_allclose(dom.weights([-0.95]), [1.0, 0.0])
    np.testing.assert_allclose(dom.weights({"p": 0.0}), [0.0, 1.0])


def test_box_outside_and_clip():
    dom = box(p=(-1.0, 0.0))
    with pytest.raises(ValueError, match="outside"):
        dom.weights(0.5)
    np.testing.assert_allclose(dom.weights(0.5, clip=True), [0.0, 1.0])


@pytest.mark.parametrize(
    "bounds, match",
    [
        ({"p": (0.0, -1.0)}, "lower bound"),
        ({"p": (1.0, 1.0)}, "lower bound"),
        ({"p": (0.0, np.inf)}, "finite"),
        ({}, "non-empty"),
        ({"p": (0.0,)}, "expected"),
    ],
)
def test_box_bad_bounds(bounds, match):
    with pytest.raises(ValueError, match=match):
        ParameterBox(bounds)


def test_bad_point_errors():
    dom = box(a=(0.0, 1.0), b=(0.0, 1.0))
    with pytest.raises(ValueError, match="expected 2 value"):
        dom.weights([0.5])
    with pytest.raises(ValueError, match="finite"):
        dom.weights([np.nan, 0.5])
    with pytest.raises(ValueError, match="missing"):
        dom.weights({"a": 0.5})


def test_simplex_weights():
    dom = Simplex(3)
    np.testing.assert_allclose(dom.weights([0.2, 0.3, 0.5]), [0.2, 0.3, 0.5])
    with pytest.raises(ValueError, match="sum to 1"):
        dom.weights([0.2, 0.3, 0.6])


def test_general_polytope_weights_reproduce_point():
    triangle = Polytope([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]], ["a", "b"])
    p = np.array([0.3, 0.6])
    delta = triangle.weights(p)
    assert np.all(delta >= 0)
    assert delta.sum() == pytest.approx(1.0)
    np.testing.assert_allclose(delta @ triangle.points, p, atol=1e-9)
    with pytest.raises(ValueError, match="outside"):
        triangle.weights([2.0, 2.0])
