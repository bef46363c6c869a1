"""Bursty (Markov) losses, analysis side (theory: Markov losses).

Closed forms of theory: Markov losses, equal rows against the i.i.d. numbers, dense
against matrix-free, exact moments against two independent samplers (the
package's engine and the event-level protocol), and bad input.
"""

import numpy as np
import control as ct
import pytest
from control.exception import ControlArgument, ControlDimension
from hypothesis import given, settings, strategies as st

import control_ncs as ncs
from control_ncs import (feedback, gilbert_elliott, is_mss, jss, moments,
                         ms_radius, simulate)
from control_ncs.protocol import simulate_protocol

from helpers import (assert_mean_within, plant_state_selector, random_plant,
                     scalar_plant)


def markov_jss(rng, n=2, N=1, M=3, radius=0.8):
    A = rng.standard_normal((N, M, n, n))
    A *= radius / np.max(np.abs(np.linalg.eigvals(A)), axis=-1)[..., None, None]
    B = rng.standard_normal((N, M, n, 1))
    C = rng.standard_normal((N, M, 1, n))
    D = rng.standard_normal((N, M, 1, 1))
    T = rng.dirichlet(np.ones(M), size=(N, M))
    return jss(A, B, C, D, transition=T)


def sample_markov(sys, steps, trials, rng, x0, w):
    """Paths of a Markov jump system written from the definition (theory: Markov losses):
    σ_0 from the initial law, σ_{t+1} ~ T_k[σ_t], one mode at a time."""
    m = sys.modes
    N, M = m.period, m.count
    sigma = rng.choice(M, size=trials, p=m.initial)
    x = np.tile(np.asarray(x0, float), (trials, 1))
    xs = np.empty((trials, x.shape[1], steps))
    zs = np.empty((trials, m.C.shape[2], steps))
    for t in range(steps):
        k = t % N
        wt = np.tile(w[:, t], (trials, 1))
        xs[:, :, t] = x
        zs[:, :, t] = (np.einsum("tij,tj->ti", m.C[k][sigma], x)
                       + np.einsum("tij,tj->ti", m.D[k][sigma], wt))
        x = (np.einsum("tij,tj->ti", m.A[k][sigma], x)
             + np.einsum("tij,tj->ti", m.B[k][sigma], wt))
        u = rng.random(trials)
        cdf = np.cumsum(m.transition[k][sigma], axis=1)
        sigma = np.minimum((u[:, None] >= cdf).sum(axis=1), M - 1)
    return xs, zs


# -- links --------------------------------------------------------------------
def test_gilbert_elliott_by_rates_gives_stationary_loss_burst_and_matrix():
    link = gilbert_elliott(fail=0.05, recover=0.74)
    assert link.loss == pytest.approx(0.05 / 0.79, rel=1e-15)
    assert link.burst == pytest.approx(1 / 0.74, rel=1e-15)
    np.testing.assert_array_equal(link.transition,
                                  [[1 - 0.74, 0.74], [0.05, 0.95]])
    # the stationary law is a left eigenvector of the transition
    pi = np.array([link.loss, 1 - link.loss])
    np.testing.assert_allclose(pi @ link.transition, pi, atol=1e-15)


def test_gilbert_elliott_by_loss_and_burst_is_the_same_chain():
    by_rates = gilbert_elliott(fail=0.05, recover=0.74)
    by_stats = gilbert_elliott(loss=by_rates.loss, burst=by_rates.burst)
    assert by_stats.fail == pytest.approx(0.05, rel=1e-12)
    assert by_stats.recover == pytest.approx(0.74, rel=1e-12)


def test_a_2x2_matrix_is_a_link_in_lost_delivered_order():
    P = scalar_plant(2.0, actuator_loss=[[0.4, 0.6], [0.1, 0.9]])
    assert P.actuator_link == gilbert_elliott(fail=0.1, recover=0.6)
    assert P.actuator_loss == pytest.approx(0.1 / 0.7)
    assert not P.is_iid


