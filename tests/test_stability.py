"""Exact mean-square stability (theory: mean-square stability)."""

import numpy as np
import control as ct
import pytest
from hypothesis import assume, given, settings, strategies as st

from control_ncs import (feedback, is_mss, jss, moments, ms_radius, nss)
from control_ncs.stability import second_moment_operator
from control_ncs.protocol import simulate_protocol
from control_ncs.stability import DENSE_MAX_STATES

from helpers import (assert_mean_within, fourth_moment_rate, random_jump,
                     random_plant, sample_jump, scalar_plant)

SLOW = settings(max_examples=25, deadline=None)
seeds = st.integers(0, 2**32 - 1)


# -- the two routes agree ----------------------------------------------------
@SLOW
@given(seed=seeds, n=st.integers(3, 6), N=st.integers(1, 3),
       M=st.integers(1, 4), radius=st.floats(0.3, 1.5))
def test_dense_and_matrix_free_agree_on_random_jump_systems(seed, n, N, M,
                                                            radius):
    sys = random_jump(np.random.default_rng(seed), n=n, N=N, M=M,
                      radius=radius)
    dense = ms_radius(sys, method="dense")
    free = ms_radius(sys, method="matrix-free")
    assert free == pytest.approx(dense, rel=1e-7, abs=1e-12)


@SLOW
@given(seed=seeds, n=st.integers(2, 3), N=st.integers(1, 3),
       controller=st.sampled_from(["static", "predictor"]),
       actuator=st.sampled_from(["zero", "hold"]),
       a1=st.floats(0, 0.9), a2=st.floats(0, 0.9))
def test_dense_and_matrix_free_agree_on_networked_loops(seed, n, N, controller,
                                                        actuator, a1, a2):
    rng = np.random.default_rng(seed)
    s1 = rng.integers(0, 2, (N, n))
    s2 = rng.integers(0, 2, (N, 1))
    if controller == "static":     # make the loop close at phase 0
        s1[0, 0], s2[0, 0] = 1, 1
    P = random_plant(rng, n=n, sensor_schedule=s1, actuator_schedule=s2,
                     sensor_loss=a1, actuator_loss=a2)
    nk = n + (1 if controller == "predictor" and actuator == "hold" else 0)
    K = rng.standard_normal((N, 1, nk)) * 0.5
    CL = feedback(P, K, controller=controller, actuator=actuator)
    assume(CL.modes.A.shape[-1] > 2)    # n² <= 4 is dense on both routes
    dense = ms_radius(CL, method="dense")
    free = ms_radius(CL, method="matrix-free")
    assert free == pytest.approx(dense, rel=1e-7, abs=1e-12)


def test_auto_route_goes_matrix_free_for_large_n_and_matches_closed_form():
    """Two modes ``V diag(a) Vᵀ``, ``V diag(b) Vᵀ`` (same orthogonal V) with
    probabilities p, 1-p: in the basis V, 𝒯 is diagonal on ``Q_ij`` with
    factor ``p a_i a_j + (1-p) b_i b_j``, so ρ is the largest modulus."""
    rng = np.random.default_rng(0)
    n = DENSE_MAX_STATES + 6
    a, b = rng.uniform(-1.1, 1.1, n), rng.uniform(-0.5, 0.5, n)
    p = 0.6
    V = np.linalg.qr(rng.standard_normal((n, n)))[0]
    modes = np.array([V @ np.diag(a) @ V.T, V @ np.diag(b) @ V.T])
    sys = jss(modes, np.zeros((n, 1)), np.zeros((1, n)), [[0.0]], [p, 1 - p])
    expected = np.max(np.abs(p * np.outer(a, a) + (1 - p) * np.outer(b, b)))
    assert ms_radius(sys) == pytest.approx(expected, rel=1e-8)


def test_matrix_free_reports_zero_for_a_system_that_forgets_in_one_period():
    # x⁺ = S x with S a 3 × 3 shift (S³ = 0), N = 3 phases: 𝒯 = 0
    S = np.diag([1.0, 1.0], 1)
    sys = jss([[S], [S], [S]], np.zeros((3, 1)), np.zeros((1, 3)), [[0.0]],
              [[1.0]] * 3)
    assert ms_radius(sys, method="matrix-free") == 0.0
    assert ms_radius(sys, method="dense") == 0.0


# -- closed forms ----------------------------------------------------------
@SLOW
@given(seed=seeds, n=st.integers(1, 6), dt=st.sampled_from([True, 0.1]))
def test_deterministic_statespace_has_ms_radius_rho_a_squared(seed, n, dt):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    sys = ct.ss(A, np.zeros((n, 1)), np.zeros((1, n)), 0, dt)
    rho2 = np.max(np.abs(np.linalg.eigvals(A))) ** 2
    for method in ("dense", "matrix-free"):
        assert ms_radius(sys, method=method) == pytest.approx(rho2, rel=1e-7)


