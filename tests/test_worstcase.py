"""Worst-case gain, passivity and decay rate over every allowed pattern,
against closed forms, python-control and brute force over patterns
(theory: worst-case dissipativity)."""

from __future__ import annotations

import itertools
import math

import control as ct
import numpy as np
import pytest
from control.exception import ControlArgument, ControlDimension
from hypothesis import given, settings, strategies as st

import control_ncs as ncs

#: At most one loss in a row: node 0 after a delivery, node 1 after a loss
#: (mode 0 lost, mode 1 delivered); built by hand from its definition.
ONE_LOSS_IN_A_ROW = [(0, 0, 1), (0, 1, 0), (1, 0, 1)]

#: At most one loss in any three (weakly hard): nodes are the last two
#: outcomes with at most one loss, 0 = (1, 1), 1 = (1, 0), 2 = (0, 1).
ONE_IN_THREE = [(0, 0, 1), (0, 1, 0), (1, 2, 1), (2, 0, 1)]

#: The pair of Ahmadi, Jungers, Parrilo and Roozbehani (JSR
#: 3.917384715148 = ρ(A1 A2)^½).
AJPR = np.array([[[-1.0, -1.0], [-4.0, 0.0]], [[3.0, 3.0], [-2.0, 1.0]]])


def theory_example():
    """x⁺ = 1.5x + w + θu, u = -1.5x, z = x: lost a = 1.5, delivered 0."""
    return ncs.SwitchingSystem([[[1.5]], [[0.0]]], [[1.0]], [[1.0]],
                               [[0.0]], ONE_LOSS_IN_A_ROW)


def lifted(A, B, C, D, modes):
    """The pattern's lift over one period, written from its definition:
    x_{k+1} = A_k x_k + B_k w_k stepped one column of inputs at a time."""
    n, m, p, L = A.shape[-1], B.shape[-1], C.shape[-2], len(modes)
    Phi = np.eye(n)
    for i in modes:
        Phi = A[i] @ Phi
    Gam = np.zeros((n, L * m))
    Psi = np.zeros((L * p, n))
    Delta = np.zeros((L * p, L * m))
    for col in range(L * m + 1):
        # col < L m: unit input at one step from rest; col = L m: x0 = I
        x = np.zeros((n, 1)) if col < L * m else np.eye(n)
        for k, i in enumerate(modes):
            w = np.zeros((m, x.shape[1]))
            if col < L * m and col // m == k:
                w[col % m, 0] = 1.0
            z = C[i] @ x + D[i] @ w
            if col < L * m:
                Delta[k * p:(k + 1) * p, col] = z[:, 0]
            else:
                Psi[k * p:(k + 1) * p] = z
            x = A[i] @ x + B[i] @ w
        if col < L * m:
            Gam[:, col] = x[:, 0]
    return Phi, Gam, Psi, Delta


# -- the theory page's example ------------------------------------------------
def test_the_theory_example_is_certified_at_gain_two():
    res = ncs.worst_case_gain(theory_example())
    assert res.status == "certified" and res.exact
    assert 2.0 <= res.figure <= 2.0 * (1 + 1e-7)
    assert res.bound == pytest.approx(2.0, rel=1e-12)
    assert set(itertools.permutations(res.cycle)) >= {(0, 1)}


def test_the_pattern_lost_then_delivered_has_gain_two_at_every_frequency():
    # Φ = 0·1.5: G(z) = Δ + Ψ Γ / z = [[0, 1/z], [1, 1.5/z]], whose singular
    # values are those of [[0, 1], [1, 1.5]]: 2 and 1/2 at every frequency
    sys = theory_example()
    Phi, Gam, Psi, Delta = lifted(sys.A, sys.B, sys.C, sys.D, [0, 1])
    assert np.allclose(Phi, 0.0)
    for omega in np.linspace(0.0, np.pi, 7):
        G = Delta + Psi @ Gam * np.exp(-1j * omega)
        assert np.linalg.svd(G, compute_uv=False) == pytest.approx(
            [2.0, 0.5], rel=1e-12)


