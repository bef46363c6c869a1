"""Path-dependent quadratic Lyapunov bounds on the joint spectral radius.

(:ref:`theory-worst-case`; Lee & Dullerud 2006, Ahmadi, Jungers, Parrilo &
Roozbehani 2014, Philippe et al. 2016.) On a graph (the user's, its
memory-``M`` lift or its ``T``-step graph), one ``P_u ≻ 0`` per node with
``A_eᵀ P_v A_e ≼ γ² P_u`` on every edge ``(u, v, e)``. ``γ`` is found by
bisection, each step an SDP (:class:`control_ncs.lmi.jsr.QuadraticJSRModel`);
the bound returned is never the bisection's ``γ`` but the one the best
``P`` proves, recomputed exactly (:func:`quadratic_check`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

__all__: list[str] = []

#: Bisection steps at most (each an SDP).
MAX_STEPS = 40


def quadratic_check(mats: np.ndarray, source: np.ndarray,
                    target: np.ndarray, P: np.ndarray) -> float:
    """The bound the node forms ``P`` prove, exactly.

    ``γ* = max_e λ_max(L_u⁻¹ A_eᵀ P_v A_e L_u⁻ᵀ)^{1/2}`` with
    ``P_u = L_u L_uᵀ`` (Cholesky; inf if some ``P_u`` is not positive
    definite), so that ``‖A_e x‖_{P_v} ≤ γ* ‖x‖_{P_u}`` for every edge.
    """
    factors = []
    for Pu in P:
        try:
            factors.append(np.linalg.cholesky(0.5 * (Pu + Pu.T)))
        except np.linalg.LinAlgError:
            return math.inf
    worst = 0.0
    for A, u, v in zip(mats, source.tolist(), target.tolist()):
        L = factors[u]
        # np.linalg.solve, not scipy's solve_triangular: the same answer
        # for these small triangular systems, without its per-call cost
        X = np.linalg.solve(L, A.T @ P[v] @ A)
        X = np.linalg.solve(L, X.T)
        worst = max(worst, float(np.linalg.eigvalsh(0.5 * (X + X.T))[-1]))
    return math.sqrt(max(worst, 0.0))


def node_coordinates(mats: np.ndarray, source: np.ndarray,
                     target: np.ndarray, P: np.ndarray) -> np.ndarray:
    """The edge matrices in the coordinates of the node norms,
    ``L_vᵀ A_e L_u⁻ᵀ``: their 2-norms are ``‖A_e‖_{v←u}``, and closed
    walks keep their spectra (a similarity per node)."""
    L = [np.linalg.cholesky(0.5 * (Pu + Pu.T)) for Pu in P]
    out = np.empty_like(mats)
    for k, (A, u, v) in enumerate(zip(mats, source.tolist(),
                                      target.tolist())):
        out[k] = np.linalg.solve(L[u], (L[v].T @ A).T).T
    return out


@dataclass
class Quadratic:
    """A bisection's outcome: the exact bound of the best ``P`` found
    (inf and ``P`` None when none was found), and how many SDPs."""

    bound: float
    P: np.ndarray | None
    solves: int = 0
    statuses: list = field(default_factory=list)


def quadratic_bound(mats: np.ndarray, source: np.ndarray,
                    target: np.ndarray, nodes: int, lo: float, *,
                    rel: float, deadline: float = math.inf,
                    solver: str | None = None) -> Quadratic:
    """Bisection on ``γ`` in ``[lo, max ‖A_e‖]`` (relative width ``rel``).

    The matrices are divided by ``max ‖A_e‖`` for the solver (a scaling
    any ``P`` is indifferent to); every ``P`` returned is checked on the
    original matrices and the smallest proven bound kept. ``P = I`` proves
    ``max ‖A_e‖`` and is the starting point.
    """
    from .lmi.jsr import QuadraticJSRModel
    n = mats.shape[-1]
    scale = max(float(np.linalg.norm(A, 2)) for A in mats)
    identity = np.broadcast_to(np.eye(n), (nodes, n, n)).copy()
    out = Quadratic(quadratic_check(mats, source, target, identity),
                    identity)
    if scale == 0.0:
        return out
    model = QuadraticJSRModel(mats / scale, source, target, nodes)
    low, high = max(lo / scale, 0.0), 1.0
    while out.solves < MAX_STEPS and high - low > rel * high:
        left = deadline - time.perf_counter()
        if left <= 0:
            break
        gamma = math.sqrt(low * high) if low > 0 else 0.5 * high
        P, margin, report = model.solve_at(gamma, time_limit=left
                                           if math.isfinite(left) else None,
                                           solver=solver)
        out.solves += 1
        out.statuses.append(report.status)
        if P is not None:
            proven = quadratic_check(mats, source, target, P)
            if proven < out.bound:
                out.bound, out.P = proven, P
        if P is not None and margin > 0:
            high = min(gamma, out.bound / scale)
        else:
            low = gamma
    return out
