"""The periodic steady state of the second moment under white noise
(:ref:`theory-performance`).

The stationary covariances ``Q_k`` of a mean-square stable jump system
driven by unit white noise, and the output power ``‖G‖₂²`` they give: the
fixed point of the forced second-moment recursion over one period, solved
on the same kernel that :func:`control_ncs.ms_radius` certifies with
(:func:`control_ncs.stability.second_moment_operator`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.linalg import solve_discrete_lyapunov
from scipy.sparse.linalg import LinearOperator, gmres

from ._blas import serial_blas
from ._checks import choice, positive_real
from .jump import JumpStateSpace, as_jump
from .stability import (DENSE_MAX_STATES, dense_monodromy, kernel_side,
                        ms_radius, second_moment_operator)

__all__ = ["stationary_covariances"]

#: With ``method='auto'``, a fixed point GMRES does not bring to ``tol``
#: (slow convergence next to the stability edge, or rounding stagnation at
#: ``tol ≈ 1e-13``) is solved on the dense Kronecker system up to this many
#: unknowns (a matrix of 128 MiB; an estimator over a Gilbert–Elliott
#: sensor and a bursty actuator link, 864 unknowns, needed it).
DENSE_FALLBACK_SIZE = 4096


def phase_forcing(B: np.ndarray, p: np.ndarray,
                  T: np.ndarray | None) -> np.ndarray:
    """What white unit noise adds to the second moment in one phase, on
    per-mode arrays ``B`` (M, n, m): ``Σ_i p_i B_i B_iᵀ`` (i.i.d.), or per
    next mode ``j`` ``Σ_i T[i, j] π_i B_i B_iᵀ`` (Markov, ``p = π`` the
    stationary marginals, ``T`` the phase's transitions)."""
    BB = B @ B.transpose(0, 2, 1)                      # (M, n, n)
    if T is None:
        return np.tensordot(p, BB, axes=1)
    return np.tensordot(T.T, p[:, None, None] * BB, axes=1)


def _forcing(sys: JumpStateSpace, k: int) -> np.ndarray:
    """:func:`phase_forcing` of phase ``k`` of ``sys``."""
    T = None if sys.modes.is_iid else sys.modes.transitions()[k]
    return phase_forcing(sys.modes.B[k], sys.modes.probabilities[k], T)


def stationary_covariances(sys: Any, *, method: str = "auto",
                           tol: float = 1e-12) -> np.ndarray:
    """The periodic stationary second moments under unit white noise.

    ``Q_k = E ξ_k ξ_kᵀ`` (i.i.d. modes) or ``Q_{k,i} = E[ξ_k ξ_kᵀ 1{σ_k = i}]``
    (Markov modes) of ``ξ⁺ = A ξ + B w`` with ``E w wᵀ = I``, in the
    periodic steady state: the linear fixed point
    ``Q_{k+1} = 𝒯_k(Q_k) + Σ p B Bᵀ`` (:ref:`theory-performance`), solved
    over one period, ``(I - 𝒯) Q_0 = F``, by a dense solve of the Kronecker
    monodromy or matrix-free by GMRES on :func:`second_moment_operator`.

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time control.StateSpace
        Mean-square stable.
    method : {'auto', 'dense', 'matrix-free'}
        As for :func:`ms_radius` (by the operator's size).
    tol : float
        Relative residual asked of GMRES (matrix-free route).

    Returns
    -------
    ndarray, shape (N, n, n) or (N, M, n, n)
        Per phase (and per mode for Markov modes).

    Raises
    ------
    ValueError
        If ``sys`` is not proven mean-square stable (no steady state, or
        the radius' certified bracket contains 1), or GMRES does not reach
        ``tol``.

    Examples
    --------
    ``x⁺ = a x + w`` with ``a = 0.5`` or ``0.9`` (probabilities 0.3, 0.7):
    ``E x² = 1/(1 - E a²) = 1/(1 - 0.642)``.

    >>> import control_ncs as ncs
    >>> sys = ncs.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7])
    >>> round(float(ncs.stationary_covariances(sys)[0, 0, 0]), 10)
    2.7932960894
    """
    sys = as_jump(sys)
    choice(method, "method", ("auto", "dense", "matrix-free"))
    tol = positive_real(tol, "tol")
    radius = ms_radius(sys, bracket=True)
    if radius.stable is not True:
        raise ValueError(f"sys: not proven mean-square stable "
                         f"({radius.message}): the noise-driven second "
                         "moment has no steady state")
    return stationary_of_stable(sys, method, tol)


def stationary_of_stable(sys: JumpStateSpace, method: str, tol: float
                         ) -> np.ndarray:
    """:func:`stationary_covariances` of a mean-square stable system."""
    with serial_blas(kernel_side(sys, method)):
        return _stationary_run(sys, method, tol)


def _stationary_run(sys: JumpStateSpace, method: str, tol: float
                    ) -> np.ndarray:
    n, N = sys.modes.A.shape[-1], sys.period
    mats = sys.deterministic() if N == 1 and sys.modes.is_iid else None
    if mats is not None:
        # one live mode: the Stein equation Q = A Q Aᵀ + B Bᵀ (Bartels-
        # Stewart, O(n³)) instead of the n² × n² Kronecker system
        A, B = mats[0][0], mats[1][0]
        Q = solve_discrete_lyapunov(A, B @ B.T)
        return 0.5 * (Q + Q.T)[None]
    markov = not sys.modes.is_iid
    shape = (sys.nmodes, n, n) if markov else (n, n)
    size = int(np.prod(shape))
    # forcing accumulated over one period from Q_0 = 0
    F = np.zeros(shape)
    for k in range(N):
        F = second_moment_operator(sys, k).matvec(F.ravel()).reshape(shape) \
            + _forcing(sys, k)
    chosen = method
    if method == "auto":
        method = "dense" if size <= DENSE_MAX_STATES ** 2 else "matrix-free"
    q = None
    if method == "matrix-free":
        op = second_moment_operator(sys)
        lhs = LinearOperator((size, size), dtype=float,
                             matvec=lambda v: v - op.matvec(v))
        q, info = gmres(lhs, F.ravel(), rtol=tol, atol=0.0, restart=50,
                        maxiter=200)
        if info != 0:
            if chosen != "auto" or size > DENSE_FALLBACK_SIZE:
                raise ValueError(
                    f"sys: GMRES did not reach tol={tol:g} on the stationary "
                    f"second moment ({size} unknowns)")
            q = None          # the route was ours to choose: solve it dense
    if q is None:
        q = np.linalg.solve(np.eye(size) - dense_monodromy(sys), F.ravel())
    out = [q.reshape(shape)]
    for k in range(N - 1):
        out.append(second_moment_operator(sys, k).matvec(
            out[-1].ravel()).reshape(shape) + _forcing(sys, k))
    Q = np.array(out)
    return 0.5 * (Q + np.swapaxes(Q, -1, -2))


def output_power(sys: Any, *, method: str = "auto",
                 tol: float = 1e-12) -> float:
    """``‖G‖₂²``: the stationary mean output power under unit white noise.

    Averaged over the period: ``(1/N) Σ_k Σ_i [tr(C_ki Q_ki C_kiᵀ) +
    p_ki tr(D_ki D_kiᵀ)]`` with the covariances of
    :func:`stationary_covariances` (:ref:`theory-performance`); ``inf``
    when ``sys`` is not proven mean-square stable.
    """
    sys = as_jump(sys)
    choice(method, "method", ("auto", "dense", "matrix-free"))
    tol = positive_real(tol, "tol")
    if ms_radius(sys, bracket=True).stable is not True:
        return float("inf")
    Q = stationary_of_stable(sys, method, tol)
    m = sys.modes
    total = 0.0
    for k in range(sys.period):
        p = m.probabilities[k]
        Qk = Q[k] if not m.is_iid else p[:, None, None] * Q[k][None]
        CQC = np.einsum("mab,mbc,mac->m", m.C[k], Qk, m.C[k])
        DD = np.einsum("mab,mab->m", m.D[k], m.D[k])
        total += float(CQC.sum() + p @ DD)
    return total / sys.period
