"""A periodic state-feedback gain and the controller it belongs to."""

from __future__ import annotations

from typing import Any

import numpy as np

from control.exception import ControlArgument, ControlDimension

from ._checks import choice, real_array

__all__ = ["PeriodicGain"]

#: The controller kinds a gain can belong to; the builder
#: (:func:`control_ncs.build`) writes one mode function per kind, for every
#: actuator strategy below.
CONTROLLERS = ("static", "predictor", "estimator", "lti")
#: What an actuator applies when its message is lost or not scheduled.
ACTUATORS = ("zero", "hold")


def controllers() -> tuple[str, ...]:
    """Controller kinds, those the builder writes loops for.

    Returns
    -------
    tuple of str
        E.g. ``('static', 'predictor')``.

    Examples
    --------
    >>> from control_ncs.gain import controllers
    >>> 'static' in controllers()
    True
    """
    return CONTROLLERS


def actuators() -> tuple[str, ...]:
    """Actuator strategies, those the builder writes loops for.

    Returns
    -------
    tuple of str
        E.g. ``('zero', 'hold')``.

    Examples
    --------
    >>> from control_ncs.gain import actuators
    >>> 'hold' in actuators()
    True
    """
    return ACTUATORS


#: Above this many entries the repr gives the shape, not the numbers (a
#: screenful; ``numpy.asarray(K)`` shows them all).
REPR_ENTRIES = 64


