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
