"""The LQG loop over two lossy links as a jump system, and its exact cost
with its gradient (:ref:`theory-estimation`).

The plant ``x⁺ = A x + ν B v + G w``, ``y = C x + v_m`` reaches an
estimator controller ``x̂_{k|k} = x̂ + γ L_f (y - C x̂)``, ``v = K x̂_{k|k}``
through a sensor link (arrival ``γ``, probability ``λ``); its command
crosses an actuator link (arrival ``ν``, probability ``ν̄``). With
acknowledgements (TCP-like) the estimator adds the command that arrived,
``x̂⁺ = A x̂_{k|k} + ν B v``; without (UDP-like) its expected value,
``x̂⁺ = A x̂_{k|k} + ν̄ B v``. On ``[x; x̂]`` with i.i.d. modes ``(γ, ν)``
and unit noise ``[w; v_m]`` (scaled here) the loop is an i.i.d. jump
system whose H2 norm squared is the stationary cost ``E[xᵀQx + ν vᵀRv]``.
Its gradient follows from the stationary covariance ``X`` and its adjoint
``V`` (``V = Σ p_i (A_iᵀ V A_i + C_iᵀ C_i)``): ``dJ = Σ_i ⟨S_A, dA_i⟩ +
⟨S_B, dB_i⟩ + ⟨S_C, dC_i⟩ + ⟨S_D, dD_i⟩`` with ``S_A = 2 p_i V A_i X``,
``S_B = 2 p_i V B_i``, ``S_C = 2 p_i C_i X``, ``S_D = 2 p_i D_i``. Each mode
matrix is affine in ``K`` (``M = m_K K h_K + …``) and in ``L_f``
separately, so ``∂J/∂K = Σ m_Kᵀ S h_Kᵀ`` and likewise for ``L_f``: the
gradient is exact (:func:`cost`).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from scipy.optimize import minimize

from ._mare import _pairs, _sym_kron, _from_tri, _to_tri

__all__: list[str] = []


class LoopData(NamedTuple):
    """The plant, noise and weights of the LQG loop (square roots taken)."""

    A: np.ndarray
    B: np.ndarray
    G: np.ndarray          #: ``G QN^½``: process noise per unit input
    C: np.ndarray
    Rv: np.ndarray         #: ``RN^½``: measurement noise per unit input
    Qh: np.ndarray         #: ``Q^½`` (rows of z)
    Rh: np.ndarray         #: ``R^½``
    lam: float             #: sensor arrival probability
    nu: float              #: actuator arrival probability


def sqrt_psd(M: np.ndarray) -> np.ndarray:
    """The symmetric square root of a positive semidefinite matrix."""
    w, U = np.linalg.eigh(0.5 * (M + M.T))
    return (U * np.sqrt(np.clip(w, 0.0, None))) @ U.T


def modes(data: LoopData, K: np.ndarray, Lf: np.ndarray,
          acknowledged: bool) -> tuple:
    """``(A_i, B_i, C_i, D_i, p_i)`` of the loop on ``[x; x̂]``, modes
    ``(γ, ν) = (0, 0), (1, 0), (0, 1), (1, 1)``; ``K`` acts as ``v = K
    x̂_{k|k}`` (the package's sign)."""
    A, B, G, C, Rv = data.A, data.B, data.G, data.C, data.Rv
    n, g, p = A.shape[0], G.shape[1], C.shape[0]
    lam, nu = data.lam, data.nu
    As, Bs, Cs, Ds, probs = [], [], [], [], []
    for nu_i in (0.0, 1.0):
        for gamma in (0.0, 1.0):
            Hx = gamma * Lf @ C
            Hh = np.eye(n) - Hx
            Hv = gamma * Lf @ Rv
            used = nu_i if acknowledged else data.nu
            Ahat = A + used * B @ K
            As.append(np.block([[A + nu_i * B @ K @ Hx, nu_i * B @ K @ Hh],
                                [Ahat @ Hx, Ahat @ Hh]]))
            Bs.append(np.block([[G, nu_i * B @ K @ Hv],
                                [np.zeros((n, g)), Ahat @ Hv]]))
            Cs.append(np.block([[data.Qh, np.zeros_like(data.Qh)],
                                [nu_i * data.Rh @ K @ Hx,
                                 nu_i * data.Rh @ K @ Hh]]))
            Ds.append(np.block([[np.zeros((data.Qh.shape[0], g + p))],
                                [np.zeros((data.Rh.shape[0], g)),
                                 nu_i * data.Rh @ K @ Hv]]))
            probs.append((lam if gamma else 1 - lam) *
                         (nu if nu_i else 1 - nu))
    return (np.array(As), np.array(Bs), np.array(Cs), np.array(Ds),
            np.array(probs))


def _stationary(As: np.ndarray, p: np.ndarray, F: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray] | None:
    """``X = Σ p_i A_i X A_iᵀ + F`` and ``Y`` with forcing ``I`` (dense,
    symmetric unknowns), or None when ``Y ⊁ 0`` (not mean-square stable:
    ``ρ ≥ 1``)."""
    n = As.shape[-1]
    i, j = _pairs(n)
    op = sum(w * _sym_kron(M, i, j) for w, M in zip(p, As) if w > 0)
    rhs = np.column_stack([_to_tri(F[None], i, j),
                           _to_tri(np.eye(n)[None], i, j)])
    try:
        sol = np.linalg.solve(np.eye(i.size) - op, rhs)
    except np.linalg.LinAlgError:
        return None
    X = _from_tri(sol[:, 0], 1, n, i, j)[0]
    Y = _from_tri(sol[:, 1], 1, n, i, j)[0]
    try:
        np.linalg.cholesky(Y)
    except np.linalg.LinAlgError:
        return None
    return X, Y


def cost(data: LoopData, K: np.ndarray, Lf: np.ndarray, *,
         acknowledged: bool = False, gradient: bool = False
         ) -> tuple[float, np.ndarray | None]:
    """The loop's exact stationary cost (``inf`` when it is not mean-square
    stable) and, if asked, its gradient in ``(K, L_f)`` (flattened,
    ``K`` first)."""
    As, Bs, Cs, Ds, p = modes(data, K, Lf, acknowledged)
    F = np.einsum("i,iab,icb->ac", p, Bs, Bs)
    primal = _stationary(As, p, F)
    if primal is None:
        return np.inf, None
    X = primal[0]
    J = float(np.einsum("i,iab,bc,iac->", p, Cs, X, Cs)
              + np.einsum("i,iab,iab->", p, Ds, Ds))
    if not gradient:
        return J, None
    dual = _stationary(As.transpose(0, 2, 1), p,
                       np.einsum("i,iba,ibc->ac", p, Cs, Cs))
    if dual is None:
        return np.inf, None
    V = dual[0]
    return J, _gradient(data, K, Lf, acknowledged, p, V, X, As, Bs, Cs, Ds)


def _gradient(data: LoopData, K: np.ndarray, Lf: np.ndarray,
              acknowledged: bool, p: np.ndarray, V: np.ndarray,
              X: np.ndarray, As: np.ndarray, Bs: np.ndarray, Cs: np.ndarray,
              Ds: np.ndarray) -> np.ndarray:
    """``(∂J/∂K, ∂J/∂L_f)`` flattened (module docstring). Per mode
    ``(γ, ν)``, with ``u`` the command the estimator adds (``ν`` or ``ν̄``),
    ``H = [γL_fC, I - γL_fC]``, ``H_b = [0, γL_f R_v]``, ``Â = A + uBK``:
    ``A_i = [νB; uB] K H + …``, ``B_i = [νB; uB] K H_b + …``, ``C_i = [0;
    νR^½] K H + …``, ``D_i = [0; νR^½] K H_b``; and in ``L_f``: ``A_i =
    γ[νBK; Â] L_f C [I, -I] + …``, ``B_i = γ[νBK; Â] L_f [0, R_v] + …``,
    ``C_i = γ[0; νR^½K] L_f C [I, -I] + …``, ``D_i = γ[0; νR^½K] L_f [0,
    R_v]``."""
    A, B, C, Rv, Rh = data.A, data.B, data.C, data.Rv, data.Rh
    n, g, pm = A.shape[0], data.G.shape[1], C.shape[0]
    nq = data.Qh.shape[0]
    gK = np.zeros_like(K)
    gL = np.zeros_like(Lf)
    hL = np.hstack([C, -C])
    hB = np.hstack([np.zeros((pm, g)), Rv])
    k = 0
    for nu_i in (0.0, 1.0):
        for gamma in (0.0, 1.0):
            w = 2 * p[k]
            SA = w * V @ As[k] @ X
            SB = w * V @ Bs[k]
            SC = w * Cs[k] @ X
            SD = w * Ds[k]
            k += 1
            u = nu_i if acknowledged else data.nu
            Hx = gamma * Lf @ C
            H = np.hstack([Hx, np.eye(n) - Hx])
            Hb = np.hstack([np.zeros((n, g)), gamma * Lf @ Rv])
            bK = np.vstack([nu_i * B, u * B])
            cK = np.vstack([np.zeros((nq, B.shape[1])), nu_i * Rh])
            gK += bK.T @ SA @ H.T + bK.T @ SB @ Hb.T + cK.T @ SC @ H.T \
                + cK.T @ SD @ Hb.T
            if gamma:
                aL = np.vstack([nu_i * B @ K, A + u * B @ K])
                cL = np.vstack([np.zeros((nq, n)), nu_i * Rh @ K])
                gL += aL.T @ SA @ hL.T + aL.T @ SB @ hB.T + \
                    cL.T @ SC @ hL.T + cL.T @ SD @ hB.T
    return np.concatenate([gK.ravel(), gL.ravel()])


def _split(theta: np.ndarray, kshape: tuple, lshape: tuple
           ) -> tuple[np.ndarray, np.ndarray]:
    k = int(np.prod(kshape))
    return theta[:k].reshape(kshape), theta[k:].reshape(lshape)


def search(data: LoopData, K0: np.ndarray, L0: np.ndarray, *,
           maxiter: int = 300) -> tuple[np.ndarray, np.ndarray, float, dict]:
    """A local minimum of the UDP-like cost from ``(K0, L0)`` (BFGS on the
    exact cost and its analytic gradient); the start is shrunk towards
    ``K = 0`` until the loop is mean-square stable when it is not."""
    kshape, lshape = K0.shape, L0.shape
    start = np.concatenate([K0.ravel(), L0.ravel()])
    J0, _ = cost(data, K0, L0)
    shrink = 0
    while not np.isfinite(J0) and shrink < 40:
        shrink += 1
        K0 = 0.8 * K0
        start = np.concatenate([K0.ravel(), L0.ravel()])
        J0, _ = cost(data, K0, L0)
    if not np.isfinite(J0):
        return K0, L0, np.inf, dict(start_cost=np.inf, iterations=0,
                                    gradient_norm=np.nan, shrink=shrink,
                                    converged=False, message="no stable "
                                    "start")

    def fun(theta: np.ndarray) -> tuple[float, np.ndarray]:
        J, g = cost(data, *_split(theta, kshape, lshape), gradient=True)
        if g is None:
            return 1e300, np.zeros_like(theta)
        return J, g

    res: Any = minimize(fun, start, jac=True, method="BFGS",
                        options=dict(maxiter=maxiter, gtol=1e-9 * max(1.0, J0)))
    K, L = _split(res.x, kshape, lshape)
    J, g = cost(data, K, L, gradient=True)
    if not np.isfinite(J) or J > J0:        # keep the start if BFGS lost it
        K, L = _split(start, kshape, lshape)
        J, g = cost(data, K, L, gradient=True)
    norm = float(np.linalg.norm(g)) if g is not None else np.nan
    # stationary to the cost's own accuracy (BFGS may report a loss of
    # precision in its line search there)
    return K, L, J, dict(start_cost=J0, iterations=int(res.nit),
                         gradient_norm=norm, shrink=shrink,
                         converged=bool(norm <= 1e-6 * max(1.0, J)),
                         message=str(res.message))
