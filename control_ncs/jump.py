"""The generic periodic jump linear system (:ref:`theory-jump-system`), written
once.

Two objects share one shape, indexed by phase ``k = 0..N-1`` and mode ``i``
(probability ``p[k, i]``, modes i.i.d. from step to step):

* :class:`JumpPlant` -- the system before the gain is chosen::

      ξ⁺ = (A_ki + Bu_ki K_k E_k) ξ + Bw_ki w
      z  = (Cz_ki + Du_ki K_k E_k) ξ + Dw_ki w

  Network strategies (``strategies.py``) build it, synthesis consumes it.

* :class:`JumpStateSpace` -- the closed loop ``ξ⁺ = A_ki ξ + B_ki w``,
  ``z = C_ki ξ + D_ki w``. It *is* a :class:`control.StateSpace`: its own
  ``A, B, C, D`` are the exact mean (first-moment) system of
  :ref:`theory-moments`, lifted over one period when ``N > 1``. Analysis and
  simulation consume it.

Markov-driven modes (Gilbert–Elliott losses, :ref:`theory-markov`) carry a
transition array of shape ``(N, M, M)`` beside ``probabilities`` (then the
per-phase marginals of the periodic stationary chain) and an initial
distribution. i.i.d. modes are the case where every row of it equals the next
phase's ``probabilities``: such a transition is stored as ``None``, so that
every i.i.d. number is computed exactly as before. Code that reads only
``probabilities`` must first test :attr:`Modes.is_iid`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
import control as ct
from control.exception import ControlArgument, ControlDimension

from ._checks import discrete_dt, no_extra_kwargs, real_array

__all__ = ["Modes", "JumpStateSpace", "JumpPlant", "jss", "lift"]

_PROB_TOL = 1e-9

#: Largest lifted face (entries of ``A, B, C, D`` over one period) that a
#: JumpStateSpace builds: 5e7 float64 entries are 400 MB. The block lower
#: triangular ``D`` of size ``N·p × N·m`` is inherent to the lifted face, so a
#: longer period is refused at once rather than after minutes of work.
MAX_LIFTED_ENTRIES = 50_000_000


@dataclass(frozen=True, eq=False)
class Modes:
    """Per-phase, per-mode matrices of a closed-loop jump system.

    Attributes
    ----------
    A, B, C, D : ndarray, shapes (N, M, n, n), (N, M, n, m), (N, M, p, n), (N, M, p, m)
        ``ξ⁺ = A[k, i] ξ + B[k, i] w``, ``z = C[k, i] ξ + D[k, i] w`` in mode
        ``i`` at phase ``k``.
    probabilities : ndarray, shape (N, M)
        ``P(mode i at phase k)``; rows sum to one. i.i.d. modes: the law of
        every step; Markov modes: the marginals of the periodic stationary
        chain.
    transition : ndarray, shape (N, M, M), or None
        Markov modes (:ref:`theory-markov`):
        ``T[k, i, j] = P(σ_{k+1} = j | σ_k = i)``; None for i.i.d. modes.
    initial : ndarray, shape (M,), or None
        Markov modes: the law of the mode at time 0 (phase 0); None for
        i.i.d. modes.

    Examples
    --------
    Every :class:`JumpStateSpace` holds one; here two scalar modes with
    probabilities 0.3 and 0.7 (period 1):

    >>> m = jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7]).modes
    >>> m.A.shape, m.period, m.count
    ((1, 2, 1, 1), 1, 2)
    >>> m.mean()[0].tolist()                 # 0.3 * 0.5 + 0.7 * 0.9
    [[[0.78]]]
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    probabilities: np.ndarray
    transition: np.ndarray | None = None
    initial: np.ndarray | None = None

    @property
    def is_iid(self) -> bool:
        """True for i.i.d. modes: ``probabilities`` alone says everything.

        Any code that reads only ``probabilities`` (the i.i.d. formulas of
        :ref:`theory-mss`, :ref:`theory-passivity`, :ref:`theory-moments`,
        :ref:`theory-synthesis`) must check this first and refuse a Markov
        system.
        """
        return self.transition is None

    def transitions(self) -> np.ndarray:
        """``T[k, i, j] = P(σ_{k+1} = j | σ_k = i)``, shape (N, M, M).

        For i.i.d. modes every row of ``T[k]`` is ``probabilities[k + 1]``.
        """
        if self.transition is not None:
            return self.transition
        nxt = np.roll(self.probabilities, -1, axis=0)
        return np.repeat(nxt[:, None, :], self.count, axis=1)

    def start(self) -> np.ndarray:
        """Law of the mode at time 0: ``initial``, or ``probabilities[0]``."""
        return self.probabilities[0] if self.initial is None else self.initial

    @property
    def period(self) -> int:
        """Number of phases ``N``."""
        return self.probabilities.shape[0]

    @property
    def count(self) -> int:
        """Number of modes ``M`` per phase."""
        return self.probabilities.shape[1]

    def mean(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Per-phase mean matrices ``Σ_i p_ki M_ki``.

        Returns
        -------
        A, B, C, D : ndarray
            Shapes (N, n, n), (N, n, m), (N, p, n), (N, p, m).
        """
        p = self.probabilities
        return tuple(np.einsum("km,kmij->kij", p, M)
                     for M in (self.A, self.B, self.C, self.D))

    def __repr__(self) -> str:
        N, M, n, m = self.B.shape
        return (f"<Modes: period {N}, {M} modes per phase, {n} states, "
                f"{m} inputs, {self.C.shape[2]} outputs>")

    def summary(self) -> str:
        """A few lines for humans: sizes and the probabilities per phase.

        Returns
        -------
        str
            At most 10 phases and 8 modes shown.

        Examples
        --------
        >>> m = jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7]).modes
        >>> print(m.summary())
        Modes: period 1, 2 modes per phase, 1 states, 1 inputs, 1 outputs
          phase 0: p = 0.3, 0.7
        """
        lines = [repr(self)[1:-1]]
        for k in range(min(self.period, 10)):
            p = ", ".join(f"{x:.4g}" for x in self.probabilities[k, :8])
            more = ", ..." if self.count > 8 else ""
            lines.append(f"  phase {k}: p = {p}{more}")
        if self.period > 10:
            lines.append(f"  ... ({self.period - 10} more phases)")
        if self.transition is not None:
            lines.append("  Markov modes: p are the stationary marginals; "
                         "transition T[k][i, j] = P(j next | i now)")
        return "\n".join(lines)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Modes) and all(
            np.array_equal(getattr(self, f), getattr(other, f))
            for f in ("A", "B", "C", "D", "probabilities")) and all(
            (a is None and b is None) or (a is not None and b is not None
                                          and np.array_equal(a, b))
            for a, b in ((self.transition, other.transition),
                         (self.initial, other.initial)))

    # unhashable: mutable numpy content. None is Python's documented way to
    # say so; typeshed types object.__hash__ as a method only.
    __hash__ = None  # type: ignore[assignment]


def _phase_mode_array(value: Any, name: str, N: int, M: int, shape: tuple
                      ) -> np.ndarray:
    """Broadcast a matrix, a per-mode stack or a per-phase-per-mode stack."""
    arr = real_array(value, name, ndim=(0, 1, 2, 3, 4))
    if arr.ndim < 2:
        arr = arr.reshape(1, 1) if arr.size == 1 else arr
    if arr.ndim < 2:
        raise ControlDimension(f"{name}: expected a matrix of shape {shape}, "
                               f"a stack (M, ...) or (N, M, ...), got {arr.shape}")
    if arr.ndim == 3:
        arr = arr[None]
    try:
        return np.array(np.broadcast_to(arr, (N, M) + shape))
    except ValueError:
        raise ControlDimension(
            f"{name}: expected shape {shape} per mode, for N={N} phases and "
            f"M={M} modes (a matrix, an (M, ...) or an (N, M, ...) stack), "
            f"got {arr.shape}") from None


def _probabilities(value: Any, name: str = "probabilities") -> np.ndarray:
    p = real_array(value, name, ndim=(1, 2))
    if p.ndim == 1:
        p = p[None]
    if np.any(p < -_PROB_TOL) or np.any(p > 1 + _PROB_TOL):
        raise ValueError(f"{name}: probabilities must lie in [0, 1]")
    if not np.allclose(p.sum(axis=1), 1.0, atol=_PROB_TOL, rtol=0):
        raise ValueError(f"{name}: the mode probabilities of each phase must "
                         f"sum to 1, got sums {p.sum(axis=1).tolist()}")
    # rounding (e.g. merged eq. 14 modes summing to 1 + 2e-16) is tolerated
    # as for the row sums, then removed
    return np.clip(p, 0.0, 1.0)


def periodic_stationary(T: np.ndarray) -> np.ndarray:
    """Per-phase marginals ``p[k]`` of the periodic stationary law of a
    chain with transitions ``T[k]`` (shape (N, M, M)): ``p[0] Φ = p[0]`` for
    ``Φ = T[0] ⋯ T[N-1]``, ``p[k+1] = p[k] T[k]``. For a reducible chain the
    law is one of several (the least-squares one)."""
    N, M, _ = T.shape
    phi = np.eye(M)
    for Tk in T:
        phi = phi @ Tk
    lhs = np.vstack([phi.T - np.eye(M), np.ones((1, M))])
    rhs = np.zeros(M + 1)
    rhs[-1] = 1.0
    pi = np.linalg.lstsq(lhs, rhs, rcond=None)[0]
    # rounding leaves ~1e-17 on modes the chain never visits: they are 0
    pi[pi < M * np.finfo(float).eps] = 0.0
    p = np.empty((N, M))
    p[0] = pi / pi.sum()
    for k in range(N - 1):
        p[k + 1] = p[k] @ T[k]
    return p


def _chain(transition: Any, initial: Any, N: int, M: int | None
           ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """``(probabilities, transition, initial)`` of a Markov jump system;
    equal rows give the i.i.d. system (transition None) unless ``initial``
    differs from its law."""
    from .network import transition_matrix
    T = transition_matrix(transition, "transition")
    if T.ndim == 2:
        T = T[None]
    if T.ndim != 3 or T.shape[1] != T.shape[2] or T.shape[0] not in (1, N) \
            or (M is not None and T.shape[1] != M):
        raise ControlDimension(
            f"transition: expected shape (M, M) or (N, M, M) with N = {N} "
            f"phases" + (f" and M = {M} modes" if M is not None else "")
            + f", got {np.shape(transition)}")
    T = np.array(np.broadcast_to(T, (N,) + T.shape[1:]))
    M = T.shape[1]
    init = None
    if initial is not None:
        init = _probabilities(initial, "probabilities")
        if init.shape != (1, M):
            raise ControlDimension(
                f"probabilities: with a transition it is the law of the "
                f"initial mode, shape ({M},), got {np.shape(initial)}")
        init = init[0]
    if np.all(T == T[:, :1, :]):
        # equal rows: i.i.d. modes, the law of phase k+1 is any row of T[k]
        p = np.roll(T[:, 0, :], 1, axis=0)
        if init is None or np.array_equal(init, p[0]):
            return p, None, None
    p = periodic_stationary(T)
    return p, T, (p[0].copy() if init is None else init)


def lift(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray
         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Lift an N-periodic linear system over one period.

    Parameters
    ----------
    A, B, C, D : ndarray, shapes (N, n, n), (N, n, m), (N, p, n), (N, p, m)
        ``x[t+1] = A[k] x[t] + B[k] w[t]``, ``z[t] = C[k] x[t] + D[k] w[t]``,
        ``k = t mod N``.

    Returns
    -------
    AL, BL, CL, DL : ndarray
        The time-invariant system from ``x[jN]`` and the stacked inputs
        ``[w[jN]; w[jN+1]; …; w[jN+N-1]]`` (time-major: all channels of
        phase 0 first) to ``x[(j+1)N]`` and the stacked outputs
        ``[z[jN]; …; z[jN+N-1]]``. Shapes (n, n), (n, N m), (N p, n),
        (N p, N m); ``DL`` is block lower triangular.

    Examples
    --------
    A scalar system with ``A = 2`` at phase 0 and ``A = 0.5`` at phase 1:
    over one period ``x[2] = 0.5 · 2 · x[0] + 0.5 w[0] + w[1]``, and
    ``z[1] = 2 x[0] + w[0]``:

    >>> A = np.array([[[2.0]], [[0.5]]])
    >>> B, C, D = np.ones((2, 1, 1)), np.ones((2, 1, 1)), np.zeros((2, 1, 1))
    >>> AL, BL, CL, DL = lift(A, B, C, D)
    >>> AL.tolist(), BL.tolist(), CL.tolist(), DL.tolist()
    ([[1.0]], [[0.5, 1.0]], [[1.0], [2.0]], [[0.0, 0.0], [1.0, 0.0]])
    """
    N, n = A.shape[0], A.shape[1]
    m, p = B.shape[2], C.shape[1]
    # phi = A[N-1] ... A[j]: the transition from phase j to the period end
    BL = np.zeros((n, N * m))
    phi = np.eye(n)
    for j in range(N - 1, -1, -1):
        BL[:, j * m:(j + 1) * m] = phi @ B[j]
        phi = phi @ A[j]
    AL = phi
    # CL[k] = C[k] A[k-1] ... A[0]
    CL = np.zeros((N * p, n))
    forward = np.eye(n)
    for k in range(N):
        CL[k * p:(k + 1) * p] = C[k] @ forward
        forward = A[k] @ forward
    # DL[k, j] = C[k] A[k-1] ... A[j+1] B[j] for j < k, D[k] on the diagonal.
    # One sub-diagonal d = k - j at a time, all its blocks at once:
    # G[j] = A[j+d-1] ... A[j+1] B[j], so the Python loop runs N times, not N²/2.
    DL = np.zeros((N, p, N, m))
    phases = np.arange(N)
    DL[phases, :, phases, :] = D
    G = np.asarray(B, float)
    for d in range(1, N):
        first = phases[:N - d]  # the phases j of the blocks (j + d, j)
        if d > 1:
            G = A[first + d - 1] @ G[:N - d]
        else:
            G = G[:N - 1]
        DL[first + d, :, first, :] = C[first + d] @ G
    return AL, BL, CL, DL.reshape(N * p, N * m)


