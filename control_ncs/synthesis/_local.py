"""The one local-search kernel of the designs (:ref:`theory-synthesis`,
:ref:`theory-performance`, :ref:`theory-links-compose`).

Where no convex program is exact (a structured gain: a sensor schedule, a
hold actuator, the predictor's or the estimator's ``[I 0]``, a gain per age
of a buffered measurement), every design searches the gain's free entries on
exact figures of the loop it closes. This module owns what they share: the
loop as a function of the free entries (:class:`Loop`: ``A + Bu K E`` per
phase and mode, its exact mean-square rate and the rate's Perron gradient),
the quasi-Newton method with a weak Wolfe line search (HIFOO's scheme), the
starting points (the full-information gain projected on what the gain reads,
the mean-square LQ gain restricted, zero, a continuation in the loss), the
passivity level's objectives (the analysis LMI's optimum with its envelope
gradient for i.i.d. modes; the certified level itself, derivative-free, for
Markov modes) and the one exact refutation that needs no solver
(:func:`autonomous_rate`). The H2 and ℓ2 objectives (:mod:`._h2`,
:mod:`._hinf`) build on :class:`Loop`; the drivers are in
:mod:`.refine` (passivity) and :mod:`.norms` (H2, H∞). Every figure a design
returns is measured again on its loop by an analysis of its own.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
import scipy.linalg
from scipy.optimize import minimize
from scipy.sparse.linalg import (ArpackError, ArpackNoConvergence,
                                 LinearOperator, eigs)

from ..exceptions import TIME_LIMIT, CertificationError
from ..modes import entered_modes
from ..openloop import JumpPlant
from ..stability import ms_radius as exact_ms_radius
from ..stability import monodromy_matrix, phase_adjoint, phase_map

__all__: list[str] = []

#: Up to this size of the second-moment operator (``n²``, ``M n²`` for
#: Markov modes) its eigenvectors come from the dense Kronecker monodromy;
#: above, from ARPACK on the matrix-free operator (dense ``eig`` with left
#: vectors took 30 ms at 100 unknowns, docs/benchmarks.md, structured
#: refinement).
DENSE_MAX_SIZE = 64

#: Stage 1 stops once ``ms_radius ≤ TARGET_FRACTION · min(1, r²)``: room
#: for the analysis LMI's strictness margin near the stability edge.
TARGET_FRACTION = 0.9

#: Loss fractions of the continuation (``1`` is the plant itself).
CONTINUATION = (0.0, 0.5, 0.8, 0.95, 1.0)

#: Seeded random restarts after the deterministic starts, perturbing the
#: best point by these multiples of its largest entry in turn.
RESTARTS = 6
RESTART_SCALES = (0.3, 1.0, 3.0)

#: Quasi-Newton iterations of stage 2 at most (each evaluation solves the
#: analysis LMI once).
STAGE2_ITERATIONS = 30

#: Markov modes' stage 2 (derivative-free): certified loops evaluated.
EVALUATIONS = 200

#: Stage 2 with a given ``eta`` aims this far above it (relative, at least
#: 1 absolute), so that the analysis LMI's strictness margin still fits.
ETA_STEP = 1e-3

#: Weak Wolfe line search constants (Lewis & Overton 2013).
WOLFE = (1e-4, 0.5)


# -- the loop as a function of the free entries ---------------------------------
class Loop:
    """``Acl_ki = A_ki + Bu_ki K_k E_k`` and its exact second-moment rate.

    ``weights`` are the mode probabilities (i.i.d.) or the transition
    matrices (Markov): the moment of phase ``k`` is one ``n × n`` matrix
    for i.i.d. modes and ``M`` of them (``Q_ki = E[ξξᵀ 1{σ_k = i}]``,
    :ref:`theory-markov`) for Markov modes.
    """

    def __init__(self, plant: JumpPlant, probabilities: np.ndarray,
                 transition: np.ndarray | None):
        self.A, self.Bu = plant.A, plant.Bu
        self.E = plant.readings()[0]                 # (N, M, nk, nx)
        self.p, self.T = probabilities, transition
        self.N, self.M, self.n = plant.A.shape[0], plant.A.shape[1], \
            plant.A.shape[-1]
        mask = np.zeros(plant.gain_shape(), bool)
        for k in range(self.N):
            rows = plant.active_inputs(k)
            cols = np.flatnonzero(np.any(self.E[k] != 0, axis=(0, 2)))
            mask[k][np.ix_(rows, cols)] = True
        self.mask = mask
        self.free = np.flatnonzero(mask)
        self.evaluations = 0
        self._warm: list = [None, None]

    def gains(self, x: np.ndarray) -> np.ndarray:
        K = np.zeros(self.mask.shape)
        K.flat[self.free] = x
        return K

    def rows(self, x: np.ndarray) -> np.ndarray:
        """``F_ki = K_k E_ki``, (N, M, nu, n): the same for every mode
        unless the reading is per mode (a gain per age of a buffered
        measurement)."""
        return np.einsum("kuj,kmjx->kmux", self.gains(x), self.E)

    def chain(self, dF: np.ndarray) -> np.ndarray:
        """A derivative in ``F_ki`` as one in the gains: ``Σ_i dF_ki
        E_kiᵀ``, in the gains' shape."""
        return np.einsum("kmux,kmjx->kuj", dF, self.E)

    def reading(self) -> np.ndarray:
        """Everything the gain reads at each phase, (N, nk, n): the union
        of the modes' readings (their blocks do not overlap)."""
        return np.abs(self.E).max(axis=1)

    def closed(self, x: np.ndarray) -> np.ndarray:
        return self.A + self.Bu @ self.rows(x)

    # one phase of the second-moment map and its adjoint: stability's kernel
    def _law(self, k: int) -> np.ndarray:
        """The mode law of phase ``k``: ``p_k``, or ``T_k`` (Markov)."""
        return self.p[k] if self.T is None else self.T[k]

    def _step(self, Acl: np.ndarray, k: int, Q: np.ndarray) -> np.ndarray:
        return phase_map(Acl[k], self._law(k), Q, self.T is not None)

    def _weights(self, k: int, V: np.ndarray) -> np.ndarray:
        """``W_ki`` with ``𝒯_k*(V)_i = Acl_kiᵀ W_ki Acl_ki``."""
        if self.T is None:
            return self.p[k][:, None, None] * V[None]
        return np.tensordot(self.T[k], V, axes=1)

    def _adjoint(self, Acl: np.ndarray, k: int, V: np.ndarray) -> np.ndarray:
        return phase_adjoint(Acl[k], self._law(k), V, self.T is not None)

    def _shape(self) -> tuple:
        return (self.n, self.n) if self.T is None else (self.M, self.n,
                                                        self.n)

    def _perron(self, Acl: np.ndarray) -> tuple[float, np.ndarray,
                                                np.ndarray]:
        """Spectral radius of the monodromy and its right/left eigenvectors."""
        shape = self._shape()
        size = int(np.prod(shape))
        if size <= DENSE_MAX_SIZE:
            Mono = monodromy_matrix(Acl, np.stack(
                [self._law(k) for k in range(self.N)]), self.T is not None)
            w, vl, vr = scipy.linalg.eig(Mono, left=True, right=True)
            # the Perron root ρ is an eigenvalue and no other has a larger
            # real part; others of modulus ρ (a cyclic period structure)
            # are complex, and their vectors give no gradient of ρ
            j = int(np.argmax(w.real))
            return float(abs(w[j])), vr[:, j].real.reshape(shape), \
                vl[:, j].real.reshape(shape)

        def forward(v):
            Q = v.reshape(shape)
            for k in range(self.N):
                Q = self._step(Acl, k, Q)
            return Q.ravel()

        def backward(v):
            V = v.reshape(shape)
            for k in reversed(range(self.N)):
                V = self._adjoint(Acl, k, V)
            return V.ravel()

        start = np.broadcast_to(np.eye(self.n), shape).ravel().copy()
        vecs = []
        lam = 0.0
        for j, apply in enumerate((forward, backward)):
            # warm start: the last evaluation's eigenvector (the line search
            # and BFGS move little between calls); deterministic all the same
            v0 = self._warm[j] if self._warm[j] is not None else start
            op = LinearOperator((size, size), matvec=apply, dtype=float)
            if not np.any(apply(v0)):
                return 0.0, v0.reshape(shape), v0.reshape(shape)
            try:
                # 'LR', not 'LM': see the dense branch
                vals, vec = eigs(op, k=1, which="LR", v0=v0, tol=1e-10,
                                 ncv=min(size - 1, 20), maxiter=20000)
            except (ArpackNoConvergence, ArpackError):
                return self._power(forward, backward, v0, shape)
            lam = max(lam, float(abs(vals[0])))
            v = vec[:, 0].real
            # Perron vectors are PSD: the sign with positive trace
            v = v if np.sum(v.reshape(shape) * start.reshape(shape)) >= 0 \
                else -v
            vecs.append(v.reshape(shape))
        self._warm = [vecs[0].ravel().copy(), vecs[1].ravel().copy()]
        return lam, vecs[0], vecs[1]

    @staticmethod
    def _power(forward, backward, v0, shape):
        """Power iteration: slow, but always defined (a positive map)."""
        q, v, lam = v0, v0, 0.0
        for _ in range(2000):
            q1 = forward(q)
            lam = float(np.linalg.norm(q1))
            if lam == 0:
                break
            q = q1 / lam
            v = backward(v)
            v = v / max(np.linalg.norm(v), 1e-300)
        return lam, q.reshape(shape), v.reshape(shape)

    def _gradient(self, Acl: np.ndarray, Qs: list, Vs: list) -> np.ndarray:
        """``∂ρ/∂K`` up to the scale ``⟨V_0, Q_0⟩``, in the gains' shape:
        ``2 Bu_kiᵀ W_ki Acl_ki Q_k`` per mode, chained to the gains."""
        # batched products (BLAS), not a 4-operand einsum (8 ms at n = 16)
        dF = np.array([2 * self.Bu[k].transpose(0, 2, 1)
                       @ self._weights(k, Vs[k + 1]) @ Acl[k] @ Qs[k]
                       for k in range(self.N)])
        return self.chain(dF)

    def rate(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        """``log ms_radius`` (per step) and its gradient in ``x``."""
        self.evaluations += 1
        Acl = self.closed(x)
        lam, Q0, V0 = self._perron(Acl)
        if not lam > 0:
            return -np.inf, np.zeros_like(x)
        # Q_k forward from Q_0, V_{k+1} backward from V_N = V_0
        Qs = [Q0]
        for k in range(self.N - 1):
            Qs.append(self._step(Acl, k, Qs[-1]))
        Vs: list[np.ndarray] = [V0] * (self.N + 1)
        for k in reversed(range(1, self.N)):
            Vs[k] = self._adjoint(Acl, k, Vs[k + 1])
        scale = float(np.sum(V0 * Q0))
        G = self._gradient(Acl, Qs, Vs)
        if scale == 0 or not np.isfinite(scale):
            return math.log(lam) / self.N, np.zeros_like(x)
        grad = G.flat[self.free] / (scale * lam * self.N)
        return math.log(lam) / self.N, grad


# -- BFGS with a weak Wolfe line search (HIFOO's scheme) -----------------------
def line_search(fg, x, f, g, d, deadline):
    c1, c2 = WOLFE
    slope = float(g @ d)
    lo, hi, t = 0.0, np.inf, 1.0
    best = (x, f, g)
    for _ in range(40):
        if deadline is not None and time.perf_counter() > deadline:
            break
        x1 = x + t * d
        f1, g1 = fg(x1)
        if f1 < best[1]:
            best = (x1, f1, g1)
        if not f1 <= f + c1 * t * slope:      # not enough descent
            hi = t
        elif not float(g1 @ d) >= c2 * slope:  # weak Wolfe: curvature
            lo = t
        else:
            return x1, f1, g1, True
        t = 0.5 * (lo + hi) if np.isfinite(hi) else 2.0 * lo
        if hi - lo < 1e-14 * max(1.0, lo):
            break
    return (*best, False)


def bfgs(fg, x, target, deadline, max_iterations):
    """Minimise ``fg`` from ``x`` until ``f ≤ target``, convergence or time.

    Returns ``(x, f, iterations, stopped)``.
    """
    f, g = fg(x)
    H = np.eye(x.size)
    first, reset = True, False
    for it in range(max_iterations):
        if f <= target:
            return x, f, it, "target"
        if deadline is not None and time.perf_counter() > deadline:
            return x, f, it, TIME_LIMIT
        if not np.all(np.isfinite(g)) or np.linalg.norm(g) < 1e-10:
            return x, f, it, "converged"
        d = -H @ g
        if not float(g @ d) < 0:
            H = np.eye(x.size)
            d = -g
        if first:
            # first step: a relative change of about 10 % of the gain
            d = d * min(1.0, 0.1 * max(1.0, np.linalg.norm(x))
                        / max(np.linalg.norm(d), 1e-300))
            first = False
        x1, f1, g1, ok = line_search(fg, x, f, g, d, deadline)
        if not f1 < f - 1e-12 * max(1.0, abs(f)):
            if reset:
                return x, f, it + 1, "converged"
            # a stale curvature model at a kink: once more along -g
            H, reset = np.eye(x.size), True
            continue
        reset = False
        s, y = x1 - x, g1 - g
        sy = float(s @ y)
        if sy > 1e-16 * np.linalg.norm(s) * np.linalg.norm(y):
            rho = 1.0 / sy
            Hy = H @ y
            H = (H - rho * (np.outer(s, Hy) + np.outer(Hy, s))
                 + (rho * rho * float(y @ Hy) + rho) * np.outer(s, s))
        x, f, g = x1, f1, g1
    return x, f, max_iterations, "converged"


# -- starting points ------------------------------------------------------------
def lq_gain(plant: JumpPlant, probabilities: np.ndarray,
             sweeps: int = 500) -> np.ndarray:
    """The unstructured (``E_k = I``) periodic mean-square LQ gain.

    The coupled Riccati recursion of the expected cost ``Σ ‖ξ‖² + ‖u‖²``
    for i.i.d. modes (:ref:`theory-synthesis`'s exact setting), iterated
    backwards over the period; its gain sees every coordinate. Used only as a
    starting point: with Markov modes it is run on the marginals.
    """
    N, n, nu = plant.period, plant.shape["nx"], plant.shape["nu"]
    A, B, p = plant.A, plant.Bu, probabilities
    Pn = np.eye(n)
    G = np.zeros((N, nu, n))
    for _ in range(sweeps):
        before = Pn
        for k in reversed(range(N)):
            # Σ_i p_i Xᵀ P Y as batched products (a four-operand einsum
            # loops over every index: M n⁴ per term)
            w = p[k][:, None, None]
            PA, PB = Pn @ A[k], Pn @ B[k]
            At, Bt = A[k].transpose(0, 2, 1), B[k].transpose(0, 2, 1)
            S = np.sum(w * (At @ PA), axis=0)
            R = np.eye(nu) + np.sum(w * (Bt @ PB), axis=0)
            Nb = np.sum(w * (Bt @ PA), axis=0)
            G[k] = -np.linalg.solve(R, Nb)
            Pn = np.eye(n) + S + Nb.T @ G[k]
            Pn = 0.5 * (Pn + Pn.T)
        if not np.all(np.isfinite(Pn)) or np.linalg.norm(Pn) > 1e12:
            break
        if np.linalg.norm(Pn - before) <= 1e-10 * np.linalg.norm(Pn):
            break
    return G if np.all(np.isfinite(G)) else np.zeros_like(G)


def restrict(loop: Loop, G: np.ndarray) -> np.ndarray:
    """Free entries of ``K_k = G_k E_kᵀ`` (the full gain on what is known)."""
    return np.einsum("kux,kjx->kuj", G, loop.reading()).flat[
        loop.free].copy()


def projected(plant: JumpPlant, loop: Loop, G: np.ndarray
               ) -> np.ndarray | None:
    """Free entries of the structured gain closest to a full-information
    gain ``G`` (shape (N, nu, nx)) in that loop's own stationary moments.

    ``K_k`` minimises ``Σ_i p_ki tr((G_k − K_k E_ki) Q_ki (G_k − K_k
    E_ki)ᵀ)`` over the free entries, ``Q`` the stationary second moment of
    ``ξ⁺ = (A + Bu G) ξ + v`` under unit white ``v``: where the gain reads
    an old measurement, the correlation with the present state carries
    ``G`` to it (for ``y = x`` read ``a`` steps late, about ``G A^a``).
    None when ``G``'s loop is not mean-square stable.
    """
    from ..jump import JumpStateSpace
    from ..stationary import stationary_covariances
    N, M, n = loop.N, loop.M, loop.n
    A = plant.A + plant.Bu @ G[:, None]
    eye = np.broadcast_to(np.eye(n), (N, M, n, n))
    zeros = np.zeros((N, M, 1, n))
    CL = JumpStateSpace(A, eye, zeros, np.zeros((N, M, 1, n)),
                        None if plant.transition is not None
                        else plant.probabilities, plant.dt,
                        transition=plant.transition)
    if not exact_ms_radius(CL) < 1.0:
        return None
    Q = stationary_covariances(CL)
    if Q.ndim == 3:                       # i.i.d.: Q_ki = p_ki Q_k
        Q = plant.probabilities[:, :, None, None] * Q[:, None]
    E = loop.E
    K = np.zeros(loop.mask.shape)
    for k in range(N):
        lhs = np.einsum("mjx,mxy,miy->ji", E[k], Q[k], E[k])
        rhs = np.einsum("ux,mxy,miy->ui", G[k], Q[k], E[k])
        for u in range(K.shape[1]):
            cols = np.flatnonzero(loop.mask[k, u])
            if cols.size:
                K[k, u, cols] = np.linalg.lstsq(
                    lhs[np.ix_(cols, cols)], rhs[u, cols], rcond=None)[0]
    return K.flat[loop.free].copy() if np.all(np.isfinite(K)) else None


def continued(plant: JumpPlant, t: float
               ) -> tuple[np.ndarray, np.ndarray | None]:
    """Modes interpolated from the loss-free one (``t = 0``) to the plant's."""
    nominal = np.eye(plant.probabilities.shape[1])[plant.nominal]
    p = (1 - t) * nominal + t * plant.probabilities
    if plant.transition is None:
        return p, None
    # from every mode, the next phase's loss-free mode
    ahead = np.roll(nominal, -1, axis=0)[:, None, :]
    return p, (1 - t) * ahead + t * plant.transition


# -- stage 2: the analysis LMI's optimal η as a function of the gain ------------
class IndexObjective:
    """``η*(K)``: the analysis LMI's optimum (:ref:`theory-passivity`) and its
    gradient.

    By the envelope theorem, with ``Z_k ≽ 0`` the dual of ``Θ_k ≼ -t·S_k``
    at the optimum, ``∂η*/∂K_k = -∂⟨Z_k, Θ_k⟩/∂K_k``
    ``= -2 Σ_i p_ki (Bu_kiᵀ [P_{k+1} F_ki Z_k]_ξ - Du_kiᵀ [Z_k]_wξ) E_kᵀ``
    with ``F_ki = [Acl_ki, Bw_ki]`` (the stationarity in η normalises
    ``Z``). A guide for the search only: the η returned is certified from
    ``P`` by :func:`control_ncs.verify.certify_index`.
    """

    def __init__(self, plant: JumpPlant, loop: Loop, decay: float):
        self.plant, self.loop, self.decay = plant, loop, decay
        self.evaluations = 0

    def value(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        """``-η*`` (to minimise) and its gradient; ``inf`` if infeasible."""
        from ..lmi import DEFAULT_MARGIN, analysis_model, solve
        self.evaluations += 1
        plant, loop = self.plant, self.loop
        K = loop.gains(x)
        CL = plant.close(K)
        if not exact_ms_radius(CL) < min(1.0, self.decay ** 2):
            return np.inf, np.zeros_like(x)
        model = analysis_model(CL, None, DEFAULT_MARGIN, self.decay)
        report = solve(model.problem)
        if report.status not in ("optimal", "optimal_inaccurate"):
            return np.inf, np.zeros_like(x)
        model.check_current()
        theta = model.theta_duals()
        P = np.array([Pk.value for Pk in model.P])
        n = plant.shape["nx"]
        N = plant.period
        F = np.concatenate([loop.closed(x), plant.Bw], axis=-1)
        G = np.zeros(loop.mask.shape)
        for k in range(N):
            Z = theta[k]
            Z = 0.5 * (Z + Z.T)
            p = plant.probabilities[k]
            PFZ = P[(k + 1) % N] @ F[k] @ Z                  # (M, n, n+m)
            BtPFZ = plant.Bu[k].transpose(0, 2, 1) @ PFZ[:, :, :n]
            DtZ = plant.Du[k].transpose(0, 2, 1) @ Z[n:, :n]
            G[k] = 2 * np.tensordot(
                p, (BtPFZ - DtZ) @ loop.E[k].transpose(0, 2, 1), axes=1)
        return -float(report.value or 0.0), G.flat[loop.free].copy()


def certificate_of(CL, eta, decay):
    """The exact certificate of a closed loop (``None`` if none verified)."""
    from ..passivity import passivity_certificate
    try:
        res = passivity_certificate(CL, eta, decay=decay)
    except CertificationError:
        return None
    if not res.passive or res.certificate is None:
        return None
    return res.certificate


class Reached(Exception):
    """The derivative-free stage met the requested level."""


def certified_search(plant: JumpPlant, loop: Loop, K: np.ndarray,
                      cert: Any, eta: float | None, decay: float,
                      deadline: float | None) -> tuple[np.ndarray, Any]:
    """Nelder–Mead on ``-η`` of the analysis certificate of each loop
    (``EVALUATIONS`` at most), from ``K``; returns the best certified gain
    met (``K`` and ``cert`` when none beats them, or, ``eta`` given, when
    none reaches it)."""
    best = {"K": K, "cert": cert}
    seen: dict[bytes, float] = {}

    def certify(x: np.ndarray) -> float:
        key = x.tobytes()
        if key in seen:         # the simplex may return to a point
            return seen[key]
        if deadline is not None and time.perf_counter() > deadline:
            return math.inf
        seen[key] = value = level(x)
        return value

    def level(x: np.ndarray) -> float:
        Kx = loop.gains(x)
        # the certificate refutes a loop that is not mean-square stable
        # (ms_radius ≥ min(1, r²), a certified bracket) before any solve
        c = certificate_of(plant.close(Kx), None, decay)
        if c is None or not c.verified:
            return math.inf
        if best["cert"] is None or c.eta > best["cert"].eta:
            best.update(K=Kx, cert=c)
        if eta is not None and c.eta >= eta:
            raise Reached
        return -float(c.eta)

    try:
        minimize(certify, K.flat[loop.free].copy(), method="Nelder-Mead",
                 options=dict(maxfev=EVALUATIONS, xatol=1e-5, fatol=1e-7))
    except Reached:
        pass
    if eta is not None and (best["cert"] is None or best["cert"].eta < eta):
        return K, cert            # nothing met the level asked
    return best["K"], best["cert"]


# -- a proof that no gain helps ---------------------------------------------------
def autonomous_rate(plant: JumpPlant, bound: float | None = None
                    ) -> tuple[float, np.ndarray]:
    """The exact rate of the part of the loop no gain reaches, and its states.

    The largest set ``S`` of coordinates with ``Bu_ki[S] = 0`` and
    ``A_ki[S, not S] = 0`` for every phase and mode evolves on its own,
    ``ξ_S⁺ = A_ki[S, S] ξ_S``, whatever ``K`` (e.g. the predictor's
    estimation error, :ref:`theory-predictor`). The second moment of ``ξ_S`` is
    a block of the loop's, so every closed loop's ``ms_radius`` is at least
    that of this block (:ref:`theory-mss`): when it is ``≥ min(1, r²)`` no gain
    of any structure is certified. Returns ``(rate, S)``; ``(0.0, [])`` when
    ``S`` is empty. With ``bound`` given, ``rate`` is a certified upper
    bound on the rate when one below ``bound`` is found cheaply
    (:func:`_rate_upper`: then nothing is refuted, and the exact rate of
    a large block is not computed).
    """
    from ..jump import jss
    S = np.flatnonzero(~np.any(plant.Bu != 0, axis=(0, 1, 3)))
    while S.size:
        rest = np.setdiff1d(np.arange(plant.shape["nx"]), S)
        coupled = np.any(plant.A[..., S, :][..., rest] != 0, axis=(0, 1, 3))
        if not coupled.any():
            break
        S = S[~coupled]
    if not S.size:
        return 0.0, S
    A = plant.A[..., S, :][..., S]
    T = plant.transition
    if T is not None:
        # modes no transition enters at any phase: the moments there vanish
        # after one step (a zero diagonal block of the operator), so the
        # rate is that of the others; dropped, as ARPACK and GMRES crawl on
        # the nilpotent part (minutes for a buffer of 5)
        keep = np.flatnonzero(entered_modes(T).any(axis=0))
        A, T = A[:, keep], T[:, keep][:, :, keep]
    N, M = A.shape[:2]
    if bound is not None:
        upper = _rate_upper(A, plant.probabilities if T is None else None, T,
                            bound)
        if upper < bound:
            return upper, S
    zeros = np.zeros((N, M, 1, 1))
    sub = jss(A, np.zeros((N, M, S.size, 1)), np.zeros((N, M, 1, S.size)),
              zeros, None if T is not None else plant.probabilities,
              transition=T)
    return exact_ms_radius(sub), S


def _rate_upper(A: np.ndarray, p: np.ndarray | None, T: np.ndarray | None,
                bound: float, terms: int = 60) -> float:
    """An upper bound on the per-step mean-square rate of ``ξ⁺ = A_ki ξ``
    (laws ``p`` or ``T``), aimed at proving it below ``bound``:
    Collatz–Wielandt, ``𝒯(Y) ≼ t Y`` with ``Y ≻ 0`` proves ``ρ(𝒯) ≤ t``
    for the period's positive map ``𝒯``. ``Y = Σ_{j<terms} (𝒯/c)^j(I)``,
    ``c = bound^N``: when ``ρ(𝒯) < c`` the series converges and ``𝒯(Y) =
    c (Y - I)`` up to its tail, so ``t < c``. ``inf`` when ``Y`` is not
    positive definite or the series overflows."""
    N, M, n = A.shape[0], A.shape[1], A.shape[-1]
    markov = T is not None
    eye = np.broadcast_to(np.eye(n), (M, n, n)) if markov else np.eye(n)
    laws = T if T is not None else p
    assert laws is not None

    def period(Q: np.ndarray) -> np.ndarray:
        for k in range(N):
            Q = phase_map(A[k], laws[k], Q, markov)
        return Q

    c = bound ** N
    Y = np.array(eye, float)
    with np.errstate(all="ignore"):
        for _ in range(terms - 1):
            Y = eye + period(Y) / c
            if not np.all(np.isfinite(Y)):
                return math.inf
        Z = period(Y)
    Ys, Zs = (Y, Z) if markov else (Y[None], Z[None])
    top = 0.0
    for Yj, Zj in zip(Ys, Zs):
        try:
            L = np.linalg.cholesky(0.5 * (Yj + Yj.T))
        except np.linalg.LinAlgError:
            return math.inf
        half = np.linalg.solve(L, Zj)
        W = np.linalg.solve(L, half.T)
        top = max(top, float(np.linalg.eigvalsh(0.5 * (W + W.T))[-1]))
    return top ** (1.0 / N) if top > 0 else 0.0
