"""The one builder: plant + network + controller kind → JumpPlant
(:ref:`theory-links-compose`, :ref:`theory-static-loop`,
:ref:`theory-predictor`, :ref:`theory-output-feedback`,
:ref:`theory-delays`).

The network is the product of the two links' chains
(:mod:`control_ncs.links`) and, for a sampled plant with sub-sample input
delays, the delay's chain; a mode is a tuple of their states and the
builder reads only what each state emits: the age of the packet the
receiver uses, or stale. Buffered measurements, commands and noises are
loop state, as are the controller's memory and held values. One function
per controller kind writes a mode's matrices; every link combination goes
through it. Builders never call a solver, and nothing downstream looks at
schedules or links again.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np
from control.exception import ControlArgument, ControlDimension

from ._checks import choice, positive_int, real_array
from ._lifting import check_lifted_size
from .gain import ACTUATORS, CONTROLLERS
from .automata import LossAutomaton
from .modes import (entered_modes, join_labels, keep_modes, lump_markov,
                    markov_classes)
from .openloop import JumpPlant
from .plant import NetworkedStateSpace
from .modechain import Network, network

__all__ = ["build", "loop_closes", "require_state_measured"]

#: Largest number of loop states the builder writes (the matrices of a
#: mode are dense): a buffer or a period beyond this is refused up front.
MAX_LOOP_STATES = 4000
#: The most memory the builder gives the loop's per-mode matrices (before
#: their Markov modes are lumped): an estimator over two delayed links of
#: buffers 10 and 5 on a 60-state plant asks 1008 modes of 1325 states,
#: 15 GiB.
MAX_MODE_BYTES = 2 * 2 ** 30


# -- the loop state ---------------------------------------------------------------
class Layout:
    """Named blocks of the loop state ``ξ``, in order."""

    def __init__(self, blocks: list[tuple[str, int]]):
        self.slices: dict[str, slice] = {}
        start = 0
        for name, size in blocks:
            self.slices[name] = slice(start, start + size)
            start += size
        self.size = start

    def has(self, name: str) -> bool:
        return name in self.slices and \
            self.slices[name].stop > self.slices[name].start


class Rows:
    """Linear expressions in ``[ξ_k; w_k; v_k; w_{k+1}; ω_k; n_s]``: a
    matrix per quantity, columns in that order (``v`` the controller's
    output, ``w_{k+1}`` the noise a measurement of the next step carries,
    ``ω_k`` a disturbance added to the plant's next state: where the noise
    of a continuous plant's period goes, :ref:`theory-intersample-cost`;
    ``n_s`` the continuous noise gathered from a period's start to its
    late sample, :ref:`theory-sampling-jitter`)."""

    def __init__(self, layout: Layout, nw: int, nv: int, n: int):
        self.layout, self.nw, self.nv = layout, nw, nv
        self.iw = slice(layout.size, layout.size + nw)
        self.iv = slice(self.iw.stop, self.iw.stop + nv)
        self.inext = slice(self.iv.stop, self.iv.stop + nw)
        self.iomega = slice(self.inext.stop, self.inext.stop + n)
        self.isample = slice(self.iomega.stop, self.iomega.stop + n)
        self.width = self.isample.stop

    def omega(self) -> np.ndarray:
        out = self.zeros(self.iomega.stop - self.iomega.start)
        out[:, self.iomega] = np.eye(out.shape[0])
        return out

    def zeros(self, rows: int) -> np.ndarray:
        return np.zeros((rows, self.width))

    def state(self, name: str, part: slice | None = None) -> np.ndarray:
        s = self.layout.slices[name]
        cols = range(s.start, s.stop)[part] if part is not None else \
            range(s.start, s.stop)
        out = self.zeros(len(cols))
        out[np.arange(len(cols)), list(cols)] = 1.0
        return out

    def noise(self) -> np.ndarray:
        out = self.zeros(self.nw)
        out[:, self.iw] = np.eye(self.nw)
        return out

    def next_noise(self) -> np.ndarray:
        out = self.zeros(self.nw)
        out[:, self.inext] = np.eye(self.nw)
        return out

    def command(self, rows: slice) -> np.ndarray:
        out = self.zeros(self.nv)[rows]
        out[:, self.iv] = np.eye(self.nv)[rows]
        return out


@dataclass
class Context:
    """What every mode of one loop shares: the plant, the schedules, the
    layout, the buffers and the strategies."""

    P: NetworkedStateSpace
    N: int
    rows: Rows
    Ds: int
    Da: int
    Dw: int
    H: np.ndarray          # the actuators some phase addresses (held)
    hold: bool
    S1: np.ndarray         # (N, p2) sensor schedule over the loop's period
    S2: np.ndarray         # (N, m2)
    L: np.ndarray | None   # estimator gains (N_L, n, p2)
    sensor_hold: bool = False  # LTI: a stale measurement keeps its value

    def applied(self, k: int, b: int) -> np.ndarray:
        """``u_k`` as rows: the components the command packet of age ``b``
        carries, the rest held or zero (:ref:`theory-delays`)."""
        r, m2 = self.rows, self.P.ncon
        carried = np.diag(self.S2[(k - b) % self.N].astype(float)) \
            if b <= self.Da else np.zeros((m2, m2))
        u = r.zeros(m2)
        if b == 0:
            u = u + carried @ r.command(slice(0, m2))
        elif b <= self.Da:
            u = u + carried @ r.state(f"v{b}")
        if self.hold:
            u = u + (np.eye(m2) - carried) @ self.H.T @ r.state("u_prev")
        return u

    def previous_input(self) -> np.ndarray:
        """``u_{k-1}`` as rows (zero when it is not kept)."""
        r = self.rows
        if not r.layout.has("u_prev"):
            return r.zeros(self.P.ncon)
        return self.H.T @ r.state("u_prev")

    def plant(self, x: np.ndarray, u: np.ndarray, c: int) -> np.ndarray:
        """``x_{k+1}`` as rows: ``A x + B1 w + B2 u``, or with a sub-sample
        delay ``τ_c``, ``Φ x + B1 w + Γ0(τ) u + Γ1(τ) u_{k-1}``."""
        P, r = self.P, self.rows
        step = P.A @ x + P.B1 @ r.noise() + r.omega()
        delay = P.input_delay
        if delay is None:
            return step + P.B2 @ u
        return step + delay.gamma0[c] @ u + \
            delay.gamma1[c] @ self.previous_input()

    def at_sample(self, x: np.ndarray, held: np.ndarray, noise: np.ndarray,
                  d: int) -> np.ndarray:
        """The plant state at a late sample as rows, ``x`` the state at
        the period's start: ``e^{As} x + Γs held + Γws noise + n_s``
        (the input ``held`` and, in the sampled model, the noise held
        until then; the continuous noise gathered, ``n_s``, in its own
        columns, :ref:`theory-sampling-jitter`). ``x`` itself when the
        sample ``d`` is not late."""
        delay = self.P.input_delay
        if delay is None or delay.samples is None or \
                not delay.samples[d] > 0:
            return x
        assert delay.sample_state is not None
        assert delay.sample_input is not None
        assert delay.sample_noise is not None
        out = delay.sample_state[d] @ x + delay.sample_input[d] @ held \
            + delay.sample_noise[d] @ noise
        out[:, self.rows.isample] += np.eye(x.shape[0])
        return out

    def output(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        P = self.P
        return P.C1 @ x + P.D11 @ self.rows.noise() + P.D12 @ u

    def measurement(self, x: np.ndarray, back: int) -> np.ndarray:
        """``y_s = C2 x_s + D21 w_s`` as rows, ``x_s`` given, for the step
        ``s = k - back`` (``back = -1``: the next step)."""
        P, r = self.P, self.rows
        y = P.C2 @ x
        if not np.any(P.D21):
            return y
        if back == -1:
            return y + P.D21 @ r.next_noise()
        if back == 0:
            return y + P.D21 @ r.noise()
        return y + P.D21 @ r.state(f"w{back}")

    def shift(self, nxt: dict, u: np.ndarray) -> None:
        """The buffers move one step: commands, noises, held inputs."""
        r, m2 = self.rows, self.P.ncon
        for j in range(1, self.Da + 1):
            nxt[f"v{j}"] = r.command(slice(0, m2)) if j == 1 else \
                r.state(f"v{j - 1}")
        for j in range(1, self.Dw + 1):
            nxt[f"w{j}"] = r.noise() if j == 1 else r.state(f"w{j - 1}")
        if r.layout.has("u_prev"):
            nxt["u_prev"] = self.H @ u


@dataclass
class Mode:
    """One mode's matrices before the gain, as rows on ``[ξ; w; v; w⁺; ω]``,
    with the plant state ``x_k`` and the input ``u_k`` it applies (for the
    cost between the samples of a continuous plant)."""

    nxt: dict
    z: np.ndarray
    E: np.ndarray
    Ew: np.ndarray
    x: np.ndarray
    u: np.ndarray
    En: np.ndarray | None = None   # the reading's rows on n_s (static)


# -- one function per controller kind ---------------------------------------------
def _static_mode(ctx: Context, k: int, a: int, b: int, c: int, d: int,
                 a_prev: int | None) -> Mode:
    """Memoryless gain (:ref:`theory-static-loop`): ``v_k = K_{k,a} ŷ``,
    the gain of the measurement's age ``a`` (a block of the gain per age),
    nothing when the sensor link is stale. A late sample reads the state
    at ``kh + s`` (buffered as it was sampled)."""
    r, P = ctx.rows, ctx.P
    p2 = P.C2.shape[0]
    x = r.state("x")
    u = ctx.applied(k, b)
    xs = ctx.at_sample(x, ctx.previous_input(), r.noise(), d)
    nxt = {"x": ctx.plant(x, u, c)}
    for j in range(1, ctx.Ds + 1):
        nxt[f"x{j}"] = xs if j == 1 else r.state(f"x{j - 1}")
    ctx.shift(nxt, u)
    read = np.zeros(((ctx.Ds + 1) * p2, r.width))
    if a <= ctx.Ds:
        S1 = np.diag(ctx.S1[(k - a) % ctx.N].astype(float))
        xa = xs if a == 0 else r.state(f"x{a}")
        read[a * p2:(a + 1) * p2] = S1 @ ctx.measurement(xa, a)
    L = r.layout.size
    return Mode(nxt, ctx.output(x, u), read[:, :L], read[:, r.iw], x, u,
                read[:, r.isample])


def _lti_mode(ctx: Context, k: int, a: int, b: int, c: int, d: int,
              a_prev: int | None) -> Mode:
    """An LTI controller (:ref:`theory-output-feedback`): its input ``ŷ``,
    what arrived at the end of the step (age ``a`` at ``k + 1``), is loop
    state; its realisation ``[[Dc, Cc], [Bc, Ac]]`` is the gain on
    ``[ŷ; xc]`` with outputs ``[v; xc⁺]``."""
    r, P = ctx.rows, ctx.P
    p2 = P.C2.shape[0]
    m2 = P.ncon
    x = r.state("x")
    u = ctx.applied(k, b)
    xn = ctx.plant(x, u, c)
    nxt = {"x": xn}
    for j in range(1, ctx.Ds + 1):
        nxt[f"x{j}"] = x if j == 1 else r.state(f"x{j - 1}")
    ctx.shift(nxt, u)
    nc = r.layout.slices["xc"].stop - r.layout.slices["xc"].start
    nxt["xc"] = r.command(slice(m2, m2 + nc))
    Hs = _heard(ctx.S1)
    held = Hs.T @ r.state("y_rcv") if ctx.sensor_hold else r.zeros(p2)
    if a <= ctx.Ds:
        S1 = np.diag(ctx.S1[(k + 1 - a) % ctx.N].astype(float))
        xs = ctx.at_sample(xn, u, r.next_noise(), d) if a == 0 else (
            x if a == 1 else r.state(f"x{a - 1}"))
        y = S1 @ ctx.measurement(xs, a - 1) + (np.eye(p2) - S1) @ held
    else:
        y = held
    nxt["y_rcv"] = Hs @ y
    E = np.vstack([Hs.T @ r.state("y_rcv"), r.state("xc")])
    L = r.layout.size
    return Mode(nxt, ctx.output(x, u), E[:, :L],
                np.zeros((p2 + nc, P.B1.shape[1])), x, u)


def _model_mode(ctx: Context, k: int, a: int, b: int, c: int, d: int,
                a_prev: int | None) -> Mode:
    """The model-based controller (:ref:`theory-predictor`,
    :ref:`theory-output-feedback`): estimates ``x̂`` of the last ``Ds + 1``
    steps, predicted with the known inputs and corrected when the packet
    that arrives at ``k + 1`` (age ``a``) is new; state ``[x̂; u⁻; e]``
    with ``e = x − x̂`` per step."""
    r, P = ctx.rows, ctx.P
    Ds = ctx.Ds
    L = ctx.L
    assert L is not None           # the predictor's is I
    xh = [r.state("xh")] + [r.state(f"xh{j}") for j in range(1, Ds + 1)]
    er = [r.state("e")] + [r.state(f"e{j}") for j in range(1, Ds + 1)]
    x = xh[0] + er[0]
    u = ctx.applied(k, b)
    xn = ctx.plant(x, u, c)
    # at k + 1, before the correction: x̂_{k+1} predicted, older ones kept;
    # index j holds step k + 1 - j
    est = [P.A @ xh[0] + P.B2 @ u] + xh[:Ds]
    true = [xn] + [xh[j] + er[j] for j in range(Ds)]
    # a late sample of step k + 1: the estimator corrects with it as if it
    # were taken at the instant (it knows the timing no more than τ)
    sampled = [ctx.at_sample(xn, u, r.next_noise(), d)] + true[1:]
    new = a <= Ds and (a_prev is None or a <= a_prev)
    if new:
        S1 = np.diag(ctx.S1[(k + 1 - a) % ctx.N].astype(float))
        Lk = L[(k + 1 - a) % L.shape[0]]
        innovation = S1 @ (ctx.measurement(sampled[a], a - 1)
                            - P.C2 @ est[a])
        for j in range(a + 1):
            est[j] = est[j] + np.linalg.matrix_power(P.A, a - j) @ Lk \
                @ innovation
    nxt = {"xh": est[0], "e": true[0] - est[0]}
    for j in range(1, Ds + 1):
        nxt[f"xh{j}"] = est[j]
        nxt[f"e{j}"] = true[j] - est[j]
    ctx.shift(nxt, u)
    E = r.state("xh")
    if ctx.hold:
        E = np.vstack([E, ctx.H.T @ r.state("u_prev")])
    nX = r.layout.size
    return Mode(nxt, ctx.output(x, u), E[:, :nX],
                np.zeros((E.shape[0], P.B1.shape[1])), x, u)


def _heard(S1: np.ndarray) -> np.ndarray:
    """Selector of the sensors some phase schedules: a never-scheduled
    sensor delivers nothing; its held value would be a constant 0 with an
    eigenvalue 1 in every mode, so it is left out."""
    idx = np.flatnonzero(S1.any(axis=0))
    H = np.zeros((idx.size, S1.shape[1]))
    H[np.arange(idx.size), idx] = 1.0
    return H


MODE_BUILDERS: dict[str, Callable[..., Mode]] = {
    "static": _static_mode, "lti": _lti_mode, "predictor": _model_mode,
    "estimator": _model_mode}


# -- the builder ------------------------------------------------------------------
def build(P: NetworkedStateSpace, controller: str = "static",
          actuator: str = "zero", *, period: int | None = None,
          sensor: str = "zero", controller_order: int = 0,
          estimator_gain: Any = None) -> JumpPlant:
    """The networked loop of ``P`` before the gain (a JumpPlant).

    The gain the plant is closed with (:meth:`JumpPlant.close`,
    :func:`control_ncs.passivesyn`) acts in positive feedback, as it is:
    ``v_k = K_k E ξ`` (``u = K y`` for the static controller, ``u = K x̂``
    for the predictor and the estimator; for an LTI controller the "gain"
    is its realisation, see below). Negate a gain designed for
    ``u = -K x``, such as :func:`control.dlqr`'s.

    Every link combination is built the same way: the links are chains
    (:mod:`control_ncs.links`), a mode is a tuple of their states, and
    what a buffered link may still deliver is loop state
    (:ref:`theory-links-compose`).

    Parameters
    ----------
    P : NetworkedStateSpace
        Plant with its network.
    controller : {'static', 'predictor', 'estimator', 'lti'}
        ``'static'``: ``v = K_k ŷ`` with ``ŷ`` the received measurement
        (paper eq. 2-3, :ref:`theory-static-loop`); over a buffered
        (delayed) sensor link a gain per age of the measurement, the
        columns of ``K_k`` in blocks ``[age 0 | age 1 | …]``.
        ``'predictor'``: the model-based controller of
        :ref:`theory-predictor`, ``v = K_k x̂`` (needs ``y = x``).
        ``'estimator'``: :ref:`theory-output-feedback`, the predictor
        corrected through ``estimator_gain`` ``L_k`` for any ``y = C2 x``;
        ``v = K_k x̂``. ``'lti'``: a discrete-time LTI controller
        ``xc⁺ = Ac xc + Bc ŷ``, ``v = Cc xc + Dc ŷ`` of order
        ``controller_order``; its gain is ``[[Dc, Cc], [Bc, Ac]]`` acting
        on ``[ŷ; xc]`` (use :func:`feedback` with the controller itself).
    actuator : {'zero', 'hold'}
        What an actuator applies when its message is lost, stale or not
        scheduled.
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
        Unmerged. Without buffers the four modes ``(θ1, θ2) = (0, 0),
        (1, 0), (0, 1), (1, 1)`` (the sensor bit of the step's end for the
        controllers with memory); in general the product of the links'
        states, the sensor link's fastest; over a buffered (delayed) link
        Markov modes no transition enters are left out (never drawn) and
        modes that move alike are lumped; ``nominal`` is the loss-free
        mode.

    Raises
    ------
    ControlArgument
        If ``P`` is not a :class:`NetworkedStateSpace`, the controller,
        actuator or sensor strategy is unknown, the predictor is asked for
        without ``y = x``, a link combination has no chain, or an option
        is given to a controller that does not take it.
    ControlDimension
        If ``estimator_gain`` has the wrong shape.
    ValueError
        If ``period`` is not an int >= 1, not a multiple of ``P.period``,
        or the loop would be too large.

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
    ctx, net, options = _plan(P, controller, actuator, period, sensor,
                              controller_order, estimator_gain)
    return _run(ctx, net, controller, actuator, options)


