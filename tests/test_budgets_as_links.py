"""A loss budget is a link: plants, loops, worst-case analysis and design.

A :class:`~control_ncs.LossAutomaton` given as ``sensor_loss=`` or
``actuator_loss=`` makes the loop a :class:`~control_ncs.ConstrainedLoop`;
its joint spectral radius is checked against closed forms (the scalar
weakly-hard rate, the stochastic-beside-budget example of the theory),
against the mean-square radius of the periodic jump system of one pattern
(python-control's neighbour :func:`ncs.ms_radius`, a route of its own),
against a brute force over every allowed periodic pattern written here,
and its matrices against loops written out by hand for every controller
kind and actuator.
"""

import math
import pickle
import warnings

import control as ct
import numpy as np
import pytest
from control.exception import ControlArgument
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import control_ncs as ncs
from control_ncs.network import budget_loss


def scalar_plant(a, b=1.0, **network):
    """``x⁺ = a x + w + b u``, ``z = x``, ``y = x``."""
    return ncs.nss([[a]], [[1.0, b]], [[1.0], [1.0]], [[0.0, 0.0],
                                                       [0.0, 0.0]],
                   nmeas=1, ncon=1, **network)


def weakly_hard_rate(a, b, misses, window):
    """The theory's closed form: lost ``a``, delivered ``b``."""
    a, b = abs(a), abs(b)
    if a >= b:
        return (a ** misses * b ** (window - misses)) ** (1.0 / window)
    return b


def closed_words(aut, length):
    """Every word read by a closed walk of ``length`` edges (the allowed
    periodic patterns), from the automaton's edges directly."""
    out = {}
    for q, _, _ in aut.edges:
        out.setdefault(q, [])
    for q, q2, d in aut.edges:
        out[q].append((q2, d))
    words = set()
    for start in out:
        stack = [(start, ())]
        while stack:
            q, word = stack.pop()
            if len(word) == length:
                if q == start:
                    words.add(word)
                continue
            for q2, d in out[q]:
                stack.append((q2, word + (d,)))
    return words


# -- the plant -------------------------------------------------------------------
@pytest.mark.parametrize("budget, fraction", [
    (ncs.weakly_hard(1, 3), 1 / 3), (ncs.weakly_hard(2, 5), 0.4),
    (ncs.max_consecutive_losses(2), 2 / 3),
    (ncs.loss_automaton([("ok", "ok", 1), ("ok", "a", 0), ("a", "b", 1),
                         ("b", "ok", 1)], initial="ok"), 1 / 3)])
def test_a_budget_is_a_link_of_the_plant(budget, fraction):
    P = scalar_plant(2.0, actuator_loss=budget, sensor_loss=0.1)
    assert P.actuator_link == budget
    assert P.actuator_loss == pytest.approx(fraction, abs=1e-15)
    assert P.sensor_loss == 0.1 and not P.is_iid
    assert f"actuator budget '{budget.name}'" in repr(P)
    assert f"actuator budget '{budget.name}'" in str(P)
    Q = P.with_network(sensor_loss=budget, actuator_loss=0.0)
    assert Q.sensor_link == budget and Q.actuator_loss == 0.0


@settings(max_examples=40, deadline=None)
@given(st.integers(2, 4), st.data())
def test_the_budgets_loss_fraction_is_its_worst_periodic_pattern(states,
                                                                 data):
    # a random automaton on which every state goes on
    edges = [(q, data.draw(st.integers(0, states - 1)),
              data.draw(st.integers(0, 1))) for q in range(states)]
    edges += data.draw(st.lists(st.tuples(st.integers(0, states - 1),
                                          st.integers(0, states - 1),
                                          st.integers(0, 1)), max_size=5))
    aut = ncs.loss_automaton(edges)
    worst = max(word.count(0) / len(word)
                for length in range(1, 2 * states + 1)
                for word in closed_words(aut, length))
    # a simple cycle has at most `states` edges: the brute force sees it
    assert budget_loss(aut) == pytest.approx(worst, abs=1e-12)


