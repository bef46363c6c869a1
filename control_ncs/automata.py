"""Loss patterns as automata: which 0/1 outcome sequences a link may produce.

(:ref:`theory-worst-case`.) A link that is known only to respect a budget
(at most ``m`` losses in any ``K`` consecutive transmissions, at most ``k``
losses in a row, a pattern of the user's) has no probabilities: it is a
finite automaton whose edges ``(state, next_state, delivered)`` say which
outcome (1 = delivered, 0 = lost) may come next. The worst case over every
allowed pattern is a joint spectral radius on this graph
(:func:`control_ncs.jsr`). Nothing here knows about plants or controllers:
an automaton is pure data.
"""

from __future__ import annotations

import itertools
import math
from collections import deque
from typing import Any, Hashable, Iterable, Sequence

import numpy as np
from control.exception import ControlArgument

from ._checks import positive_int

__all__ = ["LossAutomaton", "weakly_hard", "max_consecutive_losses",
           "loss_automaton"]

#: Largest number of states an automaton may have: factories and products
#: refuse larger ones before allocating anything (a state is a Python
#: object, and the joint spectral radius grows with the graph).
MAX_STATES = 100_000

Label = Any   # 0 or 1 for one link, a tuple of 0/1 for several


def _label(value: Any, where: str) -> tuple[int, ...]:
    """An edge's outcome as a tuple of 0/1 (one entry per link)."""
    items = value if isinstance(value, (tuple, list, np.ndarray)) else (value,)
    out = []
    for item in items:
        if isinstance(item, (bool, np.bool_)):
            item = int(item)
        if not isinstance(item, (int, np.integer)) or item not in (0, 1):
            raise ValueError(f"{where}: delivered must be 0 (lost) or 1 "
                             f"(delivered), or a tuple of them, got {value!r}")
        out.append(int(item))
    if not out:
        raise ValueError(f"{where}: delivered is empty")
    return tuple(out)


