"""Network strategies as builders of the generic jump system (MATH §4, §8b, §10).

Each builder turns a :class:`~control_ncs.plant.NetworkedStateSpace` into a
:class:`~control_ncs.jump.JumpPlant` with the four network modes of each
phase listed in the order of paper eq. 14, ``(θ1, θ2) = (0,0), (1,0), (0,1),
(1,1)``; the last one is loss-free. Builders never call a solver, and nothing
downstream looks at schedules or losses again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial
from typing import Any, Callable

import numpy as np
from control.exception import ControlArgument, ControlDimension

from ._checks import choice, no_extra_kwargs, real_array
from .gain import PeriodicGain
from .jump import JumpPlant, JumpStateSpace, check_lifted_size
from .plant import NetworkedStateSpace

__all__ = ["build", "feedback", "loop_closes"]

MODES = ((0, 0), (1, 0), (0, 1), (1, 1))


def build(P: NetworkedStateSpace, controller: str = "static",
          actuator: str = "zero", *, period: int | None = None) -> JumpPlant:
    """The networked loop of ``P`` as a :class:`JumpPlant`, before the gain.

    The gain the plant is closed with (:meth:`JumpPlant.close`,
    :func:`control_ncs.passivesyn`) acts in positive feedback, as it is:
    ``v_k = K_k E_k ξ`` (``u = K y`` for the static controller, ``u = K x̂``
    for the predictor). Negate a gain designed for ``u = -K x``.

    Parameters
    ----------
    P : NetworkedStateSpace
        Plant with its network.
    controller : {'static', 'predictor'}
        ``'static'``: ``v = K_k ŷ`` with ``ŷ = θ1 Σ1 y`` (paper eq. 2-3,
        MATH §4). ``'predictor'``: the model-based controller of MATH §8b,
        ``v = K_k x̂`` (needs ``y = x``).
    actuator : {'zero', 'hold'}
        What an actuator applies when its message is lost or not scheduled.
    period : int, optional
        Build over this many phases (a multiple of ``P.period``), e.g. to
        match a gain sequence.

    Returns
    -------
    JumpPlant
        Unmerged: four modes per phase, eq. 14 order; ``nominal`` is the
        loss-free mode.

    Raises
    ------
    ControlArgument
        If ``P`` is not a :class:`NetworkedStateSpace`, the controller or
        actuator is unknown, or the predictor is asked for without ``y = x``.
    ValueError
        If ``period`` is not a multiple of ``P.period`` or its lifted face
        would be too large.

    Examples
    --------
    The scalar plant ``x⁺ = 2x + u`` with ``y = x`` over a network that
    loses the actuator's message with probability 0.2; the modes are
    ``(θ1, θ2) = (0, 0), (0, 1), (1, 0), (1, 1)``:

    >>> P = nss([[2.0]], [[0.0, 1.0]], [[0.0], [1.0]],
    ...         [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1, actuator_loss=0.2)
    >>> plant = build(P)
    >>> plant.probabilities.tolist(), plant.nominal.tolist()
    ([[0.0, 0.2, 0.0, 0.8]], [3])
    >>> plant.close(np.full((1, 1, 1), -2.0)).modes.A[0, :, 0, 0].tolist()
    [2.0, 0.0]
    """
    if not isinstance(P, NetworkedStateSpace):
        raise ControlArgument(f"P: expected a NetworkedStateSpace (see nss()), "
                              f"got {type(P).__name__}")
    strategy = _strategy(controller, actuator)
    N = P.period if period is None else int(period)
    if N % P.period:
        raise ValueError(f"period: {N} is not a multiple of the plant's network "
                         f"period {P.period}")
    # the state has at least n entries: refuse a hopeless period before the
    # per-phase work, not after it
    check_lifted_size(P.nstates, len(P.disturbance_labels),
                      len(P.performance_labels), N, "P")
    if strategy.needs_state and not _measures_state(P):
        raise ControlArgument(
            f"controller={controller!r} needs the full state measured: y = x "
            f"(C2 = I), got C2 of shape {P.C2.shape}")
    # a phase's matrices depend on k only through the schedules' rows at k
    # and k + 1: build each distinct phase once (long periods repeat them)
    s1 = P.sensor_schedule.pattern
    s2 = P.actuator_schedule.pattern
    built: dict = {}
    fields = []
    for k in range(N):
        key = (s1[k % P.period].tobytes(), s1[(k + 1) % P.period].tobytes(),
               s2[k % P.period].tobytes())
        if key not in built:
            built[key] = [strategy.phase(P, k, t1, t2) for (t1, t2) in MODES]
        fields.extend(built[key])
    stacked = {f: np.array([m[f] for m in fields]).reshape(
        (N, 4) + fields[0][f].shape) for f in fields[0] if f != "E"}
    E = np.array([fields[4 * k]["E"] for k in range(N)])
    a1, a2 = P.sensor_loss, P.actuator_loss
    prob = P.mode_probabilities()
    p = np.tile([prob[m] for m in MODES], (N, 1))
    # bursty links (MATH §11): the channels evolve at every step whether or
    # not a node is scheduled; the predictor's mode (θ1,k+1, θ2,k) follows
    # the same Kronecker chain as the static one's (θ1,k, θ2,k)
    T = P.mode_transition()
    transition = None if T is None else np.tile(T, (N, 1, 1))
    info = dict(controller=controller, actuator=actuator, sensor_loss=a1,
                actuator_loss=a2, plant_period=P.period, plant=P.name)
    if T is not None:
        info.update(sensor_link=P.sensor_link, actuator_link=P.actuator_link)
    return JumpPlant(stacked["A"], stacked["Bu"], stacked["Bw"], stacked["Cz"],
                     stacked["Du"], stacked["Dw"], E, p, P.dt,
                     transition=transition, nominal=np.full(N, 3), inputs=P.disturbance_labels,
                     outputs=P.performance_labels,
                     states=strategy.states(P), info=info)


def _measures_state(P: NetworkedStateSpace) -> bool:
    return P.C2.shape == (P.nstates, P.nstates) and np.array_equal(
        P.C2, np.eye(P.nstates))


def _static_phase(P: NetworkedStateSpace, k: int, t1: int, t2: int, *,
                  actuator: str) -> dict:
    """Memoryless gain, MATH §4: ``u = θ2 Σ2 K θ1 Σ1 y``."""
    n, m2 = P.nstates, P.ncon
    S1 = P.sensor_schedule.selection(k)
    S2 = P.actuator_schedule.selection(k)
    g = t1 * t2
    A, B1, B2, C1, D11, D12 = P.A, P.B1, P.B2, P.C1, P.D11, P.D12
    E = S1 @ P.C2
    if actuator == "zero":
        return dict(A=A, Bu=g * B2 @ S2, Bw=B1, Cz=C1, Du=g * D12 @ S2,
                    Dw=D11, E=E)
    # hold: ξ = [x; u⁻], u = (I - θ2 Σ2) u⁻ + θ2 Σ2 v
    H = _held(P)
    h = H.shape[0]
    keep = np.eye(m2) - t2 * S2
    Z = np.zeros
    return dict(
        A=np.block([[A, B2 @ keep @ H.T], [Z((h, n)), H @ keep @ H.T]]),
        Bu=g * np.vstack([B2 @ S2, H @ S2]),
        Bw=np.vstack([B1, Z((h, B1.shape[1]))]),
        Cz=np.hstack([C1, D12 @ keep @ H.T]), Du=g * D12 @ S2, Dw=D11,
        E=np.hstack([E, Z((E.shape[0], h))]))


def _held(P: NetworkedStateSpace) -> np.ndarray:
    """Selector of the actuators whose last value a hold actuator keeps.

    An actuator that no phase addresses applies its initial value 0 forever;
    keeping it in the state would add an eigenvalue 1 to every mode (a
    constant nobody can change), so it is left out.
    """
    idx = np.flatnonzero(P.actuator_schedule.pattern.any(axis=0))
    H = np.zeros((idx.size, P.ncon))
    H[np.arange(idx.size), idx] = 1.0
    return H


def _predictor_phase(P: NetworkedStateSpace, k: int, t1_next: int, t2: int,
                     *, actuator: str) -> dict:
    """Model-based controller, MATH §8b; the mode is ``(θ1,k+1, θ2,k)``.

    State ``[x̂; e]`` (zero actuator) or ``[x̂; u⁻; e]`` (hold; ``u⁻`` the
    last inputs of the actuators some phase addresses), with ``x̂`` the
    estimate after the sensor update and ``e = x - x̂``.
    """
    n, m2 = P.nstates, P.ncon
    S2 = P.actuator_schedule.selection(k)
    R = t1_next * P.sensor_schedule.selection(k + 1)
    A, B1, B2, C1, D11, D12 = P.A, P.B1, P.B2, P.C1, P.D11, P.D12
    I, Z = np.eye(n), np.zeros
    m1 = B1.shape[1]
    if actuator == "zero":
        return dict(
            A=np.block([[A, R @ A], [Z((n, n)), (I - R) @ A]]),
            Bu=t2 * np.vstack([B2 @ S2, Z((n, m2))]),
            Bw=np.vstack([R @ B1, (I - R) @ B1]),
            Cz=np.hstack([C1, C1]), Du=t2 * D12 @ S2, Dw=D11,
            E=np.hstack([I, Z((n, n))]))
    H = _held(P)
    h = H.shape[0]
    keep = np.eye(m2) - t2 * S2
    # the gain acts on [x̂; u⁻] with all m2 last inputs (never-addressed ones
    # are identically zero and left out of the state, see _held)
    E = np.zeros((n + m2, 2 * n + h))
    E[:n, :n] = I
    E[n:, n:n + h] = H.T
    return dict(
        A=np.block([[A, B2 @ keep @ H.T, R @ A],
                    [Z((h, n)), H @ keep @ H.T, Z((h, n))],
                    [Z((n, n)), Z((n, h)), (I - R) @ A]]),
        Bu=t2 * np.vstack([B2 @ S2, H @ S2, Z((n, m2))]),
        Bw=np.vstack([R @ B1, Z((h, m1)), (I - R) @ B1]),
        Cz=np.hstack([C1, D12 @ keep @ H.T, C1]), Du=t2 * D12 @ S2, Dw=D11,
        E=E)


def _plant_states(P: NetworkedStateSpace) -> list[str]:
    return list(P.state_labels)


def _held_names(P: NetworkedStateSpace) -> list[str]:
    controls = P.input_labels[len(P.disturbance_labels):]
    return [f"{controls[i]}_prev"
            for i in np.flatnonzero(P.actuator_schedule.pattern.any(axis=0))]


def _predictor_states(P: NetworkedStateSpace, hold: bool) -> list[str]:
    x = list(P.state_labels)
    return ([f"{s}_hat" for s in x] + (_held_names(P) if hold else [])
            + [f"{s}_err" for s in x])


@dataclass(frozen=True)
class Strategy:
    """How one (controller, actuator) pair builds a phase of the jump plant.

    Attributes
    ----------
    phase : callable
        ``phase(P, k, t1, t2)`` -> dict of ``A, Bu, Bw, Cz, Du, Dw, E`` of the
        network mode ``(t1, t2)`` at phase ``k``.
    states : callable
        ``states(P)`` -> names of the state ``ξ``.
    memoryless : bool
        The controller keeps nothing between messages, so it acts only at
        phases that schedule a sensor and an actuator together (MATH §4).
    needs_state : bool
        The controller needs ``y = x`` (``C2 = I``).
    """

    phase: Callable[..., dict]
    states: Callable[[NetworkedStateSpace], list]
    memoryless: bool
    needs_state: bool


#: Every network strategy, keyed by ``(controller, actuator)``: a new one is
#: one entry here (and its gain shape in :class:`~control_ncs.jump.JumpPlant`
#: follows from its ``E``). The accepted choices are derived from the keys.
STRATEGIES: dict[tuple[str, str], Strategy] = {
    ("static", "zero"): Strategy(
        partial(_static_phase, actuator="zero"), _plant_states,
        memoryless=True, needs_state=False),
    ("static", "hold"): Strategy(
        partial(_static_phase, actuator="hold"),
        lambda P: _plant_states(P) + _held_names(P),
        memoryless=True, needs_state=False),
    ("predictor", "zero"): Strategy(
        partial(_predictor_phase, actuator="zero"),
        partial(_predictor_states, hold=False),
        memoryless=False, needs_state=True),
    ("predictor", "hold"): Strategy(
        partial(_predictor_phase, actuator="hold"),
        partial(_predictor_states, hold=True),
        memoryless=False, needs_state=True),
}


def _strategy(controller: Any, actuator: Any) -> Strategy:
    """The registered strategy, or ControlArgument naming the choices."""
    choice(controller, "controller", dict.fromkeys(c for c, _ in STRATEGIES))
    choice(actuator, "actuator", dict.fromkeys(a for _, a in STRATEGIES))
    if (controller, actuator) not in STRATEGIES:
        raise ControlArgument(
            f"actuator: {actuator!r} is not available with controller="
            f"{controller!r}; available pairs: {sorted(STRATEGIES)}")
    return STRATEGIES[controller, actuator]


def loop_closes(P: NetworkedStateSpace) -> bool:
    """Whether a memoryless (static) gain can act on the loop of ``P``.

    It can only at a phase that schedules a sensor and an actuator together
    (MATH §4).

    Parameters
    ----------
    P : NetworkedStateSpace
        Plant with its network.

    Returns
    -------
    bool
        True if some phase schedules a sensor and an actuator together.

    Examples
    --------
    >>> P = nss([[2.0]], [[0.0, 1.0]], [[0.0], [1.0]],
    ...         [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
    ...         sensor_schedule=[1, 0], actuator_schedule=[0, 1])
    >>> loop_closes(P), loop_closes(P.with_network(actuator_schedule=[1, 1]))
    (False, True)
    """
    return bool((P.sensor_schedule.pattern.any(axis=1)
                 & P.actuator_schedule.pattern.any(axis=1)).any())


def feedback(P: NetworkedStateSpace, K: Any, *, controller: str | None = None,
             actuator: str | None = None, **kwargs: Any) -> JumpStateSpace:
    """Close the networked loop of ``P`` with a (periodic) gain.

    The gain is applied as it is, in positive feedback: the controller sends
    ``v_k = K_k ŷ_k`` (static: ``u = K y`` when every message arrives, so
    ``u = K x`` for ``y = x``) or ``v_k = K_k x̂_k`` (predictor: ``u = K x̂``).
    A gain designed for ``u = -K x``, as :func:`control.dlqr` returns, must be
    negated (see the Examples).

    Parameters
    ----------
    P : NetworkedStateSpace
        Plant with its network.
    K : PeriodicGain or array_like
        A gain from :func:`control_ncs.passivesyn`, or gains of shape
        ``(m2, nk)`` (constant) or ``(N_K, m2, nk)`` (periodic; the loop's
        period is the least common multiple of ``N_K`` and ``P.period``).
        ``nk`` is ``nmeas`` for the static controller, ``n`` for the
        predictor, plus ``m2`` for the predictor with a hold actuator.
    controller : {'static', 'predictor'}, optional
        Default: the gain's own kind, else ``'static'``.
    actuator : {'zero', 'hold'}, optional
        Default: the gain's own strategy, else ``'zero'``.
    **kwargs
        None are accepted: an unknown keyword raises ``TypeError``.

    Returns
    -------
    JumpStateSpace
        The closed loop ``w → z`` (modes merged); ``info`` records the
        controller, actuator and gains.

    Raises
    ------
    ValueError
        If a static gain can never close the loop because no phase schedules
        a sensor and an actuator together (e.g. a shared channel, MATH §4),
        or if ``K`` has non-finite entries.
    ControlDimension
        If the gain has the wrong shape.

    Examples
    --------
    >>> import numpy as np
    >>> P = nss([[2.0]], [[0.0, 1.0]], [[0.0], [1.0]], [[1.0, 0.0], [0.0, 0.0]],
    ...         nmeas=1, ncon=1, actuator_loss=0.2)
    >>> CL = feedback(P, [[-2.0]])                 # u = -2 x when it arrives
    >>> CL.modes.probabilities.round(3).tolist()
    [[0.2, 0.8]]
    >>> CL.modes.A[0, :, 0, 0].tolist()           # lost: 2, arrived: 2 - 2
    [2.0, 0.0]

    An LQR gain is designed for ``u = -K x``: pass ``-K``.

    >>> K, _, _ = ct.dlqr(P.A, P.B2, np.eye(1), np.eye(1))
    >>> CL = feedback(P, -K)
    >>> bool(ms_radius(CL) < 1)
    True
    """
    no_extra_kwargs("feedback", kwargs)
    if isinstance(K, PeriodicGain):
        controller = controller or K.controller
        actuator = actuator or K.actuator
        gains = K.gains
    else:
        # validate here so that messages name the argument K, not 'gains'
        arr = real_array(K, "K", ndim=(2, 3))
        if 0 in arr.shape:
            raise ControlDimension(f"K: expected a non-empty gain (at least "
                                   f"one phase, one row, one column), got "
                                   f"shape {arr.shape}")
        gains = PeriodicGain(arr, controller or "static",
                             actuator or "zero").gains
    if 0 in gains.shape:
        raise ControlDimension(f"K: expected a non-empty gain (at least one "
                               f"phase, one row, one column), got shape "
                               f"{gains.shape}")
    controller, actuator = controller or "static", actuator or "zero"
    strategy = _strategy(controller, actuator)
    if not isinstance(P, NetworkedStateSpace):
        raise ControlArgument(f"P: expected a NetworkedStateSpace (see nss()), "
                              f"got {type(P).__name__}")
    if strategy.memoryless and not loop_closes(P):
        raise ValueError(
            "K: a memoryless (static) gain never closes this loop: no phase "
            "schedules a sensor and an actuator together (a shared channel "
            "forces this, MATH §4), so F_k = Σ2 K Σ1 = 0 and the plant runs "
            "open loop. Use controller='predictor', which keeps a model-based "
            "estimate between messages.")
    N = math.lcm(P.period, gains.shape[0])
    plant = build(P, controller, actuator, period=N)
    want = plant.gain_shape()[1:]
    if gains.shape[1:] != want:
        raise ControlDimension(
            f"K: expected gains of shape {want} (or ({gains.shape[0]}, "
            f"{want[0]}, {want[1]}) per phase) for controller={controller!r}, "
            f"actuator={actuator!r}, got {gains.shape[1:]}")
    gains = np.tile(gains, (N // gains.shape[0], 1, 1))
    return plant.close(gains)
