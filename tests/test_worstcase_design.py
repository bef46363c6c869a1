"""State feedback certified for every allowed loss pattern, against closed
forms, the package's Bernoulli and loss-free designs, and brute force over
patterns (theory: worst-case dissipativity)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from control.exception import ControlArgument

import control_ncs as ncs

#: At most one command lost in a row (mode 0 lost, 1 delivered), by hand.
ONE_LOSS_IN_A_ROW = [(0, 0, 1), (0, 1, 0), (1, 0, 1)]

#: At most two lost in a row.
TWO_LOSSES_IN_A_ROW = [(0, 0, 1), (0, 1, 0), (1, 0, 1), (1, 2, 0), (2, 0, 1)]


def theory_plant():
    """x⁺ = 1.5x + w + θu, z = x (theory: worst-case loss patterns)."""
    return ncs.ConstrainedPlant.lossy(1.5, 1.0, 1.0, 1.0, 0.0, 0.0,
                                      ONE_LOSS_IN_A_ROW)


def closed_walk_rates(A_of_edge, edges, max_length):
    """``ρ(A_w)^(1/|w|)`` of every closed walk up to ``max_length`` edges,
    by brute force: every walk from every node, depth first."""
    rates = []
    n = A_of_edge(0).shape[0]
    for start in {u for u, _, _ in edges}:
        stack = [(start, np.eye(n), 0)]
        while stack:
            node, T, k = stack.pop()
            if k and node == start:
                rates.append(max(abs(np.linalg.eigvals(T))) ** (1 / k))
            if k < max_length:
                stack += [(v, A_of_edge(e) @ T, k + 1)
                          for e, (u, v, _) in enumerate(edges) if u == node]
    return np.array(rates)


def test_gain_design_reaches_two_the_least_any_linear_feedback_allows():
    # from rest, delivered then lost: x1 = w0 (u0 = K·0), x2 = 1.5 w0 + w1
    # whatever the gain, so z = (0, w0, 1.5w0 + w1): gain σmax([[1, 0],
    # [1.5, 1]]) = 2 for every linear state feedback
    res = ncs.worst_case_design(theory_plant(), spec="gain")
    assert 2.0 <= res.figure <= 2.0 * (1 + 1e-6)
    assert res.bound == pytest.approx(2.0, rel=1e-9) and res.exact
    assert res.rate < 1


def test_the_figure_is_the_fixed_loops_analysis_not_the_lmis():
    P = theory_plant()
    res = ncs.worst_case_design(P, spec="gain", memory=1)
    lift = P.graph.lift(1)
    loop = P.close(res.K, lift)
    assert np.array_equal(loop.A, res.loop.A)
    again = ncs.worst_case_gain(loop)
    assert res.figure == again.figure and res.analysis.figure == res.figure
    assert res.K.shape == (len(lift.walks), 1, 1)


def test_bernoulli_lq_gain_fails_the_budget_the_worst_case_design_meets():
    A = np.array([[-0.9, 0.0], [1.3, 1.2]])
    B = np.array([[-1.0], [0.3]])
    # the LQ gain for commands lost half the time, independently
    K_b, _, _ = ncs.dlqr(A, B, np.eye(2), np.eye(1), arrival=0.5)
    A_b = A - B @ K_b
    # mean-square stable on average (second moments: 0.5 A⊗A + 0.5 Ab⊗Ab)
    ms = 0.5 * np.kron(A, A) + 0.5 * np.kron(A_b, A_b)
    assert max(abs(np.linalg.eigvals(ms))) < 1
    # ... but the allowed pattern (lost, delivered), repeated, grows
    assert max(abs(np.linalg.eigvals(A_b @ A))) > 1.05
    P = ncs.ConstrainedPlant.lossy(A, B, np.eye(2), np.eye(2),
                                   np.zeros((2, 1)), np.zeros((2, 2)),
                                   ONE_LOSS_IN_A_ROW)
    assert ncs.worst_case_rate(P.close(-K_b)).status == "not_mss"
    res = ncs.worst_case_design(P, spec="stability")
    assert res.status == "certified" and res.rate < 1
    # every closed walk of the designed loop up to 10 steps, by brute force:
    # the gain of the node an edge leaves
    edges = ONE_LOSS_IN_A_ROW
    rates = closed_walk_rates(
        lambda e: A + edges[e][2] * B @ res.K[edges[e][0]], edges, 10)
    assert rates.max() <= res.rate * (1 + 1e-9)


def test_a_rate_is_met_for_every_pattern():
    P = ncs.ConstrainedPlant.lossy(2.0, 1.0, 1.0, 1.0, 0.0, 0.0,
                                   TWO_LOSSES_IN_A_ROW)
    res = ncs.worst_case_design(P, spec="stability", rate=0.5)
    assert res.rate < 0.5 and res.figure <= res.rate
    edges = TWO_LOSSES_IN_A_ROW
    rates = closed_walk_rates(
        lambda e: np.array([[2.0 + edges[e][2] * res.K[edges[e][0], 0, 0]]]),
        edges, 9)
    assert rates.max() <= res.rate * (1 + 1e-9)


def test_a_growing_pattern_without_commands_is_proven_infeasible():
    # every command may be lost forever: x⁺ = 1.2x, no gain helps
    P = ncs.ConstrainedPlant.lossy(1.2, 1.0, 1.0, 1.0, 0.0, 0.0,
                                   [(0, 0, 0), (0, 0, 1)])
    with pytest.raises(ncs.SynthesisError) as info:
        ncs.worst_case_design(P, spec="gain")
    assert info.value.reason == "infeasible"
    assert info.value.figures["cycle"] == (0,)


def test_one_gain_for_every_node_is_never_better_than_gains_per_node():
    A = np.array([[-0.9, 0.0], [1.3, 1.2]])
    B = np.array([[-1.0], [0.3]])
    P = ncs.ConstrainedPlant.lossy(A, B, np.eye(2), np.eye(2),
                                   np.zeros((2, 1)), np.zeros((2, 2)),
                                   ONE_LOSS_IN_A_ROW)
    node = ncs.worst_case_design(P, spec="stability", rate=0.95)
    common = ncs.worst_case_design(P, spec="stability", rate=0.95,
                                   gain="common")
    assert common.K.shape == (1, 2) and common.rate < 0.95
    # the rate LMI with one gain is a special case of the node gains' one
    assert common.gain == "common" and node.gain == "node"


def test_more_memory_never_worsens_the_design_lmi():
    A = np.array([[-0.9, 0.0], [1.3, 1.2]])
    B = np.array([[-1.0], [0.3]])
    P = ncs.ConstrainedPlant.lossy(A, B, np.eye(2), 0.1 * np.eye(2),
                                   np.zeros((2, 1)), np.zeros((2, 2)),
                                   ONE_LOSS_IN_A_ROW)
    res = [ncs.worst_case_design(P, spec="gain", memory=M, cycle_length=6)
           for M in (0, 1)]
    assert res[1].figure_synthesis <= res[0].figure_synthesis * (1 + 1e-6)
    assert all(r.bound <= r.figure for r in res)


def loss_free_plant():
    A = np.array([[1.1, 0.4], [0.0, 0.9]])
    B1, B2 = np.array([[1.0], [0.5]]), np.array([[0.0], [1.0]])
    return A, B1, B2


def test_one_mode_gain_design_agrees_with_hinfsyn():
    A, B1, B2 = loss_free_plant()
    C1 = np.array([[1.0, 0.0], [0.0, 0.0]])
    D12 = np.array([[0.0], [1.0]])
    P = ncs.nss(A, np.hstack([B1, B2]), np.vstack([C1, np.eye(2)]),
                np.block([[np.zeros((2, 1)), D12], [np.zeros((2, 2))]]),
                True, nmeas=2, ncon=1)
    _, _, gamma = ncs.hinfsyn(P)
    res = ncs.worst_case_design((A, B2, B1, C1, D12, np.zeros((2, 1))),
                                spec="gain")
    assert res.figure == pytest.approx(gamma, rel=1e-5)
    assert res.bound <= res.figure and res.exact


def test_one_mode_passivity_design_is_at_least_passivesyns():
    A, B1, B2 = loss_free_plant()
    C, D = np.array([[1.0, 0.5]]), np.array([[0.5]])
    P = ncs.nss(A, np.hstack([B1, B2]), np.vstack([C, np.eye(2)]),
                np.block([[D, np.zeros((1, 1))], [np.zeros((2, 2))]]),
                True, nmeas=2, ncon=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")     # its level is a shortage
        _, _, eta = ncs.passivesyn(P)
    res = ncs.worst_case_design((A, B2, B1, C, np.zeros((1, 1)), D),
                                spec="passivity")
    assert res.figure >= eta - 1e-6
    assert res.figure <= res.bound and res.status == "certified_shortage"


def test_passivity_design_with_a_rate_decays_at_it():
    P = ncs.ConstrainedPlant.lossy(1.5, 1.0, 1.0, 1.0, 0.0, 2.0,
                                   ONE_LOSS_IN_A_ROW)
    free = ncs.worst_case_design(P, spec="passivity")
    fast = ncs.worst_case_design(P, spec="passivity", rate=0.5)
    assert fast.rate < 0.5 and fast.figure <= free.figure + 1e-9
    assert free.figure <= free.bound


def test_bad_arguments_are_refused_by_name():
    with pytest.raises(ControlArgument, match="spec"):
        ncs.worst_case_design(theory_plant(), spec="h2")
    with pytest.raises(ValueError, match="memory"):
        ncs.worst_case_design(theory_plant(), memory=-1)
    with pytest.raises(ControlArgument, match="graph"):
        ncs.worst_case_design(theory_plant(), ONE_LOSS_IN_A_ROW)


def test_results_survive_pickling():
    import pickle
    res = ncs.worst_case_design(theory_plant(), spec="gain")
    again = pickle.loads(pickle.dumps(res))
    assert again.figure == res.figure and again.status == res.status
    assert np.array_equal(again.K, res.K)
    assert again.analysis.cycle == res.analysis.cycle
