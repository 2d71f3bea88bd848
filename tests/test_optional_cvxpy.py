"""cvxpy is optional: the library designs without it, and asks for it by name."""

import subprocess
import sys

import pytest

from ctrl_lpv.lmi import cvxpy_backend, solvers

#: A design in a fresh interpreter, certified and checked on the vertices.
_DESIGN = (
    "import numpy as np\n"
    "import ctrl_lpv as lpv\n"
    "sys_ = lpv.PolytopicStateSpace([\n"
    "    (np.array([[0.0, 1.0], [a, -0.5]]), np.array([[0.0], [1.0]]),\n"
    "     np.eye(2), np.zeros((2, 1))) for a in (-1.0, 2.0)])\n"
    "design = lpv.quadratic_stabilization(sys_, u=sys_.input_labels[0])\n"
    "assert design.certificate.verified\n"
    "for A, B, _, _ in sys_.vertex_data():\n"
    "    assert np.linalg.eigvals(A - B @ design.gains[0]).real.max() < 0\n"
)


def _fresh(prologue, epilogue):
    """The last lines printed by `_DESIGN` run between `prologue` and
    `epilogue` in a fresh interpreter."""
    script = "import sys\n" + prologue + _DESIGN + epilogue
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True
    )
    assert result.returncode == 0, result.stderr
    return result.stdout.splitlines()


def test_a_design_without_cvxpy_installed():
    # A fresh interpreter where `import cvxpy` fails: the direct backend
    # designs and certifies, and the default chain holds no cvxpy solver.
    chain, imported = _fresh(
        "sys.modules['cvxpy'] = None\n",
        "from ctrl_lpv.lmi import default_solvers\n"
        "print([name for name, _ in default_solvers()])\n"
        "print('cvxpy' in sys.modules and sys.modules['cvxpy'] is not None)\n",
    )[-2:]
    assert set(eval(chain)) <= {"CLARABEL", "SCS"}
    assert imported == "False"


def test_a_cvxpy_solver_without_cvxpy_names_the_extra(monkeypatch):
    monkeypatch.setattr(cvxpy_backend, "available", lambda: False)
    for cached in (cvxpy_backend.installed, solvers._installed_solvers):
        cached.cache_clear()
    try:
        with pytest.raises(ValueError, match=r"solvers: .*ctrl_lpv\[cvxpy\]"):
            solvers.solver_chain(["MOSEK"])
        # Clarabel needs no cvxpy.
        assert solvers.solver_chain(["clarabel"])[0][0] == "CLARABEL"
    finally:
        monkeypatch.undo()
        for cached in (cvxpy_backend.installed, solvers._installed_solvers):
            cached.cache_clear()


def test_the_default_chain_is_the_installed_solvers_in_order():
    # The cheap probe of the default chain lists what cvxpy's own probe does.
    listed = [name for name, _ in solvers.default_solvers()]
    expected = ["CLARABEL", "SCS", "CVXOPT", "MOSEK"]
    assert listed == [n for n in expected if n in solvers._installed_solvers()]


def test_a_design_with_the_direct_solvers_does_not_import_cvxpy():
    import importlib.util

    if any(importlib.util.find_spec(m) for m in ("cvxopt", "mosek")):
        pytest.skip("a default-chain solver is called through cvxpy here")
    assert _fresh("", "print('cvxpy' in sys.modules)\n")[-1] == "False"
