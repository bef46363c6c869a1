"""Positive-real (passive) synthesis over a lossy network (MATH §8, §8b).

``K, CL, eta = passivesyn(P, ...)`` in the manner of :func:`control.hinfsyn`.
The LMI is built for the generic plant of MATH §10 (``lmi.py``), so every
controller kind and schedule goes through one code path; every gain returned
has passed the exact checks of ``verify.py``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from control.exception import ControlArgument, ControlDimension

from ._checks import choice
from .gain import ACTUATORS, CONTROLLERS, PeriodicGain
from .jump import JumpPlant, JumpStateSpace
from .lmi import (DEFAULT_MARGIN, SolveReport, fallback_solver,
                  read_gains, solve, synthesis_model)
from .plant import NetworkedStateSpace
from .strategies import build, loop_closes
from .verify import (Certificate, SynthesisError, certify_index,
                     check_certificate)

__all__ = ["passivesyn", "SynthesisResult", "SynthesisError"]

#: Attempts made in turn while the answer is inaccurate or fails the exact
#: checks: (margin multiplier, relative back-off of ``η`` below the first
#: attempt's optimum). A maximum sits on the boundary of the feasible set,
#: where interior-point answers are least accurate; a retry therefore solves
#: the feasibility problem a little below it. Measured (loss-free plants
#: with unstable A, tests/test_passivity.py): the maximisation ends
#: 'optimal_inaccurate', the feasibility problem 1e-3 below is 'optimal',
#: at a cost of ~9e-4 of η; trying 1e-5 and 1e-4 first rescued 1 of 3 such
#: cases, so they are not tried. A retry reported infeasible proves nothing
#: (its η comes from an inaccurate optimum): only the problem as posed, with
#: the default or the fallback solver (``lmi.FALLBACK_SOLVER``), decides
#: infeasibility.
RETRIES = ((1.0, 0.0), (1.0, 1e-3), (1e2, 1e-2))

FORMS = ("merged", "paper")
STRUCTURES = ("auto", "full", "block", "extended")


@dataclass
class SynthesisResult:
    """Everything :func:`passivesyn` knows about the gain it returned.

    Attributes
    ----------
    gain : PeriodicGain
    eta : float
        Certified dissipation (the one returned): the requested one, or a
        relative 1e-6 below the supremum the certificate proves
        (:func:`control_ncs.verify.certify_index`).
    eta_solver : float
        The solver's objective value (``η`` maximised), or the requested one.
    decay : float
        Decay bound ``r`` (1 = none); ``ms_radius < r²`` is checked.
    certificate : Certificate
        ``P_k = X_k⁻¹`` and the exact figures: ``λmax(Θ_k)``, ``λmin(P_k)``,
        ``ms_radius``, ``eta_sup``.
    X, Y : ndarray
        LMI variables per phase (``Y`` zero-padded to ``(N, nu, nx)``).
    form : {'merged', 'paper'}
    structure : {'full', 'block', 'extended'}
        Which LMI certified the gain: ``'full'`` is exact (feasible iff a
        certified gain exists); ``'block'`` and ``'extended'`` are sufficient.
    width : int
        Side of each LMI block ``Ψ_k``.
    report : SolveReport
        Solver, status, compile and solve times of the successful solve.
    attempts : list of SolveReport
        Every solve made, including retries.
    plant : JumpPlant
        The open-loop jump system that was designed for.
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

    @property
    def ms_radius(self) -> float:
        return self.certificate.ms_radius

    def summary(self) -> str:
        """A few lines for humans: the figures that prove the result."""
        c = self.certificate
        return (f"passivesyn: controller={self.gain.controller!r}, "
                f"actuator={self.gain.actuator!r}, N={self.gain.period}, "
                f"form={self.form}, structure={self.structure}\n"
                f"  certified eta = {self.eta:.6g} (solver {self.eta_solver:.6g},"
                f" sup proved by P: {c.eta_sup:.6g})\n"
                f"  max_k lambda_max(Theta_k) = {c.theta_max.max():.3e} < 0, "
                f"min_k lambda_min(P_k) = {c.P_min.min():.3e} > 0\n"
                f"  ms_radius = {c.ms_radius:.6f} < "
                f"{min(1.0, self.decay ** 2):.6f}\n"
                f"  solver {self.report.solver}: {self.report.status}, compile "
                f"{self.report.compile_time:.3f} s, solve "
                f"{self.report.solve_time:.3f} s, {len(self.attempts)} attempt(s)")


