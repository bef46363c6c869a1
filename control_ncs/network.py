"""Communication schedules and loss models (:ref:`theory-conventions`,
:ref:`theory-network`, :ref:`theory-markov`).

A schedule says, for each phase ``k`` of a period ``N``, which sensors (or
actuators) may send. A loss model says how likely a message is to be lost:
Bernoulli (a float, i.i.d. losses) or Gilbert–Elliott (a two-state Markov
chain, losses in bursts). Together they give the probabilities of the four
network modes of paper eq. 14 and, for bursty links, their joint transition
matrix. Nothing here knows about plants or controllers.
"""

from __future__ import annotations

import math
import warnings
from typing import Any, Sequence

import numpy as np

from ._checks import caller_stacklevel, real_or_nan
from .automata import LossAutomaton
from .exceptions import ScheduleWarning
from .modes import transition_matrix

__all__ = ["Schedule", "schedule", "mode_probabilities", "GilbertElliott",
           "gilbert_elliott", "mode_transition"]


class Schedule:
    """Periodic access pattern of a set of network nodes.

    A schedule of ``nodes`` sensors (or actuators) with period ``N`` is a 0/1
    matrix ``pattern`` of shape ``(N, nodes)``: ``pattern[k, i] = 1`` when
    node ``i`` may send at every time ``t`` with ``t mod N = k``.

    Use :func:`schedule` to build one from the paper's index vectors.

    Parameters
    ----------
    pattern : array_like of 0/1, shape (N, nodes)
        Which nodes may send at each phase.
    name : str, optional
        What the schedule is of (``'sensor_schedule'``), used in messages.

    Attributes
    ----------
    pattern : ndarray of bool, shape (N, nodes)
        The access pattern (read-only).
    period : int
        Number of phases ``N``.
    nodes : int
        Number of sensors or actuators.
    name : str
        What the schedule is of, as given.

    Examples
    --------
    Two sensors sending in turn, then a silent phase:

    >>> S = ncs.Schedule([[1, 0], [0, 1], [0, 0]], "sensor_schedule")
    >>> S.period, S.nodes, S.senders(1).tolist(), S.senders(2).tolist()
    (3, 2, [1], [])
    >>> S == ncs.schedule([1, 2, 0], 2)
    True
    """

    def __init__(self, pattern: Any, name: str = "schedule"):
        pattern = np.asarray(pattern)
        if pattern.ndim != 2 or pattern.shape[0] < 1:
            raise ValueError(
                f"{name}: expected a 0/1 matrix of shape (N, nodes) with N >= 1, "
                f"got shape {pattern.shape}")
        if not np.all((pattern == 0) | (pattern == 1)):
            raise ValueError(f"{name}: a schedule matrix must contain only 0 and 1")
        self.pattern = pattern.astype(bool)
        self.pattern.flags.writeable = False
        self.name = name

    @property
    def period(self) -> int:
        """Number of phases ``N``."""
        return self.pattern.shape[0]

    @property
    def nodes(self) -> int:
        """Number of sensors or actuators."""
        return self.pattern.shape[1]

    @property
    def is_everyone(self) -> bool:
        """True when every node may send at every phase (no scheduling)."""
        return bool(self.pattern.all())

    def selection(self, k: int) -> np.ndarray:
        """Diagonal 0/1 selection matrix ``Σ_k`` of phase ``k mod N``.

        Parameters
        ----------
        k : int
            Time step or phase; taken modulo the period.

        Returns
        -------
        ndarray, shape (nodes, nodes)
            Ones on the diagonal for the nodes that may send.

        Examples
        --------
        >>> ncs.Schedule([[1, 0], [0, 1]]).selection(1).tolist()
        [[0.0, 0.0], [0.0, 1.0]]
        """
        return np.diag(self.pattern[k % self.period].astype(float))

    def senders(self, k: int) -> np.ndarray:
        """Indices (0-based) of the nodes that may send at time ``k``.

        Parameters
        ----------
        k : int
            Time step or phase; taken modulo the period.

        Returns
        -------
        ndarray of int
            The senders, in increasing order (empty if nobody sends).

        Examples
        --------
        >>> ncs.Schedule([[1, 0], [0, 1]]).senders(3).tolist()
        [1]
        """
        return np.flatnonzero(self.pattern[k % self.period])

    def repeat(self, period: int) -> "Schedule":
        """The schedule written over ``period`` phases (a multiple of N).

        Parameters
        ----------
        period : int
            The new number of phases; a multiple of :attr:`period`.

        Returns
        -------
        Schedule
            The pattern tiled ``period // N`` times.

        Raises
        ------
        ValueError
            If ``period`` is not a multiple of :attr:`period`.

        Examples
        --------
        >>> ncs.Schedule([[1, 0], [0, 1]]).repeat(4).period
        4
        """
        if period % self.period:
            raise ValueError(f"{self.name}: period {period} is not a multiple of "
                             f"{self.period}")
        return Schedule(np.tile(self.pattern, (period // self.period, 1)), self.name)

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, Schedule)
                and np.array_equal(self.pattern, other.pattern))

    def __hash__(self) -> int:
        return hash(self.pattern.tobytes())

    def __repr__(self) -> str:
        if self.pattern.size <= 64:
            return f"Schedule({self.pattern.astype(int).tolist()!r})"
        return (f"<Schedule {self.name}: period {self.period}, {self.nodes} "
                f"nodes, {int(self.pattern.sum())} send slots>")

    def summary(self) -> str:
        """A few lines for humans: who may send at each phase.

        Returns
        -------
        str
            One line per phase (at most 20; longer periods are elided), then
            the nodes that never send, if any.

        Examples
        --------
        >>> print(ncs.schedule([2, 1, 0], 2, "sensor_schedule").summary())
        Schedule sensor_schedule: period 3, 2 nodes (1-based)
          phase 0: 2
          phase 1: 1
          phase 2: nobody
        """
        lines = [f"Schedule {self.name}: period {self.period}, {self.nodes} "
                 f"nodes (1-based)"]
        shown = range(self.period) if self.period <= 20 else \
            list(range(10)) + list(range(self.period - 9, self.period))
        for k in shown:
            if k == self.period - 9 and self.period > 20:
                lines.append("  ...")
            who = self.senders(k) + 1
            lines.append(f"  phase {k}: "
                         f"{', '.join(map(str, who)) if who.size else 'nobody'}")
        silent = np.flatnonzero(~self.pattern.any(axis=0)) + 1
        if silent.size:
            lines.append(f"  never send: {', '.join(map(str, silent))}")
        return "\n".join(lines)

    def __reduce__(self) -> tuple:
        return (Schedule, (self.pattern.astype(int), self.name))


def schedule(spec: Any, nodes: int, name: str = "schedule") -> Schedule:
    """Build a :class:`Schedule` from any of the accepted descriptions.

    Parameters
    ----------
    spec : None, Schedule, 1-D sequence of int, or 2-D 0/1 array
        * ``None``: every node sends at every step (period 1).
        * The paper's index vector ``s`` of length ``N``: at phase ``k`` node
          ``s[k]`` (1-based) may send; ``0`` means nobody.
        * A 0/1 (or boolean) matrix of shape ``(N, nodes)``: several nodes
          per phase.
    nodes : int
        Number of sensors (``p2``) or actuators (``m2``).
    name : str
        Argument name used in error messages.

    Returns
    -------
    Schedule

    Raises
    ------
    ValueError
        If an index is out of ``0..nodes`` or a matrix has the wrong width
        (or rows of unequal width).

    Examples
    --------
    The paper's example, ``N = 4``, ``s1 = [2, 1, 0, 2]``:

    >>> s = ncs.schedule([2, 1, 0, 2], nodes=2)
    >>> [s.senders(k).tolist() for k in range(7)]
    [[1], [0], [], [1], [1], [0], []]
    """
    if spec is None:
        return Schedule(np.ones((1, nodes), dtype=int), name)
    if isinstance(spec, Schedule):
        if spec.nodes != nodes:
            raise ValueError(f"{name}: schedule is for {spec.nodes} nodes, "
                             f"expected {nodes}")
        return Schedule(spec.pattern.astype(int), name)
    try:
        arr = np.asarray(spec)
    except ValueError:  # ragged rows: numpy cannot even form the array
        raise ValueError(f"{name}: a schedule matrix needs rows of equal "
                         f"width ({nodes} columns, one per node), got "
                         f"{spec!r}") from None
    if arr.dtype == bool and arr.ndim == 2:
        arr = arr.astype(int)  # a boolean matrix is a 0/1 matrix
    if arr.dtype == object or arr.dtype.kind not in "biuf":
        raise ValueError(f"{name}: expected None, an index vector or a 0/1 "
                         f"matrix, got {spec!r}")
    if arr.ndim == 1:
        if arr.size == 0:
            raise ValueError(f"{name}: an index vector needs at least one entry")
        if not np.all(np.equal(np.mod(arr, 1), 0)):
            raise ValueError(f"{name}: index vector entries must be integers")
        idx = arr.astype(int)
        if idx.min() < 0 or idx.max() > nodes:
            raise ValueError(
                f"{name}: index vector entries must lie in 0..{nodes} "
                f"(0 = nobody, i = node i, 1-based), got {idx.tolist()}")
        pattern = np.zeros((idx.size, nodes), dtype=int)
        for k, i in enumerate(idx):
            if i > 0:
                pattern[k, i - 1] = 1
        return Schedule(pattern, name)
    if arr.ndim == 2:
        if arr.shape[1] != nodes:
            raise ValueError(f"{name}: a schedule matrix needs {nodes} columns "
                             f"(one per node), got shape {arr.shape}")
        return Schedule(arr, name)
    raise ValueError(f"{name}: expected None, an index vector or a 0/1 matrix, "
                     f"got an array of {arr.ndim} dimensions")


def warn_silent_nodes(S: Schedule, what: str, labels: Sequence[str]) -> None:
    """Warn (:class:`~control_ncs.exceptions.ScheduleWarning`) about nodes
    that no phase of ``S`` lets send, naming them.

    Parameters
    ----------
    S : Schedule
    what : str
        ``'sensor'`` or ``'actuator'``.
    labels : sequence of str
        Signal of each node (``y[i]`` or ``u[i]``), for the message.
    """
    silent = np.flatnonzero(~S.pattern.any(axis=0))
    if silent.size == 0:
        return
    named = ", ".join(f"{what} {i + 1} ({labels[int(i)]})" for i in silent)
    verb, it = ("never sends", "it") if silent.size == 1 else \
        ("never send", "them")
    example = ", ".join(str(i) for i in range(S.nodes))
    warnings.warn(
        f"{S.name}: {named} {verb}: no phase of the schedule (period "
        f"{S.period}) lets {it}. In an index vector 0 means nobody and "
        f"{what}s are numbered 1..{S.nodes} (so [{example}] never schedules "
        f"{what} {S.nodes}); write 1-based indices, or pass a 0/1 matrix",
        ScheduleWarning, stacklevel=caller_stacklevel())


def common_period(*schedules: Schedule) -> int:
    """Least common multiple of the periods (:ref:`theory-network`)."""
    return math.lcm(*(s.period for s in schedules))


def loss_probability(value: Any, name: str) -> float:
    """Validate a Bernoulli loss probability ``P(θ = 0)`` in [0, 1]."""
    alpha = real_or_nan(value)
    if not 0.0 <= alpha <= 1.0:  # also rejects nan (a bool, str, complex)
        raise ValueError(f"{name}: expected a probability in [0, 1] (a real "
                         f"number), got {value!r}")
    return alpha


def mode_probabilities(sensor_loss: float, actuator_loss: float) -> dict:
    """Probabilities of the four network modes (paper eq. 14).

    Parameters
    ----------
    sensor_loss : float
        ``α1 = P(θ1 = 0)``, loss probability sensor → controller.
    actuator_loss : float
        ``α2 = P(θ2 = 0)``, loss probability controller → actuator.

    Returns
    -------
    dict
        ``{(θ1, θ2): probability}`` for ``θ1, θ2 ∈ {0, 1}`` (1 = arrived).

    References
    ----------
    .. [1] B. Riyanto and I. Arifin, *Positive Real Synthesis of Networked
           Control System: An LMI Approach* (the seed paper; its errors and
           their corrections: :ref:`errata`).

    Examples
    --------
    >>> p = ncs.mode_probabilities(0.1, 0.2)
    >>> round(p[(1, 1)], 12), round(sum(p.values()), 12)
    (0.72, 1.0)
    """
    a1 = loss_probability(sensor_loss, "sensor_loss")
    a2 = loss_probability(actuator_loss, "actuator_loss")
    return {(0, 0): a1 * a2, (1, 0): (1 - a1) * a2,
            (0, 1): a1 * (1 - a2), (1, 1): (1 - a1) * (1 - a2)}


class GilbertElliott:
    """A link that loses packets in bursts: a two-state Markov chain.

    (:ref:`theory-markov`.)

    ``θ = 0`` (lost) or ``1`` (delivered); ``P(θ⁺ = 0 | θ = 1) = fail``,
    ``P(θ⁺ = 1 | θ = 0) = recover``. Build one with :func:`gilbert_elliott`.

    Attributes
    ----------
    fail, recover : float
        ``f`` and ``r``, both in ``(0, 1]``.
    loss : float
        Stationary loss probability ``f / (f + r)``.
    burst : float
        Mean length of a run of losses, ``1 / r``.
    transition : ndarray, shape (2, 2)
        ``T[a, b] = P(θ⁺ = b | θ = a)``, state order (lost, delivered).
    is_bernoulli : bool
        Equal rows (``f + r = 1``): i.i.d. losses with probability ``loss``.

    Examples
    --------
    >>> link = ncs.gilbert_elliott(fail=0.05, recover=0.75)
    >>> round(link.loss, 6), round(link.burst, 6)
    (0.0625, 1.333333)
    >>> link.transition.tolist()
    [[0.25, 0.75], [0.05, 0.95]]
    """

    def __init__(self, fail: float, recover: float):
        self.fail = _rate(fail, "fail")
        self.recover = _rate(recover, "recover")

    @property
    def loss(self) -> float:
        """Stationary loss probability ``f / (f + r)``."""
        if self.is_bernoulli:
            return self.fail  # exactly the Bernoulli α = f = 1 - r
        return self.fail / (self.fail + self.recover)

    @property
    def burst(self) -> float:
        """Mean burst length ``1 / r`` (steps)."""
        return 1.0 / self.recover

    @property
    def transition(self) -> np.ndarray:
        """``T[a, b] = P(θ⁺ = b | θ = a)``, order (lost, delivered)."""
        f, r = self.fail, self.recover
        if self.is_bernoulli:
            return np.array([[f, 1.0 - f], [f, 1.0 - f]])
        return np.array([[1.0 - r, r], [f, 1.0 - f]])

    @property
    def is_bernoulli(self) -> bool:
        """True when ``f + r = 1`` (to rounding): i.i.d. losses.

        Equal rows: losses with probability ``f``, independent."""
        return bool(abs(self.fail + self.recover - 1.0)
                    <= 4 * np.finfo(float).eps)

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, GilbertElliott) and self.fail == other.fail
                and self.recover == other.recover)

    def __hash__(self) -> int:
        return hash((self.fail, self.recover))

    def __repr__(self) -> str:
        return (f"GilbertElliott(fail={self.fail:g}, recover={self.recover:g}; "
                f"loss={self.loss:.4g}, burst={self.burst:.4g})")

    def __reduce__(self) -> tuple:
        return (GilbertElliott, (self.fail, self.recover))


