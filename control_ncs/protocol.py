"""Event-level reference simulator of the networked protocol (validation only).

This module is the independent reference that the tests use to validate the
jump matrices the package builds; it is **not** an API for modelling (it is
not exported by the package, and its interface may change). To model,
analyse or simulate a networked loop use :func:`control_ncs.nss`,
:func:`control_ncs.feedback` and :func:`control_ncs.simulate`.

It simulates, packet by packet with time stamps, a plant controlled over a
network with periodic schedules, lossy and delayed links on both sides at
once, written from the protocol's description alone -- it never builds the
augmented (Markov jump) system matrices -- so that its trajectories are
evidence independent of that formulation.

Model
-----
Plant (discrete time)::

    x(t+1) = A x(t) + B1 w(t) + B2 u(t)
    z(t)   = C1 x(t) + D11 w(t) + D12 u(t)
    y(t)   = C2 x(t) + D21 w(t)          (C2 = I, D21 = 0 unless given)

or, with a sub-sample input delay, ``x(t+1) = A x + B1 w + Γ0(τ_t) u(t) +
Γ1(τ_t) u(t-1)``, ``τ_t`` drawn i.i.d. at every step (``B2`` is then only the
model of the predictor and the estimator).

Schedules of period ``N``: ``S1[t mod N, i] = 1`` if sensor ``i`` may send at
step ``t``, ``S2[t mod N, j] = 1`` if actuator ``j`` is addressed. At step
``t`` each link sends one packet stamped ``t`` if its schedule names
someone; it carries ``Σ1,t y(t)`` (the scheduled sensors) or the addressed
components of the command ``v(t)``.

Links (each of the two, independently): perfect; Bernoulli loss; a
Gilbert--Elliott channel that moves at every step (a packet sent at ``t``
arrives iff the channel delivers at ``t``); random delays ``δ`` drawn per
packet from a pmf, after a Bernoulli loss if one is given too (the thinned
law); bursty delays, where a packet still in flight at age ``c`` arrives
at step ``t`` with the hazard ``q_c / (1 - Σ_{c'<c} q_c')`` of the pmf of
the channel's state at ``t``. The receiver uses the freshest packet that
has arrived (largest stamp); older than the link's buffer it is stale.

Controllers: a static gain per phase and per age of the measurement,
``v = K[t mod N, a] ŷ`` (0 when stale); an LTI controller fed with the
freshest measurement (a missing sensor reads 0 or its last value); the
estimator, which keeps estimates of the last ``Ds + 1`` steps, predicts
with ``(A, B2)`` and the applied inputs (acknowledged), and on a *new*
packet of age ``a`` corrects ``x̂(t - j) += A^(a-j) L ν`` for ``j = 0..a``
with ``ν = Σ1 (y(t-a) - C2 x̂(t-a))`` and ``L`` of the measured step's
phase; the predictor is the estimator with ``C2 = I``, ``L = I``. The
actuator applies the addressed components of the freshest command, the
others 0 or their last value.

Random draws
------------
At every step -- whether or not anything is scheduled -- in this order:
``rng.random(trials) >= loss`` for each undelayed link (sensor, then
actuator), where ``loss`` is the loss probability of a Bernoulli link, and
for a Gilbert--Elliott one the stationary loss at the first step, then
``f`` after a delivery and ``1 - r`` after a loss; then each delayed link's
draws (sensor, then actuator): a Bernoulli loss if given, then the delay
``δ`` of the new packet; or, for a bursty link, its channel state and one
uniform per packet in flight; then the sub-sample delay (a Bernoulli link
with ``f = 1 - r = α`` draws exactly as a Gilbert--Elliott one would).
"""

from __future__ import annotations

from dataclasses import dataclass
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


def _pmf(value: Any, name: str) -> NDArray[np.float64]:
    pmf = np.asarray(value, dtype=float)
    if pmf.ndim != 1 or pmf.size == 0 or not np.all(np.isfinite(pmf)) \
            or np.any(pmf < 0) or pmf.sum() > 1 + 1e-12:
        raise ValueError(f"{name} must be a pmf [P(δ = 0), P(δ = 1), ...] "
                         f"with a sum <= 1, got {pmf.tolist()}")
    return pmf


def _hazards(pmf: NDArray[np.float64], buffer: int) -> NDArray[np.float64]:
    """``h(c) = q_c / (1 - Σ_{c'<c} q_c')`` for ages ``c = 0..buffer``: a
    packet not arrived before age ``c`` arrives at ``c`` (0 beyond the
    law, or once nothing is left to arrive)."""
    h = np.zeros(buffer + 1)
    left = 1.0
    for c in range(min(pmf.size, buffer + 1)):
        h[c] = pmf[c] / left if left > 1e-15 else 0.0
        left -= pmf[c]
    return h


