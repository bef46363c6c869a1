"""The modified Riccati equation solved as an equation (theory: estimation).

The kernel behind ``dlqe`` and ``dlqr``: policy iteration against value
iteration, the dense route against the matrix-free one, the certified
spectral-radius bracket against the dense eigenvalue; ``dlqr`` next to the
critical probability (the scalar closed form), and the critical
probability of single-input plants against an LMI written here (Sinopoli
et al.'s, theory: estimation, for the dual pair) and the kernel's own bisection.
"""

import math

import cvxpy as cp
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import control_ncs as ncs
from control_ncs import _mare


def control_mare_root(a, nu, q=1.0, r=1.0):
    """Scalar S = a²S + q - ν a²S²/(S + r): the positive root of
    (1 - a² + ν a²) S² + (r - a² r - q) S - q r = 0."""
    k2, k1, k0 = 1 - a * a + nu * a * a, r - a * a * r - q, -q * r
    return (-k1 + math.sqrt(k1 * k1 - 4 * k2 * k0)) / (2 * k2)


def test_dlqr_solves_next_to_the_critical_probability():
    """a = 1.2: critical 1 - 1/1.44 = 0.305556; at 0.305656 S = 9956."""
    K, S, E, info = ncs.dlqr([[1.2]], [[1.0]], [[1.0]], [[1.0]],
                             arrival=0.305656, full_output=True)
    assert S[0, 0] == pytest.approx(control_mare_root(1.2, 0.305656),
                                    rel=1e-10)
    assert round(S[0, 0]) == 9956
    assert info.ms_radius < 1 and info.residual <= 1e-12


def single_input(seed):
    """A random single-input pair with at least two unstable eigenvalues
    (so that B cannot reach the whole unstable subspace)."""
    rng = np.random.default_rng(seed)
    n = 2 + seed % 3
    while True:
        A = 1.1 * rng.standard_normal((n, n))
        mu = np.linalg.eigvals(A)
        if (abs(mu) > 1.02).sum() >= 2 and abs(mu).max() < 2.5:
            return A, rng.standard_normal((n, 1)), mu


def lmi_gain(A, C, lam):
    """Sinopoli et al.'s LMI, 3 × 3 blocks, most interior point: maximise t with
    the 3 × 3 block ⪰ t I, t I ⪯ P ⪯ I; the gain L = -P⁻¹ Z (None when
    t* ≤ 1e-9: no gain, on the solver's word)."""
    n = A.shape[0]
    P = cp.Variable((n, n), symmetric=True)
    Z = cp.Variable((n, C.shape[0]))
    t = cp.Variable()
    arrived = math.sqrt(lam) * (P @ A + Z @ C)
    lost = math.sqrt(1 - lam) * (P @ A)
    O = np.zeros((n, n))
    M = cp.bmat([[P, arrived.T, lost.T], [arrived, P, O], [lost, O, P]])
    problem = cp.Problem(cp.Maximize(t), [0.5 * (M + M.T) >> t * np.eye(3 * n),
                                          P >> t * np.eye(n),
                                          P << np.eye(n)])
    problem.solve(solver="CLARABEL")
    if not t.value > 1e-9:
        return None
    return -np.linalg.solve(P.value, Z.value)


def fixed_gain_radius(A, C, L, lam):
    AL = A - L @ C
    return max(abs(np.linalg.eigvals((1 - lam) * np.kron(A, A)
                                     + lam * np.kron(AL, AL))))


@pytest.mark.parametrize("seed", range(6))
def test_single_input_critical_probability_is_exact(seed):
    """The critical probability dlqr states for one input is 1 - 1/Π|μ_u|²:
    within 1e-6 of the kernel's certified LMI bisection, separating an
    independent LMI's infeasible from feasible side, and an arrival 1e-6
    above it is accepted."""
    A, B, mu = single_input(seed)
    n = A.shape[0]
    closed = 1 - 1 / np.prod(np.maximum(1, abs(mu))) ** 2
    with pytest.raises(ncs.SynthesisError, match="exact, one input") as info:
        ncs.dlqr(A, B, np.eye(n), np.eye(1), arrival=closed)
    stated = info.value.figures["critical"]
    assert stated == pytest.approx(closed, abs=1e-15)
    th = _mare.threshold(A.T, B.T, closed_forms=False)
    assert th.upper - th.lower <= 1e-7
    assert th.lower - 1e-6 <= stated <= th.upper
    assert lmi_gain(A.T, B.T, stated - 1e-4) is None
    L = lmi_gain(A.T, B.T, stated + 1e-4)
    assert fixed_gain_radius(A.T, B.T, L, stated + 1e-4) < 1
    K, S, E = ncs.dlqr(A, B, np.eye(n), np.eye(1), arrival=stated + 1e-6)
    assert np.all(np.isfinite(S)) and np.linalg.eigvalsh(S)[0] > 0


