"""H∞ design of structured gains: a local search on the bounded real lemma's
optimum (:ref:`theory-performance`).

For a fixed gain the ℓ2 gain's square ``γ²*(x)`` is the optimum of the
bounded real lemma of the loop, an LMI in the storages (exact for a fixed
jump system, :func:`control_ncs.l2_gain`). Its derivative in the gains comes
from the LMI's dual variables by the envelope theorem, as the refinement's
passivity level does (:mod:`control_ncs.refine`): with ``Z_{k,ℓ} ⪰ 0`` the
dual of ``Θ_{k,ℓ} ≼ -εI``,

``∂γ²*/∂Acl_ki = 2 t_i [P_{k+1,i} F_ki Z_{k,ℓ}]_ξ``,
``∂γ²*/∂Ccl_ki = 2 t_i [H_ki Z_{k,ℓ}]_ξ``

(``F = [Acl, Bw]``, ``H = [Ccl, Dw]``, ``t`` the row of ``ℓ``, ``[·]_ξ``
the state columns; the noise columns give ``∂γ²*/∂Bcl``, ``∂γ²*/∂Dcl``
when the gain also reads the noise), chained to the free entries by the
loop's structure. A
guide for the search only: the returned figure is :func:`l2_gain`'s
certified bound of the returned loop, never this objective.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..jump import JumpStateSpace
from ..lmi import DEFAULT_MARGIN, quadratic_supply_model, solve
from ._h2 import StructuredLoop
from ..verify import supply_rows

__all__: list[str] = []


class GainObjective(StructuredLoop):
    """``log γ²*`` of a structured loop and its gradient in the gains
    (parameters as :class:`control_ncs.synthesis._h2.StructuredLoop`)."""

    def closed(self, Acl: np.ndarray, Bcl: np.ndarray, Ccl: np.ndarray,
               Dcl: np.ndarray) -> JumpStateSpace:
        """The loop with its modes exactly as the search's (not lumped)."""
        T = self.loop.T
        return JumpStateSpace(Acl, Bcl, Ccl, Dcl,
                              None if T is not None else self.pi, True,
                              transition=T)

    def value(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        """``(log γ²*, gradient)``; ``(inf, 0)`` when the loop is not
        mean-square stable or the solver gives no optimum."""
        self.evaluations += 1
        loop = self.loop
        rate, _ = loop.rate(x)
        if not rate < 0.0:
            return math.inf, np.zeros_like(x)
        F, Acl, Bcl, Ccl, Dcl = self.matrices(x)
        CL = self.closed(Acl, Bcl, Ccl, Dcl)
        model = quadratic_supply_model(CL, -1.0, 0.0, None, DEFAULT_MARGIN)
        report = solve(model.problem)
        level = model.level
        if report.status not in ("optimal", "optimal_inaccurate") or \
                level is None or level.value is None:
            return math.inf, np.zeros_like(x)
        g2 = float(level.value)
        if not g2 > 0:
            return math.inf, np.zeros_like(x)
        P = model.certificate()
        rows = supply_rows(CL.modes)
        N, L = rows.shape[:2]
        n = Acl.shape[-1]
        iid = CL.modes.is_iid
        # the constraints are Θ_{k,ℓ} then P_{k,ℓ}, phase-major
        thetas = model.problem.constraints[0::2]
        dF = np.zeros(F.shape)
        dFw = np.zeros(F.shape[:3] + (Bcl.shape[-1],))
        for k in range(N):
            for ell in range(L):
                Z: Any = thetas[k * L + ell].dual_value
                if Z is None:
                    return math.inf, np.zeros_like(x)
                Z = 0.5 * (np.asarray(Z) + np.asarray(Z).T)
                t = rows[k, ell]
                for i in np.flatnonzero(t > 0):
                    Pn = P[(k + 1) % N][0 if iid else i]
                    Fi = np.concatenate([Acl[k, i], Bcl[k, i]], axis=1)
                    Hi = np.concatenate([Ccl[k, i], Dcl[k, i]], axis=1)
                    gF = 2 * t[i] * (Pn @ Fi @ Z)
                    gH = 2 * t[i] * (Hi @ Z)
                    dF[k, i] += loop.Bu[k, i].T @ gF[:, :n] \
                        + self.Du[k, i].T @ gH[:, :n]
                    dFw[k, i] += loop.Bu[k, i].T @ gF[:, n:] \
                        + self.Du[k, i].T @ gH[:, n:]
        dK = loop.chain(dF)
        if self.Ew is not None:
            for k in range(N):
                dK[k] += np.einsum("muw,mjw->uj", dFw[k], self.Ew[k])
        grad = dK.flat[loop.free] / g2
        return math.log(g2), np.asarray(grad)