def _plan(P: Any, controller: Any, actuator: Any, period: Any, sensor: Any,
          controller_order: Any, estimator_gain: Any
          ) -> tuple[Context, Network, dict]:
    """Validate, then lay out the loop: the network's chain, the state's
    blocks and what every mode shares."""
    if not isinstance(P, NetworkedStateSpace):
        raise ControlArgument(f"P: expected a NetworkedStateSpace (see nss()), "
                              f"got {type(P).__name__}")
    choice(controller, "controller", CONTROLLERS)
    choice(actuator, "actuator", ACTUATORS)
    opts = _options(P, controller, sensor, controller_order, estimator_gain)
    N = positive_int(period, "period", allow_none=True) or P.period
    for what, NL in (("network", P.period),
                     ("estimator gain", opts["L"].shape[0] if "L" in opts
                      else 1)):
        if N % NL:
            raise ValueError(f"period: {N} is not a multiple of the {what} "
                             f"period {NL}")
    check_lifted_size(P.nstates, len(P.disturbance_labels),
                      len(P.performance_labels), N, "P")
    require_state_measured(P, controller, allow_static=True)
    if controller != "static" and P.sensor_delay is not None and \
            P.input_delay is not None and P.input_delay.late:
        raise ControlArgument(
            f"P: a late sample over a delayed sensor link has no model for "
            f"controller={controller!r} (its buffer holds the plant states "
            f"at the instants); use the static gain, or timing without "
            f"sampling delays")
    net = network(P, controller, N)
    Ds, Da = _buffer(P.sensor_delay), _buffer(P.actuator_delay)
    n, m1, m2 = P.nstates, P.B1.shape[1], P.ncon
    S1 = P.sensor_schedule.repeat(N).pattern
    S2 = P.actuator_schedule.repeat(N).pattern
    H = _addressed(S2)
    hold = actuator == "hold"
    keep_u = hold or P.input_delay is not None
    noisy = bool(np.any(P.D21))
    memory = controller != "static"
    Dw = (max(Ds - 1, 0) if memory else Ds) if noisy else 0
    blocks: list[tuple[str, int]]
    if controller == "static":
        blocks = [("x", n), ("u_prev", H.shape[0] if keep_u else 0)]
        blocks += [(f"x{j}", n) for j in range(1, Ds + 1)]
        nv = m2
    elif controller == "lti":
        nc = opts["nc"]
        blocks = [("x", n), ("xc", nc), ("y_rcv", _heard(S1).shape[0]),
                  ("u_prev", H.shape[0] if keep_u else 0)]
        blocks += [(f"x{j}", n) for j in range(1, Ds + 1)]
        nv = m2 + nc
    else:
        blocks = [("xh", n), ("u_prev", H.shape[0] if keep_u else 0),
                  ("e", n)]
        blocks += [(f"xh{j}", n) for j in range(1, Ds + 1)]
        blocks += [(f"e{j}", n) for j in range(1, Ds + 1)]
        nv = m2
    blocks += [(f"v{j}", m2) for j in range(1, Da + 1)]
    blocks += [(f"w{j}", m1) for j in range(1, Dw + 1)]
    layout = Layout(blocks)
    if layout.size > MAX_LOOP_STATES:
        raise ValueError(
            f"P: the loop would have {layout.size} states (plant {n}, "
            f"buffers of {Ds} measurements and {Da} commands), more than "
            f"MAX_LOOP_STATES = {MAX_LOOP_STATES}; use shorter buffers")
    L = opts.get("L")
    if controller == "predictor":
        L = np.eye(n)[None]
    ctx = Context(P, N, Rows(layout, m1, nv, n), Ds, Da, Dw, H, hold,
                  S1, S2, L, sensor_hold=sensor == "hold")
    return ctx, net, opts


