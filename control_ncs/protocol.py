"""Event-level reference simulator of the networked protocol (validation only).

This module is the independent reference that the tests use to validate the
jump matrices built by :mod:`control_ncs.strategies`; it is **not** an API
for modelling (it is not exported by the package, and its interface may
change). To model, analyse or simulate a networked loop use
:func:`control_ncs.nss`, :func:`control_ncs.feedback` and
:func:`control_ncs.simulate`.

It simulates, packet by packet, a plant controlled over a shared network
with periodic medium-access schedules and Bernoulli packet losses, written
from the protocol description alone -- it never builds the augmented
(Markov jump) system matrices -- so that its trajectories are evidence
independent of that formulation.

Model
-----
Plant (discrete time; sensor ``i`` measures ``y_i = (C2 x)_i``, by default
``C2 = I``: sensor ``i`` measures state ``i``)::

    x(k+1) = A x(k) + B1 w(k) + B2 u(k)
    z(k)   = C1 x(k) + D11 w(k) + D12 u(k)
    y(k)   = C2 x(k) + D21 w(k)          (D21 = 0 unless given)

Controllers: a static gain on the received measurement, the model-based
predictor (:ref:`theory-predictor`), the estimator
(:ref:`theory-output-feedback`: the predictor corrected by
``L_k (y - C2 xhat)``) and any discrete-time LTI controller fed with the
received measurements (a lost one is 0 or the last received value).

Network with period ``N``: ``S1[k mod N, i] = 1`` if sensor ``i`` may send at
step ``k`` (one packet carries all scheduled sensors), ``S2[k mod N, j] = 1``
if actuator ``j`` is addressed at step ``k`` (one packet). ``theta1_k = 0``
(probability ``alpha1``) means the sensor packet is lost, ``theta2_k = 0``
(probability ``alpha2``) means the controller-to-actuator packet is lost.

A link may instead lose packets in bursts (Gilbert--Elliott): its channel
is a two-state chain that moves at every step, scheduled or not, with
``P(lost next | delivered now) = f`` and ``P(delivered next | lost now) = r``;
it starts from its stationary law (loss ``f / (f + r)``).

Random draws
------------
For reproducibility, at every step ``k`` -- whether or not anything is
scheduled -- the simulator draws, in this order::

    theta1 = rng.random(trials) >= loss1      # loss1: P(theta1_k = 0 | past)
    theta2 = rng.random(trials) >= loss2

where ``loss`` is the loss probability for a Bernoulli link, and for a
bursty one the stationary loss at ``k = 0``, then ``f`` after a delivery and
``1 - r`` after a loss (so a Bernoulli link, ``f = 1 - r = alpha``, draws
exactly as before). No other random numbers are consumed.

Random delays (time-stamped packets)
------------------------------------
A link given a delay law (``sensor_delay=``, ``actuator_delay=``: a pmf
``[P(δ = 0), P(δ = 1), …]`` or an object with ``pmf`` and ``buffer``) sends
at every step its schedule addresses it one packet stamped with the step
``t``; the packet arrives at ``t + δ``, ``δ`` drawn from the pmf (lost with
probability ``1 - Σ pmf``), in place of that link's ``theta`` draw. The
receiver keeps the freshest packet that has arrived, by its stamp; one
older than ``buffer`` steps is stale (the actuator then applies 0 or holds,
the static controller sends 0). The static controller applies the gain of
the measurement's age, ``v_t = K[a] y_{t-a}``; an LTI controller reads
``y_{t-a}`` (or, when it is stale, 0 or its last reading). Written from this
description alone, it is the reference for the age chain of
:ref:`theory-delays`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["simulate_protocol"]

# its own list, not the package registry: the reference stays independent
_CONTROLLERS = ("static", "predictor", "estimator", "lti")
_SENSORS = ("zero", "hold")
_ACTUATORS = ("zero", "hold")


def _matrix(value: ArrayLike, name: str) -> NDArray[np.float64]:
    """Return ``value`` as a finite 2-D float array (scalars become 1x1)."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a real numeric matrix") from exc
    if arr.ndim == 0:
        arr = arr.reshape(1, 1)
    if arr.ndim != 2:
        raise ValueError(
            f"{name} must be a 2-D array, got an array with {arr.ndim} dimensions"
        )
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must contain only finite values")
    return arr


