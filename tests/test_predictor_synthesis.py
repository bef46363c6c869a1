"""Passive synthesis of the model-based predictor (theory: predictor).

The closed loops are rebuilt here from the event order of theory: predictor
(sensor update, control, actuator, plant step), independently of
``strategies.py``; the certificate ``P_k = X_k⁻¹`` is checked on them with
``Θ_k`` of theory: passivity and the Kronecker second-moment operator of theory: mean-square stability.
"""

import itertools

import numpy as np
import pytest

import control_ncs as cn
from control_ncs import SynthesisError, ispassive, nss, passivesyn

from helpers import kron_ms_radius

# -- the paper's kind of shared channel: N = 3, sensors at phases 0 and 1,
#    the actuator at phase 2, one message per step ---------------------------
A = np.array([[1.1, 0.3], [0.0, 0.9]])
B1 = np.array([[1.0], [0.5]])
B2 = np.array([[0.0], [1.0]])
C1 = np.array([[1.0, 0.0]])
D11 = np.array([[2.0]])
D12 = np.array([[0.2]])
SENSORS = np.array([[1, 0], [0, 1], [0, 0]])   # Σ1,k diagonals
ACTUATORS = np.array([[0], [0], [1]])          # Σ2,k diagonals
ALPHA1, ALPHA2 = 0.1, 0.2


def shared_channel_plant(sensor_loss=ALPHA1, actuator_loss=ALPHA2):
    n = A.shape[0]
    return nss(A, np.hstack([B1, B2]), np.vstack([C1, np.eye(n)]),
               np.block([[D11, D12], [np.zeros((n, 2))]]), True, nmeas=n,
               ncon=1, sensor_schedule=SENSORS,
               actuator_schedule=[0, 0, 1], sensor_loss=sensor_loss,
               actuator_loss=actuator_loss, shared_channel=True)


def predictor_modes(gains, actuator, a1=ALPHA1, a2=ALPHA2, plant=None):
    """Per phase k: [(p, A_cl, B_cl, C_cl, D_cl)] over (θ2,k, θ1,k+1).

    State [x̂; e] (zero) or [x̂; u⁻; e] (hold), x̂ the estimate after the
    sensor update, e = x - x̂ (theory: predictor, written from the event order).
    """
    A_, B1_, B2_, C1_, D11_, D12_, S1, S2 = plant or (
        A, B1, B2, C1, D11, D12, SENSORS, ACTUATORS)
    n, m = A_.shape[0], B2_.shape[1]
    N = len(gains)
    I, Z = np.eye(n), np.zeros
    phases = []
    for k in range(N):
        Sig2 = np.diag(S2[k % len(S2)])
        Sig1n = np.diag(S1[(k + 1) % len(S1)])
        modes = []
        for t2, t1n in itertools.product((0, 1), (0, 1)):
            p = (a2 if t2 == 0 else 1 - a2) * (a1 if t1n == 0 else 1 - a1)
            R = t1n * Sig1n
            if actuator == "zero":
                K = gains[k]                      # v = K x̂
                U = t2 * Sig2 @ K                 # u = U x̂
                Acl = np.block([[A_ + B2_ @ U, R @ A_],
                                [Z((n, n)), (I - R) @ A_]])
                Bcl = np.vstack([R @ B1_, (I - R) @ B1_])
                Ccl = np.hstack([C1_ + D12_ @ U, C1_])
            else:
                Kx, Ku = gains[k][:, :n], gains[k][:, n:]  # v = Kx x̂ + Ku u⁻
                keep = np.eye(m) - t2 * Sig2
                Ux = t2 * Sig2 @ Kx                       # u = Ux x̂ + Uu u⁻
                Uu = keep + t2 * Sig2 @ Ku
                Acl = np.block([[A_ + B2_ @ Ux, B2_ @ Uu, R @ A_],
                                [Ux, Uu, Z((m, n))],
                                [Z((n, n)), Z((n, m)), (I - R) @ A_]])
                Bcl = np.vstack([R @ B1_, Z((m, B1_.shape[1])),
                                 (I - R) @ B1_])
                Ccl = np.hstack([C1_ + D12_ @ Ux, D12_ @ Uu, C1_])
            modes.append((p, Acl, Bcl, Ccl, D11_))
        phases.append(modes)
    return phases


