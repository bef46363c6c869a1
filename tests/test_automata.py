"""Loss automata accept exactly the patterns their budgets describe.

Languages are checked by brute force over every 0/1 word up to length 12
against the budget written out in the test (a sliding window, a run
length), not against another automaton.
"""

import itertools
import pickle

import numpy as np
import pytest
from control.exception import ControlArgument

import control_ncs as ncs
from control_ncs.automata import MAX_STATES

WORDS = [w for length in range(13)
         for w in itertools.product((0, 1), repeat=length)]


def _windows_ok(word, misses, window):
    """At most ``misses`` zeros in every ``window`` consecutive outcomes
    (windows of a short word are the word itself)."""
    width = min(window, len(word))
    return all(word[i:i + width].count(0) <= misses
               for i in range(len(word) - width + 1))


def _longest_run_of_losses(word):
    run = best = 0
    for d in word:
        run = run + 1 if d == 0 else 0
        best = max(best, run)
    return best


@pytest.mark.parametrize("k", [0, 1, 2, 3])
def test_max_consecutive_losses_and_weakly_hard_k_of_k_plus_1_agree(k):
    a, b = ncs.max_consecutive_losses(k), ncs.weakly_hard(k, k + 1)
    for w in WORDS:
        assert a.allows(w) == b.allows(w) == (_longest_run_of_losses(w) <= k)


@pytest.mark.parametrize("misses, window",
                         [(0, 3), (1, 2), (1, 4), (2, 5), (3, 5), (2, 7),
                          (1, 1), (4, 4)])
def test_weakly_hard_accepts_exactly_the_words_within_the_budget(misses,
                                                                  window):
    aut = ncs.weakly_hard(misses, window)
    for w in WORDS:
        assert aut.allows(w) == _windows_ok(w, misses, window), w


@pytest.mark.parametrize("misses, window", [(2, 5), (3, 9), (1, 12)])
def test_weakly_hard_has_the_stated_number_of_states(misses, window):
    from math import comb
    aut = ncs.weakly_hard(misses, window)
    assert len(aut.states) == sum(comb(window - 1, i)
                                  for i in range(misses + 1))
    assert aut.states[0] == "1" * (window - 1) == aut.initial[0]


def test_weakly_hard_refuses_a_huge_automaton_naming_its_size():
    with pytest.raises(ValueError, match="states"):
        ncs.weakly_hard(15, 40)


def test_weakly_hard_refuses_more_misses_than_the_window():
    with pytest.raises(ValueError, match="misses"):
        ncs.weakly_hard(5, 2)


def test_product_allows_a_pair_pattern_iff_each_link_allows_its_own():
    a, b = ncs.max_consecutive_losses(1), ncs.weakly_hard(1, 3)
    both = a.product(b)
    assert both.channels == 2
    for w1 in itertools.product((0, 1), repeat=5):
        for w2 in itertools.product((0, 1), repeat=5):
            assert both.allows(list(zip(w1, w2))) == (a.allows(w1)
                                                      and b.allows(w2))


def test_periodic_skips_phases_that_send_nothing():
    aut = ncs.weakly_hard(1, 3)
    sent = [1, 0, 1]
    lifted = aut.periodic(sent)
    for w in itertools.product((0, 1), repeat=9):
        # idle phases carry 0; the budget reads the transmitted outcomes
        idle_ok = all(w[t] == 0 for t in range(9) if not sent[t % 3])
        sent_only = [w[t] for t in range(9) if sent[t % 3]]
        assert lifted.allows(w) == (idle_ok and aut.allows(sent_only))


def test_product_of_two_periodic_links_keeps_the_phases_aligned():
    one = ncs.max_consecutive_losses(1).periodic([1, 0])
    both = one.product(one)
    assert {(s1[1], s2[1]) for s1, s2 in both.states} == {(0, 0), (1, 1)}


def test_automaton_survives_pickling_and_compares_equal():
    aut = ncs.weakly_hard(2, 5).product(ncs.max_consecutive_losses(2))
    again = pickle.loads(pickle.dumps(aut))
    assert again == aut and hash(again) == hash(aut)
    assert again.allows([(0, 0), (1, 0), (0, 1)])
    assert aut != ncs.weakly_hard(2, 5)


def test_automaton_is_immutable():
    aut = ncs.max_consecutive_losses(2)
    with pytest.raises(AttributeError):
        aut.name = "other"


def test_transition_graph_lists_the_edges_by_state_index():
    aut = ncs.weakly_hard(1, 3)
    src, dst, d = aut.transition_graph()
    pairs = {(aut.states[i], aut.states[j], int(x))
             for i, j, x in zip(src, dst, d)}
    assert pairs == set(aut.edges)
    assert src.dtype.kind == "i" and src.shape == d.shape


def test_repr_and_summary_name_the_budget():
    aut = ncs.weakly_hard(2, 5)
    assert "at most 2 lost in any 5" in repr(aut)
    assert aut.summary().startswith("LossAutomaton: at most 2 lost in any 5")


def test_loss_automaton_refuses_an_outcome_other_than_0_or_1():
    with pytest.raises(ValueError, match="delivered"):
        ncs.loss_automaton([(0, 0, 2)])


def test_loss_automaton_refuses_a_state_without_a_next_transmission():
    with pytest.raises(ValueError, match="no outgoing edge"):
        ncs.loss_automaton([(0, 0, 1), (0, 1, 0)])


def test_loss_automaton_refuses_a_state_unreachable_from_the_start():
    with pytest.raises(ValueError, match="cannot be reached"):
        ncs.loss_automaton([(0, 0, 1), (1, 1, 0)], initial=0)


def test_loss_automaton_accepts_a_start_up_phase_on_no_cycle():
    aut = ncs.loss_automaton([("boot", "run", 1), ("run", "run", 1),
                              ("run", "run", 0)], initial="boot")
    assert aut.allows([1, 0, 0]) and not aut.allows([0])


def test_loss_automaton_refuses_mixed_numbers_of_links():
    with pytest.raises(ControlArgument, match="outcome"):
        ncs.loss_automaton([(0, 0, 1), (0, 0, (1, 0))])


def test_loss_automaton_refuses_an_unknown_initial_state():
    with pytest.raises(ValueError, match="initial"):
        ncs.loss_automaton([(0, 0, 1)], initial=3)


def test_constructor_refuses_an_edge_naming_a_missing_state():
    with pytest.raises(ValueError, match="not one of"):
        ncs.LossAutomaton(2, [(0, 1, 1), (1, 2, 0)])


def test_product_refuses_a_huge_result_before_building_it():
    big = ncs.max_consecutive_losses(MAX_STATES // 10)
    with pytest.raises(ValueError, match="states"):
        big.product(ncs.max_consecutive_losses(20))


def test_allows_checks_the_number_of_outcomes_per_step():
    both = ncs.max_consecutive_losses(1).product(ncs.max_consecutive_losses(1))
    with pytest.raises(ControlArgument, match="outcome"):
        both.allows([1, 0])


def test_duplicate_edges_count_once():
    aut = ncs.loss_automaton([(0, 0, 1), (0, 0, 1), (0, 0, np.int64(0))])
    assert len(aut.edges) == 2
