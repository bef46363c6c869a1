"""H2 norm, Lyapunov exponent and LQ over a lossy link, against closed forms
and independent routes (theory: performance)."""

from __future__ import annotations

import math

import control as ct
import numpy as np
import pytest
from control.exception import ControlArgument, ControlDimension
from hypothesis import given, settings, strategies as st

import control_ncs as ncs


def scalar_iid(a, p):
    """``x⁺ = a_i x + w``, ``z = x``, mode ``i`` with probability ``p_i``."""
    return ncs.jss([[[x]] for x in a], [[1.0]], [[1.0]], [[0.0]], p)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-1.2, 1.2), min_size=2, max_size=3),
       st.floats(0.05, 0.95))
def test_h2_of_a_scalar_iid_system_is_one_over_one_minus_e_a_squared(a, q):
    p = [q, 1 - q] + [0.0] * (len(a) - 2)
    Ea2 = sum(pi * ai ** 2 for pi, ai in zip(p, a))
    sys = scalar_iid(a, p)
    if Ea2 < 0.999:
        assert ncs.norm(sys) ** 2 == pytest.approx(1 / (1 - Ea2), rel=1e-9)
    elif Ea2 > 1.001:
        with pytest.warns(UserWarning, match="not mean-square stable"):
            assert ncs.norm(sys) == math.inf


@pytest.mark.parametrize("method", ["dense", "matrix-free"])
def test_h2_of_the_costa_fragoso_marques_example_is_31_over_3(method):
    A = np.array([[[[2.0, -1.0], [0.0, 0.0]], [[0.0, 1.0], [0.0, 2.0]]]])
    sys = ncs.jss(A, np.eye(2), np.eye(2), np.zeros((2, 2)),
                  transition=[[0.1, 0.9], [0.9, 0.1]])
    assert ncs.norm(sys, method=method) ** 2 == pytest.approx(31 / 3,
                                                              rel=1e-10)


def test_h2_of_a_lossy_loop_is_not_the_mean_systems():
    """x⁺ = 1.1x + θu + w, u = -x, loss 0.3, z = x, built as users do."""
    P = ncs.nss([[1.1]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0], [0.0, 0.0]],
                True, nmeas=1, ncon=1, actuator_loss=0.3)
    CL = ncs.feedback(P, [[-1.0]])
    assert ncs.norm(CL, 2) == pytest.approx(1.25988, abs=5e-6)
    assert ncs.norm(CL, 2) == pytest.approx(math.sqrt(1 / 0.63), rel=1e-12)
    assert ct.norm(CL.mean(), 2) == pytest.approx(1.09109, abs=5e-6)


