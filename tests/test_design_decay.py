"""h2syn and hinfsyn keep the loop away from the edge of stability when
asked (``decay=``), and say when the program was only sufficient.

The DC motor ``1000/(s(s+1))`` sampled at 10 ms, ``z`` weighting the speed
and the input but not the angle: the optimal loops leave the angle's
integrator at the edge of mean-square stability.
"""

import control as ct
import numpy as np
import pytest

import control_ncs as ncs


def _motor(**network):
    G = ct.sample_system(ct.ss([[0, 1], [0, -1.0]], [[0], [1000.0]],
                               [[1, 0]], [[0]]), 0.01)
    B = np.hstack([G.B, G.B])                      # w enters with u
    C = np.vstack([[0, 1.0], [0, 0], np.eye(2)])   # z = [speed; u], y = x
    D = np.zeros((4, 2))
    D[1, 1] = 1.0
    return ncs.nss(G.A, B, C, D, 0.01, nmeas=2, ncon=1, **network)


@pytest.mark.parametrize("design", [ncs.h2syn, ncs.hinfsyn])
def test_without_decay_the_optimum_sits_at_the_edge(design):
    K, CL, value = design(_motor())
    assert 1 - 1e-5 < ncs.ms_radius(CL) < 1.0
    assert K.result.exact and K.result.decay == 1.0


@pytest.mark.parametrize("design", [ncs.h2syn, ncs.hinfsyn])
def test_a_decay_bound_keeps_the_loop_inside_it(design):
    K, CL, value = design(_motor(), decay=0.999)
    bracket = ncs.ms_radius(CL, bracket=True)
    assert bracket.upper < 0.999 ** 2
    assert not K.result.exact and "sufficient" in K.result.note
    # the figure is still the returned loop's own, and costs a little more
    free = design(_motor())[2]
    assert value >= free * (1 - 1e-9)
    if design is ncs.h2syn:
        assert value == pytest.approx(ncs.norm(CL), rel=1e-12)
    else:
        assert value == pytest.approx(ncs.l2_gain(CL).gamma, rel=1e-9)


def test_the_local_search_keeps_to_the_decay_bound():
    P = _motor(actuator_loss=0.1)
    K, CL, h2 = ncs.h2syn(P, actuator="hold", decay=0.995)
    assert K.result.route == "local"
    assert ncs.ms_radius(CL, bracket=True).upper < 0.995 ** 2


def test_a_decay_bound_no_gain_meets_is_proven_or_said_not_found():
    with pytest.raises(ncs.SynthesisError) as info:
        ncs.h2syn(_motor(actuator_loss=0.9), decay=0.5)
    assert info.value.reason in ("infeasible", "not_mss", "solver_failed")
