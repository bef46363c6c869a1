"""The Kalman filter with intermittent observations (theory: estimation).

``dlqe`` against python-control, Sinopoli et al.'s example, scalar closed
forms, an independent fixed-point iteration of the modified Riccati
equation written here, the fixed-gain covariance (16.1) solved here and
sampled by Monte Carlo; Gilbert–Elliott links against their coupled
equations iterated here; ``critical_arrival`` and ``isestimable`` against
their closed forms and against ``dlqe`` itself.
"""

import math

import control as ct
import numpy as np
import pytest
from control.exception import ControlArgument
from hypothesis import given, settings, strategies as st

import control_ncs as ncs
from control_ncs import _mare

SINOPOLI_A = np.array([[1.25, 1.0, 0.0], [0.0, 0.9, 7.0], [0.0, 0.0, 0.6]])
SINOPOLI_C = np.array([[1.0, 0.0, 2.0]])


def sinopoli(lam):
    return ncs.dlqe(SINOPOLI_A, np.eye(3), SINOPOLI_C, 20 * np.eye(3),
                    [[2.5]], arrival=lam)


def mare_iteration(A, C, W, R, lam, steps=200_000):
    """S ← g_λ(S) from S = 0 until it stops moving (monotone from below,
    theory: estimation), with g_λ written completed-square, (1 - λ) A S Aᵀ +
    λ ((A - L C) S (A - L C)ᵀ + L R Lᵀ) + W at L = A S Cᵀ (C S Cᵀ + R)⁻¹:
    the subtractive form diverges in floating point on this example."""
    S = np.zeros_like(W)
    for _ in range(steps):
        L = A @ S @ C.T @ np.linalg.inv(C @ S @ C.T + R)
        AL = A - L @ C
        new = (1 - lam) * A @ S @ A.T + lam * (AL @ S @ AL.T + L @ R @ L.T) \
            + W
        if np.linalg.norm(new - S) <= 1e-15 * np.linalg.norm(new):
            return new
        S = new
    return S


def fixed_gain_covariance(A, C, W, R, L, lam):
    """(16.1) for a given gain, by its Kronecker system written here."""
    n = A.shape[0]
    AL = A - L @ C
    M = (1 - lam) * np.kron(A, A) + lam * np.kron(AL, AL)
    F = W + lam * L @ R @ L.T
    return np.linalg.solve(np.eye(n * n) - M, F.ravel()).reshape(n, n)


def random_system(rng, n, p):
    A = rng.standard_normal((n, n))
    A *= rng.uniform(0.5, 1.4) / max(abs(np.linalg.eigvals(A)))
    return A, rng.standard_normal((n, n)), rng.standard_normal((p, n))


# -- dlqe: Bernoulli ----------------------------------------------------------
def test_sinopolis_example_without_losses_is_the_dare():
    L, S, E = sinopoli(1.0)
    assert np.trace(S) == pytest.approx(5573.872181, abs=5e-7)
    L1, S1, E1 = ct.dlqe(SINOPOLI_A, np.eye(3), SINOPOLI_C, 20 * np.eye(3),
                         [[2.5]])
    np.testing.assert_allclose(S, S1, rtol=1e-10)
    np.testing.assert_allclose(L, L1, rtol=1e-10)
    np.testing.assert_allclose(np.sort_complex(E), np.sort_complex(E1),
                               rtol=1e-10)


def test_sinopolis_example_at_arrival_0_8():
    assert np.trace(sinopoli(0.8)[1]) == pytest.approx(14640.766706,
                                                       abs=5e-7)


@pytest.mark.parametrize("lam", [0.8, 0.5])
def test_sinopolis_example_equals_an_independent_fixed_point_iteration(lam):
    S = sinopoli(lam)[1]
    ref = mare_iteration(SINOPOLI_A, SINOPOLI_C, 20 * np.eye(3),
                         np.array([[2.5]]), lam)
    np.testing.assert_allclose(S, ref, rtol=1e-9)


