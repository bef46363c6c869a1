"""Schedules and loss models (theory: conventions, §3; paper eq. 14)."""

import pickle

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from control_ncs import Schedule, mode_probabilities, schedule
from control_ncs.network import common_period

from helpers import random_plant

PAPER_S1 = [2, 1, 0, 2]


def senders_by_time(sched, times):
    """1-based sensor numbers that may send at each time (0-based list)."""
    return {k: (sched.senders(k) + 1).tolist() for k in times}


# -- the paper's example (theory: network) -----------------------------------------
def test_paper_schedule_sensor_one_sends_at_k_1_and_5():
    s = schedule(PAPER_S1, nodes=2)
    times = [k for k in range(12) if 1 in senders_by_time(s, [k])[k]]
    assert times == [1, 5, 9]


def test_paper_schedule_sensor_two_sends_at_k_0_3_4_7():
    s = schedule(PAPER_S1, nodes=2)
    times = [k for k in range(8) if 2 in senders_by_time(s, [k])[k]]
    assert times == [0, 3, 4, 7]


def test_paper_schedule_nobody_sends_at_k_2_and_6():
    s = schedule(PAPER_S1, nodes=2)
    silent = [k for k in range(8) if s.senders(k).size == 0]
    assert silent == [2, 6]
    assert np.array_equal(s.selection(2), np.zeros((2, 2)))
    assert np.array_equal(s.selection(6), np.zeros((2, 2)))


def test_paper_schedule_through_nss():
    P = random_plant(np.random.default_rng(0), n=2,
                     sensor_schedule=PAPER_S1)
    assert P.period == 4
    got = senders_by_time(P.sensor_schedule, range(7))
    assert got == {0: [2], 1: [1], 2: [], 3: [2], 4: [2], 5: [1], 6: []}


def test_selection_matrix_is_the_diagonal_of_the_pattern_row():
    s = schedule(PAPER_S1, nodes=2)
    # Σ1,k = S1ᵀ S1 with S1 the paper's row selector e_i ᵀ (theory: network)
    for k, who in enumerate(PAPER_S1 * 2):
        S_row = np.zeros((1, 2)) if who == 0 else np.eye(2)[[who - 1]]
        assert np.array_equal(s.selection(k), S_row.T @ S_row)


# -- other descriptions ----------------------------------------------------
def test_matrix_schedule_lets_several_sensors_send_in_one_slot():
    s = schedule([[1, 1, 0], [0, 0, 1]], nodes=3)
    assert s.period == 2
    assert s.senders(0).tolist() == [0, 1]
    assert s.senders(3).tolist() == [2]
    assert np.array_equal(s.selection(0), np.diag([1.0, 1.0, 0.0]))


def test_boolean_matrix_schedule_is_a_zero_one_matrix():
    s = schedule(np.array([[True, False], [True, True]]), nodes=2)
    assert s == schedule([[1, 0], [1, 1]], nodes=2)


def test_none_schedule_means_everyone_every_step():
    s = schedule(None, nodes=3)
    assert s.period == 1 and s.is_everyone
    assert all(s.senders(k).tolist() == [0, 1, 2] for k in range(5))
    assert np.array_equal(s.selection(7), np.eye(3))


def test_index_vector_and_equivalent_matrix_give_the_same_schedule():
    assert schedule([2, 0, 1], 2) == schedule([[0, 1], [0, 0], [1, 0]], 2)


def test_schedule_object_passes_through_and_keeps_its_pattern():
    s = schedule(PAPER_S1, nodes=2)
    assert schedule(s, nodes=2) == s


def test_common_period_is_the_least_common_multiple():
    a, b = schedule([1, 0], 1), schedule([1, 0, 0], 1)
    assert common_period(a, b) == 6
    assert common_period(a, schedule([1, 0, 1, 0], 1)) == 4


def test_nss_writes_both_schedules_over_the_lcm_of_their_periods():
    s1, s2 = [1, 0], [0, 1, 1]
    P = random_plant(np.random.default_rng(1), n=1, sensor_schedule=s1,
                     actuator_schedule=s2)
    assert P.period == 6
    assert P.sensor_schedule.period == P.actuator_schedule.period == 6
    for k in range(12):
        assert P.sensor_schedule.selection(k)[0, 0] == s1[k % 2]
        assert P.actuator_schedule.selection(k)[0, 0] == s2[k % 3]


def test_repeat_rejects_a_period_that_is_not_a_multiple():
    with pytest.raises(ValueError, match="period 3"):
        schedule([1, 0], 1).repeat(3)


def test_schedule_pickles_and_compares_by_pattern():
    s = schedule(PAPER_S1, nodes=2, name="sensor_schedule")
    t = pickle.loads(pickle.dumps(s))
    assert isinstance(t, Schedule) and t == s and hash(t) == hash(s)
    assert s != schedule([1, 2, 0, 2], nodes=2)


def test_schedule_pattern_is_read_only():
    s = schedule(PAPER_S1, nodes=2)
    with pytest.raises(ValueError):
        s.pattern[0, 0] = True


# -- eq. 14 ------------------------------------------------------------------
@pytest.mark.parametrize("a1, a2, expected", [
    # (θ1, θ2) = (0,0), (1,0), (0,1), (1,1), worked by hand
    (0.1, 0.2, (0.02, 0.18, 0.08, 0.72)),
    (0.0, 0.0, (0.0, 0.0, 0.0, 1.0)),
    (1.0, 0.5, (0.5, 0.0, 0.5, 0.0)),
    (0.25, 0.75, (0.1875, 0.5625, 0.0625, 0.1875)),
])
def test_eq14_probabilities_at_worked_points(a1, a2, expected):
    p = mode_probabilities(a1, a2)
    got = tuple(p[m] for m in ((0, 0), (1, 0), (0, 1), (1, 1)))
    assert got == pytest.approx(expected, abs=1e-15)


@settings(max_examples=25, deadline=None)
@given(a1=st.floats(0, 1), a2=st.floats(0, 1))
def test_eq14_probabilities_are_the_product_of_independent_bernoullis(a1, a2):
    p = mode_probabilities(a1, a2)
    for (t1, t2), value in p.items():
        # θ = 1 (arrived) has probability 1 - α (theory: conventions)
        expect = (a1 if t1 == 0 else 1 - a1) * (a2 if t2 == 0 else 1 - a2)
        assert value == pytest.approx(expect, abs=1e-15)


@settings(max_examples=25, deadline=None)
@given(a1=st.floats(0, 1), a2=st.floats(0, 1))
def test_eq14_probabilities_sum_to_one_and_have_the_loss_marginals(a1, a2):
    p = mode_probabilities(a1, a2)
    assert set(p) == {(0, 0), (1, 0), (0, 1), (1, 1)}
    assert all(v >= 0 for v in p.values())
    assert sum(p.values()) == pytest.approx(1.0, abs=1e-14)
    assert p[(0, 0)] + p[(0, 1)] == pytest.approx(a1, abs=1e-14)  # P(θ1 = 0)
    assert p[(0, 0)] + p[(1, 0)] == pytest.approx(a2, abs=1e-14)  # P(θ2 = 0)


def test_eq14_loop_closes_with_probability_q():
    a1, a2 = 0.3, 0.15
    assert mode_probabilities(a1, a2)[(1, 1)] == pytest.approx(
        (1 - a1) * (1 - a2), abs=1e-15)


def test_nss_mode_probabilities_use_its_own_losses():
    P = random_plant(np.random.default_rng(2), sensor_loss=0.3,
                     actuator_loss=0.15)
    assert P.mode_probabilities() == mode_probabilities(0.3, 0.15)
