"""The joint spectral radius: literature values, certificates, brute force.

Every certificate a test receives is re-checked here with algebra written
in the test (generalized eigenvalues for quadratic forms, the test's own
linear or cone programs for polytopes, a walk-by-walk check for product
norms), and brackets are compared with closed forms, published values and
a brute-force enumeration of every allowed product up to length 12.
"""

import math
import pickle

import numpy as np
import pytest
import scipy.linalg
from control.exception import ControlArgument, ControlDimension
from hypothesis import given, settings, strategies as st
from scipy.optimize import linprog

import control_ncs as ncs

GOLDEN = [[[1, 1], [0, 1]], [[1, 0], [1, 1]]]
PHI = (1 + math.sqrt(5)) / 2
AJPR = [[[-1, -1], [-4, 0]], [[3, 3], [-2, 1]]]
GRIPENBERG = [np.array([[3, 0], [1, 3]]) / 5, np.array([[3, -3], [0, -1]]) / 5]
NILPOTENT = [[[0, 1], [0, 0]], [[0, 0], [1, 0]]]
#: After A2, two A1 (modes 0 = A1, 1 = A2).
AFTER_A2_TWO_A1 = [(0, 0, 0), (0, 1, 1), (1, 2, 0), (2, 0, 0)]


# -- independent checks --------------------------------------------------------
def _edges_of(sys, graph):
    """The user's graph as (u, v, mode) triples and mode -> matrix."""
    mats = ({k: np.atleast_2d(np.asarray(v, float)) for k, v in sys.items()}
            if isinstance(sys, dict) else
            {i: np.atleast_2d(np.asarray(m, float)) for i, m in
             enumerate(sys)})
    if graph is None:
        edges = [(0, 0, k) for k in mats]
    elif isinstance(graph, ncs.LossAutomaton):
        edges = list(graph.edges)
    else:
        edges = [tuple(e) for e in graph]
    return mats, list(dict.fromkeys(edges))


def _certificate_graph(cert, edges, mats):
    """The edges (i, j, matrix) of the graph the certificate lives on: the
    component's edges (memory 0) or its memory lift, rebuilt from names;
    for a quadratic on the T-step graph, its walks of T edges."""
    index = {name: i for i, name in enumerate(cert.nodes)}
    if cert.memory == 0:
        out = [(index[u], index[v], mats[m]) for u, v, m in edges
               if u in index and v in index]
    else:
        out = []
        for w in cert.nodes:
            for e in edges:
                nxt = w[1:] + (e,)
                if e[0] == w[-1][1] and nxt in index:
                    out.append((index[w], index[nxt], mats[e[2]]))
    if cert.kind == "quadratic" and cert.length > 1:
        walks = out
        for _ in range(cert.length - 1):
            walks = [(i, v, B @ A) for i, j, A in walks
                     for u, v, B in out if u == j]
        out = walks
    return out


def _real_gauge(V, z):
    k = V.shape[0]
    res = linprog(np.ones(2 * k), A_eq=np.hstack([V.T, -V.T]), b_eq=z,
                  bounds=(0, None), method="highs")
    assert res.status == 0
    return res.fun


def _complex_gauge(V, z):
    import cvxpy as cp
    c = cp.Variable(V.shape[0], complex=True)
    prob = cp.Problem(cp.Minimize(cp.sum(cp.abs(c))), [V.T @ c == z])
    prob.solve(solver=cp.CLARABEL)
    assert prob.status == cp.OPTIMAL
    return prob.value


def _walks_meet(B, graph, bound, length):
    """Every walk from every node has a prefix of at most ``length`` steps
    whose norm (2-norm of the products of ``B``) is within ``bound^i``."""
    slack = 1 + 1e-9
    frontier = [(np.eye(B[0].shape[0]), j) for j in
                sorted({e[0] for e in graph})]
    for depth in range(1, length + 1):
        nxt = []
        for P, u in frontier:
            for (i, j, _), Be in zip(graph, B):
                if i != u:
                    continue
                Q = Be @ P
                if np.linalg.norm(Q, 2) > slack * bound ** depth:
                    nxt.append((Q, j))
        frontier = nxt
        if not frontier:
            return True
    return False