def _expect_shape(arr: NDArray[Any], shape: tuple[int, ...], name: str) -> None:
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {arr.shape}")


def _schedule(value: ArrayLike, name: str, width: int) -> NDArray[np.float64]:
    """Return a 0/1 schedule of shape (N, width) as a float array."""
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a 0/1 array") from exc
    if arr.ndim != 2 or arr.shape[1] != width or arr.shape[0] < 1:
        raise ValueError(
            f"{name} must have shape (N, {width}) with N >= 1, got {arr.shape}"
        )
    if not (np.issubdtype(arr.dtype, np.number) or arr.dtype == bool):
        raise ValueError(f"{name} must be a numeric or boolean 0/1 array")
    if not np.all((arr == 0) | (arr == 1)):
        raise ValueError(f"{name} must contain only 0 and 1 entries")
    return arr.astype(float)


def _probability(value: Any, name: str) -> float:
    try:
        p = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a real probability in [0, 1]") from exc
    if not 0.0 <= p <= 1.0:  # also rejects NaN
        raise ValueError(f"{name} must be a probability in [0, 1], got {value!r}")
    return p


def _count(value: Any, name: str, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value}")
    return int(value)


def _vector(value: ArrayLike, name: str, length: int) -> NDArray[np.float64]:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a real vector of length {length}") from exc
    # Accept column vectors too, since control code often carries (n, 1) states.
    if arr.shape not in ((length,), (length, 1)):
        raise ValueError(f"{name} must have shape ({length},), got {arr.shape}")
    arr = arr.reshape(length)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must contain only finite values")
    return arr


def _link(value: Any, name: str) -> tuple[float, float, float]:
    """``(stationary loss, P(lost | delivered before), P(lost | lost before))``
    of a float, a 2x2 transition matrix (rows: from lost, from delivered)
    or an object with such a ``transition`` attribute."""
    T = getattr(value, "transition", value)
    if np.ndim(T) == 0:
        a = _probability(T, name)
        return a, a, a
    T = np.asarray(T, dtype=float)
    if T.shape != (2, 2) or not np.all(np.isfinite(T)) or np.any(T < 0) \
            or not np.allclose(T.sum(axis=1), 1.0):
        raise ValueError(f"{name} must be a probability or a 2x2 transition "
                         f"matrix with rows summing to 1, got {T.tolist()}")
    fail, recover = T[1, 0], T[0, 1]
    if fail + recover == 0:
        raise ValueError(f"{name}: the channel never changes state")
    return fail / (fail + recover), fail, T[0, 0]


