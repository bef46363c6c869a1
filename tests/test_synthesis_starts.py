"""The local searches' starts and refutations, against independent routes.

The full-information H2 start from the periodic Riccati recursion against
the exact H2 program (SDP); the constant gain over a delayed link against
python-control's LQ gain closed by ``feedback``; the cheap bound on the
rate of the part no gain reaches against the certified ``ms_radius``.
"""

from dataclasses import replace

import numpy as np
import pytest

import control as ct
import control_ncs as ncs
from control_ncs.lmi import DEFAULT_MARGIN, h2_model, solve
from control_ncs.strategies import build
from control_ncs.synthesis._local import Loop, _rate_upper
from control_ncs.synthesis.norms import _riccati_h2_gain
from control_ncs.synthesis.refine import delay_free_gain


def _scheduled(n=4, seed=0):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    A *= 1.05 / max(abs(np.linalg.eigvals(A)))
    B = np.hstack([np.eye(n), rng.standard_normal((n, 2))])
    C = np.vstack([np.eye(n), np.zeros((2, n)), np.eye(n)])
    D = np.zeros((2 * n + 2, n + 2))
    D[n:n + 2, n:] = np.eye(2)
    schedule = np.zeros((n // 2, n), int)
    for k in range(n // 2):
        schedule[k, 2 * k:2 * k + 2] = 1
    return ncs.nss(A, B, C, D, True, nmeas=n, ncon=2, actuator_loss=0.2,
                   sensor_schedule=schedule)


@pytest.mark.parametrize("seed", [0, 1])
def test_the_riccati_start_is_the_h2_programs_optimum(seed):
    plant = build(_scheduled(seed=seed), "static", "zero")
    nx = plant.shape["nx"]
    full = replace(plant, E=np.broadcast_to(np.eye(nx), (plant.period, nx,
                                                         nx)),
                   Ew=None, Gw=None)
    G = _riccati_h2_gain(plant)
    model = h2_model(full, DEFAULT_MARGIN)
    solve(model.problem)
    h2_riccati = ncs.norm(full.close(G))
    h2_sdp = ncs.norm(full.close(model.gains()))
    # the recursion's gain is optimal: no worse than the program's (whose
    # objective bounds the optimum from above, to the solver's accuracy)
    assert h2_riccati <= h2_sdp * (1 + 1e-9)
    assert h2_riccati == pytest.approx(np.sqrt(model.problem.value),
                                       rel=1e-6)


@pytest.mark.parametrize("controller", ["static", "predictor"])
def test_the_constant_start_is_the_delay_free_lq_gain(controller):
    A = np.array([[1.05, 0.3], [0.0, 0.8]])
    P = ncs.nss(A, np.array([[1.0, 1.0], [0.0, 0.5]]),
                np.array([[1.0, 0.0], [0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]),
                np.array([[1.0, 0.0], [0.0, 0.0], [0.0, 0.0], [0.0, 0.0]]),
                True, nmeas=2, ncon=1, sensor_delay=[0.5, 0.3, 0.2])
    plant = build(P, controller, "zero")
    loop = Loop(plant, plant.probabilities, plant.transition)
    x = delay_free_gain(plant, loop)
    Kd = ct.dlqr(A, P.B2, np.eye(2), np.eye(1))[0]
    # the same loop as feedback closes with -Kd on every age (or on the
    # predictor's estimate): the same exact rate
    CL = ncs.feedback(P, -Kd, controller=controller)
    assert np.exp(loop.rate(x)[0]) == pytest.approx(ncs.ms_radius(CL),
                                                    rel=1e-9)


def test_the_cheap_rate_bound_is_above_the_certified_rate():
    rng = np.random.default_rng(5)
    A = 0.5 * rng.standard_normal((1, 3, 4, 4))
    T = np.array([[[0.5, 0.5, 0.0], [0.2, 0.8, 0.0], [1.0, 0.0, 0.0]]])
    sub = ncs.jss(A[0], np.zeros((3, 4, 1)), np.zeros((3, 1, 4)),
                  np.zeros((3, 1, 1)), None, transition=T[0])
    exact = ncs.ms_radius(sub)
    for bound in (exact * 1.5, 0.999):
        upper = _rate_upper(A, None, T, bound)
        assert exact <= upper * (1 + 1e-12) and upper < bound
    # below the rate no bound is found under it
    assert not _rate_upper(A, None, T, 0.9 * exact) < 0.9 * exact
