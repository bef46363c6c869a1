"""Links as Markov chains with an emission, and their product
(:ref:`theory-links-compose`).

Every link kind is one chain over its own states with an emission: at each
step, the age of the freshest packet the receiver holds (0 = sent this
step), or *stale* (nothing usable). A perfect or lossy link is a chain of
two states (lost, delivered) emitting age 0 when a packet was sent and got
through; a Gilbert–Elliott link is the same two states moving in bursts; a
random delay is the age chain of the freshest packet (:ref:`theory-delays`),
thinned by a Bernoulli loss on the same link; a bursty delay is the pair
(channel state, age). The sub-sample input delay of a sampled plant is one
more chain (i.i.d. over the delay grid) whose emission is the delay's index.
A loss budget (a :class:`~control_ncs.LossAutomaton`,
:ref:`theory-worst-case`) is a *constrained* chain: its transition is the
0/1 pattern of the moves the automaton allows, not probabilities, and its
states remember the automaton state and the last outcome (a Moore machine).

The two links are independent: the network's mode chain is the product of
the links' chains with the schedule's phases (:func:`product`); with a
budget among them, :func:`constraint` separates the allowed moves of the
budgets from the probabilities of the rest. This module is the one place
that knows which link kind produced a chain; the builder
(:mod:`control_ncs.strategies`) reads only the chains.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
from control.exception import ControlArgument

from .automata import LossAutomaton
from .constrained import Constraint
from .modes import age_chain, periodic_stationary
from .delays import BurstyDelay, RandomDelay
from .network import GilbertElliott

__all__: list[str] = []


@dataclass(frozen=True, eq=False)
class LinkChain:
    """One link (or timing) as a periodic Markov chain with an emission.

    Attributes
    ----------
    transition : ndarray, shape (N, S, S)
        ``T[k][s, s'] = P(s_{k+1} = s' | s_k = s)`` from phase ``k``.
    emission : ndarray of int, shape (N, S)
        What the receiver uses at phase ``k`` in state ``s``: the age of
        the freshest packet, ``0..buffer``, or ``buffer + 1`` (stale). For
        a timing chain, the index of the delay.
    buffer : int
        The oldest usable age ``D``.
    states : tuple of str
        A name per state, for people.
    nominal : int
        The loss-free state (delivered, age 0).
    constrained : bool
        A loss budget: ``transition`` holds the allowed moves (0/1, rows
        need not sum to 1), not probabilities.
    start : ndarray of bool, shape (S,), or None
        A budget's states at phase 0 (None for a stochastic chain).
    known : bool
        A budget whose state the receiver can track from the outcomes (a
        deterministic automaton).
    """

    transition: np.ndarray
    emission: np.ndarray
    buffer: int
    states: tuple
    nominal: int = 0
    constrained: bool = False
    start: np.ndarray | None = None
    known: bool = True

    @property
    def stale(self) -> int:
        """The emission that means nothing usable: ``buffer + 1``."""
        return self.buffer + 1

    @property
    def period(self) -> int:
        """Number of phases ``N``."""
        return self.transition.shape[0]

    @property
    def size(self) -> int:
        """Number of states ``S``."""
        return self.transition.shape[1]

    def shifted(self) -> "LinkChain":
        """The same chain read one step ahead: the state ``s_{k+1}`` as the
        phase-``k`` state (the controllers with memory are updated by the
        measurement that arrives at the end of the step,
        :ref:`theory-predictor`)."""
        start = self.start
        if start is not None:       # the states one step after phase 0
            start = (start.astype(float) @ self.transition[0]) > 0
        return LinkChain(np.roll(self.transition, -1, axis=0),
                         np.roll(self.emission, -1, axis=0), self.buffer,
                         self.states, self.nominal, self.constrained, start,
                         self.known)

    def pairs(self) -> "LinkChain":
        """The chain of consecutive states ``(s_k, s_{k+1})`` at phase ``k``,
        ``s_k`` the slow index; the emission is ``s_{k+1}``'s.

        Whether the packet in use at ``k + 1`` is new (fresher than the one
        at ``k``) depends on both; the estimator corrects only on a new
        packet (:ref:`theory-delays`)."""
        if self.constrained:
            raise ControlArgument("a loss budget has no buffer: its chain "
                                  "is never read in pairs")
        N, S = self.period, self.size
        T = np.zeros((N, S * S, S * S))
        nxt = np.roll(self.transition, -1, axis=0)      # s_{k+1} -> s_{k+2}
        for s1 in range(S):
            # (s0, s1) -> (s1, s2) with probability T[k+1][s1, s2]
            T[:, s1::S, s1 * S:(s1 + 1) * S] = nxt[:, None, s1, :]
        emission = np.repeat(np.roll(self.emission, -1, axis=0)[:, None, :],
                             S, axis=1).reshape(N, S * S)
        states = tuple(f"({a}, {b})" for a in self.states for b in self.states)
        return LinkChain(T, emission, self.buffer, states,
                         self.nominal * S + self.nominal)

    def previous(self) -> np.ndarray:
        """Emission of the earlier state of each pair of :meth:`pairs`,
        shape (N, S·S): ``s_k``'s emission at phase ``k``."""
        S = self.size
        return np.repeat(self.emission, S, axis=1)

    def repeat(self, period: int) -> "LinkChain":
        """The chain over ``period`` phases (a multiple of its own)."""
        reps = period // self.period
        return LinkChain(np.tile(self.transition, (reps, 1, 1)),
                         np.tile(self.emission, (reps, 1)), self.buffer,
                         self.states, self.nominal, self.constrained,
                         self.start, self.known)


