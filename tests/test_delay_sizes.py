"""Delay links that no loop could hold are refused when they are made, and
a link's send flags are flags."""

import tracemalloc

import numpy as np
import pytest

import control_ncs as ncs
import control_ncs.delays as delays
from control_ncs.delays import MAX_BUFFER


def scalar_plant(**network_settings):
    return ncs.nss([[1.1]], [[1.0, 1.0]], [[1.0], [1.0]],
                   [[0.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
                   **network_settings)


@pytest.fixture
def no_chain_is_built(monkeypatch):
    """Building an age chain (the first large allocation) fails the test."""
    def refuse(*args, **kwargs):
        raise AssertionError("an age chain was built")
    monkeypatch.setattr(delays, "age_chain", refuse)


# -- sizes ------------------------------------------------------------------------
def test_huge_buffer_is_refused_at_construction_naming_the_loop_it_needs(
        no_chain_is_built):
    tracemalloc.start()
    try:
        with pytest.raises(ValueError) as info:
            ncs.random_delay([0.5, 0.3], buffer=10**6)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    message = str(info.value)
    assert message.startswith("buffer: a buffer of 1000000 ages")
    assert "a chain of 1000002 states" in message
    assert "at least 1000001 states in 1000002 modes" in message
    assert f"MAX_BUFFER = {MAX_BUFFER}" in message
    assert peak < 2**20          # nothing of the chain's size was allocated


def test_pmf_with_a_delay_beyond_the_cap_is_refused_naming_the_delay(
        no_chain_is_built):
    pmf = np.full(10**6, 0.5e-6)
    with pytest.raises(ValueError, match=r"^pmf: a delay of up to 999999 "
                       r"steps \(a buffer of 999999 ages\) would make the "
                       r"link a chain of 1000001 states"):
        ncs.random_delay(pmf)


def test_long_pmf_whose_tail_is_zero_is_the_short_law():
    pmf = np.zeros(10**6)
    pmf[:3] = [0.5, 0.3, 0.1]
    link = ncs.random_delay(pmf)
    assert link == ncs.random_delay([0.5, 0.3, 0.1])
    assert link.buffer == 2 and link.pmf.size == 3


def test_plant_given_a_long_pmf_is_refused_naming_the_link(no_chain_is_built):
    with pytest.raises(ValueError, match="^sensor_delay: pmf: a delay of up "
                       "to 999 steps"):
        scalar_plant(sensor_delay=np.full(1000, 1e-3))


@pytest.mark.parametrize("laws, buffer, match", [
    (([0.2], [0.7, 0.3]), 10**6, "^buffer: a buffer of 1000000 ages would "
     "make the link a chain of 2000004 states"),
    (([0.2], np.full(10**6, 0.5e-6)), None, r"^pmf_bad, pmf_good: a delay "
     r"of up to 999999 steps"),
])
def test_huge_bursty_delay_is_refused_at_construction(no_chain_is_built,
                                                      laws, buffer, match):
    link = ncs.gilbert_elliott(fail=0.1, recover=0.4)
    with pytest.raises(ValueError, match=match):
        ncs.bursty_delay(link, *laws, buffer=buffer)


@pytest.mark.parametrize("make", [
    lambda D: ncs.random_delay([0.5, 0.3], buffer=D),
    lambda D: ncs.bursty_delay(ncs.gilbert_elliott(fail=0.1, recover=0.4),
                               [0.2], [0.7, 0.3], buffer=D),
    lambda D: ncs.random_delay(np.full(D + 1, 0.5 / (D + 1))),
])
def test_the_cap_is_the_last_buffer_accepted(make):
    assert make(MAX_BUFFER).buffer == MAX_BUFFER
    with pytest.raises(ValueError, match=f"{MAX_BUFFER + 1} ages"):
        make(MAX_BUFFER + 1)


@pytest.mark.parametrize("D", [1, 3])
def test_the_named_minimum_loop_is_what_the_builder_writes(D):
    # the message says "at least D + 1 states in D + 2 modes per phase":
    # the smallest loop (one state, a static gain) is at least that large
    P = scalar_plant(sensor_delay=ncs.random_delay([0.5, 0.3], buffer=D))
    plant = ncs.build(P)
    assert plant.A.shape[-1] >= D + 1
    assert plant.probabilities.shape[-1] >= D + 2


# -- send flags -------------------------------------------------------------------
@pytest.mark.parametrize("sent", [[2, 0], [1, 0.5], [1, -1], ["1", "0"],
                                  [1, np.nan], [], [[1, 0], [0, 1]]])
def test_age_transition_refuses_anything_but_flags(sent):
    link = ncs.random_delay([0.5, 0.3])
    with pytest.raises(ValueError, match=r"^sent: expected one flag \(a "
                       r"bool, or 0/1\) per phase"):
        link.age_transition(sent)


def test_bursty_transition_refuses_anything_but_flags():
    link = ncs.bursty_delay(ncs.gilbert_elliott(fail=0.1, recover=0.4),
                            [0.2], [0.7, 0.3])
    with pytest.raises(ValueError, match="^sent: expected one flag"):
        link.transition([2, 0])


@pytest.mark.parametrize("sent", [[1, 0], [1.0, 0.0], np.array([1, 0]),
                                  (True, False)])
def test_bools_and_zero_one_flags_give_the_same_chain(sent):
    link = ncs.random_delay([0.5, 0.3])
    assert np.array_equal(link.age_transition(sent),
                          link.age_transition([True, False]))


def test_a_loop_whose_mode_matrices_exceed_memory_is_refused_before_allocation(
        monkeypatch):
    # an estimator over two delayed links on a 60-state plant: 1008 modes
    # of 1325 states, 15 GiB of mode matrices (the process was killed
    # before the builder refused it)
    import control_ncs.strategies as strategies
    n = 60
    P = ncs.nss(0.5 * np.eye(n), np.ones((n, 2)), np.ones((2, n)),
               np.zeros((2, 2)), nmeas=1, ncon=1,
               sensor_delay=ncs.random_delay([0.1] * 9 + [0.05], buffer=10),
               actuator_delay=ncs.random_delay([0.5, 0.3], buffer=5))
    built = []
    original = strategies._assemble
    monkeypatch.setattr(strategies, "_assemble",
                        lambda *a: built.append(1) or original(*a))
    with pytest.raises(ValueError, match="MAX_MODE_BYTES") as info:
        ncs.feedback(P, [[-0.1]], controller="estimator",
                    estimator_gain=0.01 * np.ones((n, 1)))
    assert "1008 modes x 1325 states" in str(info.value)
    assert len(built) == 1                  # one mode's matrices, no more


def test_a_markov_mean_beyond_memory_is_refused_naming_its_order():
    import control_ncs.jump as jump
    M, n = 300, 60                            # order 18000: 2.4 GiB
    A = np.zeros((M, n, n))
    T = np.roll(np.eye(M), 1, axis=1)         # a cycle: Markov, not i.i.d.
    with pytest.raises(ValueError, match="order 18000") as info:
        ncs.jss(A, np.zeros((n, 1)), np.zeros((1, n)), [[0.0]],
               transition=T)
    assert f"{jump.MAX_MEAN_BYTES / 2 ** 30:.3g} GiB" in str(info.value)
