"""The analysis LMIs: a certificate for a fixed closed loop.

The dissipation inequality of :ref:`theory-passivity` (input-feedforward
level ``η``, and the supply with an output-feedback term ``ρ``) for a jump
system, with one storage per phase and previous mode.
"""

from __future__ import annotations

from typing import Any, cast

import numpy as np
import cvxpy as cp

from ..jump import JumpStateSpace
from ..verify import supply_rows
from ._core import (data_scale, _lower, _Model, _param, _quad_map,
                    _symmetric_scatter, _template, _Template)


# -- analysis: theory: passivity ----------------------------------------------
class AnalysisModel(_Model):
    """The analysis LMI: ``Θ_k(P, η) ≼ -ε diag(P_k, I)``, ``P_k ≽ ε I``.

    Attributes
    ----------
    problem : cvxpy.Problem
    P : list of cvxpy.Variable
        ``P_k`` per phase.
    eta : cvxpy.Variable or float
        ``η`` when maximised, else the given value.
    margin : cvxpy.Variable or float
        The absolute margin ``ε`` (relative margin times the data's scale),
        or the variable ``t`` when the margin is maximised.
    """

    def __init__(self, template, values, eta, margin):
        super().__init__(template, values)
        self.P = template.parts["P"]
        self.eta, self.margin = eta, margin

    def values(self) -> np.ndarray:
        """The solved certificate ``P_k``, shape (N, n, n)."""
        return np.array([Pk.value for Pk in self.P])

    def theta_duals(self) -> list[np.ndarray]:
        """The dual variables of the ``Θ_k`` constraints, one per phase
        (the template adds ``Θ_k ≼ …`` then ``P_k ≽ …`` for each phase)."""
        return [np.asarray(c.dual_value, float)
                for c in self.problem.constraints[0::2]]


def analysis_model(sys: JumpStateSpace, eta: float | None,
                   margin: float | None, decay: float = 1.0) -> AnalysisModel:
    """Build the LMI of :ref:`theory-passivity` (maximise ``η`` when ``eta`` is
    None).

    ``margin=None`` (with a given ``eta``) maximises the strictness margin
    ``t`` itself: ``Θ_k ≼ -t I``, ``P_k ≽ t I``. Its answer is the most
    interior certificate, the one most likely to pass the exact check when
    ``η`` lies within a fixed margin of the index; ``t ≤ 0`` at the optimum
    means no strict certificate exists.

    The problem is compiled once per shape (period, sizes, which of ``η``
    and the margin is maximised) and reused in this thread.
    """
    A, B, p = sys.modes.A, sys.modes.B, sys.modes.probabilities
    _, _, Cbar, Dbar = sys.modes.mean()
    N, n, m = sys.period, A.shape[-1], B.shape[-1]
    if margin is None and eta is None:
        raise ValueError("analysis_model: margin=None needs a given eta")
    key = ("analysis", N, n, m, Cbar.shape[-2], eta is None, margin is None)
    template = _template(key, lambda: _analysis_template(*key[1:]))
    values: dict[Any, Any] = {"decay2": float(decay) ** 2}
    if eta is not None:
        values["eta"] = float(eta)
    if margin is not None:
        eps = margin * data_scale(A, B, sys.modes.C, sys.modes.D)
        values["margin"] = eps
    for k in range(N):
        G = np.concatenate([A[k], B[k]], axis=-1)
        values[("quad", k)] = _quad_map(
            [(p[k, i], G[i]) for i in np.flatnonzero(p[k] > 0)], n, m)
        values[("C", k)] = Cbar[k]
        values[("Dsym", k)] = Dbar[k] + Dbar[k].T
    return AnalysisModel(
        template, values,
        template.parts["eta"] if eta is None else float(eta),
        template.parts["margin"] if margin is None else eps)


def _analysis_template(N, n, m, nz, maximise_eta, maximise_margin):
    params: dict = {}
    d2 = _param(params, "decay2")
    e = cp.Variable(name="eta") if maximise_eta else _param(params, "eta")
    t = (cp.Variable(name="margin") if maximise_margin
         else _param(params, "margin"))
    P = [cp.Variable((n, n), symmetric=True, name=f"P{k}") for k in range(N)]
    cons = []
    lower_n, lower_nm = _lower(n), _lower(n + m)
    scatter = _symmetric_scatter(n + m)
    for k in range(N):
        Pn = P[(k + 1) % N]
        quad = cp.reshape(
            scatter @ (_param(params, ("quad", k),
                              (lower_nm.size, lower_n.size))
                       @ cp.vec(Pn, order="F")[lower_n]),
            (n + m, n + m), order="F")
        C = _param(params, ("C", k), (nz, n))
        supply = cp.bmat([
            [-d2 * P[k], -C.T],
            [-C, 2 * e * np.eye(m) - _param(params, ("Dsym", k), (m, m))]])
        # The (1,1) block is homogeneous in P, so its margin is relative to
        # P_k (a decay margin 1 - ε). An absolute ε·I there forces
        # ‖P‖ ≳ ε / (1 - ms_radius) and, through the supply coupling, costs η:
        # measured on a loop from passivesyn with ms_radius = 1 - 1e-6, the
        # absolute margin certified η = -4.7e5 where the synthesis P proves
        # 1.5285 (tests/test_passivity.py).
        slack = (np.eye(n + m) if maximise_margin else
                 cp.bmat([[P[k], np.zeros((n, m))],
                          [np.zeros((m, n)), np.eye(m)]]))
        # symmetric by construction (see _symmetric_scatter)
        cons += [quad + supply << -t * slack, P[k] >> t * np.eye(n)]
    objective = (cp.Maximize(t) if maximise_margin else
                 cp.Maximize(e) if maximise_eta else cp.Minimize(0))
    return _Template(cp.Problem(objective, cons), params, P=P, eta=e, margin=t)


