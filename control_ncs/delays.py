"""Delayed links: random and bursty delays of one link
(:ref:`theory-delays`, :ref:`theory-links-compose`).

A delayed link carries packets stamped with their send time; each is
delayed by a random number of steps (a pmf, :class:`RandomDelay`) or by a
law that depends on a Gilbert–Elliott state (:class:`BurstyDelay`), and the
receiver uses the freshest packet it holds. The age of that packet is a
Markov chain over a buffer of ages (:func:`control_ncs.modes.age_chain`);
this module checks the laws and sizes the buffer, nothing more.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .modes import age_chain
from .network import GilbertElliott

__all__ = ["RandomDelay", "random_delay", "BurstyDelay", "bursty_delay"]


class BurstyDelay:
    """A link whose delays come in bursts: a delay law per link state.

    A Gilbert–Elliott chain (:class:`GilbertElliott`) moves between a bad
    and a good state at every step; while it is in state ``g``, a packet of
    age ``c`` still in flight arrives with the hazard of ``pmfs[g]``
    (:ref:`theory-delays`). The receiver keeps the freshest packet, so the
    pair (link state, age) is a Markov chain. A bad state that delivers
    nothing (``pmf = [0]``) and a good state that delivers at once
    (``[1]``) give back the bursty-loss link. Build one with
    :func:`bursty_delay`.

    Parameters
    ----------
    link : GilbertElliott
        The link-state chain (state 0 bad, 1 good).
    pmf_bad, pmf_good : array_like
        The delay laws of the two states (``[0]``: nothing arrives).
    buffer : int, optional
        The oldest usable age (default: the largest delay).

    Attributes
    ----------
    link : GilbertElliott
        The link-state chain (state 0 bad, 1 good).
    pmfs : tuple of ndarray
        The delay laws of the bad and the good state.
    buffer : int
        The oldest usable age.
    loss : float
        For reference: the stationary mix of the two pmfs' losses.

    Examples
    --------
    >>> link = ncs.bursty_delay(ncs.gilbert_elliott(fail=0.1, recover=0.4),
    ...                         [0.2], [0.7, 0.3])
    >>> link.buffer, link.transition().shape
    (1, (1, 6, 6))
    """

    def __init__(self, link: GilbertElliott, pmf_bad: Any, pmf_good: Any,
                 buffer: int | None = None):
        if not isinstance(link, GilbertElliott):
            raise ValueError(f"link: expected a gilbert_elliott link, got "
                             f"{type(link).__name__}")
        pmfs = []
        for name, value in (("pmf_bad", pmf_bad), ("pmf_good", pmf_good)):
            q = np.asarray(value, dtype=float) if not isinstance(
                value, str) else np.array([np.nan])
            if q.ndim != 1 or q.size == 0 or not np.all(np.isfinite(q)) \
                    or np.any(q < 0) or q.sum() > 1.0 + _TOL:
                shown = _listed(q) if q.ndim == 1 and not isinstance(
                    value, str) else repr(value)
                raise ValueError(f"{name}: expected non-negative delay "
                                 f"probabilities summing to at most 1, got "
                                 f"{shown}{_sum_of(q)}")
            pmfs.append(q / max(1.0, q.sum()))
        if not any(np.any(q > 0) for q in pmfs):
            raise ValueError("pmf_bad, pmf_good: no packet ever arrives")
        d = max(int(np.flatnonzero(q)[-1]) if np.any(q > 0) else 0
                for q in pmfs)
        _check_buffer(d, "pmf_bad, pmf_good", 2 * (d + 2),
                      f"a delay of up to {d} steps (a buffer of {d} ages)")
        # the laws up to the largest delay: trailing zeros carry nothing
        pmfs = [q[:d + 1] for q in pmfs]
        self.link, self.pmfs = link, tuple(pmfs)
        self.buffer = _buffer(buffer, d, 2)

    @property
    def loss(self) -> float:
        """The stationary mix of the two pmfs' losses (for reference)."""
        pi = (self.link.loss, 1.0 - self.link.loss)     # P(bad), P(good)
        return float(sum(p * (1.0 - q.sum()) for p, q in zip(pi, self.pmfs)))

    def transition(self, sent: Any = None) -> np.ndarray:
        """The chain of (link state, age), periodic under a schedule.

        Parameters
        ----------
        sent : array_like of bool or 0/1, shape (N,), optional
            Whether a packet is sent at each phase (default: every step).

        Returns
        -------
        ndarray, shape (N, 2 (D + 2), 2 (D + 2))
            States ``(g, a)`` g-major: ``T[k][(g, a), (g', b)] =
            T_link[g, g'] · T_{g'}[a, b]``, the arrivals of the step judged
            by the state ``g'`` the link is in.
        """
        sent = None if sent is None else _sent_flags(sent)
        ages = [age_chain(q, self.buffer, sent) for q in self.pmfs]
        G = self.link.transition
        N, S = ages[0].shape[0], ages[0].shape[1]
        T = np.zeros((N, 2 * S, 2 * S))
        for g in range(2):
            for h in range(2):
                T[:, g * S:(g + 1) * S, h * S:(h + 1) * S] = \
                    G[g, h] * ages[h]
        return T

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, BurstyDelay) and self.buffer == other.buffer
                and self.link == other.link
                and all(np.array_equal(a, b)
                        for a, b in zip(self.pmfs, other.pmfs)))

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return (f"BurstyDelay({self.link!r}, pmf_bad={self.pmfs[0].tolist()}, "
                f"pmf_good={self.pmfs[1].tolist()}, buffer={self.buffer})")