# --------------------------------------------------------------------------
# links: what the receiver holds at each step
# --------------------------------------------------------------------------
class _Instant:
    """An undelayed link: the packet of step ``t`` arrives at ``t`` or
    never, as the channel drawn at that step says (buffer 0)."""

    buffer = 0
    queued = False

    def __init__(self, link: tuple[float, float, float], trials: int) -> None:
        self.link = link
        self.trials = trials
        self.theta: Any = None          # the draw of this step
        self.before: Any = None         # the draw of the previous step

    def draw(self, rng: np.random.Generator) -> None:
        loss = (self.link[0] if self.theta is None
                else np.where(self.theta, self.link[1], self.link[2]))
        self.before = self.theta
        self.theta = rng.random(self.trials) >= loss

    def send(self, t: int, sent: bool, rng: np.random.Generator) -> None:
        """Nothing to draw: the channel was drawn by :meth:`draw`."""

    def receive(self, t: int, content: NDArray[np.float64],
                sent: bool) -> tuple[Any, Any, Any]:
        fresh = self.theta & sent
        return (np.where(fresh, 0, 1), content * fresh[:, None], fresh)


class _Queue:
    """The time-stamped packets of a delayed link, for all trials.

    Slot ``c`` holds the packet stamped ``t - c`` (``c = 0..buffer``): its
    arrival time (``inf``: not arrived, lost or never sent) and content.
    Older packets are stale and dropped.
    """

    queued = True

    def __init__(self, buffer: int, trials: int, width: int) -> None:
        self.buffer = buffer
        self.trials = trials
        self.arrival = np.full((trials, buffer + 1), np.inf)
        self.content = np.zeros((trials, buffer + 1, width))
        self.theta: Any = None

    def draw(self, rng: np.random.Generator) -> None:
        """Nothing to draw before the step: the queue draws in :meth:`send`."""

    def _shift(self) -> None:
        self.arrival = np.roll(self.arrival, 1, axis=1)
        self.content = np.roll(self.content, 1, axis=1)

    def send(self, t: int, sent: bool, rng: np.random.Generator) -> None:
        raise NotImplementedError

    def receive(self, t: int, content: NDArray[np.float64],
                sent: bool) -> tuple[Any, Any, Any]:
        """Store the packet stamped ``t``; the age and content of the
        freshest arrived packet no older than the buffer (0 where none)."""
        self.content[:, 0] = content
        arrived = self.arrival <= t
        fresh: Any = arrived.any(axis=1)
        c = np.argmax(arrived, axis=1)          # smallest age that arrived
        value = self.content[np.arange(c.size), c] * fresh[:, None]
        self.theta = fresh
        return np.where(fresh, c, self.buffer + 1), value, fresh


class _DelayQueue(_Queue):
    """Delays drawn per packet when it is sent; a Bernoulli loss first."""

    def __init__(self, pmf: NDArray[np.float64], buffer: int, loss: float,
                 trials: int, width: int) -> None:
        super().__init__(buffer, trials, width)
        self.cdf = np.cumsum(pmf)
        self.lost = pmf.size                    # the outcome "never arrives"
        self.loss = loss

    def send(self, t: int, sent: bool, rng: np.random.Generator) -> None:
        lost: Any = (rng.random(self.trials) < self.loss if self.loss > 0
                     else False)
        delta = np.searchsorted(self.cdf, rng.random(self.trials),
                                side="right")
        self._shift()
        self.arrival[:, 0] = np.where((delta < self.lost) & ~lost & sent,
                                      t + delta, np.inf)


class _BurstyQueue(_Queue):
    """A Gilbert--Elliott channel (state 0 bad, 1 good) with a delay law per
    state: every packet in flight arrives with the hazard of its age in the
    channel's state of the step."""

    def __init__(self, channel: NDArray[np.float64], pmfs: tuple,
                 buffer: int, trials: int, width: int) -> None:
        super().__init__(buffer, trials, width)
        self.fail, self.recover = channel[1, 0], channel[0, 1]
        self.hazard = np.array([_hazards(q, buffer) for q in pmfs])
        self.good: Any = None
        self.pending = np.zeros((trials, buffer + 1), dtype=bool)

    def send(self, t: int, sent: bool, rng: np.random.Generator) -> None:
        draw = rng.random(self.trials)
        if self.good is None:       # the channel's stationary law
            self.good = draw >= self.fail / (self.fail + self.recover)
        else:
            self.good = draw >= np.where(self.good, self.fail,
                                         1.0 - self.recover)
        self._shift()
        self.pending = np.roll(self.pending, 1, axis=1)
        self.arrival[:, 0] = np.inf
        self.pending[:, 0] = sent
        h = self.hazard[self.good.astype(int)]          # (trials, buffer + 1)
        arrive = self.pending & (rng.random(h.shape) < h)
        self.arrival[arrive] = t
        self.pending &= ~arrive