@pytest.mark.filterwarnings("ignore::control_ncs.ScheduleWarning")
def test_pickling_keeps_a_plant_with_a_budget_and_its_loop():
    P = scalar_plant(2.0, actuator_loss=ncs.weakly_hard(1, 3),
                     sensor_schedule=[1, 0, 1], actuator_schedule=[1, 1, 0])
    Q = pickle.loads(pickle.dumps(P))
    assert Q.equals(P) and Q.actuator_link == ncs.weakly_hard(1, 3)
    CL = ncs.feedback(P, [[-1.8]])
    CL2 = pickle.loads(pickle.dumps(CL))
    assert np.array_equal(CL2.A, CL.A)
    assert ncs.jsr(CL2).upper == pytest.approx(ncs.jsr(CL).upper, rel=1e-12)


# -- refusals -----------------------------------------------------------------------
def test_a_budget_beside_a_delay_on_one_link_is_refused_by_name():
    with pytest.raises(ControlArgument, match="budget beside a delay"):
        scalar_plant(2.0, actuator_loss=ncs.weakly_hard(1, 3),
                     actuator_delay=[0.5, 0.5])
    # a delay on the other link composes
    P = scalar_plant(2.0, actuator_loss=ncs.weakly_hard(1, 3),
                     sensor_delay=[0.5, 0.5])
    assert isinstance(ncs.feedback(P, [[-2.0]]), ncs.ConstrainedLoop)


def test_an_automaton_of_two_links_is_refused_as_one_links_budget():
    both = ncs.max_consecutive_losses(1).product(ncs.max_consecutive_losses(1))
    with pytest.raises(ControlArgument, match="each link its own automaton"):
        scalar_plant(2.0, actuator_loss=both)


def test_probabilities_of_a_budget_are_refused_by_name():
    P = scalar_plant(2.0, actuator_loss=ncs.weakly_hard(1, 3))
    for ask in (P.mode_probabilities, P.mode_transition):
        with pytest.raises(ControlArgument, match="loss budget"):
            ask()
    with pytest.raises(ControlArgument, match="no transition probabilities"):
        ncs.network.mode_transition(0.0, ncs.weakly_hard(1, 3))
    plant = ncs.build(P)
    for ask in (plant.mean, plant.transitions):
        with pytest.raises(ControlArgument, match="loss budget"):
            ask()


@pytest.mark.parametrize("analysis", [
    ncs.ms_radius, ncs.norm, ncs.l2_gain, ncs.is_mss,
    lambda CL: ncs.moments(CL, np.arange(3)),
    lambda CL: ncs.simulate(CL, np.arange(3), seed=1),
    lambda CL: ncs.ispassive(CL)])
def test_jump_system_analyses_refuse_a_constrained_loop_naming_jsr(analysis):
    CL = ncs.feedback(scalar_plant(2.0, actuator_loss=ncs.weakly_hard(1, 3)),
                      [[-2.0]])
    with pytest.raises(ControlArgument, match=r"ncs\.jsr"):
        analysis(CL)


def test_switching_view_refuses_a_loop_with_a_random_part():
    CL = ncs.feedback(scalar_plant(1.5, sensor_loss=0.2,
                                   actuator_loss=ncs.weakly_hard(1, 3)),
                      [[-1.4]])
    assert CL.random and CL.scale == "mean_square"
    with pytest.raises(ControlArgument, match=r"random.*ncs\.jsr"):
        CL.switching()


# -- the loop: closed forms ----------------------------------------------------------
@pytest.mark.parametrize("a, b, misses, window", [
    (3.0, 0.2, 1, 4), (2.0, 0.5, 1, 3), (1.5, 0.1, 2, 5), (-2.5, 0.3, 2, 4),
    (0.3, 0.9, 1, 4), (1.2, -0.6, 0, 3)])