@pytest.mark.parametrize("kwargs, error, words", [
    (dict(fail=0.0, recover=0.5), ValueError, "fail"),
    (dict(fail=0.1, recover=0.0), ValueError, "never recovers"),
    (dict(fail=1.5, recover=0.5), ValueError, "fail"),
    (dict(fail=0.1, recover=-0.2), ValueError, "recover"),
    (dict(fail=0.1), ControlArgument, "recover"),
    (dict(fail=0.1, recover=0.5, loss=0.2), ControlArgument, "one pair"),
    (dict(loss=0.0, burst=2.0), ValueError, "loss"),
    (dict(loss=0.2, burst=0.5), ValueError, "burst"),
    (dict(loss=0.9, burst=1.0), ValueError, "fail"),
])
def test_bad_gilbert_elliott_arguments_are_named(kwargs, error, words):
    with pytest.raises(error, match=words):
        gilbert_elliott(**kwargs)


@pytest.mark.parametrize("link, error, words", [
    ([[0.5, 0.6], [0.1, 0.9]], ValueError, "sum to 1"),
    ([[1.2, -0.2], [0.1, 0.9]], ValueError, "non-negative"),
    ([[0.5, 0.5, 0.0], [0.1, 0.9, 0.0]], ControlDimension, "2x2"),
    ([[1.0, 0.0], [0.1, 0.9]], ValueError, "never recovers"),
    ([[0.5, 0.5], [0.0, 1.0]], ValueError, "fail"),
])
def test_bad_link_matrix_in_nss_is_named(link, error, words):
    with pytest.raises(error, match=words) as info:
        scalar_plant(2.0, sensor_loss=link)
    assert "sensor_loss" in str(info.value)


@pytest.mark.parametrize("kwargs, error, words", [
    (dict(transition=[[0.5, 0.6], [0.1, 0.9]]), ValueError, "sum to 1"),
    (dict(transition=[[1.5, -0.5], [0.1, 0.9]]), ValueError, "non-negative"),
    (dict(transition=np.full((3, 3), 1 / 3)), ControlDimension, "M = 2"),
    (dict(transition=[[0.5, 0.5], [0.1, 0.9]], probabilities=[[0.5, 0.5]] * 2),
     ControlDimension, "initial"),
    (dict(), ValueError, "transition"),
])
def test_bad_transition_in_jss_is_named(kwargs, error, words):
    with pytest.raises(error, match=words) as info:
        jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], **kwargs)
    assert "transition" in str(info.value) or "probabilities" in str(info.value)


# -- equal rows are the i.i.d. system ------------------------------------------
def iid_and_equal_rows(rng):
    sys = markov_jss(rng, n=3, N=2, M=3)
    p = rng.dirichlet(np.ones(3), size=2)
    m = sys.modes
    iid = jss(m.A, m.B, m.C, m.D, p)
    rows = np.repeat(np.roll(p, -1, axis=0)[:, None, :], 3, axis=1)
    return iid, jss(m.A, m.B, m.C, m.D, transition=rows)


def test_equal_rows_give_exactly_the_iid_system():
    iid, rows = iid_and_equal_rows(np.random.default_rng(1))
    assert rows.modes.is_iid and rows.equals(iid)
    assert ms_radius(rows) == ms_radius(iid)
    assert ms_radius(rows, method="matrix-free") == ms_radius(
        iid, method="matrix-free")
    w = np.sin(np.arange(12))[None]
    a, b = (moments(s, 12, inputs=w, initial_state=1.0) for s in (iid, rows))
    np.testing.assert_array_equal(a.states_second_moment, b.states_second_moment)
    np.testing.assert_array_equal(a.outputs_mean, b.outputs_mean)
    sa, sb = (simulate(s, 12, inputs=w, initial_state=1.0, trials=50, seed=3)
              for s in (iid, rows))
    np.testing.assert_array_equal(sa.outputs, sb.outputs)


def test_bernoulli_links_given_as_chains_give_the_iid_loop():
    K = [[-1.5]]
    P = scalar_plant(2.0, sensor_loss=0.2, actuator_loss=0.1)
    Q = scalar_plant(2.0, sensor_loss=[[0.2, 0.8], [0.2, 0.8]],
                     actuator_loss=gilbert_elliott(fail=0.1, recover=0.9))
    assert Q.is_iid and Q.mode_transition() is None
    assert feedback(Q, K).equals(feedback(P, K))
    assert ms_radius(feedback(Q, K)) == ms_radius(feedback(P, K))