def test_scalar_mare_is_the_positive_root_of_its_quadratic():
    """a = 1.5, c = q = r = 1, λ = 0.6: (S + 1)((1 - a²)S - 1) + λa²S² = 0."""
    a, lam = 1.5, 0.6
    L, S, E = ncs.dlqe([[a]], [[1.0]], [[1.0]], [[1.0]], [[1.0]],
                       arrival=lam)
    k2, k1 = (1 - a * a) + lam * a * a, (1 - a * a) - 1
    root = (-k1 + math.sqrt(k1 * k1 + 4 * k2)) / (2 * k2)
    assert S[0, 0] == pytest.approx(22.935995892520, rel=1e-12)
    assert S[0, 0] == pytest.approx(root, rel=1e-12)
    assert L[0, 0] == pytest.approx(a * root / (root + 1), rel=1e-12)
    assert L[0, 0] == pytest.approx(1.437332877, abs=1e-9)
    assert E[0] == pytest.approx(0.062667123, abs=1e-9)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(1, 5),
       p=st.integers(1, 3))
def test_loss_free_dlqe_equals_python_control(seed, n, p):
    rng = np.random.default_rng(seed)
    A, G, C = random_system(rng, n, p)
    QN, RN = np.eye(n), np.diag(rng.uniform(0.5, 2.0, p))
    L, S, E = ncs.dlqe(A, G, C, QN, RN)
    L1, S1, E1 = ct.dlqe(A, G, C, QN, RN)
    scale = np.abs(S1).max()
    np.testing.assert_allclose(S, S1, atol=1e-10 * scale)
    np.testing.assert_allclose(L, L1, atol=1e-10 * max(1, np.abs(L1).max()))


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(1, 4),
       p=st.integers(1, 2), lam=st.floats(0.75, 0.99))
def test_the_solution_is_its_gains_exact_covariance_and_the_best(seed, n, p,
                                                                  lam):
    """S solves (16.1) for the returned gain; any other gain does worse."""
    rng = np.random.default_rng(seed)
    A, G, C = random_system(rng, n, p)
    A *= 1.05 / max(abs(np.linalg.eigvals(A)))
    W, R = G @ G.T, np.eye(p)
    L, S, E = ncs.dlqe(A, G, C, np.eye(n), R, arrival=lam)
    AL = A - L @ C
    lhs = (1 - lam) * A @ S @ A.T + lam * (AL @ S @ AL.T + L @ R @ L.T) + W
    assert np.abs(lhs - S).max() <= 1e-12 * np.abs(S).max()
    # the solution of (16.1) itself, to the accuracy its conditioning allows
    rho = max(abs(np.linalg.eigvals((1 - lam) * np.kron(A, A)
                                    + lam * np.kron(AL, AL))))
    np.testing.assert_allclose(fixed_gain_covariance(A, C, W, R, L, lam), S,
                               rtol=1e-12 / (1 - rho),
                               atol=1e-12 / (1 - rho) * np.abs(S).max())
    other = L + 0.05 * rng.standard_normal(L.shape)
    AO = A - other @ C
    M = (1 - lam) * np.kron(A, A) + lam * np.kron(AO, AO)
    if max(abs(np.linalg.eigvals(M))) < 1:
        worse = fixed_gain_covariance(A, C, W, R, other, lam)
        assert np.linalg.eigvalsh(worse - S)[0] >= -1e-9 * np.abs(S).max()


def test_fixed_gain_covariance_equals_a_monte_carlo_of_the_estimator():
    """e⁺ = (A - γLC) e + G w - γ L v sampled over 20 000 independent
    paths: E e eᵀ at step 200 within 4 standard errors of S."""
    A = np.array([[1.1, 0.3], [0.0, 0.7]])
    G, C = np.eye(2), np.array([[1.0, 0.5]])
    QN, RN, lam = np.diag([1.0, 0.5]), np.array([[0.8]]), 0.8
    L, S, _ = ncs.dlqe(A, G, C, QN, RN, arrival=lam)
    rng = np.random.default_rng(7)
    trials = 20_000
    e = np.zeros((trials, 2))
    Gq, rv = G @ np.linalg.cholesky(QN), math.sqrt(RN[0, 0])
    for _ in range(200):
        gamma = rng.random(trials) < lam
        w = rng.standard_normal((trials, 2)) @ Gq.T
        v = rng.standard_normal(trials) * rv
        innov = e @ C[0] + v                        # y - C x̂ = C e + v
        e = e @ A.T + w - (gamma * innov)[:, None] * L[:, 0]
    samples = np.einsum("ti,tj->tij", e, e)
    mean = samples.mean(axis=0)
    se = samples.std(axis=0, ddof=1) / math.sqrt(trials)
    assert np.all(np.abs(mean - S) <= 4 * se), (mean, S, se)


