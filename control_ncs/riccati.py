"""A certified Riccati-type iteration for full-information synthesis.

The LMI of MATH §8 has ``N·n(n+1)/2`` unknowns and PSD blocks of side
``2n + m1``; an interior-point solver factors a dense ``s(s+1)/2`` block per
cone, so its time grows like ``n⁵``-``n⁶`` and its memory like ``n³``-``n⁴``
(docs/benchmarks.md §2a: at ``n = 64, N = 4`` Clarabel cannot allocate its
KKT system). When the gain sees the whole state at every phase
(``structure='full'``: ``E_k = I``, any actuator schedule) the same problem
is solved here by a monotone matrix iteration with ``O(N·M·n³)`` work per
sweep and ``O(N·n²)`` memory, numpy only.

Derivation (MATH §6, §8, §10)
-----------------------------
For the closed loop ``Ā_i = A_i + Bu_i K``, ``C̄ = C̄z + D̄u K`` (bars: means
over the modes of the phase, ``p_i`` their probabilities), the dissipation
matrix of MATH §6 is::

    Θ_k = [ Σ p Ā_iᵀ P⁺ Ā_i − r² P_k     M12        ]    P⁺ = P_{k+1}
          [ M12ᵀ                  −R_k(P⁺)           ]

with ``M12 = Σ p Ā_iᵀ P⁺ Bw_i − C̄ᵀ`` and
``R_k(P⁺) = D̄w + D̄wᵀ − 2ηI − Σ p Bw_iᵀ P⁺ Bw_i``. By a Schur complement on
the ``w`` block, ``Θ_k ≺ 0`` iff ``R_k ≻ 0`` and::

    r² P_k ≻ G_k(K; P⁺) = Σ p Ā_iᵀ P⁺ Ā_i + M12 R_k⁻¹ M12ᵀ.

``G_k`` is a matrix quadratic in ``K``,
``G = G0 + KᵀL + LᵀK + KᵀHK`` with ``H = Σ p Bu_iᵀ P⁺ Bu_i + Tᵀ R⁻¹ T``,
``L = Σ p Bu_iᵀ P⁺ A_i + Tᵀ R⁻¹ S0ᵀ``, ``S0 = Σ p A_iᵀ P⁺ Bw_i − C̄zᵀ``,
``T = Σ p Bw_iᵀ P⁺ Bu_i − D̄u``, so ``K* = −H⁻¹L`` minimises it in the
Loewner order: ``G(K) = G(K*) + (K − K*)ᵀ H (K − K*)``. A gain and a
certificate exist iff some ``P`` satisfies ``r² P_k ≻ G_k(K*; P_{k+1})`` for
every ``k``.

The map ``F_k(P⁺) = (G_k(K*; P⁺) + εI) / r²`` is monotone in ``P⁺``
(``xᵀ G x`` is a maximum over ``w`` and a minimum over ``u`` of expressions
increasing in ``P⁺``) and in ``η`` (``R`` decreases as ``η`` grows).
Iterating it backwards over the period from ``P = 0`` therefore gives an
increasing sequence that stays below every ``P̂`` with
``r² P̂_k ≽ G_k(K*; P̂_{k+1}) + εI``: it converges iff the LMI with the
margin ``ε`` is feasible, and its limit is the smallest such ``P̂``.

Verdicts at a fixed ``η``
-------------------------
* **converged**: after a sweep, the only phase whose residual is not
  ``εI`` by construction is the one that used ``P_0`` of the previous
  sweep; when ``r² P_{N-1} − G_{N-1}(K_{N-1}; P_0) ≽ (ε/2) I`` (a Cholesky
  factorisation, with ``R_{N-1} ≻ 0``), every ``Θ_k ≺ 0`` holds for the
  current ``(P, K)``. The caller still checks it exactly
  (:func:`control_ncs.verify.check_certificate`).
* **diverged**: ``R_k`` loses positive definiteness. Since every iterate
  lies below any solution of the LMI with margin, this proves that the LMI
  with margin ``ε`` is infeasible: :class:`~control_ncs.exceptions.SynthesisError`
  with reason ``'infeasible'``.
* **blow-up**: ``P`` exceeds ``1e12`` times the scale of the data. Any
  certificate would be at least as large, beyond what the exact check can
  verify in double precision; the LMI is probably infeasible, but this is a
  threshold, not a proof: reason ``'solver_failed'``.
* **out of sweeps**: inconclusive (the iteration converges sublinearly near
  the supremum of ``η``); reason ``'solver_failed'``.

Maximising ``η``
----------------
Bisection on ``η`` between a converged level and the feedthrough bound
``λmin(D̄w + D̄wᵀ)/2``, warm-started (``P(η)`` increases with ``η``, so the
iterate at a feasible level is a valid monotone start above it). After each
converged level the lower bound jumps to the supremum its ``P`` proves
(the Schur complement of :func:`control_ncs.verify.certified_index`, here
computed with BLAS products). A level still unconverged after
``probe_sweeps`` sweeps counts as infeasible: conservative (the result is
certified, only possibly below the supremum by more than ``rtol``).

References
----------
MATH §6 (analysis LMI), §8 (synthesis), §10 (generic jump plant);
docs/benchmarks.md §2 and §7.1 (measurements of this route against the LMI).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from control.exception import ControlArgument

from ._checks import decay_bound, positive_int, positive_real
from .jump import JumpPlant
from .exceptions import INFEASIBLE, SOLVER_FAILED, SynthesisError

__all__ = ["RiccatiResult", "riccati_synthesis",
           "RICCATI_MARGIN"]

#: Default margin ``ε`` of the iteration, relative to the scale of the data
#: (largest norm of ``C̄z``, ``D̄w + D̄wᵀ``, at least 1): each step adds
#: ``εI`` to ``r² P_k``. Large enough that the converged certificate clears
#: the exact check's rounding bound (``~16 n eps ‖Θ‖``) by orders of
#: magnitude, small enough to cost a negligible part of ``η``.
RICCATI_MARGIN = 1e-6

#: ``P`` larger than this times the data scale counts as divergence.
_BLOWUP = 1e12


@dataclass
class RiccatiResult:
    """Outcome of :func:`riccati_synthesis`.

    Attributes
    ----------
    gains : ndarray, shape (N, nu, nk), or None
        ``K_k``.
    P : ndarray, shape (N, n, n)
        The certificate candidate ``P_k`` (an iterate of the monotone
        sequence). Not yet checked exactly: the caller does that.
    eta : float
        The requested ``η``, or the largest level found: a converged level,
        or the supremum its ``P`` proves (not itself certified: the strict
        inequality holds only below it). Unchecked: :func:`passivesyn`
        certifies a level below it with
        :func:`control_ncs.verify.certify_index`, which is why these
        functions are internal (``control_ncs.riccati``), not exported.
    sweeps : int
        Backward sweeps over the period, over all levels tried.
    bisections : int
        Levels tried besides the first (0 for a fixed ``η``).
    time : float
        Seconds spent.
    """

    gains: np.ndarray | None
    P: np.ndarray
    eta: float
    sweeps: int
    bisections: int
    time: float


class _Phase:
    """One phase's data, restricted to live modes and active inputs."""

    def __init__(self, p, A, Bu, Bw, Cz, Du, Dw, active):
        live = np.flatnonzero(p > 0)
        self.p = p[live]
        self.active = active
        self.n, self.nw, self.nu = A.shape[-1], Bw.shape[-1], active.size
        # [A Bw Bu] per mode: one batched product gives every quadratic term
        self.F = np.concatenate([A[live], Bw[live], Bu[live][:, :, active]],
                                axis=2)
        self.Czb = np.einsum("i,iab->ab", self.p, Cz[live])
        self.Dub = np.einsum("i,iab->ab", self.p, Du[live])[:, active]
        Dwb = np.einsum("i,iab->ab", self.p, Dw[live])
        self.Dsym = Dwb + Dwb.T

    def quad(self, Pn: np.ndarray) -> tuple[np.ndarray, ...]:
        """Blocks of ``Σ p Fᵀ P⁺ F``: (AA, AW, AU, WW, WU, UU)."""
        F = self.F
        Q = np.tensordot(self.p, np.swapaxes(F, 1, 2) @ (Pn @ F), axes=1)
        n, nw = self.n, self.nw
        a, w, u = slice(0, n), slice(n, n + nw), slice(n + nw, None)
        return Q[a, a], Q[a, w], Q[a, u], Q[w, w], Q[w, u], Q[u, u]