def test_a_markov_chain_on_the_stationary_law_keeps_iid_marginals_apart():
    """Same stationary law, different futures: the chain is not i.i.d. and
    its ms_radius differs from the Bernoulli one (theory: Markov losses)."""
    P = scalar_plant(2.0, actuator_loss=gilbert_elliott(fail=0.05, recover=0.74))
    CL = feedback(P, [[-2.0]])
    iid = feedback(scalar_plant(2.0, actuator_loss=P.actuator_loss), [[-2.0]])
    assert not CL.modes.is_iid
    np.testing.assert_allclose(CL.modes.probabilities[0, [1, 3]],
                               iid.modes.probabilities[0], atol=1e-12)
    assert ms_radius(iid) == pytest.approx(4 * P.actuator_loss)
    assert ms_radius(CL) == pytest.approx(4 * (1 - 0.74))


# -- closed forms (theory: Markov losses) ---------------------------------------------------
@pytest.mark.parametrize("a, f, r", [(2.0, 0.05, 0.74), (2.0, 0.3, 0.8),
                                     (1.5, 0.5, 0.2), (3.0, 0.9, 0.95)])
def test_deadbeat_gain_over_an_actuator_chain_has_rate_one_minus_r_a2(a, f, r):
    P = scalar_plant(a, actuator_loss=gilbert_elliott(fail=f, recover=r))
    CL = feedback(P, [[-a]])
    for method in ("dense", "matrix-free"):
        assert ms_radius(CL, method=method) == pytest.approx((1 - r) * a * a,
                                                             rel=1e-9)


@pytest.mark.parametrize("a, f, r", [(2.0, 0.05, 0.74), (1.5, 0.5, 0.2)])
def test_no_gain_beats_one_minus_r_a2_over_an_actuator_chain(a, f, r):
    P = scalar_plant(a, actuator_loss=gilbert_elliott(fail=f, recover=r))
    bound = (1 - r) * a * a
    rates = [ms_radius(feedback(P, [[k]])) for k in np.linspace(-2 * a, a, 301)]
    assert min(rates) >= bound * (1 - 1e-9)


@pytest.mark.parametrize("f1, r1, f2, r2", [(0.1, 0.3, 0.2, 0.5),
                                            (0.05, 0.74, 0.3, 0.8)])
def test_both_links_markov_deadbeat_rate_is_a2_rho_of_t_oo(f1, r1, f2, r2):
    a = 1.6
    P = scalar_plant(a, sensor_loss=gilbert_elliott(fail=f1, recover=r1),
                     actuator_loss=gilbert_elliott(fail=f2, recover=r2))
    T = np.kron(gilbert_elliott(fail=f2, recover=r2).transition,
                gilbert_elliott(fail=f1, recover=r1).transition)
    rho_oo = np.max(np.abs(np.linalg.eigvals(T[:3, :3])))
    CL = feedback(P, [[-a]])
    assert ms_radius(CL) == pytest.approx(a * a * rho_oo, rel=1e-9)
    rates = [ms_radius(feedback(P, [[k]])) for k in np.linspace(-2 * a, 0, 161)]
    assert min(rates) >= a * a * rho_oo * (1 - 1e-9)


def test_bursty_six_percent_cannot_be_stabilised_but_spread_27_percent_can():
    """theory: Markov losses's numbers: a = 2; f = 0.05, r = 0.74 (6.3 % loss, bursts)
    has (1-r) a² > 1; f = 0.3, r = 0.8 (27 %) has (1-r) a² < 1, while
    Bernoulli at 27 % has α a² > 1."""
    bursty = scalar_plant(2.0, actuator_loss=gilbert_elliott(fail=0.05,
                                                             recover=0.74))
    spread = scalar_plant(2.0, actuator_loss=gilbert_elliott(fail=0.3,
                                                             recover=0.8))
    bernoulli = scalar_plant(2.0, actuator_loss=spread.actuator_loss)
    assert bursty.actuator_loss < 0.07 < 0.27 < spread.actuator_loss
    gains = np.linspace(-4, 0, 81)
    assert not any(is_mss(feedback(bursty, [[k]])) for k in gains)
    assert is_mss(feedback(spread, [[-2.0]]))
    assert not any(is_mss(feedback(bernoulli, [[k]])) for k in gains)


def alternating(A1, A2, stay):
    T = [[stay, 1 - stay], [1 - stay, stay]]
    return jss(np.array([A1, A2]), [[1.0], [0.0]], [[1.0, 0.0]], [[0.0]],
               transition=T)