def lifted_size(n: int, m: int, p: int, N: int) -> int:
    """Number of entries of the lifted face ``(AL, BL, CL, DL)``."""
    return n * n + N * n * (m + p) + N * N * p * m


def check_lifted_size(n: int, m: int, p: int, N: int, name: str) -> None:
    """Refuse a period whose lifted face exceeds :data:`MAX_LIFTED_ENTRIES`."""
    size = lifted_size(n, m, p, N)
    if N > 1 and size > MAX_LIFTED_ENTRIES:
        raise ValueError(
            f"{name}: period N = {N} is too long: the lifted mean system "
            f"(n = {n}, {m} inputs, {p} outputs per step) would have "
            f"{size:.3g} entries, more than MAX_LIFTED_ENTRIES = "
            f"{MAX_LIFTED_ENTRIES:.3g} (its D alone is {N * p} x {N * m}); "
            f"use shorter schedules, whose least common multiple sets N")


def lifted_names(names: Sequence[str], N: int) -> list[str]:
    """Signal names of the lifted face: ``'<name>[k]'`` for phase ``k``."""
    if N == 1:
        return list(names)
    return [f"{s}[{k}]" for k in range(N) for s in names]


class JumpStateSpace(ct.StateSpace):
    """Periodic jump linear system whose StateSpace face is its exact mean.

    ``ξ[t+1] = A[k,i] ξ[t] + B[k,i] w[t]``, ``z[t] = C[k,i] ξ[t] + D[k,i] w[t]``
    with ``k = t mod N`` and mode ``i`` drawn independently at every step
    with probability ``probabilities[k, i]`` (:ref:`theory-jump-system`), or,
    given a ``transition``, a Markov chain
    ``T[k][i, j] = P(σ[t+1] = j | σ[t] = i)`` (:ref:`theory-markov`). For
    Markov modes the StateSpace face is the exact mean system of order ``M·n``
    (state ``E[ξ 1{σ = i}]`` per mode ``i``) under the periodic stationary
    chain; a transition with equal rows is the i.i.d. system.

    The :class:`control.StateSpace` matrices ``self.A, self.B, self.C,
    self.D`` are the *mean system* of :ref:`theory-moments`: ``E ξ`` and
    ``E z`` obey them exactly for deterministic inputs, because the mode at
    time ``t`` is independent of ``ξ[t]``. For ``N = 1`` that system is
    ``(Σ p_i A_i, Σ p_i B_i, Σ p_i C_i, Σ p_i D_i)``; for ``N > 1`` it is that
    periodic system lifted over one period (:func:`lift`), with sampling time
    ``N·dt``, inputs ``w[0], …, w[N-1]`` and outputs ``z[0], …, z[N-1]``
    stacked time-major (all channels of phase 0 first) and named
    ``'<signal>[k]'`` for phase ``k`` (e.g. ``'w[0][1]'``: channel ``w[0]``
    at phase 1). Hence ``control.step_response`` and ``control.bode_plot``
    of this object are exact statements about ``E z``; for ``N > 1`` they
    are statements per period (a step of the lifted input ``w[j][k]`` is a
    pulse train at phase ``k``), and ``control.forced_response`` needs time
    points spaced by ``N·dt``. For ``E z`` and its spread at the base rate,
    for any ``N``, use :func:`control_ncs.forced_response`,
    :func:`control_ncs.step_response` and :func:`control_ncs.moments`; for
    a readable frequency plot of one phase, :meth:`phase`.

    python-control's algebra keeps the randomness: ``control.feedback``,
    ``series``, ``parallel``, ``append``, the operators ``*``, ``+``,
    ``-`` and indexing, with a deterministic LTI system ``G`` (StateSpace,
    TransferFunction, scalar or array, at the base step), return a
    ``JumpStateSpace`` built mode by mode (python-control's operation on
    each mode, probabilities kept): exact, and equal to
    :func:`control_ncs.jump_feedback` for feedback. Indices refer to the
    per-step signals for any ``N``. Two jump systems together raise
    ``ControlArgument`` (their modes are independent only if you say so).
    Calls python-control does not dispatch to this object (a
    ``TransferFunction`` on the left, ``control.feedback(G, sys)``,
    ``control.append(G, sys)``, ``control.interconnect``) read the face and
    return an ordinary system built from the mean (the exact mean of the
    interconnection only if no algebraic loop multiplies two mode-dependent
    matrices); :func:`control_ncs.interconnect` is the exact
    interconnection by signal names. ``==`` and ``hash`` are by identity,
    as for python-control's systems; :meth:`equals` compares values.

    Build one with :func:`jss` or :func:`control_ncs.feedback`. Its arrays
    (the modes and the mean face) are read-only, so the face stays the mean
    of the modes. A period whose lifted face would exceed
    ``MAX_LIFTED_ENTRIES`` entries is refused.

    Parameters
    ----------
    A, B, C, D : array_like
        Per-mode matrices, shape ``(N, M, ., .)``; an ``(M, ., .)`` stack
        means ``N = 1``; a single matrix is shared by all modes.
    probabilities : array_like, shape (M,) or (N, M), optional
        Mode probabilities per phase; each row sums to 1. With a
        ``transition``: the law of the mode at time 0, shape ``(M,)``
        (default: the periodic stationary law).
    dt : True or float > 0
        Sampling period of one step (discrete time only).
    transition : array_like, shape (M, M) or (N, M, M), optional
        Markov modes: ``T[k][i, j] = P(σ[t+1] = j | σ[t] = i)`` at phase
        ``k``; rows non-negative, summing to 1.
    nominal : array_like of int, shape (N,), optional
        Index of the loss-free mode at each phase, for :meth:`nominal`.
    name, inputs, outputs, states : optional
        As in :class:`control.StateSpace`; ``inputs``/``outputs`` name the
        per-step signals ``w`` and ``z``, not the lifted ones.
    info : dict, optional
        What built the system, kept as the ``info`` attribute.
    **kwargs
        None are accepted: an unknown keyword raises ``TypeError``.

    Attributes
    ----------
    modes : Modes
        The per-phase, per-mode matrices and probabilities.
    period : int
        ``N``.
    jump_inputs, jump_outputs, jump_states : list of str
        Names of ``w``, ``z`` and ``ξ`` at one step.
    info : dict
        What built the system (controller kind, actuator strategy, plant,
        gains), for reference; analysis never reads it.

    Examples
    --------
    A scalar loop that loses its control with probability 0.2; the
    StateSpace face is the mean ``0.2 · 2 + 0.8 · 0``:

    >>> sys = JumpStateSpace([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]],
    ...                      [0.2, 0.8], nominal=[1])
    >>> sys.period, sys.nmodes, float(sys.A[0, 0])
    (1, 2, 0.4)
    >>> sys.nominal().A.tolist()
    [[0.0]]
    """

    def __init__(self, A: Any, B: Any, C: Any, D: Any,
                 probabilities: Any = None, dt: Any = True, *,
                 transition: Any = None, nominal: Any = None,
                 name: str | None = None, inputs: Any = None,
                 outputs: Any = None, states: Any = None,
                 info: dict | None = None, **kwargs: Any):
        no_extra_kwargs("JumpStateSpace", kwargs)
        a = real_array(A, "A", ndim=(2, 3, 4))
        if transition is None:
            if probabilities is None:
                raise ValueError("probabilities: give the mode probabilities, "
                                 "or a transition matrix (Markov modes)")
            p, T, init = _probabilities(probabilities), None, None
        else:
            nt = np.ndim(transition)
            N0 = max(a.shape[0] if a.ndim == 4 else 1,
                     np.shape(transition)[0] if nt == 3 else 1)
            p, T, init = _chain(transition, probabilities, N0,
                                a.shape[-3] if a.ndim >= 3 else None)
        N, M = p.shape
        n = a.shape[-1]
        if a.shape[-2] != n:
            raise ControlDimension(f"A: each mode matrix must be square, got "
                                   f"shape {a.shape}")
        A_ = _phase_mode_array(a, "A", N, M, (n, n))
        b = real_array(B, "B", ndim=(2, 3, 4))
        m = b.shape[-1]
        B_ = _phase_mode_array(b, "B", N, M, (n, m))
        c = real_array(C, "C", ndim=(2, 3, 4))
        q = c.shape[-2]
        for arg, count, what in (("B", m, "input w (a column of B)"),
                                 ("C", q, "output z (a row of C)")):
            if count == 0:
                raise ControlDimension(
                    f"{arg}: a jump system needs at least one {what}; for "
                    f"a system without one, pass a zero column or row")
        check_lifted_size(n, m, q, N, "probabilities")
        C_ = _phase_mode_array(c, "C", N, M, (q, n))
        D_ = _phase_mode_array(D, "D", N, M, (q, m))
        for X in (A_, B_, C_, D_, p, T, init):
            if X is not None:
                X.setflags(write=False)
        self.modes = Modes(A_, B_, C_, D_, p, T, init)
        self.dt_step = discrete_dt(dt)
        self.nominal_mode = None if nominal is None else self._check_nominal(
            nominal, N, M)
        self.info = dict(info or {})
        self.jump_inputs = _names(inputs, m, "w", "inputs")
        self.jump_outputs = _names(outputs, q, "z", "outputs")
        self.jump_states = _names(states, n, "x", "states")

        if T is None:
            Abar, Bbar, Cbar, Dbar = self.modes.mean()
            face_states = self.jump_states
        else:
            check_lifted_size(M * n, m, q, N, "transition")
            Abar, Bbar, Cbar, Dbar = _markov_mean(self.modes)
            face_states = [f"{s}#{i}" for i in range(M)
                           for s in self.jump_states]
        if N == 1:
            mats = (Abar[0], Bbar[0], Cbar[0], Dbar[0])
            lifted_dt = self.dt_step
        else:
            mats = lift(Abar, Bbar, Cbar, Dbar)
            lifted_dt = True if self.dt_step is True else self.dt_step * N
        super().__init__(*mats, lifted_dt, name=name,
                         inputs=lifted_names(self.jump_inputs, N),
                         outputs=lifted_names(self.jump_outputs, N),
                         states=face_states)
        # the face is the exact mean of self.modes only while neither changes
        for X in (self.A, self.B, self.C, self.D):
            X.setflags(write=False)

    @staticmethod
    def _check_nominal(nominal: Any, N: int, M: int) -> np.ndarray:
        idx = np.atleast_1d(np.asarray(nominal))
        if idx.shape != (N,) or not np.issubdtype(idx.dtype, np.integer) \
                or idx.min() < 0 or idx.max() >= M:
            raise ValueError(f"nominal: expected {N} mode indices in 0..{M - 1}, "
                             f"got {nominal!r}")
        return idx.astype(int)

    # -- accessors -----------------------------------------------------------
    @property
    def period(self) -> int:
        """Number of phases ``N``."""
        return self.modes.period

    @property
    def nmodes(self) -> int:
        """Number of modes ``M`` per phase."""
        return self.modes.count

    def mode(self, k: int, i: int) -> tuple[np.ndarray, ...]:
        """Matrices ``(A, B, C, D)`` of mode ``i`` at phase ``k mod N``.

        Parameters
        ----------
        k : int
            Time step or phase; taken modulo the period.
        i : int
            Mode index, ``0 <= i < nmodes``.

        Returns
        -------
        A, B, C, D : ndarray
            Read-only views of the mode's matrices.

        Examples
        --------
        >>> sys = jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7])
        >>> sys.mode(0, 1)[0].tolist()
        [[0.9]]
        """
        k %= self.period
        return tuple(M[k, i] for M in (self.modes.A, self.modes.B,
                                       self.modes.C, self.modes.D))

    def mean_phase(self, k: int) -> tuple[np.ndarray, ...]:
        """Mean matrices ``(Σ p A, Σ p B, Σ p C, Σ p D)`` at phase ``k mod N``.

        For Markov modes ``p`` are the stationary marginals: the average
        matrices of the phase, not the mean dynamics (the face is).

        Parameters
        ----------
        k : int
            Time step or phase; taken modulo the period.

        Returns
        -------
        A, B, C, D : ndarray
            The probability-weighted means over the modes of that phase.

        Examples
        --------
        >>> sys = jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7])
        >>> sys.mean_phase(0)[0].tolist()
        [[0.78]]
        """
        return tuple(M[k % self.period] for M in self.modes.mean())

    def deterministic(self) -> tuple[np.ndarray, ...] | None:
        """Per-phase ``(A, B, C, D)`` if the system is deterministic, else None.

        The system is deterministic when, at every phase, all modes of
        positive probability have identical matrices (whether or not they
        were merged); then each step applies one known linear map and the
        mean system is the system itself.

        Returns
        -------
        tuple of ndarray or None
            ``(A, B, C, D)`` of shapes ``(N, n, n)``, ``(N, n, m)``,
            ``(N, p, n)``, ``(N, p, m)`` (copies), or None if some phase
            has two live modes that differ.

        Examples
        --------
        Two identical modes make a deterministic system; two different ones
        do not:

        >>> jss([[[0.5]], [[0.5]]], [[1.0]], [[1.0]], [[0.0]],
        ...     [0.3, 0.7]).deterministic()[0].tolist()
        [[[0.5]]]
        >>> jss([[[0.5]], [[0.4]]], [[1.0]], [[1.0]], [[0.0]],
        ...     [0.3, 0.7]).deterministic() is None
        True
        """
        m = self.modes
        live = m.probabilities > 0
        first = np.argmax(live, axis=1)  # a live mode of each phase
        k = np.arange(self.period)
        mats = tuple(X[k, first] for X in (m.A, m.B, m.C, m.D))
        for X, ref in zip((m.A, m.B, m.C, m.D), mats):
            same = np.all(X == ref[:, None], axis=(2, 3))
            if not np.all(same | ~live):
                return None
        return mats

    def mean(self) -> ct.StateSpace:
        """The mean system as a plain :class:`control.StateSpace` (a copy).

        Returns
        -------
        control.StateSpace
            The face ``(self.A, self.B, self.C, self.D)`` with its signal
            names, lifted if ``N > 1``.
        """
        return ct.StateSpace(self.A, self.B, self.C, self.D, self.dt,
                             inputs=self.input_labels, outputs=self.output_labels,
                             states=self.state_labels,
                             name=f"{self.name}$mean")

    def nominal(self) -> ct.StateSpace:
        """The loss-free system (every message arrives), lifted if ``N > 1``.

        Returns
        -------
        control.StateSpace
            The loss-free mode of every phase, as a deterministic system.

        Raises
        ------
        ValueError
            If the system was built without knowing its loss-free mode.
        """
        if self.nominal_mode is None:
            raise ValueError("nominal: this jump system does not know which "
                             "mode is loss-free; pass nominal= to jss()")
        k = np.arange(self.period)
        A, B, C, D = (M[k, self.nominal_mode] for M in (
            self.modes.A, self.modes.B, self.modes.C, self.modes.D))
        mats = (lift(A, B, C, D) if self.period > 1
                else (A[0], B[0], C[0], D[0]))
        return ct.StateSpace(*mats, self.dt, inputs=self.input_labels,
                             outputs=self.output_labels,
                             name=f"{self.name}$nominal")

    def merged(self) -> "JumpStateSpace":
        """The same system with coinciding modes merged (probabilities added).

        Returns
        -------
        JumpStateSpace
            Equal in distribution to ``self``, with fewer modes where modes
            coincide; zero-probability modes are dropped (except the
            loss-free one).
        """
        if not self.modes.is_iid:
            # modes may share a row only if their futures coincide too (theory:
            # Markov losses); merging is not attempted for Markov modes
            return self
        keys = (self.modes.A, self.modes.B, self.modes.C, self.modes.D)
        groups, nominal = _merge_groups(keys, self.modes.probabilities,
                                        self.nominal_mode)
        return self._rebuild(groups, nominal)

    def _rebuild(self, groups: list, nominal: np.ndarray | None
                 ) -> "JumpStateSpace":
        (A, B, C, D), p = _apply_groups(
            (self.modes.A, self.modes.B, self.modes.C, self.modes.D),
            self.modes.probabilities, groups)
        return JumpStateSpace(A, B, C, D, p, self.dt_step, nominal=nominal,
                              name=self.name, inputs=self.jump_inputs,
                              outputs=self.jump_outputs, states=self.jump_states,
                              info=self.info)

    def phase(self, k: int) -> ct.StateSpace:
        """The mean system of phase ``k`` at the base rate, as a plain StateSpace.

        For frequency plots of one phase when ``N > 1``: the lifted face
        (``N·dt``, stacked signals) is exact but its Bode plot has
        ``N·p × N·m`` panels. This is the phase-``k`` mean
        ``(Σ p A, Σ p B, Σ p C, Σ p D)`` frozen in time, with step ``dt``
        and the per-step signal names: the loop as it would be if every
        step were phase ``k``. For ``N = 1`` it is :meth:`mean` itself; for
        ``N > 1`` it is a view of one phase, not a statement about ``E z``
        of the periodic loop (the face and the package's base-rate
        responses, :func:`control_ncs.step_response` and
        :func:`control_ncs.forced_response`, are).

        Parameters
        ----------
        k : int
            Time step or phase; taken modulo the period.

        Returns
        -------
        control.StateSpace
            Named ``'<name>$phase<k>'``.

        Examples
        --------
        >>> sys = jss([[[[0.5]]], [[[0.9]]]], [[1.0]], [[1.0]], [[0.0]],
        ...           [[1.0], [1.0]], dt=0.1)
        >>> sys.dt, sys.ninputs                   # the lifted face
        (0.2, 2)
        >>> one = sys.phase(1)
        >>> one.A.tolist(), one.dt, one.input_labels
        ([[0.9]], 0.1, ['w[0]'])
        """
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)):
            raise ControlArgument(f"k: expected an int phase, got {k!r}")
        k = int(k) % self.period
        return ct.StateSpace(*self.mean_phase(k), self.dt_step,
                             inputs=self.jump_inputs, outputs=self.jump_outputs,
                             states=self.jump_states,
                             name=f"{self.name}$phase{k}")

    def update_names(self, **kwargs: Any) -> None:
        """Rename the system or its per-step signals (as python-control).

        Parameters
        ----------
        **kwargs
            ``name``, and ``inputs``, ``outputs``, ``states`` naming the
            per-step signals ``w``, ``z``, ``ξ`` (the lifted face's names
            follow); anything else raises ``TypeError``.
        """
        allowed = {"name", "inputs", "outputs", "states"}
        extra = set(kwargs) - allowed
        if extra:
            raise TypeError(f"update_names: unknown keyword(s) "
                            f"{sorted(extra)}; expected {sorted(allowed)}")
        n = self.modes.A.shape[-1]
        counts = dict(inputs=len(self.jump_inputs),
                      outputs=len(self.jump_outputs), states=n)
        prefix = dict(inputs="w", outputs="z", states="x")
        face: dict = {}
        for key in ("inputs", "outputs", "states"):
            if key in kwargs:
                names = _names(kwargs[key], counts[key], prefix[key], key)
                setattr(self, f"jump_{key}", names)
                face[key] = (names if key == "states"
                             else lifted_names(names, self.period))
        if "name" in kwargs:
            face["name"] = kwargs["name"]
        super().update_names(**face)

    # -- python-control algebra, mode by mode (theory: interconnections, jump system) ---
    # python-control's operators, feedback, append and indexing dispatch to
    # these methods (ct.series and ct.parallel call the operators; Python
    # calls a subclass's reflected operator first, so ``G * CL`` reaches
    # __rmul__). With a deterministic LTI ``G`` each mode of the result is
    # python-control's operation on that mode, at the base rate, with the
    # same probabilities: exact, because ``G`` has no modes and the mode at
    # time t is the same draw on both sides (an algebraic loop is closed
    # inside the mode, as in control_ncs.jump_feedback).
    def mode_system(self, k: int, i: int) -> ct.StateSpace:
        """Mode ``i`` of phase ``k`` as a StateSpace at the base rate.

        Parameters
        ----------
        k : int
            Time step or phase; taken modulo the period.
        i : int
            Mode index, ``0 <= i < nmodes``.

        Returns
        -------
        control.StateSpace
            With the jump system's signal names and its base sampling time.

        Examples
        --------
        >>> sys = jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7])
        >>> sys.mode_system(0, 1).A.tolist()
        [[0.9]]
        """
        return ct.StateSpace(*self.mode(k, i), self.dt_step,
                             inputs=self.jump_inputs,
                             outputs=self.jump_outputs,
                             states=self.jump_states, name=self.name)

    def _operand(self, other: Any, what: str) -> Any:
        """``other`` checked to be deterministic LTI data at the base rate."""
        from control.exception import ControlArgument
        if isinstance(other, JumpStateSpace):
            raise ControlArgument(
                f"{what}: both operands are jump systems. Their modes are "
                f"independent only if you say so, and python-control's "
                f"algebra cannot: the interconnection needs the joint law of "
                f"the two mode sequences. Build one jump system over the "
                f"joint modes with jss() (products of the probabilities if "
                f"independent), or use the mean systems .mean() knowingly "
                f"(exact for E z only without an algebraic loop)")
        from .plant import NetworkedStateSpace  # plant.py builds on jump.py
        if isinstance(other, NetworkedStateSpace):
            raise ControlArgument(
                f"{what}: other is a NetworkedStateSpace, a plant without its "
                f"network loop; close it first (control_ncs.feedback)")
        if isinstance(other, ct.TransferFunction):
            other = ct.ss(other)
        if isinstance(other, ct.StateSpace):
            if ct.isctime(other, strict=True):
                raise ValueError(f"{what}: other is continuous-time; a jump "
                                 f"system is discrete-time (dt = "
                                 f"{self.dt_step}); discretize it with "
                                 f"other.sample(dt)")
            if other.dt is not True and self.dt_step is not True \
                    and not np.isclose(other.dt, self.dt_step, rtol=1e-12,
                                       atol=0):
                hint = (f" (N = {self.period}: the modes act per step, so "
                        f"other must run at the base rate dt, not N·dt)"
                        if np.isclose(other.dt, self.dt_step * self.period)
                        else "")
                raise ValueError(f"{what}: sampling periods differ: the jump "
                                 f"system steps with dt = {self.dt_step}, "
                                 f"other has dt = {other.dt}{hint}")
            return other
        if isinstance(other, ct.InputOutputSystem):
            raise ControlArgument(
                f"{what}: expected a deterministic LTI system (StateSpace, "
                f"TransferFunction), a scalar or an array, got "
                f"{type(other).__name__}")
        if isinstance(other, (list, tuple)):
            other = np.array(other, dtype=float)
        if isinstance(other, (int, float, np.number, np.ndarray)) \
                and not isinstance(other, (bool, np.bool_, complex)):
            return other
        return NotImplemented

    def mode_law(self) -> tuple[np.ndarray, np.ndarray | None]:
        """The ``(probabilities, transition)`` that rebuild this mode law.

        A system built from new per-mode matrices with the same mode law
        (an interconnection, python-control's algebra) passes both to
        :class:`JumpStateSpace`; ``probabilities`` is the initial law for
        Markov modes (:ref:`theory-markov`) and ``transition`` is None for
        i.i.d. ones.

        Returns
        -------
        probabilities : ndarray, shape (N, M) or (M,)
        transition : ndarray, shape (N, M, M), or None

        Examples
        --------
        >>> S = jss([[[0.5]], [[1.2]]], [[1.0]], [[1.0]], [[0.0]],
        ...         transition=[[0.5, 0.5], [0.125, 0.875]])
        >>> p, T = S.mode_law()
        >>> T.shape
        (1, 2, 2)
        """
        m = self.modes
        law = m.probabilities if m.initial is None else m.initial
        return law, m.transition


    def _modewise(self, op: Any, what: str, *, name: str | None = None,
                  names: dict | None = None) -> "JumpStateSpace":
        """The jump system whose mode (k, i) is ``op`` of mode (k, i)."""
        N, M = self.period, self.nmodes
        try:
            first = op(self.mode_system(0, 0))
        except ValueError as err:
            # python-control's message names neither side's sizes
            raise ControlDimension(
                f"{what}: {err} (the jump system has "
                f"{len(self.jump_inputs)} inputs and "
                f"{len(self.jump_outputs)} outputs per step)") from err
        done = [[first if k == i == 0 else op(self.mode_system(k, i))
                 for i in range(M)] for k in range(N)]
        A, B, C, D = (np.array([[getattr(S, X) for S in row] for row in done],
                               dtype=float) for X in "ABCD")
        labels = dict(inputs=list(first.input_labels),
                      outputs=list(first.output_labels),
                      states=list(first.state_labels))
        labels.update(names or {})
        dt = self.dt_step if first.dt is True else first.dt
        return JumpStateSpace(A, B, C, D, self.mode_law()[0], dt,
                              transition=self.modes.transition,
                              nominal=self.nominal_mode, name=name,
                              info=dict(self.info, algebra=what),
                              inputs=labels["inputs"],
                              outputs=labels["outputs"],
                              states=labels["states"])

    def __neg__(self) -> "JumpStateSpace":
        return self._modewise(lambda S: -S, "-sys")

    def __add__(self, other: Any) -> Any:
        G = self._operand(other, "sys + other")
        if G is NotImplemented:
            return G
        return self._modewise(lambda S: S + G, "sys + other")

    def __radd__(self, other: Any) -> Any:
        G = self._operand(other, "other + sys")
        if G is NotImplemented:
            return G
        return self._modewise(lambda S: G + S, "other + sys")

    def __sub__(self, other: Any) -> Any:
        G = self._operand(other, "sys - other")
        if G is NotImplemented:
            return G
        return self._modewise(lambda S: S - G, "sys - other")

    def __rsub__(self, other: Any) -> Any:
        G = self._operand(other, "other - sys")
        if G is NotImplemented:
            return G
        return self._modewise(lambda S: G - S, "other - sys")

    def __mul__(self, other: Any) -> Any:
        G = self._operand(other, "sys * other")
        if G is NotImplemented:
            return G
        return self._modewise(lambda S: S * G, "sys * other")

    def __rmul__(self, other: Any) -> Any:
        G = self._operand(other, "other * sys")
        if G is NotImplemented:
            return G
        return self._modewise(lambda S: G * S, "other * sys")

    def __truediv__(self, other: Any) -> Any:
        G = self._operand(other, "sys / other")
        if G is NotImplemented:
            return G
        return self._modewise(lambda S: S / G, "sys / other")

    def __rtruediv__(self, other: Any) -> Any:
        return self._refuse("other / sys")

    def __pow__(self, other: Any) -> Any:
        if type(other) is int and other == 1:
            return self._modewise(lambda S: S, "sys ** 1")
        if type(other) is int and other == -1:
            # the inverse of the map at each step is the inverse of its mode
            return self._modewise(lambda S: S ** -1, "sys ** -1")
        return self._refuse(f"sys ** {other!r}")

    def _refuse(self, what: str) -> Any:
        from control.exception import ControlArgument
        raise ControlArgument(
            f"{what}: not defined for a jump system: it would put two copies "
            f"of the same random system in series, whose modes are neither "
            f"the same draw nor independent; build the interconnection with "
            f"control_ncs.interconnect or jss()")

    def __getitem__(self, key: Any) -> "JumpStateSpace":
        # indices and names refer to the per-step signals z (rows) and w
        # (columns) for any N, not to the lifted face's stacked ones
        sizes = (len(self.jump_outputs), len(self.jump_inputs))
        if isinstance(key, tuple) and len(key) == 2:
            for index, size, what in zip(key, sizes, ("output", "input")):
                if isinstance(index, (int, np.integer)) and not (
                        -size <= index < size):
                    raise ControlDimension(
                        f"sys[{key!r}]: {what} index {index} is out of "
                        f"range for {size} {what}s")
        try:
            first = self.mode_system(0, 0)[key]
        except (IndexError, KeyError, ValueError, TypeError) as err:
            raise ControlDimension(f"sys[{key!r}]: {err}") from None
        if first.noutputs == 0 or first.ninputs == 0:
            raise ControlDimension(
                f"sys[{key!r}]: selects no output or no input of {sizes[0]} "
                f"outputs and {sizes[1]} inputs")
        return self._modewise(lambda S: S[key], f"sys[{key!r}]",
                              name=first.name)

    def append(self, other: Any) -> "JumpStateSpace":
        """Append a deterministic LTI system, mode by mode (python-control's).

        Parameters
        ----------
        other : StateSpace, TransferFunction, scalar or array
            Deterministic, with the same base step ``dt``.

        Returns
        -------
        JumpStateSpace
            Inputs and outputs of ``self`` then of ``other``; same modes.
        """
        G = self._operand(other, "append(sys, other)")
        if G is NotImplemented:
            return self._refuse("append(sys, other)")
        return self._modewise(lambda S: S.append(G), "append(sys, other)")

    def feedback(self, other: Any = 1, sign: float = -1, **kwargs: Any
                 ) -> "JumpStateSpace":
        """Feedback with a deterministic LTI system, mode by mode.

        :func:`control.feedback` calls this method. Each mode of the result
        is python-control's feedback of that mode with ``other`` (an
        algebraic loop through ``other``'s feedthrough is closed inside the
        mode, exactly); the result equals
        :func:`control_ncs.jump_feedback`.

        Parameters
        ----------
        other : StateSpace, TransferFunction, scalar or array, optional
            Deterministic feedback path with the same base step ``dt``.
        sign : float, optional
            Feedback sign (default -1).
        **kwargs
            ``name``, ``inputs``, ``outputs``, ``states`` for the result.

        Returns
        -------
        JumpStateSpace
            Same inputs and outputs as ``self``; the state is
            ``[ξ; x_other]``.
        """
        G = self._operand(other, "feedback(sys, other)")
        if G is NotImplemented:
            return self._refuse("feedback(sys, other)")
        m, p = len(self.jump_inputs), len(self.jump_outputs)
        if np.ndim(G) == 0 and not isinstance(G, ct.StateSpace) and m == p:
            G = G * np.eye(m)  # a scalar gain on every channel, as jump_feedback
        if isinstance(G, ct.StateSpace):
            gstates = [f"{G.name}.{x}" for x in G.state_labels]
        else:
            gstates = []
        loop = self._modewise(
            lambda S: S.feedback(G, sign), "feedback(sys, other)",
            names=dict(inputs=self.jump_inputs, outputs=self.jump_outputs,
                       states=self.jump_states + gstates))
        if kwargs:
            loop.update_names(**kwargs)
        return loop

    # -- python protocol -----------------------------------------------------
    def __reduce__(self) -> tuple:
        # control.StateSpace holds lambdas and cannot be pickled; rebuild
        # from the defining data instead (this also serves copy/deepcopy).
        m = self.modes
        return (_restore_jss, (m.A, m.B, m.C, m.D, self.mode_law()[0], self.dt_step,
                               self.nominal_mode, self.name, self.jump_inputs,
                               self.jump_outputs, self.jump_states, self.info,
                               m.transition))

    def equals(self, other: object) -> bool:
        """Whether ``other`` is the same jump system, value by value.

        Same modes and probabilities, step, signal names and loss-free mode
        (the name and ``info`` are not compared).

        Parameters
        ----------
        other : object
            Anything; only a :class:`JumpStateSpace` can be equal.

        Returns
        -------
        bool

        Examples
        --------
        >>> import copy
        >>> sys = jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7])
        >>> twin = copy.deepcopy(sys)
        >>> sys.equals(twin), sys == twin
        (True, False)
        """
        return (type(other) is type(self) and self.modes == other.modes
                and self.dt_step == other.dt_step
                and self.jump_inputs == other.jump_inputs
                and self.jump_outputs == other.jump_outputs
                and _same_nominal(self.nominal_mode, other.nominal_mode))

    # ``==`` and ``hash`` are by identity, as for every python-control
    # system: ct.interconnect and dicts key systems by object, and a value
    # ``==`` with an identity hash would break dict semantics (equal objects
    # must hash equal). Compare values with :meth:`equals`.
    __eq__ = object.__eq__
    __hash__ = object.__hash__

    def __repr__(self) -> str:
        n = self.modes.A.shape[-1]
        return (f"<JumpStateSpace {self.name}: {n} states, "
                f"{len(self.jump_inputs)} inputs, {len(self.jump_outputs)} outputs, "
                f"period {self.period}, {self.nmodes} modes, dt={self.dt_step}>")

    def __str__(self) -> str:
        p = np.array2string(self.modes.probabilities, precision=4)
        law = "i.i.d." if self.modes.is_iid else "Markov"
        head = (f"JumpStateSpace: {self.name}\n"
                f"Periodic jump linear system, period N = {self.period}, "
                f"{self.nmodes} {law} modes per step, dt = {self.dt_step}\n"
                f"Mode probabilities (rows = phases):\n{p}\n")
        if self.modes.transition is not None:
            T = np.array2string(self.modes.transition, precision=4)
            head += f"Transition T[k][i, j] = P(j next | i now):\n{T}\n"
        kind = self.info.get("controller")
        if kind:
            head += (f"Closed loop of a networked plant: controller={kind!r}, "
                     f"actuator={self.info.get('actuator')!r}\n")
        what = ("Mean system (exact E z for deterministic w)" if self.period == 1
                else "Mean system lifted over one period (dt = N·dt)")
        return head + what + ":\n" + ct.StateSpace.__str__(self.mean())