def _sym(M: np.ndarray) -> np.ndarray:
    return 0.5 * (M + M.T)


def _chol(M: np.ndarray) -> np.ndarray | None:
    try:
        return np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        return None


def _step(d: _Phase, Pn: np.ndarray, eta: float):
    """``(G_k(K*; P⁺), K*)``, or None when ``R_k(P⁺)`` is not positive definite."""
    Qaa, Qaw, Qau, Qww, Qwu, Quu = d.quad(Pn)
    Lr = _chol(_sym(d.Dsym - 2 * eta * np.eye(d.nw) - Qww))
    if Lr is None:
        return None
    S0 = Qaw - d.Czb.T                                  # (n, nw)
    Ws = np.linalg.solve(Lr, S0.T)                      # L⁻¹ S0ᵀ
    G = Qaa + Ws.T @ Ws
    if d.nu == 0:
        return _sym(G), np.zeros((0, d.n))
    Wt = np.linalg.solve(Lr, Qwu - d.Dub)               # L⁻¹ T
    H = _sym(Quu + Wt.T @ Wt)
    L = Qau.T + Wt.T @ Ws                               # (nu, n)
    Lh = _chol(H)
    if Lh is not None:
        K = -np.linalg.solve(Lh.T, np.linalg.solve(Lh, L))
    else:   # H singular (P = 0 at the start): L lies in its range
        K = -np.linalg.lstsq(H, L, rcond=None)[0]
    return _sym(G + K.T @ L), K        # G0 + S0 R⁻¹ S0ᵀ − Lᵀ H⁻¹ L