def _rate(value: Any, name: str) -> float:
    x = real_or_nan(value)
    if not 0.0 < x <= 1.0:
        extra = (" (a link with recover = 0 never recovers)"
                 if name == "recover" and x == 0 else "")
        raise ValueError(f"{name}: expected a probability in (0, 1]{extra}, "
                         f"got {value!r}")
    return x


def gilbert_elliott(fail: float | None = None, recover: float | None = None,
                    *, loss: float | None = None, burst: float | None = None
                    ) -> GilbertElliott:
    """A bursty (Gilbert–Elliott) link, by rates or loss and burst.

    Give either ``fail`` and ``recover``, or ``loss`` and ``burst``.

    Parameters
    ----------
    fail : float in (0, 1]
        ``f = P(lost next | delivered now)``.
    recover : float in (0, 1]
        ``r = P(delivered next | lost now)``; ``r = 0`` would never recover.
    loss : float in (0, 1)
        Stationary loss probability ``f / (f + r)``.
    burst : float >= 1
        Mean burst length ``1 / r`` in steps.

    Returns
    -------
    GilbertElliott

    Raises
    ------
    ControlArgument
        Neither or both pairs given, or only half a pair.
    ValueError
        A value outside its range, or ``loss`` and ``burst`` that need
        ``f > 1``.

    References
    ----------
    .. [1] E. N. Gilbert, "Capacity of a burst-noise channel", *Bell System
           Technical Journal* 39(5), 1960.
    .. [2] E. O. Elliott, "Estimates of error rates for codes on burst-noise
           channels", *Bell System Technical Journal* 42(5), 1963.
    .. [3] O. L. V. Costa, M. D. Fragoso and R. P. Marques, *Discrete-Time
           Markov Jump Linear Systems*, Springer, 2005.

    Examples
    --------
    >>> ncs.gilbert_elliott(loss=0.25, burst=2.0)
    GilbertElliott(fail=0.166667, recover=0.5; loss=0.25, burst=2)
    >>> ncs.gilbert_elliott(fail=0.3, recover=0.7).is_bernoulli
    True
    """
    from control.exception import ControlArgument
    rates = (fail is not None, recover is not None)
    stats = (loss is not None, burst is not None)
    if rates == (True, True) and stats == (False, False):
        return GilbertElliott(fail, recover)  # type: ignore[arg-type]
    if stats == (True, True) and rates == (False, False):
        a = real_or_nan(loss)
        if not 0.0 < a < 1.0:
            raise ValueError(f"loss: expected a probability in (0, 1), got "
                             f"{loss!r}")
        b = real_or_nan(burst)
        if not 1.0 <= b < math.inf:
            raise ValueError(f"burst: expected a mean burst length >= 1 (steps), "
                             f"got {burst!r}")
        r = 1.0 / b
        f = a * r / (1.0 - a)
        if f > 1.0:
            raise ValueError(
                f"loss, burst: a stationary loss {a:g} with bursts of mean "
                f"length {b:g} needs fail = {f:.4g} > 1; shorten the bursts "
                f"(burst <= {a / (1 - a):.4g}) or lower the loss")
        return GilbertElliott(f, r)
    raise ControlArgument("gilbert_elliott: give fail= and recover=, or loss= "
                          "and burst= (one pair, both of its values)")


