"""A loop over loss budgets: modes constrained by automata, not drawn.

(:ref:`theory-worst-case`, :ref:`theory-links-compose`.) When a link is a
loss budget (:func:`~control_ncs.weakly_hard`,
:func:`~control_ncs.max_consecutive_losses`, a user's
:func:`~control_ncs.loss_automaton`), the network's modes are not drawn
with probabilities: an automaton says which sequences may occur. The
builder (:func:`~control_ncs.build`) keeps, for each mode, the state of the
budgets' product chain (a Moore machine: the automaton state and the last
outcome of each budget link) and the state of the stochastic rest (the
other link, a sub-sample delay), with the moves the budgets allow per phase
and the probabilities of the rest: a :class:`Constraint`. Closing the loop
gives a :class:`ConstrainedLoop`: per phase and mode the closed-loop
matrices and that constraint. It is not a jump system (without
probabilities it has no mean and no mean-square figure of its own): the
analyses take its constrained switching system, the worst case over the
budgets and the mean square over the rest (:func:`~control_ncs.jsr`), or,
when nothing is random, its :class:`~control_ncs.SwitchingSystem`
(:func:`~control_ncs.worst_case_gain`,
:func:`~control_ncs.worst_case_passivity`).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from control.exception import ControlArgument

from .switching import SwitchingGraph, SwitchingSystem

__all__ = ["ConstrainedLoop", "Constraint"]

#: What ``ConstrainedLoop.scale`` says when nothing is random: the radius of
#: the loop matrices themselves.
SCALE_MATRICES = "matrices"
#: What it says with a stochastic part: the radius of the second-moment
#: operators (the squared scale of :func:`control_ncs.ms_radius`).
SCALE_MEAN_SQUARE = "mean_square"


def _frozen(value: Any, dtype: Any) -> Any:
    if value is None:
        return None
    out = np.array(value, dtype)
    out.flags.writeable = False
    return out


@dataclass(frozen=True, eq=False)
class Constraint:
    """Which modes loss budgets allow in turn, and the law of the rest.

    Every mode ``i`` of a loop over loss budgets is a pair: the state
    ``state[i]`` of the budgets' chain (no probabilities: the automaton
    says which state may follow which) and the state ``part[i]`` of the
    stochastic rest of the network (the other link, a sub-sample delay),
    which keeps its law. The two are independent.

    Parameters
    ----------
    state : array_like of int, shape (M,)
        The budget state of each mode, in ``0 .. C-1``.
    part : array_like of int, shape (M,)
        The stochastic state of each mode, in ``0 .. R-1``.
    allowed : array_like of bool, shape (N, C, C)
        ``allowed[k, c, c']``: the budget state ``c`` at phase ``k`` may be
        followed by ``c'`` at phase ``k + 1``.
    start : array_like of bool, shape (C,)
        The budget states a pattern may be in at phase 0.
    law : array_like, shape (N, R)
        The probabilities of the stochastic states per phase (for a Markov
        rest: its periodic stationary marginals).
    transition : array_like, shape (N, R, R), optional
        A Markov rest: ``transition[k, s, s']`` from phase ``k`` to
        ``k + 1``. None: the rest is i.i.d. with ``law``.
    names : sequence, optional
        A name per budget state: for one budget link ``(q, θ)``, the
        automaton state and the last outcome (1 delivered, 0 lost or not
        sent); for two, a pair of those.
    known : bool, optional
        Whether the controller can track the budget state from what
        arrives and the acknowledgements (deterministic automata).

    Attributes
    ----------
    state, part, allowed, start, law, transition, names, known
        As given (read-only arrays).

    Examples
    --------
    One budget link (at most one loss in a row), nothing random:

    >>> loop = ncs.feedback(ncs.nss([[2.0]], [[0.0, 1.0]], [[0.0], [1.0]],
    ...     [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
    ...     actuator_loss=ncs.max_consecutive_losses(1)), [[-2.0]])
    >>> c = loop.constraint
    >>> c.names, c.random
    (((0, 1), (1, 0)), False)
    >>> c.allowed[0].astype(int).tolist()
    [[1, 1], [1, 0]]
    """

    state: np.ndarray
    part: np.ndarray
    allowed: np.ndarray
    start: np.ndarray
    law: np.ndarray
    transition: np.ndarray | None = None
    names: tuple = ()
    known: bool = True

    def __post_init__(self) -> None:
        put = object.__setattr__
        put(self, "state", _frozen(self.state, int))
        put(self, "part", _frozen(self.part, int))
        put(self, "allowed", _frozen(self.allowed, bool))
        put(self, "start", _frozen(self.start, bool))
        put(self, "law", _frozen(self.law, float))
        put(self, "transition", _frozen(self.transition, float))
        names = tuple(self.names) or tuple(range(self.allowed.shape[1]))
        put(self, "names", names)
        put(self, "known", bool(self.known))

    @property
    def period(self) -> int:
        """Number of phases ``N``."""
        return self.allowed.shape[0]

    @property
    def size(self) -> int:
        """Number of budget states ``C``."""
        return self.allowed.shape[1]

    @property
    def random(self) -> bool:
        """Whether the rest of the network is random.

        False when it is i.i.d. with one state of probability 1 at every
        phase (a perfect link, a loss of 0): the loop's matrices are then
        determined by the budget states alone."""
        return self.transition is not None or bool(
            np.any((self.law > 0).sum(axis=1) > 1))

    def weights(self, k: int) -> np.ndarray:
        """Each mode's probability given its budget state, at phase k.

        Parameters
        ----------
        k : int
            Phase (taken modulo the period).

        Returns
        -------
        ndarray, shape (M,)
            The probability of each mode's stochastic state.
        """
        return self.law[k % self.period][self.part]

    def pairs(self) -> "Constraint":
        """The constraint of pair modes ``(ℓ, i)``, index ``ℓ M + i``.

        A gain that depends on the previous mode ``ℓ`` makes the loop's
        matrix depend on the pair; the pair's budget state is
        ``(state[ℓ], state[i])`` (a memory-1 lift of the budget chain) and
        its stochastic state ``(part[ℓ], part[i])``, Markov even when the
        rest is i.i.d. (consecutive pairs share a state), unless nothing is
        random.

        Returns
        -------
        Constraint
        """
        C, R, N = self.size, self.law.shape[1], self.period
        M = self.state.size
        ell, i = np.divmod(np.arange(M * M), M)
        eye = np.eye(C, dtype=bool)
        # (a, b) -> (b', d): b = b' and the budget allows b -> d
        allowed = np.einsum("bc,kcd->kbcd", eye,
                            self.allowed).reshape(N, 1, C, C * C)
        allowed = np.broadcast_to(allowed, (N, C, C, C * C)).reshape(
            N, C * C, C * C)
        start = np.tile(self.start, C)
        names = tuple((a, b) for a in self.names for b in self.names)
        prev = np.roll(self.law, 1, axis=0)
        if not self.random:
            law = np.einsum("kr,ks->krs", prev, self.law).reshape(N, R * R)
            transition = None
        else:
            T = self.transition if self.transition is not None else \
                np.repeat(np.roll(self.law, -1, axis=0)[:, None, :], R, 1)
            transition = np.einsum("rs,kst->krst", np.eye(R), T)
            transition = np.broadcast_to(
                transition.reshape(N, 1, R, R * R), (N, R, R, R * R)
            ).reshape(N, R * R, R * R)
            Tprev = np.roll(T, 1, axis=0)
            law = (prev[:, :, None] * Tprev).reshape(N, R * R)
        return Constraint(self.state[ell] * C + self.state[i],
                          self.part[ell] * R + self.part[i], allowed, start,
                          law, transition, names, self.known)


@dataclass(frozen=True, eq=False)
class ConstrainedLoop:
    """A closed loop whose modes follow loss budgets, not chance.

    (:ref:`theory-worst-case`.) Per phase ``k`` and mode ``i``:
    ``ξ⁺ = A[k, i] ξ + B[k, i] w``, ``z = C[k, i] ξ + D[k, i] w``; the
    sequence of modes is any the :class:`Constraint` allows, the budget
    states following the allowed moves and the stochastic rest its law.
    Made by :func:`control_ncs.feedback` (or ``build(P).close(K)``) for a
    plant with a loss-budget link. It is not a
    :class:`~control_ncs.JumpStateSpace`: without probabilities there is
    no mean system and no mean-square figure; :func:`control_ncs.jsr`
    analyses it for every allowed pattern (:meth:`switching_system`), and
    :meth:`switching` gives the :class:`~control_ncs.SwitchingSystem` that
    :func:`control_ncs.worst_case_gain` and
    :func:`control_ncs.worst_case_passivity` read when nothing is random.

    Parameters
    ----------
    A, B, C, D : array_like, shape (N, M, ., .)
        The closed loop per phase and mode.
    constraint : Constraint
        The budget state and stochastic state of each mode, the allowed
        moves, the law of the rest.
    dt : True or float, optional
        The sampling period of one step.
    inputs, outputs, states : list of str, optional
        Names of ``w``, ``z`` and ``ξ``.
    name : str, optional
    info : dict, optional
        What built the loop (the network, the gains).

    Attributes
    ----------
    A, B, C, D : ndarray
        Read-only.
    constraint : Constraint
    dt, inputs, outputs, states, name, info
        As given.

    Examples
    --------
    ``x⁺ = 2x + u``, ``u = -1.5 x`` when the command arrives, at most one
    command lost in a row: the pattern (lost, delivered) grows like
    ``√(2 · 0.5) = 1``; ``jsr`` finds it.

    >>> P = ncs.nss([[2.0]], [[0.0, 1.0]], [[0.0], [1.0]],
    ...             [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
    ...             actuator_loss=ncs.max_consecutive_losses(1), name="servo")
    >>> CL = ncs.feedback(P, [[-1.5]])
    >>> CL
    <ConstrainedLoop servo (closed loop): 1 states, period 1, 2 budget states (at most 1 consecutive loss), nothing random>
    >>> res = ncs.jsr(CL)
    >>> round(res.upper, 6), res.scale, res.cycle
    (1.0, 'matrices', ((0, (1, 0)), (0, (0, 1))))
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    constraint: Constraint
    dt: Any = True
    inputs: list | None = None
    outputs: list | None = None
    states: list | None = None
    name: str | None = None
    info: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        for f in ("A", "B", "C", "D"):
            object.__setattr__(self, f, _frozen(getattr(self, f), float))
        object.__setattr__(self, "info", dict(self.info))
        N, M = self.A.shape[:2]
        c = self.constraint
        if c.period != N or c.state.size != M:
            raise ValueError(
                f"constraint: made for {c.period} phases and {c.state.size} "
                f"modes, the loop has {N} and {M}")

    # -- sizes --------------------------------------------------------------
    @property
    def period(self) -> int:
        """Number of phases ``N``."""
        return self.A.shape[0]

    @property
    def nstates(self) -> int:
        """Number of loop states."""
        return self.A.shape[-1]

    @property
    def ninputs(self) -> int:
        """Number of inputs ``w``."""
        return self.B.shape[-1]

    @property
    def noutputs(self) -> int:
        """Number of outputs ``z``."""
        return self.C.shape[-2]

    @property
    def random(self) -> bool:
        """Whether part of the network is random (see :attr:`scale`)."""
        return self.constraint.random

    @property
    def scale(self) -> str:
        """What :func:`control_ncs.jsr` of this loop measures.

        ``'matrices'`` when nothing is random: the growth rate per step of
        ``‖ξ‖`` for the worst allowed pattern. ``'mean_square'`` with a
        stochastic part: the growth rate per step of ``E‖ξ‖²`` for the
        worst allowed pattern of the budgets, averaged over the rest (the
        scale of :func:`control_ncs.ms_radius`)."""
        return SCALE_MEAN_SQUARE if self.random else SCALE_MATRICES

    # -- the graph of budget states -------------------------------------------
    def nodes(self) -> tuple:
        """The reachable ``(phase, budget state name)`` pairs.

        In the order of :meth:`switching`'s nodes.

        Returns
        -------
        tuple of (int, object)
            Phase ``k`` and the name of the budget state at step ``k``
            (:attr:`Constraint.names`).
        """
        return tuple((k, self.constraint.names[c])
                     for k, c in self._graph()[0])

    def _graph(self) -> tuple[list, list, list]:
        """Reachable nodes ``(k, c)``, edges ``(u, v)`` between their
        indices, and the start nodes (phase 0), breadth first."""
        con = self.constraint
        N = con.period
        index: dict = {}
        nodes: list = []
        todo: deque = deque()
        for c in np.flatnonzero(con.start):
            index[(0, int(c))] = len(nodes)
            nodes.append((0, int(c)))
            todo.append((0, int(c)))
        starts = list(range(len(nodes)))
        edges = []
        while todo:
            k, c = todo.popleft()
            nk = (k + 1) % N
            for d in np.flatnonzero(con.allowed[k, c]):
                key = (nk, int(d))
                if key not in index:
                    index[key] = len(nodes)
                    nodes.append(key)
                    todo.append(key)
                edges.append((index[(k, c)], index[key]))
        return nodes, edges, starts

    def _modes_of(self, k: int, c: int) -> np.ndarray:
        """The modes of budget state ``c`` that occur at phase ``k`` (with
        a positive probability of their stochastic state)."""
        con = self.constraint
        return np.flatnonzero((con.state == c) & (con.weights(k) > 0))

    def _deterministic_mode(self, k: int, c: int) -> int:
        modes = self._modes_of(k, c)
        if modes.size != 1:
            raise ControlArgument(
                "the loop has a random part: no single matrix per budget "
                "state (use switching_system() for the mean-square operators)")
        return int(modes[0])

    def _operator(self, k: int, c: int) -> np.ndarray:
        """The second-moment operator of budget state ``c`` at phase ``k``:
        ``Σ p_s A_s ⊗ A_s`` (i.i.d. rest) or, for a Markov rest, the block
        ``(s', s)`` ``T[k, s, s'] A_s ⊗ A_s`` on tuples indexed by ``s``."""
        con = self.constraint
        n = self.nstates
        modes = np.flatnonzero(con.state == c)
        if con.transition is None:
            w = con.weights(k)
            out = np.zeros((n * n, n * n))
            for i in modes:
                if w[i] > 0:
                    out += w[i] * np.kron(self.A[k, i], self.A[k, i])
            return out
        R = con.law.shape[1]
        out = np.zeros((R * n * n, R * n * n))
        for i in modes:
            s = con.part[i]
            block = np.kron(self.A[k, i], self.A[k, i])
            for t in np.flatnonzero(con.transition[k, s] > 0):
                out[t * n * n:(t + 1) * n * n, s * n * n:(s + 1) * n * n] += \
                    con.transition[k, s, t] * block
        return out

    def switching_system(self) -> tuple[dict, list, str]:
        """The constrained switching system :func:`control_ncs.jsr` reads.

        Nodes are the reachable ``(phase, budget state)`` pairs; an edge
        to a state the budgets allow next applies the matrix of the node it
        leaves: the loop matrix when nothing is random, else the
        second-moment operator averaged over the stochastic rest (on
        tuples indexed by its state when it is Markov)
        (:ref:`theory-worst-case`).

        Returns
        -------
        matrices : dict
            One matrix per node, keyed by ``(phase, budget state name)``.
        edges : list of (node, next_node, mode)
            ``mode`` is the node left.
        scale : str
            :attr:`scale`.

        Examples
        --------
        >>> P = ncs.nss([[1.5]], [[0.0, 1.0]], [[0.0], [1.0]],
        ...             [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
        ...             sensor_loss=0.2,
        ...             actuator_loss=ncs.max_consecutive_losses(2))
        >>> mats, edges, scale = ncs.feedback(P, [[-1.4]]).switching_system()
        >>> scale, round(float(mats[(0, (0, 1))][0, 0]), 6)
        ('mean_square', 0.458)
        """
        nodes, edges, _ = self._graph()
        names = self.nodes()
        random = self.random
        mats = {}
        for key, (k, c) in zip(names, nodes):
            mats[key] = self._operator(k, c) if random else \
                self.A[k, self._deterministic_mode(k, c)]
        return (mats, [(names[u], names[v], names[u]) for u, v in edges],
                self.scale)

    def switching(self) -> SwitchingSystem:
        """The loop as a SwitchingSystem (when nothing is random).

        Node ``j`` is ``nodes()[j]``; its edges apply mode ``j``, the loop
        ``(A, B, C, D)`` of that phase and budget state. The start nodes
        are the budget states at phase 0 (the loop at rest before them).

        Returns
        -------
        SwitchingSystem

        Raises
        ------
        ControlArgument
            When part of the network is random: the worst case over the
            budget and an average over the rest is not a switching system
            of matrices (use :func:`control_ncs.jsr` on the loop).

        Examples
        --------
        >>> P = ncs.nss([[1.5]], [[1.0, 1.0]], [[1.0], [1.0]],
        ...             [[0.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
        ...             actuator_loss=ncs.max_consecutive_losses(1))
        >>> res = ncs.worst_case_gain(ncs.feedback(P, [[-1.5]]).switching())
        >>> round(res.bound, 6)
        2.0
        """
        if self.random:
            raise ControlArgument(
                "sys: part of this loop's network is random (a stochastic "
                "link or a sub-sample delay beside the budget); the "
                "worst-case gain and passivity over switching systems need "
                "every mode determined by the budgets. Its stability for "
                "every pattern, averaged over the rest: ncs.jsr(loop)")
        nodes, edges, starts = self._graph()
        modes = [self._deterministic_mode(k, c) for k, c in nodes]
        ks = [k for k, _ in nodes]
        pick = (np.array(ks), np.array(modes))
        graph = SwitchingGraph([(u, v, u) for u, v in edges],
                               nodes=len(nodes), start=starts)
        return SwitchingSystem(self.A[pick], self.B[pick], self.C[pick],
                               self.D[pick], graph)

    # -- python protocols ---------------------------------------------------------
    def _analysis_refusal(self, name: str) -> str:
        """Why the jump-system analyses refuse this loop (for their
        message)."""
        return (f"{name}: a ConstrainedLoop, a loop over a loss budget: its "
                f"modes follow the budget's automaton, without probabilities, "
                f"so it has no mean, no mean-square radius, no H2 norm and no "
                f"sample paths to draw. Analyse it for every allowed pattern "
                f"with ncs.jsr(loop) (stability), or "
                f"ncs.worst_case_gain(loop.switching()) / "
                f"ncs.worst_case_passivity(loop.switching()) when nothing "
                f"else is random")

    def __repr__(self) -> str:
        con = self.constraint
        budget = self.info.get("budget", "")
        budget = f" ({budget})" if budget else ""
        rest = "a random part" if self.random else "nothing random"
        return (f"<ConstrainedLoop {self.name}: {self.nstates} states, period "
                f"{self.period}, {con.size} budget states{budget}, {rest}>")

    def summary(self) -> str:
        """A few lines: the loop's sizes, its budget and how to analyse it.

        Returns
        -------
        str
        """
        nodes, edges, _ = self._graph()
        lines = [repr(self),
                 f"  {len(nodes)} reachable (phase, budget state) nodes, "
                 f"{len(edges)} allowed moves",
                 f"  jsr(loop) measures: {self.scale}"]
        return "\n".join(lines)
