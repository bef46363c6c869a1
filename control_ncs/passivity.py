"""Stochastic passivity analysis of jump systems (MATH §6), certified.

Names mirror :mod:`control.passivity`: :func:`ispassive` and
:func:`get_input_ff_index`, with the same supply-rate convention
(``wᵀz - ν wᵀw``, equivalently MATH's ``2wᵀz - 2η wᵀw``), so that for a
loss-free, time-invariant loop the numbers coincide with python-control's.

Two different indices exist for a lossy loop, and they are named apart:

* :func:`get_input_ff_index` -- the *stochastic* (certified) index: the
  supply inequality holds in expectation for every input adapted to the past,
  as in a feedback interconnection. Certified by ``P_k`` with ``Θ_k ≺ 0``.
* :func:`mean_input_ff_index` -- the index of the *mean system* (the
  StateSpace face, MATH §7): a statement about ``E z`` for deterministic
  inputs only. It is never smaller than the stochastic one.

Two routes produce a certificate, both checked exactly by
:mod:`control_ncs.verify`:

* ``'lmi'`` -- the LMI of MATH §6 solved by an interior-point solver
  (any jump system);
* ``'riccati'`` -- for a deterministic system (one mode, period 1): the KYP
  frequency test gives the index from above, and one discrete algebraic
  Riccati equation just below it gives ``P`` (see :func:`_riccati_storage`);
  no solver, ``O(n³)`` work against the LMI's ``n(n+1)/2`` dense unknowns.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from control.exception import ControlArgument, ControlDimension
from scipy.linalg import (LinAlgError, eigvals, schur, solve_discrete_are,
                          solve_discrete_lyapunov)

from ._checks import (choice, decay_bound, finite_real, no_extra_kwargs,
                      positive_real, real_array)
from .jump import as_jump
from .lmi import (DEFAULT_MARGIN, SolveReport, analysis_model,
                  fallback_solver, solve)
from .stability import ms_radius
from .verify import (Certificate, CertificationError, certify_index,
                     check_certificate)

__all__ = ["ispassive", "get_input_ff_index", "mean_input_ff_index",
           "frequency_ff_index", "passivity_certificate", "PassivityResult"]

#: Routes of :func:`passivity_certificate` (``method``). ``'auto'`` takes the
#: Riccati route for every deterministic system, whatever its size. Measured
#: on benchmarks/bench_passivity.py's systems (interleaved, median of 3; one
#: BLAS thread): n = 4: 7.5 ms against the LMI's 14 ms; n = 16: 0.11 s
#: against 0.25 s; n = 32: 0.45 s against 14 s; n = 64: 1.2 s, the LMI
#: unfinished after 150 s. It agrees with control.get_input_ff_index to
#: ~1e-6, like the LMI. With several BLAS threads on busy cores both small
#: cases vary 3-5× from run to run.
METHODS = ("auto", "riccati", "lmi")

#: Grid of the KYP frequency search on [0, π] (also frequency_ff_index's).
KYP_POINTS = 2000

#: Points of each local grid that refines a minimum of the KYP test (the
#: bracket shrinks 16-fold per round: 8 rounds from the grid's spacing to
#: 1e-12 rad).
ZOOM_POINTS = 33

#: Relative back-offs, below the KYP upper bound ν̂, of the levels at which
#: the Riccati route solves its equation, in turn. The first is small
#: because the exact check (verify.certify_index) backs off another 1e-6;
#: measured on n = 4..64: 1e-7 below ν̂ the Riccati equation solves and its
#: P passes the exact check, 1e-8 also does, so 1e-7 leaves a factor 10.
RICCATI_BACKOFFS = (1e-7, 1e-6, 1e-5, 1e-4, 1e-3)

#: Strictness ``ε`` of the Riccati route, as a fraction of the largest
#: admissible one, ``min_θ 2(λmin(θ) - η)/‖(e^{jθ}I - A)⁻¹B‖²`` (estimated
#: on the grid, which can miss a peak: hence well below 1).
RICCATI_EPS_FRACTION = 0.25

#: Pencil corrections of ν̂ (a dip of ``λmin`` that the grid missed) before
#: the Riccati route gives up and, under ``'auto'``, the LMI takes over.
KYP_CORRECTIONS = 4

#: An eigenvalue of the symplectic pencil counts as a unit-circle crossing
#: when ``| |z| - 1 | <`` this. Only a candidate: ``λmin`` is evaluated there
#: and kept only if lower, so a loose tolerance costs evaluations, nothing
#: else (a tangency is a double eigenvalue, computed to ~√eps).
CROSSING_TOL = 1e-5

#: Attempts, in turn, until an answer passes the exact checks, as
#: (margin multiplier, relative back-off of η or None). For an index: the
#: maximisation, then feasibility problems a little below its optimum (a
#: maximum sits on the boundary, where interior-point answers end
#: 'optimal_inaccurate'; measured on periodic lossy loops: at 1e-6 below,
#: Clarabel says 'optimal'), then a 100× larger margin.
INDEX_ATTEMPTS = ((1.0, None), (1.0, 1e-6), (1.0, 1e-4), (1.0, 1e-3),
                  (1e2, None))
#: For a given η: the LMI with its margin, a 100× larger one, and last the
#: LMI that maximises its own margin (multiplier None), for an η so close to
#: the index that a fixed margin makes the LMI infeasible; its answer is the
#: most interior certificate and is checked exactly like any other.
#: Measured: needed to re-certify the η that passivesyn returns (1e-6
#: below what its certificate proves); the non-strict LMI (margin 0)
#: instead returns boundary points that fail the exact check.
LEVEL_ATTEMPTS = ((1.0, None), (1e2, None), (None, None))


@dataclass
class PassivityResult:
    """A verified (or refuted) passivity certificate of a jump system.

    Attributes
    ----------
    passive : bool
        True: certified by ``certificate``. False: ``reason`` says why.
    eta : float
        Dissipation level certified (for an index: a relative 1e-6 below
        the supremum ``certificate.eta_sup`` the certificate proves, see
        :func:`control_ncs.verify.certify_index`).
    certificate : Certificate or None
        Exact verification figures (``P_k``, ``λmax(Θ_k)``, ``ms_radius``).
    report : SolveReport or None
        The solver's status and timings.
    reason : str
        ``'certified'``, ``'not_mss'``, ``'feedthrough'`` (``D̄ + D̄ᵀ ≻ 2ηI``
        fails, a necessary condition), ``'infeasible'`` (the LMI has no
        solution with its margin, and the margin-maximising LMI gives no
        certificate that passes the exact check; on the Riccati route: a
        frequency with ``λmin(G + Gᴴ)/2 ≤ η`` was found, so by the KYP
        lemma no certificate exists, see ``eta_upper``).
    method : str
        Route that decided: ``'lmi'`` or ``'riccati'``.
    eta_upper : float
        Riccati route: ``ν̂ = λmin(G + Gᴴ)/2`` at the lowest frequency found,
        an upper bound on the index (``ν ∈ (eta, eta_upper]`` for an index).
        NaN on the LMI route.

    Notes
    -----
    On the Riccati route ``report`` is filled in the same terms:
    ``solver='scipy.linalg.solve_discrete_are'``, ``compile_time`` is the
    frequency search, ``solve_time`` the Riccati solves, pencil corrections
    and exact checks, ``iterations`` the number of Riccati solves, ``value``
    the level ``η`` of the last one and ``options`` its ``level`` and ``eps``.
    """

    passive: bool
    eta: float
    certificate: Certificate | None
    report: SolveReport | None
    reason: str
    method: str = "lmi"
    eta_upper: float = np.nan


def _feedthrough_refutes(sys, ifp_index) -> bool:
    """``D̄ + D̄ᵀ ≻ 2ηI`` fails: no certificate for ``η`` (MATH §6)."""
    if ifp_index is None:
        return False
    _, _, _, Dbar = sys.modes.mean()
    sym_min = min(np.linalg.eigvalsh(D + D.T).min() for D in Dbar)
    return not sym_min > 2 * ifp_index


def _deterministic(sys) -> tuple[np.ndarray, ...] | None:
    """``(A, B, C, D)`` if ``sys`` is deterministic (period 1, all live
    modes equal) with at least one state, else None."""
    m = sys.modes
    live = np.flatnonzero(m.probabilities[0] > 0)
    if sys.period != 1 or m.A.shape[-1] == 0:
        return None
    first = live[0]
    if any(not np.array_equal(X[0, i], X[0, first])
           for i in live[1:] for X in (m.A, m.B, m.C, m.D)):
        return None
    return tuple(np.asarray(X[0, first], float) for X in (m.A, m.B, m.C, m.D))


class _FrequencyResponse:
    """``G(e^{jθ}) = D + C (e^{jθ}I - A)⁻¹ B`` at many frequencies at once.

    One complex Schur form ``A = U T Uᴴ`` (unitary, hence backward stable)
    turns every ``(zI - A)⁻¹B`` into ``U (zI - T)⁻¹ UᴴB``, a triangular
    solve; the back substitution runs over the ``n`` rows for all
    frequencies together: ``O(n² m)`` per frequency against ``O(n³)`` for a
    dense solve, and ``n`` vectorised steps instead of a loop over
    frequencies.
    """

    def __init__(self, A: np.ndarray, B: np.ndarray, C: np.ndarray,
                 D: np.ndarray):
        self.A, self.B, self.C, self.D = A, B, C, D
        if A.shape[0]:
            T, U = schur(A, output="complex")
        else:
            T, U = np.zeros((0, 0), complex), np.eye(0)
        self.T, self.UB, self.CU = T, U.conj().T @ B, C @ U
        #: spectral radius of A (the diagonal of T)
        self.radius = float(np.abs(np.diag(T)).max()) if A.shape[0] else 0.0

    def _resolvent(self, z: np.ndarray) -> np.ndarray:
        """``(zI - T)⁻¹ UᴴB`` for each ``z``, shape (n, len(z), m)."""
        n, m = self.UB.shape
        if z.size == 1:
            # one LAPACK call for the refinement's many single points;
            # measured: ?trtrs (solve_triangular) is 10-50× slower than
            # ?gesv here for n ≤ 8 when OpenBLAS threads compete for cores
            return np.linalg.solve(z[0] * np.eye(n) - self.T,
                                   self.UB)[:, None, :]
        # frequency-major columns: (f, j) at f·m + j
        X = np.tile(self.UB, (1, z.size))
        zz = np.repeat(z, m)
        for i in range(n - 1, -1, -1):
            # row i of (zI - T) X = UᴴB, the rows below already solved
            X[i] += self.T[i, i + 1:] @ X[i + 1:]
            X[i] /= zz - self.T[i, i]
        return X.reshape(n, z.size, m)

    def values(self, thetas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``λmin(G + Gᴴ)/2`` and ``‖(zI - A)⁻¹B‖_F`` at ``z = e^{jθ}``."""
        z = np.exp(1j * np.atleast_1d(np.asarray(thetas, float)))
        X = self._resolvent(z)
        n, F, m = X.shape
        CX = (self.CU @ X.reshape(n, F * m)).reshape(-1, F, m)
        G = self.D + CX.transpose(1, 0, 2)
        lam = np.linalg.eigvalsh(0.5 * (G + G.conj().transpose(0, 2, 1)))
        return lam[:, 0], np.sqrt(np.sum(np.abs(X) ** 2, axis=(0, 2)))

    def refine(self, lo: Any, hi: Any) -> tuple[float, float]:
        """Lowest ``λmin`` in the brackets ``[lo, hi]`` (arrays: several
        at once): (value, θ).

        Successive local grids of ``ZOOM_POINTS`` points, each spanning the
        two neighbours of the previous grid's lowest point, until the
        spacing is below ``1e-12`` rad. Every round is one vectorised
        evaluation (instead of ~40 scalar ones per bracket for a scalar
        search: measured, small LAPACK calls are what costs here).
        """
        lo = np.atleast_1d(lo).astype(float)
        hi = np.atleast_1d(hi).astype(float)
        best, at, rows = np.inf, float(lo[0]), np.arange(lo.size)
        while True:
            grids = lo[:, None] + np.outer(hi - lo,
                                           np.linspace(0, 1, ZOOM_POINTS))
            lam = self.values(grids.ravel())[0].reshape(grids.shape)
            j = lam.argmin(axis=1)
            k = int(lam[rows, j].argmin())
            if lam[k, j[k]] < best:
                best, at = float(lam[k, j[k]]), float(grids[k, j[k]])
            step = (hi - lo) / (ZOOM_POINTS - 1)
            if step.max() < 1e-12:
                return best, at
            centre = grids[rows, j]
            lo = np.maximum(centre - step, lo)
            hi = np.minimum(centre + step, hi)

    def minimum(self, thetas: np.ndarray, lam: np.ndarray,
                refine: bool = True) -> tuple[float, float]:
        """Lowest ``λmin`` on the grid ``thetas`` (ascending; ``lam`` its
        values), refined between the neighbours of its three lowest local
        minima when ``refine``: (value, θ)."""
        i = int(np.argmin(lam))
        best, theta = float(lam[i]), float(thetas[i])
        if refine and lam.size > 2:
            padded = np.concatenate([[np.inf], lam, [np.inf]])
            local = np.flatnonzero((lam <= padded[:-2]) & (lam <= padded[2:]))
            local = local[np.argsort(lam[local])][:3]
            last = lam.size - 1
            value, at = self.refine(thetas[np.maximum(local - 1, 0)],
                                    thetas[np.minimum(local + 1, last)])
            if value < best:
                best, theta = value, at
        return best, theta

    def crossings(self, eta: float) -> np.ndarray:
        """Frequencies in ``[0, π]`` where ``G + Gᴴ - 2ηI`` is singular.

        They are the unit-circle eigenvalues of the extended symplectic
        pencil of the Riccati equation of :func:`_riccati_storage` with
        ``ε = 0`` (the pencil scipy's ``solve_discrete_are`` factors;
        van Dooren 1981): ``z`` is a finite eigenvalue of it iff
        ``det Φ(z) = 0`` for the Popov function
        ``Φ(z) = G(z) + G(1/z)ᵀ - 2ηI``.
        """
        A, B, C, D = self.A, self.B, self.C, self.D
        n, m = B.shape
        Z, I = np.zeros, np.eye
        H = np.block([[A, Z((n, n)), B], [Z((n, n)), I(n), -C.T],
                      [C, Z((m, n)), D + D.T - 2 * eta * I(m)]])
        J = np.block([[I(n), Z((n, n + m))], [Z((n, n)), A.T, Z((n, m))],
                      [Z((m, n)), -B.T, Z((m, m))]])
        alpha, beta = eigvals(H, J, homogeneous_eigvals=True)
        finite = np.abs(beta) > 1e-12 * np.abs(alpha)
        z = alpha[finite] / beta[finite]
        on_circle = np.abs(np.abs(z) - 1.0) < CROSSING_TOL
        return np.unique(np.abs(np.angle(z[on_circle])))

    def lower_near_crossings(self, eta: float) -> tuple[float, float] | None:
        """Lowest ``λmin`` found at and between the crossings at level
        ``η`` (one step of the Boyd-Balakrishnan / Bruinsma-Steinbuch
        iteration: between two crossings ``λmin - η`` keeps its sign, so
        a dip below ``η`` the grid missed has a crossing on each side),
        refined between its neighbours; None without crossings."""
        angles = self.crossings(eta)
        if not angles.size:
            return None
        pts = np.unique(np.concatenate([[0.0, np.pi], angles]))
        cand = np.unique(np.concatenate([pts, 0.5 * (pts[1:] + pts[:-1])]))
        lam, _ = self.values(cand)
        i = int(np.argmin(lam))
        value, at = self.refine(cand[max(i - 1, 0)],
                                cand[min(i + 1, cand.size - 1)])
        return (value, at) if value < lam[i] else (float(lam[i]),
                                                   float(cand[i]))


