"""Jitterbug's continuous-time cost of a sampled loop, against routes
written here: the worked examples of the theory page, Gauss–Legendre
quadrature of the period's integrals, the covariance ODE, the Riccati
closed forms, and a Monte Carlo of the continuous plant on a sub-grid.
"""

from __future__ import annotations

import functools
import math
import pickle

import control as ct
import numpy as np
import pytest
import scipy.linalg as sl
from scipy.sparse.linalg import LinearOperator, eigs
from hypothesis import given, settings, strategies as st

import control_ncs as ncs
from control_ncs.intersample import (delay_augmented_loss, intersample_weight,
                                     sampled_loss, sampled_noise)


# --------------------------------------------------------------------------
# independent routes
# --------------------------------------------------------------------------
def _flow(A, B, t):
    """``(e^{At}, ∫_0^t e^{As} ds B)``: the zero-order-hold sampling."""
    n, m = np.shape(B)
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, B
    E = sl.expm(M * t)
    return E[:n, :n], E[:n, n:]


def _gauss(a, b, order=24):
    x, w = np.polynomial.legendre.leggauss(order)
    return 0.5 * (b - a) * x + 0.5 * (b + a), 0.5 * (b - a) * w


def _weight_by_quadrature(A, B2, C1, D12, h, tau):
    """``W(τ)``: ``z(t) = M(t) [x; u_prev; u]`` integrated by
    Gauss–Legendre on ``[0, τ)`` (old input) and ``[τ, h)`` (new)."""
    n, m = B2.shape
    W = np.zeros((n + 2 * m, n + 2 * m))
    Z = np.zeros_like(D12)
    if tau > 0:
        for t, wt in zip(*_gauss(0.0, tau)):
            E, G = _flow(A, B2, t)
            M = np.hstack([C1 @ E, C1 @ G + D12, Z])
            W += wt * M.T @ M
    Gtau = _flow(A, B2, tau)[1]
    for t, wt in zip(*_gauss(tau, h)):
        E = _flow(A, B2, t)[0]
        Er, Gr = _flow(A, B2, t - tau)
        M = np.hstack([C1 @ E, C1 @ Er @ Gtau, C1 @ Gr + D12])
        W += wt * M.T @ M
    return W


def _noise_by_ode(A, B1, t):
    """``(Σ(t), ∫_0^t Σ(s) ds)`` from the covariance ODE
    ``vec Σ' = (I⊗A + A⊗I) vec Σ + vec B1B1ᵀ``: one exponential of the
    linear system with its integral and its constant forcing."""
    n = A.shape[0]
    k = n * n
    L = np.zeros((2 * k + 1, 2 * k + 1))
    L[:k, :k] = np.kron(np.eye(n), A) + np.kron(A, np.eye(n))
    L[:k, 2 * k] = (B1 @ B1.T).ravel()
    L[k:2 * k, :k] = np.eye(k)
    v = sl.expm(L * t)[:, 2 * k]
    return v[:k].reshape(n, n), v[k:2 * k].reshape(n, n)


def _plant(A, B1, B2, C1, D12, C2, D21=None):
    """The continuous generalized plant with inputs [w; u], outputs [z; y]."""
    A, B1, B2, C1, D12, C2 = (np.atleast_2d(np.asarray(X, float))
                              for X in (A, B1, B2, C1, D12, C2))
    D21 = np.zeros((C2.shape[0], B1.shape[1])) if D21 is None else \
        np.atleast_2d(np.asarray(D21, float))
    p1, m1 = C1.shape[0], B1.shape[1]
    D = np.block([[np.zeros((p1, m1)), D12],
                  [D21, np.zeros((C2.shape[0], B2.shape[1]))]])
    return ct.ss(A, np.hstack([B1, B2]), np.vstack([C1, C2]), D)


def _integrator():
    return _plant([[0.0]], [[1.0]], [[1.0]], [[1.0]], [[0.0]], [[1.0]])


def _kushner_tobias():
    s = ct.tf("s")
    G = ct.ss(6 / ((s + 1) * (s + 2)))
    return _plant(G.A, G.B, G.B, G.C, [[0.0]], G.C)


@functools.lru_cache(maxsize=None)
def _kt_cost(j):
    h = 1.42
    taus = np.arange(j + 1) * h / 50
    P = ncs.nss(_kushner_tobias(), nmeas=1, ncon=1, dt=h,
                input_delay=(taus, np.full(j + 1, 1.0 / (j + 1))))
    return ncs.cost(ncs.feedback(P, [[-1.0]]))


