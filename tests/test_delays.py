"""Random transmission delays: the age chain of the freshest packet.

The chain (theory: random delays) is checked against its worked example and
against a packet-level simulation of the rule it models: every packet is
delayed independently, the receiver keeps the newest one it holds.
"""

import math

import control as ct
import numpy as np
import pytest
from control.exception import ControlArgument, ControlDimension
from hypothesis import given, settings, strategies as st

import control_ncs as ncs
from control_ncs.modes import age_chain
from control_ncs.protocol import simulate_protocol


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
    ages = packet_level_ages(pmf, buffer, sent, steps, rng)
    assert_ages_follow_the_chain(ages, pmf, buffer, sent)


def assert_ages_follow_the_chain(ages, pmf, buffer, sent):
    """``ages``: one path, or independent paths (rows), each from phase 0;
    the transitions of every path after its first ``buffer + 2`` steps are
    counted together."""
    T = age_chain(np.asarray(pmf, float), buffer, np.asarray(sent, bool))
    counts = sum(empirical_transitions(path, len(sent), buffer + 2,
                                       buffer + 2)
                 for path in np.atleast_2d(ages))
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


# -- closed loops over delayed links ---------------------------------------------
def _scalar(a, **network):
    return ncs.nss([[a]], [[1.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0],
                                                          [0.0, 0.0]],
                   True, nmeas=1, ncon=1, **network)


@pytest.mark.parametrize("pmf", [[0.5, 0.3, 0.1], [0.2, 0.2, 0.2, 0.3],
                                 [0.9]])
def test_predictor_turns_delays_into_losses(pmf):
    """Scalar x⁺ = a x + u, deadbeat predictor, delays on the sensor link:
    the second-moment radius is exactly ℓ a², whatever the delay pmf."""
    a = 1.5
    CL = ncs.feedback(_scalar(a, sensor_delay=pmf), [[-a]],
                      controller="predictor")
    loss = 1.0 - sum(pmf)
    assert ncs.ms_radius(CL) == pytest.approx(loss * a * a, rel=1e-9,
                                              abs=1e-12)


@pytest.mark.parametrize("side", ["sensor", "actuator"])
@pytest.mark.parametrize("actuator", ["zero", "hold"])
def test_a_link_that_only_loses_is_the_bernoulli_link(side, actuator):
    delayed = ncs.feedback(_scalar(1.1, **{f"{side}_delay": [0.8]}),
                           [[-1.0]], actuator=actuator)
    lossy = ncs.feedback(_scalar(1.1, **{f"{side}_loss": 0.2}), [[-1.0]],
                         actuator=actuator)
    assert ncs.ms_radius(delayed) == pytest.approx(ncs.ms_radius(lossy),
                                                   rel=1e-12)


def _packet_loop(P, K, sens, act, actuator, steps, rng, sent=(True,)):
    """The protocol itself, from packets (independent of the jump model):
    ages of the freshest measurement and command from packet-level
    delays, v_t = K_a y_{t-a}, u_t = v_{t-b}; the time average of z²."""
    A, B1, B2 = P.A, P.B1, P.B2
    C1, C2 = P.C1, P.C2
    n = A.shape[0]
    a_t = packet_level_ages(sens.pmf, sens.buffer, list(sent), steps, rng)
    b_t = packet_level_ages(act.pmf, act.buffer, [True], steps, rng)
    w = rng.standard_normal((steps, B1.shape[1]))
    xs = np.zeros((steps + 1, n))
    vs = np.zeros((steps, B2.shape[1]))
    us = np.zeros((steps, B2.shape[1]))
    zz = np.zeros(steps)
    for t in range(steps):
        a = a_t[t]
        vs[t] = K[min(a, len(K) - 1)] @ (C2 @ xs[t - a]) \
            if a <= sens.buffer and t - a >= 0 else 0.0
        b = b_t[t]
        if b <= act.buffer and t - b >= 0:
            us[t] = vs[t - b]
        elif actuator == "hold" and t > 0:
            us[t] = us[t - 1]
        z = C1 @ xs[t]
        zz[t] = z @ z
        xs[t + 1] = A @ xs[t] + B1 @ w[t] + B2 @ us[t]
    return zz


