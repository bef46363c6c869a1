"""Invariant polytopes: an extremal norm that makes a cycle's rate exact.

(:ref:`theory-worst-case`; Guglielmi & Protasov 2013, Jungers, Cicone &
Guglielmi 2014 for graphs.) From a candidate closed walk ``c`` of rate
``r``, the edges' matrices are divided by ``r`` and one vertex set per node
is grown from the leading eigenvector of ``A_c`` (and its conjugate when
the leading eigenvalue is complex: the balanced complex polytope) until
every edge maps every vertex into the next node's polytope, up to
``1 + tol``. The node gauges are then norms in which every edge contracts
by ``μ ≤ 1 + tol``, so ``ρ̂ ≤ r μ``. Termination is guaranteed when ``c``
is a dominant spectrum-maximising product; otherwise a vertex budget or
the deadline stops the growth and the caller falls back to other bounds.

:func:`polytope_bound` re-proves ``μ`` from the vertices alone (every
vertex, every edge, a fresh gauge with its residual), and is what the
returned bound rests on. Real gauges are linear programs (SciPy's HiGHS),
complex ones second-order cone programs (:mod:`control_ncs.lmi.jsr`).
"""

from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass

import numpy as np

from ._jsr_cycles import cycle_rate
from ._switching import SwitchingGraph

__all__: list[str] = []

#: A vertex this much larger than the seeds means an image keeps growing:
#: the candidate is not spectrum-maximising.
GROWTH_CAP = 1e8

#: Relative imaginary part below which a leading eigenvalue is real.
REAL_EIGENVALUE = 1e-10


@dataclass
class Polytope:
    """The outcome of one polytope construction.

    ``vertices[u]`` is an array (k_u, n) (complex for the balanced complex
    polytope); ``bound`` the rechecked ``r μ`` (inf on failure);
    ``reason`` why it stopped when it failed; ``better`` a closed walk
    ``(rate, walk)`` met on the way whose rate beats the candidate's.
    """

    success: bool
    rate: float
    vertices: list
    bound: float
    mu: float
    is_complex: bool
    reason: str = ""
    gauges: int = 0
    better: tuple | None = None


def _real_gauge(Vt: np.ndarray, z: np.ndarray
                ) -> tuple[float, np.ndarray | None]:
    """``min Σ|c|`` with ``Vt c = z`` (an LP), polished on its support."""
    n, k = Vt.shape
    if n == 1:
        i = int(np.argmax(np.abs(Vt[0])))
        if Vt[0, i] == 0.0:
            return (0.0 if z[0] == 0.0 else math.inf), None
        c = np.zeros(k)
        c[i] = z[0] / Vt[0, i]
        return abs(float(c[i])), c
    from scipy.optimize import linprog
    res = linprog(np.ones(2 * k), A_eq=np.hstack([Vt, -Vt]), b_eq=z,
                  bounds=(0, None), method="highs",
                  options=dict(primal_feasibility_tolerance=1e-10,
                               dual_feasibility_tolerance=1e-10))
    if res.status != 0 or res.x is None:
        return math.inf, None
    c = res.x[:k] - res.x[k:]
    return float(np.abs(c).sum()), _polish(Vt, z, c)


def _polish(Vt: np.ndarray, z: np.ndarray, c: np.ndarray) -> np.ndarray:
    """The LP's answer re-solved on its support by least squares: the
    same coefficients to the solver's accuracy, a residual near rounding."""
    support = np.flatnonzero(np.abs(c) > 1e-12 * max(1.0, np.abs(c).max()))
    if support.size == 0:
        return c
    sub, *_ = np.linalg.lstsq(Vt[:, support], z, rcond=None)
    out = np.zeros_like(c)
    out[support] = sub
    before = np.linalg.norm(Vt @ c - z)
    after = np.linalg.norm(Vt @ out - z)
    return out if after <= before else c


def _gauge(Vt: np.ndarray, z: np.ndarray, is_complex: bool
           ) -> tuple[float, np.ndarray | None]:
    if Vt.shape[1] == 0:
        return (0.0 if not np.any(z) else math.inf), None
    if is_complex:
        from .lmi.jsr import complex_gauge
        value, c = complex_gauge(Vt, z)
        if c is None:
            return value, None
        c = _polish(Vt, z, c)
        return float(np.abs(c).sum()), c
    return _real_gauge(Vt, z)