@pytest.mark.parametrize("side", ["sensor", "actuator"])
def test_scalar_weakly_hard_loop_has_the_closed_form_rate(a, b, misses,
                                                          window, side):
    P = scalar_plant(a, **{f"{side}_loss": ncs.weakly_hard(misses, window)})
    CL = ncs.feedback(P, [[b - a]])            # delivered: a + (b - a) = b
    res = ncs.jsr(CL)
    want = weakly_hard_rate(a, b, misses, window)
    assert res.scale == "matrices" and res.exact
    assert res.lower == pytest.approx(want, rel=1e-9)
    assert res.upper == pytest.approx(want, rel=1e-6)
    # the theory's example
    if (a, b, misses, window) == (3.0, 0.2, 1, 4):
        assert res.upper == pytest.approx(0.39360, abs=5e-6)


def _stochastic_beside_budget(sensor_loss):
    """Theory's example: a = 1.5, b = 0.1, actuator at most two lost in a
    row, the sensor link random."""
    P = scalar_plant(1.5, sensor_loss=sensor_loss,
                     actuator_loss=ncs.max_consecutive_losses(2))
    return ncs.feedback(P, [[0.1 - 1.5]])


def test_stochastic_link_beside_a_budget_gives_the_theorys_rate():
    c = 0.2 * 1.5 ** 2 + 0.8 * 0.1 ** 2
    want = max(c, (1.5 ** 4 * c) ** (1 / 3))
    res = ncs.jsr(_stochastic_beside_budget(0.2))
    assert want == pytest.approx(1.32356, abs=5e-6)
    assert res.scale == "mean_square" and res.exact
    assert res.lower == pytest.approx(want, rel=1e-9)
    assert res.upper == pytest.approx(want, rel=1e-6)
    # a Gilbert-Elliott link without memory is the Bernoulli link: the
    # operators on tuples of its states give the same rate
    res_markov = ncs.jsr(_stochastic_beside_budget(
        ncs.gilbert_elliott(fail=0.2, recover=0.8)))
    assert res_markov.lower == pytest.approx(want, rel=1e-9)
    assert res_markov.upper == pytest.approx(want, rel=1e-6)


def _pattern_jump_system(CL_outcomes, a, b, sensor):
    """The periodic jump system of one actuator pattern with a random
    sensor link (the scalar loop: ``b`` when both messages arrive, else
    ``a``), written here for :func:`ncs.ms_radius`."""
    L = len(CL_outcomes)
    A = np.array([[[[a]], [[b if d else a]]] for d in CL_outcomes])
    B = np.ones((L, 2, 1, 1))
    C = np.ones((L, 2, 1, 1))
    D = np.zeros((L, 2, 1, 1))
    if isinstance(sensor, float):
        return ncs.jss(A, B, C, D, np.tile([sensor, 1 - sensor], (L, 1)))
    return ncs.jss(A, B, C, D, transition=np.tile(sensor.transition,
                                                  (L, 1, 1)))


@pytest.mark.parametrize("sensor", [
    0.2, 0.35, ncs.gilbert_elliott(fail=0.1, recover=0.4)])
def test_the_worst_pattern_is_the_mean_square_radius_of_its_jump_system(
        sensor):
    a, b = 1.5, 0.1
    P = scalar_plant(a, sensor_loss=sensor,
                     actuator_loss=ncs.max_consecutive_losses(2))
    res = ncs.jsr(ncs.feedback(P, [[b - a]]))
    outcomes = [name[1] for _, name in res.cycle]    # (automaton, outcome)
    J = _pattern_jump_system(outcomes, a, b, sensor)
    assert ncs.ms_radius(J) == pytest.approx(res.lower, rel=1e-9)
    # and no other periodic pattern of up to 6 steps is worse
    for length in range(1, 7):
        for word in closed_words(ncs.max_consecutive_losses(2), length):
            J = _pattern_jump_system(word, a, b, sensor)
            assert ncs.ms_radius(J) <= res.upper * (1 + 1e-9)


# -- the loop: brute force --------------------------------------------------------------
def _random_automaton(data, states):
    edges = [(q, data.draw(st.integers(0, states - 1)),
              data.draw(st.integers(0, 1))) for q in range(states)]
    edges += data.draw(st.lists(st.tuples(st.integers(0, states - 1),
                                          st.integers(0, states - 1),
                                          st.integers(0, 1)),
                                min_size=1, max_size=4))
    return ncs.loss_automaton(edges)


