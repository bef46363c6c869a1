"""Positive-real (passive) synthesis over a lossy network (MATH §8, §8b).

``K, CL, eta = passivesyn(P, ...)`` in the manner of :func:`control.hinfsyn`.
The LMI is built for the generic plant of MATH §10 (``lmi.py``), so every
controller kind and schedule goes through one code path; every gain returned
has passed the exact checks of ``verify.py``. Loops whose gain sees the
whole state (``structure='full'``) can instead go through the monotone
Riccati iteration of ``riccati.py`` (``solver='riccati'``, chosen
automatically above ``RICCATI_THRESHOLD`` states); its gains pass the same
checks.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from control.exception import ControlArgument, ControlDimension

from ._checks import choice, decay_bound, finite_real, positive_real
from .gain import ACTUATORS, CONTROLLERS, PeriodicGain
from .jump import JumpPlant, JumpStateSpace
from .lmi import (DEFAULT_MARGIN, SolveReport, fallback_solver,
                  read_gains, solve, synthesis_model)
from .plant import NetworkedStateSpace
from .riccati import riccati_synthesis
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

#: With ``solver=None`` and no solver options, a loop whose structure
#: resolves to ``'full'`` with more states than this is designed by the
#: Riccati iteration (``control_ncs.riccati``) instead of the LMI.
#: Measured (η maximised, passivesyn end to end with the exact checks,
#: ``benchmarks.common.random_plant(n, N, seed=0)``, one run each on a
#: shared 2-core machine), Clarabel / Riccati: n=4: 0.05/0.03 s (N=1),
#: 0.21/0.12 s (N=4); n=6: 0.17/0.05, 1.05/1.16; n=8: 0.19/0.29,
#: 0.58/0.19; n=10: 0.57/0.37, 6.2/0.49; n=12: 4.3/0.37, 14.1/3.4;
#: n=16 (N=1): 7.7/3.2. From n = 10 on Riccati wins every case, and
#: Clarabel starts ending 'optimal_inaccurate' (its retry backs off 1e-3,
#: so Riccati's η is then higher); at n <= 8 the two are within a factor of
#: about 3 either way, and on small plants with a wide η range (the random
#: plants of tests/test_riccati.py, n = 2..5) Clarabel is 10-50x faster and
#: its η is closer to the supremum (1e-6 against Riccati's bisection
#: tolerance 1e-4). Hence the LMI up to 8 states.
RICCATI_THRESHOLD = 8

#: Largest state dimension at which an automatically chosen Riccati
#: iteration that runs out of sweeps (inconclusive) is followed by the LMI:
#: Clarabel still solves n = 16 in seconds to tens of seconds (benchmarks
#: §1), while at n = 24, N = 4 it already takes minutes.
RICCATI_FALLBACK_MAX = 16

#: Options of the Riccati route (``solver='riccati'``), passed through
#: ``**solver_options``; any other raises TypeError.
RICCATI_OPTIONS = ("rtol", "max_sweeps", "probe_sweeps")

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
        The solver's objective value (``η`` maximised), or the requested one;
        for the Riccati route, the level its bisection reached.
    decay : float
        Decay bound ``r`` (1 = none); ``ms_radius < r²`` is checked.
    certificate : Certificate
        ``P_k = X_k⁻¹`` and the exact figures: ``λmax(Θ_k)``, ``λmin(P_k)``,
        ``ms_radius``, ``eta_sup``.
    X, Y : ndarray
        LMI variables per phase (``Y`` zero-padded to ``(N, nu, nx)``); for
        the Riccati route ``X_k = P_k⁻¹`` and ``Y_k = K_k X_k`` (the LMI
        variables its certificate corresponds to).
    form : {'merged', 'paper'}
        The LMI's form; ``'merged'`` for the Riccati route (``form`` is
        ignored there: modes are always merged).
    structure : {'full', 'block', 'extended'}
        Which LMI certified the gain: ``'full'`` is exact (feasible iff a
        certified gain exists); ``'block'`` and ``'extended'`` are sufficient.
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
    eta = finite_real(eta, "eta", allow_none=True)
    if eta is not None:
        D = P.D11
        low = float(np.linalg.eigvalsh(D + D.T).min())
        if not low > 2 * eta:
            raise ValueError(
                f"eta: D11 + D11ᵀ ≻ 2·eta·I is necessary (paper's Assumption 1, "
                f"MATH §6), but λmin(D11 + D11ᵀ) = {low:.6g} ≤ 2·eta = "
                f"{2 * eta:.6g}")
    decay = decay_bound(decay)
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
        An installed cvxpy solver for the LMI, or ``'riccati'``
        (case-insensitive) for the monotone Riccati iteration of
        :mod:`control_ncs.riccati` (needs ``structure`` to resolve to
        ``'full'``; no cvxpy, memory ``O(N n²)``; ``form`` does not apply to
        it). None (default): the Riccati iteration when the structure
        resolves to ``'full'``, the plant has more than
        ``RICCATI_THRESHOLD`` states and no solver options are given (if
        that iteration is inconclusive and the plant has at most
        ``RICCATI_FALLBACK_MAX`` states, Clarabel after it), else Clarabel.
    margin : float, optional
        Relative strictness margin of the LMIs (for the Riccati iteration:
        the ``εI`` added at each step, relative to the data's scale).
    **solver_options
        Passed to the solver. For ``solver='riccati'``: ``rtol``
        (bisection tolerance on ``η``, default 1e-4), ``max_sweeps``
        (default 20000), ``probe_sweeps`` (per bisection level, default
        3000); see :func:`control_ncs.riccati.riccati_synthesis`.

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
        Riccati route: ``'infeasible'`` when some ``R_k`` loses positive
        definiteness (a proof that the LMI with its margin is infeasible),
        ``'solver_failed'`` when it runs out of sweeps or ``P`` grows beyond
        what double precision can certify (inconclusive),
        ``'not_verified'`` when its gain fails the exact checks (no retries).
    ValueError, ControlDimension, ControlArgument
        The pre-solve checks: ``dim w ≠ dim z``, ``D11 + D11ᵀ ⊁ 2ηI``,
        ``y ≠ x``, a static gain that can never close the loop,
        ``solver='riccati'`` for a loop whose structure is not ``'full'``.
    TypeError
        An option the Riccati iteration does not know.

    Examples
    --------
    ``x⁺ = 2x + w + u``, ``z = x + w``, actuator loss 10 %:

    >>> P = nss([[2.0]], [[1.0, 1.0]], [[1.0], [1.0]], [[1.0, 0.0], [0.0, 0.0]],
    ...         nmeas=1, ncon=1, actuator_loss=0.1)
    >>> K, CL, eta = passivesyn(P, decay=0.9)
    >>> K.result.certificate.verified, bool(ms_radius(CL) < 0.81)
    (True, True)

    The same by the Riccati iteration:

    >>> K, CL, eta = passivesyn(P, decay=0.9, solver='riccati')
    >>> K.result.report.solver, bool(ms_radius(CL) < 0.81)
    ('RICCATI', True)
    """
    plant = build(P, controller, actuator) if isinstance(
        P, NetworkedStateSpace) else None
    eta, decay, structure = _checks(P, eta, decay, controller, actuator, form,
                                    structure, plant)
    margin = positive_real(margin, "margin")
    riccati = isinstance(solver, str) and solver.upper() == "RICCATI"
    if riccati and structure != "full":
        raise ValueError(
            f"solver: 'riccati' needs structure 'full' (the gain sees every "
            f"state at every phase); this loop resolves to structure "
            f"{structure!r} (controller={controller!r}, actuator="
            f"{actuator!r}, sensor schedule or predictor): use an LMI solver")
    chosen = (solver is None and not solver_options and structure == "full"
              and plant.shape["nx"] > RICCATI_THRESHOLD)
    if riccati:
        return _riccati(plant, eta, decay, margin, solver_options)
    if chosen:
        try:
            return _riccati(plant, eta, decay, margin, solver_options)
        except SynthesisError as err:
            # Chosen for the caller, not by them: an inconclusive iteration
            # (out of sweeps, e.g. a tight decay bound) falls back to the LMI
            # while the LMI is still affordable; a divergence is a proof of
            # infeasibility and stands.
            if (err.reason != "solver_failed"
                    or plant.shape["nx"] > RICCATI_FALLBACK_MAX):
                raise
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
            X, Y = _variables(model, plant)
            return _finish(plant, X, Y, gains, CL, cert, cert.eta,
                           eta_solver, decay, form, structure, model.width,
                           report, attempts)
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