class LossAutomaton:
    """The 0/1 outcome sequences a link may produce, as an automaton.

    (:ref:`theory-worst-case`.) An edge ``(state, next_state, delivered)``
    says that from ``state`` the next transmission may have the outcome
    ``delivered`` (1 = delivered, 0 = lost), after which the link is in
    ``next_state``. A pattern is allowed when a walk of the automaton,
    starting at an initial state, reads it. Several links together
    (:meth:`product`) have one outcome per link: ``delivered`` is then a
    tuple. The automaton is immutable, hashable, comparable and picklable.

    Build one with :func:`weakly_hard`, :func:`max_consecutive_losses` or
    :func:`loss_automaton`.

    Parameters
    ----------
    states : int or sequence of hashable
        The number of states (named ``0 .. states-1``) or their names.
    edges : sequence of (state, next_state, delivered)
        The allowed transitions. Repeated edges count once.
    initial : state or sequence of states, optional
        Where a pattern may start (default: at any state).
    name : str, optional
        What the automaton describes, shown by ``repr`` and :meth:`summary`.

    Attributes
    ----------
    states : tuple
        The state names, in order; ``transition_graph`` indexes them.
    edges : tuple of (state, next_state, delivered)
        The transitions with state names; ``delivered`` is ``0`` or ``1``
        (one link) or a tuple of them (:attr:`channels` links).
    initial : tuple or None
        The initial states, or None when a pattern may start anywhere.
    channels : int
        Number of links whose outcomes an edge carries.
    name : str
        The description given or made by the factory.

    Raises
    ------
    ValueError
        An edge names a state that does not exist or an outcome other than
        0/1; a state has no outgoing edge (every allowed pattern must be
        able to go on); a state cannot be reached from the initial states.
    ControlArgument
        Edges whose outcomes have different numbers of links.

    Notes
    -----
    States that lie on no cycle are accepted: they describe a start-up
    phase that a pattern passes once, and do not change the worst-case
    growth rate (:func:`control_ncs.jsr` looks at the strongly connected
    components).

    Examples
    --------
    At most one loss in a row, starting with nothing lost:

    >>> aut = ncs.LossAutomaton(2, [(0, 0, 1), (0, 1, 0), (1, 0, 1)],
    ...                         initial=0)
    >>> aut.allows([1, 0, 1, 0]), aut.allows([0, 0, 1])
    (True, False)
    >>> aut == ncs.max_consecutive_losses(1)
    True
    """

    __slots__ = ("_states", "_edges", "_initial", "_channels", "_name",
                 "_index", "_steps")
    _states: tuple
    _edges: tuple
    _initial: tuple | None
    _channels: int
    _name: str
    _index: dict
    _steps: dict

    def __init__(self, states: int | Sequence[Hashable],
                 edges: Iterable[tuple[Any, Any, Label]],
                 initial: Any = None, *, name: str | None = None) -> None:
        names = _state_names(states)
        index = {s: i for i, s in enumerate(names)}
        edge_list, channels = _edges(edges, index)
        init = _initial(initial, index)
        sources = {i for i, _, _ in edge_list}
        dead = [names[i] for i in range(len(names)) if i not in sources]
        if dead:
            raise ValueError(
                f"edges: state(s) {dead[:5]} have no outgoing edge; every "
                f"state of a link must allow a next transmission (a pattern "
                f"that cannot go on is not a link's behaviour)")
        if init is not None:
            unreachable = sorted(set(range(len(names)))
                                 - _reachable(len(names), edge_list, init))
            if unreachable:
                raise ValueError(
                    f"initial: state(s) {[names[i] for i in unreachable[:5]]}"
                    f" cannot be reached from the initial states "
                    f"{[names[i] for i in init]}")
        steps: dict[tuple[int, tuple[int, ...]], list[int]] = {}
        for i, j, d in edge_list:
            steps.setdefault((i, d), []).append(j)
        put = object.__setattr__
        put(self, "_states", names)
        put(self, "_index", index)
        put(self, "_edges", tuple(edge_list))
        put(self, "_initial", init)
        put(self, "_channels", channels)
        put(self, "_name", str(name) if name is not None else
            f"loss automaton ({len(names)} states)")
        put(self, "_steps", {key: tuple(v) for key, v in steps.items()})

    def __setattr__(self, key: str, value: Any) -> None:
        raise AttributeError("LossAutomaton is immutable")

    # -- the data -------------------------------------------------------------
    @property
    def states(self) -> tuple:
        """The state names, in order."""
        return self._states

    @property
    def edges(self) -> tuple:
        """The transitions ``(state, next_state, delivered)``, by name."""
        return tuple((self._states[i], self._states[j], self._public(d))
                     for i, j, d in self._edges)

    @property
    def initial(self) -> tuple | None:
        """The initial states (None: a pattern may start anywhere)."""
        if self._initial is None:
            return None
        return tuple(self._states[i] for i in self._initial)

    @property
    def channels(self) -> int:
        """Number of links whose outcomes an edge carries."""
        return self._channels

    @property
    def name(self) -> str:
        """What the automaton describes."""
        return self._name

    def _public(self, label: tuple[int, ...]) -> Label:
        return label[0] if self._channels == 1 else label

    def transition_graph(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The edges as arrays of state indices and outcomes.

        Returns
        -------
        source, target : ndarray of int, shape (E,)
            Indices into :attr:`states`.
        delivered : ndarray of int, shape (E,) or (E, channels)
            The outcome of each edge (one column per link when
            ``channels > 1``).

        Examples
        --------
        >>> src, dst, d = ncs.max_consecutive_losses(1).transition_graph()
        >>> src.tolist(), dst.tolist(), d.tolist()
        ([0, 0, 1], [0, 1, 0], [1, 0, 1])
        """
        E = len(self._edges)
        src = np.array([e[0] for e in self._edges], dtype=np.int64)
        dst = np.array([e[1] for e in self._edges], dtype=np.int64)
        lab = np.array([e[2] for e in self._edges], dtype=np.int64).reshape(
            E, self._channels)
        return src, dst, (lab[:, 0] if self._channels == 1 else lab)

    def allows(self, pattern: Iterable[Label]) -> bool:
        """Whether a walk from an initial state reads ``pattern``.

        Parameters
        ----------
        pattern : sequence of 0/1 (or of tuples of 0/1 for several links)
            Outcomes in time order (1 = delivered).

        Returns
        -------
        bool

        Examples
        --------
        >>> wh = ncs.weakly_hard(1, 3)
        >>> wh.allows([0, 1, 1, 0, 1, 1]), wh.allows([0, 1, 0])
        (True, False)
        """
        current = set(range(len(self._states)) if self._initial is None
                      else self._initial)
        for t, outcome in enumerate(pattern):
            label = _label(outcome, f"pattern[{t}]")
            if len(label) != self._channels:
                raise ControlArgument(
                    f"pattern[{t}]: expected {self._channels} outcome(s) per "
                    f"step, got {outcome!r}")
            current = {j for i in current
                       for j in self._steps.get((i, label), ())}
            if not current:
                return False
        return True

    # -- combinations ------------------------------------------------------------
    def product(self, other: "LossAutomaton") -> "LossAutomaton":
        """Two independent links: states and outcomes side by side.

        Parameters
        ----------
        other : LossAutomaton

        Returns
        -------
        LossAutomaton
            States ``(s1, s2)``, outcomes ``(d1, d2)`` (flattened when a
            factor already has several links). With initial states, only
            the pairs reachable from the initial pairs are kept: so the
            product of two :meth:`periodic` automata keeps their phases
            aligned.

        Raises
        ------
        ValueError
            If the product would have more than ``MAX_STATES`` states.

        Examples
        --------
        >>> both = ncs.max_consecutive_losses(1).product(
        ...     ncs.max_consecutive_losses(1))
        >>> len(both.states), both.channels, both.allows([(0, 1), (1, 0)])
        (4, 2, True)
        """
        if not isinstance(other, LossAutomaton):
            raise ControlArgument(f"other: expected a LossAutomaton, got "
                                  f"{type(other).__name__}")
        size = len(self._states) * len(other._states)
        _check_size(size, "product")
        pairs = list(itertools.product(range(len(self._states)),
                                       range(len(other._states))))
        by_source: dict[int, list] = {}
        for i, j, d in other._edges:
            by_source.setdefault(i, []).append((j, d))
        edges = [((i1, i2), (j1, j2), d1 + d2)
                 for i1, j1, d1 in self._edges
                 for i2 in range(len(other._states))
                 for j2, d2 in by_source[i2]]
        if self._initial is None and other._initial is None:
            init = None
        else:
            first = self._initial or range(len(self._states))
            second = other._initial or range(len(other._states))
            init = [(a, b) for a in first for b in second]
            keep = _reachable_labelled(init, edges)
            pairs = [p for p in pairs if p in keep]
            edges = [e for e in edges if e[0] in keep]
        names = [(self._states[a], other._states[b]) for a, b in pairs]
        where = {p: names[k] for k, p in enumerate(pairs)}
        return LossAutomaton(
            names, [(where[u], where[v], d) for u, v, d in edges],
            None if init is None else [where[p] for p in init],
            name=f"{self._name} x {other._name}")

    def periodic(self, sent: Any) -> "LossAutomaton":
        """The link under a period-N schedule: states ``(s, k mod N)``.

        A phase at which the link sends nothing consumes no step of the
        automaton: the budget counts transmissions (a deadline-miss budget
        counts the jobs that ran, Bernat et al. 2001), not time steps.
        At such a phase the state is kept and the outcome is 0 (nothing was
        delivered, because nothing was sent).

        Parameters
        ----------
        sent : array_like of bool, shape (N,)
            Whether the link transmits at each phase of the schedule.

        Returns
        -------
        LossAutomaton
            States ``(s, k)``; a pattern starts at phase 0 (from the
            initial states, or from any state). States that cannot be
            reached that way are dropped.

        Raises
        ------
        ControlArgument
            If the automaton has several links (combine each link with its
            schedule first, then take the :meth:`product`).

        Examples
        --------
        At most one loss in a row, sending at every other step:

        >>> aut = ncs.max_consecutive_losses(1).periodic([1, 0])
        >>> aut.allows([0, 0, 1, 0, 0, 0]), aut.allows([0, 0, 0, 0])
        (True, False)
        """
        if self._channels != 1:
            raise ControlArgument(
                "periodic: the automaton has several links; combine each "
                "link with its schedule first, then take the product")
        flags = np.asarray(sent)
        if flags.ndim != 1 or flags.size < 1 or not np.all(
                (flags == 0) | (flags == 1)):
            raise ValueError(f"sent: expected a 0/1 vector of length N >= 1, "
                             f"got {sent!r}")
        flags = flags.astype(bool)
        N = flags.size
        _check_size(len(self._states) * N, "periodic")
        edges = []
        for k in range(N):
            nxt = (k + 1) % N
            if flags[k]:
                edges += [((i, k), (j, nxt), d) for i, j, d in self._edges]
            else:
                edges += [((i, k), (i, nxt), (0,))
                          for i in range(len(self._states))]
        init = [(i, 0) for i in (self._initial if self._initial is not None
                                 else range(len(self._states)))]
        keep = _reachable_labelled(init, edges)
        pairs = sorted(keep, key=lambda p: (p[1], p[0]))
        names = {p: (self._states[p[0]], p[1]) for p in pairs}
        bits = "".join("1" if f else "0" for f in flags)
        return LossAutomaton(
            [names[p] for p in pairs],
            [(names[u], names[v], d) for u, v, d in edges if u in keep],
            [names[p] for p in init], name=f"{self._name}, sent {bits}")

    # -- python protocols ----------------------------------------------------------
    def _key(self) -> tuple:
        return (self._states, frozenset(self._edges),
                None if self._initial is None else frozenset(self._initial))

    def __eq__(self, other: object) -> bool:
        return isinstance(other, LossAutomaton) and self._key() == other._key()

    def __hash__(self) -> int:
        return hash(self._key())

    def __reduce__(self) -> tuple:
        return (_rebuild, (self._states, self.edges, self.initial, self._name))

    def __repr__(self) -> str:
        return (f"LossAutomaton({self._name}: {len(self._states)} states, "
                f"{len(self._edges)} edges)")

    def summary(self) -> str:
        """A few lines: what it describes, its size and its edges.

        Returns
        -------
        str

        Examples
        --------
        >>> print(ncs.max_consecutive_losses(1).summary())
        LossAutomaton: at most 1 consecutive loss
          2 states, 3 edges, 1 link; starts at [0]
          0 -1-> 0, 0 -0-> 1, 1 -1-> 0
        """
        links = "1 link" if self._channels == 1 else f"{self._channels} links"
        start = ("starts anywhere" if self._initial is None else
                 f"starts at {list(self.initial or ())}")
        shown = [f"{u} -{_text(d)}-> {v}" for u, v, d in self.edges[:12]]
        more = len(self._edges) - len(shown)
        lines = [f"LossAutomaton: {self._name}",
                 f"  {len(self._states)} states, {len(self._edges)} edges, "
                 f"{links}; {start}",
                 "  " + ", ".join(shown) + (f", ... ({more} more)" if more
                                            else "")]
        return "\n".join(lines)


def _text(label: Label) -> str:
    return "".join(map(str, label)) if isinstance(label, tuple) else \
        str(label)


def _rebuild(states: tuple, edges: tuple, initial: Any, name: str
             ) -> LossAutomaton:
    return LossAutomaton(states, edges, initial, name=name)


def _check_size(size: int, what: str) -> None:
    if size > MAX_STATES:
        raise ValueError(f"{what}: the automaton would have {size} states, "
                         f"more than MAX_STATES = {MAX_STATES}")


def _state_names(states: Any) -> tuple:
    if isinstance(states, (int, np.integer)) and not isinstance(
            states, (bool, np.bool_)):
        count = positive_int(states, "states")
        _check_size(count, "states")
        return tuple(range(count))
    if isinstance(states, (str, bytes)) or not isinstance(
            states, (list, tuple, range, np.ndarray)):
        raise ControlArgument(f"states: expected a count or a sequence of "
                              f"state names, got {type(states).__name__}")
    names = tuple(s.item() if isinstance(s, np.generic) else s
                  for s in states)
    if not names:
        raise ValueError("states: an automaton needs at least one state")
    _check_size(len(names), "states")
    try:
        distinct = len(set(names))
    except TypeError:
        raise ControlArgument("states: state names must be hashable") from None
    if distinct != len(names):
        raise ValueError("states: state names must be distinct")
    return names


def _edges(edges: Any, index: dict) -> tuple[list, int]:
    if isinstance(edges, (str, bytes)):
        raise ControlArgument("edges: expected a sequence of (state, "
                              "next_state, delivered) triples")
    out: dict = {}
    channels = None
    for k, edge in enumerate(edges):
        try:
            u, v, d = edge
        except (TypeError, ValueError):
            raise ControlArgument(
                f"edges[{k}]: expected (state, next_state, delivered), got "
                f"{edge!r}") from None
        for s in (u, v):
            try:
                known = s in index
            except TypeError:
                known = False
            if not known:
                raise ValueError(f"edges[{k}]: state {s!r} is not one of the "
                                 f"automaton's states")
        label = _label(d, f"edges[{k}]")
        if channels is None:
            channels = len(label)
        elif len(label) != channels:
            raise ControlArgument(
                f"edges[{k}]: {len(label)} outcome(s), but earlier edges "
                f"have {channels} (one per link)")
        out.setdefault((index[u], index[v], label), None)
    if channels is None:
        raise ValueError("edges: an automaton needs at least one edge")
    return list(out), channels


def _initial(initial: Any, index: dict) -> tuple[int, ...] | None:
    if initial is None:
        return None
    try:
        single = initial in index
    except TypeError:
        single = False
    items = [initial] if single else initial
    if isinstance(items, (str, bytes)) or not isinstance(
            items, (list, tuple, set, frozenset, range, np.ndarray)):
        raise ValueError(f"initial: {initial!r} is not a state or a "
                         f"sequence of states")
    out = []
    for s in items:
        s = s.item() if isinstance(s, np.generic) else s
        try:
            known = s in index
        except TypeError:
            known = False
        if not known:
            raise ValueError(f"initial: {s!r} is not one of the automaton's "
                             f"states")
        if index[s] not in out:
            out.append(index[s])
    if not out:
        raise ValueError("initial: expected at least one state (or None)")
    return tuple(out)


def _reachable(count: int, edges: list, start: Iterable[int]) -> set[int]:
    succ: list[list[int]] = [[] for _ in range(count)]
    for i, j, _ in edges:
        succ[i].append(j)
    seen = set(start)
    todo = deque(seen)
    while todo:
        i = todo.popleft()
        for j in succ[i]:
            if j not in seen:
                seen.add(j)
                todo.append(j)
    return seen


def _reachable_labelled(start: list, edges: list) -> set:
    succ: dict = {}
    for u, v, _ in edges:
        succ.setdefault(u, []).append(v)
    seen = set(start)
    todo = deque(start)
    while todo:
        u = todo.popleft()
        for v in succ.get(u, ()):
            if v not in seen:
                seen.add(v)
                todo.append(v)
    return seen


# -- factories ------------------------------------------------------------------
def weakly_hard(misses: int, window: int) -> LossAutomaton:
    """At most ``misses`` losses in any ``window`` transmissions.

    The weakly-hard "any-miss" constraint of Bernat, Burns and Llamosi
    (2001), ``misses`` first (:ref:`theory-worst-case`). A state is the
    last ``window - 1`` outcomes (a string of ``'0'``/``'1'``, oldest
    first) with at most ``misses`` zeros; from ``w`` the outcome ``d`` is
    allowed when ``w d`` has at most ``misses`` zeros, and leads to ``w``
    without its oldest outcome, ``d`` appended. There are
    ``Σ_{i ≤ misses} C(window - 1, i)`` states; a pattern starts with
    nothing lost (the all-ones state), so the allowed patterns are exactly
    those with at most ``misses`` zeros in every ``window`` consecutive
    outcomes.

    Parameters
    ----------
    misses : int
        Largest number of losses in a window, ``0 <= misses <= window``.
    window : int
        Length of the window, ``>= 1``.

    Returns
    -------
    LossAutomaton

    Raises
    ------
    ValueError
        ``misses`` outside ``[0, window]``, or more than ``MAX_STATES``
        states (the message gives the count).

    References
    ----------
    .. [1] G. Bernat, A. Burns and A. Llamosi, "Weakly hard real-time
           systems", *IEEE Transactions on Computers* 50(4), 2001.

    Examples
    --------
    >>> wh = ncs.weakly_hard(1, 4)
    >>> len(wh.states), wh.initial
    (4, ('111',))
    >>> wh.allows([1, 1, 1, 0, 1, 1, 1, 0]), wh.allows([0, 1, 1, 0])
    (True, False)
    """
    window = positive_int(window, "window")
    if isinstance(misses, (bool, np.bool_)) or not isinstance(
            misses, (int, np.integer)) or not 0 <= misses <= window:
        raise ValueError(f"misses: expected an int in [0, window = {window}] "
                         f"(losses allowed in a window), got {misses!r}")
    misses = int(misses)
    width = window - 1
    size = sum(math.comb(width, i) for i in range(min(misses, width) + 1))
    _check_size(size, "weakly_hard")
    names: list[str] = []
    for zeros in range(min(misses, width) + 1):
        for where in itertools.combinations(range(width), zeros):
            bits = ["1"] * width
            for k in where:
                bits[k] = "0"
            names.append("".join(bits))
    names.sort(reverse=True)
    edges = []
    for state in names:
        for d in (1, 0):
            word = state + str(d)
            if word.count("0") <= misses:
                edges.append((state, word[1:], d))
    return LossAutomaton(names, edges, "1" * width,
                         name=f"at most {misses} lost in any {window}")


def max_consecutive_losses(k: int) -> LossAutomaton:
    """At most ``k`` losses in a row: states ``0..k``, the current run.

    (:ref:`theory-worst-case`.) The same patterns as
    ``weakly_hard(k, k + 1)`` with ``k + 1`` states instead of ``2^k``.

    Parameters
    ----------
    k : int
        Largest run of consecutive losses, ``>= 0``.

    Returns
    -------
    LossAutomaton
        From ``j`` a delivery leads to ``0``, a loss to ``j + 1`` (for
        ``j < k``); a pattern starts at ``0``.

    Raises
    ------
    ValueError
        ``k`` negative, or more than ``MAX_STATES`` states.

    Examples
    --------
    >>> aut = ncs.max_consecutive_losses(2)
    >>> aut.states, aut.allows([0, 0, 1, 0, 0]), aut.allows([1, 0, 0, 0])
    ((0, 1, 2), True, False)
    """
    if isinstance(k, (bool, np.bool_)) or not isinstance(
            k, (int, np.integer)) or k < 0:
        raise ValueError(f"k: expected an int >= 0 (losses in a row), got "
                         f"{k!r}")
    k = int(k)
    _check_size(k + 1, "max_consecutive_losses")
    edges = []
    for j in range(k + 1):
        edges.append((j, 0, 1))
        if j < k:
            edges.append((j, j + 1, 0))
    loss = "loss" if k == 1 else "losses"
    return LossAutomaton(k + 1, edges, 0,
                         name=f"at most {k} consecutive {loss}")


def loss_automaton(edges: Iterable[tuple[Any, Any, Label]],
                   initial: Any = None, *, name: str | None = None
                   ) -> LossAutomaton:
    """A loss pattern of the user's, from its edges.

    The states are those the edges name, in order of appearance
    (:ref:`theory-worst-case`).

    Parameters
    ----------
    edges : sequence of (state, next_state, delivered)
        ``delivered`` is 0 (lost) or 1 (delivered); states are any
        hashable names.
    initial : state or sequence of states, optional
        Where a pattern may start (default: anywhere). When given, every
        state must be reachable from it.
    name : str, optional
        A description for ``repr`` and ``summary``.

    Returns
    -------
    LossAutomaton

    Raises
    ------
    ValueError
        An outcome other than 0/1, a state without outgoing edge, a state
        not reachable from ``initial``.

    Notes
    -----
    Every state must have an outgoing edge: a link always produces a next
    outcome. States on no cycle (a start-up phase) are accepted; they do
    not change the worst-case growth rate.

    Examples
    --------
    A denial-of-service budget: after a loss, three deliveries.

    >>> aut = ncs.loss_automaton([("ok", "ok", 1), ("ok", "a", 0),
    ...                           ("a", "b", 1), ("b", "c", 1),
    ...                           ("c", "ok", 1)], initial="ok")
    >>> aut.states, aut.allows([0, 1, 1, 1, 0]), aut.allows([0, 1, 0])
    (('ok', 'a', 'b', 'c'), True, False)
    """
    if isinstance(edges, (str, bytes)) or not isinstance(
            edges, (list, tuple)):
        edges = list(edges)
    names: dict = {}
    for k, edge in enumerate(edges):
        try:
            u, v, _ = edge
            names.setdefault(u, None)
            names.setdefault(v, None)
        except (TypeError, ValueError):
            raise ControlArgument(
                f"edges[{k}]: expected (state, next_state, delivered), got "
                f"{edge!r}") from None
    if not names:
        raise ValueError("edges: an automaton needs at least one edge")
    return LossAutomaton(list(names), edges, initial, name=name)
