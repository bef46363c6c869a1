"""h2syn on a plant sampled from a continuous one minimises the
continuous-time cost between the samples (Jitterbug's J).

Checked against the closed forms of the sampled LQ problem: the discrete
Riccati equation with the cross term of the sampled loss (Åström and
Wittenmark), on the plant and, with a constant input delay, on the state
augmented with the held input (Jitterbug's ``lqgdesign`` for state
feedback); the figure returned is ``√J`` measured on the returned loop by
``ncs.cost``, and the open loop whose H2 norm is ``J`` agrees with
``ncs.cost`` on any gain.
"""


import control as ct
import numpy as np
import pytest
import scipy.linalg

import control_ncs as ncs
from control_ncs.intersample import (cost_open_loop, delay_augmented_loss,
                                     sampled_loss, sampled_noise)


def _servo(h, **kw):
    """``ẍ = -0.5 ẋ + u + w``, ``z = [x; 0.3 u]`` weighted, ``y = x``."""
    A = np.array([[0.0, 1.0], [0.0, -0.5]])
    B1 = np.array([[0.0], [1.0]])
    B2 = np.array([[0.0], [1.0]])
    C1 = np.array([[1.0, 0.0]])
    D12 = np.array([[0.3]])
    G = ct.ss(A, np.hstack([B1, B2]), np.vstack([C1, np.eye(2)]),
              np.vstack([np.hstack([[[0.0]], D12]), np.zeros((2, 2))]))
    return ncs.nss(G, nmeas=2, ncon=1, dt=h, **kw), (A, B1, B2, C1, D12)


def test_without_delay_the_design_is_the_sampled_lq_optimum():
    h = 0.4
    P, (A, B1, B2, C1, D12) = _servo(h)
    K, CL, value = ncs.h2syn(P)
    Q1, Q12, Q2 = sampled_loss(A, B2, C1, D12, h)
    Phi = scipy.linalg.expm(A * h)
    M = np.zeros((3, 3))
    M[:2, :2], M[:2, 2:] = A, B2
    Gamma = scipy.linalg.expm(M * h)[:2, 2:]
    R1d, c = sampled_noise(A, B1, C1, h)
    X = scipy.linalg.solve_discrete_are(Phi, Gamma, Q1, Q2, s=Q12)
    best = (np.trace(X @ R1d) + c) / h
    assert K.result.route == "program" and K.result.exact
    # measured on the returned loop: never below the optimum, and the
    # program's solution within its accuracy of it
    assert best * (1 - 1e-12) <= value ** 2 <= best * (1 + 1e-7)
    assert value ** 2 == pytest.approx(ncs.cost(CL).cost, rel=1e-12)
    # the optimal gain of the sampled LQ problem, u = -L x (package: +)
    L = np.linalg.solve(Q2 + Gamma.T @ X @ Gamma,
                        Gamma.T @ X @ Phi + Q12.T)
    assert np.allclose(K.gains[0], -L, rtol=1e-4, atol=1e-4)


def test_with_a_constant_delay_the_predictor_reaches_the_augmented_optimum():
    """Reading the state and the held input (the predictor with a hold
    actuator, y = x), the design is the Riccati optimum on [x; u_{k-1}]; a
    static gain that does not read u_{k-1} cannot do better."""
    h, tau = 0.4, 0.15
    P, (A, B1, B2, C1, D12) = _servo(h, input_delay=([tau], [1.0]))
    Pa, Ga, Q1, Q12, Q2 = delay_augmented_loss(A, B2, C1, D12, h, tau)
    R1d, c = sampled_noise(A, B1, C1, h)
    X = scipy.linalg.solve_discrete_are(Pa, Ga, Q1, Q2, s=Q12)
    R1a = scipy.linalg.block_diag(R1d, np.zeros((1, 1)))
    best = (np.trace(X @ R1a) + c) / h
    K, CL, value = ncs.h2syn(P, controller="predictor", actuator="hold")
    assert value ** 2 == pytest.approx(best, rel=1e-7)
    assert value ** 2 == pytest.approx(ncs.cost(CL).cost, rel=1e-12)
    Ks, CLs, static = ncs.h2syn(P)
    assert static ** 2 >= best * (1 - 1e-9)


@pytest.mark.parametrize("network", [
    dict(), dict(actuator_loss=0.2),
    dict(input_delay=([0.0, 0.2], [0.5, 0.5])),
    dict(sensor_loss=0.1, input_delay=([0.0, 0.2], [0.5, 0.5]))])
@pytest.mark.parametrize("controller,actuator", [
    ("static", "zero"), ("static", "hold"), ("predictor", "hold")])
def test_the_cost_open_loop_has_the_cost_as_its_h2_norm(network, controller,
                                                        actuator):
    P, _ = _servo(0.3, **network)
    plant = ncs.build(P, controller, actuator)
    rng = np.random.default_rng(5)
    K = -np.abs(rng.standard_normal(plant.gain_shape())) * 0.5
    CL = plant.close(K)
    if not ncs.ms_radius(CL) < 1:
        pytest.skip("this gain does not stabilise the loop")
    J = ncs.cost(CL).cost
    assert ncs.norm(cost_open_loop(plant).close(K)) ** 2 == pytest.approx(
        J, rel=1e-10)


def test_a_discrete_plant_keeps_its_h2_design():
    P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [0.0], [1.0]],
                [[0.0, 0.0], [0.0, 1.0], [0.0, 0.0]], True, nmeas=1,
                ncon=1, actuator_loss=0.5)
    K, CL, h2 = ncs.h2syn(P)
    assert h2 ** 2 == pytest.approx(5.762615414813, rel=1e-8)
    assert K.result.note == ""
    with pytest.raises(ValueError, match="discrete plant"):
        cost_open_loop(ncs.build(P))
