"""Exact mean-square stability (:ref:`theory-mss`).

The second moment ``Q = E ξξᵀ`` of the unforced system evolves by
``Q⁺ = 𝒯_k(Q) = Σ_i p_ki A_ki Q A_kiᵀ``. Over one period this is the
monodromy operator ``𝒯 = 𝒯_{N-1} ∘ … ∘ 𝒯_0``; the system is mean-square
stable exactly when its spectral radius is below one. Two routes compute it:

* ``'dense'``: the ``n² × n²`` Kronecker matrix ``Σ p (A ⊗ A)`` per phase,
  multiplied over the period, then all eigenvalues (memory ``O(n⁴)``);
* ``'matrix-free'``: ``𝒯`` applied by matrix products
  (``O(N·M·n³)`` per application) inside ARPACK
  (:func:`scipy.sparse.linalg.eigs`) for the eigenvalue of largest modulus,
  which for this positive map is the spectral radius itself.

Markov modes (:ref:`theory-markov`) carry the second moment per mode,
``Q_i = E[ξξᵀ 1{σ = i}]``, and ``Q⁺_j = Σ_i T_k[i, j] A_ki Q_i A_kiᵀ``: the
same two routes on ``M``-tuples (Kronecker size ``M·n²``). i.i.d. modes use
the ``n²`` operator above, so their numbers do not change.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.linalg import solve_discrete_lyapunov
from scipy.sparse.linalg import (ArpackError, ArpackNoConvergence,
                                  LinearOperator, eigs, gmres)

from ._checks import choice, no_extra_kwargs, positive_real
from .jump import JumpStateSpace, as_jump

__all__ = ["ms_radius", "is_mss", "second_moment_operator",
           "stationary_covariances"]

#: Above this state dimension, method='auto' goes matrix-free (the dense
#: monodromy needs n⁴ floats and N·n⁶ flops; see benchmarks/). Markov modes:
#: above an operator of side DENSE_MAX_STATES² (M·n² unknowns).
DENSE_MAX_STATES = 24


# -- the one second-moment kernel, on arrays ---------------------------------
def phase_map(A: np.ndarray, weights: np.ndarray, Q: np.ndarray,
              markov: bool) -> np.ndarray:
    """One phase of the second-moment map on per-mode arrays.

    i.i.d. modes (``weights = p_k``, ``Q`` of shape (n, n)):
    ``Q⁺ = Σ_i p_i A_i Q A_iᵀ``. Markov modes (``weights = T_k``, ``Q`` of
    shape (M, n, n), ``Q_i = E[ξξᵀ 1{σ = i}]``):
    ``Q⁺_j = Σ_i T_k[i, j] A_i Q_i A_iᵀ``. Every route of this module and
    the refinement's gradient (:mod:`control_ncs.refine`) apply it.
    """
    if markov:
        Y = A @ Q @ A.transpose(0, 2, 1)                 # (M, n, n)
        return np.tensordot(weights.T, Y, axes=1)        # Σ_i T[i, j] Y_i
    live = weights > 0
    Al = A[live]
    return np.einsum("m,mab,bc,mdc->ad", weights[live], Al, Q, Al,
                     optimize=True)


def phase_adjoint(A: np.ndarray, weights: np.ndarray, V: np.ndarray,
                  markov: bool) -> np.ndarray:
    """The adjoint of :func:`phase_map` (trace inner product):
    ``Σ_i p_i A_iᵀ V A_i``, or per mode ``A_iᵀ (Σ_j T_k[i, j] V_j) A_i``."""
    if markov:
        W = np.tensordot(weights, V, axes=1)             # Σ_j T[i, j] V_j
        return A.transpose(0, 2, 1) @ W @ A
    Y = A.transpose(0, 2, 1) @ V @ A
    return np.tensordot(weights, Y, axes=1)


def phase_matrix(A: np.ndarray, weights: np.ndarray,
                 markov: bool) -> np.ndarray:
    """:func:`phase_map` as a dense matrix on the row-major ``vec``
    (``Σ p_i A_i ⊗ A_i``; Markov: block ``(j, i) = T[i, j] A_i ⊗ A_i``)."""
    M, n = A.shape[0], A.shape[-1]
    if markov:
        blocks = np.array([np.kron(A[i], A[i]) for i in range(M)])
        return np.einsum("ij,iab->jaib", weights, blocks).reshape(M * n * n,
                                                                  -1)
    out = np.zeros((n * n, n * n))
    for i in np.flatnonzero(weights > 0):
        out += weights[i] * np.kron(A[i], A[i])          # vec(AQAᵀ)
    return out


def second_moment_operator(sys: Any, k: int | None = None) -> LinearOperator:
    """The second-moment map as a scipy LinearOperator.

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time StateSpace
    k : int, optional
        Phase whose one-step map ``𝒯_k`` is wanted (taken modulo the
        period ``N``); default: the monodromy ``𝒯`` over a whole period.
        Acts on ``vec(Q)`` (row-major ravel).

    Returns
    -------
    LinearOperator of shape (n², n²), or (M·n², M·n²) for Markov modes
        For Markov modes it acts on the tuple ``(vec Q_0, …, vec Q_{M-1})``
        stacked, ``Q_i = E[ξξᵀ 1{σ = i}]`` (:ref:`theory-markov`).

    Raises
    ------
    ValueError
        ``k`` is not an int.

    References
    ----------
    .. [1] O. L. V. Costa, M. D. Fragoso and R. P. Marques, *Discrete-Time
           Markov Jump Linear Systems*, Springer, 2005.

    Examples
    --------
    ``x⁺ = 2x`` with probability 0.2, else ``x⁺ = 0``: ``E x²`` is
    multiplied by ``0.2·4 = 0.8``.

    >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> ncs.second_moment_operator(sys).matvec(np.array([1.0])).round(12).tolist()
    [0.8]

    With period 2 and ``x⁺ = 0.5x`` at phase 1, ``k=1`` gives that phase's
    map (``0.25``) and the monodromy both phases (``0.8·0.25 = 0.2``):

    >>> sys2 = ncs.jss([[[[2.0]], [[0.0]]], [[[0.5]], [[0.5]]]], [[1.0]], [[1.0]],
    ...            [[0.0]], [[0.2, 0.8], [0.5, 0.5]])
    >>> ncs.second_moment_operator(sys2, k=1) @ np.array([1.0])
    array([0.25])
    >>> (ncs.second_moment_operator(sys2) @ np.array([1.0])).round(12)
    array([0.2])
    """
    sys = as_jump(sys)
    if k is not None and (isinstance(k, (bool, np.bool_))
                          or not isinstance(k, (int, np.integer))):
        raise ValueError(f"k: expected an int (a phase) or None, got {k!r}")
    A, p = sys.modes.A, sys.modes.probabilities
    n = A.shape[-1]
    phases = range(sys.period) if k is None else [k % sys.period]
    dtype = np.result_type(A.dtype, float)
    if not sys.modes.is_iid:
        return _markov_operator(sys, phases, dtype)

    def apply(v: np.ndarray) -> np.ndarray:
        Q = np.asarray(v).reshape(n, n)
        for j in phases:
            Q = phase_map(A[j], p[j], Q, False)
        return Q.reshape(-1)

    return LinearOperator((n * n, n * n), matvec=apply, rmatvec=None,
                          dtype=dtype)


def _markov_operator(sys: JumpStateSpace, phases: Any, dtype: Any
                     ) -> LinearOperator:
    A, T = sys.modes.A, sys.modes.transitions()
    M, n = A.shape[1], A.shape[-1]

    def apply(v: np.ndarray) -> np.ndarray:
        Q = np.asarray(v).reshape(M, n, n)
        for k in phases:
            Q = phase_map(A[k], T[k], Q, True)
        return Q.reshape(-1)

    size = M * n * n
    return LinearOperator((size, size), matvec=apply, rmatvec=None,
                          dtype=dtype)


def _dense_monodromy(sys: JumpStateSpace) -> np.ndarray:
    """The monodromy ``𝒯`` as a dense matrix (row-major ``vec``)."""
    markov = not sys.modes.is_iid
    A = sys.modes.A
    W = sys.modes.transitions() if markov else sys.modes.probabilities
    n = A.shape[-1]
    out = np.eye(n * n * (A.shape[1] if markov else 1))
    for k in range(sys.period):
        out = phase_matrix(A[k], W[k], markov) @ out
    return out


def _deterministic_monodromy(sys: JumpStateSpace) -> np.ndarray | None:
    """``Φ = A_{N-1} ⋯ A_0`` of a deterministic system
    (:meth:`JumpStateSpace.deterministic`), else None."""
    mats = sys.deterministic()
    if mats is None:
        return None
    phi = np.eye(sys.nstates)
    for A_k in mats[0]:
        phi = A_k @ phi
    return phi


def ms_radius(sys: Any, *, method: str = "auto", tol: float = 1e-10,
              **kwargs: Any) -> float:
    """Per-step mean-square spectral radius ``ρ(𝒯)^(1/N)``.

    ``E‖ξ_t‖²`` of the unforced system decays (or grows) like this number to
    the power ``t``; the system is mean-square stable exactly when it is
    below 1. For a deterministic system it is ``ρ(A)²``. A periodic system
    is judged over its whole period, never by the average of its phases.
    Markov modes (:ref:`theory-markov`) are judged by the operator on
    ``M``-tuples of second moments, from every initial state and mode.

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time control.StateSpace
    method : {'auto', 'dense', 'matrix-free'}
        ``'auto'``: for a deterministic system (one live mode per phase)
        ``ρ(Φ)^(2/N)`` from the eigenvalues of the ``n × n`` monodromy
        ``Φ`` (exact, since ``𝒯 = Φ ⊗ Φ``); otherwise ``'dense'`` up to
        ``DENSE_MAX_STATES`` states (Markov modes: up to an operator of side
        ``DENSE_MAX_STATES²``, ``M·n²`` unknowns), else ``'matrix-free'``.
    tol : float
        Relative accuracy asked of ARPACK (matrix-free route); a finite
        number > 0.
    **kwargs
        Reserved: any keyword raises ``TypeError`` (unknown keyword).

    Returns
    -------
    float

    Raises
    ------
    TypeError
        Unknown keyword.
    ControlArgument
        Unknown ``method``.
    ValueError
        ``tol`` is not a positive finite number.
    RuntimeError
        If ARPACK does not converge (the message gives its best estimate).

    References
    ----------
    .. [1] O. L. V. Costa, M. D. Fragoso and R. P. Marques, *Discrete-Time
           Markov Jump Linear Systems*, Springer, 2005.

    Examples
    --------
    ``x⁺ = 2x + u``, ``u = -2x`` applied with probability 0.8: ``E x²`` is
    multiplied by ``0.2·4 = 0.8`` per step.

    >>> from control_ncs import jss
    >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> round(ncs.ms_radius(sys), 12)
    0.8

    The same loop losing its control in bursts (mean length 2), with the
    same average loss 0.2: ``E x²`` now grows.

    >>> bursty = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]],
    ...              transition=[[0.5, 0.5], [0.125, 0.875]])
    >>> round(ncs.ms_radius(bursty), 12)
    2.0
    """
    no_extra_kwargs("ms_radius", kwargs)
    sys = as_jump(sys)
    choice(method, "method", ("auto", "dense", "matrix-free"))
    tol = positive_real(tol, "tol")
    n = sys.modes.A.shape[-1]
    markov = not sys.modes.is_iid
    if method == "auto":
        phi = None if markov else _deterministic_monodromy(sys)
        if phi is not None:
            # one live mode per phase: 𝒯 = Φ ⊗ Φ, so ρ(𝒯) = ρ(Φ)² exactly
            rho = float(np.max(np.abs(np.linalg.eigvals(phi)))) ** 2 \
                if n else 0.0
            return rho ** (1.0 / sys.period)
    size = n * n * (sys.nmodes if markov else 1)
    if method == "auto":
        # by the operator's size: a Markov operator acts on M matrices
        method = ("dense" if size <= DENSE_MAX_STATES ** 2
                  else "matrix-free")
    if method == "dense" or size <= 4:
        rho = float(np.max(np.abs(np.linalg.eigvals(_dense_monodromy(sys)))))
    else:
        op = second_moment_operator(sys)
        # A PSD start lies in the cone where the Perron eigenvector lives.
        v0 = np.eye(n).reshape(-1)
        if markov:
            v0 = np.tile(v0, sys.nmodes)
        # 𝒯(I) = Σ p Π Πᵀ over all mode products Π of a period, so it is zero
        # only when every Π is: then 𝒯 = 0 and ARPACK would fail on it.
        if not np.any(op.matvec(v0)):
            return 0.0
        try:
            vals = eigs(op, k=1, which="LM", v0=v0, tol=tol,
                        ncv=min(size - 1, 30), maxiter=5000,
                        return_eigenvectors=False)
        except ArpackNoConvergence as err:
            raise RuntimeError(
                "ms_radius: ARPACK did not converge on the second-moment "
                f"operator (n = {n}); partial estimates {err.eigenvalues}. "
                "Try method='dense' for small n, or a larger tol.") from None
        except ArpackError as err:
            # ARPACK's restart can fail outright on a small operator whose
            # dominant eigenvalues share a modulus (𝒯 = A ⊗ A with a complex
            # pair: λ², λ̄², |λ|²); the dense route is exact and cheap there
            if size <= DENSE_MAX_STATES ** 2:
                return ms_radius(sys, method="dense")
            raise RuntimeError(
                f"ms_radius: ARPACK failed on the second-moment operator "
                f"(n = {n}, {size} unknowns): {err}") from None
        rho = float(np.abs(vals[0]))
    return rho ** (1.0 / sys.period)


def is_mss(sys: Any, **kwargs: Any) -> bool:
    """True when ``sys`` is mean-square stable (``ms_radius < 1``).

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time control.StateSpace
    **kwargs
        ``method`` and ``tol``, passed to :func:`ms_radius`; an unknown
        keyword raises ``TypeError``.

    Returns
    -------
    bool
        ``E‖ξ_t‖² → 0`` for the unforced system from every initial state.

    Raises
    ------
    TypeError, ControlArgument, ValueError, RuntimeError
        As :func:`ms_radius`.

    References
    ----------
    .. [1] O. L. V. Costa, M. D. Fragoso and R. P. Marques, *Discrete-Time
           Markov Jump Linear Systems*, Springer, 2005.

    Examples
    --------
    >>> ncs.is_mss(ct.ss([[0.5]], [[1]], [[1]], [[0]], True))
    True
    >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7])
    >>> ncs.is_mss(sys), round(ncs.ms_radius(sys), 12)     # 0.3·2² = 1.2
    (False, 1.2)
    """
    return ms_radius(sys, **kwargs) < 1.0


# -- the forced second moment: the H2 norm ------------------------------------
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
        If ``sys`` is not mean-square stable (no steady state), or GMRES
        does not reach ``tol``.

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
    if not ms_radius(sys) < 1.0:
        raise ValueError("sys: not mean-square stable (ms_radius >= 1): the "
                         "noise-driven second moment has no steady state")
    return _stationary(sys, method, tol)


def _stationary(sys: JumpStateSpace, method: str, tol: float) -> np.ndarray:
    """:func:`stationary_covariances` of a mean-square stable system."""
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
    if method == "auto":
        method = "dense" if size <= DENSE_MAX_STATES ** 2 else "matrix-free"
    if method == "dense":
        q = np.linalg.solve(np.eye(size) - _dense_monodromy(sys), F.ravel())
    else:
        op = second_moment_operator(sys)
        lhs = LinearOperator((size, size), dtype=float,
                             matvec=lambda v: v - op.matvec(v))
        q, info = gmres(lhs, F.ravel(), rtol=tol, atol=0.0, restart=50,
                        maxiter=200)
        if info != 0:
            raise ValueError(f"sys: GMRES did not reach tol={tol:g} on the "
                             f"stationary second moment ({size} unknowns)")
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
    when ``sys`` is not mean-square stable.
    """
    sys = as_jump(sys)
    choice(method, "method", ("auto", "dense", "matrix-free"))
    tol = positive_real(tol, "tol")
    if not ms_radius(sys) < 1.0:
        return float("inf")
    Q = _stationary(sys, method, tol)
    m = sys.modes
    total = 0.0
    for k in range(sys.period):
        p = m.probabilities[k]
        Qk = Q[k] if not m.is_iid else p[:, None, None] * Q[k][None]
        CQC = np.einsum("mab,mbc,mac->m", m.C[k], Qk, m.C[k])
        DD = np.einsum("mab,mab->m", m.D[k], m.D[k])
        total += float(CQC.sum() + p @ DD)
    return total / sys.period