def _fourth_moment_radius(CL):
    """Radius of ``E[A⊗A⊗A⊗A]`` (period 1; per mode for Markov modes):
    below 1, the Monte Carlo's error bars can be trusted.

    Applied factor by factor (``O(n⁵)`` per mode, never the
    ``M n⁴``-square matrix), its largest eigenvalues by ARPACK from a
    fixed start; :func:`_dense_fourth_moment_radius` is the dense route."""
    m = CL.modes
    A, p = m.A[0], m.probabilities[0]
    M, n = A.shape[0], A.shape[-1]
    d = n ** 4

    def kron4(a, x):
        X = x.reshape(n, n, n, n)
        for _ in range(4):
            # contract the leading index with a, append it last
            X = np.tensordot(X, a, axes=([0], [1]))
        return X.ravel()

    if m.is_iid:
        size = d

        def apply(x):
            return sum(pi * kron4(a, x) for pi, a in zip(p, A) if pi)
    else:
        size, T = M * d, m.transition[0]

        def apply(x):
            # block (j, i) = T[i, j] (a_i⊗a_i⊗a_i⊗a_i)
            X = x.reshape(M, d)
            return (T.T @ np.array([kron4(a, X[i]) for i, a in
                                    enumerate(A)])).ravel()
    if size <= 16:
        return _dense_fourth_moment_radius(CL)
    op = LinearOperator((size, size), matvec=apply, dtype=float)
    values = eigs(op, k=min(6, size - 2), which="LM", v0=np.ones(size),
                  ncv=min(size - 1, 40), return_eigenvectors=False)
    return float(np.max(np.abs(values)))


def _dense_fourth_moment_radius(CL):
    """:func:`_fourth_moment_radius` on the dense matrix."""
    m = CL.modes
    A, p = m.A[0], m.probabilities[0]
    blocks = [np.kron(np.kron(a, a), np.kron(a, a)) for a in A]
    if m.is_iid:
        op = sum(pi * b for pi, b in zip(p, blocks))
    else:
        T, d = m.transition[0], blocks[0].shape[0]
        op = np.zeros((len(A) * d, len(A) * d))
        for i, b in enumerate(blocks):
            for j in range(len(A)):
                op[j * d:(j + 1) * d, i * d:(i + 1) * d] = T[i, j] * b
    return float(np.max(np.abs(np.linalg.eigvals(op))))


def test_fourth_moment_radius_is_the_dense_one():
    """The Monte Carlo tests' tail check against the dense matrix, on
    i.i.d. and Markov modes (a random transition matrix)."""
    rng = np.random.default_rng(3)
    for n, M in ((2, 3), (3, 2)):
        A = np.array([[rng.standard_normal((n, n)) / n for _ in range(M)]])
        B = np.zeros((1, M, n, 1))
        C, D = np.zeros((1, M, 1, n)), np.zeros((1, M, 1, 1))
        p = rng.dirichlet(np.ones(M), size=1)
        T = rng.dirichlet(np.ones(M), size=M)
        for sys in (ncs.jss(A, B, C, D, p, True),
                    ncs.jss(A, B, C, D, transition=T, dt=True)):
            assert _fourth_moment_radius(sys) == pytest.approx(
                _dense_fourth_moment_radius(sys), rel=1e-10)


