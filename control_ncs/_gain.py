"""The ℓ2 gain of a fixed jump system from its Riccati equation.

(:ref:`theory-performance`.) For a fixed loop the bounded real lemma is
exact, and its boundary is a Riccati equation: the value of the game
``sup_w E Σ_t (‖z_t‖² - γ²‖w_t‖² + ε‖ξ_t‖²)`` over inputs adapted to the
past is ``ξᵀ P_{k,ℓ} ξ`` (per phase ``k`` and, for Markov modes, previous
mode ``ℓ``: the rows ``t`` of :func:`control_ncs.verify.supply_rows`), with
``P = S(M(P)) + εI``, ``M(P) = Σ_i t_i ([A_i B_i]ᵀ P⁺_i [A_i B_i] +
[C_i D_i]ᵀ[C_i D_i]) - diag(0, γ²I)`` and ``S`` its Schur complement on the
``w`` block, which must stay negative definite. The stabilizing solution
exists when ``γ`` exceeds the gain of the loop with the output
``[z; √ε ξ]``, and then ``Θ(P, γ²) = M - diag(P, 0)`` has the Schur
complement ``-εI``: a strict certificate, checked exactly by
:func:`control_ncs.verify.gain_certificate_check`.

The equation is solved by policy iteration (Newton–Kleinman for the
maximising input: each step solves the linear equation of the loop closed
by ``w = W ξ``, dense over one period). The maximising policy also gives a
lower bound: the input ``w = v`` at phase ``k`` when the previous mode is
``ℓ``, then ``w = W ξ``, from rest, has the energies ``vᵀ N_z v`` and
``vᵀ N_w v`` (the same linear equations), so the gain is at least
``√λmax(N_z, N_w)``. Bisection on ``γ`` closes the bracket.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq
from scipy.sparse.linalg import eigs

from .jump import JumpStateSpace
from .verify import gain_certificate_check, supply_rows

__all__: list[str] = []

#: Policy evaluations above this many unknowns (``L·n²``) are not solved
#: here (a dense LU of the one-period map).
RICCATI_MAX_SIZE = 1600

#: Newton steps at most per level.
NEWTON_STEPS = 60

#: Strictness terms ``ε`` tried per level, relative to the size of the
#: storage: the certificate's Schur complement is ``-εI``, which must clear
#: the rounding of ``Θ`` (about ``eps·‖P‖``) in the exact check.
STRICTNESS = (1e-11, 1e-9, 1e-7)

_EPS = float(np.finfo(float).eps)


@dataclass(frozen=True, eq=False)
class LoopData:
    """The per-mode arrays the Riccati equation reads, rows included."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    rows: np.ndarray          # (N, L, M): the law of the mode at phase k
    markov: bool

    @property
    def shape(self) -> tuple[int, int, int, int]:
        """``(N, L, n, m)``."""
        N, L, _ = self.rows.shape
        return N, L, self.A.shape[-1], self.B.shape[-1]

    @classmethod
    def of(cls, J: JumpStateSpace) -> "LoopData":
        """The arrays of ``J``."""
        m = J.modes
        return cls(m.A, m.B, m.C, m.D, supply_rows(m), not m.is_iid)


@dataclass(frozen=True, eq=False)
class Level:
    """The Riccati solution at one ``γ``: storage, worst policy, check."""

    gamma: float
    P: np.ndarray             # (N, L, n, n)
    W: np.ndarray             # (N, L, m, n): the maximising w = W ξ
    certified: bool
    theta_max: np.ndarray
    P_min: np.ndarray


@dataclass(frozen=True, eq=False)
class GainBracket:
    """``lower ≤ gain < upper``: the certified level and the worst input's
    gain; ``level`` None when no level was certified."""

    upper: float
    lower: float
    level: Level | None
    levels: int


def bellman(d: LoopData, P: np.ndarray, gamma2: float) -> np.ndarray:
    """``M(P)`` per phase and row, shape (N, L, n + m, n + m)."""
    N, L, n, m = d.shape
    out = np.empty((N, L, n + m, n + m))
    F = np.concatenate([d.A, d.B], axis=-1)         # (N, M, n, n + m)
    H = np.concatenate([d.C, d.D], axis=-1)
    HH = H.transpose(0, 1, 3, 2) @ H
    for k in range(N):
        nxt = P[(k + 1) % N]
        Pn = nxt if d.markov else nxt[[0] * F.shape[1]]
        FPF = F[k].transpose(0, 2, 1) @ Pn @ F[k] + HH[k]
        for ell in range(L):
            out[k, ell] = np.tensordot(d.rows[k, ell], FPF, axes=1)
    out[..., n:, n:] -= gamma2 * np.eye(m)
    return 0.5 * (out + out.swapaxes(-1, -2))