def _blocks(d: _Phase, P: np.ndarray, Pn: np.ndarray, K: np.ndarray,
            decay: float):
    """``M11``, ``M12`` and ``M22`` at ``η = 0`` of ``Θ_k`` (MATH §6) for a gain."""
    Qaa, Qaw, Qau, Qww, Qwu, Quu = d.quad(Pn)
    KQ = K.T @ Qau.T
    M11 = Qaa + KQ + KQ.T + K.T @ Quu @ K - decay ** 2 * P
    M12 = Qaw + K.T @ Qwu.T - (d.Czb + d.Dub @ K).T
    return _sym(M11), M12, _sym(Qww - d.Dsym)


def _residual_ok(d: _Phase, P: np.ndarray, Pn: np.ndarray, K: np.ndarray,
                 eta: float, decay: float, slack: float) -> bool:
    """``Θ_k ≼ -slack·diag(I, 0)`` roughly: ``R ≻ 0`` and
    ``r² P_k − G_k(K; P⁺) ≽ slack·I`` (Cholesky factorisations)."""
    M11, M12, M22 = _blocks(d, P, Pn, K, decay)
    Lr = _chol(-M22 - 2 * eta * np.eye(d.nw))
    if Lr is None:
        return False
    W = np.linalg.solve(Lr, M12.T)
    return _chol(-(M11 + W.T @ W) - slack * np.eye(d.n)) is not None


def _certified_sup(data, P, K, decay):
    """Supremum of the ``η`` that ``(P, K)`` certify (``-inf``: none), by the
    Schur complement of :func:`control_ncs.verify.certified_index`; used only
    to move the bisection, never as a verdict."""
    N, best = len(data), np.inf
    for k, d in enumerate(data):
        M11, M12, M22 = _blocks(d, P[k], P[(k + 1) % N], K[k], decay)
        Lm = _chol(-M11)
        if Lm is None:
            return -np.inf
        W = np.linalg.solve(Lm, M12)
        S = _sym(M22 + W.T @ W)
        best = min(best, -np.linalg.eigvalsh(S)[-1] / 2)
    return float(best)


