"""Sampling jitter as users give it: ``nss(..., timing=(pairs, probs))``,
the joint pmf of the sample's delay ``s`` and the input's delay ``τ``.

Checked against routes written here or in the intersample tests: the
loop built by hand on ``[x_k; u_{k-1}]`` (cost, radius, and its sampled
model with the noise held over the period), the loop shifted in time (a
constant late sample), and a Monte Carlo of the continuous plant.
"""

from __future__ import annotations

import math
import pickle

import control as ct
import numpy as np
import pytest
from control.exception import ControlArgument, ControlDimension
from hypothesis import given, settings, strategies as st

import control_ncs as ncs
from test_intersample_cost import (_estimator, _flow, _fourth_moment_radius,
                                   _late_sample_loop, _lti, _monte_carlo,
                                   _oscillator, _plant)

H, GRAINS = 0.5, 10
#: (s, τ) in sub-steps of h / GRAINS, with their probabilities
GRID = [((0, 0), 0.3), ((2, 4), 0.4), ((3, 7), 0.3)]
#: a smaller joint pmf for the controllers with memory (their modes run
#: on consecutive pairs)
GRID2 = [((0, 2), 0.5), ((3, 7), 0.5)]


def _pairs(grid, h=H, grains=GRAINS):
    return ([(s * h / grains, t * h / grains) for (s, t), _ in grid],
            [q for _, q in grid])


def _noisy_oscillator():
    """The oscillator with its process noise continuous (a B1 column)
    and its measurement noise discrete (a D21 column)."""
    A = np.array([[0.0, 1.0], [-1.0, -0.4]])
    B = np.array([[0.0], [1.0]])
    return _plant(A, np.hstack([B, np.zeros((2, 1))]), B, [[1.0, 0.0]],
                  [[0.3]], [[1.0, 0.0]], [[0.0, 0.1]]), A, B


def _pd(kp, kd, h):
    """``v = -kp y - kd (y - y_prev) / h`` as a discrete controller."""
    return ct.ss([[0.0]], [[1.0]], [[kd / h]], [[-(kp + kd / h)]], h)


def _held_noise_loop(G, h, K, timings):
    """The sampled model of the static loop with the noise held over the
    period (what ms_radius, norm and simulate see): ``x(kh + s) = e^{As}
    x_k + Γs u_{k-1} + Γws w_k``, ``x_{k+1} = Φ x_k + Γw w_k + Γ0(τ) u_k
    + Γ1(τ) u_{k-1}``, ``u_k = K C2 x(kh + s)``, ``z_k = C1 x_k + D12
    u_k``."""
    A, B = np.asarray(G.A), np.asarray(G.B)
    n = A.shape[0]
    B1, B2 = B[:, :1], B[:, 1:]
    C1, C2 = np.asarray(G.C)[:1], np.asarray(G.C)[1:]
    D12 = np.asarray(G.D)[:1, 1:]
    Phi, Gw = _flow(A, B1, h)
    As, Bs, Cs, Ds = [], [], [], []
    for (s, tau), _ in timings:
        Es, Gs = _flow(A, B2, s)
        Gws = _flow(A, B1, s)[1]
        Erest, G0 = _flow(A, B2, h - tau)
        G1 = Erest @ _flow(A, B2, tau)[1]
        U, Uw = np.hstack([K @ C2 @ Es, K @ C2 @ Gs]), K @ C2 @ Gws
        As.append(np.block([[Phi, G1], [np.zeros((1, n + 1))]])
                  + np.vstack([G0, np.eye(1)]) @ U)
        Bs.append(np.vstack([Gw + G0 @ Uw, Uw]))
        Cs.append(np.hstack([C1, np.zeros((1, 1))]) + D12 @ U)
        Ds.append(D12 @ Uw)
    return ncs.jss(np.array(As), np.array(Bs), np.array(Cs), np.array(Ds),
                   [q for _, q in timings], h)


# --------------------------------------------------------------------------
# the static gain against the loop built by hand
# --------------------------------------------------------------------------
def test_static_gain_loop_equals_the_hand_built_late_sample_loop():
    G, K = _oscillator(), np.array([[-0.8]])
    timings = list(zip(*_pairs(GRID)))
    P = ncs.nss(G, nmeas=1, ncon=1, dt=H, timing=_pairs(GRID))
    CL, ref = ncs.feedback(P, K), _late_sample_loop(G, H, K, timings)
    assert ncs.cost(CL).cost == pytest.approx(ncs.cost(ref).cost, rel=1e-10)
    assert ncs.ms_radius(CL) == pytest.approx(ncs.ms_radius(ref), rel=1e-10)


