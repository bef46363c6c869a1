"""Closed loops over links with random delays (:ref:`theory-delays`).

A delayed link keeps the freshest packet; the age of what it holds is a
Markov chain (:func:`control_ncs.modes.age_chain`). The loop is a Markov jump
system on a state that remembers what the buffers may still deliver::

    X_k = [x_k; x_{k-1}; …; x_{k-Ds};  v_{k-1}; …; v_{k-Da};  u_{k-1}; …;
           xc_k; ŷ_{k-1}; w_{k-1}; …; w_{k-Ds}]

(``Ds``, ``Da``: the sensor and actuator buffers; ``v`` the controller's
commands; the applied inputs ``u`` kept as far as the predictor or a hold
actuator needs them; an LTI controller's state ``xc`` and, when it holds
a stale measurement, the last one it read; with measurement noise,
``y = C2 x + D21 w``, the past disturbances a buffered measurement
carries), with the mode ``(a_k, b_k)`` of the two ages,
independent chains (``T = T_a ⊗ T_b``). In mode ``(a, b)``:

* the controller uses the freshest measurement, of age ``a``: the static
  gain sends ``v_k = K_a y_{k-a}``, ``y = C2 x + D21 w`` (one gain, or one
  per age read from the
  time stamp); the predictor sends ``v_k = K x̂_k`` with
  ``x̂_k = A^a y_{k-a} + Σ_{i=1}^{a} A^{i-1} B2 u_{k-i}`` (it knows the applied
  inputs from acknowledgements); nothing when the measurement is stale;
  an LTI controller ``xc⁺ = Ac xc + Bc ŷ``, ``v = Cc xc + Dc ŷ`` reads
  ``ŷ_k = y_{k-a}``, and 0 or the last value it read (``sensor='hold'``)
  when the measurement is stale;
  the estimator keeps its estimates of the last ``Ds + 1`` steps and,
  when the freshest measurement is new (fresher than the one used the step
  before), corrects the estimate of its step and carries the correction to
  the present, ``x̂'_{k-j} = x̂_{k-j} + A^{a-j} L (y_{k-a} - C2 x̂_{k-a})``,
  then sends ``v_k = K x̂'_k`` (its mode is the pair of consecutive ages);
* the actuator applies the freshest command, ``u_k = v_{k-b}``; zero, or the
  last applied input (``'hold'``), when the command is stale.

Every analysis of the package applies to the result: it is a
:class:`~control_ncs.jump.JumpStateSpace` with Markov modes.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from control.exception import ControlArgument, ControlDimension

from ._checks import real_array
from .jump import JumpStateSpace
from .modes import age_chain
from .network import BurstyDelay, RandomDelay
from .plant import NetworkedStateSpace
from ._sampling import sampling_entry

__all__: list[str] = []

CONTROLLERS = ("static", "predictor", "estimator", "lti")
ACTUATORS = ("zero", "hold")


def _chain(delay: RandomDelay | BurstyDelay | None, sent: np.ndarray,
           N: int) -> tuple[int, np.ndarray, np.ndarray]:
    """``(buffer, T, ages)`` of a link over the period: the chain ``T``
    (N, S, S), periodic under the link's schedule (``sent`` per phase), and
    the age of each of its S states (``buffer + 1``: stale). A bursty link's
    states are (link state, age); no delay: one state, age 0."""
    if delay is None:
        return 0, np.ones((N, 1, 1)), np.zeros(1, int)
    D = delay.buffer
    if isinstance(delay, BurstyDelay):
        return D, delay.transition(sent), np.tile(np.arange(D + 2), 2)
    return D, age_chain(delay.pmf, D, sent), np.arange(D + 2)


def _gains(K: Any, count: int, shape: tuple[int, int]) -> np.ndarray:
    """One gain per age (``count`` of them): ``K`` of shape ``shape`` for
    every age, or a stack ``(count,) + shape``."""
    if hasattr(K, "gains"):           # a PeriodicGain of one phase
        K = K.gains
    G = real_array(K, "K", ndim=(2, 3))
    if G.ndim == 2:
        G = np.repeat(G[None], count, axis=0)
    if G.shape == (1,) + shape:
        G = np.repeat(G, count, axis=0)
    if G.shape != (count,) + shape:
        raise ControlDimension(
            f"K: expected a gain of shape {shape}, or one per age of the "
            f"sensor link ({count}, {shape[0]}, {shape[1]}), got {G.shape}")
    return G


def delayed_loop(P: NetworkedStateSpace, K: Any, controller: str,
                 actuator: str, sensor: str = "zero",
                 estimator_gain: Any = None) -> JumpStateSpace:
    """The closed loop of ``P`` over its delayed links (module docstring).

    Parameters
    ----------
    P : NetworkedStateSpace
        With ``sensor_delay``, ``actuator_delay`` and/or ``input_delay``.
    K : array_like or control.StateSpace
        The gain ``(ncon, nmeas)`` (predictor: ``(ncon, n)``), or one per
        sensor age, ``(Ds + 1, …)``; for ``controller='lti'`` the
        controller, discrete-time with the plant's ``dt``.
    controller : {'static', 'predictor', 'estimator', 'lti'}
    actuator : {'zero', 'hold'}
    sensor : {'zero', 'hold'}
        LTI controller: what it reads when the measurement is stale.
    estimator_gain : array_like, shape (n, nmeas), optional
        The estimator's ``L`` (``controller='estimator'``).

    Returns
    -------
    JumpStateSpace
        Markov modes ``(a, b)``, ``a`` the sensor age (``0..Ds``, then
        stale), ``b`` the actuator age, and ``τ`` the input delay when the
        plant has one (``(a, b, τ)``); ``info['delay_modes']`` names them.
    """
    return _build(P, K, controller, actuator, sensor, estimator_gain)[0]


def gain_shape(P: NetworkedStateSpace, controller: str) -> tuple[int, ...]:
    """One gain per sensor age (static) or one predictor gain."""
    n, m2, p2 = P.nstates, P.B2.shape[1], P.C2.shape[0]
    ages = (P.sensor_delay.buffer + 1) if P.sensor_delay is not None else 1
    if controller == "predictor":
        return (1, m2, n)
    return (ages, m2, p2)


def start_from(gains: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """A design without delays as a start over delayed links, in ``shape``
    (:func:`gain_shape`): its first phase (and previous mode), on what the
    delayed gain reads (a held command's columns, which come after, are
    dropped), at every age."""
    K = np.asarray(gains, float)
    K = K[:, 0] if K.ndim == 4 else K
    return np.broadcast_to(K[:1, :, :shape[-1]], shape).copy()


class DelayedParts(NamedTuple):
    """The delayed loop, mode by mode, affine in the gains
    (:func:`delayed_parts`)."""

    A0: np.ndarray          # (M, nX, nX)
    L: np.ndarray           # (M, nX, m2): where the command enters
    S: np.ndarray           # (M, width, nX): what the gain reads
    g: np.ndarray           # (M,): which gain (sensor age) acts
    T: np.ndarray           # (N, M, M): the chain
    C0: np.ndarray          # (M, p1, nX)
    LC: np.ndarray          # (M, p1, m2)
    B: np.ndarray           # (M, nX, m1)
    D: np.ndarray           # (M, p1, m1)
    pi: np.ndarray          # (N, M): the stationary law


def delayed_parts(P: NetworkedStateSpace, controller: str, actuator: str
                  ) -> DelayedParts:
    """The loop of a static gain per sensor age, or of the predictor, as an
    affine function of the gains, for the local designs.

    Mode ``i`` of :func:`delayed_loop` (same order) is ``A_i = A0_i + L_i
    K_{g_i} S_i``, ``C_i = C0_i + LC_i K_{g_i} S_i``: ``K_g`` the gain of
    sensor age ``g_i`` (one per age; the predictor's one gain is age 0's),
    ``S_i`` what it reads (zero when stale); ``B_i``, ``D_i`` do not
    depend on the gains.
    """
    if np.any(np.asarray(P.D21) != 0):
        raise ControlArgument(
            "P: design over delayed links needs D21 = 0 (with measurement "
            "noise the gain also acts on w); design for D21 = 0 and analyse "
            "the loop with the noise: feedback(P, K)")
    CL, parts = _build(P, np.zeros(gain_shape(P, controller)), controller,
                       actuator, "zero")
    A0, L, S, g, C0, LC, B = (np.array(X) for X in zip(*parts))
    if controller == "predictor":
        g = np.zeros_like(g)
    # the chain (a delay law that never delays nor loses gives i.i.d.
    # modes: their chain has equal rows)
    T = CL.modes.transitions()
    return DelayedParts(A0, L, S, g, T, C0, LC, B,
                        np.array(CL.modes.D[0]), CL.modes.probabilities)


def _build(P: NetworkedStateSpace, K: Any, controller: str, actuator: str,
           sensor: str, estimator_gain: Any = None
           ) -> tuple[JumpStateSpace, list[tuple]]:
    """:func:`delayed_loop` and, for gains, its affine parts per mode."""
    if controller not in CONTROLLERS:
        raise ControlArgument(f"controller: over delayed links expected one "
                              f"of {CONTROLLERS}, got {controller!r}")
    if actuator not in ACTUATORS:
        raise ControlArgument(f"actuator: over delayed links expected one "
                              f"of {ACTUATORS}, got {actuator!r}")
    n, m1, m2 = P.nstates, P.B1.shape[1], P.B2.shape[1]
    p1, p2 = P.C1.shape[0], P.C2.shape[0]
    if controller == "predictor" and not (
            P.C2.shape == (n, n) and np.array_equal(P.C2, np.eye(n))):
        raise ControlArgument(
            f"controller='predictor' needs the full state measured: y = x "
            f"(C2 = I), got C2 of shape {P.C2.shape}")
    N = P.period
    Ds, Ts, sensor_ages = _chain(P.sensor_delay,
                                 P.sensor_schedule.pattern.any(axis=1), N)
    Da, Ta, actuator_ages = _chain(P.actuator_delay,
                                   P.actuator_schedule.pattern.any(axis=1), N)
    estimator = controller == "estimator"
    width = n if controller in ("predictor", "estimator") else p2
    lti = controller == "lti"
    if estimator:
        Lg = real_array(estimator_gain, "estimator_gain", ndim=(2,))
        if Lg.shape != (n, p2):
            raise ControlDimension(
                f"estimator_gain: over delayed links one gain L of shape "
                f"{(n, p2)} (n, nmeas), got {Lg.shape}")
        if P.input_delay is not None:
            raise ControlArgument(
                "controller: the estimator's model over sub-sample input "
                "delays is not written; use 'static', 'predictor' or an LTI "
                "controller")
    if lti:             # v = Cc xc + Dc ŷ, xc⁺ = Ac xc + Bc ŷ
        Ac, Bc, Cc, Dc = (np.asarray(M, float) for M in (K.A, K.B, K.C, K.D))
    else:
        G = _gains(K, 1 if estimator else Ds + 1, (m2, width))
    nc = Ac.shape[0] if lti else 0
    hy = p2 if lti and sensor == "hold" else 0
    # how many applied inputs are kept: the predictor's window and the hold
    delay = P.input_delay
    Lu = max(Ds if controller == "predictor" else 0,
             1 if actuator == "hold" or delay is not None else 0)
    taus = 1 if delay is None else delay.taus.size
    # a measurement with noise (D21 ≠ 0) is buffered with its noise: the
    # past disturbances w_{k-1..k-Ds} it may still carry join the state
    D21 = np.asarray(P.D21, float)
    Dw = Ds if np.any(D21 != 0) else 0
    # blocks of X: x (Ds + 1 copies), v (Da), u (Lu), xc (nc), ŷ_{k-1} (hy),
    # w (Dw)
    # the estimator keeps its estimates x̂_k, …, x̂_{k-Ds} (corrected so far)
    ne = n * (Ds + 1) if estimator else 0
    nX = n * (Ds + 1) + m2 * Da + m2 * Lu + nc + hy + m1 * Dw + ne
    ox, ov, ou = 0, n * (Ds + 1), n * (Ds + 1) + m2 * Da
    xcb = slice(ou + m2 * Lu, ou + m2 * Lu + nc)
    yb = slice(xcb.stop, xcb.stop + hy)
    ow = yb.stop
    oe = ow + m1 * Dw

    def wb(j: int) -> slice:        # w_{k-j}, j >= 1
        return slice(ow + m1 * (j - 1), ow + m1 * j)

    def eb(j: int) -> slice:        # x̂_{k-j}, j >= 0
        return slice(oe + n * j, oe + n * (j + 1))

    def xb(j: int) -> slice:        # x_{k-j}
        return slice(ox + n * j, ox + n * (j + 1))

    def vb(j: int) -> slice:        # v_{k-j}, j >= 1
        return slice(ov + m2 * (j - 1), ov + m2 * j)

    def ub(j: int) -> slice:        # u_{k-j}, j >= 1
        return slice(ou + m2 * (j - 1), ou + m2 * j)

    A, B1, B2 = (np.asarray(M, float) for M in (P.A, P.B1, P.B2))
    C1, D11, D12 = (np.asarray(M, float) for M in (P.C1, P.D11, P.D12))
    C2 = np.asarray(P.C2, float)
    powers = [np.linalg.matrix_power(A, i) for i in range(Ds + 1)]

    def measured(a: int) -> tuple[np.ndarray, np.ndarray]:
        """``y_{k-a} = C2 x_{k-a} + D21 w_{k-a}`` as rows on ``X`` and on
        the current ``w_k`` (``a = 0``)."""
        Y, Yw = np.zeros((p2, nX)), np.zeros((p2, m1))
        Y[:, xb(a)] = C2
        if a == 0:
            Yw[:] = D21
        elif Dw:
            Y[:, wb(a)] = D21
        return Y, Yw

    def read(a: int) -> tuple[np.ndarray, np.ndarray]:
        """What a gain acts on at sensor age ``a``, as rows on ``X`` and on
        ``w_k``: ``y_{k-a}`` (static) or the prediction
        ``x̂_k = A^a y_{k-a} + Σ A^{i-1} B2 u_{k-i}`` (predictor, ``y = x``
        with its noise); zero when the measurement is stale (nothing is
        sent)."""
        S, Sw = np.zeros((width, nX)), np.zeros((width, m1))
        if a <= Ds:
            Y, Yw = measured(a)
            if controller == "static":
                S, Sw = Y, Yw
            else:
                S, Sw = powers[a] @ Y, powers[a] @ Yw
                for i in range(1, a + 1):
                    S[:, ub(i)] += powers[i - 1] @ B2
        return S, Sw

    def assemble(b: int, c: int) -> tuple[Any, ...]:
        """Mode ``(·, b, τ_c)`` affine in the command ``v_k``:
        ``A = A0 + L v``, ``C = C0 + LC v`` (the sensor age enters only
        through ``v``), and the input applied after ``τ``, ``U0 X +
        fresh v``. With ``τ > 0`` the sampled ``z`` sees the input held
        until then, ``u_{k-1}``."""
        U0 = np.zeros((m2, nX))         # the applied input, v_k aside
        if 1 <= b <= Da:
            U0[:, vb(b)] = np.eye(m2)
        elif b > Da and actuator == "hold":
            U0[:, ub(1)] = np.eye(m2)
        fresh = 1.0 if b == 0 else 0.0  # u_k = v_k
        A0 = np.zeros((nX, nX))
        L = np.zeros((nX, m2))
        Bm = np.zeros((nX, m1))
        A0[xb(0), xb(0)] = A
        if delay is None:
            A0[xb(0)] += B2 @ U0
            L[xb(0)] = fresh * B2
        else:
            # the previous input acts first, then u_k (after τ)
            A0[xb(0)] += delay.gamma0[c] @ U0
            A0[xb(0), ub(1)] += delay.gamma1[c]
            L[xb(0)] = fresh * delay.gamma0[c]
        Bm[xb(0)] = B1
        for j in range(1, Ds + 1):       # shift the measurements
            A0[xb(j), xb(j - 1)] = np.eye(n)
        if Dw:                           # and the noise they carry
            Bm[wb(1)] = np.eye(m1)
            for j in range(2, Dw + 1):
                A0[wb(j), wb(j - 1)] = np.eye(m1)
        if Da:
            L[vb(1)] = np.eye(m2)        # v_k joins the commands
            for j in range(2, Da + 1):
                A0[vb(j), vb(j - 1)] = np.eye(m2)
        if Lu:
            A0[ub(1)] = U0               # u_k joins the history
            L[ub(1)] = fresh * np.eye(m2)
            for j in range(2, Lu + 1):
                A0[ub(j), ub(j - 1)] = np.eye(m2)
        C0 = np.zeros((p1, nX))
        C0[:, xb(0)] = C1
        if delay is not None and delay.taus[c] > 0:
            # z at the sample sees the input held until τ: u_{k-1}
            C0[:, ub(1)] += D12
            LC = np.zeros((p1, m2))
        else:
            C0 += D12 @ U0
            LC = fresh * D12
        if estimator:       # x̂_{k+1} = A x̂'_k + B2 u_k (u known by ack)
            A0[eb(0)] = B2 @ U0
            L[eb(0)] = fresh * B2
        return A0, L, Bm, C0, LC, U0, fresh

    def corrected(ap: int, a: int) -> tuple[list, list]:
        """The estimates after a new measurement of age ``a`` (new: fresher
        than the one used the step before, of age ``ap``): ``x̂'_{k-j} =
        x̂_{k-j} + A^{a-j} L (y_{k-a} - C2 x̂_{k-a})`` for ``j ≤ a``, the
        correction propagated to the present; as rows on ``X`` and ``w_k``
        per ``j``."""
        rows = []
        for j in range(Ds + 1):
            R = np.zeros((n, nX))
            R[:, eb(j)] = np.eye(n)
            rows.append([R, np.zeros((n, m1))])
        if a <= Ds and a <= ap:
            Y, Yw = measured(a)
            Y = Y.copy()
            Y[:, eb(a)] -= C2              # the innovation y - C2 x̂
            for j in range(a + 1):
                gain = powers[a - j] @ Lg
                rows[j][0] = rows[j][0] + gain @ Y
                rows[j][1] = rows[j][1] + gain @ Yw
        return [r[0] for r in rows], [r[1] for r in rows]

    modes_A, modes_B, modes_C, modes_D, names = [], [], [], [], []
    inputs: list[tuple[np.ndarray, np.ndarray]] = []
    parts: list[tuple] = []
    # the estimator's mode is the pair (previous age, age): whether the
    # freshest measurement is new depends on both
    sensor_modes: list[tuple[int | None, int]] = (
        [(int(ap), int(a)) for ap in sensor_ages for a in sensor_ages]
        if estimator else [(None, int(a)) for a in sensor_ages])
    for ap, a in sensor_modes:
        if ap is not None:
            Xh, Xhw = corrected(ap, a)
            S, Sw = Xh[0], Xhw[0]
            V, Vw = G[0] @ S, G[0] @ Sw
        elif lti:       # the command v_k as rows acting on X and w_k
            # what the controller reads: the measurement, or 0 / the last
            # one it read when stale
            Y, Yw = measured(a) if a <= Ds else (np.zeros((p2, nX)),
                                                 np.zeros((p2, m1)))
            if a > Ds and hy:
                Y[:, yb] = np.eye(p2)
            V, Vw = Dc @ Y, Dc @ Yw
            V[:, xcb] += Cc
        else:
            S, Sw = read(a)
            V, Vw = G[min(a, Ds)] @ S, G[min(a, Ds)] @ Sw
        for b in actuator_ages:
            for c in range(taus):
                A0, L, Bm, C0, LC, U0, fresh = assemble(b, c)
                if lti:
                    A0[xcb] = Bc @ Y
                    A0[xcb, xcb] += Ac
                    Bm[xcb] = Bc @ Yw
                    A0[yb] = Y[:hy]              # ŷ_k kept for a hold
                    Bm[yb] = Yw[:hy]
                elif estimator:
                    A0[eb(0)] += A @ Xh[0]
                    Bm[eb(0)] += A @ Xhw[0]
                    for j in range(1, Ds + 1):   # shift the estimates
                        A0[eb(j)] = Xh[j - 1]
                        Bm[eb(j)] = Xhw[j - 1]
                    parts.append((A0, L, S, 0, C0, LC, Bm))
                else:
                    parts.append((A0, L, S, min(int(a), Ds), C0, LC, Bm))
                # the input applied after τ in this mode (intersample cost)
                inputs.append((U0 + fresh * V, fresh * Vw))
                modes_A.append(A0 + L @ V)
                modes_B.append(Bm + L @ Vw)
                modes_C.append(C0 + LC @ V)
                modes_D.append(D11 + LC @ Vw)
                age = (int(a),) if ap is None else (int(ap), int(a))
                names.append(age + (int(b),) if delay is None
                             else age + (int(b), float(delay.taus[c])))
    if estimator:       # (a⁻, a) → (a, a⁺) with the age chain's law
        count = len(sensor_ages)
        pairs = np.zeros((N, count * count, count * count))
        for k in range(N):
            for s0 in range(count):
                for s1 in range(count):
                    pairs[k, s0 * count + s1,
                          s1 * count:(s1 + 1) * count] = Ts[k][s1]
        Ts = pairs
    # (a, b) → (a⁺, b⁺), a-major, per phase; τ i.i.d., innermost
    T = np.array([np.kron(Ts[k], Ta[k]) for k in range(N)])
    if delay is not None:
        T = np.array([np.kron(Tk, np.tile(delay.probabilities, (taus, 1)))
                      for Tk in T])
    states = ([f"{s}[k-{j}]" if j else s for j in range(Ds + 1)
               for s in P.state_labels]
              + [f"v{i}[k-{j}]" for j in range(1, Da + 1) for i in range(m2)]
              + [f"u{i}[k-{j}]" for j in range(1, Lu + 1) for i in range(m2)]
              + [f"xc[{i}]" for i in range(nc)]
              + [f"y{i}_rcv[k-1]" for i in range(hy)]
              + [f"{s}[k-{j}]" for j in range(1, Dw + 1)
                 for s in P.disturbance_labels]
              + [f"{s}_hat[k-{j}]" if j else f"{s}_hat" for j in range(
                  Ds + 1 if estimator else 0) for s in P.state_labels])
    # the same matrices at every phase; the schedule is in the chain
    Ak, Bk, Ck, Dk = (np.repeat(np.array([X]), N, axis=0)
                      for X in (modes_A, modes_B, modes_C, modes_D))
    CL = JumpStateSpace(
        Ak, Bk, Ck, Dk, None, P.dt, transition=T,
        inputs=P.disturbance_labels, outputs=P.performance_labels,
        states=states,
        name=None if P.name is None else f"{P.name} (closed loop)",
        info=dict(controller=controller, actuator=actuator, plant=P.name,
                  **({"sensor": sensor, "controller_system": K} if lti
                     else {"gains": G}),
                  delay_modes=names,
                  sensor_delay=P.sensor_delay,
                  actuator_delay=P.actuator_delay,
                  input_delay=None if delay is None else delay.taus))
    if P.continuous is not None:
        prev = np.zeros((m2, nX))
        if Lu:
            prev[:, ub(1)] = np.eye(m2)
        tau = (np.zeros(len(names)) if delay is None else
               np.array([name[-1] for name in names], float))
        CL.info["sampling"] = sampling_entry(
            P, x=xb(0), u=[u for u, _ in inputs], u_w=[w for _, w in inputs],
            u_prev=[prev] * len(names), tau=tau, period=N)
    return CL, parts