def _checks(P, eta, decay, controller, actuator, form, structure, plant):
    if not isinstance(P, NetworkedStateSpace):
        raise ControlArgument(f"P: expected a NetworkedStateSpace (see nss()), "
                              f"got {type(P).__name__}")
    m1, p1 = P.B1.shape[1], P.C1.shape[0]
    if m1 != p1 or m1 == 0:
        raise ControlDimension(
            f"P: passivity needs w and z of equal, nonzero size (paper eq. 1 "
            f"with m1 = p1), got {m1} disturbance inputs and {p1} performance "
            "outputs")
    n = P.nstates
    if P.C2.shape != (n, n) or not np.array_equal(P.C2, np.eye(n)):
        raise ControlArgument(
            f"P: synthesis needs the state measured, y = x (C2 = I, {n}x{n}), "
            f"got C2 of shape {P.C2.shape}")
    if eta is not None:
        eta = float(eta)
        if not np.isfinite(eta):
            raise ValueError(f"eta: expected a finite number or None, got {eta}")
        D = P.D11
        low = float(np.linalg.eigvalsh(D + D.T).min())
        if not low > 2 * eta:
            raise ValueError(
                f"eta: D11 + D11ᵀ ≻ 2·eta·I is necessary (paper's Assumption 1, "
                f"MATH §6), but λmin(D11 + D11ᵀ) = {low:.6g} ≤ 2·eta = "
                f"{2 * eta:.6g}")
    if decay is None:
        decay = 1.0
    decay = float(decay)
    if not 0.0 < decay <= 1.0:
        raise ValueError(f"decay: expected r in (0, 1], got {decay}")
    choice(controller, "controller", CONTROLLERS)
    choice(actuator, "actuator", ACTUATORS)
    choice(form, "form", FORMS)
    choice(structure, "structure", STRUCTURES)
    if controller == "static" and not loop_closes(P):
        raise ValueError(
            "P: a memoryless (static) gain never closes this loop: no phase "
            "schedules a sensor and an actuator together (MATH §4). Use "
            "controller='predictor'.")
    structured = any(plant.known_coordinates(k).size < plant.shape["nx"]
                     for k in range(plant.period))
    if structure == "auto":
        structure = "extended" if structured else "full"
    elif structure == "full" and structured:
        raise ValueError(
            "structure: 'full' needs every state known at every phase; this "
            f"loop (controller={controller!r}, sensor schedule) needs 'block' "
            "or 'extended' (MATH §8)")
    return eta, decay, structure