@pytest.mark.parametrize("p", [2, "inf"])
def test_python_control_norm_refuses_a_jump_system(p):
    """ct.norm would compute the mean system's norm: refused, naming ncs.norm;
    a deterministic jump system and the explicit mean are still answered."""
    P = ncs.nss([[1.1]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0], [0.0, 0.0]],
                True, nmeas=1, ncon=1, actuator_loss=0.3)
    CL = ncs.feedback(P, [[-1.0]])
    with pytest.raises(ControlArgument, match="control_ncs.norm"):
        ct.norm(CL, p)
    assert ct.norm(CL.mean(), p) == pytest.approx(ct.norm(ct.ss(CL), p))
    same = ncs.jss([[[0.5]], [[0.5]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7])
    assert ct.norm(same, 2) == pytest.approx(ncs.norm(same, 2), rel=1e-12)


@pytest.mark.parametrize("seed", range(4))
def test_h2_of_a_deterministic_system_equals_python_control(seed):
    rng = np.random.default_rng(seed)
    n, m, p = 4, 2, 3
    A = rng.standard_normal((n, n))
    A *= 0.9 / np.abs(np.linalg.eigvals(A)).max()
    G = ct.ss(A, rng.standard_normal((n, m)), rng.standard_normal((p, n)),
              rng.standard_normal((p, m)), 0.1)
    assert ncs.norm(G) == pytest.approx(ct.norm(G, 2), rel=1e-10)
    square = G[:2, :]       # python-control's H∞ (without slycot): square
    assert ncs.norm(square, "inf") == pytest.approx(ct.norm(square, "inf"),
                                                    rel=1e-10)
    Gc = ct.ss([[-1.0]], [[1.0]], [[1.0]], [[0.0]])
    assert ncs.norm(Gc) == pytest.approx(ct.norm(Gc, 2), rel=1e-10)


def test_h2_of_a_periodic_system_is_the_lifted_norm_per_step():
    """One mode, period 3: the lifted system's squared H2 norm is the
    energy of a whole period, N times the per-step power."""
    rng = np.random.default_rng(5)
    A = rng.standard_normal((3, 1, 2, 2)) * 0.5
    B = rng.standard_normal((3, 1, 2, 1))
    C = rng.standard_normal((3, 1, 1, 2))
    D = rng.standard_normal((3, 1, 1, 1))
    sys = ncs.jss(A, B, C, D, [[1.0]] * 3)
    lifted = ct.ss(sys.A, sys.B, sys.C, sys.D, True)
    assert ncs.norm(sys) ** 2 == pytest.approx(ct.norm(lifted, 2) ** 2 / 3,
                                               rel=1e-9)


def test_h2_agrees_with_a_long_sample_path():
    """Independent route: the time average of z² along one long path of a
    period-2 Markov system driven by white noise."""
    A = np.array([[[[0.6, 0.3], [0.0, 0.5]], [[1.1, 0.0], [0.2, 0.3]]],
                  [[[0.4, -0.2], [0.1, 0.7]], [[0.2, 0.5], [0.0, 0.9]]]])
    B = np.array([[[[1.0], [0.5]]] * 2] * 2)
    C = np.array([[[[1.0, -1.0]]] * 2] * 2)
    T = np.array([[[0.8, 0.2], [0.4, 0.6]], [[0.7, 0.3], [0.5, 0.5]]])
    sys = ncs.jss(A, B, C, np.zeros((2, 2, 1, 1)), transition=T)
    h2sq = ncs.norm(sys) ** 2
    rng = np.random.default_rng(7)
    steps, x, mode = 400_000, np.zeros(2), 0
    noise = rng.standard_normal(steps)
    u = rng.random(steps)
    zs = np.empty(steps)
    for t in range(steps):
        k = t % 2
        zs[t] = C[k, mode, 0] @ x
        x = A[k, mode] @ x + B[k, mode, :, 0] * noise[t]
        mode = int(u[t] > T[k, mode, 0])
    power = zs[1000:] ** 2
    # batch means for the standard error of a correlated series
    batches = power[: power.size // 100 * 100].reshape(100, -1).mean(axis=1)
    se = batches.std(ddof=1) / 10
    assert abs(power.mean() - h2sq) < 4 * se


def _scalar_gain(a, b, c, d, p):
    """MATH's scalar bounded real lemma: γ² = inf over P > E c²/(1 - E a²)
    of E b² P + E d² + (E(ab) P + E(cd))² / (P (1 - E a²) - E c²), in
    closed form: with u = P (1 - E a²) - E c² > 0 it is
    const + (α/σ + g²) u + h²/u, least at u = |h| / √(α/σ + g²)."""
    E = lambda x: float(np.dot(p, x))          # noqa: E731
    a, b, c, d = map(np.asarray, (a, b, c, d))
    alpha, delta, beta, kappa = E(b * b), E(d * d), E(a * b), E(c * d)
    sigma, tau = 1 - E(a * a), E(c * c)
    g, h = beta / sigma, beta * tau / sigma + kappa
    gamma2 = (alpha * tau / sigma + delta + 2 * g * h
              + 2 * abs(h) * math.sqrt(alpha / sigma + g * g))
    return math.sqrt(gamma2)


@settings(max_examples=8, deadline=None)
@given(st.lists(st.floats(-0.9, 0.9), min_size=2, max_size=2),
       st.lists(st.floats(0.2, 1.5), min_size=2, max_size=2),
       st.floats(0.2, 0.8), st.floats(-0.5, 0.5))
def test_certified_l2_gain_is_the_scalar_bounded_real_lemma(a, c, q, d):
    p = [q, 1 - q]
    sys = ncs.jss([[[x]] for x in a], [[1.0]], [[[x]] for x in c], [[d]], p)
    res = ncs.l2_gain(sys)
    true = _scalar_gain(a, [1.0, 1.0], c, [d, d], p)
    assert res.gamma >= true * (1 - 1e-9)         # certified: never below
    assert res.gamma <= true * (1 + 1e-4)
    assert res.lower <= true * (1 + 1e-9)
    assert ncs.norm(sys, "inf") == res.gamma


def test_l2_gain_certificate_passes_the_exact_check_again():
    from control_ncs.verify import gain_certificate_check
    A = np.array([[[[0.6, 0.3], [0.0, 0.5]], [[1.1, 0.0], [0.2, 0.3]]]])
    sys = ncs.jss(A, [[1.0], [0.5]], [[1.0, -1.0]], [[0.2]],
                  transition=[[0.8, 0.2], [0.4, 0.6]])
    res = ncs.l2_gain(sys)
    ok, theta, Pmin = gain_certificate_check(sys, res.P, res.gamma)
    assert ok and theta.max() < 0 and Pmin.min() > 0
    assert not gain_certificate_check(sys, res.P, 0.99 * res.lower)[0]
    assert res.lower <= res.gamma


def test_norm_refuses_what_it_does_not_compute():
    sys = scalar_iid([0.5, 0.9], [0.3, 0.7])
    with pytest.raises(ControlArgument, match="^p:"):
        ncs.norm(sys, 1)
    with pytest.raises(TypeError, match="unknown_kw"):
        ncs.norm(sys, unknown_kw=1)


# -- Lyapunov exponent ----------------------------------------------------------
def test_lyapunov_exponent_of_the_scalar_example_is_exact():
    sys = scalar_iid([2.0, 0.25], [0.5, 0.5])
    res = ncs.lyapunov_exponent(sys)
    assert res.exact and res.exponent == pytest.approx(0.5 * math.log(0.5),
                                                       abs=1e-15)
    assert res.exponent == pytest.approx(-0.34657, abs=5e-6)
    assert not ncs.is_mss(sys) and res.ms_bound > 0
    assert "almost surely stable; not mean-square stable" in res.summary()


def test_lyapunov_exponent_estimate_lies_below_jensens_bound_and_repeats():
    A = np.array([[[[1.5, 0.3], [0.0, 0.2]], [[0.1, 0.0], [0.5, 0.4]]]])
    sys = ncs.jss(A, np.zeros((2, 1)), np.zeros((1, 2)), [[0.0]], [0.5, 0.5])
    res = ncs.lyapunov_exponent(sys, seed=3)
    assert res.confidence_interval[1] < res.ms_bound
    again = ncs.lyapunov_exponent(sys, seed=3)
    assert again.exponent == res.exponent
    longer = ncs.lyapunov_exponent(sys, steps=40_000, trials=10, seed=11)
    lo, hi = res.confidence_interval
    assert lo - 0.01 < longer.exponent < hi + 0.01


def test_lyapunov_exponent_of_a_deterministic_system_is_log_spectral_radius():
    A = np.array([[0.5, 1.0], [0.0, 0.8]])
    res = ncs.lyapunov_exponent(ct.ss(A, [[0.0], [1.0]], [[1.0, 0.0]],
                                      [[0.0]], True), steps=20_000, seed=1)
    assert res.exponent == pytest.approx(math.log(0.8), abs=2e-3)


@pytest.mark.parametrize("kwargs, match", [
    (dict(trials=1), "^trials:"), (dict(steps=0), "^steps:"),
    (dict(seed=-1), "^seed:")])
def test_lyapunov_exponent_bad_input_names_the_argument(kwargs, match):
    sys = ncs.jss(np.eye(2)[None, None] * 0.5, np.zeros((2, 1)),
                  np.zeros((1, 2)), [[0.0]], [1.0])
    with pytest.raises((ValueError, ControlArgument), match=match):
        ncs.lyapunov_exponent(sys, **kwargs)


# -- LQ over a lossy actuator link ------------------------------------------------
def test_modified_riccati_solution_of_the_scalar_example():
    K, S, E = ncs.dlqr([[1.2]], [[1.0]], [[1.0]], [[1.0]], arrival=0.5)
    assert S[0, 0] == pytest.approx(5.762615414813, rel=1e-12)
    # the closed form of 0.28 S² - 1.44 S - 1 = 0
    assert S[0, 0] == pytest.approx((1.44 + math.sqrt(1.44 ** 2 + 1.12))
                                    / 0.56, rel=1e-12)
    assert K[0, 0] == pytest.approx(1.2 * S[0, 0] / (S[0, 0] + 1), rel=1e-12)
    assert E[0] == pytest.approx(1.2 - 0.5 * K[0, 0], rel=1e-12)


def test_lossless_dlqr_equals_python_control():
    rng = np.random.default_rng(2)
    A, B = rng.standard_normal((3, 3)), rng.standard_normal((3, 2))
    Q, R = np.eye(3), np.diag([1.0, 2.0])
    K, S, E = ncs.dlqr(A, B, Q, R)
    K2, S2, E2 = ct.dlqr(A, B, Q, R)
    np.testing.assert_allclose(K, K2, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(S, S2, rtol=1e-8, atol=1e-10)


def test_dlqr_below_the_critical_probability_says_what_it_is():
    with pytest.raises(ValueError, match=r"critical arrival probability "
                       r"0\.305556 \(exact"):
        ncs.dlqr([[1.2]], [[1.0]], [[1.0]], [[1.0]], arrival=0.3)


def test_dlqr_takes_the_actuator_link_of_a_networked_plant():
    P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0], [0.0, 0.0]],
                True, nmeas=1, ncon=1, actuator_loss=0.5)
    K, S, _ = ncs.dlqr(P, [[1.0]], [[1.0]])
    assert S[0, 0] == pytest.approx(5.762615414813, rel=1e-12)
    # the optimal loop is mean-square stable, and its cost is tr(B1ᵀ S B1)
    # for unit noise: check with the H2 norm of z = [x; θu] weighted by
    # q = r = 1
    CL = ncs.jss([[[1.2 - K[0, 0]]], [[1.2]]], [[1.0]], [[[1.0], [-K[0, 0]]],
                                                       [[1.0], [0.0]]],
                 [[0.0], [0.0]], [0.5, 0.5])
    assert ncs.norm(CL) ** 2 == pytest.approx(S[0, 0], rel=1e-9)