def _riccati_storage(resp: _FrequencyResponse, eta: float, eps: float
                     ) -> np.ndarray | None:
    """``P ≻ 0`` with ``Θ(P, η) ≺ 0`` from one Riccati equation, or None.

    Derivation. For ``ξ⁺ = Aξ + Bw``, ``z = Cξ + Dw`` (MATH §6 with one
    mode and ``N = 1``; the matrix of ``verify.dissipation_matrices``)::

        Θ(P, η) = [ AᵀPA - P    AᵀPB - Cᵀ           ] = [ Θ11  L  ]
                  [ BᵀPA - C    BᵀPB + 2ηI - D - Dᵀ ]   [ Lᵀ   -W ]

    with ``W = D + Dᵀ - 2ηI - BᵀPB``. By a Schur complement on the ``w``
    block, ``Θ ≺ 0`` iff ``W ≻ 0`` and ``Θ11 + L W⁻¹ Lᵀ ≺ 0``. Ask for
    the latter with equality and a margin ``ε > 0``::

        AᵀPA - P + (AᵀPB - Cᵀ) W⁻¹ (BᵀPA - C) = -εI.              (*)

    With ``X = -P`` and ``Q = -εI``, ``S = Cᵀ``, ``R = D + Dᵀ - 2ηI``,
    (*) times -1 is scipy's DARE
    ``AᵀXA - X - (AᵀXB + S)(R + BᵀXB)⁻¹(BᵀXA + Sᵀ) + Q = 0``
    (``R + BᵀXB = W``, ``AᵀXB + S = -L``). ``solve_discrete_are`` returns
    the stabilising solution: the value of the LQ problem
    ``ξ0ᵀXξ0 = min_w Σ_t (ξᵀQξ + 2ξᵀSw + wᵀRw)
    = min_w Σ_t (2wᵀz - 2η wᵀw - ε‖ξ‖²)`` (twice the supply rate less
    ``ε‖ξ‖²``), which exists iff the Popov function
    ``G + Gᴴ - 2ηI - εFᴴF`` (``F = (e^{jθ}I - A)⁻¹B``) is positive definite
    on the unit circle: for ``η < ν`` and ``ε‖F‖²_∞ < 2(ν - η)``. Then
    ``W ≻ 0`` and (*) give ``Θ ≺ 0``; ``w = 0`` gives
    ``ξ0ᵀXξ0 ≤ -ε‖ξ0‖²``, so ``P = -X ≻ 0`` (up to the ``ε`` term, the
    available storage, the smallest storage function).

    A decay bound ``r`` (``Θ11 = AᵀPA - r²P``) is the same problem for
    ``(A/r, B/r)`` and ``r²P``: ``resp`` holds the scaled data, the caller
    divides by ``r²``. None of this is trusted: the caller checks ``P``
    exactly.
    """
    A, B, C, D = resp.A, resp.B, resp.C, resp.D
    n, m = B.shape
    Q, R, S = -eps * np.eye(n), D + D.T - 2 * eta * np.eye(m), C.T
    try:
        X = solve_discrete_are(A, B, Q, R, s=S)
    except (LinAlgError, ValueError):
        # pencil eigenvalues on (or too close to) the unit circle: η ≥ ν,
        # or ε too large for this η
        return None

    def residual(X):
        K = np.linalg.solve(R + B.T @ X @ B, B.T @ X @ A + S.T)
        Res = A.T @ X @ A - X - (A.T @ X @ B + S) @ K + Q
        return 0.5 * (Res + Res.T), A - B @ K

    try:
        # One Newton step (Hewer 1971): the residual's derivative at X is
        # N ↦ AcᵀNAc - N, Ac = A - BK, so N solves a Stein equation. The
        # QZ solution's residual is ~eps·cond·‖X‖, which near a lightly
        # damped pole exceeds the margin ε (measured: 1 - |pole| = 1e-6,
        # ‖P‖ = 6e5, residual 3e-5 > ε = 1e-7; after the step 2e-10).
        Res, Ac = residual(X)
        step = solve_discrete_lyapunov(Ac.T, Res)
        if np.linalg.norm(residual(X + step)[0]) < np.linalg.norm(Res):
            X = X + step
    except (LinAlgError, ValueError):
        pass  # keep the QZ solution; the exact check decides
    P = -0.5 * (X + X.T)
    return P if np.all(np.isfinite(P)) else None