def test_the_storages_returned_pass_an_independent_check():
    sys = theory_example()
    res = ncs.worst_case_gain(sys, memory=1)
    lift = sys.graph.lift(1)
    gamma2 = res.figure ** 2 * (1 + 1e-9)
    P = res.storages
    for u, v, i in lift.graph.edges:
        F = np.hstack([sys.A[i], sys.B[i]])
        H = np.hstack([sys.C[i], sys.D[i]])
        M = F.T @ P[v] @ F + H.T @ H
        M[:1, :1] -= P[u]
        M[1:, 1:] -= gamma2
        assert np.linalg.eigvalsh(M).max() < 0
    assert np.linalg.eigvalsh(P).min() > 0


# -- one node, one mode: the LTI figures ----------------------------------------
def random_stable_ss(rng, n, m):
    A = rng.standard_normal((n, n))
    A *= 0.8 / max(abs(np.linalg.eigvals(A)))
    return ct.ss(A, rng.standard_normal((n, m)), rng.standard_normal((m, n)),
                 rng.standard_normal((m, m)) + 2 * np.eye(m), True)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_one_mode_gain_is_the_hinf_norm(seed):
    G = random_stable_ss(np.random.default_rng(seed), 3, 2)
    res = ncs.worst_case_gain([G])
    hinf = ct.norm(G, "inf", tol=1e-12)
    assert res.bound <= hinf * (1 + 1e-9)
    assert hinf * (1 - 1e-9) <= res.figure <= hinf * (1 + 1e-6)
    assert res.exact


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_one_mode_passivity_is_python_controls_index(seed):
    G = random_stable_ss(np.random.default_rng(seed), 3, 2)
    res = ncs.worst_case_passivity([G])
    assert res.figure <= res.bound
    # python-control's index comes from CVXOPT, accurate to about 1e-6
    assert res.figure == pytest.approx(ct.get_input_ff_index(G), abs=1e-5)


# -- closed forms ---------------------------------------------------------------
@pytest.mark.parametrize("a", [(0.2, 0.7), (-0.5, 0.3, 0.6)])
def test_scalar_switching_gain_is_that_of_the_slowest_mode(a):
    # x⁺ = a_i x + w, z = x: |z_t| ≤ Σ |a|max^(t-k) |w_k| (triangle
    # inequality), attained by the constant slowest mode: 1/(1 - max|a|)
    sys = ([[[x]] for x in a], [[1.0]], [[1.0]], [[0.0]])
    res = ncs.worst_case_gain(sys, cycle_length=5)
    closed = 1 / (1 - max(abs(x) for x in a))
    assert res.bound <= closed * (1 + 1e-12)
    assert closed <= res.figure <= closed * (1 + 1e-6)
    assert res.exact


def test_scalar_passivity_worst_pattern_keeps_the_smallest_feedthrough():
    # x⁺ = 0.5x + w, z = x + d_i w: Σ 2wz = Σ 2wx + 2 d_i w² ≥ the constant
    # d_min system's, whose index is d_min - 1/(1 + 0.5) (at ω = π)
    sys = ncs.SwitchingSystem(0.5, 1.0, 1.0, [[[1.0]], [[2.0]], [[1.5]]])
    res = ncs.worst_case_passivity(sys, cycle_length=5)
    closed = 1.0 - 1 / 1.5
    assert res.bound == pytest.approx(closed, abs=1e-12)
    assert closed - 1e-6 <= res.figure <= closed + 1e-12
    assert res.cycle == (0,)


def test_weakly_hard_scalar_rate_is_the_closed_form():
    # losses a = 3, deliveries b = 0.2, at most one lost in any three:
    # (|a| |b|²)^(1/3) (theory: worst-case loss patterns)
    sys = ncs.SwitchingSystem([[[3.0]], [[0.2]]], 0.0, 0.0, 0.0, ONE_IN_THREE)
    res = ncs.worst_case_rate(sys)
    closed = (3 * 0.2 ** 2) ** (1 / 3)
    assert res.lower == pytest.approx(closed, rel=1e-12)
    assert closed <= res.rate <= closed * (1 + 1e-6)
    assert res.exact and sorted(res.cycle) == [0, 1, 1]