def _run(ctx: Context, net: Network, controller: str, actuator: str,
         options: dict) -> JumpPlant:
    """Every mode of every phase, then the JumpPlant."""
    P, r, N = ctx.P, ctx.rows, ctx.N
    layout = r.layout
    mode = MODE_BUILDERS[controller]
    M = net.count
    fields: dict[str, list] = {f: [] for f in (
        "A", "Bu", "Bw", "Cz", "Du", "Dw", "E", "Ew", "Gnext", "x", "u",
        "u_w", "u_v", "u_prev", "omega", "e_n", "n_in")}
    cache: dict = {}
    for k in range(N):
        for i in range(M):
            a, b, c, d = (int(e) for e in net.emissions[k, i])
            a_prev = None if net.previous is None else \
                int(net.previous[k, i])
            key = _phase_key(ctx, controller, k, (a, b, c, d, a_prev))
            if key not in cache:
                cache[key] = _assemble(mode(ctx, k, a, b, c, d, a_prev),
                                       layout, r, ctx.previous_input())
                if len(cache) == 1:
                    _check_mode_bytes(N, M, sum(
                        v.size for v in cache[key].values()), layout.size)
            for f, value in cache[key].items():
                fields[f].append(value)
    arr = {f: np.array(v).reshape((N, M) + v[0].shape)
           for f, v in fields.items()}
    arr["tau"] = net.emissions[:, :, 2]
    arr["s"] = net.emissions[:, :, 2]          # the period's own pair
    p, T = net.law()
    nominal = net.nominal()
    observed = None if T is None and net.constraint is None \
        else net.observed()
    if T is not None:
        arr, p, T, nominal, observed = _lumped(
            arr, p, T, nominal, observed, buffered=bool(ctx.Ds or ctx.Da))
    E, Ew, Bu, Du = _per_phase_reading(arr["E"], arr["Ew"], arr["Bu"],
                                       arr["Du"])
    Gw = None
    late = P.input_delay is not None and P.input_delay.late
    if np.any(arr["Gnext"]) or (late and controller != "static"):
        # the noise of a measurement of the next step reaches the state with
        # that step's input: step k + 1 acts on ξ + Gw[k + 1, ℓ] w, ℓ = the
        # mode at k (theory: measurement noise); so does a late sample's
        # continuous noise, read at the end of the step (the record's n_in)
        Gw = np.roll(arr["Gnext"], 1, axis=0)
    if not np.any(Ew):
        Ew = None
    sampling = None if P.continuous is None else _sampling(P, arr,
                                                           controller)
    description = _description(P, net)
    if controller == "lti":
        description["sensor"] = "hold" if ctx.sensor_hold else "zero"
    return JumpPlant(
        arr["A"], Bu, arr["Bw"], arr["Cz"], Du, arr["Dw"], E, p, P.dt,
        transition=T, nominal=nominal, inputs=P.disturbance_labels,
        outputs=P.performance_labels, states=_state_names(P, layout, ctx),
        name=P.name, controller=controller, actuator=actuator,
        observed=observed, constraint=net.constraint,
        estimator_gain=options.get("L"), Ew=Ew, Gw=Gw,
        description=description, sampling=sampling)