def theta_max(phases, P, eta):
    worst = -np.inf
    N = len(phases)
    for k, modes in enumerate(phases):
        n = P[k].shape[0]
        m = modes[0][2].shape[1]
        T = sum(p * np.hstack([Ac, Bc]).T @ P[(k + 1) % N]
                @ np.hstack([Ac, Bc]) for p, Ac, Bc, _, _ in modes)
        Cbar = sum(p * Cc for p, _, _, Cc, _ in modes)
        Dbar = sum(p * Dc for p, _, _, _, Dc in modes)
        T[:n, :n] -= P[k]
        T[:n, n:] -= Cbar.T
        T[n:, :n] -= Cbar
        T[n:, n:] += 2 * eta * np.eye(m) - Dbar - Dbar.T
        worst = max(worst, np.linalg.eigvalsh(0.5 * (T + T.T)).max())
    return worst


def assert_predictor_verified(K, CL, eta, actuator, **loop):
    phases = predictor_modes(K.gains, actuator, **loop)
    P = np.array([np.linalg.inv(0.5 * (X + X.T)) for X in K.result.X])
    assert min(np.linalg.eigvalsh(Pk).min() for Pk in P) > 0
    assert theta_max(phases, P, eta) < 0
    rho = kron_ms_radius(phases)
    assert rho < 1
    assert cn.ms_radius(CL) == pytest.approx(rho, rel=1e-8, abs=1e-12)
    assert K.result.certificate.verified
    return rho


# -- the shared channel ---------------------------------------------------------
@pytest.mark.parametrize("actuator", ["zero", "hold"])
def test_predictor_closes_a_shared_channel_loop_with_verified_gain(actuator):
    P = shared_channel_plant()
    K, CL, eta = passivesyn(P, controller="predictor", actuator=actuator)
    assert (K.controller, K.actuator) == ("predictor", actuator)
    nk = 2 if actuator == "zero" else 3
    assert K.gains.shape == (3, 1, nk)
    # the controller only speaks at phase 2, where the actuator listens
    assert np.all(K.gains[:2] == 0) and np.any(K.gains[2] != 0)
    assert_predictor_verified(K, CL, eta, actuator)
    assert ispassive(CL, ifp_index=eta)
    assert K.result.structure in ("block", "extended")


def test_static_gain_cannot_close_the_shared_channel_loop():
    with pytest.raises(ValueError, match="predictor"):
        passivesyn(shared_channel_plant())
    with pytest.raises(ValueError, match="predictor"):
        cn.feedback(shared_channel_plant(), np.zeros((3, 1, 2)))


def test_predictor_structure_full_is_refused():
    with pytest.raises(ValueError, match="full"):
        passivesyn(shared_channel_plant(), controller="predictor",
                   options={"structure": "full"})


def test_predictor_with_decay_bound_is_verified():
    P = shared_channel_plant()
    K, CL, eta = passivesyn(P, controller="predictor", decay=0.99)
    rho = assert_predictor_verified(K, CL, eta, "zero")
    assert rho < 0.99 ** 2


def test_predictor_modes_match_the_package_closed_loop():
    """The jump system the package builds is the one of theory: predictor."""
    rng = np.random.default_rng(0)
    for actuator, nk in (("zero", 2), ("hold", 3)):
        gains = rng.standard_normal((3, 1, nk))
        CL = cn.feedback(shared_channel_plant(), gains,
                         controller="predictor", actuator=actuator)
        phases = predictor_modes(gains, actuator)
        assert cn.ms_radius(CL) == pytest.approx(kron_ms_radius(phases),
                                                 rel=1e-9)
        for k, modes in enumerate(phases):
            Abar, Bbar, Cbar, Dbar = CL.mean_phase(k)
            np.testing.assert_allclose(
                Abar, sum(p * Ac for p, Ac, *_ in modes), atol=1e-12)
            np.testing.assert_allclose(
                Bbar, sum(p * Bc for p, _, Bc, _, _ in modes), atol=1e-12)
            np.testing.assert_allclose(
                Cbar, sum(p * Cc for p, _, _, Cc, _ in modes), atol=1e-12)


