"""H2 design where no convex program is exact: a local search on the exact
norm (:ref:`theory-performance`).

The H2 programs of :mod:`control_ncs.synthesis.norms` are exact when
the static gain sees the whole loop state. Where it does not — a sensor
schedule, the predictor or the estimator (part of the loop state is the
estimation error), a held command, a delayed link (the gain reads one past
measurement) — the gain is structured and the problem is not convex. Here
the free entries ``x`` of the gains are searched directly on the exact
figure:

``J(x) = ‖G‖₂² = (1/N) Σ_k ⟨G_k, Q_k⟩ + (1/N) Σ_k Σ_i π_ki tr(Dw Dwᵀ)``

with ``Q`` the periodic stationary second moments of the loop
(``Q_{k+1} = 𝒯_k(Q_k) + Σ π Bw Bwᵀ``, :func:`control_ncs.stability_covariances`'
fixed point) and ``G_k`` the output weights ``Σ_i ω_ki Ccl_kiᵀ Ccl_ki``. Its
gradient comes from one adjoint fixed point, ``V_k = 𝒯_k*(V_{k+1}) + G_k``:
with ``W_ki`` the weights of ``V_{k+1}`` (``𝒯_k*(V)_i = Acl_kiᵀ W_ki
Acl_ki``) and ``F_ki = K E_ki`` the feedback rows,

``∂J/∂F_ki = (2/N) (Bu_kiᵀ W_ki Acl_ki Q_ki + ω_ki Du_kiᵀ Ccl_ki Q_ki)``,

chained to the gains by the loop's structure (:mod:`control_ncs.refine`'s
``Loop``). The search: the refinement's quasi-Newton
method on the exact rate until the loop is mean-square stable, then on
``log J``. The returned figure is :func:`control_ncs.norm` of the returned
loop, built by :func:`control_ncs.feedback` (an independent route), never
the search's value; the gain is a local optimum.
"""

from __future__ import annotations

import math
import time

import numpy as np
import scipy.linalg
from scipy.sparse.linalg import LinearOperator, gmres

from ..exceptions import NOT_FOUND, TIME_LIMIT, SynthesisError
from ._local import Loop, bfgs
from ..stability import (DENSE_MAX_STATES, monodromy_matrix,
                         phase_adjoint, phase_map)
from ..stationary import phase_forcing

__all__: list[str] = []

#: Stage 1 (stabilise) stops below this rate, as the refinement's.
TARGET_RATE = 0.9
#: The searches keep the rate this far (relative) inside its bound.
EDGE_MARGIN = 1e-6
#: Quasi-Newton iterations per stage.
ITERATIONS = 200


class StructuredLoop:
    """A structured loop's matrices as functions of the gains' free
    entries: ``Acl = A + Bu F``, ``Ccl = Cz + Du F`` (``F = K E`` per mode)
    and, when the gain also reads the noise (``Ew``), ``Bcl = Bw + Bu K
    Ew``, ``Dcl = Dw + Du K Ew``. The objectives of the local H2 and H∞
    designs share it.

    Parameters
    ----------
    loop : refine.Loop
        The closed-loop state matrices ``A + Bu F(x)`` and the law.
    Cz, Du, Bw, Dw : ndarray, shape (N, M, ...)
        Per phase and mode.
    pi : ndarray, shape (N, M)
        The mode law per phase (the stationary one for Markov modes).
    Ew : ndarray, shape (N, M, nk, nw), optional
        A static gain that also reads the noise, ``v = K (E ξ + Ew w)``
        (measurement noise, ``D21 ≠ 0``), per phase and mode.
    decay : float, optional
        The decay bound ``r``: only gains with ``ms_radius < r²`` count
        (the objective is infinite elsewhere).
    """

    def __init__(self, loop: Loop, Cz: np.ndarray, Du: np.ndarray,
                 Bw: np.ndarray, Dw: np.ndarray, pi: np.ndarray,
                 Ew: np.ndarray | None = None, decay: float = 1.0):
        self.loop = loop
        self.Cz, self.Du, self.Bw, self.Dw, self.pi = Cz, Du, Bw, Dw, pi
        self.Ew = Ew
        # log of the rate's bound r², a little inside it: an optimum on the
        # edge could not be certified below it
        self.edge = 2.0 * math.log(decay) + math.log1p(-EDGE_MARGIN)
        self.markov = loop.T is not None
        self.evaluations = 0

    def matrices(self, x: np.ndarray) -> tuple[np.ndarray, ...]:
        """``(F, Acl, Bcl, Ccl, Dcl)`` per phase and mode."""
        loop = self.loop
        F = loop.rows(x)
        Acl = loop.A + loop.Bu @ F
        Ccl = self.Cz + self.Du @ F
        if self.Ew is None:
            return F, Acl, self.Bw, Ccl, self.Dw
        Fw = np.einsum("kuj,kmjw->kmuw", loop.gains(x), self.Ew)
        return (F, Acl, self.Bw + loop.Bu @ Fw, Ccl, self.Dw + self.Du @ Fw)


