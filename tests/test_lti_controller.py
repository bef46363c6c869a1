"""A discrete-time LTI controller in the networked loop.

``feedback(P, K)`` with a ``control.StateSpace`` / ``TransferFunction``
controller builds the jump system ``[x; xc; ŷ; u⁻]``; these tests check it
against python-control's own closed loop (loss-free) and against the
event-level protocol simulator (lossy, scheduled), and that the analysis
functions run on it.
"""

import control as ct
import numpy as np
import pytest
from control.exception import ControlArgument, ControlDimension

from control_ncs import (feedback, get_input_ff_index, ispassive, moments,
                         ms_radius, nss, schedule_plot, simulate)
from control_ncs.protocol import simulate_protocol

from helpers import assert_mean_within, fourth_moment_rate

T = 30
TRIALS = 20000
N_SE = 5


def output_plant(rng, *, n=3, m1=1, m2=2, p2=2, radius=1.05, **network):
    """A random plant measuring ``y = C2 x`` with ``p2 < n`` sensors."""
    A = rng.standard_normal((n, n))
    A *= radius / max(abs(np.linalg.eigvals(A)))
    B = rng.standard_normal((n, m1 + m2))
    C = np.vstack([rng.standard_normal((m1, n)), rng.standard_normal((p2, n))])
    D = np.zeros((m1 + p2, m1 + m2))
    D[:m1, :m1] = 0.4
    D[:m1, m1:] = 0.3 * rng.standard_normal((m1, m2))
    return nss(A, B, C, D, True, nmeas=p2, ncon=m2, **network)


def stabilising_controller(P):
    """An observer-based controller (u = K y in positive feedback, the LQR
    and Kalman gains negated as python-control designs them)."""
    n = P.nstates
    Klqr, _, _ = ct.dlqr(P.A, P.B2, np.eye(n), np.eye(P.ncon))
    Lt, _, _ = ct.dlqr(P.A.T, P.C2.T, np.eye(n), np.eye(P.C2.shape[0]))
    L = Lt.T
    # x̂⁺ = A x̂ + B2 u + L (y - C2 x̂), u = -Klqr x̂
    Ac = P.A - P.B2 @ Klqr - L @ P.C2
    return ct.ss(Ac, L, -Klqr, np.zeros((P.ncon, P.C2.shape[0])), True)


def batch_reactor(h=0.05, **network):
    """The unstable batch reactor and its PI controller (Walsh, Ye and
    Bushnell 2002), both discretised with a zero-order hold at step h."""
    A = np.array([[1.38, -0.2077, 6.715, -5.676],
                  [-0.5814, -4.29, 0, 0.675],
                  [1.067, 4.273, -6.654, 5.893],
                  [0.048, 4.273, 1.343, -2.104]])
    B = np.array([[0, 0], [5.679, 0], [1.136, -3.146], [1.136, 0]])
    C = np.array([[1.0, 0, 1, -1], [0, 1, 0, 0]])
    G = ct.ss(A, np.hstack([B, B]), np.vstack([C, C]), 0).sample(h)
    P = nss(G.A, G.B, G.C, np.zeros((4, 4)), h, nmeas=2, ncon=2, **network)
    # u = Cc ∫y + Dc y, positive feedback as written in the literature
    K = ct.ss(np.zeros((2, 2)), [[0, 1], [1, 0]], [[-2, 0], [0, 8]],
              [[0, -2], [5, 0]]).sample(h)
    return P, K


# -- loss-free: python-control's own closed loop -------------------------
@pytest.mark.parametrize("sensor, actuator", [("zero", "zero"),
                                              ("hold", "hold")])
def test_loss_free_mean_is_python_controls_lft(sensor, actuator):
    P = output_plant(np.random.default_rng(1))
    K = stabilising_controller(P)
    CL = feedback(P, K, sensor=sensor, actuator=actuator)
    reference = ct.ss(P).lft(K)               # u = K y: positive feedback
    t = np.arange(40)
    ours = ct.impulse_response(CL, t).outputs
    theirs = ct.impulse_response(reference, t).outputs
    assert np.max(abs(ours - theirs)) < 1e-12 * max(1, np.max(abs(theirs)))
    assert ms_radius(CL) == pytest.approx(
        max(abs(np.linalg.eigvals(reference.A))) ** 2, rel=1e-9)


def test_transfer_function_controller_is_its_realisation():
    P = nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0], [0.0, 0.0]],
            True, nmeas=1, ncon=1, sensor_loss=0.1, actuator_loss=0.2)
    Ktf = ct.tf([-0.9, 0.3], [1, -0.5], True)
    assert ms_radius(feedback(P, Ktf)) == pytest.approx(
        ms_radius(feedback(P, ct.ss(Ktf))), rel=1e-12)


