"""Local refinement of structured gains on the exact quantities
(:ref:`theory-mss`, :ref:`theory-passivity`, :ref:`theory-synthesis`).

Where the gain is structured (a sensor schedule zeroes the columns of
silent sensors, a hold actuator or the predictor's ``[I 0]`` hides part of
the loop's state, :ref:`theory-synthesis`, :ref:`theory-predictor`,
:ref:`theory-jump-system`) the synthesis LMIs ``'block'`` and ``'extended'``
are only sufficient, and 2-3 times too pessimistic in the loss they accept
(the batch reactor below). This module works on the gain's free entries directly, with
the exact figures of a *given* gain:

1. **stabilise**: minimise the exact mean-square rate ``ms_radius``
(:ref:`theory-mss`)
   over the free entries of ``K_k``. The rate is the spectral radius of the
   second-moment monodromy, nonsmooth where its leading eigenvalue is
   multiple; its gradient where it is simple comes from the right and left
   Perron eigenvectors ``Q``, ``V`` propagated over the period:
   ``∂ρ/∂K_k = 2 Σ_i w_ki Bu_kiᵀ V_{k+1} Acl_ki Q_k E_kᵀ / ⟨V_0, Q_0⟩``.
   BFGS with a weak Wolfe line search minimises it, as HIFOO does for
   structured H∞ (Lewis & Overton, *Nonsmooth optimization via
   quasi-Newton methods*, Math. Program. 2013): the inverse-Hessian
   approximation becomes ill-conditioned along the nonsmooth directions
   instead of failing, and the line search never needs a derivative that
   does not exist.
2. **certify and improve η**: the η of a fixed gain comes only from the
   analysis of that closed loop, :func:`control_ncs.passivity_certificate`
   (exactly verified; never the optimiser's number). Where it falls short
   of ``eta`` (or ``eta`` is None) the same quasi-Newton scheme climbs the
   analysis LMI's optimum ``η*(K)`` over the free entries, its gradient
   from the LMI's dual variables (envelope theorem, :class:`_Index`); the
   gain it ends at is certified again by the analysis, and kept only if
   that certificate is better.

Why this stage 2, by measurement (the batch reactor of the tests, sensor
schedule, actuator loss 0.6, the gain of least ``ms_radius`` = 0.972,
analysis η = -282.07): alternating convex steps (``P`` fixed: an LMI in
``(K, η)`` by a Schur complement; ``K`` fixed: the analysis LMI) are
monotone but moved η from -282.067 to -282.059 in two rounds (the P-step
leaves the K-step no room: the constraint is tight at the optimum); the
dual-gradient climb reached -224.4 in 16 iterations (1.7 s). A
convex-concave (inner approximation) iteration was not implemented: it
linearises the same bilinear term around the analysis optimum ``(P, K)``,
where the alternation above already finds no room. At a fixed level such as ``eta=-100`` stage 1 sets
most of the certified loss threshold and stage 2 the rest: on the sensor
schedule case stage 1 alone certifies nothing at loss 0.55 (η = -107
there), with stage 2 the loss 0.57 is certified.

Starting points: a given gain (e.g. the sufficient LMI's), the
unstructured (full-information) mean-square LQ gain restricted to the
structure and the zero gain, taken in the order of their measured rate,
lowest first; then, if none reaches the target rate (or, ``eta`` given, a
certificate), a continuation in the loss probability (modes interpolated
from the loss-free one to the plant's, each level started from the last)
and seeded random restarts. The search stops at the first gain certified
at a given ``eta``. Everything is deterministic given ``seed``; the work
is bounded by ``time_limit``. Before any search the synthesis checks the
one exact refutation available without a solver
(:func:`autonomous_rate`: states no gain reaches).

What it guarantees: a gain returned as certified passed
:func:`control_ncs.verify.check_certificate` (``Θ_k ≺ 0``, ``P_k ≻ 0``,
``ms_radius < min(1, r²)``). What it does not: global optimality — the
problem is nonconvex, a local method can stop in a local minimum, and a
failure to certify proves nothing.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg
from control.exception import ControlArgument, ControlDimension
from scipy.optimize import minimize
from scipy.sparse.linalg import (ArpackError, ArpackNoConvergence,
                                 LinearOperator, eigs)

from ._checks import (choice, decay_bound, finite_real, positive_int,
                      positive_real, real_array)
from ._results import Result
from .exceptions import CERTIFIED, NOT_FOUND, TIME_LIMIT, CertificationError
from .gain import PeriodicGain, actuators, controllers
from .openloop import JumpPlant
from .plant import NetworkedStateSpace
from .stability import ms_radius as exact_ms_radius
from .stability import phase_adjoint, phase_map, phase_matrix
from .verify import Certificate

__all__ = ["refine_gain", "RefineResult"]

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


@dataclass(repr=False)
class RefineResult(Result):
    """What :func:`refine_gain` found, and how far it moved the gain.

    Attributes
    ----------
    gains : ndarray, shape (N, nu, nk)
        The refined ``K_k`` (zero outside the free entries).
    verified : bool
        True when ``certificate`` passed the exact checks.
    certificate : Certificate or None
        The exact certificate of the closed loop with ``gains``
        (:func:`control_ncs.verify.check_certificate`); None when no
        certificate was found.
    eta : float
        Certified dissipation (``nan`` when not verified).
    ms_radius : float
        Exact per-step mean-square rate of the closed loop with ``gains``.
    start : str
        Which starting point led to ``gains``: ``'given'``, ``'full'``
        (the unstructured gain restricted), ``'zero'``,
        ``'continuation'`` or ``'restart'``.
    ms_radius_before : float
        The rate at that starting point.
    eta_before : float
        The η certified at the first stabilising gain, before stage 2
        (``nan`` if none was certified there).
    iterations : int
        Quasi-Newton iterations of stage 1 plus alternations of stage 2.
    evaluations : int
        Evaluations of the rate and its gradient.
    stopped : str
        Why it stopped: ``'certified'``, ``'converged'``, ``'time_limit'``.
    message : str
        One sentence for humans.
    starts : list of tuple
        ``(start, ms_radius at the start, ms_radius reached)`` per start
        tried, in order.
    time : float
        Seconds spent.

    Examples
    --------
    >>> P = ncs.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]],
    ...         [[1.0, 0.0], [0.0, 0.0]], nmeas=1, ncon=1, actuator_loss=0.1)
    >>> res = ncs.refine_gain(P, eta=0.0)
    >>> res.verified, res.stopped, bool(res.ms_radius < 1)
    (True, 'certified', True)
    """

    gains: np.ndarray
    verified: bool
    certificate: Certificate | None
    eta: float
    ms_radius: float
    start: str
    ms_radius_before: float
    eta_before: float
    iterations: int
    evaluations: int
    stopped: str
    message: str
    starts: list = field(default_factory=list)
    time: float = 0.0

    _repr_fields = ("eta", "ms_radius", "start", "iterations", "stopped")

    @property
    def success(self) -> bool:
        """``verified``: the refined gain's certificate passed."""
        return self.verified

    @property
    def status(self) -> str:
        """``'certified'``, or ``'time_limit'`` / ``'not_found'``."""
        if self.verified:
            return CERTIFIED
        return TIME_LIMIT if self.stopped == TIME_LIMIT else NOT_FOUND

    def _details(self) -> list[str]:
        return [f"ms_radius {self.ms_radius_before:.6g} -> "
                f"{self.ms_radius:.6g} from the start {self.start!r}",
                f"eta {self.eta_before:.6g} -> {self.eta:.6g}, "
                f"{self.iterations} iterations, {self.time:.3f} s"]


