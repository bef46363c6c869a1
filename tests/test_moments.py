"""Exact first and second moments (theory: moments)."""

import numpy as np
import control as ct
import pytest

from control_ncs import MomentsResponse, feedback, jss, moments

from helpers import (assert_cov_within, assert_mean_within,
                     dense_fourth_moment_rate, fourth_moment_rate,
                     random_jump, random_plant, sample_jump, scalar_plant)

# the scalar loop of the closed forms: x⁺ = a x + bw w + u, z = c x + d w +
# d12 u, u = -k x delivered with probability q = (1-α1)(1-α2)
A_, BW, C_, D_, D12, K_ = 1.3, 0.7, 2.0, 0.5, 0.4, 0.9
ALPHA1, ALPHA2 = 0.2, 0.25
Q_ = (1 - ALPHA1) * (1 - ALPHA2)


def scalar_loop():
    P = scalar_plant(A_, bw=BW, c=C_, d=D_, d12=D12, sensor_loss=ALPHA1,
                     actuator_loss=ALPHA2)
    return feedback(P, [[-K_]])


def test_scalar_unforced_moments_are_powers_of_the_mean_and_ms_factors():
    """w = 0: E x_t = (a - qk)^t x0, E x_t² = [(1-q)a² + q(a-k)²]^t x0²."""
    x0, T = 1.5, 12
    r = moments(scalar_loop(), T, initial_state=[x0])
    t = np.arange(T)
    assert np.allclose(r.states_mean[0], (A_ - Q_ * K_) ** t * x0, rtol=1e-12)
    ms = (1 - Q_) * A_**2 + Q_ * (A_ - K_) ** 2
    assert np.allclose(r.states_second_moment[0, 0], ms**t * x0**2, rtol=1e-12)


def test_scalar_forced_moments_follow_the_hand_derived_recursion():
    """With deterministic w_t and white noise of variance W added to w:
    m⁺ = (a - qk) m + bw w
    s⁺ = [(1-q)a² + q(a-k)²] s + 2 (a - qk) bw m w + bw² (w² + W)
    E z = (c - q d12 k) m + d w
    E z² = [(1-q)c² + q(c - d12 k)²] s + 2 (c - q d12 k) d m w + d² (w² + W)."""
    T, W, x0 = 15, 0.3, -0.8
    w = np.sin(0.7 * np.arange(T)) + 0.2
    r = moments(scalar_loop(), T, inputs=w, initial_state=[x0],
                noise_covariance=[[W]])
    m, s = x0, x0**2
    abar, cbar = A_ - Q_ * K_, C_ - Q_ * D12 * K_
    for t in range(T):
        ez = cbar * m + D_ * w[t]
        ez2 = ((1 - Q_) * C_**2 + Q_ * (C_ - D12 * K_) ** 2) * s \
            + 2 * cbar * D_ * m * w[t] + D_**2 * (w[t] ** 2 + W)
        assert r.states_mean[0, t] == pytest.approx(m, rel=1e-12)
        assert r.states_second_moment[0, 0, t] == pytest.approx(s, rel=1e-12)
        assert r.outputs_mean[0, t] == pytest.approx(ez, rel=1e-12, abs=1e-14)
        assert r.outputs_cov[0, 0, t] == pytest.approx(ez2 - ez**2, rel=1e-10)
        m, s = (abar * m + BW * w[t],
                ((1 - Q_) * A_**2 + Q_ * (A_ - K_) ** 2) * s
                + 2 * abar * BW * m * w[t] + BW**2 * (w[t] ** 2 + W))


def test_mean_is_the_forced_response_of_the_mean_system():
    rng = np.random.default_rng(0)
    P = random_plant(rng, n=3, m1=2, sensor_loss=0.3, actuator_loss=0.2)
    CL = feedback(P, rng.standard_normal((1, 3)) * 0.3)
    T = 20
    w = rng.standard_normal((2, T))
    x0 = rng.standard_normal(3)
    r = moments(CL, T, inputs=w, initial_state=x0)
    ref = ct.forced_response(CL.mean(), T=np.arange(T), U=w, X0=x0)
    assert np.allclose(r.states_mean, ref.states, atol=1e-12)
    assert np.allclose(r.outputs_mean, ref.outputs, atol=1e-12)


def test_deterministic_statespace_has_zero_covariance():
    sys = ct.ss([[0.5, 0.1], [0.0, 0.8]], [[1.0], [0.5]], [[1.0, 1.0]],
                [[0.2]], True)
    r = moments(sys, 10, inputs=np.ones(10), initial_state=[1.0, 2.0])
    assert np.allclose(r.states_cov, 0, atol=1e-12)
    assert np.allclose(r.outputs_cov, 0, atol=1e-12)


def test_initial_covariance_adds_to_the_second_moment():
    """Unforced and deterministic: E ξ_t ξ_tᵀ = A^t (P0 + x0 x0ᵀ) A^tᵀ."""
    A = np.array([[0.9, 0.2], [-0.1, 0.7]])
    sys = ct.ss(A, np.zeros((2, 1)), np.eye(2), np.zeros((2, 1)), True)
    P0 = np.array([[1.0, 0.3], [0.3, 0.5]])
    x0 = np.array([1.0, -1.0])
    r = moments(sys, 5, initial_state=x0, initial_covariance=P0)
    At = np.linalg.matrix_power(A, 4)
    assert np.allclose(r.states_second_moment[:, :, 4],
                       At @ (P0 + np.outer(x0, x0)) @ At.T, atol=1e-12)
    assert np.allclose(r.states_cov[:, :, 4], At @ P0 @ At.T, atol=1e-12)