def test_below_the_fixed_gain_threshold_dlqe_refuses_and_states_it():
    with pytest.raises(ncs.SynthesisError, match="fixed_gain = 0.75") as info:
        ncs.dlqe([[2.0]], [[1.0]], [[1.0]], [[1.0]], [[1.0]], arrival=0.75)
    assert info.value.reason == "not_mss"
    assert isinstance(info.value, ValueError)
    assert info.value.figures["fixed_gain"] == 0.75
    L, S, _ = ncs.dlqe([[2.0]], [[1.0]], [[1.0]], [[1.0]], [[1.0]],
                       arrival=0.75 + 1e-6)
    assert S[0, 0] > 1e5 and np.isfinite(S).all()


def test_full_output_keeps_the_checks():
    L, S, E, info = ncs.dlqe(SINOPOLI_A, np.eye(3), SINOPOLI_C,
                             20 * np.eye(3), [[2.5]], arrival=0.5,
                             full_output=True)
    assert info.success and info.status == "certified"
    assert info.residual <= 1e-12
    lo, hi = info.ms_radius_bracket
    assert info.radius_exact and lo <= info.ms_radius <= hi < 1
    AL = SINOPOLI_A - L @ SINOPOLI_C
    rho = max(abs(np.linalg.eigvals(0.5 * np.kron(SINOPOLI_A, SINOPOLI_A)
                                    + 0.5 * np.kron(AL, AL))))
    assert info.ms_radius == pytest.approx(rho, rel=1e-10)
    assert "certified" in info.summary()


# -- dlqe: a plant, and bursty links --------------------------------------------
def sensor_plant(loss, n=2):
    A = np.array([[1.2, 0.4], [0.0, 0.8]])
    return ncs.nss(A, [[1.0, 0.0, 1.0], [0.0, 1.0, 0.5]],
                   [[1.0, 0.0], [1.0, 1.0]], np.zeros((2, 3)), nmeas=1,
                   ncon=1, sensor_loss=loss)


def test_a_plants_sensor_link_gives_the_arrivals():
    P = sensor_plant(0.3)
    got = ncs.dlqe(P, np.eye(2), [[0.5]])
    want = ncs.dlqe(P.A, P.B1, P.C2, np.eye(2), [[0.5]], arrival=0.7)
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w)
    with pytest.raises(ControlArgument, match="^arrival:"):
        ncs.dlqe(P, np.eye(2), [[0.5]], arrival=0.5)


def test_a_memoryless_gilbert_elliott_link_is_the_bernoulli_link():
    memoryless = ncs.gilbert_elliott(fail=0.3, recover=0.7)
    got = ncs.dlqe(sensor_plant(memoryless), np.eye(2), [[0.5]])
    want = ncs.dlqe(sensor_plant(0.3), np.eye(2), [[0.5]])
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w)
    # the coupled equations themselves with equal rows: Q_0 = Q_1 = S
    P = sensor_plant(0.3)
    rows = np.array([[0.3, 0.7], [0.3, 0.7]])       # T̃ of a memoryless link
    eq = _mare.Equation(P.A, P.C2, P.B1 @ P.B1.T, np.array([[0.5]]), rows,
                        rows * [[0.0, 1.0]])
    X = _mare.solve(eq).X
    np.testing.assert_allclose(X[0], want[1], rtol=1e-10)
    np.testing.assert_allclose(X[1], want[1], rtol=1e-10)


def _riccati_step(A, C, W, R, S):
    """The loss-free Riccati map, completed-square."""
    L = A @ S @ C.T @ np.linalg.inv(C @ S @ C.T + R)
    AL = A - L @ C
    return AL @ S @ AL.T + L @ R @ L.T + W


def bursty_iteration(A, C, W, R, T, steps=100_000):
    """Theory (estimation), one gain: Q_j = Σ_i (π_i T[i, j]/π_j) h_i(Q_i),
    h_0 = A Q Aᵀ + W, h_1 the loss-free Riccati map (completed-square);
    iterated from 0."""
    pi = np.array([T[1, 0], T[0, 1]]) / (T[1, 0] + T[0, 1])
    Q = np.zeros((2,) + A.shape)
    for _ in range(steps):
        h0 = A @ Q[0] @ A.T + W
        h1 = _riccati_step(A, C, W, R, Q[1])
        new = np.array([sum(pi[i] * T[i, j] / pi[j] * (h0, h1)[i]
                            for i in range(2)) for j in range(2)])
        if np.linalg.norm(new - Q) <= 1e-15 * np.linalg.norm(new):
            return new
        Q = new
    return Q