def _make_link(loss: Any, delay: Any, name: str, S: NDArray[np.float64],
               trials: int) -> Any:
    """The receiver model of one link from its loss and delay arguments."""
    side = name.split("_")[0]
    link = _link(loss, f"{side}_loss")
    if delay is None:
        return _Instant(link, trials)
    if np.any(S.any(axis=1) & ~S.all(axis=1)):
        raise ValueError(f"{name}: one packet carries all nodes of the link, "
                         f"so its schedule must address all of them or none")
    bursty = getattr(delay, "pmfs", None)
    if link[1] != link[2]:
        raise ValueError(f"{name}: a Gilbert-Elliott loss and a delay on one "
                         f"link have no finite chain; give a bursty delay")
    if bursty is not None:
        if link[0] != 0.0:
            raise ValueError(f"{name}: a Bernoulli loss and a bursty delay on "
                             f"one link; put the loss in the delay laws")
        pmfs = tuple(_pmf(q, name) for q in bursty)
        buffer = int(delay.buffer)
        channel = np.asarray(delay.link.transition, dtype=float)
        return _BurstyQueue(channel, pmfs, buffer, trials, S.shape[1])
    pmf = _pmf(getattr(delay, "pmf", delay), name)
    buffer = int(getattr(delay, "buffer", pmf.size - 1))
    if buffer < 0:
        raise ValueError(f"{name}: buffer must be >= 0, got {buffer}")
    return _DelayQueue(pmf, buffer, link[0], trials, S.shape[1])


