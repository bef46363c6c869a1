"""Exact mean-square stability (:ref:`theory-mss`).

The second moment ``Q = E ξξᵀ`` of the unforced system evolves by
``Q⁺ = 𝒯_k(Q) = Σ_i p_ki A_ki Q A_kiᵀ``. Over one period this is the
monodromy operator ``𝒯 = 𝒯_{N-1} ∘ … ∘ 𝒯_0``; the system is mean-square
stable exactly when its spectral radius is below one. It is computed with
a certified bracket (:class:`RadiusBracket`): an eigenvalue estimate, then
linear solves of the resolvent ``(μ - 𝒯)X = I`` just above and below it
whose signs prove on which side of ``μ`` the radius lies
(:mod:`control_ncs._perron`). Three routes give the estimate and the
solves:

* ``'deterministic'`` (one live mode per phase): ``𝒯 = Φ ⊗ Φ`` for the
  ``n × n`` monodromy ``Φ``, its eigenvalues and Stein equations;
* ``'dense'``: the ``n² × n²`` Kronecker matrix ``Σ p (A ⊗ A)`` per phase,
  multiplied over the period, its eigenvalues and LU (memory ``O(n⁴)``);
* ``'matrix-free'``: ``𝒯`` applied by matrix products
  (``O(N·M·n³)`` per application), ARPACK (:func:`scipy.sparse.linalg.eigs`)
  for the two leading eigenvalues, GMRES preconditioned by the Stein
  equation of the mean dynamics for the solves.

Every probe is checked with the map applied by matrix products, never with
the matrix a solver used. Markov modes (:ref:`theory-markov`) carry the
second moment per mode, ``Q_i = E[ξξᵀ 1{σ = i}]``, and
``Q⁺_j = Σ_i T_k[i, j] A_ki Q_i A_kiᵀ``: the same routes on ``M``-tuples
(Kronecker size ``M·n²``). i.i.d. modes use the ``n²`` operator above, so
their numbers do not change.
"""

from __future__ import annotations

import math
import warnings
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any, Callable, ClassVar, Iterator, Literal, overload

import numpy as np
from scipy.linalg import LinAlgWarning, lu_factor, lu_solve, matrix_balance
from scipy.sparse.linalg import (ArpackError, ArpackNoConvergence,
                                  LinearOperator, eigs, gmres)

from ._blas import serial_blas
from ._checks import choice, no_extra_kwargs, positive_real
from ._perron import certify, power_estimate
from ._results import Result
from ._stein import Stein
from .exceptions import CERTIFIED, NOT_MSS, NOT_VERIFIED, CertificationError
from .jump import JumpStateSpace, as_jump

__all__ = ["ms_radius", "is_mss", "RadiusBracket", "second_moment_operator"]

_EPS = float(np.finfo(float).eps)

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
        Y = _sandwich(A, Q)                              # (M, n, n)
        return np.tensordot(weights.T, Y, axes=1)        # Σ_i T[i, j] Y_i
    live = weights > 0
    Al = A if live.all() else A[live]
    Y = _sandwich(Al, Q)
    # Σ_i w_i Y_i as one product (tensordot's reshaping costs as much at
    # n ≈ 60)
    return np.dot(weights[live], Y.reshape(len(Y), -1)).reshape(Y.shape[1:])