def check_certificate(cert, mats, edges):
    """Re-prove ``cert.bound`` on the graph ``edges`` with ``mats``."""
    graph = _certificate_graph(cert, edges, mats)
    assert graph, "the certificate's graph has no edge"
    if cert.kind == "quadratic":
        P, T = cert.P, cert.length
        for i, j, A in graph:
            worst = scipy.linalg.eigh(A.T @ P[j] @ A, P[i], eigvals_only=True)
            assert worst[-1] <= cert.bound ** (2 * T) * (1 + 1e-9)
    elif cert.kind in ("polytope", "complex_polytope"):
        gauge = _complex_gauge if cert.kind == "complex_polytope" \
            else _real_gauge
        n = next(iter(mats.values())).shape[0]
        for V in cert.vertices:
            assert np.linalg.matrix_rank(V) == n     # a norm, not a seminorm
        for i, j, A in graph:
            for y in cert.vertices[i]:
                z = A @ y / cert.rate
                assert gauge(cert.vertices[j], z) <= \
                    cert.bound / cert.rate * (1 + 1e-7)
    elif cert.kind == "product_norms":
        n = next(iter(mats.values())).shape[0]
        if cert.P is None:
            L = [np.eye(n)] * len(cert.nodes)
        else:
            L = [np.linalg.cholesky(P) for P in cert.P]
        B = [L[j].T @ A @ np.linalg.inv(L[i].T) for i, j, A in graph]
        assert _walks_meet(B, graph, cert.bound, cert.length)
    else:
        assert cert.kind == "no_cycle" and cert.bound == 0.0


def check_result(res, sys, graph=None):
    """Every certificate re-proved; ``lower`` attained by ``cycle``."""
    mats, edges = _edges_of(sys, graph)
    for cert in res.certificates:
        check_certificate(cert, mats, edges)
    assert res.upper == max(c.bound for c in res.certificates)
    if res.cycle:
        P = np.eye(next(iter(mats.values())).shape[0])
        for mode in res.cycle:
            P = mats[mode] @ P
        rho = np.abs(np.linalg.eigvals(P)).max()
        assert rho ** (1 / len(res.cycle)) == pytest.approx(res.lower,
                                                            rel=1e-9)
        walk = res.walk
        assert all(e in edges for e in walk)
        assert all(walk[k][1] == walk[(k + 1) % len(walk)][0]
                   for k in range(len(walk)))
        assert tuple(e[2] for e in walk) == res.cycle
    assert res.lower <= res.upper * (1 + 1e-12)


# -- the literature ------------------------------------------------------------
def test_golden_ratio_pair_is_exact():
    res = ncs.jsr(GOLDEN)
    check_result(res, GOLDEN)
    assert res.exact and res.lower == pytest.approx(PHI, rel=1e-13)
    assert res.upper - res.lower <= 1e-6 * res.upper


def test_ahmadi_jungers_parrilo_roozbehani_pair_is_sqrt_rho_of_the_product():
    res = ncs.jsr(AJPR)
    check_result(res, AJPR)
    A1, A2 = (np.array(A, float) for A in AJPR)
    exact = math.sqrt(np.abs(np.linalg.eigvals(A1 @ A2)).max())
    assert res.exact and sorted(res.cycle) == [0, 1]
    assert res.lower == pytest.approx(exact, rel=1e-13)
    assert res.lower == pytest.approx(3.917384715148, abs=1e-12)


def test_gripenbergs_pair_lands_in_the_published_bracket():
    res = ncs.jsr(GRIPENBERG)
    check_result(res, GRIPENBERG)
    assert 0.6596789 <= res.lower <= res.upper <= 0.6596924
    assert len(res.cycle) > 12          # no short cycle enters the bracket


def test_nilpotent_pair_has_radius_one_from_the_product_cycle():
    res = ncs.jsr(NILPOTENT)
    check_result(res, NILPOTENT)
    assert res.lower == res.upper == 1.0 and sorted(res.cycle) == [0, 1]