def _restore_jss(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray,
                 p: np.ndarray, dt: float | bool, nominal: np.ndarray | None,
                 name: str, inputs: list[str], outputs: list[str],
                 states: list[str], info: dict,
                 transition: np.ndarray | None = None) -> JumpStateSpace:
    return JumpStateSpace(A, B, C, D, p, dt, transition=transition,
                          nominal=nominal, name=name,
                          inputs=inputs, outputs=outputs, states=states,
                          info=info)


def _same_nominal(a: np.ndarray | None, b: np.ndarray | None) -> bool:
    """Whether two loss-free mode sequences (or their absence) agree."""
    if a is None or b is None:
        return a is b
    return bool(np.array_equal(a, b))


def _names(value: Any, count: int, prefix: str, argname: str) -> list[str]:
    if value is None:
        return [f"{prefix}[{i}]" for i in range(count)]
    if isinstance(value, str):
        value = [value] if count == 1 else [f"{value}[{i}]" for i in range(count)]
    names = [str(v) for v in value]
    if len(names) != count:
        raise ControlDimension(f"{argname}: expected {count} signal names, "
                               f"got {len(names)}")
    return names


def _merge_groups(mats: Sequence[np.ndarray], p: np.ndarray,
                  nominal: np.ndarray | None) -> tuple[list, np.ndarray | None]:
    """Per phase, lists of mode indices whose matrices coincide exactly.

    Modes of probability zero are dropped, except the loss-free one.
    """
    N, M = p.shape
    groups = []
    new_nominal = np.zeros(N, int)
    for k in range(N):
        phase: list[list[int]] = []
        for i in range(M):
            if p[k, i] == 0 and (nominal is None or nominal[k] != i):
                continue
            for g in phase:
                j = g[0]
                if all(np.array_equal(X[k, i], X[k, j]) for X in mats):
                    g.append(i)
                    break
            else:
                phase.append([i])
        if not phase:  # all-zero row cannot happen for valid probabilities
            phase = [[0]]
        if nominal is not None:
            new_nominal[k] = next(g for g, grp in enumerate(phase)
                                  if nominal[k] in grp)
        groups.append(phase)
    return groups, None if nominal is None else new_nominal


