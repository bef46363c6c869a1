"""Exact, solver-independent checks of passivity and stability certificates.

A solver's status is not a proof (MATH §8). Every verdict the library returns
is re-checked here with plain linear algebra on the *closed-loop* jump
system: the eigenvalues of the dissipation matrices ``Θ_k`` of MATH §6 for
the certificate ``P_k``, the eigenvalues of ``P_k`` themselves, and the
spectral radius of the second-moment operator (MATH §5). The figures are
kept on a :class:`Certificate`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from control.exception import ControlDimension

from ._checks import real_array
from .jump import as_jump
from .stability import ms_radius

__all__ = ["Certificate", "CertificationError", "SynthesisError",
           "dissipation_matrices", "certified_index", "check_certificate",
           "certify_index"]

#: Relative back-offs of ``η`` below the supremum a certificate proves, tried
#: in turn by :func:`certify_index`. The supremum comes from a Schur
#: complement, which loses accuracy when ``M11`` is nearly singular (a loop
#: at the mean-square boundary, ``ms_radius → 1``, which maximising ``η``
#: produces; measured: 1e-9 below failed the exact check at
#: ms_radius = 1 - 1e-6). Stepping 1e-6 below also leaves a certificate
#: margin that a fresh solve can find again: at 1e-9 below, ``ispassive``
#: could not re-certify passivesyn's η (its most interior certificate has
#: λmax(Θ) ≈ -1e-10, below Clarabel's accuracy).
INDEX_BACKOFFS = (1e-6, 1e-5, 1e-4)


class CertificationError(RuntimeError):
    """A passivity or stability result could not be certified.

    Attributes
    ----------
    reason : str
        ``'infeasible'`` (the LMI has no solution), ``'solver_failed'``,
        ``'inaccurate'`` (the solver's own status), ``'not_verified'`` (the
        solver's answer fails the exact checks), ``'not_stable'``.
    figures : dict
        Whatever was measured (solver status, eigenvalues, ``ms_radius``).
    """

    def __init__(self, message: str, reason: str, figures: dict | None = None):
        super().__init__(message)
        self.reason = reason
        self.figures = dict(figures or {})


class SynthesisError(CertificationError):
    """:func:`control_ncs.passivesyn` found no gain it could certify."""


def _float_margin(M: np.ndarray) -> float:
    """Rounding error bound of a symmetric eigenvalue computation.

    LAPACK's symmetric eigensolvers are backward stable: computed eigenvalues
    are exact for a matrix within ``c·n·eps·‖M‖₂`` of ``M``. A sign is only
    claimed when the eigenvalue clears this bound.
    """
    return 16 * M.shape[0] * np.finfo(float).eps * max(np.linalg.norm(M, 2), 1e-300)


def _next(P: np.ndarray, k: int) -> np.ndarray:
    return P[(k + 1) % P.shape[0]]


def dissipation_matrices(sys: Any, P: np.ndarray, eta: float, *,
                         decay: float = 1.0) -> list[np.ndarray]:
    """The matrices ``Θ_k`` of MATH §6 for a closed-loop jump system.

    ``Θ_k = Σ_i p_i [A_i B_i]ᵀ P_{k+1} [A_i B_i]
    + [[-r² P_k, -C̄ᵀ], [-C̄, 2ηI - D̄ - D̄ᵀ]]`` with ``C̄ = Σ p_i C_i``,
    ``D̄ = Σ p_i D_i`` (the supply rate is linear in ``z``) and ``r`` the
    decay bound (``r = 1``: none). ``Θ_k ≺ 0`` for all ``k`` certifies strict
    stochastic passivity with dissipation ``η`` and mean-square stability
    (with ``E V`` decaying at least like ``r^(2t)``).

    Parameters
    ----------
    sys : JumpStateSpace
    P : ndarray, shape (N, n, n)
    eta : float
    decay : float, optional

    Returns
    -------
    list of ndarray, each (n + m, n + m)
    """
    sys = as_jump(sys)
    A, B, p = sys.modes.A, sys.modes.B, sys.modes.probabilities
    _, _, Cbar, Dbar = sys.modes.mean()
    n, m = A.shape[-1], B.shape[-1]
    out = []
    for k in range(sys.period):
        F = np.concatenate([A[k], B[k]], axis=2)  # (M, n, n + m)
        # Σ_i p_i F_iᵀ P F_i as batched matrix products (BLAS): a plain
        # 4-operand einsum loops in C without BLAS (0.7 s at n = 64).
        PF = _next(P, k) @ F                       # (M, n, n + m)
        T = np.tensordot(p[k], F.transpose(0, 2, 1) @ PF, axes=1)
        T[:n, :n] -= decay ** 2 * P[k]
        T[n:, :n] -= Cbar[k]
        T[:n, n:] -= Cbar[k].T
        T[n:, n:] += 2 * eta * np.eye(m) - Dbar[k] - Dbar[k].T
        out.append(0.5 * (T + T.T))
    return out


def certified_index(sys: Any, P: np.ndarray, *, decay: float = 1.0) -> float:
    """Largest ``η`` that the certificate ``P`` proves, exactly.

    ``Θ_k ≺ 0`` holds iff its ``(1,1)`` block ``M11 ≺ 0`` and
    ``2η < -λmax(M22 - M21 M11⁻¹ M12)`` (Schur complement), so for a given
    ``P`` the supremum of certified ``η`` is
    ``min_k -λmax(S_k)/2``. Strict inequality: every ``η`` below the returned
    value is certified, the value itself is not.

    Returns ``-inf`` when some ``M11`` is not negative definite (``P`` proves
    nothing).
    """
    sys = as_jump(sys)
    n = sys.modes.A.shape[-1]
    best = np.inf
    for T in dissipation_matrices(sys, P, 0.0, decay=decay):
        M11, M12, M22 = T[:n, :n], T[:n, n:], T[n:, n:]
        if np.linalg.eigvalsh(M11).max() >= -_float_margin(M11):
            return -np.inf
        S = M22 - M12.T @ np.linalg.solve(M11, M12)
        best = min(best, -np.linalg.eigvalsh(0.5 * (S + S.T)).max() / 2)
    return float(best)


@dataclass
class Certificate:
    """Exact verification figures of a passivity certificate.

    Attributes
    ----------
    verified : bool
        All checks passed.
    eta : float
        Dissipation level checked.
    decay : float
        Decay bound ``r`` checked (1 = none).
    P : ndarray, shape (N, n, n)
        The certificate ``P_k``.
    theta_max : ndarray, shape (N,)
        ``λmax(Θ_k)``; must be < 0.
    P_min : ndarray, shape (N,)
        ``λmin(P_k)``; must be > 0.
    ms_radius : float
        Per-step spectral radius of the second-moment operator (MATH §5),
        computed independently of ``P``; must be < 1, and ``< r²`` with a
        decay bound (``E‖ξ‖²`` decays like ``r^(2t)``).
    eta_sup : float
        Supremum of the ``η`` certified by ``P`` (:func:`certified_index`).
    failures : list of str
        What failed, in words.
    """

    verified: bool
    eta: float
    decay: float
    P: np.ndarray
    theta_max: np.ndarray
    P_min: np.ndarray
    ms_radius: float
    eta_sup: float
    failures: list = field(default_factory=list)

    def figures(self) -> dict:
        """The measured numbers as a plain dict (for messages and reports)."""
        return dict(eta=self.eta, decay=self.decay,
                    theta_max=self.theta_max.tolist(),
                    P_min=self.P_min.tolist(), ms_radius=self.ms_radius,
                    eta_sup=self.eta_sup)


def check_certificate(sys: Any, P: Any, eta: float, *, decay: float = 1.0
                      ) -> Certificate:
    """Check a passivity certificate exactly (no solver involved).

    Parameters
    ----------
    sys : JumpStateSpace
        The closed loop.
    P : array_like, shape (N, n, n) or (n, n)
        Candidate ``P_k`` (symmetrised before use).
    eta : float
        Dissipation level to certify.
    decay : float, optional
        Mean-square decay bound ``r`` in (0, 1].

    Returns
    -------
    Certificate
        ``verified`` is True only if every ``λmax(Θ_k)`` and ``-λmin(P_k)``
        is negative beyond the rounding bound of the eigenvalue computation
        and ``ms_radius < min(1, r²)``.
    """
    sys = as_jump(sys)
    n, N = sys.modes.A.shape[-1], sys.period
    P = real_array(P, "P", ndim=(2, 3))
    if P.ndim == 2:
        P = P[None]
    if P.shape[0] == 1 and N > 1:
        P = np.repeat(P, N, axis=0)
    if P.shape != (N, n, n):
        raise ControlDimension(f"P: expected shape ({N}, {n}, {n}) or ({n}, {n}) "
                               f"(one P_k per phase), got {np.shape(P)}")
    P = 0.5 * (P + P.transpose(0, 2, 1))
    thetas = dissipation_matrices(sys, P, eta, decay=decay)
    theta_max = np.array([np.linalg.eigvalsh(T).max() for T in thetas])
    theta_ok = [t < -_float_margin(T) for t, T in zip(theta_max, thetas)]
    P_min = np.array([np.linalg.eigvalsh(Pk).min() for Pk in P])
    P_ok = [v > _float_margin(Pk) for v, Pk in zip(P_min, P)]
    rho = ms_radius(sys)
    failures = []
    if not all(theta_ok):
        failures.append(f"λmax(Θ_k) = {theta_max.max():.3e} is not < 0")
    if not all(P_ok):
        failures.append(f"λmin(P_k) = {P_min.min():.3e} is not > 0")
    if not rho < 1.0:
        failures.append(f"ms_radius = {rho:.6g} is not < 1")
    if decay < 1.0 and not rho < decay ** 2:
        failures.append(f"ms_radius = {rho:.6g} is not < r² = {decay ** 2:.6g}")
    return Certificate(not failures, float(eta), float(decay), P, theta_max,
                       P_min, rho, certified_index(sys, P, decay=decay),
                       failures)


def certify_index(sys: Any, P: Any, *, decay: float = 1.0) -> Certificate:
    """Certificate of the largest ``η`` that ``P`` proves, checked exactly.

    Takes the supremum from :func:`certified_index`, steps just below it
    (relative back-offs ``INDEX_BACKOFFS``) and returns the first
    :func:`check_certificate` that passes, else the last one tried (with
    ``verified`` False). Every verdict is the exact check's, never the
    Schur complement's.
    """
    sys = as_jump(sys)
    sup = certified_index(sys, P, decay=decay)
    if not np.isfinite(sup):
        # P proves nothing (some M11 is not negative definite): report the
        # figures (all failing) at a level below the feedthrough bound.
        _, _, _, Dbar = sys.modes.mean()
        low = min(np.linalg.eigvalsh(D + D.T).min() for D in Dbar) / 2
        return check_certificate(sys, P, float(low) - 1.0, decay=decay)
    cert = None
    for backoff in INDEX_BACKOFFS:
        cert = check_certificate(sys, P, sup - backoff * max(1.0, abs(sup)),
                                 decay=decay)
        if cert.verified:
            break
    return cert