def test_dlqr_refuses_what_it_does_not_solve():
    P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0], [0.0, 0.0]],
                True, nmeas=1, ncon=1, sensor_loss=0.1)
    with pytest.raises(ControlArgument, match="sensor_loss=0"):
        ncs.dlqr(P, [[1.0]], [[1.0]])
    with pytest.raises(ValueError, match="^R:"):
        ncs.dlqr([[1.2]], [[1.0]], [[1.0]], [[0.0]])
    with pytest.raises(ValueError, match="^arrival:"):
        ncs.dlqr([[1.2]], [[1.0]], [[1.0]], [[1.0]], arrival=1.5)


def test_dlqr_over_a_bursty_link_solves_the_coupled_riccati_equations():
    """Gains on the previous link state: the scalar value iteration of the
    tests, and h2syn's convex program on a two-state plant (z = [x; θu],
    unit noise on the state: cost Σ π_ℓ tr S_ℓ)."""
    link = ncs.gilbert_elliott(fail=0.2, recover=0.6)
    pi = np.array([0.2, 0.6]) / 0.8                    # (lost, delivered)
    K, S, E = ncs.dlqr(_lq_plant(loss=link), [[1.0]], [[1.0]])
    assert K.shape == (2, 1, 1) and S.shape == (2, 1, 1) and E.shape == (2, 1)
    assert pi @ S[:, 0, 0] == pytest.approx(
        _bursty_lq_cost(1.2, 1.0, 0.2, 0.6), rel=1e-10)
    A, B = np.array([[1.1, 0.3], [0.0, 0.9]]), np.array([[0.0], [1.0]])
    P = ncs.nss(A, np.hstack([np.eye(2), B]),
                np.vstack([np.eye(2), np.zeros((1, 2)), np.eye(2)]),
                np.vstack([np.zeros((2, 3)), [[0, 0, 1.0]],
                           np.zeros((2, 3))]), True, nmeas=2, ncon=1,
                actuator_loss=link)
    K, S, _ = ncs.dlqr(P, np.eye(2), [[1.0]])
    Kh, _, h2 = ncs.h2syn(P)
    assert sum(pi[ell] * np.trace(S[ell]) for ell in range(2)) == \
        pytest.approx(h2 ** 2, rel=1e-9)
    np.testing.assert_allclose(-K[1], Kh.gains[0, -1], rtol=1e-5)
    with pytest.raises(ValueError, match="^sys: .*no gain makes the loop "
                       "mean-square stable"):
        ncs.dlqr(_lq_plant(loss=ncs.gilbert_elliott(fail=0.3, recover=0.3)),
                 [[1.0]], [[1.0]])