def _two_state_delayed_loop():
    """A two-state plant over delayed links, with a gain per sensor age."""
    P = ncs.nss([[0.9, 0.4], [-0.3, 0.8]],
                [[1.0, 1.0], [0.5, 0.3]],
                [[1.0, -1.0], [1.0, 0.0], [0.0, 1.0]],
                [[0.0, 0.0], [0.0, 0.0], [0.0, 0.0]], True, nmeas=2, ncon=1,
                sensor_delay=ncs.random_delay([0.6, 0.25, 0.1], buffer=2),
                actuator_delay=ncs.random_delay([0.7, 0.2], buffer=1))
    return P, np.array([[[-0.4, -0.3]], [[-0.3, -0.2]], [[-0.2, -0.1]]])


def _per_age(K):
    """A stack of gains, one per age of the measurement (as the packet
    simulations read it), as the loop takes it: blocks of columns."""
    return ncs.PeriodicGain(np.concatenate(list(K), axis=-1), ages=len(K))


@pytest.mark.parametrize("actuator", ["zero", "hold"])
def test_delayed_loop_power_equals_a_packet_level_simulation(actuator):
    """Stationary output power under unit noise: exact (the jump model's
    stationary covariances) against the protocol run from packets."""
    P, K = _two_state_delayed_loop()
    CL = ncs.feedback(P, _per_age(K), actuator=actuator)
    exact = ncs.norm(CL) ** 2
    zz = _packet_loop(P, K, P.sensor_delay, P.actuator_delay, actuator,
                      200_000, np.random.default_rng(3))[1000:]
    batches = zz[: zz.size // 100 * 100].reshape(100, -1).mean(axis=1)
    se = batches.std(ddof=1) / 10
    assert abs(zz.mean() - exact) < 4 * se


def test_time_stamped_packets_of_the_protocol_simulator_follow_the_chain():
    """The event-level simulator stamps each packet and keeps the freshest
    (its own implementation, not packet_level_ages): the ages it uses follow
    the age chain, scheduled or not. 1000 independent paths of 150 steps
    (the transitions after each path's first buffer + 2 steps counted
    together: about 144,000, as many as one path of 150,000 steps gives)."""
    pmf, buffer, sent = [0.5, 0.3, 0.1], 3, (True, True, False)
    out = simulate_protocol(
        [[0.5]], [[0.0]], [[1.0]], [[1.0]], [[0.0]], [[0.0]],
        [[int(s)] for s in sent], [[1]] * 3, 0.0, 0.0,
        np.zeros((buffer + 1, 1, 1)), 150, trials=1000,
        sensor_delay=ncs.random_delay(pmf, buffer=buffer),
        rng=np.random.default_rng(5))
    assert out["age1"].shape == (1000, 150)
    assert_ages_follow_the_chain(out["age1"], pmf, buffer, sent)


@pytest.mark.parametrize("actuator", ["zero", "hold"])
def test_delayed_loop_power_equals_the_protocol_simulator(actuator):
    """Stationary output power under unit noise: exact against the
    event-level simulator with time-stamped packets on both links."""
    P, K = _two_state_delayed_loop()
    exact = ncs.norm(ncs.feedback(P, _per_age(K), actuator=actuator)) ** 2
    rng = np.random.default_rng(12)
    trials, steps, burn = 2000, 500, 100
    out = simulate_protocol(
        P.A, P.B1, P.B2, P.C1, P.D11, P.D12, [[1, 1]], [[1]], 0.0, 0.0, K,
        steps, actuator=actuator, C2=P.C2, trials=trials, rng=rng,
        inputs=rng.standard_normal((trials, 1, steps)),
        sensor_delay=P.sensor_delay, actuator_delay=P.actuator_delay)
    power = (out["z"][:, :, burn:] ** 2).sum(axis=1).mean(axis=1)
    se = power.std(ddof=1) / np.sqrt(trials)
    assert abs(power.mean() - exact) < 4 * se


def _pi_tracking_plant(**network):
    G = ct.ss([[1.05]], [[1.0, 0.0, 0.5]], [[1.0], [-1.0]],
              [[0.0, -1.0, 0.0], [0.0, 0.0, 0.0]], True)
    return G, ncs.nss(G, nmeas=1, ncon=1, **network)


PI = ct.ss([[1.0]], [[1.0]], [[0.2]], [[0.8]], True)


def test_lti_controller_over_links_that_only_lose_is_the_bernoulli_loop():
    """A delay law with all its mass on 0 is a Bernoulli link: the LTI
    loop over delayed links equals the one over lossy links, and with no
    loss python-control's lft."""
    G, on_time = _pi_tracking_plant(sensor_delay=[1.0])
    assert ncs.norm(ncs.feedback(on_time, PI)) == pytest.approx(
        ct.norm(G.lft(PI, 1, 1), 2), rel=1e-12)
    _, delayed = _pi_tracking_plant(sensor_delay=[0.7], actuator_delay=[0.9])
    _, lossy = _pi_tracking_plant(sensor_loss=0.3, actuator_loss=0.1)
    for sensor in ("zero", "hold"):
        for actuator in ("zero", "hold"):
            exact = ncs.norm(ncs.feedback(lossy, PI, sensor=sensor,
                                          actuator=actuator))
            assert ncs.norm(ncs.feedback(
                delayed, PI, sensor=sensor, actuator=actuator)) == \
                pytest.approx(exact, rel=1e-12)


@pytest.mark.parametrize("sensor, actuator", [("zero", "zero"),
                                              ("hold", "hold")])
def test_lti_controller_over_delayed_links_equals_the_protocol_simulator(
        sensor, actuator):
    _, P = _pi_tracking_plant(sensor_delay=[0.5, 0.3, 0.1],
                              actuator_delay=[0.8, 0.15])
    CL = ncs.feedback(P, PI, sensor=sensor, actuator=actuator)
    assert "xc[0]" in CL.jump_states
    exact = ncs.norm(CL) ** 2
    rng = np.random.default_rng(21)
    trials, steps, burn = 2000, 500, 100
    out = simulate_protocol(
        P.A, P.B1, P.B2, P.C1, P.D11, P.D12, [[1]], [[1]], 0.0, 0.0, None,
        steps, controller="lti", sensor=sensor, actuator=actuator, C2=P.C2,
        controller_system=(PI.A, PI.B, PI.C, PI.D), trials=trials, rng=rng,
        inputs=rng.standard_normal((trials, 2, steps)),
        sensor_delay=P.sensor_delay, actuator_delay=P.actuator_delay)
    power = (out["z"][:, :, burn:] ** 2).sum(axis=1).mean(axis=1)
    se = power.std(ddof=1) / np.sqrt(trials)
    assert abs(power.mean() - exact) < 4 * se


def test_protocol_simulator_refuses_links_it_does_not_model():
    args = ([[0.5]], [[0.0]], [[1.0]], [[1.0]], [[0.0]], [[0.0]], [[1]],
            [[1]])
    bursty = ncs.gilbert_elliott(fail=0.2, recover=0.5)
    with pytest.raises(ValueError, match="^sensor_delay: a Gilbert-Elliott"):
        simulate_protocol(*args, bursty, 0.0, np.zeros((2, 1, 1)), 5,
                          sensor_delay=[0.5, 0.3])
    with pytest.raises(ValueError, match="^actuator_delay: a Bernoulli loss"):
        simulate_protocol(*args, 0.0, 0.2, np.zeros((1, 1, 1)), 5,
                          actuator_delay=ncs.bursty_delay(bursty, [0.5],
                                                          [1.0]))
    with pytest.raises(ValueError, match=r"^gains must have shape \(D \+ 1"):
        simulate_protocol(*args, 0.0, 0.0, np.zeros((1, 1, 1)), 5,
                          sensor_delay=[0.5, 0.3])


def test_a_loss_on_a_delayed_link_thins_its_delay_law():
    """A packet is lost with probability α, else delayed by the pmf: the
    loop is the one of the thinned pmf, and the link's loss is total."""
    both = _scalar(1.1, sensor_delay=[0.5, 0.4], sensor_loss=0.3)
    thinned = _scalar(1.1, sensor_delay=[0.35, 0.28])
    assert both.sensor_loss == pytest.approx(1 - 0.7 * 0.9, rel=1e-12)
    assert ncs.ms_radius(ncs.feedback(both, [[-1.0]])) == pytest.approx(
        ncs.ms_radius(ncs.feedback(thinned, [[-1.0]])), rel=1e-12)


def test_link_combinations_without_a_chain_are_refused_by_name():
    link = ncs.gilbert_elliott(fail=0.1, recover=0.5)
    with pytest.raises(ControlArgument, match="^sensor_loss: a bursty"):
        _scalar(1.1, sensor_delay=[0.5, 0.4], sensor_loss=link)
    with pytest.raises(ControlArgument, match="^actuator_loss: a loss "
                       "beside a bursty delay"):
        _scalar(1.1, actuator_delay=ncs.bursty_delay(link, [0.0], [1.0]),
                actuator_loss=0.2)
    with pytest.raises(ValueError, match="^sensor_delay:.*together"):
        ncs.nss([[1.1, 0], [0, 1]], [[1.0, 1.0], [1.0, 0.0]],
                [[1.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
                [[0.0, 0.0], [0.0, 0.0], [0.0, 0.0]], True, nmeas=2, ncon=1,
                sensor_schedule=[1, 2], sensor_delay=[0.5, 0.4])


def test_a_delayed_plant_has_an_open_loop_for_synthesis():
    P = _scalar(1.1, sensor_delay=[0.5, 0.4])
    plant = ncs.build(P)
    assert plant.reads_per_mode          # a gain per age of the measurement
    assert plant.gain_shape() == (1, 1, 2)
    with pytest.raises(ControlArgument, match="^estimator_gain: only"):
        ncs.feedback(P, [[-1.0]], controller="static",
                     estimator_gain=[[0.5]])


def test_a_delayed_plant_survives_pickling_and_with_network():
    import pickle
    P = _scalar(1.1, sensor_delay=[0.5, 0.4], actuator_delay=[0.9])
    Q = pickle.loads(pickle.dumps(P))
    assert Q.equals(P) and Q.sensor_delay == P.sensor_delay
    assert Q.sensor_loss == pytest.approx(0.1)
    R = P.with_network(actuator_delay=None)
    assert R.actuator_delay is None and R.sensor_delay == P.sensor_delay


def _kushner_tobias_plant(jitter_steps):
    """The generalized plant of P(s) = 6/((s+1)(s+2)) (w enters nowhere,
    z = y), sampled at h = 1.42 with τ uniform on {0, δ, …, jδ}."""
    G = ct.ss(ct.tf([6.0], [1.0, 3.0, 2.0]))
    plant = ct.ss(G.A, np.hstack([np.zeros_like(G.B), G.B]),
                  np.vstack([G.C, G.C]), np.zeros((2, 2)))
    taus = np.arange(jitter_steps + 1) * 1.42 / 50
    return ncs.nss(plant, nmeas=1, ncon=1, dt=1.42,
                   input_delay=(taus, np.full(taus.size, 1 / taus.size)))


@pytest.mark.parametrize("jitter, radius", [
    (0, 0.978055), (23, 0.981160), (24, 1.006315)])
def test_kushner_tobias_loop_built_as_users_do(jitter, radius):
    CL = ncs.feedback(_kushner_tobias_plant(jitter), [[-1.0]])
    assert ncs.ms_radius(CL) == pytest.approx(radius, abs=5e-7)
    assert ncs.ms_radius(CL) == pytest.approx(kushner_tobias_radius(jitter),
                                              rel=1e-12)


def test_input_delay_needs_a_continuous_plant_and_a_probability_law():
    G = ct.ss([[-1.0]], [[0.0, 1.0]], [[1.0], [1.0]], [[0.0, 0.0],
                                                       [0.0, 0.0]])
    with pytest.raises(ValueError, match="^input_delay:.*continuous"):
        ncs.nss(G.sample(0.5), nmeas=1, ncon=1, input_delay=([0.0], [1.0]))
    with pytest.raises(ValueError, match="^input_delay:.*sum to 1"):
        ncs.nss(G, nmeas=1, ncon=1, dt=0.5, input_delay=([0.0, 0.1],
                                                         [0.5, 0.4]))
    with pytest.raises(ValueError, match="^input_delay:.*\\[0, h\\)"):
        ncs.nss(G, nmeas=1, ncon=1, dt=0.5, input_delay=([0.6], [1.0]))


def test_scheduled_delayed_link_power_equals_a_packet_level_simulation():
    """The sensor packet is sent at even steps only: the age chain is
    periodic (period 2) and the loop a period-2 Markov jump system; its
    stationary output power equals the protocol run from packets."""
    P = ncs.nss([[0.9, 0.4], [-0.3, 0.8]],
                [[1.0, 1.0], [0.5, 0.3]],
                [[1.0, -1.0], [1.0, 0.0], [0.0, 1.0]],
                [[0.0, 0.0], [0.0, 0.0], [0.0, 0.0]], True, nmeas=2, ncon=1,
                sensor_schedule=[[1, 1], [0, 0]],
                sensor_delay=ncs.random_delay([0.6, 0.3], buffer=3),
                actuator_delay=ncs.random_delay([0.8], buffer=0))
    K = np.array([[[-0.4, -0.3]], [[-0.3, -0.2]], [[-0.2, -0.15]],
                  [[-0.1, -0.1]]])
    CL = ncs.feedback(P, _per_age(K))
    assert CL.period == 2
    exact = ncs.norm(CL) ** 2
    zz = _packet_loop(P, K, P.sensor_delay, P.actuator_delay, "zero",
                      200_000, np.random.default_rng(8),
                      sent=(True, False))[1000:]
    batches = zz[: zz.size // 100 * 100].reshape(100, -1).mean(axis=1)
    se = batches.std(ddof=1) / 10
    assert abs(zz.mean() - exact) < 4 * se


# -- bursty delays: a delay law per Gilbert-Elliott state ------------------------
def test_bursty_delay_that_only_loses_is_the_gilbert_elliott_link():
    ge = ncs.gilbert_elliott(fail=0.1, recover=0.4)
    for side in ("sensor", "actuator"):
        for actuator in ("zero", "hold"):
            delayed = ncs.feedback(
                _scalar(1.1, **{f"{side}_delay": ncs.bursty_delay(
                    ge, [0.0], [1.0])}), [[-1.0]], actuator=actuator)
            lossy = ncs.feedback(_scalar(1.1, **{f"{side}_loss": ge}),
                                 [[-1.0]], actuator=actuator)
            assert ncs.ms_radius(delayed) == pytest.approx(
                ncs.ms_radius(lossy), rel=1e-12)


def test_bursty_delay_chain_equals_a_packet_level_simulation():
    """Link state from the Gilbert-Elliott chain; every packet in flight
    arrives with the hazard of the state the link is in; the receiver
    keeps the freshest. Empirical (state, age) transitions against the
    chain."""
    ge = ncs.gilbert_elliott(fail=0.2, recover=0.3)
    link = ncs.bursty_delay(ge, [0.1, 0.3], [0.6, 0.3, 0.05], buffer=3)
    D, steps = link.buffer, 150_000
    rng = np.random.default_rng(12)
    hazards = []
    for q in link.pmfs:
        tail = 1.0 - np.concatenate(([0.0], np.cumsum(q)))[:q.size]
        h = np.zeros(D + 1)
        h[:q.size] = np.where(tail > 0, q / np.where(tail > 0, tail, 1), 0)
        hazards.append(h)
    g, arrived_at = 1, np.full(steps, False)
    latest, states = -10 ** 9, np.empty(steps, int)
    T_ge = ge.transition
    for t in range(steps):
        g = int(rng.random() < T_ge[g, 1])          # P(next = good | g)
        for c in range(D + 1):                     # packets of age c
            s = t - c
            if s >= 0 and not arrived_at[s] and rng.random() < hazards[g][c]:
                arrived_at[s] = True
                latest = max(latest, s)
        age = t - latest
        states[t] = g * (D + 2) + (age if age <= D else D + 1)
    counts = np.zeros((2 * (D + 2), 2 * (D + 2)))
    np.add.at(counts, (states[1000:-1], states[1001:]), 1.0)
    rows = counts.sum(axis=1, keepdims=True)
    empirical = counts / np.where(rows > 0, rows, 1)
    T = link.transition()[0]
    seen = rows[:, 0] > 2000
    assert np.abs(empirical[seen] - T[seen]).max() < 0.02


def test_bursty_delay_refuses_a_link_that_never_delivers():
    ge = ncs.gilbert_elliott(fail=0.2, recover=0.3)
    with pytest.raises(ValueError, match="no packet ever arrives"):
        ncs.bursty_delay(ge, [0.0], [0.0])
    with pytest.raises(ValueError, match="^pmf_good:"):
        ncs.bursty_delay(ge, [0.5], [0.9, 0.3])


# -- passive design over delayed links (a local search on exact figures) --------
def _passive_scalar(**network):
    """x⁺ = 1.2x + w + u, z = x + 0.5w, y = x."""
    return ncs.nss([[1.2]], [[1.0, 1.0]], [[1.0], [1.0]],
                   [[0.5, 0.0], [0.0, 0.0]], True, nmeas=1, ncon=1,
                   **network)


def test_passivesyn_over_a_delayed_link_certifies_a_gain_per_age():
    P = _passive_scalar(sensor_delay=[0.5, 0.3, 0.1])
    K, CL, eta = ncs.passivesyn(P)
    assert K.gains.shape == (1, 1, 3)              # one gain per age
    assert K.result.certificate.verified and eta == K.result.eta
    # the certified level is the analysis' of the returned loop
    again = ncs.passivity_certificate(ncs.feedback(P, K), None)
    assert again.certificate.verified and again.eta == pytest.approx(
        eta, abs=1e-5)
    # not worse than the design without delays (their loss kept) used at
    # every age
    K0 = ncs.passivesyn(P.with_network(
        sensor_delay=None, sensor_loss=P.sensor_loss))[0].gains[:1]
    start = ncs.passivity_certificate(ncs.feedback(P, K0), None)
    assert eta >= start.eta - 1e-9


def test_passivesyn_over_a_delayed_link_says_when_a_level_is_not_reached():
    P = _passive_scalar(sensor_delay=[0.5, 0.3, 0.1])
    with pytest.raises(ncs.SynthesisError, match="nothing is proven") as info:
        ncs.passivesyn(P, eta=0.4, options={"time_limit": 1.0})
    # a local search that stops proves nothing, whatever stopped it
    assert info.value.reason in ("not_found", "time_limit")
    with pytest.raises(ControlArgument, match="^structure:"):
        ncs.passivesyn(P, options={"structure": "full"})


@pytest.mark.parametrize("controller", ["static", "predictor"])
@pytest.mark.parametrize("actuator", ["zero", "hold"])
def test_delayed_design_rate_and_gradient_are_the_loops(controller, actuator):
    """The design's rate (the loop affine in the gains, mode by mode) is the
    exact ms_radius of feedback(P, K), and its Perron gradient matches
    central differences of that independent route."""
    from control_ncs.synthesis._local import Loop
    A = np.array([[1.1, 0.3], [0.0, 0.8]])
    P = ncs.nss(A, np.array([[1.0, 1.0], [0.0, 0.5]]),
                np.array([[1.0, 0.0], [1.0, 0.0], [0.0, 1.0]]),
                np.zeros((3, 2)), True, nmeas=2, ncon=1,
                sensor_delay=[0.5, 0.3, 0.1], actuator_delay=[0.6, 0.3])
    plant = ncs.build(P, controller, actuator)
    loop = Loop(plant, plant.probabilities, plant.transition)
    x = 0.3 * np.random.default_rng(7).standard_normal(loop.free.size)

    def exact(x):
        CL = ncs.feedback(P, loop.gains(x), controller=controller,
                          actuator=actuator)
        return math.log(ncs.ms_radius(CL))

    f, grad = loop.rate(x)
    assert np.max(np.abs(grad)) > 1e-3          # the gain matters here
    assert f == pytest.approx(exact(x), abs=1e-10)
    h = 1e-6
    central = np.array([(exact(x + h * e) - exact(x - h * e)) / (2 * h)
                        for e in np.eye(x.size)])
    assert np.max(np.abs(central - grad)) < 1e-6 * np.max(np.abs(grad))


def test_passivesyn_over_a_delayed_link_stabilises_an_unstable_start():
    """From a gain whose delayed loop is not mean-square stable, the first
    stage (quasi-Newton on the exact rate) reaches a certified loop."""
    P = _passive_scalar(sensor_delay=[0.1, 0.2, 0.6])
    start = [[[-2.0, -2.0, -2.0]]]           # the same gain at every age
    assert ncs.ms_radius(ncs.feedback(P, start[0])) > 2.0
    K, CL, eta = ncs.passivesyn(P, eta=-50.0, initial_gain=start)
    assert ncs.ms_radius(CL) < 1.0 and K.result.certificate.verified
    assert eta >= -50.0
    assert ncs.ms_radius(ncs.feedback(P, K)) == pytest.approx(
        ncs.ms_radius(CL), rel=1e-12)


# -- the estimator over a delayed sensor link ---------------------------------
def _estimator_plant(**network):
    """x⁺ = A x + w + 0.5 u (second state), y = z = x1."""
    A = np.array([[1.1, 0.3], [0.0, 0.8]])
    return ncs.nss(A, np.array([[1.0, 1.0], [0.0, 0.5]]),
                   np.array([[1.0, 0.0], [1.0, 0.0]]), np.zeros((2, 2)),
                   True, nmeas=1, ncon=1, **network)


L_EST = np.array([[0.8], [0.3]])
K_EST = np.array([[-0.9, -0.4]])


@pytest.mark.parametrize("actuator", ["zero", "hold"])
def test_the_delayed_estimator_of_a_link_that_only_loses_is_bernoullis(
        actuator):
    """A delay law with all its mass at 0: the estimator corrects with the
    measurement of the step or not at all, exactly the Bernoulli loop's."""
    K_hold = np.hstack([K_EST, [[0.0]]]) if actuator == "hold" else K_EST
    delayed = ncs.feedback(
        _estimator_plant(sensor_delay=[0.7], actuator_delay=[0.8]), K_hold,
        controller="estimator", estimator_gain=L_EST, actuator=actuator)
    lossy = ncs.feedback(
        _estimator_plant(sensor_loss=0.3, actuator_loss=0.2), K_hold,
        controller="estimator", estimator_gain=L_EST, actuator=actuator)
    assert ncs.norm(delayed) == pytest.approx(ncs.norm(lossy), rel=1e-12)


def test_the_delayed_estimator_matches_a_packet_level_simulation():
    """Freshest packet, corrected only when newer than the last one used:
    the innovation y_s - C2 x̂_s corrects the estimate of step s, and the
    model re-runs from there with the applied inputs (a re-simulation, not
    the jump model's propagated correction); stationary power within 4
    standard errors of the exact norm."""
    pmf, buffer = [0.5, 0.3, 0.1], 2
    P = _estimator_plant(sensor_delay=ncs.random_delay(pmf, buffer))
    CL = ncs.feedback(P, K_EST, controller="estimator",
                      estimator_gain=L_EST)
    exact = ncs.norm(CL) ** 2
    rng = np.random.default_rng(8)
    steps = 200_000
    ages = packet_level_ages(pmf, buffer, [True], steps, rng)
    A, B1, B2 = P.A, P.B1, P.B2
    w = rng.standard_normal(steps)
    x = np.zeros((steps + 1, 2))
    xhat = np.zeros((steps + 1, 2))
    u = np.zeros(steps)
    zz = np.zeros(steps)
    used = -1                                    # stamp of the last packet
    for t in range(steps):
        a = ages[t]
        if a <= buffer and t - a > used:
            s = t - a
            used = s
            xhat[s] += L_EST[:, 0] * (x[s, 0] - xhat[s, 0])
            for i in range(s + 1, t + 1):
                xhat[i] = A @ xhat[i - 1] + B2[:, 0] * u[i - 1]
        u[t] = K_EST[0] @ xhat[t]
        zz[t] = x[t, 0] ** 2
        x[t + 1] = A @ x[t] + B1[:, 0] * w[t] + B2[:, 0] * u[t]
        xhat[t + 1] = A @ xhat[t] + B2[:, 0] * u[t]
    zz = zz[1000:]
    batches = zz[: zz.size // 100 * 100].reshape(100, -1).mean(axis=1)
    se = batches.std(ddof=1) / 10
    assert abs(zz.mean() - exact) < 4 * se, (zz.mean(), se, exact)


def test_the_delayed_estimator_needs_its_gain():
    P = _estimator_plant(sensor_delay=[0.5, 0.3])
    with pytest.raises(ControlArgument, match="^estimator_gain: .*needs"):
        ncs.feedback(P, K_EST, controller="estimator")
    with pytest.raises(ControlDimension, match="^estimator_gain:"):
        ncs.feedback(P, K_EST, controller="estimator",
                     estimator_gain=np.ones((3, 1)))