def test_every_mode_stable_yet_the_markov_system_is_not():
    A1 = np.array([[0.5, 2.0], [0.0, 0.5]])
    A2 = np.array([[0.5, 0.0], [2.0, 0.5]])
    assert all(max(abs(np.linalg.eigvals(A))) < 1 for A in (A1, A2))
    assert not is_mss(alternating(A1, A2, stay=0.05))
    # staying long in each (stable) mode is stable
    assert is_mss(alternating(A1, A2, stay=0.995))


def test_an_unstable_mode_left_at_once_leaves_the_system_stable():
    sys = jss([[[2.0]], [[0.1]]], [[1.0]], [[1.0]], [[0.0]],
              transition=[[0.1, 0.9], [0.5, 0.5]])
    L = np.array([[0.1 * 4, 0.5 * 0.01], [0.9 * 4, 0.5 * 0.01]])
    assert ms_radius(sys) == pytest.approx(max(abs(np.linalg.eigvals(L))))
    assert is_mss(sys)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 4),
       N=st.integers(1, 3), M=st.integers(2, 4))
def test_dense_and_matrix_free_ms_radius_agree(seed, n, N, M):
    sys = markov_jss(np.random.default_rng(seed), n=n, N=N, M=M, radius=1.0)
    dense = ms_radius(sys, method="dense")
    free = ms_radius(sys, method="matrix-free")
    assert free == pytest.approx(dense, rel=1e-6, abs=1e-12)


def test_second_moment_operator_acts_on_mode_tuples():
    sys = markov_jss(np.random.default_rng(2), n=2, N=1, M=3)
    op = ncs.stability.second_moment_operator(sys)
    assert op.shape == (3 * 4, 3 * 4)
    Q = np.stack([np.eye(2) * (i + 1) for i in range(3)])
    m = sys.modes
    want = np.einsum("ij,iab,ibc,idc->jad", m.transition[0], m.A[0], Q, m.A[0])
    np.testing.assert_allclose(op.matvec(Q.reshape(-1)), want.reshape(-1))


# -- moments, mean face, simulation --------------------------------------------
def test_markov_moments_match_an_independent_sampler():
    rng = np.random.default_rng(7)
    sys = markov_jss(rng, n=2, N=2, M=3, radius=0.9)
    steps = 15
    w = np.cos(0.5 * np.arange(steps))[None]
    mom = moments(sys, steps, inputs=w, initial_state=[1.0, -1.0])
    xs, zs = sample_markov(sys, steps, 40000, np.random.default_rng(8),
                           [1.0, -1.0], w)
    assert_mean_within(xs, mom.states_mean, 5)
    assert_mean_within(np.einsum("sit,sjt->sijt", xs, xs),
                       mom.states_second_moment, 5)
    assert_mean_within(zs, mom.outputs_mean, 5)


def test_simulate_of_a_markov_closed_loop_matches_exact_moments():
    P = random_plant(np.random.default_rng(0), n=2, radius=1.05,
                     sensor_loss=gilbert_elliott(fail=0.1, recover=0.5),
                     actuator_loss=gilbert_elliott(fail=0.2, recover=0.6))
    K = -0.5 * ct.dlqr(P.A, P.B2, np.eye(2), np.eye(1))[0]
    CL = feedback(P, K)
    steps = 20
    w = np.sin(0.3 * np.arange(steps))[None]
    mom = moments(CL, steps, inputs=w, initial_state=[1.0, 0.5],
                  noise_covariance=[[0.1]])
    sim = simulate(CL, steps, inputs=w, initial_state=[1.0, 0.5],
                   noise_covariance=[[0.1]], trials=30000, seed=4)
    x = sim.states.transpose(1, 0, 2)          # (trials, n, T)
    assert_mean_within(x, mom.states_mean, 5)
    assert_mean_within(np.einsum("sit,sjt->sijt", x, x),
                       mom.states_second_moment, 5)


def test_simulate_with_a_markov_chain_is_reproducible_by_seed():
    sys = markov_jss(np.random.default_rng(5))
    a, b = (simulate(sys, 10, initial_state=1.0, trials=30, seed=9)
            for _ in range(2))
    c = simulate(sys, 10, initial_state=1.0, trials=30, seed=10)
    np.testing.assert_array_equal(a.states, b.states)
    assert not np.array_equal(a.states, c.states)