def _certain(Vt: np.ndarray, z: np.ndarray, is_complex: bool,
             unit: float) -> float:
    """A bound on the gauge of ``z`` that accounts for the residual of the
    solver's coefficients: ``Σ|c| + ‖Vt c - z‖₁ · unit`` where ``unit``
    bounds the gauge of every basis vector."""
    value, c = _gauge(Vt, z, is_complex)
    if c is None:
        return value
    residual = float(np.abs(Vt @ c - z).sum())
    return float(np.abs(c).sum()) + residual * unit


def _unit(Vt: np.ndarray, is_complex: bool) -> float:
    """A bound on the gauge of every basis vector ``e_j`` (inf when the
    vertices do not span): ``max ĝ_j / (1 - max ‖ρ_j‖₁)`` for the
    computed gauges ``ĝ_j`` with residuals ``ρ_j``."""
    n = Vt.shape[0]
    g_hat, res = 0.0, 0.0
    for j in range(n):
        e = np.zeros(n, dtype=Vt.dtype)
        e[j] = 1.0
        value, c = _gauge(Vt, e, is_complex)
        if c is None or not math.isfinite(value):
            return math.inf
        g_hat = max(g_hat, float(np.abs(c).sum()))
        res = max(res, float(np.abs(Vt @ c - e).sum()))
    return g_hat / (1.0 - res) if res < 1.0 else math.inf


def polytope_bound(graph: SwitchingGraph, vertices: list, rate: float,
                   is_complex: bool, deadline: float = math.inf) -> float:
    """``r μ``, re-proved from the vertices: every vertex of every node
    through every edge, each image's gauge solved afresh and bounded with
    its residual. inf when some node's vertices do not span the space (or
    the deadline passes first: nothing is proved then)."""
    mats = graph.edge_matrices() / rate
    Vt = [np.asarray(V).T for V in vertices]
    units = [_unit(V, is_complex) for V in Vt]
    if not all(math.isfinite(u) for u in units):
        return math.inf
    mu = 0.0
    out = graph.out_edges()
    for u in range(graph.node_count):
        for y in vertices[u]:
            if time.perf_counter() > deadline:
                return math.inf
            for e in out[u]:
                v = int(graph.target[e])
                mu = max(mu, _certain(Vt[v], mats[e] @ y, is_complex,
                                      units[v]))
    return rate * mu