def _riccati_certificate(sys, mats, ifp_index, decay
                         ) -> tuple[PassivityResult | None, dict]:
    """The Riccati route of :func:`passivity_certificate`.

    Returns ``(result, figures)``: ``result`` None when no level gave a
    certificate that passes the exact check (the caller falls back to the
    LMI or raises).
    """
    start = time.perf_counter()
    A, B, C, D = mats
    if not decay > 0:
        return PassivityResult(False, np.nan, None, None, "not_mss",
                               "riccati"), {}
    # ms_radius of a deterministic system is ρ(A)², the Schur form's diagonal
    resp = _FrequencyResponse(A / decay, B / decay, C, D)
    if not (resp.radius * decay) ** 2 < min(1.0, decay ** 2):
        return PassivityResult(False, np.nan, None, None, "not_mss",
                               "riccati"), {}
    if _feedthrough_refutes(sys, ifp_index):
        return PassivityResult(False, float(ifp_index), None, None,
                               "feedthrough", "riccati"), {}
    grid = np.linspace(0.0, np.pi, KYP_POINTS)
    lam, gain = resp.values(grid)
    upper, theta = resp.minimum(grid, lam)
    t_freq = time.perf_counter() - start

    def strictness(level: float) -> float:
        # Φ - εFᴴF ≻ 0 (see _riccati_storage) at θ where
        # 2(λmin(θ) - η) > ε‖F(θ)‖²; the grid and θ̂ estimate the worst θ
        _, at = resp.values(np.array([theta]))
        norms = np.append(gain, at) ** 2
        room = 2 * (np.append(lam, upper) - level)
        ok = norms > 0
        limit = (room[ok] / norms[ok]).min() if ok.any() else room.min()
        return RICCATI_EPS_FRACTION * float(limit)

    levels, solves, corrections = [], 0, 0
    cert, level, eps = None, np.nan, np.nan

    def report(status: str, message: str = "") -> SolveReport:
        total = time.perf_counter() - start
        return SolveReport(status, "scipy.linalg.solve_discrete_are", t_freq,
                           total - t_freq, total, solves, float(level),
                           message, dict(level=float(level), eps=float(eps)))

    def refuted() -> tuple[PassivityResult, dict]:
        # KYP: Θ ≺ 0 needs G + Gᴴ ≻ 2ηI at every frequency
        return PassivityResult(
            False, float(ifp_index), None,
            report("infeasible", f"λmin(G + Gᴴ)/2 = {upper:.10g} ≤ η at "
                   f"θ = {theta:.10g} rad/sample"),
            "infeasible", "riccati", upper), {}

    fixed = ifp_index is not None
    if fixed and not ifp_index < upper:
        return refuted()
    plan = [None] if fixed else list(RICCATI_BACKOFFS)
    while plan:
        backoff = plan.pop(0)
        step = 0.0 if fixed else backoff * max(1.0, abs(upper))
        level = float(ifp_index) if fixed else upper - step
        eps = strictness(level)
        levels.append(level)
        solves += 1
        P = _riccati_storage(resp, level, eps)
        if P is not None:
            P = P[None] / decay ** 2
            cert = (check_certificate(sys, P, level, decay=decay) if fixed
                    else certify_index(sys, P, decay=decay))
            # an index must come with P proving (nearly) the level asked
            if cert.verified and (fixed or cert.eta_sup >= level - step):
                return PassivityResult(True, cert.eta, cert,
                                       report("optimal"), "certified",
                                       "riccati", upper), {}
        if corrections < KYP_CORRECTIONS:
            corrections += 1
            lower = resp.lower_near_crossings(level)
            # accept a dip the grid missed only if it takes at least half
            # the room between level and ν̂ (not a rounding-level change)
            if lower is not None and lower[0] < 0.5 * (level + upper):
                upper, theta = lower
                if fixed:
                    if not ifp_index < upper:
                        return refuted()
                    plan = [None]
                else:
                    plan = list(RICCATI_BACKOFFS)
    figures = dict(levels=levels, eta_upper=upper, frequency=theta,
                   **(cert.figures() if cert is not None else {}))
    return None, figures


