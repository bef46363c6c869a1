"""The modified algebraic Riccati equation, solved as an equation
(:ref:`theory-estimation`).

One kernel serves the Kalman filter with intermittent observations and, by
duality (``A → Aᵀ``, ``C → Bᵀ``, ``W → Q``), LQ control over a lossy
actuator link (:mod:`control_ncs.lq`). In its coupled form ``N`` matrices
``X_s``, one per link state, solve

``X_s = W + Σ_t a[s, t] A X_t Aᵀ - b[s, t] A X_t Cᵀ (C X_t Cᵀ + R)⁻¹ C X_t Aᵀ``

with the rows of ``a`` summing to one and ``0 ≤ b ≤ a``: one Bernoulli
link is ``N = 1``, ``a = 1``, ``b = λ`` (the MARE); a Gilbert–Elliott link
gives two states (:ref:`theory-estimation`). The gain ``L_t = A X_t Cᵀ (C
X_t Cᵀ + R)⁻¹`` of a state ``t`` does not depend on ``s``, so the equation
is the minimum over gains of the fixed-gain equation

``X = 𝓛_L(X) + F_L``, ``𝓛_L(X)_s = Σ_t (a - b)[s, t] A X_t Aᵀ + b[s, t] A_t
X_t A_tᵀ``, ``A_t = A - L_t C``, ``F_L,s = W + Σ_t b[s, t] L_t R L_tᵀ``,

the exact stationary covariance of those gains (mean-square stable iff
``ρ(𝓛_L) < 1``). The solver finds a stabilising start (value iteration
from below when it converges, the closed-form gain when ``C`` sees the
whole unstable subspace, more value iteration, the loss-free Riccati gain,
or the gain of the LMI of :mod:`control_ncs.lmi.mare`), then runs policy
(Newton) iteration: each
step solves the fixed-gain equation exactly (a Kronecker solve on the
symmetric unknowns, or GMRES preconditioned by a Stein solve for large
``n``), converging quadratically, also next to the critical probability
where value iteration crawls. Every answer is checked: the equation's
residual, and ``ρ(𝓛_L) < 1`` proven by the Collatz–Wielandt bound of the
positive map ``𝓛_L`` (``𝓛_L(Y) ≼ t Y`` with ``Y ≻ 0`` gives ``ρ ≤ t``),
with the dense spectral radius beside it when it is cheap.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar, Iterator, NamedTuple

import numpy as np
import scipy.linalg as sla
from scipy.sparse.linalg import LinearOperator, gmres

from ._results import CertifiedResult
from .exceptions import (NOT_FOUND, NOT_MSS, NOT_VERIFIED, SOLVER_FAILED,
                         SynthesisError)

__all__ = ["RiccatiSolution"]

#: The fixed-gain equation is solved by a dense Kronecker factorisation up
#: to this many unknowns (``N·n(n+1)/2``; n = 24 for one link), by GMRES
#: on matrix products beyond: with its Stein preconditioner GMRES is the
#: faster from n ≈ 25 (measured: n = 40, 0.14 s against 0.46 s; n = 50,
#: 0.18 s against 0.91 s, one thread).
DENSE_MAX = 300
#: The dense operator's eigenvalues (the exact spectral radius) are
#: computed up to this many unknowns; beyond, the certified bracket alone.
EXACT_RADIUS_MAX = 300
#: Policy (Newton) steps at most; quadratic convergence needs a handful.
NEWTON_STEPS = 80
#: Relative residual the returned solution must meet.
RESIDUAL = 1e-9
#: Eigenvalues of modulus at least this are corrected by the gain (unstable
#: or on the unit circle).
UNSTABLE = 1.0 - 1e-9
#: Value-iteration steps tried before a policy start (16 times as many
#: once the cheaper starts have failed).
VALUE_STEPS = 256
#: Relative tolerance of a singular value for "C sees the unstable subspace".
RANK_TOL = 1e-10
#: GMRES: relative residual asked, restart length and restart cycles; an
#: answer is accepted when its residual is below GMRES_ACCEPT times ``‖X‖``.
GMRES_RTOL, GMRES_RESTART, GMRES_RESTARTS = 1e-14, 40, 25
GMRES_ACCEPT = 1e-13


class MareError(SynthesisError, ValueError):
    """No stabilising solution (``reason='not_mss'``), or none found.

    A :class:`control_ncs.SynthesisError` that is also a ``ValueError``,
    the kind of error :func:`control.dlqr` and :func:`control.dlqe` raise
    for a Riccati equation without a stabilising solution (numpy's
    ``LinAlgError``).
    """


class Equation:
    """The coupled MARE's data: ``A (n, n)``, ``C (p, n)``, ``W (n, n)``,
    ``R (p, p)`` and the weights ``a, b (N, N)`` (module docstring)."""

    def __init__(self, A: np.ndarray, C: np.ndarray, W: np.ndarray,
                 R: np.ndarray, a: np.ndarray, b: np.ndarray):
        self.A, self.C, self.W, self.R = A, C, W, R
        self.a, self.b = np.atleast_2d(a), np.atleast_2d(b)
        self.N, self.n, self.p = self.a.shape[0], A.shape[0], C.shape[0]
        self.acting = self.b.sum(axis=0) > 0

    # -- the maps ------------------------------------------------------------
    def riccati(self, X: np.ndarray) -> np.ndarray:
        """One value-iteration step ``X ↦ g(X)``, in the completed-square
        form ``𝓛_L(X) + F_L`` at ``L = L_X``: a sum of positive
        semidefinite terms. The subtractive form ``A X Aᵀ - A X Cᵀ(…)⁻¹C X
        Aᵀ`` is the same map but loses the cancellation in floating point:
        on Sinopoli et al.'s example at arrival 0.8 its iteration from 0
        overshoots the solution and diverges (to 1e154 in 3000 steps),
        where this form converges to it."""
        L = self.gains(X)
        out = self.apply(L, X) + self.forcing(L)
        return 0.5 * (out + out.transpose(0, 2, 1))

    def gains(self, X: np.ndarray) -> np.ndarray:
        """``L_t = A X_t Cᵀ (C X_t Cᵀ + R)⁻¹`` (zero where no gain acts)."""
        L = np.zeros((self.N, self.n, self.p))
        for t in np.flatnonzero(self.acting):
            AXC = self.A @ X[t] @ self.C.T
            L[t] = np.linalg.solve(self.C @ X[t] @ self.C.T + self.R,
                                   AXC.T).T
        return L

    def forcing(self, L: np.ndarray) -> np.ndarray:
        """``F_L,s = W + Σ_t b[s, t] L_t R L_tᵀ``."""
        LRL = L @ self.R @ L.transpose(0, 2, 1)
        F = self.W + np.tensordot(self.b, LRL, axes=1)
        return 0.5 * (F + F.transpose(0, 2, 1))

    def apply(self, L: np.ndarray, X: np.ndarray) -> np.ndarray:
        """The fixed-gain map ``𝓛_L(X)`` on ``X`` of shape (N, n, n)."""
        At = self.A - L @ self.C
        AXA = self.A @ X @ self.A.T
        AtXAt = At @ X @ At.transpose(0, 2, 1)
        return np.tensordot(self.a - self.b, AXA, axes=1) + \
            np.tensordot(self.b, AtXAt, axes=1)

    def residual(self, X: np.ndarray) -> float:
        """``‖X - g(X)‖ / max(1, ‖X‖)`` (Frobenius, over the states)."""
        return float(np.linalg.norm(X - self.riccati(X))
                     / max(1.0, float(np.linalg.norm(X))))

    def lost_radius(self) -> float:
        """``ρ(a - b) ρ(A)²``: a lower bound on ``ρ(𝓛_L)`` for every gain
        (``𝓛_L ≽`` its lost part), attained when ``C`` sees the whole
        unstable subspace."""
        rho_a = float(np.max(np.abs(np.linalg.eigvals(self.a - self.b))))
        return rho_a * spectral_radius(self.A) ** 2


def spectral_radius(A: np.ndarray) -> float:
    """``ρ(A)`` (0 for an empty matrix)."""
    return float(np.max(np.abs(np.linalg.eigvals(A)))) if A.size else 0.0


# -- where C sees the unstable subspace: the closed form ----------------------
def unstable_split(A: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """Real Schur form ``A = U T Uᵀ`` with the eigenvalues of modulus
    ``≥ UNSTABLE`` first: ``(T, U, n_u)``."""
    T, U, n_u = sla.schur(A, output="real",
                          sort=lambda re, im: re * re + im * im >=
                          UNSTABLE ** 2)
    return T, U, int(n_u)


def closed_form_gain(A: np.ndarray, C: np.ndarray) -> np.ndarray | None:
    """The gain ``L = U [T_u C_u⁺; 0]`` that zeroes the unstable block of
    ``A - LC`` when ``C_u = (CU)[:, :n_u]`` is injective (``C`` sees the
    whole unstable subspace), else None.

    ``A - LC`` is then block upper triangular with diagonal blocks ``0``
    and ``T_s``, and the lost part alone remains on the unstable block: the
    threshold ``ρ(a - b) ρ(A)² < 1`` is exact (Plarre and Bullo 2009)."""
    T, U, n_u = unstable_split(A)
    Cu = (C @ U)[:, :n_u]
    if n_u and (n_u > C.shape[0] or np.linalg.svd(Cu, compute_uv=False)[-1]
                <= RANK_TOL * max(1.0, float(np.linalg.norm(C, 2)))):
        return None
    L = np.zeros((A.shape[0], C.shape[0]))
    if n_u:
        L[:n_u] = T[:n_u, :n_u] @ np.linalg.pinv(Cu)
    return U @ L


# -- the fixed-gain equation ----------------------------------------------------
def _pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    return np.triu_indices(n)


def _sym_kron(M: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """``X ↦ M X Mᵀ`` on the upper triangle of a symmetric ``X``
    (unknowns ``X[k, l]``, ``k ≤ l``, in the order of ``(i, j)``)."""
    off = (i != j).astype(float)
    return M[i][:, i] * M[j][:, j] + off[None, :] * M[i][:, j] * M[j][:, i]


def _to_tri(X: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    return X[..., i, j].reshape(-1)


def _from_tri(v: np.ndarray, N: int, n: int, i: np.ndarray,
              j: np.ndarray) -> np.ndarray:
    X = np.zeros((N, n, n))
    v = v.reshape(N, -1)
    X[:, i, j] = v
    X[:, j, i] = v
    return X


class Fixed(NamedTuple):
    """A fixed gain's exact stationary covariance and its certificate."""

    X: np.ndarray               #: covariance, ``X = 𝓛_L(X) + F_L``
    radius: float               #: certified upper bound on ``ρ(𝓛_L)``
    radius_lower: float         #: certified lower bound
    radius_exact: float | None  #: unused here (set by the solver's end)
    route: str                  #: 'dense' or 'matrix-free'
    Y: np.ndarray | None = None  #: ``Y = 𝓛_L(Y) + I``, the certificate