def test_controller_without_states_is_the_static_gain():
    """Carrying the received ŷ in the state shifts the mode's time index,
    not the loop: rate and mean response equal the static gain's."""
    P = output_plant(np.random.default_rng(2), sensor_loss=0.2,
                     actuator_loss=0.1, sensor_schedule=[[1, 1], [0, 1]],
                     actuator_schedule=[[1, 1], [1, 0]])
    D = -0.2 * np.ones((2, 2))
    static = feedback(P, D)
    lti = feedback(P, ct.ss([], [], [], D, True))
    assert ms_radius(lti) == pytest.approx(ms_radius(static), rel=1e-9)
    w = np.ones((1, 20))
    assert np.allclose(moments(lti, 20, inputs=w).outputs_mean,
                       moments(static, 20, inputs=w).outputs_mean, atol=1e-12)


# -- lossy and scheduled: the event-level protocol -------------------------
def protocol_case(sensor, actuator):
    P = output_plant(np.random.default_rng(3), n=2, m2=1, radius=1.0,
                     sensor_schedule=[[1, 1], [0, 1], [1, 0]],
                     actuator_schedule=[[1], [0], [1]], sensor_loss=0.2,
                     actuator_loss=0.15)
    K = stabilising_controller(P.with_network(sensor_loss=0.0,
                                              actuator_loss=0.0))
    return P, K


@pytest.mark.parametrize("sensor, actuator", [
    ("zero", "zero"), ("zero", "hold"), ("hold", "zero"), ("hold", "hold")])
def test_exact_moments_match_the_event_level_simulation(sensor, actuator):
    """Mean and second moment of x and mean of z over 30 steps (x0 = 0, so
    the first received value is 0; xc0 ≠ 0 and w ≠ 0): 20000 protocol
    paths, every entry within 5 standard errors of the exact moments."""
    P, K = protocol_case(sensor, actuator)
    CL = feedback(P, K, sensor=sensor, actuator=actuator)
    assert ms_radius(CL) < 1
    assert (fourth_moment_rate(CL) / ms_radius(CL) ** 2) ** T < 10
    xc0 = np.array([0.5, -1.0])
    xi0 = np.zeros(len(CL.jump_states))
    xi0[2:4] = xc0                               # [x; xc; ŷ; u⁻]
    w = np.sin(0.4 * np.arange(T + 1))[None]
    mom = moments(CL, T + 1, inputs=w, initial_state=xi0)
    sim = simulate_protocol(
        P.A, P.B1, P.B2, P.C1, P.D11, P.D12, P.sensor_schedule.pattern,
        P.actuator_schedule.pattern, 0.2, 0.15, None, T, controller="lti",
        actuator=actuator, sensor=sensor, C2=P.C2,
        controller_system=(K.A, K.B, K.C, K.D), inputs=w[:, :T],
        initial_controller_state=xc0, trials=TRIALS,
        rng=np.random.default_rng(7))
    x = sim["x"]
    assert_mean_within(x, mom.states_mean[:2], N_SE)
    assert_mean_within(np.einsum("sit,sjt->sijt", x, x),
                       mom.states_second_moment[:2, :2], N_SE)
    assert_mean_within(sim["xc"], mom.states_mean[2:4], N_SE)
    assert_mean_within(sim["z"], mom.outputs_mean[:, :T], N_SE)


@pytest.mark.parametrize("sensor, actuator", [("zero", "zero"),
                                              ("hold", "hold")])
def test_loss_free_protocol_path_is_the_mean(sensor, actuator):
    P, K = protocol_case(sensor, actuator)
    P = P.with_network(sensor_loss=0.0, actuator_loss=0.0)
    CL = feedback(P, K, sensor=sensor, actuator=actuator)
    xi0 = np.zeros(len(CL.jump_states))
    xi0[2:4] = [1.0, 0.5]
    w = np.cos(0.3 * np.arange(T + 1))[None]
    mom = moments(CL, T + 1, inputs=w, initial_state=xi0)
    sim = simulate_protocol(
        P.A, P.B1, P.B2, P.C1, P.D11, P.D12, P.sensor_schedule.pattern,
        P.actuator_schedule.pattern, 0.0, 0.0, None, T, controller="lti",
        actuator=actuator, sensor=sensor, C2=P.C2,
        controller_system=(K.A, K.B, K.C, K.D), inputs=w[:, :T],
        initial_controller_state=[1.0, 0.5], rng=np.random.default_rng(0))
    assert np.allclose(sim["x"][0], mom.states_mean[:2], atol=1e-10)
    assert np.allclose(sim["z"][0], mom.outputs_mean[:, :T], atol=1e-10)
    assert np.allclose(mom.states_cov, 0, atol=1e-10)


