"""Modes no transition enters are never drawn (theory: Markov losses).

A Markov mode that no mode moves into is occupied at most at the first
step, and never under the stationary law: the builder drops it. Checked
against the chain with it (the mean-square rate and the H2 norm, two
independent figures of the second-moment operator), against the closed
form of the predictor over a delayed link (theory: delays), and on the
loops a design certifies: the loop the local search certifies is the one
``feedback`` builds, mode for mode.
"""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import control_ncs as ncs
from control_ncs.modes import entered_modes, keep_modes


def _chain_with_unentered(rng, N, M, dead):
    """A periodic chain whose last ``dead`` modes of every phase receive
    nothing (their columns are zero) but move on like any other."""
    T = rng.dirichlet(np.ones(M - dead), size=(N, M))
    T = np.concatenate([T, np.zeros((N, M, dead))], axis=2)
    return T


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), N=st.integers(1, 3),
       M=st.integers(2, 5), n=st.integers(1, 3), data=st.data())
def test_dropping_modes_nothing_enters_keeps_the_rate_and_the_norm(
        seed, N, M, n, data):
    dead = data.draw(st.integers(1, M - 1))
    rng = np.random.default_rng(seed)
    T = _chain_with_unentered(rng, N, M, dead)
    A = rng.standard_normal((N, M, n, n))
    A *= 0.9 / np.max(np.abs(np.linalg.eigvals(A)), axis=-1)[..., None, None]
    # the modes never drawn may be wildly unstable: they are a zero block
    A[:, M - dead:] *= 5.0
    B = rng.standard_normal((N, M, n, 1))
    C = rng.standard_normal((N, M, 1, n))
    D = rng.standard_normal((N, M, 1, 1))
    full = ncs.jss(A, B, C, D, transition=T)
    keep = entered_modes(T)
    assert keep[:, :M - dead].all() and not keep[:, M - dead:].any()
    mats, TK, p, index = keep_modes([A, B, C, D], T, full.modes.probabilities,
                                    keep)
    assert TK.shape == (N, M - dead, M - dead)
    assert np.allclose(TK.sum(axis=2), 1.0)
    assert np.allclose(p, full.modes.probabilities[:, :M - dead])
    small = ncs.jss(*mats, transition=TK)
    assert ncs.ms_radius(small) == pytest.approx(ncs.ms_radius(full),
                                                 rel=1e-9, abs=1e-12)
    if ncs.ms_radius(full) < 1:
        assert ncs.norm(small) == pytest.approx(ncs.norm(full), rel=1e-8)


def test_a_mode_entered_only_from_a_dropped_mode_is_dropped_too():
    # 2 -> 1 -> 0 <-> 0: nothing enters 2, then only 2 entered 1
    T = np.array([[[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]])
    assert entered_modes(T).tolist() == [[True, False, False]]
    # the loss-free mode is kept whatever enters it
    assert entered_modes(T, np.array([1])).tolist() == [[True, True, False]]


def test_phases_with_fewer_modes_repeat_one_that_nothing_enters():
    T = np.array([[[0.5, 0.5, 0.0], [0.5, 0.5, 0.0], [0.2, 0.8, 0.0]],
                  [[0.3, 0.3, 0.4]] * 3])
    keep = entered_modes(T)
    assert keep.tolist() == [[True, True, True], [True, True, False]]
    mats, TK, p, index = keep_modes([np.arange(6.0).reshape(2, 3, 1, 1)], T,
                                    np.full((2, 3), 1 / 3), keep)
    assert [i.tolist() for i in index] == [[0, 1, 2], [0, 1, 0]]
    assert np.all(TK[0][:, 2] == 0)          # the copy receives nothing
    assert np.allclose(TK.sum(axis=2), 1.0)


def _passive_scalar(**network):
    """x⁺ = 1.2x + w + u, z = x + 0.5w, y = x."""
    return ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]],
                   [[0.5, 0.0], [0.0, 0.0]], True, nmeas=1, ncon=1,
                   **network)


@pytest.mark.parametrize("controller", ["static", "predictor"])
def test_a_delayed_link_builds_only_modes_it_draws(controller):
    P = _passive_scalar(sensor_delay=[0.5, 0.3, 0.1])
    plant = ncs.build(P, controller)
    assert plant.transition is not None
    assert np.all(plant.probabilities > 0)
    assert np.allclose(plant.transition.sum(axis=2), 1.0)


@pytest.mark.parametrize("pmf", [[0.5, 0.3, 0.1], [0.1, 0.2, 0.6],
                                 [0.0, 0.0, 0.9]])
def test_the_deadbeat_predictor_keeps_its_closed_form(pmf):
    """Scalar ``x⁺ = a x + u`` (theory: delays): the predictor with the
    deadbeat gain has the second-moment radius ``ℓ a²`` whatever the
    pmf (``ℓ`` the loss), on the loop without its never-drawn modes.
    The last pmf never delivers a packet of age 0 or 1: the loss-free
    mode (age 0) is kept for what the designs read of it, and the modes
    it leads to, all of probability 0."""
    a = 1.5
    P = ncs.nss([[a]], [[0.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0], [0.0, 0.0]],
                True, nmeas=1, ncon=1, sensor_delay=pmf)
    CL = ncs.feedback(P, [[-a]], controller="predictor")
    drawn = CL.modes.probabilities > 0
    assert drawn.all() if pmf[0] > 0 else drawn.sum() == 2
    loss = 1.0 - sum(pmf)
    assert ncs.ms_radius(CL) == pytest.approx(loss * a ** 2, rel=1e-9,
                                              abs=1e-12)


def test_the_search_certifies_the_loop_feedback_builds():
    """The design's certificate is one of ``feedback(P, K)``'s loop: the
    same states and modes, every mode drawn, and the same level."""
    P = _passive_scalar(sensor_delay=[0.1, 0.2, 0.6])
    K, CL, eta = ncs.passivesyn(P, eta=-50.0,
                                initial_gain=[[[-2.0, -2.0, -2.0]]])
    again = ncs.feedback(P, K)
    assert CL.modes.A.shape == again.modes.A.shape
    assert CL.modes.transition.shape == again.modes.transition.shape
    assert np.all(again.modes.probabilities > 0)
    cert = K.result.certificate
    assert cert.verified
    assert cert.P.shape[:2] == again.modes.probabilities.shape
    assert ncs.check_certificate(again, cert.P, eta).verified
