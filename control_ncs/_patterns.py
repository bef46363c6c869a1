"""Periodic patterns of a switching graph: the other side of a bracket.

A closed walk ``c`` of the graph, reachable from a start node, is an
allowed periodic pattern (the loop at rest until it begins). Repeated, it is
an ``L``-periodic linear system; lifted over one period
(``x⁺ = Φ x + Γ W``, ``Z = Ψ x + Δ W``, :ref:`theory-worst-case-dissipativity`)
it is time invariant, and from rest

* its spectral radius gives ``ρ(Φ)^(1/L) ≤`` the joint spectral radius;
* for a supply ``s(w, z) = zᵀQz + 2zᵀSw + wᵀRw`` (``Q ⪯ 0``), every
  frequency ``ω`` gives an upper bound ``λmin(Π(e^{jω}))`` on the level
  ``t`` with ``Σ s ≥ t Σ wᵀw`` for every pattern:
  ``Π = [G; I]ᴴ [[Q, S], [Sᵀ, R]] [G; I]`` with ``G = Δ + Ψ(zI − Φ)⁻¹Γ``
  and the supply repeated over the period (Parseval: a narrow-band input
  near ``ω`` approaches it). For the ℓ2 gain this is ``-σmax(G)²``, for
  passivity ``2 λmin(G + Gᴴ)/2``.

Each figure is computed from one product of matrices and is an attained
value, so a frequency grid refined by a bounded local search gives a valid
bound whatever it misses.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

__all__: list[str] = []

#: Uniform frequencies (on [0, π]) that rank the patterns.
COARSE = 32

#: Uniform frequencies per pattern ranked among the worst, before the local
#: refinement; the angles of Φ's eigenvalues are added.
GRID = 96

#: Patterns whose grid minimum is refined by a bounded local search.
REFINED = 4


def reachable(graph) -> np.ndarray:
    """Boolean mask of the nodes reachable from the start nodes."""
    seen = np.zeros(graph.nodes, bool)
    out = graph.out_edges()
    queue = deque(graph.start)
    seen[list(graph.start)] = True
    while queue:
        u = queue.popleft()
        for e in out[u]:
            v = int(graph.edges[e, 1])
            if not seen[v]:
                seen[v] = True
                queue.append(v)
    return seen


def _primitive(w: tuple) -> bool:
    L = len(w)
    return not any(L % d == 0 and w == w[d:] + w[:d] for d in range(1, L))


def _canonical(w: tuple) -> bool:
    """True when ``w`` is the smallest of its rotations."""
    return all(w <= w[k:] + w[:k] for k in range(1, len(w)) if w[k] == w[0])


def closed_walks(graph, max_length: int) -> list[tuple[int, ...]]:
    """The primitive closed walks (edge indices) of at most ``max_length``
    edges among the reachable nodes, one rotation each (the smallest).

    Depth-first from each edge ``e0`` over edges ``≥ e0`` only, pruned by
    the distance back to ``e0``'s tail; sorted by length.
    """
    E = graph.edges
    live = reachable(graph)
    out = graph.out_edges()
    found: list[tuple[int, ...]] = []
    for e0 in range(len(E)):
        s = int(E[e0, 0])
        if not live[s]:
            continue
        dist = _distance_to(graph, s, e0)
        stack: list[tuple[int, tuple[int, ...]]] = [(int(E[e0, 1]), (e0,))]
        while stack:
            v, w = stack.pop()
            if v == s and _canonical(w) and _primitive(w):
                found.append(w)
            if len(w) == max_length:
                continue
            for e in out[v]:
                if e < e0:
                    continue
                nxt = int(E[e, 1])
                if len(w) + 1 + dist[nxt] <= max_length:
                    stack.append((nxt, w + (e,)))
    found.sort(key=lambda w: (len(w), w))
    return found


def _distance_to(graph, target: int, e0: int) -> np.ndarray:
    """Edges needed from each node back to ``target`` using edges ≥ e0."""
    dist = np.full(graph.nodes, np.iinfo(np.int64).max // 4, dtype=np.int64)
    dist[target] = 0
    into: list[list[int]] = [[] for _ in range(graph.nodes)]
    for e in range(e0, len(graph.edges)):
        into[int(graph.edges[e, 1])].append(int(graph.edges[e, 0]))
    queue = deque([target])
    while queue:
        v = queue.popleft()
        for u in into[v]:
            if dist[u] > dist[v] + 1:
                dist[u] = dist[v] + 1
                queue.append(u)
    return dist


def pattern_lift(A, B, C, D, modes) -> tuple:
    """``(Φ, Γ, Ψ, Δ)`` of the periodic system applying ``modes`` in turn.

    ``x_{k+1} = A_k x_k + B_k w_k``, ``z_k = C_k x_k + D_k w_k`` over one
    period: ``Φ = A_L⋯A_1``, ``Γ = [A_L⋯A_2 B_1, …, B_L]``,
    ``Ψ = [C_1; C_2 A_1; …]``, ``Δ`` block lower triangular.
    """
    L = len(modes)
    n, m = B.shape[-2], B.shape[-1]
    p = C.shape[-2]
    Psi = np.zeros((L * p, n))
    Delta = np.zeros((L * p, L * m))
    Gam = np.zeros((n, L * m))
    # T[k] = A_{k-1}⋯A_0 (state transition to step k); G[j] = the effect of
    # w_j on the present state
    T = np.eye(n)
    into: list[np.ndarray] = []     # per j: state at the present from w_j
    for k, i in enumerate(modes):
        Psi[k * p:(k + 1) * p] = C[i] @ T
        for j, X in enumerate(into):
            Delta[k * p:(k + 1) * p, j * m:(j + 1) * m] = C[i] @ X
        Delta[k * p:(k + 1) * p, k * m:(k + 1) * m] = D[i]
        into = [A[i] @ X for X in into] + [B[i]]
        T = A[i] @ T
    for j, X in enumerate(into):
        Gam[:, j * m:(j + 1) * m] = X
    return T, Gam, Psi, Delta


def _pi_min(lifted: tuple, Qb, Sb, Rb, omegas: np.ndarray) -> np.ndarray:
    """``λmin(Π(e^{jω}))`` at each frequency; ``lifted`` may hold a stack
    of patterns of one length (leading axis), then shape (K, F)."""
    Phi, Gam, Psi, Delta = (np.asarray(X)[..., None, :, :] for X in lifted)
    n = Phi.shape[-1]
    z = np.exp(1j * np.asarray(omegas, float))[:, None, None]
    X = np.linalg.solve(z * np.eye(n) - Phi, Gam)
    G = Delta + Psi @ X
    GH = np.conj(np.swapaxes(G, -1, -2))
    Pi = GH @ Qb @ G + GH @ Sb + Sb.T @ G + Rb
    Pi = 0.5 * (Pi + np.conj(np.swapaxes(Pi, -1, -2)))
    return np.linalg.eigvalsh(Pi)[..., 0]


def _grid(Phi: np.ndarray) -> np.ndarray:
    angles = (np.abs(np.angle(np.linalg.eigvals(Phi))) if Phi.size
              else np.zeros(0))
    return np.unique(np.concatenate([np.linspace(0.0, np.pi, GRID),
                                     np.clip(angles, 0.0, np.pi)]))


def _refine(lifted, Qb, Sb, Rb) -> tuple[float, float]:
    """The minimum over a grid with ``Φ``'s eigenvalue angles, then a
    bounded local search around it."""
    grid = _grid(lifted[0])
    values = _pi_min(lifted, Qb, Sb, Rb, grid)
    j = int(np.argmin(values))
    best, where = float(values[j]), float(grid[j])
    lo, hi = grid[max(j - 1, 0)], grid[min(j + 1, len(grid) - 1)]
    if hi > lo:
        res = minimize_scalar(
            lambda w: float(_pi_min(lifted, Qb, Sb, Rb, np.array([w]))[0]),
            bounds=(lo, hi), method="bounded",
            options=dict(xatol=1e-12 * max(1.0, hi)))
        if res.fun < best:
            best, where = float(res.fun), float(res.x)
    return best, where


#: Patterns evaluated together (one stack of lifted systems).
CHUNK = 64


@dataclass(frozen=True)
class PatternBound:
    """What the periodic patterns say (see the module's docstring).

    ``level``: the least pattern level (an upper bound on every certifiable
    supply level; ``inf`` without patterns); ``walk``/``omega``: the
    pattern and frequency attaining it; ``rate``: the largest
    ``ρ(Φ)^(1/L)`` (a lower bound on the joint spectral radius), attained
    on ``rate_walk``; ``count``: patterns examined.
    """

    level: float
    walk: tuple
    omega: float
    rate: float
    rate_walk: tuple
    count: int


def pattern_rates(sys, walks) -> tuple[float, tuple]:
    """The largest ``ρ(Φ)^(1/L)`` over ``walks`` and the walk attaining
    it."""
    best, arg = 0.0, ()
    modes = sys.graph.edges[:, 2]
    for w in walks:
        T = np.eye(sys.nstates)
        for e in w:
            T = sys.A[modes[e]] @ T
        r = float(np.max(np.abs(np.linalg.eigvals(T)))) ** (1.0 / len(w))
        if r > best or not arg:
            best, arg = r, w
    return best, arg


def pattern_bound(sys, Q, S, R, max_length: int, *,
                  supply: bool = True) -> PatternBound:
    """Examine every periodic pattern of at most ``max_length`` steps.

    When a pattern is not stable (``ρ(Φ) ≥ 1``) the supply figures are not
    computed (``level`` is ``nan``): no storage certifies anything.
    ``supply=False`` computes the rates only.
    """
    walks = closed_walks(sys.graph, max_length)
    rate, rate_walk = pattern_rates(sys, walks)
    if not supply or rate >= 1.0 or not walks:
        return PatternBound(np.nan if walks and rate >= 1.0 else np.inf, (),
                            np.nan, rate, rate_walk, len(walks))
    modes = sys.graph.edges[:, 2]
    uniform = np.linspace(0.0, np.pi, COARSE)
    coarse = []
    for L in sorted({len(w) for w in walks}):
        group = [w for w in walks if len(w) == L]
        Qb, Sb, Rb = (np.kron(np.eye(L), X) for X in (Q, S, R))
        for start in range(0, len(group), CHUNK):
            chunk = group[start:start + CHUNK]
            lifts = [pattern_lift(sys.A, sys.B, sys.C, sys.D,
                                  modes[list(w)]) for w in chunk]
            stack = tuple(np.array(X) for X in zip(*lifts))
            values = _pi_min(stack, Qb, Sb, Rb, uniform).min(axis=-1)
            coarse += [(float(v), w, lift, (Qb, Sb, Rb))
                       for v, w, lift in zip(values, chunk, lifts)]
    coarse.sort(key=lambda item: item[0])
    best: tuple[float, tuple, float] = (np.inf, (), np.nan)
    for _, w, lifted, weights in coarse[:REFINED]:
        level, omega = _refine(lifted, *weights)
        if level < best[0]:
            best = (level, w, omega)
    return PatternBound(best[0], best[1], best[2], rate, rate_walk,
                        len(walks))