def simulate_protocol(
    A: ArrayLike,
    B1: ArrayLike,
    B2: ArrayLike,
    C1: ArrayLike,
    D11: ArrayLike,
    D12: ArrayLike,
    sensor_schedule: ArrayLike,
    actuator_schedule: ArrayLike,
    sensor_loss: Any,
    actuator_loss: Any,
    gains: ArrayLike,
    steps: int,
    *,
    controller: str = "static",
    actuator: str = "zero",
    inputs: ArrayLike | None = None,
    initial_state: ArrayLike | None = None,
    initial_estimate: ArrayLike | None = None,
    trials: int = 1,
    rng: np.random.Generator | None = None,
    C2: ArrayLike | None = None,
    estimator_gains: ArrayLike | None = None,
    controller_system: tuple | None = None,
    sensor: str = "zero",
    initial_controller_state: ArrayLike | None = None,
    D21: ArrayLike | None = None,
    sensor_delay: Any = None,
    actuator_delay: Any = None,
) -> dict[str, NDArray[Any]]:
    """Simulate a scheduled, lossy networked control loop event by event.

    All trials are simulated simultaneously (leading trial axis); only time
    is iterated.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Plant state matrix.
    B1 : array_like, shape (n, m1)
        Disturbance input matrix.
    B2 : array_like, shape (n, m2)
        Control input matrix.
    C1 : array_like, shape (p1, n)
        Performance output matrix.
    D11 : array_like, shape (p1, m1)
        Disturbance feedthrough to the performance output.
    D12 : array_like, shape (p1, m2)
        Control feedthrough to the performance output.
    sensor_schedule : array_like, shape (N, p2)
        0/1 array; ``sensor_schedule[k mod N, i] == 1`` if sensor ``i`` may
        send at step ``k``. Its first dimension defines the period ``N``.
        ``p2`` is the number of rows of ``C2`` (``n`` by default).
    actuator_schedule : array_like, shape (N, m2)
        0/1 array; ``actuator_schedule[k mod N, j] == 1`` if actuator ``j``
        is addressed at step ``k``.
    sensor_loss : float, 2x2 array or Gilbert-Elliott link
        ``alpha1 = P(theta1_k = 0)``, the sensor-packet loss probability,
        or the bursty channel's transition matrix (rows: from lost, from
        delivered; or an object with a ``transition`` attribute).
    actuator_loss : float, 2x2 array or Gilbert-Elliott link
        ``alpha2 = P(theta2_k = 0)``, likewise for the actuator packets.
    gains : array_like, shape (N, m2, nk), (N, 4, m2, nk) or (D + 1, m2, p2)
        Periodic gains; step ``k`` uses ``gains[k mod N]``. With a
        ``sensor_delay`` of buffer ``D``: one gain per age of the
        measurement, ``gains[a]``. ``nk = p2``
        (static) or ``n`` (predictor, estimator), except for the predictor
        and the estimator with ``actuator='hold'``, where ``nk = n + m2``
        and the gain acts on ``[xhat; u_{k-1}]``. Ignored (pass ``None``)
        for ``controller='lti'``. A 4-D stack holds gains ``K_{k,ℓ}`` on
        the previous network mode (:ref:`theory-markov`), which the controller
        knows from arrivals and acknowledgements: ``ℓ`` indexes
        ``(θ1, θ2) = (0, 0), (1, 0), (0, 1), (1, 1)`` of the static
        controller's previous step, ``(θ1,k, θ2,k-1)`` for the predictor
        and the estimator; the channels are then drawn once more before
        step 0 (step -1), so that ``ℓ`` at step 0 follows the chains.
    steps : int
        Number of time steps to simulate (>= 0).
    controller : {'static', 'predictor', 'estimator', 'lti'}, optional
        ``'static'``: ``v_k = K_k theta1_k diag(S1[k]) y_k``.
        ``'predictor'``: model-based estimate ``xhat`` overwritten by the
        received measurements (``C2 = I``) and propagated with
        ``A xhat + B2 u`` (the applied ``u`` is known through
        acknowledgements). ``'estimator'``: the same estimate corrected by
        ``xhat += L_k (theta1_k diag(S1[k]) (y_k - C2 xhat))``.
        ``'lti'``: ``controller_system`` driven by the received
        measurements, ``v_k`` its output.
    actuator : {'zero', 'hold'}, optional
        ``'zero'``: unaddressed or lost actuators apply 0.
        ``'hold'``: unaddressed or lost actuators keep their previous value
        (``u_{-1} = 0``).
    inputs : array_like, shape (m1, steps) or (trials, m1, steps), optional
        Disturbance sequence ``w``, shared by the trials or one per trial
        (e.g. white noise drawn by the caller); zeros if omitted.
    initial_state : array_like, shape (n,), optional
        Plant initial state ``x_0`` shared by all trials; zeros if omitted.
    initial_estimate : array_like, shape (n,), optional
        Predictor estimate before the first sensor update at ``k = 0``;
        zeros if omitted. Only allowed with ``controller='predictor'`` or
        ``'estimator'``.
    trials : int, optional
        Number of independent Monte Carlo trials (>= 1).
    rng : numpy.random.Generator, optional
        Source of randomness. If omitted a fresh, unseeded generator is used
        (results are then not reproducible). The global NumPy RNG is never
        used.
    C2 : array_like, shape (p2, n), optional
        Measurement matrix; identity if omitted (only the estimator, the
        static gain and the LTI controller accept another one).
    estimator_gains : array_like, shape (N, n, p2), optional
        ``L_k`` of ``controller='estimator'`` (required there).
    controller_system : tuple of 4 array_like, optional
        ``(Ac, Bc, Cc, Dc)`` of ``controller='lti'`` (required there):
        ``xc(k+1) = Ac xc + Bc yrcv``, ``v = Cc xc + Dc yrcv``, where
        ``yrcv`` is what the controller received at step ``k``.
    sensor : {'zero', 'hold'}, optional
        ``controller='lti'`` only: a lost or unscheduled measurement is
        received as 0, or as the last received value (initially 0).
    initial_controller_state : array_like, shape (nc,), optional
        ``xc_0`` of ``controller='lti'``; zeros if omitted.
    D21 : array_like, shape (p2, m1), optional
        Feedthrough of ``w`` into the measurements (noise, references).
    sensor_delay, actuator_delay : array_like or object, optional
        Random integer delays of the link's time-stamped packets (see the
        module's notes): a pmf, or an object with ``pmf`` and ``buffer``
        (such as :func:`control_ncs.random_delay`'s). The link's loss must
        then be 0 (the pmf carries it), its schedule must address all of
        its nodes together or none, and the controller must be
        ``'static'`` or ``'lti'`` (which reads the freshest measurement, or
        0 or its last reading when that is stale).

    Returns
    -------
    dict
        ``'x'`` : ndarray, shape (trials, n, steps + 1)
            Plant states ``x_0 .. x_steps``.
        ``'z'`` : ndarray, shape (trials, p1, steps)
            Performance outputs ``z_k = C1 x_k + D11 w_k + D12 u_k``.
        ``'u'`` : ndarray, shape (trials, m2, steps)
            Applied control inputs.
        ``'theta1'``, ``'theta2'`` : ndarray of bool, shape (trials, steps)
            Packet-success indicators drawn at each step (a delayed link:
            whether a packet no older than its buffer was in use).
        ``'age1'``, ``'age2'`` : ndarray of int, shape (trials, steps)
            Only for a delayed link: the age of the packet in use
            (``buffer + 1``: stale or none).
        ``'xc'`` : ndarray, shape (trials, nc, steps + 1)
            Only for ``controller='lti'``: controller states.
        ``'xhat'`` : ndarray, shape (trials, n, steps + 1)
            Only for ``controller='predictor'`` or ``'estimator'``. ``xhat[:, :, k]`` is the
            estimate after the sensor update at step ``k``; the last column
            is the prediction ``A xhat + B2 u`` made at the final step,
            before any further update.

    Raises
    ------
    ValueError
        If any argument has the wrong shape, type or range, or if
        ``controller`` / ``actuator`` is not a recognised name.

    Notes
    -----
    At every step the simulator draws ``theta1`` for all trials and then
    ``theta2`` for all trials, as ``rng.random(trials) >= alpha``, even
    when nothing is scheduled, so that the random stream does not depend on
    the schedules.

    Examples
    --------
    >>> import numpy as np
    >>> from control_ncs.protocol import simulate_protocol
    >>> out = simulate_protocol(
    ...     [[2.0]], [[0.0]], [[1.0]], [[1.0]], [[0.0]], [[0.0]],
    ...     [[1]], [[1]], 0.0, 0.0, [[[-2.0]]], 3,
    ...     initial_state=[1.0], rng=np.random.default_rng(0))
    >>> out["x"][0, 0]
    array([1., 0., 0., 0.])
    """
    # --- argument validation -------------------------------------------
    if not isinstance(controller, str) or controller not in _CONTROLLERS:
        raise ValueError(
            f"controller must be one of {_CONTROLLERS}, got {controller!r}"
        )
    if not isinstance(actuator, str) or actuator not in _ACTUATORS:
        raise ValueError(f"actuator must be one of {_ACTUATORS}, got {actuator!r}")

    A = _matrix(A, "A")
    n = A.shape[0]
    _expect_shape(A, (n, n), "A")
    B1 = _matrix(B1, "B1")
    B2 = _matrix(B2, "B2")
    if B1.shape[0] != n:
        raise ValueError(f"B1 must have {n} rows (shape (n, m1)), got {B1.shape}")
    if B2.shape[0] != n:
        raise ValueError(f"B2 must have {n} rows (shape (n, m2)), got {B2.shape}")
    m1, m2 = B1.shape[1], B2.shape[1]
    C1 = _matrix(C1, "C1")
    if C1.shape[1] != n:
        raise ValueError(f"C1 must have {n} columns (shape (p1, n)), got {C1.shape}")
    p1 = C1.shape[0]
    D11 = _matrix(D11, "D11")
    _expect_shape(D11, (p1, m1), "D11")
    D12 = _matrix(D12, "D12")
    _expect_shape(D12, (p1, m2), "D12")

    if not isinstance(sensor, str) or sensor not in _SENSORS:
        raise ValueError(f"sensor must be one of {_SENSORS}, got {sensor!r}")
    if sensor != "zero" and controller != "lti":
        raise ValueError("sensor='hold' is only modelled for controller='lti'")
    if C2 is None:
        C2m = np.eye(n)
    else:
        C2m = _matrix(C2, "C2")
        if C2m.shape[1] != n:
            raise ValueError(f"C2 must have {n} columns, got {C2m.shape}")
        if controller == "predictor" and not np.array_equal(C2m, np.eye(n)):
            raise ValueError("controller='predictor' needs C2 = I")
    p2 = C2m.shape[0]
    S1 = _schedule(sensor_schedule, "sensor_schedule", p2)
    N = S1.shape[0]
    S2 = _schedule(actuator_schedule, "actuator_schedule", m2)
    if S2.shape[0] != N:
        raise ValueError(
            f"actuator_schedule must have the same period as sensor_schedule "
            f"(shape ({N}, {m2})), got {S2.shape}"
        )

    link1 = _link(sensor_loss, "sensor_loss")
    link2 = _link(actuator_loss, "actuator_loss")
    delay1 = _delay(sensor_delay, "sensor_delay", link1, S1)
    delay2 = _delay(actuator_delay, "actuator_delay", link2, S2)
    if (delay1 or delay2) and controller not in ("static", "lti"):
        raise ValueError("sensor_delay, actuator_delay: delayed links are "
                         "simulated with controller='static' or 'lti'")
    D21m = np.zeros((p2, m1)) if D21 is None else _matrix(D21, "D21")
    _expect_shape(D21m, (p2, m1), "D21")

    predictor = controller in ("predictor", "estimator")
    estimator = controller == "estimator"
    lti = controller == "lti"
    hold = actuator == "hold"
    nk = n + m2 if (predictor and hold) else (n if predictor else p2)
    if lti:
        if controller_system is None or len(controller_system) != 4:
            raise ValueError("controller='lti' needs controller_system = "
                             "(Ac, Bc, Cc, Dc)")
        Ac, Bc, Cc, Dc = (np.asarray(X, dtype=float).reshape(np.shape(X))
                          for X in controller_system)
        nc = Ac.shape[0] if Ac.ndim == 2 else 0
        Ac = Ac.reshape(nc, nc)
        Bc, Cc, Dc = Bc.reshape(nc, p2), Cc.reshape(m2, nc), Dc.reshape(m2, p2)
        gains = np.zeros((N, m2, nk))
    elif controller_system is not None:
        raise ValueError("controller_system is only for controller='lti'")
    if estimator:
        if estimator_gains is None:
            raise ValueError("controller='estimator' needs estimator_gains")
        L = np.asarray(estimator_gains, dtype=float)
        if L.shape != (N, n, p2):
            raise ValueError(f"estimator_gains must have shape ({N}, {n}, "
                             f"{p2}), got {L.shape}")
    elif estimator_gains is not None:
        raise ValueError("estimator_gains is only for controller='estimator'")
    try:
        K = np.asarray(gains, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError("gains must be a real array of shape (N, m2, nk)") from exc
    by_mode = K.ndim == 4 and not lti
    per_age = bool(delay1) and not lti
    NK = delay1[1] + 1 if delay1 and per_age else N   # per age, or phase
    if (delay1 or delay2) and by_mode:
        raise ValueError("gains: over delayed links one gain per phase, or "
                         "per age over a delayed sensor link, not per mode")
    if per_age and K.shape != (NK, m2, nk):
        raise ValueError(
            f"gains must have shape (D + 1, m2, p2) = ({NK}, {m2}, {nk}) "
            f"over a delayed sensor link (a gain per age), got {K.shape}")
    if not per_age and \
            K.shape != ((N, 4, m2, nk) if by_mode else (N, m2, nk)):
        raise ValueError(
            f"gains must have shape (N, m2, nk) = ({N}, {m2}, {nk}) or "
            f"(N, 4, m2, nk) = ({N}, 4, {m2}, {nk}) for "
            f"controller={controller!r}, actuator={actuator!r}, got {K.shape}"
        )
    if not np.all(np.isfinite(K)):
        raise ValueError("gains must contain only finite values")

    steps = _count(steps, "steps", 0)
    trials = _count(trials, "trials", 1)

    W: NDArray[np.float64] = np.zeros((1, m1, steps))
    if inputs is not None:
        given = (np.asarray(inputs, dtype=float)
                 if np.ndim(inputs) in (2, 3) else None)
        if given is None or given.shape not in ((m1, steps),
                                                (trials, m1, steps)) \
                or not np.all(np.isfinite(given)):
            raise ValueError(
                f"inputs must be finite, of shape (m1, steps) = ({m1}, "
                f"{steps}) or (trials, m1, steps), got {np.shape(inputs)}"
            )
        W = given if given.ndim == 3 else given[None]

    x0 = np.zeros(n) if initial_state is None else _vector(
        initial_state, "initial_state", n
    )
    if initial_estimate is not None and not predictor:
        raise ValueError(
            "initial_estimate is only meaningful for controller='predictor' "
            "or 'estimator'"
        )
    xhat0 = np.zeros(n) if initial_estimate is None else _vector(
        initial_estimate, "initial_estimate", n
    )

    if rng is None:
        rng = np.random.default_rng()
    elif not isinstance(rng, np.random.Generator):
        raise ValueError(
            f"rng must be a numpy.random.Generator or None, got {type(rng).__name__}"
        )

    # --- simulation ----------------------------------------------------
    # Row-vector convention (trials, dim) so that one matmul with a
    # transposed matrix advances every trial at once.
    x = np.tile(x0, (trials, 1))
    xhat = np.tile(xhat0, (trials, 1))
    u_prev = np.zeros((trials, m2))
    if lti:
        xc0 = (np.zeros(nc) if initial_controller_state is None
               else _vector(initial_controller_state,
                            "initial_controller_state", nc))
        xc = np.tile(xc0, (trials, 1))
        xc_hist = np.empty((trials, nc, steps + 1))
        xc_hist[:, :, 0] = xc
        y_rcv = np.zeros((trials, p2))
    elif initial_controller_state is not None:
        raise ValueError("initial_controller_state is only for "
                         "controller='lti'")

    x_hist = np.empty((trials, n, steps + 1))
    z_hist = np.empty((trials, p1, steps))
    u_hist = np.empty((trials, m2, steps))
    # empty (and not returned) without the predictor
    xhat_hist = np.empty((trials, n if predictor else 0, steps + 1))
    th1_hist = np.empty((trials, steps), dtype=bool)
    th2_hist = np.empty((trials, steps), dtype=bool)
    # delayed links: the packets stamped t - c, c = 0..buffer, with their
    # arrival times and contents, and the age of the packet in use
    sens_q: Any = _Queue(delay1, trials, p2, steps) if delay1 else None
    act_q: Any = _Queue(delay2, trials, m2, steps) if delay2 else None

    def draw(link: tuple[float, float, float], before: Any) -> Any:
        loss = (link[0] if before is None
                else np.where(before, link[1], link[2]))
        return rng.random(trials) >= loss

    th1: Any = None
    th2: Any = None
    if by_mode:
        # step -1: the previous mode at step 0 (stationary channels)
        th1 = draw(link1, th1)
        th2 = draw(link2, th2)
    x_hist[:, :, 0] = x
    for k in range(steps):
        phase = k % N
        before1, before2 = th1, th2
        # Drawn unconditionally so the random stream is independent of the
        # schedule (the channel moves whether or not it carries a packet);
        # with a loss of 1 this is always False since random() < 1.
        th1 = draw(link1, th1) if not delay1 else None
        th2 = draw(link2, th2) if not delay2 else None
        if delay1:
            sens_q.send(k, S1[phase].any(), rng)
        if delay2:
            act_q.send(k, S2[phase].any(), rng)

        # A packet is received only if scheduled and not lost; the product
        # is the per-trial, per-channel delivery mask.
        # (a delayed link's mask comes from its queue below)
        recv1: Any = th1[:, None] * S1[phase][None, :] if not delay1 else None
        recv2: Any = th2[:, None] * S2[phase][None, :] if not delay2 else None
        Kk = K[phase % NK]
        if by_mode:
            # ℓ = σ_{k-1}: (θ1,k-1, θ2,k-1) for the static gain, (θ1,k,
            # θ2,k-1) for the model-based controllers (theory: Markov losses)
            seen1 = th1 if predictor else before1
            Kk = Kk[np.asarray(seen1, int) + 2 * np.asarray(before2, int)]
        w = W[:, :, k]

        y = x @ C2m.T + w @ D21m.T
        if delay1:
            sens_q.store(y)
            y, th1 = sens_q.freshest(k)
            recv1 = th1[:, None] * np.ones((1, p2))     # a fresh packet
            if per_age:
                Kk = K[np.minimum(sens_q.age[:, k], NK - 1)]
        if estimator:
            xhat = xhat + (recv1 * (y - xhat @ C2m.T)) @ L[phase].T
        elif predictor:
            xhat = xhat + recv1 * (x - xhat)
        if predictor:
            xhat_hist[:, :, k] = xhat
            feedback = np.concatenate([xhat, u_prev], axis=1) if hold else xhat
            v = (np.einsum("tij,tj->ti", Kk, feedback) if by_mode
                 else feedback @ Kk.T)
        elif lti:
            if sensor == "hold":
                y_rcv = y_rcv + recv1 * (y - y_rcv)
            else:
                y_rcv = recv1 * y
            v = xc @ Cc.T + y_rcv @ Dc.T
            xc = xc @ Ac.T + y_rcv @ Bc.T
            xc_hist[:, :, k + 1] = xc
        elif by_mode or per_age:
            v = np.einsum("tij,tj->ti", Kk, recv1 * y)
        else:
            v = (recv1 * y) @ Kk.T

        if delay2:
            act_q.store(v)
            v, th2 = act_q.freshest(k)
            recv2 = th2[:, None] * np.ones((1, m2))
        th1_hist[:, k] = th1
        th2_hist[:, k] = th2
        if hold:
            u = u_prev + recv2 * (v - u_prev)
        else:
            u = recv2 * v

        z_hist[:, :, k] = x @ C1.T + w @ D11.T + u @ D12.T
        u_hist[:, :, k] = u

        x = x @ A.T + w @ B1.T + u @ B2.T
        if predictor:
            # The controller does not know w, so its model propagates
            # without it; u is known exactly thanks to acknowledgements.
            xhat = xhat @ A.T + u @ B2.T
        u_prev = u
        x_hist[:, :, k + 1] = x

    result: dict[str, NDArray[Any]] = {
        "x": x_hist,
        "z": z_hist,
        "u": u_hist,
        "theta1": th1_hist,
        "theta2": th2_hist,
    }
    if predictor:
        xhat_hist[:, :, steps] = xhat
        result["xhat"] = xhat_hist
    if lti:
        result["xc"] = xc_hist
    if delay1:
        result["age1"] = sens_q.age
    if delay2:
        result["age2"] = act_q.age
    return result


def _delay(value: Any, name: str, link: tuple[float, float, float],
           S: NDArray[np.float64]) -> tuple[NDArray[np.float64], int] | None:
    """``(pmf, buffer)`` of a delayed link, checked; None without one."""
    if value is None:
        return None
    pmf = np.asarray(getattr(value, "pmf", value), dtype=float)
    if pmf.ndim != 1 or pmf.size == 0 or not np.all(np.isfinite(pmf)) \
            or np.any(pmf < 0) or pmf.sum() > 1 + 1e-12 or pmf.sum() == 0:
        raise ValueError(f"{name} must be a pmf [P(δ = 0), P(δ = 1), ...] "
                         f"with a positive sum <= 1, got {pmf.tolist()}")
    buffer = int(getattr(value, "buffer", pmf.size - 1))
    if buffer < 0:
        raise ValueError(f"{name}: buffer must be >= 0, got {buffer}")
    if link != (0.0, 0.0, 0.0):
        raise ValueError(f"{name}: the link's loss is 1 - sum(pmf); give "
                         f"a loss of 0 with a delay law")
    if np.any(S.any(axis=1) & ~S.all(axis=1)):
        raise ValueError(f"{name}: one packet carries all nodes of the link, "
                         f"so its schedule must address all of them or none")
    return pmf, buffer


class _Queue:
    """The time-stamped packets of one delayed link, for all trials.

    Slot ``c`` holds the packet stamped ``t - c`` (``c = 0..buffer``): its
    arrival time (``inf``: lost or never sent) and its content. Older
    packets are stale and dropped.
    """

    def __init__(self, delay: tuple[NDArray[np.float64], int], trials: int,
                 width: int, steps: int) -> None:
        pmf, buffer = delay
        self.buffer: int = buffer
        self.cdf = np.cumsum(pmf)
        self.lost = pmf.size                    # the outcome "never arrives"
        self.arrival = np.full((trials, self.buffer + 1), np.inf)
        self.content = np.zeros((trials, self.buffer + 1, width))
        self.age = np.full((trials, steps), self.buffer + 1)

    def send(self, t: int, sent: bool, rng: np.random.Generator) -> None:
        """Age every slot by one step and stamp the packet of step ``t``."""
        trials = self.arrival.shape[0]
        delta = np.searchsorted(self.cdf, rng.random(trials), side="right")
        self.arrival = np.roll(self.arrival, 1, axis=1)
        self.content = np.roll(self.content, 1, axis=1)
        self.arrival[:, 0] = np.where((delta < self.lost) & sent,
                                      t + delta, np.inf)

    def store(self, value: NDArray[np.float64]) -> None:
        """The content of the packet stamped now."""
        self.content[:, 0] = value

    def freshest(self, t: int) -> tuple[NDArray[np.float64], Any]:
        """The content of the freshest arrived packet no older than the
        buffer (0 where none) and whether there is one."""
        arrived = self.arrival <= t
        fresh: Any = arrived.any(axis=1)
        c = np.argmax(arrived, axis=1)          # smallest age that arrived
        self.age[:, t] = np.where(fresh, c, self.buffer + 1)
        value = self.content[np.arange(c.size), c] * fresh[:, None]
        return value, fresh
