"""A certified Riccati-type iteration for full-information synthesis.

The LMI of :ref:`theory-synthesis` has ``N·n(n+1)/2`` unknowns and PSD blocks
of side ``2n + m1``; an interior-point solver factors a dense ``s(s+1)/2``
block per cone, so its time grows like ``n⁵``-``n⁶`` and its memory like
``n³``-``n⁴`` (docs/benchmarks.md §2a: at ``n = 64, N = 4`` Clarabel cannot
allocate its KKT system). When the gain sees the whole state at every phase
(``structure='full'``: ``E_k = I``, any actuator schedule) the same problem
is solved here by a monotone matrix iteration with ``O(N·M·n³)`` work per
sweep and ``O(N·n²)`` memory, numpy only.

Derivation
----------
The theory: :ref:`theory-passivity`, :ref:`theory-synthesis`,
:ref:`theory-jump-system`.

For the closed loop ``Ā_i = A_i + Bu_i K``, ``C̄ = C̄z + D̄u K`` (bars: means
over the modes of the phase, ``p_i`` their probabilities), the dissipation
matrix of :ref:`theory-passivity` is::

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

Markov modes (coupled Riccati equations)
----------------------------------------
With a Markov chain of modes (:ref:`theory-markov`) the certificate is
``P_{k,ℓ}`` per previous mode ``ℓ`` and the gain ``K_{k,ℓ}``: for each ``ℓ``
the quadratic form above takes the row ``t = T_{k-1}[ℓ]`` in place of ``p`` and
``P_{k+1,i}`` per next mode ``i`` in place of ``P⁺``
(``Σ t_i F_iᵀ P_{k+1,i} F_i``). Previous modes with equal rows share one
equation (``modes.mode_classes``); i.i.d. modes have one per phase, the
iteration above. Monotonicity, the divergence proof and the convergence
test carry over unchanged, one equation at a time.

References
----------
O. L. V. Costa, M. D. Fragoso and R. P. Marques, *Discrete-Time Markov Jump
Linear Systems*, Springer, 2005 (coupled Riccati equations); S. Bittanti and
P. Colaneri, *Periodic Systems: Filtering and Control*, Springer, 2009
(periodic Riccati iterations);
:ref:`theory-passivity` (analysis LMI), :ref:`theory-synthesis` (synthesis),
:ref:`theory-jump-system` (generic jump plant), :ref:`theory-markov`;
docs/benchmarks.md §2 and §7.1 (measurements of this route against the LMI).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from control.exception import ControlArgument

from scipy.linalg import (LinAlgError, solve_discrete_are,
                          solve_discrete_lyapunov)

from ._checks import decay_bound, positive_int, positive_real
from .exceptions import (CERTIFIED, FEEDTHROUGH, INFEASIBLE, NOT_MSS,
                         SOLVER_FAILED, SynthesisError)
from .jump import JumpStateSpace
from .kyp import KYP_POINTS, FrequencyResponse
from .modes import mode_classes
from .openloop import JumpPlant
from .verify import (certify_index, check_certificate, dissipation_blocks,
                     feedthrough_bound, ifp_supremum)

__all__ = ["RiccatiResult", "riccati_synthesis",
           "RICCATI_MARGIN"]

#: Margin ``ε`` added at each step, relative to the data's scale: clears the
#: exact check's rounding bound by orders of magnitude at a negligible cost.
RICCATI_MARGIN = 1e-6

#: ``P`` larger than this times the data scale counts as divergence.
_BLOWUP = 1e12


@dataclass
class RiccatiResult:
    """Outcome of :func:`riccati_synthesis`.

    Attributes
    ----------
    gains : ndarray, shape (N, nu, nk) or (N, M, nu, nk), or None
        ``K_k``; Markov modes: ``K_{k,ℓ}`` per previous mode.
    P : ndarray, shape (N, n, n) or (N, M, n, n)
        The certificate candidate ``P_k`` (Markov: ``P_{k,ℓ}``), an
        iterate of the monotone sequence. Not yet checked exactly: the
        caller does that.
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

    def __init__(self, p, A, Bu, Bw, Cz, Du, Dw, active, means, nxt=None,
                 shared=None):
        live = np.flatnonzero(p > 0)
        self.p = p[live]
        self.live = live
        # Markov modes: the phase's products Fᵢᵀ P⁺ Fᵢ, shared by its classes
        self.shared = shared
        # Markov modes: the class of each live next mode at phase k + 1
        self.nxt = None if nxt is None else np.asarray(nxt)[live]
        self.active = active
        self.n, self.nw, self.nu = A.shape[-1], Bw.shape[-1], active.size
        # [A Bw Bu] per mode: one batched product gives every quadratic term
        self.F = np.concatenate([A[live], Bw[live], Bu[live][:, :, active]],
                                axis=2)
        # per-mode data for the verify kernel (closed loops of a gain)
        self.A, self.Bw, self.Bu = A[live], Bw[live], Bu[live][:, :, active]
        self.Cz, self.Du, self.Dw = Cz[live], Du[live][:, :, active], Dw[live]
        # the phase's means (JumpPlant.mean): C̄z, D̄u, D̄w
        self.Czb, Dub, Dwb = means
        self.Dub = Dub[:, active]
        self.Dsym = Dwb + Dwb.T

    def after(self, Pn: np.ndarray) -> np.ndarray:
        """``P⁺`` from the next phase's stack (one per class): the first
        (i.i.d.), or one per live next mode (Markov)."""
        return Pn[0] if self.nxt is None else Pn[self.nxt]

    def quad(self, Pnext: np.ndarray) -> tuple[np.ndarray, ...]:
        """Blocks of ``Σ p Fᵀ P⁺ F``: (AA, AW, AU, WW, WU, UU), from the
        next phase's stack ``Pnext`` (:meth:`after`). With Markov modes
        each mode's ``Fᵢᵀ P⁺ Fᵢ`` is the same for every class of previous
        modes (only the weights differ): computed once per stack."""
        if self.shared is not None:
            Y = self.shared.products(Pnext)[self.live]
        else:
            F = self.F
            Pn = self.after(Pnext)
            Y = np.swapaxes(F, 1, 2) @ (Pn @ F)
        Q = np.tensordot(self.p, Y, axes=1)
        n, nw = self.n, self.nw
        a, w, u = slice(0, n), slice(n, n + nw), slice(n + nw, None)
        return Q[a, a], Q[a, w], Q[a, u], Q[w, w], Q[w, u], Q[u, u]