class PolicyMap:
    """``P ↦ (Σ_i t_i G_iᵀ P⁺_i G_i)_{k,ℓ}``, ``G_i = A_i + B_i W_{k,ℓ}``:
    the adjoint second-moment map of the loop closed by ``w = W ξ``, as
    dense matrices per phase (row-major ``vec``)."""

    def __init__(self, d: LoopData, W: np.ndarray):
        N, L, n, _ = d.shape
        self.shape, self.size = (N, L, n, n), L * n * n
        self.ops = []
        for k in range(N):
            Ak = np.zeros((L, n * n, L, n * n))
            for ell in range(L):
                for i in np.flatnonzero(d.rows[k, ell] > 0):
                    G = d.A[k, i] + d.B[k, i] @ W[k, ell]
                    Ak[ell, :, i if d.markov else 0] += \
                        d.rows[k, ell, i] * np.kron(G.T, G.T)
            self.ops.append(Ak.reshape(self.size, self.size))

    def apply(self, P: np.ndarray) -> np.ndarray:
        """``(𝒜_k P_{k+1})_k``."""
        N = self.shape[0]
        flat = P.reshape(N, self.size)
        out = np.array([self.ops[k] @ flat[(k + 1) % N] for k in range(N)])
        return out.reshape(self.shape)

    def solve(self, Q: np.ndarray) -> np.ndarray:
        """``P = 𝒜(P) + Q`` over the period (``P_N = P_0``)."""
        N, size = self.shape[0], self.size
        q = Q.reshape(N, size)
        Phi, c = np.eye(size), np.zeros(size)
        for k in range(N):
            c += Phi @ q[k]
            Phi = Phi @ self.ops[k]
        out = np.empty((N, size))
        out[0] = np.linalg.solve(np.eye(size) - Phi, c)
        for k in range(N - 1, 0, -1):
            out[k] = self.ops[k] @ out[(k + 1) % N] + q[k]
        P = out.reshape(self.shape)
        return 0.5 * (P + P.swapaxes(-1, -2))


def stage_cost(d: LoopData, W: np.ndarray, z: float, w: float,
               x: float) -> np.ndarray:
    """``z Σ_i t_i ‖(C_i + D_i W)ξ‖² + w ‖Wξ‖² + x ‖ξ‖²`` as matrices."""
    N, L, n, _ = d.shape
    Q = np.empty((N, L, n, n))
    for k in range(N):
        for ell in range(L):
            Z = d.C[k] + d.D[k] @ W[k, ell]
            ZZ = np.tensordot(d.rows[k, ell], Z.transpose(0, 2, 1) @ Z, 1)
            Q[k, ell] = z * ZZ + w * W[k, ell].T @ W[k, ell] + x * np.eye(n)
    return 0.5 * (Q + Q.swapaxes(-1, -2))


def solve_level(d: LoopData, gamma: float, eps: float,
                start: np.ndarray | None = None
                ) -> tuple[np.ndarray, np.ndarray] | None:
    """The stabilizing solution ``(P, W)`` at ``γ`` (with ``ε``), or None.

    Newton–Kleinman for the maximising input from ``start``, a policy whose
    loop is mean-square stable (default ``W = 0``, the loop itself; the
    policy of a higher level also is). Each step evaluates the policy
    (``P = 𝒜_W(P) + Q_W``) and improves it (``W = -M22⁻¹ M21``); while
    the improved policies keep the loop mean-square stable the storages
    increase (the improved policy does at least as well on the old
    storage). None, not a proof, when the ``w`` block is not negative
    definite, a storage decreases (the policy's loop left mean-square
    stability: ``γ`` is below the level), a step is singular, or
    ``NEWTON_STEPS`` pass.
    """
    N, L, n, m = d.shape
    gamma2 = gamma * gamma
    W = np.zeros((N, L, m, n)) if start is None else start
    last, previous = math.inf, None
    for _ in range(NEWTON_STEPS):
        with np.errstate(all="ignore"):
            try:
                P = PolicyMap(d, W).solve(stage_cost(d, W, 1.0, -gamma2,
                                                     eps))
            except np.linalg.LinAlgError:
                return None
            if not np.all(np.isfinite(P)):
                return None
            M = bellman(d, P, gamma2)
        scale = float(np.abs(P).max())
        if previous is not None and np.linalg.eigvalsh(
                P - previous)[..., 0].min() < -1e-9 * scale:
            return None
        M22, M21 = M[..., n:, n:], M[..., n:, :n]
        if np.any(np.linalg.eigvalsh(M22)[..., -1] >= 0):
            return None
        W = -np.linalg.solve(M22, M21)
        # the Riccati residual, zero at the fixed point
        S = M[..., :n, :n] + M21.swapaxes(-1, -2) @ W
        res = float(np.abs(S + eps * np.eye(n) - P).max())
        if res <= 1e-13 * scale or (res <= 1e-9 * scale and res >= last):
            return P, W
        last, previous = res, P
    return None