# -- against sampled paths ---------------------------------------------------
@pytest.mark.parametrize("n, N, M", [(3, 1, 2), (3, 3, 4), (4, 2, 3)])
def test_fourth_moment_rate_is_the_dense_kronecker_radius(n, N, M):
    """The Monte Carlo tests' tail check: the factor-by-factor operator
    and ARPACK give the radius of the dense ``Π_k Σ_i p A⊗A⊗A⊗A``."""
    rng = np.random.default_rng(10 * n + N)
    for radius in (0.6, 1.02):
        sys = random_jump(rng, n=n, N=N, M=M, radius=radius)
        assert fourth_moment_rate(sys) == pytest.approx(
            dense_fourth_moment_rate(sys), rel=1e-10)


def mc_check(sys, T, trials, seed, n_se, **kw):
    # sample standard errors are trustworthy only with a light enough tail:
    # a mean-square stable fourth moment (see helpers.fourth_moment_rate)
    assert fourth_moment_rate(sys) < 1
    mom = moments(sys, T, inputs=kw.get("inputs"),
                  initial_state=kw.get("x0"),
                  noise_covariance=kw.get("noise_covariance"),
                  initial_covariance=kw.get("initial_covariance"))
    xs, zs = sample_jump(sys, T, trials, np.random.default_rng(seed), **kw)
    assert_mean_within(xs, mom.states_mean, n_se)
    assert_mean_within(zs, mom.outputs_mean, n_se)
    assert_cov_within(xs, mom.states_cov, n_se)
    assert_cov_within(zs, mom.outputs_cov, n_se)


def test_moments_match_sampled_paths_with_deterministic_input():
    """Mean and covariance of state and output vs 20000 sampled paths of a
    random 2-mode, 2-phase system: every entry within 4.5 standard errors
    (4.5 rather than 4: some 150 correlated comparisons)."""
    rng = np.random.default_rng(1)
    sys = random_jump(rng, n=2, N=2, M=2, m=1, p=2, radius=0.7)
    T = 12
    w = np.cos(0.5 * np.arange(T))[None]
    mc_check(sys, T, 20000, 2, 4.5, inputs=w, x0=[1.0, -0.5])


def test_moments_match_sampled_paths_with_white_noise():
    """As above, with w = deterministic + white Gaussian noise of covariance
    W (2 channels) and a random initial state of covariance P0."""
    rng = np.random.default_rng(8)
    sys = random_jump(rng, n=2, N=1, M=3, m=2, p=1, radius=0.6)
    T = 12
    W = np.array([[0.5, 0.2], [0.2, 0.3]])
    P0 = np.array([[0.4, 0.0], [0.0, 0.1]])
    w = np.vstack([np.ones(T), np.linspace(-1, 1, T)])
    mc_check(sys, T, 20000, 4, 4.5, inputs=w, x0=[0.5, 0.5],
             noise_covariance=W, initial_covariance=P0)


def test_networked_loop_moments_match_sampled_paths():
    """A lossy static loop with a sensor schedule driven by white noise from
    rest: stationary spread builds up; 20000 paths, 4.5 standard errors."""
    rng = np.random.default_rng(5)
    P = random_plant(rng, n=2, m1=1, radius=1.0, sensor_schedule=[[1, 1], [0, 1]],
                     sensor_loss=0.1, actuator_loss=0.2)
    CL = feedback(P, -0.5 * ct.dlqr(P.A, P.B2, np.eye(2), np.eye(1))[0])
    mc_check(CL, 14, 20000, 6, 4.5, noise_covariance=[[1.0]])


# -- bookkeeping -------------------------------------------------------------
def test_time_points_follow_the_sampling_time():
    sys = random_jump(np.random.default_rng(7), n=2, dt=0.1)
    r = moments(sys, np.arange(5) * 0.1)
    assert np.allclose(r.time, [0, 0.1, 0.2, 0.3, 0.4])
    assert r.states_mean.shape == (2, 5) and r.states_cov.shape == (2, 2, 5)
    assert np.allclose(moments(sys, 5).time, r.time)


def test_outputs_std_is_the_root_of_the_covariance_diagonal():
    r = moments(scalar_loop(), 6, initial_state=[1.0],
                noise_covariance=[[0.5]])
    assert isinstance(r, MomentsResponse)
    assert np.allclose(r.outputs_std ** 2, r.outputs_cov[0, 0])


def test_to_response_is_the_exact_mean_as_time_response_data():
    CL = scalar_loop()
    r = moments(CL, 6, initial_state=[1.0])
    resp = r.to_response()
    assert isinstance(resp, ct.TimeResponseData)
    assert np.allclose(np.squeeze(resp.outputs), r.outputs_mean[0])
    assert np.allclose(resp.time, r.time)


def test_docstring_example_values():
    sys = jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    r = moments(sys, 3, initial_state=[1.0])
    # mean factor 0.2·2 = 0.4, second-moment factor 0.2·4 = 0.8
    assert np.allclose(r.states_mean[0], [1.0, 0.4, 0.16])
    assert np.allclose(r.states_second_moment[0, 0], [1.0, 0.8, 0.64])