# -- H2 synthesis -----------------------------------------------------------------
def _lq_plant(loss=0.5, **network):
    """x⁺ = 1.2 x + θ u + w, z = [x; θu], y = x."""
    return ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [0.0], [1.0]],
                   [[0.0, 0.0], [0.0, 1.0], [0.0, 0.0]], True, nmeas=1,
                   ncon=1, actuator_loss=loss, **network)


def test_h2syn_reaches_the_modified_riccati_cost():
    K, CL, h2 = ncs.h2syn(_lq_plant())
    S = 5.762615414813
    assert h2 ** 2 >= S * (1 - 1e-12)        # no gain does better than S
    assert h2 ** 2 == pytest.approx(S, rel=1e-7)
    assert h2 == ncs.norm(CL) == K.result.h2
    Klq = ncs.dlqr([[1.2]], [[1.0]], [[1.0]], [[1.0]], arrival=0.5)[0]
    assert K.gains[0, 0, 0] == pytest.approx(-Klq[0, 0], rel=1e-3)


def _bursty_lq_cost(a, b, fail, recover):
    """TCP-like LQ over a Gilbert–Elliott actuator link, by value iteration
    on the coupled Riccati equations of the previous link state ℓ
    (0 lost, 1 delivered): ``S_ℓ = min_k Σ_i T[ℓ, i] (1 + θ_i k² + S_i
    (a + θ_i b k)²)``; the H2 cost is ``Σ_i π_i S_i`` (noise enters after
    the link state is drawn)."""
    T = np.array([[1 - recover, recover], [fail, 1 - fail]])
    theta = np.array([0.0, 1.0])
    S = np.ones(2)
    for _ in range(5000):
        c2 = T @ (theta + S * (theta * b) ** 2)
        c1 = T @ (2 * S * a * theta * b)
        c0 = T @ (1 + S * a * a)
        S = c0 - c1 ** 2 / (4 * c2)
    pi = np.array([fail, recover]) / (fail + recover)
    return float(pi @ S)


@pytest.mark.parametrize("fail, recover", [(0.2, 0.6), (0.1, 0.5),
                                           (0.3, 0.8)])
def test_h2syn_over_a_bursty_link_solves_the_coupled_riccati_equations(
        fail, recover):
    P = _lq_plant(loss=ncs.gilbert_elliott(fail=fail, recover=recover))
    K, CL, h2 = ncs.h2syn(P)
    assert K.gains.ndim == 4                    # K_{k,ℓ} on the last state
    assert h2 ** 2 == pytest.approx(_bursty_lq_cost(1.2, 1.0, fail, recover),
                                    rel=1e-7)
    assert h2 == ncs.norm(CL) == ncs.norm(ncs.feedback(P, K))


def test_h2syn_over_a_link_without_memory_is_the_bernoulli_design():
    """f = α, r = 1 - α: the chain forgets, the link is Bernoulli(α)."""
    bernoulli = ncs.h2syn(_lq_plant(loss=0.3))[2]
    memoryless = ncs.h2syn(_lq_plant(
        loss=ncs.gilbert_elliott(fail=0.3, recover=0.7)))[2]
    assert memoryless == pytest.approx(bernoulli, rel=1e-7)


def test_hinfsyn_over_a_bursty_link_beats_one_gain_for_every_link_state():
    """Gains on the previous link state: the certified gain is below the
    best single gain's (Nelder-Mead over the scalar, each loop certified)
    and the H2 design's."""
    from scipy.optimize import minimize_scalar
    P = _lq_plant(loss=ncs.gilbert_elliott(fail=0.2, recover=0.6))
    K, CL, gamma = ncs.hinfsyn(P)
    assert K.result.status == "certified" and K.result.lower <= gamma
    assert gamma == ncs.l2_gain(ncs.feedback(P, K)).gamma

    def single(k):
        loop = ncs.feedback(P, [[k]])
        return ncs.l2_gain(loop).gamma if ncs.is_mss(loop) else 1e9

    best = minimize_scalar(single, bounds=(-1.6, -0.9), method="bounded",
                           options=dict(xatol=1e-6)).fun
    assert gamma <= best * (1 + 1e-6)
    assert gamma < ncs.l2_gain(ncs.h2syn(P)[1]).gamma


def test_h2syn_beats_every_other_gain_on_a_periodic_plant():
    """Two states, two inputs on a period-2 actuator schedule: the exact
    H2 norm of the designed loop is at most that of passivesyn's gain and
    of nearby perturbations of the designed gain."""
    P = ncs.nss([[1.1, 0.3], [0.0, 0.9]],
                [[1.0, 0.0, 1.0, 0.0], [0.0, 1.0, 0.0, 1.0]],
                [[1.0, 0.0], [0.0, 1.0], [0.0, 0.0], [0.0, 0.0], [1.0, 0.0],
                 [0.0, 1.0]],
                [[0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 1.0, 0], [0, 0, 0, 1.0],
                 [0, 0, 0, 0], [0, 0, 0, 0]], True, nmeas=2, ncon=2,
                actuator_schedule=[1, 2], actuator_loss=0.2)
    K, CL, h2 = ncs.h2syn(P)
    rng = np.random.default_rng(4)
    for _ in range(5):
        G = K.gains + 0.05 * rng.standard_normal(K.gains.shape)
        other = ncs.feedback(P, G)
        if ncs.is_mss(other):
            assert ncs.norm(other) >= h2 * (1 - 1e-9)