def dense_operator(eq: Equation, L: np.ndarray) -> np.ndarray:
    """``𝓛_L`` as a matrix on the stacked upper triangles."""
    i, j = _pairs(eq.n)
    KA = _sym_kron(eq.A, i, j)
    m = KA.shape[0]
    op = np.zeros((eq.N * m, eq.N * m))
    d = eq.a - eq.b
    for t in range(eq.N):
        Kt = _sym_kron(eq.A - L[t] @ eq.C, i, j) if eq.acting[t] else None
        for s in range(eq.N):
            block = d[s, t] * KA
            if Kt is not None and eq.b[s, t]:
                block = block + eq.b[s, t] * Kt
            op[s * m:(s + 1) * m, t * m:(t + 1) * m] = block
    return op


def solve_fixed(eq: Equation, L: np.ndarray, *, x0: np.ndarray | None = None,
                dense: bool | None = None, certify: bool = True,
                final: bool = False) -> Fixed | None:
    """The exact covariance of the gains ``L`` with its stability proof, or
    None when ``L`` does not make ``𝓛_L`` a contraction (no ``Y ≻ 0``
    solves ``Y = 𝓛_L(Y) + I``: then ``ρ(𝓛_L) ≥ 1``).

    ``certify=False`` skips the proof on the matrix-free route (a policy
    step from a certified gain; the final answer is certified again);
    ``final=True`` tightens the bracket by power steps there (the dense
    route always does: its proof comes with the factorisation)."""
    N, n = eq.N, eq.n
    i, j = _pairs(n)
    unknowns = N * i.size
    dense = unknowns <= DENSE_MAX if dense is None else dense
    F = eq.forcing(L)
    eye = np.broadcast_to(np.eye(n), (N, n, n))
    exact = None
    if dense:
        op = dense_operator(eq, L)
        lhs = np.eye(unknowns) - op
        rhs = np.column_stack([_to_tri(F, i, j), _to_tri(eye, i, j)])
        try:
            sol = np.linalg.solve(lhs, rhs)
        except np.linalg.LinAlgError:
            return None
        if not np.all(np.isfinite(sol)):
            return None
        X = _from_tri(sol[:, 0], N, n, i, j)
        Y = _from_tri(sol[:, 1], N, n, i, j)
    else:
        Xm = _gmres(eq, L, F, x0)
        if Xm is None:
            return None
        if not certify:
            return Fixed(Xm, np.nan, np.nan, None, "matrix-free")
        Ym = _gmres(eq, L, np.array(eye), None)
        if Ym is None:
            return None
        X, Y = Xm, Ym
    bracket = collatz_wielandt(eq, L, Y, steps=40 if final or dense else 1)
    if bracket is None or not bracket[1] < 1.0:
        return None
    return Fixed(X, bracket[1], bracket[0], exact,
                 "dense" if dense else "matrix-free", Y)