def test_initial_mode_law_is_used_by_moments_and_simulate():
    """From mode 0 for sure, x⁺ = 2x first, then the chain moves."""
    sys = jss([[[2.0]], [[0.5]]], [[1.0]], [[1.0]], [[0.0]], [1.0, 0.0],
              transition=[[0.5, 0.5], [0.25, 0.75]])
    mom = moments(sys, 3, initial_state=1.0)
    # E x_1 = 2; E x_2 = 0.5·2·2 + 0.5·0.5·2
    np.testing.assert_allclose(mom.states_mean[0], [1.0, 2.0, 2.5])
    sim = simulate(sys, 3, initial_state=1.0, trials=200, seed=1)
    np.testing.assert_array_equal(sim.states[0, :, 1], 2.0)


def test_mean_face_is_the_exact_mean_of_order_m_n():
    sys = markov_jss(np.random.default_rng(3), n=2, N=1, M=3)
    assert sys.nstates == 6
    steps = 10
    w = np.ones((1, steps))
    x0 = np.array([1.0, 2.0])
    mom = moments(sys, steps, inputs=w, initial_state=x0)
    face = ct.forced_response(sys.mean(), T=np.arange(steps), U=w,
                              X0=np.kron(sys.modes.initial, x0))
    np.testing.assert_allclose(face.outputs, mom.outputs_mean[0], atol=1e-12)


def test_algebra_and_pickling_keep_the_chain():
    import pickle
    sys = markov_jss(np.random.default_rng(4))
    for other in (pickle.loads(pickle.dumps(sys)), 2 * sys,
                  ct.feedback(sys, 0.5)):
        np.testing.assert_array_equal(other.modes.transition,
                                      sys.modes.transition)
    assert pickle.loads(pickle.dumps(sys)).equals(sys)
    assert sys.merged() is sys


# -- the event-level protocol with bursty links ---------------------------------
@pytest.mark.parametrize("controller, actuator", [
    ("static", "zero"), ("static", "hold"), ("predictor", "zero"),
    ("predictor", "hold")])
def test_protocol_with_markov_links_matches_the_jump_matrices(controller,
                                                              actuator):
    s1 = gilbert_elliott(fail=0.1, recover=0.4)
    s2 = gilbert_elliott(fail=0.15, recover=0.5)
    P = random_plant(np.random.default_rng(0), n=2, radius=1.0,
                     sensor_schedule=[[1, 1], [0, 1]],
                     actuator_schedule=[[1], [0]],
                     sensor_loss=s1, actuator_loss=s2)
    if controller == "predictor":
        P = P.with_network(sensor_schedule=[1, 2, 0],
                           actuator_schedule=[0, 0, 1], shared_channel=True)
    K = -0.5 * ct.dlqr(P.A, P.B2, np.eye(2), np.eye(1))[0]
    if (controller, actuator) == ("predictor", "hold"):
        K = np.hstack([K, [[0.2]]])        # gain on [x̂; u⁻]
    CL = feedback(P, K, controller=controller, actuator=actuator)
    steps = 25
    x0 = np.array([1.0, -0.5])
    w = np.sin(0.4 * np.arange(steps + 1))[None]
    xi0 = np.zeros(CL.modes.A.shape[-1])
    hat = [i for i, s in enumerate(CL.jump_states) if s.endswith("_hat")]
    xi0[hat if hat else [0, 1]] = x0
    mom = moments(CL, steps + 1, inputs=w, initial_state=xi0)
    S = plant_state_selector(CL, 2)
    sim = simulate_protocol(
        P.A, P.B1, P.B2, P.C1, P.D11, P.D12, P.sensor_schedule.pattern,
        P.actuator_schedule.pattern, s1, s2, np.tile(K, (P.period, 1, 1)),
        steps, controller=controller, actuator=actuator, inputs=w[:, :steps],
        initial_state=x0,
        initial_estimate=x0 if controller == "predictor" else None,
        trials=20000, rng=np.random.default_rng(11))
    x = sim["x"]
    assert_mean_within(x, S @ mom.states_mean, 5)
    assert_mean_within(np.einsum("sit,sjt->sijt", x, x),
                       np.einsum("ia,abt,jb->ijt", S, mom.states_second_moment,
                                 S), 5)
    # the protocol's channels do burst: consecutive losses are correlated
    lost = ~sim["theta2"]
    both = np.mean(lost[:, 1:] & lost[:, :-1])
    assert both == pytest.approx(s2.loss * (1 - s2.recover), abs=0.01)


