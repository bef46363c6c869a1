"""The LMIs of worst-case analysis and design over a switching graph.

One storage ``P_u`` (design: ``X_u = P_u⁻¹``) per node of a (lifted)
graph, one inequality per edge (:ref:`theory-worst-case-dissipativity`):

* :func:`storage_model` -- a fixed loop, a quadratic supply
  ``s = zᵀQz + 2zᵀSw + wᵀRw``: maximise the level ``t`` with
  ``Σ s ≥ t Σ wᵀw`` (the ℓ2 gain is ``γ² = -t`` for ``Q = -I``, passivity
  ``η = t/2`` for ``S = I``);
* :func:`rate_model` -- a fixed loop: ``A_eᵀ P_v A_e ≼ r² P_u`` for a rate
  ``r`` (a Parameter: bisection reuses one compilation);
* :func:`design_model` -- an open loop: gains per node (``Y_u = K_u X_u``)
  or one gain for all (``Y = K G`` with a common slack ``G``), for a rate or
  a supply level.

Every inequality is symmetric by construction (``Fᵀ P F`` with ``P``
symmetric, blocks beside their transposes), never symmetrised explicitly:
that would double cvxpy's compilation, which dominates these programs'
time. Nothing here decides whether an answer is true: the callers check
the storages exactly (:mod:`control_ncs.worstcase`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, cast

import numpy as np
import cvxpy as cp

from ._core import SolveReport, data_scale, fallback_solver, solve

__all__ = ["StorageModel", "storage_model", "RateModel", "rate_model",
           "DesignModel", "design_model", "solve_once"]


def solve_once(problem: cp.Problem, solver: str | None,
               options: dict) -> SolveReport:
    """Solve, and when the default solver fails without settling the
    question (an error, not infeasibility), ask the fallback solver once
    (:data:`control_ncs.lmi.FALLBACK_SOLVER`, only when none was named)."""
    report = solve(problem, solver, **options)
    if report.status in ("optimal", "optimal_inaccurate") or \
            report.infeasible:
        return report
    other = fallback_solver(solver)
    if other is None:
        return report
    again = solve(problem, other)
    return again if again.status in ("optimal", "optimal_inaccurate") or \
        again.infeasible else report


def _factor(Q: np.ndarray) -> np.ndarray:
    """``L`` with ``LᵀL = -Q`` (rows for the nonzero eigenvalues only)."""
    lam, V = np.linalg.eigh(-0.5 * (Q + Q.T))
    keep = lam > 1e-14 * max(1.0, float(np.abs(lam).max(initial=0.0)))
    return (np.sqrt(lam[keep])[:, None] * V[:, keep].T)


@dataclass
class StorageModel:
    """``max t`` over storages ``P_u`` with the supply's LMI per edge.

    Attributes
    ----------
    problem : cvxpy.Problem
    P : list of cvxpy.Variable
        One per node.
    level : cvxpy.Variable
        ``t``.
    """

    problem: cp.Problem
    P: list
    level: Any

    def storages(self) -> np.ndarray:
        """The solver's ``P_u``, shape (V, n, n), symmetrised."""
        P = np.array([np.asarray(X.value, float) for X in self.P])
        return 0.5 * (P + P.transpose(0, 2, 1))