def bursty_delay(link: GilbertElliott, pmf_bad: Any, pmf_good: Any,
                 buffer: int | None = None) -> BurstyDelay:
    """A link with bursty delays: a delay law per link state.

    Parameters
    ----------
    link : GilbertElliott
        The link-state chain (:func:`gilbert_elliott`).
    pmf_bad, pmf_good : array_like
        ``P(δ = c)`` in the bad and the good state (``[0]``: nothing
        arrives).
    buffer : int, optional
        The oldest usable age (default: the largest delay).

    Returns
    -------
    BurstyDelay

    Raises
    ------
    ValueError
        A pmf that is not probabilities summing to at most 1, two laws that
        never deliver, a ``buffer`` below the largest delay, or a delay or
        ``buffer`` beyond ``MAX_BUFFER = 64`` ages.

    Examples
    --------
    A link that delivers at once while good and a step late at best while
    bad:

    >>> link = ncs.bursty_delay(ncs.gilbert_elliott(fail=0.1, recover=0.4),
    ...                         [0.0, 0.5], [1.0])
    >>> round(link.loss, 6)
    0.1
    """
    return BurstyDelay(link, pmf_bad, pmf_good, buffer)


def delay_model(value: Any, name: str) -> "RandomDelay | BurstyDelay | None":
    """A link's delay model: None, a :class:`RandomDelay` or
    :class:`BurstyDelay`, or a delay pmf (``[P(δ = 0), P(δ = 1), …]``,
    buffer = the largest delay)."""
    if value is None or isinstance(value, (RandomDelay, BurstyDelay)):
        return value
    try:
        return random_delay(value)
    except (ValueError, TypeError) as err:
        raise type(err)(f"{name}: {err}") from None


_TOL = 1e-9

#: The oldest age a delayed link's receiver may keep. A buffer of ``D`` ages
#: is a chain of ``D + 2`` states (``2 (D + 2)`` for a bursty link), so a
#: loop over it has at least ``D + 2`` modes per phase and ``D + 1`` states
#: (a stored copy of the plant state, or of the command, per age), and the
#: exact mean that every closed loop carries (python-control's face of a
#: jump system) is a dense matrix of order modes × states: quadratic in
#: ``D``, so its memory grows as ``D⁴``, long before the builder's own
#: limits (``strategies.MAX_LOOP_STATES``, ``modechain.MAX_MODES``) are
#: reached.
#: Measured on the smallest loop (a one-state plant, a static gain, the
#: actuator link's two states: ``2 (D + 2)`` modes), closing it with
#: :func:`control_ncs.feedback`: ``D = 64`` takes 4.5 s and a 1.3 GB peak
#: (a mean of order 8580), ``D = 100`` 38 s (order 20604, 3.4 GB for the
#: mean alone), and ``D = 200`` asks numpy for 49 GiB. A delay of more than
#: 64 samples also says the loop samples much faster than its network
#: delivers: a slower sampling period models it better.
MAX_BUFFER = 64