def test_constrained_golden_pair_two_a1_after_each_a2():
    res = ncs.jsr(GOLDEN, AFTER_A2_TWO_A1)
    check_result(res, GOLDEN, AFTER_A2_TWO_A1)
    assert res.exact
    assert res.lower == pytest.approx((2 + math.sqrt(3)) ** (1 / 3),
                                      rel=1e-12)
    assert res.lower == pytest.approx(1.5511335, abs=1e-7)
    assert sorted(res.cycle) == [0, 0, 1]


def test_without_the_polytope_path_dependent_quadratics_close_the_ajpr_pair():
    # memory 2 suffices (Ahmadi, Jungers, Parrilo, Roozbehani 2014)
    res = ncs.jsr(AJPR, options=dict(max_vertices=1))
    check_result(res, AJPR)
    assert res.exact and res.route in ("quadratic", "product_norms")
    assert res.certificate.memory >= 1


def test_a_rotation_is_certified_by_a_balanced_complex_polytope():
    # A1 rotates by 1 rad in skewed coordinates (an irrational angle: no
    # real polytope with finitely many vertices is invariant), A2 shrinks
    c, s = math.cos(1.0), math.sin(1.0)
    S = np.array([[1.0, 2.0], [0.0, 1.0]])
    A1 = S @ np.array([[c, -s], [s, c]]) @ np.linalg.inv(S)
    sys = [A1, 0.2 * np.eye(2)]
    res = ncs.jsr(sys)
    check_result(res, sys)
    assert res.route == "complex_polytope"
    assert res.exact and res.lower == pytest.approx(1.0, rel=1e-12)


# -- loss automata ---------------------------------------------------------------
@pytest.mark.parametrize("a, b, misses, window",
                         [(3.0, 0.2, 1, 4), (1.5, 0.5, 2, 5), (-2.0, 0.3, 1, 2),
                          (0.4, 0.9, 2, 3), (1.2, -0.7, 3, 7)])
def test_scalar_loop_under_weakly_hard_losses(a, b, misses, window):
    aut = ncs.weakly_hard(misses, window)
    src, dst, delivered = aut.transition_graph()
    graph = [(int(i), int(j), int(d)) for i, j, d in zip(src, dst, delivered)]
    sys = [[[a]], [[b]]]           # mode 0: lost, mode 1: delivered
    res = ncs.jsr(sys, graph)
    check_result(res, sys, graph)
    expected = ((abs(a) ** misses * abs(b) ** (window - misses))
                ** (1 / window) if abs(a) >= abs(b) else abs(b))
    assert res.exact and res.lower == pytest.approx(expected, rel=1e-12)


def test_the_automaton_is_its_own_graph():
    res = ncs.jsr([[[3.0]], [[0.2]]], ncs.weakly_hard(1, 4))
    assert res.lower == pytest.approx((3 * 0.2 ** 3) ** 0.25, rel=1e-12)
    assert round(res.upper, 5) == 0.3936 and res.exact


def test_worst_mean_square_rate_of_a_stochastic_link_beside_an_automaton():
    # sensor link: Bernoulli loss 0.2; actuator: at most 2 losses in a row.
    # Per actuator outcome, the second moment of x+ = a x (lost) or
    # x+ = (a or b) x with the sensor's probabilities (delivered)
    a, b, p = 1.5, 0.1, 0.2
    ops = {0: [[a * a]], 1: [[p * a * a + (1 - p) * b * b]]}
    res = ncs.jsr(ops, ncs.max_consecutive_losses(2))
    check_result(res, ops, ncs.max_consecutive_losses(2))
    c = 0.458
    assert res.exact
    assert res.lower == pytest.approx(max(c, (a ** 4 * c) ** (1 / 3)),
                                      rel=1e-12)
    assert round(res.lower, 5) == 1.32356
    assert res.stable is False


