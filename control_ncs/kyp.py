"""Frequency-domain (KYP) tests of deterministic systems
(:ref:`theory-passivity`).

For a Schur-stable LTI system ``G(z) = D + C (zI - A)⁻¹ B`` the
input-feedforward passivity index equals
``min_θ λmin(G(e^{jθ}) + G(e^{jθ})ᴴ) / 2`` (KYP lemma). This module
evaluates that minimum (:class:`FrequencyResponse`, used by
:func:`control_ncs.frequency_ff_index` and the Riccati route of
:func:`control_ncs.passivity_certificate`) and locates, by the symplectic
pencil of the Riccati equation, the frequencies where
``G + Gᴴ - 2ηI`` is singular. Nothing here certifies: a frequency only
bounds the index from above.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.linalg import eigvals, schur

__all__: list[str] = []

#: Grid of the KYP frequency search on [0, π] (also frequency_ff_index's).
KYP_POINTS = 2000

#: Points of each local grid refining a KYP minimum (the bracket shrinks
#: 16-fold per round: 8 rounds from the grid's spacing to 1e-12 rad).
ZOOM_POINTS = 33

#: A pencil eigenvalue with ``| |z| - 1 |`` below this is a candidate crossing
#: (a tangency is a double eigenvalue, ~√eps); a loose value only costs time.
CROSSING_TOL = 1e-5


class FrequencyResponse:
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

    def refine(self, lo: Any, hi: Any, fn: Any = None) -> tuple[float, float]:
        """Lowest ``λmin`` in the brackets ``[lo, hi]`` (arrays: several
        at once): (value, θ).

        Successive local grids of ``ZOOM_POINTS`` points, each spanning the
        two neighbours of the previous grid's lowest point, until the
        spacing is below ``1e-12`` rad. ``fn(thetas)`` replaces
        ``λmin`` when given. Every round is one vectorised
        evaluation (instead of ~40 scalar ones per bracket for a scalar
        search: measured, small LAPACK calls are what costs here).
        """
        lo = np.atleast_1d(lo).astype(float)
        hi = np.atleast_1d(hi).astype(float)
        best, at, rows = np.inf, float(lo[0]), np.arange(lo.size)
        while True:
            grids = lo[:, None] + np.outer(hi - lo,
                                           np.linspace(0, 1, ZOOM_POINTS))
            flat = grids.ravel()
            lam = (self.values(flat)[0] if fn is None else fn(flat)
                   ).reshape(grids.shape)
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
                refine: bool = True, fn: Any = None) -> tuple[float, float]:
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
                                    thetas[np.minimum(local + 1, last)], fn)
            if value < best:
                best, theta = value, at
        return best, theta

    def crossings(self, eta: float) -> np.ndarray:
        """Frequencies in ``[0, π]`` where ``G + Gᴴ - 2ηI`` is singular.

        They are the unit-circle eigenvalues of the extended symplectic
        pencil of the Riccati equation of
        :func:`control_ncs.riccati.dare_storage` with
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


def frequency_minimum(resp: FrequencyResponse,
                      thetas: np.ndarray | None = None,
                      points: int | None = None) -> float:
    """``min λmin(G + Gᴴ)/2`` of ``resp`` on the grid ``thetas``
    (rad/sample, ascending), or on ``points`` (default ``KYP_POINTS``)
    points of ``[0, π]``
    refined around the grid's three lowest local minima (when ``thetas``
    is None). An upper bound on the index, attained at a frequency."""
    refine = thetas is None
    if thetas is None:
        thetas = np.linspace(0.0, np.pi,
                             KYP_POINTS if points is None else points)
    return resp.minimum(thetas, resp.values(thetas)[0], refine)[0]


# -- non-strict passivity of deterministic LTI systems ------------------------
#: A pole whose modulus is within this of 1 lies on the boundary (discrete
#: time, after the Cayley map of a continuous-time system).
BOUNDARY_TOL = 1e-9
#: Relative tolerance of "≥ 0" for the Popov function (python-control's
#: boundary cases: a system shifted by exactly its index is passive,
#: shifted by 1e-6 more it is not).
POPOV_TOL = 1e-9
#: Radial offsets at which ``(z - z0) G(z)`` estimates a residue.
_RESIDUE_STEPS = (1e-6, 1e-7)