# --------------------------------------------------------------------------
# a Monte Carlo of the continuous plant, written from the definitions
# --------------------------------------------------------------------------
def _monte_carlo(G, h, L, timings, controller, *, nmeas, ncon, paths=200,
                 periods=800, burn=60, sensor_loss=0.0, actuator_loss=0.0,
                 seed=0):
    """``J`` with its standard error over independent paths.

    Sub-steps ``δ = h/L``; ``timings`` is ``[((s, τ) in sub-steps,
    probability), …]``; the plant noise of each sub-step is drawn exactly
    (``Σ(δ)``); ``zᵀz`` is integrated by the trapezoid rule with the input
    of each sub-step, so the switch gets its left and right limits. The
    controller is ``(init(paths), step(state, y, arrived))`` returning
    ``(state, v)``; the actuator applies ``v`` when it arrives, else 0; its
    input is held over ``[kh + τ, (k+1)h + τ')``.
    """
    rng = np.random.default_rng(seed)
    A, B = np.asarray(G.A), np.asarray(G.B)
    C, D = np.asarray(G.C), np.asarray(G.D)
    n, m1 = A.shape[0], B.shape[1] - ncon
    p1 = C.shape[0] - nmeas
    B1, B2, C1, D12 = B[:, :m1], B[:, m1:], C[:p1], D[:p1, m1:]
    C2, D21 = C[p1:], D[p1:, :m1]
    delta = h / L
    Ed, Gd = _flow(A, B2, delta)
    vals, vecs = np.linalg.eigh(_noise_by_ode(A, B1, delta)[0])
    R = vecs * np.sqrt(np.clip(vals, 0.0, None))      # R Rᵀ = Σ(δ)
    pts = np.array([t for t, _ in timings])
    pr = np.array([q for _, q in timings])
    x = np.zeros((paths, n))
    u_prev = np.zeros((paths, ncon))
    state = controller[0](paths)
    total = np.zeros(paths)
    for k in range(burn + periods):
        pick = rng.choice(len(pts), size=paths, p=pr)
        s_idx, t_idx = pts[pick, 0], pts[pick, 1]
        noise = rng.standard_normal((L, paths, n)) @ R.T
        # the state at each path's sample: the old input acts until then
        xs, xj = x.copy(), x
        for j in range(int(s_idx.max())):
            xj = xj @ Ed.T + u_prev @ Gd.T + noise[j]
            xs[s_idx == j + 1] = xj[s_idx == j + 1]
        y = xs @ C2.T + rng.standard_normal((paths, m1)) @ D21.T
        arrived = rng.random(paths) >= sensor_loss
        state, v = controller[1](state, y, arrived)
        delivered = rng.random(paths) >= actuator_loss
        u_now = np.where(delivered[:, None], v, 0.0)
        # the period again with the same noise, switching at τ
        acc = np.zeros(paths)
        for j in range(L):
            u = np.where((j < t_idx)[:, None], u_prev, u_now)
            z0 = x @ C1.T + u @ D12.T
            x = x @ Ed.T + u @ Gd.T + noise[j]
            z1 = x @ C1.T + u @ D12.T
            acc += 0.5 * delta * ((z0 ** 2).sum(1) + (z1 ** 2).sum(1))
        u_prev = u_now
        if k >= burn:
            total += acc
    J = total / (periods * h)
    return float(J.mean()), float(J.std(ddof=1) / math.sqrt(paths))


def _static(K):
    K = np.atleast_2d(K)
    return (lambda paths: None,
            lambda st, y, arrived: (st, np.where(arrived[:, None], y, 0.0)
                                    @ K.T))


def _lti(Kss):
    Ac, Bc, Cc, Dc = (np.asarray(X, float) for X in (Kss.A, Kss.B, Kss.C,
                                                      Kss.D))

    def step(xc, y, arrived):
        yh = np.where(arrived[:, None], y, 0.0)
        return xc @ Ac.T + yh @ Bc.T, xc @ Cc.T + yh @ Dc.T
    return (lambda paths: np.zeros((paths, Ac.shape[0])), step)


def _estimator(Phi, Gamma, C2, K, Lg):
    """``x̂⁻ = Φ x̂ + Γ u`` (the applied input, acknowledged), corrected by
    ``L (y - C2 x̂⁻)`` when the measurement arrives; ``v = K x̂``."""
    def step(st, y, arrived):
        xh, u = st
        pred = xh @ Phi.T + u @ Gamma.T
        corr = (y - pred @ C2.T) @ Lg.T
        xh = pred + np.where(arrived[:, None], corr, 0.0)
        v = xh @ K.T
        return (xh, v), v
    return (lambda paths: (np.zeros((paths, Phi.shape[0])),
                           np.zeros((paths, K.shape[0]))), step)


# --------------------------------------------------------------------------
# the period's integrals
# --------------------------------------------------------------------------
@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), frac=st.floats(0.0, 0.95))
def test_period_weight_equals_gauss_legendre_quadrature(seed, frac):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((2, 2))
    B2, C1, D12 = (rng.standard_normal(s) for s in ((2, 1), (2, 2), (2, 1)))
    h = 0.7
    W = intersample_weight(A, B2, C1, D12, h, frac * h)
    ref = _weight_by_quadrature(A, B2, C1, D12, h, frac * h)
    np.testing.assert_allclose(W, ref, rtol=1e-9, atol=1e-11)


def test_sampled_loss_is_the_astrom_wittenmark_quadrature():
    rng = np.random.default_rng(3)
    A, B2 = rng.standard_normal((3, 3)), rng.standard_normal((3, 2))
    C1, D12 = rng.standard_normal((2, 3)), rng.standard_normal((2, 2))
    h = 0.4
    Qc = np.hstack([C1, D12]).T @ np.hstack([C1, D12])
    ref = np.zeros((5, 5))
    for t, w in zip(*_gauss(0.0, h)):
        E, G = _flow(A, B2, t)
        F = np.block([[E, G], [np.zeros((2, 3)), np.eye(2)]])
        ref += w * F.T @ Qc @ F
    Q1, Q12, Q2 = sampled_loss(A, B2, C1, D12, h)
    np.testing.assert_allclose(np.block([[Q1, Q12], [Q12.T, Q2]]), ref,
                               rtol=1e-10, atol=1e-12)