class _Products:
    """``Fᵢᵀ P⁺_{cls(i)} Fᵢ`` of every mode ``i`` of one phase (Markov), for
    the last stack of next-phase ``P`` asked: the classes of previous modes
    of a phase weigh the same products (one sweep: one stack)."""

    def __init__(self, F: np.ndarray, nxt: np.ndarray, used: np.ndarray):
        self.F, self.nxt, self.used = F, np.asarray(nxt), used
        self.key: np.ndarray | None = None
        self.Y = np.zeros((F.shape[0], F.shape[2], F.shape[2]))

    def products(self, Pnext: np.ndarray) -> np.ndarray:
        if self.key is not Pnext:
            F, u = self.F[self.used], self.used
            self.Y[u] = np.swapaxes(F, 1, 2) @ (Pnext[self.nxt[u]] @ F)
            self.key = Pnext
        return self.Y


def _sym(M: np.ndarray) -> np.ndarray:
    return 0.5 * (M + M.T)


def _chol(M: np.ndarray) -> np.ndarray | None:
    try:
        return np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        return None


def _step(d: _Phase, Pn: np.ndarray, eta: float):
    """``(G_k(K*; P⁺), K*)``, or None when ``R_k(P⁺)`` is not positive definite."""
    Qaa, Qaw, Qau, Qww, Qwu, Quu = d.quad(Pn)   # Pn: the next stack
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


def _theta0(d: _Phase, P: np.ndarray, Pn: np.ndarray, K: np.ndarray,
            decay: float) -> np.ndarray:
    """``Θ_k`` at ``η = 0`` of the loop closed by ``K`` (the verify kernel)."""
    return dissipation_blocks(d.p, d.A + d.Bu @ K, d.Bw, d.Cz + d.Du @ K,
                              d.Dw, P, Pn, 0.0, decay=decay)