# -- the loop as a function of the free entries ---------------------------------
class _Loop:
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
            Mono = np.eye(size)
            for k in range(self.N):
                Mono = phase_matrix(Acl[k], self._law(k),
                                    self.T is not None) @ Mono
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
def _line_search(fg, x, f, g, d, deadline):
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


def _bfgs(fg, x, target, deadline, max_iterations):
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
        x1, f1, g1, ok = _line_search(fg, x, f, g, d, deadline)
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
def _lq_gain(plant: JumpPlant, probabilities: np.ndarray,
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
            S = np.einsum("m,mxa,xy,myb->ab", p[k], A[k], Pn, A[k])
            R = np.eye(nu) + np.einsum("m,mxa,xy,myb->ab", p[k], B[k], Pn,
                                       B[k])
            Nb = np.einsum("m,mxa,xy,myb->ab", p[k], B[k], Pn, A[k])
            G[k] = -np.linalg.solve(R, Nb)
            Pn = np.eye(n) + S + Nb.T @ G[k]
            Pn = 0.5 * (Pn + Pn.T)
        if not np.all(np.isfinite(Pn)) or np.linalg.norm(Pn) > 1e12:
            break
        if np.linalg.norm(Pn - before) <= 1e-10 * np.linalg.norm(Pn):
            break
    return G if np.all(np.isfinite(G)) else np.zeros_like(G)


def _restrict(loop: _Loop, G: np.ndarray) -> np.ndarray:
    """Free entries of ``K_k = G_k E_kᵀ`` (the full gain on what is known)."""
    return np.einsum("kux,kjx->kuj", G, loop.reading()).flat[
        loop.free].copy()


def _projected(plant: JumpPlant, loop: _Loop, G: np.ndarray
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
    from .jump import JumpStateSpace
    from .stability import stationary_covariances
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


def _continued(plant: JumpPlant, t: float
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
class _Index:
    """``η*(K)``: the analysis LMI's optimum (:ref:`theory-passivity`) and its
    gradient.

    By the envelope theorem, with ``Z_k ≽ 0`` the dual of ``Θ_k ≼ -t·S_k``
    at the optimum, ``∂η*/∂K_k = -∂⟨Z_k, Θ_k⟩/∂K_k``
    ``= -2 Σ_i p_ki (Bu_kiᵀ [P_{k+1} F_ki Z_k]_ξ - Du_kiᵀ [Z_k]_wξ) E_kᵀ``
    with ``F_ki = [Acl_ki, Bw_ki]`` (the stationarity in η normalises
    ``Z``). A guide for the search only: the η returned is certified from
    ``P`` by :func:`control_ncs.verify.certify_index`.
    """

    def __init__(self, plant: JumpPlant, loop: _Loop, decay: float):
        self.plant, self.loop, self.decay = plant, loop, decay
        self.evaluations = 0

    def value(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        """``-η*`` (to minimise) and its gradient; ``inf`` if infeasible."""
        from .lmi import DEFAULT_MARGIN, analysis_model, solve
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


def _analysis(CL, eta, decay):
    """The exact certificate of a closed loop (``None`` if none verified)."""
    from .passivity import passivity_certificate
    try:
        res = passivity_certificate(CL, eta, decay=decay)
    except CertificationError:
        return None
    if not res.passive or res.certificate is None:
        return None
    return res.certificate


class _Reached(Exception):
    """The derivative-free stage met the requested level."""


def _certified_search(plant: JumpPlant, loop: _Loop, K: np.ndarray,
                      cert: Any, eta: float | None, decay: float,
                      deadline: float | None) -> tuple[np.ndarray, Any]:
    """Nelder–Mead on ``-η`` of the analysis certificate of each loop
    (``EVALUATIONS`` at most), from ``K``; returns the best certified gain
    met (``K`` and ``cert`` when none beats them, or, ``eta`` given, when
    none reaches it)."""
    best = {"K": K, "cert": cert}
    bound = min(1.0, decay ** 2)

    def certify(x: np.ndarray) -> float:
        if deadline is not None and time.perf_counter() > deadline:
            return math.inf
        Kx = loop.gains(x)
        CL = plant.close(Kx)
        if not exact_ms_radius(CL) < bound:
            return math.inf
        c = _analysis(CL, None, decay)
        if c is None or not c.verified:
            return math.inf
        if best["cert"] is None or c.eta > best["cert"].eta:
            best.update(K=Kx, cert=c)
        if eta is not None and c.eta >= eta:
            raise _Reached
        return -float(c.eta)

    try:
        minimize(certify, K.flat[loop.free].copy(), method="Nelder-Mead",
                 options=dict(maxfev=EVALUATIONS, xatol=1e-5, fatol=1e-7))
    except _Reached:
        pass
    if eta is not None and (best["cert"] is None or best["cert"].eta < eta):
        return K, cert            # nothing met the level asked
    return best["K"], best["cert"]


# -- the driver -----------------------------------------------------------------
def _refine(plant: JumpPlant, eta: float | None, decay: float,
            given: np.ndarray | None, rng: np.random.Generator,
            deadline: float | None, max_iterations: int) -> RefineResult:
    """Stages 1 and 2 on checked arguments."""
    began = time.perf_counter()
    loop = _Loop(plant, plant.probabilities, plant.transition)
    bound = min(1.0, decay ** 2)
    target = math.log(TARGET_FRACTION * bound)
    edge = math.log(bound)
    iterations = 0
    tried: list[tuple] = []

    def out_of_time():
        return deadline is not None and time.perf_counter() > deadline

    certified: dict = {}

    def settled(f, x):
        """At the target rate, or (a level given) already certified there:
        further starts are not needed."""
        if f <= target:
            return True
        if eta is None or not f < edge:
            return False
        key = x.tobytes()
        if key not in certified:
            certified[key] = _analysis(plant.close(loop.gains(x)), eta,
                                       decay)
        return certified[key] is not None

    # starting points, best (lowest rate) first
    starts = []
    if given is not None:
        starts.append(("given", given.flat[loop.free].copy()))
    G = _lq_gain(plant, plant.probabilities)
    projected = _projected(plant, loop, G)
    if projected is not None:
        starts.append(("projected", projected))
    starts.append(("full", _restrict(loop, G)))
    starts.append(("zero", np.zeros(loop.free.size)))
    scored = sorted(((loop.rate(x)[0], j, name, x)
                     for j, (name, x) in enumerate(starts)),
                    key=lambda s: (s[0], s[1]))
    best = None            # (f, x, start, f at start)
    stopped = "converged"
    for f0, _, name, x in scored:
        if out_of_time():
            stopped = TIME_LIMIT
            break
        x, f, its, why = _bfgs(loop.rate, x, target, deadline,
                               max_iterations)
        iterations += its
        tried.append((name, math.exp(f0), math.exp(f)))
        if best is None or f < best[0]:
            best = (f, x, name, f0)
        if why == TIME_LIMIT:
            stopped = TIME_LIMIT
        if why == TIME_LIMIT or settled(f, x):
            break
    if best is None:
        f0, _, name, x = scored[0]
        best = (f0, x, name, f0)
    if (not settled(best[0], best[1]) and plant.nominal is not None
            and not out_of_time()):
        # continuation in the loss probability from the best start
        x = starts[[s[0] for s in starts].index(best[2])][1]
        f0 = loop.rate(x)[0]
        for t in CONTINUATION:
            level = _Loop(plant, *_continued(plant, t))
            x, f, its, why = _bfgs(level.rate, x,
                                   target if t == 1.0 else -np.inf,
                                   deadline, max_iterations)
            iterations += its
            loop.evaluations += level.evaluations
            if why == TIME_LIMIT:
                stopped = TIME_LIMIT
                break
        f = loop.rate(x)[0]
        tried.append(("continuation", math.exp(f0), math.exp(f)))
        if f < best[0]:
            best = (f, x, "continuation", f0)
    for restart in range(RESTARTS):
        if settled(best[0], best[1]) or out_of_time():
            break
        scale = max(1.0, float(np.abs(best[1]).max(initial=0.0)))
        spread = RESTART_SCALES[restart % len(RESTART_SCALES)]
        x = best[1] + spread * scale * rng.standard_normal(best[1].size)
        f0 = loop.rate(x)[0]
        x, f, its, why = _bfgs(loop.rate, x, target, deadline,
                               max_iterations)
        iterations += its
        tried.append(("restart", math.exp(f0), math.exp(f)))
        if f < best[0]:
            best = (f, x, "restart", f0)
    f, x, start, f0 = best
    K = loop.gains(x)

    def result(K, cert, eta_before, stopped, message):
        rate = exact_ms_radius(plant.close(K))
        ok = cert is not None and cert.verified
        return RefineResult(
            K, ok, cert, float(cert.eta) if ok else float("nan"), rate,
            start, math.exp(f0), eta_before, iterations, loop.evaluations,
            stopped, message, tried, time.perf_counter() - began)

    if not f < edge:
        why = ("the time limit was reached" if stopped == TIME_LIMIT else
               "the local search converged")
        return result(K, None, float("nan"), stopped,
                      f"refinement found no mean-square stabilising gain: "
                      f"{why} at ms_radius {math.exp(f):.6g} >= "
                      f"{bound:.6g} (a local method: nothing is proven)")
    cert = certified.get(x.tobytes()) if x.tobytes() in certified \
        else _analysis(plant.close(K), eta, decay)
    eta_before = float(cert.eta) if cert is not None else float("nan")
    if (cert is None or eta is None) and plant.is_iid and not out_of_time():
        # stage 2: the certified η of a fixed gain is the analysis LMI's;
        # climb its optimum η*(K) (the LMI of theory: passivity is written for
        # i.i.d. modes: Markov loops keep the stage-1 gain)
        index = _Index(plant, loop, decay)
        x0 = K.flat[loop.free].copy()
        goal = -np.inf if eta is None else -(eta + ETA_STEP * max(
            1.0, abs(eta)))
        x2, _, its, why = _bfgs(index.value, x0, goal, deadline,
                                min(max_iterations, STAGE2_ITERATIONS))
        iterations += its
        loop.evaluations += index.evaluations
        if why == TIME_LIMIT:
            stopped = TIME_LIMIT
        if not np.array_equal(x2, x0):
            K2 = loop.gains(x2)
            cert2 = _analysis(plant.close(K2), eta, decay)
            if cert2 is not None and (cert is None or cert2.eta > cert.eta):
                K, cert = K2, cert2
    elif (cert is None or eta is None) and not out_of_time():
        # Markov modes: the gradient above is written for i.i.d. modes; a
        # derivative-free search on the certified η itself, keeping the best
        # certified loop it meets
        K, cert = _certified_search(plant, loop, K, cert, eta, decay,
                                    deadline)
    if cert is not None and cert.verified:
        if stopped != TIME_LIMIT:
            stopped = CERTIFIED
        what = ("certified" if stopped == CERTIFIED else
                "certified before the time limit stopped the refinement")
        return result(K, cert, eta_before, stopped,
                      f"refinement {what}: eta = {cert.eta:.6g}, ms_radius "
                      f"{math.exp(f0):.6g} at the start ({start}) -> "
                      f"{cert.ms_radius:.6g}")
    why = ("the time limit was reached" if stopped == TIME_LIMIT or
           out_of_time() else "no certificate was found")
    return result(K, None, eta_before,
                  TIME_LIMIT if out_of_time() else stopped,
                  f"refinement reached ms_radius {math.exp(f):.6g} but "
                  f"{why} at eta = {eta} (a local method: nothing is "
                  f"proven)")


# -- a proof that no gain helps ---------------------------------------------------
def autonomous_rate(plant: JumpPlant) -> tuple[float, np.ndarray]:
    """The exact rate of the part of the loop no gain reaches, and its states.

    The largest set ``S`` of coordinates with ``Bu_ki[S] = 0`` and
    ``A_ki[S, not S] = 0`` for every phase and mode evolves on its own,
    ``ξ_S⁺ = A_ki[S, S] ξ_S``, whatever ``K`` (e.g. the predictor's
    estimation error, :ref:`theory-predictor`). The second moment of ``ξ_S`` is
    a block of the loop's, so every closed loop's ``ms_radius`` is at least
    that of this block (:ref:`theory-mss`): when it is ``≥ min(1, r²)`` no gain
    of any structure is certified. Returns ``(rate, S)``; ``(0.0, [])`` when
    ``S`` is empty.
    """
    from .jump import jss
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
    N, M = A.shape[:2]
    zeros = np.zeros((N, M, 1, 1))
    sub = jss(A, np.zeros((N, M, S.size, 1)), np.zeros((N, M, 1, S.size)),
              zeros, None if plant.transition is not None
              else plant.probabilities, transition=plant.transition)
    return exact_ms_radius(sub), S


# -- public entry ----------------------------------------------------------------
def refine_gain(P: NetworkedStateSpace | JumpPlant, eta: float | None = None,
                *, decay: float | None = None, controller: str = "static",
                actuator: str = "zero", gains: Any = None, seed: Any = 0,
                time_limit: float | None = 60.0, max_iterations: int = 200
                ) -> RefineResult:
    """Locally refine a structured gain on the exact quantities.

    Minimises the exact mean-square rate ``ms_radius`` (:ref:`theory-mss`) over
    the free entries of ``K_k`` (those a scheduled sensor and actuator leave;
    the zero pattern of the structure) until it is below
    ``TARGET_FRACTION · min(1, r²)``, then certifies the gain with the
    analysis of the closed loop (:func:`control_ncs.passivity_certificate`)
    and, where that does not reach ``eta`` (or ``eta`` is None), climbs the
    analysis LMI's optimal η over the same entries. Starts, best first: the
    given ``gains``, the unstructured mean-square LQ gain restricted to the
    structure, zero; then a continuation in the loss probability and
    seeded random restarts (see the module's notes).

    A local method: it finds and proves a gain (``verified``), or it
    proves nothing; it never proves that no gain exists.

    Parameters
    ----------
    P : NetworkedStateSpace or JumpPlant
        Plant with its network (built with ``controller``, ``actuator``),
        or the open-loop jump system a strategy built
        (:func:`control_ncs.build`).
    eta : float, optional
        Dissipation to certify; None: the largest the method reaches.
    decay : float in (0, 1], optional
        Mean-square decay bound ``r`` (``ms_radius < r²``).
    controller : {'static', 'predictor', 'estimator'}
        As :func:`control_ncs.build` (ignored for a JumpPlant).
    actuator : {'zero', 'hold'}
        As :func:`control_ncs.build` (ignored for a JumpPlant).
    gains : array_like or PeriodicGain, optional
        A starting gain of shape ``(N, nu, nk)`` (e.g. an LMI's); entries
        outside the structure are ignored.
    seed : int, numpy.random.Generator or None, optional
        Seed of the random restarts (default 0: the same gain every call).
    time_limit : float or None, optional
        Seconds (default 60; None: no limit). The search stops at the
        limit with ``stopped == 'time_limit'`` and says so in ``message``.
    max_iterations : int, optional
        Quasi-Newton iterations per local search.

    Returns
    -------
    RefineResult
        ``verified`` only with an exact certificate.

    Raises
    ------
    ControlArgument
        ``P`` is not a plant, an unknown ``controller`` or ``actuator``.
    ControlDimension
        ``gains`` of the wrong shape; ``w`` and ``z`` of different size.
    ValueError
        ``eta`` not finite or above the feedthrough bound, ``decay`` not in
        (0, 1], ``time_limit`` or ``max_iterations`` not positive.

    Examples
    --------
    Two sensors taking turns (``N = 2``) on ``x⁺ = A x + w + u``, half the
    actuator's messages lost:

    >>> A = [[1.1, 0.3], [0.0, 0.9]]
    >>> D = np.zeros((4, 4))
    >>> D[:2, :2] = np.eye(2)
    >>> P = ncs.nss(A, np.hstack([np.eye(2), np.eye(2)]),
    ...         np.vstack([np.eye(2), np.eye(2)]), D, True, nmeas=2, ncon=2,
    ...         actuator_loss=0.5, sensor_schedule=[1, 2])
    >>> res = ncs.refine_gain(P, eta=-1.0)
    >>> res.verified, bool(res.ms_radius < 1), res.gains.shape
    (True, True, (2, 2, 2))
    >>> res.gains[0, :, 1].tolist()      # sensor 2 is silent at k = 0
    [0.0, 0.0]
    """
    from .passivity import passivity_certificate  # noqa: F401 (import cost)
    from .strategies import build
    from .verify import feedthrough_bound
    if isinstance(P, NetworkedStateSpace):
        choice(controller, "controller", controllers())
        choice(actuator, "actuator", actuators())
        plant = build(P, controller, actuator)
    elif isinstance(P, JumpPlant):
        plant = P
    else:
        raise ControlArgument(f"P: expected a NetworkedStateSpace (see nss()) "
                              f"or a JumpPlant (see build()), got "
                              f"{type(P).__name__}")
    plant.require_noise_free("refine")
    if plant.shape["nw"] != plant.shape["nz"] or plant.shape["nw"] == 0:
        raise ControlDimension(
            f"P: passivity needs w and z of equal, nonzero size, got "
            f"{plant.shape['nw']} and {plant.shape['nz']}")
    eta = finite_real(eta, "eta", allow_none=True)
    if eta is not None:
        bound, _ = feedthrough_bound(plant.probabilities, plant.Dw)
        if not bound > eta:
            raise ValueError(f"eta: D11 + D11ᵀ ≻ 2·eta·I is necessary "
                             f"(theory: passivity), but λmin(D11 + D11ᵀ)/2 = "
                             f"{bound:.6g} ≤ eta = {eta:.6g}")
    decay = decay_bound(decay)
    if time_limit is not None:
        time_limit = positive_real(time_limit, "time_limit")
    max_iterations = positive_int(max_iterations, "max_iterations")
    if gains is not None:
        gains = real_array(gains.gains if isinstance(gains, PeriodicGain)
                           else gains, "gains", ndim=(2, 3))
        if gains.ndim == 2:
            gains = np.repeat(gains[None], plant.period, axis=0)
        if gains.shape != plant.gain_shape():
            raise ControlDimension(f"gains: expected shape "
                                   f"{plant.gain_shape()} (N, nu, nk), got "
                                   f"{gains.shape}")
    if isinstance(seed, np.random.Generator):
        rng = seed
    elif seed is None or (isinstance(seed, (int, np.integer))
                          and not isinstance(seed, bool)):
        rng = np.random.default_rng(seed)
    else:
        raise ControlArgument(f"seed: expected an int, a numpy Generator or "
                              f"None, got {type(seed).__name__}")
    deadline = (None if time_limit is None
                else time.perf_counter() + time_limit)
    return _refine(plant, eta, decay, gains, rng, deadline, max_iterations)