def test_bursty_link_one_gain_solves_the_coupled_equations():
    link = ncs.gilbert_elliott(fail=0.1, recover=0.4)
    P = sensor_plant(link)
    L, S, E = ncs.dlqe(P, np.eye(2), [[0.5]])
    W = P.B1 @ P.B1.T
    ref = bursty_iteration(P.A, P.C2, W, np.array([[0.5]]), link.transition)
    np.testing.assert_allclose(S, ref, rtol=1e-9)
    Q1 = ref[1]
    np.testing.assert_allclose(
        L, P.A @ Q1 @ P.C2.T @ np.linalg.inv(P.C2 @ Q1 @ P.C2.T + 0.5),
        rtol=1e-9)
    # S[j] is the exact covariance of this gain given the current arrival:
    # the error loop as a Markov jump system (mode γ_k), its stationary
    # moments E[e eᵀ 1{γ = j}] = π_j S[j]
    modes = np.array([P.A, P.A - L @ P.C2])
    B = np.array([np.hstack([P.B1, np.zeros((2, 1))]),
                  np.hstack([P.B1, -L * math.sqrt(0.5)])])
    loop = ncs.jss(modes, B, np.eye(2), np.zeros((2, 3)),
                   transition=link.transition)
    Qs = ncs.stationary_covariances(loop)[0]
    pi = np.array([link.loss, 1 - link.loss])
    np.testing.assert_allclose(Qs, pi[:, None, None] * S, rtol=1e-9)


def previous_iteration(A, C, W, R, Tr, steps=100_000):
    """Theory (estimation), gains on the previous arrival: P_0 = Σ_ℓ T̃[0, ℓ] A P_ℓ Aᵀ
    + W, P_1 = Σ_ℓ T̃[1, ℓ] g_1(P_ℓ)."""
    P = np.zeros((2,) + A.shape)
    for _ in range(steps):
        g = [_riccati_step(A, C, W, R, P[ell]) for ell in range(2)]
        new = np.array([
            sum(Tr[0, ell] * (A @ P[ell] @ A.T + W) for ell in range(2)),
            sum(Tr[1, ell] * g[ell] for ell in range(2))])
        if np.linalg.norm(new - P) <= 1e-15 * np.linalg.norm(new):
            return new
        P = new
    return P


@pytest.mark.parametrize("loss", [0.3, ncs.gilbert_elliott(0.1, 0.4)])
def test_gains_on_the_previous_arrival_solve_their_equations_and_do_better(
        loss):
    P = sensor_plant(loss)
    L2, S2, E2 = ncs.dlqe(P, np.eye(2), [[0.5]], previous_arrival=True)
    assert L2.shape == (2, 2, 1) and S2.shape == (2, 2, 2) \
        and E2.shape == (2, 2)
    if isinstance(loss, float):
        Tr = np.tile([loss, 1 - loss], (2, 1))
        pi = np.array([loss, 1 - loss])
    else:
        T = loss.transition
        pi = np.array([loss.loss, 1 - loss.loss])
        Tr = pi[None, :] * T.T / pi[:, None]
    ref = previous_iteration(P.A, P.C2, P.B1 @ P.B1.T, np.array([[0.5]]),
                             Tr)
    np.testing.assert_allclose(S2, ref, rtol=1e-9)
    _, S1, _ = ncs.dlqe(P, np.eye(2), [[0.5]])
    one = S1 if S1.ndim == 2 else pi @ S1.reshape(2, -1)
    two = pi @ S2.reshape(2, -1)
    assert np.trace(two.reshape(2, 2)) < np.trace(np.reshape(one, (2, 2)))


def test_a_bursty_link_that_stays_down_too_long_is_refused():
    with pytest.raises(ncs.SynthesisError, match="no estimator gain") as info:
        ncs.dlqe(sensor_plant(ncs.gilbert_elliott(0.05, 0.2)), np.eye(2),
                 [[0.5]])
    assert info.value.reason == "not_mss"


# -- critical probabilities ---------------------------------------------------
def test_sinopolis_example_has_critical_probability_0_36():
    res = ncs.critical_arrival(SINOPOLI_A, SINOPOLI_C)
    assert res.lower == res.fixed_gain == res.value == pytest.approx(0.36,
                                                                     abs=1e-15)
    assert res.exact and res.fixed_gain_exact and res.critical_recover == \
        pytest.approx(0.36)