def _check_mode_bytes(N: int, M: int, per_mode: int, states: int) -> None:
    """Refuse, before it is allocated, a loop whose per-mode matrices would
    take more than :data:`MAX_MODE_BYTES` (the modes are distinct chain
    states even where their matrices repeat)."""
    size = 8.0 * N * M * per_mode
    if size > MAX_MODE_BYTES:
        raise ValueError(
            f"P: the loop's matrices would take {size / 2 ** 30:.3g} GiB "
            f"({N} phase(s) x {M} modes x {states} states), more than "
            f"MAX_MODE_BYTES = {MAX_MODE_BYTES / 2 ** 30:.3g} GiB; use "
            f"shorter buffers or a smaller plant")


def _lumped(arr: dict, p: np.ndarray, T: np.ndarray, nominal: np.ndarray,
            observed: Any, buffered: bool = False) -> tuple:
    """The Markov modes lumped exactly (:func:`~control_ncs.modes.markov_
    classes`): modes of equal matrices, readings and records that move
    alike are one mode. The product of two links' chains repeats itself
    (an estimator's pairs of ages differ only in whether the packet is
    new; a burst state matters only through the next outcome), so the
    loop has the modes its figures need. Gains per previous mode see the
    lumped mode: a class holding modes the controller tells apart joins
    their labels. Over a buffered (delayed) link the modes no transition
    enters are dropped first (:func:`~control_ncs.modes.entered_modes`:
    exact, they are never drawn; e.g. the other link's loss state when it
    loses nothing, or pairs of ages that cannot follow each other): the
    certificates of such loops cost their modes, and GMRES crawls on the
    nilpotent block they add. Without buffers the modes keep the layout
    ``(θ1, θ2)`` that gains per previous mode are given on. Equal rows
    after lumping: i.i.d. modes."""
    names = list(arr)
    keep = entered_modes(T, nominal)
    if buffered and not keep.all():
        mats, T, p, index = keep_modes([arr[f] for f in names], T, p, keep)
        arr = dict(zip(names, mats))
        N = T.shape[0]
        nominal = np.array([int(np.flatnonzero(index[k] == nominal[k])[0])
                            for k in range(N)])
        if observed is not None:
            observed = np.stack([observed[k][index[k - 1]]
                                 for k in range(N)])
    mats = [arr[f] for f in names]
    labels = markov_classes(mats, T)
    if not all(int(lab.max()) + 1 == T.shape[1] for lab in labels):
        mats, T, p = lump_markov(mats, T, p, labels)
        nominal = np.array([labels[k][nominal[k]]
                            for k in range(T.shape[0])])
        if observed is not None:
            observed = join_labels(observed, labels)
    TL: np.ndarray | None = T
    if np.all(T == T[:, :1, :]):
        TL, observed = None, None
    return dict(zip(names, mats)), p, TL, nominal, observed