class PeriodicGain:
    """Per-phase gains ``K_k`` (or ``K_{k,ℓ}``) of a controller.

    The gain is applied as is: ``u = K_k ŷ`` (positive feedback, no minus
    sign). :func:`control.dlqr` and :func:`control.lqr` return ``K`` for
    ``u = -K x``: negate such a gain (``PeriodicGain(-K)``). See
    :ref:`guide-sign`.

    Parameters
    ----------
    gains : array_like, shape (N, m2, nk), (m2, nk) or (N, M, m2, nk)
        ``K_k`` for ``k = 0..N-1``. What ``K_k`` multiplies depends on the
        controller: the received measurement ``ŷ`` (``'static'``, with either
        actuator), the estimate ``x̂`` (``'predictor'`` with a ``'zero'``
        actuator), or ``[x̂; u⁻]``, the estimate and the last applied input
        (``'predictor'`` with a ``'hold'`` actuator). A 4-D stack holds
        gains that also use the previous network mode ``ℓ = σ_{k-1}``
        (``K_{k,ℓ}``, :ref:`theory-markov`: the controller knows it through
        acknowledgements and arrivals), ``M`` modes in the order of the
        loop's modes (for a :func:`control_ncs.build` plant the four
        ``(θ1, θ2)`` of :ref:`theory-conventions`).
    controller : {'static', 'predictor', 'estimator'}
    actuator : {'zero', 'hold'}
    result : object, optional
        The synthesis result that produced the gain (certificate and
        verification figures), if any.
    estimator_gain : array_like, shape (n, nmeas) or (N_L, n, nmeas), optional
        The estimator's ``L_k`` (:ref:`theory-output-feedback`) that
        ``controller='estimator'`` gains belong to (an
        :class:`control_ncs.estimator.EstimatorGain` is accepted);
        :func:`control_ncs.feedback` closes the loop with it.
    ages : int, optional
        For a ``'static'`` gain over a buffered (delayed) sensor link
        (:ref:`theory-delays`): the number ``D + 1`` of measurement ages
        whose gains the columns hold, in blocks ``[age 0 | age 1 | …]`` of
        ``nk / ages`` columns each. It labels the gain (it is one gain per
        phase, not ``ages`` phases); the loop reads the columns as they are.

    Attributes
    ----------
    gains : ndarray, shape (N, m2, nk), or (N, M, m2, nk)
        Read-only; 4-D when :attr:`mode_dependent`.
    estimator_gain : ndarray, shape (N_L, n, nmeas), or None
        Read-only.
    period : int
    ages : int or None
        Number of measurement ages of a per-age gain, or None.

    Notes
    -----
    ``numpy.asarray(K)`` is the ``(m2, nk)`` matrix when ``N = 1`` (as
    :func:`control.lqr` returns) and the ``(N, m2, nk)`` stack otherwise;
    for mode-dependent gains always the ``(N, M, m2, nk)`` stack.

    Examples
    --------
    An LQR gain for ``x⁺ = 2x + u`` (``u = -K x`` in python-control),
    used here as ``u = K x``:

    >>> import control as ct
    >>> Klqr, _, _ = ct.dlqr([[2.0]], [[1.0]], [[1.0]], [[1.0]])
    >>> K = ncs.PeriodicGain(-Klqr)
    >>> bool(abs(2.0 + K[0][0, 0]) < 1)
    True

    Gains per previous mode (two modes, one phase): ``K[k]`` is the stack
    ``K_{k,ℓ}`` over ``ℓ``:

    >>> Km = ncs.PeriodicGain([[[[-1.0]], [[-2.0]]]])
    >>> Km.mode_dependent, Km.modes, Km[0][1].tolist()
    (True, 2, [[-2.0]])

    A gain per age of the measurement (a buffer of two steps, one sensor):
    one phase, one block of columns per age:

    >>> Ka = ncs.PeriodicGain([[-0.9, -0.5, -0.2]], ages=3)
    >>> Ka.period, Ka.ages
    (1, 3)
    >>> Ka
    PeriodicGain(controller='static', actuator='zero', period=1, per sensor age (3),
    [[-0.9 -0.5 -0.2]])
    """

    def __init__(self, gains: Any, controller: str = "static",
                 actuator: str = "zero", result: Any = None,
                 estimator_gain: Any = None, ages: int | None = None):
        K = real_array(gains, "gains", ndim=(2, 3, 4))
        if 0 in K.shape:
            raise ControlDimension(f"gains: expected nonzero dimensions, got "
                                   f"shape {K.shape}")
        self.gains = K[None] if K.ndim == 2 else K
        self.gains.flags.writeable = False
        self.controller = choice(controller, "controller", controllers())
        self.actuator = choice(actuator, "actuator", actuators())
        self.result = result
        L = None
        if estimator_gain is not None:
            if self.controller != "estimator":
                raise ControlArgument(
                    f"estimator_gain: only controller='estimator' gains carry "
                    f"an estimator gain, got controller={self.controller!r}")
            # an EstimatorGain exposes its stack; np.asarray would drop the
            # phase axis when N_L = 1
            L = real_array(getattr(estimator_gain, "gains", estimator_gain),
                           "estimator_gain", ndim=(2, 3))
            L = np.array(L[None] if L.ndim == 2 else L)
            if 0 in L.shape:
                raise ControlDimension(f"estimator_gain: expected nonzero "
                                       f"dimensions, got shape {L.shape}")
            # K_k multiplies x̂ ('zero') or [x̂; u⁻] ('hold')
            m2, nk = self.gains.shape[-2:]
            n = nk if self.actuator == "zero" else nk - m2
            if L.shape[1] != n:
                raise ControlDimension(
                    f"estimator_gain: expected L_k with {n} rows (the "
                    f"estimate x̂ the gains act on), got shape {L.shape}")
            L.flags.writeable = False
        self.estimator_gain = L
        self.ages = self._ages(ages)

    def _ages(self, ages: Any) -> int | None:
        """``ages`` checked against the controller and the columns."""
        if ages is None:
            return None
        if isinstance(ages, (bool, np.bool_)) or not isinstance(
                ages, (int, np.integer)) or ages < 1:
            raise ValueError(f"ages: expected an int >= 1 (the number of "
                             f"measurement ages), got {ages!r}")
        if self.controller != "static":
            raise ControlArgument(
                f"ages: only controller='static' gains read the measurement "
                f"per age, got controller={self.controller!r}")
        nk = self.gains.shape[-1]
        if nk % ages:
            raise ControlDimension(
                f"ages: {nk} columns do not split into {ages} blocks of "
                f"equal width (one per age: [age 0 | age 1 | ...])")
        return int(ages)

    @property
    def period(self) -> int:
        """Number of phases ``N``."""
        return self.gains.shape[0]

    @property
    def mode_dependent(self) -> bool:
        """True for gains ``K_{k,ℓ}`` that use the previous mode ``ℓ``."""
        return self.gains.ndim == 4

    @property
    def modes(self) -> int | None:
        """Number ``M`` of previous modes the gains use, or None."""
        return self.gains.shape[1] if self.mode_dependent else None

    def __getitem__(self, k: int) -> np.ndarray:
        """``K_k`` for any time ``k`` (taken mod N); the ``(M, m2, nk)``
        stack ``K_{k,ℓ}`` for mode-dependent gains."""
        return self.gains[k % self.period]

    def __array__(self, dtype=None, copy=None):
        out = (self.gains[0] if self.period == 1 and not self.mode_dependent
               else self.gains)
        return np.array(out, dtype=dtype)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, PeriodicGain):
            return False
        L, M = self.estimator_gain, other.estimator_gain
        same_L = (L is None and M is None) or (
            L is not None and M is not None and np.array_equal(L, M))
        return (np.array_equal(self.gains, other.gains)
                and self.controller == other.controller
                and self.actuator == other.actuator and same_L
                and self.ages == other.ages)

    __hash__ = None  # type: ignore[assignment]  # value equality, mutable arrays

    def __reduce__(self):
        L = None if self.estimator_gain is None else np.array(
            self.estimator_gain)
        return (PeriodicGain, (np.array(self.gains), self.controller,
                               self.actuator, self.result, L, self.ages))

    def __repr__(self) -> str:
        head = (f"PeriodicGain(controller={self.controller!r}, "
                f"actuator={self.actuator!r}, period={self.period}")
        if self.ages is not None:
            head += f", per sensor age ({self.ages})"
        if self.mode_dependent:
            head += f", previous modes={self.modes}"
        if self.estimator_gain is not None:
            head += f", estimator_gain shape={self.estimator_gain.shape}"
        if self.gains.size > REPR_ENTRIES:
            return f"{head}, shape={self.gains.shape})"
        g = np.array2string(np.asarray(self), precision=4)
        return f"{head},\n{g})"