@pytest.mark.filterwarnings("ignore::control_ncs.ScheduleWarning")
@settings(max_examples=12, deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_no_allowed_pattern_up_to_length_10_beats_the_upper_bound(data):
    floats = st.floats(-1.5, 1.5, allow_nan=False)
    A = np.array(data.draw(st.lists(floats, min_size=4, max_size=4))
                 ).reshape(2, 2)
    B2 = np.array(data.draw(st.lists(floats, min_size=2, max_size=2))
                  ).reshape(2, 1)
    K = np.array(data.draw(st.lists(floats, min_size=2, max_size=2))
                 ).reshape(1, 2)
    aut = _random_automaton(data, data.draw(st.integers(1, 3)))
    side = data.draw(st.sampled_from(["sensor", "actuator"]))
    P = ncs.nss(A, np.hstack([np.eye(2)[:, :1], B2]),
                np.vstack([np.eye(2)[:1], np.eye(2)]), np.zeros((3, 2)),
                nmeas=2, ncon=1, **{f"{side}_loss": aut})
    res = ncs.jsr(ncs.feedback(P, K))
    mats = {0: A, 1: A + B2 @ K}                    # lost, delivered
    worst = 0.0
    for length in range(1, 11):
        for word in closed_words(aut, length):
            prod = np.eye(2)
            for d in word:
                prod = mats[d] @ prod
            rho = max(abs(np.linalg.eigvals(prod)))
            worst = max(worst, rho ** (1.0 / length))
    assert worst <= res.upper * (1 + 1e-9) + 1e-12
    assert res.lower <= res.upper * (1 + 1e-9) + 1e-12


# -- composed with a schedule ---------------------------------------------------------------
@pytest.mark.parametrize("sent", [[1, 0], [1, 1, 0], [0, 1, 1, 0]])
def test_a_budget_under_a_schedule_counts_transmissions_only(sent):
    """The actuator sends at the phases ``sent``; the budget takes a step
    only then (:meth:`LossAutomaton.periodic`): the loop's radius is the
    radius of the periodic automaton with lost/delivered matrices."""
    a, b = 2.0, 0.25
    budget = ncs.max_consecutive_losses(1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ncs.ScheduleWarning)
        P = scalar_plant(a, actuator_loss=budget, actuator_schedule=sent)
    res = ncs.jsr(ncs.feedback(P, [[b - a]]))
    want = ncs.jsr([[[a]], [[b]]], budget.periodic(sent))
    assert res.exact and want.exact
    assert res.upper == pytest.approx(want.upper, rel=1e-6)
    assert res.lower == pytest.approx(want.lower, rel=1e-9)
    # and by hand: over one period the worst is losing every other
    # transmission allowed, the rest applies a with nothing sent
    N = len(sent)
    words = closed_words(budget.periodic(sent), N * 2)
    hand = max(np.prod([b if d else a for d in w]) ** (1 / len(w))
               for w in words)
    assert hand <= res.upper * (1 + 1e-9)


def test_a_sensor_budget_and_an_actuator_budget_form_their_product():
    a, b = 1.8, 0.3
    sensor, actuator = ncs.weakly_hard(1, 3), ncs.max_consecutive_losses(1)
    P = scalar_plant(a, sensor_loss=sensor, actuator_loss=actuator)
    res = ncs.jsr(ncs.feedback(P, [[b - a]]))
    both = sensor.product(actuator)
    # the loop closes only when both arrive: the product automaton with
    # one matrix per pair of outcomes
    want = ncs.jsr({(0, 0): [[a]], (1, 0): [[a]], (0, 1): [[a]],
                    (1, 1): [[b]]}, both)
    assert res.upper == pytest.approx(want.upper, rel=1e-6)
    assert res.lower == pytest.approx(want.lower, rel=1e-9)


# -- the loop's matrices, by hand -----------------------------------------------------------
A_, B_, K_ = 1.3, 0.7, -1.1


def _hand(controller, actuator, t1, t2, extra):
    """The scalar loop of each controller kind, written out: ``(A, B)`` on
    its state, ``t1`` the sensor outcome the controller uses (for the
    controllers with memory, the measurement arriving at the step's end),
    ``t2`` the actuator's."""
    a, b, k = A_, B_, K_
    if controller == "static" and actuator == "zero":
        return [[a + t1 * t2 * b * k]], [[1.0]]
    if controller == "static":                      # [x; u_prev]
        if t2:
            return [[a + t1 * b * k, 0], [t1 * k, 0]], [[1.0], [0.0]]
        return [[a, b], [0, 1]], [[1.0], [0.0]]
    if controller in ("predictor", "estimator"):
        l = extra if controller == "estimator" else 1.0
        g = t1 * l
        if actuator == "zero":                      # [xh; e]
            return ([[a + t2 * b * k, g * a], [0, (1 - g) * a]],
                    [[g], [1 - g]])
        k1, k2 = k, 0.4                              # [xh; u_prev; e]
        u_row = [t2 * k1, t2 * k2 + (1 - t2), 0]    # u on [xh; u_prev; e]
        xh = [a + b * u_row[0], b * u_row[1], g * a]
        return ([xh, u_row, [0, 0, (1 - g) * a]], [[g], [0], [1 - g]])
    # an LTI controller xc⁺ = ac xc + bc ŷ, v = cc xc + dc ŷ on [x; xc; ŷ]
    ac, bc, cc, dc = extra
    hold = actuator == "hold-sensor"
    x_row = [a, t2 * b * cc, t2 * b * dc]
    y_row = [t1 * v for v in x_row]
    if hold and not t1:
        y_row[2] += 1.0
    return ([x_row, [0, ac, bc], y_row], [[1.0], [0.0], [t1 * 1.0]])


@pytest.mark.parametrize("controller, actuator", [
    ("static", "zero"), ("static", "hold"), ("predictor", "zero"),
    ("predictor", "hold"), ("estimator", "zero"), ("lti", "zero"),
    ("lti", "hold-sensor")])
def test_every_controller_kind_closes_a_budget_loop_as_written_by_hand(
        controller, actuator):
    P = scalar_plant(A_, B_, sensor_loss=ncs.weakly_hard(1, 2),
                     actuator_loss=ncs.max_consecutive_losses(1))
    extra = None
    if controller == "lti":
        extra = (0.5, 0.2, -0.3, K_)
        Kc = ct.ss([[extra[0]]], [[extra[1]]], [[extra[2]]], [[extra[3]]],
                   True)
        CL = ncs.feedback(P, Kc, sensor="hold" if actuator == "hold-sensor"
                          else "zero")
    elif controller == "estimator":
        extra = 0.6
        CL = ncs.feedback(P, [[K_]], controller="estimator",
                          estimator_gain=[[extra]])
    elif actuator == "hold" and controller == "predictor":
        CL = ncs.feedback(P, [[K_, 0.4]], controller=controller,
                          actuator=actuator)
    else:
        CL = ncs.feedback(P, [[K_]], controller=controller,
                          actuator=actuator)
    assert isinstance(CL, ncs.ConstrainedLoop) and not CL.random
    con = CL.constraint
    seen = set()
    for i in range(CL.A.shape[1]):
        (_, t1), (_, t2) = con.names[con.state[i]]
        A, B = _hand(controller, actuator, t1, t2, extra)
        np.testing.assert_allclose(CL.A[0, i], A, atol=1e-14)
        np.testing.assert_allclose(CL.B[0, i], B, atol=1e-14)
        seen.add((t1, t2))
    assert seen == {(0, 0), (0, 1), (1, 0), (1, 1)}


def test_gains_per_previous_mode_make_pairs_of_budget_states():
    P = scalar_plant(2.0, actuator_loss=ncs.max_consecutive_losses(1))
    plant = ncs.build(P)
    M = plant.probabilities.shape[1]
    con = plant.constraint
    # gain -2 after a delivery, -1 after a loss
    K = np.array([[[[-2.0 if con.names[con.state[ell]][1] else -1.0]]]
                  for ell in range(M)]).reshape(1, M, 1, 1)
    CL = ncs.feedback(P, K)
    # the pattern (lost, delivered): 2 then 2 - 1 = 1; (delivered) 0
    res = ncs.jsr(CL)
    assert res.lower == pytest.approx(np.sqrt(2.0 * 1.0), rel=1e-9)
    assert res.exact


# -- the design route ---------------------------------------------------------------------
def test_route_certifies_the_theorys_gain_example():
    """x⁺ = 1.5x + w + θu, z = x, at most one loss in a row: the pattern
    (lost, delivered) has gain 2 (theory: worst-case gain)."""
    P = scalar_plant(1.5, actuator_loss=ncs.max_consecutive_losses(1))
    res = ncs.worst_case_route(ncs.build(P), "hinf")
    assert res.status == "certified" and res.exact
    assert res.figure == pytest.approx(2.0, rel=1e-6)
    assert res.bound == pytest.approx(2.0, rel=1e-9)
    # the gains close the plant's loop as feedback does
    CL = ncs.feedback(P, res.gains)
    assert np.array_equal(CL.A, res.loop.A)
    again = ncs.worst_case_gain(CL.switching())
    assert again.figure == pytest.approx(res.figure, rel=1e-6)
    assert ncs.jsr(CL).upper < 1


def test_route_beats_a_bernoulli_design_that_fails_under_the_budget():
    """The theory's pair: an LQ gain for half the commands lost is
    mean-square stable, yet grows under at most one loss in a row."""
    A = np.array([[-0.9, 0.0], [1.3, 1.2]])
    B = np.array([[-1.0], [0.3]])
    plant = dict(nmeas=2, ncon=1)
    mats = (A, np.hstack([np.eye(2)[:, :1], B]),
            np.vstack([np.eye(2)[:1], np.eye(2)]), np.zeros((3, 2)))
    bernoulli = ncs.nss(*mats, actuator_loss=0.5, **plant)
    Klq, _, _ = ncs.dlqr(A, B, np.eye(2), np.eye(1), arrival=0.5)
    assert ncs.ms_radius(ncs.feedback(bernoulli, -Klq)) < 1
    budget = ncs.nss(*mats, actuator_loss=ncs.max_consecutive_losses(1),
                     **plant)
    fails = ncs.jsr(ncs.feedback(budget, -Klq))
    lost_then_delivered = A @ (A - B @ Klq)
    growth = max(abs(np.linalg.eigvals(lost_then_delivered))) ** 0.5
    assert growth > 1.05 ** 0.5 and fails.lower >= growth * (1 - 1e-12)
    res = ncs.worst_case_route(ncs.build(budget), "stability")
    assert res.rate < 1 and ncs.jsr(ncs.feedback(budget, res.gains)).upper < 1


def test_route_refuses_what_it_does_not_cover_by_name():
    budget = ncs.weakly_hard(1, 3)
    P = scalar_plant(2.0, actuator_loss=budget)
    with pytest.raises(ControlArgument, match="no loss budget"):
        ncs.worst_case_route(ncs.build(scalar_plant(2.0)))
    with pytest.raises(ControlArgument, match="controller='predictor'"):
        ncs.worst_case_route(ncs.build(P, "predictor"))
    with pytest.raises(ControlArgument, match="actuator='hold'"):
        ncs.worst_case_route(ncs.build(P, actuator="hold"))
    with pytest.raises(ControlArgument, match="random besides the budget"):
        ncs.worst_case_route(ncs.build(P.with_network(sensor_loss=0.1)))
    odd = ncs.loss_automaton([(0, 0, 1), (0, 1, 1), (1, 0, 0), (1, 1, 1)])
    with pytest.raises(ControlArgument, match="not deterministic"):
        ncs.worst_case_route(ncs.build(P.with_network(actuator_loss=odd)))
    with pytest.raises(ControlArgument, match="JumpPlant"):
        ncs.worst_case_route(P)
    with pytest.raises(ControlArgument, match="eta"):
        ncs.worst_case_route(ncs.build(P), "hinf", eta=0.1)


def test_the_designs_over_a_budget_certify_every_allowed_pattern():
    """hinfsyn and passivesyn take the worst-case route on a budget link;
    the figure they return is re-checked on the closed loop's switching
    view, pattern by pattern."""
    P = scalar_plant(1.5, actuator_loss=ncs.max_consecutive_losses(1))
    K, CL, gamma = ncs.hinfsyn(P)
    res = K.result
    assert res.spec == "hinf" and res.route == "program"
    assert gamma == pytest.approx(2.0, rel=1e-6)
    again = ncs.feedback(P, K)
    assert np.array_equal(again.A, CL.A) and ncs.jsr(again).upper < 1
    worst = ncs.worst_case_gain(again.switching())
    assert worst.figure <= gamma * (1 + 1e-6)
    assert "ms_radius" not in res.message     # no probabilities: no radius
    K, CL, eta = ncs.passivesyn(P)
    assert K.result.spec == "passivity" and math.isfinite(eta)
    assert ncs.jsr(CL).upper < 1


def test_averaging_designs_and_analyses_refuse_a_budget_by_name():
    P = scalar_plant(1.5, actuator_loss=ncs.max_consecutive_losses(1))
    with pytest.raises(ControlArgument, match="loss budget"):
        ncs.h2syn(P)
    with pytest.raises(ControlArgument, match="loss budget"):
        ncs.dlqr(P, [[1.0]], [[1.0]])
    S = scalar_plant(1.5, sensor_loss=ncs.weakly_hard(1, 3))
    with pytest.raises(ControlArgument, match="loss budget"):
        ncs.estimation_error_loop(S, [[1.0]])


# -- design maps over (misses, window) --------------------------------------------------
def test_design_map_over_misses_and_window_runs_the_route_per_cell():
    P = ncs.nss([[1.6]], [[1.0, 1.0]], [[1.0], [1.0]],
                [[0.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1)
    misses, windows = [0, 1, 2], [2, 3]
    dm = ncs.design_map(P, actuator_budget=(misses, windows),
                        objective="hinf", progress=False)
    assert dm.axes == ("actuator_misses", "actuator_window")
    assert dm.values[0].tolist() == misses and dm.values[1].tolist() == \
        windows
    for i, m in enumerate(misses):
        for j, K in enumerate(windows):
            if m >= K:
                # every command may be lost forever and |a| > 1: proven
                assert dm.reason[i, j] == "infeasible" and not \
                    dm.feasible[i, j]
                continue
            assert dm.feasible[i, j] and dm.reason[i, j] == "certified"
    # a cell is the route on that cell's plant
    cell = ncs.worst_case_route(ncs.build(P.with_network(
        actuator_loss=ncs.weakly_hard(1, 3))), "hinf")
    assert dm.value[1, 1] == pytest.approx(cell.figure, rel=1e-6)
    assert dm.ms_radius[1, 1] == pytest.approx(cell.rate ** 2, rel=1e-6)
    assert np.isnan(dm.eta).all()
    # no loss: the deadbeat gain, z = x = w delayed, gain 1
    assert dm.value[0, 0] == pytest.approx(1.0, rel=1e-6)


def test_design_map_over_a_budget_refuses_what_it_cannot_design():
    P = ncs.nss([[1.6]], [[1.0, 1.0]], [[1.0], [1.0]],
                [[0.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1)
    grid = ([1], [3])
    with pytest.raises(ControlArgument, match="no probabilities"):
        ncs.design_map(P, actuator_budget=grid, objective="h2",
                       progress=False)
    with pytest.raises(ControlArgument, match="perfect"):
        ncs.design_map(P, [0.1], actuator_budget=grid, progress=False)
    with pytest.raises(ControlArgument, match="give no actuator_loss"):
        ncs.design_map(P, [0.0], [0.1, 0.2], actuator_budget=grid,
                       progress=False)
    with pytest.raises(ControlArgument, match="two axes"):
        ncs.design_map(P, actuator_budget=grid, sensor_budget=grid,
                       progress=False)
    with pytest.raises(ValueError, match="window"):
        ncs.design_map(P, actuator_budget=([1], [0]), progress=False)
    with pytest.raises(ControlArgument, match="static"):
        ncs.design_map(P, actuator_budget=grid, controller="predictor",
                       progress=False)
