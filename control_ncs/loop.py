"""Closing the loop: :func:`feedback` applies a gain or an LTI controller
to a networked plant (:ref:`theory-static-loop`, :ref:`theory-predictor`,
:ref:`theory-output-feedback`, :ref:`theory-links-compose`).

The loop is built once, by the one builder (:func:`control_ncs.build`),
whatever the links; here the gain is checked against the loop it closes.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import control as ct
import numpy as np
from control.exception import ControlArgument, ControlDimension

from ._checks import caller_stacklevel, choice, no_extra_kwargs, real_array
from ._lti import lti_operand
from .exceptions import ScheduleWarning
from .constrained import ConstrainedLoop
from .gain import PeriodicGain
from .jump import JumpStateSpace
from .openloop import JumpPlant
from .plant import NetworkedStateSpace
from .modechain import measurement_ages
from .strategies import CONTROLLERS, build, loop_closes

__all__ = ["feedback"]


def feedback(P: NetworkedStateSpace, K: Any, *, controller: str | None = None,
             actuator: str | None = None, sensor: str | None = None,
             estimator_gain: Any = None, **kwargs: Any
             ) -> JumpStateSpace | ConstrainedLoop:
    """Close the loop of ``P`` with a gain or an LTI controller.

    Sign convention ``u = K y``: the gain or controller is applied as it
    is, in positive feedback. The controller sends ``v_k = K_k ŷ_k``
    (static: ``u = K y`` when every message arrives, so ``u = K x`` for
    ``y = x``), ``v_k = K_k x̂_k`` (predictor and estimator: ``u = K x̂``),
    or the output of the LTI system ``K`` driven by the received
    measurements ``ŷ``. A gain designed for ``u = -K x``, as
    :func:`control.dlqr` returns, must be negated (see the Examples); so
    must a controller designed for negative feedback. See
    :ref:`guide-sign`.

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
        at every step. Over a buffered (delayed) sensor link
        (:ref:`theory-delays`) the static controller may use a gain per age
        of the measurement: ``nk = (Ds + 1) nmeas``, the columns in blocks
        ``[age 0 | age 1 | …]`` (as designs return it); a gain of width
        ``nmeas`` is used at every age. A leading axis is always the
        phase: a stack ``(N, m2, nmeas)`` is a periodic gain over the
        delayed link too (never read as one gain per age).
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
        0 for one that was lost). Over a loss budget
        (``nss(..., actuator_loss=ncs.weakly_hard(m, K))``, any
        :class:`~control_ncs.LossAutomaton`): a
        :class:`~control_ncs.ConstrainedLoop`, whose modes follow the
        budget instead of probabilities; analyse it for every allowed
        pattern with :func:`control_ncs.jsr` (:ref:`theory-worst-case`).

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
        gains = np.asarray(K.gains, float)
    else:
        # validate here so that messages name the argument K, not 'gains'
        gains = real_array(K, "K", ndim=(2, 3, 4))
    if 0 in gains.shape:
        raise ControlDimension(f"K: expected a non-empty gain (at least one "
                               f"phase, one row, one column), got shape "
                               f"{gains.shape}")
    if controller is None:
        controller = "static" if estimator_gain is None else "estimator"
    actuator = actuator or "zero"
    choice(controller, "controller", CONTROLLERS)
    if controller == "lti":
        raise ControlArgument("K: controller='lti' needs K as a discrete-time "
                              "control.StateSpace or TransferFunction, got "
                              f"{type(K).__name__}")
    if controller == "static" and not loop_closes(P):
        raise ValueError(
            "K: a memoryless (static) gain never closes this loop: no phase "
            "schedules a sensor and an actuator together (a shared channel "
            "forces this, theory: static-gain loop), so F_k = Σ2 K Σ1 = 0 and "
            "the plant runs open loop. Use controller='predictor', which "
            "keeps a model-based estimate between messages.")
    gains = _per_age(P, gains, controller)
    gains = gains[None] if gains.ndim == 2 else gains
    NL = 1
    if controller == "estimator" and estimator_gain is not None:
        NL = np.shape(estimator_gain)[0] if np.ndim(estimator_gain) == 3 else 1
    N = math.lcm(P.period, gains.shape[0], NL)
    plant = build(P, controller, actuator, period=N,
                  estimator_gain=estimator_gain)
    gains = _fitted(plant, gains, controller, actuator, N)
    if gains.ndim == 4 and plant.observed is not None:
        _require_observed(gains, plant.observed)
    effective = _warn_unused_gains(P, plant, gains, controller)
    CL = plant.close(gains)
    CL.info["effective_gains"] = effective
    return CL


