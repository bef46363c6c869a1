"""LQG over a lossy sensor link and a lossy actuator link (theory:
estimation).

TCP-like: the closed form (16.4) against the scalar example, the loop's H2
norm, python-control's textbook LQG and a Monte Carlo of the controller
written here. UDP-like: the cost above the TCP-like bound, the analytic
gradient against finite differences, and the returned loop against a
Monte Carlo of the controller written here.
"""

import math

import control as ct
import numpy as np
import pytest
from control.exception import ControlArgument
from hypothesis import given, settings, strategies as st

import control_ncs as ncs
from control_ncs import _lqg_loops


def scalar_plant(sensor_loss=0.2, actuator_loss=0.1, **network):
    """x⁺ = 1.2 x + θ2 u + w, y = x + v (the scalar example of theory: estimation)."""
    return ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]],
                   [[0.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
                   sensor_loss=sensor_loss, actuator_loss=actuator_loss,
                   **network)


def two_state_plant(sensor_loss, actuator_loss):
    A = np.array([[1.1, 0.3], [0.0, 0.8]])
    return ncs.nss(A, [[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]],
                   [[1.0, 0.0], [1.0, 0.5]], np.zeros((2, 3)), nmeas=1,
                   ncon=1, sensor_loss=sensor_loss,
                   actuator_loss=actuator_loss)


def test_scalar_tcp_like_example():
    K, CL, J = ncs.lqg(scalar_plant(), [[1.0]], [[1.0]], [[1.0]], [[1.0]])
    assert J == pytest.approx(4.360314, abs=5e-7)
    _, Sc, _ = ncs.dlqr([[1.2]], [[1.0]], [[1.0]], [[1.0]], arrival=0.9)
    _, S, _ = ncs.dlqe([[1.2]], [[1.0]], [[1.0]], [[1.0]], [[1.0]],
                       arrival=0.8)
    assert Sc[0, 0] == pytest.approx(2.210687, abs=5e-7)
    assert S[0, 0] == pytest.approx(2.569149, abs=5e-7)
    assert S[0, 0] - 0.8 * S[0, 0] ** 2 / (S[0, 0] + 1) == \
        pytest.approx(1.089687, abs=5e-7)
    assert K.controller == "estimator"
    assert K.estimator_gain[0, 0, 0] == pytest.approx(S[0, 0] / (S[0, 0] + 1))
    assert K.result.gap == pytest.approx(0.0, abs=1e-12)


def test_tcp_like_cost_is_the_loops_h2_norm_and_its_closed_form():
    K, CL, J = ncs.lqg(two_state_plant(0.25, 0.15), np.diag([1.0, 0.5]),
                       [[0.3]], np.eye(2), [[0.4]])
    assert J == ncs.norm(CL, 2) ** 2
    assert K.result.closed_form == pytest.approx(J, rel=1e-10)
    assert K.result.ms_radius == ncs.ms_radius(CL) < 1
    assert CL.input_labels == ["w[0]", "w[1]", "v[0]"]


def test_loss_free_lqg_is_the_textbook_lqg():
    """python-control's gains, and the textbook cost tr(S_c W) +
    tr(Kᵀ(BᵀS_cB + R)K P̃) with the a posteriori covariance P̃."""
    P = two_state_plant(0.0, 0.0)
    Q, R, QN, RN = np.diag([1.0, 0.5]), np.array([[0.3]]), np.eye(2), \
        np.array([[0.4]])
    K, CL, J = ncs.lqg(P, Q, R, QN, RN)
    Kc, Sc, _ = ct.dlqr(P.A, P.B2, Q, R)
    Lp, S, _ = ct.dlqe(P.A, P.B1, P.C2, QN, RN)
    Lf = S @ P.C2.T @ np.linalg.inv(P.C2 @ S @ P.C2.T + RN)
    np.testing.assert_allclose(K.gains[0], -Kc, rtol=1e-9)
    np.testing.assert_allclose(K.estimator_gain[0], Lf, rtol=1e-9)
    post = S - Lf @ P.C2 @ S
    W = P.B1 @ QN @ P.B1.T
    textbook = np.trace(Sc @ W) + np.trace(
        Kc.T @ (P.B2.T @ Sc @ P.B2 + R) @ Kc @ post)
    assert J == pytest.approx(textbook, rel=1e-9)


def simulate_controller(P, K, Lf, Q, R, QN, RN, *, acknowledged, trials,
                        steps, seed):
    """The estimator controller of theory: estimation run path by path: the
    plant, the two links, the correction, the command and the prediction
    with the command that arrived (TCP-like) or its expected value
    (UDP-like). Returns one cost sample per path (its mean over the last
    half of the steps)."""
    rng = np.random.default_rng(seed)
    A, B, G, C = (np.asarray(M, float) for M in (P.A, P.B2, P.B1, P.C2))
    n, m = B.shape
    lam, nu = 1 - P.sensor_loss, 1 - P.actuator_loss
    Gq = G @ np.linalg.cholesky(QN)
    Rv = np.linalg.cholesky(RN)
    x = np.zeros((trials, n))
    xh = np.zeros((trials, n))
    total = np.zeros(trials)
    for k in range(steps):
        gamma = (rng.random(trials) < lam)[:, None]
        arrive = (rng.random(trials) < nu)[:, None]
        y = x @ C.T + rng.standard_normal((trials, C.shape[0])) @ Rv.T
        post = xh + gamma * ((y - xh @ C.T) @ Lf.T)
        v = post @ K.T
        u = arrive * v
        if k >= steps // 2:
            total += np.einsum("ti,ij,tj->t", x, Q, x) + \
                np.einsum("ti,ij,tj->t", u, R, u)
        x = x @ A.T + u @ B.T + rng.standard_normal((trials, Gq.shape[1])) \
            @ Gq.T
        xh = post @ A.T + (u if acknowledged else nu * v) @ B.T
    return total / (steps - steps // 2)


@pytest.mark.parametrize("acknowledgements", [True, False])
def test_cost_equals_a_monte_carlo_of_the_controller(acknowledgements):
    P = two_state_plant(0.25, 0.15)
    Q, R, QN, RN = np.diag([1.0, 0.5]), np.array([[0.3]]), np.eye(2), \
        np.array([[0.4]])
    K, CL, J = ncs.lqg(P, Q, R, QN, RN, acknowledgements=acknowledgements)
    samples = simulate_controller(P, K.gains[0], K.estimator_gain[0], Q, R,
                                  QN, RN, acknowledged=acknowledgements,
                                  trials=4000, steps=120, seed=3)
    se = samples.std(ddof=1) / math.sqrt(samples.size)
    assert abs(samples.mean() - J) <= 4 * se, (samples.mean(), J, se)


def test_the_returned_udp_loop_simulates_to_its_cost():
    P = two_state_plant(0.25, 0.15)
    K, CL, J = ncs.lqg(P, np.eye(2), [[1.0]], np.eye(2), [[1.0]],
                       acknowledgements=False)
    paths = ncs.simulate(CL, 80, trials=3000, seed=5,
                         noise_covariance=np.eye(3))
    power = (paths.outputs[:, :, 40:] ** 2).sum(axis=0).mean(axis=1)
    se = power.std(ddof=1) / math.sqrt(power.size)
    assert abs(power.mean() - J) <= 4 * se


@settings(max_examples=3, deadline=None)
@given(seed=st.integers(0, 1000), a1=st.floats(0.0, 0.3),
       a2=st.floats(0.0, 0.3))
def test_udp_like_cost_is_never_below_the_tcp_like_optimum(seed, a1, a2):
    rng = np.random.default_rng(seed)
    P = two_state_plant(a1, a2)
    Q = np.diag(rng.uniform(0.2, 2.0, 2))
    R = np.array([[rng.uniform(0.1, 2.0)]])
    _, _, J_tcp = ncs.lqg(P, Q, R, np.eye(2), [[0.5]])
    K, CL, J = ncs.lqg(P, Q, R, np.eye(2), [[0.5]], acknowledgements=False)
    assert J >= J_tcp * (1 - 1e-10)
    assert K.result.lower_bound == pytest.approx(J_tcp, rel=1e-10)
    assert K.result.gap == pytest.approx(J - J_tcp, abs=1e-12)
    # a local optimum: no better than the certainty-equivalent start
    assert J <= K.result.search["start_cost"] * (1 + 1e-12)


def test_udp_gradient_is_the_derivative_of_the_exact_cost():
    data = _lqg_loops.LoopData(np.array([[1.1, 0.3], [0.0, 0.8]]),
                               np.array([[0.0], [1.0]]), np.eye(2),
                               np.array([[1.0, 0.5]]), np.array([[0.7]]),
                               np.eye(2), np.array([[0.6]]), 0.75, 0.85)
    K = np.array([[-0.4, -0.9]])
    Lf = np.array([[0.6], [0.2]])
    J, g = _lqg_loops.cost(data, K, Lf, gradient=True)
    theta = np.concatenate([K.ravel(), Lf.ravel()])
    h = 1e-6
    for k in range(theta.size):
        e = np.zeros(theta.size)
        e[k] = h
        up = _lqg_loops.cost(data, *_lqg_loops._split(theta + e, K.shape,
                                                      Lf.shape))[0]
        down = _lqg_loops.cost(data, *_lqg_loops._split(theta - e, K.shape,
                                                        Lf.shape))[0]
        assert g[k] == pytest.approx((up - down) / (2 * h), rel=1e-6,
                                     abs=1e-8)


def test_the_udp_formulas_with_acknowledgements_give_the_feedback_loop():
    """The UDP-like jump system of theory: estimation with ν in place of ν̄ is the loop
    feedback builds for the estimator controller."""
    P = two_state_plant(0.25, 0.15)
    K, CL, J = ncs.lqg(P, np.eye(2), [[1.0]], np.eye(2), [[1.0]])
    data = _lqg_loops.LoopData(P.A, P.B2, P.B1, P.C2, np.eye(1), np.eye(2),
                               np.eye(1), 0.75, 0.85)
    J_formula, _ = _lqg_loops.cost(data, K.gains[0], K.estimator_gain[0],
                                   acknowledged=True)
    assert J_formula == pytest.approx(J, rel=1e-10)


def test_lqg_refuses_what_it_does_not_cover():
    bursty = scalar_plant(sensor_loss=ncs.gilbert_elliott(0.1, 0.5))
    with pytest.raises(ControlArgument, match="Bernoulli"):
        ncs.lqg(bursty, [[1.0]], [[1.0]], [[1.0]], [[1.0]])
    noisy = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]],
                    [[0.0, 0.0], [1.0, 0.0]], nmeas=1, ncon=1)
    with pytest.raises(ControlArgument, match="D21"):
        ncs.lqg(noisy, [[1.0]], [[1.0]], [[1.0]], [[1.0]])
    with pytest.raises(ValueError, match="critical"):
        ncs.lqg(scalar_plant(sensor_loss=0.8), [[1.0]], [[1.0]], [[1.0]],
                [[1.0]])