def test_iid_modes_with_equal_matrices_are_each_drawn():
    """Two unmerged i.i.d. modes with the same matrices (0.3 + 0.3) and a
    third: the sample mean still follows 0.6·a + 0.4·b."""
    sys = jss([[[1.0]], [[1.0]], [[0.0]]], [[0.0]], [[1.0]], [[0.0]],
              [0.3, 0.3, 0.4])
    sim = simulate(sys, 2, initial_state=1.0, trials=20000, seed=2)
    assert sim.states[0, :, 1].mean() == pytest.approx(0.6, abs=0.02)


def test_markov_modes_with_equal_matrices_follow_their_own_futures():
    """Modes 0 and 1 share their matrices but not their futures: the mean
    of simulate matches the exact moments."""
    sys = jss([[[1.0]], [[1.0]], [[0.5]]], [[0.0]], [[1.0]], [[0.0]],
              transition=[[0.9, 0.0, 0.1], [0.0, 0.2, 0.8], [0.3, 0.3, 0.4]])
    mom = moments(sys, 8, initial_state=1.0)
    sim = simulate(sys, 8, initial_state=1.0, trials=20000, seed=5)
    assert_mean_within(sim.states.transpose(1, 0, 2), mom.states_mean, 5)


def test_lifted_mean_face_of_a_periodic_markov_system_is_the_exact_mean():
    sys = markov_jss(np.random.default_rng(6), n=2, N=2, M=3)
    assert sys.nstates == 6 and sys.ninputs == 2
    periods = 6
    w = np.sin(np.arange(2 * periods))[None]
    x0 = np.array([0.5, -1.0])
    mom = moments(sys, 2 * periods, inputs=w, initial_state=x0)
    face = ct.forced_response(sys.mean(), T=2 * np.arange(periods),
                              U=w.reshape(periods, 2).T,
                              X0=np.kron(sys.modes.initial, x0))
    np.testing.assert_allclose(face.outputs.T.reshape(-1),
                               mom.outputs_mean[0], atol=1e-12)


def test_stationary_law_of_a_closed_loop_has_exact_zeros_on_unvisited_modes():
    P = scalar_plant(2.0, actuator_loss=gilbert_elliott(loss=0.2, burst=5.0))
    law = feedback(P, [[-2.0]]).modes.initial
    assert law[0] == 0.0 and law[2] == 0.0
    np.testing.assert_allclose(law[[1, 3]], [0.2, 0.8], atol=1e-14)


# -- the chain survives interconnection; Bernoulli-only tools refuse it ------
def test_jump_feedback_and_interconnect_keep_the_chain():
    S = ncs.jss([[[0.5]], [[1.2]]], [[1.0]], [[1.0]], [[0.0]],
                transition=[[0.5, 0.5], [0.125, 0.875]], dt=1, name="S")
    G = ct.ss([[0.3]], [[1.0]], [[0.2]], [[0.1]], 1, name="G",
              inputs="e", outputs="f")
    loop = ncs.jump_feedback(S, G)
    chain = ncs.interconnect([S, G], connections=[["G.e", "S.z[0]"]],
                             inplist=["S.w[0]"], outlist=["G.f"])
    for J in (loop, chain):
        assert not J.modes.is_iid
        np.testing.assert_array_equal(J.modes.transition, S.modes.transition)


def test_schedule_search_refuses_markov_links_without_explicit_losses():
    from control.exception import ControlArgument
    link = ncs.gilbert_elliott(fail=0.05, recover=0.74)
    P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]],
                [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
                actuator_loss=link)
    with pytest.raises(ControlArgument, match="Markov"):
        ncs.schedule_search(P, 2)


def _bursty_loop():
    link = ncs.gilbert_elliott(fail=0.05, recover=0.74)
    P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]],
                [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
                actuator_loss=link)
    return P, ncs.feedback(P, [[-1.0]])