def _variables(model, plant):
    """The LMI's ``X_k`` and ``Y_k`` (zero-padded to ``(N, nu, nx)``)."""
    model._check_current()
    s = plant.shape
    Y = np.zeros((plant.period, s["nu"], s["nx"]))
    for k, Yv in enumerate(model.Y):
        if Yv is not None:
            known, active, _ = model.blocks[k]
            Y[k][np.ix_(active, known)] = Yv.value
    X = np.array([np.asarray(Xk.value, float) for Xk in model.X])
    return X, Y


def _riccati(plant, eta, decay, margin, options):
    """The Riccati route (``structure='full'``), checked like the LMI's."""
    unknown = set(options) - set(RICCATI_OPTIONS)
    if unknown:
        raise TypeError(
            f"passivesyn() got solver option(s) {sorted(unknown)} not "
            f"accepted by solver='riccati' (known: {list(RICCATI_OPTIONS)})")
    res = riccati_synthesis(plant, eta, decay=decay, margin=margin, **options)
    report = SolveReport("optimal", "RICCATI", 0.0, res.time, res.time,
                         res.sweeps, res.eta, options=dict(options))
    CL = plant.close(res.gains)
    cert = (certify_index(CL, res.P, decay=decay) if eta is None
            else check_certificate(CL, res.P, eta, decay=decay))
    if not cert.verified:
        raise SynthesisError(
            "passivesyn: no verified gain (the Riccati gain fails the exact "
            "check: " + "; ".join(cert.failures) + ")", "not_verified",
            dict(status=report.status, solver=report.solver,
                 statuses=[report.status], **cert.figures()))
    s = plant.shape
    X = np.array([np.linalg.inv(Pk) for Pk in res.P])
    X = 0.5 * (X + X.transpose(0, 2, 1))
    # K_k E_k is the full gain (E_k selects every coordinate)
    Y = np.einsum("kuj,kjx,kxy->kuy", res.gains, plant.E, X)
    return _finish(plant, X, Y, res.gains, CL, cert, cert.eta,
                   res.eta if eta is None else eta, decay, "merged", "full",
                   s["nx"] + s["nw"], report, [report])


def _finish(plant, X, Y, gains, CL, cert, eta_ok, eta_solver, decay, form,
            structure, width, report, attempts):
    info = plant.info
    K = PeriodicGain(gains, info["controller"], info["actuator"])
    result = SynthesisResult(
        K, float(eta_ok), float(eta_solver), decay, cert,
        X, Y, form, structure, width, report, attempts, plant)
    K.result = result
    CL.info["synthesis"] = result
    return K, CL, float(eta_ok)