# -- x⁺ = a x + u: where memory helps (theory: predictor) -------------------------------------
def scalar(a, a1, a2):
    """Pure stabilization data, no schedules."""
    return nss([[a]], [[0.0, 1.0]], [[0.0], [1.0]], [[1.0, 0.0], [0.0, 0.0]],
               True, nmeas=1, ncon=1, sensor_loss=a1, actuator_loss=a2)


def feasible(P, **kwargs):
    try:
        K, CL, eta = passivesyn(P, **kwargs)
    except SynthesisError as err:
        assert err.reason == "infeasible", err
        return False
    assert K.result.certificate.verified and cn.ms_radius(CL) < 1
    return True


# a = 2: predictor needs α1 < 1/4 and α2 < 1/4
PREDICTOR_POINTS = [(0.24, 0.1, True), (0.26, 0.1, False),
                    (0.1, 0.24, True), (0.1, 0.26, False),
                    (0.249, 0.249, True), (0.0, 0.26, False)]


@pytest.mark.parametrize("a1, a2, expected", PREDICTOR_POINTS)
def test_predictor_feasible_exactly_when_each_loss_below_one_over_a_squared(
        a1, a2, expected):
    a = 2.0
    assert (a1 * a * a < 1 and a2 * a * a < 1) == expected
    P = scalar(a, a1, a2)
    assert feasible(P, controller="predictor") == expected
    if expected:
        K, CL, eta = passivesyn(P, controller="predictor")
        plant = (np.array([[a]]), np.zeros((1, 1)), np.ones((1, 1)),
                 np.zeros((1, 1)), np.ones((1, 1)), np.zeros((1, 1)),
                 np.ones((1, 1)), np.ones((1, 1)))
        rho = assert_predictor_verified(K, CL, eta, "zero", a1=a1, a2=a2,
                                        plant=plant)
        # the estimation error alone decays like α1 a² (theory: predictor)
        assert rho >= a1 * a * a - 1e-12


# memoryless: (1 - (1-α1)(1-α2)) a² < 1
STATIC_POINTS = [(0.1, 0.16, True), (0.1, 0.18, False), (0.0, 0.24, True),
                 (0.24, 0.0, True), (0.26, 0.0, False), (0.2, 0.2, False)]


@pytest.mark.parametrize("a1, a2, expected", STATIC_POINTS)
def test_memoryless_gain_feasible_exactly_when_success_rate_suffices(
        a1, a2, expected):
    a = 2.0
    assert ((1 - (1 - a1) * (1 - a2)) * a * a < 1) == expected
    assert feasible(scalar(a, a1, a2)) == expected


def test_only_the_predictor_stabilises_at_twenty_percent_loss_on_both_links():
    # (1 - 0.8²)·4 = 1.44 > 1, but 0.2·4 = 0.8 < 1
    P = scalar(2.0, 0.2, 0.2)
    assert not feasible(P)
    assert feasible(P, controller="predictor")
    assert feasible(P, controller="predictor", actuator="hold")


def test_predictor_ms_radius_reaches_the_larger_loss_rate_with_decay():
    """x̂ and e separate (theory: predictor): the best rate is max(α1, α2)·a², so a
    decay bound r² just above it is feasible and just below is not."""
    a, a1, a2 = 2.0, 0.1, 0.2
    best = max(a1, a2) * a * a
    P = scalar(a, a1, a2)
    K, CL, eta = passivesyn(P, controller="predictor",
                            decay=np.sqrt(best * 1.02))
    assert best - 1e-9 <= cn.ms_radius(CL) < best * 1.02
    with pytest.raises(SynthesisError) as info:
        passivesyn(P, controller="predictor", decay=np.sqrt(best * 0.98))
    assert info.value.reason == "infeasible"