def _per_age(P: NetworkedStateSpace, gains: np.ndarray, controller: str
             ) -> np.ndarray:
    """A static gain over a buffered sensor link as the loop reads it: one
    block per age of the measurement, ``[age 0 | age 1 | …]``. A gain of
    width ``nmeas`` (one per phase, or a single one) acts the same at
    every age; a leading axis is always the phase, never the age (a gain
    per age is given as blocks of columns, ``PeriodicGain(..., ages=)``),
    so a periodic gain keeps its period over a delayed link."""
    Ds = measurement_ages(P) - 1
    p2 = P.C2.shape[0]
    if controller != "static" or not Ds or gains.shape[-1] != p2:
        return gains
    return np.concatenate([gains] * (Ds + 1), axis=-1)


def _fitted(plant: JumpPlant, gains: np.ndarray, controller: str,
            actuator: str, N: int) -> np.ndarray:
    """The gains checked against the loop's shape and tiled over ``N``."""
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
    return np.tile(gains, (N // gains.shape[0],) + (1,) * (gains.ndim - 1))


def _warn_unused_gains(P: NetworkedStateSpace, plant: JumpPlant,
                       gains: np.ndarray, controller: str) -> np.ndarray:
    """The gains as the loop applies them, with one warning when some of
    their entries multiply an input the controller never has at that phase
    (a sensor the schedule leaves silent): such entries act on zeros."""
    E = plant.E if plant.E.ndim == 3 else plant.E.any(axis=1)
    dead = ~np.any(E != 0, axis=2)                        # (N, nk)
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
        # columns numbered from 1, as sensors are in the schedules
        where = {int(k % P.period): (np.flatnonzero(unused[k]) + 1).tolist()
                 for k in range(unused.shape[0]) if unused[k].any()}
        what = ("sensors" if controller == "static" else "inputs")
        warnings.warn(ScheduleWarning(
            f"K: at phase(s) {sorted(where)} the gain's columns for {what} "
            f"{where} (phase: columns numbered from 1, as in the schedule) "
            f"multiply nothing (no message is scheduled there); the "
            f"loop applies the gain without them (CL.info['effective_gains']). "
            f"To use every measurement, hold the last one (an LTI "
            f"controller with sensor='hold') or let a model bridge the "
            f"silence (controller='predictor' or 'estimator')"),
            stacklevel=caller_stacklevel())
    return effective


def _require_observed(gains: np.ndarray, observed: np.ndarray) -> None:
    """Refuse gains ``K_{k,ℓ}`` that use something of ``ℓ`` the controller
    never sees (a link idle the step before, a channel state behind a
    delay, :meth:`control_ncs.modechain.Network.observed`)."""
    for k, labels in enumerate(observed):
        for o in np.unique(labels):
            same = np.flatnonzero(labels == o)
            for ell in same[1:]:
                if not np.array_equal(gains[k, ell], gains[k, same[0]]):
                    raise ControlArgument(
                        f"K: at phase {k} the gains for previous modes "
                        f"{int(same[0])} and {int(ell)} differ, but the "
                        f"controller cannot tell these modes apart (a link "
                        f"carried no message the step before, so no arrival "
                        f"or acknowledgement revealed its state); give them "
                        f"the same gain")


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
                  estimator_gain: Any) -> JumpStateSpace | ConstrainedLoop:
    """:func:`feedback` with an LTI controller: checks, then build + close."""
    Kss = _lti_controller(P, K, controller, estimator_gain)
    realisation = np.block([[Kss.D, Kss.C], [Kss.B, Kss.A]])
    plant = build(P, "lti", actuator or "zero", sensor=sensor or "zero",
                  controller_order=Kss.nstates)
    gains = np.tile(realisation, (plant.period, 1, 1))
    return plant.close(gains, controller_system=Kss)