def link_model(value: Any, name: str
               ) -> float | GilbertElliott | LossAutomaton:
    """A link's loss model: a float (Bernoulli), a :class:`GilbertElliott`,
    a 2×2 transition matrix (state order (lost, delivered)) or a loss
    budget (a :class:`~control_ncs.LossAutomaton` of one link,
    :ref:`theory-worst-case`)."""
    if isinstance(value, GilbertElliott):
        return value
    if isinstance(value, LossAutomaton):
        if value.channels != 1:
            from control.exception import ControlArgument
            raise ControlArgument(
                f"{name}: the automaton carries the outcomes of "
                f"{value.channels} links; give each link its own automaton "
                f"(the loop takes the product of the two links itself)")
        return value
    arr = np.asarray(value) if isinstance(value, (list, tuple, np.ndarray)) \
        else None
    if arr is None or arr.ndim == 0:
        return loss_probability(value, name)
    from control.exception import ControlDimension
    if arr.shape != (2, 2):
        raise ControlDimension(
            f"{name}: expected a loss probability, a gilbert_elliott link or "
            f"a 2x2 transition matrix (rows: from lost, from delivered), got "
            f"an array of shape {arr.shape}")
    T = transition_matrix(arr, name)
    try:
        return GilbertElliott(T[1, 0], T[0, 1])
    except ValueError as err:
        raise ValueError(f"{name}: transition {T.tolist()}: {err}") from None