def certify_level(J: JumpStateSpace, d: LoopData, gamma: float,
                  scale: float, start: np.ndarray | None = None
                  ) -> Level | None:
    """Solve at ``γ`` and check the storage exactly, with the strictness
    terms ``STRICTNESS`` (times ``scale``, the storage's expected size)
    in turn; None when no solution exists at the first."""
    found = None
    for rel in STRICTNESS:
        sol = solve_level(d, gamma, rel * scale, start)
        if sol is None:
            return found
        P, W = sol
        stack = P if d.markov else P[:, 0]
        ok, theta_max, P_min = gain_certificate_check(J, stack, gamma)
        found = Level(gamma, P, W, ok, theta_max, P_min)
        if ok:
            return found
        scale = max(scale, float(np.abs(P).max()))
    return found


def _period(op: PolicyMap, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                    np.ndarray]:
    """``Φ = 𝒜_0 ⋯ 𝒜_{N-1}``, the cost ``c`` of one period from phase 0,
    and ``Q`` flattened per phase."""
    N = op.shape[0]
    q = Q.reshape(N, op.size)
    Phi, c = np.eye(op.size), np.zeros(op.size)
    for k in range(N):
        c += Phi @ q[k]
        Phi = Phi @ op.ops[k]
    return Phi, c, q


def horizon_values(op: PolicyMap, costs: list[np.ndarray],
                   growth: float = 1e10) -> list[np.ndarray]:
    """Finite-horizon costs ``Σ_{t<T} 𝒜^t Q`` per phase for each ``Q`` of
    ``costs``, all over the same horizon: the first ``T = 2^j`` periods at
    which the first cost exceeds ``growth`` times one period's (at most
    ``2^60`` periods; the loop need not be stable)."""
    N = op.shape[0]
    periods = [_period(op, Q) for Q in costs]
    Phi = periods[0][0]
    c0 = periods[0][1]
    S, power = np.eye(op.size), Phi
    base = max(float(np.abs(c0).max()), 1e-300)
    for _ in range(60):
        S_next, power = S + power @ S, power @ power
        if not np.all(np.isfinite(S_next)):
            break
        S = S_next
        if float(np.abs(S @ c0).max()) > growth * base:
            break
    out = []
    for _, c, q in periods:
        vals = np.empty((N, op.size))
        vals[0] = S @ c
        for k in range(N - 1, 0, -1):
            vals[k] = op.ops[k] @ vals[(k + 1) % N] + q[k]
        out.append(vals.reshape(op.shape))
    return out


def worst_input_gain(d: LoopData, W: np.ndarray) -> float:
    """A lower bound on the ℓ2 gain from the policy ``W``.

    The input ``w = v`` at phase ``k`` when the previous mode is ``ℓ``,
    then ``w = W ξ`` for a long horizon (:func:`horizon_values`), then 0,
    from rest: its energies are ``vᵀ N_z v`` and ``vᵀ N_w v`` exactly, and
    the best ``v`` gives ``√λmax(N_z, N_w)``. Near the gain's level the
    maximising policy's loop is on the edge of mean-square stability, so
    the feedback part carries almost all the energy and the ratio tends to
    the gain.
    """
    N, L, n, m = d.shape
    op = PolicyMap(d, W)
    with np.errstate(all="ignore"):
        Pw, Pz = horizon_values(op, [stage_cost(d, W, 0.0, 1.0, 0.0),
                                     stage_cost(d, W, 1.0, 0.0, 0.0)])
    if not (np.all(np.isfinite(Pz)) and np.all(np.isfinite(Pw))):
        return 0.0
    best = 0.0
    for k in range(N):
        for ell in range(L):
            t = d.rows[k, ell]
            nz, nw = np.zeros((m, m)), np.eye(m)
            for i in np.flatnonzero(t > 0):
                j = i if d.markov else 0
                B, D = d.B[k, i], d.D[k, i]
                nz += t[i] * (D.T @ D + B.T @ Pz[(k + 1) % N, j] @ B)
                nw += t[i] * (B.T @ Pw[(k + 1) % N, j] @ B)
            try:
                Lw = np.linalg.cholesky(0.5 * (nw + nw.T))
            except np.linalg.LinAlgError:
                continue
            X = np.linalg.solve(Lw, np.linalg.solve(Lw, nz).T)
            best = max(best, float(np.linalg.eigvalsh(0.5 * (X + X.T))[-1]))
    return math.sqrt(max(best, 0.0))