def _loss_chain(link: float | GilbertElliott, sent: np.ndarray) -> LinkChain:
    """A link without delays: states (lost, delivered), emission age 0 when
    a packet was sent and delivered (:ref:`theory-markov`)."""
    N = sent.size
    if isinstance(link, GilbertElliott):
        T = np.repeat(link.transition[None], N, axis=0)
    else:
        T = np.tile([[link, 1.0 - link]], (N, 2, 1))
    emission = np.ones((N, 2), int)                   # stale = 1
    emission[:, 1] = np.where(sent, 0, 1)
    return LinkChain(T, emission, 0, ("lost", "delivered"), 1)


def _budget_chain(aut: LossAutomaton, sent: np.ndarray) -> LinkChain:
    """A loss budget as a constrained chain (:ref:`theory-worst-case`).

    States ``(q, θ)``: the automaton state after the step and the step's
    outcome (1 delivered; 0 lost, or nothing sent). At a phase that sends,
    ``(q, θ) → (q', θ')`` for every edge ``(q, q', θ')``; at a phase that
    sends nothing the automaton takes no step (``(q, θ) → (q, 0)``,
    :meth:`LossAutomaton.periodic`'s rule). Emission: age 0 when the step
    delivered a packet, stale otherwise. States no pattern reaches at any
    phase are dropped."""
    N = sent.size
    Q = len(aut.states)
    src, dst, d = aut.transition_graph()
    step = np.zeros((2 * Q, 2 * Q), bool)        # (q, θ) -> (q', θ')
    for q, q2, t in zip(src, dst, d):
        step[2 * q:2 * q + 2, 2 * q2 + t] = True
    idle = np.zeros((2 * Q, 2 * Q), bool)
    for q in range(Q):
        idle[2 * q:2 * q + 2, 2 * q] = True
    # the move from phase k to k + 1 is the automaton's step at k + 1
    T = np.array([step if sent[(k + 1) % N] else idle for k in range(N)])
    init = np.zeros(2 * Q, bool)
    init[[2 * q + t for q in (range(Q) if aut.initial is None else
                              [aut.states.index(s) for s in aut.initial])
          for t in (0, 1)]] = True
    start = ((init @ step) > 0) if sent[0] else ((init @ idle) > 0)
    seen = np.zeros((N, 2 * Q), bool)
    seen[0] = start
    todo = [(0, int(c)) for c in np.flatnonzero(start)]
    while todo:
        k, c = todo.pop()
        nk = (k + 1) % N
        for c2 in np.flatnonzero(T[k, c] & ~seen[nk]):
            seen[nk, c2] = True
            todo.append((nk, int(c2)))
    keep = np.flatnonzero(seen.any(axis=0))
    T = T[:, keep][:, :, keep].astype(float)
    emission = np.where((keep % 2 == 1)[None, :] & sent[:, None], 0, 1)
    names = tuple((aut.states[c // 2], int(c % 2)) for c in keep)
    delivered = [j for j, c in enumerate(keep) if c % 2 == 1]
    first = [j for j in delivered if start[keep[j]]] or delivered or [0]
    known = all(len(v) == 1 for v in _successors(aut).values())
    return LinkChain(T, emission, 0, names, first[0], True, start[keep],
                     known)


def _successors(aut: LossAutomaton) -> dict:
    """The successors of each (state, outcome), as lists."""
    out: dict = {}
    for q, q2, t in zip(*aut.transition_graph()):
        out.setdefault((int(q), int(t)), []).append(int(q2))
    return out


def _delay_chain(delay: RandomDelay, loss: float, sent: np.ndarray
                 ) -> LinkChain:
    """The age chain of the freshest packet; a Bernoulli loss on the same
    link thins the delay law (:ref:`theory-links-compose`)."""
    D = delay.buffer
    T = age_chain((1.0 - loss) * delay.pmf, D, sent)
    emission = np.tile(np.arange(D + 2), (sent.size, 1))
    return LinkChain(T, emission, D, tuple(delay.states))


def _bursty_chain(delay: BurstyDelay, sent: np.ndarray) -> LinkChain:
    """The pair (channel state, age), channel-major (:ref:`theory-delays`)."""
    D = delay.buffer
    ages = [f"age {a}" for a in range(D + 1)] + ["stale"]
    return LinkChain(delay.transition(sent),
                     np.tile(np.tile(np.arange(D + 2), 2), (sent.size, 1)), D,
                     tuple(f"{g}, {a}" for g in ("bad", "good") for a in ages),
                     D + 2)


def link_chain(loss: Any, delay: Any, sent: Any, name: str) -> LinkChain:
    """The chain of one link from its loss and delay models.

    Parameters
    ----------
    loss : float, GilbertElliott or LossAutomaton
        The link's loss model (a Bernoulli probability, bursts, or a loss
        budget).
    delay : RandomDelay, BurstyDelay or None
        The link's delay model.
    sent : array_like of bool, shape (N,)
        Whether the link carries a packet at each phase of the schedule.
    name : str
        ``'sensor'`` or ``'actuator'``, for messages.

    Returns
    -------
    LinkChain

    Raises
    ------
    ControlArgument
        For a combination no finite chain models: a Gilbert–Elliott loss
        with a delay, a Bernoulli loss with a bursty delay, a loss budget
        with a delay.
    """
    sent = np.asarray(sent, bool).ravel()
    if isinstance(loss, LossAutomaton):
        if delay is not None:
            raise ControlArgument(
                f"{name}_loss: a loss budget beside a delay on the same link "
                f"has no model (the budget counts lost transmissions, the "
                f"delay law delivers them late by chance)")
        return _budget_chain(loss, sent)
    if delay is None:
        return _loss_chain(loss, sent)
    if isinstance(loss, GilbertElliott):
        raise ControlArgument(
            f"{name}_loss: a bursty (Gilbert–Elliott) loss on a delayed link "
            f"has no finite chain here (a packet lost while the channel is "
            f"bad, delayed otherwise, needs the channel's past); give the "
            f"delay law of each channel state instead: "
            f"{name}_delay=ncs.bursty_delay(link, pmf_bad, pmf_good)")
    if isinstance(delay, BurstyDelay):
        if loss:
            raise ControlArgument(
                f"{name}_loss: a loss beside a bursty delay is not a thinning "
                f"of one law (the channel state sets the arrivals); put the "
                f"losses in the delay laws of bursty_delay (pmf_bad, "
                f"pmf_good summing to less than 1), and {name}_loss=0")
        return _bursty_chain(delay, sent)
    return _delay_chain(delay, float(loss), sent)


def timing_chain(probabilities: Any, N: int) -> LinkChain:
    """The sub-sample input delay as a chain: i.i.d. over its grid, the
    emission the index of the delay."""
    p = np.asarray(probabilities, float)
    M = p.size
    return LinkChain(np.tile(p, (N, M, 1)), np.tile(np.arange(M), (N, 1)),
                     M - 1, tuple(f"tau {i}" for i in range(M)))


def product(chains: Sequence[LinkChain]) -> tuple[np.ndarray, np.ndarray]:
    """The independent chains' product, the first chain's state fastest.

    Parameters
    ----------
    chains : sequence of LinkChain
        Of the same period.

    Returns
    -------
    transition : ndarray, shape (N, S, S)
        ``S = Π S_c``; mode ``i = s_0 + S_0 (s_1 + S_1 (s_2 + …))``.
    emissions : ndarray of int, shape (N, S, len(chains))
        Each mode's emission of each chain.
    """
    N = chains[0].period
    T = np.ones((N, 1, 1))
    em = np.zeros((N, 1, 0), int)
    for c in chains:
        T = np.array([np.kron(c.transition[k], T[k]) for k in range(N)])
        S, old = c.size, em.shape[1]
        em = np.concatenate(
            [np.tile(em, (1, S, 1)),
             np.repeat(c.emission, old, axis=1)[:, :, None]], axis=2)
    return T, em


def constraint(chains: Sequence[LinkChain]) -> Constraint | None:
    """The budgets' allowed moves and the law of the rest, per mode.

    Parameters
    ----------
    chains : sequence of LinkChain
        The chains of :func:`product`, in its order.

    Returns
    -------
    Constraint or None
        None when no chain is constrained. Otherwise, per mode of the
        product, the index of its state in the product of the constrained
        chains (their allowed moves the product of theirs) and in the
        product of the others (their transition the product of theirs: an
        i.i.d. law when every row of every phase agrees, else Markov).
    """
    fixed = [c for c in chains if c.constrained]
    if not fixed:
        return None
    rest = [c for c in chains if not c.constrained]
    M = int(np.prod([c.size for c in chains]))
    modes = np.arange(M)
    state = np.zeros(M, int)
    part = np.zeros(M, int)
    stride, scale_c, scale_r = 1, 1, 1
    for c in chains:
        digit = (modes // stride) % c.size
        stride *= c.size
        if c.constrained:
            state += scale_c * digit
            scale_c *= c.size
        else:
            part += scale_r * digit
            scale_r *= c.size
    allowed = product(fixed)[0] > 0
    start = np.ones(1, bool)
    names: list = [()]
    for c in fixed:
        assert c.start is not None
        start = np.kron(c.start, start).astype(bool)
        names = [n + (s,) for s in c.states for n in names]
    N = chains[0].period
    T = product(rest)[0] if rest else np.ones((N, 1, 1))
    if np.all(T == T[:, :1, :]):
        law, transition = np.roll(T[:, 0, :], 1, axis=0), None
    else:
        law, transition = periodic_stationary(T), T
    return Constraint(state, part, allowed, start, law, transition,
                      tuple(n[0] if len(n) == 1 else n for n in names),
                      all(c.known for c in fixed))
