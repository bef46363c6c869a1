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

The two links are independent: the network's mode chain is the product of
the links' chains with the schedule's phases (:func:`product`). This module
is the one place that knows which link kind produced a chain; the builder
(:mod:`control_ncs.strategies`) reads only the chains.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
from control.exception import ControlArgument

from .modes import age_chain
from .network import BurstyDelay, GilbertElliott, RandomDelay

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
    """

    transition: np.ndarray
    emission: np.ndarray
    buffer: int
    states: tuple
    nominal: int = 0

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
        return LinkChain(np.roll(self.transition, -1, axis=0),
                         np.roll(self.emission, -1, axis=0), self.buffer,
                         self.states, self.nominal)

    def pairs(self) -> "LinkChain":
        """The chain of consecutive states ``(s_k, s_{k+1})`` at phase ``k``,
        ``s_k`` the slow index; the emission is ``s_{k+1}``'s.

        Whether the packet in use at ``k + 1`` is new (fresher than the one
        at ``k``) depends on both; the estimator corrects only on a new
        packet (:ref:`theory-delays`)."""
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
                         self.states, self.nominal)


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
    loss : float or GilbertElliott
        The link's loss model (a Bernoulli probability, or bursts).
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
        with a delay, or a Bernoulli loss with a bursty delay.
    """
    sent = np.asarray(sent, bool).ravel()
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
