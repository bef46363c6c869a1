"""Random transmission delays: the age chain of the freshest packet.

The chain (theory: random delays) is checked against its worked example and
against a packet-level simulation of the rule it models: every packet is
delayed independently, the receiver keeps the newest one it holds.
"""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import control_ncs as ncs
from control_ncs.modes import age_chain


def packet_level_ages(pmf, buffer, sent, steps, rng):
    """Ages of the packet in use, from packets: each sent one gets a delay
    drawn from ``pmf`` (or is lost); at step t the receiver uses the
    freshest packet that has arrived by t; older than ``buffer`` is stale
    (``buffer + 1``)."""
    pmf = np.asarray(pmf, float)
    N = len(sent)
    outcomes = np.arange(pmf.size + 1)          # the last one: lost
    probs = np.append(pmf, 1.0 - pmf.sum())
    delay = rng.choice(outcomes, size=steps, p=probs).astype(float)
    delay[delay == pmf.size] = np.inf
    delay[~np.asarray(sent, bool)[np.arange(steps) % N]] = np.inf
    arrival = np.arange(steps) + delay
    ages = np.full(steps, buffer + 1)
    for c in range(buffer, -1, -1):             # freshest (smallest c) last
        t = np.arange(c, steps)
        ages[t[arrival[t - c] <= t]] = c
    return ages


def empirical_transitions(ages, N, states, skip):
    counts = np.zeros((N, states, states))
    t = np.arange(skip, ages.size - 1)
    np.add.at(counts, (t % N, ages[t], ages[t + 1]), 1.0)
    return counts


def assert_matches_simulation(pmf, buffer, sent, seed, steps=200_000):
    rng = np.random.default_rng(seed)
    T = age_chain(np.asarray(pmf, float), buffer, np.asarray(sent, bool))
    ages = packet_level_ages(pmf, buffer, sent, steps, rng)
    counts = empirical_transitions(ages, len(sent), buffer + 2, buffer + 2)
    visits = counts.sum(axis=2, keepdims=True)
    seen = visits[..., 0] >= 200
    freq = counts / np.maximum(visits, 1.0)
    # binomial standard errors; 5 sigma over a few dozen cells
    sigma = np.sqrt(T * (1.0 - T) / np.maximum(visits, 1.0))
    err = np.abs(freq - T)[seen]
    assert np.all(err <= 5.0 * sigma[seen] + 1e-12), err.max()
    # a transition the chain forbids never happens among packets
    assert np.all(counts[T == 0.0] == 0.0)


def test_worked_example_gives_the_rows_of_the_theory_page():
    link = ncs.random_delay([0.5, 0.3, 0.1], buffer=3)
    expected = [[.5, .5, 0, 0, 0], [.5, .3, .2, 0, 0], [.5, .3, .1, .1, 0],
                [.5, .3, .1, 0, .1], [.5, .3, .1, 0, .1]]
    np.testing.assert_allclose(link.transition, expected, atol=1e-15)
    assert link.loss == pytest.approx(0.1, abs=1e-15)
    assert link.states[-1] == "stale" and len(link.states) == 5


def test_age_chain_equals_a_packet_level_simulation():
    assert_matches_simulation([0.5, 0.3, 0.1], 3, [True], seed=1)


def test_scheduled_sender_gives_the_periodic_chain_of_packets():
    # the node sends at phases 0 and 2 of 3: the chain is periodic
    assert_matches_simulation([0.4, 0.35, 0.15], 3, [True, False, True],
                              seed=2)


@settings(max_examples=20, deadline=None)
@given(st.lists(st.floats(0.0, 1.0, allow_subnormal=False), min_size=1,
                max_size=4),
       st.floats(0.0, 0.6), st.integers(0, 2))
def test_from_an_age_beyond_the_largest_delay_nothing_arrives_with_the_loss(
        weights, loss, extra):
    w = np.array(weights)
    if w.sum() == 0 or w[-1] == 0:
        w[-1] = 1.0
    pmf = (1.0 - loss) * w / w.sum()
    link = ncs.random_delay(pmf, buffer=pmf.size - 1 + extra)
    T = link.transition
    assert np.allclose(T.sum(axis=1), 1.0)
    d, D = link.max_delay, link.buffer
    for a in range(d, D + 2):
        # the packet in use only grows older (or goes stale) when no newer
        # one arrives: probability Π_{c≤d}(1 - h(c)) = the loss
        assert T[a, min(a + 1, D + 1)] == pytest.approx(link.loss, abs=1e-12)
    assert link.loss == pytest.approx(loss, abs=1e-9)


def test_losses_alone_are_the_bernoulli_link():
    link = ncs.random_delay([0.7])
    np.testing.assert_allclose(link.transition, [[0.7, 0.3], [0.7, 0.3]])
    assert link.loss == pytest.approx(0.3)


def test_link_survives_pickling_and_compares_by_value():
    import pickle
    link = ncs.random_delay([0.5, 0.3, 0.1], buffer=4)
    again = pickle.loads(pickle.dumps(link))
    assert again == link and hash(again) == hash(link)
    assert again != ncs.random_delay([0.5, 0.3, 0.1], buffer=3)