def _gmres(eq: Equation, L: np.ndarray, F: np.ndarray,
           x0: np.ndarray | None) -> np.ndarray | None:
    """``X = 𝓛_L(X) + F`` by GMRES on matrix products, preconditioned per
    link state by the Stein solve (Smith's doubling) of its dominant own
    term: ``X_s - c A X_s Aᵀ`` with ``c = (a - b)[s, s]`` (a loss) or ``X_s
    - c A_s X_s A_sᵀ`` with ``c = b[s, s]`` (an arrival), whichever has the
    larger ``c ρ²`` below 1. Near the critical probability the loss term carries the slow
    mode: at n = 100, ``λ = λ_c + 0.01``, GMRES needs 25 steps with it and
    does not converge in 800 with the arrival term (or none). The answer is
    accepted on its own residual, relative to ``X``."""
    N, n = eq.N, eq.n
    shape = (N, n, n)
    size = N * n * n
    At = eq.A - L @ eq.C
    rho_A = spectral_radius(eq.A) ** 2
    stein: list = []
    for s in range(N):
        terms = [((eq.a - eq.b)[s, s] * rho_A, (eq.a - eq.b)[s, s], eq.A)]
        if eq.acting[s]:
            terms.append((eq.b[s, s] * spectral_radius(At[s]) ** 2,
                          eq.b[s, s], At[s]))
        usable = [t for t in terms if 0 < t[0] < 1]
        best = max(usable, key=lambda t: t[0]) if usable else None
        stein.append([] if best is None else
                     _doubling_powers(np.sqrt(best[1]) * best[2]))

    def matvec(v: np.ndarray) -> np.ndarray:
        X = v.reshape(shape)
        return (X - eq.apply(L, X)).ravel()

    def precondition(v: np.ndarray) -> np.ndarray:
        out = v.reshape(shape).copy()
        for s in range(N):
            for M in stein[s]:          # Smith's doubling of Σ M^k R Mᵀᵏ
                out[s] = out[s] + M @ out[s] @ M.T
        return out.ravel()

    op = LinearOperator((size, size), matvec=matvec, dtype=float)
    pre = LinearOperator((size, size), matvec=precondition, dtype=float)
    x = np.zeros(size) if x0 is None else x0.ravel()
    # one restart cycle at a time, judged on the residual relative to X:
    # near the critical probability ‖X‖ ≫ ‖F‖, and GMRES's own test
    # (relative to ‖F‖) cannot be met below the rounding of X
    for _ in range(GMRES_RESTARTS):
        x, _ = gmres(op, F.ravel(), x0=x, rtol=GMRES_RTOL, atol=0.0,
                     restart=GMRES_RESTART, maxiter=1, M=pre)
        if not np.all(np.isfinite(x)):
            return None
        X = x.reshape(shape)
        X = 0.5 * (X + X.transpose(0, 2, 1))
        residual = float(np.linalg.norm(X - eq.apply(L, X) - F))
        if residual <= GMRES_ACCEPT * float(np.linalg.norm(X)):
            return X
    return None