# -- memory ---------------------------------------------------------------------
def test_memory_tightens_the_certified_gain_until_the_bracket_closes():
    A = AJPR / 4.2
    sys = (A, [[1.0], [0.0]], [[0.0, 1.0]], [[0.0]])
    figures = [ncs.worst_case_gain(sys, memory=M) for M in (0, 1, 2)]
    assert figures[0].figure > figures[1].figure > figures[2].figure
    assert not figures[0].exact and figures[2].exact
    assert all(r.bound == pytest.approx(figures[0].bound, rel=1e-12)
               for r in figures)
    assert all(r.figure >= r.bound for r in figures)


def test_memory_two_closes_the_rate_of_the_ajpr_pair():
    sys = (AJPR, np.zeros((2, 1)), np.zeros((1, 2)), np.zeros((1, 1)))
    res = ncs.worst_case_rate(sys, memory=2)
    published = 3.917384715148
    assert res.lower == pytest.approx(published, rel=1e-12)
    assert published <= res.rate <= published * (1 + 1e-6)
    assert ncs.worst_case_rate(sys).rate > 3.95         # one quadratic


def test_the_rate_bounds_every_allowed_product_in_the_node_norms():
    sys = ncs.SwitchingSystem(AJPR / 4, np.zeros((2, 1)), np.zeros((1, 2)),
                              0.0, ONE_IN_THREE)
    res = ncs.worst_case_rate(sys, memory=1, tol=1e-4)
    lift = sys.graph.lift(1)
    L = [np.linalg.cholesky(P) for P in res.storages]
    out = lift.graph.out_edges()
    # every walk of the lift up to 8 steps: ‖L_vᵀ A_w L_u⁻ᵀ‖ ≤ rateᵏ
    stack = [(u, u, np.eye(2), 0) for u in range(lift.graph.nodes)]
    while stack:
        u, v, T, k = stack.pop()
        if k:
            norm = np.linalg.norm(L[v].T @ T @ np.linalg.inv(L[u].T), 2)
            assert norm <= res.rate ** k * (1 + 1e-9)
        if k < 8:
            for e in out[v]:
                _, w, i = lift.graph.edges[e]
                stack.append((u, int(w), sys.A[i] @ T, k + 1))


# -- every pattern, by brute force ------------------------------------------------
@settings(max_examples=8, deadline=None)
@given(st.integers(0, 2 ** 32 - 1))
def test_certified_gain_bounds_every_pattern_by_brute_force(seed):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((2, 2, 2))
    A *= 0.85 / np.linalg.norm(A, 2, axis=(1, 2))[:, None, None]
    B, C = rng.standard_normal((2, 2, 1)), rng.standard_normal((2, 1, 2))
    D = 0.5 * rng.standard_normal((2, 1, 1))
    res = ncs.worst_case_gain((A, B, C, D))
    assert res.bound <= res.figure
    for L in range(1, 8):
        for word in itertools.product((0, 1), repeat=L):
            # from rest over any (not only periodic) pattern: the finite
            # horizon map from w_0..w_{L-1} to z_0..z_{L-1}
            Delta = lifted(A, B, C, D, word)[3]
            assert np.linalg.norm(Delta, 2) <= res.figure * (1 + 1e-9)
            if L <= 3:
                G = ct.ss(*lifted(A, B, C, D, word), True)
                assert ct.norm(G, "inf", tol=1e-10) <= \
                    res.figure * (1 + 1e-6)


