"""Loss-free ``dlqr``: the plain DARE solved by SciPy's generalized Schur
method and checked as the equation kernel checks its answers.

Cross-checked against python-control's ``dlqr`` (the same equation) and the
kernel's own route (policy iteration); the stability bound against the
exact spectral radius of the closed loop.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import control as ct
import control_ncs as ncs
from control_ncs import _mare


def _plant(n, m, seed, radius=1.1):
    rng = np.random.default_rng([n, m, seed])
    A = rng.standard_normal((n, n))
    A *= radius / np.max(np.abs(np.linalg.eigvals(A)))
    return A, rng.standard_normal((n, m))


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 8), st.integers(1, 3), st.integers(0, 10 ** 6))
def test_loss_free_dlqr_is_python_controls_with_its_checks(n, m, seed):
    A, B = _plant(n, m, seed)
    Q, R = np.eye(n), np.eye(m)
    K, S, E, info = ncs.dlqr(A, B, Q, R, full_output=True)
    Kc, Sc, Ec = ct.dlqr(A, B, Q, R)
    assert np.allclose(K, Kc, rtol=1e-8, atol=1e-10)
    assert np.allclose(S, Sc, rtol=1e-8, atol=1e-10)
    assert info.route == "schur" and info.newton_steps == 0
    assert info.residual <= 1e-9
    # the spectral radius of X ↦ A_Kᵀ X A_K is ρ(A - BK)², inside the
    # certified bracket, which proves it below 1
    rho2 = np.max(np.abs(np.linalg.eigvals(A - B @ K))) ** 2
    lower, upper = info.ms_radius_bracket
    assert info.ms_radius == pytest.approx(rho2, rel=1e-12)
    assert lower <= rho2 * (1 + 1e-9) and rho2 <= upper * (1 + 1e-9)
    assert upper < 1
    assert np.allclose(np.sort_complex(E), np.sort_complex(Ec))


def test_the_kernel_route_gives_the_same_answer():
    A, B = _plant(6, 2, 3)
    Q, R = np.diag([1.0, 0, 2, 0, 1, 0.5]), np.array([[2.0, 0.3],
                                                      [0.3, 1.0]])
    K, S, E, info = ncs.dlqr(A, B, Q, R, full_output=True)
    eq = _mare.Equation(A.T, B.T, Q, R, *_mare.bernoulli(1.0))
    sol = _mare.solve(eq)
    assert info.route == "schur"
    assert np.allclose(S, sol.X[0], rtol=1e-9, atol=1e-12)
    assert np.allclose(K, sol.gains[0].T, rtol=1e-9, atol=1e-12)


def test_a_singular_state_weight_is_certified_by_the_stein_solution():
    """Q = 0: the cost S is singular and proves nothing, so the bound comes
    from Y = A_Kᵀ Y A_K + I (the closed loop is stable all the same)."""
    A, B = _plant(4, 1, 7, radius=0.9)
    K, S, E, info = ncs.dlqr(A, B, np.zeros((4, 4)), np.eye(1),
                             full_output=True)
    assert np.allclose(K, 0) and info.route == "schur"
    assert info.ms_radius_bracket[1] < 1
    assert info.ms_radius == pytest.approx(
        np.max(np.abs(np.linalg.eigvals(A))) ** 2, rel=1e-12)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_an_unstabilisable_plant_is_refused_by_the_kernel():
    """The Schur solver fails; the kernel's route then names the mode."""
    A = np.diag([1.5, 0.5])
    B = np.array([[0.0], [1.0]])
    with pytest.raises(ValueError, match="not stabilisable.*1.5"):
        ncs.dlqr(A, B, np.eye(2), np.eye(1))
    with pytest.raises(ValueError):
        ct.dlqr(A, B, np.eye(2), np.eye(1))