def _check_buffer(buffer: int, name: str, states: int, what: str) -> None:
    """Refuse a buffer beyond :data:`MAX_BUFFER`, naming the loop it would
    need (a chain of ``states`` states) before anything is allocated."""
    if buffer <= MAX_BUFFER:
        return
    modes, size = states, buffer + 1
    gib = 8.0 * (modes * size) ** 2 / 2 ** 30
    raise ValueError(
        f"{name}: {what} would make the link a chain of {states} states, "
        f"and a loop over it at least {size} states in {modes} modes per "
        f"phase, whose exact mean (a dense matrix of order {modes * size}) "
        f"takes {gib:.3g} GiB; at most MAX_BUFFER = {MAX_BUFFER} ages are "
        f"accepted (a delay of more than {MAX_BUFFER} samples: sample the "
        f"plant more slowly)")


def _buffer(buffer: Any, d: int, chain: int) -> int:
    """The buffer of a delay link whose largest delay is ``d`` (default
    ``d``), checked; ``chain`` states per age (2 for a bursty link)."""
    if buffer is None:
        buffer = d
    if isinstance(buffer, (bool, np.bool_)) or not isinstance(
            buffer, (int, np.integer)) or buffer < d:
        raise ValueError(f"buffer: expected an int >= the largest delay "
                         f"{d}, got {buffer!r}")
    buffer = int(buffer)
    _check_buffer(buffer, "buffer", chain * (buffer + 2),
                  f"a buffer of {buffer} ages")
    return buffer


def _sum_of(q: np.ndarray) -> str:
    """``', summing to 1.1'`` for a message about a pmf summing above 1."""
    total = float(np.sum(q)) if q.ndim == 1 and q.size else math.nan
    return f", summing to {total:.6g}" if total > 1.0 + _TOL else ""


def _listed(q: np.ndarray) -> str:
    """A pmf for a message: its entries as given, the first ten of many."""
    if q.size <= 10:
        return str(q.tolist())
    return f"{str(q[:10].tolist())[:-1]}, ...] ({q.size} entries)"


def _sent_flags(sent: Any) -> np.ndarray:
    """``sent`` as one bool per phase: bools or 0/1 only (a 2 or 0.5 is
    not a flag)."""
    s = np.asarray(sent)
    if s.ndim > 1 or s.size == 0 or not (
            s.dtype == bool or (s.dtype.kind in "iuf"
                                and np.all((s == 0) | (s == 1)))):
        raise ValueError(f"sent: expected one flag (a bool, or 0/1) per "
                         f"phase, got {sent!r}")
    return s.astype(bool).ravel()