def _residual_ok(d: _Phase, P: np.ndarray, Pn: np.ndarray, K: np.ndarray,
                 eta: float, decay: float, slack: float) -> bool:
    """``Θ_k ≼ -slack·diag(I, 0)`` roughly: ``R ≻ 0`` and
    ``r² P_k − G_k(K; P⁺) ≽ slack·I`` (Cholesky factorisations)."""
    theta = _theta0(d, P, Pn, K, decay)
    n = d.n
    M11, M12, M22 = theta[:n, :n], theta[:n, n:], theta[n:, n:]
    Lr = _chol(-M22 - 2 * eta * np.eye(d.nw))
    if Lr is None:
        return False
    W = np.linalg.solve(Lr, M12.T)
    return _chol(-(M11 + W.T @ W) - slack * np.eye(d.n)) is not None


def _certified_sup(data, P, K, decay):
    """Supremum of the ``η`` that ``(P, K)`` certify (``-inf``: none), by
    :func:`control_ncs.verify.ifp_supremum`; used only to move the
    bisection, never as a verdict."""
    N = len(data)
    return min(ifp_supremum(_theta0(d, P[k][c], d.after(P[(k + 1) % N]),
                                    K[k][c], decay), d.n)
               for k, ds in enumerate(data) for c, d in enumerate(ds))


def _iterate(data, eta, decay, eps, P0, max_sweeps, blowup):
    """Backward sweeps from ``P0`` at level ``eta``.

    Returns ``(status, P, K, sweeps)`` with status ``'converged'`` (the
    current ``(P, K)`` satisfy every ``Θ_k ≺ 0``), ``'diverged'`` (some
    ``R_k`` lost positive definiteness: the LMI with margin is infeasible),
    ``'blowup'`` (``P`` beyond ``blowup``) or ``'max_sweeps'``.
    """
    N = len(data)
    n = data[0][0].n
    # P[k]: one matrix per class of previous modes (i.i.d.: one)
    P = [Pk.copy() for Pk in P0]
    K = [[None] * len(ds) for ds in data]
    eye = eps * np.eye(n)
    r2 = decay ** 2
    for sweep in range(1, max_sweeps + 1):
        change = 0.0
        for k in reversed(range(N)):
            new = np.empty_like(P[k])
            for c, d in enumerate(data[k]):
                out = _step(d, P[(k + 1) % N], eta)
                if out is None:      # R_k lost definiteness: a proof
                    return "diverged", P, K, sweep
                G, K[k][c] = out
                new[c] = (G + eye) / r2
            change = max(change, float(np.max(np.abs(new - P[k]))))
            P[k] = new
        top = max(float(np.max(np.abs(Pk))) for Pk in P)
        if not np.isfinite(top) or top > blowup:
            # a threshold, not a proof: any certificate would be at least
            # this large, beyond what the exact check can verify
            return "blowup", P, K, sweep
        # Phases 0..N-2 have residual εI by construction; the wrap-around
        # phase N-1 used the previous P_0. Its exact residual decides, once
        # the increments are small enough for it to possibly hold.
        if change <= 1e2 * eps and all(
                _residual_ok(d, P[N - 1][c], d.after(P[0]), K[N - 1][c],
                             eta, decay, eps / 2)
                for c, d in enumerate(data[N - 1])):
            return "converged", P, K, sweep
    return "max_sweeps", P, K, max_sweeps


def _scale(data) -> float:
    return max([1.0] + [float(np.linalg.norm(M, 2)) for ds in data
                        for d in ds for M in (d.Czb, d.Dsym) if M.size])


