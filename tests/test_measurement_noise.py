"""Measurement noise and references in y (``D21 ≠ 0``).

Every loop is checked against an independent route: a closed form (static
gain), python-control's own interconnection when nothing is lost, and the
event-level protocol simulator when messages are lost.
"""

from __future__ import annotations

import control as ct
import numpy as np
import pytest
from control.exception import ControlArgument

import control_ncs as ncs
from control_ncs.protocol import simulate_protocol


def _tracking_plant(**network):
    """``x⁺ = 1.05 x + w1 + 0.5 u``; ``w = [w1, r]``; ``z = x - r``; the
    controller hears ``y = r - x`` (a reference, ``D21 = [0, 1]``)."""
    G = ct.ss([[1.05]], [[1.0, 0.0, 0.5]], [[1.0], [-1.0]],
              [[0.0, -1.0, 0.0], [0.0, 1.0, 0.0]], True)
    return G, ncs.nss(G, nmeas=1, ncon=1, **network)


PI = ct.ss([[1.0]], [[1.0]], [[0.2]], [[0.8]], True)   # u = 0.8 e + 0.2 Σ e


def test_static_gain_with_noisy_measurement_matches_the_closed_form():
    """``x⁺ = a x + w1 + θ k (x + d w2)``, ``z = [x; θ u]``: the H2 norm
    is ``S + q k² (S + d²)`` with ``S = (1 + q k² d²) / (1 - E a²)``."""
    a, d, k, loss = 1.1, 0.5, -0.8, 0.3
    P = ncs.nss([[a]], [[1.0, 0.0, 1.0]], [[1.0], [0.0], [1.0]],
                [[0, 0, 0], [0, 0, 1.0], [0, d, 0]], True, nmeas=1, ncon=1,
                actuator_loss=loss)
    CL = ncs.feedback(P, [[k]])
    q = 1 - loss
    S = (1 + q * (k * d) ** 2) / (1 - loss * a * a - q * (a + k) ** 2)
    assert ncs.norm(CL) ** 2 == pytest.approx(S + q * k * k * (S + d * d),
                                              rel=1e-12)


def test_lossless_pi_tracking_loop_is_python_controls_lft():
    G, P = _tracking_plant()
    CL = ncs.feedback(P, PI)
    reference = G.lft(PI, 1, 1)      # python-control: u = K y
    assert ncs.norm(CL) == pytest.approx(ct.norm(reference, 2), rel=1e-10)
    for sensor, actuator in (("hold", "zero"), ("zero", "hold")):
        other = ncs.feedback(P, PI, sensor=sensor, actuator=actuator)
        assert ncs.norm(other) == pytest.approx(ncs.norm(CL), rel=1e-10)


def test_lossless_estimator_loop_with_sensor_noise_is_the_observer_loop():
    """The estimator controller without losses is the textbook
    observer-based controller (update, then predict), built here by hand."""
    A = np.array([[1.1, 0.3], [0.0, 0.95]])
    B1 = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    B2 = np.array([[0.0], [1.0]])
    C2 = np.array([[1.0, 0.0]])
    D21 = np.array([[0.0, 0.0, 0.4]])
    C1 = np.vstack([np.eye(2), np.zeros((1, 2))])
    D12 = np.array([[0.0], [0.0], [1.0]])
    P = ncs.nss(A, np.hstack([B1, B2]), np.vstack([C1, C2]),
                np.block([[np.zeros((3, 3)), D12], [D21, np.zeros((1, 1))]]),
                True, nmeas=1, ncon=1)
    K = -ct.dlqr(A, B2, np.eye(2), np.eye(1))[0]
    L = np.array([[0.8], [0.3]])
    CL = ncs.feedback(P, K, controller="estimator", estimator_gain=L)
    # state [x; p] with p the predicted estimate: u = K (p + L (y - C2 p))
    I = np.eye(2)
    Ku_x, Ku_p, Ku_w = K @ L @ C2, K @ (I - L @ C2), K @ L @ D21
    Acl = np.block([[A + B2 @ Ku_x, B2 @ Ku_p],
                    [(A + B2 @ K) @ L @ C2, (A + B2 @ K) @ (I - L @ C2)]])
    Bcl = np.vstack([B1 + B2 @ Ku_w, (A + B2 @ K) @ L @ D21])
    Ccl = np.hstack([C1 + D12 @ Ku_x, D12 @ Ku_p])
    reference = ct.ss(Acl, Bcl, Ccl, D12 @ Ku_w, True)
    assert ncs.norm(CL) == pytest.approx(ct.norm(reference, 2), rel=1e-10)