def passivesyn(P: NetworkedStateSpace, eta: float | None = None, *,
               decay: float | None = None, controller: str = "static",
               actuator: str = "zero", form: str = "merged",
               structure: str = "auto", solver: str | None = None,
               margin: float = DEFAULT_MARGIN, **solver_options: Any
               ) -> tuple[PeriodicGain, JumpStateSpace, float]:
    """Periodic state feedback making a networked loop strictly passive.

    Solves the LMI of MATH §8 (paper Theorem 1, corrected) for ``X_k ≻ 0``,
    ``Y_k`` and, when ``eta`` is None, the largest dissipation ``η``; reads
    ``K_k = Y_k X_k⁻¹`` (or ``Y_k G_k⁻¹`` in the extended form); then checks
    the closed loop exactly: ``λmax(Θ_k) < 0`` with ``P_k = X_k⁻¹`` for every
    phase and ``ms_radius < 1`` (``< r²`` with ``decay=r``). A gain that fails
    is never returned.

    Parameters
    ----------
    P : NetworkedStateSpace
        Plant with its network; needs ``y = x`` and ``dim w = dim z``.
    eta : float, optional
        Dissipation to achieve; None maximises it. Maximising drives the
        mean-square margin towards zero (``ms_radius → 1``); bound it with
        ``decay``.
    decay : float in (0, 1], optional
        Mean-square decay bound ``r``: ``E‖x_t‖²`` decays at least like
        ``r^(2t)``, i.e. ``ms_radius < r²``.
    controller : {'static', 'predictor'}
        The paper's memoryless gain, or the model-based predictor of
        MATH §8b (needed under a shared channel).
    actuator : {'zero', 'hold'}
        What actuators apply when their message is lost or not addressed.
    form : {'merged', 'paper'}
        ``'merged'`` (default): coinciding network modes merged, LMI side
        ``n + m1 + 2n`` for the static gain; ``'paper'``: one row per mode
        (eq. 15), side ``n + m1 + 4n``. Both give the same optimum.
    structure : {'auto', 'full', 'block', 'extended'}
        ``'auto'``: ``'full'`` (exact) when the controller knows every
        coordinate at every phase, else ``'extended'``. ``'block'`` and
        ``'extended'`` are sufficient conditions (MATH §8).
    solver : str, optional
        Installed cvxpy solver (default Clarabel).
    margin : float, optional
        Relative strictness margin of the LMIs.
    **solver_options
        Passed to the solver.

    Returns
    -------
    K : PeriodicGain
        ``K.gains`` has shape ``(N, m2, nk)``; ``K.result`` is the
        :class:`SynthesisResult`.
    CL : JumpStateSpace
        The closed loop ``w → z``; ``CL.info['synthesis']`` is the result.
    eta : float
        The certified dissipation (the requested one, or the certified
        maximum).

    Raises
    ------
    SynthesisError
        The LMI is infeasible, the solver failed or was inaccurate, or the
        answer failed the exact checks, after the retries (``RETRIES``) and,
        without ``solver=``, one solve of the problem as posed by
        ``lmi.FALLBACK_SOLVER``; ``reason`` and ``figures`` say which.
    ValueError, ControlDimension, ControlArgument
        The pre-solve checks: ``dim w ≠ dim z``, ``D11 + D11ᵀ ⊁ 2ηI``,
        ``y ≠ x``, a static gain that can never close the loop.

    Examples
    --------
    ``x⁺ = 2x + w + u``, ``z = x + w``, actuator loss 10 %:

    >>> P = nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[1.0, 0.0], [0.0, 0.0]],
    ...         nmeas=1, ncon=1, actuator_loss=0.1)
    >>> K, CL, eta = passivesyn(P, decay=0.9)
    >>> K.result.certificate.verified, bool(ms_radius(CL) < 0.81)
    (True, True)
    """
    plant = build(P, controller, actuator) if isinstance(
        P, NetworkedStateSpace) else None
    eta, decay, structure = _checks(P, eta, decay, controller, actuator, form,
                                    structure, plant)
    attempts = []
    last_cert = last_report = best = None
    tried = set()
    plan = [(scale, backoff, solver) for scale, backoff in RETRIES]
    if fallback_solver(solver):
        plan.append((1.0, 0.0, fallback_solver(solver)))
    for scale, backoff, name in plan:
        target = eta
        if eta is None and backoff:
            if best is None:
                continue  # the first solve gave no optimum to back off from
            target = best - backoff * max(1.0, abs(best))
        if (scale, target, name) in tried:
            continue  # a fixed η has nothing to back off from
        tried.add((scale, target, name))
        # the problem as posed (not a retry asking for more)
        original = scale == 1.0 and target == eta
        model = synthesis_model(plant, target, decay, margin * scale,
                                structure, form)
        # the caller's options are for the solver the caller chose
        report = solve(model.problem, name,
                       **(solver_options if name == solver else {}))
        attempts.append(report)
        if original and best is None and eta is None:
            best = report.value
        if report.infeasible and not original:
            # Only the problem as posed decides feasibility: a retry asks
            # for more (a larger margin, or an η taken from an inaccurate
            # optimum that may lie above the true one).
            continue
        if report.infeasible:
            raise SynthesisError(
                f"passivesyn: the LMI is infeasible (solver {report.solver}, "
                f"status {report.status!r}): no gain of this kind "
                + ("exists with a certificate" if structure == "full" else
                   f"passes the sufficient '{structure}' condition")
                + f" for eta={'max' if eta is None else eta}, decay={decay}",
                "infeasible", dict(status=report.status, solver=report.solver,
                                   structure=structure,
                                   statuses=[a.status for a in attempts]))
        if report.status not in ("optimal", "optimal_inaccurate"):
            continue
        gains, Pcert = read_gains(model, plant)
        CL = plant.close(gains)
        cert = (certify_index(CL, Pcert, decay=decay) if eta is None
                else check_certificate(CL, Pcert, eta, decay=decay))
        last_cert, last_report = cert, report
        if cert.verified and report.ok:
            eta_solver = eta if eta is not None else (
                best if best is not None else cert.eta)
            return _finish(plant, model, gains, CL, cert, cert.eta,
                           eta_solver, decay, form, structure, report,
                           attempts)
    # The last attempt that produced a gain says why it was refused; with
    # none, the solver never produced an answer to check.
    report = last_report if last_cert is not None else attempts[-1]
    figures = dict(status=report.status, solver=report.solver,
                   statuses=[a.status for a in attempts],
                   **(last_cert.figures() if last_cert else {}))
    if last_cert is None:
        reason, what = "solver_failed", f"the solver failed ({report.message})"
    elif not report.ok:
        reason, what = "inaccurate", "the solver's status stayed inaccurate"
    else:
        reason = "not_verified"
        what = "the gain fails the exact check: " + "; ".join(last_cert.failures)
    raise SynthesisError(
        f"passivesyn: no verified gain ({what}; statuses "
        f"{[a.status for a in attempts]} after {len(attempts)} attempts, "
        f"(margin, back-off) = {[(margin * m, b) for m, b in RETRIES]})",
        reason, figures)


def _finish(plant, model, gains, CL, cert, eta_ok, eta_solver, decay, form,
            structure, report, attempts):
    s = plant.shape
    N = plant.period
    Y = np.zeros((N, s["nu"], s["nx"]))
    for k, Yv in enumerate(model.Y):
        if Yv is not None:
            known, active, _ = model.blocks[k]
            Y[k][np.ix_(active, known)] = Yv.value
    X = np.array([np.asarray(Xk.value, float) for Xk in model.X])
    info = plant.info
    K = PeriodicGain(gains, info["controller"], info["actuator"])
    result = SynthesisResult(
        K, float(eta_ok), float(eta_solver), decay, cert,
        X, Y, form, structure, model.width, report, attempts, plant)
    K.result = result
    CL.info["synthesis"] = result
    return K, CL, float(eta_ok)