def _sandwich(A: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """``A_i Q_i A_iᵀ`` for a stack of ``A_i`` (and of ``Q_i``, or one
    ``Q``)."""
    if A.dtype == np.float64 or A.dtype == np.complex128:
        # batched products (BLAS); einsum's path search cost more than the
        # products themselves below n ≈ 40
        return A @ Q @ A.transpose(0, 2, 1)
    # extended precision has no BLAS: numpy's dot loops faster than its
    # batched matmul (1.7× at n = 60)
    Qs = Q if Q.ndim == 3 else [Q] * len(A)
    return np.array([np.dot(np.dot(a, q), a.T) for a, q in zip(A, Qs)])


def phase_adjoint(A: np.ndarray, weights: np.ndarray, V: np.ndarray,
                  markov: bool) -> np.ndarray:
    """The adjoint of :func:`phase_map` (trace inner product):
    ``Σ_i p_i A_iᵀ V A_i``, or per mode ``A_iᵀ (Σ_j T_k[i, j] V_j) A_i``."""
    if markov:
        W = np.tensordot(weights, V, axes=1)             # Σ_j T[i, j] V_j
        return A.transpose(0, 2, 1) @ W @ A
    Y = A.transpose(0, 2, 1) @ V @ A
    return np.tensordot(weights, Y, axes=1)


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
    >>> ncs.stability.second_moment_operator(sys).matvec(np.array([1.0])).round(12).tolist()
    [0.8]

    With period 2 and ``x⁺ = 0.5x`` at phase 1, ``k=1`` gives that phase's
    map (``0.25``) and the monodromy both phases (``0.8·0.25 = 0.2``):

    >>> sys2 = ncs.jss([[[[2.0]], [[0.0]]], [[[0.5]], [[0.5]]]], [[1.0]], [[1.0]],
    ...            [[0.0]], [[0.2, 0.8], [0.5, 0.5]])
    >>> ncs.stability.second_moment_operator(sys2, k=1) @ np.array([1.0])
    array([0.25])
    >>> (ncs.stability.second_moment_operator(sys2) @ np.array([1.0])).round(12)
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


def dense_monodromy(sys: JumpStateSpace) -> np.ndarray:
    """The monodromy ``𝒯`` as a dense matrix (row-major ``vec``)."""
    markov = not sys.modes.is_iid
    W = sys.modes.transitions() if markov else sys.modes.probabilities
    return monodromy_matrix(sys.modes.A, W, markov)


def monodromy_matrix(A: np.ndarray, weights: np.ndarray,
                     markov: bool) -> np.ndarray:
    """The period's second-moment map ``𝒯_{N-1} ⋯ 𝒯_0`` (:func:`phase_map`
    per phase, ``A`` of shape (N, M, n, n), ``weights`` the laws ``p_k``
    or ``T_k``) as a dense matrix on the row-major ``vec`` (the stack of
    the ``M`` moments for Markov modes): the period applied to every unit
    matrix at once, batched ``n × n`` products (``2 M N n⁵`` flops against
    ``N n⁶`` for the product of the phases' Kronecker matrices)."""
    N, M, n = A.shape[0], A.shape[1], A.shape[-1]
    shape = (M, n, n) if markov else (n, n)
    size = int(np.prod(shape))
    X = np.eye(size, dtype=np.result_type(A, float)).reshape(
        (size,) + shape)
    for k in range(N):
        if markov:
            Y = A[k] @ X @ A[k].transpose(0, 2, 1)        # (size, M, n, n)
            X = np.einsum("ij,sinm->sjnm", weights[k], Y)
        else:
            out = np.zeros_like(X)
            for i in np.flatnonzero(weights[k] > 0):
                out += weights[k][i] * (A[k, i] @ X @ A[k, i].T)
            X = out
    return X.reshape(size, size).T


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


# -- the certified radius (theory: mean-square stability) ---------------------
#: Below this multiple of the operator's norm bound the radius counts as
#: zero for the bracket's width (a relative width means nothing at 0).
RADIUS_ATOL = 1e-14

#: GMRES on the preconditioned resolvent (matrix-free probes): Krylov
#: dimension per cycle and cycles at most.
GMRES_RESTART = 60
GMRES_CYCLES = 5


@dataclass(frozen=True, repr=False, eq=False)
class RadiusBracket(Result):
    """The mean-square radius with a certified bracket around it.

    ``lower ≤ ms_radius < upper`` is proven (:ref:`theory-mss`): the upper
    end by a positive definite ``X`` with ``𝒯(X) ≺ upper^N X``
    (Collatz–Wielandt for the PSD cone), the lower end by a solution of
    ``(μ - 𝒯)X = F``, ``F ⪰ 0``, that is not PSD (``μ = lower^N``; the
    resolvent of a cone-preserving map is positive above its radius).

    Attributes
    ----------
    radius : float
        The point value :func:`ms_radius` returns, inside the bracket.
    lower, upper : float
        The certified ends, per step (``ρ(𝒯)^(1/N)``).
    route : str
        ``'deterministic'``, ``'dense'``, ``'matrix-free'`` or ``'zero'``
        (the monodromy maps ``I`` to exactly 0, so ``𝒯 = 0``).
    certificate : ndarray or None
        ``X ≻ 0`` proving the upper end, (n, n) or (M, n, n) (Markov
        modes); None when no upper end was proven (``upper = inf``) or
        ``route = 'zero'``.
    probes : int
        Linear solves spent on the bracket.

    Examples
    --------
    >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> res = ncs.ms_radius(sys, bracket=True)
    >>> res.status, bool(res.lower <= 0.8 < res.upper), res.width < 1e-11
    ('certified', True, True)
    """

    radius: float
    lower: float
    upper: float
    route: str
    certificate: np.ndarray | None
    probes: int

    _repr_fields: ClassVar[tuple[str, ...]] = ("radius", "lower", "upper")

    @property
    def width(self) -> float:
        """``(upper - lower) / upper`` (0 when both are 0)."""
        return 0.0 if self.upper == 0 else \
            (self.upper - self.lower) / self.upper

    def below(self, bound: float) -> bool | None:
        """Whether the radius is below ``bound``, as the bracket proves it.

        Parameters
        ----------
        bound : float

        Returns
        -------
        bool or None
            True if ``upper ≤ bound`` (``ρ < upper``), False if
            ``lower ≥ bound``, None when the bracket straddles ``bound``.
        """
        if self.upper <= bound:
            return True
        if self.lower >= bound:
            return False
        return None

    @property
    def stable(self) -> bool | None:
        """Mean-square stable (True), proven not (False), or undecided.

        :meth:`below` 1.
        """
        return self.below(1.0)

    @property
    def success(self) -> bool:
        """True when proven mean-square stable."""
        return self.stable is True

    @property
    def status(self) -> str:
        """The verdict in the words of the reason registry.

        ``'certified'`` (stable), ``'not_mss'`` (proven unstable) or
        ``'not_verified'`` (the bracket contains 1).
        """
        return {True: CERTIFIED, False: NOT_MSS, None: NOT_VERIFIED}[
            self.stable]

    @property
    def message(self) -> str:
        """The verdict and the bracket in words."""
        verdict = {True: "mean-square stable",
                   False: "not mean-square stable",
                   None: "undecided: the bracket contains 1"}[self.stable]
        return (f"{verdict}: ms_radius in [{self.lower:.12g}, "
                f"{self.upper:.12g}) (relative width {self.width:.1e})")

    def _details(self) -> list[str]:
        return [f"route {self.route}, {self.probes} probes"]


def _identity(sys: JumpStateSpace) -> np.ndarray:
    """``I`` per component: (1, n, n), or (M, n, n) for Markov modes."""
    n = sys.modes.A.shape[-1]
    count = 1 if sys.modes.is_iid else sys.nmodes
    return np.broadcast_to(np.eye(n), (count, n, n)).copy()


#: Up to this many states the probes' residual ``μX - 𝒯(X)`` is formed in
#: extended precision (``numpy.longdouble``, where it is wider than double):
#: the width of the bracket is set by the rounding of that residual.
EXTENDED_MAX_STATES = 64


class _TupleMap:
    """The monodromy on (L, n, n) stacks by matrix products: the map every
    probe checks with, and a bound on its rounding.

    Rounding (first order): phase ``k`` computes ``Σ_i w_i A_i Q_k A_iᵀ``
    with an error of Frobenius norm at most
    ``γ Σ_i w_i ‖A_i‖_F² ‖Q_k‖_F`` (``γ = 2(n + M)·u``, ``u`` the unit
    roundoff: two products of length ``n``, a sum over the modes); the
    later phases carry it with norm ``‖tail_k(I)‖₂`` (a positive map's
    norm is its value at ``I``, Russo–Dye), computed once here.
    """

    def __init__(self, sys: JumpStateSpace):
        self.markov = not sys.modes.is_iid
        self.A, self.N = sys.modes.A, sys.period
        self.W = (sys.modes.transitions() if self.markov
                  else sys.modes.probabilities)
        n, M = self.A.shape[-1], self.A.shape[1]
        self.fro = np.sum(self.A ** 2, axis=(-2, -1))        # ‖A_ki‖_F²
        wide = np.finfo(np.longdouble).eps < _EPS and \
            n <= EXTENDED_MAX_STATES
        self.dtype = np.longdouble if wide else np.float64
        self.unit = float(np.finfo(self.dtype).eps)
        self.gamma = 2 * (n + M) * self.unit
        self.A_wide = self.A.astype(self.dtype)
        self.W_wide = self.W.astype(self.dtype)
        E = _identity(sys)
        self.tails = [self._norm(self._run(E, k + 1))
                      for k in range(self.N)]
        #: ‖𝒯(I)‖₂ = ‖𝒯‖ (Russo–Dye): the scale of the radius
        self.norm = self._norm(self._run(E, 0))

    @staticmethod
    def _norm(X: np.ndarray) -> float:
        """Largest spectral norm of a stack of PSD matrices."""
        return float(np.linalg.eigvalsh(0.5 * (X + X.swapaxes(-1, -2)))
                     .max(initial=0.0))

    def _phase(self, k: int, Q: np.ndarray, A: np.ndarray | None = None,
               W: np.ndarray | None = None) -> np.ndarray:
        A = self.A[k] if A is None else A
        W = self.W[k] if W is None else W
        if self.markov:
            return phase_map(A, W, Q, True)
        return phase_map(A, W, Q[0], False)[None]

    def _run(self, X: np.ndarray, first: int) -> np.ndarray:
        for k in range(first, self.N):
            X = self._phase(k, X)
        return X

    def __call__(self, X: np.ndarray) -> np.ndarray:
        """``𝒯(X)``."""
        return self._run(X, 0)

    def _local(self, k: int, Q: np.ndarray) -> float:
        """The rounding of phase ``k`` on ``Q`` per unit of ``γ``, carried
        to the end of the period: ``‖tail_k‖ Σ_i w_i ‖A_i‖_F² ‖Q_i‖_F``
        (per next mode for Markov modes)."""
        size = np.sqrt(np.sum(np.asarray(Q, float) ** 2,
                              axis=(-2, -1)))              # ‖Q_k,i‖_F
        if self.markov:     # per next mode j: Σ_i T[i, j] ‖A_i‖² ‖Q_i‖
            local = self.W[k].T @ (self.fro[k] * size)
        else:
            local = (self.W[k] @ self.fro[k]) * size
        return self.tails[k] * float(local.max())

    def predicted_error(self, X: np.ndarray, wide: bool = False) -> float:
        """The rounding bound of ``𝒯(X)`` that :meth:`residual` would
        carry, from the map applied in double precision: a prediction (for
        placing probes), not a proof."""
        unit = float(np.finfo(self.dtype if wide else np.float64).eps)
        gamma = self.gamma / self.unit * unit
        err, Q = 0.0, X
        for k in range(self.N):
            err += gamma * self._local(k, Q)
            Q = self._phase(k, Q)
        # the subtraction's rounding and the final rounding to double, as
        # in residual at μ = 0 (the second dominates in extended precision)
        scale = float(np.sqrt(np.sum(Q ** 2, axis=(-2, -1))).max())
        return err + 2 * unit * scale + \
            _EPS * float(np.abs(Q).sum(axis=-1).max())

    def residual(self, X: np.ndarray, mu: float, wide: bool = False
                 ) -> tuple[np.ndarray, float]:
        """``F = μX - 𝒯(X)`` (double) and a bound on the spectral norm of
        its error: the products' rounding, the subtraction's and the final
        rounding to double; in extended precision when ``wide`` (and
        ``n ≤ EXTENDED_MAX_STATES``)."""
        dtype = self.dtype if wide else np.float64
        unit = float(np.finfo(dtype).eps)
        gamma = self.gamma / self.unit * unit
        A = self.A_wide if wide else self.A
        W = self.W_wide if wide else self.W
        err = 0.0
        Q = X.astype(dtype)
        for k in range(self.N):
            err += gamma * self._local(k, Q)
            Q = self._phase(k, Q, A[k], W[k])
        exact = dtype(mu) * X.astype(dtype) - Q
        scale = mu * float(np.sqrt(np.sum(X ** 2, axis=(-2, -1))).max()) + \
            float(np.sqrt(np.sum(np.asarray(Q, float) ** 2,
                                 axis=(-2, -1))).max())
        F = np.asarray(exact, float)
        err += 2 * unit * scale + _EPS * float(np.abs(F).sum(axis=-1).max())
        return F, err


def _splitting(sys: JumpStateSpace) -> list[np.ndarray]:
    """Per component ``Ψ_j`` with ``𝒯(X)_j ⪰ Ψ_j X_j Ψ_jᵀ`` for every PSD
    tuple (a regular splitting ``μ - 𝒯 = S - V``, ``S_j = μ - Ψ_j·Ψ_jᵀ``).

    i.i.d. modes: the mean monodromy ``Φ̄ = Π_k Σ_i p_ki A_ki``
    (``E[ΠXΠᵀ] ⪰ E[Π] X E[Π]ᵀ``). Markov modes: over the paths from mode
    ``j`` back to ``j`` in one period, weights ``w`` (summing to ``c_j``)
    and products ``Π``, ``Σ w ΠXΠᵀ ⪰ (Σ wΠ) X (Σ wΠ)ᵀ / c_j``; ``Ψ_j`` is
    ``(Σ wΠ)/√c_j``, zero when the chain cannot return.
    """
    A, N = sys.modes.A, sys.period
    n = A.shape[-1]
    if sys.modes.is_iid:
        p = sys.modes.probabilities
        Phi = np.eye(n)
        for k in range(N):
            Phi = np.tensordot(p[k], A[k], axes=1) @ Phi
        return [Phi]
    T = sys.modes.transitions()
    M = A.shape[1]
    G = np.eye(M * n)
    back = np.eye(M)
    for k in range(N):
        # block (j, i) = T_k[i, j] A_ki: the mean of ξ 1{σ = j} one step on
        Gk = (T[k].T[:, :, None, None] * A[k][None]).transpose(0, 2, 1, 3)
        G = Gk.reshape(M * n, M * n) @ G
        back = back @ T[k]
    out = []
    for j in range(M):
        c = back[j, j]
        block = G[j * n:(j + 1) * n, j * n:(j + 1) * n]
        out.append(block / math.sqrt(c) if c > 0 else np.zeros((n, n)))
    return out


def _gmres_solver(sys: JumpStateSpace, apply: Callable[[np.ndarray],
                                                       np.ndarray]
                  ) -> Callable[[float], np.ndarray]:
    """``μ ↦ X ≈ (μ - 𝒯)⁻¹ I`` by GMRES on ``S⁻¹(μ - 𝒯)`` with the
    regular splitting of :func:`_splitting` (its Stein solves are the
    preconditioner; the rest of ``𝒯`` is what loss, or switching, adds)."""
    E = _identity(sys)
    shape, size = E.shape, E.size
    split = _splitting(sys)
    stretch = max(float(np.linalg.norm(P, 2)) ** 2 for P in split)
    steins = [Stein(P) for P in split]

    def solve(mu: float) -> np.ndarray:
        def S_inv(F: np.ndarray) -> np.ndarray:
            return np.array([stein(mu, Fj) for stein, Fj in zip(steins, F)])

        def matvec(v: np.ndarray) -> np.ndarray:
            X = v.reshape(shape)
            return S_inv(mu * X - apply(X)).ravel()

        op = LinearOperator((size, size), matvec=matvec, dtype=float)
        # enough for a probe: ‖E - (μ - 𝒯)X‖₂ ≤ ‖S‖·‖S⁻¹ residual‖ ≤ 0.1
        x, _ = gmres(op, S_inv(E).ravel(), rtol=0.0,
                     atol=0.1 / (mu + stretch), restart=GMRES_RESTART,
                     maxiter=GMRES_CYCLES)
        return x.reshape(shape)

    return solve


def _dense_solver(sys: JumpStateSpace) -> tuple[
        Callable[[float, np.ndarray], np.ndarray], float]:
    """``(μ, F) ↦ (μ - 𝒯)⁻¹ F`` by LU of the Kronecker monodromy (one
    factorisation per ``μ``), and the largest modulus of its eigenvalues
    (the estimate)."""
    T = dense_monodromy(sys)
    est = float(np.max(np.abs(np.linalg.eigvals(T))))
    factors: dict[float, Any] = {}

    def solve(mu: float, F: np.ndarray) -> np.ndarray:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", LinAlgWarning)
            try:
                if mu not in factors:
                    factors.clear()
                    factors[mu] = lu_factor(mu * np.eye(T.shape[0]) - T)
                x = lu_solve(factors[mu], F.ravel())
            except (np.linalg.LinAlgError, ValueError):
                return np.full_like(F, np.nan)
        return x.reshape(F.shape)

    return solve, est


def _refinement(solve: Callable[[float, np.ndarray], np.ndarray],
                apply: _TupleMap, E: np.ndarray
                ) -> Callable[[float, np.ndarray], np.ndarray]:
    """``(μ, X) ↦ X + (μ - 𝒯)⁻¹(I - F)``: one step of iterative
    refinement, the residual ``F`` formed as the probes form it (extended
    precision); near the radius ``X`` is huge and a plain solve's residual
    is what decides."""
    def refine(mu: float, X: np.ndarray) -> np.ndarray:
        F, _ = apply.residual(X, mu, True)
        return X + solve(mu, E - F)
    return refine


def _arpack_estimate(sys: JumpStateSpace, apply: Callable[[np.ndarray],
                                                          np.ndarray],
                     tol: float) -> float:
    """ARPACK's leading Ritz value, or a power estimate if ARPACK fails;
    the probes correct either.

    The radius of this positive map is a real positive eigenvalue of
    largest modulus: a leading Ritz value that is complex or negative
    means ARPACK found another eigenvalue first (of that modulus or, when
    the top ones are close, below it), so three are asked for then.
    """
    E = _identity(sys)
    size = E.size
    op = LinearOperator((size, size), dtype=float,
                        matvec=lambda v: apply(v.reshape(E.shape)).ravel())
    vals = np.zeros(0)
    for k in (1, 3):
        k = min(k, size - 2)
        try:
            vals = eigs(op, k=k, which="LM", v0=E.ravel(), tol=tol,
                        ncv=min(size - 1, max(2 * k + 1, 30)),
                        maxiter=5000, return_eigenvectors=False)
        except ArpackNoConvergence as err:
            vals = err.eigenvalues
        except ArpackError:
            vals = np.zeros(0)
        top = vals[np.argmax(np.abs(vals))] if len(vals) else None
        if top is not None and top.real > 0 and \
                abs(top.imag) <= 1e-8 * abs(top):
            break
    if len(vals):
        return float(np.max(np.abs(vals)))
    return power_estimate(apply, E)


def _bracket(sys: JumpStateSpace, method: str, tol: float) -> RadiusBracket:
    """:func:`ms_radius` with ``bracket=True``, on checked arguments.

    A bracket rounding leaves wide (a badly scaled state: entries of
    ``1e5`` beside ``1e-7``) is computed again in the coordinates
    ``ξ = diag(t) ξ̃`` that balance ``Σ |A|`` (powers of two: exact both
    ways, the same radius); its certificate is mapped back,
    ``X = diag(t) X̃ diag(t)``."""
    first = _bracket_once(sys, method, tol)
    if first.width <= _BALANCE_WIDTH:
        return first
    t = _balancing(sys)
    if t is None:
        return first
    A, B, C = sys.modes.A, sys.modes.B, sys.modes.C
    modes = sys.modes
    law: dict = (dict(transition=modes.transition) if not modes.is_iid else {})
    scaled = JumpStateSpace(A * t[None, :] / t[:, None], B / t[:, None],
                            C * t[None, :], modes.D,
                            None if law else modes.probabilities, sys.dt,
                            **law)
    again = _bracket_once(scaled, method, tol)
    if again.width >= first.width:
        return first
    X = again.certificate
    if X is not None:
        X = X * t[:, None] * t[None, :]
    return RadiusBracket(again.radius, again.lower, again.upper, again.route,
                         X, first.probes + again.probes)


#: Relative bracket width beyond which :func:`_bracket` balances the state.
_BALANCE_WIDTH = 1e-3


def _balancing(sys: JumpStateSpace) -> np.ndarray | None:
    """The state scaling of :func:`scipy.linalg.matrix_balance` on
    ``Σ |A_ki|`` (powers of two), or None when it is the identity."""
    W = np.abs(sys.modes.A).sum(axis=(0, 1))
    _, (t, _) = matrix_balance(W, permute=False, separate=True)
    return None if np.all(t == 1.0) else np.asarray(t, float)


def _bracket_once(sys: JumpStateSpace, method: str, tol: float
                  ) -> RadiusBracket:
    """:func:`_bracket` in the given coordinates."""
    n, N = sys.modes.A.shape[-1], sys.period
    markov = not sys.modes.is_iid
    if n == 0:
        return RadiusBracket(0.0, 0.0, 0.0, "zero", None, 0)
    apply = _TupleMap(sys)
    E = _identity(sys)
    if apply.norm == 0.0:
        # 𝒯(I) = Σ w ΠΠᵀ over the products Π of a period: 0 only if every
        # Π is, and then 𝒯 = 0
        return RadiusBracket(0.0, 0.0, 0.0, "zero", None, 0)
    phi = None if markov or method != "auto" else \
        _deterministic_monodromy(sys)
    size = E.size
    solve: Callable[[float], np.ndarray]
    direct: Callable[[float, np.ndarray], np.ndarray]
    if phi is not None:
        route = "deterministic"
        est = float(np.max(np.abs(np.linalg.eigvals(phi)))) ** 2
        solver = Stein(phi)

        def stein(mu: float, F: np.ndarray) -> np.ndarray:
            return solver(mu, F[0])[None]
        direct = stein
    elif method == "dense" or (method == "auto" and
                               size <= DENSE_MAX_STATES ** 2) or size <= 4:
        route = "dense"
        direct, est = _dense_solver(sys)
    else:
        route = "matrix-free"
        est = _arpack_estimate(sys, apply, tol)
        solve = _gmres_solver(sys, apply)
    refine = None
    if route != "matrix-free":
        refine = _refinement(direct, apply, E)

        def solve(mu: float) -> np.ndarray:
            return direct(mu, E)
    # the rounding bound per unit of X, at X = I: a probe at μ = ρ(1 ± s)
    # has ‖X‖ ≈ ‖I‖/(sρ), so it decides once s ≳ 2·err(I)/ρ
    err = apply.predicted_error(E, True)
    b = certify(apply.residual, solve, est, refine=refine,
                atol=RADIUS_ATOL * apply.norm,
                first_step=min(2 * err / max(est, 1e-300), 1e-3))
    X = None if b.upper_X is None else (
        b.upper_X if markov else b.upper_X[0])
    root = 1.0 / N
    return RadiusBracket(b.estimate ** root, b.lower ** root,
                         b.upper ** root, route, X, b.probes)


@overload
def ms_radius(sys: Any, *, method: str = ..., tol: float = ...,
              bracket: Literal[False] = ..., **kwargs: Any) -> float: ...


@overload
def ms_radius(sys: Any, *, method: str = ..., tol: float = ...,
              bracket: Literal[True], **kwargs: Any) -> RadiusBracket: ...


@overload
def ms_radius(sys: Any, *, method: str = ..., tol: float = ...,
              bracket: bool, **kwargs: Any) -> float | RadiusBracket: ...


def ms_radius(sys: Any, *, method: str = "auto", tol: float = 1e-8,
              bracket: bool = False, **kwargs: Any
              ) -> float | RadiusBracket:
    """Per-step mean-square spectral radius ``ρ(𝒯)^(1/N)``.

    ``E‖ξ_t‖²`` of the unforced system decays (or grows) like this number to
    the power ``t``; the system is mean-square stable exactly when it is
    below 1. For a deterministic system it is ``ρ(A)²``. A periodic system
    is judged over its whole period, never by the average of its phases.
    Markov modes (:ref:`theory-markov`) are judged by the operator on
    ``M``-tuples of second moments, from every initial state and mode.

    The number is certified: an eigenvalue estimate (dense, or ARPACK's
    leading Ritz values) is bracketed by linear solves of the resolvent
    ``(μ - 𝒯)X = I`` just above and below it, each checked with the exact
    map: a positive definite ``X`` proves ``ρ < μ`` (Collatz–Wielandt), a
    solution that is not PSD proves ``ρ ≥ μ``. A probe that contradicts the
    estimate moves it, so an eigensolver that stops on the wrong eigenvalue
    cannot pass. The bracket is ~1e-12 wide relative unless the solves
    are too ill-conditioned (then its width says so).

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time control.StateSpace
    method : {'auto', 'dense', 'matrix-free'}
        ``'auto'``: for a deterministic system (one live mode per phase)
        from the ``n × n`` monodromy ``Φ`` (``𝒯 = Φ ⊗ Φ``: its eigenvalues,
        and Stein equations for the probes); otherwise ``'dense'`` up to
        ``DENSE_MAX_STATES`` states (Markov modes: up to an operator of side
        ``DENSE_MAX_STATES²``, ``M·n²`` unknowns), else ``'matrix-free'``
        (ARPACK for the estimate, GMRES preconditioned by the Stein
        equation of the mean dynamics for the probes).
    tol : float
        Relative accuracy asked of ARPACK (matrix-free route); a finite
        number > 0.
    bracket : bool
        Return the :class:`RadiusBracket` (the point value, the certified
        ends and the stability verdict they prove) instead of the float.
    **kwargs
        Reserved: any keyword raises ``TypeError`` (unknown keyword).

    Returns
    -------
    float or RadiusBracket
        The float lies in the certified bracket.

    Raises
    ------
    TypeError
        Unknown keyword.
    ControlArgument
        Unknown ``method``.
    ValueError
        ``tol`` is not a positive finite number, or ``bracket`` not a bool.

    References
    ----------
    .. [1] O. L. V. Costa, M. D. Fragoso and R. P. Marques, *Discrete-Time
           Markov Jump Linear Systems*, Springer, 2005.
    .. [2] A. Berman and R. J. Plemmons, *Nonnegative Matrices in the
           Mathematical Sciences*, SIAM, 1994 (cones, Collatz–Wielandt).

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
    >>> ncs.ms_radius(bursty, bracket=True).status
    'not_mss'
    """
    no_extra_kwargs("ms_radius", kwargs)
    sys = as_jump(sys)
    choice(method, "method", ("auto", "dense", "matrix-free"))
    tol = positive_real(tol, "tol")
    if not isinstance(bracket, (bool, np.bool_)):
        raise ValueError(f"bracket: expected True or False, got {bracket!r}")
    res = _measured(sys, method, tol)
    return res if bracket else res.radius


def _measured(sys: JumpStateSpace, method: str, tol: float
              ) -> RadiusBracket:
    """The certified bracket of ``sys``; inside :func:`radius_memo`,
    computed once per loop (its modes are read-only)."""
    memo = _MEMO.get()
    key = (id(sys.modes), method, float(tol))
    if memo is not None and key in memo and memo[key][0] is sys.modes:
        return memo[key][1]
    with serial_blas(kernel_side(sys, method)):
        res = _bracket(sys, method, tol)
    if memo is not None:
        memo[key] = (sys.modes, res)
    return res


#: The brackets of the loops measured inside :func:`radius_memo`, by the
#: identity of their (read-only) modes; None outside.
_MEMO: ContextVar[dict | None] = ContextVar("ms_radius_memo", default=None)


@contextmanager
def radius_memo() -> Iterator[None]:
    """Within the block, :func:`ms_radius` of one loop is computed once.

    A passivity certificate measures its loop twice (the necessary
    condition before the solve, the exact check after it); the second
    reads the first. Outside the block every call computes (timings of
    ``ms_radius`` stay what they say). Nested blocks share the outer memo.
    """
    if _MEMO.get() is not None:
        yield
        return
    token = _MEMO.set({})
    try:
        yield
    finally:
        _MEMO.reset(token)


def kernel_side(sys: JumpStateSpace, method: str) -> int:
    """The side of the largest matrix the kernel factors or multiplies:
    the Kronecker operator's (``M·n²``) on the dense route, else ``n``
    (what :func:`control_ncs._blas.serial_blas` decides by)."""
    n = sys.modes.A.shape[-1]
    size = n * n * (1 if sys.modes.is_iid else sys.nmodes)
    dense = method == "dense" or (method == "auto" and
                                  size <= DENSE_MAX_STATES ** 2)
    return size if dense and sys.deterministic() is None else n


def is_mss(sys: Any, **kwargs: Any) -> bool:
    """True when ``sys`` is proven mean-square stable.

    Decided by the certified bracket of :func:`ms_radius`: True when its
    upper end is at most 1, False when its lower end is at least 1. A
    bracket that contains 1 (a radius within ~1e-12 of 1) decides nothing
    and raises.

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
    TypeError, ControlArgument, ValueError
        As :func:`ms_radius`.
    CertificationError
        ``'not_verified'``: the certified bracket contains 1 (its
        ``figures`` give the ends).

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
    if "bracket" in kwargs:
        raise TypeError("is_mss() got an unexpected keyword argument "
                        "'bracket'")
    res = ms_radius(sys, bracket=True, **kwargs)
    if res.stable is None:
        raise CertificationError(
            f"is_mss: undecided, {res.message}", NOT_VERIFIED,
            dict(lower=res.lower, upper=res.upper, radius=res.radius))
    return res.stable