def _iterate(data, eta, decay, eps, P0, max_sweeps, blowup):
    """Backward sweeps from ``P0`` at level ``eta``.

    Returns ``(status, P, K, sweeps)`` with status ``'converged'`` (the
    current ``(P, K)`` satisfy every ``Θ_k ≺ 0``), ``'diverged'`` (some
    ``R_k`` lost positive definiteness: the LMI with margin is infeasible),
    ``'blowup'`` (``P`` beyond ``blowup``) or ``'max_sweeps'``.
    """
    N = len(data)
    n = data[0].n
    P = P0.copy()
    K = [None] * N
    eye = eps * np.eye(n)
    r2 = decay ** 2
    for sweep in range(1, max_sweeps + 1):
        change = 0.0
        for k in reversed(range(N)):
            out = _step(data[k], P[(k + 1) % N], eta)
            if out is None:          # R_k lost definiteness: a proof
                return "diverged", P, K, sweep
            G, K[k] = out
            new = (G + eye) / r2
            change = max(change, float(np.max(np.abs(new - P[k]))))
            P[k] = new
        top = float(np.max(np.abs(P)))
        if not np.isfinite(top) or top > blowup:
            # a threshold, not a proof: any certificate would be at least
            # this large, beyond what the exact check can verify
            return "blowup", P, K, sweep
        # Phases 0..N-2 have residual εI by construction; the wrap-around
        # phase N-1 used the previous P_0. Its exact residual decides, once
        # the increments are small enough for it to possibly hold.
        if change <= 1e2 * eps and _residual_ok(
                data[N - 1], P[N - 1], P[0], K[N - 1], eta, decay, eps / 2):
            return "converged", P, K, sweep
    return "max_sweeps", P, K, max_sweeps


def _scale(data) -> float:
    return max([1.0] + [float(np.linalg.norm(M, 2)) for d in data
                        for M in (d.Czb, d.Dsym) if M.size])


def _search(data, eta, decay, margin, rtol, max_sweeps, probe_sweeps):
    """Fixed ``eta``: one iteration; ``eta=None``: the bisection. Returns
    ``(P, K, η, sweeps, bisections)``; raises SynthesisError."""
    N, n = len(data), data[0].n
    scale = _scale(data)
    eps = margin * scale
    blowup = _BLOWUP * scale
    zero = np.zeros((N, n, n))
    figures = dict(margin=margin, decay=decay)

    if eta is not None:
        status, P, K, sweeps = _iterate(data, float(eta), decay, eps, zero,
                                        max_sweeps, blowup)
        if status == "diverged":
            raise SynthesisError(
                f"riccati: the iteration diverged at eta={eta} (sweep "
                f"{sweeps}): the LMI with margin {margin} is infeasible, no "
                "gain has a certificate for this eta and decay",
                INFEASIBLE, dict(figures, sweeps=sweeps))
        if status == "blowup":
            raise SynthesisError(
                f"riccati: inconclusive: P grew beyond {_BLOWUP:g} times the "
                f"data scale at eta={eta} (sweep {sweeps}): any certificate "
                "would be too large for double precision to verify; the LMI "
                "is probably infeasible", SOLVER_FAILED,
                dict(figures, sweeps=sweeps))
        if status == "max_sweeps":
            raise SynthesisError(
                f"riccati: inconclusive: the iteration did not converge in "
                f"max_sweeps={max_sweeps} sweeps at eta={eta} (nor diverge); "
                "raise max_sweeps, lower eta, or use an LMI solver",
                SOLVER_FAILED, dict(figures, sweeps=sweeps))
        return P, K, float(eta), sweeps, 0

    hi = min(float(np.linalg.eigvalsh(d.Dsym)[0]) for d in data) / 2
    width = max(1.0, abs(hi))
    sweeps = bis = 0
    while True:   # a feasible starting level: lower it until it converges
        trial = hi - width
        status, P, K, sw = _iterate(data, trial, decay, eps, zero,
                                    max_sweeps, blowup)
        sweeps += sw
        if status == "converged":
            lo = trial
            break
        if status == "max_sweeps":
            raise SynthesisError(
                f"riccati: inconclusive: no convergence in max_sweeps="
                f"{max_sweeps} sweeps at eta={trial:.6g}",
                SOLVER_FAILED, dict(figures, sweeps=sweeps))
        width *= 8
        if width > 1e8 * max(1.0, abs(hi)):
            if status == "diverged":
                raise SynthesisError(
                    "riccati: the iteration diverged for every eta down to "
                    f"{trial:.3g}: no gain has a certificate (margin "
                    f"{margin}, decay {decay})", INFEASIBLE,
                    dict(figures, sweeps=sweeps))
            raise SynthesisError(
                "riccati: inconclusive: for every eta down to "
                f"{trial:.3g}, P grew beyond {_BLOWUP:g} times the data "
                "scale: probably no mean-square stabilising gain exists "
                f"(margin {margin}, decay {decay})", SOLVER_FAILED,
                dict(figures, sweeps=sweeps))
    lo = max(lo, min(_certified_sup(data, P, K, decay), hi))
    while hi - lo > rtol * max(1.0, abs(hi)):
        mid = 0.5 * (lo + hi)
        status, Pm, Km, sw = _iterate(data, mid, decay, eps, P,
                                      probe_sweeps, blowup)
        sweeps += sw
        bis += 1
        if status != "converged":    # diverged, or (conservatively) too slow
            hi = mid
            continue
        P, K = Pm, list(Km)
        lo = max(mid, min(_certified_sup(data, P, K, decay), hi))
    return P, K, lo, sweeps, bis