def _apply_groups(mats: Sequence[np.ndarray], p: np.ndarray, groups: list
                  ) -> tuple[list[np.ndarray], np.ndarray]:
    """Merged matrices and probabilities, padded with probability-0 copies."""
    N = p.shape[0]
    M = max(len(g) for g in groups)
    out = [np.zeros((N, M) + X.shape[2:]) for X in mats]
    prob = np.zeros((N, M))
    for k, phase in enumerate(groups):
        for slot in range(M):
            grp = phase[slot] if slot < len(phase) else phase[0]
            for X, Y in zip(mats, out):
                Y[k, slot] = X[k, grp[0]]
            prob[k, slot] = p[k, grp].sum() if slot < len(phase) else 0.0
    return out, prob


def jss(A: Any, B: Any, C: Any, D: Any, probabilities: Any = None,
        dt: Any = True, *, transition: Any = None, **kwargs: Any
        ) -> JumpStateSpace:
    """Create a periodic jump linear system from per-mode matrices.

    Parameters
    ----------
    A, B, C, D : array_like
        Per-mode matrices: a stack of shape ``(M, ., .)`` for ``N = 1``,
        ``(N, M, ., .)`` for period ``N``; a single matrix is shared by all
        modes.
    probabilities : array_like, shape (M,) or (N, M), optional
        Probability of each mode at each phase (i.i.d. in time). With a
        ``transition``: the law of the mode at time 0, shape ``(M,)``
        (default: the periodic stationary law).
    dt : True or float > 0, optional
        Sampling period (discrete time only; default True = unspecified).
    transition : array_like, shape (M, M) or (N, M, M), optional
        Markov modes (:ref:`theory-markov`):
        ``T[k][i, j] = P(σ[t+1] = j | σ[t] = i)`` at phase ``k``. Equal rows
        are exactly the i.i.d. system.
    **kwargs
        ``nominal`` (loss-free mode index per phase), ``name``, ``inputs``,
        ``outputs``, ``states`` (as for :class:`control.StateSpace`), and
        ``info`` (a dict kept on the result for reference, never read by
        analysis); anything else raises ``TypeError``.

    Returns
    -------
    JumpStateSpace

    Raises
    ------
    ValueError
        Complex, string, non-finite or overflowing (``> 1e150``) entries,
        probabilities outside ``[0, 1]`` or not summing to 1, a
        continuous-time ``dt``, or a period whose lifted face exceeds
        ``MAX_LIFTED_ENTRIES``.
    ControlDimension
        Inconsistent shapes, or no input or output.
    TypeError
        Unknown keyword.

    References
    ----------
    .. [1] O. L. V. Costa, M. D. Fragoso and R. P. Marques, *Discrete-Time
           Markov Jump Linear Systems*, Springer, 2005.

    Examples
    --------
    A scalar loop ``x⁺ = 2x + u`` with ``u = -2x`` applied with probability
    0.8 (else ``u = 0``) has mean ``x⁺ = 0.4 x``:

    >>> sys = jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]], [0.2, 0.8])
    >>> float(sys.A[0, 0])
    0.4

    The same modes driven by a Markov chain (bursts of mode 0): the mean
    face has one state per mode.

    >>> bursty = jss([[[2.0]], [[0.0]]], [[1.0]], [[1.0]], [[0.0]],
    ...              transition=[[0.5, 0.5], [0.125, 0.875]])
    >>> bursty.modes.is_iid, bursty.nstates, bursty.modes.probabilities.round(12).tolist()
    (False, 2, [[0.2, 0.8]])
    """
    return JumpStateSpace(A, B, C, D, probabilities, dt, transition=transition,
                          **kwargs)