def _search(data, eta, decay, margin, rtol, max_sweeps, probe_sweeps):
    """Fixed ``eta``: one iteration; ``eta=None``: the bisection. Returns
    ``(P, K, η, sweeps, bisections)``; raises SynthesisError."""
    n = data[0][0].n
    scale = _scale(data)
    eps = margin * scale
    blowup = _BLOWUP * scale
    zero = [np.zeros((len(ds), n, n)) for ds in data]
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

    hi = min(float(np.linalg.eigvalsh(d.Dsym)[0]) for ds in data
             for d in ds) / 2
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
                    f"{trial:.3g}: no gain has a certificate with the "
                    f"strictness margin {margin} (relative), decay {decay}",
                    INFEASIBLE,
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
        P, K = Pm, [list(Kk) for Kk in Km]
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

    Finds ``K_k`` and ``P_k`` with ``Θ_k ≺ 0`` (:ref:`theory-passivity`) for
    the plant's closed loop, at the given ``η`` or for the largest ``η`` the
    bisection reaches (see the module docstring for the derivation). Markov
    modes (:ref:`theory-markov`): ``K_{k,ℓ}`` and ``P_{k,ℓ}`` per previous
    mode, from the coupled equations. The result is not checked here:
    :func:`control_ncs.passivesyn` checks it exactly.

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
    plant.require_noise_free("the Riccati iteration")
    plant = plant.merged()
    s, N = plant.shape, plant.period
    nx = s["nx"]
    for k in range(N):
        if plant.known_coordinates(k).size < nx or not plant.is_selection():
            raise ValueError(
                "plant: the Riccati iteration needs every state known at "
                "every phase (structure 'full', E_k = I); this plant needs "
                "the LMI ('block' or 'extended')")
    data, labels = _phases(plant)
    P, K, e, sweeps, bis = _search(data, eta, float(decay), margin, rtol,
                                   int(max_sweeps), int(probe_sweeps))
    M = plant.probabilities.shape[1]
    gains = np.zeros((N, len(labels[0]) if labels else 1, s["nu"], s["nk"]))
    cert = np.zeros((N, gains.shape[1], nx, nx))
    for k in range(N):
        for ell, c in enumerate(labels[k] if labels else [0]):
            Kfull = np.zeros((s["nu"], nx))
            Kfull[data[k][c].active] = K[k][c]
            # K_k E_k = Kfull (E_k selects all)
            gains[k, ell] = Kfull @ plant.E[k].T
            cert[k, ell] = P[k][c]
    if not labels:
        gains, cert = gains[:, 0], cert[:, 0]
    assert not labels or gains.shape[1] == M
    return RiccatiResult(gains, cert, float(e), sweeps, bis,
                         time.perf_counter() - start)


def _phases(plant: JumpPlant) -> tuple[list, list]:
    """The equations of each phase: one :class:`_Phase` (i.i.d. modes), or
    one per class of previous modes with equal rows ``T_{k-1}[ℓ]``
    (Markov, :ref:`theory-markov`), and the class of each ``ℓ`` per phase
    (empty list
    for i.i.d. modes)."""
    N = plant.period
    if plant.transition is None:
        _, _, _, Czb, Dub, Dwb = plant.mean()
        return [[_Phase(plant.probabilities[k], plant.A[k], plant.Bu[k],
                        plant.Bw[k], plant.Cz[k], plant.Du[k], plant.Dw[k],
                        plant.active_inputs(k), (Czb[k], Dub[k], Dwb[k]))]
                for k in range(N)], []
    T = plant.transitions()
    classes = [mode_classes(T[k - 1]) for k in range(N)]
    data = []
    for k in range(N):
        ds = []
        active = plant.active_inputs(k)
        used = np.flatnonzero(np.any(T[k - 1][classes[k][1]] > 0, axis=0))
        shared = _Products(np.concatenate(
            [plant.A[k], plant.Bw[k], plant.Bu[k][:, :, active]], axis=2),
            classes[(k + 1) % N][0], used)
        for rep in classes[k][1]:
            t = T[k - 1][rep]
            means = tuple(np.einsum("m,mij->ij", t, X[k])
                          for X in (plant.Cz, plant.Du, plant.Dw))
            ds.append(_Phase(t, plant.A[k], plant.Bu[k], plant.Bw[k],
                             plant.Cz[k], plant.Du[k], plant.Dw[k],
                             active, means,
                             nxt=classes[(k + 1) % N][0], shared=shared))
        data.append(ds)
    return data, [c[0] for c in classes]


# -- deterministic systems: the DARE storage of the certified index ----------
# The analysis route of control_ncs.passivity_certificate for an LTI system
# (one mode, period 1): no iteration, one Riccati equation per level.

