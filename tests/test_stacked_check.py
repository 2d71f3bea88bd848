"""The float64 check of a point with a spec's LMIs evaluated stacked over
the coefficients (`StackedTerms`, `LMIProblem.add(stacked=...)`): the same
matrices as each LMI's block function alone, and the LMI's own block
function wherever a group's stacked values disagree with the maps."""

from types import SimpleNamespace

import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv
from _independent import generate_case
from ctrl_lpv import twomass
from ctrl_lpv.lmi import LMIProblem, assemble
from ctrl_lpv.lmi.blocks import Batch
from ctrl_lpv.lmi.reading import ConicReading


@pytest.fixture
def compared(monkeypatch):
    """Every stacked matrix a check keeps, next to its LMI's block
    function evaluated alone at the same point."""
    pairs = []
    original = ConicReading._stacked_values

    def recorded(self, v, values, active):
        found = original(self, v, values, active)
        for (name, blocks, _, _), F in zip(active, found):
            if F is not None:
                pairs.append((name, F, assemble(blocks(v))))
        return found

    monkeypatch.setattr(ConicReading, "_stacked_values", recorded)
    return pairs


def _two_mass():
    return twomass.lpv_model(p_bounds=(-0.95, 0.0), formulation="tracking",
                             integral=True)  # fmt: skip


CALLS = {
    "Lemma 2": lambda: lpv.hinf_state_feedback(
        _two_mass(), w="Td", u="Tm", z=_two_mass().output_labels
    ),
    "Theorem 2": lambda: lpv.gain_scheduled_hinf(
        _two_mass(), w="Td", u="Tm", z=_two_mass().output_labels
    ),
    "H2 affine, rates": lambda: lpv.synthesize(
        _two_mass(),
        objective=lpv.H2(w="Td"),
        u="Tm",
        gains="scheduled",
        lyapunov="affine",
        rate_bounds={"p": 0.5},
    ),  # fmt: skip
    "discrete, affine W, rates": lambda: lpv.synthesize(
        _discrete_oscillator(),
        0,
        gains="scheduled",
        lyapunov="affine",
        rate_bounds={"k": 0.5},
    ),  # fmt: skip
}


def _discrete_oscillator():
    """``x'' + 0.5 x' + k x = u``, ``k`` in ``[1, 4]``, sampled at 0.1 s."""
    vertices = [
        ct.c2d(ct.ss([[0.0, 1.0], [-k, -0.5]], [[0.0], [1.0]], [[1.0, 0.0]], 0), 0.1)
        for k in (1.0, 4.0)
    ]
    return lpv.PolytopicStateSpace(vertices, domain=lpv.box(k=(1.0, 4.0)))


@pytest.mark.parametrize("call", list(CALLS))
def test_stacked_matrices_are_the_block_functions_own(compared, call):
    design = CALLS[call]()
    assert design.certificate.verified
    assert compared, "no LMI was checked stacked"
    for name, stacked, alone in compared:
        # Term for term the same sums: bit for bit the same matrix.
        np.testing.assert_array_equal(stacked, alone, err_msg=name)


def _run_fuzz_case(index):
    """Fuzz case 2026:`index` (small) through the library; a refusal reads
    and checks points too."""
    try:
        generate_case(2026, index, small=True).call(lpv)
    except lpv.InfeasibleError:
        pass


@pytest.mark.parametrize("index", [1, 2, 3, 4, 5, 7])
def test_stacked_matrices_on_the_fuzz_corpus(compared, index):
    _run_fuzz_case(index)
    for name, stacked, alone in compared:
        np.testing.assert_array_equal(stacked, alone, err_msg=f"{index}: {name}")