def _sampling(P: NetworkedStateSpace, arr: dict, controller: str) -> dict:
    """What the cost between the samples needs of the open loop
    (:mod:`control_ncs.intersample`'s record, before the gain): per phase
    and mode the rows of ``x_k``, of ``u_k`` on the state, the noise and
    the command, of ``u_{k-1}``, where ``ω_k`` enters, and the delay; with
    sampling jitter the period's sampling delay ``s``, the reading's rows
    on ``n_s`` (``e_n``) and where the sample's noise enters ``ξ_{k+1}``
    (``n_in``: this period's for the static gain, the next period's for a
    controller with memory, ``sample_next``)."""
    sys: Any = P.continuous
    delay = P.input_delay
    taus = np.zeros(1) if delay is None else np.asarray(delay.taus, float)
    samples = (np.zeros(1) if delay is None or delay.samples is None
               else np.asarray(delay.samples, float))
    return dict(h=float(P.dt), plant=tuple(np.array(X, float) for X in (
        sys.A, sys.B, sys.C, sys.D)), nmeas=P.nmeas, ncon=P.ncon,
        x=arr["x"], u=arr["u"], u_w=arr["u_w"], u_v=arr["u_v"],
        u_prev=arr["u_prev"], omega=arr["omega"],
        tau=taus[arr["tau"]], s=samples[arr["s"]], e_n=arr["e_n"],
        n_in=arr["n_in"], sample_next=controller != "static")