@pytest.mark.parametrize("a, k, a1, a2", [
    (1.2, 1.0, 0.0, 0.3),      # actuator loss only
    (2.0, 1.5, 0.2, 0.0),      # sensor loss only
    (0.9, 0.4, 0.25, 0.1),
    (1.5, 1.5, 0.3, 0.3),      # K = -a: dead-beat when delivered
])
def test_scalar_static_loop_has_the_closed_form_rate(a, k, a1, a2):
    """x⁺ = a x + u, u = -k x delivered with probability q = (1-α1)(1-α2):
    E x⁺² = [(1-q) a² + q (a-k)²] E x²."""
    q = (1 - a1) * (1 - a2)
    CL = feedback(scalar_plant(a, sensor_loss=a1, actuator_loss=a2), [[-k]])
    assert ms_radius(CL) == pytest.approx((1 - q) * a**2 + q * (a - k)**2,
                                          rel=1e-12)


def test_scalar_periodic_gain_rate_is_the_geometric_mean_of_the_phases():
    """Gains k0, k1 alternate: over one period E x² is multiplied by
    Π_j [(1-q) a² + q (a-k_j)²]; the per-step rate is its square root."""
    a, q, ks = 1.3, 0.8, (0.5, 1.6)
    CL = feedback(scalar_plant(a, actuator_loss=1 - q), [[[-ks[0]]], [[-ks[1]]]])
    per_phase = [(1 - q) * a**2 + q * (a - kj)**2 for kj in ks]
    assert CL.period == 2
    assert ms_radius(CL) == pytest.approx(np.sqrt(np.prod(per_phase)),
                                          rel=1e-12)


def test_sensor_schedule_on_decoupled_channels_has_the_closed_form_rate():
    """A = diag(a1, a2), B2 = I, K = diag(-k1, -k2), sensors 1 then 2:
    channel i is fed back only at its phase, so E x_i² grows by
    [(1-q) a_i² + q (a_i-k_i)²]·a_i² per period, and the cross moment is
    bounded by these (Cauchy–Schwarz): ρ(𝒯) is the larger of the two."""
    a, k = np.array([1.4, 0.9]), np.array([1.0, 1.2])
    q = 0.7
    P = nss(np.diag(a), [[1.0, 1.0, 0.0], [1.0, 0.0, 1.0]],
            [[1.0, 1.0], [1.0, 0.0], [0.0, 1.0]], np.zeros((3, 3)),
            nmeas=2, ncon=2, sensor_schedule=[1, 2], actuator_loss=1 - q)
    CL = feedback(P, -np.diag(k))
    rates = ((1 - q) * a**2 + q * (a - k)**2) * a**2
    assert ms_radius(CL) == pytest.approx(np.sqrt(rates.max()), rel=1e-12)


def test_predictor_scalar_rate_is_the_worse_of_estimate_and_error_parts():
    """Predictor for x⁺ = a x + u, K = -k (theory: predictor): the error obeys
    e⁺ = (1-θ1) a e (factor α1 a²), the estimate x̂⁺ = (a - θ2 k) x̂ + …
    (factor α2 a² + (1-α2)(a-k)²); block triangular, so ρ is the max."""
    a, k, a1, a2 = 1.4, 1.1, 0.3, 0.2
    CL = feedback(scalar_plant(a, sensor_loss=a1, actuator_loss=a2), [[-k]],
                  controller="predictor")
    expected = max(a1 * a**2, a2 * a**2 + (1 - a2) * (a - k)**2)
    assert ms_radius(CL) == pytest.approx(expected, rel=1e-12)


def test_is_mss_is_ms_radius_below_one():
    a, a2 = 1.5, 0.3
    stable = feedback(scalar_plant(a, actuator_loss=a2), [[-1.5]])   # 0.675
    unstable = feedback(scalar_plant(a, actuator_loss=0.5), [[-1.5]])  # 1.125
    assert is_mss(stable) and not is_mss(unstable)
    assert is_mss(ct.ss([[0.99]], [[1]], [[1]], [[0]], True))
    assert not is_mss(ct.ss([[-1.01]], [[1]], [[1]], [[0]], True))


# -- the operator --------------------------------------------------------
def test_one_step_operator_is_the_probability_weighted_congruence():
    rng = np.random.default_rng(2)
    sys = random_jump(rng, n=3, N=2, M=3)
    Q = rng.standard_normal((3, 3))
    Q = Q @ Q.T
    for k in range(2):
        expected = sum(sys.modes.probabilities[k, i]
                       * sys.modes.A[k, i] @ Q @ sys.modes.A[k, i].T
                       for i in range(3))
        got = second_moment_operator(sys, k).matvec(Q.ravel()).reshape(3, 3)
        assert np.allclose(got, expected, rtol=1e-12, atol=1e-12)