@settings(max_examples=5, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_static_gain_on_random_plants_and_timings_is_the_hand_built_loop(seed):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((2, 2))
    A -= (np.linalg.eigvals(A).real.max() + 0.5) * np.eye(2)   # Hurwitz
    B = rng.standard_normal((2, 1)) / 4
    G = _plant(A, B, B, rng.standard_normal((1, 2)), [[0.2]],
               rng.standard_normal((1, 2)))
    K = np.array([[-0.3]])
    h = 0.4
    taus = np.sort(rng.uniform(0.0, h, 3))
    pairs = [(rng.uniform(0.0, t), t) for t in taus]
    probs = rng.dirichlet(np.ones(3))
    timings = list(zip(pairs, probs))
    CL = ncs.feedback(ncs.nss(G, nmeas=1, ncon=1, dt=h,
                              timing=(pairs, probs)), K)
    ref = _late_sample_loop(G, h, K, timings)
    assert ncs.ms_radius(CL) == pytest.approx(ncs.ms_radius(ref), rel=1e-9)
    J, J_ref = ncs.cost(CL).cost, ncs.cost(ref).cost
    assert math.isfinite(J_ref) and J == pytest.approx(J_ref, rel=1e-9)
    assert ncs.norm(CL, 2) == pytest.approx(
        ncs.norm(_held_noise_loop(G, h, K, timings), 2), rel=1e-9)


def test_the_sampled_model_holds_the_noise_until_the_late_sample():
    G, K = _oscillator(), np.array([[-0.8]])
    timings = list(zip(*_pairs(GRID)))
    CL = ncs.feedback(ncs.nss(G, nmeas=1, ncon=1, dt=H, timing=_pairs(GRID)),
                      K)
    ref = _held_noise_loop(G, H, K, timings)
    assert ncs.norm(CL, 2) == pytest.approx(ncs.norm(ref, 2), rel=1e-9)


def test_timing_without_late_samples_is_the_input_delay():
    G, K = _oscillator(), np.array([[-0.8]])
    taus, probs = [0.0, 0.2, 0.35], [0.3, 0.4, 0.3]
    a = ncs.nss(G, nmeas=1, ncon=1, dt=H, input_delay=(taus, probs))
    b = ncs.nss(G, nmeas=1, ncon=1, dt=H,
                timing=([(0.0, t) for t in taus], probs))
    assert a.input_delay == b.input_delay and not b.input_delay.late
    assert ncs.cost(ncs.feedback(a, K)).cost == ncs.cost(
        ncs.feedback(b, K)).cost


# --------------------------------------------------------------------------
# a constant late sample is the loop shifted in time
# --------------------------------------------------------------------------
@pytest.mark.parametrize("controller", ["static", "lti", "estimator"])
def test_a_constant_late_sample_is_the_loop_shifted_in_time(controller):
    G, A, B = _noisy_oscillator()
    s, tau = 0.15, 0.35
    if controller == "static":
        kw: dict = dict(K=np.array([[-0.8]]))
    elif controller == "lti":
        kw = dict(K=_pd(0.6, 0.3, H))
    else:
        Phi, Gam = _flow(A, B, H)
        kw = dict(K=-ct.dlqr(Phi, Gam, np.eye(2), np.eye(1))[0],
                  estimator_gain=[[0.5], [0.3]])
    late = ncs.nss(G, nmeas=1, ncon=1, dt=H, timing=([(s, tau)], [1.0]))
    shifted = ncs.nss(G, nmeas=1, ncon=1, dt=H,
                      input_delay=([tau - s], [1.0]))
    J = [ncs.cost(ncs.feedback(P, **kw)).cost for P in (late, shifted)]
    assert math.isfinite(J[1])
    assert J[0] == pytest.approx(J[1], rel=1e-9)


# --------------------------------------------------------------------------
# controllers with memory against a Monte Carlo of the continuous plant
# --------------------------------------------------------------------------
def test_pd_controller_with_sampling_jitter_matches_monte_carlo():
    G, _, _ = _noisy_oscillator()
    Kss = _pd(0.6, 0.3, H)
    P = ncs.nss(G, nmeas=1, ncon=1, dt=H, timing=_pairs(GRID2),
                sensor_loss=0.1)
    J = ncs.cost(ncs.feedback(P, Kss)).cost
    mc, se = _monte_carlo(G, H, GRAINS, GRID2, _lti(Kss), nmeas=1, ncon=1,
                          sensor_loss=0.1, paths=200, periods=600, seed=11)
    assert abs(mc - J) < 4 * se, (J, mc, se)
    assert se < 0.03 * J


def test_estimator_with_sampling_jitter_matches_monte_carlo():
    G, A, B = _noisy_oscillator()
    Phi, Gam = _flow(A, B, H)
    K = -ct.dlqr(Phi, Gam, np.eye(2), np.eye(1))[0]
    Lg = np.array([[0.5], [0.3]])
    P = ncs.nss(G, nmeas=1, ncon=1, dt=H, timing=_pairs(GRID2))
    CL = ncs.feedback(P, K, estimator_gain=Lg)
    J = ncs.cost(CL).cost
    mc, se = _monte_carlo(G, H, GRAINS, GRID2,
                          _estimator(Phi, Gam, np.array([[1.0, 0.0]]), K, Lg),
                          nmeas=1, ncon=1, paths=200, periods=600, seed=12)
    assert abs(mc - J) < 4 * se, (J, mc, se)
    assert se < 0.03 * J


def test_static_gain_with_sampling_jitter_and_losses_matches_monte_carlo():
    G, K = _oscillator(), np.array([[-0.8]])
    P = ncs.nss(G, nmeas=1, ncon=1, dt=H, timing=_pairs(GRID),
                sensor_loss=0.2)
    CL = ncs.feedback(P, K)
    assert _fourth_moment_radius(CL) < 1
    J = ncs.cost(CL).cost
    from test_intersample_cost import _static
    mc, se = _monte_carlo(G, H, GRAINS, GRID, _static(K), nmeas=1, ncon=1,
                          sensor_loss=0.2, paths=200, periods=600, seed=13)
    assert abs(mc - J) < 4 * se, (J, mc, se)


# --------------------------------------------------------------------------
# the interface
# --------------------------------------------------------------------------
def test_timing_is_checked_at_the_boundary():
    G = _oscillator()
    with pytest.raises(ValueError, match="s <= tau"):
        ncs.nss(G, nmeas=1, ncon=1, dt=H, timing=([(0.3, 0.2)], [1.0]))
    with pytest.raises(ValueError, match=r"\[0, h\)"):
        ncs.nss(G, nmeas=1, ncon=1, dt=H, timing=([(0.1, 0.5)], [1.0]))
    with pytest.raises(ValueError, match="give one"):
        ncs.nss(G, nmeas=1, ncon=1, dt=H, timing=([(0.0, 0.1)], [1.0]),
                input_delay=([0.1], [1.0]))
    with pytest.raises(ControlDimension, match="pairs"):
        ncs.nss(G, nmeas=1, ncon=1, dt=H, timing=([[0.0, 0.1, 0.2]], [1.0]))
    with pytest.raises(ValueError, match="sum to 1"):
        ncs.nss(G, nmeas=1, ncon=1, dt=H, timing=([(0.0, 0.1)], [0.5]))
    with pytest.raises(ValueError, match="continuous-time"):
        ncs.nss(ct.sample_system(G, H), nmeas=1, ncon=1,
                timing=([(0.0, 0.1)], [1.0]))


def test_a_late_sample_over_a_delayed_sensor_link_needs_the_static_gain():
    G = _oscillator()
    P = ncs.nss(G, nmeas=1, ncon=1, dt=H, timing=_pairs(GRID),
                sensor_delay=[0.7, 0.3])
    assert math.isfinite(ncs.cost(ncs.feedback(P, [[-0.5, -0.2]])).cost)
    with pytest.raises(ControlArgument, match="delayed sensor link"):
        ncs.feedback(P, _pd(0.6, 0.3, H))


def test_a_plant_with_timing_prints_and_pickles_its_samples():
    P = ncs.nss(_oscillator(), nmeas=1, ncon=1, dt=H, timing=_pairs(GRID))
    assert "sample delays 0..0.15 s" in repr(P)
    assert "sampled at s = [0, 0.1, 0.15]" in str(P)
    Q = pickle.loads(pickle.dumps(P))
    assert Q.equals(P) and Q.input_delay.late
    assert P.with_network(sensor_loss=0.1).input_delay == P.input_delay