# -- refusals and proofs ----------------------------------------------------------
def test_an_unstable_pattern_is_refused_with_its_proof():
    sys = ncs.SwitchingSystem([[[1.1]], [[0.1]]], 1.0, 1.0, 0.0)
    with pytest.raises(ncs.CertificationError, match=r"\(0,\)") as info:
        ncs.worst_case_gain(sys)
    assert info.value.reason == "not_mss"


def test_a_supply_a_pattern_violates_is_proven_infeasible():
    sys = ncs.SwitchingSystem([[[0.2]], [[0.5]]], 1.0, 1.0, 1.0)
    res = ncs.worst_case_dissipativity(sys, -1.0, 1.25, -1.0)
    assert res.status == "infeasible" and not res.success
    assert res.figure <= res.bound < 0


def test_a_supply_with_room_is_certified():
    sys = ncs.SwitchingSystem([[[0.2]], [[0.5]]], 1.0, 1.0, 1.0)
    # passivity with dissipation 0.1 written as a supply: 2wz - 0.2w²
    # (the index is 1 - 1/1.2 = 0.1667, from the slowest-at-π mode a = 0.2)
    res = ncs.worst_case_dissipativity(sys, 0.0, 1.0, -0.2)
    eta = ncs.worst_case_passivity(sys)
    assert res.status == "certified"
    assert res.figure == pytest.approx(2 * eta.figure - 0.2, abs=1e-7)


def test_a_rate_a_pattern_exceeds_is_proven_infeasible():
    sys = ncs.SwitchingSystem([[[3.0]], [[0.2]]], 0.0, 0.0, 0.0,
                              ONE_LOSS_IN_A_ROW)
    with pytest.raises(ncs.CertificationError) as info:
        ncs.worst_case_rate(sys, rate=0.7)
    assert info.value.reason == "infeasible"
    assert ncs.worst_case_rate(sys, rate=0.8).rate < 0.8


def test_a_start_node_restricts_the_patterns():
    # from node 1 the graph never returns to the fast-growing loop at node 0
    G = ncs.SwitchingGraph([(0, 0, 0), (0, 1, 1), (1, 1, 1)], start=1)
    sys = ncs.SwitchingSystem([[[1.5]], [[0.5]]], 1.0, 1.0, 0.0, G)
    res = ncs.worst_case_gain(sys)
    assert res.figure == pytest.approx(2.0, rel=1e-6) and res.exact
    assert len(res.walks) == 1


def test_a_node_without_an_edge_out_is_refused():
    with pytest.raises(ControlArgument, match="no edge out"):
        ncs.SwitchingGraph([(0, 1, 0)])


def test_an_edge_applying_a_missing_mode_is_refused():
    with pytest.raises(ControlDimension, match="mode 2"):
        ncs.SwitchingSystem([[[0.5]], [[0.1]]], 1.0, 1.0, 0.0,
                            [(0, 0, 2)])


def test_a_graph_beside_a_switching_system_is_refused():
    with pytest.raises(ControlArgument, match="graph"):
        ncs.worst_case_gain(theory_example(), ONE_LOSS_IN_A_ROW)


def test_passivity_needs_square_loops():
    with pytest.raises(ControlDimension, match="as many outputs"):
        ncs.worst_case_passivity((0.5, [[1.0, 1.0]], 1.0, [[0.0, 0.0]]))


def test_the_lift_remembers_the_last_edges():
    lift = ncs.SwitchingGraph(ONE_LOSS_IN_A_ROW).lift(2)
    for (a, b, i), e in zip(lift.graph.edges, lift.origin):
        u, tail = lift.walks[a]
        v, nxt = lift.walks[b]
        assert nxt == (tail + (int(e),))[-2:]
        assert ONE_LOSS_IN_A_ROW[e][:2] == (u, v)
        assert ONE_LOSS_IN_A_ROW[e][2] == i


def test_summary_states_the_bracket():
    text = ncs.worst_case_gain(theory_example()).summary()
    assert "WorstCaseResult: certified" in text and "(0, 1)" in text
    assert math.isfinite(ncs.worst_case_rate(theory_example()).rate)