# --------------------------------------------------------------------------
# continuous weights on a sampled plant (theory: LQG with continuous weights)
# --------------------------------------------------------------------------
def _servo_plant(h, **kw):
    """The DC servo ``ẋ = [[0, 1], [0, -1]] x + [0; 1](u + w)``, ``y = x1``,
    as a continuous plant sampled at ``h`` (``z`` is not used)."""
    A = np.array([[0.0, 1.0], [0.0, -1.0]])
    B = np.array([[0.0], [1.0]])
    G = ct.ss(A, np.hstack([B, B]), np.vstack([np.eye(2), [[1.0, 0.0]]]),
              np.zeros((3, 2)))
    return ncs.nss(G, nmeas=1, ncon=1, dt=h, **kw), A, B


def _sampled_by_quadrature(A, B, B1, Q, R, QN, h, tau=0.0, order=20):
    """Åström–Wittenmark's sampled loss on ``[x; u_{k-1}; u_k]`` with the
    input switching at ``τ`` by Gauss–Legendre on each piece of the
    period; ``R1d = Σ(h)`` and ``c = ∫_0^h tr(Q Σ(t)) dt`` from the
    covariance ODE ``Σ' = AΣ + ΣAᵀ + B1 QN B1ᵀ`` (one exponential of the
    linear system with its integral)."""
    from scipy.linalg import expm
    n, m = B.shape
    x, w = np.polynomial.legendre.leggauss(order)

    def nodes(a, b):
        return 0.5 * (b - a) * x + 0.5 * (b + a), 0.5 * (b - a) * w

    def flow(t):
        M = np.zeros((n + m, n + m))
        M[:n, :n], M[:n, n:] = A, B
        E = expm(M * t)
        return E[:n, :n], E[:n, n:]

    Qc = np.block([[Q, np.zeros((n, m))], [np.zeros((m, n)), R]])
    W = np.zeros((n + 2 * m, n + 2 * m))
    for t, wt in zip(*nodes(0.0, tau)) if tau > 0 else ():
        E, G = flow(t)
        F = np.block([[E, G, np.zeros((n, m))],
                      [np.zeros((m, n)), np.eye(m), np.zeros((m, m))]])
        W += wt * F.T @ Qc @ F
    Gt = flow(tau)[1]
    for t, wt in zip(*nodes(tau, h)):
        E = flow(t)[0]
        Er, Gr = flow(t - tau)
        F = np.block([[E, Er @ Gt, Gr],
                      [np.zeros((m, n + m)), np.eye(m)]])
        W += wt * F.T @ Qc @ F
    k = n * n
    L = np.zeros((2 * k + 1, 2 * k + 1))
    L[:k, :k] = np.kron(np.eye(n), A) + np.kron(A, np.eye(n))
    L[:k, 2 * k] = (B1 @ QN @ B1.T).ravel()
    L[k:2 * k, :k] = np.eye(k)
    v = expm(L * h)[:, 2 * k]
    return W, v[:k].reshape(n, n), float(np.trace(Q @ v[k:2 * k].reshape(n, n)))