def _doubling_powers(M: np.ndarray, steps: int = 40) -> list:
    """``M, M², M⁴, …`` until the next power is below ``1e-10`` in norm:
    ``X ← X + P X Pᵀ`` over them sums the Stein series ``Σ M^k R Mᵀᵏ``
    (the solution of ``X - M X Mᵀ = R``) by matrix products alone, with the
    powers computed once per preconditioner."""
    out = [M]
    for _ in range(steps):
        P = out[-1] @ out[-1]
        if not np.linalg.norm(P, 2) > 1e-10 or not np.all(np.isfinite(P)):
            break
        out.append(P)
    return out


def collatz_wielandt(eq: Equation, L: np.ndarray, Y: np.ndarray,
                     steps: int = 40) -> tuple[float, float] | None:
    """``[s, t]`` containing ``ρ(𝓛_L)``: ``s Y ≼ 𝓛_L(Y) ≼ t Y`` for
    ``Y ≻ 0`` (the map keeps the cone of PSD tuples, Collatz–Wielandt),
    tightened by power steps ``Y ← 𝓛_L(Y)``; None if ``Y`` is not ``≻ 0``.
    """
    lower, upper = 0.0, np.inf
    for _ in range(steps):
        LY = eq.apply(L, Y)
        lo, hi = np.inf, -np.inf
        for s in range(eq.N):
            try:
                chol = np.linalg.cholesky(0.5 * (Y[s] + Y[s].T))
            except np.linalg.LinAlgError:
                return None if upper == np.inf else (lower, upper)
            half = np.linalg.solve(chol, LY[s])
            M = np.linalg.solve(chol, half.T)
            ev = np.linalg.eigvalsh(0.5 * (M + M.T))
            lo, hi = min(lo, ev[0]), max(hi, ev[-1])
        lower, upper = max(lower, float(lo)), min(upper, float(hi))
        if upper - lower <= 1e-12 * max(upper, 1e-300) or upper < 0.5:
            break
        top = float(np.linalg.norm(LY))
        if not top > 0:
            break
        Y = LY / top
    return lower, upper


# -- the solution ------------------------------------------------------------
class Solution(NamedTuple):
    """The stabilising solution with its figures."""

    X: np.ndarray            #: ``X_s``, shape (N, n, n)
    gains: np.ndarray        #: ``L_t``, shape (N, n, p)
    residual: float          #: ``‖X - g(X)‖ / max(1, ‖X‖)``
    radius: float            #: certified upper bound on ``ρ(𝓛_L)``
    radius_lower: float      #: certified lower bound on ``ρ(𝓛_L)``
    radius_exact: float | None  #: dense spectral radius, when computed
    start: str               #: where the stabilising start came from
    newton_steps: int
    route: str               #: 'dense' or 'matrix-free'

    def result(self, link: str) -> RiccatiSolution:
        """The public record of the checks."""
        exact = self.radius_exact
        return RiccatiSolution(
            residual=self.residual,
            ms_radius=self.radius if exact is None else exact,
            ms_radius_bracket=(self.radius_lower, self.radius),
            radius_exact=exact is not None, start=self.start,
            newton_steps=self.newton_steps, route=self.route, link=link)