def test_noise_term_and_R1d_match_the_covariance_ode():
    rng = np.random.default_rng(4)
    A, B1, C1 = (rng.standard_normal(s) for s in ((3, 3), (3, 2), (2, 3)))
    R1d, c = sampled_noise(A, B1, C1, 0.9)
    S, area = _noise_by_ode(A, B1, 0.9)
    np.testing.assert_allclose(R1d, S, rtol=1e-10, atol=1e-12)
    assert c == pytest.approx(np.trace(C1.T @ C1 @ area), rel=1e-10)


def test_noise_term_with_the_sampled_weight_is_44_percent_too_large():
    G = _kushner_tobias()
    A, B, C = G.A, G.B[:, :1], G.C[:1]
    h = 1.42
    c = sampled_noise(A, B, C, h)[1]
    area = _noise_by_ode(A, B, h)[1]
    Qd = sampled_loss(A, B, C, [[0.0]], h)[0]
    assert np.trace(Qd @ area) / c == pytest.approx(1.441, abs=1e-3)


def test_delay_augmented_model_is_the_sampled_model_of_the_delays():
    A, B2 = np.array([[0.0, 1.0], [-2.0, -0.5]]), np.array([[0.0], [1.0]])
    h, tau = 0.3, 0.12
    Pa, Ga, Q1, Q12, Q2 = delay_augmented_loss(A, B2, np.eye(2),
                                               np.zeros((2, 1)), h, tau)
    Phi, G_rest = _flow(A, B2, h - tau)
    E_tau, G_tau = _flow(A, B2, tau)
    np.testing.assert_allclose(Pa[:2, :2], _flow(A, B2, h)[0], atol=1e-14)
    np.testing.assert_allclose(Pa[:2, 2:], Phi @ G_tau, atol=1e-14)
    np.testing.assert_allclose(Ga[:2], G_rest, atol=1e-14)
    W = _weight_by_quadrature(A, B2, np.eye(2), np.zeros((2, 1)), h, tau)
    np.testing.assert_allclose(np.block([[Q1, Q12], [Q12.T, Q2]]), W,
                               rtol=1e-10, atol=1e-12)


# --------------------------------------------------------------------------
# worked examples (theory: intersample cost)
# --------------------------------------------------------------------------
@pytest.mark.parametrize("k, h", [(1.0, 1.0), (2.0, 0.5), (0.5, 1.2),
                                  (3.0, 0.3)])
def test_integrator_cost_is_the_closed_form(k, h):
    P = ncs.nss(_integrator(), nmeas=1, ncon=1, dt=h)
    Sx = h / (1.0 - (1.0 - k * h) ** 2)
    J = Sx * (1 - k * h + (k * h) ** 2 / 3) + h / 2
    assert ncs.cost(ncs.feedback(P, [[-k]])).cost == pytest.approx(J,
                                                                   rel=1e-12)


def test_integrator_at_kh_1_costs_5h_over_6_not_the_sampled_h_squared():
    h = 0.8
    CL = ncs.feedback(ncs.nss(_integrator(), nmeas=1, ncon=1, dt=h), [[-1 / h]])
    assert ncs.cost(CL).cost == pytest.approx(5 * h / 6, rel=1e-12)
    assert ncs.norm(CL, 2) ** 2 == pytest.approx(h ** 2, rel=1e-12)


def test_integrator_with_half_a_period_of_delay_costs_13_over_8():
    P = ncs.nss(_integrator(), nmeas=1, ncon=1, dt=1.0,
                input_delay=([0.5], [1.0]))
    assert ncs.cost(ncs.feedback(P, [[-1.0]])).cost == pytest.approx(
        13 / 8, rel=1e-12)


def test_integrator_with_jitter_costs_59_over_48_less_than_the_fixed_delay():
    P = ncs.nss(_integrator(), nmeas=1, ncon=1, dt=1.0,
                input_delay=([0.0, 0.5], [0.5, 0.5]))
    assert ncs.cost(ncs.feedback(P, [[-1.0]])).cost == pytest.approx(
        59 / 48, rel=1e-12)