def test_continuous_lqg_is_the_classical_sampled_lqg():
    import scipy.linalg as sl
    h = 0.3
    P, A, B = _servo_plant(h)
    Q, R, QN, RN = np.diag([1.0, 0.2]), np.array([[0.1]]), \
        np.array([[2.0]]), np.array([[0.01]])
    K, CL, J = ncs.lqg(P, Q, R, QN, RN)
    W, R1d, c = _sampled_by_quadrature(A, B, B, Q, R, QN, h)
    Q1, Q12, Q2 = W[:2, :2], W[:2, 3:], W[3:, 3:]
    Phi, Gam = np.asarray(P.A), np.asarray(P.B2)
    S = sl.solve_discrete_are(Phi, Gam, Q1, Q2, s=Q12)
    L = np.linalg.solve(Q2 + Gam.T @ S @ Gam, Gam.T @ S @ Phi + Q12.T)
    C = np.array([[1.0, 0.0]])
    Pm = sl.solve_discrete_are(Phi.T, C.T, R1d, RN)
    Kf = Pm @ C.T @ np.linalg.inv(C @ Pm @ C.T + RN)
    Pkk = Pm - Kf @ C @ Pm
    J_ref = (np.trace(S @ R1d) + c
             + np.trace(Pkk @ L.T @ (Q2 + Gam.T @ S @ Gam) @ L)) / h
    assert J == pytest.approx(J_ref, rel=1e-9)
    np.testing.assert_allclose(K.gains[0], -L, rtol=1e-8)
    np.testing.assert_allclose(K.estimator_gain[0], Kf, rtol=1e-8)
    assert ncs.cost(CL).cost == pytest.approx(J, rel=1e-12)
    assert K.result.gap == pytest.approx(0.0, abs=1e-9 * J)
    # the continuous cost is not the sampled one: a discrete design of the
    # same weights at the instants costs more
    Kd = -ct.dlqr(Phi, Gam, Q, R)[0]
    from control_ncs._lqg_sampled import cost_plant, sample
    Pc = cost_plant(P, sample(P, Q, R, QN, None), Q, R, QN, RN)
    J_d = ncs.cost(ncs.feedback(Pc, Kd, estimator_gain=Kf)).cost
    assert J_d > J