@dataclass(frozen=True, repr=False)
class RiccatiSolution(CertifiedResult):
    """How a modified Riccati equation was solved, and its checks.

    Returned by :func:`control_ncs.dlqe` and :func:`control_ncs.dlqr` with
    ``full_output=True``. The solution exists only with its checks passed:
    the equation's residual, and the mean-square stability of the loop its
    gain gives (the estimation error, or the closed loop), proven by a
    certified bracket on the spectral radius of the second-moment map
    (:ref:`theory-estimation`).

    Attributes
    ----------
    residual : float
        ``‖S - g(S)‖ / max(1, ‖S‖)`` (Frobenius, over the link states).
    ms_radius : float
        The spectral radius of the gain's second-moment map: the exact
        (dense) eigenvalue when ``radius_exact``, else the certified upper
        end of ``ms_radius_bracket``.
    ms_radius_bracket : tuple of float
        ``(lower, upper)`` with ``lower ≤ ρ ≤ upper`` proven
        (Collatz–Wielandt: ``s Y ≼ 𝓛(Y) ≼ t Y`` for ``Y ≻ 0``);
        ``upper < 1`` is the proof of mean-square stability.
    radius_exact : bool
        Whether ``ms_radius`` is the dense eigenvalue.
    start : str
        Where the stabilising start of the policy iteration came from.
    newton_steps : int
        Policy (Newton) steps taken.
    route : str
        ``'dense'`` (Kronecker solves) or ``'matrix-free'`` (GMRES).
    link : str
        The arrival law solved for.
    success : bool
        True (a solution exists only with its checks passed).
    status : str
        ``'certified'``.
    message : str
        The verdict in one sentence.

    Examples
    --------
    >>> L, S, E, info = ncs.dlqe([[1.5]], [[1.0]], [[1.0]], [[1.0]], [[1.0]],
    ...                          arrival=0.6, full_output=True)
    >>> info.success, info.residual < 1e-12, info.ms_radius < 1
    (True, True, True)
    """

    residual: float
    ms_radius: float
    ms_radius_bracket: tuple
    radius_exact: bool
    start: str
    newton_steps: int
    route: str
    link: str

    _repr_fields: ClassVar[tuple[str, ...]] = ("residual", "ms_radius",
                                               "newton_steps")

    @property
    def message(self) -> str:
        """One sentence: what the checks proved."""
        return (f"certified: the equation holds to {self.residual:.2g} and "
                f"the gain's loop is mean-square stable (spectral radius "
                f"{self.ms_radius:.6g} <= {self.ms_radius_bracket[1]:.6g} "
                f"< 1)")

    def _details(self) -> list[str]:
        return [f"link: {self.link}",
                f"start: {self.start}; {self.newton_steps} policy steps "
                f"({self.route})"]


def _starts(eq: Equation) -> Iterator[tuple[str, Any]]:
    """Candidate gains, cheapest first; each is tried by one exact solve.

    Value iteration from below costs ``O(N n³)`` a step: far from the
    critical probability it converges in tens of steps, and its gain is
    then nearly optimal. Near it, the iteration crawls (rate → 1), and the
    closed-form gain (when ``C`` sees the unstable subspace), the gain after
    a fixed number of steps, the loss-free Riccati gain and the LMI's gain
    are tried in turn."""
    X = np.zeros((eq.N, eq.n, eq.n))
    done, converged = 0, False
    while done < VALUE_STEPS and not converged:
        new = eq.riccati(X)
        if not np.all(np.isfinite(new)):
            break
        done += 1
        step = float(np.linalg.norm(new - X))
        X = new
        converged = step <= 1e-13 * float(np.linalg.norm(X))
    finite = bool(np.all(np.isfinite(X)))
    if converged:
        yield f"value iteration (converged in {done} steps)", eq.gains(X)
    Lc = closed_form_gain(eq.A, eq.C)
    if Lc is not None:
        yield "closed-form gain", np.broadcast_to(Lc, (eq.N, eq.n, eq.p))
    if finite and not converged:
        yield f"value iteration ({done} steps)", eq.gains(X)
    try:
        P = sla.solve_discrete_are(eq.A.T, eq.C.T, eq.W, eq.R)
        yield "loss-free Riccati gain", eq.gains(
            np.broadcast_to(P, (eq.N, eq.n, eq.n)))
    except (ValueError, np.linalg.LinAlgError):
        pass
    if finite and not converged:
        for _ in range(VALUE_STEPS, 16 * VALUE_STEPS):
            X = eq.riccati(X)
        if np.all(np.isfinite(X)):
            yield f"value iteration ({16 * VALUE_STEPS} steps)", eq.gains(X)
    yield "LMI", None        # resolved by the caller (needs cvxpy)


