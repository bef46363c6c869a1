"""Network strategies as builders of the generic jump system
(:ref:`theory-static-loop`, :ref:`theory-predictor`,
:ref:`theory-jump-system`).

Each builder turns a :class:`~control_ncs.plant.NetworkedStateSpace` into a
:class:`~control_ncs.jump.JumpPlant` with the four network modes of each
phase listed in the order of paper eq. 14, ``(θ1, θ2) = (0,0), (1,0), (0,1),
(1,1)``; the last one is loss-free. Builders never call a solver, and nothing
downstream looks at schedules or losses again.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from functools import partial
from typing import Any, Callable

import control as ct
import numpy as np
from control.exception import ControlArgument, ControlDimension

from ._checks import (caller_stacklevel, choice, no_extra_kwargs,
                      positive_int, real_array)
from .exceptions import ScheduleWarning
from .gain import PeriodicGain
from ._lifting import check_lifted_size
from .jump import JumpStateSpace
from .delays import delayed_loop
from .openloop import JumpPlant
from ._lti import lti_operand
from .plant import NetworkedStateSpace
from ._sampling import undelayed_entry

__all__ = ["build", "feedback", "loop_closes", "require_state_measured"]

MODES = ((0, 0), (1, 0), (0, 1), (1, 1))


def build(P: NetworkedStateSpace, controller: str = "static",
          actuator: str = "zero", *, period: int | None = None,
          sensor: str = "zero", controller_order: int = 0,
          estimator_gain: Any = None) -> JumpPlant:
    """The networked loop of ``P`` before the gain (a JumpPlant).

    The gain the plant is closed with (:meth:`JumpPlant.close`,
    :func:`control_ncs.passivesyn`) acts in positive feedback, as it is:
    ``v_k = K_k E_k ξ`` (``u = K y`` for the static controller, ``u = K x̂``
    for the predictor and the estimator; for an LTI controller the "gain"
    is its realisation, see below). Negate a gain designed for
    ``u = -K x``, such as :func:`control.dlqr`'s.

    Parameters
    ----------
    P : NetworkedStateSpace
        Plant with its network.
    controller : {'static', 'predictor', 'estimator', 'lti'}
        ``'static'``: ``v = K_k ŷ`` with ``ŷ = θ1 Σ1 y`` (paper eq. 2-3,
        :ref:`theory-static-loop`). ``'predictor'``: the model-based controller
        of :ref:`theory-predictor`, ``v = K_k x̂`` (needs ``y = x``).
        ``'estimator'``: :ref:`theory-output-feedback`, the predictor corrected
        through ``estimator_gain`` ``L_k`` for any ``y = C2 x``;
        ``v = K_k x̂``. ``'lti'``: a discrete-time LTI controller
        ``xc⁺ = Ac xc + Bc ŷ``, ``v = Cc xc + Dc ŷ`` of order
        ``controller_order``; its gain is ``[[Dc, Cc], [Bc, Ac]]`` acting on
        ``[ŷ; xc]`` (use :func:`feedback` with the controller itself).
    actuator : {'zero', 'hold'}
        What an actuator applies when its message is lost or not scheduled.
    period : int, optional
        Build over this many phases (a multiple of ``P.period``), e.g. to
        match a gain sequence.
    sensor : {'zero', 'hold'}
        LTI controller only: what it receives for a lost or unscheduled
        measurement, 0 (the paper's eq. 2) or the last received value.
    controller_order : int
        LTI controller only: its number of states ``nc``.
    estimator_gain : array_like, shape (n, nmeas) or (N_L, n, nmeas)
        Estimator only (required): the correction gains ``L_k``.

    Returns
    -------
    JumpPlant
        Unmerged: four modes per phase, ``(θ1, θ2) = (0, 0), (1, 0),
        (0, 1), (1, 1)`` in that order; ``nominal`` is the loss-free mode.

    Raises
    ------
    ControlArgument
        If ``P`` is not a :class:`NetworkedStateSpace`, the controller,
        actuator or sensor strategy is unknown, the predictor is asked for
        without ``y = x``, or an option is given to a controller that does
        not take it.
    ControlDimension
        If ``estimator_gain`` has the wrong shape.
    ValueError
        If ``period`` is not an int >= 1, not a multiple of ``P.period``, or
        its lifted face would be too large.

    Examples
    --------
    The scalar plant ``x⁺ = 2x + u`` with ``y = x`` over a network that
    loses the actuator's message with probability 0.2; the modes are
    ``(θ1, θ2) = (0, 0), (1, 0), (0, 1), (1, 1)``:

    >>> P = ncs.nss([[2.0]], [[0.0, 1.0]], [[0.0], [1.0]],
    ...         [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1, actuator_loss=0.2)
    >>> plant = ncs.build(P)
    >>> plant.probabilities.tolist(), plant.nominal.tolist()
    ([[0.0, 0.2, 0.0, 0.8]], [3])
    >>> plant.close(np.full((1, 1, 1), -2.0)).modes.A[0, :, 0, 0].tolist()
    [2.0, 0.0]
    """
    if not isinstance(P, NetworkedStateSpace):
        raise ControlArgument(f"P: expected a NetworkedStateSpace (see nss()), "
                              f"got {type(P).__name__}")
    if P.sensor_delay is not None or P.actuator_delay is not None or \
            P.input_delay is not None:
        raise ControlArgument(
            "P: a plant with delayed links has no open-loop builder "
            "(JumpPlant) for synthesis over delayed links: close its loop "
            "with feedback(P, K), or design with passivesyn(P), which "
            "searches the gains locally there")
    strategy = _strategy(controller, actuator)
    opts = _options(P, controller, sensor, controller_order, estimator_gain)
    N = positive_int(period, "period", allow_none=True) or P.period
    for what, NL in (("network", P.period),
                     ("estimator gain", opts["L"].shape[0] if "L" in opts
                      else 1)):
        if N % NL:
            raise ValueError(f"period: {N} is not a multiple of the {what} "
                             f"period {NL}")
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
        key: tuple = (s1[k % P.period].tobytes(),
                      s1[(k + 1) % P.period].tobytes(),
                      s2[k % P.period].tobytes())
        if "L" in opts:
            key += (opts["L"][(k + 1) % opts["L"].shape[0]].tobytes(),)
        if key not in built:
            built[key] = [strategy.phase(P, k, t1, t2, **opts)
                          for (t1, t2) in MODES]
        fields.extend(built[key])
    per_phase = ("E", "Ew", "Gnext")
    stacked = {f: np.array([m[f] for m in fields]).reshape(
        (N, 4) + fields[0][f].shape) for f in fields[0]
        if f not in per_phase}
    E = np.array([fields[4 * k]["E"] for k in range(N)])
    # measurement noise (D21 ≠ 0, theory: measurement noise): read at once
    # (Ew, the static gain) or stored on arrival, the next step's offset
    # Gw[k + 1, ℓ] of this step's mode ℓ (the model-based controllers)
    Ew = Gw = None
    if np.any(P.D21 != 0):
        if "Ew" in fields[0]:
            Ew = np.array([fields[4 * k]["Ew"] for k in range(N)])
        if "Gnext" in fields[0]:
            Gw = np.roll(np.array([m["Gnext"] for m in fields]).reshape(
                (N, 4) + fields[0]["Gnext"].shape), 1, axis=0)
    a1, a2 = P.sensor_loss, P.actuator_loss
    prob = P.mode_probabilities()
    p = np.tile([prob[m] for m in MODES], (N, 1))
    # bursty links (theory: Markov losses): the channels evolve at every step
    # whether or not a node is scheduled; the predictor's mode (θ1,k+1, θ2,k)
    # follows the same Kronecker chain as the static one's (θ1,k, θ2,k)
    T = P.mode_transition()
    transition = None if T is None else np.tile(T, (N, 1, 1))
    description: dict = dict(sensor_loss=a1, actuator_loss=a2,
                             plant_period=P.period)
    if T is not None:
        description.update(sensor_link=P.sensor_link,
                           actuator_link=P.actuator_link)
    if controller == "lti":
        description["sensor"] = sensor
    return JumpPlant(stacked["A"], stacked["Bu"], stacked["Bw"], stacked["Cz"],
                     stacked["Du"], stacked["Dw"], E, p, P.dt,
                     transition=transition, nominal=np.full(N, 3),
                     inputs=P.disturbance_labels,
                     outputs=P.performance_labels,
                     states=strategy.states(P, **opts), name=P.name,
                     controller=controller, actuator=actuator,
                     observed=(None if T is None
                               else _observed(P, controller, N)),
                     estimator_gain=opts.get("L"), Ew=Ew, Gw=Gw,
                     description=description)


def _observed(P: NetworkedStateSpace, controller: str, N: int) -> np.ndarray:
    """What the controller observes of the previous mode, per phase.

    The mode index is ``θ1 + 2θ2`` (``MODES``). The static gain's previous
    mode is ``(θ1,k-1, θ2,k-1)``; the model-based controllers' is
    ``(θ1,k, θ2,k-1)`` (their mode is ``(θ1,k+1, θ2,k)``,
    :ref:`theory-markov`). A link reveals its bit only at a step where it
    is scheduled (an arrival, or an acknowledgement). Returns the
    observation class of each previous mode, shape (N, 4): equal labels
    for modes the controller cannot tell apart.
    """
    s1 = P.sensor_schedule.pattern.any(axis=1)
    s2 = P.actuator_schedule.pattern.any(axis=1)
    shift = 1 if controller == "static" else 0
    out = np.zeros((N, len(MODES)), int)
    for k in range(N):
        see1 = bool(s1[(k - shift) % P.period])
        see2 = bool(s2[(k - 1) % P.period])
        out[k] = [t1 * see1 + 2 * t2 * see2 for t1, t2 in MODES]
    return out


def _options(P: NetworkedStateSpace, controller: str, sensor: Any,
             controller_order: Any, estimator_gain: Any) -> dict:
    """The builder options a controller takes, checked; refused elsewhere."""
    choice(sensor, "sensor", ("zero", "hold"))
    if controller == "lti":
        nc = controller_order
        if isinstance(nc, bool) or not isinstance(nc, (int, np.integer)) \
                or nc < 0:
            raise ValueError(f"controller_order: expected an integer >= 0, "
                             f"got {nc!r}")
        if estimator_gain is not None:
            raise ControlArgument("estimator_gain: only controller='estimator'"
                                  " takes an estimator gain")
        return dict(sensor=sensor, nc=int(nc))
    if sensor != "zero" or controller_order:
        raise ControlArgument(
            f"sensor, controller_order: only an LTI controller "
            f"(controller='lti') takes them, got controller={controller!r}")
    if controller != "estimator":
        if estimator_gain is not None:
            raise ControlArgument(
                f"estimator_gain: only controller='estimator' takes an "
                f"estimator gain, got controller={controller!r}")
        return {}
    if estimator_gain is None:
        raise ControlArgument("estimator_gain: controller='estimator' needs "
                              "the estimator gains L_k (see estimator_gain())")
    L = real_array(estimator_gain, "estimator_gain", ndim=(2, 3))
    L = L[None] if L.ndim == 2 else L
    want = (P.nstates, P.C2.shape[0])
    if L.shape[1:] != want or L.shape[0] == 0:
        raise ControlDimension(
            f"estimator_gain: expected L_k of shape {want} (n, nmeas), or a "
            f"stack (N_L, {want[0]}, {want[1]}), got {L.shape}")
    return dict(L=L)


def require_state_measured(P: NetworkedStateSpace, controller: str) -> None:
    """Refuse state feedback for a plant that does not measure x.

    Parameters
    ----------
    P : NetworkedStateSpace
        Plant with its network.
    controller : str
        The controller kind asked for.

    Raises
    ------
    ControlArgument
        If ``controller`` is ``'static'`` or ``'predictor'`` and ``C2 ≠ I``.

    Examples
    --------
    >>> P = ncs.nss([[2.0, 1.0], [0.0, 0.5]], [[0.0, 1.0], [1.0, 0.0]],
    ...         [[1.0, 0.0], [1.0, 0.0]], [[0.0, 0.0], [0.0, 0.0]],
    ...         nmeas=1, ncon=1)
    >>> ncs.require_state_measured(P, "estimator")       # any C2 will do
    """
    if controller in ("static", "predictor") and not _measures_state(P):
        raise ControlArgument(
            f"controller={controller!r}: static gains need y = x; use "
            f"controller='estimator' (got C2 of shape {P.C2.shape}, not I)")


def _measures_state(P: NetworkedStateSpace) -> bool:
    return P.C2.shape == (P.nstates, P.nstates) and np.array_equal(
        P.C2, np.eye(P.nstates))


def _static_phase(P: NetworkedStateSpace, k: int, t1: int, t2: int, *,
                  actuator: str, **_: Any) -> dict:
    """Memoryless gain, :ref:`theory-static-loop`: ``u = θ2 Σ2 K θ1 Σ1 y``."""
    n, m2 = P.nstates, P.ncon
    S1 = P.sensor_schedule.selection(k)
    S2 = P.actuator_schedule.selection(k)
    g = t1 * t2
    A, B1, B2, C1, D11, D12 = P.A, P.B1, P.B2, P.C1, P.D11, P.D12
    E = S1 @ P.C2
    Ew = S1 @ P.D21           # the noise read with the measurement
    if actuator == "zero":
        return dict(A=A, Bu=g * B2 @ S2, Bw=B1, Cz=C1, Du=g * D12 @ S2,
                    Dw=D11, E=E, Ew=Ew)
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
        E=np.hstack([E, Z((E.shape[0], h))]), Ew=Ew)


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
                     *, actuator: str, L: np.ndarray | None = None) -> dict:
    """Model-based controller, :ref:`theory-predictor`; the mode is
    ``(θ1,k+1, θ2,k)``.

    State ``[x̂; e]`` (zero actuator) or ``[x̂; u⁻; e]`` (hold; ``u⁻`` the
    last inputs of the actuators some phase addresses), with ``x̂`` the
    estimate after the sensor update and ``e = x - x̂``. With estimator
    gains ``L`` (:ref:`theory-output-feedback`) the correction is
    ``R = θ1 L_{k+1} Σ1 C2`` instead of :ref:`theory-predictor`'s ``θ1 Σ1``
    (which is ``C2 = I``, ``L = I``). A measurement with noise
    (``D21 ≠ 0``) moves the estimate by ``Rw w_{k+1}``, ``Rw = θ1 L_{k+1}
    Σ1 D21``, and the error by ``-Rw w_{k+1}``: the next step's offset
    ``Gnext`` (:ref:`theory-measurement-noise`).
    """
    n, m2 = P.nstates, P.ncon
    S2 = P.actuator_schedule.selection(k)
    R = t1_next * P.sensor_schedule.selection(k + 1)
    Rw = R @ P.D21
    if L is not None:
        Rw = L[(k + 1) % L.shape[0]] @ Rw
        R = L[(k + 1) % L.shape[0]] @ R @ P.C2
    A, B1, B2, C1, D11, D12 = P.A, P.B1, P.B2, P.C1, P.D11, P.D12
    I, Z = np.eye(n), np.zeros
    m1 = B1.shape[1]
    if actuator == "zero":
        return dict(
            A=np.block([[A, R @ A], [Z((n, n)), (I - R) @ A]]),
            Bu=t2 * np.vstack([B2 @ S2, Z((n, m2))]),
            Bw=np.vstack([R @ B1, (I - R) @ B1]),
            Cz=np.hstack([C1, C1]), Du=t2 * D12 @ S2, Dw=D11,
            E=np.hstack([I, Z((n, n))]), Gnext=np.vstack([Rw, -Rw]))
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
        E=E, Gnext=np.vstack([Rw, Z((h, m1)), -Rw]))


def _plant_states(P: NetworkedStateSpace, **_: Any) -> list[str]:
    return list(P.state_labels)


def _held_names(P: NetworkedStateSpace) -> list[str]:
    controls = P.input_labels[len(P.disturbance_labels):]
    return [f"{controls[i]}_prev"
            for i in np.flatnonzero(P.actuator_schedule.pattern.any(axis=0))]


def _predictor_states(P: NetworkedStateSpace, hold: bool, **_: Any
                      ) -> list[str]:
    x = list(P.state_labels)
    return ([f"{s}_hat" for s in x] + (_held_names(P) if hold else [])
            + [f"{s}_err" for s in x])


def _heard(P: NetworkedStateSpace) -> np.ndarray:
    """Selector of the sensors some phase schedules (cf. :func:`_held`).

    A never-scheduled sensor delivers nothing; its held value would be a
    constant 0 with an eigenvalue 1 in every mode, so it is left out.
    """
    idx = np.flatnonzero(P.sensor_schedule.pattern.any(axis=0))
    H = np.zeros((idx.size, P.C2.shape[0]))
    H[np.arange(idx.size), idx] = 1.0
    return H


def _lti_phase(P: NetworkedStateSpace, k: int, t1_next: int, t2: int, *,
               actuator: str, sensor: str, nc: int) -> dict:
    """A discrete-time LTI controller in the loop (theory: output feedback).

    State ``ξ = [x; xc; ŷ; u⁻]``: plant, controller, the measurements the
    controller received at this step (sensors some phase schedules), and
    with a hold actuator the last applied inputs. The received value
    ``ŷ_k = θ1,k Σ1,k y_k`` (+ ``(I - θ1,k Σ1,k) ŷ_{k-1}`` with a hold
    sensor) is carried in the state so that the loss ``θ1`` acts on the
    controller's input while the controller itself stays a gain
    ``[[Dc, Cc], [Bc, Ac]]`` on ``E ξ = [ŷ; xc]``, with outputs
    ``[v; xc⁺]``. As for the predictor the transition ``k → k+1`` depends
    on ``(θ2,k, θ1,k+1)``. The noise of a measurement ``y = C2 x + D21 w``
    arrives with ``w_{k+1}``, the next step's input: the stored ``ŷ`` is
    the noise-free part and the next step's offset ``Gnext`` adds
    ``θ1 Σ1 D21 w`` (:ref:`theory-measurement-noise`).
    """
    n, m2 = P.nstates, P.ncon
    A, B1, B2, C1, D11, D12 = P.A, P.B1, P.B2, P.C1, P.D11, P.D12
    m1 = B1.shape[1]
    Hs = _heard(P)
    Hu = _held(P) if actuator == "hold" else np.zeros((0, m2))
    hs, hu = Hs.shape[0], Hu.shape[0]
    nx = n + nc + hs + hu
    ix, ic, iy, iu = (slice(0, n), slice(n, n + nc),
                      slice(n + nc, n + nc + hs), slice(n + nc + hs, nx))
    S2 = P.actuator_schedule.selection(k)
    S1n = P.sensor_schedule.selection(k + 1)
    # applied input u = Ux ξ + Uv v: the held part (hold actuator) and the
    # delivered part of the controller's message
    Ux = np.zeros((m2, nx))
    if actuator == "hold":
        Ux[:, iu] = (np.eye(m2) - t2 * S2) @ Hu.T
    Uv = t2 * S2
    # x⁺ = A x + B1 w + B2 u, without the gain's part B2 Uv v
    Ax = np.zeros((n, nx))
    Ax[:, ix] = A
    Ax += B2 @ Ux
    Bv = B2 @ Uv
    # what arrives at k+1: θ1 Σ1 C2 x⁺ (+ the held rest)
    Rn = t1_next * Hs @ S1n @ P.C2
    Amat = np.zeros((nx, nx))
    Bu = np.zeros((nx, m2 + nc))
    Amat[ix] = Ax
    Bu[ix, :m2] = Bv
    Bu[ic, m2:] = np.eye(nc)
    Amat[iy] = Rn @ Ax
    if sensor == "hold":
        Amat[iy, iy] += Hs @ (np.eye(Hs.shape[1]) - t1_next * S1n) @ Hs.T
    Bu[iy, :m2] = Rn @ Bv
    Amat[iu] = Hu @ Ux
    Bu[iu, :m2] = Hu @ Uv
    Bw = np.zeros((nx, m1))
    Bw[ix] = B1
    Bw[iy] = Rn @ B1
    Cz = D12 @ Ux
    Cz[:, ix] += C1
    E = np.zeros((Hs.shape[1] + nc, nx))
    E[:Hs.shape[1], iy] = Hs.T
    E[Hs.shape[1]:, ic] = np.eye(nc)
    Gnext = np.zeros((nx, m1))
    Gnext[iy] = t1_next * Hs @ S1n @ P.D21
    return dict(A=Amat, Bu=Bu, Bw=Bw, Cz=Cz,
                Du=np.hstack([D12 @ Uv, np.zeros((C1.shape[0], nc))]),
                Dw=D11, E=E, Gnext=Gnext)


def _lti_states(P: NetworkedStateSpace, hold: bool, nc: int, **_: Any
                ) -> list[str]:
    ys = P.output_labels[len(P.performance_labels):]
    return (list(P.state_labels) + [f"xc[{i}]" for i in range(nc)]
            + [f"{ys[i]}_rcv" for i in np.flatnonzero(
                P.sensor_schedule.pattern.any(axis=0))]
            + (_held_names(P) if hold else []))


@dataclass(frozen=True)
class Strategy:
    """How one (controller, actuator) pair builds a phase of the jump plant.

    Attributes
    ----------
    phase : callable
        ``phase(P, k, t1, t2, **options)`` -> dict of ``A, Bu, Bw, Cz, Du,
        Dw, E`` of the network mode ``(t1, t2)`` at phase ``k``; the options
        are the controller's (:func:`build`: ``L`` for the estimator,
        ``sensor`` and ``nc`` for an LTI controller).
    states : callable
        ``states(P, **options)`` -> names of the state ``ξ``.
    memoryless : bool
        The controller keeps nothing between messages, so it acts only at
        phases that schedule a sensor and an actuator together
        (:ref:`theory-static-loop`).
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
        lambda P, **_: _plant_states(P) + _held_names(P),
        memoryless=True, needs_state=False),
    ("predictor", "zero"): Strategy(
        partial(_predictor_phase, actuator="zero"),
        partial(_predictor_states, hold=False),
        memoryless=False, needs_state=True),
    ("predictor", "hold"): Strategy(
        partial(_predictor_phase, actuator="hold"),
        partial(_predictor_states, hold=True),
        memoryless=False, needs_state=True),
    ("estimator", "zero"): Strategy(
        partial(_predictor_phase, actuator="zero"),
        partial(_predictor_states, hold=False),
        memoryless=False, needs_state=False),
    ("estimator", "hold"): Strategy(
        partial(_predictor_phase, actuator="hold"),
        partial(_predictor_states, hold=True),
        memoryless=False, needs_state=False),
    ("lti", "zero"): Strategy(
        partial(_lti_phase, actuator="zero"),
        partial(_lti_states, hold=False),
        memoryless=False, needs_state=False),
    ("lti", "hold"): Strategy(
        partial(_lti_phase, actuator="hold"),
        partial(_lti_states, hold=True),
        memoryless=False, needs_state=False),
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
    (:ref:`theory-static-loop`).

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
    >>> P = ncs.nss([[2.0]], [[0.0, 1.0]], [[0.0], [1.0]],
    ...         [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
    ...         sensor_schedule=[1, 0], actuator_schedule=[0, 1])
    >>> ncs.loop_closes(P), ncs.loop_closes(P.with_network(actuator_schedule=[1, 1]))
    (False, True)
    """
    return bool((P.sensor_schedule.pattern.any(axis=1)
                 & P.actuator_schedule.pattern.any(axis=1)).any())


def feedback(P: NetworkedStateSpace, K: Any, *, controller: str | None = None,
             actuator: str | None = None, sensor: str | None = None,
             estimator_gain: Any = None, **kwargs: Any) -> JumpStateSpace:
    """Close the loop of ``P`` with a gain or an LTI controller.

    Sign convention ``u = K y``: the gain or controller is applied as it
    is, in positive feedback. The controller sends ``v_k = K_k ŷ_k``
    (static: ``u = K y`` when every message arrives, so ``u = K x`` for
    ``y = x``), ``v_k = K_k x̂_k`` (predictor and estimator: ``u = K x̂``),
    or the output of the LTI system ``K`` driven by the received
    measurements ``ŷ``. A gain designed for ``u = -K x``, as
    :func:`control.dlqr` returns, must be negated (see the Examples); so
    must a controller designed for negative feedback.

    Parameters
    ----------
    P : NetworkedStateSpace
        Plant with its network.
    K : PeriodicGain, array_like, control.StateSpace or TransferFunction
        A gain from :func:`control_ncs.passivesyn`, or gains of shape
        ``(m2, nk)`` (constant), ``(N_K, M, m2, nk)`` (per phase and
        previous network mode ``ℓ``, :ref:`theory-markov`: the loop is then a
        Markov jump system on pair modes ``(ℓ, i)``, for i.i.d. links too,
        where ``ℓ`` is extra information) or ``(N_K, m2, nk)`` (periodic; the
        loop's period is the least common multiple of ``N_K``, ``P.period`` and
        the estimator gain's period). ``nk`` is ``nmeas`` for the static
        controller, ``n`` for the predictor and the estimator, plus ``m2``
        for those with a hold actuator. Or a discrete-time LTI controller
        with the plant's ``dt``, ``nmeas`` inputs (the received
        measurements) and ``ncon`` outputs (the controls it sends); it runs
        at every step. Over delayed links (:ref:`theory-delays`): a static
        gain, or one per age of the measurement ``(Ds + 1, m2, nmeas)``,
        the predictor's or the estimator's gain ``(m2, n)``, or an LTI
        controller reading the freshest measurement.
    controller : {'static', 'predictor', 'estimator', 'lti'}, optional
        Default: ``'lti'`` for a system ``K``, else the gain's own kind,
        else ``'estimator'`` when an estimator gain is given, else
        ``'static'``.
    actuator : {'zero', 'hold'}, optional
        Default: the gain's own strategy, else ``'zero'``.
    sensor : {'zero', 'hold'}, optional
        LTI controller only: what it receives for a lost or unscheduled
        measurement, 0 (default, the paper's eq. 2) or the last received
        value.
    estimator_gain : array_like, shape (n, nmeas) or (N_L, n, nmeas), optional
        The estimator's ``L_k`` (:ref:`theory-output-feedback`), e.g. from
        :func:`control_ncs.estimator_gain` or ``ct.dlqe``'s gain (see its
        notes); default ``K.estimator_gain`` when ``K`` carries one.
    **kwargs
        None are accepted: an unknown keyword raises ``TypeError``.

    Returns
    -------
    JumpStateSpace
        The closed loop ``w → z`` (modes merged); ``info`` records the
        controller, actuator and gains. For an LTI controller its state is
        ``[x; xc; ŷ; u⁻]`` (plant, controller, received measurements of the
        sensors some phase schedules, held inputs); ``ŷ`` at step 0 is what
        arrived then (e.g. ``C2 x0`` for a first message that got through,
        0 for one that was lost).

    Raises
    ------
    ValueError
        If a static gain can never close the loop because no phase schedules
        a sensor and an actuator together (e.g. a shared channel,
        :ref:`theory-static-loop`), or if ``K`` has non-finite entries.
    ControlDimension
        If the gain, the estimator gain or the controller has the wrong
        shape.
    ControlArgument
        If an LTI controller is continuous-time or has another ``dt`` than
        the plant, or an option does not fit the controller.

    References
    ----------
    .. [1] B. Riyanto and I. Arifin, *Positive Real Synthesis of Networked
           Control System: An LMI Approach* (the seed paper; its errors and
           their corrections: :ref:`errata`).

    Examples
    --------
    >>> import numpy as np
    >>> P = ncs.nss([[2.0]], [[0.0, 1.0]], [[0.0], [1.0]], [[1.0, 0.0], [0.0, 0.0]],
    ...         nmeas=1, ncon=1, actuator_loss=0.2)
    >>> CL = ncs.feedback(P, [[-2.0]])                 # u = -2 x when it arrives
    >>> CL.modes.probabilities.round(3).tolist()
    [[0.2, 0.8]]
    >>> CL.modes.A[0, :, 0, 0].tolist()           # lost: 2, arrived: 2 - 2
    [2.0, 0.0]

    An LQR gain is designed for ``u = -K x``: pass ``-K``.

    >>> K, _, _ = ct.dlqr(P.A, P.B2, np.eye(1), np.eye(1))
    >>> CL = ncs.feedback(P, -K)
    >>> bool(ncs.ms_radius(CL) < 1)
    True

    A PI controller ``u = -(2 y + 0.1 Σ y)`` (an LTI system, ``u = K y``
    with the sign inside it):

    >>> C = ct.ss([[1.0]], [[1.0]], [[-0.1]], [[-2.0]], True)
    >>> CL = ncs.feedback(P, C)
    >>> CL.jump_states
    ['x[0]', 'xc[0]', 'y[0]_rcv']
    >>> bool(ncs.ms_radius(CL) < 1)
    True
    """
    no_extra_kwargs("feedback", kwargs)
    if not isinstance(P, NetworkedStateSpace):
        raise ControlArgument(f"P: expected a NetworkedStateSpace (see nss()), "
                              f"got {type(P).__name__}")
    if P.sensor_delay is not None or P.actuator_delay is not None or \
            P.input_delay is not None:
        if isinstance(K, (ct.StateSpace, ct.TransferFunction)):
            Kss = _lti_controller(P, K, controller, estimator_gain)
            choice(sensor or "zero", "sensor", ("zero", "hold"))
            return delayed_loop(P, Kss, "lti", str(actuator or "zero"),
                                str(sensor or "zero"))
        if sensor is not None:
            raise ControlArgument("sensor: only an LTI controller (K a "
                                  "control.StateSpace or TransferFunction) "
                                  "takes a sensor strategy")
        L = estimator_gain if estimator_gain is not None else \
            getattr(K, "estimator_gain", None)
        kind = str(controller or getattr(K, "controller", None) or
                   ("estimator" if L is not None else "static"))
        if kind == "estimator" and L is None:
            raise ControlArgument(
                "estimator_gain: controller='estimator' needs the estimator "
                "gain L (n, nmeas), e.g. ncs.estimator_gain of the plant "
                "without its delays, or control.dlqe's")
        if kind != "estimator" and estimator_gain is not None:
            raise ControlArgument("estimator_gain: only controller="
                                  "'estimator' takes an estimator gain")
        return delayed_loop(P, K, kind,
                            str(actuator or getattr(K, "actuator", "zero")),
                            estimator_gain=L if kind == "estimator" else None)
    if isinstance(K, (ct.StateSpace, ct.TransferFunction)):
        return _feedback_lti(P, K, controller, actuator, sensor,
                             estimator_gain)
    if sensor is not None:
        raise ControlArgument("sensor: only an LTI controller (K a "
                              "control.StateSpace or TransferFunction) takes "
                              "a sensor strategy")
    if isinstance(K, PeriodicGain):
        controller = controller or K.controller
        actuator = actuator or K.actuator
        if estimator_gain is None:
            estimator_gain = getattr(K, "estimator_gain", None)
        gains = K.gains
    else:
        # validate here so that messages name the argument K, not 'gains'
        gains = real_array(K, "K", ndim=(2, 3, 4))
        gains = gains[None] if gains.ndim == 2 else gains
    if 0 in gains.shape:
        raise ControlDimension(f"K: expected a non-empty gain (at least one "
                               f"phase, one row, one column), got shape "
                               f"{gains.shape}")
    if controller is None:
        controller = "static" if estimator_gain is None else "estimator"
    actuator = actuator or "zero"
    strategy = _strategy(controller, actuator)
    if controller == "lti":
        raise ControlArgument("K: controller='lti' needs K as a discrete-time "
                              "control.StateSpace or TransferFunction, got "
                              f"{type(K).__name__}")
    if strategy.memoryless and not loop_closes(P):
        raise ValueError(
            "K: a memoryless (static) gain never closes this loop: no phase "
            "schedules a sensor and an actuator together (a shared channel "
            "forces this, theory: static-gain loop), so F_k = Σ2 K Σ1 = 0 and the plant runs "
            "open loop. Use controller='predictor', which keeps a model-based "
            "estimate between messages.")
    NL = 1
    if controller == "estimator" and estimator_gain is not None:
        NL = np.shape(estimator_gain)[0] if np.ndim(estimator_gain) == 3 else 1
    N = math.lcm(P.period, gains.shape[0], NL)
    plant = build(P, controller, actuator, period=N,
                  estimator_gain=estimator_gain)
    want: tuple[int, ...] = plant.gain_shape()[1:]
    if gains.ndim == 4:
        # K_{k,ℓ}: one gain per previous mode ℓ (theory: Markov losses)
        want = (plant.probabilities.shape[1],) + want
    if gains.shape[1:] != want:
        raise ControlDimension(
            f"K: expected gains of shape {want[-2:]} (or "
            f"({gains.shape[0]}, {want[-2]}, {want[-1]}) per phase, or "
            f"({gains.shape[0]}, {plant.probabilities.shape[1]}, {want[-2]}, "
            f"{want[-1]}) per phase and previous mode) for "
            f"controller={controller!r}, actuator={actuator!r}, got "
            f"{gains.shape[1:]}")
    gains = np.tile(gains, (N // gains.shape[0],) + (1,) * (gains.ndim - 1))
    observed = plant.observed
    if gains.ndim == 4 and observed is not None:
        _require_observed(gains, observed)
    effective = _warn_unused_gains(P, plant, gains, controller)
    CL = plant.close(gains)
    CL.info["effective_gains"] = effective
    if P.continuous is not None:        # for the cost between the samples
        CL.info["sampling"] = undelayed_entry(P, CL, lambda Q: build(
            Q, controller, actuator, period=N,
            estimator_gain=estimator_gain).close(gains))
    return CL


def _warn_unused_gains(P: NetworkedStateSpace, plant: JumpPlant,
                       gains: np.ndarray, controller: str) -> np.ndarray:
    """The gains as the loop applies them, with one warning when some of
    their entries multiply an input the controller never has at that phase
    (a sensor the schedule leaves silent): such entries act on zeros."""
    dead = ~np.any(plant.E != 0, axis=2)                  # (N, nk)
    used = np.any(gains != 0, axis=-2)                    # (N, [M,] nk)
    if used.ndim == 3:
        used = used.any(axis=1)
    unused = dead & used
    effective = gains.copy()
    if gains.ndim == 4:
        effective[:, :, :, :] *= ~dead[:, None, None, :]
    else:
        effective *= ~dead[:, None, :]
    if unused.any():
        where = {int(k % P.period): np.flatnonzero(unused[k]).tolist()
                 for k in range(unused.shape[0]) if unused[k].any()}
        what = ("sensors" if controller == "static" else "inputs")
        warnings.warn(ScheduleWarning(
            f"K: at phase(s) {sorted(where)} the gain's columns for {what} "
            f"{where} multiply nothing (no message is scheduled there); the "
            f"loop applies the gain without them (CL.info['effective_gains']). "
            f"To use every measurement, hold the last one (an LTI "
            f"controller with sensor='hold') or let a model bridge the "
            f"silence (controller='predictor' or 'estimator')"),
            stacklevel=caller_stacklevel())
    return effective


def _require_observed(gains: np.ndarray, observed: np.ndarray) -> None:
    """Refuse gains ``K_{k,ℓ}`` that use a bit of ``ℓ`` the controller never
    sees (a link idle the step before, :func:`_observed`)."""
    for k, labels in enumerate(observed):
        for o in np.unique(labels):
            same = np.flatnonzero(labels == o)
            for ell in same[1:]:
                if not np.array_equal(gains[k, ell], gains[k, same[0]]):
                    raise ControlArgument(
                        f"K: at phase {k} the gains for previous modes "
                        f"{MODES[same[0]]} and {MODES[ell]} (θ1, θ2) differ, "
                        "but the controller cannot tell these modes apart (a "
                        "link carried no message the step before, so no "
                        "arrival or acknowledgement revealed its state); give "
                        "them the same gain")


def _lti_controller(P: NetworkedStateSpace, K: Any, controller: str | None,
                    estimator_gain: Any) -> ct.StateSpace:
    """An LTI controller ``K`` for ``P``, checked: discrete-time with the
    plant's ``dt``, ``nmeas`` inputs, ``ncon`` outputs, finite."""
    if controller not in (None, "lti"):
        raise ControlArgument(f"controller: a system K is an LTI controller "
                              f"(controller='lti'), got {controller!r}")
    if estimator_gain is not None:
        raise ControlArgument("estimator_gain: an LTI controller takes no "
                              "estimator gain")
    Kss = lti_operand(K, "K", dt=P.dt)
    nmeas, ncon = P.C2.shape[0], P.ncon
    if (Kss.ninputs, Kss.noutputs) != (nmeas, ncon):
        raise ControlDimension(
            f"K: expected a controller with {nmeas} inputs (the received "
            f"measurements) and {ncon} outputs (the controls), got "
            f"{Kss.ninputs} inputs and {Kss.noutputs} outputs")
    if not np.all(np.isfinite(np.block([[Kss.D, Kss.C], [Kss.B, Kss.A]]))):
        raise ValueError("K: the controller's matrices must be finite")
    return Kss


def _feedback_lti(P: NetworkedStateSpace, K: Any, controller: str | None,
                  actuator: str | None, sensor: str | None,
                  estimator_gain: Any) -> JumpStateSpace:
    """:func:`feedback` with an LTI controller: checks, then build + close."""
    Kss = _lti_controller(P, K, controller, estimator_gain)
    realisation = np.block([[Kss.D, Kss.C], [Kss.B, Kss.A]])
    plant = build(P, "lti", actuator or "zero", sensor=sensor or "zero",
                  controller_order=Kss.nstates)
    gains = np.tile(realisation, (P.period, 1, 1))
    CL = plant.close(gains, controller_system=Kss)
    if P.continuous is not None:        # for the cost between the samples
        CL.info["sampling"] = undelayed_entry(P, CL, lambda Q: build(
            Q, "lti", actuator or "zero", sensor=sensor or "zero",
            controller_order=Kss.nstates).close(gains))
    return CL