def test_two_links_losing_in_turn_keep_the_loop_open_forever():
    # each link loses at most one in a row, but alternating losses leave
    # no step with both messages through: the loop runs open (rate |a|)
    aut = ncs.max_consecutive_losses(1).product(ncs.max_consecutive_losses(1))
    a, b = 2.0, 0.25
    sys = {(1, 1): [[b]], (1, 0): [[a]], (0, 1): [[a]], (0, 0): [[a]]}
    res = ncs.jsr(sys, aut)
    check_result(res, sys, aut)
    assert res.lower == res.upper == a
    assert (1, 1) not in res.cycle and aut.allows(res.cycle * 3)


# -- brute force over every allowed product ------------------------------------------
def _brute_force(mats, edges, length=12):
    """(max over closed walks of ρ^{1/k}, max over walks of length
    ``length`` of ‖A_w‖^{1/length}), every walk enumerated."""
    nodes = sorted({e[0] for e in edges} | {e[1] for e in edges}, key=str)
    n = next(iter(mats.values())).shape[0]
    # both figures scale with the matrices: work at norm 1 (no underflow)
    scale = max(np.linalg.norm(mats[e[2]], 2) for e in edges) or 1.0
    mats = {k: A / scale for k, A in mats.items()}
    best_cycle = norms = 0.0
    for start in nodes:
        # every walk from start, grouped by the node it ends at
        frontier = {start: np.eye(n)[None]}
        for k in range(1, length + 1):
            nxt = {}
            for u, v, m in edges:
                if u in frontier:
                    nxt.setdefault(v, []).append(
                        np.einsum("ij,kjl->kil", mats[m], frontier[u]))
            frontier = {v: np.concatenate(P) for v, P in nxt.items()}
            if start in frontier:
                rho = np.abs(np.linalg.eigvals(frontier[start])).max()
                best_cycle = max(best_cycle, rho ** (1 / k))
        norms = max([norms] + [np.linalg.norm(P, 2, axis=(1, 2)).max()
                               ** (1 / length) for P in frontier.values()])
    return best_cycle * scale, norms * scale


@st.composite
def _systems(draw):
    n = draw(st.integers(1, 3))
    # magnitudes of 1e-3 or more (or 0): products of 12 stay far from
    # underflow in the brute force
    entries = st.one_of(st.just(0.0), st.floats(1e-3, 2), st.floats(-2, -1e-3))
    mats = {k: np.array(draw(st.lists(entries, min_size=n * n,
                                      max_size=n * n))).reshape(n, n)
            for k in (0, 1)}
    if draw(st.booleans()):
        return mats, None
    states = draw(st.integers(1, 4))
    edges = []
    for s in range(states):
        out = draw(st.lists(st.tuples(st.integers(0, states - 1),
                                      st.integers(0, 1)),
                            min_size=1, max_size=2, unique=True))
        edges += [(s, t, d) for t, d in out]
    return mats, ncs.loss_automaton(edges)


@settings(max_examples=12, deadline=None, derandomize=True)
@given(_systems())
def test_no_allowed_product_up_to_length_12_beats_the_upper_bound(system):
    mats, aut = system
    res = ncs.jsr(mats, aut, options=dict(search_budget=20_000,
                                          max_vertices=100, max_memory=1))
    check_result(res, mats, aut)
    _, edges = _edges_of(mats, aut)
    cycles, norms = _brute_force(mats, edges)
    assert cycles <= res.upper * (1 + 1e-9) + 1e-300
    assert norms >= res.lower * (1 - 1e-9)


# -- graphs ---------------------------------------------------------------------
def test_a_graph_is_as_fast_as_its_fastest_strongly_connected_component():
    sys = {"slow": [[0.5]], "fast": [[2.0]], "pass": [[100.0]]}
    graph = [("a", "a", "slow"), ("a", "b", "pass"), ("b", "b", "fast"),
             ("b", "c", "slow"), ("c", "b", "slow")]
    res = ncs.jsr(sys, graph)
    check_result(res, sys, graph)
    assert res.lower == res.upper == 2.0 and len(res.certificates) == 2
    assert res.cycle == ("fast",) and res.walk == (("b", "b", "fast"),)


def test_a_graph_without_cycles_has_radius_zero():
    res = ncs.jsr([[[5.0]]], [(0, 1, 0), (1, 2, 0)])
    assert (res.lower, res.upper, res.route, res.exact) == (0.0, 0.0,
                                                            "no_cycle", True)