class LmiAnswer(NamedTuple):
    """What the fixed-gain LMI said at one set of weights."""

    verdict: str                #: 'feasible', 'infeasible' or 'open'
    gain: np.ndarray | None     #: a gain that passed the exact check
    fixed: Fixed | None         #: its covariance and certificate
    margin: float | None        #: the LMI's best margin ``ε*``
    status: str                 #: the solver's status


#: The LMI's best margin at or below this (the solver's accuracy) proves,
#: on the solver's word, that no gain exists.
MARGIN_TOL = 1e-9


def lmi_gain(eq: Equation, solver: str | None = None) -> LmiAnswer:
    """Ask the fixed-gain LMI (:mod:`control_ncs.lmi.mare`) and check its
    gain exactly: ``'feasible'`` only with a gain whose ``ρ(𝓛_L) < 1`` is
    proven, ``'infeasible'`` when the best margin is ``≤ MARGIN_TOL`` (or
    the solver proves infeasibility), ``'open'`` otherwise."""
    from . import lmi
    from .lmi.mare import mare_model
    A, C = eq.A, eq.C
    # balanced coordinates x = diag(t) x̃ (powers of two, exact)
    t = lmi.balancing_scale(np.abs(A), np.zeros(eq.n),
                            np.abs(C).sum(axis=0), 16.0)
    t = np.ones(eq.n) if t is None else t
    At, Ct = A * (1 / t)[:, None] * t[None, :], C * t[None, :]
    model = mare_model(At, Ct, eq.a, eq.b)
    report = lmi.solve(model.problem, solver)
    if report.infeasible:
        return LmiAnswer("infeasible", None, None, None, report.status)
    if model.V[0].value is None or model.margin.value is None:
        return LmiAnswer("open", None, None, None, report.status)
    margin = float(model.margin.value)
    if margin > 0:
        L = t[None, :, None] * model.gains()
        fixed = solve_fixed(eq, L)
        if fixed is not None:
            return LmiAnswer("feasible", L, fixed, margin, report.status)
    verdict = "infeasible" if margin <= MARGIN_TOL and report.ok else "open"
    return LmiAnswer(verdict, None, None, margin, report.status)


def solve(eq: Equation, *, solver: str | None = None,
          dense: bool | None = None) -> Solution:
    """The stabilising solution of the coupled MARE, checked.

    Raises
    ------
    MareError
        ``'not_mss'`` when no gain can make ``𝓛_L`` a contraction (the
        lost part alone is not, or the LMI is infeasible: the figures say
        which); ``'not_found'`` or ``'not_verified'`` when no stabilising
        start was found or the answer fails its checks (nothing proven).
    """
    bound = eq.lost_radius()
    if not bound < 1.0:
        raise MareError("no gain is stabilising: the lost part alone has "
                        f"spectral radius {bound:.6g} >= 1", NOT_MSS,
                        dict(lost_radius=bound, proof="closed form"))
    fixed, start, answer, L0 = None, "", None, None
    for name, L in _starts(eq):
        if L is None:
            answer = lmi_gain(eq, solver)
            fixed, L = answer.fixed, answer.gain
        else:
            fixed = solve_fixed(eq, L, dense=dense)
        if fixed is not None:
            start, L0 = name, L
            break
    if fixed is None:
        figures: dict[str, Any] = dict(lost_radius=bound)
        if answer is not None:
            figures.update(status=answer.status, lmi_margin=answer.margin)
        if answer is not None and answer.verdict == "infeasible":
            raise MareError("no gain is stabilising: the fixed-gain LMI is "
                            "infeasible", NOT_MSS,
                            dict(figures, proof="LMI infeasible"))
        raise MareError("no stabilising gain was found (value iteration and "
                        "the LMI); nothing is proven either way", NOT_FOUND,
                        figures)
    return _newton(eq, fixed, np.array(L0), start, dense)


