"""What a synthesis returns: :class:`SynthesisResult`, built once.

Every route of :func:`control_ncs.passivesyn` (the LMI, the Riccati
iteration, the refinement) ends in :func:`_finish`, which wraps the
certified gain, its certificate and the solver's reports into one result
and hangs it on the gain and the closed loop.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..gain import PeriodicGain
from ..openloop import JumpPlant
from ..lmi import (SolveReport)
from .._results import Result
from ..exceptions import (CERTIFIED, CERTIFIED_SHORTAGE, MESSAGES)
from ..verify import (Certificate)


#: What helps a design whose certified level is negative (see
#: :class:`~control_ncs.exceptions.NotPassiveWarning`).
_SHORTAGE_HELP = ("a larger feedthrough D11 from w to z, a weaker decay "
                  "requirement or less loss on the links would raise eta")


@dataclass(repr=False)
class SynthesisResult(Result):
    """Everything :func:`passivesyn` knows about the gain it returned.

    The gain is applied as is, ``u = K_k ŷ`` (positive feedback; a
    :func:`control.dlqr` gain, for ``u = -K x``, must be negated).

    Attributes
    ----------
    gain : PeriodicGain
        ``K_k``, applied as ``u = K_k ŷ``.
    eta : float
        Certified dissipation (the one returned): the requested one, or the
        supremum the certificate proves less the first back-off of
        ``verify.INDEX_BACKOFFS`` (1e-6, 1e-5, 1e-4, times ``max(1, |sup|)``:
        absolute below 1) that passes the exact check
        (:func:`control_ncs.verify.certify_index`).
    eta_solver : float
        The solver's objective value (``η`` maximised), or the requested one;
        for the Riccati route, the level its bisection reached; for the
        fixed-``η`` search of the default call, the highest level that
        verified (a lower bound, not an optimum).
    decay : float
        Decay bound ``r`` (1 = none); ``ms_radius < r²`` is checked.
    certificate : Certificate
        ``P_k = X_k⁻¹`` (in the plant's coordinates) and the exact figures:
        ``λmax(Θ_k)``, ``λmin(P_k)``, ``ms_radius``, ``eta_sup``. For an LMI
        solved in balanced coordinates ``x = T x̃`` the figures are those
        of the exact check there (``Θ̃_k`` is congruent to ``Θ_k``: same
        signs; ``ms_radius`` is the same).
    X, Y : ndarray
        LMI variables per phase (``Y`` zero-padded to ``(N, nu, nx)``;
        Markov links: per phase and previous mode, ``(N, M, ., .)``); for
        the Riccati route ``X_k = P_k⁻¹`` and ``Y_k = K_k X_k`` (the LMI
        variables its certificate corresponds to).
    form : {'merged', 'paper'}
        The LMI's form; ``'merged'`` for the Riccati route (``form`` is
        ignored there: modes are always merged).
    structure : {'full', 'block', 'extended', 'per_mode'}
        Which LMI certified the gain: ``'full'`` is exact (feasible iff a
        certified gain exists); ``'block'`` and ``'extended'`` are sufficient;
        ``'per_mode'``: a gain that reads a different block in each mode (a
        gain per age of a buffered measurement), which no LMI expresses,
        certified by the analysis of its loop (``method='refine'``).
    gain_kind : {'phase', 'mode'}
        Which kind of gain was certified: ``K_k`` per phase, or
        ``K_{k,ℓ}`` per phase and previous network mode (Markov links,
        :ref:`theory-markov`; the closed loop is then a jump system on pair
        modes ``(ℓ, i)`` and ``certificate.P`` is ``P_{k,(ℓ',ℓ)} = P_{k,ℓ}``).
        On Markov links ``'phase'`` is sufficient only.
    note : str
        Why the call took another route than asked or than usual (e.g. the
        Riccati iteration is written for i.i.d. modes: Markov links fall
        back to the LMI), or ''.
    width : int
        Side of each LMI block ``Ψ_k``; for the Riccati route, the side
        ``n + m1`` of the matrices ``Θ_k`` it certifies (it works with
        ``n × n`` matrices only).
    report : SolveReport
        Solver, status, compile and solve times of the successful solve.
        Riccati route: solver ``'RICCATI'``, status ``'optimal'``, compile
        time 0, solve time = the iteration's, ``iterations`` = its sweeps.
    attempts : list of SolveReport
        Every solve made, including retries.
    plant : JumpPlant
        The open-loop jump system that was designed for.
    method : {'lmi', 'refine'}
        What certified the gain: ``'lmi'`` the synthesis LMI (or the
        Riccati route, see ``report.solver``); ``'refine'`` the local
        refinement of :func:`control_ncs.refine.refine_gain`, its gain
        certified by the analysis of its closed loop (then ``X_k = P_k⁻¹``,
        ``Y_k = K_k E_k X_k``, ``report.solver`` is ``'REFINE'`` and
        ``structure`` names the loop's sufficient LMI, whose gain was the
        first start when it had one).
    start : str or None
        Refinement only: the starting point that led to the gain
        (``'lmi'``, ``'projected'`` (the full-information gain projected on
        what the gain reads), ``'full'``, ``'zero'``, ``'continuation'``,
        ``'restart'``).
    refinement : RefineResult or None
        Refinement only: how far it moved the gain (``ms_radius_before``,
        ``ms_radius``, ``eta_before``, ``eta``, ``iterations``,
        ``message``).
    exact : bool
        True when the condition that certified the gain is also necessary
        (the LMI with structure ``'full'`` and gains on all the controller
        observes): no gain of this kind certifies a level above ``eta`` by
        more than the LMI's margin. False for sufficient LMIs and for
        the refinement (a local method).

    Examples
    --------
    ``x⁺ = 2x + w + u``, ``z = x + w``, actuator loss 10 %:

    >>> P = ncs.nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[1.0, 0.0], [0.0, 0.0]],
    ...         nmeas=1, ncon=1, actuator_loss=0.1)
    >>> K, CL, eta = ncs.passivesyn(P, eta=0.0, decay=0.9)
    >>> res = K.result
    >>> res.structure, res.certificate.verified, bool(res.ms_radius < 0.81)
    ('full', True, True)
    """

    gain: PeriodicGain
    eta: float
    eta_solver: float
    decay: float
    certificate: Certificate
    X: np.ndarray
    Y: np.ndarray
    form: str
    structure: str
    width: int
    report: SolveReport
    attempts: list = field(default_factory=list)
    plant: JumpPlant | None = None
    gain_kind: str = "phase"
    note: str = ""
    method: str = "lmi"
    start: str | None = None
    refinement: Any = None
    exact: bool = False

    @property
    def ms_radius(self) -> float:
        """The closed loop's exact ``ms_radius`` (from the certificate)."""
        return self.certificate.ms_radius

    @property
    def success(self) -> bool:
        """True: :func:`passivesyn` returns only certified gains."""
        return True

    @property
    def passive(self) -> bool:
        """True when the certified level is passive (``η ≥ 0``).

        A negative ``η`` is certified too, but it is an input-feedforward
        shortage: the loop is mean-square stable and dissipative, not
        passive.
        """
        return self.eta >= 0.0

    @property
    def status(self) -> str:
        """``'certified'``, or ``'certified_shortage'`` when ``η < 0``."""
        return CERTIFIED if self.passive else CERTIFIED_SHORTAGE

    @property
    def message(self) -> str:
        """One sentence: what the certificate proves."""
        text = (f"{MESSAGES[self.status]} (eta = {self.eta:.6g}, ms_radius = "
                f"{self.ms_radius:.6g}, structure {self.structure}, "
                f"{self.gain_kind} gains)")
        if not self.passive:
            text += f"; the loop is not passive ({_SHORTAGE_HELP})"
        return text

    _repr_fields = ("eta", "ms_radius", "period", "structure", "gain_kind",
                    "method")

    @property
    def period(self) -> int:
        """The gain's period ``N``."""
        return self.gain.period

    def _details(self) -> list[str]:
        r = self.report
        lines = [f"controller={self.gain.controller!r}, "
                 f"actuator={self.gain.actuator!r}, N={self.gain.period}, "
                 f"form={self.form}, structure={self.structure}, "
                 f"gain={self.gain_kind}",
                 f"certified eta = {self.eta:.6g} (solver "
                 f"{self.eta_solver:.6g})",
                 f"solver {r.solver}: {r.status}, compile "
                 f"{r.compile_time:.3f} s, solve {r.solve_time:.3f} s, "
                 f"{len(self.attempts)} attempt(s)"]
        if self.gain.estimator_gain is not None:
            # theory: output feedback: the loop's rate is the larger of these
            # two loops'
            lines.append(f"estimator gain L_k of shape "
                         f"{self.gain.estimator_gain.shape} (N_L, n, nmeas)")
        if self.note:
            lines.append(f"note: {self.note}")
        return lines + self.certificate.summary().splitlines()


def _finish(plant, X, Y, gains, CL, cert, eta_ok, eta_solver, decay, form,
            structure, width, report, attempts):
    K = PeriodicGain(gains, plant.controller, plant.actuator,
                     estimator_gain=plant.estimator_gain)
    result = SynthesisResult(
        K, float(eta_ok), float(eta_solver), decay, cert,
        X, Y, form, structure, width, report, attempts, plant,
        "mode" if K.mode_dependent else "phase")
    K.result = result
    CL.info["synthesis"] = result
    return K, CL, float(eta_ok)