def test_passivesyn_designs_for_markov_links_and_markov_jump_plants():
    """theory: Markov losses (tests/test_markov_synthesis.py has the closed
    forms); the estimator controller designs over bursty links too."""
    P, _ = _bursty_loop()
    for plant in (P, ncs.build(P, "static", "zero")):
        K, CL, _ = ncs.passivesyn(plant)
        assert K.result.gain_kind == "mode" and K.result.certificate.verified
        assert ms_radius(CL) < 1
    K, CL, _ = ncs.passivesyn(P, controller="estimator")
    assert K.result.certificate.verified and CL.modes.transition is not None


def test_mean_system_index_is_exact_for_markov_modes_too():
    _, CL = _bursty_loop()
    lti = CL.mean()
    assert ncs.mean_input_ff_index(CL) == ncs.get_input_ff_index(lti)


# -- output feedback (LTI controller, estimator) over bursty links ------------
def output_feedback_case():
    """Two states, y = x1 (C2 = [1 0]) sent every other step; an
    observer-based LTI controller and an estimator loop with gains from the
    loss-free designs (rates below 0.86, so 20000 paths estimate the
    moments well)."""
    P = ncs.nss([[0.9, 1.0], [0.0, 0.5]], [[1.0, 0.0], [0.3, 1.0]],
                [[1.0, 0.0], [1.0, 0.0]], [[0.5, 0.0], [0.0, 0.0]], True,
                nmeas=1, ncon=1, sensor_schedule=[[1], [0]],
                sensor_loss=gilbert_elliott(fail=0.1, recover=0.5),
                actuator_loss=gilbert_elliott(fail=0.05, recover=0.5))
    Kx = -ct.dlqr(P.A, P.B2, np.eye(2), np.eye(1))[0]
    L = ct.dlqr(P.A.T, P.C2.T, np.eye(2), np.eye(1))[0].T
    lti = ct.ss(P.A + P.B2 @ Kx - L @ P.C2, L, Kx, 0, True)
    # the estimator's L_k corrects x̂ after the update: x̂ += L (y - C2 x̂)
    Lest = np.linalg.solve(P.A, L)
    return P, lti, Kx, Lest


@pytest.mark.parametrize("controller, actuator", [
    ("lti", "zero"), ("lti", "hold"), ("estimator", "zero"),
    ("estimator", "hold")])
def test_output_feedback_over_markov_links_matches_the_protocol(controller,
                                                                actuator):
    """Exact mean and second moment of x (and mean of z) against 20000
    event-level protocol paths with Gilbert-Elliott sensor and actuator
    links, within 5 standard errors."""
    P, lti, Kx, L = output_feedback_case()
    s1, s2 = P.sensor_link, P.actuator_link
    steps = 20
    w = np.sin(0.4 * np.arange(steps + 1))[None]
    if controller == "lti":
        CL = feedback(P, lti, actuator=actuator)
        x0, xc0 = np.zeros(2), np.array([0.5, -1.0])
        xi0 = np.zeros(len(CL.jump_states))
        xi0[2:4] = xc0                               # [x; xc; ŷ; u⁻]
        S = np.eye(2, len(CL.jump_states))
        extra = dict(controller_system=(lti.A, lti.B, lti.C, lti.D),
                     initial_controller_state=xc0)
        gains = None
    else:
        K = np.hstack([Kx, [[0.0]]]) if actuator == "hold" else Kx
        CL = feedback(P, K, controller="estimator", actuator=actuator,
                      estimator_gain=L)
        x0 = np.array([1.0, -0.5])
        xi0 = np.zeros(len(CL.jump_states))
        xi0[[i for i, s in enumerate(CL.jump_states)
             if s.endswith("_hat")]] = x0
        S = plant_state_selector(CL, 2)
        extra = dict(estimator_gains=np.tile(L, (P.period, 1, 1)),
                     initial_estimate=x0)
        gains = np.tile(K, (P.period, 1, 1))
    assert CL.modes.transition is not None
    assert ms_radius(CL) < 0.9
    mom = moments(CL, steps + 1, inputs=w, initial_state=xi0)
    sim = simulate_protocol(
        P.A, P.B1, P.B2, P.C1, P.D11, P.D12, P.sensor_schedule.pattern,
        P.actuator_schedule.pattern, s1, s2, gains, steps,
        controller=controller, actuator=actuator, C2=P.C2,
        inputs=w[:, :steps], initial_state=x0, trials=20000,
        rng=np.random.default_rng(12), **extra)
    x = sim["x"]
    assert_mean_within(x, S @ mom.states_mean, 5)
    assert_mean_within(np.einsum("sit,sjt->sijt", x, x),
                       np.einsum("ia,abt,jb->ijt", S, mom.states_second_moment,
                                 S), 5)
    assert_mean_within(sim["z"], mom.outputs_mean[:, :steps], 5)
    # the links do burst in the protocol: consecutive losses correlate
    lost = ~sim["theta1"]
    both = np.mean(lost[:, 1:] & lost[:, :-1])
    assert both == pytest.approx(s1.loss * (1 - s1.recover), abs=0.01)