def _newton(eq: Equation, fixed: Fixed, L: np.ndarray, start: str,
            dense: bool | None) -> Solution:
    """Policy iteration from a certified stabilising gain ``L`` (``fixed``
    its exact covariance): ``L ← L_X``, ``X ←`` the covariance of ``L``,
    until the Riccati residual of ``X`` reaches the rounding level. The
    answer is the last gain with its exact covariance and its certificate.
    """
    change = np.inf
    steps = 0
    for steps in range(1, NEWTON_STEPS + 1):
        residual = eq.residual(fixed.X)
        if residual <= 1e-14:
            break
        L_new = eq.gains(fixed.X)
        new = solve_fixed(eq, L_new, x0=fixed.X, dense=dense,
                          certify=False)
        if new is None:
            raise MareError("a policy step lost its stability certificate "
                            "(the fixed-gain solve failed)", NOT_VERIFIED,
                            dict(start=start, newton_steps=steps))
        step = float(np.linalg.norm(new.X - fixed.X))
        fixed, L = new, L_new
        # at the rounding level of an ill-conditioned solve (near the
        # critical probability the solution is determined to about cond·ε
        # only), the steps stop shrinking
        if step <= 1e-14 * max(1.0, float(np.linalg.norm(fixed.X))) or (
                step >= change and eq.residual(fixed.X) <= 1e-10):
            break
        change = step
    if np.isnan(fixed.radius) or fixed.Y is None:
        certified = solve_fixed(eq, L, x0=fixed.X, dense=dense, final=True)
    else:                   # certified already: tighten its bracket
        bracket = collatz_wielandt(eq, L, fixed.Y)
        certified = fixed if bracket is None else fixed._replace(
            radius=min(fixed.radius, bracket[1]),
            radius_lower=max(fixed.radius_lower, bracket[0]))
    residual = eq.residual(fixed.X)
    if certified is None or not residual <= RESIDUAL:
        raise MareError(
            f"the solution fails its checks (residual {residual:.3g}, "
            f"stability {'not ' if certified is None else ''}certified)",
            NOT_VERIFIED, dict(residual=residual, start=start))
    exact = certified.radius_exact
    if exact is None and eq.N * eq.n * (eq.n + 1) // 2 <= EXACT_RADIUS_MAX:
        exact = float(np.max(np.abs(np.linalg.eigvals(
            dense_operator(eq, L)))))
    return Solution(certified.X, L, eq.residual(certified.X),
                    certified.radius, certified.radius_lower, exact, start,
                    steps, certified.route)


# -- the critical probability of one Bernoulli link ---------------------------
class Threshold(NamedTuple):
    """``λ_max`` of one Bernoulli link: exact, or a certified bracket."""

    lower: float          #: no gain at or below (closed form, or the LMI)
    upper: float          #: a gain is certified at (and above) this
    exact: bool           #: closed form (``lower == upper``)
    how: str              #: 'subspace', 'one channel' or 'bisection'
    gain: np.ndarray | None   #: the gain certified at ``upper``, if any
    radius: float         #: its certified ``ρ(𝓛_L)`` bound at ``upper``
    trials: int           #: LMIs solved
    inconclusive: int     #: LMIs the solver left open (counted as below)


def bernoulli(lam: float) -> tuple[np.ndarray, np.ndarray]:
    """The weights ``(a, b)`` of one Bernoulli link."""
    return np.ones((1, 1)), np.full((1, 1), float(lam))


def undetectable(A: np.ndarray, C: np.ndarray) -> list:
    """Eigenvalues of modulus ``≥ UNSTABLE`` that ``C`` does not see
    (PBH: ``[A - μI; C]`` rank deficient)."""
    n = A.shape[0]
    scale = max(1.0, float(np.linalg.norm(A, 2)), float(np.linalg.norm(C, 2)))
    out = []
    for mu in np.linalg.eigvals(A):
        if abs(mu) >= UNSTABLE:
            M = np.vstack([A - mu * np.eye(n), C.astype(complex)])
            if np.linalg.svd(M, compute_uv=False)[-1] <= 1e-10 * scale:
                out.append(complex(mu))
    return out


def mahler(A: np.ndarray) -> float:
    """``Π max(1, |μ_i|)`` over the eigenvalues of ``A``."""
    return float(np.prod(np.maximum(1.0, np.abs(np.linalg.eigvals(A)))))


def threshold(A: np.ndarray, C: np.ndarray, *, tol: float = 1e-7,
              solver: str | None = None,
              closed_forms: bool = True) -> Threshold:
    """The arrival probability above which a fixed gain exists, ``λ_max``.

    Closed forms: ``1 - 1/ρ(A)²`` when ``C`` sees the whole unstable
    subspace (Plarre and Bullo 2009); ``1 - 1/Π|μ_u|²`` (the unstable
    eigenvalues' product) when ``C`` has one row (the dual of Elia's
    mean-square capacity of a fading input channel, 2005). Otherwise a
    bracket (:func:`_bisect`) whose upper end is certified by the exact
    check of a gain and whose lower end rests on the LMI's solver, or is
    ``1 - 1/ρ(A)²`` (a proof). ``closed_forms=False`` brackets always (the
    tests compare both).

    Raises
    ------
    ValueError
        If ``(A, C)`` is not detectable (no gain even without loss).
    """
    missed = undetectable(A, C)
    if missed:
        raise ValueError(
            f"the unstable mode(s) {', '.join(f'{m:.4g}' for m in missed)} "
            f"are not seen by the measurement: no gain makes the error "
            f"stable, even without losses")
    rho = spectral_radius(A)
    low = max(0.0, 1.0 - 1.0 / rho ** 2) if rho > 0 else 0.0
    Lc = closed_form_gain(A, C) if closed_forms else None
    if Lc is not None:
        return Threshold(low, low, True, "subspace", Lc, float("nan"), 0, 0)
    if C.shape[0] == 1 and closed_forms:
        value = 1.0 - 1.0 / mahler(A) ** 2
        return Threshold(value, value, True, "one channel", None,
                         float("nan"), 0, 0)
    return _bisect(A, C, low, tol, solver)