def _phase_key(ctx: Context, controller: str, k: int, emissions: tuple
               ) -> tuple:
    """A mode's matrices depend on the phase only through the schedules'
    rows the ages point to and the estimator gain: modes of equal keys are
    built once (long periods repeat them)."""
    a, b, c, d, a_prev = emissions
    shift = 0 if controller == "static" else 1
    rows = [ctx.S1[(k + shift - j) % ctx.N].tobytes()
            for j in range(ctx.Ds + 1)]
    rows += [ctx.S2[(k - j) % ctx.N].tobytes() for j in range(ctx.Da + 1)]
    if ctx.L is not None and ctx.L.shape[0] > 1:
        rows += [ctx.L[(k + shift - j) % ctx.L.shape[0]].tobytes()
                 for j in range(ctx.Ds + 1)]
    return (a, b, c, d, a_prev, *rows)


def _assemble(m: Mode, layout: Layout, r: Rows, u_prev: np.ndarray
              ) -> dict:
    """A mode's rows as the JumpPlant's matrices, and its sampling rows:
    ``x_k``, ``u_k`` (on ``ξ``, ``w`` and the command), ``u_{k-1}`` and
    where ``ω_k`` enters ``ξ_{k+1}``."""
    nX = layout.size
    nxt = np.zeros((nX, r.width))
    for name, rows in m.nxt.items():
        nxt[layout.slices[name]] = rows
    n = r.isample.stop - r.isample.start
    return dict(A=nxt[:, :nX], Bw=nxt[:, r.iw], Bu=nxt[:, r.iv],
                Gnext=nxt[:, r.inext], Cz=m.z[:, :nX], Dw=m.z[:, r.iw],
                Du=m.z[:, r.iv], E=m.E, Ew=m.Ew, x=m.x[:, :nX],
                u=m.u[:, :nX], u_w=m.u[:, r.iw], u_v=m.u[:, r.iv],
                u_prev=u_prev[:, :nX], omega=nxt[:, r.iomega],
                e_n=(np.zeros((m.E.shape[0], n)) if m.En is None else m.En),
                n_in=nxt[:, r.isample])