def _protocol_power(P, seed, trials=3000, steps=400, burn=100, **loop):
    """Mean ``‖z‖²`` of the protocol run packet by packet by the reference
    simulator (:mod:`control_ncs.protocol`), each trial with its own white
    ``w``: the measurement ``y = C2 x + D21 w`` is read when its packet
    arrives; the mean of the per-trial time averages and its standard
    error."""
    rng = np.random.default_rng(seed)
    w = rng.standard_normal((trials, P.B1.shape[1], steps))
    out = simulate_protocol(
        P.A, P.B1, P.B2, P.C1, P.D11, P.D12,
        np.ones((1, P.nmeas)), np.ones((1, P.ncon)),
        # a delayed link carries its loss in its delay law
        0.0 if P.sensor_delay is not None else P.sensor_link,
        0.0 if P.actuator_delay is not None else P.actuator_link,
        loop.pop("gains", None), steps, inputs=w,
        trials=trials, rng=rng, C2=P.C2, D21=P.D21, **loop)
    power = (out["z"][:, :, burn:] ** 2).sum(axis=1).mean(axis=1)
    return power.mean(), power.std(ddof=1) / np.sqrt(trials)


@pytest.mark.parametrize("sensor, actuator, bursty", [
    ("zero", "zero", False), ("hold", "hold", False), ("zero", "hold", True)])
def test_lossy_pi_tracking_loop_agrees_with_the_protocol_simulator(
        sensor, actuator, bursty):
    link = ncs.gilbert_elliott(loss=0.2, burst=2.5) if bursty else 0.2
    _, P = _tracking_plant(sensor_loss=link, actuator_loss=0.1)
    CL = ncs.feedback(P, PI, sensor=sensor, actuator=actuator)
    exact = ncs.norm(CL) ** 2
    mean, se = _protocol_power(
        P, 1, controller="lti", sensor=sensor, actuator=actuator,
        gains=np.zeros((1, 1, 1)),
        controller_system=(PI.A, PI.B, PI.C, PI.D))
    assert abs(mean - exact) < 4 * se, (mean, se, exact)


def test_lossy_estimator_loop_with_sensor_noise_agrees_with_the_protocol():
    P = ncs.nss([[1.2]], [[1.0, 0.0, 1.0]], [[1.0], [0.0], [1.0]],
                [[0, 0, 0], [0, 0, 1.0], [0, 0.5, 0]], True, nmeas=1,
                ncon=1, sensor_loss=0.3, actuator_loss=0.1)
    K, L = np.array([[-0.9]]), np.array([[0.7]])
    CL = ncs.feedback(P, K, controller="estimator", estimator_gain=L)
    exact = ncs.norm(CL) ** 2
    mean, se = _protocol_power(P, 7, controller="estimator",
                               gains=K[None], estimator_gains=L[None])
    assert abs(mean - exact) < 4 * se, (mean, se, exact)