def _square(sys) -> None:
    m, p = sys.modes.B.shape[-1], sys.modes.C.shape[-2]
    if m != p:
        raise ControlDimension(f"sys: passivity needs as many inputs as outputs "
                               f"(w and z of equal size), got {m} inputs and "
                               f"{p} outputs")


def passivity_certificate(sys: Any, ifp_index: float | None = None, *,
                          decay: float = 1.0, method: str = "auto",
                          solver: str | None = None,
                          margin: float = DEFAULT_MARGIN,
                          **solver_options: Any) -> PassivityResult:
    """Search for and exactly verify a stochastic passivity certificate.

    Finds ``P_k`` with ``Θ_k(P, η) ≺ 0`` (MATH §6; ``η`` maximised when
    ``ifp_index`` is None), then checks it with
    :func:`control_ncs.verify.check_certificate`. Necessary conditions that
    fail (``ms_radius ≥ 1``, ``D̄ + D̄ᵀ ⊁ 2ηI``) give an exact "no" without a
    solve. Two routes find ``P`` (``method``): the LMI, solved by cvxpy,
    for any jump system; and, for a deterministic system (one mode,
    period 1), the KYP frequency test and one Riccati equation, without a
    solver (see Notes).

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time StateSpace
        Square (``w`` and ``z`` of equal size).
    ifp_index : float, optional
        Dissipation ``η`` to certify; None: the largest certifiable one.
    decay : float, optional
        Also certify ``E V`` decaying like ``r^(2t)`` (``r = decay``).
    method : {'auto', 'riccati', 'lmi'}, optional
        ``'auto'``: the Riccati route for a deterministic system (unless
        ``solver`` or solver options are given), falling back to the LMI
        if it cannot certify; the LMI otherwise.
        ``'riccati'``: the Riccati route only (deterministic systems).
        ``'lmi'``: the LMI only.
    solver : str, optional
        LMI route: any installed cvxpy solver (default Clarabel).
    margin : float, optional
        LMI route: relative strictness margin of the LMI.
    **solver_options
        LMI route: passed to the solver (e.g. Clarabel's ``tol_gap_rel``).

    Returns
    -------
    PassivityResult
        ``method`` says which route decided.

    Raises
    ------
    ControlArgument
        If ``method`` is not one of the above, or is ``'riccati'`` for a
        system that is not deterministic (or has no state).
    CertificationError
        If no attempt (``INDEX_ATTEMPTS`` or ``LEVEL_ATTEMPTS``, then the
        fallback solver) gives an answer that passes the exact checks:
        ``reason`` is ``'solver_failed'``, ``'inaccurate'``,
        ``'not_verified'`` or, for an index, ``'infeasible'`` (a retry was
        reported infeasible); the figures are on the exception. With
        ``method='riccati'``: ``'not_verified'`` when no Riccati level
        gives a certificate that passes.

    Notes
    -----
    The Riccati route (derivation at :func:`_riccati_storage`): the KYP
    frequency test on a grid of ``KYP_POINTS`` points, refined by a bounded
    scalar search, gives ``ν̂ ≥ ν`` (a value of ``λmin(G + Gᴴ)/2`` at one
    frequency). Just below ``ν̂`` (``RICCATI_BACKOFFS``) one discrete
    algebraic Riccati equation gives ``P ≻ 0``, and
    :func:`control_ncs.verify.certify_index` certifies the largest ``η`` it
    proves, so ``ν`` lies in ``(eta, eta_upper]``, ~1e-6 wide (relative).
    If the Riccati equation fails or its ``P`` does not verify, the
    symplectic pencil at that level locates any dip the grid missed
    (its unit-circle eigenvalues are the frequencies where
    ``G + Gᴴ - 2ηI`` is singular), ``ν̂`` is lowered and the levels are
    tried again; then larger back-offs.
    """
    sys = as_jump(sys)
    _square(sys)
    choice(method, "method", METHODS)
    ifp_index = finite_real(ifp_index, "ifp_index", allow_none=True)
    margin = positive_real(margin, "margin")
    decay = decay_bound(decay)
    if sys.modes.A.shape[-1] == 0:
        raise ControlDimension(
            "sys: a passivity certificate needs at least one state (a static "
            "system's index is λmin(D + Dᵀ)/2)")
    mats = _deterministic(sys)
    if method == "riccati" and mats is None:
        raise ControlArgument(
            "method: 'riccati' needs a deterministic system with at least "
            f"one state (one mode, period 1); sys has period {sys.period}, "
            f"{int(np.sum(sys.modes.probabilities > 0))} live mode(s) and "
            f"{sys.modes.A.shape[-1]} state(s); use method='lmi' or 'auto'")
    # under 'auto', a named solver or solver options ask for the LMI
    lmi_asked = solver is not None or bool(solver_options)
    if mats is not None and (method == "riccati"
                             or (method == "auto" and not lmi_asked)):
        result, figures = _riccati_certificate(sys, mats, ifp_index, decay)
        if result is not None:
            return result
        if method == "riccati":
            raise CertificationError(
                "passivity: the Riccati route found no certificate that "
                f"passes the exact check (levels tried: {figures['levels']}; "
                f"upper bound {figures['eta_upper']:.10g}); try "
                "method='lmi'", "not_verified", figures)
    return _lmi_certificate(sys, ifp_index, decay, solver, margin,
                            solver_options)


