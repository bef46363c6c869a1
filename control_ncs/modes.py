"""The mode chain of a jump system and its law (:ref:`theory-jump-system`,
:ref:`theory-markov`).

A jump system's modes are drawn per phase ``k`` either independently
(``probabilities[k, i]``) or by a Markov chain with transitions ``T[k]``
and an initial law. This module owns that law: its checks, the periodic
stationary marginals of a chain, the merging of modes whose matrices
coincide, and the Markov mean system (state ``E[ξ 1{σ = i}]`` per mode).
It knows nothing of plants, networks or gains.

i.i.d. modes are the case where every row of ``T[k]`` equals the law of
phase ``k + 1``: such a transition is stored as ``None``, so that every
i.i.d. number is computed by the i.i.d. formulas. Code that reads only
``probabilities`` must first test :attr:`Modes.is_iid`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
from control.exception import ControlDimension
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ._checks import real_array

__all__ = ["Modes"]

_PROB_TOL = 1e-9


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

    >>> m = ncs.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7]).modes
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
        >>> m = ncs.jss([[[0.5]], [[0.9]]], [[1.0]], [[1.0]], [[0.0]], [0.3, 0.7]).modes
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



def check_probabilities(value: Any, name: str = "probabilities") -> np.ndarray:
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



def chain_law(transition: Any, initial: Any, N: int, M: int | None
           ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """``(probabilities, transition, initial)`` of a Markov jump system;
    equal rows give the i.i.d. system (transition None) unless ``initial``
    differs from its law."""
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
        init = check_probabilities(initial, "probabilities")
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



def merge_groups(mats: Sequence[np.ndarray], p: np.ndarray,
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


def markov_classes(mats: Sequence[np.ndarray], T: np.ndarray,
                   decimals: int = 12) -> list[np.ndarray]:
    """The coarsest exact lumping of a periodic chain's modes: per phase
    ``k``, the class of each mode (an int array of length M, classes
    numbered from 0 by first member).

    Two modes of a phase share a class when their matrices (every
    ``X[k, i]`` of ``mats``) coincide exactly and they move into every
    class of the next phase with the same probability (strong
    lumpability, :ref:`theory-markov`). The second moments summed over a
    class then follow the lumped chain: the state process is the same,
    so every mean, moment and mean-square figure is unchanged. The
    partition is refined from the matrices' classes until no class
    splits; probabilities equal to ``decimals`` places are equal (sums in
    another order).
    """
    N, M = T.shape[:2]
    labels = []
    for k in range(N):
        index: dict = {}
        keys = [b"".join(np.ascontiguousarray(X[k, i]).tobytes()
                         for X in mats) for i in range(M)]
        labels.append(np.array([index.setdefault(key, len(index))
                                for key in keys]))
    counts = [int(lab.max()) + 1 for lab in labels]
    while True:
        new = []
        for k in range(N):
            nxt = labels[(k + 1) % N]
            into = np.zeros((M, int(nxt.max()) + 1))
            np.add.at(into.T, nxt, T[k].T)          # mass into each class
            sig = np.column_stack([labels[k], np.round(into, decimals)])
            _, first, lab = np.unique(sig, axis=0, return_index=True,
                                      return_inverse=True)
            # number classes by their first member: stable, readable
            order = np.argsort(np.argsort(first))
            new.append(order[lab.ravel()])
        labels = new
        now = [int(lab.max()) + 1 for lab in labels]
        if now == counts:
            return labels
        counts = now


def lump_markov(mats: Sequence[np.ndarray], T: np.ndarray, p: np.ndarray,
                labels: list[np.ndarray]
                ) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """The lumped chain of :func:`markov_classes`: matrices of each class's
    first member, its transitions into classes and the classes'
    marginals. Phases with fewer classes repeat their first class as a
    copy no mode moves into (probability 0)."""
    N = T.shape[0]
    G = max(int(lab.max()) + 1 for lab in labels)
    first = _padded([np.unique(lab, return_index=True)[1] for lab in labels],
                    G)
    out = _picked(mats, first)
    TL = np.zeros((N, G, G))
    prob = np.zeros((N, G))
    for k in range(N):
        nxt = labels[(k + 1) % N]
        rows = T[k, first[k]]
        np.add.at(TL[k].T, nxt, rows.T)
        np.add.at(prob[k], labels[k], p[k])
    return out, TL, prob


def _padded(index: list[np.ndarray], G: int) -> list[np.ndarray]:
    """Mode indices per phase, each padded to ``G`` by repeating its first
    (a copy no mode moves into, probability 0)."""
    return [np.concatenate([ix, np.full(G - ix.size, ix[0])])
            for ix in index]


def _picked(mats: Sequence[np.ndarray], index: list[np.ndarray]
            ) -> list[np.ndarray]:
    """Every ``X`` of ``mats`` with the modes ``index[k]`` at phase ``k``."""
    return [np.stack([X[k, ix] for k, ix in enumerate(index)]) for X in mats]


def entered_modes(T: np.ndarray, always: np.ndarray | None = None
                  ) -> np.ndarray:
    """The modes a periodic chain can occupy after any number of steps:
    ``keep[k, j]`` is False when no kept mode of phase ``k - 1`` moves into
    mode ``j`` of phase ``k`` (repeated until nothing changes).

    A mode left out is occupied at most at the first step, and never under
    a law that gives it probability 0 (the stationary one): its second
    moment vanishes after one step, a zero diagonal block of the operator
    (:ref:`theory-markov`), so every mean, moment and mean-square figure of
    the chain without it is unchanged. ``always`` (shape (N,), a mode per
    phase, e.g. the loss-free one) is kept whatever enters it.
    """
    N, M = T.shape[:2]
    keep = np.ones((N, M), bool)
    while True:
        entered = np.stack([np.any(T[k - 1][keep[k - 1]] > 0, axis=0)
                            for k in range(N)])
        if always is not None:
            entered[np.arange(N), always] = True
        new = keep & entered
        if np.array_equal(new, keep):
            return keep
        keep = new


def keep_modes(mats: Sequence[np.ndarray], T: np.ndarray, p: np.ndarray,
               keep: np.ndarray) -> tuple[list[np.ndarray], np.ndarray,
                                          np.ndarray, list[np.ndarray]]:
    """The chain on the modes ``keep`` (:func:`entered_modes`) marks: every
    ``X[k]`` of ``mats``, ``T`` and ``p`` restricted to them, and the old
    index of each new mode per phase. Phases with fewer modes repeat their
    first kept mode as a copy no mode moves into (probability 0), as
    :func:`lump_markov` pads."""
    N = T.shape[0]
    G = int(keep.sum(axis=1).max())
    index = _padded([np.flatnonzero(keep[k]) for k in range(N)], G)
    out = _picked(mats, index)
    TK = np.zeros((N, G, G))
    prob = np.zeros((N, G))
    for k in range(N):
        nxt = index[(k + 1) % N]
        real = int(keep[(k + 1) % N].sum())
        TK[k][:, :real] = T[k][np.ix_(index[k], nxt[:real])]
        real_k = int(keep[k].sum())
        prob[k, :real_k] = p[k, index[k][:real_k]]
    return out, TK, prob, index


def join_labels(observed: np.ndarray, labels: list[np.ndarray]
                ) -> np.ndarray:
    """What a controller knows of the previous lumped mode: ``observed[k,
    i]`` labels the mode ``i`` of phase ``k - 1``; a class of
    :func:`markov_classes` holding modes of several labels joins them (the
    coarsest labels constant on every class), per lumped class, padded
    like :func:`lump_markov`."""
    N = observed.shape[0]
    G = max(int(lab.max()) + 1 for lab in labels)
    out = np.zeros((N, G), int)
    for k in range(N):
        lab = labels[(k - 1) % N]
        # classes and labels as one graph, an edge per mode: its
        # components are the joined labels
        C = int(lab.max()) + 1
        _, o = np.unique(observed[k], return_inverse=True)
        graph = coo_matrix((np.ones(lab.size), (lab, C + o.ravel())),
                           shape=(C + o.max() + 1,) * 2)
        comp = connected_components(graph, directed=False)[1][:C]
        joined = np.unique(comp, return_inverse=True)[1].ravel()
        out[k, :C] = joined
        out[k, C:] = joined[0]
    return out


def apply_groups(mats: Sequence[np.ndarray], p: np.ndarray, groups: list
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



def markov_mean(modes: Modes) -> tuple[np.ndarray, ...]:
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


def transition_matrix(value: Any, name: str) -> np.ndarray:
    """A row-stochastic matrix (or stack), checked: finite, non-negative,
    rows summing to one."""
    if np.iscomplexobj(value):
        raise ValueError(f"{name}: a transition matrix needs real entries "
                         f"(got complex ones)")
    try:
        T = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a real transition matrix, got "
                         f"{value!r}") from None
    if T.dtype == object or not np.all(np.isfinite(T)):
        raise ValueError(f"{name}: a transition matrix needs finite real entries")
    if np.any(T < -_PROB_TOL):
        raise ValueError(f"{name}: transition probabilities must be "
                         f"non-negative, got a minimum {T.min():g}")
    sums = T.sum(axis=-1)
    if not np.allclose(sums, 1.0, atol=_PROB_TOL, rtol=0):
        raise ValueError(f"{name}: each row of a transition matrix must sum "
                         f"to 1, got row sums {np.round(sums, 12).tolist()}")
    return np.clip(T, 0.0, 1.0)


def mode_classes(T_prev: np.ndarray) -> tuple[np.ndarray, list]:
    """Previous modes ``ℓ`` grouped by equal rows ``T_{k-1}[ℓ]``.

    Their blocks ``Θ_{k,ℓ}`` coincide (:ref:`theory-markov`), so they share the
    variables ``X_{k,ℓ}``, ``Y_{k,ℓ}``. Returns the class of each ``ℓ`` and
    a representative mode per class.
    """
    labels = np.empty(T_prev.shape[0], int)
    reps: list = []
    for ell, row in enumerate(T_prev):
        for c, r in enumerate(reps):
            if np.array_equal(row, T_prev[r]):
                labels[ell] = c
                break
        else:
            labels[ell] = len(reps)
            reps.append(ell)
    return labels, reps


def age_chain(pmf: np.ndarray, buffer: int, sent: np.ndarray | None = None
              ) -> np.ndarray:
    """The age of the freshest packet held, as a periodic Markov chain.

    Every packet carries its send time; its delay ``δ`` has pmf
    ``pmf[c] = P(δ = c)``, ``c = 0..d``, i.i.d. per packet, and
    ``1 - Σ pmf`` is the loss. The receiver uses the newest packet it holds.
    With the hazard ``h(c) = pmf[c] / P(δ ≥ c)`` (0 for ``c > d``, and 0 for
    a packet that was never sent), the packets that can replace the one of
    age ``a`` at the next step are those of ages ``0..a`` then, none of
    which has arrived yet (:ref:`theory-delays`)::

        P(a⁺ = b | a) = h(b) Π_{c<b} (1 - h(c))     b ≤ a
        P(a⁺ = a + 1 | a) = Π_{c≤a} (1 - h(c))

    Ages above ``buffer`` are one "stale" state (nothing usable).

    Parameters
    ----------
    pmf : ndarray, shape (d + 1,)
        The delay pmf, checked by the caller (non-negative, sum ≤ 1).
    buffer : int
        The largest age kept, ``≥ d``.
    sent : ndarray of bool, shape (N,), optional
        Whether a packet is sent at each phase of a schedule (default: at
        every step, ``N = 1``).

    Returns
    -------
    ndarray, shape (N, buffer + 2, buffer + 2)
        ``T[k][a, b] = P(a_{k+1} = b | a_k = a)``; states ``0..buffer``,
        then stale.
    """
    pmf = np.asarray(pmf, float)
    sent = np.ones(1, bool) if sent is None else np.asarray(sent, bool)
    N, D = sent.size, int(buffer)
    tail = 1.0 - np.concatenate(([0.0], np.cumsum(pmf)))[:pmf.size]
    hazard = np.zeros(D + 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        h = np.where(tail > 0, pmf / np.where(tail > 0, tail, 1.0), 0.0)
    hazard[:min(h.size, D + 1)] = np.clip(h[:D + 1], 0.0, 1.0)
    T = np.zeros((N, D + 2, D + 2))
    for k in range(N):
        # the packet of age c at step k + 1 was sent at phase k + 1 - c
        hk = np.array([hazard[c] if sent[(k + 1 - c) % N] else 0.0
                       for c in range(D + 1)])
        waiting = np.concatenate(([1.0], np.cumprod(1.0 - hk)))
        arrive = hk * waiting[:-1]            # b is the freshest arrival
        for a in range(D + 2):
            top = min(a, D)                   # candidates: ages 0..a (≤ D)
            T[k, a, :top + 1] = arrive[:top + 1]
            T[k, a, min(a + 1, D + 1)] += waiting[top + 1]
    return T