def _markov_mean(modes: Modes) -> tuple[np.ndarray, ...]:
    """Per-phase mean system of Markov modes, state ``μ_i = E[ξ 1{σ = i}]``
    stacked by mode (:ref:`theory-markov`):
    ``μ⁺_j = Σ_i T[i, j] (A_i μ_i + π_i B_i w)``,
    ``E z = Σ_i (C_i μ_i + π_i D_i w)`` with ``π`` the stationary marginals."""
    A, B, C, D, p, T = (modes.A, modes.B, modes.C, modes.D,
                        modes.probabilities, modes.transitions())
    N, M, n, m = B.shape
    q = C.shape[2]
    Abar = np.einsum("kij,kiab->kjaib", T, A).reshape(N, M * n, M * n)
    Bbar = np.einsum("kij,ki,kiab->kjab", T, p, B).reshape(N, M * n, m)
    Cbar = C.transpose(0, 2, 1, 3).reshape(N, q, M * n)
    Dbar = np.einsum("ki,kiab->kab", p, D)
    return Abar, Bbar, Cbar, Dbar


class JumpPlant:
    """A periodic jump system before its gain is chosen
    (:ref:`theory-jump-system`).

    ``ξ⁺ = (A + Bu K_k E_k) ξ + Bw w``, ``z = (Cz + Du K_k E_k) ξ + Dw w``, all
    matrices per phase ``k`` and mode ``i``. ``E_k`` says what the controller
    knows of ``ξ``: for synthesis it must be a coordinate selection (each row
    a unit vector or zero). Network strategies build this object
    (``strategies.py``); :func:`control_ncs.passivesyn` designs ``K``;
    :meth:`close` applies it.

    Parameters
    ----------
    A, Bu, Bw, Cz, Du, Dw : array_like, shape (N, M, ., .)
        Per-phase, per-mode matrices of the loop before the gain: shapes
        ``(nx, nx)``, ``(nx, nu)``, ``(nx, nw)``, ``(nz, nx)``, ``(nz, nu)``,
        ``(nz, nw)``. Taken as they are (no broadcasting, no validation):
        builders such as :func:`control_ncs.build` check their inputs.
    E : array_like, shape (N, nk, nx)
        What the controller sees of ``ξ`` at each phase.
    probabilities : array_like, shape (N, M)
        Mode probabilities per phase; each row sums to 1.
    dt : True or float > 0, optional
        Sampling period of one step (default True, unspecified).
    nominal : array_like of int, shape (N,), optional
        The loss-free mode of each phase.
    transition : array_like, shape (N, M, M), optional
        Markov modes (:ref:`theory-markov`):
        ``T[k, i, j] = P(σ_{k+1} = j | σ_k = i)``; ``probabilities`` are then
        the stationary marginals. None: i.i.d.
    inputs, outputs, states : list of str, optional
        Names of ``w``, ``z`` and ``ξ``, handed to the closed loop.
    info : dict, optional
        Strategy description, kept as the ``info`` attribute.

    Attributes
    ----------
    A, Bu, Bw, Cz, Du, Dw : ndarray, shape (N, M, ., .)
        The matrices above, as float arrays.
    E : ndarray, shape (N, nk, nx)
        The selection of ``ξ`` that the gain acts on.
    probabilities : ndarray, shape (N, M)
        Mode probabilities per phase.
    transition : ndarray, shape (N, M, M), or None
        The Markov chain of the modes; None for i.i.d. modes.
    dt : True or float
        Sampling period of one step.
    nominal : ndarray of int, shape (N,), or None
        The loss-free mode of each phase.
    inputs, outputs, states : list of str or None
        Signal names of ``w``, ``z`` and ``ξ``.
    info : dict
        Strategy description (controller, actuator, network), for reference.

    Examples
    --------
    The scalar plant ``x⁺ = 2x + u`` whose actuator message is lost with
    probability 0.2, closed with ``u = -2x``:

    >>> P = nss([[2.0]], [[0.0, 1.0]], [[0.0], [1.0]],
    ...         [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1, actuator_loss=0.2)
    >>> plant = build(P)
    >>> plant.gain_shape(), plant.probabilities.tolist()
    ((1, 1, 1), [[0.0, 0.2, 0.0, 0.8]])
    >>> CL = plant.close(np.full((1, 1, 1), -2.0))
    >>> CL.modes.A[0, :, 0, 0].tolist(), CL.modes.probabilities.tolist()
    ([2.0, 0.0], [[0.2, 0.8]])
    """

    _FIELDS = ("A", "Bu", "Bw", "Cz", "Du", "Dw")

    def __init__(self, A: Any, Bu: Any, Bw: Any, Cz: Any, Du: Any, Dw: Any,
                 E: Any, probabilities: Any, dt: Any = True, *,
                 transition: Any = None,
                 nominal: Any = None, inputs: Any = None, outputs: Any = None,
                 states: Any = None, info: dict | None = None):
        self.A, self.Bu, self.Bw = (np.asarray(X, float) for X in (A, Bu, Bw))
        self.Cz, self.Du, self.Dw = (np.asarray(X, float) for X in (Cz, Du, Dw))
        self.E = np.asarray(E, float)
        self.probabilities = np.asarray(probabilities, float)
        self.transition = None if transition is None else np.asarray(
            transition, float)
        self.dt = dt
        self.nominal = None if nominal is None else np.asarray(nominal, int)
        self.inputs, self.outputs, self.states = inputs, outputs, states
        self.info = dict(info or {})

    @property
    def period(self) -> int:
        """Number of phases ``N``."""
        return self.probabilities.shape[0]

    @property
    def is_iid(self) -> bool:
        """True for i.i.d. modes; synthesis from ``probabilities`` alone
        (:ref:`theory-synthesis`) is valid only then."""
        return self.transition is None

    @property
    def shape(self) -> dict:
        """Sizes: ``nx`` (state), ``nw``, ``nz``, ``nu`` (control), ``nk``."""
        return dict(nx=self.A.shape[-1], nw=self.Bw.shape[-1],
                    nz=self.Cz.shape[-2], nu=self.Bu.shape[-1],
                    nk=self.E.shape[1])

    def gain_shape(self) -> tuple[int, int, int]:
        """Shape ``(N, nu, nk)`` of a gain sequence for :meth:`close`.

        Returns
        -------
        tuple of int
            ``(period, nu, nk)``.
        """
        s = self.shape
        return (self.period, s["nu"], s["nk"])

    def close(self, gains: np.ndarray, **info: Any) -> JumpStateSpace:
        """The closed loop with ``v = K_k E_k ξ`` as a :class:`JumpStateSpace`.

        The gain acts in positive feedback, as it is (``u = K x`` for
        ``E = I``); negate a gain designed for ``u = -K x``, such as
        :func:`control.dlqr`'s.

        Parameters
        ----------
        gains : array_like, shape (N, nu, nk)
            ``K_k`` per phase (:meth:`gain_shape`).
        **info
            Added to the result's ``info``.

        Returns
        -------
        JumpStateSpace
            Coinciding modes merged; named ``'<plant> (closed loop)'`` after
            ``info['plant']``, the plant's name, when the builder recorded
            it (as :func:`control_ncs.build` does).
        """
        K = np.asarray(gains, float)
        plant = self.info.get("plant")
        name = None if plant is None else f"{plant} (closed loop)"
        if K.ndim == 4:
            return self._close_pairs(K, name, info)
        F = np.einsum("kuj,kjx->kux", K, self.E)  # K_k E_k, per phase
        A = self.A + np.einsum("kmxu,kuy->kmxy", self.Bu, F)
        C = self.Cz + np.einsum("kmzu,kuy->kmzy", self.Du, F)
        loop = (A, self.Bw, C, self.Dw)
        if self.transition is not None:
            # Markov modes are not merged (their futures differ, theory: Markov
            # losses)
            return JumpStateSpace(*loop, None, self.dt,
                                  transition=self.transition,
                                  nominal=self.nominal,
                                  inputs=self.inputs, outputs=self.outputs,
                                  states=self.states, name=name,
                                  info=dict(self.info, gains=K, **info))
        # merge before building: the lifted face is then built once
        groups, nominal = _merge_groups(loop, self.probabilities, self.nominal)
        (A, B, C, D), p = _apply_groups(loop, self.probabilities, groups)
        return JumpStateSpace(A, B, C, D, p, self.dt, nominal=nominal,
                              inputs=self.inputs, outputs=self.outputs,
                              states=self.states, name=name,
                              info=dict(self.info, gains=K, **info))

    def transitions(self) -> np.ndarray:
        """``T[k, i, j] = P(σ_{k+1} = j | σ_k = i)``, shape (N, M, M).

        For i.i.d. modes every row of ``T[k]`` is ``probabilities[k + 1]``.

        Returns
        -------
        ndarray
        """
        if self.transition is not None:
            return self.transition
        M = self.probabilities.shape[1]
        nxt = np.roll(self.probabilities, -1, axis=0)
        return np.repeat(nxt[:, None, :], M, axis=1)

    def _close_pairs(self, K: np.ndarray, name: Any, info: dict
                     ) -> JumpStateSpace:
        """The closed loop with gains ``K_{k,ℓ}`` (shape (N, M, nu, nk)) on
        the previous mode ``ℓ = σ_{k-1}`` (:ref:`theory-markov`).

        A Markov jump system on pair modes ``(ℓ, i)``, ``(ℓ, i) → (i, j)``
        with probability ``T_k[i, j]``, mode matrices
        ``A_{k,i} + Bu_{k,i} K_{k,ℓ} E_k``. Pairs with the same ``i`` and
        the same matrices (e.g. every ``ℓ`` when the input is lost in
        ``i``) have the same future and are lumped into one mode; phases
        with fewer lumped modes repeat their last one, unreachable. The
        current plant mode ``i`` of each lumped mode is
        ``info['pair_modes']``, shape (N, G). The initial law is the
        stationary one.
        """
        N, M = self.probabilities.shape
        T = self.transitions()
        F = np.einsum("kluj,kjx->klux", K, self.E)  # K_{k,ℓ} E_k
        A = self.A[:, None] + np.einsum("kmxu,kluy->klmxy", self.Bu, F)
        C = self.Cz[:, None] + np.einsum("kmzu,kluy->klmzy", self.Du, F)
        # lumped mode of the pair (ℓ, i) at each phase; first member kept
        where: list = []
        groups: list = []
        for k in range(N):
            index: dict = {}
            where.append({})
            groups.append([])
            for i in range(M):
                for ell in range(M):
                    key = (i, A[k, ell, i].tobytes(), C[k, ell, i].tobytes())
                    if key not in index:
                        index[key] = len(groups[k])
                        groups[k].append((i, ell))
                    where[k][(ell, i)] = index[key]
        G = max(map(len, groups))
        # unreachable copies keep the shape (N, G): no flow enters them
        padded = [g + [g[-1]] * (G - len(g)) for g in groups]
        cur = np.array([[i for i, _ in g] for g in padded])
        Ap = np.array([[A[k, ell, i] for i, ell in g]
                       for k, g in enumerate(padded)])
        Cp = np.array([[C[k, ell, i] for i, ell in g]
                       for k, g in enumerate(padded)])
        Bp = np.array([[self.Bw[k, i] for i, _ in g]
                       for k, g in enumerate(padded)])
        Dp = np.array([[self.Dw[k, i] for i, _ in g]
                       for k, g in enumerate(padded)])
        Tp = np.zeros((N, G, G))
        for k in range(N):
            for s, (i, _) in enumerate(padded[k]):
                for j in range(M):
                    Tp[k, s, where[(k + 1) % N][(i, j)]] += T[k, i, j]
        nominal = None
        if self.nominal is not None:
            # the loss-free mode reached from the loss-free mode
            nominal = [where[k][(self.nominal[k - 1], self.nominal[k])]
                       for k in range(N)]
        return JumpStateSpace(Ap, Bp, Cp, Dp, None, self.dt, transition=Tp,
                              nominal=nominal, inputs=self.inputs,
                              outputs=self.outputs, states=self.states,
                              name=name,
                              info=dict(self.info, gains=K, pair_modes=cur,
                                        **info))

    def merged(self) -> "JumpPlant":
        """The same plant with coinciding modes merged
        (:ref:`theory-synthesis`, merged form).

        Returns
        -------
        JumpPlant
            Same ``E``, fewer modes where modes coincide.
        """
        if self.transition is not None:
            return self  # Markov modes are not merged (theory: Markov losses)
        mats = [getattr(self, f) for f in self._FIELDS]
        groups, nominal = _merge_groups(mats, self.probabilities, self.nominal)
        (A, Bu, Bw, Cz, Du, Dw), p = _apply_groups(mats, self.probabilities,
                                                   groups)
        return JumpPlant(A, Bu, Bw, Cz, Du, Dw, self.E, p, self.dt, nominal=nominal,
                         inputs=self.inputs, outputs=self.outputs,
                         states=self.states, info=self.info)

    def mean(self) -> tuple[np.ndarray, ...]:
        """Per-phase mean matrices ``Σ_i p_ki X_ki`` of every field.

        Returns
        -------
        A, Bu, Bw, Cz, Du, Dw : ndarray, each shape (N, ., .)
            In the order of the attributes, as :meth:`Modes.mean`.
        """
        p = self.probabilities
        return tuple(np.einsum("km,kmij->kij", p, getattr(self, f))
                     for f in self._FIELDS)

    def known_coordinates(self, k: int) -> np.ndarray:
        """Coordinates of ``ξ`` the controller sees at phase ``k``.

        Parameters
        ----------
        k : int
            Time step or phase; taken modulo the period.

        Returns
        -------
        ndarray of int
            Indices of the columns of ``E_k`` that are not zero.
        """
        return np.flatnonzero(np.any(self.E[k % self.period] != 0, axis=0))

    def active_inputs(self, k: int) -> np.ndarray:
        """Control inputs that can act at phase ``k`` (others are never applied).

        Parameters
        ----------
        k : int
            Time step or phase; taken modulo the period.

        Returns
        -------
        ndarray of int
            Indices of the columns of ``Bu`` or ``Du`` nonzero in some mode.
        """
        k %= self.period
        used = np.any(self.Bu[k] != 0, axis=(0, 1)) | np.any(self.Du[k] != 0,
                                                             axis=(0, 1))
        return np.flatnonzero(used)

    def is_selection(self) -> bool:
        """True when every ``E_k`` is a 0/1 coordinate selection.

        Returns
        -------
        bool
            Whether each row and each column of every ``E_k`` holds at most
            one 1 and otherwise zeros (required by synthesis).
        """
        E = self.E
        binary = np.all((E == 0) | (E == 1))
        return bool(binary and np.all(E.sum(axis=2) <= 1)
                    and np.all(E.sum(axis=1) <= 1))

    def __repr__(self) -> str:
        s = self.shape
        return (f"<JumpPlant: {s['nx']} states, {s['nw']} w, {s['nz']} z, "
                f"{s['nu']} u, period {self.period}, "
                f"{self.probabilities.shape[1]} modes, info={self.info}>")