@settings(max_examples=5, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_static_gain_without_delay_costs_the_sampled_loss_by_quadrature(seed):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((2, 2)) - np.eye(2)
    B1, B2 = rng.standard_normal((2, 1)), rng.standard_normal((2, 1))
    C1, D12 = rng.standard_normal((2, 2)), rng.standard_normal((2, 1))
    h = 0.25
    Phi, Gam = _flow(A, B2, h)
    K = -ct.dlqr(Phi, Gam, np.eye(2), np.eye(1))[0]
    P = ncs.nss(_plant(A, B1, B2, C1, D12, np.eye(2)), nmeas=2, ncon=1, dt=h)
    # Åström–Wittenmark: Q1, Q12, Q2 and R1d by Gauss–Legendre, c by the ODE
    Qc = np.hstack([C1, D12]).T @ np.hstack([C1, D12])
    Qx, R1d = np.zeros((2, 2)), np.zeros((2, 2))
    for t, w in zip(*_gauss(0.0, h)):
        E, G = _flow(A, B2, t)
        F = np.vstack([E + G @ K, K])
        Qx += w * F.T @ Qc @ F
        R1d += w * E @ B1 @ B1.T @ E.T
    Sx = sl.solve_discrete_lyapunov(Phi + Gam @ K, R1d)
    c = np.trace(C1.T @ C1 @ _noise_by_ode(A, B1, h)[1])
    J = (np.trace(Qx @ Sx) + c) / h
    assert ncs.cost(ncs.feedback(P, K)).cost == pytest.approx(J, rel=1e-9)


# --------------------------------------------------------------------------
# Kushner–Tobias (theory: delays, sub-sample delays)
# --------------------------------------------------------------------------
def test_kushner_tobias_cost_is_finite_at_23_grains_and_infinite_at_24():
    at23, at24 = _kt_cost(23), _kt_cost(24)
    assert math.isfinite(at23.cost) and at23.ms_radius == pytest.approx(
        0.981160, abs=1e-6)
    assert at24.cost == math.inf and at24.status == "not_mss"
    assert at24.ms_radius == pytest.approx(1.006315, abs=1e-6)


def test_kushner_tobias_cost_first_falls_then_rises_with_the_jitter():
    J = [_kt_cost(j).cost for j in (0, 8, 16, 23)]
    assert J[0] > J[1] and J[1] < J[2] < J[3]


# --------------------------------------------------------------------------
# Riccati closed forms (theory: design for J)
# --------------------------------------------------------------------------
def _servo():
    A = np.array([[0.0, 1.0], [0.0, -1.0]])
    B = np.array([[0.0], [1.0]])
    return A, B


def test_lq_optimum_is_trace_P_R1d_plus_c_over_h():
    A, B = _servo()
    C1, D12, h = np.array([[1.0, 0.0], [0.0, 0.0]]), np.array([[0.0], [0.3]]), 0.2
    Q1, Q12, Q2 = sampled_loss(A, B, C1, D12, h)
    Phi, Gam = _flow(A, B, h)
    Pr = sl.solve_discrete_are(Phi, Gam, Q1, Q2, s=Q12)
    L = -np.linalg.solve(Q2 + Gam.T @ Pr @ Gam, Gam.T @ Pr @ Phi + Q12.T)
    R1d, c = sampled_noise(A, B, C1, h)
    P = ncs.nss(_plant(A, B, B, C1, D12, np.eye(2)), nmeas=2, ncon=1, dt=h)
    J = ncs.cost(ncs.feedback(P, L)).cost
    assert J == pytest.approx((np.trace(Pr @ R1d) + c) / h, rel=1e-10)
    # the optimum: any other gain costs more
    assert ncs.cost(ncs.feedback(P, 1.05 * L)).cost > J


def test_constant_delay_lq_optimum_matches_its_augmented_riccati():
    A, B = _servo()
    C1, D12, h, tau = np.eye(2), np.array([[0.0], [0.0]]), 0.2, 0.07
    Pa, Ga, Q1, Q12, Q2 = delay_augmented_loss(A, B, C1, D12, h, tau)
    Pr = sl.solve_discrete_are(Pa, Ga, Q1, Q2, s=Q12)
    L = -np.linalg.solve(Q2 + Ga.T @ Pr @ Ga, Ga.T @ Pr @ Pa + Q12.T)
    R1d, c = sampled_noise(A, B, C1, h)
    Ra = sl.block_diag(R1d, np.zeros((1, 1)))
    # u_k = Lx x_k + Lu u_{k-1}: a controller whose state is u_{k-1}
    Lx, Lu = L[:, :2], L[:, 2:]
    Kss = ct.ss(Lu, Lx, Lu, Lx, h)
    P = ncs.nss(_plant(A, B, B, C1, D12, np.eye(2)), nmeas=2, ncon=1, dt=h,
                input_delay=([tau], [1.0]))
    J = ncs.cost(ncs.feedback(P, Kss)).cost
    assert J == pytest.approx((np.trace(Pr @ Ra) + c) / h, rel=1e-9)


def test_sampled_lqg_with_the_estimator_costs_the_separation_formula():
    A, B = _servo()
    C1, D12, h = np.array([[1.0, 0.0]]), np.array([[0.0]]), 0.2
    C2, rn = np.array([[1.0, 0.0]]), 0.05
    Q1, Q12, Q2 = sampled_loss(A, B, C1, D12, h)
    Phi, Gam = _flow(A, B, h)
    Pr = sl.solve_discrete_are(Phi, Gam, Q1, Q2, s=Q12)
    L = -np.linalg.solve(Q2 + Gam.T @ Pr @ Gam, Gam.T @ Pr @ Phi + Q12.T)
    R1d, c = sampled_noise(A, B, C1, h)
    Pm = sl.solve_discrete_are(Phi.T, C2.T, R1d, rn * np.eye(1))
    Kf = Pm @ C2.T @ np.linalg.inv(C2 @ Pm @ C2.T + rn)
    Pkk = Pm - Kf @ C2 @ Pm
    J_ref = (np.trace(Pr @ R1d) + c
             + np.trace(Pkk @ L.T @ (Q2 + Gam.T @ Pr @ Gam) @ L)) / h
    # process noise continuous (a B1 column), measurement noise discrete
    G = _plant(A, np.hstack([B, np.zeros((2, 1))]), B, C1, D12, C2,
               [[0.0, math.sqrt(rn)]])
    P = ncs.nss(G, nmeas=1, ncon=1, dt=h)
    J = ncs.cost(ncs.feedback(P, L, estimator_gain=Kf)).cost
    assert J == pytest.approx(J_ref, rel=1e-9)


# --------------------------------------------------------------------------
# Monte Carlo of the continuous plant
# --------------------------------------------------------------------------
def test_pd_servo_with_jitter_and_a_weighted_input_matches_monte_carlo():
    A, B = _servo()
    h, L = 0.2, 10
    G = _plant(A, np.hstack([B, np.zeros((2, 1))]), B,
               [[1.0, 0.0], [0.0, 0.0]], [[0.0], [0.5]], [[1.0, 0.0]],
               [[0.0, 0.1]])
    kp, kd = 1.5, 0.8          # v = -kp y - kd (y - y_prev)/h
    Kss = ct.ss([[0.0]], [[1.0]], [[kd / h]], [[-(kp + kd / h)]], h)
    timings = [((0, 0), 0.3), ((0, 3), 0.4), ((0, 6), 0.3)]
    P = ncs.nss(G, nmeas=1, ncon=1, dt=h,
                input_delay=([0.0, 3 * h / L, 6 * h / L], [0.3, 0.4, 0.3]))
    CL = ncs.feedback(P, Kss)
    assert _fourth_moment_radius(CL) < 1
    J = ncs.cost(CL).cost
    mc, se = _monte_carlo(G, h, L, timings, _lti(Kss), nmeas=1, ncon=1,
                          seed=1)
    assert abs(mc - J) < 4 * se, (J, mc, se)
    assert se < 0.03 * J


def test_state_feedback_over_a_lossy_actuator_matches_monte_carlo():
    A = np.array([[0.0, 1.0], [1.0, -0.2]])
    B = np.array([[0.0], [1.0]])
    h, L = 0.25, 10
    G = _plant(A, B, B, np.eye(2), [[0.0], [0.0]], np.eye(2))
    Phi, Gam = _flow(A, B, h)
    K = -ct.dlqr(Phi, Gam, np.eye(2), np.eye(1))[0]
    P = ncs.nss(G, nmeas=2, ncon=1, dt=h, actuator_loss=0.2)
    CL = ncs.feedback(P, K)
    assert _fourth_moment_radius(CL) < 1
    J = ncs.cost(CL).cost
    mc, se = _monte_carlo(G, h, L, [((0, 0), 1.0)], _static(K), nmeas=2,
                          ncon=1, actuator_loss=0.2, seed=2)
    assert abs(mc - J) < 4 * se, (J, mc, se)
    assert se < 0.03 * J


def test_estimator_over_a_lossy_noisy_sensor_matches_monte_carlo():
    A, B = np.array([[0.3]]), np.array([[1.0]])
    h, L = 0.5, 10
    G = _plant(A, [[1.0, 0.0]], B, [[1.0]], [[0.0]], [[1.0]], [[0.0, 0.3]])
    Phi, Gam = _flow(A, B, h)
    K = -ct.dlqr(Phi, Gam, np.eye(1), np.eye(1))[0]
    Lg = np.array([[0.6]])
    P = ncs.nss(G, nmeas=1, ncon=1, dt=h, sensor_loss=0.3)
    CL = ncs.feedback(P, K, estimator_gain=Lg)
    assert _fourth_moment_radius(CL) < 1
    J = ncs.cost(CL).cost
    mc, se = _monte_carlo(G, h, L, [((0, 0), 1.0)],
                          _estimator(Phi, Gam, np.eye(1), K, Lg), nmeas=1,
                          ncon=1, sensor_loss=0.3, seed=3)
    assert abs(mc - J) < 4 * se, (J, mc, se)
    assert se < 0.03 * J


# --------------------------------------------------------------------------
# delays on the measurement path
# --------------------------------------------------------------------------
def test_a_measurement_one_step_late_costs_what_a_delaying_controller_costs():
    A, B = _servo()
    h = 0.2
    G = _plant(A, B, B, [[1.0, 0.0]], [[0.2]], np.eye(2))
    K = np.array([[-2.0, -1.5]])
    jitter = dict(input_delay=([0.0, 0.05], [0.5, 0.5]))
    late = ncs.nss(G, nmeas=2, ncon=1, dt=h, sensor_delay=[0.0, 1.0],
                   **jitter)
    at_once = ncs.nss(G, nmeas=2, ncon=1, dt=h, **jitter)
    delaying = ct.ss(np.zeros((2, 2)), np.eye(2), K, np.zeros((1, 2)), h)
    J_late = ncs.cost(ncs.feedback(late, K)).cost
    J_ctrl = ncs.cost(ncs.feedback(at_once, delaying)).cost
    assert J_late == pytest.approx(J_ctrl, rel=1e-10)


@pytest.mark.parametrize("controller", ["estimator", "lti", "lti-hold"])
def test_a_link_that_never_delays_costs_what_the_lossy_link_costs(controller):
    """The two builders record the loop in different coordinates (buffers
    and estimates against the estimator's [x̂; e], a stored measurement);
    a delay law with all its mass at 0 is the Bernoulli link."""
    A, B = _servo()
    h = 0.2
    G = _plant(A, np.hstack([B, np.zeros((2, 1))]), B, [[1.0, 0.0], [0.0, 0.0]],
               [[0.0], [0.3]], [[1.0, 0.0]], [[0.0, 0.1]])
    K = -ct.dlqr(*_flow(A, B, h), np.eye(2), np.eye(1))[0]
    kw = (dict(K=K, estimator_gain=[[0.5], [0.8]]) if controller == "estimator"
          else dict(K=ct.ss([[0.0]], [[1.0]], [[2.0]], [[-5.0]], h),
                    sensor="hold" if controller == "lti-hold" else "zero"))
    delayed = ncs.nss(G, nmeas=1, ncon=1, dt=h, sensor_delay=[0.8])
    lossy = ncs.nss(G, nmeas=1, ncon=1, dt=h, sensor_loss=0.2)
    J = [ncs.cost(ncs.feedback(P, **kw)).cost for P in (delayed, lossy)]
    assert J[0] == pytest.approx(J[1], rel=1e-10)


def _late_sample_loop(G, h, K, timings):
    """A static gain ``u_k = K y_k`` reading ``y_k = C2 x(kh + s)``, the
    input switching at ``kh + τ`` (``s ≤ τ``), as a jump system on
    ``[x_k; u_{k-1}]`` with the record of the sampling jitter (theory:
    intersample cost, the late sample's noise ``n_s``)."""
    A, B = np.asarray(G.A), np.asarray(G.B)
    n = A.shape[0]
    B2 = B[:, 1:]
    C2 = np.asarray(G.C)[1:]
    Phi = _flow(A, B2, h)[0]
    As, Bs, u, un, nn, S, T = [], [], [], [], [], [], []
    for (s, tau), _ in timings:
        Es, Gs = _flow(A, B2, s)
        Erest, G0 = _flow(A, B2, h - tau)
        G1 = Erest @ _flow(A, B2, tau)[1]
        U = np.hstack([K @ C2 @ Es, K @ C2 @ Gs])
        As.append(np.block([[Phi, G1], [np.zeros((1, n + 1))]])
                  + np.vstack([G0, np.eye(1)]) @ U)
        Bs.append(np.zeros((n + 1, 1)))
        u.append(U)
        un.append(K @ C2)
        nn.append(np.vstack([G0 @ K @ C2, K @ C2]))
        S.append(s)
        T.append(tau)
    p = [q for _, q in timings]
    CL = ncs.jss(np.array(As), np.array(Bs),
                 np.hstack([np.asarray(G.C)[:1], np.zeros((1, 1))]),
                 [[0.0]], p, h)
    prev = np.hstack([np.zeros((1, n)), np.eye(1)])
    CL.info["sampling"] = dict(
        h=h, plant=(G.A, G.B, G.C, G.D), nmeas=1, ncon=1, x=slice(0, n),
        u=np.array(u)[None], u_w=np.zeros((1, len(p), 1, 1)),
        u_prev=np.repeat(prev[None, None], len(p), 1), tau=np.array([T]),
        s=np.array([S]), u_n=np.array(un)[None], n_noise=np.array(nn)[None])
    return CL


def _oscillator():
    A = np.array([[0.0, 1.0], [-1.0, -0.4]])
    B = np.array([[0.0], [1.0]])
    return _plant(A, B, B, [[1.0, 0.0]], [[0.3]], [[1.0, 0.0]])


def test_a_constant_late_sample_is_the_loop_shifted_in_time():
    G, h, K = _oscillator(), 0.5, np.array([[-0.8]])
    s, tau = 0.15, 0.35
    J_late = ncs.cost(_late_sample_loop(G, h, K, [((s, tau), 1.0)])).cost
    P = ncs.nss(G, nmeas=1, ncon=1, dt=h, input_delay=([tau - s], [1.0]))
    assert J_late == pytest.approx(ncs.cost(ncs.feedback(P, K)).cost,
                                   rel=1e-10)


def test_sampling_and_actuation_jitter_together_match_monte_carlo():
    G, h, L, K = _oscillator(), 0.5, 10, np.array([[-0.8]])
    grid = [((0, 0), 0.3), ((2, 4), 0.4), ((3, 7), 0.3)]
    CL = _late_sample_loop(G, h, K, [((s * h / L, t * h / L), q)
                                     for (s, t), q in grid])
    assert _fourth_moment_radius(CL) < 1
    J = ncs.cost(CL).cost
    mc, se = _monte_carlo(G, h, L, grid, _static(K), nmeas=1, ncon=1, seed=4)
    assert abs(mc - J) < 4 * se, (J, mc, se)
    assert se < 0.03 * J


# --------------------------------------------------------------------------
# the interface
# --------------------------------------------------------------------------
def test_discrete_plant_cost_is_the_h2_norm_squared():
    P = ncs.nss([[1.1]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0],
                [0.0, 0.0]], nmeas=1, ncon=1, actuator_loss=0.1)
    CL = ncs.feedback(P, [[-1.0]])
    res = ncs.cost(CL)
    assert not res.continuous and res.cost == pytest.approx(
        ncs.norm(CL, 2) ** 2, rel=1e-12)