def test_continuous_lqg_with_a_constant_delay_is_lqgdesign():
    import scipy.linalg as sl
    h, tau = 0.3, 0.12
    P, A, B = _servo_plant(h, input_delay=([tau], [1.0]))
    Q, R, QN, RN = np.diag([1.0, 0.2]), np.array([[0.1]]), \
        np.array([[2.0]]), np.array([[0.01]])
    K, CL, J = ncs.lqg(P, Q, R, QN, RN)
    W, R1d, c = _sampled_by_quadrature(A, B, B, Q, R, QN, h, tau)
    G0, G1 = P.input_delay.gamma0[0], P.input_delay.gamma1[0]
    Phi = np.asarray(P.A)
    Pa = np.block([[Phi, G1], [np.zeros((1, 3))]])
    Ga = np.vstack([G0, np.eye(1)])
    Q1, Q12, Q2 = W[:3, :3], W[:3, 3:], W[3:, 3:]
    S = sl.solve_discrete_are(Pa, Ga, Q1, Q2, s=Q12)
    L = np.linalg.solve(Q2 + Ga.T @ S @ Ga, Ga.T @ S @ Pa + Q12.T)
    C = np.array([[1.0, 0.0]])
    Pm = sl.solve_discrete_are(Phi.T, C.T, R1d, RN)
    Pkk = Pm - Pm @ C.T @ np.linalg.inv(C @ Pm @ C.T + RN) @ C @ Pm
    Pka = sl.block_diag(Pkk, np.zeros((1, 1)))
    J_ref = (np.trace(S @ sl.block_diag(R1d, np.zeros((1, 1)))) + c
             + np.trace(Pka @ L.T @ (Q2 + Ga.T @ S @ Ga) @ L)) / h
    assert J == pytest.approx(J_ref, rel=1e-9)
    assert ncs.cost(CL).cost == pytest.approx(J, rel=1e-12)
    assert isinstance(K, ct.StateSpace) and K.result.cost == J