def budget_loss(automaton: LossAutomaton) -> float:
    """The largest long-run fraction of transmissions a budget may lose.

    The maximum, over the automaton's cycles, of the fraction of lost
    outcomes on the cycle (Karp's maximum cycle mean of the weights
    ``1 - delivered``, :ref:`theory-worst-case`): ``misses / window`` for
    :func:`~control_ncs.weakly_hard`, ``k / (k + 1)`` for
    :func:`~control_ncs.max_consecutive_losses`. It is what
    ``NetworkedStateSpace.sensor_loss`` reports for a budget: not a
    probability, the worst average the budget admits.

    Parameters
    ----------
    automaton : LossAutomaton
        One link's budget.

    Returns
    -------
    float
        In ``[0, 1]``.

    Examples
    --------
    >>> from control_ncs.network import budget_loss
    >>> budget_loss(ncs.weakly_hard(2, 5)), budget_loss(
    ...     ncs.max_consecutive_losses(3))
    (0.4, 0.75)
    """
    src, dst, delivered = automaton.transition_graph()
    V = len(automaton.states)
    weight = 1.0 - np.asarray(delivered, float).reshape(len(src), -1)[:, 0]
    # Karp (1978) from a virtual source joined to every state: D[k][v] is
    # the largest weight of a walk of k edges ending at v. Two passes keep
    # one row at a time: D[V] first, then the minimum over k of
    # (D[V] - D[k]) / (V - k) for every v.
    order = np.argsort(dst, kind="stable")
    src, dst, weight = src[order], dst[order], weight[order]
    heads = np.flatnonzero(np.r_[True, dst[1:] != dst[:-1]])
    ends = dst[heads]

    def step(row: np.ndarray) -> np.ndarray:
        out = np.full(V, -np.inf)
        out[ends] = np.maximum.reduceat(row[src] + weight, heads)
        return out

    row = np.zeros(V)
    for _ in range(V):
        row = step(row)
    last = row
    best = np.full(V, np.inf)
    row = np.zeros(V)
    for k in range(V):
        with np.errstate(invalid="ignore"):
            best = np.minimum(best, np.where(np.isfinite(row),
                                             (last - row) / (V - k), np.inf))
        row = step(row)
    rates = best[np.isfinite(last) & np.isfinite(best)]
    return float(min(max(rates.max(), 0.0), 1.0)) if rates.size else 0.0