def test_h2syn_designs_locally_what_its_exact_program_does_not_cover():
    """A held command and a schedule hiding a bursty link's state are
    structured loops: searched locally, the figure still exact."""
    K, CL, h2 = ncs.h2syn(_lq_plant(), actuator="hold")
    assert K.result.route == "local"
    assert h2 == ncs.norm(ncs.feedback(_lq_plant(), K, actuator="hold"))
    hidden = _lq_plant(loss=ncs.gilbert_elliott(fail=0.2, recover=0.5),
                       actuator_schedule=[1, 0])
    K, CL, h2 = ncs.h2syn(hidden)
    assert K.result.route == "local" and h2 == ncs.norm(CL)
    with pytest.raises(ControlArgument, match="^P:"):
        ncs.h2syn(ct.ss([[1.0]], [[1.0]], [[1.0]], [[0.0]], True))
    with pytest.raises(ControlArgument, match="^solver: .*locally"):
        ncs.h2syn(_lq_plant(), actuator="hold", options={"solver": "CLARABEL"})
    with pytest.raises(ControlArgument, match="^solver: .*locally"):
        ncs.hinfsyn(_lq_plant(), actuator="hold",
                    options={"solver": "CLARABEL"})


def test_dlqr_states_the_exact_critical_probability_of_a_two_state_plant():
    """One input reaching the one unstable eigenvalue 1.1: the critical
    probability is 1 - 1/1.1² exactly, and it separates arrivals that work
    from arrivals that do not to 1e-6."""
    A = np.array([[1.1, 0.2], [0.0, 0.9]])
    B = np.array([[0.0], [1.0]])
    critical = 1 - 1 / 1.1 ** 2
    with pytest.raises(ncs.SynthesisError, match="exact") as info:
        ncs.dlqr(A, B, np.eye(2), np.eye(1), arrival=0.1)
    assert info.value.reason == "not_mss"
    assert info.value.figures["critical"] == pytest.approx(critical,
                                                          abs=1e-15)
    ncs.dlqr(A, B, np.eye(2), np.eye(1), arrival=critical + 1e-6)
    with pytest.raises(ValueError):
        ncs.dlqr(A, B, np.eye(2), np.eye(1), arrival=critical - 1e-6)


def test_critical_loss_of_a_gain_matches_the_closed_form():
    """x⁺ = 2x + θu (+ w), u = -Kx: E x² per step 4α + (2 - K)²(1 - α)."""
    P = ncs.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0],
                                                         [0.0, 0.0]],
                True, nmeas=1, ncon=1)
    assert ncs.critical_loss(P, [[-2.0]]) == pytest.approx(0.25, abs=2e-6)
    # K = 1.5: 4α + 0.25(1 - α) = 1 at α = 0.2
    assert ncs.critical_loss(P, [[-1.5]]) == pytest.approx(0.2, abs=2e-6)
    assert ncs.critical_loss(P, [[-2.0]], link="sensor") == \
        pytest.approx(0.25, abs=2e-6)
    assert ncs.critical_loss(P, [[0.0]]) == 0.0
    stable = ncs.nss([[0.5]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0],
                                                              [0.0, 0.0]],
                     True, nmeas=1, ncon=1)
    assert ncs.critical_loss(stable, [[-0.1]]) == 1.0


def test_critical_loss_of_an_l2_gain_spec_is_the_bounded_real_lemmas():
    """x⁺ = 2x + w + θu, z = x, u = -2x: modes a ∈ {2 (lost), 0}; the loss
    at which the scalar lemma's gain reaches 3 (brentq on the closed form)
    is where the certified gain stops being below 3."""
    from scipy.optimize import brentq
    P = ncs.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0],
                                                         [0.0, 0.0]],
                True, nmeas=1, ncon=1)

    def gain(alpha):
        return _scalar_gain([2.0, 0.0], [1.0, 1.0], [1.0, 1.0], [0.0, 0.0],
                            [alpha, 1 - alpha])

    true = brentq(lambda a: gain(a) - 3.0, 0.01, 0.24, xtol=1e-12)
    got = ncs.critical_loss(P, [[-2.0]], hinf=3.0, tol=1e-6)
    # certified just below, never above (the bound is an upper bound)
    assert true - 1e-5 < got <= true + 1e-6
    assert ncs.l2_gain(ncs.feedback(P.with_network(actuator_loss=got - 2e-6),
                                    [[-2.0]])).gamma < 3.0


def test_critical_loss_of_a_passivity_level_is_the_scalar_lemmas():
    """x⁺ = -0.5x + w + θu, z = x + w, u = 0.9x: modes a ∈ {-0.5, 0.4};
    the storage inequality of theory (passivity) for p x² gives
    η* = d - (√(1 - s + m²) - m)/(1 - s), m = E a, s = E a², d = 1."""
    from scipy.optimize import brentq
    P = ncs.nss([[-0.5]], [[1.0, 1.0]], [[1.0], [1.0]], [[1.0, 0.0],
                                                          [0.0, 0.0]],
                True, nmeas=1, ncon=1)

    def eta(alpha):
        m = -0.5 * alpha + 0.4 * (1 - alpha)
        s = 0.25 * alpha + 0.16 * (1 - alpha)
        return 1.0 - (math.sqrt(1 - s + m * m) - m) / (1 - s)

    CL = ncs.feedback(P.with_network(actuator_loss=0.2), [[0.9]])
    assert ncs.passivity_certificate(CL, None).eta == pytest.approx(
        eta(0.2), abs=1e-5)
    true = brentq(eta, 0.1, 0.5, xtol=1e-12)
    got = ncs.critical_loss(P, [[0.9]], eta=0.0, tol=1e-7)
    assert got == pytest.approx(true, abs=1e-5)
    with pytest.raises(ControlArgument, match="^h2, eta:"):
        ncs.critical_loss(P, [[0.9]], h2=1.0, eta=0.0)