def _options(rtol, max_sweeps, probe_sweeps, margin, decay):
    """The iteration's options, checked: (rtol, max_sweeps, probe_sweeps,
    margin, decay)."""
    return (positive_real(rtol, "rtol"), positive_int(max_sweeps, "max_sweeps"),
            positive_int(probe_sweeps, "probe_sweeps"),
            positive_real(margin, "margin"), decay_bound(decay))


def riccati_synthesis(plant: JumpPlant, eta: float | None = None, *,
                      decay: float = 1.0, margin: float = RICCATI_MARGIN,
                      rtol: float = 1e-4, max_sweeps: int = 20000,
                      probe_sweeps: int = 3000) -> RiccatiResult:
    """Full-information periodic gain by the monotone Riccati iteration.

    Finds ``K_k`` and ``P_k`` with ``Θ_k ≺ 0`` (MATH §6) for the plant's
    closed loop, at the given ``η`` or for the largest ``η`` the bisection
    reaches (see the module docstring for the derivation). The result is not
    checked here: :func:`control_ncs.passivesyn` checks it exactly.

    Parameters
    ----------
    plant : JumpPlant
        Every state known at every phase (``structure='full'``): each
        ``E_k`` selects all coordinates. Modes are merged here.
    eta : float, optional
        Dissipation to achieve; None maximises it.
    decay : float in (0, 1]
        Mean-square decay bound ``r`` (``r² P_k ≻ G_k``).
    margin : float
        ``ε`` relative to the data scale (:data:`RICCATI_MARGIN`).
    rtol : float
        Bisection stops when ``hi − lo ≤ rtol·max(1, |hi|)``.
    max_sweeps : int
        Sweep budget of a fixed ``η`` (and of the first level of the
        bisection).
    probe_sweeps : int
        Sweep budget of each bisection level; a level not converged by then
        counts as infeasible (conservative).

    Returns
    -------
    RiccatiResult

    Raises
    ------
    ValueError
        ``plant`` is not full-information, or a bad option.
    SynthesisError
        ``'infeasible'`` (divergence: the LMI with margin has no solution)
        or ``'solver_failed'`` (out of sweeps: inconclusive).
    """
    start = time.perf_counter()
    rtol, max_sweeps, probe_sweeps, margin, decay = _options(
        rtol, max_sweeps, probe_sweeps, margin, decay)
    if not isinstance(plant, JumpPlant):
        raise ControlArgument(
            f"plant: expected a JumpPlant (control_ncs.build(P)), got "
            f"{type(plant).__name__}")
    plant = plant.merged()
    s, N = plant.shape, plant.period
    nx = s["nx"]
    for k in range(N):
        if plant.known_coordinates(k).size < nx or not plant.is_selection():
            raise ValueError(
                "plant: the Riccati iteration needs every state known at "
                "every phase (structure 'full', E_k = I); this plant needs "
                "the LMI ('block' or 'extended')")
    data = [_Phase(plant.probabilities[k], plant.A[k], plant.Bu[k],
                   plant.Bw[k], plant.Cz[k], plant.Du[k], plant.Dw[k],
                   plant.active_inputs(k)) for k in range(N)]
    P, K, e, sweeps, bis = _search(data, eta, float(decay), margin, rtol,
                                   int(max_sweeps), int(probe_sweeps))
    gains = np.zeros((N, s["nu"], s["nk"]))
    for k in range(N):
        Kfull = np.zeros((s["nu"], nx))
        Kfull[data[k].active] = K[k]
        gains[k] = Kfull @ plant.E[k].T      # K_k E_k = Kfull (E_k selects all)
    return RiccatiResult(gains, P, float(e), sweeps, bis,
                         time.perf_counter() - start)

