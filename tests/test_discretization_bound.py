"""The sampling error bound of `PolytopicStateSpace.sample` (issue 19).

Each bound is compared with the error measured from the frozen systems and
exact matrix exponentials (`tests/_quarter_car.py`): never below it, and,
on the quarter car and the two-mass drive at 2 ms, within a factor 2 of it
(the 2-norm bound of the first release was 1900x and 2.4e8x there).
"""

import warnings

import numpy as np
import pytest

import ctrl_lpv as lpv
from _quarter_car import box_grid, measured_errors, quarter_car
from ctrl_lpv import twomass


def test_quarter_car_bound_is_tight_at_2ms():
    plant = quarter_car()
    sysd = plant.sample(2e-3)
    phi, gamma = measured_errors(plant, sysd, box_grid(plant.domain, 21))
    bound = sysd.discretization_error
    assert 0 < phi <= bound.phi < 1.5 * phi
    assert 0 < gamma <= bound.gamma < 1.5 * gamma


def test_two_mass_bound_is_tight_at_2ms():
    plant = twomass.lpv_model(p_bounds=(-0.95, 0.0), formulation="tracking")
    sysd = plant.sample(2e-3)
    phi, gamma = measured_errors(plant, sysd, box_grid(plant.domain, 201))
    bound = sysd.discretization_error
    assert 0 < phi <= bound.phi < 1.5 * phi
    assert 0 < gamma <= bound.gamma < 1.5 * gamma


def test_quarter_car_with_payload_three_parameters():
    plant = quarter_car(payload=(1 / 400, 1 / 250))
    sysd = plant.sample(2e-3)
    phi, gamma = measured_errors(plant, sysd, box_grid(plant.domain, 7))
    bound = sysd.discretization_error
    assert 0 < phi <= bound.phi < 2 * phi
    assert 0 < gamma <= bound.gamma < 2 * gamma


def test_simplex_bound_is_tight():
    """The quarter car's 4 vertices as a simplex (2-norm bound: 3500x)."""
    plant = quarter_car()
    simplex = lpv.pss(plant.vertices)  # the same 4 vertices, as a simplex
    sysd = simplex.sample(2e-3)
    rng = np.random.default_rng(0)
    phi, gamma = measured_errors(simplex, sysd, rng.dirichlet(np.ones(4), 400))
    bound = sysd.discretization_error
    assert 0 < phi <= bound.phi < 5 * phi
    assert 0 < gamma <= bound.gamma < 5 * gamma


def _random_plant(rng, kind):
    k, n, m = (int(v) for v in rng.integers(1, 4, size=3))
    scale = 10 ** rng.uniform(-1, 2)  # time constants from 10 s to 10 ms
    base = rng.normal(size=(n, n)) * scale
    spread = 10 ** rng.uniform(-2, 0) * scale

    def vertex():
        A = base + spread * rng.normal(size=(n, n))
        return A, rng.normal(size=(n, m)), np.eye(n), 0

    if kind == "box":
        lows = rng.normal(size=k)
        box = lpv.ParameterBox(
            {
                f"p{i}": (lo, lo + w)
                for i, (lo, w) in enumerate(zip(lows, 0.1 + rng.random(k)))
            }
        )
        return lpv.pss([vertex() for _ in range(2**k)], box), scale
    return lpv.pss([vertex() for _ in range(k + 1)]), scale


@pytest.mark.parametrize("kind", ["box", "simplex"])
@pytest.mark.parametrize("seed", range(8))
def test_bound_is_never_below_the_measured_error(kind, seed):
    """Random polytopes and periods (T times the data's scale in 1e-3..3)."""
    rng = np.random.default_rng(100 + seed)
    plant, scale = _random_plant(rng, kind)
    Ts = 10 ** rng.uniform(-3, 0.5) / scale
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "too long" at times
        sysd = plant.sample(Ts)
    if kind == "box":
        # the bound's own grid has 1025^(1/k) points per axis; 9 per axis
        # plus centres puts points between them for k = 2, 3
        points = box_grid(plant.domain, 9 if plant.domain.nparams > 1 else 60)
    else:
        points = rng.dirichlet(np.ones(len(plant.vertices)), 200)
    phi, gamma = measured_errors(plant, sysd, points)
    bound = sysd.discretization_error
    assert phi <= bound.phi * (1 + 1e-9) and gamma <= bound.gamma * (1 + 1e-9)


def test_long_period_gives_a_finite_valid_bound_with_a_warning(mass_spring):
    """Ts = 1000 s on a stable plant: no NaN (it was phi=inf, gamma=nan)."""
    with pytest.warns(UserWarning, match="Ts = 1000 is too long for a meaningful"):
        sysd = mass_spring.sample(1e3)
    bound = sysd.discretization_error
    assert not np.isnan(bound.phi) and not np.isnan(bound.gamma)
    phi, gamma = measured_errors(mass_spring, sysd, np.linspace(1, 4, 31)[:, None])
    assert phi <= bound.phi and gamma <= bound.gamma


def test_overflowing_bound_is_inf_with_a_warning(mass_spring):
    with pytest.warns(UserWarning, match="overflows"):
        sysd = mass_spring.sample(1e4)
    bound = sysd.discretization_error
    assert bound.phi == np.inf and bound.gamma == np.inf and not bound.exact


def test_overflowing_vertex_is_refused_naming_ts():
    unstable = lpv.pss([([[1.0]], [[1.0]], [[1.0]], 0), ([[2.0]], [[1.0]], [[1.0]], 0)])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow warning on the way
        with pytest.raises(ValueError, match=r"^Ts: 1000 is too long"):
            unstable.sample(1e3)


def test_short_period_has_no_warning(mass_spring):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        bound = mass_spring.sample(0.05).discretization_error
    assert 0 < bound.phi < 1e-3 and 0 < bound.gamma < 1e-3