# -- any quadratic supply -----------------------------------------------------------
def test_the_supply_kernel_gives_passivity_and_the_gain_as_cases():
    from control_ncs.verify import dissipation_blocks, supply_blocks
    rng = np.random.default_rng(9)
    A, B = rng.standard_normal((3, 2, 2)), rng.standard_normal((3, 2, 1))
    C, D = rng.standard_normal((3, 1, 2)), rng.standard_normal((3, 1, 1))
    p = np.array([0.2, 0.3, 0.5])
    P, Pn = np.eye(2) * 2, np.eye(2) * 3
    np.testing.assert_allclose(
        dissipation_blocks(p, A, B, C, D, P, Pn, 0.3, ofp_index=0.1,
                           decay=0.9),
        supply_blocks(p, A, B, C, D, P, Pn, -0.2, 1.0, -0.6, decay=0.9))
    # the bounded real lemma's Θ, written out: Σ p_i ([A B]ᵀP⁺[A B]
    # + [C D]ᵀ[C D]) - diag(P, γ² I), γ² = 4
    AB, CD = np.concatenate([A, B], 2), np.concatenate([C, D], 2)
    theta = sum(p[i] * (AB[i].T @ Pn @ AB[i] + CD[i].T @ CD[i])
                for i in range(3)) - np.diag([2.0, 2.0, 4.0])
    np.testing.assert_allclose(
        supply_blocks(p, A, B, C, D, P, Pn, -np.eye(1), np.zeros((1, 1)),
                      4.0 * np.eye(1)), theta, atol=1e-12)


def test_dissipativity_certifies_passivity_up_to_the_index_and_the_gain():
    sys = ncs.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[1.0]], [0.5, 0.5])
    nu = ncs.get_input_ff_index(sys)
    assert ncs.dissipativity(sys, 0.0, 1.0, -2 * 0.99 * nu).dissipative
    assert not ncs.dissipativity(sys, 0.0, 1.0, -2 * 1.01 * nu).dissipative
    gamma = ncs.l2_gain(sys).gamma
    assert ncs.dissipativity(sys, -1.0, 0.0, (1.001 * gamma) ** 2).dissipative
    # below the gain no storage exists, and the solver's certificate of
    # that passes the exact check
    res = ncs.dissipativity(sys, -1.0, 0.0, (0.99 * gamma) ** 2)
    assert not res.dissipative and res.status == "infeasible"
    assert "proven" in res.message


def test_dissipativity_refuses_a_supply_outside_its_theory():
    sys = ncs.jss([[[0.5]]], [[1.0]], [[1.0], [0.0]], [[1.0], [0.0]], [1.0])
    with pytest.raises(ValueError, match="^Q:"):
        ncs.dissipativity(ncs.jss([[[0.5]]], [[1.0]], [[1.0]], [[1.0]],
                                  [1.0]), 1.0, 0.0, 1.0)
    with pytest.raises(ControlDimension, match="^S:"):
        ncs.dissipativity(sys, 0.0, 1.0, 0.0)


# -- H∞ synthesis -------------------------------------------------------------------
def test_hinfsyn_beats_the_h2_design_and_nearby_gains_on_the_l2_gain():
    P = _lq_plant()
    K, CL, gamma = ncs.hinfsyn(P)
    assert gamma == K.result.gamma == ncs.l2_gain(CL).gamma
    assert K.result.lower <= gamma
    h2_loop = ncs.feedback(P, ncs.h2syn(P)[0].gains)
    assert gamma <= ncs.l2_gain(h2_loop).gamma
    for delta in (-0.05, 0.05):
        other = ncs.feedback(P, K.gains + delta)
        assert ncs.l2_gain(other).gamma >= gamma * (1 - 1e-4)


def test_hinfsyn_of_a_scalar_loop_matches_the_bounded_real_lemma():
    """x⁺ = 1.2x + w + θu, z = [x; θu]: for the designed gain k the loop's
    gain is the scalar lemma's, over modes a ∈ {1.2 - k, 1.2} (probability
    1/2 each), c = [1; -k] or [1; 0]."""
    P = _lq_plant()
    K, CL, gamma = ncs.hinfsyn(P)
    k = -K.gains[0, 0, 0]
    # only ‖c‖² enters the scalar lemma (d = 0)
    true = _scalar_gain([1.2 - k, 1.2], [1.0, 1.0],
                        [math.sqrt(1 + k * k), 1.0], [0.0, 0.0], [0.5, 0.5])
    assert true <= gamma <= true * (1 + 1e-4)


def test_hinfsyn_refuses_what_neither_route_covers():
    with pytest.raises(ControlArgument, match="^controller:"):
        ncs.hinfsyn(_lq_plant(), controller="lti")
    with pytest.raises(ControlArgument, match="^initial_gain:"):
        ncs.hinfsyn(_lq_plant(), initial_gain=[[[-1.0]]])