def test_critical_loss_without_a_gain_is_the_exact_single_input_value():
    A, B, mu = single_input(1)
    n = A.shape[0]
    P = ncs.nss(A, np.hstack([np.eye(n), B]),
                np.vstack([np.eye(n), np.eye(n)]), np.zeros((2 * n, n + 1)),
                nmeas=n, ncon=1)
    assert ncs.critical_loss(P) == pytest.approx(
        1 / np.prod(np.maximum(1, abs(mu))) ** 2, abs=1e-12)


# -- the kernel ------------------------------------------------------------------
def random_equation(seed, n, p, lam, rho=1.1):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    A *= rho / max(abs(np.linalg.eigvals(A)))
    C = rng.standard_normal((p, n))
    G = rng.standard_normal((n, n))
    return _mare.Equation(A, C, G @ G.T, np.eye(p), *_mare.bernoulli(lam))


@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(1, 4),
       p=st.integers(1, 2), lam=st.floats(0.8, 1.0))
def test_policy_iteration_equals_value_iteration_from_below(seed, n, p, lam):
    """ρ(A) = 1.05: every λ ≥ 0.8 is far above the critical probability
    (at most 1 - 1/1.05⁸ = 0.32 with one measurement), where value iteration
    converges fast enough to be the reference."""
    eq = random_equation(seed, n, p, lam, rho=1.05)
    sol = _mare.solve(eq)
    X = np.zeros_like(sol.X)
    for _ in range(100_000):
        new = eq.riccati(X)
        if np.linalg.norm(new - X) <= 1e-15 * np.linalg.norm(new):
            break
        X = new
    np.testing.assert_allclose(sol.X, new, rtol=1e-8,
                               atol=1e-12 * np.abs(new).max())
    assert sol.residual <= 1e-9


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(2, 6),
       lam=st.floats(0.6, 0.95))
def test_matrix_free_route_equals_the_dense_one(seed, n, lam):
    eq = random_equation(seed, n, 1, lam)
    try:
        dense = _mare.solve(eq, dense=True)
    except ncs.SynthesisError:
        return                      # below this plant's threshold
    free = _mare.solve(eq, dense=False)
    np.testing.assert_allclose(free.X, dense.X, rtol=1e-9,
                               atol=1e-11 * np.abs(dense.X).max())
    assert free.route == "matrix-free" and free.radius < 1


@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(1, 4),
       lam=st.floats(0.6, 1.0))
def test_certified_bracket_contains_the_dense_spectral_radius(seed, n, lam):
    eq = random_equation(seed, n, 1, lam)
    try:
        sol = _mare.solve(eq)
    except ncs.SynthesisError:
        return
    L = sol.gains[0]
    AL = eq.A - L @ eq.C
    rho = max(abs(np.linalg.eigvals((1 - lam) * np.kron(eq.A, eq.A)
                                    + lam * np.kron(AL, AL))))
    assert sol.radius_lower * (1 - 1e-9) <= rho <= sol.radius * (1 + 1e-9)
    assert sol.radius < 1


def test_a_gain_that_does_not_stabilise_gets_no_certificate():
    """x⁺ = 2x, the deadbeat gain on arrival: ρ = (1 - λ)·4."""
    def equation(lam):
        return _mare.Equation(np.array([[2.0]]), np.array([[1.0]]),
                              np.eye(1), np.eye(1), *_mare.bernoulli(lam))
    assert _mare.solve_fixed(equation(0.5), np.array([[[2.0]]])) is None
    fixed = _mare.solve_fixed(equation(0.8), np.array([[[2.0]]]),
                              final=True)
    assert fixed.radius_lower == pytest.approx(0.8, rel=1e-12)
    assert fixed.radius == pytest.approx(0.8, rel=1e-12)


def test_no_gain_below_the_lost_parts_radius():
    eq = _mare.Equation(np.array([[2.0]]), np.array([[1.0]]), np.eye(1),
                        np.eye(1), *_mare.bernoulli(0.7))
    with pytest.raises(ncs.SynthesisError, match="lost part") as info:
        _mare.solve(eq)
    assert info.value.reason == "not_mss"