def _lmi_certificate(sys, ifp_index, decay, solver, margin, solver_options
                     ) -> PassivityResult:
    """The LMI route of :func:`passivity_certificate` (any jump system)."""
    rho = ms_radius(sys)
    if not rho < min(1.0, decay ** 2):
        return PassivityResult(False, np.nan, None, None, "not_mss")
    if _feedthrough_refutes(sys, ifp_index):
        return PassivityResult(False, float(ifp_index), None, None,
                               "feedthrough")
    fixed = ifp_index is not None
    plan = [(scale, backoff, solver) for scale, backoff in
            (LEVEL_ATTEMPTS if fixed else INDEX_ATTEMPTS)]
    if fallback_solver(solver):
        plan.append(((None if fixed else 1.0), None, fallback_solver(solver)))
    attempts, last, best, refuted = [], None, None, False
    while plan:
        scale, backoff, name = plan.pop(0)
        target = ifp_index
        if backoff is not None:
            if best is None:
                continue  # the first solve gave no optimum to back off from
            target = best - backoff * max(1.0, abs(best))
        level = None if scale is None else margin * scale
        model = analysis_model(sys, target, level, decay)
        # the caller's options are for the solver the caller chose
        report = solve(model.problem, name,
                       **(solver_options if name == solver else {}))
        attempts.append((level, target, report.solver, report.status))
        if len(attempts) == 1:
            best = report.value
        if report.infeasible:
            last = (report, None, "infeasible")
            if fixed:
                refuted = True
                # a larger margin is infeasible too; a smaller one may not be
                plan = [a for a in plan if a[0] is None]
                continue
            if len(attempts) == 1:
                break
            continue  # e.g. a backed-off target still above the index
        if report.status not in ("optimal", "optimal_inaccurate"):
            last = (report, None, "solver_failed")
            continue
        if scale is None and report.value is not None and report.value <= 0:
            # the largest margin is not positive: no strict certificate
            # (unless another solver's answer verifies after all)
            last, refuted = (report, None, "infeasible"), True
            continue
        model._check_current()
        P = np.array([Pk.value for Pk in model.P])
        cert = (check_certificate(sys, P, float(ifp_index), decay=decay)
                if fixed else certify_index(sys, P, decay=decay))
        # For a given η the exact check is the proof, whatever the solver's
        # status; an index also claims optimality, which needs 'optimal'.
        if cert.verified and (report.ok or fixed):
            return PassivityResult(True, cert.eta, cert, report, "certified")
        last = (report, cert, "not_verified" if report.ok else "inaccurate")
    report, cert, reason = last
    if refuted:
        # No certificate with a margin exists, and without one none verified.
        return PassivityResult(False, float(ifp_index), None, report,
                               "infeasible")
    if reason == "infeasible" and len(attempts) == 1:
        return PassivityResult(False, np.nan, None, report, "infeasible")
    figures = dict(status=report.status, solver=report.solver,
                   attempts=attempts,
                   **(cert.figures() if cert is not None else {}))
    what = {"solver_failed": "the solver failed",
            "inaccurate": "the solver's status stayed inaccurate",
            "infeasible": "a retry was reported infeasible",
            "not_verified": "the solver's answer fails the exact check: "
            + ("; ".join(cert.failures) if cert is not None else "")}[reason]
    raise CertificationError(
        f"passivity: no certificate could be verified ({what}; attempts "
        f"(margin, eta, solver, status): {attempts})", reason, figures)


