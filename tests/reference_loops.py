"""Independent augmented-state constructions of networked loops.

The tests compare the package's closed loops with the loops built here.
Everything is written from the event-level semantics of the networked loop
(plant, schedules, the two links, freshest packet wins, the controllers and
the actuator strategies) and from the theory page's random delays and
composed links; nothing of the package is used but :func:`control_ncs.jss`,
which turns the matrices into a jump system.

Construction
------------
* **Links.** Every link is a channel chain (one state, or the two states
  lost/bad and delivered/good of a Gilbert–Elliott channel) with a delay law
  per channel state and a buffer ``D``. A perfect link is the law ``[1]``,
  a Bernoulli loss ``α`` the law ``[1 - α]``, a Gilbert–Elliott loss the
  laws ``[0]`` (lost) and ``[1]`` (delivered), a delay ``q`` with a loss
  ``α`` the thinned law ``(1 - α) q``. Its Markov chain is over
  ``(channel state g, age a)``, ``a ∈ {0..D, stale}``: between ``t`` and
  ``t + 1`` the channel moves, then each packet newer than the one in use
  (ages ``c = 0..min(a, D)`` at ``t + 1``, sent at a phase that sends)
  arrives with the hazard ``h_g'(c) = q_c / (1 - Σ_{c' < c} q_c')`` of the
  new channel state ``g'``; the freshest arrival is the new age, else the
  packet in use ages by one (stale beyond ``D``).
* **Modes.** The product of the sensor link's chain (with whether the
  packet in use is new, for the model-based controllers, which correct on
  new packets only: a function of consecutive ages), the
  actuator link's chain and the sub-sample input delay's i.i.d. draw; modes
  that the stationary chain never visits are dropped. The initial law is
  the periodic stationary law at phase 0.
* **Loop state.** ``[x(t); y(t-1..t-Ds); v(t-1..t-Da); u(t-1); xc(t);
  ŷ(t-1); x̂(t), x̂(t-1..t-Ds)]`` (the parts the loop needs). One step of
  the protocol in a given mode is a linear map of ``(state, w)``; its
  matrices are read off by applying the step to the unit vectors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg

from control_ncs import jss

__all__ = ["Link", "perfect", "bernoulli", "gilbert_elliott", "delay",
           "bursty", "Plant", "sample_input_delay", "link_chain", "loop"]


# --------------------------------------------------------------------------
# links
# --------------------------------------------------------------------------
@dataclass(frozen=True)
class Link:
    """A channel chain with a delay law per channel state and a buffer."""

    channel: np.ndarray          # (G, G): P(g' | g), state 0 lost/bad
    pmfs: tuple                  # G arrays, P(δ = c) while in that state
    buffer: int                  # D: the oldest usable age

    @property
    def states(self) -> int:
        return self.channel.shape[0]


def _ge(fail: float, recover: float) -> np.ndarray:
    # rows: from lost (bad), from delivered (good)
    return np.array([[1.0 - recover, recover], [fail, 1.0 - fail]])


def perfect() -> Link:
    return Link(np.ones((1, 1)), (np.array([1.0]),), 0)


def bernoulli(alpha: float) -> Link:
    return Link(np.ones((1, 1)), (np.array([1.0 - alpha]),), 0)


def gilbert_elliott(fail: float, recover: float) -> Link:
    return Link(_ge(fail, recover), (np.array([0.0]), np.array([1.0])), 0)


def delay(pmf: Any, buffer: int | None = None, loss: float = 0.0) -> Link:
    q = (1.0 - loss) * np.asarray(pmf, float)          # thinned by the loss
    return Link(np.ones((1, 1)), (q,),
                len(q) - 1 if buffer is None else buffer)


def bursty(fail: float, recover: float, pmf_bad: Any, pmf_good: Any,
           buffer: int | None = None) -> Link:
    bad, good = np.asarray(pmf_bad, float), np.asarray(pmf_good, float)
    D = max(len(bad), len(good)) - 1 if buffer is None else buffer
    return Link(_ge(fail, recover), (bad, good), D)


def _hazard(q: np.ndarray, c: int) -> float:
    """P(a packet arrives at age c | it has not arrived before)."""
    if c >= len(q):
        return 0.0
    left = 1.0 - float(np.sum(q[:c]))
    return float(q[c]) / left if left > 1e-15 else 0.0


@dataclass(frozen=True)
class _Chain:
    """A periodic Markov chain: state labels, ``T[k]`` from phase k to
    k + 1, and the law at phase 0."""

    labels: list
    T: np.ndarray                # (N, S, S)
    initial: np.ndarray          # (S,)


def _stationary(T: np.ndarray) -> np.ndarray:
    """The law at phase 0 of the periodic chain run from the far past."""
    S = T.shape[1]
    M = np.eye(S)
    for Tk in T:
        M = M @ Tk
    # π M = π, Σ π = 1 (least squares on the stacked system; exact when the
    # stationary law is unique, which is checked)
    lhs = np.vstack([M.T - np.eye(S), np.ones((1, S))])
    rhs = np.concatenate([np.zeros(S), [1.0]])
    pi, *_ = np.linalg.lstsq(lhs, rhs, rcond=None)
    assert np.linalg.matrix_rank(lhs, tol=1e-10) == S, "several stationary laws"
    pi[pi < 1e-14] = 0.0
    return pi / pi.sum()


def link_chain(link: Link, sent: Any) -> _Chain:
    """The chain of ``(g, a)`` of a link whose sender sends at the phases
    where ``sent`` is true; ``a = D + 1`` is stale."""
    sent = np.asarray(sent, bool)
    N, G, D = sent.size, link.states, link.buffer
    A = D + 2
    labels = [(g, a) for g in range(G) for a in range(A)]
    T = np.zeros((N, G * A, G * A))
    for k in range(N):
        for g in range(G):
            for a in range(A):
                for g2 in range(G):
                    pg = link.channel[g, g2]
                    survive = pg
                    for c in range(min(a, D) + 1):
                        # the packet of age c at t + 1 was stamped t + 1 - c
                        h = _hazard(link.pmfs[g2], c) * sent[(k + 1 - c) % N]
                        T[k, g * A + a, g2 * A + c] += survive * h
                        survive *= 1.0 - h
                    T[k, g * A + a, g2 * A + min(a + 1, D + 1)] += survive
    return _Chain(labels, T, _stationary(T))


def _with_news(chain: _Chain, stale: int) -> _Chain:
    """The chain of ``(new, g, a)``: whether the packet in use at ``t`` is
    new (not stale, and fresher than the one used at ``t - 1``) is a
    function of the ages at ``t - 1`` and ``t``, so the triple is Markov."""
    N = chain.T.shape[0]

    def news(before: int, now: int) -> bool:
        return now != stale and (before == stale or now <= before)

    labels = [(new, g, a) for new in (False, True) for (g, a) in chain.labels]
    index = {lab: i for i, lab in enumerate(labels)}
    T = np.zeros((N, len(labels), len(labels)))
    for k in range(N):
        for (_, g, a), i in index.items():
            row = chain.labels.index((g, a))
            for j, (g2, b) in enumerate(chain.labels):
                T[k, i, index[(news(a, b), g2, b)]] = chain.T[k, row, j]
    # the law at phase 0 from the law at phase N - 1 and the last step
    last = chain.initial.copy()
    for Tk in chain.T[:-1]:
        last = last @ Tk
    initial = np.zeros(len(labels))
    for i, (_, ap) in enumerate(chain.labels):
        for j, (g, a) in enumerate(chain.labels):
            initial[index[(news(ap, a), g, a)]] += last[i] * chain.T[-1, i, j]
    return _Chain(labels, T, initial)


def _iid(probabilities: Any, N: int) -> _Chain:
    p = np.asarray(probabilities, float)
    return _Chain([(i,) for i in range(p.size)],
                  np.tile(p, (N, p.size, 1)), p)


def _product(chains: list) -> _Chain:
    labels = [()]
    T = np.ones((chains[0].T.shape[0], 1, 1))
    initial = np.ones(1)
    for ch in chains:
        labels = [lab + (part,) for lab in labels for part in ch.labels]
        T = np.stack([np.kron(Tk, Ck) for Tk, Ck in zip(T, ch.T)])
        initial = np.kron(initial, ch.initial)
    return _Chain(labels, T, initial)


def _visited(chain: _Chain) -> np.ndarray:
    """The states the stationary chain visits, closed under every phase's
    transition (so that each kept row keeps its whole mass: a kept state
    improbable at some phase keeps its true successors)."""
    keep = chain.initial > 0
    edges = (chain.T > 0).any(axis=0)
    while True:
        grown = keep | ((keep.astype(float) @ edges) > 0)
        if np.array_equal(grown, keep):
            return keep
        keep = grown


# --------------------------------------------------------------------------
# the plant and the sampled input delay
# --------------------------------------------------------------------------
@dataclass(frozen=True)
class Plant:
    """``x⁺ = A x + B1 w + B2 u``, ``z = C1 x + D11 w + D12 u``,
    ``y = C2 x + D21 w``; with ``gamma0, gamma1, taus_p`` the sampled
    input delay ``x⁺ = A x + B1 w + Γ0(τ) u + Γ1(τ) u⁻`` (``B2``: the
    model of the controller)."""

    A: np.ndarray
    B1: np.ndarray
    B2: np.ndarray
    C1: np.ndarray
    D11: np.ndarray
    D12: np.ndarray
    C2: np.ndarray
    D21: np.ndarray
    gamma0: np.ndarray | None = None
    gamma1: np.ndarray | None = None
    delay_probabilities: np.ndarray | None = None


def sample_input_delay(Ac, B1c, B2c, h, taus):
    """``(Φ, B1d, B2d, Γ0, Γ1)`` of a continuous plant sampled every ``h``
    whose input is applied ``τ`` after the sample:
    ``Γ0(τ) = ∫_0^{h-τ} e^{As} ds B``, ``Γ1(τ) = e^{A(h-τ)} ∫_0^τ e^{As} ds B``."""
    Ac, B1c, B2c = (np.atleast_2d(np.asarray(X, float)) for X in (Ac, B1c, B2c))
    n, m = B2c.shape

    def integral(B, s):
        """(e^{As}, ∫_0^s e^{Ar} dr B) from one exponential."""
        k = B.shape[1]
        big = np.zeros((n + k, n + k))
        big[:n, :n], big[:n, n:] = Ac, B
        E = scipy.linalg.expm(big * s)
        return E[:n, :n], E[:n, n:]

    Phi, B2d = integral(B2c, h)
    _, B1d = integral(B1c, h)
    g0, g1 = [], []
    for tau in taus:
        g0.append(integral(B2c, h - tau)[1])
        g1.append(integral(B2c, h - tau)[0] @ integral(B2c, tau)[1])
    return Phi, B1d, B2d, np.array(g0), np.array(g1)


# --------------------------------------------------------------------------
# the loop
# --------------------------------------------------------------------------
@dataclass
class _Loop:
    plant: Plant
    N: int
    S1: np.ndarray
    S2: np.ndarray
    Ds: int
    Da: int
    controller: str
    actuator: str
    sensor: str
    K: np.ndarray
    L: np.ndarray | None
    lti: tuple | None
    slices: dict


def _layout(c: _Loop, n: int, p2: int, m2: int, nc: int) -> dict:
    parts = [("x", n)]
    parts += [(("y", j), p2) for j in range(1, c.Ds + 1)]
    parts += [(("v", j), m2) for j in range(1, c.Da + 1)]
    if c.actuator == "hold" or c.plant.gamma0 is not None:
        parts.append(("u", m2))
    if c.controller == "lti":
        parts.append(("xc", nc))
        if c.sensor == "hold":
            parts.append(("yhat", p2))
    if c.controller in ("predictor", "estimator"):
        parts += [(("xhat", j), n) for j in range(c.Ds + 1)]
    slices, start = {}, 0
    for name, size in parts:
        slices[name] = slice(start, start + size)
        start += size
    slices["size"] = start
    return slices


def _step(c: _Loop, k: int, age: int | None, new: bool, cage: int | None,
          tau: int | None, xi: np.ndarray, w: np.ndarray):
    """One step of the protocol at phase k: the sensor packet in use has
    age ``age`` (None: stale), is ``new`` or not, the command packet age
    ``cage``; returns (next state, z), linear in (xi, w)."""
    P, s = c.plant, c.slices
    cols = xi.shape[1]
    m2, p2 = P.B2.shape[1], P.C2.shape[0]
    x = xi[s["x"]]
    y0 = P.C2 @ x + P.D21 @ w

    def y_at(j):
        return y0 if j == 0 else xi[s[("y", j)]]

    u_prev = xi[s["u"]] if "u" in s else np.zeros((m2, cols))
    if age is not None:
        sig1 = np.diag(c.S1[(k - age) % c.N])
        ypkt = sig1 @ y_at(age)
    nxt = np.zeros((s["size"], cols))

    if c.controller == "static":
        NK, NA = c.K.shape[:2]
        v = (c.K[k % NK, min(age, NA - 1)] @ ypkt if age is not None
             else np.zeros((m2, cols)))
    elif c.controller == "lti":
        Ac, Bc, Cc, Dc = c.lti
        h = xi[s["yhat"]] if c.sensor == "hold" else np.zeros((p2, cols))
        yhat = (ypkt + (np.eye(p2) - sig1) @ h) if age is not None else h
        xc = xi[s["xc"]]
        v = Cc @ xc + Dc @ yhat
        nxt[s["xc"]] = Ac @ xc + Bc @ yhat
        if c.sensor == "hold":
            nxt[s["yhat"]] = yhat
    else:
        X = [xi[s[("xhat", j)]].copy() for j in range(c.Ds + 1)]
        if new:
            nu = sig1 @ (y_at(age) - P.C2 @ X[age])
            corr = c.L[(k - age) % c.L.shape[0]] @ nu
            for j in range(age + 1):
                X[j] = X[j] + np.linalg.matrix_power(P.A, age - j) @ corr
        feed = np.vstack([X[0], u_prev]) if c.actuator == "hold" else X[0]
        v = c.K[k % c.K.shape[0]] @ feed

    held = u_prev if c.actuator == "hold" else np.zeros((m2, cols))
    if cage is not None:
        sig2 = np.diag(c.S2[(k - cage) % c.N])
        vpkt = v if cage == 0 else xi[s[("v", cage)]]
        u = sig2 @ vpkt + (np.eye(m2) - sig2) @ held
    else:
        u = held
    z = P.C1 @ x + P.D11 @ w + P.D12 @ u
    if P.gamma0 is None:
        nxt[s["x"]] = P.A @ x + P.B1 @ w + P.B2 @ u
    else:
        nxt[s["x"]] = P.A @ x + P.B1 @ w + P.gamma0[tau] @ u \
            + P.gamma1[tau] @ u_prev
    for j in range(1, c.Ds + 1):
        nxt[s[("y", j)]] = y_at(j - 1)
    for j in range(1, c.Da + 1):
        nxt[s[("v", j)]] = v if j == 1 else xi[s[("v", j - 1)]]
    if "u" in s:
        nxt[s["u"]] = u
    if c.controller in ("predictor", "estimator"):
        nxt[s[("xhat", 0)]] = P.A @ X[0] + P.B2 @ u
        for j in range(1, c.Ds + 1):
            nxt[s[("xhat", j)]] = X[j - 1]
    return nxt, z


def _schedule(S: Any, width: int) -> np.ndarray:
    if S is None:
        return np.ones((1, width))
    return np.asarray(S, float).reshape(-1, width)


def loop(plant: Plant, sensor_link: Link, actuator_link: Link, gains: Any,
         *, controller: str = "static", actuator: str = "zero",
         sensor: str = "zero", sensor_schedule: Any = None,
         actuator_schedule: Any = None, estimator_gains: Any = None,
         controller_system: tuple | None = None, dt: Any = True):
    """The closed loop ``w → z`` as a Markov jump system (``ncs.jss``).

    ``gains``: static ``(NK, NA, m2, p2)`` (per phase and age, ``NA = 1``
    for every age) or ``(m2, p2)``; predictor/estimator ``(NK, m2, nk)``
    or ``(m2, nk)`` (``nk = n`` or ``n + m2`` with a hold actuator);
    ignored for ``controller='lti'`` (``controller_system = (Ac, Bc, Cc,
    Dc)``). ``estimator_gains``: ``(NL, n, p2)`` or ``(n, p2)``, indexed by
    the measured step's phase; the predictor is ``C2 = I``, ``L = I``.
    """
    n, m2, p2 = plant.A.shape[0], plant.B2.shape[1], plant.C2.shape[0]
    S1, S2 = _schedule(sensor_schedule, p2), _schedule(actuator_schedule, m2)
    K = np.asarray(gains if gains is not None else np.zeros((1, m2, 1)),
                   float)
    if controller == "static":
        K = K.reshape((1, 1) + K.shape) if K.ndim == 2 else K
    elif K.ndim == 2:
        K = K[None]
    L = None
    if controller == "predictor":
        L = np.eye(n)[None]
        assert np.array_equal(plant.C2, np.eye(n)), "the predictor needs y = x"
    elif controller == "estimator":
        L = np.asarray(estimator_gains, float)
        L = L[None] if L.ndim == 2 else L
    lti, nc = None, 0
    if controller == "lti":
        lti = tuple(np.atleast_2d(np.asarray(X, float))
                    for X in controller_system)
        nc = lti[0].shape[0] if np.size(lti[0]) else 0
        lti = (lti[0].reshape(nc, nc), lti[1].reshape(nc, p2),
               lti[2].reshape(m2, nc), lti[3].reshape(m2, p2))
    N = math.lcm(S1.shape[0], S2.shape[0], K.shape[0],
                 1 if L is None else L.shape[0])
    S1 = np.tile(S1, (N // S1.shape[0], 1))
    S2 = np.tile(S2, (N // S2.shape[0], 1))
    c = _Loop(plant, N, S1, S2, sensor_link.buffer, actuator_link.buffer,
              controller, actuator, sensor, K, L, lti, {})
    c.slices = _layout(c, n, p2, m2, nc)

    model_based = controller in ("predictor", "estimator")
    s_chain = link_chain(sensor_link, S1.any(axis=1))
    stale_s = sensor_link.buffer + 1
    if model_based:
        s_chain = _with_news(s_chain, stale_s)
    a_chain = link_chain(actuator_link, S2.any(axis=1))
    chains = [s_chain, a_chain]
    if plant.gamma0 is not None:
        chains.append(_iid(plant.delay_probabilities, N))
    chain = _product(chains)
    keep = _visited(chain)
    labels = [lab for lab, k in zip(chain.labels, keep) if k]
    T = chain.T[:, keep][:, :, keep]
    initial = chain.initial[keep]

    size, m1 = c.slices["size"], plant.B1.shape[1]
    basis = np.eye(size + m1)
    mats: dict = {}
    A = np.zeros((N, len(labels), size, size))
    B = np.zeros((N, len(labels), size, m1))
    C = np.zeros((N, len(labels), plant.C1.shape[0], size))
    Dm = np.zeros((N, len(labels), plant.C1.shape[0], m1))
    for i, lab in enumerate(labels):
        sens, act = lab[0], lab[1]
        tau = lab[2][0] if len(lab) > 2 else None
        a = sens[-1] if sens[-1] <= sensor_link.buffer else None
        new = bool(sens[0]) if model_based else False
        b = act[1] if act[1] <= actuator_link.buffer else None
        for k in range(N):
            key = (k, a, new, b, tau)
            if key not in mats:
                nxt, z = _step(c, k, a, new, b, tau, basis[:size],
                               basis[size:])
                mats[key] = (nxt[:, :size], nxt[:, size:], z[:, :size],
                             z[:, size:])
            A[k, i], B[k, i], C[k, i], Dm[k, i] = mats[key]
    return jss(A, B, C, Dm, initial, dt, transition=T)