def test_critical_loss_of_the_best_gain_is_the_modified_riccati_limit():
    P = _lq_plant(0.0)
    assert ncs.critical_loss(P) == pytest.approx(1 / 1.44, rel=1e-12)
    # no gain at a loss just above it stabilises: the dlqr refuses there
    with pytest.raises(ValueError, match="critical"):
        ncs.dlqr(P.with_network(actuator_loss=1 / 1.44 + 0.01),
                 [[1.0]], [[1.0]])
    with pytest.raises(ControlArgument, match="^K:"):
        ncs.critical_loss(P, link="sensor")


# -- design maps of the performance specs ----------------------------------------

def _two_state_plant() -> ncs.NetworkedStateSpace:
    """``x⁺ = A x + w + B2 θu``, ``z = [x; θu]``: the LQ problem with
    ``Q = I``, ``R = 1`` and unit process noise."""
    return ncs.nss([[1.1, 0.3], [0.0, 0.9]],
                   [[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]],
                   [[1.0, 0.0], [0.0, 1.0], [0.0, 0.0], [1.0, 0.0],
                    [0.0, 1.0]],
                   [[0, 0, 0], [0, 0, 0], [0, 0, 1.0], [0, 0, 0], [0, 0, 0]],
                   True, nmeas=2, ncon=1)


def test_h2_design_map_is_the_modified_riccati_cost_of_each_cell():
    """Each cell's H2 norm is √tr(S) of the modified Riccati equation at
    the arrival probability (1 - α1)(1 - α2): a sensor and a command lost
    are the same to a static gain (an independent route, lq.py)."""
    P = _two_state_plant()
    a1, a2 = [0.0, 0.1], [0.0, 0.2, 0.35]
    dm = ncs.design_map(P, a1, a2, objective="h2", progress=False)
    assert dm.feasible.all() and np.isnan(dm.eta).all()
    for i, x in enumerate(a1):
        for j, y in enumerate(a2):
            S = ncs.dlqr(P.A, P.B2, np.eye(2), np.eye(1),
                         arrival=(1 - x) * (1 - y))[1]
            assert dm.value[i, j] == pytest.approx(math.sqrt(np.trace(S)),
                                                   rel=1e-6)
    assert (np.diff(dm.value, axis=1) > 0).all()   # every loss costs
    assert "best h2" in dm.summary()
    pytest.importorskip("pandas")
    frame = dm.to_pandas()
    assert frame["h2"].tolist() == dm.value.ravel().tolist()


def test_hinf_design_map_cells_are_hinfsyn_and_run_anywhere_alike():
    from concurrent.futures import ThreadPoolExecutor
    P = _two_state_plant()
    dm = ncs.design_map(P, [0.0], [0.0, 0.3], objective="hinf",
                        progress=False)
    for j, y in enumerate([0.0, 0.3]):
        K, CL, gamma = ncs.hinfsyn(P.with_network(actuator_loss=y))
        assert dm.value[0, j] == pytest.approx(gamma, rel=1e-6)
        assert dm.ms_radius[0, j] == pytest.approx(ncs.ms_radius(CL),
                                                   rel=1e-6)
        assert K.result.lower <= dm.value[0, j]
    with ThreadPoolExecutor(2) as pool:
        again = ncs.design_map(P, [0.0], [0.0, 0.3], objective="hinf",
                               progress=False, executor=pool)
    assert np.array_equal(again.value, dm.value)
    cp = dm.plot()
    assert cp.axes[0, 0].images or cp.axes[0, 0].collections
    assert "ℓ2-gain bound" in cp.axes[0, 0].get_title()
    with pytest.raises(ControlArgument, match="^quantity:"):
        dm.plot("eta")


@pytest.mark.parametrize("kwargs, match", [
    (dict(eta=0.1), "^eta:"), (dict(decay=0.9), "^decay:"),
    (dict(method="lmi"), "^method:"),
    (dict(objective="h3"), "^objective:")])
def test_performance_design_map_refuses_passivity_options(kwargs, match):
    with pytest.raises(ControlArgument, match=match):
        ncs.design_map(_two_state_plant(), [0.0], [0.1], progress=False,
                       **{"objective": "h2", **kwargs})


def test_performance_design_map_designs_structured_gains_locally():
    """A sensor schedule or a held command: every cell is h2syn's local
    design with the map's controller and actuator."""
    scheduled = _two_state_plant().with_network(sensor_schedule=[1, 2])
    dm = ncs.design_map(scheduled, [0.0], [0.1, 0.3], objective="h2",
                        progress=False)
    for j, loss in enumerate((0.1, 0.3)):
        h2 = ncs.h2syn(scheduled.with_network(actuator_loss=loss))[2]
        assert dm.value[0, j] == pytest.approx(h2, rel=1e-9)
    held = ncs.design_map(_two_state_plant(), [0.0], [0.2], objective="h2",
                          actuator="hold", progress=False)
    assert held.value[0, 0] == pytest.approx(ncs.h2syn(
        _two_state_plant().with_network(actuator_loss=0.2),
        actuator="hold")[2], rel=1e-9)