# --------------------------------------------------------------------------
# the simulator
# --------------------------------------------------------------------------
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
    input_delay: tuple | None = None,
    warmup: int = 0,
) -> dict[str, NDArray[Any]]:
    """Simulate a scheduled, lossy, delayed networked loop event by event.

    All trials are simulated simultaneously (leading trial axis); only time
    is iterated.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Plant state matrix.
    B1 : array_like, shape (n, m1)
        Disturbance input matrix.
    B2 : array_like, shape (n, m2)
        Control input matrix (with ``input_delay``: only the model of the
        predictor and the estimator).
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
        delivered; or an object with a ``transition`` attribute). With a
        ``sensor_delay``: a Bernoulli loss before the delay (the thinned
        law); a Gilbert-Elliott loss is then refused.
    actuator_loss : float, 2x2 array or Gilbert-Elliott link
        ``alpha2 = P(theta2_k = 0)``, likewise for the actuator packets.
    gains : array_like
        Step ``k`` uses phase ``k mod N``. Static controller: ``(N, m2,
        p2)`` per phase; over a delayed sensor link of buffer ``D``
        ``(D + 1, m2, p2)`` per age of the measurement or ``(N, D + 1, m2,
        p2)`` per phase and age. Predictor and estimator: ``(N, m2, nk)``
        with ``nk = n``, or ``n + m2`` with ``actuator='hold'`` (the gain
        acts on ``[xhat; u_{k-1}]``). Over undelayed links a 4-D stack
        ``(N, 4, m2, nk)`` holds gains ``K_{k,ℓ}`` on the previous network
        mode (:ref:`theory-markov`): ``ℓ`` indexes ``(θ1, θ2) = (0, 0), (1,
        0), (0, 1), (1, 1)`` of the static controller's previous step,
        ``(θ1,k, θ2,k-1)`` for the predictor and the estimator; the
        channels are then drawn once more before the first step. Ignored
        (pass ``None``) for ``controller='lti'``.
    steps : int
        Number of time steps to simulate (>= 0).
    controller : {'static', 'predictor', 'estimator', 'lti'}, optional
        ``'static'``: ``v = K ŷ`` on the freshest measurement (0 when
        stale). ``'estimator'``: estimates of the last ``Ds + 1`` steps
        (``Ds`` the sensor link's buffer), predicted with ``A xhat + B2
        u`` (the applied ``u`` is known through acknowledgements) and
        corrected when a new packet arrives (see the module's notes);
        ``v = K xhat``. ``'predictor'``: the estimator with ``C2 = I``,
        ``L = I``. ``'lti'``: ``controller_system`` driven by the received
        measurements, ``v`` its output.
    actuator : {'zero', 'hold'}, optional
        ``'zero'``: components not in the freshest command packet (or all,
        when stale) apply 0. ``'hold'``: they keep their previous value
        (``u_{-1} = 0``).
    inputs : array_like, shape (m1, steps) or (trials, m1, steps), optional
        Disturbance sequence ``w``, shared by the trials or one per trial
        (e.g. white noise drawn by the caller); zeros if omitted.
    initial_state : array_like, shape (n,), optional
        Plant initial state ``x_0`` shared by all trials; zeros if omitted.
    initial_estimate : array_like, shape (n,), optional
        Estimate ``xhat_0`` before the first sensor update; zeros if
        omitted. Only with ``controller='predictor'`` or ``'estimator'``.
    trials : int, optional
        Number of independent Monte Carlo trials (>= 1).
    rng : numpy.random.Generator, optional
        Source of randomness. If omitted a fresh, unseeded generator is used
        (results are then not reproducible). The global NumPy RNG is never
        used.
    C2 : array_like, shape (p2, n), optional
        Measurement matrix; identity if omitted (the predictor needs it).
    estimator_gains : array_like, shape (N_L, n, p2), optional
        ``L_k`` of ``controller='estimator'`` (required there), indexed by
        the phase ``(t - a) mod N_L`` of the measured step.
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
        Random integer delays of the link's time-stamped packets: a pmf,
        an object with ``pmf`` and ``buffer`` (such as
        :func:`control_ncs.random_delay`'s), or a bursty one with ``link``
        (a Gilbert-Elliott chain with a ``transition``), ``pmfs`` (bad,
        good) and ``buffer`` (:func:`control_ncs.bursty_delay`'s). The
        link's schedule must address all of its nodes together or none.
    input_delay : tuple (gamma0, gamma1, probabilities), optional
        Sub-sample input delay: ``gamma0``, ``gamma1`` of shape ``(M, n,
        m2)``; at every step ``τ`` is drawn with ``probabilities`` and
        ``x⁺ = A x + B1 w + gamma0[τ] u + gamma1[τ] u_{k-1}``.
    warmup : int, optional
        Steps the network runs before step 0 with every signal 0 (packets
        carry zeros), so that the links start near their stationary law.

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
            The channel draws of an undelayed link; for a delayed link,
            whether a packet no older than its buffer was in use.
        ``'age1'``, ``'age2'`` : ndarray of int, shape (trials, steps)
            Only for a delayed link: the age of the packet in use
            (``buffer + 1``: stale or none).
        ``'xc'`` : ndarray, shape (trials, nc, steps + 1)
            Only for ``controller='lti'``: controller states.
        ``'xhat'`` : ndarray, shape (trials, n, steps + 1)
            Only for ``controller='predictor'`` or ``'estimator'``:
            ``xhat[:, :, k]`` is the estimate of ``x_k`` after the sensor
            update at step ``k``; the last column is the prediction made at
            the final step, before any further update.

    Raises
    ------
    ValueError
        If any argument has the wrong shape, type or range, if
        ``controller`` / ``actuator`` is not a recognised name, or if a
        link combines what has no model (a Gilbert-Elliott loss with a
        delay, a Bernoulli loss with a bursty delay, a partial schedule on
        a delayed link).

    Examples
    --------
    >>> from control_ncs.protocol import simulate_protocol
    >>> out = simulate_protocol(
    ...     [[2.0]], [[0.0]], [[1.0]], [[1.0]], [[0.0]], [[0.0]],
    ...     [[1]], [[1]], 0.0, 0.0, [[[-2.0]]], 3,
    ...     initial_state=[1.0], rng=np.random.default_rng(0))
    >>> out["x"][0, 0]
    array([1., 0., 0., 0.])
    """
    plan = _plan(dict(locals()))
    if rng is None:
        rng = np.random.default_rng()
    elif not isinstance(rng, np.random.Generator):
        raise ValueError(
            f"rng must be a numpy.random.Generator or None, got {type(rng).__name__}"
        )
    return _run(plan, rng)


@dataclass
class _Plan:
    """The validated loop: plant, network, controller, run settings."""

    mats: dict
    S1: NDArray[np.float64]
    S2: NDArray[np.float64]
    controller: str
    actuator: str
    sensor: str
    K: NDArray[np.float64]
    gain_kind: str              # 'phase', 'phase_age', 'mode' (or 'lti')
    L: NDArray[np.float64] | None
    lti: tuple | None
    links: tuple                # ((loss, delay), (loss, delay))
    buffers: tuple              # (Ds, Da)
    W: NDArray[np.float64]
    x0: NDArray[np.float64]
    xhat0: NDArray[np.float64]
    xc0: NDArray[np.float64]
    input_delay: tuple | None
    steps: int
    trials: int
    warmup: int