def ispassive(sys: Any, ifp_index: float = 0.0, **kwargs: Any) -> bool:
    """True if ``sys`` is certified strictly passive with dissipation ``η``.

    Stochastic strict passivity (MATH §6): there is ``ε > 0`` such that
    ``E Σ_t (wᵀz - η wᵀw) ≥ ε E Σ_t wᵀw`` from rest, for every input adapted
    to the past. True only with a certificate that passed the exact checks
    (see :func:`passivity_certificate`, which also returns the figures).

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time StateSpace
    ifp_index : float, optional
        Input-feedforward index ``η`` to certify (default 0: passivity).
    **kwargs
        ``decay``, ``method``, ``solver``, ``margin`` and solver options, as
        for :func:`passivity_certificate`.

    Returns
    -------
    bool
        False means: a necessary condition fails, or no certificate was
        found (the LMI is infeasible with its margin, and the LMI that
        maximises its margin gives none that passes the exact check).

    Examples
    --------
    >>> import control as ct
    >>> G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True)
    >>> ispassive(G), ispassive(G, ifp_index=0.4)
    (True, False)
    """
    return passivity_certificate(sys, ifp_index, **kwargs).passive


def get_input_ff_index(sys: Any, **kwargs: Any) -> float:
    """Largest certified input-feedforward passivity index (stochastic).

    The supremum of ``η`` for which a certificate ``P_k`` with ``Θ_k ≺ 0``
    exists (MATH §6); the value returned is certified exactly, a relative
    1e-6 below the supremum the solver's ``P_k`` proves (room for any later
    check, e.g. :func:`ispassive`, to re-certify it). For a loss-free
    ``N = 1`` loop it equals :func:`control.get_input_ff_index` and, for a
    stable system, :func:`frequency_ff_index`; such a deterministic system
    takes the Riccati route by default (no cvxpy solve, see
    :func:`passivity_certificate`).

    Parameters
    ----------
    sys : JumpStateSpace or discrete-time StateSpace
    **kwargs
        As for :func:`passivity_certificate` (``method``, ``decay``,
        ``solver``, ``margin``, solver options).

    Returns
    -------
    float

    Raises
    ------
    CertificationError
        ``reason='not_stable'`` if ``sys`` is not mean-square stable (no
        index exists); see :func:`passivity_certificate` for the others.

    Examples
    --------
    ``G(z) = 1 + 1/(z - 0.5)`` has ``min Re G = 1/3`` on the unit circle:

    >>> import control as ct
    >>> G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True)
    >>> round(get_input_ff_index(G), 5)
    0.33333
    """
    result = passivity_certificate(sys, None, **kwargs)
    if result.reason == "not_mss":
        raise CertificationError(
            "get_input_ff_index: sys is not mean-square stable "
            "(ms_radius ≥ 1, or ≥ r² with a decay bound); no passivity "
            "index exists", "not_stable", dict(ms_radius=ms_radius(sys)))
    if not result.passive:
        # sys is mean-square stable, so some η is certifiable (MATH §6: the
        # (1,1) block is Lemma 1); an infeasible LMI here is numerical.
        raise CertificationError(
            "get_input_ff_index: the LMI was reported infeasible although "
            f"sys is mean-square stable (status {result.report.status!r})",
            "infeasible", dict(status=result.report.status))
    return result.eta