def test_hold_sensor_keeps_the_last_value_zero_sensor_does_not():
    """One sensor, sending every other step, no losses: with 'hold' the
    static controller u = -y sees y at the silent step too."""
    P = nss([[0.5]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0], [0.0, 0.0]],
            True, nmeas=1, ncon=1, sensor_schedule=[1, 0])
    K = ct.ss([], [], [], [[-1.0]], True)
    zero = feedback(P, K).modes.A[1, 0][0, 0]
    hold = feedback(P, K, sensor="hold").modes.A[1, 0]
    assert zero == pytest.approx(0.5)                     # x⁺ = 0.5 x
    assert hold[0].tolist() == pytest.approx([0.5, -1.0])  # x⁺ = 0.5x - ŷ


# -- everything downstream runs on it ---------------------------------------
def test_analysis_functions_run_on_an_lti_loop():
    P = output_plant(np.random.default_rng(4), radius=0.9, sensor_loss=0.1,
                     actuator_loss=0.1, sensor_schedule=[[1, 1], [1, 0]])
    K = stabilising_controller(P)
    CL = feedback(P, K, sensor="hold")
    assert ms_radius(CL) < 1
    paths = simulate(CL, 20, trials=50, seed=1)
    assert paths.outputs.shape == (1, 50, 20)     # (outputs, trials, time)
    mom = moments(CL, 20, inputs=np.ones((1, 20)))
    assert np.all(np.isfinite(mom.outputs_mean))
    nu = get_input_ff_index(CL)
    assert np.isfinite(nu)
    assert ispassive(CL, ifp_index=nu - 0.05)
    assert not ispassive(CL, ifp_index=nu + 0.05)
    assert schedule_plot(P) is not None


# -- the batch reactor over a lossy network ----------------------------------
def test_batch_reactor_pi_loop_is_stable_loss_free():
    P, K = batch_reactor()
    assert max(abs(np.linalg.eigvals(P.A))) > 1          # unstable plant
    assert ms_radius(feedback(P, K)) < 0.93


def test_batch_reactor_pi_loop_loses_mean_square_stability_at_half_loss():
    """Both links losing 50 % (zero strategies): the PI loop is no longer
    mean-square stable; at 20 % it still is."""
    P, K = batch_reactor()
    lossy = P.with_network(sensor_loss=0.2, actuator_loss=0.2)
    assert ms_radius(feedback(lossy, K)) < 0.94
    lossy = P.with_network(sensor_loss=0.5, actuator_loss=0.5)
    assert ms_radius(feedback(lossy, K)) > 1.01


# -- bad input ----------------------------------------------------------------
def scalar():
    return nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0], [0.0, 0.0]],
               0.1, nmeas=1, ncon=1)


def test_continuous_time_controller_is_refused_with_what_to_do():
    with pytest.raises(ValueError, match=r"K: continuous-time.*sample"):
        feedback(scalar(), ct.tf([1], [1, 1]))


def test_controller_with_another_dt_is_refused():
    with pytest.raises(ValueError, match=r"K: sampling periods differ.* 0.1, "
                       r"K has dt = 0.2"):
        feedback(scalar(), ct.ss([[0.5]], [[1]], [[1]], [[0]], 0.2))


def test_controller_of_the_wrong_size_is_refused():
    with pytest.raises(ControlDimension, match=r"K: expected a controller "
                       r"with 1 inputs .* got 2 inputs"):
        feedback(scalar(), ct.ss([[0.5]], [[1, 1]], [[1]], [[0, 0]], 0.1))


def test_sensor_strategy_is_refused_for_a_gain():
    with pytest.raises(ControlArgument, match="sensor: only an LTI"):
        feedback(scalar(), [[-1.0]], sensor="hold")


def test_unknown_sensor_strategy_is_refused():
    with pytest.raises(ControlArgument, match="sensor: expected one of"):
        feedback(scalar(), ct.ss([], [], [], [[-1.0]], 0.1), sensor="last")


def test_lti_controller_kind_needs_a_system():
    with pytest.raises(ControlArgument, match="controller='lti' needs K"):
        feedback(scalar(), [[-1.0]], controller="lti")