def _plant(a: dict) -> dict:
    A = _matrix(a["A"], "A")
    n = A.shape[0]
    _expect_shape(A, (n, n), "A")
    B1, B2 = _matrix(a["B1"], "B1"), _matrix(a["B2"], "B2")
    if B1.shape[0] != n:
        raise ValueError(f"B1 must have {n} rows (shape (n, m1)), got {B1.shape}")
    if B2.shape[0] != n:
        raise ValueError(f"B2 must have {n} rows (shape (n, m2)), got {B2.shape}")
    m1, m2 = B1.shape[1], B2.shape[1]
    C1 = _matrix(a["C1"], "C1")
    if C1.shape[1] != n:
        raise ValueError(f"C1 must have {n} columns (shape (p1, n)), got {C1.shape}")
    p1 = C1.shape[0]
    D11, D12 = _matrix(a["D11"], "D11"), _matrix(a["D12"], "D12")
    _expect_shape(D11, (p1, m1), "D11")
    _expect_shape(D12, (p1, m2), "D12")
    C2 = np.eye(n) if a["C2"] is None else _matrix(a["C2"], "C2")
    if C2.shape[1] != n:
        raise ValueError(f"C2 must have {n} columns, got {C2.shape}")
    if a["controller"] == "predictor" and not np.array_equal(C2, np.eye(n)):
        raise ValueError("controller='predictor' needs C2 = I")
    p2 = C2.shape[0]
    D21 = np.zeros((p2, m1)) if a["D21"] is None else _matrix(a["D21"], "D21")
    _expect_shape(D21, (p2, m1), "D21")
    return dict(A=A, B1=B1, B2=B2, C1=C1, D11=D11, D12=D12, C2=C2, D21=D21,
                n=n, m1=m1, m2=m2, p1=p1, p2=p2)


def _buffer(delay: Any) -> int:
    if delay is None:
        return 0
    if hasattr(delay, "buffer"):
        return int(delay.buffer)
    return int(np.size(delay)) - 1