def cayley(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray
           ) -> tuple[tuple[np.ndarray, ...], float]:
    """A continuous-time system as ``G_d(z) = G_c(a (z - 1)/(z + 1))``.

    The Cayley (bilinear) map sends the imaginary axis onto the unit
    circle (``ω = a tan(θ/2)``) and the open left half plane into the open
    disk, so it keeps positive realness and every Popov inequality
    exactly; ``a`` is kept away from the eigenvalues of ``A``.

    Returns
    -------
    (Ad, Bd, Cd, Dd), a
    """
    n = A.shape[0]
    eig = np.linalg.eigvals(A) if n else np.zeros(0)
    scale = max(1.0, float(np.abs(eig).max()) if n else 1.0)
    candidates = scale * np.array([1.0, 1.7, 2.9, 0.6, 4.3])
    a = float(max(candidates, key=lambda c: np.abs(eig - c).min()
                  if n else 1.0))
    M = a * np.eye(n) - A
    MB, CM = np.linalg.solve(M, B), np.linalg.solve(M.T, C.T).T
    Ad = np.linalg.solve(M, a * np.eye(n) + A)
    root = np.sqrt(2 * a)
    return (Ad, root * MB, root * CM, D + C @ MB), a


class PositiveReal:
    """Non-strict passivity of a deterministic, square LTI system.

    For a transfer function ``G`` (discrete time; a continuous-time one
    through :func:`cayley`) and the supply ``(1 + ρν) yᵀu - ρ yᵀy - ν uᵀu``
    (python-control's), ``G`` is passive when

    * every pole ``|z| > 1`` is absent (hidden modes do not count: the
      test is of the input-output map from rest);
    * poles on the unit circle are simple, with ``ρ ≤ 0`` and a residue
      whose continuous-time image ``2R/(z0 + 1)²`` (``-R/2`` at
      ``z0 = -1``) is Hermitian positive semidefinite;
    * the Popov function
      ``Φ(θ) = (1 + ρν) (G + Gᴴ)/2 - ρ GᴴG - νI ⪰ 0`` on the circle.

    The minimum of ``λmin Φ`` is found on a grid refined around its
    lowest local minima; with ``ρ = 0`` (``Φ`` affine in ``G``) the
    Hamiltonian pencil's unit-circle eigenvalues (:meth:`FrequencyResponse
    .crossings`) catch any dip the grid missed.
    """

    def __init__(self, A: np.ndarray, B: np.ndarray, C: np.ndarray,
                 D: np.ndarray, continuous: bool):
        self.continuous = continuous
        self.a = 1.0
        if continuous:
            (A, B, C, D), self.a = cayley(A, B, C, D)
        self.resp = FrequencyResponse(A, B, C, D)
        self.A, self.D = A, D
        eig = np.linalg.eigvals(A) if A.shape[0] else np.zeros(0)
        outside = eig[np.abs(eig) > 1 + BOUNDARY_TOL]
        self.unstable = [z for z in outside if self._pole_order(z) > 0]
        edge = eig[np.abs(np.abs(eig) - 1) <= BOUNDARY_TOL]
        # one representative per distinct boundary eigenvalue; the grid
        # avoids them all, poles of G or hidden modes
        reps: list = []
        for z in edge:
            if all(abs(z - r) > 1e-6 for r in reps):
                reps.append(z)
        self.edge_angles = np.abs(np.angle(np.array(reps, complex)))
        boundary = [(z, self._residue(z)) for z in reps]
        self.boundary = [(z, R) for z, R in boundary if R is not None]

    # -- G at any complex point ----------------------------------------------
    def at(self, z: complex) -> np.ndarray:
        """``G(z)``."""
        X = self.resp._resolvent(np.array([z], complex))
        return self.resp.D + self.resp.CU @ X[:, 0, :]

    def _scale(self) -> float:
        return max(1.0, float(np.linalg.norm(self.D, 2)),
                   float(np.linalg.norm(self.at(np.exp(0.5j)), 2)))

    def _limits(self, z0: complex) -> list[np.ndarray]:
        return [(z0 * d) * self.at(z0 * (1 + d)) for d in _RESIDUE_STEPS]

    def _pole_order(self, z0: complex) -> int:
        """0: not a pole of ``G`` (hidden mode); 1: simple; 2: higher."""
        r1, r2 = self._limits(z0)
        size = max(np.linalg.norm(r1), np.linalg.norm(r2))
        if size <= 1e-8 * self._scale():
            return 0
        return 1 if np.linalg.norm(r1 - r2) <= 1e-3 * size else 2

    def _residue(self, z0: complex) -> np.ndarray | str | None:
        """The continuous-time residue at a boundary pole; None if ``z0``
        is not a pole of ``G``; ``'multiple'`` for a multiple pole."""
        order = self._pole_order(z0)
        if order == 0:
            return None
        if order == 2:
            return "multiple"
        R = self._limits(z0)[1]
        if abs(z0 + 1) < 1e-6:
            return -R / 2
        return 2 * R / (z0 + 1) ** 2

    # -- the decision -------------------------------------------------------
    def transfer(self, thetas: np.ndarray) -> np.ndarray:
        """``G(e^{jθ})`` at each ``θ``, shape (len(θ), p, m)."""
        z = np.exp(1j * np.atleast_1d(np.asarray(thetas, float)))
        X = self.resp._resolvent(z)
        n, F, m = X.shape
        CX = (self.resp.CU @ X.reshape(n, F * m)).reshape(-1, F, m)
        return self.resp.D + CX.transpose(1, 0, 2)

    def grid(self) -> np.ndarray:
        """``KYP_POINTS`` angles of ``[0, π]``, away from boundary modes."""
        thetas = np.linspace(0.0, np.pi, KYP_POINTS)
        for angle in self.edge_angles:
            thetas = thetas[np.abs(thetas - angle) > 1e-6]
        return thetas

    def popov(self, thetas: np.ndarray, rho: float, nu: float) -> np.ndarray:
        """``λmin Φ(θ)`` at each ``θ``."""
        G = self.transfer(thetas)
        Gh = G.conj().transpose(0, 2, 1)
        Phi = (0.5 * (1 + rho * nu) * (G + Gh) - rho * (Gh @ G)
               - nu * np.eye(G.shape[-1]))
        return np.linalg.eigvalsh(Phi)[:, 0]

    def minimum(self, rho: float = 0.0, nu: float = 0.0
                ) -> tuple[float, float]:
        """``min_θ λmin Φ(θ)`` and where (rad/sample of the discrete
        image), away from the boundary poles."""
        thetas = self.grid()
        values = self.popov(thetas, rho, nu)
        best, at = self.resp.minimum(thetas, values, True,
                                     fn=lambda t: self.popov(t, rho, nu))
        if rho == 0.0 and not self.edge_angles.size:
            # Φ = (G + Gᴴ)/2 - ν: the pencil at the level λmin (G + Gᴴ)/2
            low = self.resp.lower_near_crossings(best + nu + POPOV_TOL)
            if low is not None and low[0] - nu < best:
                best, at = low[0] - nu, low[1]
        return best, at

    def frequency(self, theta: float) -> float:
        """``θ`` of the discrete image as the system's own frequency
        (rad per time unit for continuous time: ``a tan(θ/2)``)."""
        if not self.continuous:
            return theta
        return float(np.inf) if theta >= np.pi else self.a * np.tan(theta / 2)

    def refusal(self, rho: float = 0.0, nu: float = 0.0) -> str | None:
        """Why the poles alone refute passivity, or None."""
        if self.unstable:
            return "unstable"
        for _, R in self.boundary:
            if isinstance(R, str):
                return "multiple boundary pole"
            if rho > 0:
                return "boundary pole with rho > 0"
            W = (1 + rho * nu) * R
            size = max(1.0, float(np.linalg.norm(W)))
            if np.linalg.norm(W - W.conj().T) > 1e-6 * size or \
                    np.linalg.eigvalsh(0.5 * (W + W.conj().T))[0] < \
                    -1e-6 * size:
                return "boundary residue"
        return None

    def decide(self, rho: float = 0.0, nu: float = 0.0
               ) -> tuple[bool, str, float]:
        """(passive, reason, ``min λmin Φ``)."""
        why = self.refusal(rho, nu)
        if why is not None:
            return False, why, -np.inf
        value, _ = self.minimum(rho, nu)
        tol = POPOV_TOL * self._scale() ** (2 if rho else 1)
        return bool(value >= -tol), "popov", value

    def ofp_bound(self) -> float:
        """``min_θ λmin(G⁻¹ + G⁻ᴴ)/2``: the largest ``ρ`` with
        ``G + Gᴴ - 2ρ GᴴG ⪰ 0`` on the circle (where ``G`` is invertible);
        ``inf`` if ``G`` is nowhere invertible."""
        def values(thetas: np.ndarray) -> np.ndarray:
            G = self.transfer(thetas)
            out = np.full(G.shape[0], np.inf)
            ok = np.linalg.cond(G) < 1e8
            if ok.any():
                Gi = np.linalg.inv(G[ok])
                out[ok] = np.linalg.eigvalsh(
                    0.5 * (Gi + Gi.conj().transpose(0, 2, 1)))[:, 0]
            return out

        thetas = self.grid()
        return self.resp.minimum(thetas, values(thetas), True, fn=values)[0]


def output_feedback_loop(A: np.ndarray, B: np.ndarray, C: np.ndarray,
                         D: np.ndarray, rho: float
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                    np.ndarray] | None:
    """``G (I - ρG)⁻¹`` (``u = v + ρy``), or None if ``I - ρD`` is singular.

    The loop transformation of the output-feedback index: ``G`` is
    dissipative for ``yᵀu - ρ yᵀy`` exactly when this loop is passive
    (same state, same storage)."""
    M = np.eye(D.shape[0]) - rho * D
    if np.linalg.cond(M) > 1e12:
        return None
    Mi = np.linalg.inv(M)
    return A + rho * B @ Mi @ C, B @ Mi, Mi @ C, Mi @ D