def test_products_that_vanish_give_radius_zero_exactly():
    sys = [[[0.0, 1.0], [0.0, 0.0]]]
    res = ncs.jsr(sys)
    check_result(res, sys)
    assert res.upper == 0.0 and res.exact


def test_a_reducible_family_is_bracketed_by_its_blocks():
    sys = [[[0.9, 5.0], [0.0, 0.3]], [[0.2, -3.0], [0.0, 0.95]]]
    res = ncs.jsr(sys)
    check_result(res, sys)
    assert res.lower == pytest.approx(0.95, rel=1e-12)
    assert res.upper <= 0.95 * (1 + 1e-6) or not res.exact


def test_an_object_can_supply_second_moment_operators_and_their_graph():
    class Loop:
        def switching_system(self):
            return {0: [[2.25]], 1: [[0.458]]}, \
                ncs.max_consecutive_losses(2), "mean_square"

    res = ncs.jsr(Loop())
    assert res.scale == "mean_square" and round(res.lower, 5) == 1.32356


def test_time_limit_returns_a_certified_bracket_and_says_it_cut():
    rng = np.random.default_rng(3)
    sys = [rng.standard_normal((6, 6)) for _ in range(3)]
    res = ncs.jsr(sys, time_limit=1e-9)
    assert res.time_limited and res.status == "time_limit"
    check_result(res, sys)
    assert res.upper >= max(np.abs(np.linalg.eigvals(A)).max() for A in sys)


def test_result_reports_and_pickles():
    res = ncs.jsr(GOLDEN)
    assert res.status == "exact" and res.success
    assert "exact to tol" in res.message
    assert res.summary().startswith("JSRResult: exact")
    assert "lower" in repr(res)
    again = pickle.loads(pickle.dumps(res))
    assert again.upper == res.upper and again.cycle == res.cycle


def test_stable_says_whether_every_switching_decays():
    assert ncs.jsr([[[0.5]], [[0.9]]]).stable is True
    assert ncs.jsr(GOLDEN).stable is False


# -- bad input ------------------------------------------------------------------
def test_non_square_matrix_is_refused():
    with pytest.raises(ControlDimension, match="square"):
        ncs.jsr([[[1.0, 2.0]]])


def test_matrices_of_different_sizes_are_refused():
    with pytest.raises(ControlDimension, match="sys\\[1\\]"):
        ncs.jsr([np.eye(2), np.eye(3)])


def test_nan_is_refused():
    with pytest.raises(ValueError, match="finite"):
        ncs.jsr([[[np.nan]]])


def test_a_graph_naming_a_missing_mode_is_refused():
    with pytest.raises(ValueError, match="mode 2"):
        ncs.jsr(GOLDEN, [(0, 0, 0), (0, 0, 2)])


def test_an_automaton_outcome_without_a_matrix_is_refused():
    with pytest.raises(ValueError, match="outcome"):
        ncs.jsr({1: [[1.0]]}, ncs.max_consecutive_losses(1))


def test_a_malformed_edge_is_refused():
    with pytest.raises(ControlArgument, match="graph\\[0\\]"):
        ncs.jsr(GOLDEN, [(0, 1)])


def test_an_unknown_option_raises_type_error():
    with pytest.raises(TypeError, match="max_lenght"):
        ncs.jsr(GOLDEN, options=dict(max_lenght=3))


def test_a_bad_tolerance_is_refused():
    with pytest.raises(ValueError, match="tol"):
        ncs.jsr(GOLDEN, tol=0.0)


def test_a_huge_lift_is_refused_before_it_is_built():
    from control_ncs._switching import switching_graph
    g = switching_graph([np.eye(1)] * 8)
    with pytest.raises(ValueError, match="MAX_LIFT"):
        g.lift(6)


def test_an_automaton_naming_a_missing_state_is_refused_before_any_search():
    with pytest.raises(ValueError, match="not one of"):
        ncs.jsr(GOLDEN, ncs.LossAutomaton(2, [(0, 1, 1), (1, 5, 0)]))