def mean_input_ff_index(sys: Any, **kwargs: Any) -> float:
    """Input-feedforward index of the *mean* system (deterministic inputs).

    The StateSpace face of a :class:`~control_ncs.JumpStateSpace` (its exact
    mean, lifted over the period if ``N > 1``) is an ordinary LTI system;
    this is its passivity index, certified the same way. It bounds ``E z``
    for deterministic ``w`` only, and is never below
    :func:`get_input_ff_index` (MATH §6-§7).
    """
    sys = as_jump(sys)
    return get_input_ff_index(sys.mean(), **kwargs)


def frequency_ff_index(sys: Any, omega: Any = None, *,
                       points: int = KYP_POINTS, **kwargs: Any) -> float:
    """KYP frequency test: ``min_ω λmin(G(e^{jω}) + G(e^{jω})ᴴ) / 2``.

    For a Schur-stable LTI system this equals its input-feedforward index
    (KYP lemma); an independent route to check the LMIs. A grid over
    ``[0, π/dt]`` (or ``omega``) is refined around its three lowest local
    minima with a bounded scalar search (not when ``omega`` is given). The
    value is attained at a frequency, so it is an upper bound on the index,
    up to the rounding of ``G``; a dip narrower than the grid's spacing can
    be missed (:func:`get_input_ff_index` also checks the Riccati pencil).

    ``G`` is evaluated at all frequencies at once from one complex Schur
    form of ``A`` (``O(n³)`` once, then ``O(n² m)`` per frequency).

    Parameters
    ----------
    sys : discrete-time StateSpace (for a jump system: its mean system)
    omega : array_like, optional
        Frequencies (rad per time unit) of the grid.
    points : int
        Grid size when ``omega`` is None.

    Returns
    -------
    float

    Raises
    ------
    ValueError
        If the system is not Schur stable (the test does not apply).

    Examples
    --------
    >>> G = ct.ss([[0.5]], [[1.0]], [[1.0]], [[1.0]], True)
    >>> round(frequency_ff_index(G), 10)  # min Re(1 + 1/(z - 0.5)) = 1/3
    0.3333333333
    """
    no_extra_kwargs("frequency_ff_index", kwargs)
    J = as_jump(sys)
    lti = J.mean()
    A, B, C, D = (np.asarray(M, float) for M in (lti.A, lti.B, lti.C, lti.D))
    if B.shape[1] != C.shape[0]:
        raise ControlDimension("sys: the frequency test needs a square system")
    resp = _FrequencyResponse(A, B, C, D)
    if resp.radius >= 1:
        raise ValueError("sys: frequency_ff_index needs a Schur-stable system")
    dt = 1.0 if lti.dt is True else float(lti.dt)
    if omega is None:
        thetas = np.linspace(0.0, np.pi, points)
    else:
        thetas = np.sort(real_array(omega, "omega", ndim=(0, 1)).ravel()
                         * dt)
        if thetas.size == 0:
            raise ValueError("omega: expected at least one frequency")
    return resp.minimum(thetas, resp.values(thetas)[0], omega is None)[0]