def _vertex_lyapunov(group_error=0.0, group_raises=False):
    """P A_j' + A_j P < 0 at three stable vertices, with a stacked group
    that is right, wrong by `group_error` relative, or raises."""
    As = [np.array([[-1.0, 2.0], [0.0, -3.0]]), np.array([[-2.0, 0.5], [1.0, -1.0]]),
          np.array([[-1.5, -1.0], [0.3, -2.5]])]  # fmt: skip
    lmi = LMIProblem()
    lmi.variable("P", (2, 2), symmetric=True)
    stacked_A = np.stack(As).view(Batch)

    def group(v):
        if group_raises:
            raise TypeError("does not broadcast")
        return [[(stacked_A.T @ v.P + v.P @ stacked_A) * (1 + group_error)]]

    lmi.add("P > 0", lambda v: [[-v.P]])
    for j, A in enumerate(As):
        lmi.add(f"vertex {j}", lambda v, A=A: [[A.T @ v.P + v.P @ A]],
                stacked=(group, j))  # fmt: skip
    lmi.add("P <= I", lambda v: [[v.P - np.eye(2)]], strict=False,
            normalization=True)  # fmt: skip
    return lmi, As


@pytest.mark.parametrize("error, raises", [(0.0, False), (1e-6, False), (0.0, True)])
def test_a_group_that_disagrees_with_its_maps_is_not_used(error, raises):
    lmi, As = _vertex_lyapunov(error, raises)
    P = lmi.solve().P
    namespace = SimpleNamespace(**{**lmi._numeric(), "P": P})
    stacked = lmi._stacked_values(namespace, {"P": P}, lmi._active("default"))
    assert any(F is not None for F in stacked) == (error == 0.0 and not raises)
    with_groups = lmi.check({"P": P})
    lmi._stacked.clear()
    alone = lmi.check({"P": P})
    assert with_groups == alone
    for j, A in enumerate(As):
        # The certificate's verdict is the LMI's own (numpy's eigenvalue).
        top = np.linalg.eigvalsh(A.T @ P + P @ A)[-1]
        check = next(c for c in alone if c.what == f"vertex {j}")
        assert check.passed and top < 0


@pytest.fixture
def problems(monkeypatch):
    """Every LMI problem a call solves, with the stage it solved."""
    from ctrl_lpv.lmi import problem as lmi_problem

    seen = []
    original = lmi_problem.LMIProblem.check

    def recorded(self, values, stage="default"):
        if not any(p is self and s == stage for p, s in seen):
            seen.append((self, stage))
        return original(self, values, stage)

    monkeypatch.setattr(lmi_problem.LMIProblem, "check", recorded)
    return seen


def _conic(lmi, stage, groups):
    """The stage's conic data read afresh, with or without the groups."""
    kept = dict(lmi._stacked)
    if not groups:
        lmi._stacked.clear()
    lmi._columns.clear()
    lmi._conic.clear()
    try:
        return lmi._conic_data(stage, True)[0]
    finally:
        lmi._stacked.update(kept)


def _assert_same_conic(new, old, what):
    assert new.sizes == old.sizes, what
    assert new.A.shape == old.A.shape, what
    A, B = new.A.tocsc(), old.A.tocsc()
    A.sort_indices()
    B.sort_indices()
    np.testing.assert_array_equal(A.indptr, B.indptr, err_msg=what)
    np.testing.assert_array_equal(A.indices, B.indices, err_msg=what)
    np.testing.assert_array_equal(A.data, B.data, err_msg=what)
    np.testing.assert_array_equal(new.b0, old.b0, err_msg=what)
    np.testing.assert_array_equal(new.b_margin, old.b_margin, err_msg=what)


@pytest.mark.parametrize("call", list(CALLS))
def test_grouped_reading_gives_the_same_conic_data(problems, call, caplog):
    CALLS[call]()
    assert problems
    grouped = 0
    for lmi, stage in problems:
        active = [name for name, *_ in lmi._active(stage)]
        grouped += sum(name in lmi._stacked for name in active)
        with caplog.at_level("DEBUG", logger="ctrl_lpv.lmi"):
            new = _conic(lmi, stage, groups=True)
        # A group reads stacked where its LMIs read batched one by one.
        if "does not read stacked" in caplog.text:
            assert "does not evaluate batched" in caplog.text
        _assert_same_conic(new, _conic(lmi, stage, groups=False), f"{call} {stage}")
    assert grouped, "no grouped LMI"


@pytest.mark.parametrize("index", [1, 2, 3, 4, 5, 7])
def test_grouped_reading_on_the_fuzz_corpus(problems, index):
    _run_fuzz_case(index)
    for lmi, stage in problems:
        new = _conic(lmi, stage, groups=True)
        _assert_same_conic(new, _conic(lmi, stage, groups=False), f"{index} {stage}")