@pytest.mark.parametrize("pmf, buffer, match", [
    ([0.5, -0.1], None, "^pmf: expected non-negative"),
    ([0.7, 0.5], None, "^pmf: expected non-negative"),
    ([], None, "^pmf: expected a 1-D array"),
    ([[0.5]], None, "^pmf: expected a 1-D array"),
    ([0.5, 1j], None, "^pmf: expected a 1-D array"),
    ([np.nan], None, "^pmf: expected non-negative"),
    ([0.0, 0.0], None, "^pmf: no packet ever arrives"),
    ([0.5, 0.3, 0.1], 1, "^buffer: expected an int >= the largest delay 2"),
    ([0.5, 0.3], 1.5, "^buffer: expected an int"),
    ([0.5, 0.3], True, "^buffer: expected an int"),
])
def test_bad_delay_models_are_refused_naming_the_argument(pmf, buffer, match):
    with pytest.raises(ValueError, match=match):
        ncs.random_delay(pmf, buffer)


# -- sub-sample delays of a sampled continuous plant ---------------------------
def kushner_tobias_radius(jitter_steps):
    """P(s) = 6/((s+1)(s+2)), u = -y, h = 1.42, τ uniform on the grid
    {0, δ, ..., jδ} with δ = h/50: the loop on [x; u[k-1]] per mode τ."""
    from control_ncs.plant import input_delay_sampling
    import control as ct
    G = ct.ss(ct.tf([6.0], [1.0, 3.0, 2.0]))
    h = 1.42
    taus = np.arange(jitter_steps + 1) * h / 50
    Phi, G0, G1 = input_delay_sampling(G.A, G.B, h, taus)
    n = Phi.shape[0]
    A = np.array([np.block([[Phi - G0[i] @ G.C, G1[i]],
                            [-G.C, np.zeros((1, 1))]])
                  for i in range(taus.size)])
    loop = ncs.jss(A, np.zeros((n + 1, 1)), np.zeros((1, n + 1)),
                   np.zeros((1, 1)), np.full(taus.size, 1.0 / taus.size))
    return ncs.ms_radius(loop)


@pytest.mark.parametrize("jitter, radius", [
    (0, 0.978055), (23, 0.981160), (24, 1.006315)])
def test_kushner_tobias_loop_has_the_reference_radii(jitter, radius):
    assert kushner_tobias_radius(jitter) == pytest.approx(radius, abs=5e-7)


def test_no_sub_sample_delay_is_the_zero_order_hold():
    import control as ct
    from control_ncs.plant import input_delay_sampling
    G = ct.ss([[0.0, 1.0], [-2.0, -0.3]], [[0.0], [1.0]], [[1.0, 0.0]], 0.0)
    Gd = ct.sample_system(G, 0.1, method="zoh")
    Phi, G0, G1 = input_delay_sampling(G.A, G.B, 0.1, [0.0])
    np.testing.assert_allclose(Phi, Gd.A, atol=1e-14)
    np.testing.assert_allclose(G0[0], Gd.B, atol=1e-14)
    np.testing.assert_allclose(G1[0], 0.0, atol=1e-14)


def test_delayed_input_splits_the_period_between_old_and_new_input():
    """Γ0(τ) + Γ1(τ) is the zero-order hold's B: the same constant input,
    old or new, over the whole period."""
    import control as ct
    from control_ncs.plant import input_delay_sampling
    A, B = [[0.0, 1.0], [-2.0, -0.3]], [[0.0], [1.0]]
    Phi, G0, G1 = input_delay_sampling(A, B, 0.1, [0.0, 0.03, 0.07])
    Gd = ct.sample_system(ct.ss(A, B, [[1.0, 0.0]], 0.0), 0.1, method="zoh")
    np.testing.assert_allclose(G0 + G1, np.broadcast_to(Gd.B, G0.shape),
                               atol=1e-14)


def test_input_delays_outside_the_period_are_refused():
    from control_ncs.plant import input_delay_sampling
    with pytest.raises(ValueError, match="^taus: expected delays in"):
        input_delay_sampling([[0.0]], [[1.0]], 0.1, [0.1])


def test_continuous_plant_is_sampled_with_a_zero_order_hold():
    import control as ct
    Gc = ct.ss([[0.0, 1.0], [-2.0, -0.3]], [[0.0, 0.0], [1.0, 1.0]],
               [[1.0, 0.0], [1.0, 0.0]], [[0.0, 0.0], [0.0, 0.0]],
               name="servo")
    P = ncs.nss(Gc, nmeas=1, ncon=1, dt=0.05, actuator_loss=0.1)
    Gd = ct.sample_system(Gc, 0.05, method="zoh")
    assert P.dt == 0.05 and P.name == "servo"
    for X, Y in ((P.A, Gd.A), (P.B, Gd.B), (P.C, Gd.C), (P.D, Gd.D)):
        np.testing.assert_allclose(X, Y, atol=1e-14)


def test_continuous_plant_without_a_sampling_period_is_refused():
    import control as ct
    Gc = ct.ss([[-1.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0], [0.0, 0.0]])
    with pytest.raises(ValueError, match="^dt: the plant is continuous-time"):
        ncs.nss(Gc, nmeas=1, ncon=1)
    Gd = ct.sample_system(Gc, 0.1)
    with pytest.raises(ValueError, match="^dt: the plant is discrete-time"):
        ncs.nss(Gd, nmeas=1, ncon=1, dt=0.2)
    assert ncs.nss(Gd, nmeas=1, ncon=1, dt=0.1).dt == 0.1