def storage_model(A: np.ndarray, B: np.ndarray, C: np.ndarray,
                  D: np.ndarray, edges: np.ndarray, nodes: int,
                  Q: np.ndarray, S: np.ndarray, R: np.ndarray,
                  margin: float) -> StorageModel:
    """Per edge ``(u, v, i)``, with ``F = [A_i B_i]``, ``H = [C_i D_i]``::

        Fᵀ P_v F − diag(P_u, 0) − HᵀQH − He([0; I]ᵀ Sᵀ H) − diag(0, R − tI)
            ≼ −ε diag(P_u, 0),          P_u ≽ ε I,

    ``ε`` the relative ``margin`` times the data's scale; maximise ``t``.
    """
    n, m = A.shape[-1], B.shape[-1]
    eps = margin * data_scale(A, B, C, D)
    P = [cp.Variable((n, n), symmetric=True, name=f"P{u}")
         for u in range(nodes)]
    t = cp.Variable(name="level")
    E_w = np.vstack([np.zeros((n, m)), np.eye(m)])
    cons = [X >> eps * np.eye(n) for X in P]
    for u, v, i in edges:
        F = np.hstack([A[i], B[i]])
        H = np.hstack([C[i], D[i]])
        fixed = (-H.T @ Q @ H - H.T @ S @ E_w.T - E_w @ S.T @ H
                 - E_w @ R @ E_w.T)
        fixed = 0.5 * (fixed + fixed.T)             # data: exactly symmetric
        top = cp.bmat([[P[u], np.zeros((n, m))],
                       [np.zeros((m, n)), np.zeros((m, m))]])
        M = F.T @ P[v] @ F - top + fixed + t * (E_w @ E_w.T)
        # the margin keeps M11 ≺ 0 (the exact check needs it); the level is
        # recomputed from the storage, so the (2,2) block needs none
        slack = cp.bmat([[P[u], np.zeros((n, m))],
                         [np.zeros((m, n)), np.zeros((m, m))]])
        cons.append(M + eps * slack << 0)
    return StorageModel(cp.Problem(cp.Maximize(t), cons), P, t)


@dataclass
class RateModel:
    """``A_eᵀ P_v A_e ≼ r² P_u``, ``P_u ≽ I``: feasibility at ``r²``.

    Attributes
    ----------
    problem : cvxpy.Problem
    P : list of cvxpy.Variable
    rate2 : cvxpy.Parameter
        ``r²``; set ``rate2.value`` before each solve.
    """

    problem: cp.Problem
    P: list
    rate2: cp.Parameter

    def storages(self) -> np.ndarray:
        """The solver's ``P_u``, shape (V, n, n), symmetrised."""
        P = np.array([np.asarray(X.value, float) for X in self.P])
        return 0.5 * (P + P.transpose(0, 2, 1))


def rate_model(A: np.ndarray, edges: np.ndarray, nodes: int) -> RateModel:
    """The rate LMI of :ref:`theory-worst-case-dissipativity` (homogeneous
    in ``P``, so ``P_u ≽ I`` normalises it)."""
    n = A.shape[-1]
    r2 = cp.Parameter(nonneg=True, name="rate2")
    P = [cp.Variable((n, n), symmetric=True, name=f"P{u}")
         for u in range(nodes)]
    cons = [X >> np.eye(n) for X in P]
    for u, v, i in edges:
        cons.append(A[i].T @ P[v] @ A[i] - r2 * P[u] << 0)
    return RateModel(cp.Problem(cp.Minimize(0), cons), P, r2)


@dataclass
class DesignModel:
    """Gains with storages on a (lifted) graph.

    Attributes
    ----------
    problem : cvxpy.Problem
    X : list of cvxpy.Variable
        ``X_u = P_u⁻¹`` per node.
    Y : list of cvxpy.Variable
        ``Y_u = K_u X_u`` per node (node gains), or one ``Y = K G``.
    G : cvxpy.Variable or None
        The common slack of one gain for every node (None for node gains).
    level : cvxpy.Variable or None
        ``t`` of the supply (None for a rate).
    """

    problem: cp.Problem
    X: list
    Y: list
    G: Any
    level: Any

    def gains(self) -> np.ndarray:
        """``K_u = Y_u X_u⁻¹`` (V, q, n), or ``K = Y G⁻¹`` (q, n)."""
        if self.G is not None:
            G = np.asarray(self.G.value, float)
            return np.linalg.solve(G.T, np.asarray(self.Y[0].value,
                                                   float).T).T
        return np.array([np.linalg.solve(np.asarray(X.value, float).T,
                                         np.asarray(Y.value, float).T).T
                         for X, Y in zip(self.X, self.Y)])


