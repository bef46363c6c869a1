"""The loop's mode chain: the product of its links' chains, as the
controller kind reads them (:ref:`theory-links-compose`).

Each link is one chain with an emission (:mod:`control_ncs.links`); the
network's modes are tuples of their states (and of the sub-sample timing's),
the sensor chain read one step ahead for controllers with memory and in
pairs of consecutive ages for the estimator over a buffered link. The
builder (:mod:`control_ncs.strategies`) writes one mode per tuple.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._timing import timing_chain
from .constrained import Constraint
from .links import LinkChain, constraint, link_chain, product
from .modes import periodic_stationary
from .plant import NetworkedStateSpace

__all__: list[str] = []

#: Largest number of network modes per phase.
MAX_MODES = 20000


@dataclass(frozen=True)
class Network:
    """The mode chain of a loop: the product of its links' chains.

    Attributes
    ----------
    sensor, actuator : LinkChain
        The links as the controller kind reads them (the sensor chain one
        step ahead for controllers with memory, in pairs for the
        estimator over a buffered link).
    timing : LinkChain or None
        Sub-sample timing: the pairs ``(s, τ)`` of the sample's and the
        input's delays.
    transition : ndarray, shape (N, M, M)
    emissions : ndarray of int, shape (N, M, 4)
        Per mode: sensor age, actuator age, the index of the timing pair
        whose ``τ`` delays the input (0 without one) and of the pair whose
        ``s`` delays the sample the mode reads (the same pair for the
        static gain, the next period's for the controllers with memory,
        which read the measurement at the end of the step).
    previous : ndarray of int, shape (N, M), or None
        The sensor age the step before (pairs only).
    constraint : Constraint or None
        With a loss budget among the links: the budget state and the
        stochastic state of each mode, the moves the budgets allow and the
        law of the rest (:ref:`theory-worst-case`); ``transition`` then
        mixes 0/1 moves with probabilities and is not a law.
    """

    sensor: LinkChain
    actuator: LinkChain
    timing: LinkChain | None
    transition: np.ndarray
    emissions: np.ndarray
    previous: np.ndarray | None
    constraint: Constraint | None = None

    @property
    def count(self) -> int:
        """Number of modes per phase."""
        return self.transition.shape[1]

    def law(self) -> tuple[np.ndarray, np.ndarray | None]:
        """``(probabilities, transition)``: i.i.d. modes when every row of
        every phase is the same (transition None), else the periodic
        stationary marginals and the chain. Over a loss budget: the
        probability of each mode's stochastic state given its budget state
        (rows sum to 1 over the modes of one budget state), and no
        transition (:attr:`constraint` holds the rest)."""
        if self.constraint is not None:
            c = self.constraint
            return np.array([c.weights(k) for k in range(c.period)]), None
        T = self.transition
        if np.all(T == T[:, :1, :]):
            return np.roll(T[:, 0, :], 1, axis=0), None
        return periodic_stationary(T), T

    def nominal(self) -> np.ndarray:
        """The loss-free mode of each phase: every chain in its best state
        (delivered, age 0, the first delay)."""
        chains = [self.sensor, self.actuator] + (
            [] if self.timing is None else [self.timing])
        i, scale = 0, 1
        for c in chains:
            i += scale * c.nominal
            scale *= c.size
        return np.full(self.transition.shape[0], i)

    def observed(self) -> np.ndarray:
        """What the controller knows of the previous mode, per phase: equal
        labels for modes whose emissions (ages the controller reads or is
        told through acknowledgements) are equal; the sub-sample delay is
        never seen. A budget's state is known when its automaton is
        deterministic (the controller follows it from the outcomes)."""
        em = self.emissions[:, :, :2]
        c = self.constraint
        if c is not None and c.known:
            em = np.concatenate([em, np.broadcast_to(
                c.state[None, :, None], em.shape[:2] + (1,))], axis=2)
        if self.previous is not None:
            em = np.concatenate([em, self.previous[:, :, None]], axis=2)
        em = np.roll(em, 1, axis=0)                 # [k] = the mode at k - 1
        out = np.zeros(em.shape[:2], int)
        for k in range(em.shape[0]):
            _, out[k] = np.unique(em[k], axis=0, return_inverse=True)
        return out


def measurement_ages(P: NetworkedStateSpace) -> int:
    """How many ages of the measurement the sensor link can deliver (its
    chain's buffer + 1; 1 for an undelayed link): a static gain reads one
    block of columns per age."""
    sent = P.sensor_schedule.pattern.any(axis=1)
    return link_chain(P.sensor_link, P.sensor_delay, sent, "sensor").buffer + 1


def network(P: NetworkedStateSpace, controller: str, N: int) -> Network:
    """The mode chain of ``P``'s loop with a controller of this kind."""
    sent = [P.sensor_schedule.repeat(N).pattern.any(axis=1),
            P.actuator_schedule.repeat(N).pattern.any(axis=1)]
    sensor = link_chain(P.sensor_link, P.sensor_delay, sent[0], "sensor")
    actuator = link_chain(P.actuator_link, P.actuator_delay, sent[1],
                          "actuator")
    previous = None
    if controller in ("predictor", "estimator") and sensor.buffer:
        # the estimator corrects only on a new packet: consecutive ages
        previous = sensor.previous()
        sensor = sensor.pairs()
    elif controller != "static":
        sensor = sensor.shifted()
    chains = [sensor, actuator]
    timing = None
    if P.input_delay is not None:
        timing = timing_chain(P.input_delay, N, controller != "static")
        chains.append(timing)
    size = int(np.prod([c.size for c in chains]))
    if size > MAX_MODES:
        raise ValueError(
            f"P: the network has {size} modes per phase (sensor link "
            f"{sensor.size} states x actuator link {actuator.size}"
            f"{'' if timing is None else f' x {timing.size} delays'}), more "
            f"than MAX_MODES = {MAX_MODES}; use shorter buffers")
    T, em = product(chains)
    if previous is not None:        # per mode of the product
        previous = previous[:, np.arange(T.shape[1]) % sensor.size]
    if timing is None:
        em = np.concatenate([em, np.zeros(em.shape[:2] + (2,), int)], axis=2)
    else:           # the pair code c·M + d as the two pair indices
        assert P.input_delay is not None
        M = P.input_delay.taus.size
        em = np.concatenate([em[:, :, :2], em[:, :, 2:] // M,
                             em[:, :, 2:] % M], axis=2)
    return Network(sensor, actuator, timing, T, em, previous,
                   constraint(chains))