def _per_phase_reading(E: np.ndarray, Ew: np.ndarray, Bu: np.ndarray,
                       Du: np.ndarray) -> tuple:
    """What the gain reads, per phase when the modes agree on it.

    A mode that reads nothing sends nothing (``Bu K 0 = 0``); it keeps the
    phase's reading with its input columns set to zero, so that every
    mode of a phase reads the same ``E_k`` (the form the convex programs
    need). When modes read different things (a gain per age of a buffered
    measurement) the reading stays per mode, shape (N, M, nk, nx)."""
    N, M = E.shape[:2]
    EP = np.zeros((N,) + E.shape[2:])
    EwP = np.zeros((N,) + Ew.shape[2:])
    Bu, Du = Bu.copy(), Du.copy()
    for k in range(N):
        reads = [i for i in range(M) if np.any(E[k, i]) or np.any(Ew[k, i])]
        if not reads:
            continue
        first = reads[0]
        if not all(np.array_equal(E[k, i], E[k, first])
                   and np.array_equal(Ew[k, i], Ew[k, first]) for i in reads):
            return E, Ew, Bu, Du
        EP[k], EwP[k] = E[k, first], Ew[k, first]
        for i in set(range(M)) - set(reads):
            Bu[k, i] = 0.0
            Du[k, i] = 0.0
    return EP, EwP, Bu, Du


def _buffer(delay: Any) -> int:
    return 0 if delay is None else int(delay.buffer)


def _addressed(S2: np.ndarray) -> np.ndarray:
    """Selector of the actuators whose last value is kept: an actuator that
    no phase addresses applies 0 forever; keeping it in the state would add
    an eigenvalue 1 to every mode (a constant nobody can change)."""
    idx = np.flatnonzero(S2.any(axis=0))
    H = np.zeros((idx.size, S2.shape[1]))
    H[np.arange(idx.size), idx] = 1.0
    return H


