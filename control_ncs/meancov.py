"""Exact first and second moments of a jump system (:ref:`theory-moments`), no
sampling."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Any

import numpy as np
import control as ct
from control.exception import ControlDimension

from ._blas import serial_blas
from ._checks import matrix, no_extra_kwargs, real_array
from .jump import as_jump

__all__ = ["moments", "MomentsResponse"]


def real_values(value: Any, name: str, ndim: Any = None) -> np.ndarray:
    """:func:`real_array` that also refuses complex values.

    numpy casts a complex array to float by dropping the imaginary part
    (with only a warning); a signal or state given as complex is a mistake
    to report, not to truncate.
    """
    try:
        is_complex = np.iscomplexobj(value)
    except Exception:          # not array-like: real_array names the problem
        is_complex = False
    if is_complex:
        raise ValueError(f"{name}: expected real numbers, got complex values")
    return real_array(value, name, ndim=ndim)


def time_grid(sys: Any, timepts: Any) -> np.ndarray:
    """The time points of a run: ``0, dt, 2·dt, …``.

    ``timepts`` is a number of steps (an int ``>= 1``, or a float equal to
    one) or the times themselves, which must start at 0 and be spaced by
    ``dt`` (1 when ``sys.dt`` is True): step ``j`` runs phase ``j mod N``,
    so a grid starting elsewhere would silently shift the phases. Every
    time-domain function of the package (:func:`moments`,
    :func:`control_ncs.simulate` and the ensemble responses) reads its
    times here.
    """
    dt = 1.0 if sys.dt_step is True else float(sys.dt_step)
    if np.ndim(timepts) == 0:
        return _count_grid(timepts, dt)
    t = real_values(timepts, "timepts", ndim=1)
    if t.size < 1:
        raise ValueError("timepts: needs at least one time")
    if t[0] != 0:
        # step j runs phase j mod N: a grid starting elsewhere would
        # silently assign the wrong phases
        raise ValueError(f"timepts: times must start at 0, got {t[0]!r}")
    if not np.allclose(t, t[0] + np.arange(t.size) * dt, rtol=0,
                       atol=1e-9 * max(1.0, abs(t[-1]))):
        raise ValueError(f"timepts: a discrete-time system needs equally spaced "
                         f"times with spacing dt = {dt}")
    return t


def _count_grid(timepts: Any, dt: float) -> np.ndarray:
    bad = ValueError(f"timepts: expected a number of steps >= 1 or an array "
                     f"of times, got {timepts!r}")
    if isinstance(timepts, np.ndarray):          # 0-d array
        timepts = timepts.item()
    if isinstance(timepts, (bool, np.bool_)) or not isinstance(
            timepts, numbers.Real):
        raise bad
    if isinstance(timepts, numbers.Integral):
        steps = int(timepts)
    else:
        # every numbers.Real has __floor__ (math.floor is exact for
        # Fraction); typeshed's Real declares no __int__ for int()
        whole = math.floor(timepts) if math.isfinite(timepts) else None
        if whole is None or timepts != whole:
            raise bad
        steps = int(whole)
    if steps < 1:
        raise bad
    try:
        return np.arange(steps) * dt
    except (MemoryError, ValueError, OverflowError):
        raise ValueError(f"timepts: {steps} steps do not fit in memory"
                         ) from None


def initial_mean(initial_state: Any, n: int) -> np.ndarray:
    """``initial_state`` as ``n`` floats (None = zeros, a scalar broadcasts)."""
    if initial_state is None:
        return np.zeros(n)
    x0 = real_values(initial_state, "initial_state", ndim=(0, 1))
    if x0.ndim == 0:
        return np.full(n, float(x0))
    if x0.size != n:
        raise ControlDimension(f"initial_state: expected {n} entries, got "
                               f"{x0.size}")
    return x0.copy()


def covariance(value: Any, size: int, name: str) -> np.ndarray | None:
    """A checked covariance matrix (symmetrised), or None for None.

    Refuses, naming ``name``, a matrix that is not ``size × size``, not
    symmetric or not positive semidefinite (an eigenvalue below
    ``-1e-9`` relative to its largest entry): a negative "variance" would
    give negative exact variances and no Gaussian to sample.
    """
    if value is None:
        return None
    real_values(value, name)
    W = matrix(value, name, (size, size))
    scale = max(1.0, float(np.max(np.abs(W), initial=0.0)))
    if not np.allclose(W, W.T, rtol=0, atol=1e-12 * scale):
        raise ValueError(f"{name}: a covariance matrix must be symmetric")
    W = 0.5 * (W + W.T)
    lam = np.linalg.eigvalsh(W)
    if lam.size and lam.min() < -1e-9 * scale:
        raise ValueError(f"{name}: a covariance matrix must be positive "
                         f"semidefinite, got eigenvalue {lam.min():.3g}")
    return W


def input_signal(inputs: Any, m: int, steps: int, name: str = "inputs"
                 ) -> np.ndarray:
    """``inputs`` as an ``(m, steps)`` array (None = zeros, scalars broadcast)."""
    if inputs is None:
        return np.zeros((m, steps))
    u = real_values(inputs, name, ndim=(0, 1, 2))
    if u.ndim == 1 and m == 1 and u.size == steps:
        u = u[None]
    try:
        return np.array(np.broadcast_to(u if u.ndim != 1 else u[:, None],
                                        (m, steps)))
    except ValueError:
        raise ControlDimension(f"{name}: expected shape ({m}, {steps}) "
                               f"(signals × time points), got {u.shape}") from None


@dataclass
class MomentsResponse:
    """Exact moments over time (all arrays have time as the last axis).

    Attributes
    ----------
    time : ndarray, shape (T,)
    states_mean : ndarray, shape (n, T)
        ``E ξ_t``.
    outputs_mean : ndarray, shape (p, T)
        ``E z_t``.
    states_cov, outputs_cov : ndarray, shapes (n, n, T), (p, p, T)
        Covariances ``E[ξξᵀ] - E ξ E ξᵀ`` and likewise for ``z``.
    states_second_moment : ndarray, shape (n, n, T)
        ``E[ξ ξᵀ]``.
    sys : JumpStateSpace
        The system, for its signal names.

    Examples
    --------
    ``x⁺ = 2x`` with probability 0.2, else 0, from ``x_0 = 1``:
    ``E x_t = 0.4^t`` and ``E x_t² = 0.8^t``.

    >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> r = ncs.moments(sys, 3, initial_state=1.0)
    >>> r.outputs_mean.round(6).tolist(), r.outputs_cov[0, 0].round(6).tolist()
    ([[1.0, 0.4, 0.16]], [0.0, 0.64, 0.6144])
    """

    time: np.ndarray
    states_mean: np.ndarray
    outputs_mean: np.ndarray
    states_cov: np.ndarray
    outputs_cov: np.ndarray
    states_second_moment: np.ndarray
    sys: Any = None

    def __repr__(self) -> str:
        name = getattr(self.sys, "name", "?")
        return (f"<MomentsResponse of {name}: exact mean and covariance, "
                f"{self.states_mean.shape[0]} states, "
                f"{self.outputs_mean.shape[0]} outputs, {self.time.size} "
                f"time points>")

    def summary(self) -> str:
        """A few lines for humans: the exact moments at the last time.

        Returns
        -------
        str
            Per output (at most 10): ``E z`` and its standard deviation.

        Examples
        --------
        >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8],
        ...           name="loop", outputs="z")
        >>> print(ncs.moments(sys, 3, initial_state=1.0).summary())
        MomentsResponse of loop: exact mean and covariance, 1 states, 1 outputs, 3 time points
          at t = 2: z: mean 0.16, std 0.784
        """
        lines = [repr(self)[1:-1]]
        labels = getattr(self.sys, "jump_outputs", None) or [
            f"z[{i}]" for i in range(self.outputs_mean.shape[0])]
        m, sd = self.outputs_mean[:, -1], self.outputs_std[:, -1]
        for i, name in enumerate(labels[:10]):
            lines.append(f"  at t = {self.time[-1]:g}: {name}: mean "
                         f"{m[i]:.3g}, std {sd[i]:.3g}")
        return "\n".join(lines)

    @property
    def outputs_std(self) -> np.ndarray:
        """Standard deviation of each output, shape (p, T).

        The square root of the diagonal of :attr:`outputs_cov` (rounding
        below zero clipped).

        Examples
        --------
        >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
        >>> ncs.moments(sys, 3, initial_state=1.0).outputs_std.round(4).tolist()
        [[0.0, 0.8, 0.7838]]
        """
        d = np.einsum("iit->it", self.outputs_cov)
        return np.sqrt(np.maximum(d, 0.0))

    def to_response(self) -> ct.TimeResponseData:
        """The mean as a :class:`control.TimeResponseData` (plottable).

        Returns
        -------
        control.TimeResponseData
            Outputs ``E z``, states ``E ξ``, labelled like ``sys``; no
            inputs.

        Examples
        --------
        >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8],
        ...           name="loop")
        >>> data = ncs.moments(sys, 3, initial_state=1.0).to_response()
        >>> data.outputs.round(6).tolist(), data.title
        ([[1.0, 0.4, 0.16]], 'Exact mean of loop')
        """
        s = self.sys
        return ct.TimeResponseData(
            self.time, self.outputs_mean, self.states_mean, issiso=False,
            output_labels=s.jump_outputs, state_labels=s.jump_states,
            plot_inputs=False, sysname=s.name, title=f"Exact mean of {s.name}")


def moments(sys: Any, timepts: Any, inputs: Any = None, initial_state: Any = None,
            *, noise_covariance: Any = None, initial_covariance: Any = None,
            **kwargs: Any) -> MomentsResponse:
    """Exact mean and covariance of a jump system's state and output.

    Propagates ``m⁺ = Σ p (A m + B w)`` and
    ``Q⁺ = Σ p [A Q Aᵀ + A m wᵀBᵀ + B w mᵀAᵀ + B (w wᵀ + W) Bᵀ]``
    (:ref:`theory-moments`, written for the generic modes of
    :ref:`theory-jump-system`), where ``w`` is deterministic and ``W`` the
    covariance of an added white part. For Markov modes (:ref:`theory-markov`)
    the same recursion runs per mode on ``E[ξ 1{σ = i}]`` and
    ``E[ξξᵀ 1{σ = i}]``, redistributed by the transition at every step, from
    the mode law ``sys.modes.initial`` (independent of ``ξ_0``).

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time control.StateSpace
    timepts : int or array_like
        Number of steps ``T``, or the times ``0, dt, …, (T-1)·dt`` (they
        must start at 0); phase ``t mod N`` applies at step ``t``.
    inputs : array_like, shape (m, T), optional
        Deterministic part of ``w`` (default zero; scalars broadcast).
    initial_state : array_like, shape (n,), or scalar, optional
        Mean of ``ξ_0`` (default zero; a scalar applies to every state).
    noise_covariance : array_like, shape (m, m), optional
        Covariance ``W`` of a zero-mean white part of ``w`` (symmetric
        positive semidefinite).
    initial_covariance : array_like, shape (n, n), optional
        Covariance of ``ξ_0`` (default zero: known initial state; symmetric
        positive semidefinite).
    **kwargs
        Reserved: any keyword raises ``TypeError`` (unknown keyword).

    Returns
    -------
    MomentsResponse

    Raises
    ------
    TypeError
        Unknown keyword.
    ValueError
        Bad ``timepts`` (not a count, not starting at 0, not spaced by
        ``dt``), complex or non-finite values, or a covariance that is not
        symmetric positive semidefinite.
    ControlDimension
        Arrays of the wrong shape.

    References
    ----------
    .. [1] O. L. V. Costa, M. D. Fragoso and R. P. Marques, *Discrete-Time
           Markov Jump Linear Systems*, Springer, 2005.

    Examples
    --------
    >>> from control_ncs import jss
    >>> sys = ncs.jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> r = ncs.moments(sys, 3, initial_state=[1.0])
    >>> r.states_mean.round(6).tolist(), r.states_second_moment[0, 0].round(6).tolist()
    ([[1.0, 0.4, 0.16]], [1.0, 0.8, 0.64])
    """
    no_extra_kwargs("moments", kwargs)
    sys = as_jump(sys)
    n, m, q = (sys.modes.A.shape[-1], sys.modes.B.shape[-1],
               sys.modes.C.shape[-2])
    t = time_grid(sys, timepts)
    T = t.size
    w = input_signal(inputs, m, T)
    x0 = initial_mean(initial_state, n)
    W = covariance(noise_covariance, m, "noise_covariance")
    W = np.zeros((m, m)) if W is None else W
    P0 = covariance(initial_covariance, n, "initial_covariance")
    P0 = np.zeros((n, n)) if P0 is None else P0
    mean_x, mean_z = np.zeros((n, T)), np.zeros((q, T))
    # one (n, n) block per step, time first: a step's store is contiguous
    # (time last would scatter it with a stride of T floats)
    Sx, Sz = np.zeros((T, n, n)), np.zeros((T, q, q))
    with serial_blas(n):
        if sys.modes.is_iid:
            _iid_moments(sys.modes, w, x0, P0, W, mean_x, mean_z, Sx, Sz)
        else:
            _markov_moments(sys.modes, w, x0, P0, W, mean_x, mean_z, Sx, Sz)
    Sx, Sz = Sx.transpose(1, 2, 0), Sz.transpose(1, 2, 0)
    cov_x = Sx - np.einsum("at,bt->abt", mean_x, mean_x)
    cov_z = Sz - np.einsum("at,bt->abt", mean_z, mean_z)
    return MomentsResponse(t, mean_x, mean_z, cov_x, cov_z, Sx, sys)


def _iid_moments(modes, w, x0, P0, W, mean_x, mean_z, Sx, Sz) -> None:
    """Fill the moments of a jump system with i.i.d. modes: the recursion
    of :func:`moments` from ``m_0 = x0``, ``Q_0 = P0 + x0 x0ᵀ``."""
    A, B, C, D, p = modes.A, modes.B, modes.C, modes.D, modes.probabilities
    mk, Qk = x0.copy(), P0 + np.outer(x0, x0)
    for j in range(w.shape[1]):
        k = j % modes.period
        pk = p[k]
        wk = w[:, j]
        W2 = np.outer(wk, wk) + W
        mean_x[:, j], Sx[j] = mk, Qk
        # Σ_i p_i F_i m as products (a three-operand einsum loops in C
        # over every index: 0.5 ms a step at n = 200)
        mean_z[:, j] = pk @ (C[k] @ mk) + pk @ (D[k] @ wk)
        Sz[j] = _second_moment_step(pk, C[k], D[k], Qk, mk, wk, W2)
        mk, Qk = (pk @ (A[k] @ mk) + pk @ (B[k] @ wk),
                  _second_moment_step(pk, A[k], B[k], Qk, mk, wk, W2))


def _markov_moments(modes, w, x0, P0, W, mean_x, mean_z, Sx, Sz) -> None:
    """Fill the moments of a Markov jump system (:ref:`theory-markov`): per
    mode ``i``, ``μ_i = E[ξ 1{σ = i}]``, ``Q_i = E[ξξᵀ 1{σ = i}]`` and
    ``π_i = P(σ = i)``; one step applies mode ``i``'s matrices to its share,
    then the chain
    ``T_k`` redistributes the shares."""
    A, B, C, D, T = modes.A, modes.B, modes.C, modes.D, modes.transitions()
    N = modes.period
    pi = modes.start().copy()
    mu = pi[:, None] * x0[None]
    Q = pi[:, None, None] * (P0 + np.outer(x0, x0))[None]
    for j in range(w.shape[1]):
        k = j % N
        wk = w[:, j]
        W2 = np.outer(wk, wk) + W
        mean_x[:, j], Sx[j] = mu.sum(0), Q.sum(0)
        mean_z[:, j] = np.einsum("iab,ib->a", C[k], mu) + \
            np.einsum("i,iab,b->a", pi, D[k], wk)
        Sz[j] = _shares_step(pi, C[k], D[k], Q, mu, wk, W2).sum(0)
        nu = np.einsum("iab,ib->ia", A[k], mu) + pi[:, None] * (B[k] @ wk)
        Y = _shares_step(pi, A[k], B[k], Q, mu, wk, W2)
        mu = T[k].T @ nu
        Q = np.tensordot(T[k].T, Y, axes=1)
        pi = pi @ T[k]


def _shares_step(pi, F, G, Q, mu, w, W2):
    """Per mode ``i``: ``F Q_i Fᵀ + F μ_i wᵀ Gᵀ + G w μ_iᵀ Fᵀ + π_i G W2 Gᵀ``."""
    Fm = np.einsum("iab,ib->ia", F, mu)
    Gw = G @ w
    cross = np.einsum("ia,id->iad", Fm, Gw)
    S = (F @ Q @ F.transpose(0, 2, 1) + cross + cross.transpose(0, 2, 1)
         + pi[:, None, None] * (G @ W2 @ G.transpose(0, 2, 1)))
    return 0.5 * (S + S.transpose(0, 2, 1))


def _second_moment_step(p, F, G, Q, m, w, W2):
    """``Σ p [F Q Fᵀ + F m wᵀ Gᵀ + G w mᵀ Fᵀ + G W2 Gᵀ]``."""
    # batched matrix products (BLAS); a many-operand einsum without
    # optimisation loops in C over every index (seconds at n = 32)
    Fm, Gw = F @ m, G @ w                                  # (M, n) each
    cross = (p[:, None] * Fm).T @ Gw                     # Σ p Fm Gwᵀ
    S = (np.tensordot(p, F @ Q @ F.transpose(0, 2, 1), axes=1)
         + cross + cross.T
         + np.tensordot(p, G @ W2 @ G.transpose(0, 2, 1), axes=1))
    return 0.5 * (S + S.T)