def test_monodromy_applies_the_phases_in_time_order():
    rng = np.random.default_rng(3)
    sys = random_jump(rng, n=2, N=3, M=2)
    v = rng.standard_normal(4)
    step = [second_moment_operator(sys, k) for k in range(3)]
    assert np.allclose(second_moment_operator(sys).matvec(v),
                       step[2].matvec(step[1].matvec(step[0].matvec(v))))


# -- Monte Carlo consistency -----------------------------------------------
def test_ms_radius_is_the_decay_rate_of_exact_and_sampled_second_moments():
    """A scheduled, lossy static loop from x0: the sample mean of ‖x_k‖²
    over 20000 event-level paths is within 4 standard errors of the exact
    tr E[x xᵀ] at every k; the exact per-period growth converges to ρ(𝒯);
    the sampled growth k=6 → 26 is within 4 standard errors (delta method,
    covariance ignored: conservative) of the exact one. A gentle gain keeps
    the loop's fourth moment close to the square of its second moment, so
    that sample standard errors are meaningful (checked first)."""
    P = random_plant(np.random.default_rng(1), n=2, m1=1, radius=1.0,
                     sensor_schedule=[[1, 1], [1, 0]], sensor_loss=0.1,
                     actuator_loss=0.1)
    K = -0.5 * ct.dlqr(P.A, P.B2, np.eye(2), np.eye(1))[0]
    CL = feedback(P, K)
    rate = ms_radius(CL)
    assert (fourth_moment_rate(CL) / rate**2) ** 26 < 3
    x0 = np.array([1.0, -1.0])
    T = 27
    exact = np.einsum("iit->t", moments(CL, 81, initial_state=x0)
                      .states_second_moment)
    # exact growth converges to the rate (power iteration on 𝒯)
    assert (exact[80] / exact[60]) ** (1 / 20) == pytest.approx(rate, rel=1e-6)
    sim = simulate_protocol(P.A, P.B1, P.B2, P.C1, P.D11, P.D12,
                            P.sensor_schedule.pattern, [[1], [1]], 0.1, 0.1,
                            np.array([K, K]), T - 1, initial_state=x0,
                            trials=20000, rng=np.random.default_rng(4))
    sq = np.sum(sim["x"] ** 2, axis=1)        # (trials, T)
    assert_mean_within(sq, exact[:T], n_se=4)
    m, se = sq.mean(0), sq.std(0, ddof=1) / np.sqrt(sq.shape[0])
    growth = np.log(m[26] / m[6])
    growth_se = np.hypot(se[26] / m[26], se[6] / m[6])
    assert abs(growth - np.log(exact[26] / exact[6])) < 4 * growth_se
    assert rate < 1 and m[26] < 0.1 * m[6]


def alternating_example(a2, s2):
    """Period 2; phase k has two modes A_k ± σ I (probability 1/2 each),
    A_0 = a e1 e2ᵀ, A_1 = a e2 e1ᵀ, so 𝒯_k(Q) = A_k Q A_kᵀ + σ² Q."""
    a = np.sqrt(a2)
    s = np.sqrt(s2)
    A0 = np.array([[0.0, a], [0.0, 0.0]])
    A1 = A0.T
    I = np.eye(2)
    return [[A0 + s * I, A0 - s * I], [A1 + s * I, A1 - s * I]]


def test_periodic_system_is_not_judged_by_the_average_of_its_phases():
    """With a² = 1.6, σ² = 0.1 (closed forms worked from 𝒯_k above):
    each phase alone has ρ = σ² (A_k ⊗ A_k is nilpotent); the phase-averaged
    operator (𝒯_0 + 𝒯_1)/2 has ρ = a²/2 + σ² = 0.9 on span(E11, E22);
    the period map on (Q11, Q22) is [[σ⁴, σ²a²], [σ²a², a⁴+σ⁴]], so the
    per-step rate is √(σ⁴ + a⁴/2 + √(a⁸/4 + σ⁴a⁴)) ≈ 1.606 > 1."""
    a2, s2 = 1.6, 0.1
    modes = alternating_example(a2, s2)
    B, C, D = np.zeros((2, 1)), np.zeros((1, 2)), [[0.0]]
    periodic = jss(modes, B, C, D, [[0.5, 0.5]] * 2)
    phase = [jss(modes[k], B, C, D, [0.5, 0.5]) for k in range(2)]
    averaged = jss(modes[0] + modes[1], B, C, D, [0.25] * 4)  # (𝒯0 + 𝒯1)/2
    lam = s2**2 + a2**2 / 2 + np.sqrt(a2**4 / 4 + s2**2 * a2**2)
    assert ms_radius(phase[0]) == pytest.approx(s2, rel=1e-10)
    assert ms_radius(phase[1]) == pytest.approx(s2, rel=1e-10)
    assert ms_radius(averaged) == pytest.approx(a2 / 2 + s2, rel=1e-10)
    assert ms_radius(periodic) == pytest.approx(np.sqrt(lam), rel=1e-10)
    assert is_mss(averaged) and not is_mss(periodic)