def _description(P: NetworkedStateSpace, net: Network) -> dict:
    """The network's description, for people (copied into ``info``)."""
    out: dict = dict(sensor_loss=P.sensor_loss, actuator_loss=P.actuator_loss,
                     plant_period=P.period)
    if net.transition is not None:
        out.update(sensor_link=P.sensor_link, actuator_link=P.actuator_link)
    if net.constraint is not None:
        budgets = [(side, getattr(P, f"{side}_link").name)
                   for side in ("sensor", "actuator")
                   if isinstance(getattr(P, f"{side}_link"), LossAutomaton)]
        out["budget"] = budgets[0][1] if len(budgets) == 1 else ", ".join(
            f"{side}: {name}" for side, name in budgets)
    for side in ("sensor", "actuator"):
        if getattr(P, f"{side}_delay") is not None:
            out[f"{side}_delay"] = getattr(P, f"{side}_delay")
    if P.input_delay is not None:
        out["input_delay"] = P.input_delay.taus
        if P.input_delay.late:
            out["sample_delay"] = P.input_delay.samples
    return out


def _state_names(P: NetworkedStateSpace, layout: Layout, ctx: Context
                 ) -> list[str]:
    """Names of the loop state, block by block."""
    x = list(P.state_labels)
    controls = P.input_labels[len(P.disturbance_labels):]
    held = [f"{controls[i]}_prev"
            for i in np.flatnonzero(ctx.S2.any(axis=0))]
    ys = P.output_labels[len(P.performance_labels):]
    names: list[str] = []
    for name, s in layout.slices.items():
        size = s.stop - s.start
        if not size:
            continue
        j = name.lstrip("xhevwc_") or "0"
        if name == "x":
            names += x
        elif name == "xh":
            names += [f"{q}_hat" for q in x]
        elif name == "e":
            names += [f"{q}_err" for q in x]
        elif name == "u_prev":
            names += held
        elif name == "xc":
            names += [f"xc[{i}]" for i in range(size)]
        elif name == "y_rcv":
            names += [f"{ys[i]}_rcv" for i in np.flatnonzero(
                ctx.S1.any(axis=0))]
        elif name.startswith("xh"):
            names += [f"{q}_hat[k-{j}]" for q in x]
        elif name.startswith("x"):
            names += [f"{q}[k-{j}]" for q in x]
        elif name.startswith("e"):
            names += [f"{q}_err[k-{j}]" for q in x]
        elif name.startswith("v"):
            names += [f"v{i}[k-{j}]" for i in range(size)]
        elif name.startswith("w"):
            names += [f"{q}[k-{j}]" for q in P.disturbance_labels]
    return names


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


def require_state_measured(P: NetworkedStateSpace, controller: str,
                           allow_static: bool = False) -> None:
    """Refuse state feedback for a plant that does not measure x.

    Parameters
    ----------
    P : NetworkedStateSpace
        Plant with its network.
    controller : str
        The controller kind asked for.
    allow_static : bool
        Accept a static output feedback (``'static'`` on any ``C2``); only
        the predictor then needs ``y = x``.

    Raises
    ------
    ControlArgument
        If ``controller`` is ``'predictor'`` (or ``'static'``, unless
        ``allow_static``) and ``C2 ≠ I``.

    Examples
    --------
    >>> P = ncs.nss([[2.0, 1.0], [0.0, 0.5]], [[0.0, 1.0], [1.0, 0.0]],
    ...         [[1.0, 0.0], [1.0, 0.0]], [[0.0, 0.0], [0.0, 0.0]],
    ...         nmeas=1, ncon=1)
    >>> ncs.strategies.require_state_measured(P, "estimator")  # any C2
    """
    kinds = ("predictor",) if allow_static else ("static", "predictor")
    if controller in kinds and not _measures_state(P):
        raise ControlArgument(
            f"controller={controller!r}: state-feedback gains need y = x; "
            f"use controller='estimator' (got C2 of shape {P.C2.shape}, "
            f"not I)")


def _measures_state(P: NetworkedStateSpace) -> bool:
    return P.C2.shape == (P.nstates, P.nstates) and np.array_equal(
        P.C2, np.eye(P.nstates))


def loop_closes(P: NetworkedStateSpace) -> bool:
    """Whether a memoryless gain can ever close the loop of ``P``.

    A static gain acts only on what arrives in the same step, so some
    phase must schedule a sensor and an actuator together
    (:ref:`theory-static-loop`); a shared channel never does. Over a
    buffered link a measurement may be used later, so any phase with an
    actuator message at most the buffer's age after a sensor message
    closes the loop.

    Parameters
    ----------
    P : NetworkedStateSpace
        Plant with its network.

    Returns
    -------
    bool
        True if the loop can close.

    Examples
    --------
    >>> P = ncs.nss([[2.0]], [[0.0, 1.0]], [[0.0], [1.0]],
    ...         [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1,
    ...         sensor_schedule=[1, 0], actuator_schedule=[0, 1])
    >>> ncs.loop_closes(P), ncs.loop_closes(P.with_network(actuator_schedule=[1, 1]))
    (False, True)
    """
    s1 = P.sensor_schedule.pattern.any(axis=1)
    s2 = P.actuator_schedule.pattern.any(axis=1)
    N = P.period
    return bool(any(s1[k] and s2[(k + a) % N] for k in range(N)
                    for a in range(_buffer(P.sensor_delay) + 1)))