def test_static_gain_over_bursty_links_with_noise_agrees_with_the_protocol():
    P = ncs.nss([[1.1, 0.0], [0.3, 0.5]], [[1.0, 0.0, 1.0], [0.0, 1.0, 0.5]],
                [[1.0, 0.0], [0.0, 1.0], [1.0, 0.0]],
                [[0, 0, 0], [0, 0, 0], [0.3, 0.2, 0]], True, nmeas=1,
                ncon=1, sensor_loss=ncs.gilbert_elliott(loss=0.2, burst=3.0),
                actuator_loss=0.1)
    K = np.array([[[-1.1]]])
    CL = ncs.feedback(P, K)
    exact = ncs.norm(CL) ** 2
    mean, se = _protocol_power(P, 11, gains=K)
    assert abs(mean - exact) < 4 * se, (mean, se, exact)


def test_synthesis_refuses_a_noisy_measurement_and_says_what_to_do():
    P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]],
                [[1.0, 0.0], [0.5, 0.0]], True, nmeas=1, ncon=1)
    with pytest.raises(ControlArgument, match="^P: passivesyn .*D21"):
        ncs.passivesyn(P)
    with pytest.raises(ControlArgument, match="^P: sweeps .*D21"):
        ncs.design_map(P, progress=False)
    with pytest.raises(ValueError, match="^D: .*D22"):
        ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]],
                [[1.0, 0.0], [0.0, 0.3]], True, nmeas=1, ncon=1)
    # the loop itself closes: analysis covers it
    assert ncs.is_mss(ncs.feedback(P, [[-1.0]]))


# -- measurement noise over delayed links --------------------------------------
def _noisy_scalar(**network):
    """``x⁺ = 1.1 x + w1 + u``, ``y = x + 0.5 w2``, ``z = [x; u]``."""
    return ncs.nss([[1.1]], [[1.0, 0.0, 1.0]], [[1.0], [0.0], [1.0]],
                   [[0, 0, 0], [0, 0, 1.0], [0, 0.5, 0]], True, nmeas=1,
                   ncon=1, **network)


@pytest.mark.parametrize("actuator", ["zero", "hold"])
def test_a_noisy_link_that_only_loses_is_the_bernoulli_loop(actuator):
    """A delay law with all its mass at 0 is the Bernoulli link: the
    buffered noisy measurement gives the loop of the noise read at once
    (static gain) and of the noise the LTI controller hears, exactly."""
    delayed = _noisy_scalar(sensor_delay=[0.7], actuator_delay=[0.9])
    lossy = _noisy_scalar(sensor_loss=0.3, actuator_loss=0.1)
    for kwargs in (dict(), dict(sensor="hold")):
        if kwargs:
            K = ct.ss([[0.5]], [[1.0]], [[-0.3]], [[-0.6]], True)
        else:
            K = [[-0.8]]
        a = ncs.norm(ncs.feedback(delayed, K, actuator=actuator, **kwargs))
        b = ncs.norm(ncs.feedback(lossy, K, actuator=actuator, **kwargs))
        assert a == pytest.approx(b, rel=1e-10)


def test_a_noisy_delayed_loop_without_delay_or_loss_is_python_controls():
    G = ct.ss([[1.05]], [[1.0, 0.0, 0.5]], [[1.0], [-1.0]],
              [[0.0, -1.0, 0.0], [0.0, 1.0, 0.0]], True)
    P = ncs.nss(G, nmeas=1, ncon=1, sensor_delay=ncs.random_delay([1.0],
                                                                   buffer=2))
    CL = ncs.feedback(P, PI)
    assert ncs.norm(CL) == pytest.approx(ct.norm(G.lft(PI, 1, 1), 2),
                                         rel=1e-10)