def _loop_radius(d: LoopData, W: np.ndarray) -> float:
    """``ρ`` of the one-period map of the loop closed by ``w = W ξ`` (an
    eigenvalue estimate: it only aims the witness, which is exact)."""
    op = PolicyMap(d, W)
    Phi = _period(op, np.zeros(op.shape))[0]
    if op.size <= 400:
        return float(np.max(np.abs(np.linalg.eigvals(Phi))))
    vals = eigs(Phi, k=2, which="LM", return_eigenvectors=False,
                maxiter=5000, tol=1e-12)
    return float(np.max(np.abs(vals)))


def edge_witness(d: LoopData, W: np.ndarray) -> float:
    """The best of :func:`worst_input_gain` at ``W`` and at ``cW``, the
    smallest ``c ≥ 1`` that puts the policy's loop just past the edge
    (``ρ = 1 + 1e-9``).

    At the gain's level the maximising policy's loop is on the edge of
    mean-square stability and its Perron second moment is the worst
    stationary input; just above the level, ``W`` is a little short of the
    edge and an impulse's energy is not yet negligible. Past the edge the
    feedback's energy grows without bound and the ratio tends to that of
    the Perron mode, continuous in ``c``.
    """
    best = worst_input_gain(d, W)
    target = 1.0 + 1e-9

    def gap(c: float) -> float:
        return _loop_radius(d, c * W) - target

    try:
        if not np.any(W) or gap(1.0) >= 0:
            return best
        hi = 1.0
        while gap(hi) < 0:
            hi *= 1.5
            if hi > 1e3:
                return best
        # any c gives a valid input; this one makes a good one
        c = brentq(gap, 1.0, hi, xtol=1e-14, rtol=4 * _EPS, maxiter=100)
    except (ValueError, RuntimeError, np.linalg.LinAlgError):
        return best
    return max(best, worst_input_gain(d, c * W))


def _level_search(d: LoopData, lower: float
                  ) -> tuple[float, np.ndarray | None, int]:
    """The gain's level by bisection on Newton's iteration (no
    strictness): the lowest level solved (to ``1e-10`` relative) and its
    policy. A level not solved is no proof: only a direction."""
    hi, count = max(2 * lower, 1e-8), 0
    sol = None
    while count < 60:
        count += 1
        sol = solve_level(d, hi, 0.0)
        if sol is not None:
            break
        lower, hi = hi, 2 * hi
    if sol is None:
        return math.inf, None, count
    W, lo = sol[1], lower
    while count < 120 and hi > lo * (1 + 1e-10):
        mid = 0.5 * (lo + hi)
        count += 1
        sol = solve_level(d, mid, 0.0, W)
        if sol is None:
            lo = mid
        else:
            hi, W = mid, sol[1]
    return hi, W, count


def gain_bracket_size(J: JumpStateSpace) -> int:
    """Unknowns of the policy evaluation: ``L·n²``."""
    N, L, n, _ = LoopData.of(J).shape
    return L * n * n


def gain_bracket(J: JumpStateSpace, lower: float) -> GainBracket | None:
    """The certified level closest to the gain and the best worst input
    below it; None when the loop is too large for the dense policy
    evaluation or no level is certified. ``lower``: a proven lower bound
    to start from.

    Newton's iteration without strictness locates the level
    (:func:`_level_search`); certificates are then sought just above it,
    at relative distances ``1e-8, 1e-7, …, 1`` (the strictness term moves
    the level a little), and the worst input from its policy
    (:func:`edge_witness`).
    """
    d = LoopData.of(J)
    N, L, n, _ = d.shape
    if L * n * n > RICCATI_MAX_SIZE or n == 0:
        return None
    level, W, count = _level_search(d, lower)
    if W is None:
        return None
    scale = 1.0
    for rel in 10.0 ** np.arange(-8, 1):
        count += 1
        found = certify_level(J, d, level * (1 + rel), scale)
        if found is not None and found.certified:
            witness = edge_witness(d, W)
            return GainBracket(float(found.gamma),
                               float(min(max(lower, witness), found.gamma)),
                               found, count)
        if found is not None:
            scale = max(scale, float(np.abs(found.P).max()))
    return None
