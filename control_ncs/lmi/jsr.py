"""The joint spectral radius's convex programs (:ref:`theory-worst-case`).

* :class:`QuadraticJSRModel`: path-dependent quadratic Lyapunov functions
  on a graph, ``A_eᵀ P_v A_e ≼ γ² P_u`` for every edge ``(u, v, e)``,
  with the largest margin at a given ``γ`` (one compiled problem per
  graph; ``γ²`` is its only parameter, so a bisection re-solves it);
* :func:`complex_gauge`: the gauge of a balanced complex polytope, an SOCP
  solved by Clarabel directly (thousands of tiny problems: cvxpy's
  compilation would cost more than the solves).

Neither decides anything: the bound a ``P`` or a gauge proves is
recomputed exactly by the callers in ``control_ncs._jsr_*``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import cvxpy as cp

from ._core import solve, SolveReport

#: ``P_u ≼ CAP · I`` (with ``P_u ≽ I``) keeps the margin's problem bounded.
CAP = 1e6


class QuadraticJSRModel:
    """Maximise ``t``: ``γ² P_u - A_eᵀ P_v A_e ≽ t I``, ``I ≼ P_u ≼ CAP·I``.

    Parameters
    ----------
    matrices : ndarray, shape (E, n, n)
        The matrix of each edge.
    source, target : ndarray of int, shape (E,)
        The edges' end nodes, indices below ``nodes``.
    nodes : int

    Attributes
    ----------
    problem : cvxpy.Problem
    P : list of cvxpy.Variable
        One symmetric ``n × n`` variable per node.
    """

    def __init__(self, matrices: np.ndarray, source: np.ndarray,
                 target: np.ndarray, nodes: int) -> None:
        n = matrices.shape[-1]
        self.gamma2 = cp.Parameter(nonneg=True, name="gamma2")
        self.P = [cp.Variable((n, n), symmetric=True, name=f"P{u}")
                  for u in range(nodes)]
        self.t = cp.Variable(name="t")
        eye = np.eye(n)
        cons = []
        for u in range(nodes):
            cons += [self.P[u] >> eye, self.P[u] << CAP * eye]
        for A, u, v in zip(matrices, source.tolist(), target.tolist()):
            lhs = self.gamma2 * self.P[u] - A.T @ self.P[v] @ A
            cons.append(0.5 * (lhs + lhs.T) - self.t * eye >> 0)
        self.problem = cp.Problem(cp.Maximize(self.t), cons)

    def solve_at(self, gamma: float, time_limit: float | None = None,
                 solver: str | None = None
                 ) -> tuple[np.ndarray | None, float, SolveReport]:
        """Solve at ``γ``: the ``P_u`` (None when none was returned), the
        margin ``t`` (``-inf`` without an answer) and the solver's report."""
        self.gamma2.value = float(gamma) ** 2
        report = solve(self.problem, solver, time_limit=time_limit)
        if report.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) or any(
                P.value is None for P in self.P):
            return None, -np.inf, report
        values = [np.asarray(Pu.value, float) for Pu in self.P]
        P = np.array([0.5 * (V + V.T) for V in values])
        margin = self.t.value
        return P, -np.inf if margin is None else float(margin), report


def complex_gauge(V: np.ndarray, z: np.ndarray
                  ) -> tuple[float, np.ndarray | None]:
    """``min Σ|c_i|`` over complex ``c`` with ``V c = z``: the gauge of
    ``z`` in the balanced complex hull of the columns of ``V``.

    Returns ``(value, c)``; ``(inf, None)`` when ``z`` is not in the span
    of ``V`` (Clarabel's infeasibility) or the solver fails. ``c`` is the
    solver's answer: the caller measures ``V c - z`` itself.
    """
    import clarabel
    import scipy.sparse as sp
    n, N = V.shape
    Vr, Vi = V.real, V.imag
    # x = [t_1, a_1, b_1, t_2, a_2, b_2, ...], c_i = a_i + i b_i
    Aeq = np.zeros((2 * n, 3 * N))
    Aeq[:n, 1::3], Aeq[:n, 2::3] = Vr, -Vi
    Aeq[n:, 1::3], Aeq[n:, 2::3] = Vi, Vr
    A = sp.vstack([sp.csc_matrix(Aeq), -sp.identity(3 * N, format="csc")],
                  format="csc")
    b = np.concatenate([z.real, z.imag, np.zeros(3 * N)])
    q = np.zeros(3 * N)
    q[0::3] = 1.0
    cones: list[Any] = [clarabel.ZeroConeT(2 * n)] + [
        clarabel.SecondOrderConeT(3) for _ in range(N)]
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_abs = settings.tol_gap_rel = 1e-10
    settings.tol_feas = 1e-10
    solver = clarabel.DefaultSolver(sp.csc_matrix((3 * N, 3 * N)), q, A, b,
                                    cones, settings)
    sol = solver.solve()
    if str(sol.status) not in ("Solved", "AlmostSolved"):
        return np.inf, None
    x = np.asarray(sol.x)
    c = x[1::3] + 1j * x[2::3]
    return float(np.abs(c).sum()), c