def mode_transition(sensor_link: Any, actuator_link: Any) -> np.ndarray:
    """Transition matrix of the four network modes.

    The links are independent chains, so
    ``T[(a1, a2), (b1, b2)] = T1[a1, b1] · T2[a2, b2]``, modes in the order
    of paper eq. 14, ``(θ1, θ2) = (0,0), (1,0), (0,1), (1,1)``. A float is
    a Bernoulli link (equal rows).

    Parameters
    ----------
    sensor_link, actuator_link : float, GilbertElliott or 2x2 array_like

    Returns
    -------
    ndarray, shape (4, 4)

    Examples
    --------
    >>> T = ncs.network.mode_transition(0.0, ncs.gilbert_elliott(fail=0.1, recover=0.5))
    >>> T[3].round(3).tolist()          # from (1, 1): θ2 fails w.p. 0.1
    [0.0, 0.1, 0.0, 0.9]
    """
    T1 = _link_transition(link_model(sensor_link, "sensor_loss"))
    T2 = _link_transition(link_model(actuator_link, "actuator_loss"))
    # index = θ1 + 2 θ2 (eq. 14 order): θ2 is the slow index
    return np.kron(T2, T1)


def _link_transition(link: float | GilbertElliott | LossAutomaton
                     ) -> np.ndarray:
    if isinstance(link, LossAutomaton):
        from control.exception import ControlArgument
        raise ControlArgument(
            f"a loss budget ({link.name}) has no transition probabilities; "
            f"the loop over it is analysed for every allowed pattern "
            f"(feedback, then ncs.jsr)")
    if isinstance(link, GilbertElliott):
        return link.transition
    return np.array([[link, 1.0 - link], [link, 1.0 - link]])