def _below(eq: Equation, S: np.ndarray, L: np.ndarray) -> Solution | None:
    """The solution at an arrival below one already solved (``S``, its
    gain ``L``): ``S`` lies below the new solution, so value iteration
    from it is a start from below; the old gain and the iterates' gains
    are tried, then policy iteration. None when no gain passes the check
    (nothing proven)."""
    X = np.array(S)
    candidates = [("the gain one step above", L)]
    for steps in (16, 64, 256):
        for _ in range(steps):
            X = eq.riccati(X)
        if not np.all(np.isfinite(X)):
            break
        candidates.append((f"value iteration from above's solution "
                           f"({steps} steps)", eq.gains(X)))
    for name, gain in candidates:
        fixed = solve_fixed(eq, gain)
        if fixed is not None:
            try:
                return _newton(eq, fixed, gain, name, None)
            except MareError:
                return None
    return None


def _bisect(A: np.ndarray, C: np.ndarray, low: float, tol: float,
            solver: str | None) -> Threshold:
    """``λ_max`` between ``low`` (a proof) and 1, to ``tol``.

    A safeguarded secant: from above, the stabilising solution ``S(λ)`` is
    followed down, and ``1 / tr S(λ)``, which vanishes at ``λ_max`` (nearly
    linearly next to it), gives the next trial by the secant through the
    last two solutions, or the bisection midpoint when that falls outside
    the bracket. A solution found from the one above (value iteration from
    below, policy iteration) certifies the upper end; where none is found
    the LMI decides: its checked gain moves the upper end, its
    infeasibility the lower. When the trial comes within half the tolerance
    of the upper end, the next one is just below it, to settle the lower
    end in one LMI."""
    n, p = A.shape[0], C.shape[0]
    W, R = np.eye(n), np.eye(p)

    def equation(lam: float) -> Equation:
        return Equation(A, C, W, R, *bernoulli(lam))

    best = solve(equation(1.0), solver=solver)
    lo, hi = low, 1.0
    points = [(1.0, 1.0 / np.trace(best.X[0]))]
    trials = open_ = 0
    fresh = False               # a solution was added by the last trial
    for _ in range(200):
        if not hi - lo > tol * (1 + 1e-9):
            break
        mid = 0.5 * (lo + hi)
        if fresh and len(points) >= 2:
            (l1, f1), (l2, f2) = points[-2], points[-1]
            if f1 > f2:
                guess = l2 - f2 * (l1 - l2) / (f1 - f2)
                mid = guess if lo < guess < hi else mid
            if hi - mid < 0.5 * tol:
                mid = max(hi - tol, lo)   # settle the lower end just below
        fresh = False
        eq = equation(mid)
        found = _below(eq, best.X, best.gains)
        if found is None:
            answer = lmi_gain(eq, solver)
            trials += 1
            if answer.gain is not None and answer.fixed is not None:
                try:
                    found = _newton(eq, answer.fixed, answer.gain, "LMI",
                                    None)
                except MareError:
                    found = None
                if found is None:   # certified, but not followed further
                    hi = mid
                    continue
            else:
                lo = mid
                open_ += answer.verdict == "open"
                continue
        hi, best, fresh = mid, found, True
        points.append((mid, 1.0 / np.trace(found.X[0])))
    return Threshold(lo, hi, False, "bisection", best.gains[0], best.radius,
                     trials, open_)


def decide(eq: Equation, solver: str | None = None
           ) -> tuple[bool, str, np.ndarray | None, float]:
    """Whether some gain makes ``𝓛_L`` a contraction: ``(verdict, proof,
    gain, radius)``. The lost part's bound and the closed form are exact;
    otherwise a gain of the LMI that passes the exact check proves yes and
    the LMI's infeasibility no.

    Raises
    ------
    MareError
        ``'solver_failed'`` when the LMI decides neither way.
    """
    bound = eq.lost_radius()
    if not bound < 1.0:
        return False, "closed form: the lost part alone", None, bound
    Lc = closed_form_gain(eq.A, eq.C)
    if Lc is not None:
        L = np.broadcast_to(Lc, (eq.N, eq.n, eq.p)).copy()
        fixed = solve_fixed(eq, L)
        if fixed is not None:
            return True, "closed form", L, fixed.radius
    answer = lmi_gain(eq, solver)
    if answer.gain is not None and answer.fixed is not None:
        return True, "LMI gain, checked exactly", answer.gain, \
            answer.fixed.radius
    if answer.verdict == "infeasible":
        return False, "LMI infeasible", None, bound
    raise MareError(f"the fixed-gain LMI decided neither way (status "
                    f"{answer.status!r}, margin {answer.margin}); nothing is "
                    f"proven", SOLVER_FAILED, dict(status=answer.status))