def test_scalar_critical_probability_is_one_minus_one_over_a_squared():
    res = ncs.critical_arrival([[2.0]], [[1.0]])
    assert res.value == res.fixed_gain == 0.75 and res.exact


def test_a_fixed_gain_needs_more_arrivals_than_the_time_varying_filter():
    """Two real unstable modes of distinct moduli, each seen by one sensor:
    the filter's threshold is 1 - 1/1.5² (non-degenerate), a fixed gain's
    1 - 1/(1.5·1.2)² (one measurement), which the LMI bisection brackets."""
    A, C = np.diag([1.5, 1.2]), np.array([[1.0, 1.0]])
    res = ncs.critical_arrival(A, C)
    assert res.exact and res.value == pytest.approx(1 - 1 / 2.25)
    assert res.fixed_gain == pytest.approx(1 - 1 / 1.8 ** 2, abs=1e-15)
    th = _mare.threshold(A, C, closed_forms=False)
    assert th.lower - 1e-6 <= res.fixed_gain <= th.upper
    assert th.upper - th.lower <= 1e-7
    ncs.dlqe(A, np.eye(2), C, np.eye(2), [[1.0]],
             arrival=res.fixed_gain + 1e-6)


def test_a_degenerate_system_reports_a_bracket():
    """A rotation (a complex unstable pair) read by one sensor: no
    structural test applies, so the threshold is only bracketed."""
    th = 0.7
    A = 1.2 * np.array([[math.cos(th), -math.sin(th)],
                        [math.sin(th), math.cos(th)]])
    res = ncs.critical_arrival(A, [[1.0, 0.0]])
    assert not res.exact and res.value is None
    assert res.bracket == (res.lower, res.fixed_gain)
    assert res.lower == pytest.approx(1 - 1 / 1.44)
    assert res.fixed_gain == pytest.approx(1 - 1 / 1.44 ** 2)


def test_a_closed_bracket_is_exact():
    """A double integrator seen through its position: no unstable
    eigenvalue (ρ(A) = 1), and a stationary gain exists at every arrival
    probability: lower = fixed_gain = 0 closes the bracket, so the value
    is known, 0, and a filter with few arrivals still has a bounded error."""
    A = [[1.0, 0.1], [0.0, 1.0]]
    res = ncs.critical_arrival(A, [[1.0, 0.0]])
    assert res.lower == res.fixed_gain == 0.0
    assert res.exact and res.value == 0.0 and res.bracket == (0.0, 0.0)
    L, S, _ = ncs.dlqe(A, np.eye(2), [[1.0, 0.0]], np.eye(2), [[1.0]],
                       arrival=0.05)
    assert np.all(np.isfinite(S))


def test_without_a_closed_form_the_bisection_is_certified_above_and_tight():
    """Two sensors that read the two unstable modes only through one
    combination: neither closed form applies."""
    A = np.diag([1.3, -1.15, 0.5])
    C = np.array([[1.0, 1.0, 0.0], [2.0, 2.0, 1.0]])
    res = ncs.critical_arrival(A, C)
    assert not res.fixed_gain_exact and res.fixed_gain_how == "bisection"
    lo, hi = res.fixed_gain_bracket
    assert hi - lo <= 1e-7 and res.lower <= lo
    ncs.dlqe(A, np.eye(3), C, np.eye(3), np.eye(2), arrival=hi)
    with pytest.raises(ncs.SynthesisError):
        ncs.dlqe(A, np.eye(3), C, np.eye(3), np.eye(2), arrival=lo - 1e-3)


def test_critical_arrival_of_a_plant_reads_its_measurement():
    P = sensor_plant(0.2)
    assert ncs.critical_arrival(P).fixed_gain == \
        ncs.critical_arrival(P.A, P.C2).fixed_gain