def test_continuous_lqg_over_a_lossy_sensor_is_optimal_among_nearby_pairs():
    h = 0.3
    P, A, B = _servo_plant(h, sensor_loss=0.3)
    Q, R, QN, RN = np.diag([1.0, 0.2]), np.array([[0.1]]), \
        np.array([[2.0]]), np.array([[0.01]])
    K, CL, J = ncs.lqg(P, Q, R, QN, RN)
    J0 = ncs.lqg(_servo_plant(h)[0], Q, R, QN, RN)[2]
    assert J > J0
    assert ncs.cost(CL).cost == pytest.approx(J, rel=1e-12)
    rng = np.random.default_rng(5)
    from control_ncs._lqg_sampled import cost_plant, sample
    s = sample(P, Q, R, QN, None)
    Pc = cost_plant(P, s, Q, R, QN, RN)
    for _ in range(3):
        dK = 1 + 0.05 * rng.standard_normal(K.gains[0].shape)
        dL = 1 + 0.05 * rng.standard_normal(K.estimator_gain[0].shape)
        other = ncs.cost(ncs.feedback(Pc, K.gains[0] * dK,
                                      estimator_gain=K.estimator_gain[0]
                                      * dL)).cost
        assert other > J


def test_continuous_lqg_refuses_what_it_does_not_cover():
    P, _, _ = _servo_plant(0.3, actuator_loss=0.1)
    with pytest.raises(ControlArgument, match="continuous weights"):
        ncs.lqg(P, np.eye(2), [[1.0]], [[1.0]], [[0.1]])
    P, _, _ = _servo_plant(0.3, input_delay=([0.0, 0.1], [0.5, 0.5]))
    with pytest.raises(ControlArgument, match="constant"):
        ncs.lqg(P, np.eye(2), [[1.0]], [[1.0]], [[0.1]])