def test_complex_transition_matrix_is_refused():
    with pytest.raises(ValueError, match="real"):
        jss([[[0.5]], [[1.2]]], [[1.0]], [[1.0]], [[0.0]],
            transition=np.eye(2) * (1 + 1j))


# -- exact lumping of the loop's Markov modes -------------------------------
@pytest.mark.parametrize("network, controller, lumps", [
    (dict(sensor_delay=ncs.random_delay([0.5, 0.3, 0.2]),
          actuator_loss=gilbert_elliott(fail=0.2, recover=0.6)), "estimator",
     True),
    (dict(sensor_delay=ncs.random_delay([0.6, 0.4], buffer=2),
          actuator_loss=0.1), "predictor", True),
    # a static gain sees every (burst state, age) pair differently: nothing
    # to lump, and the builder must leave the chain as it is
    (dict(sensor_loss=gilbert_elliott(fail=0.3, recover=0.5),
          actuator_delay=ncs.random_delay([0.7, 0.3])), "static", False),
])
def test_lumped_modes_give_the_figures_of_the_whole_chain(monkeypatch,
                                                          network,
                                                          controller, lumps):
    """The builder lumps Markov modes that share matrices and move alike;
    the loop on the whole product chain (lumping, and the drop of modes
    nothing enters, switched off) has the
    same radius, H2 norm and moments, with at least as many modes."""
    from control_ncs import strategies
    A = np.array([[1.1, 0.3], [0.0, 0.8]])
    P = ncs.nss(A, [[1.0, 0.0], [0.2, 1.0]], [[1.0, 0.0], [1.0, 0.0],
                                              [0.0, 1.0]],
                np.zeros((3, 2)), nmeas=2, ncon=1, **network)
    K = -np.array([[0.6, 0.9]])
    kw = dict(controller=controller)
    if controller == "estimator":
        kw["estimator_gain"] = np.array([[0.5, 0.0], [0.0, 0.5]])
    lumped = feedback(P, K, **kw)
    monkeypatch.setattr(strategies, "_lumped",
                        lambda arr, p, T, nominal, observed, **kw:
                        (arr, p, T, nominal, observed))
    whole = feedback(P, K, **kw)
    assert (whole.nmodes > lumped.nmodes) == lumps
    assert whole.nmodes >= lumped.nmodes
    rho = ncs.ms_radius(whole, tol=1e-13)
    assert ncs.ms_radius(lumped, tol=1e-13) == pytest.approx(rho, rel=1e-9)
    if rho < 1:
        assert ncs.norm(lumped, 2) == pytest.approx(ncs.norm(whole, 2),
                                                    rel=1e-9)
    w = np.cos(0.3 * np.arange(5))[None]
    got = moments(lumped, 5, inputs=w, noise_covariance=np.eye(1))
    want = moments(whole, 5, inputs=w, noise_covariance=np.eye(1))
    np.testing.assert_allclose(got.outputs_cov, want.outputs_cov,
                               rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(got.outputs_mean, want.outputs_mean,
                               rtol=1e-9, atol=1e-12)


def test_an_estimator_over_a_delayed_link_has_fewer_modes_than_its_pairs():
    """The estimator's chain of pairs of ages matters only through the
    age and whether the packet is new: the loop is lumped to those."""
    P = ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]], np.zeros((2, 2)),
                nmeas=1, ncon=1,
                sensor_delay=ncs.random_delay([0.5, 0.3, 0.2]),
                actuator_loss=gilbert_elliott(fail=0.2, recover=0.6))
    plant = ncs.build(P, "estimator", estimator_gain=[[0.8]])
    ages = 4                                  # 0, 1, 2 and stale (buffer 2)
    assert plant.probabilities.shape[1] < ages * ages * 2