def design_model(A: np.ndarray, Bu: np.ndarray, Bw: np.ndarray,
                 Cz: np.ndarray, Du: np.ndarray, Dw: np.ndarray,
                 edges: np.ndarray, nodes: int, *, supply: tuple | None,
                 rate: float, common: bool, margin: float) -> DesignModel:
    """The design LMIs of :ref:`theory-worst-case-dissipativity`.

    Per edge ``(u, v, i)``, with ``W = X_u`` (node gains) or ``G`` (one
    gain), ``H = X_u`` or ``G + Gᵀ − X_u``, ``Â = A_i W + Bu_i Y``,
    ``Ĉ = Cz_i W + Du_i Y`` and a decay rate ``r``:

    * ``supply=None``: ``[[r²H, Âᵀ], [Â, X_v]] ≽ ε I``, ``X_u ≽ I``;
    * ``supply=(Q, S, R)``, ``LᵀL = −Q``, maximise ``t``::

        [[r²H,    ĈᵀS,              Âᵀ,   (LĈ)ᵀ ],
         [SᵀĈ,    DᵀS+SᵀD+R−tI,     Bwᵀ,  (LD)ᵀ ],
         [Â,      Bw,               X_v,  0     ],
         [LĈ,     LD,               0,    I     ]]  ≽ ε I,   X_u ≽ ε I.

    The congruence with ``diag(W⁻¹, I, I, I)`` and
    ``WᵀX_u⁻¹W ≽ G + Gᵀ − X_u`` turns either into the analysis LMI of the
    closed loop with ``P_u = X_u⁻¹``, ``K = Y W⁻¹`` (and ``r²P_u`` in
    place of ``P_u``: the storage decays at the rate ``r``).
    """
    n, q = A.shape[-1], Bu.shape[-1]
    m = Bw.shape[-1]
    eps = margin * data_scale(A, Bu, Bw, Cz, Du, Dw)
    X = [cp.Variable((n, n), symmetric=True, name=f"X{u}")
         for u in range(nodes)]
    G = cp.Variable((n, n), name="G") if common else None
    Y = ([cp.Variable((q, n), name="Y")] if common else
         [cp.Variable((q, n), name=f"Y{u}") for u in range(nodes)])
    t = cp.Variable(name="level") if supply is not None else None
    floor = eps if supply is not None else 1.0
    cons = [Xu >> floor * np.eye(n) for Xu in X]
    if supply is not None:
        Q, S, R = supply
        L = _factor(Q)
        r = L.shape[0]
    for u, v, i in edges:
        W: Any = G if G is not None else X[u]
        Yu = Y[0] if common else Y[u]
        H = (G + G.T - X[u]) if G is not None else X[u]
        Ahat = A[i] @ W + Bu[i] @ Yu
        if supply is None:
            block = cp.bmat([[rate ** 2 * H, Ahat.T], [Ahat, X[v]]])
            cons.append(block >> eps * np.eye(2 * n))
            continue
        Chat = Cz[i] @ W + Du[i] @ Yu
        corner = Dw[i].T @ S + S.T @ Dw[i] + R
        corner = 0.5 * (corner + corner.T)
        rows = [[rate ** 2 * H, Chat.T @ S, Ahat.T],
                [S.T @ Chat, corner - cast(Any, t) * np.eye(m), Bw[i].T],
                [Ahat, Bw[i], X[v]]]
        if r:
            LC, LD = L @ Chat, L @ Dw[i]
            rows[0].append(LC.T)
            rows[1].append(LD.T)
            rows[2].append(np.zeros((n, r)))
            rows.append([LC, LD, np.zeros((r, n)), np.eye(r)])
        size = 2 * n + m + r
        cons.append(cp.bmat(rows) >> eps * np.eye(size))
    objective = cp.Maximize(t) if t is not None else cp.Minimize(0)
    return DesignModel(cp.Problem(objective, cons), X, Y, G, t)
