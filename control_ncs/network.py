"""Communication schedules and Bernoulli loss models (MATH §1, §3).

A schedule says, for each phase ``k`` of a period ``N``, which sensors (or
actuators) may send. A loss model says how likely a message is to be lost.
Together they give the probabilities of the four network modes of paper
eq. 14. Nothing here knows about plants or controllers.
"""

from __future__ import annotations

import math
import warnings
from typing import Any, Sequence

import numpy as np

from ._checks import caller_stacklevel, real_or_nan
from .exceptions import ScheduleWarning

__all__ = ["Schedule", "schedule", "mode_probabilities"]


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

    >>> S = Schedule([[1, 0], [0, 1], [0, 0]], "sensor_schedule")
    >>> S.period, S.nodes, S.senders(1).tolist(), S.senders(2).tolist()
    (3, 2, [1], [])
    >>> S == schedule([1, 2, 0], 2)
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
        >>> Schedule([[1, 0], [0, 1]]).selection(1).tolist()
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
        >>> Schedule([[1, 0], [0, 1]]).senders(3).tolist()
        [1]
        """
        return np.flatnonzero(self.pattern[k % self.period])

    def repeat(self, period: int) -> "Schedule":
        """The same schedule written over ``period`` phases (a multiple of N).

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
        >>> Schedule([[1, 0], [0, 1]]).repeat(4).period
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
        >>> print(schedule([2, 1, 0], 2, "sensor_schedule").summary())
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

    >>> s = schedule([2, 1, 0, 2], nodes=2)
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
    """Least common multiple of the periods (MATH §3)."""
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

    Examples
    --------
    >>> p = mode_probabilities(0.1, 0.2)
    >>> round(p[(1, 1)], 12), round(sum(p.values()), 12)
    (0.72, 1.0)
    """
    a1 = loss_probability(sensor_loss, "sensor_loss")
    a2 = loss_probability(actuator_loss, "actuator_loss")
    return {(0, 0): a1 * a2, (1, 0): (1 - a1) * a2,
            (0, 1): a1 * (1 - a2), (1, 1): (1 - a1) * (1 - a2)}