def test_a_map_over_delay_laws_prices_each_delay():
    """Axes (sensor loss, delay law valued by its mean delay): the law with
    all its mass at 0 is the Bernoulli link, where the exact program and
    the local search over the delayed link agree; longer delays cost."""
    P = _two_state_plant()
    laws = [[1.0], [0.5, 0.5], [0.2, 0.3, 0.5]]
    dm = ncs.design_map(P, sensor_loss=[0.0, 0.2], sensor_delay=laws,
                        objective="h2", progress=False)
    assert dm.axes == ("sensor_loss", "sensor_delay")
    np.testing.assert_allclose(dm.values[1], [0.0, 0.5, 1.3])
    for i, loss in enumerate((0.0, 0.2)):
        exact = ncs.h2syn(P.with_network(sensor_loss=loss))[2]
        assert dm.value[i, 0] == pytest.approx(exact, rel=1e-7)
        assert np.all(np.diff(dm.value[i]) > 0)
    late = P.with_network(sensor_delay=[0.4, 0.4])
    assert dm.value[1, 1] == pytest.approx(ncs.h2syn(late)[2], rel=1e-9)
    with pytest.raises(ControlArgument, match="^actuator_loss: with sensor_"):
        ncs.design_map(P, [0.0], [0.0, 0.1], sensor_delay=laws,
                       objective="h2", progress=False)
    with pytest.raises(ValueError, match=r"^sensor_delay\[1\]:"):
        ncs.design_map(P, [0.0], sensor_delay=[[1.0], [0.7, 0.7]],
                       objective="h2", progress=False)


def test_critical_loss_of_an_h2_spec_matches_the_closed_form():
    """``x⁺ = a x + w + θ k x``, ``z = x``: ``‖G‖₂² = 1/(1 - E a_cl²)``
    with ``E a_cl² = α a² + (1 - α)(a + k)²`` reaches ``b²`` at
    ``α* = (1 - 1/b² - (a + k)²) / (a² - (a + k)²)``; the spec is met
    only below the loss at which the loop stops being mean-square stable."""
    a, k, b = 1.1, -0.8, 3.0
    P = ncs.nss([[a]], [[1.0, 1.0]], [[1.0], [1.0]],
                [[0.0, 0.0], [0.0, 0.0]], True, nmeas=1, ncon=1)
    expected = (1 - 1 / b ** 2 - (a + k) ** 2) / (a ** 2 - (a + k) ** 2)
    for link in ("actuator", "sensor"):
        got = ncs.critical_loss(P, [[k]], h2=b, link=link, tol=1e-9)
        assert got == pytest.approx(expected, abs=2e-9)
    assert ncs.critical_loss(P, [[k]], h2=b) < ncs.critical_loss(P, [[k]])


def test_critical_loss_of_an_h2_spec_refuses_what_it_does_not_measure():
    P = _lq_plant(0.0)
    with pytest.raises(ValueError, match="^h2:"):
        ncs.critical_loss(P, [[-1.0]], h2=-1.0)
    with pytest.raises(ControlArgument, match="^P: expected a Networked"):
        ncs.critical_loss(ct.ss([[0.5]], [[1.0]], [[1.0]], [[0.0]], True),
                          [[-1.0]])


def test_a_map_over_the_burst_length_prices_each_burst():
    """Axes (loss, burst): each cell is the coupled Riccati cost of its
    Gilbert–Elliott link; the burst 1/(1 - a) is the Bernoulli link; bursts
    the plant cannot survive are proven infeasible, not left unsolved."""
    P = _lq_plant(loss=0.0)
    losses, bursts = [0.1, 0.3], [1.0, 1 / 0.7, 2.0, 4.0]
    dm = ncs.design_map(P, actuator_loss=losses, actuator_burst=bursts,
                        objective="h2", progress=False)
    assert dm.axes == ("actuator_loss", "actuator_burst")
    for i, a in enumerate(losses):
        for j, b in enumerate(bursts):
            recover = 1 / b
            fail = a * recover / (1 - a)
            if (1 - recover) * 1.2 ** 2 >= 1:        # stuck in a burst
                assert dm.reason[i, j] == "infeasible"
                continue
            assert dm.value[i, j] ** 2 == pytest.approx(
                _bursty_lq_cost(1.2, 1.0, fail, recover), rel=1e-6)
    bernoulli = ncs.design_map(P, actuator_loss=[0.3], objective="h2",
                               progress=False).value[0, 0]
    assert dm.value[1, 1] == pytest.approx(bernoulli, rel=1e-6)


def test_a_burst_map_refuses_what_has_no_two_axes():
    P = _lq_plant(loss=0.0)
    with pytest.raises(ControlArgument, match="^sensor_burst, actuator_burst"):
        ncs.design_map(P, actuator_loss=[0.1], sensor_burst=[2.0],
                       actuator_burst=[2.0], objective="h2", progress=False)
    with pytest.raises(ControlArgument, match="^sensor_loss: with actuator"):
        ncs.design_map(P, [0.0, 0.1], [0.1], actuator_burst=[2.0],
                       objective="h2", progress=False)
    with pytest.raises(ValueError, match=r"^actuator_burst\[1\]: .*>= 1"):
        ncs.design_map(P, actuator_loss=[0.1], actuator_burst=[2.0, 0.5],
                       objective="h2", progress=False)


def test_critical_loss_of_the_best_design_is_the_modified_riccati_costs():
    """K=None with an H2 spec: the loss at which h2syn's optimum reaches the
    bound equals the loss at which the modified Riccati cost S(α) of dlqr
    (value iteration, an independent route) reaches its square."""
    from scipy.optimize import brentq
    P = _lq_plant(loss=0.0)

    def cost(alpha):
        return float(ncs.dlqr([[1.2]], [[1.0]], [[1.0]], [[1.0]],
                              arrival=1 - alpha)[1][0, 0])

    true = brentq(lambda a: cost(a) - 9.0, 0.01, 0.6, xtol=1e-12)
    got = ncs.critical_loss(P, h2=3.0, tol=1e-6)
    assert got == pytest.approx(true, abs=1e-5)
    gamma_loss = ncs.critical_loss(P, hinf=6.0, tol=1e-4)
    below = ncs.hinfsyn(P.with_network(actuator_loss=gamma_loss - 2e-4))[2]
    assert below < 6.0