def require_iid(sys: Any, what: str, name: str = "sys") -> None:
    """Refuse Markov modes where only the i.i.d. formulas exist yet.

    For the analyses and syntheses written from ``probabilities`` alone
    (:ref:`theory-passivity`, :ref:`theory-synthesis`): on a Markov system they
    would silently answer for i.i.d. modes with the stationary marginals, which
    is wrong (:ref:`theory-markov`).

    Parameters
    ----------
    sys : JumpStateSpace or JumpPlant
    what : str
        The caller's name, for the message.
    name : str
        The argument's name, for the message.

    Raises
    ------
    ControlArgument
        If ``sys`` has Markov modes.
    """
    modes = getattr(sys, "modes", sys)
    if getattr(modes, "transition", None) is not None:
        from control.exception import ControlArgument
        raise ControlArgument(
            f"{what}: {name} has Markov (bursty) modes; {what} is written for "
            f"i.i.d. losses only and would answer for the stationary "
            f"marginals, which is wrong for bursts (theory: Markov losses). Exact "
            f"mean-square analysis works: ms_radius, moments, simulate")


def as_jump(sys: Any, name: str = "sys") -> JumpStateSpace:
    """``sys`` as a :class:`JumpStateSpace`; a deterministic discrete-time
    :class:`control.StateSpace` (or :class:`control.TransferFunction`,
    converted with :func:`control.ss`, as python-control does) becomes a
    one-mode jump system."""
    if isinstance(sys, JumpStateSpace):
        return sys
    from control.exception import ControlArgument
    from .plant import NetworkedStateSpace  # plant.py builds on jump.py
    if isinstance(sys, NetworkedStateSpace):
        # its StateSpace face is the plant without its network: analysing it
        # as a deterministic system would silently drop every loss
        raise ControlArgument(
            f"{name}: got a NetworkedStateSpace, a plant with its network but "
            f"no loop; close it first with control_ncs.feedback(P, K), or "
            f"pass ct.ss(P) to analyse the plant without its network")
    if isinstance(sys, ct.TransferFunction):
        sys = ct.ss(sys)
    if isinstance(sys, ct.StateSpace):
        dt = discrete_dt(sys.dt, f"{name}.dt")
        return JumpStateSpace(sys.A[None], sys.B[None], sys.C[None],
                              sys.D[None], [1.0], dt, nominal=[0],
                              inputs=list(sys.input_labels),
                              outputs=list(sys.output_labels),
                              states=list(sys.state_labels), name=sys.name)
    raise ControlArgument(f"{name}: expected a JumpStateSpace (see jss() or "
                          f"control_ncs.feedback()) or a discrete-time "
                          f"control.StateSpace or TransferFunction, got "
                          f"{type(sys).__name__}")