# -- analysis with an output-feedback term (theory: passivity, supply 2wᵀz -
# 2ρzᵀz - 2ηwᵀw)
class SupplyModel:
    """The analysis LMI with ``ρ`` or Markov modes: ``Θ ≼ -ε diag(P, I)``.

    A plain (uncached) cvxpy problem: the ``ρ`` term and Markov modes are
    rare next to the i.i.d. input-feedforward index of
    :func:`analysis_model`.

    Attributes
    ----------
    problem : cvxpy.Problem
    P : list of list of cvxpy.Variable
        ``P[k][ℓ]``: ``P_k`` (``ℓ = 0`` only) for i.i.d. modes, ``P_{k,ℓ}``
        per previous mode for Markov modes (:ref:`theory-markov`).
    eta, rho, margin : cvxpy.Variable or float
        The maximised one is a Variable, the others the given values.
    """

    def __init__(self, problem: cp.Problem, P: list, eta: Any, rho: Any,
                 margin: Any, markov: bool = False):
        self.problem, self.P = problem, P
        self.eta, self.rho, self.margin = eta, rho, margin
        self.markov = markov

    def check_current(self) -> None:
        """Nothing to check: the problem is this model's own."""

    def values(self) -> np.ndarray:
        """The solved certificate: (N, n, n), or (N, M, n, n) if Markov."""
        P = np.array([[v.value for v in Pk] for Pk in self.P])
        return P if self.markov else P[:, 0]


def supply_model(sys: JumpStateSpace, eta: float | None, rho: float | None,
                 margin: float | None, decay: float = 1.0) -> SupplyModel:
    """Build the LMI of :ref:`theory-passivity` / :ref:`theory-markov` with the
    supply ``2wᵀz - 2ρzᵀz - 2ηwᵀw``.

    ``Θ`` gains ``2ρ Σ_i t_i [C_i D_i]ᵀ[C_i D_i]`` (``zᵀz`` is quadratic:
    its expectation takes each mode's output matrices, not their mean; see
    :func:`control_ncs.verify.dissipation_blocks`), linear in ``P``, ``η``
    and ``ρ``. One inequality per phase and supply row
    (:func:`control_ncs.verify.supply_rows`): for Markov modes ``Θ_{k,ℓ}``
    with ``P_{k,ℓ}`` and ``P_{k+1,i}`` per next mode. Exactly one of
    ``eta``, ``rho``, ``margin`` may be None: that one is maximised
    (``margin=None``: the most interior certificate, as in
    :func:`analysis_model`).
    """
    if [eta, rho, margin].count(None) > 1:
        raise ValueError("supply_model: at most one of eta, rho, margin may "
                         "be None")
    A, B, C, D = sys.modes.A, sys.modes.B, sys.modes.C, sys.modes.D
    rows = supply_rows(sys.modes)
    markov = not sys.modes.is_iid
    N, L, n, m = sys.period, rows.shape[1], A.shape[-1], B.shape[-1]
    e = cp.Variable(name="eta") if eta is None else float(eta)
    r = cp.Variable(name="rho") if rho is None else float(rho)
    t = (cp.Variable(name="margin") if margin is None
         else margin * data_scale(A, B, C, D))
    P = [[cp.Variable((n, n), symmetric=True, name=f"P{k}_{l}")
          for l in range(L)] for k in range(N)]
    cons = []
    for k in range(N):
        Pn = P[(k + 1) % N]
        for l, p in enumerate(rows[k]):
            live = np.flatnonzero(p > 0)
            F = {i: np.concatenate([A[k, i], B[k, i]], axis=1) for i in live}
            H = {i: np.concatenate([C[k, i], D[k, i]], axis=1) for i in live}
            # i.i.d.: one P_{k+1}; Markov: P_{k+1,i} for next mode i
            quad = sum(p[i] * (F[i].T @ Pn[i if markov else 0] @ F[i])
                       for i in live)
            W = sum(p[i] * (H[i].T @ H[i]) for i in live)
            Cbar = np.tensordot(p, C[k], axes=1)
            Dbar = np.tensordot(p, D[k], axes=1)
            Pk = P[k][l]
            supply = cp.bmat([[-float(decay) ** 2 * Pk, -Cbar.T],
                              [-Cbar, 2 * e * np.eye(m) - Dbar - Dbar.T]])
            M = quad + supply + 2 * r * W
            slack = (np.eye(n + m) if margin is None else
                     cp.bmat([[Pk, np.zeros((n, m))],
                              [np.zeros((m, n)), np.eye(m)]]))
            cons += [0.5 * (M + M.T) << -t * slack, Pk >> t * np.eye(n)]
    objective = (cp.Maximize(t) if margin is None else
                 cp.Maximize(e) if eta is None else
                 cp.Maximize(r) if rho is None else cp.Minimize(0))
    return SupplyModel(cp.Problem(objective, cons), P, e, r, t, markov)