def test_direct_feedthrough_of_white_noise_to_z_is_refused():
    G = ct.ss([[-1.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.5, 0.0],
              [0.0, 0.0]])
    CL = ncs.feedback(ncs.nss(G, nmeas=1, ncon=1, dt=0.1), [[-1.0]])
    with pytest.raises(ValueError, match="D11"):
        ncs.cost(CL)


def test_a_noise_both_continuous_and_sampled_is_refused_by_name():
    G = ct.ss([[-1.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0],
              [0.2, 0.0]], inputs=["gust", "u"])
    CL = ncs.feedback(ncs.nss(G, nmeas=1, ncon=1, dt=0.1), [[-1.0]])
    with pytest.raises(ValueError, match="gust"):
        ncs.cost(CL)


def test_a_loop_changed_after_it_was_closed_is_refused():
    P = ncs.nss(_integrator(), nmeas=1, ncon=1, dt=0.5)
    CL = ncs.feedback(P, [[-2.0]])
    with pytest.raises(ValueError, match="changed"):
        ncs.cost(2.0 * CL)


def test_cost_result_states_its_verdict_and_survives_pickling():
    P = ncs.nss(_integrator(), nmeas=1, ncon=1, dt=0.5)
    CL = pickle.loads(pickle.dumps(ncs.feedback(P, [[-2.0]])))
    res = ncs.cost(CL)
    assert res.success and res.status == "exact" and res.residual < 1e-12
    assert res.noise_cost == pytest.approx(0.25) and float(res) == res.cost
    assert pickle.loads(pickle.dumps(res)).cost == res.cost
    unstable = ncs.cost(ncs.feedback(P, [[-5.0]]))
    assert not unstable.success and unstable.cost == math.inf
    assert "ms_radius" in unstable.message


def test_sampled_plant_keeps_its_continuous_plant_through_pickling():
    P = ncs.nss(_integrator(), nmeas=1, ncon=1, dt=0.5, actuator_loss=0.1)
    Q = pickle.loads(pickle.dumps(P))
    assert Q.equals(P) and np.array_equal(Q.continuous.A, P.continuous.A)
    assert P.with_network(actuator_loss=0.2).continuous is not None
    with pytest.raises(ValueError, match="continuous"):
        P.with_network(A=[[0.5]])