class H2Objective(StructuredLoop):
    """``J = ‖G‖₂²`` of a structured loop and its gradient in the gains
    (parameters as :class:`StructuredLoop`)."""

    def _forcing(self, Bcl: np.ndarray, Dcl: np.ndarray
                 ) -> tuple[list, float]:
        """What unit white noise adds to the moments per phase, and the
        direct term ``(1/N) Σ π tr(Dcl Dclᵀ)``."""
        pi, N, T = self.pi, self.loop.N, self.loop.T
        forcing = [phase_forcing(Bcl[k], pi[k], None if T is None else T[k])
                   for k in range(N)]
        direct = sum(float(pi[k] @ np.einsum("mab,mab->m", Dcl[k], Dcl[k]))
                     for k in range(N)) / N
        return forcing, direct

    def _law(self, k: int) -> np.ndarray:
        T = self.loop.T
        return T[k] if T is not None else self.pi[k]

    def step(self, Acl: np.ndarray, k: int, X: np.ndarray,
             adjoint: bool) -> np.ndarray:
        """Phase ``k`` of the second-moment map ``𝒯_k`` or its adjoint."""
        kernel = phase_adjoint if adjoint else phase_map
        return kernel(Acl[k], self._law(k), X, self.markov)

    def _periodic(self, Acl: np.ndarray, forcing: list,
                  G: list) -> tuple[np.ndarray, np.ndarray]:
        """The periodic fixed points ``Q_{k+1} = 𝒯_k(Q_k) + forcing_k``
        and ``V_k = 𝒯_k*(V_{k+1}) + G_k``; returns ``(Q_0, V_0)``: dense
        below the size where ``ms_radius`` turns matrix-free (one LU of
        ``I - 𝒯`` serves both, the adjoint's matrix being its transpose),
        GMRES above."""
        loop = self.loop
        shape = loop._shape()
        size = int(np.prod(shape))
        answers = []
        for adjoint, rhs in ((False, forcing), (True, G)):
            order = list(reversed(range(loop.N))) if adjoint else \
                list(range(loop.N))
            acc = np.zeros(shape)
            for k in order:
                acc = self.step(Acl, k, acc, adjoint) + rhs[k]
            answers.append((adjoint, order, acc.ravel()))
        if size <= DENSE_MAX_STATES ** 2:
            Mono = monodromy_matrix(Acl, np.stack(
                [self._law(k) for k in range(loop.N)]), self.markov)
            lu = scipy.linalg.lu_factor(np.eye(size) - Mono,
                                        check_finite=True)
            if np.any(np.diag(lu[0]) == 0):
                raise np.linalg.LinAlgError("I - T is singular")
            out = [scipy.linalg.lu_solve(lu, acc, trans=1 if adj else 0)
                   for adj, _, acc in answers]
            return out[0].reshape(shape), out[1].reshape(shape)
        result = []
        for adjoint, order, acc in answers:
            def period(v: np.ndarray, adjoint: bool = adjoint,
                       order: list = order) -> np.ndarray:
                X = v.reshape(shape)
                for k in order:
                    X = self.step(Acl, k, X, adjoint)
                return X.ravel()

            op = LinearOperator((size, size), dtype=float,
                                matvec=lambda v, period=period:
                                v - period(v))
            x, info = gmres(op, acc, rtol=1e-12, atol=0.0,
                            restart=50, maxiter=200)
            if info != 0:
                raise ValueError("GMRES did not converge on the H2 fixed "
                                 "point")
            result.append(x.reshape(shape))
        return result[0], result[1]

    def value(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        """``(log J, ∂ log J/∂x)``; ``(inf, 0)`` when the loop is not
        mean-square stable."""
        self.evaluations += 1
        loop = self.loop
        N = loop.N
        rate, _ = loop.rate(x)
        if not rate < self.edge:
            return math.inf, np.zeros_like(x)
        F, Acl, Bcl, Ccl, Dcl = self.matrices(x)
        forcing, direct = self._forcing(Bcl, Dcl)
        if self.markov:
            G = [Ccl[k].transpose(0, 2, 1) @ Ccl[k] for k in range(N)]
        else:
            G = [np.tensordot(self.pi[k], Ccl[k].transpose(0, 2, 1)
                              @ Ccl[k], axes=1) for k in range(N)]
        markov = self.markov
        try:
            Q0, V0 = self._periodic(Acl, forcing, G)
        except (ValueError, np.linalg.LinAlgError):
            return math.inf, np.zeros_like(x)
        Qs = [Q0]
        for k in range(N - 1):
            Qs.append(self.step(Acl, k, Qs[-1], False) + forcing[k])
        Vs: list[np.ndarray] = [V0] * (N + 1)
        for k in reversed(range(1, N)):
            Vs[k] = self.step(Acl, k, Vs[k + 1], True) + G[k]
        J = sum(float(np.sum(G[k] * Qs[k])) for k in range(N)) / N + direct
        if not (J > 0 and math.isfinite(J)):
            return math.inf, np.zeros_like(x)
        dF = []
        for k in range(N):
            W = loop._weights(k, Vs[k + 1])
            Qk = Qs[k] if markov else np.broadcast_to(Qs[k], W.shape)
            omega = np.ones(loop.M) if markov else self.pi[k]
            dF.append(2.0 / N * (
                loop.Bu[k].transpose(0, 2, 1) @ W @ Acl[k] @ Qk
                + omega[:, None, None] * (self.Du[k].transpose(0, 2, 1)
                                          @ Ccl[k] @ Qk)))
        dK = loop.chain(np.array(dF))
        if self.Ew is not None:
            # the noise's way in: ⟨V_{k+1}, d forcing_k⟩ and the direct term
            for k in range(N):
                W = loop._weights(k, Vs[k + 1])
                scale = self.pi[k] if markov else np.ones(loop.M)
                dFw = 2.0 / N * (
                    scale[:, None, None] * (loop.Bu[k].transpose(0, 2, 1)
                                            @ W @ Bcl[k])
                    + self.pi[k][:, None, None] * (
                        self.Du[k].transpose(0, 2, 1) @ Dcl[k]))
                dK[k] += np.einsum("muw,mjw->uj", dFw, self.Ew[k])
        grad = dK.flat[loop.free] / J
        return math.log(J), np.asarray(grad)


def local_h2(objective: H2Objective, starts: list[np.ndarray],
             deadline: float | None, who: str) -> np.ndarray:
    """The two stages (module docstring): stage 1 from the starts by rate
    until one is stable, stage 2 from the stable point of least norm;
    returns the free entries of the gain found."""
    loop, edge = objective.loop, objective.edge
    target = math.log(TARGET_RATE) + edge
    scored = sorted(((loop.rate(x)[0], j, x) for j, x in enumerate(starts)),
                    key=lambda s: (s[0], s[1]))
    best = (scored[0][0], scored[0][2])
    for _, _, x0 in scored:
        if best[0] < edge:
            break
        if deadline is not None and time.perf_counter() > deadline:
            break
        x, f, _, _ = bfgs(loop.rate, x0, target, deadline, ITERATIONS)
        if f < best[0]:
            best = (f, x)
    if best[0] < edge:
        # stage 2 from the stable point of least norm among the starts
        # (a given start included) and stage 1's result
        stable = [x0 for f0, _, x0 in scored if f0 < edge] + [best[1]]
        values = [objective.value(x0)[0] for x0 in stable]
        best = (best[0], stable[int(np.argmin(values))])
    if not best[0] < edge:
        out = deadline is not None and time.perf_counter() > deadline
        within = "" if edge == 0.0 else f" within {math.exp(edge):.6g}"
        raise SynthesisError(
            f"{who}: the local search found no gain that makes the loop "
            f"mean-square stable{within} (ms_radius "
            f"{math.exp(best[0]):.6g} at best; a local method: not a proof "
            f"that none exists)",
            TIME_LIMIT if out else NOT_FOUND,
            dict(ms_radius=math.exp(best[0])))
    x, _, _, _ = bfgs(objective.value, best[1], -math.inf, deadline,
                       ITERATIONS)
    return x