# -- any quadratic supply: theory: performance -----------------------------------
class QuadraticSupplyModel:
    """The LMI ``Θ_{k,ℓ}(P) ≼ -ε I``, ``P ≽ ε I`` of a quadratic supply.

    Attributes
    ----------
    problem : cvxpy.Problem
    level : cvxpy.Variable or None
        ``t`` with ``R = t I``, minimised, when the supply's ``R`` was left
        free (the ℓ2 gain: ``t = γ²``); None for a fixed supply.
    P : list of list of cvxpy.Variable
        ``P[k][ℓ]``: the storage per phase and previous mode (one ``ℓ`` for
        i.i.d. modes).
    """

    def __init__(self, problem: cp.Problem, level: Any, P: list):
        self.problem, self.level, self.P = problem, level, P

    def certificate(self) -> np.ndarray:
        """The solver's ``P`` as an (N, L, n, n) array."""
        return np.array([[np.asarray(X.value, float) for X in row]
                         for row in self.P])

    def theta_duals(self) -> np.ndarray | None:
        """The multipliers of the ``Θ_{k,ℓ}`` constraints, (N, L, n + m,
        n + m): after an ``'infeasible'`` status, the solver's Farkas
        certificate (:func:`control_ncs._farkas.supply_dual_check` checks
        it); None when the solver gave none. The model adds ``Θ_{k,ℓ}``
        then ``P_{k,ℓ}`` for each phase and row."""
        duals = [c.dual_value for c in self.problem.constraints[0::2]]
        if any(z is None for z in duals):
            return None
        N, L = len(self.P), len(self.P[0])
        Z = np.array([np.asarray(z, float) for z in duals])
        return Z.reshape((N, L) + Z.shape[1:])


def _weight(X: Any, size_out: int, size_in: int) -> np.ndarray:
    """A supply weight as a matrix (a number is that multiple of ``I``)."""
    if np.ndim(X) == 0:
        return float(X) * np.eye(size_out, size_in)
    return np.asarray(X, float)


def quadratic_supply_model(sys: JumpStateSpace, Q: Any, S: Any, R: Any,
                           margin: float, decay: float = 1.0
                           ) -> QuadraticSupplyModel:
    """The LMI of :func:`control_ncs.verify.supply_blocks` in ``P``
    (``ε = margin`` times the data's scale); ``R=None``: ``R = t I`` with
    ``t`` minimised. The supply's ``Q``, ``S``, ``R`` enter as data."""
    m, N = sys.modes, sys.period
    n, nw, nz = m.A.shape[-1], m.B.shape[-1], m.C.shape[-2]
    rows = supply_rows(m)
    L = rows.shape[1]
    eps = margin * data_scale(m.A, m.B, m.C, m.D)
    Qm, Sm = _weight(Q, nz, nz), _weight(S, nz, nw)
    P = [[cp.Variable((n, n), symmetric=True) for _ in range(L)]
         for _ in range(N)]
    level = cp.Variable(nonneg=True) if R is None else None
    Rm = None if R is None else _weight(R, nw, nw)
    cons = []
    for k in range(N):
        nxt = P[(k + 1) % N]
        for ell in range(L):
            t = rows[k, ell]
            live = np.flatnonzero(t > 0)
            Cbar = sum(t[i] * m.C[k, i] for i in live)
            Dbar = sum(t[i] * m.D[k, i] for i in live)
            terms = []
            for i in live:
                F = np.concatenate([m.A[k, i], m.B[k, i]], axis=1)
                H = np.concatenate([m.C[k, i], m.D[k, i]], axis=1)
                Pn = nxt[0] if m.is_iid else nxt[i]
                terms.append(t[i] * (F.T @ Pn @ F - H.T @ Qm @ H))
            theta = cp.sum(terms) if len(terms) > 1 else terms[0]
            cross = np.block([[np.zeros((n, n)), Cbar.T @ Sm],
                              [Sm.T @ Cbar, Dbar.T @ Sm + Sm.T @ Dbar]])
            r_block: Any = Rm
            if r_block is None:
                r_block = cast(Any, level) * np.eye(nw)
            corner = cp.bmat([[decay ** 2 * P[k][ell], np.zeros((n, nw))],
                              [np.zeros((nw, n)), r_block]])
            T = theta - cross - corner
            cons.append(0.5 * (T + T.T) << -eps * np.eye(n + nw))
            cons.append(P[k][ell] >> eps * np.eye(n))
    objective = cp.Minimize(level) if level is not None else \
        cp.Minimize(0)
    return QuadraticSupplyModel(cp.Problem(objective, cons), level, P)