@pytest.mark.parametrize("controller", ["static", "lti"])
def test_noisy_measurements_over_a_delayed_link_match_the_protocol(
        controller):
    """Packets carry y = C2 x + D21 w and arrive late: the buffered noise
    (w_{k-a} in the loop state) against the time-stamped simulator."""
    P = _noisy_scalar(sensor_delay=[0.5, 0.3, 0.1], actuator_delay=[0.9])
    if controller == "static":
        K = np.array([[[-0.8]], [[-0.6]], [[-0.4]]])
        CL = ncs.feedback(P, K)
        loop = dict(gains=K)
    else:
        C = ct.ss([[0.5]], [[1.0]], [[-0.3]], [[-0.6]], True)
        CL = ncs.feedback(P, C)
        loop = dict(controller="lti", gains=np.zeros((1, 1, 1)),
                    controller_system=(C.A, C.B, C.C, C.D))
    assert CL.nstates > 3                  # x, x[k-1], x[k-2], w[k-1], ...
    exact = ncs.norm(CL) ** 2
    mean, se = _protocol_power(P, 5, sensor_delay=P.sensor_delay,
                               actuator_delay=P.actuator_delay, **loop)
    assert abs(mean - exact) < 4 * se, (mean, se, exact)


def test_h2syn_with_a_noisy_measurement_reaches_the_closed_forms_optimum():
    """The static gain reads the noise: ``‖G‖₂² = S + q k² (S + d²)`` with
    ``S = (1 + q k² d²) / (1 - α a² - q (a + k)²)``, minimised over ``k``
    by a bounded scalar search; h2syn's local search on the exact norm
    (its gradient through the noise's way in) reaches it."""
    from scipy.optimize import minimize_scalar
    a, d, loss = 1.1, 0.5, 0.3
    P = ncs.nss([[a]], [[1.0, 0.0, 1.0]], [[1.0], [0.0], [1.0]],
                [[0, 0, 0], [0, 0, 1.0], [0, d, 0]], True, nmeas=1, ncon=1,
                actuator_loss=loss)
    q = 1 - loss

    def closed_form(k):
        den = 1 - loss * a * a - q * (a + k) ** 2
        if den <= 0:
            return np.inf
        S = (1 + q * (k * d) ** 2) / den
        return S + q * k * k * (S + d * d)

    best = minimize_scalar(closed_form, bounds=(-2.0, 0.0), method="bounded",
                           options=dict(xatol=1e-12))
    K, CL, h2 = ncs.h2syn(P)
    assert K.result.route == "local"
    assert h2 ** 2 == pytest.approx(best.fun, rel=1e-9)
    assert K.gains[0, 0, 0] == pytest.approx(best.x, abs=1e-5)
    K, CL, gamma = ncs.hinfsyn(P)
    assert gamma == ncs.l2_gain(ncs.feedback(P, K)).gamma
    assert gamma <= ncs.l2_gain(ncs.feedback(P, [[best.x]])).gamma


def test_noisy_design_is_written_for_the_static_gain():
    P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]],
                [[1.0, 0.0], [0.5, 0.0]], True, nmeas=1, ncon=1)
    with pytest.raises(ControlArgument, match="^P: design with measurement "
                                              "noise .*static gain"):
        ncs.h2syn(P, controller="predictor")


def test_h2_design_over_a_noisy_delayed_link_counts_the_noise():
    """The static gain reads the noise with each measurement, the fresh one
    at once and the buffered ones from the loop state: h2syn designs on
    that loop (its figure the exact norm of feedback's loop) and does at
    least as well as the design that ignores the noise; passivesyn's
    programs do not cover a gain on the noise and refuse."""
    P = _noisy_scalar(sensor_delay=[0.5, 0.3, 0.1])
    with pytest.raises(ControlArgument, match="^P: .*D21"):
        ncs.passivesyn(P)
    K, CL, h2 = ncs.h2syn(P)
    assert h2 == pytest.approx(ncs.norm(ncs.feedback(P, K)), rel=1e-12)
    quiet = P.with_network(D=np.array([[0, 0, 0], [0, 0, 1.0], [0, 0, 0]]))
    blind = ncs.h2syn(quiet)[0]
    assert h2 <= ncs.norm(ncs.feedback(P, blind)) * (1 + 1e-9)