#: Levels below ν̂ (units of max(1, |ν̂|)) at which the DARE is solved, in
#: turn; the first leaves room for certify_index's own 1e-6 back-off.
RICCATI_BACKOFFS = (1e-7, 1e-6, 1e-5, 1e-4, 1e-3)

#: Strictness ε as a fraction of the largest admissible one (estimated on a
#: grid that can miss a peak: hence well below 1).
RICCATI_EPS_FRACTION = 0.25

#: Pencil corrections of ν̂ (a dip of ``λmin`` that the grid missed) before
#: the Riccati route gives up and, under ``'auto'``, the LMI takes over.
KYP_CORRECTIONS = 4

def dare_storage(resp: FrequencyResponse, eta: float, eps: float
                     ) -> np.ndarray | None:
    """``P ≻ 0`` with ``Θ(P, η) ≺ 0`` from one Riccati equation, or None.

    Derivation. For ``ξ⁺ = Aξ + Bw``, ``z = Cξ + Dw`` (:ref:`theory-passivity`
    with one mode and ``N = 1``; the matrix of
    ``verify.dissipation_matrices``)::

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


def dare_certificate(sys: JumpStateSpace, mats: tuple, ifp_index: float | None,
                     decay: float) -> tuple:
    """The Riccati route of :func:`control_ncs.passivity_certificate`.

    For a deterministic system ``mats = (A, B, C, D)``: the KYP frequency
    test gives ``ν̂``, one DARE just below it (:func:`dare_storage`) gives
    ``P``, checked exactly. Returns ``(reason, eta, certificate, report,
    eta_upper, figures)``: ``reason`` None when no level gave a
    certificate that passes the exact check (the caller falls back to the
    LMI or raises), else ``'certified'``, ``'not_mss'``, ``'feedthrough'``
    or ``'infeasible'`` (KYP refutation); ``report`` is a dict of
    :class:`control_ncs.lmi.SolveReport`'s fields, or None.
    """
    start = time.perf_counter()
    A, B, C, D = mats
    # ms_radius of a deterministic system is ρ(A)², the Schur form's
    # diagonal (decay > 0: checked at the public boundary)
    resp = FrequencyResponse(A / decay, B / decay, C, D)
    if not (resp.radius * decay) ** 2 < min(1.0, decay ** 2):
        return NOT_MSS, np.nan, None, None, np.nan, {}
    if ifp_index is not None and not feedthrough_bound(
            sys.modes.probabilities, sys.modes.D)[0] > ifp_index:
        return FEEDTHROUGH, float(ifp_index), None, None, np.nan, {}
    level0 = np.nan if ifp_index is None else float(ifp_index)
    grid = np.linspace(0.0, np.pi, KYP_POINTS)
    lam, gain = resp.values(grid)
    upper, theta = resp.minimum(grid, lam)
    t_freq = time.perf_counter() - start

    def strictness(level: float) -> float:
        # Φ - εFᴴF ≻ 0 (see dare_storage) at θ where
        # 2(λmin(θ) - η) > ε‖F(θ)‖²; the grid and θ̂ estimate the worst θ
        _, at = resp.values(np.array([theta]))
        norms = np.append(gain, at) ** 2
        room = 2 * (np.append(lam, upper) - level)
        ok = norms > 0
        limit = (room[ok] / norms[ok]).min() if ok.any() else room.min()
        return RICCATI_EPS_FRACTION * float(limit)

    levels, solves, corrections = [], 0, 0
    cert, level, eps = None, np.nan, np.nan

    def report(status: str, message: str = "") -> dict:
        total = time.perf_counter() - start
        return dict(status=status, solver="scipy.linalg.solve_discrete_are",
                    compile_time=t_freq, solve_time=total - t_freq,
                    total_time=total, iterations=solves, value=float(level),
                    message=message,
                    options=dict(level=float(level), eps=float(eps)))

    def refuted() -> tuple:
        # KYP: Θ ≺ 0 needs G + Gᴴ ≻ 2ηI at every frequency
        return (INFEASIBLE, level0, None,
                report("infeasible", f"λmin(G + Gᴴ)/2 = {upper:.10g} ≤ η "
                       f"at θ = {theta:.10g} rad/sample"), upper, {})

    fixed = ifp_index is not None
    if fixed and not level0 < upper:
        return refuted()
    plan = [None] if fixed else list(RICCATI_BACKOFFS)
    while plan:
        backoff = plan.pop(0)
        # backoff is None exactly when the level is fixed
        step = 0.0 if backoff is None else backoff * max(1.0, abs(upper))
        level = level0 if fixed else upper - step
        eps = strictness(level)
        levels.append(level)
        solves += 1
        P = dare_storage(resp, level, eps)
        if P is not None:
            P = P[None] / decay ** 2
            cert = (check_certificate(sys, P, level, decay=decay) if fixed
                    else certify_index(sys, P, decay=decay))
            # an index must come with P proving (nearly) the level asked
            if cert.verified and (fixed or cert.eta_sup >= level - step):
                return (CERTIFIED, cert.eta, cert, report("optimal"), upper,
                        {})
        if corrections < KYP_CORRECTIONS:
            corrections += 1
            lower = resp.lower_near_crossings(level)
            # accept a dip the grid missed only if it takes at least half
            # the room between level and ν̂ (not a rounding-level change)
            if lower is not None and lower[0] < 0.5 * (level + upper):
                upper, theta = lower
                if fixed:
                    if not level0 < upper:
                        return refuted()
                    plan = [None]
                else:
                    plan = list(RICCATI_BACKOFFS)
    figures = dict(levels=levels, eta_upper=upper, frequency=theta,
                   **(cert.figures() if cert is not None else {}))
    return None, np.nan, None, None, upper, figures


# -- jump systems: the coupled Riccati iteration as an analysis route ---------
# A fixed loop is the plant of riccati_synthesis with no control input: the
# same monotone iteration then decides the analysis LMI (Θ_k ≺ 0, or
# Θ_{k,ℓ} ≺ 0 for Markov modes) with O(N·M·n³) work per sweep instead of an
# interior-point solve whose dense cones grow like n⁶.

#: Above this many states ``passivity_certificate(method='auto')`` tries the
#: coupled Riccati iteration before the LMI on a jump system (as passivesyn
#: does for synthesis).
COUPLED_THRESHOLD = 8


def coupled_certificate(sys: JumpStateSpace, ifp_index: float | None,
                        decay: float) -> tuple:
    """The Riccati route of :func:`control_ncs.passivity_certificate` for a
    jump system (``ρ = 0``).

    The loop's modes as a :class:`JumpPlant` without control input, given
    to :func:`riccati_synthesis` (the iteration's certificate ``P_k``, or
    ``P_{k,ℓ}``, at the level asked or the largest its bisection reaches),
    then checked exactly. Returns ``(reason, eta, certificate, report,
    figures)``: ``reason`` ``'certified'``, or None when the iteration gave
    nothing that passes the exact check (the caller falls back to the LMI
    or raises); ``report`` a dict of :class:`control_ncs.lmi.SolveReport`'s
    fields.
    """
    m = sys.modes
    N, M, nx = m.A.shape[0], m.A.shape[1], m.A.shape[-1]
    plant = JumpPlant(m.A, np.zeros((N, M, nx, 0)), m.B, m.C,
                      np.zeros((N, M, m.C.shape[-2], 0)), m.D,
                      np.repeat(np.eye(nx)[None], N, axis=0), m.probabilities,
                      sys.dt, transition=m.transition)
    try:
        res = riccati_synthesis(plant, ifp_index, decay=decay)
    except SynthesisError as err:
        return None, np.nan, None, None, dict(riccati=err.reason,
                                              **err.figures)
    cert = (certify_index(sys, res.P, decay=decay) if ifp_index is None
            else check_certificate(sys, res.P, ifp_index, decay=decay))
    if not cert.verified:
        return None, np.nan, None, None, cert.figures()
    report = dict(status="optimal", solver="RICCATI", compile_time=0.0,
                  solve_time=res.time, total_time=res.time,
                  iterations=res.sweeps, value=float(res.eta),
                  message="coupled Riccati iteration (no control input)")
    return CERTIFIED, cert.eta, cert, report, {}