def test_periodic_instability_shows_in_sampled_growth():
    """Monte Carlo of the example above: 40000 paths; sample E‖x‖² within
    4 standard errors of the exact value at each step, and it grows by more
    than 10× over 5 periods (exact rate 1.606² ≈ 2.58 per period)."""
    modes = alternating_example(1.6, 0.1)
    sys = jss(modes, np.zeros((2, 1)), np.zeros((1, 2)), [[0.0]],
              [[0.5, 0.5]] * 2)
    x0 = np.array([0.6, 0.8])
    xs, _ = sample_jump(sys, 11, 40000, np.random.default_rng(5), x0=x0)
    sq = np.sum(xs**2, axis=1)
    exact = np.einsum("iit->t", moments(sys, 11, initial_state=x0)
                      .states_second_moment)
    assert_mean_within(sq, exact, n_se=4)
    assert sq[:, 10].mean() > 10 * sq[:, 0].mean()


def test_periodic_system_can_be_stable_though_each_phase_is_not():
    """The converse: A_0 = diag(2, 0.1), A_1 = diag(0.1, 2), modes A_k ± σI,
    σ² = 0.01. 𝒯_k is diagonal on Q_ij with factor (A_k)_ii (A_k)_jj + σ²:
    each phase alone has ρ = 4.01, the average (4.01 + 0.02)/2 = 2.015, the
    period map max((4.01)(0.02), 0.21²) = 0.0802, rate √0.0802."""
    s = 0.1
    A0, A1, I = np.diag([2.0, 0.1]), np.diag([0.1, 2.0]), np.eye(2)
    modes = [[A0 + s * I, A0 - s * I], [A1 + s * I, A1 - s * I]]
    B, C, D = np.zeros((2, 1)), np.zeros((1, 2)), [[0.0]]
    periodic = jss(modes, B, C, D, [[0.5, 0.5]] * 2)
    averaged = jss(modes[0] + modes[1], B, C, D, [0.25] * 4)
    assert ms_radius(jss(modes[0], B, C, D, [0.5, 0.5])) == pytest.approx(4.01)
    assert ms_radius(averaged) == pytest.approx(2.015)
    assert ms_radius(periodic) == pytest.approx(np.sqrt(4.01 * 0.02))
    xs, _ = sample_jump(periodic, 11, 20000, np.random.default_rng(6),
                        x0=[1.0, 1.0])
    sq = np.sum(xs**2, axis=1).mean(axis=0)
    assert sq[10] < 1e-3 * sq[0]


@pytest.mark.parametrize("seed", range(4))
def test_deterministic_periodic_shortcut_matches_dense_and_matrix_free(seed):
    # one live mode per phase (a different one at each phase, the others at
    # probability zero): 'auto' takes ρ(Φ)^(2/N) from the n×n monodromy
    rng = np.random.default_rng([seed, 41])
    N, M, n = 3, 2, 5
    A = rng.standard_normal((N, M, n, n)) / np.sqrt(n)
    p = np.zeros((N, M))
    p[np.arange(N), rng.integers(0, M, N)] = 1.0
    sys = jss(A, np.ones((n, 1)), np.ones((1, n)), [[0.0]], p)
    auto = ms_radius(sys)
    assert auto == pytest.approx(ms_radius(sys, method="dense"), rel=1e-9)
    assert auto == pytest.approx(ms_radius(sys, method="matrix-free"),
                                 rel=1e-6)
    phi = np.eye(n)
    for k in range(N):
        phi = A[k, np.flatnonzero(p[k])[0]] @ phi
    assert auto == pytest.approx(
        np.max(np.abs(np.linalg.eigvals(phi))) ** (2 / N), rel=1e-12)


def test_matrix_free_route_survives_arpack_failing_on_equal_moduli():
    # 𝒯 = A ⊗ A with a complex pair λ: λ², λ̄² and |λ|² share the largest
    # modulus, and ARPACK's restart failed outright (error 3) on this 9 × 9
    # operator; a hypothesis run found it (seed 4, n = 3, M = 1)
    sys = random_jump(np.random.default_rng(4), n=3, N=1, M=1,
                      radius=0.9172994604683427)
    assert ms_radius(sys, method="matrix-free") == pytest.approx(
        ms_radius(sys, method="dense"), rel=1e-12)
