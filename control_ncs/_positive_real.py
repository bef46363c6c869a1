"""Passivity of deterministic LTI systems in python-control's meaning.

:func:`control.ispassive` asks whether an LTI system is passive (not
strictly): positive real for the supply ``(1 + ρν) yᵀu - ρ yᵀy - ν uᵀu``.
This module answers that question exactly and without a solver, in
continuous or discrete time (``strict=False`` of
:func:`control_ncs.ispassive` and the indices): the Popov function on a
refined frequency grid (:class:`~control_ncs.kyp.FrequencyResponse`), the
Hamiltonian pencil's crossings, and the residues of the poles on the
stability boundary. The stochastic, strict meaning of a jump system is
:mod:`control_ncs.passivity`'s.
"""

from __future__ import annotations

from typing import Any

import control as ct
import numpy as np
from control.exception import ControlArgument, ControlDimension

from .exceptions import INFEASIBLE, NOT_MSS, NOT_VERIFIED, CertificationError
from .jump import JumpStateSpace
from .kyp import KYP_POINTS, FrequencyResponse
from .plant import NetworkedStateSpace
from .verify import square_system

__all__: list[str] = []


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


def resolve_strict(sys: Any, strict: Any, kwargs: dict) -> bool:
    """``strict`` resolved: None means strict for jump systems, and for a
    deterministic LTI system python-control's non-strict meaning unless a
    keyword of the certified test (``decay``, ``method``, ``solver``, …)
    asks for it."""
    if strict is None:
        return bool(kwargs) or isinstance(sys, JumpStateSpace) or \
            not isinstance(sys, ct.LTI)
    if not isinstance(strict, (bool, np.bool_)):
        raise ControlArgument(f"strict: expected True, False or None, got "
                              f"{strict!r}")
    return bool(strict)


def nonstrict_system(sys: Any, name: str, kwargs: dict
                      ) -> PositiveReal:
    """The positive-real test of ``sys`` for ``strict=False``: a
    deterministic LTI system (continuous or discrete time), or a jump
    system with one mode and period 1."""
    if kwargs:
        raise ControlArgument(
            f"{name}: {', '.join(sorted(kwargs))} apply to the certified, "
            f"strict test only (strict=True); the non-strict test of an LTI "
            f"system is exact without them")
    if isinstance(sys, NetworkedStateSpace):
        square_system(sys)      # refuses it with what to do
    if isinstance(sys, JumpStateSpace):
        mats = sys.deterministic() if sys.period == 1 else None
        if mats is None:
            raise ControlArgument(
                f"{name}: strict=False is the positive-real test of a "
                f"deterministic LTI system; a jump system is certified "
                f"strictly passive (strict=True, the default)")
        A, B, C, D = (np.asarray(X[0], float) for X in mats)
        continuous = False
    elif isinstance(sys, ct.LTI):
        G = sys if isinstance(sys, ct.StateSpace) else ct.ss(sys)
        A, B, C, D = (np.asarray(X, float) for X in (G.A, G.B, G.C, G.D))
        continuous = bool(G.isctime(strict=True))
    else:
        raise ControlArgument(f"sys: expected an LTI system or a "
                              f"JumpStateSpace, got {type(sys).__name__}")
    if D.shape[0] != D.shape[1]:
        raise ControlDimension(
            f"sys: passivity needs as many inputs as outputs, got "
            f"{D.shape[1]} inputs and {D.shape[0]} outputs")
    return PositiveReal(A, B, C, D, continuous)


def nonstrict(test: PositiveReal, rho: float, nu: float) -> bool:
    """Non-strict passivity for python-control's supply
    ``(1 + ρν) yᵀu - ρ yᵀy - ν uᵀu``."""
    if rho != 0 and nu == 0:
        # ρ alone: G (I - ρG)⁻¹ passive, which also decides an unstable G
        # that output feedback makes passive (ρ < 0)
        r = test.resp
        A, B, C, D = r.A, r.B, r.C, r.D
        loop = output_feedback_loop(A, B, C, D, rho)
        if loop is None:
            return False
        return PositiveReal(*loop, False).decide()[0]
    return test.decide(rho, nu)[0]


def lti_ofp_index(test: PositiveReal) -> float:
    """The output-feedback index of an LTI system (non-strict): the largest
    ``ρ`` with ``G (I - ρG)⁻¹`` positive real. Lowering ``ρ`` only adds
    ``-ρ yᵀy`` to the supply, so the feasible ``ρ`` form an interval
    ``(-∞, ρ*]``; ``ρ*`` is at most the frequency bound
    ``min λmin(G⁻¹ + G⁻ᴴ)/2``, and equals it unless the loop is unstable
    there (then bisection below it)."""
    name = "get_output_fb_index"
    r = test.resp
    if np.linalg.cond(r.D) < 1e8:
        # the zeros of G are the zeros of every G (I - ρG)⁻¹, and a
        # positive real function has none outside the stability region
        Di = np.linalg.inv(r.D)
        inverse = PositiveReal(r.A - r.B @ Di @ r.C, r.B @ Di,
                                   -Di @ r.C, Di, False)
        if inverse.unstable:
            raise CertificationError(
                f"{name}: sys has zero dynamics outside the stability region "
                f"(a zero of G); no output feedback makes it passive",
                INFEASIBLE, dict(zeros=np.array(inverse.unstable)))
    bound = float(test.ofp_bound())
    if not np.isfinite(bound):
        raise CertificationError(
            f"{name}: G is singular at every frequency; no index is "
            f"computed", NOT_VERIFIED, dict(bound=bound))
    if nonstrict(test, bound, 0.0):
        return bound
    scale = max(1.0, abs(bound))
    hi, lo = bound, None
    for k in range(60):
        trial = bound - scale * 1e-9 * 2.0 ** k
        if nonstrict(test, trial, 0.0):
            lo = trial
            break
        hi = trial
    if lo is None:
        raise CertificationError(
            f"{name}: G (I - ρG)⁻¹ is not passive for any ρ down to "
            f"{hi:.3g} (it stays unstable); no output-feedback index is "
            f"found", NOT_VERIFIED, dict(bound=bound))
    while hi - lo > 1e-10 * scale:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if nonstrict(test, mid, 0.0) else (lo, mid)
    return lo


def lti_index_exists(test: PositiveReal, name: str) -> None:
    """Raise when no input-feedforward index exists for an LTI system."""
    why = test.refusal()
    if why == "unstable":
        poles = np.array(test.unstable)
        figures: dict = dict(poles=poles)
        if not test.continuous:
            figures["ms_radius"] = float(np.abs(poles).max() ** 2)
        raise CertificationError(
            f"{name}: sys has a pole outside the stability region; no "
            f"passivity index exists", NOT_MSS, figures)
    if why in ("multiple boundary pole", "boundary residue"):
        raise CertificationError(
            f"{name}: sys has a {why} on the stability boundary that no "
            f"feedforward ν makes passive (a multiple pole, or a residue that "
            f"is not Hermitian positive semidefinite)", INFEASIBLE, {})
