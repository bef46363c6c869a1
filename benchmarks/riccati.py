"""PROTOTYPE (benchmarks only, not part of the package): a certified
Riccati-type iteration for ``passivesyn`` with full information (MATH §8).

Why
---
The LMI of MATH §8 has ``N·n(n+1)/2`` unknowns in ``X_k`` and PSD blocks of
side ``2n + m1`` (after Clarabel's chordal split); an interior-point solver
factors a dense ``s(s+1)/2`` block per cone, so time grows like ``n⁶`` and
memory like ``n⁴``. At ``n = 64, N = 4`` that is minutes per iteration.

What
----
With the full state known at every phase (``E_k = I``; any actuator schedule,
zero actuator strategy), ``Θ_k(P, K) ≺ 0`` (MATH §6) is, by a Schur
complement on its ``w`` block (``R_k = D̄ + D̄ᵀ − 2ηI − Σ p_i Bw_iᵀ P_{k+1}
Bw_i ≻ 0``),

    r² P_k ≻ G_k(K; P_{k+1}) = Σ p_i Ā_iᵀ P_{k+1} Ā_i + M12 R_k⁻¹ M12ᵀ,

with ``Ā_i = A_i + Bu_i K``, ``M12 = S0 + Kᵀ Tᵀ``,
``S0 = Σ p_i A_iᵀ P Bw_i − C̄zᵀ``, ``T = Σ p_i Bw_iᵀ P Bu_i − D̄u``.
``G_k`` is a matrix quadratic in ``K``:
``G = G0 + KᵀL + LᵀK + KᵀHK`` with ``H = Σ p Bu_iᵀ P Bu_i + Tᵀ R⁻¹ T`` and
``L = Σ p Bu_iᵀ P A_i + Tᵀ R⁻¹ S0ᵀ``, so ``K* = −H⁻¹L`` minimises it in the
Loewner order (``G(K) = G(K*) + (K − K*)ᵀH(K − K*)``). The map
``P_{k+1} ↦ (G_k(K*) + εI)/r²`` is monotone (``xᵀGx`` is a maximum over
``w`` of functions increasing in ``P``), so iterating it backwards over the
period from ``P = 0`` increases monotonically and stays below any strict
solution of the LMI: it converges iff the LMI is feasible (with margin ``ε``).
Its limit is a certificate for the gain ``K_k = K*(P_{k+1})``, which is then
checked exactly by :func:`control_ncs.verify.check_certificate` (``λmax(Θ_k)``
and the independent ``ms_radius``), like every gain ``passivesyn`` returns.
``η`` is maximised by bisection, warm-started (``P(η)`` is increasing in
``η``, so the solution at a feasible ``η`` is a valid monotone start above it).

Cost per sweep: ``O(N·M·n³)``; no cvxpy, no solver, memory ``O(N·n²)``.

Scope of the prototype: ``structure='full'`` (no sensor schedule), any
actuator schedule, either controller whose gain sees the whole state.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from control_ncs import PeriodicGain
from control_ncs.strategies import build
from control_ncs.verify import (SynthesisError, certified_index,
                                check_certificate)


@dataclass
class RiccatiResult:
    gains: np.ndarray
    P: np.ndarray
    eta: float
    sweeps: int
    bisections: int
    certificate: object
    time: float


class _Data:
    """Per-phase data, restricted to live modes and active inputs."""

    def __init__(self, p, A, Bu, Bw, Cz, Du, Dw, act):
        live = np.flatnonzero(p > 0)
        self.p = p[live]
        self.act = act
        self.A = A[live]
        self.Bu = Bu[live][:, :, act]
        self.Bw = Bw[live]
        self.Czb = np.einsum("i,iab->ab", self.p, Cz[live])
        self.Dub = np.einsum("i,iab->ab", self.p, Du[live])[:, act]
        Dwb = np.einsum("i,iab->ab", self.p, Dw[live])
        self.Dsym = Dwb + Dwb.T

    @classmethod
    def of_plant(cls, plant, k):
        return cls(plant.probabilities[k], plant.A[k], plant.Bu[k],
                   plant.Bw[k], plant.Cz[k], plant.Du[k], plant.Dw[k],
                   plant.active_inputs(k))

    @classmethod
    def of_system(cls, sys, k):
        """A closed loop (no gain to choose): analysis, MATH §6."""
        m = sys.modes
        M, n = m.A.shape[1], m.A.shape[-1]
        none = np.zeros((M, n, 0))
        return cls(m.probabilities[k], m.A[k], none, m.B[k], m.C[k],
                   np.zeros((M, m.C.shape[-2], 0)), m.D[k],
                   np.zeros(0, int))


def _wsum(p, X, Y):
    """``Σ_i p_i X_iᵀ Y_i`` by batched BLAS products."""
    return np.tensordot(p, np.swapaxes(X, -1, -2) @ Y, axes=1)


def _step(d: _Data, Pn: np.ndarray, eta: float):
    """One Riccati step: (G(K*), K*) or None when R is not positive definite."""
    p, A, Bu, Bw = d.p, d.A, d.Bu, d.Bw
    PA = Pn @ A                    # (M, n, n)
    PBw = Pn @ Bw                  # (M, n, nw)
    R = d.Dsym - 2 * eta * np.eye(d.Dsym.shape[0]) - _wsum(p, Bw, PBw)
    R = 0.5 * (R + R.T)
    try:
        Lr = np.linalg.cholesky(R)
    except np.linalg.LinAlgError:
        return None
    G0 = _wsum(p, A, PA)
    S0 = _wsum(p, A, PBw) - d.Czb.T                               # (n, nw)
    Ws = np.linalg.solve(Lr, S0.T)                                # L⁻¹S0ᵀ
    if Bu.shape[-1] == 0:
        G = G0 + Ws.T @ Ws
        return 0.5 * (G + G.T), np.zeros((0, A.shape[-1]))
    PBu = Pn @ Bu
    T = _wsum(p, Bw, PBu) - d.Dub                                 # (nw, nu)
    Wt = np.linalg.solve(Lr, T)                                   # L⁻¹T
    H = _wsum(p, Bu, PBu) + Wt.T @ Wt
    L = _wsum(p, Bu, PA) + Wt.T @ Ws
    H = 0.5 * (H + H.T)
    K = -np.linalg.lstsq(H, L, rcond=None)[0]
    G = G0 + Ws.T @ Ws + K.T @ L      # G0 + S0R⁻¹S0ᵀ − LᵀH⁻¹L
    return 0.5 * (G + G.T), K


def _iterate(data, eta, decay, eps, P0, max_sweeps, tol, blowup):
    """Backward sweeps until the increment is below ``tol·eps``; returns
    (P, K, sweeps) or None on divergence."""
    N = len(data)
    n = data[0].A.shape[-1]
    P = P0.copy()
    K = [None] * N
    for sweep in range(1, max_sweeps + 1):
        change = 0.0
        for k in reversed(range(N)):
            out = _step(data[k], P[(k + 1) % N], eta)
            if out is None:
                return None
            G, K[k] = out
            new = (G + eps * np.eye(n)) / decay ** 2
            change = max(change, float(np.max(np.abs(new - P[k]))))
            P[k] = new
        top = float(np.max(np.abs(P)))
        if not np.isfinite(top) or top > blowup:
            return None
        if change <= tol * eps:
            return P, K, sweep
    return None


def _search(data, eta, r, margin, rtol, max_sweeps, sup_of=None,
            probe_sweeps=3000):
    """Fixed ``eta``: one iteration; ``eta=None``: bisection for the largest
    ``η`` whose iteration converges. Returns (P, K, η, sweeps, bisections).

    In the bisection a level whose iteration has not converged after
    ``probe_sweeps`` sweeps counts as infeasible (conservative: the result
    is still certified, only possibly a little low), and after each
    converged level the lower bound jumps to what its ``P`` certifies
    (``sup_of(P, K)``, the exact supremum of :func:`certified_index`)."""
    N = len(data)
    nx = data[0].A.shape[-1]
    scale = max([1.0] + [float(np.linalg.norm(M, 2)) for d in data
                         for M in (d.Czb, d.Dsym)])
    eps = margin * scale
    blowup = 1e12 * scale
    tol = 1e-3
    zero = np.zeros((N, nx, nx))
    sweeps = bis = 0

    def solve(e, P0):
        return _iterate(data, e, r, eps, P0, max_sweeps, tol, blowup)

    if eta is not None:
        out = solve(float(eta), zero)
        if out is None:
            raise SynthesisError("riccati: the iteration diverged: no gain "
                                 f"with a certificate for eta={eta}",
                                 "infeasible", {})
        Pc, Kc, sweeps = out
        return Pc, Kc, float(eta), sweeps, 0
    hi = min(np.linalg.eigvalsh(d.Dsym).min() for d in data) / 2
    lo, width = None, max(1.0, abs(hi))
    trial = hi - width
    while lo is None:        # a feasible starting level: lower until it converges
        out = solve(trial, zero)
        bis += 1
        if out is not None:
            lo, (Pc, Kc, sw) = trial, out
            sweeps += sw
        else:
            width *= 4
            trial = hi - width
            if width > 1e8:
                raise SynthesisError("riccati: no stabilising gain found",
                                     "infeasible", {})
    if sup_of is not None:
        lo = max(lo, min(sup_of(Pc, Kc), hi))
    while hi - lo > rtol * max(1.0, abs(hi)):
        mid = 0.5 * (lo + hi)
        # warm start: P(lo) ≤ P(mid)
        out = _iterate(data, mid, r, eps, Pc, probe_sweeps, tol, blowup)
        bis += 1
        if out is None:
            hi = mid
        else:
            (Pc, Kc, sw) = out
            sweeps += sw
            lo = mid
            if sup_of is not None:
                lo = max(lo, min(sup_of(Pc, Kc), hi))
    return Pc, Kc, lo, sweeps, bis


def riccati_ff_index(sys, *, decay=None, margin=1e-6, rtol=1e-6,
                     max_sweeps=20000):
    """PROTOTYPE of ``get_input_ff_index`` by the same iteration (no gain):
    the largest ``η`` whose Riccati iteration converges, certified exactly
    (``certified_index`` of the limit ``P``, then ``check_certificate``)."""
    from control_ncs.jump import as_jump
    sys = as_jump(sys)
    r = 1.0 if decay is None else float(decay)
    data = [_Data.of_system(sys, k) for k in range(sys.period)]
    Pc, _, e_best, sweeps, bis = _search(
        data, None, r, margin, rtol, max_sweeps,
        sup_of=lambda P, K: certified_index(sys, P, decay=r))
    sup = certified_index(sys, Pc, decay=r)
    eta = sup - 1e-9 * max(1.0, abs(sup))
    cert = check_certificate(sys, Pc, eta, decay=r)
    if not cert.verified:
        raise SynthesisError("riccati: the certificate fails the exact check: "
                             + "; ".join(cert.failures), "not_verified",
                             cert.figures())
    return float(eta), cert


def riccati_passivesyn(Pl, eta=None, *, decay=None, controller="static",
                       actuator="zero", margin=1e-6, rtol=1e-4,
                       max_sweeps=20000, verify=True):
    """PROTOTYPE of ``passivesyn(..., solver='riccati')``: returns
    ``(K, CL, eta, RiccatiResult)``; raises SynthesisError like passivesyn."""
    start = time.perf_counter()
    r = 1.0 if decay is None else float(decay)
    plant = build(Pl, controller, actuator).merged()
    s = plant.shape
    N, nx = plant.period, s["nx"]
    for k in range(N):
        if plant.known_coordinates(k).size < nx:
            raise ValueError("riccati prototype: needs E_k = I (no sensor "
                             "schedule); use the LMI route")
    data = [_Data.of_plant(plant, k) for k in range(N)]
    def gains_of(Kc):
        g = np.zeros((N, s["nu"], s["nk"]))
        for k in range(N):
            g[k][data[k].act] = Kc[k]
        return g

    Pc, Kc, e_best, sweeps, bis = _search(
        data, eta, r, margin, rtol, max_sweeps,
        sup_of=lambda P, K: certified_index(plant.close(gains_of(K)), P,
                                            decay=r))
    gains = gains_of(Kc)
    CL = plant.close(gains)
    eta_ok = e_best
    cert = None
    if verify:
        if eta is None:
            sup = certified_index(CL, Pc, decay=r)
            eta_ok = sup - 1e-9 * max(1.0, abs(sup))
        cert = check_certificate(CL, Pc, eta_ok, decay=r)
        if not cert.verified:
            raise SynthesisError("riccati: the gain fails the exact check: "
                                 + "; ".join(cert.failures), "not_verified",
                                 cert.figures())
    K = PeriodicGain(gains, controller, actuator)
    res = RiccatiResult(gains, Pc, float(eta_ok), sweeps, bis, cert,
                        time.perf_counter() - start)
    K.result = res
    return K, CL, float(eta_ok), res