@pytest.mark.parametrize("fail", [0.02, 0.3, 0.9])
@pytest.mark.parametrize("recover", [0.2, 0.3, 0.45, 0.8])
def test_bursty_region_is_decided_by_recover_alone_when_c_sees_all(fail,
                                                                   recover):
    """(1 - r) ρ(A)² < 1 whatever f (C invertible); dlqe agrees."""
    A, C = np.array([[1.6, 0.2], [0.0, 0.5]]), np.array([[1.0, 0.3]])
    link = ncs.gilbert_elliott(fail=fail, recover=recover)
    verdict = ncs.isestimable(A, C, link)
    assert verdict == ((1 - recover) * 1.6 ** 2 < 1)
    assert ncs.critical_arrival(A, C).critical_recover == \
        pytest.approx(1 - 1 / 1.6 ** 2)
    P = ncs.nss(A, [[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]], [[1.0, 0.0], C[0]],
                np.zeros((2, 3)), nmeas=1, ncon=1, sensor_loss=link)
    if verdict:
        ncs.dlqe(P, np.eye(2), [[1.0]])
    else:
        with pytest.raises(ncs.SynthesisError):
            ncs.dlqe(P, np.eye(2), [[1.0]])


@pytest.mark.parametrize("fail, recover", [(0.1, 0.9), (0.3, 0.5),
                                           (0.05, 0.25)])
def test_bursty_region_without_a_closed_form_agrees_with_dlqe(fail, recover):
    th = 0.9
    A = 1.15 * np.array([[math.cos(th), -math.sin(th)],
                         [math.sin(th), math.cos(th)]])
    C = np.array([[1.0, 0.0]])
    link = ncs.gilbert_elliott(fail=fail, recover=recover)
    P = ncs.nss(A, [[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]], [[1.0, 0.0], C[0]],
                np.zeros((2, 3)), nmeas=1, ncon=1, sensor_loss=link)
    if ncs.isestimable(P):
        ncs.dlqe(P, np.eye(2), [[1.0]])
    else:
        with pytest.raises(ncs.SynthesisError):
            ncs.dlqe(P, np.eye(2), [[1.0]])


def test_isestimable_over_a_bernoulli_link_is_the_fixed_gain_threshold():
    assert ncs.isestimable([[2.0]], [[1.0]], 0.25 - 1e-9)
    assert not ncs.isestimable([[2.0]], [[1.0]], 0.25)


# -- bad input ------------------------------------------------------------------
def test_dlqe_refuses_what_it_does_not_solve():
    with pytest.raises(ValueError, match="not seen"):
        ncs.dlqe(np.diag([1.2, 0.5]), np.eye(2), [[0.0, 1.0]], np.eye(2),
                 [[1.0]])
    with pytest.raises(ValueError, match="^RN:"):
        ncs.dlqe([[1.2]], [[1.0]], [[1.0]], [[1.0]], [[0.0]])
    with pytest.raises(ValueError, match="^arrival:"):
        ncs.dlqe([[1.2]], [[1.0]], [[1.0]], [[1.0]], [[1.0]], arrival=0.0)
    with pytest.raises(ControlArgument, match="schedule"):
        ncs.dlqe(sensor_plant(0.1).with_network(sensor_schedule=[1, 0]),
                 np.eye(2), [[1.0]])
    with pytest.raises(ControlArgument):
        ncs.dlqe([[1.2]], [[1.0]], [[1.0]], [[1.0]])
    with pytest.raises(ValueError, match="not seen"):
        ncs.critical_arrival(np.diag([1.2, 0.5]), [[0.0, 1.0]])


def test_a_state_space_system_is_read_as_python_control_reads_it():
    """dlqe(sys, QN, RN): G = sys.B, C = sys.C."""
    sys = ct.ss(SINOPOLI_A, np.eye(3), SINOPOLI_C, np.zeros((1, 3)), True)
    got = ncs.dlqe(sys, 20 * np.eye(3), [[2.5]], arrival=0.8)
    want = sinopoli(0.8)
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w)


def test_results_and_errors_survive_pickling():
    import pickle
    res = ncs.critical_arrival(SINOPOLI_A, SINOPOLI_C)
    again = pickle.loads(pickle.dumps(res))
    assert again.fixed_gain == res.fixed_gain and again.exact
    info = ncs.dlqe([[1.5]], [[1.0]], [[1.0]], [[1.0]], [[1.0]], arrival=0.6,
                    full_output=True)[3]
    assert pickle.loads(pickle.dumps(info)).residual == info.residual
    with pytest.raises(ncs.SynthesisError) as err:
        ncs.dlqe([[2.0]], [[1.0]], [[1.0]], [[1.0]], [[1.0]], arrival=0.5)
    back = pickle.loads(pickle.dumps(err.value))
    assert back.reason == "not_mss" and isinstance(back, ValueError)
    assert back.figures == err.value.figures