def _gains(a: dict, m: dict, N: int, Ds: int, delayed: tuple) -> tuple:
    """``(K, kind)``: the static gains as ``(N_K, ages, m2, p2)`` (kind
    'phase' or 'phase_age'), the model-based ones as ``(N, m2, nk)``, or
    ``(N, 4, m2, nk)`` on the previous network mode (kind 'mode')."""
    controller, n, m2, p2 = a["controller"], m["n"], m["m2"], m["p2"]
    if controller == "lti":
        return np.zeros((N, 1, m2, p2)), "lti"
    nk = p2 if controller == "static" else n + m2 * (a["actuator"] == "hold")
    try:
        K = np.asarray(a["gains"], dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError("gains must be a real array of shape (N, m2, nk)") \
            from exc
    if not np.all(np.isfinite(K)):
        raise ValueError("gains must contain only finite values")
    if controller == "static" and delayed[0]:
        if K.ndim == 3:
            if K.shape != (Ds + 1, m2, p2):
                raise ValueError(
                    f"gains must have shape (D + 1, m2, p2) = ({Ds + 1}, {m2}, "
                    f"{p2}) over a delayed sensor link (a gain per age), or "
                    f"(N, D + 1, m2, p2) per phase and age, got {K.shape}")
            return K[None], "phase_age"
        if K.shape != (N, Ds + 1, m2, p2):
            raise ValueError(
                f"gains must have shape (N, D + 1, m2, p2) = ({N}, {Ds + 1}, "
                f"{m2}, {p2}) per phase and age, got {K.shape}")
        return K, "phase_age"
    if K.ndim == 4:
        if any(delayed):
            raise ValueError("gains: over delayed links one gain per phase "
                             "(and per age of the measurement), not per mode")
        if K.shape != (N, 4, m2, nk):
            raise ValueError(
                f"gains must have shape (N, 4, m2, nk) = ({N}, 4, {m2}, {nk}) "
                f"for controller={controller!r}, actuator={a['actuator']!r}, "
                f"got {K.shape}")
        return K, "mode"
    if K.shape != (N, m2, nk):
        raise ValueError(
            f"gains must have shape (N, m2, nk) = ({N}, {m2}, {nk}) or "
            f"(N, 4, m2, nk) = ({N}, 4, {m2}, {nk}) for "
            f"controller={controller!r}, actuator={a['actuator']!r}, "
            f"got {K.shape}")
    return (K[:, None] if controller == "static" else K), "phase"


def _controller_parts(a: dict, m: dict) -> tuple:
    """``(L, (Ac, Bc, Cc, Dc), xc0)`` as the controller needs them."""
    controller, n, m2, p2 = a["controller"], m["n"], m["m2"], m["p2"]
    L = None
    if controller == "estimator":
        if a["estimator_gains"] is None:
            raise ValueError("controller='estimator' needs estimator_gains")
        L = np.asarray(a["estimator_gains"], dtype=float)
        if L.ndim != 3 or L.shape[1:] != (n, p2) or L.shape[0] < 1:
            raise ValueError(f"estimator_gains must have shape (N_L, {n}, "
                             f"{p2}), got {L.shape}")
    elif a["estimator_gains"] is not None:
        raise ValueError("estimator_gains is only for controller='estimator'")
    elif controller == "predictor":
        L = np.eye(n)[None]
    lti, xc0 = None, np.zeros(0)
    if controller == "lti":
        system = a["controller_system"]
        if system is None or len(system) != 4:
            raise ValueError("controller='lti' needs controller_system = "
                             "(Ac, Bc, Cc, Dc)")
        Ac, Bc, Cc, Dc = (np.asarray(X, dtype=float) for X in system)
        nc = Ac.shape[0] if Ac.ndim == 2 else 0
        lti = (Ac.reshape(nc, nc), Bc.reshape(nc, p2), Cc.reshape(m2, nc),
               Dc.reshape(m2, p2))
        given = a["initial_controller_state"]
        xc0 = (np.zeros(nc) if given is None
               else _vector(given, "initial_controller_state", nc))
    elif a["controller_system"] is not None:
        raise ValueError("controller_system is only for controller='lti'")
    elif a["initial_controller_state"] is not None:
        raise ValueError("initial_controller_state is only for "
                         "controller='lti'")
    return L, lti, xc0


def _inputs(a: dict, m: dict, steps: int, trials: int) -> NDArray[np.float64]:
    m1 = m["m1"]
    if a["inputs"] is None:
        return np.zeros((1, m1, steps))
    given = (np.asarray(a["inputs"], dtype=float)
             if np.ndim(a["inputs"]) in (2, 3) else None)
    if given is None or given.shape not in ((m1, steps), (trials, m1, steps)) \
            or not np.all(np.isfinite(given)):
        raise ValueError(
            f"inputs must be finite, of shape (m1, steps) = ({m1}, "
            f"{steps}) or (trials, m1, steps), got {np.shape(a['inputs'])}")
    return given if given.ndim == 3 else given[None]


def _input_delay(value: Any, m: dict) -> tuple | None:
    if value is None:
        return None
    try:
        g0, g1, p = (np.asarray(X, dtype=float) for X in value)
    except (TypeError, ValueError) as exc:
        raise ValueError("input_delay must be (gamma0, gamma1, "
                         "probabilities)") from exc
    M, n, m2 = p.size, m["n"], m["m2"]
    if g0.shape != (M, n, m2) or g1.shape != (M, n, m2) or p.ndim != 1 \
            or np.any(p < 0) or abs(p.sum() - 1.0) > 1e-9:
        raise ValueError(f"input_delay: gamma0, gamma1 of shape ({M}, {n}, "
                         f"{m2}) and probabilities summing to 1")
    return g0, g1, np.cumsum(p)


def _plan(a: dict) -> _Plan:
    """Validate every argument once; the run trusts what this returns."""
    controller, actuator, sensor = a["controller"], a["actuator"], a["sensor"]
    if not isinstance(controller, str) or controller not in _CONTROLLERS:
        raise ValueError(
            f"controller must be one of {_CONTROLLERS}, got {controller!r}")
    if not isinstance(actuator, str) or actuator not in _ACTUATORS:
        raise ValueError(f"actuator must be one of {_ACTUATORS}, got {actuator!r}")
    if not isinstance(sensor, str) or sensor not in _SENSORS:
        raise ValueError(f"sensor must be one of {_SENSORS}, got {sensor!r}")
    if sensor != "zero" and controller != "lti":
        raise ValueError("sensor='hold' is only modelled for controller='lti'")
    m = _plant(a)
    S1 = _schedule(a["sensor_schedule"], "sensor_schedule", m["p2"])
    N = S1.shape[0]
    S2 = _schedule(a["actuator_schedule"], "actuator_schedule", m["m2"])
    if S2.shape[0] != N:
        raise ValueError(
            f"actuator_schedule must have the same period as sensor_schedule "
            f"(shape ({N}, {m['m2']})), got {S2.shape}")
    links = ((a["sensor_loss"], a["sensor_delay"]),
             (a["actuator_loss"], a["actuator_delay"]))
    for (loss, delay), S, name in zip(links, (S1, S2),
                                      ("sensor_delay", "actuator_delay")):
        _make_link(loss, delay, name, S, 1)          # refuse early
    delayed = (a["sensor_delay"] is not None, a["actuator_delay"] is not None)
    Ds, Da = _buffer(a["sensor_delay"]), _buffer(a["actuator_delay"])
    K, kind = _gains(a, m, N, Ds, delayed)
    L, lti, xc0 = _controller_parts(a, m)
    steps = _count(a["steps"], "steps", 0)
    trials = _count(a["trials"], "trials", 1)
    model_based = controller in ("predictor", "estimator")
    if a["initial_estimate"] is not None and not model_based:
        raise ValueError("initial_estimate is only meaningful for "
                         "controller='predictor' or 'estimator'")
    x0 = (np.zeros(m["n"]) if a["initial_state"] is None
          else _vector(a["initial_state"], "initial_state", m["n"]))
    xhat0 = (np.zeros(m["n"]) if a["initial_estimate"] is None
             else _vector(a["initial_estimate"], "initial_estimate", m["n"]))
    return _Plan(m, S1, S2, controller, actuator, sensor, K, kind, L, lti,
                 links, (Ds, Da), _inputs(a, m, steps, trials), x0, xhat0,
                 xc0, _input_delay(a["input_delay"], m), steps, trials,
                 _count(a["warmup"], "warmup", 0))


def _controller_step(p: _Plan, st: dict, t: int, sens: Any, ypkt: Any,
                     mask1: Any, age1: Any, new: Any) -> Any:
    """The command ``v(t)`` of every trial; updates the controller's state
    (estimates, LTI state, held measurements) in ``st``."""
    m, K, phase = p.mats, p.K, t % p.S1.shape[0]
    if p.controller == "lti":
        Ac, Bc, Cc, Dc = p.lti                                 # type: ignore
        held = st["yhat"] if p.sensor == "hold" else 0.0
        yrcv = ypkt + (1.0 - mask1) * held
        v = st["xc"] @ Cc.T + yrcv @ Dc.T
        st["xc"] = st["xc"] @ Ac.T + yrcv @ Bc.T
        st["yhat"] = yrcv
        return v
    if p.gain_kind == "mode":
        # ℓ = σ_{t-1}: (θ1,t-1, θ2,t-1) for the static gain, (θ1,t, θ2,t-1)
        # for the model-based controllers (theory: Markov losses)
        seen1 = sens.before if p.controller == "static" else sens.theta
        ell = np.asarray(seen1, int) + 2 * np.asarray(st["before2"], int)
        Kt = K[phase][ell]                                # (trials, m2, nk)
    if p.controller == "static":
        if p.gain_kind == "mode":
            return np.einsum("tij,tj->ti", Kt, ypkt)
        Kp = K[phase % K.shape[0]]                       # (ages, m2, p2)
        if Kp.shape[0] == 1:
            return ypkt @ Kp[0].T
        return np.einsum("tij,tj->ti", Kp[np.minimum(age1, Kp.shape[0] - 1)],
                         ypkt)
    X, L, C2 = st["X"], p.L, m["C2"]
    for a in range(X.shape[1]):
        sel = new & (age1 == a)
        if not sel.any():
            continue
        # the correction of the measured step, carried to the present with
        # the known inputs
        nu = ypkt[sel] - mask1[sel] * (X[sel, a] @ C2.T)
        corr = nu @ L[(t - a) % L.shape[0]].T                  # type: ignore
        for j in range(a + 1):
            X[sel, j] += corr @ st["Apow"][a - j].T
    feed = (np.concatenate([X[:, 0], st["u"]], axis=1)
            if p.actuator == "hold" else X[:, 0])
    if p.gain_kind == "mode":
        return np.einsum("tij,tj->ti", Kt, feed)
    return feed @ K[phase].T


def _run(p: _Plan, rng: np.random.Generator) -> dict[str, NDArray[Any]]:
    m, trials, steps = p.mats, p.trials, p.steps
    n, m2 = m["n"], m["m2"]
    (loss1, delay1), (loss2, delay2) = p.links
    sens = _make_link(loss1, delay1, "sensor_delay", p.S1, trials)
    act = _make_link(loss2, delay2, "actuator_delay", p.S2, trials)
    model_based = p.controller in ("predictor", "estimator")
    st: dict[str, Any] = {
        "x": np.zeros((trials, n)), "u": np.zeros((trials, m2)),
        "X": np.zeros((trials, p.buffers[0] + 1 if model_based else 0, n)),
        "xc": np.zeros((trials, p.xc0.size)),
        "yhat": np.zeros((trials, m["p2"])),
        "Apow": [np.linalg.matrix_power(m["A"], j)
                 for j in range(p.buffers[0] + 1)],
        "last": np.full(trials, -np.inf), "before2": None}
    out: dict[str, Any] = {
        "x": np.empty((trials, n, steps + 1)),
        "z": np.empty((trials, m["p1"], steps)),
        "u": np.empty((trials, m2, steps)),
        "theta1": np.empty((trials, steps), dtype=bool),
        "theta2": np.empty((trials, steps), dtype=bool)}
    if model_based:
        out["xhat"] = np.empty((trials, n, steps + 1))
    if p.controller == "lti":
        out["xc"] = np.empty((trials, p.xc0.size, steps + 1))
    for key, link in (("age1", sens), ("age2", act)):
        if link.queued:
            out[key] = np.empty((trials, steps), dtype=int)
    if p.gain_kind == "mode":
        # step -1: the previous mode at the first step (stationary channels)
        sens.draw(rng)
        act.draw(rng)
    for t in range(-p.warmup, steps):
        if t == 0:
            st["x"] = np.tile(p.x0, (trials, 1))
            if model_based:
                st["X"][:, 0] = p.xhat0
            st["xc"] = np.tile(p.xc0, (trials, 1))
            out["x"][:, :, 0] = st["x"]
            if p.controller == "lti":
                out["xc"][:, :, 0] = st["xc"]
        _step(p, st, out, t, sens, act, rng)
    if model_based:
        out["xhat"][:, :, steps] = st["X"][:, 0]
    return out


def _step(p: _Plan, st: dict, out: dict, t: int, sens: Any, act: Any,
          rng: np.random.Generator) -> None:
    """One step of the protocol for every trial (recorded when ``t >= 0``)."""
    m, N = p.mats, p.S1.shape[0]
    phase = t % N
    sent1, sent2 = bool(p.S1[phase].any()), bool(p.S2[phase].any())
    # Drawn unconditionally so the random stream does not depend on the
    # schedule (the channel moves whether or not it carries a packet).
    st["before2"] = act.theta
    sens.draw(rng)
    act.draw(rng)
    sens.send(t, sent1, rng)
    act.send(t, sent2, rng)
    tau = None
    if p.input_delay is not None:
        cdf = p.input_delay[2]
        tau = np.minimum(np.searchsorted(cdf, rng.random(p.trials),
                                         side="right"), cdf.size - 1)
    w = p.W[:, :, t] if t >= 0 else np.zeros((1, m["m1"]))
    x = st["x"]
    y = x @ m["C2"].T + w @ m["D21"].T
    age1, ypkt, fresh1 = sens.receive(t, y, sent1)
    mask1 = p.S1[(t - age1) % N] * fresh1[:, None]
    ypkt = mask1 * ypkt
    stamp = t - age1
    new = fresh1 & (stamp > st["last"])
    st["last"] = np.where(fresh1, stamp, -np.inf)
    v = _controller_step(p, st, t, sens, ypkt, mask1, age1, new)
    age2, vpkt, fresh2 = act.receive(t, v, sent2)
    mask2 = p.S2[(t - age2) % N] * fresh2[:, None]
    held = st["u"] if p.actuator == "hold" else 0.0
    u = mask2 * vpkt + (1.0 - mask2) * held
    z = x @ m["C1"].T + w @ m["D11"].T + u @ m["D12"].T
    if p.input_delay is None:
        x = x @ m["A"].T + w @ m["B1"].T + u @ m["B2"].T
    else:
        g0, g1 = p.input_delay[0][tau], p.input_delay[1][tau]
        x = x @ m["A"].T + w @ m["B1"].T \
            + np.einsum("tij,tj->ti", g0, u) + np.einsum("tij,tj->ti", g1,
                                                          st["u"])
    if t >= 0:
        out["z"][:, :, t], out["u"][:, :, t] = z, u
        out["x"][:, :, t + 1] = x
        out["theta1"][:, t], out["theta2"][:, t] = sens.theta, act.theta
        if "age1" in out:
            out["age1"][:, t] = age1
        if "age2" in out:
            out["age2"][:, t] = age2
        if "xhat" in out:
            out["xhat"][:, :, t] = st["X"][:, 0]
        if "xc" in out:
            out["xc"][:, :, t + 1] = st["xc"]
    X = st["X"]
    if X.shape[1]:
        # the controller's model: it knows the applied u, not w
        st["X"] = np.concatenate(
            [(X[:, 0] @ m["A"].T + u @ m["B2"].T)[:, None], X[:, :-1]], axis=1)
    st["x"], st["u"] = x, u