class RandomDelay:
    """A link that delays packets at random; the freshest packet wins.

    Every packet carries its send time and is delayed by ``δ`` steps with
    probability ``pmf[δ]``, independently of the others; ``1 - Σ pmf`` is
    the probability that it never arrives. The receiver uses the newest
    packet it holds, so the age of what it uses is a Markov chain over the
    ages ``0..buffer`` and one "stale" state (:ref:`theory-delays`). Build
    one with :func:`random_delay`.

    Attributes
    ----------
    pmf : ndarray, shape (d + 1,)
        ``P(δ = c)``, ``c = 0..d`` (``pmf[-1] > 0``).
    loss : float
        ``1 - Σ pmf``: the packet never arrives.
    max_delay : int
        ``d``, the largest delay of positive probability.
    buffer : int
        ``D ≥ d``: the oldest age still usable; older is stale.
    transition : ndarray, shape (D + 2, D + 2)
        ``T[a, b] = P(a⁺ = b | a)`` when a packet is sent at every step;
        states ``0..D``, then stale.
    states : list of str
        ``'age 0'``, ..., ``'age D'``, ``'stale'``.

    Examples
    --------
    >>> link = ncs.random_delay([0.5, 0.3, 0.1], buffer=3)
    >>> round(link.loss, 12), link.max_delay, link.buffer
    (0.1, 2, 3)
    >>> link.transition.round(12).tolist()[1]
    [0.5, 0.3, 0.2, 0.0, 0.0]
    """

    def __init__(self, pmf: Any, buffer: int | None = None):
        q = np.asarray(pmf)
        if q.dtype == object or np.iscomplexobj(q) or q.ndim != 1 \
                or q.size == 0:
            raise ValueError(f"pmf: expected a 1-D array of delay "
                             f"probabilities P(δ = 0), P(δ = 1), ..., got "
                             f"{pmf!r}")
        try:
            q = q.astype(float)
        except (TypeError, ValueError):
            raise ValueError(f"pmf: expected real probabilities, got "
                             f"{pmf!r}") from None
        if not np.all(np.isfinite(q)) or np.any(q < 0) \
                or q.sum() > 1.0 + _TOL:
            raise ValueError(f"pmf: expected non-negative probabilities "
                             f"summing to at most 1 (the rest is the loss), "
                             f"got {_listed(q)}{_sum_of(q)}")
        if not np.any(q > 0):
            raise ValueError("pmf: no packet ever arrives (all zeros); a "
                             "link that never delivers closes no loop")
        d = int(np.flatnonzero(q)[-1])
        _check_buffer(d, "pmf", d + 2, f"a delay of up to {d} steps (a "
                      f"buffer of {d} ages)")
        self.pmf = q[:d + 1] / max(1.0, q.sum())
        self.max_delay = d
        self.buffer = _buffer(buffer, d, 1)

    @property
    def loss(self) -> float:
        """``1 - Σ pmf``: the probability that a packet never arrives."""
        return float(max(0.0, 1.0 - self.pmf.sum()))

    @property
    def transition(self) -> np.ndarray:
        """The age chain when a packet is sent at every step."""
        return age_chain(self.pmf, self.buffer)[0]

    def age_transition(self, sent: Any) -> np.ndarray:
        """The age chain under a schedule: one matrix per phase.

        Parameters
        ----------
        sent : array_like of bool or 0/1, shape (N,)
            Whether the link's node sends at each phase.

        Returns
        -------
        ndarray, shape (N, D + 2, D + 2)
            ``T[k][a, b] = P(a_{k+1} = b | a_k = a)``.

        Raises
        ------
        ValueError
            ``sent`` is empty or holds anything but bools or 0/1.

        Examples
        --------
        A link that sends at even phases only: at the step after phase 0
        no fresh packet exists, and the one sent at phase 0 has arrived by
        then (delays of at most one step), so the age is 1 from any age:

        >>> link = ncs.random_delay([0.5, 0.5])
        >>> link.age_transition([1, 0])[0].tolist()
        [[0.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0]]
        """
        return age_chain(self.pmf, self.buffer, _sent_flags(sent))

    @property
    def states(self) -> list[str]:
        """State names: ``'age 0'``, ..., ``'age D'``, ``'stale'``."""
        return [f"age {a}" for a in range(self.buffer + 1)] + ["stale"]

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, RandomDelay) and self.buffer == other.buffer
                and np.array_equal(self.pmf, other.pmf))

    def __hash__(self) -> int:
        return hash((self.pmf.tobytes(), self.buffer))

    def __repr__(self) -> str:
        q = ", ".join(f"{x:.4g}" for x in self.pmf)
        return (f"RandomDelay(pmf=[{q}], buffer={self.buffer}; "
                f"loss={self.loss:.4g})")

    def __reduce__(self) -> tuple:
        return (RandomDelay, (self.pmf, self.buffer))


def random_delay(pmf: Any, buffer: int | None = None) -> RandomDelay:
    """A link with random integer delays; the freshest packet wins.

    Parameters
    ----------
    pmf : array_like, shape (d + 1,)
        ``pmf[c] = P(δ = c)``: a packet sent at step ``t`` arrives at
        ``t + c``. Non-negative; ``1 - Σ pmf`` is the loss probability.
    buffer : int, optional
        The oldest age the receiver still uses (default: the largest delay
        ``d``); an older packet is stale.

    Returns
    -------
    RandomDelay

    Raises
    ------
    ValueError
        A pmf that is not a 1-D array of probabilities summing to at most 1,
        that never delivers, or a ``buffer`` below the largest delay; a
        delay or a ``buffer`` beyond ``MAX_BUFFER = 64`` ages (the message
        names the loop it would need).

    See Also
    --------
    gilbert_elliott : a link that loses packets in bursts.

    Examples
    --------
    Half the packets arrive at once, 30 % a step late, 10 % two steps
    late, 10 % never; from any age ``≥ 2`` nothing new arrives with
    probability 0.1, the loss:

    >>> link = ncs.random_delay([0.5, 0.3, 0.1])
    >>> link.states
    ['age 0', 'age 1', 'age 2', 'stale']
    >>> link.transition.round(12)[2].tolist()
    [0.5, 0.3, 0.1, 0.1]
    """
    return RandomDelay(pmf, buffer)
