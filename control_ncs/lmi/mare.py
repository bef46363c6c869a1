"""The LMI of a fixed estimator gain over a lossy sensor link
(:ref:`theory-estimation`).

Some gain makes the estimation error mean-square stable exactly when this
LMI is feasible: Sinopoli et al.'s ``λ_max`` LMI, written for the coupled
equations of :mod:`control_ncs._mare` (one storage per link state). Its
control dual (``A → Aᵀ``, ``C → Bᵀ``) is the same program. The arrival
weights enter as cvxpy Parameters, so a bisection on the arrival
probability compiles the problem once.
"""

from __future__ import annotations

import numpy as np
import cvxpy as cp

from ._core import _Model, _param, _template, _Template


class MareModel(_Model):
    """The LMI of a fixed gain, loaded with one set of arrival weights.

    With storages ``V_s ≽ I`` (one per link state) and, for each state
    ``t`` whose gain acts (``β_t = Σ_s b[s, t] > 0``),
    ``E_t = Σ_s (b[s, t]/β_t) V_s`` and ``Z_t = E_t L_t``::

        [ V_t - Aᵀ D_t A          √β_t (E_t A - Z_t C)ᵀ ]
        [ √β_t (E_t A - Z_t C)    E_t                   ]  ≽ ε I,

    ``D_t = Σ_s (a - b)[s, t] V_s``; for a state without a gain
    ``V_t - Aᵀ D_t A ≽ ε I``. By a Schur complement this is
    ``𝓛*(V) ≺ V`` for the adjoint of the fixed-gain second-moment map
    ``𝓛(X)_s = Σ_t (a - b)[s, t] A X_t Aᵀ + b[s, t] A_t X_t A_tᵀ``,
    ``A_t = A - L_t C``: strictly feasible exactly when some gains make
    ``𝓛`` a contraction. For one Bernoulli link (``a = 1``, ``b = λ``) it
    is Sinopoli et al.'s LMI (:ref:`theory-estimation`). The LMI is
    homogeneous: normalised by ``V_s ≼ I``, the margin ``ε`` (every block
    ``≽ ε I``, also ``V_s ≽ ε I``) is maximised, so that the gain comes from
    the most interior point and passes the exact check wherever the
    solver's accuracy allows; ``ε* ≤ 0`` is the solver's proof that no gain
    exists.

    Attributes
    ----------
    problem : cvxpy.Problem
    V : list of cvxpy.Variable
        ``V_s`` per link state.
    Z : dict
        ``Z_t`` (cvxpy Variable) for each state ``t`` whose gain acts.
    margin : cvxpy.Variable
        ``ε``, maximised.
    """

    def __init__(self, template: _Template, values: dict, c: np.ndarray):
        super().__init__(template, values)
        self.V = template.parts["V"]
        self.Z = template.parts["Z"]
        self.margin = template.parts["margin"]
        self._c = c

    def gains(self) -> np.ndarray:
        """``L_t = E_t⁻¹ Z_t`` of the solved problem, shape (N, n, p)
        (zero for the states without a gain)."""
        self.check_current()
        V = np.array([0.5 * (v.value + v.value.T) for v in self.V])
        N, n = V.shape[:2]
        first = next(iter(self.Z.values()))
        L = np.zeros((N, n, first.shape[1]))
        for t, Zt in self.Z.items():
            E = np.tensordot(self._c[:, t], V, axes=1)
            L[t] = np.linalg.solve(E, Zt.value)
        return L


def mare_model(A: np.ndarray, C: np.ndarray, a: np.ndarray,
               b: np.ndarray) -> MareModel:
    """The fixed-gain LMI of ``(A, C)`` under arrival weights ``(a, b)``.

    Parameters
    ----------
    A : ndarray, shape (n, n)
    C : ndarray, shape (p, n)
    a, b : ndarray, shape (N, N)
        The weights of :mod:`control_ncs._mare` (rows of ``a`` sum to 1,
        ``0 ≤ b ≤ a``).

    Returns
    -------
    MareModel
        Compiled once per ``(A, C)`` and pattern of acting gains; other
        weights only load new parameter values.
    """
    N = a.shape[0]
    beta = b.sum(axis=0)
    acting = tuple(int(t) for t in np.flatnonzero(beta > 0))
    key = ("mare", A.shape, C.shape, A.tobytes(), C.tobytes(), N, acting)
    template = _template(key, lambda: _mare_template(A, C, N, acting))
    safe = np.where(beta > 0, beta, 1.0)
    values: dict[tuple, float] = {
        ("d", s, t): float(a[s, t] - b[s, t]) for s in range(N)
        for t in range(N)}
    values.update({("c", s, t): float(b[s, t] / safe[t])
                   for s in range(N) for t in acting})
    values.update({("w", s, t): float(b[s, t] / np.sqrt(safe[t]))
                   for s in range(N) for t in acting})
    values.update({("r", t): float(np.sqrt(beta[t])) for t in acting})
    return MareModel(template, values, b / safe[None, :])


def _mare_template(A: np.ndarray, C: np.ndarray, N: int,
                   acting: tuple) -> _Template:
    n, p = A.shape[0], C.shape[0]
    params: dict = {}
    V = [cp.Variable((n, n), symmetric=True, name=f"V{s}") for s in range(N)]
    Z = {t: cp.Variable((n, p), name=f"Z{t}") for t in acting}
    eps = cp.Variable(name="margin")
    cons = []
    for t in range(N):
        D = sum(_param(params, ("d", s, t)) * V[s] for s in range(N))
        top = V[t] - A.T @ D @ A
        if t in acting:
            E = sum(_param(params, ("c", s, t)) * V[s] for s in range(N))
            off = sum(_param(params, ("w", s, t)) * (V[s] @ A)
                      for s in range(N)) - _param(params, ("r", t)) * (
                          Z[t] @ C)
            M = cp.bmat([[top, off.T], [off, E]])
            cons.append(0.5 * (M + M.T) >> eps * np.eye(2 * n))
        else:
            cons.append(0.5 * (top + top.T) >> eps * np.eye(n))
    for s in range(N):
        cons += [V[s] >> eps * np.eye(n), V[s] << np.eye(n)]
    problem = cp.Problem(cp.Maximize(eps), cons)
    return _Template(problem, params, V=V, Z=Z, margin=eps)
