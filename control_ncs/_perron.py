"""The certified Perron root of a map that keeps the PSD cone.

(:ref:`theory-mss`.) A linear map ``𝒯`` on ``M``-tuples of symmetric
``n × n`` matrices that maps positive semidefinite tuples to positive
semidefinite tuples (the second-moment operator of a jump system) has its
spectral radius ``ρ`` as an eigenvalue with a PSD eigenvector (Krein–Rutman).
For ``μ > ρ`` its resolvent ``(μ - 𝒯)⁻¹ = Σ_k 𝒯ᵏ / μᵏ⁺¹`` maps the cone
into itself. One linear solve at ``μ`` therefore decides on which side of
``μ`` the radius lies, whatever the accuracy of the solve:

* ``X ≻ 0`` and ``F = μX - 𝒯(X) ≻ 0``: then ``𝒯(X) ≺ μX``, a
  Collatz–Wielandt certificate, and ``ρ < μ``;
* ``F = μX - 𝒯(X) ⪰ 0`` and ``X`` not PSD: ``X`` is the solution of
  ``(μ - 𝒯)X = F``, which for ``μ > ρ`` would be PSD, so ``ρ ≥ μ``.

``F`` is recomputed from the ``X`` at hand with the exact map (matrix
products of the data, not the solver's matrix), and each sign is claimed
only beyond a bound on the rounding errors of that computation. The solve
(``X ≈ (μ - 𝒯)⁻¹ I``, a shifted inverse-iteration step from ``I``, so
``X`` leans on the Perron eigenvector and stays positive definite) is only
asked to make ``F`` close enough to ``I``. A search (:func:`certify`) sets
such probes just above and just below an estimate of ``ρ`` and moves the
estimate when a probe disproves it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

__all__: list[str] = []

#: Relative half-width the search aims for around the radius.
RADIUS_RTOL = 1e-12

#: Probes at most per bracket (two suffice when the estimate is right).
MAX_PROBES = 40

#: The least ``μ`` probed: a radius below it is bracketed by ``[0, TINY]``.
TINY = 1e-150

_EPS = np.finfo(float).eps


@dataclass(frozen=True, eq=False)
class Probe:
    """What one solve at ``mu`` proved.

    ``side``: ``'below'`` (``ρ < μ``, ``X ≻ 0`` is the certificate),
    ``'above'`` (``ρ ≥ μ``) or None (the solve was not accurate enough to
    decide). ``quotient``: ``μ - <X, F> / <X, X>``, an estimate of the
    eigenvalue nearest ``μ`` (nan when undecided); ``pole``:
    ``1 / Σ_j tr X_j``, whose root is ``ρ`` when the Perron term
    dominates. ``excess``: the rounding bound over ``λmin(F)`` (a probe
    needs it below 1; it scales like ``1/|μ - ρ|``), inf when ``F`` is not
    even positive as computed.
    """

    mu: float
    side: str | None
    X: np.ndarray
    quotient: float
    excess: float = math.inf
    pole: float = math.nan


#: ``residual(X, mu, wide)``: ``F = μX - 𝒯(X)`` and a bound on the
#: spectral norm of its error, in extended precision when ``wide``.
Residual = Callable[[np.ndarray, float, bool], tuple[np.ndarray, float]]


def _residual_excess(residual: Residual, X: np.ndarray, mu: float,
                     wide: bool) -> tuple[np.ndarray, float]:
    """``F`` and its rounding bound over ``λmin(F)`` (inf unless
    positive)."""
    F, err = residual(X, mu, wide)
    F = 0.5 * (F + F.swapaxes(-1, -2))
    lf = np.linalg.eigvalsh(F)
    err += 16 * X.shape[-1] * _EPS * float(np.abs(lf).max())
    F_min = float(lf[:, 0].min())
    return F, (err / F_min if F_min > 0 else math.inf)


def probe(residual: Residual, X: np.ndarray, mu: float) -> Probe:
    """Decide the side of ``mu`` from an approximate solution ``X``.

    ``X``: shape (M, n, n), symmetrised here. The residual is formed in
    double precision, and again in extended precision when that does not
    decide.
    """
    X = 0.5 * (X + X.swapaxes(-1, -2))
    if not np.all(np.isfinite(X)):
        return Probe(mu, None, X, math.nan)
    F, excess = _residual_excess(residual, X, mu, False)
    if not excess < 1:
        F, excess = _residual_excess(residual, X, mu, True)
    if not excess < 1:
        return Probe(mu, None, X, math.nan, excess)
    lx = np.linalg.eigvalsh(X)
    size_x = np.abs(lx).max(axis=-1)
    eig_round = 16 * X.shape[-1] * _EPS
    X_low, X_tol = lx[:, 0], eig_round * size_x
    quotient = mu - float(np.vdot(X, F)) / float(np.vdot(X, X))
    trace = float(np.trace(X, axis1=-2, axis2=-1).sum())
    pole = 1.0 / trace if trace else math.nan
    # the eigenvalues decide when they clear their rounding; near the
    # radius X is ill-conditioned, and a Cholesky factorisation or a
    # quadratic form in extended precision decides
    if all(X_low[j] > X_tol[j] or (X_low[j] > 0 and definite(X[j]))
           for j in range(len(X))):
        return Probe(mu, "below", X, quotient, excess, pole)
    if any(X_low[j] < -X_tol[j] or (X_low[j] < 0 and indefinite(X[j]))
           for j in range(len(X))):
        return Probe(mu, "above", X, quotient, excess, pole)
    return Probe(mu, None, X, math.nan, excess)


_WIDE = np.longdouble
_UNIT = float(np.finfo(_WIDE).eps) / 2          # unit roundoff


def definite(X: np.ndarray) -> bool:
    """True only if the symmetric ``X`` is positive definite: Cholesky of
    ``X - cI`` in extended precision runs to completion, with
    ``c = 2γ_{n+1} tr(X)`` (Rump, *Verification of positive definiteness*,
    BIT 2006: the floating-point factorisation is exact for a matrix within
    ``γ_{n+1} tr(X)`` of it)."""
    n = X.shape[0]
    gamma = (n + 1) * _UNIT / (1 - (n + 1) * _UNIT)
    d = np.diag(X)
    if np.any(d <= 0):
        return False
    A = X.astype(_WIDE) - _WIDE(2 * gamma * float(d.sum()) + 1e-300) * \
        np.eye(n, dtype=_WIDE)
    L = np.zeros((n, n), dtype=_WIDE)
    for j in range(n):
        s = A[j, j] - L[j, :j] @ L[j, :j]
        if not s > 0:
            return False
        L[j, j] = np.sqrt(s)
        L[j + 1:, j] = (A[j + 1:, j] - L[j + 1:, :j] @ L[j, :j]) / L[j, j]
    return True


def indefinite(X: np.ndarray) -> bool:
    """True only if the symmetric ``X`` has a negative direction: ``yᵀXy``
    for the eigenvector of its least eigenvalue, in extended precision,
    below minus its rounding bound ``γ_{n+1} |y|ᵀ|X||y|``."""
    n = X.shape[0]
    y = np.linalg.eigh(X)[1][:, 0]
    value = float(y.astype(_WIDE) @ X.astype(_WIDE) @ y.astype(_WIDE))
    bound = 2 * (n + 1) * _UNIT * float(np.abs(y) @ np.abs(X) @ np.abs(y))
    return value < -bound


@dataclass(frozen=True, eq=False)
class Bracket:
    """``lower ≤ ρ < upper`` (per period), proven by the probes.

    ``upper_X``: the Collatz–Wielandt certificate of the upper end
    (``X ≻ 0``, ``𝒯(X) ≺ upper·X``), None when no upper probe passed
    (``upper = inf``); ``lower_X``: the solution that is not PSD at
    ``lower`` (None when ``lower = 0``, which needs no proof).
    """

    lower: float
    upper: float
    estimate: float
    upper_X: np.ndarray | None
    lower_X: np.ndarray | None
    probes: int


def _next_estimate(lo: float, hi: float, seen: list[Probe],
                   jump: float) -> float:
    """Where the radius probably is, given the decided probes ``seen``.

    ``1/tr X(μ)`` (``X(μ) = (μ - 𝒯)⁻¹ I``) has a simple root at ``ρ``
    when the Perron term dominates the resolvent: the secant through the
    nearest probe on each side (or the last two) finds it superlinearly.
    Then the last probe's quotient, the middle of the bracket, or (no upper
    end yet) ``lo·(1 + jump)``.
    """
    # the latest probe and the latest one clearly apart from it
    last = seen[-1] if seen else None
    apart = [r for r in seen[:-1]
             if last is not None and abs(r.mu - last.mu) > 1e-9 * last.mu]
    if last is not None and apart:
        (m1, g1), (m2, g2) = (apart[-1].mu, apart[-1].pole), (last.mu,
                                                               last.pole)
        if g1 != g2 and np.isfinite(g1) and np.isfinite(g2):
            root = m2 - g2 * (m2 - m1) / (g2 - g1)
            if lo < root < hi:
                return root
    if seen and lo < seen[-1].quotient < hi:
        return seen[-1].quotient
    if hi < math.inf:
        return 0.5 * (lo + hi)
    return lo * (1 + jump)


def certify(residual: Residual, solve: Callable[[float], np.ndarray],
            estimate: float, *, atol: float = 0.0,
            rtol: float = RADIUS_RTOL, max_probes: int = MAX_PROBES,
            refine: Callable[[float, np.ndarray], np.ndarray] | None = None,
            first_step: float = 0.0) -> Bracket:
    """Bracket ``ρ(𝒯)`` by probes around ``estimate``.

    ``residual`` as for :func:`probe`; ``solve(mu)`` returns an approximation
    of ``(μ - 𝒯)⁻¹ I`` (shape (M, n, n)). Probes go to ``est·(1 + s)``
    and ``est·(1 - s)``, the step ``s`` from ``max(rtol, first_step)``
    (a prediction of where the rounding bound clears) up: an undecided
    probe raises it by its ``excess`` (the rounding bound shrinks like
    ``s``), at least tenfold, after one step of ``refine(mu, X)`` (an
    improved solution) when given. A probe on the wrong side of the
    estimate moves it (:func:`_next_estimate`). Done when the width is at
    most ``2.5·rtol`` relative, or the upper end at most ``atol`` (a scale
    for ``ρ ≈ 0``, at least ``TINY``), or no probe can narrow it.
    """
    lo, hi = 0.0, math.inf
    # below TINY a probe's X (≈ I/μ) and its squares would overflow; a
    # radius under it is reported as [0, TINY]
    atol = max(atol, TINY)
    est = max(float(estimate), atol)
    step, jump = max(rtol, first_step), 1e-6
    lo_X = hi_X = None
    seen: list[Probe] = []
    count = 0
    trusted = True          # an eigensolver's estimate: probe beside it
    while count < max_probes:
        if hi < math.inf and (hi - lo <= 2.5 * rtol * hi or
                              hi <= atol * (1 + 10 * rtol)):
            break
        if not lo < est < hi:
            new = _next_estimate(lo, hi, seen, jump)
            if hi == math.inf:
                jump *= 10
            # a small move means the estimates converge: bracket it next
            trusted = abs(new - est) <= 100 * step * est
            est = new
        up, down = est * (1 + step), est * (1 - step)
        can_up, can_down = up < hi, down > lo and step < 0.5
        if not trusted:
            mu = est            # one probe: which side, and a new secant
        # coming from above, the estimate is most likely still above
        elif can_down and (not can_up or seen and seen[-1].side == "below"):
            mu = down
        elif can_up:
            mu = up
        else:
            break
        res = probe(residual, solve(mu), mu)
        count += 1
        if res.side is None and refine is not None and \
                np.all(np.isfinite(res.X)):
            res = probe(residual, refine(mu, res.X), mu)
        if res.side is None:
            # the rounding bound shrinks like the step: jump to where it
            # clears; a failed solve (no excess) only tenfold
            grow = 2 * res.excess if math.isfinite(res.excess) else 10.0
            step *= min(max(10.0, grow), 1e6)
            trusted = True
            continue
        if res.side == "below":
            hi, hi_X = mu, res.X
        else:
            lo, lo_X = mu, res.X
        seen.append(res)
    first = float(estimate)
    point = first if lo <= first <= hi else min(max(est, lo), hi)
    return Bracket(lo, hi, point, hi_X, lo_X, count)


def power_estimate(apply: Callable[[np.ndarray], np.ndarray],
                   start: np.ndarray, steps: int = 30) -> float:
    """A rough ``ρ`` from the growth of ``𝒯ᵏ(start)`` (a fallback estimate
    when no eigensolver answered; the probes correct it)."""
    X = start
    ratio = 0.0
    for _ in range(steps):
        Y = apply(X)
        a, b = float(np.abs(Y).sum()), float(np.abs(X).sum())
        if a == 0.0 or b == 0.0:
            return 0.0
        ratio, X = a / b, Y / a
    return ratio