class _Growth:
    """The vertex sets while they grow (state of one construction)."""

    def __init__(self, graph: SwitchingGraph, rate: float, tol: float,
                 max_vertices: int, deadline: float,
                 is_complex: bool) -> None:
        self.g, self.tol = graph, tol
        self.mats = graph.edge_matrices() / rate
        self.out = [o.tolist() for o in graph.out_edges()]
        self.dst = graph.target.tolist()
        dtype = complex if is_complex else float
        self.V = [np.zeros((0, graph.n), dtype) for _ in
                  range(graph.node_count)]
        self.queue: deque = deque()
        self.count = 0
        self.max_vertices, self.deadline = max_vertices, deadline
        self.is_complex = is_complex
        self.seed_size = 1.0
        self.gauges = 0
        self.rate = rate
        self.start = -1
        self.better: tuple | None = None

    def offer(self, v: int, z: np.ndarray, walk: tuple | None) -> str:
        """Add ``z`` (the image of the seed along ``walk``, None for a
        filling vector) to node ``v`` when outside ``1 + tol``; '' or why
        the growth must stop."""
        value, _ = _gauge(self.V[v].T, z, self.is_complex)
        self.gauges += 1
        if value <= 1.0 + self.tol:
            return ""
        self.V[v] = np.vstack([self.V[v], z[None, :]])
        self.queue.append((v, z, walk))
        self.count += 1
        if walk and v == self.start:
            # back at the seed's node: the walk is a cycle of its own
            rate = cycle_rate(self.g, walk)
            if rate > self.rate * (1.0 + self.tol):
                self.better = (rate, walk)
                return "a cycle with a larger rate was found"
        if self.count > self.max_vertices:
            return f"more than {self.max_vertices} vertices"
        if np.linalg.norm(z) > GROWTH_CAP * self.seed_size:
            return "an image grew without bound (not a spectrum-maximising " \
                   "cycle)"
        return ""

    def grow(self) -> str:
        while self.queue:
            if time.perf_counter() > self.deadline:
                return "time limit"
            u, y, walk = self.queue.popleft()
            for e in self.out[u]:
                why = self.offer(self.dst[e], self.mats[e] @ y,
                                 None if walk is None else walk + (e,))
                if why:
                    return why
        return ""

    def fill(self) -> bool:
        """Add small basis vectors where a node's vertices do not span;
        True when something was added."""
        n, added = self.g.n, False
        size = max((float(np.abs(V).max()) for V in self.V if V.size),
                   default=1.0)
        for v, V in enumerate(self.V):
            if V.shape[0] and np.linalg.matrix_rank(V) == n:
                continue
            if V.shape[0]:
                _, s, Wh = np.linalg.svd(V)
                rank = int(np.sum(s > 1e-10 * s[0]))
                missing = Wh[rank:].conj()
            else:
                missing = np.eye(n, dtype=V.dtype)
            for b in missing:
                z = 1e-3 * size * b
                self.V[v] = np.vstack([self.V[v], z[None, :]])
                self.queue.append((v, z, None))
                self.count += 1
                added = True
        return added


def _seeds(graph: SwitchingGraph, walk: tuple, rate: float
           ) -> tuple[list, bool]:
    """The leading eigenvector of the cycle's product and its images along
    the cycle, as (node, vector); complex when the eigenvalue is."""
    mats = graph.edge_matrices() / rate
    C = np.eye(graph.n)
    for e in walk:
        C = mats[e] @ C
    lam, vecs = np.linalg.eig(C)
    i = int(np.argmax(np.abs(lam)))
    x = vecs[:, i]
    x = x / x[int(np.argmax(np.abs(x)))]            # a real phase if any
    is_complex = abs(lam[i].imag) > REAL_EIGENVALUE * abs(lam[i])
    if not is_complex:
        x = x.real
    x = x / np.linalg.norm(x)
    start = [x, x.conj()] if is_complex else [x]
    seeds = []
    for y in start:
        node = int(graph.source[walk[0]])
        seeds.append((node, y, ()))
        for k, e in enumerate(walk[:-1]):
            y = mats[e] @ y
            node = int(graph.target[e])
            seeds.append((node, y, tuple(walk[:k + 1])))
    return seeds, is_complex


def invariant_polytope(graph: SwitchingGraph, walk: tuple, rate: float, *,
                       tol: float, max_vertices: int,
                       deadline: float = math.inf) -> Polytope:
    """Grow the invariant polytope of the cycle ``walk`` (rate ``rate``)
    and re-prove its bound (:func:`polytope_bound`)."""
    seeds, is_complex = _seeds(graph, walk, rate)
    growth = _Growth(graph, rate, tol, max_vertices, deadline, is_complex)
    growth.seed_size = max(float(np.linalg.norm(y)) for _, y, _ in seeds)
    growth.start = int(graph.source[walk[0]])
    why = ""
    for node, y, prefix in seeds:
        why = why or growth.offer(node, y, prefix)
    for _ in range(4):
        why = why or growth.grow()
        if why or not growth.fill():
            break
    else:
        why = why or growth.grow()
    if why:
        return Polytope(False, rate, growth.V, math.inf, math.inf,
                        is_complex, why, growth.gauges, growth.better)
    bound = polytope_bound(graph, growth.V, rate, is_complex, deadline)
    if not math.isfinite(bound):
        why = "time limit" if time.perf_counter() > deadline else \
            "the vertices do not span every node"
        return Polytope(False, rate, growth.V, math.inf, math.inf,
                        is_complex, why, growth.gauges)
    return Polytope(True, rate, growth.V, bound, bound / rate, is_complex,
                    "", growth.gauges)
